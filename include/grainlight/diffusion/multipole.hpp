/// @file grainlight/diffusion/multipole.hpp
/// Multipole diffusion in a slab of finite thickness (Donner & Jensen 2005), with either the
/// classical dipole's boundary/exitance terms or the improved ones of d'Eon & Irving 2011 /
/// Habel et al. 2013 (the combination Meng15 App. A uses, there with eta = 1).
///
/// Geometry: the slab 0 < z < d (z = depth), both faces of relative index eta, extrapolated
/// boundaries at z = -z_b and z = d + z_b (z_b = 2 A D, fluence zero there). A unit-power
/// isotropic point source at depth z in [0, d] is mirrored about both extrapolated boundaries;
/// with L = d + 2 z_b the images are, for i = -n..n,
///
///   positive at c_i^+ = 2 i L + z,   negative at c_i^- = 2 i L - z - 2 z_b
///
/// (Donner & Jensen 2005's z_{r,i}, z_{v,i} with z_b(0) = z_b(d)). Each image of sign q at
/// coordinate c contributes at a face point (distance rho to the image, depth distance h from the
/// face to the image, measured along the outward normal's opposite):
///   phi += q e^{-s rho} / (4 pi D rho),   E += q h (1 + s rho) e^{-s rho} / (4 pi rho^3),
/// and the exitance is C_phi phi + C_E E: h = c at the top face (reflectance R), h = d - c at the
/// bottom face (transmittance T). Model `classical`: D = 1/(3 sigma_t'), A = (1 + F_dr)/(1 - F_dr),
/// C_phi = 0, C_E = 1 (flux only, Donner & Jensen 2005). Model `improved`: Grosjean's D,
/// A = (1 + 3 C_2)/(1 - 2 C_1), C_phi, C_E from the Fresnel moments (improved.hpp).
///
/// Totals use the infinite image series in closed form, i.e. the 1D Green's function of
/// D Phi'' - sigma_a Phi = -delta(z - z_s) with Phi(-z_b) = Phi(d + z_b) = 0: with a = z + z_b,
/// b = d + z_b - z, L = a + b,
///   Phi(0) = sinh(s z_b) sinh(s b) / (D s sinh(s L)),  D Phi'(0) = cosh(s z_b) sinh(s b) / sinh(s L),
/// and the mirror expressions (a <-> b) at z = d; R_tot = C_phi Phi(0) + C_E D Phi'(0). (At s = 0
/// they reduce to b / L and a / L: R + T = 1 without absorption.) The profiles sum n image pairs:
/// by default the smallest n with e^{-2 n s L} < 1e-7 (at least 3, at most 200); without
/// absorption the far images carry O(1) of the power to radii ~ n L, so truncated profiles
/// integrate to less than the totals there.
///
/// Pencil beam at normal incidence (R(r), T(r), totals()): model classical puts one source of
/// strength alpha' at depth min(1 / sigma_t', d) (Donner & Jensen 2005); model improved
/// integrates the exponential line source alpha' sigma_t' e^{-sigma_t' t}, t in [0, d] (PBD).
/// The unscattered beam e^{-sigma_t' d} is not included in T (add it when comparing).
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>

#include "grainlight/core/config.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/diffusion/boundary.hpp"

namespace grainlight {

/// Which boundary condition / exitance / beam model a diffusion solution uses.
enum class DiffusionModel {
    classical,  ///< Jensen et al. 2001 / Donner & Jensen 2005: D = 1/(3 sigma_t'), flux only
    improved    ///< d'Eon & Irving 2011 / Habel et al. 2013: Grosjean D, C_phi phi + C_E E
};

/// Reflectance and transmittance of a slab (both fractions of the source's power).
template <std::floating_point F>
struct SlabTotals {
    F R = F(0);  ///< leaves through the top face (z = 0)
    F T = F(0);  ///< leaves through the bottom face (z = d)
};

/// Multipole slab (see the file comment). Immutable after construction; evaluation is noexcept,
/// allocation-free and thread-safe.
template <std::floating_point F = double>
class MultipoleSlab {
public:
    /// \param sigma_s_prime reduced scattering coefficient >= 0 (1/length);
    /// \param sigma_a absorption coefficient >= 0 (1/length), sigma_s' + sigma_a > 0;
    /// \param eta relative index of both faces in (0, 10]; \param thickness d in (0, inf)
    /// (length); \param model DiffusionModel; \param n_pairs number of image pairs on each side
    /// (0 = automatic, see the file comment; at most 10000).
    /// Throws grainlight::invalid_argument naming the offending parameter.
    MultipoleSlab(F sigma_s_prime, F sigma_a, F eta, F thickness, DiffusionModel model = DiffusionModel::improved,
                  int n_pairs = 0) {
        detail::check_diffusion_parameters("MultipoleSlab", sigma_s_prime, sigma_a, eta);
        check_argument(std::isfinite(thickness) && thickness > F(0), "MultipoleSlab", "thickness", thickness,
                       "(0, inf) (length)");
        check_argument(n_pairs >= 0 && n_pairs <= 10000, "MultipoleSlab", "n_pairs", n_pairs, "[0, 10000] (0 = auto)");
        sigma_s_prime_ = sigma_s_prime;
        sigma_a_ = sigma_a;
        eta_ = eta;
        d_ = thickness;
        model_ = model;
        sigma_t_prime_ = sigma_s_prime + sigma_a;
        alpha_prime_ = sigma_s_prime / sigma_t_prime_;
        if (model == DiffusionModel::classical) {
            D_ = F(1) / (F(3) * sigma_t_prime_);
            A_ = boundary_A_classical(eta);
            w_ = ExitanceWeights<F>{F(0), F(1)};
        } else {
            D_ = (F(2) * sigma_a + sigma_s_prime) / (F(3) * sigma_t_prime_ * sigma_t_prime_);
            A_ = boundary_A(eta);
            w_ = exitance_weights(eta);
        }
        sigma_tr_ = std::sqrt(sigma_a / D_);
        z_b_ = F(2) * A_ * D_;
        L_ = d_ + F(2) * z_b_;
        if (n_pairs > 0) {
            n_ = n_pairs;
        } else {
            const F decay = F(2) * sigma_tr_ * L_;  // e-folds per image pair
            const F want = F(16.2);                 // e^{-16.2} ~ 1e-7
            n_ = decay > want / F(200) ? std::clamp(int(std::ceil(want / decay)), 3, 200) : 200;
        }
    }

    /// Reflectance profile (1/length^2) on the top face at distance r from the point above a
    /// unit-power isotropic point source at depth z in [0, d] (singular at r = 0 for a source on
    /// the face).
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE F point_R(F r, F z) const noexcept { return face(r, z, false); }
    /// Transmittance profile (1/length^2) on the bottom face at distance r from the point below
    /// the source.
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE F point_T(F r, F z) const noexcept { return face(r, z, true); }

    /// Fractions of a point source's power at depth z in [0, d] leaving through the top (R) and
    /// bottom (T) faces: the infinite image series in closed form (1D Green's function).
    [[nodiscard]] SlabTotals<F> point_totals(F z) const noexcept {
        z = std::clamp(z, F(0), d_);
        const F s = sigma_tr_;
        const F a = z + z_b_, b = d_ + z_b_ - z;
        const F sr_b = detail::sinh_ratio(s, b), sr_a = detail::sinh_ratio(s, a), sr_L = detail::sinh_ratio(s, L_);
        const F sr_zb = detail::sinh_ratio(s, z_b_);
        const F ch = F(0.5) * (F(1) + std::exp(F(-2) * s * z_b_));  // e^{-s z_b} cosh(s z_b)
        // sinh(s x) = e^{s x} s sinh_ratio(s, x); the exponentials combine to e^{-s z}, e^{-s (d - z)}.
        const F e_top = std::exp(-s * z), e_bot = std::exp(-s * (d_ - z));
        SlabTotals<F> t;
        t.R = e_top * (w_.C_phi * sr_zb * sr_b / (D_ * sr_L) + w_.C_E * ch * sr_b / sr_L);
        t.T = e_bot * (w_.C_phi * sr_zb * sr_a / (D_ * sr_L) + w_.C_E * ch * sr_a / sr_L);
        return t;
    }

    /// Reflectance profile R(r) (1/length^2) of a unit-power pencil beam at normal incidence, r > 0
    /// for the improved model (see the file comment).
    [[nodiscard]] F R(F r) const noexcept { return beam(r, false); }
    /// Transmittance profile T(r) (1/length^2) below the beam, diffuse part only.
    [[nodiscard]] F T(F r) const noexcept { return beam(r, true); }

    /// Total diffuse reflectance and transmittance of the pencil beam (T without the unscattered
    /// beam e^{-sigma_t' d}); absorbed = alpha'-weighted rest.
    [[nodiscard]] SlabTotals<F> totals() const noexcept {
        if (model_ == DiffusionModel::classical) {
            const SlabTotals<F> p = point_totals(classical_depth());
            return {alpha_prime_ * p.R, alpha_prime_ * p.T};
        }
        const F st = sigma_t_prime_;
        const F h0 = F(0.5) * std::min(d_, F(1) / st);
        SlabTotals<F> acc;
        acc.R = alpha_prime_ * st * detail::integrate_geometric([&](F t) { return std::exp(-st * t) * point_totals(t).R; }, F(0), d_, h0);
        acc.T = alpha_prime_ * st * detail::integrate_geometric([&](F t) { return std::exp(-st * t) * point_totals(t).T; }, F(0), d_, h0);
        return acc;
    }

    /// Reduced scattering coefficient sigma_s' (1/length) given at construction.
    [[nodiscard]] F sigma_s_prime() const noexcept { return sigma_s_prime_; }
    /// Absorption coefficient sigma_a (1/length).
    [[nodiscard]] F sigma_a() const noexcept { return sigma_a_; }
    /// Relative index eta = n_medium / n_outside.
    [[nodiscard]] F eta() const noexcept { return eta_; }
    /// Slab thickness d (length).
    [[nodiscard]] F thickness() const noexcept { return d_; }
    /// Source model of every pole pair (classical dipole or improved).
    [[nodiscard]] DiffusionModel model() const noexcept { return model_; }
    /// sigma_t' = sigma_s' + sigma_a (1/length).
    [[nodiscard]] F sigma_t_prime() const noexcept { return sigma_t_prime_; }
    /// alpha' = sigma_s' / sigma_t'.
    [[nodiscard]] F alpha_prime() const noexcept { return alpha_prime_; }
    /// Diffusion coefficient of the model (length).
    [[nodiscard]] F D() const noexcept { return D_; }
    /// sigma_tr = sqrt(sigma_a / D) (1/length).
    [[nodiscard]] F sigma_tr() const noexcept { return sigma_tr_; }
    /// Boundary coefficient of the model.
    [[nodiscard]] F A() const noexcept { return A_; }
    /// Extrapolation distance z_b = 2 A D (length).
    [[nodiscard]] F z_b() const noexcept { return z_b_; }
    /// Number of image pairs on each side summed by the profiles.
    [[nodiscard]] int n_pairs() const noexcept { return n_; }

private:
    [[nodiscard]] F classical_depth() const noexcept { return std::min(F(1) / sigma_t_prime_, d_); }

    // Exitance at a face point from all images of a point source at depth z.
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE F face(F r, F z, bool bottom) const noexcept {
        const F s = sigma_tr_, r2 = r * r;
        F phi = F(0), E = F(0);
        for (int i = -n_; i <= n_; ++i) {
            const F shift = F(2) * F(i) * L_;
            const F c[2] = {shift + z, shift - z - F(2) * z_b_};
            for (int k = 0; k < 2; ++k) {
                const F q = k == 0 ? F(1) : F(-1);
                const F h = bottom ? d_ - c[k] : c[k];
                const F rho = std::sqrt(r2 + h * h);
                const F e = std::exp(-s * rho);
                phi += q * e / rho;
                E += q * h * (F(1) + s * rho) * e / (rho * rho * rho);
            }
        }
        return (w_.C_phi * phi / D_ + w_.C_E * E) / (F(4) * pi_v<F>);
    }

    [[nodiscard]] F beam(F r, bool bottom) const noexcept {
        if (model_ == DiffusionModel::classical) return alpha_prime_ * face(r, classical_depth(), bottom);
        const F st = sigma_t_prime_;
        const F h0 = F(0.5) * std::min({r, F(1) / st, d_});
        const F half = F(0.5) * d_;
        // Panels refine toward both faces (the profile of a source near a face peaks at r ~ depth).
        const F top = detail::integrate_geometric([&](F t) { return std::exp(-st * t) * face(r, t, bottom); }, F(0), half, h0);
        const F bot = detail::integrate_geometric(
            [&](F u) { return std::exp(-st * (d_ - u)) * face(r, d_ - u, bottom); }, F(0), half, h0);
        return alpha_prime_ * st * (top + bot);
    }

    F sigma_s_prime_{}, sigma_a_{}, eta_{}, d_{}, sigma_t_prime_{}, alpha_prime_{}, D_{}, sigma_tr_{}, A_{}, z_b_{}, L_{};
    DiffusionModel model_ = DiffusionModel::improved;
    ExitanceWeights<F> w_{};
    int n_ = 3;
};

}  // namespace grainlight
