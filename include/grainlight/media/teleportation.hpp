/// @file grainlight/media/teleportation.hpp
/// Meng15 Sec. 4: the teleportation-transport (TT) model of a granular medium and the effective
/// RTE parameters derived from it, both from the statistics of the virtual scatterometer
/// (precompute/scatterometer.hpp) for any packing rate f and grain scale R without recomputation.
///
/// (a) `effective_rte_params` / `make_effective_medium`: Eqs. 1-4 and Sec. 4.2.3:
///     sigma_b = 3 f / (4 R (1 - f))                                   (Eq. 1)
///     lambda_beta = (lambda_b + lambda_delta) (1 - beta) / beta + lambda_b   (Eq. 3)
///     sigma_t = 1 / (lambda_beta + alpha_s lambda_s)                  (Eq. 4)
///     alpha_s and Phi reused directly; g = mean cosine of Phi;
///     sigma_s' = (1 - g) alpha_s sigma_t, sigma_t' = sigma_s' + (sigma_t - sigma_s),
///     alpha_s' = sigma_s' / sigma_t', sigma_tr = sqrt(3 sigma_a sigma_t')   (Sec. 4.2.3)
///     R is the radius of the grains' bounding spheres in world units (the packing's sphere
///     radius); the scatterometer's lengths (unit bounding sphere) are scaled by R. Per channel.
///
/// (b) `TeleportationMedium`: the TT process itself as a medium policy (media/concepts.hpp):
///     exponential flights with rate sigma_b to the next bounding sphere (Eq. 1); there the ray
///     passes through with probability 1 - beta (offset drawn from the recorded chord histogram),
///     or hits the grain: it is absorbed with probability 1 - alpha_s or teleported, with the exit
///     direction and the exit offset (along and across the incident direction, and their
///     relative azimuth) drawn jointly from the scatterometer's table.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/media/grain_stats.hpp"

namespace grainlight {

/// Effective RTE and diffusion parameters of a granular medium (Meng15 Eqs. 1-4, Sec. 4.2.3).
/// Lengths in world units (those of `bounding_radius`), coefficients in 1/length; per channel
/// where the grain is coloured.
struct EffectiveRteParams {
    double packing_rate = 0;     ///< f
    double bounding_radius = 0;  ///< R, radius of the grains' bounding spheres
    double sigma_b = 0;          ///< Eq. 1: rate of bounding-sphere encounters
    double lambda_b = 0;         ///< 1 / sigma_b
    double beta = 0;             ///< hit probability
    double lambda_delta = 0;     ///< mean pass-through offset (world units)
    double lambda_beta = 0;      ///< Eq. 3
    RGBd alpha_s{};              ///< grain albedo
    RGBd lambda_s{};             ///< |mean teleport vector| (world units)
    RGBd lambda_t{};             ///< Eq. 4: lambda_beta + alpha_s lambda_s
    RGBd sigma_t{};              ///< 1 / lambda_t
    /// @var sigma_s
    /// Scattering coefficient alpha_s sigma_t (per channel).
    RGBd sigma_s{}, sigma_a{};   ///< alpha_s sigma_t, (1 - alpha_s) sigma_t
    RGBd g{};                    ///< mean cosine of Phi
    RGBd sigma_s_reduced{};      ///< sigma_s' = (1 - g) sigma_s
    RGBd sigma_t_reduced{};      ///< sigma_t' = sigma_s' + sigma_a
    RGBd alpha_s_reduced{};      ///< alpha_s' = sigma_s' / sigma_t'
    RGBd sigma_tr{};             ///< sqrt(3 sigma_a sigma_t') (diffusion)
};

/// Meng15 Eq. 1: sigma_b = 3 f / (4 R (1 - f)), the rate of bounding-sphere encounters of a
/// packing of spheres of radius R at packing rate f (Dixmier 1978). f in (0, 1), R > 0.
[[nodiscard]] inline double bounding_sphere_sigma_b(double packing_rate, double bounding_radius) {
    check_argument(packing_rate > 0.0 && packing_rate < 1.0, "bounding_sphere_sigma_b", "packing_rate", packing_rate, "(0, 1)");
    check_argument(bounding_radius > 0.0 && std::isfinite(bounding_radius), "bounding_sphere_sigma_b", "bounding_radius",
                   bounding_radius, "(0, inf)");
    return 3.0 * packing_rate / (4.0 * bounding_radius * (1.0 - packing_rate));
}

/// Meng15 Eq. 3: lambda_beta = (lambda_b + lambda_delta) (1 - beta) / beta + lambda_b (beta in (0, 1]).
[[nodiscard]] inline double lambda_beta_eq3(double lambda_b, double lambda_delta, double beta) {
    check_argument(beta > 0.0 && beta <= 1.0, "lambda_beta_eq3", "beta", beta, "(0, 1] (beta = 0: no ray ever scatters)");
    return (lambda_b + lambda_delta) * (1.0 - beta) / beta + lambda_b;
}

/// Effective RTE parameters for packing rate f and bounding-sphere radius R (Meng15 Eqs. 1-4,
/// Sec. 4.2.3). Throws grainlight::invalid_argument for f outside (0, 1), R <= 0, or grain
/// statistics with beta = 0.
[[nodiscard]] inline EffectiveRteParams effective_rte_params(const GrainStats& stats, double packing_rate,
                                                             double bounding_radius) {
    EffectiveRteParams p;
    p.packing_rate = packing_rate;
    p.bounding_radius = bounding_radius;
    p.sigma_b = bounding_sphere_sigma_b(packing_rate, bounding_radius);
    p.lambda_b = 1.0 / p.sigma_b;
    check_argument(stats.beta() > 0.0, "effective_rte_params", "beta", stats.beta(), "(0, 1] (beta = 0: no ray ever scatters)");
    p.beta = stats.beta();
    p.lambda_delta = stats.lambda_delta() * bounding_radius;
    p.lambda_beta = lambda_beta_eq3(p.lambda_b, p.lambda_delta, p.beta);
    for (std::size_t c = 0; c < 3; ++c) {
        p.alpha_s[c] = stats.alpha_s(c);
        p.lambda_s[c] = stats.lambda_s(c) * bounding_radius;
        p.lambda_t[c] = p.lambda_beta + p.alpha_s[c] * p.lambda_s[c];
        p.sigma_t[c] = 1.0 / p.lambda_t[c];
        p.sigma_s[c] = p.alpha_s[c] * p.sigma_t[c];
        p.sigma_a[c] = p.sigma_t[c] - p.sigma_s[c];
        p.g[c] = stats.g(c);
        p.sigma_s_reduced[c] = (1.0 - p.g[c]) * p.sigma_s[c];
        p.sigma_t_reduced[c] = p.sigma_s_reduced[c] + p.sigma_a[c];
        p.alpha_s_reduced[c] = p.sigma_t_reduced[c] > 0 ? p.sigma_s_reduced[c] / p.sigma_t_reduced[c] : 0.0;
        p.sigma_tr[c] = std::sqrt(3.0 * p.sigma_a[c] * p.sigma_t_reduced[c]);
    }
    return p;
}

/// The continuous medium of Meng15 Sec. 3.3 / 4.2: sigma_t of Eq. 4, albedo alpha_s and the
/// scatterometer's tabulated Phi (per channel), for packing rate f and bounding radius R.
template <std::floating_point F = float, class S = RGB>
[[nodiscard]] inline ContinuousMedium<TabulatedPhase<F, S>, S> make_effective_medium(const GrainStats& stats,
                                                                                     double packing_rate,
                                                                                     double bounding_radius) {
    static_assert(S::size == 3, "the scatterometer records RGB");
    const EffectiveRteParams p = effective_rte_params(stats, packing_rate, bounding_radius);
    S sigma_t, albedo;
    for (std::size_t c = 0; c < 3; ++c) {
        sigma_t[c] = F(p.sigma_t[c]);
        albedo[c] = F(std::clamp(p.alpha_s[c], 0.0, 1.0));
    }
    return ContinuousMedium<TabulatedPhase<F, S>, S>(sigma_t, albedo, stats.phase<F, S>());
}

/// The teleportation-transport process (Meng15 Sec. 4.1) as a Medium (media/concepts.hpp).
///
/// `sample_interaction(ray, t_max, rng)` starts at ray.o in the space between bounding spheres
/// (e.g. the exit point of the previous grain interaction) and loops over bounding-sphere
/// encounters internally: exponential flights (rate sigma_b, Eq. 1) and pass-throughs
/// (probability 1 - beta, chord drawn from the recorded miss-chord histogram), until
///  - the distance reaches t_max: `escape` at ray(t_max);
///  - a grain absorbs the path: `absorb` at the entry point x_i (t = its distance);
///  - a grain scatters it: `scatter` with `t` = distance to the entry point x_i, `p` = the exit
///    point x_o = x_i + R * offset and `w` = the exit direction, both drawn jointly from the
///    scatterometer table; `has_direction` = true and `nee` = NeeKind::none (the exit direction
///    comes from recorded statistics, there is no phase function to connect with).
/// Spectral handling: distances are grey (geometry); the survival probability is the channel
/// mean of alpha_s and the (direction, offset) cell is drawn from the channel-mean table, with the
/// per-channel ratio in `weight` (one-sample MIS; weight 1 for grey grains).
///
/// Approximations of this TT implementation (documented in docs/meng15.md): within a table cell
/// (cos theta, along, across, relative azimuth) values are uniform; the absolute azimuth around
/// w_i is uniform (random grain rotations); the teleport can leave the aggregate's boundary
/// (t_max), which the integrator must handle (the exit point lies within 2R of the entry point).
template <std::floating_point F = float>
class TeleportationMedium {
public:
    /// Scalar and spectrum types (Medium concept): RGB of F.
    using Float = F;
    /// Spectrum type: RGB of F.
    using Spectrum = grainlight::Spectrum<3, F>;

    /// \param stats           scatterometer statistics (a single grain or a mixture)
    /// \param packing_rate    f in (0, 1)
    /// \param bounding_radius R > 0, world units
    TeleportationMedium(const GrainStats& stats, double packing_rate, double bounding_radius)
        : params_(effective_rte_params(stats, packing_rate, bounding_radius)), grid_(stats.grid) {
        stats.check_consistency("TeleportationMedium");
        R_ = bounding_radius;
        sigma_b_ = params_.sigma_b;
        beta_ = stats.beta();
        if (beta_ < 1.0) {
            double m = 0;
            for (double v : stats.chord_hist) m += v;
            if (m > 0) {
                chord_ = PiecewiseConstant1D<double>(std::span<const double>(stats.chord_hist), 0.0,
                                                     ScatterometerGrid::chord_max);
                has_chord_ = true;
            }
        }
        // Per-cell channel probabilities conditioned on a hit, and their channel mean.
        const std::size_t n = grid_.tt_cells();
        cell_p_.resize(n);
        std::vector<double> mean(n);
        survive_ = 0;
        for (std::size_t c = 0; c < 3; ++c) survive_ += stats.exit[c] / beta_ / 3.0;
        for (std::size_t i = 0; i < n; ++i) {
            double m = 0;
            for (std::size_t c = 0; c < 3; ++c) {
                const double v = stats.tt_table[c][i] / beta_;
                cell_p_[i][c] = F(v);
                m += v / 3.0;
            }
            mean[i] = m;
        }
        if (survive_ > 0) {
            cells_ = DiscreteDistribution<double>(std::span<const double>(mean));
            mu_marginal_.assign(grid_.tt_mu_bins, 0.0);
            const std::size_t per_mu = std::size_t(grid_.tt_along_bins) * grid_.tt_across_bins * grid_.tt_dphi_bins;
            for (std::size_t i = 0; i < n; ++i) mu_marginal_[i / per_mu] += mean[i];
        }
        mu_edges_ = ScatterometerGrid::mu_edges(grid_.tt_mu_bins);
    }

    /// The effective RTE parameters for the same f and R (Eqs. 1-4).
    [[nodiscard]] const EffectiveRteParams& params() const noexcept { return params_; }
    /// Eq. 1 rate of bounding-sphere encounters.
    [[nodiscard]] double sigma_b() const noexcept { return sigma_b_; }
    /// Hit probability.
    [[nodiscard]] double beta() const noexcept { return beta_; }
    /// Channel-mean probability that a hitting path is not absorbed.
    [[nodiscard]] double survival_probability() const noexcept { return survive_; }

    /// See the class comment.
    [[nodiscard]] Interaction<F, Spectrum> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        Interaction<F, Spectrum> it;
        const double tm = double(t_max);
        double t = 0;
        for (;;) {
            t += sample_exponential(rng.uniform<double>(), sigma_b_);
            if (!(t < tm)) return escape(ray, t_max);
            if (rng.uniform<double>() >= beta_) {  // pass through the bounding sphere
                t += has_chord_ ? R_ * chord_.sample(rng.uniform<double>()) : 0.0;
                if (!(t < tm)) return escape(ray, t_max);
                continue;
            }
            break;
        }
        it = grain_interaction(ray(F(t)), ray.d, rng);
        it.t = F(t);
        return it;
    }

    /// One grain interaction of the TT process at the bounding-sphere entry point `x_i` with unit
    /// incident direction `d` (the second half of `sample_interaction`, for an integrator that
    /// found the grain itself, e.g. a hybrid that leaves explicit grains at a grain hit): `absorb`
    /// at x_i with probability 1 - alpha_s (channel mean), else `scatter` with the exit point
    /// x_o = x_i + R * offset and the exit direction drawn jointly from the scatterometer table,
    /// and the per-channel weight as in sample_interaction. `t` is 0.
    [[nodiscard]] Interaction<F, Spectrum> grain_interaction(const Vec3<F>& x_i, const Vec3<F>& d_in, Rng& rng) const noexcept {
        Interaction<F, Spectrum> it;
        it.t = F(0);
        if (!(rng.uniform<double>() < survive_)) {
            it.kind = EventKind::absorb;
            it.p = x_i;
            it.weight = Spectrum(F(0));
            return it;
        }
        double pmf = 0, u_rem = 0;
        const std::size_t cell = cells_.sample(rng.uniform<double>(), &pmf, &u_rem);
        const std::size_t n_ac = grid_.tt_across_bins, n_al = grid_.tt_along_bins, n_dp = grid_.tt_dphi_bins;
        const std::size_t i_dp = cell % n_dp, c3 = cell / n_dp;
        const std::size_t i_mu = c3 / (n_al * n_ac), i_al = (c3 / n_ac) % n_al, i_ac = c3 % n_ac;
        const double mu = mu_edges_[i_mu] + rng.uniform<double>() * (mu_edges_[i_mu + 1] - mu_edges_[i_mu]);
        const double al_w = (ScatterometerGrid::along_max - ScatterometerGrid::along_min) / double(n_al);
        const double along = ScatterometerGrid::along_min + (double(i_al) + rng.uniform<double>()) * al_w;
        const double across = (double(i_ac) + rng.uniform<double>()) * ScatterometerGrid::across_max / double(n_ac);
        const double phi_offset = 2.0 * pi_v<double> * rng.uniform<double>();
        const double dphi = ScatterometerGrid::dphi_center(std::uint32_t(i_dp), std::uint32_t(n_dp)) +
                            (rng.uniform<double>() - 0.5) * 2.0 * pi_v<double> / double(n_dp);
        const double phi_dir = phi_offset + dphi;
        const Vec3d d(d_in);
        const Frame<double> frame(d);
        const Vec3d offset = along * d + across * (std::cos(phi_offset) * frame.s + std::sin(phi_offset) * frame.t);
        it.kind = EventKind::scatter;
        it.p = x_i + Vec3<F>(R_ * offset);
        it.w = Vec3<F>(glm::normalize(direction_from_cosine(d, mu, phi_dir)));
        it.has_direction = true;
        it.nee = NeeKind::none;
        // Solid-angle pdf of the direction: marginal of the mixture table over offsets.
        const double mu_mass = mu_marginal_[i_mu] / survive_;
        it.direction_pdf = F(mu_mass / (2.0 * pi_v<double> * (mu_edges_[i_mu + 1] - mu_edges_[i_mu])));
        // One-sample MIS weight p_c(cell) / mean_c p_c(cell); survival already accounts for
        // the channel-mean alpha_s (E[weight_c] = alpha_s[c]).
        const double m = pmf * survive_;
        for (std::size_t c = 0; c < 3; ++c) it.weight[c] = m > 0 ? F(double(cell_p_[cell][c]) / m) : F(0);
        return it;
    }

    /// Transmittance estimate along the ray up to t_max: 1 if a simulated TT walk reaches t_max
    /// without a grain hit, else 0 (track-length estimator; unbiased for the TT process).
    [[nodiscard]] Spectrum transmittance(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        (void)ray;
        double t = 0;
        const double tm = double(t_max);
        for (;;) {
            t += sample_exponential(rng.uniform<double>(), sigma_b_);
            if (!(t < tm)) return Spectrum(F(1));
            if (rng.uniform<double>() < beta_) return Spectrum(F(0));
            t += has_chord_ ? R_ * chord_.sample(rng.uniform<double>()) : 0.0;
            if (!(t < tm)) return Spectrum(F(1));
        }
    }

    /// Short description for logs and test failures.
    [[nodiscard]] std::string to_string() const {
        return "TeleportationMedium[sigma_b = " + std::to_string(sigma_b_) + ", beta = " + std::to_string(beta_) +
               ", alpha_s(mean) = " + std::to_string(survive_) + "]";
    }

private:
    [[nodiscard]] static Interaction<F, Spectrum> escape(const Ray<F>& ray, F t_max) noexcept {
        Interaction<F, Spectrum> it;
        it.kind = EventKind::escape;
        it.t = t_max;
        it.p = std::isfinite(t_max) ? ray(t_max) : ray.o;
        return it;
    }

    EffectiveRteParams params_;
    ScatterometerGrid grid_;
    double R_ = 1, sigma_b_ = 1, beta_ = 1, survive_ = 1;
    bool has_chord_ = false;
    PiecewiseConstant1D<double> chord_;
    DiscreteDistribution<double> cells_;
    std::vector<Spectrum> cell_p_;
    std::vector<double> mu_marginal_, mu_edges_;
};

static_assert(Medium<TeleportationMedium<float>>);

}  // namespace grainlight
