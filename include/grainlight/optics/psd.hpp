/// @file grainlight/optics/psd.hpp
/// Particle size distributions (Guo21 Sec. 4.1): log-normal (Eq. 15), bimodal log-normal and
/// tabulated, each truncated to [r_min, r_max].
///
/// N(r) dr is the number of particles per unit volume with radius in [r, r + dr];
/// N_0 = int_{r_min}^{r_max} N(r) dr is the `number_density()` (particles per cubic metre by the
/// convention of optics/bulk.hpp), and `pdf(r)` = N(r) / N_0 integrates to 1 over [r_min, r_max].
/// Radii in micrometres. Every distribution offers pdf, cdf, sample(u) (inversion, u in [0, 1)),
/// closed-form moments E[r^k] of the truncated distribution, and `breakpoints()` (radii where
/// the density has kinks or its bulk lies) for quadrature.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <boost/math/special_functions/erf.hpp>

#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/quadrature.hpp"
#include "grainlight/core/math.hpp"

namespace grainlight {

/// What optics/bulk.hpp needs from a size distribution.
template <class P>
concept SizeDistribution = requires(const P& p, double r) {
    { p.pdf(r) } -> std::convertible_to<double>;
    { p.cdf(r) } -> std::convertible_to<double>;
    { p.sample(r) } -> std::convertible_to<double>;
    { p.r_min() } -> std::convertible_to<double>;
    { p.r_max() } -> std::convertible_to<double>;
    { p.number_density() } -> std::convertible_to<double>;
    { p.breakpoints() } -> std::convertible_to<std::vector<double>>;
};

namespace detail {
using psd_policy = boost::math::policies::policy<boost::math::policies::promote_double<false>>;
/// Standard normal CDF.
inline double normal_cdf(double z) noexcept { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }
/// Standard normal quantile (p in (0, 1)).
inline double normal_quantile(double p) {
    return -std::sqrt(2.0) * boost::math::erfc_inv(2 * p, psd_policy());
}
}  // namespace detail

/// Log-normal PSD, Guo21 Eq. 15: N(r) = N_0' / (sqrt(2 pi) r ln sigma_g) exp(-(ln r - ln r_g)^2 /
/// (2 ln^2 sigma_g)), truncated to [r_min, r_max] and renormalized so that N_0 = number_density
/// particles lie inside.
class LogNormalPsd {
public:
    /// r_g > 0: geometric mean radius [um]; sigma_g > 1: geometric standard deviation;
    /// 0 <= r_min < r_max (r_max may be +inf); number_density >= 0 [1/m^3].
    LogNormalPsd(double r_g, double sigma_g, double r_min = 0.0,
                 double r_max = std::numeric_limits<double>::infinity(), double number_density = 1.0)
        : mu_(std::log(r_g)), s_(std::log(sigma_g)), r_min_(r_min), r_max_(r_max), n0_(number_density) {
        const char* who = "LogNormalPsd";
        check_argument(std::isfinite(r_g) && r_g > 0, who, "r_g", r_g, "> 0 (finite)");
        check_argument(std::isfinite(sigma_g) && sigma_g > 1, who, "sigma_g", sigma_g, "> 1 (finite)");
        check_argument(std::isfinite(r_min) && r_min >= 0, who, "r_min", r_min, ">= 0 (finite)");
        check_argument(r_max > r_min, who, "r_max", r_max, "> r_min");
        check_argument(std::isfinite(number_density) && number_density >= 0, who, "number_density", number_density,
                       ">= 0 (finite)");
        za_ = r_min > 0 ? (std::log(r_min) - mu_) / s_ : -std::numeric_limits<double>::infinity();
        zb_ = std::isfinite(r_max) ? (std::log(r_max) - mu_) / s_ : std::numeric_limits<double>::infinity();
        pa_ = detail::normal_cdf(za_);
        mass_ = detail::normal_cdf(zb_) - pa_;
        check_argument(mass_ > 1e-300, who, "[r_min, r_max]", r_max, "an interval holding part of the distribution");
    }

    /// Geometric mean radius r_g [um].
    [[nodiscard]] double r_g() const noexcept { return std::exp(mu_); }
    /// Geometric standard deviation sigma_g (> 1).
    [[nodiscard]] double sigma_g() const noexcept { return std::exp(s_); }
    /// Lower truncation radius [um].
    [[nodiscard]] double r_min() const noexcept { return r_min_; }
    /// Upper truncation radius [um] (may be +inf).
    [[nodiscard]] double r_max() const noexcept { return r_max_; }
    /// Number density N_0 of the particles inside [r_min, r_max] [1/m^3].
    [[nodiscard]] double number_density() const noexcept { return n0_; }
    /// Fraction of the untruncated log-normal inside [r_min, r_max].
    [[nodiscard]] double truncated_mass() const noexcept { return mass_; }
    /// One-line description.
    [[nodiscard]] std::string to_string() const {
        return "LogNormalPsd[r_g = " + grainlight::detail::to_display(r_g()) + " um, sigma_g = " + grainlight::detail::to_display(sigma_g()) + ", r in [" + grainlight::detail::to_display(r_min_) +
               ", " + grainlight::detail::to_display(r_max_) + "] um, N = " + grainlight::detail::to_display(n0_) + "]";
    }

    /// Normalized density on [r_min, r_max] [1/um] (0 outside).
    [[nodiscard]] double pdf(double r) const noexcept {
        if (!(r >= r_min_ && r <= r_max_) || r <= 0) return 0.0;
        const double z = (std::log(r) - mu_) / s_;
        return std::exp(-0.5 * z * z) / (std::sqrt(2 * pi_v<double>) * r * s_ * mass_);
    }
    /// N(r) = number_density * pdf(r) (Eq. 15 with truncation).
    [[nodiscard]] double density(double r) const noexcept { return n0_ * pdf(r); }
    /// Cumulative distribution on [r_min, r_max]: fraction of the particles with radius <= r.
    [[nodiscard]] double cdf(double r) const noexcept {
        if (r <= r_min_ || r <= 0) return 0.0;
        if (r >= r_max_) return 1.0;
        return std::clamp((detail::normal_cdf((std::log(r) - mu_) / s_) - pa_) / mass_, 0.0, 1.0);
    }
    /// Radius for u in [0, 1) by inversion.
    [[nodiscard]] double sample(double u) const {
        const double p = std::clamp(pa_ + u * mass_, 1e-300, 1 - 1e-16);
        return std::clamp(std::exp(mu_ + s_ * detail::normal_quantile(p)), r_min_, r_max_);
    }
    /// E[r^k] of the truncated distribution (closed form):
    /// exp(k mu + k^2 s^2 / 2) [Phi(z_b - k s) - Phi(z_a - k s)] / [Phi(z_b) - Phi(z_a)].
    [[nodiscard]] double moment(double k) const noexcept {
        return std::exp(k * mu_ + 0.5 * k * k * s_ * s_) *
               (detail::normal_cdf(zb_ - k * s_) - detail::normal_cdf(za_ - k * s_)) / mass_;
    }
    /// r_g and the ends (finite ones), for quadrature.
    [[nodiscard]] std::vector<double> breakpoints() const {
        std::vector<double> b;
        const double lo = std::max(r_min_, std::exp(mu_ - 9 * s_)), hi = std::min(r_max_, std::exp(mu_ + 9 * s_));
        b.push_back(lo);
        if (std::exp(mu_) > lo && std::exp(mu_) < hi) b.push_back(std::exp(mu_));
        b.push_back(hi);
        return b;
    }

private:
    double mu_, s_, r_min_, r_max_, n0_;
    double za_ = 0, zb_ = 0, pa_ = 0, mass_ = 1;
};

/// Mixture of two log-normal modes (Guo21 Sec. 6.7, Fig. 19: many small and a few large
/// particles), truncated to a common [r_min, r_max]. `fraction1` is mode 1's share of the
/// particles before truncation (e.g. 1.99e7 / 2e7).
class BimodalLogNormalPsd {
public:
    /// Two log-normal modes (r_g1, sigma_g1) and (r_g2, sigma_g2) (radii in um, sigma > 1), mode 1
    /// holding `fraction1` in [0, 1] of the untruncated particles, truncated to [r_min, r_max], with
    /// number_density >= 0 [1/m^3] particles inside; throws grainlight::invalid_argument otherwise.
    BimodalLogNormalPsd(double r_g1, double sigma_g1, double r_g2, double sigma_g2, double fraction1,
                        double r_min = 0.0, double r_max = std::numeric_limits<double>::infinity(),
                        double number_density = 1.0)
        : m1_(r_g1, sigma_g1, r_min, r_max, 1.0), m2_(r_g2, sigma_g2, r_min, r_max, 1.0), n0_(number_density) {
        check_argument(std::isfinite(fraction1) && fraction1 >= 0 && fraction1 <= 1, "BimodalLogNormalPsd",
                       "fraction1", fraction1, "[0, 1]");
        check_argument(std::isfinite(number_density) && number_density >= 0, "BimodalLogNormalPsd", "number_density",
                       number_density, ">= 0 (finite)");
        const double a = fraction1 * m1_.truncated_mass(), b = (1 - fraction1) * m2_.truncated_mass();
        w1_ = a / (a + b);
    }
    /// Lower truncation radius [um].
    [[nodiscard]] double r_min() const noexcept { return m1_.r_min(); }
    /// Upper truncation radius [um] (may be +inf).
    [[nodiscard]] double r_max() const noexcept { return m1_.r_max(); }
    /// Number density N_0 inside [r_min, r_max] [1/m^3].
    [[nodiscard]] double number_density() const noexcept { return n0_; }
    /// Share of mode 1 among the particles inside [r_min, r_max].
    [[nodiscard]] double weight1() const noexcept { return w1_; }
    /// Mode 1 (normalized on its own).
    [[nodiscard]] const LogNormalPsd& mode1() const noexcept { return m1_; }
    /// Mode 2 (normalized on its own).
    [[nodiscard]] const LogNormalPsd& mode2() const noexcept { return m2_; }
    /// One-line description.
    [[nodiscard]] std::string to_string() const {
        return "BimodalLogNormalPsd[w1 = " + grainlight::detail::to_display(w1_) + ", " + m1_.to_string() + ", " + m2_.to_string() + "]";
    }
    /// Normalized mixture density [1/um].
    [[nodiscard]] double pdf(double r) const noexcept { return w1_ * m1_.pdf(r) + (1 - w1_) * m2_.pdf(r); }
    /// N(r) = number_density * pdf(r) [1/(um m^3)].
    [[nodiscard]] double density(double r) const noexcept { return n0_ * pdf(r); }
    /// Cumulative distribution of the mixture.
    [[nodiscard]] double cdf(double r) const noexcept { return w1_ * m1_.cdf(r) + (1 - w1_) * m2_.cdf(r); }
    /// Picks the mode with u, re-uses the rescaled u inside it.
    [[nodiscard]] double sample(double u) const {
        if (u < w1_) return m1_.sample(w1_ > 0 ? u / w1_ : 0.0);
        return m2_.sample(std::min((u - w1_) / (1 - w1_), 1 - 1e-16));
    }
    /// E[r^k] of the mixture [um^k].
    [[nodiscard]] double moment(double k) const noexcept { return w1_ * m1_.moment(k) + (1 - w1_) * m2_.moment(k); }
    /// Sorted union of both modes' breakpoints, for quadrature.
    [[nodiscard]] std::vector<double> breakpoints() const {
        auto b = m1_.breakpoints();
        for (double r : m2_.breakpoints()) b.push_back(r);
        std::sort(b.begin(), b.end());
        const double lo = b.front(), hi = b.back();
        std::vector<double> out;
        for (double r : b)
            if (r >= lo && r <= hi && (out.empty() || r > out.back())) out.push_back(r);
        return out;
    }

private:
    LogNormalPsd m1_, m2_;
    double n0_;
    double w1_ = 1;
};

/// All particles of one radius (Guo21 Sec. 6.3's monodisperse media). Not a density: the bulk
/// properties (optics/bulk.hpp) evaluate the single radius directly (sigma = N_0 C(r_0)).
class MonodispersePsd {
public:
    /// All particles of radius `radius` > 0 [um], `number_density` >= 0 of them per m^3; throws
    /// grainlight::invalid_argument otherwise.
    explicit MonodispersePsd(double radius, double number_density = 1.0) : r0_(radius), n0_(number_density) {
        check_argument(std::isfinite(radius) && radius > 0, "MonodispersePsd", "radius", radius, "> 0 (finite)");
        check_argument(std::isfinite(number_density) && number_density >= 0, "MonodispersePsd", "number_density",
                       number_density, ">= 0 (finite)");
    }
    /// The common radius r_0 [um].
    [[nodiscard]] double radius() const noexcept { return r0_; }
    /// r_0 (the support is one point).
    [[nodiscard]] double r_min() const noexcept { return r0_; }
    /// r_0 (the support is one point).
    [[nodiscard]] double r_max() const noexcept { return r0_; }
    /// Number density N_0 [1/m^3].
    [[nodiscard]] double number_density() const noexcept { return n0_; }
    /// One-line description.
    [[nodiscard]] std::string to_string() const { return "MonodispersePsd[r = " + grainlight::detail::to_display(r0_) + " um, N = " + grainlight::detail::to_display(n0_) + "]"; }
    /// Step CDF: 0 below r_0, 1 from r_0 on.
    [[nodiscard]] double cdf(double r) const noexcept { return r >= r0_ ? 1.0 : 0.0; }
    /// Always r_0.
    [[nodiscard]] double sample(double) const noexcept { return r0_; }
    /// E[r^k] = r_0^k [um^k].
    [[nodiscard]] double moment(double k) const noexcept { return std::pow(r0_, k); }

private:
    double r0_, n0_;
};

/// Tabulated PSD: densities at radii r_0 < ... < r_n (linear in between), e.g. measured or
/// binned from a particle realization (Guo21 Fig. 7). r_min = r_0, r_max = r_n.
class TabulatedPsd {
public:
    /// Densities (>= 0, linear between nodes, positive integral) at radii (>= 2, >= 0, strictly
    /// increasing) [um], normalized internally; number_density >= 0 [1/m^3] particles in total.
    /// Throws grainlight::invalid_argument otherwise.
    TabulatedPsd(std::span<const double> radii, std::span<const double> densities, double number_density = 1.0)
        : n0_(number_density) {
        const char* who = "TabulatedPsd";
        check_argument(radii.size() >= 2, who, "radii.size()", radii.size(), ">= 2");
        check_argument(radii.size() == densities.size(), who, "densities.size()", densities.size(),
                       "equal to radii.size() = " + std::to_string(radii.size()));
        check_argument(std::isfinite(radii[0]) && radii[0] >= 0, who, "radii[0]", radii[0], ">= 0 (finite)");
        for (std::size_t i = 1; i < radii.size(); ++i)
            check_argument(std::isfinite(radii[i]) && radii[i] > radii[i - 1], who, "radii[" + std::to_string(i) + "]",
                           radii[i], "finite and increasing");
        check_argument(std::isfinite(number_density) && number_density >= 0, who, "number_density", number_density,
                       ">= 0 (finite)");
        dist_ = PiecewiseLinear1D<double>(radii, densities);
        r_.assign(radii.begin(), radii.end());
    }
    /// Smallest tabulated radius r_0 [um].
    [[nodiscard]] double r_min() const noexcept { return r_.front(); }
    /// Largest tabulated radius r_n [um].
    [[nodiscard]] double r_max() const noexcept { return r_.back(); }
    /// Number density N_0 [1/m^3].
    [[nodiscard]] double number_density() const noexcept { return n0_; }
    /// One-line description.
    [[nodiscard]] std::string to_string() const {
        return "TabulatedPsd[" + std::to_string(r_.size()) + " nodes, r in [" + grainlight::detail::to_display(r_.front()) + ", " + grainlight::detail::to_display(r_.back()) +
               "] um, N = " + grainlight::detail::to_display(n0_) + "]";
    }
    /// Normalized density [1/um] (0 outside [r_0, r_n]).
    [[nodiscard]] double pdf(double r) const noexcept {
        return (r >= r_.front() && r <= r_.back()) ? dist_.pdf(r) : 0.0;
    }
    /// N(r) = number_density * pdf(r).
    [[nodiscard]] double density(double r) const noexcept { return n0_ * pdf(r); }
    /// Cumulative distribution (exact for the piecewise-linear density).
    [[nodiscard]] double cdf(double r) const noexcept {
        if (r <= r_.front()) return 0.0;
        if (r >= r_.back()) return 1.0;
        return dist_.invert(r);
    }
    /// Radius for u in [0, 1) by exact inversion.
    [[nodiscard]] double sample(double u) const noexcept { return dist_.sample(u); }
    /// E[r^k], exact for the piecewise-linear density (Gauss-Legendre, 8 points per interval).
    [[nodiscard]] double moment(double k) const noexcept {
        constexpr auto& gl = gauss_legendre_nodes<8>;  // positive half: nodes 4..7
        double m = 0;
        for (std::size_t i = 0; i + 1 < r_.size(); ++i) {
            const double a = r_[i], b = r_[i + 1], c = 0.5 * (a + b), h = 0.5 * (b - a);
            for (std::size_t g = 4; g < 8; ++g)
                for (double sgn : {-1.0, 1.0}) {
                    const double r = c + sgn * h * gl.x[g];
                    m += h * gl.w[g] * std::pow(r, k) * dist_.pdf(r);
                }
        }
        return m;
    }
    /// The tabulated radii (the density's kinks), for quadrature.
    [[nodiscard]] std::vector<double> breakpoints() const { return r_; }

private:
    PiecewiseLinear1D<double> dist_;
    std::vector<double> r_;
    double n0_;
};

}  // namespace grainlight
