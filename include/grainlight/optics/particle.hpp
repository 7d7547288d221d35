/// @file grainlight/optics/particle.hpp
/// Optics of one spherical particle by radius, wavelength, particle and host index (Guo21 Sec. 3,
/// Eqs. 1-3): exact Lorenz-Mie below a switch radius (default 2 um) and the geometrical optics
/// approximation from it on, as the paper does (Sec. 3.3 and Sec. 6), but only where GOA is valid
/// (goa_validity in goa.hpp: x >= 45, or 100 for Im m > 2, and 2 x |m - 1| >= 6); elsewhere the
/// automatic method keeps exact Mie, which is cheap exactly where GOA fails.
///
/// Units: radius and wavelength in micrometres (um), cross sections in um^2, phase function per
/// steradian. The wavelength is the VACUUM wavelength; the wavenumber in the host is
/// k = 2 pi n_host / lambda and the size parameter x = k r. The particle index may be complex
/// (n + i k, k >= 0 absorbs); the host index is real. Amplitude conventions: lorenz_mie.hpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <optional>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"

namespace grainlight {

/// Guo21's switch from Lorenz-Mie to GOA: r >= 2 um uses GOA.
inline constexpr double default_switch_radius_um = 2.0;

/// Which theory computes a particle's amplitudes.
enum class ScatteringMethod {
    mie,        ///< exact Lorenz-Mie at every radius
    goa,        ///< geometrical optics approximation at every radius
    automatic,  ///< GOA from the switch radius on (Guo21) where GOA is valid (goa_validity), Mie elsewhere
};

/// Cross sections of one particle [um^2] and its asymmetry parameter.
struct ParticleCrossSections {
    double C_t = 0;  ///< extinction (Eq. 3)
    double C_s = 0;  ///< scattering (Eq. 2)
    double C_a = 0;  ///< absorption, C_t - C_s
};

/// Settings shared by every particle of a medium: indices, method, switch radius, GOA order.
struct ParticleModel {
    std::complex<double> particle_index{1.33, 0.0};  ///< n + i k of the particle material (k >= 0)
    double host_index = 1.0;                         ///< real index of the host medium
    /// Mie, GOA, or automatic choice by switch_radius_um.
    ScatteringMethod method = ScatteringMethod::automatic;
    double switch_radius_um = default_switch_radius_um;  ///< automatic: GOA for r >= this
    int p_max = 3;                                       ///< GOA orders 0..p_max (Guo21 uses 3)

    /// Validate (throws grainlight::invalid_argument naming the field).
    void validate() const {
        const char* who = "ParticleModel";
        check_argument(std::isfinite(particle_index.real()) && particle_index.real() > 0, who, "particle_index.real",
                       particle_index.real(), "> 0 (finite)");
        check_argument(std::isfinite(particle_index.imag()) && particle_index.imag() >= 0, who, "particle_index.imag",
                       particle_index.imag(), ">= 0 (finite; k >= 0 absorbs)");
        check_argument(std::isfinite(host_index) && host_index > 0, who, "host_index", host_index, "> 0 (finite)");
        check_argument(std::isfinite(switch_radius_um) && switch_radius_um >= 0, who, "switch_radius_um",
                       switch_radius_um, ">= 0 (finite)");
        check_argument(p_max >= 0 && p_max <= 1000, who, "p_max", p_max, "0..1000");
        check_argument(method == ScatteringMethod::mie || particle_index.real() != host_index, who,
                       "particle_index.real", particle_index.real(), "!= host_index for GOA (no rays otherwise)");
    }
    /// Relative index m = particle / host.
    [[nodiscard]] std::complex<double> relative_index() const noexcept { return particle_index / host_index; }
    /// One-line description: indices, method and GOA orders.
    [[nodiscard]] std::string to_string() const {
        const char* meth = method == ScatteringMethod::mie ? "mie" : method == ScatteringMethod::goa ? "goa" : "automatic";
        return "ParticleModel[particle index " + grainlight::detail::to_display(particle_index.real()) + " + " + grainlight::detail::to_display(particle_index.imag()) +
               "i, host index " + grainlight::detail::to_display(host_index) + ", method " + meth + ", p_max " + std::to_string(p_max) + "]";
    }
    /// Guo21's rule alone: the method by the switch radius, without GOA's validity check (prefer
    /// method_at(radius, wavelength), which optics/bulk.hpp uses).
    [[nodiscard]] ScatteringMethod method_at(double radius_um) const noexcept {
        if (method != ScatteringMethod::automatic) return method;
        return radius_um < switch_radius_um ? ScatteringMethod::mie : ScatteringMethod::goa;
    }
    /// The method used at radius r [um] and vacuum wavelength lambda [um]: automatic uses GOA only
    /// for r >= switch_radius_um where goa_validity(m, x) holds, Mie otherwise.
    [[nodiscard]] ScatteringMethod method_at(double radius_um, double wavelength_um) const noexcept {
        if (method != ScatteringMethod::automatic) return method;
        if (radius_um < switch_radius_um) return ScatteringMethod::mie;
        const double x = 2 * pi_v<double> * host_index * radius_um / wavelength_um;
        return goa_validity(relative_index(), x).valid ? ScatteringMethod::goa : ScatteringMethod::mie;
    }
    /// Smallest radius [um] from which the automatic method uses GOA at vacuum wavelength lambda
    /// [um] (infinite when the indices match).
    [[nodiscard]] double goa_from_radius_um(double wavelength_um) const noexcept {
        const double x_min = goa_valid_min_size_parameter(relative_index());
        return std::max(switch_radius_um, x_min * wavelength_um / (2 * pi_v<double> * host_index));
    }
};

/// One particle: amplitudes, cross sections and phase function (Eqs. 1-3). Construction of a
/// GOA particle integrates Eq. 2 numerically (~13 x evaluations: ~0.1 s at r = 1 mm, 0.55 um);
/// bulk integration (bulk.hpp) does not use this class and caches rays instead.
class SingleParticle {
public:
    /// radius_um > 0, wavelength_um (vacuum) > 0; model validated.
    SingleParticle(double radius_um, double wavelength_um, const ParticleModel& model)
        : r_(radius_um), lambda_(wavelength_um), model_(model) {
        check_argument(std::isfinite(radius_um) && radius_um > 0, "SingleParticle", "radius_um", radius_um, "> 0 (finite)");
        check_argument(std::isfinite(wavelength_um) && wavelength_um > 0, "SingleParticle", "wavelength_um",
                       wavelength_um, "> 0 (finite)");
        model.validate();
        k_ = 2 * pi_v<double> * model.host_index / wavelength_um;
        x_ = k_ * radius_um;
        used_ = model.method_at(radius_um, wavelength_um);
        const auto m = model.relative_index();
        validity_ = grainlight::goa_validity(m, x_);
        if (used_ == ScatteringMethod::mie) {
            mie_.emplace(m, x_);
            c_s_eq2_ = mie_->efficiencies().qsca * pi_v<double> * r_ * r_;
        } else {
            goa_.emplace(m, x_, model.p_max);
            // Refuses (invalid_argument naming x and 2 x |m - 1|) where GOA's Qext or Qsca is negative.
            goa_q_ = goa_efficiencies(*goa_);
            // Eq. 2 by quadrature (GOA is not energy-consistent: this differs from C_t - C_a).
            c_s_eq2_ = goa_intensity_moments(*goa_).i0 * pi_v<double> / (k_ * k_);
        }
    }

    /// Particle radius [um].
    [[nodiscard]] double radius_um() const noexcept { return r_; }
    /// Vacuum wavelength [um].
    [[nodiscard]] double wavelength_um() const noexcept { return lambda_; }
    /// Wavenumber in the host, 2 pi n_host / lambda [1/um].
    [[nodiscard]] double wavenumber() const noexcept { return k_; }
    /// Size parameter x = k r (k in the host).
    [[nodiscard]] double size_parameter() const noexcept { return x_; }
    /// Method actually used for this particle (automatic resolved to mie or goa).
    [[nodiscard]] ScatteringMethod method() const noexcept { return used_; }
    /// Whether GOA is valid at this (m, x) (goa.hpp); for ScatteringMethod::goa outside it the
    /// results are computed but flagged here.
    [[nodiscard]] const GoaValidity& goa_validity() const noexcept { return validity_; }
    /// Settings the particle was built with.
    [[nodiscard]] const ParticleModel& model() const noexcept { return model_; }

    /// S1, S2 at scattering angle theta [rad], 0 <= theta <= pi.
    [[nodiscard]] ScatteringAmplitudes amplitudes_at_angle(double theta) const {
        if (mie_) {
            const double mu = theta <= 0 ? 1.0 : theta >= pi_v<double> ? -1.0 : std::cos(theta);
            return mie_->amplitudes(mu);
        }
        return goa_->amplitudes_at_angle(theta);
    }
    /// |S1|^2 + |S2|^2 at theta (twice the unpolarized intensity).
    [[nodiscard]] double intensity_at_angle(double theta) const {
        const auto s = amplitudes_at_angle(theta);
        return std::norm(s.S1) + std::norm(s.S2);
    }

    /// C_t (Eq. 3), C_s, C_a [um^2]. Mie: from the series. GOA: C_t by Eq. 12 (its Re S(0)),
    /// C_a by ray optics (Eq. 13 in the weak limit), C_s = C_t - C_a (so 0 <= C_s <= C_t: a
    /// single-scattering albedo <= 1 for rendering; see scattering_cross_section_eq2).
    [[nodiscard]] ParticleCrossSections cross_sections() const {
        const double geo = pi_v<double> * r_ * r_;
        ParticleCrossSections c;
        if (mie_) {
            const auto q = mie_->efficiencies();
            c.C_t = q.qext * geo;
            c.C_s = q.qsca * geo;
        } else {
            c.C_t = goa_q_.qext * geo;
            c.C_s = goa_q_.qsca * geo;
        }
        c.C_a = c.C_t - c.C_s;
        return c;
    }

    /// C_s by Eq. 2, the integral of (|S1|^2 + |S2|^2) / (2 k^2) over the sphere [um^2]: the
    /// Mie series' C_s; for GOA a quadrature (goa_intensity_moments), which differs from the
    /// energy-consistent C_t - C_a of cross_sections() (by ~20 % at r = 2 um where Eq. 12's ripple
    /// is deep, ~1 % at 100 um).
    [[nodiscard]] double scattering_cross_section_eq2() const noexcept { return c_s_eq2_; }

    /// Phase function f_p(theta) = (|S1|^2 + |S2|^2) / (2 k^2 C_s) per steradian with C_s from
    /// Eq. 2 (so it integrates to 1 over the sphere for Mie and GOA alike) (Eq. 1).
    [[nodiscard]] double phase(double theta) const {
        return intensity_at_angle(theta) / (2 * k_ * k_ * c_s_eq2_);
    }

    /// The Mie solver when method() is mie (empty otherwise).
    [[nodiscard]] const std::optional<LorenzMie>& mie() const noexcept { return mie_; }
    /// The GOA solver when method() is goa (empty otherwise).
    [[nodiscard]] const std::optional<Goa>& goa() const noexcept { return goa_; }

private:
    double r_, lambda_;
    ParticleModel model_;
    double k_ = 0, x_ = 0, c_s_eq2_ = 0;
    ScatteringMethod used_ = ScatteringMethod::mie;
    std::optional<LorenzMie> mie_;
    std::optional<Goa> goa_;
    GoaEfficiencies goa_q_;
    GoaValidity validity_;
};

}  // namespace grainlight
