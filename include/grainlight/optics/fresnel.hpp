/// @file grainlight/optics/fresnel.hpp
/// Smooth dielectric interfaces: unpolarized Fresnel reflectance and Snell refraction.
///
/// Conventions: `cos_theta_i` is the cosine between the incident direction (pointing *away*
/// from the surface, toward where the light came from) and the normal `n`; `eta` = n_t / n_i is
/// the relative index of the side the normal points away from over the side it points into.
/// A negative cos_theta_i means the ray arrives from the other side: the functions flip to
/// eta -> 1/eta themselves.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "grainlight/core/math.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Unpolarized Fresnel reflectance of a smooth dielectric interface (average of the s and p
/// intensity coefficients). Total internal reflection returns 1; eta == 1 returns 0 exactly.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline F fresnel_dielectric(F cos_theta_i, F eta) noexcept {
    cos_theta_i = std::clamp(cos_theta_i, F(-1), F(1));
    if (cos_theta_i < 0) {
        eta = F(1) / eta;
        cos_theta_i = -cos_theta_i;
    }
    if (eta == F(1)) return F(0);
    const F sin2_i = F(1) - cos_theta_i * cos_theta_i;
    const F sin2_t = sin2_i / (eta * eta);
    if (sin2_t >= F(1)) return F(1);
    const F cos_t = safe_sqrt(F(1) - sin2_t);
    const F r_parl = (eta * cos_theta_i - cos_t) / (eta * cos_theta_i + cos_t);
    const F r_perp = (cos_theta_i - eta * cos_t) / (cos_theta_i + eta * cos_t);
    return (r_parl * r_parl + r_perp * r_perp) / F(2);
}

/// Fresnel amplitude coefficients (r_perp, r_parl) for light going from index 1 into index eta
/// at incidence cosine cos_i (>= 0); Born & Wolf sign convention. Returns false on TIR.
template <std::floating_point F>
GRAINLIGHT_HOST_DEVICE inline bool fresnel_amplitudes(F cos_i, F eta, F& r_perp, F& r_parl) noexcept {
    const F sin2_t = (F(1) - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= F(1)) {
        r_perp = r_parl = F(1);
        return false;
    }
    const F cos_t = safe_sqrt(F(1) - sin2_t);
    r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return true;
}

/// Refract `wi` (pointing away from the surface, on the side n points into when dot(wi,n) > 0)
/// through an interface of relative index eta (index behind n over index in front of n).
/// Returns false on total internal reflection. `wt` points away from the surface on the other
/// side; `eta_rel` receives the relative index actually used (eta or 1/eta).
template <std::floating_point F>
GRAINLIGHT_HOST_DEVICE inline bool refract(const Vec3<F>& wi, Vec3<F> n, F eta, Vec3<F>& wt,
                                           F* eta_rel = nullptr) noexcept {
    F cos_i = glm::dot(n, wi);
    if (cos_i < 0) {
        eta = F(1) / eta;
        cos_i = -cos_i;
        n = -n;
    }
    const F sin2_i = std::max(F(0), F(1) - cos_i * cos_i);
    const F sin2_t = sin2_i / (eta * eta);
    if (sin2_t >= F(1)) return false;
    const F cos_t = safe_sqrt(F(1) - sin2_t);
    wt = -wi / eta + (cos_i / eta - cos_t) * n;
    if (eta_rel) *eta_rel = eta;
    return true;
}

/// Hemispherical average of the Fresnel reflectance, 2 int_0^1 F(mu) mu dmu, for light inside a
/// medium of relative index eta hitting its boundary (numerical, 256-point midpoint rule in mu^2).
/// Exactly 0 at eta == 1 (pitfalls.md: fits give ~0.002 there).
template <std::floating_point F>
[[nodiscard]] inline F fresnel_diffuse_reflectance(F eta) noexcept {
    if (eta == F(1)) return F(0);
    const int n = 256;
    double acc = 0;
    for (int i = 0; i < n; ++i) {
        const double mu2 = (i + 0.5) / n;  // integrate F d(mu^2)
        acc += double(fresnel_dielectric(F(std::sqrt(mu2)), F(1) / eta));
    }
    return F(acc / n);
}

/// What a path carries: radiance for camera paths (a refraction scales it by 1/eta_rel^2),
/// importance (power) for light paths (no scaling).
enum class TransportMode : std::uint8_t { radiance, importance };

/// Result of sample_dielectric.
template <std::floating_point F>
struct DielectricSample {
    Vec3<F> w{F(0)};        ///< new propagation direction (unit)
    bool refracted = false; ///< refraction (true) or reflection (false)
    F eta_rel = F(1);       ///< n_t / n_i along the path (1 on reflection)
};

/// Resolve a smooth dielectric interface for a path travelling along `d` that hits a surface with
/// unit outward normal `n` and relative index `eta` = n_inside / n_outside, with one uniform `u`:
/// Fresnel reflection with probability F (unpolarized, fresnel_dielectric) and refraction
/// otherwise (always reflection under total internal reflection).
template <std::floating_point F>
[[nodiscard]] inline DielectricSample<F> sample_dielectric(const Vec3<F>& d, const Vec3<F>& n, F eta, F u) noexcept {
    const Vec3<F> wi = -d;  // toward where the path came from
    const F cos_i = glm::dot(wi, n);
    const F fr = fresnel_dielectric(cos_i, eta);
    DielectricSample<F> s;
    Vec3<F> wt(F(0));
    if (u >= fr && refract(wi, n, eta, wt, &s.eta_rel)) {
        s.refracted = true;
        s.w = glm::normalize(wt);
        return s;
    }
    s.refracted = false;
    s.eta_rel = F(1);
    s.w = glm::normalize(d - F(2) * glm::dot(d, n) * n);
    return s;
}

}  // namespace grainlight
