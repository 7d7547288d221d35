/// @file grainlight/diffusion/boundary.hpp
/// Boundary terms shared by the diffusion models: Fresnel moments of a smooth dielectric
/// boundary seen from inside the medium, the boundary coefficient A (extrapolation distance
/// z_b = 2 A D), the exitance weights C_phi / C_E of d'Eon & Irving 2011, the validation of the
/// reduced medium parameters, and a small composite Gauss-Legendre integrator used by the
/// profile integrals.
///
/// Why numerical moments instead of the usual polynomial fits: the fits (Egan & Hilgeman's F_dr,
/// the polynomial fits of the moments) are accurate to a few 1e-3 and are not exact at eta = 1
/// (F_dr fit ~0.0017, moment fits ~0.002 there, pitfalls.md), while Meng15 App. A runs diffusion
/// with index-matched boundaries (eta = 1), where A must be exactly 1. Integrating
/// grainlight::fresnel_dielectric gives exactly C1 = C2 = 0 at eta = 1 (the function returns 0)
/// and double-precision accuracy elsewhere (the integrand's square-root kink at the critical
/// angle is removed by a change of variable; 16 and 256 panels agree to ~1e-16).
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>

#include "grainlight/core/config.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/quadrature.hpp"
#include "grainlight/optics/fresnel.hpp"

namespace grainlight {

namespace detail {

/// 8-point Gauss-Legendre nodes (positive half, ascending) and weights on [-1, 1], from the one
/// Gauss-Legendre source (core/quadrature.hpp).
inline constexpr std::array<double, 4> gl8_x = {gauss_legendre_nodes<8>.x[4], gauss_legendre_nodes<8>.x[5],
                                                gauss_legendre_nodes<8>.x[6], gauss_legendre_nodes<8>.x[7]};
inline constexpr std::array<double, 4> gl8_w = {gauss_legendre_nodes<8>.w[4], gauss_legendre_nodes<8>.w[5],
                                                gauss_legendre_nodes<8>.w[6], gauss_legendre_nodes<8>.w[7]};

/// int_a^b f(t) dt with one 8-point Gauss-Legendre panel.
template <class F, class Fn>
[[nodiscard]] inline F gl8(Fn&& f, F a, F b) noexcept {
    const F h = F(0.5) * (b - a), m = F(0.5) * (a + b);
    F s = F(0);
    for (int i = 0; i < 4; ++i) s += F(gl8_w[i]) * (f(m - h * F(gl8_x[i])) + f(m + h * F(gl8_x[i])));
    return s * h;
}

/// int_a^b f(t) dt over panels whose widths double away from `a`: [a, a + h0], [a + h0, a + 3 h0],
/// ... (the last one clipped at b). Suited to integrands with a feature of size ~h0 at `a` and a
/// smooth tail (the beam integrals below); 8-point Gauss-Legendre per panel.
template <class F, class Fn>
[[nodiscard]] inline F integrate_geometric(Fn&& f, F a, F b, F h0) noexcept {
    F s = F(0), lo = a, h = h0;
    while (lo < b) {
        const F hi = std::min(b, lo + h);
        s += gl8(f, lo, hi);
        lo = hi;
        h *= F(2);
    }
    return s;
}

/// e^{-s x} sinh(s x) / s = -expm1(-2 s x) / (2 s), continuous at s = 0 (limit x).
template <class F>
[[nodiscard]] inline F sinh_ratio(F s, F x) noexcept {
    const F y = s * x;
    if (std::abs(y) < F(1e-8)) return x * (F(1) - y);
    return -std::expm1(F(-2) * y) / (F(2) * s);
}

}  // namespace detail

/// Fresnel moment C_i(eta) = int_0^1 F_r(mu) mu^i dmu of a smooth boundary for light *inside* a
/// medium of relative index eta = n_medium / n_outside (> 0) hitting it at direction cosine mu
/// (d'Eon & Irving 2011; Habel et al. 2013). Exactly 0 at eta = 1.
/// Computed numerically from grainlight::fresnel_dielectric: total internal reflection below the
/// critical cosine mu_c = sqrt(1 - 1/eta^2) (eta > 1) is integrated analytically, the rest with
/// 16 x 8-point Gauss-Legendre panels in s, mu = mu_c + (1 - mu_c) s^2 (smooth integrand).
template <std::floating_point F>
[[nodiscard]] inline F fresnel_moment(int i, F eta) noexcept {
    if (eta == F(1)) return F(0);
    const double e = double(eta);
    const double mu_c = e > 1.0 ? std::sqrt(1.0 - 1.0 / (e * e)) : 0.0;
    double acc = std::pow(mu_c, i + 1) / (i + 1);  // TIR part: F_r = 1
    const int panels = 16;
    for (int p = 0; p < panels; ++p) {
        const double s0 = double(p) / panels, s1 = double(p + 1) / panels;
        acc += detail::gl8(
            [&](double s) {
                const double mu = mu_c + (1.0 - mu_c) * s * s;
                const double jac = 2.0 * (1.0 - mu_c) * s;
                return double(fresnel_dielectric(F(mu), F(1.0 / e))) * std::pow(mu, i) * jac;
            },
            s0, s1);
    }
    return F(acc);
}

/// Diffuse Fresnel reflectance F_dr = 2 C_1 (hemispherical average for light inside).
template <std::floating_point F>
[[nodiscard]] inline F diffuse_fresnel_reflectance(F eta) noexcept {
    return F(2) * fresnel_moment(1, eta);
}

/// Classical boundary coefficient of Jensen et al. 2001, A = (1 + F_dr) / (1 - F_dr),
/// with F_dr = 2 C_1 integrated numerically (not the Egan-Hilgeman fit). Exactly 1 at eta = 1.
template <std::floating_point F>
[[nodiscard]] inline F boundary_A_classical(F eta) noexcept {
    const F fdr = diffuse_fresnel_reflectance(eta);
    return (F(1) + fdr) / (F(1) - fdr);
}

/// Boundary coefficient of the improved model (d'Eon & Irving 2011; Habel et al. 2013),
/// A = (1 + 3 C_2) / (1 - 2 C_1) = (1 - C_E) / (2 C_phi). Exactly 1 at eta = 1.
template <std::floating_point F>
[[nodiscard]] inline F boundary_A(F eta) noexcept {
    return (F(1) + F(3) * fresnel_moment(2, eta)) / (F(1) - F(2) * fresnel_moment(1, eta));
}

/// Exitance weights of d'Eon & Irving 2011: the radiant exitance leaving the boundary
/// is C_phi phi + C_E (-D n . grad phi) with C_phi = (1 - 2 C_1) / 4, C_E = (1 - 3 C_2) / 2
/// (1/4 and 1/2 at eta = 1).
template <std::floating_point F>
struct ExitanceWeights {
    F C_phi = F(0.25);  ///< weight of the fluence
    F C_E = F(0.5);     ///< weight of the outward flux
};

/// C_phi and C_E for a boundary of relative index eta (see ExitanceWeights).
template <std::floating_point F>
[[nodiscard]] inline ExitanceWeights<F> exitance_weights(F eta) noexcept {
    return {F(0.25) * (F(1) - F(2) * fresnel_moment(1, eta)), F(0.5) * (F(1) - F(3) * fresnel_moment(2, eta))};
}

namespace detail {
/// Construction-time validation of the reduced medium parameters shared by every model.
template <class F>
inline void check_diffusion_parameters(const char* where, F sigma_s_prime, F sigma_a, F eta) {
    check_argument(std::isfinite(sigma_s_prime) && sigma_s_prime >= F(0), where, "sigma_s_prime", sigma_s_prime,
                   "[0, inf) (reduced scattering coefficient, 1/length)");
    check_argument(std::isfinite(sigma_a) && sigma_a >= F(0), where, "sigma_a", sigma_a,
                   "[0, inf) (absorption coefficient, 1/length)");
    const F sigma_t_prime = sigma_s_prime + sigma_a;
    check_argument(sigma_t_prime > F(0), where, "sigma_t_prime", sigma_t_prime,
                   "(0, inf) (sigma_s_prime + sigma_a must be positive)");
    check_argument(std::isfinite(eta) && eta > F(0) && eta <= F(10), where, "eta", eta,
                   "(0, 10] (relative index n_medium / n_outside)");
}
}  // namespace detail

}  // namespace grainlight
