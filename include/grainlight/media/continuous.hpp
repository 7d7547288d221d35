/// @file grainlight/media/continuous.hpp
/// Homogeneous RTE medium: extinction sigma_t and single-scattering albedo per channel, and a
/// phase function policy.
///
/// Spectral free-flight sampling without bias: a channel c is chosen uniformly, the distance is
/// drawn from sigma_t[c] exp(-sigma_t[c] t), and the sample is weighted by the one-sample MIS
/// (balance) pdf averaged over channels (the "hero"/spectral-MIS estimator). The collision is then
/// split into scatter/absorb by Russian roulette on the largest channel's scatter weight w_max
/// (capped at 1): channel c then carries w_c / w_max <= 1, and its second moment per event,
/// w_c^2 / w_max <= w_c, stays below its mean. (Roulette on the mean weight, used before
/// 2026-12-06, gave a channel above the mean a factor w_c / mean > 1 per event and, where w_c^2 >
/// mean, a variance that grows geometrically with the path length: albedos (0.95, 0.68, 0.46)
/// made the red channel's per-event second moment 1.31.) For a grey medium every weight is
/// exactly 1 and events happen with the analog probabilities (albedo for scatter).
#pragma once

#include <algorithm>
#include <cmath>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/phase/concepts.hpp"

namespace grainlight {

/// Homogeneous medium of the radiative transfer equation: extinction sigma_t and albedo per
/// channel and one phase function. Free flights are sampled analogously in one channel chosen
/// uniformly (spectral MIS weights in Interaction::weight when channels differ), absorption by
/// Russian roulette on the largest channel's collision weight. Immutable; thread-safe for queries (the Rng is
/// the caller's). Models Medium and PhaseMedium.
template <PhaseFunction Phase, SpectrumType S = typename Phase::Spectrum>
class ContinuousMedium {
public:
    /// Floating-point type (the phase function's).
    using Float = typename Phase::Float;
    /// Short alias of Float.
    using F = Float;
    /// Spectrum type of coefficients and weights.
    using Spectrum = S;
    /// The phase function type.
    using PhaseType = Phase;
    /// Number of spectral channels.
    static constexpr std::size_t channels = S::size;

    /// \param sigma_t extinction coefficient per channel (>= 0, finite; 1/length)
    /// \param albedo  single-scattering albedo sigma_s / sigma_t per channel, in [0, 1]
    /// \param phase   phase function (moved in)
    ContinuousMedium(const S& sigma_t, const S& albedo, Phase phase)
        : sigma_t_(sigma_t), albedo_(albedo), phase_(std::move(phase)) {
        for (std::size_t c = 0; c < channels; ++c) {
            check_argument(std::isfinite(double(sigma_t[c])) && sigma_t[c] >= F(0), "ContinuousMedium",
                           "sigma_t[" + std::to_string(c) + "]", sigma_t[c], "[0, inf)");
            check_argument(albedo[c] >= F(0) && albedo[c] <= F(1), "ContinuousMedium",
                           "albedo[" + std::to_string(c) + "]", albedo[c], "[0, 1]");
        }
        grey_ = true;
        for (std::size_t c = 1; c < channels; ++c) grey_ = grey_ && sigma_t[c] == sigma_t[0];
    }
    /// Grey convenience: the same sigma_t and albedo in every channel.
    ContinuousMedium(F sigma_t, F albedo, Phase phase) : ContinuousMedium(S(sigma_t), S(albedo), std::move(phase)) {}

    /// Extinction coefficient sigma_t per channel [1/length].
    [[nodiscard]] const S& sigma_t() const noexcept { return sigma_t_; }
    /// Single-scattering albedo sigma_s / sigma_t per channel, in [0, 1].
    [[nodiscard]] const S& albedo() const noexcept { return albedo_; }
    /// Scattering coefficient sigma_s = albedo sigma_t per channel [1/length].
    [[nodiscard]] S sigma_s() const noexcept { return sigma_t_ * albedo_; }
    /// Absorption coefficient sigma_a = sigma_t - sigma_s per channel [1/length].
    [[nodiscard]] S sigma_a() const noexcept { return sigma_t_ - sigma_s(); }
    /// The phase function.
    [[nodiscard]] const Phase& phase() const noexcept { return phase_; }

    /// Transmittance exp(-sigma_t t) per channel (deterministic; rng unused).
    [[nodiscard]] S transmittance(const Ray<F>&, F t, Rng&) const noexcept { return transmittance(t); }
    /// Transmittance exp(-sigma_t t) per channel over distance t >= 0.
    [[nodiscard]] S transmittance(F t) const noexcept {
        S tr;
        for (std::size_t c = 0; c < channels; ++c) tr[c] = sigma_t_[c] > 0 ? std::exp(-sigma_t_[c] * t) : F(1);
        return tr;
    }

    /// Sample the next event along `ray` before `t_max` (see media/concepts.hpp).
    [[nodiscard]] Interaction<F, S> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        Interaction<F, S> it;
        // Pick the channel that drives the distance.
        std::size_t c = 0;
        if (!grey_) c = std::min<std::size_t>(std::size_t(rng.uniform<F>() * F(channels)), channels - 1);
        const F u = rng.uniform<F>();
        const F st = sigma_t_[c];
        const F t = st > 0 ? sample_exponential(u, st) : std::numeric_limits<F>::infinity();
        if (!(t < t_max)) {
            // Escape: weight T(t_max) / P(escape), P averaged over channels.
            it.kind = EventKind::escape;
            it.t = t_max;
            it.p = ray(t_max);
            if (!grey_) {
                const S tr = transmittance(t_max);
                it.weight = tr / tr.average();
            }
            return it;
        }
        it.t = t;
        it.p = ray(t);
        // Collision weight sigma_s T(t) / pdf(t), pdf = channel average of sigma_t T.
        S w_scatter = albedo_;
        if (!grey_) {
            const S tr = transmittance(t);
            const S dens = sigma_t_ * tr;
            w_scatter = sigma_s() * tr / dens.average();
        }
        resolve_collision(it, w_scatter, rng);
        return it;
    }

    /// Human-readable description (channel 0's sigma_t and albedo).
    [[nodiscard]] std::string to_string() const {
        std::string s = "ContinuousMedium[sigma_t[0] = " + std::to_string(double(sigma_t_[0])) +
                        ", albedo[0] = " + std::to_string(double(albedo_[0])) + "]";
        return s;
    }

private:
    S sigma_t_, albedo_;
    Phase phase_;
    bool grey_ = true;
};

}  // namespace grainlight
