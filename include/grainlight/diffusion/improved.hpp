/// @file grainlight/diffusion/improved.hpp
/// Improved (d'Eon & Irving 2011 "better dipole" boundary condition, as used by photon beam
/// diffusion, Habel, Christensen & Jarosz 2013) diffusion in a semi-infinite medium: the model
/// Meng15 Sec. 3.4 / App. A use for the VPT -> DA switch, in place of the classical dipole.
///
/// Differences to the classical dipole (dipole.hpp), all from the two papers:
///  - Grosjean's diffusion coefficient D = (2 sigma_a + sigma_s') / (3 sigma_t'^2) and
///    sigma_tr = sqrt(sigma_a / D);
///  - boundary coefficient A = (1 + 3 C_2) / (1 - 2 C_1) from the Fresnel moments, extrapolation
///    distance z_b = 2 A D;
///  - the radiant exitance counts both the fluence and the flux: R = C_phi phi + C_E (-D dphi/dn),
///    C_phi = (1 - 2 C_1) / 4, C_E = (1 - 3 C_2) / 2 (boundary.hpp);
///  - a collimated beam is an exponential line of sources (density alpha' sigma_t' e^{-sigma_t' t}
///    at depth t along the refracted beam, PBD), not one point at 1 / sigma_t'.
///
/// Point source (Meng15 App. A, semi-infinite case): a unit-power isotropic source at depth z
/// (the VPT vertex x_i^k) and a negative image at height z + 2 z_b above the surface (the mirror
/// about the extrapolated boundary, z_v = -z - 2 z_b). With d_r = sqrt(r^2 + z^2),
/// d_v = sqrt(r^2 + (z + 2 z_b)^2), s = sigma_tr:
///
///   phi(r)  = 1/(4 pi D) [ e^{-s d_r} / d_r - e^{-s d_v} / d_v ]
///   E(r)    = 1/(4 pi)   [ z (1 + s d_r) e^{-s d_r} / d_r^3 + (z + 2 z_b) (1 + s d_v) e^{-s d_v} / d_v^3 ]
///   R_p(r; z) = C_phi phi(r) + C_E E(r)                                  (1/length^2)
///   int R_p 2 pi r dr = C_phi / (2 D s) [e^{-s z} - e^{-s (z + 2 z_b)}] + C_E / 2 [e^{-s z} + e^{-s (z + 2 z_b)}]
///
/// (= 1 at sigma_a = 0 for any eta: C_phi 2 A + C_E = 1, the model conserves energy).
/// Beam: R_b(r) = int_0^inf alpha' sigma_t' e^{-sigma_t' t} R_p(r; t) dt, total
///   R_b = alpha' sigma_t' / (sigma_t' + s) [ (C_phi / D) (1 - e^{-2 s z_b}) / (2 s) + (C_E / 2) (1 + e^{-2 s z_b}) ].
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <limits>

#include "grainlight/core/config.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/diffusion/boundary.hpp"

namespace grainlight {

/// Improved diffusion in a half-space (see the file comment). Immutable after construction; the
/// evaluation functions are noexcept, allocation-free and thread-safe.
template <std::floating_point F = double>
class ImprovedDiffusion {
public:
    /// \param sigma_s_prime reduced scattering coefficient sigma_s (1 - g) >= 0 (1/length);
    /// \param sigma_a absorption coefficient >= 0 (1/length), sigma_s' + sigma_a > 0;
    /// \param eta relative index n_medium / n_outside in (0, 10] (Meng15 App. A: 1).
    /// Throws grainlight::invalid_argument naming the offending parameter.
    ImprovedDiffusion(F sigma_s_prime, F sigma_a, F eta = F(1)) {
        detail::check_diffusion_parameters("ImprovedDiffusion", sigma_s_prime, sigma_a, eta);
        sigma_s_prime_ = sigma_s_prime;
        sigma_a_ = sigma_a;
        eta_ = eta;
        sigma_t_prime_ = sigma_s_prime + sigma_a;
        alpha_prime_ = sigma_s_prime / sigma_t_prime_;
        D_ = (F(2) * sigma_a + sigma_s_prime) / (F(3) * sigma_t_prime_ * sigma_t_prime_);
        sigma_tr_ = std::sqrt(sigma_a / D_);
        A_ = boundary_A(eta);
        z_b_ = F(2) * A_ * D_;
        w_ = exitance_weights(eta);
    }

    /// Exitance profile R_p(r; z) (1/length^2) of a unit-power isotropic point source at depth
    /// z >= 0, at distance r >= 0 from the point above it (r = z = 0 is singular).
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE F point_R(F r, F z) const noexcept {
        const F s = sigma_tr_;
        const F z_v = z + F(2) * z_b_;  // height of the image above the surface
        const F r2 = r * r;
        const F d_r = std::sqrt(r2 + z * z), d_v = std::sqrt(r2 + z_v * z_v);
        const F e_r = std::exp(-s * d_r), e_v = std::exp(-s * d_v);
        const F phi = (e_r / d_r - e_v / d_v) / (F(4) * pi_v<F> * D_);
        const F E = (z * (F(1) + s * d_r) * e_r / (d_r * d_r * d_r) + z_v * (F(1) + s * d_v) * e_v / (d_v * d_v * d_v)) /
                    (F(4) * pi_v<F>);
        return w_.C_phi * phi + w_.C_E * E;
    }

    /// int_0^inf R_p(r; z) 2 pi r dr: the fraction of a point source's power at depth z >= 0 that
    /// leaves the surface (closed form, see the file comment).
    [[nodiscard]] F point_total(F z) const noexcept {
        const F s = sigma_tr_;
        const F e = std::exp(-s * z), e_b = std::exp(F(-2) * s * z_b_);
        return w_.C_phi / D_ * e * detail::sinh_ratio(s, z_b_) + F(0.5) * w_.C_E * e * (F(1) + e_b);
    }

    /// Reflectance profile R_b(r) (1/length^2) of a unit-power pencil beam at normal incidence
    /// (exponential line source, PBD), r > 0 (diverges like 1/r at r = 0). Deterministic
    /// quadrature in depth: 8-point Gauss-Legendre panels doubling from min(r, 1/sigma_t') / 2
    /// down to 50 / sigma_t' (~100-300 evaluations of R_p).
    [[nodiscard]] F R(F r) const noexcept {
        const F st = sigma_t_prime_;
        const F h0 = F(0.5) * std::min(r, F(1) / st);
        const F t_max = F(50) / st;
        return alpha_prime_ * st *
               detail::integrate_geometric([&](F t) { return std::exp(-st * t) * point_R(r, t); }, F(0), t_max, h0);
    }

    /// Total diffuse reflectance of the pencil beam, int R_b(r) 2 pi r dr (closed form).
    [[nodiscard]] F total_reflectance() const noexcept {
        const F s = sigma_tr_, st = sigma_t_prime_;
        const F e_b = std::exp(F(-2) * s * z_b_);
        return alpha_prime_ * st / (st + s) *
               (w_.C_phi / D_ * detail::sinh_ratio(s, z_b_) + F(0.5) * w_.C_E * (F(1) + e_b));
    }

    /// Meng15 Sec. 5 (VPT -> DA): a VPT vertex may switch to diffusion when it is at least
    /// d_DA = min(1 / sigma_t', 0.5 / sigma_tr) from the boundary (length).
    [[nodiscard]] F switch_distance() const noexcept {
        const F inv_tr = sigma_tr_ > F(0) ? F(0.5) / sigma_tr_ : std::numeric_limits<F>::infinity();
        return std::min(F(1) / sigma_t_prime_, inv_tr);
    }

    /// Reduced scattering coefficient sigma_s' (1/length) given at construction.
    [[nodiscard]] F sigma_s_prime() const noexcept { return sigma_s_prime_; }
    /// Absorption coefficient sigma_a (1/length).
    [[nodiscard]] F sigma_a() const noexcept { return sigma_a_; }
    /// Relative index eta = n_medium / n_outside.
    [[nodiscard]] F eta() const noexcept { return eta_; }
    /// sigma_t' = sigma_s' + sigma_a (1/length).
    [[nodiscard]] F sigma_t_prime() const noexcept { return sigma_t_prime_; }
    /// alpha' = sigma_s' / sigma_t'.
    [[nodiscard]] F alpha_prime() const noexcept { return alpha_prime_; }
    /// Grosjean's D = (2 sigma_a + sigma_s') / (3 sigma_t'^2) (length).
    [[nodiscard]] F D() const noexcept { return D_; }
    /// sigma_tr = sqrt(sigma_a / D) (1/length).
    [[nodiscard]] F sigma_tr() const noexcept { return sigma_tr_; }
    /// A = (1 + 3 C_2) / (1 - 2 C_1).
    [[nodiscard]] F A() const noexcept { return A_; }
    /// Extrapolation distance z_b = 2 A D (length).
    [[nodiscard]] F z_b() const noexcept { return z_b_; }
    /// C_phi, C_E.
    [[nodiscard]] ExitanceWeights<F> weights() const noexcept { return w_; }

private:
    F sigma_s_prime_{}, sigma_a_{}, eta_{}, sigma_t_prime_{}, alpha_prime_{}, D_{}, sigma_tr_{}, A_{}, z_b_{};
    ExitanceWeights<F> w_{};
};

}  // namespace grainlight
