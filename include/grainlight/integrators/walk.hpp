/// @file grainlight/integrators/walk.hpp
/// The walk kernel: one random walk of a path through a scene of surfaces and media, with
/// per-event callbacks (DESIGN "Composition": the same code serves camera paths and photon walks:
/// slab R/T, the scatterometer, Meng15's detector sphere, Moon07's shell precomputation).
///
/// The kernel owns what every walk does the same way: free flights through the current medium
/// (`Medium::sample_interaction`), phase-function sampling at scattering events (or the medium's
/// own direction), smooth-dielectric Fresnel reflection / Snell refraction, index-matched
/// boundaries, Lambertian bounces, Russian roulette and the medium bookkeeping across
/// boundaries. What a walk *measures* lives in the callbacks:
///
///   - `bool on_scatter(PathState&, const Interaction&, const Medium&)`: a scattering event in a
///     medium at `it.p`, before the new direction is sampled (a VPT does next-event estimation
///     here). Return false to stop the walk.
///   - `bool on_surface(PathState&, const SurfaceHit&)`: a surface hit, before the kernel resolves
///     it (emission + MIS, NEE at diffuse surfaces, tallies of boundary crossings). Return false
///     to stop.
///   - `void on_escape(const PathState&)`: the path left the scene (no surface ahead, no medium).
///   - `void on_absorb(const PathState&)`: absorbed in a medium or by an absorbing surface.
///   - `void on_segment(const PathState&, F t)`: a straight segment of length t was travelled
///     in the current medium (path-length tallies).
///
/// Every callback is optional (detected with `requires`); the callback object is passed by
/// reference and may carry any tallies. Callbacks may modify `state.throughput` and
/// `state.ray.cone`.
///
/// Ray footprints: the kernel carries the ray cone through the walk (width grows by t * spread
/// along every segment; the spread angle is kept at events). Integrators that need a wider cone
/// after diffuse or volume scattering set it in `on_scatter` / `on_surface`.
///
/// Transport mode: camera paths carry importance and gather radiance (`TransportMode::radiance`):
/// refraction into a medium of relative index eta scales the throughput by 1/eta^2 (radiance
/// L/n^2 is invariant). Light paths / photon walks carry power (`TransportMode::importance`):
/// no scaling. Fresnel reflection vs refraction is chosen with probability F / (1 - F), so the
/// weight is 1 either way.
///
/// Kernel rules: no allocation, no exceptions, no virtual calls; randomness only from `rng`.
#pragma once

#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>

#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/optics/microfacet.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

// TransportMode (radiance / importance) is defined in optics/fresnel.hpp.

/// How a walk ended.
enum class WalkEnd : std::uint8_t {
    escaped,    ///< left the scene
    absorbed,   ///< absorbed in a medium or by an absorbing surface
    roulette,   ///< killed by Russian roulette
    max_depth,  ///< reached WalkOptions::max_depth events
    stopped     ///< a callback returned false
};

/// Options of a walk.
template <std::floating_point F>
struct WalkOptions {
    /// Maximum number of scattering + surface events (reflections, refractions, bounces; index-
    /// matched passes do not count). The walk ends with WalkEnd::max_depth beyond it.
    int max_depth = 1 << 30;
    /// Russian roulette starts after this many events: survive with q = min(1, max channel of
    /// the throughput), divide by q. Paths whose throughput stays <= 1 and grey (analog photon
    /// walks) are never killed by it, so it adds no variance there.
    int rr_depth = 5;
    /// Radiance (camera paths: 1/eta^2 scaling at refractions) or importance (light and photon paths: none).
    TransportMode mode = TransportMode::radiance;
};

/// The state of a path during a walk.
template <std::floating_point F, class S>
struct PathState {
    Ray<F> ray;               ///< current ray (origin = last event, unit direction)
    S throughput = S(F(1));   ///< path weight so far (NB: S{x} would be an initializer list: (x, 0, 0))
    int medium = -1;          ///< index of the medium the ray travels in (-1 = none)
    int depth = 0;            ///< number of scattering + surface events so far
    bool specular = true;     ///< last direction was chosen by a delta event (camera, Fresnel)
    F last_pdf = F(0);        ///< solid-angle pdf of the last sampled direction (0 if delta)
    Vec3<F> last_p{F(0)};     ///< position of the last non-passthrough event (for MIS)
};

/// A path starting at ray `r` (origin, unit direction, optional cone) inside medium `medium`
/// with weight `w`: a camera ray (w = 1), or a photon leaving a light (w = its power/pdf).
template <std::floating_point F, class S>
[[nodiscard]] inline PathState<F, S> start_path(const Ray<F>& r, int medium = -1, S w = S(F(1))) noexcept {
    PathState<F, S> s;
    s.ray = r;
    s.throughput = w;
    s.medium = medium;
    s.last_p = r.o;
    return s;
}

/// An empty callback set (the kernel then only simulates).
struct NoCallbacks {};

namespace detail {

template <class S>
[[nodiscard]] inline auto max_channel(const S& s) noexcept {
    return s.max_value();
}

/// Russian roulette on the path throughput; returns false if the path is killed.
template <std::floating_point F, class S>
[[nodiscard]] inline bool russian_roulette(PathState<F, S>& st, const WalkOptions<F>& opt, Rng& rng) noexcept {
    if (st.depth < opt.rr_depth) return true;
    const F q = std::min(F(1), F(max_channel(st.throughput)));
    if (q >= F(1)) return true;
    if (!(q > F(0)) || rng.uniform<F>() >= q) return false;
    st.throughput /= q;
    return true;
}

}  // namespace detail

/// Out-parameter form of sample_dielectric (optics/fresnel.hpp), kept for one release: returns the
/// new direction, `refracted` tells which, `eta_rel` = n_t / n_i along the path (1 on reflection).
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> sample_dielectric(const Vec3<F>& d, const Vec3<F>& n, F eta, F u, bool& refracted,
                                               F& eta_rel) noexcept {
    const DielectricSample<F> s = sample_dielectric(d, n, eta, u);
    refracted = s.refracted;
    eta_rel = s.eta_rel;
    return s.w;
}

/// Run one walk from `state` through `scene` until it escapes, is absorbed, is killed or a
/// callback stops it. Returns how it ended; `state` holds the final path state.
template <WalkScene Scene, class Callbacks = NoCallbacks>
    requires Medium<typename Scene::Medium>
inline WalkEnd walk(const Scene& scene, PathState<typename Scene::Float, typename Scene::Spectrum>& st, Rng& rng,
                    Callbacks& cb, const WalkOptions<typename Scene::Float>& opt = {}) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    using M = typename Scene::Medium;
    constexpr F inf = std::numeric_limits<F>::infinity();

    for (;;) {
        const SurfaceHit<F, S> hit = scene.intersect(st.ray);
        const F t_hit = hit.hit() ? hit.t : inf;

        // Free flight through the current medium.
        if (st.medium >= 0) {
            const M& m = scene.medium(st.medium);
            const Interaction<F, S> it = m.sample_interaction(st.ray, t_hit, rng);
            if constexpr (requires { cb.on_segment(st, it.t); }) cb.on_segment(st, it.t);
            st.throughput *= it.weight;
            if (it.kind == EventKind::absorb) {
                st.ray.o = it.p;
                if constexpr (requires { cb.on_absorb(st); }) cb.on_absorb(st);
                return WalkEnd::absorbed;
            }
            if (it.kind == EventKind::null) {
                st.ray = Ray<F>(it.p, st.ray.d, inf, st.ray.cone.advanced(it.t));
                continue;
            }
            if (it.kind == EventKind::scatter) {
                if (++st.depth > opt.max_depth) return WalkEnd::max_depth;
                st.ray.o = it.p;
                if constexpr (requires { cb.on_scatter(st, it, m); }) {
                    if (!cb.on_scatter(st, it, m)) return WalkEnd::stopped;
                }
                Vec3<F> w_new;
                F pdf;
                if (it.has_direction) {
                    w_new = it.w;
                    pdf = it.direction_pdf;
                } else {
                    if constexpr (PhaseMedium<M>) {
                        const auto ps = m.phase().sample(st.ray.d, rng.template uniform2<F>());
                        if (!ps) return WalkEnd::absorbed;
                        st.throughput *= ps.weight;
                        w_new = ps.w;
                        pdf = ps.pdf;
                    } else {
                        return WalkEnd::absorbed;  // a medium without a phase must choose directions
                    }
                }
                st.ray = Ray<F>(it.p, w_new, inf, st.ray.cone.advanced(it.t));
                st.specular = false;
                st.last_pdf = pdf;
                st.last_p = it.p;
                if (!detail::russian_roulette(st, opt, rng)) return WalkEnd::roulette;
                continue;
            }
            // escape: the flight reached the surface (or infinity) unscattered.
        } else if constexpr (requires { cb.on_segment(st, t_hit); }) {
            cb.on_segment(st, t_hit);
        }

        if (!hit.hit()) {
            if constexpr (requires { cb.on_escape(st); }) cb.on_escape(st);
            return WalkEnd::escaped;
        }

        if constexpr (requires { cb.on_surface(st, hit); }) {
            if (!cb.on_surface(st, hit)) return WalkEnd::stopped;
        }
        const Vec3<F> d = st.ray.d;
        const bool from_outside = glm::dot(d, hit.n) < F(0);
        const RayCone<F> cone = st.ray.cone.advanced(hit.t);
        switch (hit.type) {
            case SurfaceType::absorber: {
                st.ray.o = hit.p;
                if constexpr (requires { cb.on_absorb(st); }) cb.on_absorb(st);
                return WalkEnd::absorbed;
            }
            case SurfaceType::passthrough: {
                st.medium = from_outside ? hit.medium_inside : hit.medium_outside;
                st.ray = Ray<F>(offset_ray_origin(hit.p, hit.n, d), d, inf, cone);
                continue;  // not an event: specular/last_pdf/last_p unchanged
            }
            case SurfaceType::dielectric: {
                if (++st.depth > opt.max_depth) return WalkEnd::max_depth;
                bool refracted = false;
                F eta_rel = F(1);
                const Vec3<F> w_new = sample_dielectric(d, hit.n, hit.eta, rng.template uniform<F>(), refracted, eta_rel);
                if (refracted) {
                    st.medium = from_outside ? hit.medium_inside : hit.medium_outside;
                    if (opt.mode == TransportMode::radiance) st.throughput /= eta_rel * eta_rel;
                }
                st.ray = Ray<F>(offset_ray_origin(hit.p, hit.n, w_new), w_new, inf, cone);
                st.specular = true;
                st.last_pdf = F(0);
                st.last_p = hit.p;
                break;
            }
            case SurfaceType::diffuse: {
                if (++st.depth > opt.max_depth) return WalkEnd::max_depth;
                const Vec3<F> nf = from_outside ? hit.n : -hit.n;  // facing the arriving path
                const Vec3<F> local = sample_cosine_hemisphere(rng.template uniform2<F>());
                const Vec3<F> w_new = glm::normalize(Frame<F>(nf).to_world(local));
                st.throughput *= hit.reflectance;  // f cos / pdf = (rho/pi) cos / (cos/pi)
                st.ray = Ray<F>(offset_ray_origin(hit.p, nf, w_new), w_new, inf, cone);
                st.specular = false;
                st.last_pdf = cosine_hemisphere_pdf(local.z);
                st.last_p = hit.p;
                if (st.throughput.is_black()) {
                    if constexpr (requires { cb.on_absorb(st); }) cb.on_absorb(st);
                    return WalkEnd::absorbed;
                }
                break;
            }
            case SurfaceType::glossy: {
                if (++st.depth > opt.max_depth) return WalkEnd::max_depth;
                const Vec3<F> nf = from_outside ? hit.n : -hit.n;  // facing the arriving path
                const Frame<F> fr(nf);
                const GlossySample<F, S> gs =
                    sample_glossy(fr.to_local(-d), hit.reflectance, hit.roughness, rng.template uniform2<F>());
                if (!gs.valid) {
                    if constexpr (requires { cb.on_absorb(st); }) cb.on_absorb(st);
                    return WalkEnd::absorbed;
                }
                const Vec3<F> w_new = glm::normalize(fr.to_world(gs.wi));
                st.throughput *= gs.weight;
                st.ray = Ray<F>(offset_ray_origin(hit.p, nf, w_new), w_new, inf, cone);
                st.specular = false;
                st.last_pdf = gs.pdf;
                st.last_p = hit.p;
                if (st.throughput.is_black()) {
                    if constexpr (requires { cb.on_absorb(st); }) cb.on_absorb(st);
                    return WalkEnd::absorbed;
                }
                break;
            }
        }
        if (!detail::russian_roulette(st, opt, rng)) return WalkEnd::roulette;
    }
}

/// Convenience overload for a walk without callbacks.
template <WalkScene Scene>
    requires Medium<typename Scene::Medium>
inline WalkEnd walk(const Scene& scene, PathState<typename Scene::Float, typename Scene::Spectrum>& st, Rng& rng,
                    const WalkOptions<typename Scene::Float>& opt = {}) noexcept {
    NoCallbacks cb;
    return walk(scene, st, rng, cb, opt);
}

}  // namespace grainlight
