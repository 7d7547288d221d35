/// @file grainlight/optics/microfacet.hpp
/// A glossy reflector: the GGX (Trowbridge-Reitz) microfacet BRDF with the height-correlated
/// Smith shadowing-masking term and Schlick's Fresnel approximation on a normal-incidence
/// reflectance F0 per channel (Walter, Marschner, Li, Torrance, "Microfacet models for refraction
/// through rough surfaces", EGSR 2007; Heitz, "Understanding the masking-shadowing function in
/// microfacet-based BRDFs", JCGT 3(2), 2014; Schlick, CGF 13(3), 1994), sampled by the
/// distribution of visible normals (Heitz, "Sampling the GGX distribution of visible normals",
/// JCGT 7(4), 2018), so a sample's weight f cos / pdf is F(wo.h) G2 / G1(wo) <= 1 per channel.
///
/// Local frame: the normal is +z; wo and wi point away from the surface (wo toward the viewer,
/// i.e. minus the arriving propagation direction; wi the sampled outgoing propagation direction).
/// `alpha` is the GGX width (alpha = roughness in the usual alpha = r^2 convention's r^2), in
/// [glossy_min_alpha, 1].
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "grainlight/core/math.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Smallest GGX width the glossy model accepts (below it the lobe is a mirror to float precision).
inline constexpr double glossy_min_alpha = 1e-3;

/// GGX microfacet distribution of width alpha in the local frame (normal +z).
template <std::floating_point F>
struct Ggx {
    F alpha = F(0.2);  ///< width (in [glossy_min_alpha, 1])

    /// D(h): microfacet normal density (projected-area normalised: int D(h) h.z dh = 1).
    [[nodiscard]] F D(const Vec3<F>& h) const noexcept {
        if (h.z <= F(0)) return F(0);
        const F a2 = alpha * alpha;
        const F t = h.z * h.z * (a2 - F(1)) + F(1);
        return a2 / (pi_v<F> * t * t);
    }
    /// Smith's Lambda(w).
    [[nodiscard]] F lambda(const Vec3<F>& w) const noexcept {
        const F c2 = w.z * w.z;
        if (c2 <= F(0)) return std::numeric_limits<F>::infinity();
        const F tan2 = std::max(F(0), F(1) - c2) / c2;
        return (std::sqrt(F(1) + alpha * alpha * tan2) - F(1)) / F(2);
    }
    /// Masking G1(w) = 1 / (1 + Lambda(w)).
    [[nodiscard]] F G1(const Vec3<F>& w) const noexcept { return F(1) / (F(1) + lambda(w)); }
    /// Height-correlated masking-shadowing G2(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)).
    [[nodiscard]] F G2(const Vec3<F>& wo, const Vec3<F>& wi) const noexcept {
        return F(1) / (F(1) + lambda(wo) + lambda(wi));
    }
    /// A visible normal for wo (wo.z > 0) from u in [0, 1)^2 (Heitz 2018): density
    /// G1(wo) max(0, wo.h) D(h) / wo.z.
    [[nodiscard]] Vec3<F> sample_visible_normal(const Vec3<F>& wo, Vec2<F> u) const noexcept {
        const Vec3<F> vh = glm::normalize(Vec3<F>(alpha * wo.x, alpha * wo.y, wo.z));
        const F lensq = vh.x * vh.x + vh.y * vh.y;
        const Vec3<F> t1 = lensq > F(0) ? Vec3<F>(-vh.y, vh.x, F(0)) / std::sqrt(lensq) : Vec3<F>(F(1), F(0), F(0));
        const Vec3<F> t2 = glm::cross(vh, t1);
        const F r = std::sqrt(u.x), phi = F(2) * pi_v<F> * u.y;
        const F p1 = r * std::cos(phi);
        F p2 = r * std::sin(phi);
        const F s = F(0.5) * (F(1) + vh.z);
        p2 = (F(1) - s) * std::sqrt(std::max(F(0), F(1) - p1 * p1)) + s * p2;
        const Vec3<F> nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(F(0), F(1) - p1 * p1 - p2 * p2)) * vh;
        return glm::normalize(Vec3<F>(alpha * nh.x, alpha * nh.y, std::max(F(1e-7), nh.z)));
    }
};

/// Schlick's Fresnel: F0 + (1 - F0) (1 - cos)^5, per channel.
template <class S, std::floating_point F>
[[nodiscard]] inline S fresnel_schlick(const S& F0, F cos_theta) noexcept {
    const F m = std::clamp(F(1) - cos_theta, F(0), F(1));
    const F m5 = m * m * m * m * m;
    return F0 + (S(F(1)) - F0) * m5;
}

/// A sampled glossy direction: wi (local), the weight f cos(wi) / pdf per channel, the pdf
/// (solid angle); `valid` false when the sample goes below the surface (weight 0).
template <std::floating_point F, class S>
struct GlossySample {
    Vec3<F> wi{F(0), F(0), F(1)};  ///< outgoing propagation direction (local, z = normal)
    S weight = S(F(0));            ///< f cos(wi) / pdf
    F pdf = F(0);                  ///< solid-angle density of wi
    bool valid = false;            ///< wi above the surface
};

/// f(wo, wi) cos(wi) of the glossy BRDF (local frame; 0 unless both are above the surface), and
/// in `pdf` the density with which sample_glossy draws wi: G1(wo) D(h) / (4 wo.z).
template <std::floating_point F, class S>
[[nodiscard]] inline S eval_glossy(const Vec3<F>& wo, const Vec3<F>& wi, const S& F0, F alpha, F& pdf) noexcept {
    pdf = F(0);
    if (wo.z <= F(0) || wi.z <= F(0)) return S(F(0));
    const Vec3<F> hs = wo + wi;
    const F hl = glm::length(hs);
    if (!(hl > F(0))) return S(F(0));
    const Vec3<F> h = hs / hl;
    const Ggx<F> g{alpha};
    const F d = g.D(h);
    const F cos_oh = std::max(F(0), glm::dot(wo, h));
    pdf = g.G1(wo) * d / (F(4) * wo.z);
    return fresnel_schlick(F0, cos_oh) * (d * g.G2(wo, wi) / (F(4) * wo.z));
}

/// Sample the glossy BRDF for wo (local, wo.z > 0) from u in [0, 1)^2 by a visible normal.
template <std::floating_point F, class S>
[[nodiscard]] inline GlossySample<F, S> sample_glossy(const Vec3<F>& wo, const S& F0, F alpha, Vec2<F> u) noexcept {
    GlossySample<F, S> s;
    if (wo.z <= F(0)) return s;
    const Ggx<F> g{alpha};
    const Vec3<F> h = g.sample_visible_normal(wo, u);
    const F cos_oh = glm::dot(wo, h);
    if (cos_oh <= F(0)) return s;
    s.wi = F(2) * cos_oh * h - wo;
    if (s.wi.z <= F(0)) return s;
    s.pdf = g.G1(wo) * g.D(h) / (F(4) * wo.z);
    if (!(s.pdf > F(0))) return s;
    s.weight = fresnel_schlick(F0, cos_oh) * (g.G2(wo, s.wi) / g.G1(wo));
    s.valid = true;
    return s;
}

}  // namespace grainlight
