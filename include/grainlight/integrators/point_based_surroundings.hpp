/// @file grainlight/integrators/point_based_surroundings.hpp
/// Wang18 Sec. 3.5.1: camera rays that reach the point-based medium after diffuse or specular
/// bounces in a surrounding scene. The surroundings are any LitScene (our scene/scene.hpp or a
/// user's) in which the medium's boundary is one opaque shape, `object_shape` (e.g. added with
/// `Material::absorber()`); the path is the VPT of integrators/vpt.hpp through the surroundings
/// (NEE with MIS at diffuse surfaces, Fresnel at smooth dielectrics, Russian roulette), and where
/// it reaches the object it adds its throughput times the renderer's radiance along the arriving
/// ray (`PointBasedRenderer::radiance`, Eqs. 5-9) and ends.
///
/// What the split means: `surroundings` is the light of the scene's own lights and environment
/// (as vpt_radiance would give with the object black), `object` the light that left the medium
/// after scattering in it, seen directly or through the surroundings. The object is opaque to
/// shadow rays (it shadows the surroundings; no caustics through it) and adds no emission to
/// NEE (its light is found by BSDF sampling only, so nothing is counted twice). As in the
/// renderer, the light reflected by the outside of the boundary is not part of the result. The
/// light that reaches the medium after a bounce in the surroundings (Sec. 3.4.2) is, when the
/// renderer was built with the `EnteringLight` records of `environment_entering_light`
/// (integrators/point_based_environment.hpp) for the same scene.
///
/// `Renderer` needs only `radiance(const Ray<F>&, Rng&) -> Spectrum` (the radiance leaving the
/// medium toward the ray's origin); any such model of the object's appearance works.
#pragma once

#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Radiance along a camera ray in the surroundings, split by where the light comes from.
template <class S>
struct SurroundingsRadiance {
    S surroundings = S(0.0f);  ///< the scene's lights and environment (direct and through the surroundings)
    S object = S(0.0f);        ///< light scattered in the medium, directly or after bounces in the surroundings
    /// Their sum.
    [[nodiscard]] S total() const noexcept { return surroundings + object; }
};

/// The walk callbacks of `point_based_in_scene` (see the file comment); usable with `walk`
/// directly by integrators that add their own events.
template <LitScene Scene, class Renderer>
struct SurroundingsCallbacks {
    using F = typename Scene::Float;     ///< floating-point type
    using S = typename Scene::Spectrum;  ///< spectrum type
    VptCallbacks<Scene> vpt;             ///< the surroundings' VPT (its `L` is the `surroundings` part)
    const Renderer* renderer;            ///< the object's radiance
    int object_shape;                    ///< the object's shape index in the scene
    S object = S(F(0));                  ///< light from the object, accumulated

    /// At the object: add throughput x the object's radiance along the arriving ray, end the path.
    /// Elsewhere: the VPT's surface callback.
    bool on_surface(PathState<F, S>& st, const SurfaceHit<F, S>& hit) noexcept {
        if (hit.shape == object_shape) {
            object += st.throughput * renderer->radiance(st.ray, vpt.rng);
            return false;
        }
        return vpt.on_surface(st, hit);
    }
    /// The VPT's scattering callback (media of the surroundings, if any).
    template <class M>
    bool on_scatter(PathState<F, S>& st, const Interaction<F, S>& it, const M& m) noexcept {
        return vpt.on_scatter(st, it, m);
    }
    /// The VPT's escape callback (environment light).
    void on_escape(const PathState<F, S>& st) noexcept { vpt.on_escape(st); }
};

/// Radiance arriving along the camera ray `ray` (starting in vacuum, outside the object) in the
/// surroundings `scene`, whose shape `object_shape` is the boundary of the medium that `renderer`
/// renders (see the file comment). Deterministic for the state of `rng`.
template <LitScene Scene, class Renderer>
    requires Medium<typename Scene::Medium> &&
             requires(const Renderer& r, const Ray<typename Scene::Float>& ray, Rng& rng) {
                 { r.radiance(ray, rng) } -> std::convertible_to<typename Scene::Spectrum>;
             }
[[nodiscard]] SurroundingsRadiance<typename Scene::Spectrum> point_based_in_scene(
    const Scene& scene, int object_shape, const Renderer& renderer, const Ray<typename Scene::Float>& ray, Rng& rng,
    const VptOptions& opt = {}) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    SurroundingsCallbacks<Scene, Renderer> cb{VptCallbacks<Scene>{scene, rng, opt}, &renderer, object_shape};
    PathState<F, S> st = start_path<F, S>(ray, -1);
    WalkOptions<F> wopt;
    wopt.max_depth = opt.max_depth;
    wopt.rr_depth = opt.rr_depth;
    wopt.mode = TransportMode::radiance;
    (void)walk(scene, st, rng, cb, wopt);
    SurroundingsRadiance<S> out;
    out.surroundings = cb.vpt.L;
    out.object = cb.object;
    return out;
}

}  // namespace grainlight
