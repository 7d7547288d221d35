/// @file grainlight/integrators/vpt.hpp
/// Volumetric path tracer built on the walk kernel (integrators/walk.hpp): camera paths in
/// radiance mode, refraction and Fresnel reflection at smooth dielectric boundaries (kernel),
/// next-event estimation wherever a shadow connection exists (diffuse and glossy surfaces, scattering events
/// in media, through index-matched boundaries and the media behind them), multiple importance
/// sampling (power heuristic, Veach 1997 ch. 9) between light sampling and BSDF/phase sampling
/// for area and environment lights, Russian roulette (kernel).
///
/// Templated on the scene (LitScene concept: scene/concepts.hpp) and, through it, on the medium
/// (Medium concept: media/concepts.hpp). Usable with any scene type meeting the concepts.
///
/// Estimator summary for a camera ray: L = sum over path vertices of
///   throughput * (emission with MIS weight  +  NEE contribution with MIS weight),
/// where the free flights are sampled by the medium (analog: transmittance cancels), NEE shadow
/// rays multiply the medium transmittance of every segment and pass only index-matched surfaces
/// (a dielectric, diffuse or absorbing surface blocks them: no caustic connections).
#pragma once

#include <cmath>
#include <limits>

#include "grainlight/core/frame.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/optics/microfacet.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Options of the volumetric path tracer.
struct VptOptions {
    int max_depth = 256;  ///< maximum scattering + surface events per path
    int rr_depth = 5;     ///< Russian roulette after this many events
    bool nee = true;      ///< next-event estimation (with MIS); false: pure path tracing
};

// power_heuristic (MIS weight) is defined in core/warp.hpp.

/// Transmittance of a shadow segment from p along unit w over distance `dist` (inf: to infinity;
/// the segment stops a small scale-aware margin short of dist so the target emitter never blocks)
/// starting in medium `medium`: the product of the media transmittances of its pieces; 0 if any
/// surface other than an index-matched (passthrough) boundary lies on it, or if an unbounded
/// medium extends to infinity.
template <WalkScene Scene>
[[nodiscard]] inline typename Scene::Spectrum shadow_transmittance(const Scene& scene,
                                                                   const Vec3<typename Scene::Float>& p,
                                                                   const Vec3<typename Scene::Float>& w,
                                                                   typename Scene::Float dist, int medium,
                                                                   Rng& rng) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    S tr(F(1));
    Vec3<F> o = p;
    // Stop short of the light point: a relative margin plus the scale of origin offsets
    // (offset_ray_origin), so the emitter's own surface is never counted as a blocker.
    const F eps_abs = (sizeof(F) == 4 ? F(5e-4) : F(3e-9)) * (F(1) + max_abs_component(p));
    F remaining = std::isinf(dist) ? dist : dist * (F(1) - F(1e-4)) - eps_abs;
    if (remaining <= F(0)) return tr;
    for (int k = 0; k < 256; ++k) {
        const Ray<F> r(o, w, remaining);
        const SurfaceHit<F, S> hit = scene.intersect(r);
        const F seg = hit.hit() ? hit.t : remaining;
        if (medium >= 0) {
            if (std::isinf(seg)) return S(F(0));
            tr *= scene.medium(medium).transmittance(r, seg, rng);
        }
        if (!hit.hit()) return tr;
        if (hit.type != SurfaceType::passthrough) return S(F(0));
        medium = glm::dot(w, hit.n) < F(0) ? hit.medium_inside : hit.medium_outside;
        o = offset_ray_origin(hit.p, hit.n, w);
        if (!std::isinf(remaining)) {
            remaining -= glm::length(o - r.o);
            if (remaining <= F(0)) return tr;
        }
    }
    return S(F(0));
}

/// The VPT's per-event callbacks: accumulate radiance L along one camera path.
template <LitScene Scene>
struct VptCallbacks {
    /// Floating-point type of the scene.
    using F = typename Scene::Float;
    /// Spectrum type of the scene.
    using S = typename Scene::Spectrum;
    /// The scene traced (lights, surfaces, media).
    const Scene& scene;
    /// The path's random number generator (the caller's, e.g. Pcg32::from_key(seed, pixel, sample)).
    Rng& rng;
    /// VPT options (NEE on/off, depths).
    VptOptions opt;
    /// Radiance accumulated along the path so far.
    S L{F(0)};
    bool last_nee = false;  ///< whether NEE was done at the last non-specular vertex (MIS partner)

    /// Emission seen by the path, MIS-weighted against the NEE that was done at the last vertex.
    void add_emission(const PathState<F, S>& st, const S& Le, const SurfaceHit<F, S>& hit) noexcept {
        if (Le.is_black()) return;
        F w = F(1);
        if (opt.nee && !st.specular && last_nee) {
            const F pl = scene.light_pdf(st.last_p, st.ray.d, hit);
            w = power_heuristic(st.last_pdf, pl);
        }
        L += st.throughput * Le * w;
    }

    /// NEE from `ref` (shadow ray origin `origin`, current medium) with the given BSDF/phase
    /// evaluator: eval(w) -> {f (spectrum, includes cosine for surfaces), pdf}.
    template <class Eval>
    void next_event(const PathState<F, S>& st, const Vec3<F>& ref, const Vec3<F>& origin, Eval&& eval) noexcept {
        const Vec3<F> u(rng.uniform<F>(), rng.uniform<F>(), rng.uniform<F>());
        const LightSample<F, S> ls = scene.sample_light(ref, u);
        if (!ls || ls.L.is_black()) return;
        S f(F(0));
        F pdf_b = F(0);
        if (!eval(ls.w, f, pdf_b) || f.is_black()) return;
        // Distance to the light point from the (offset) shadow-ray origin.
        const F dist = std::isinf(ls.dist) ? ls.dist : ls.dist - glm::dot(origin - ref, ls.w);
        const S tr = shadow_transmittance(scene, origin, ls.w, dist, st.medium, rng);
        if (tr.is_black()) return;
        const F w = ls.delta ? F(1) : power_heuristic(ls.pdf, pdf_b);
        L += st.throughput * f * tr * ls.L * (w / ls.pdf);
    }

    /// Walk callback at a surface hit: adds MIS-weighted emission and, at diffuse surfaces with NEE on,
    /// a light sample; returns true (the walk continues).
    bool on_surface(PathState<F, S>& st, const SurfaceHit<F, S>& hit) noexcept {
        if (hit.light >= 0) add_emission(st, scene.emitted(hit, st.ray.d), hit);
        if (hit.type == SurfaceType::diffuse || hit.type == SurfaceType::glossy) last_nee = opt.nee;
        if (opt.nee && hit.type == SurfaceType::glossy) {
            const Vec3<F> nf = glm::dot(st.ray.d, hit.n) < F(0) ? hit.n : -hit.n;
            const Frame<F> fr(nf);
            const Vec3<F> wo = fr.to_local(-st.ray.d);
            next_event(st, hit.p, offset_ray_origin(hit.p, nf, nf), [&](const Vec3<F>& w, S& f, F& pdf) {
                f = eval_glossy(wo, fr.to_local(w), hit.reflectance, hit.roughness, pdf);
                return pdf > F(0);
            });
        }
        if (opt.nee && hit.type == SurfaceType::diffuse) {
            const Vec3<F> nf = glm::dot(st.ray.d, hit.n) < F(0) ? hit.n : -hit.n;
            const S rho_over_pi = hit.reflectance * inv_pi_v<F>;
            next_event(st, hit.p, offset_ray_origin(hit.p, nf, nf), [&](const Vec3<F>& w, S& f, F& pdf) {
                const F c = glm::dot(w, nf);
                if (c <= F(0)) return false;
                f = rho_over_pi * c;
                pdf = c * inv_pi_v<F>;
                return true;
            });
        }
        return true;
    }

    /// Walk callback at a scattering event of medium m: next-event estimation with m's phase function
    /// (when NEE is on and the medium lets the kernel pick the direction); returns true.
    template <class M>
    bool on_scatter(PathState<F, S>& st, const Interaction<F, S>& it, const M& m) noexcept {
        last_nee = false;  // media that choose their own direction (or custom NEE) get no MIS partner
        if constexpr (PhaseMedium<M>) {
            if (opt.nee && !it.has_direction && it.nee == NeeKind::phase) {
                last_nee = true;
                const Vec3<F> d = st.ray.d;
                next_event(st, it.p, it.p, [&](const Vec3<F>& w, S& f, F& pdf) {
                    const auto pe = m.phase().eval(d, w);
                    f = pe.value;
                    pdf = pe.pdf;
                    return pdf > F(0);
                });
            }
        }
        return true;
    }

    /// Walk callback when the path leaves the scene: adds the environment radiance, MIS-weighted.
    void on_escape(const PathState<F, S>& st) noexcept {
        const S Le = scene.environment(st.ray.d);
        if (Le.is_black()) return;
        add_emission(st, Le, SurfaceHit<F, S>{});
    }
};

/// One camera path (radiance transport) from `ray`, starting in medium `medium`, walked with the
/// callback set `cb` (VptCallbacks or an extension of it that accumulates into `cb.L`); returns
/// cb.L. The VPT of this header and the discrete-particle VPT are this walk with their callbacks.
template <LitScene Scene, class Callbacks>
    requires Medium<typename Scene::Medium>
[[nodiscard]] inline typename Scene::Spectrum camera_walk(const Scene& scene, const Ray<typename Scene::Float>& ray,
                                                          int medium, Rng& rng, const VptOptions& opt,
                                                          Callbacks& cb) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    PathState<F, S> st = start_path<F, S>(ray, medium);
    WalkOptions<F> wopt;
    wopt.max_depth = opt.max_depth;
    wopt.rr_depth = opt.rr_depth;
    wopt.mode = TransportMode::radiance;
    (void)walk(scene, st, rng, cb, wopt);
    return cb.L;
}

/// Radiance arriving at the camera along `ray` (which starts in medium `medium`).
template <LitScene Scene>
    requires Medium<typename Scene::Medium>
[[nodiscard]] inline typename Scene::Spectrum vpt_radiance(const Scene& scene, const Ray<typename Scene::Float>& ray,
                                                           int medium, Rng& rng, const VptOptions& opt = {}) noexcept {
    VptCallbacks<Scene> cb{scene, rng, opt};
    return camera_walk(scene, ray, medium, rng, opt, cb);
}

}  // namespace grainlight
