/// @file grainlight/scene/concepts.hpp
/// What integrators may ask of a scene: the surface-hit record and the WalkScene / LitScene
/// concepts. Integrators (integrators/walk.hpp, integrators/vpt.hpp) see scenes only through
/// these; any user type meeting them works (our own scene/scene.hpp is one model, the analytic
/// plane-parallel slab of scene/slab.hpp another).
///
/// Conventions
///  - Directions are propagation directions (the way light or the path travels), unit length.
///  - A surface separates an *outside* (the side the unit normal `n` points into) from an
///    *inside*. `medium_outside` / `medium_inside` name the media on either side by index into
///    the scene's media (-1 = vacuum / no medium). Closed shapes have outward normals.
///  - `eta` = n_inside / n_outside: the relative index of refraction across a dielectric
///    interface (1 for an index-matched boundary).
#pragma once

#include <concepts>
#include <cstdint>
#include <limits>

#include "grainlight/core/ray.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// How the walk kernel resolves a surface hit.
enum class SurfaceType : std::uint8_t {
    passthrough,  ///< index-matched medium boundary (no reflection): the path continues straight on
    dielectric,   ///< smooth dielectric interface: Fresnel reflection or Snell refraction (eta)
    diffuse,      ///< Lambertian reflector with albedo `reflectance` (opaque)
    absorber,     ///< black, opaque (an emitter with no reflectance, a light shield)
    glossy        ///< opaque GGX microfacet reflector (optics/microfacet.hpp): F0 = `reflectance`, width `roughness`
};

/// A ray-surface intersection. `t` = +inf means no hit (then the other fields are unspecified).
template <std::floating_point F, class S>
struct SurfaceHit {
    F t = std::numeric_limits<F>::infinity();  ///< distance along the (unit) ray direction
    Vec3<F> p{F(0)};                           ///< hit point
    Vec3<F> n{F(0), F(0), F(1)};               ///< unit geometric normal, pointing to the outside
    /// How the walk kernel treats the surface (absorber for a miss).
    SurfaceType type = SurfaceType::absorber;
    F eta = F(1);                 ///< n_inside / n_outside (dielectric)
    S reflectance{F(0)};          ///< diffuse albedo per channel (diffuse); normal-incidence Fresnel F0 (glossy)
    F roughness = F(0);           ///< GGX width alpha (glossy)
    int medium_inside = -1;       ///< medium behind n (-1 = none)
    int medium_outside = -1;      ///< medium in front of n (-1 = none)
    int shape = -1;               ///< shape index (scene-defined)
    int light = -1;               ///< area-light index if the surface emits, else -1
    /// True if the ray hit a surface (t finite).
    [[nodiscard]] bool hit() const noexcept { return t < std::numeric_limits<F>::infinity(); }
    /// Same as hit().
    [[nodiscard]] explicit operator bool() const noexcept { return hit(); }
};

/// A scene the walk kernel can trace: closest-hit queries and media by index.
///   - `intersect(ray)`: closest surface hit with t in (0, ray.t_max); the caller offsets
///     origins off surfaces (offset_ray_origin) so t > 0 suffices.
///   - `medium(i)`: the medium with index i >= 0 (every index a SurfaceHit reports).
template <class Sc>
concept WalkScene = requires(const Sc& s, const Ray<typename Sc::Float>& r, int i) {
    typename Sc::Float;
    typename Sc::Spectrum;
    typename Sc::Medium;
    { s.intersect(r) } -> std::same_as<SurfaceHit<typename Sc::Float, typename Sc::Spectrum>>;
    { s.medium(i) } -> std::convertible_to<const typename Sc::Medium&>;
};

/// A light sample for next-event estimation from point `ref`: `w` is the unit direction *from
/// ref toward the light* (light arrives at ref travelling along -w), `dist`
/// the distance to the sampled light point (+inf for directional/environment lights), `pdf` the
/// solid-angle pdf including the light-selection probability (for delta lights: the selection
/// probability, with `delta` = true), `L` the emitted radiance (or intensity / dist^2 for a
/// point light) not yet divided by the pdf.
template <std::floating_point F, class S>
struct LightSample {
    /// Unit direction from the reference point toward the light.
    Vec3<F> w{F(0), F(0), F(1)};
    /// Distance to the sampled light point (+inf for directional and environment lights).
    F dist = std::numeric_limits<F>::infinity();
    /// Emitted radiance (intensity / dist^2 for point and spot lights), not divided by pdf.
    S L{F(0)};
    /// Solid-angle pdf including the light-selection probability (delta lights: the selection probability).
    F pdf = F(0);
    /// True for a delta light (point, spot, directional): no MIS with phase or BSDF sampling.
    bool delta = false;
    /// True if the sample is usable (pdf > 0).
    [[nodiscard]] explicit operator bool() const noexcept { return pdf > F(0); }
};

/// A scene with lights, for integrators that do next-event estimation and MIS:
///   - `sample_light(ref, u3)`: pick a light and a point/direction on it (LightSample);
///   - `light_pdf(ref, w, hit)`: solid-angle pdf (with selection probability) with which
///     sample_light from `ref` would have produced direction `w` hitting emitter `hit.light`
///     (or the environment when `hit` is a miss);
///   - `emitted(hit, w)`: radiance leaving the hit emitter along -w toward the path (w = the
///     path's direction of travel when it hit);
///   - `environment(w)`: radiance arriving along a ray that escapes in direction w;
///   - `occluded(p, q)`: any surface strictly between points p and q (plain shadow test; the VPT
///     uses its own medium-aware shadow_transmittance, which lets index-matched boundaries pass).
template <class Sc>
concept LitScene = WalkScene<Sc> && requires(const Sc& s, const Vec3<typename Sc::Float>& p,
                                             const Vec3<typename Sc::Float>& u,
                                             const SurfaceHit<typename Sc::Float, typename Sc::Spectrum>& h) {
    { s.sample_light(p, u) } -> std::same_as<LightSample<typename Sc::Float, typename Sc::Spectrum>>;
    { s.light_pdf(p, p, h) } -> std::convertible_to<typename Sc::Float>;
    { s.emitted(h, p) } -> std::same_as<typename Sc::Spectrum>;
    { s.environment(p) } -> std::same_as<typename Sc::Spectrum>;
    { s.occluded(p, p) } -> std::convertible_to<bool>;
};

}  // namespace grainlight
