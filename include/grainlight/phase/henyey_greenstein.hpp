/// @file grainlight/phase/henyey_greenstein.hpp
/// Henyey-Greenstein phase function (Henyey & Greenstein 1941):
///   p(cos theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^(3/2)),
/// with cos(theta) = dot(w_in, w_out) and g > 0 forward-peaked (convention: phase/concepts.hpp).
/// Sampling inverts the CDF of cos(theta) exactly; any g in (-1, 1), including negative g.
#pragma once

#include <cmath>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/phase/concepts.hpp"

namespace grainlight {

/// HG density of cos(theta) on [-1, 1] (integrates to 1); the solid-angle value is this / (2 pi).
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline F henyey_greenstein_cos_pdf(F cos_theta, F g) noexcept {
    const F denom = F(1) + g * g - F(2) * g * cos_theta;
    return F(0.5) * (F(1) - g * g) / (denom * std::sqrt(denom));
}

/// Invert the HG CDF in cos(theta): u -> 1 gives cos(theta) -> 1 for every g.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline F sample_henyey_greenstein_cos(F u, F g) noexcept {
    if (std::abs(g) < F(1e-3)) return std::clamp(F(2) * u - F(1), F(-1), F(1));
    // Evaluate in double: the closed form cancels badly in float near |g| -> 1.
    const double gd = double(g);
    const double s = (1.0 - gd * gd) / (1.0 - gd + 2.0 * gd * double(u));
    const double c = (1.0 + gd * gd - s * s) / (2.0 * gd);
    return F(std::clamp(c, -1.0, 1.0));
}

/// Henyey-Greenstein phase function p(cos theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^{3/2}),
/// grey (the same in every channel of S), sampled exactly by inversion: eval's pdf equals its value
/// and sample's weight is 1. A PhaseFunction (phase/concepts.hpp); immutable, thread-safe.
template <std::floating_point F = float, class S = Spectrum<1, F>>
class HenyeyGreenstein {
public:
    /// Floating-point type of directions and pdfs.
    using Float = F;
    /// Spectrum type of values and weights.
    using Spectrum = S;

    /// \param g asymmetry parameter in (-1, 1); throws grainlight::invalid_argument otherwise.
    explicit HenyeyGreenstein(F g) : g_(g) {
        check_argument(std::isfinite(g) && g > F(-1) && g < F(1), "HenyeyGreenstein", "g", g, "(-1, 1)");
    }

    /// Phase value and pdf for propagation directions w_in, w_out (unit; cos theta = dot(w_in, w_out)).
    [[nodiscard]] PhaseEval<F, S> eval(const Vec3<F>& w_in, const Vec3<F>& w_out) const noexcept {
        const F p = henyey_greenstein_cos_pdf(F(glm::dot(w_in, w_out)), g_) * inv_two_pi_v<F>;
        return {S(p), p};
    }
    /// Draw w_out around w_in: u.x selects cos theta by inversion, u.y the azimuth. Weight 1.
    [[nodiscard]] PhaseSample<F, S> sample(const Vec3<F>& w_in, Vec2<F> u) const noexcept {
        const F cos_theta = sample_henyey_greenstein_cos(u.x, g_);
        const Vec3<F> w = direction_from_cosine(w_in, cos_theta, F(2) * pi_v<F> * u.y);
        return {w, S(F(1)), henyey_greenstein_cos_pdf(cos_theta, g_) * inv_two_pi_v<F>};
    }
    /// Density of cos theta on [-1, 1] (integrates to 1; the solid-angle pdf times 2 pi).
    [[nodiscard]] F pdf_cos_theta(F cos_theta) const noexcept { return henyey_greenstein_cos_pdf(cos_theta, g_); }
    /// Asymmetry parameter g in every channel.
    [[nodiscard]] S mean_cosine() const noexcept { return S(g_); }
    /// Asymmetry parameter g (mean cosine), in (-1, 1).
    [[nodiscard]] F g() const noexcept { return g_; }
    /// Human-readable description, e.g. "HenyeyGreenstein[g = 0.5]".
    [[nodiscard]] std::string to_string() const { return "HenyeyGreenstein[g = " + std::to_string(g_) + "]"; }

private:
    F g_;
};

}  // namespace grainlight
