/// @file grainlight/integrators/discrete_vpt.hpp
/// Volumetric path tracing through a discrete-particle medium (Guo21 Sec. 5; media/
/// discrete_particles.hpp) on the walk kernel (integrators/walk.hpp): the medium samples the
/// member of the query cylinder that scatters and the new direction from that particle's phase
/// function; these callbacks add next-event estimation at the scattering vertex (the particle's
/// centre) with the particle's phase function, the shadow ray's transmittance T_A through the
/// medium (vpt.hpp's shadow_transmittance, so the particle itself is excluded: s > 0) and MIS
/// (power heuristic) against phase sampling for area lights. Surfaces: VptCallbacks (emission
/// with MIS, NEE at diffuse surfaces). Media without `particle_at` (the explicit-sphere EPT
/// reference) get no NEE at their events, like any medium that chooses its own directions.
/// Shadow rays at particle events after the first are Russian-rouletted by the phase value toward
/// the light (DiscreteVptCallbacks::nee_roulette): a shadow gather costs as much as a free flight,
/// and most light directions of a forward-peaked particle phase carry little (docs/guo21.md,
/// Fig. 20). With Guo21 Sec. 5.5's sampler (DiscreteSampling::global) the events are points of the
/// ray and NEE uses Eq. 24's Q over the query sphere there (DiscreteParticleMedium::global_nee_factor).
#pragma once

#include <concepts>

#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/integrators/walk.hpp"

namespace grainlight {

/// Walk callbacks of volumetric path tracing through a discrete-particle medium (see the file
/// comment): VptCallbacks with next-event estimation at particle scattering vertices.
/// One object per path (it holds the scene, rng and options of VptCallbacks).
template <LitScene Scene>
struct DiscreteVptCallbacks : VptCallbacks<Scene> {
    /// The surface and emission callbacks this extends.
    using Base = VptCallbacks<Scene>;
    /// Floating-point type (the scene's).
    using F = typename Scene::Float;
    /// Spectrum type (the scene's).
    using S = typename Scene::Spectrum;
    /// Russian roulette of the NEE shadow rays at particle events after the path's first event
    /// (depth >= 2): a shadow ray toward a light direction w is traced with probability
    /// min(1, nee_roulette 4 pi f(w)) (f the particle's normalised phase: directions where it is
    /// below isotropic / nee_roulette are sampled), its contribution divided by that probability.
    /// At the first event every shadow ray is traced (single scattering, the whole image of a thin
    /// medium seen from the side, would otherwise pay the roulette's variance). 0: always traced.
    F nee_roulette = F(1);

    template <class M>
    /// Walk callback at a scattering event of medium m: when NEE is on, the medium chose the
    /// direction and `it.p` is a particle's centre (m.particle_at), next-event estimation with that
    /// particle's phase function (MIS against phase sampling); media without particle_at get none.
    /// Returns true (the path goes on).
    bool on_scatter(PathState<F, S>& st, const Interaction<F, S>& it, const M& m) noexcept {
        this->last_nee = false;
        // Guo21 Sec. 5.5's sampler (DiscreteSampling::global): the event is a point y of the ray,
        // not a particle; NEE with Eq. 24's Q over the query sphere at y (global_nee_factor), MIS
        // against the global phase the direction was sampled from.
        if constexpr (requires(S& f, F& pdf) {
                          { m.global_sampling() } -> std::convertible_to<bool>;
                          m.global_nee_factor(it, st.ray.d, st.ray.d, f, pdf);
                      }) {
            if (m.global_sampling()) {
                if (!this->opt.nee || !it.has_direction) return true;
                this->last_nee = true;
                const Vec3<F> d = st.ray.d;
                this->next_event(st, it.p, it.p,
                                 [&](const Vec3<F>& w, S& f, F& pdf) { return m.global_nee_factor(it, d, w, f, pdf); });
                return true;
            }
        }
        if constexpr (requires { m.particle_at(it.p); m.phase_eval(0u, it.p, it.p); }) {
            if (!this->opt.nee || !it.has_direction) return true;
            const auto idx = m.particle_at(it.p);
            if (idx < 0) return true;
            this->last_nee = true;
            const Vec3<F> d = st.ray.d;
            const auto i = std::uint32_t(idx);
            this->next_event(st, it.p, it.p, [&](const Vec3<F>& w, S& f, F& pdf) {
                const auto pe = m.phase_eval(i, d, w);
                f = pe.value;
                pdf = pe.pdf;
                if (!(pdf > F(0))) return false;
                // Russian roulette on the shadow ray (its gather costs as much as a free flight):
                // kept with probability min(1, nee_roulette * 4 pi f), weight 1 / probability, from
                // the second event of the path on (the first one, the single scattering a thin
                // medium shows, keeps every shadow ray). Unbiased (the NEE estimate keeps its
                // expectation, so MIS stays valid); a surviving contribution is at most that of an
                // isotropic scatterer / nee_roulette.
                if (nee_roulette > F(0) && st.depth >= 2) {
                    const F keep = nee_roulette * F(4) * pi_v<F> * f.max_value();
                    if (keep < F(1)) {
                        if (!(this->rng.template uniform<F>() < keep)) return false;
                        f = f * (F(1) / keep);
                    }
                }
                return true;
            });
        }
        return true;
    }
};

/// Radiance along a camera ray starting in medium `medium`; `nee_roulette` as
/// DiscreteVptCallbacks::nee_roulette (1: the default; 0: every shadow ray traced).
template <LitScene Scene>
    requires Medium<typename Scene::Medium>
[[nodiscard]] inline typename Scene::Spectrum discrete_vpt_radiance(const Scene& scene, const Ray<typename Scene::Float>& ray,
                                                                    int medium, Rng& rng, const VptOptions& opt = {},
                                                                    typename Scene::Float nee_roulette = 1) noexcept {
    DiscreteVptCallbacks<Scene> cb{{scene, rng, opt}};
    cb.nee_roulette = nee_roulette;
    return camera_walk(scene, ray, medium, rng, opt, cb);
}

/// Render with discrete_vpt_radiance (deterministic for any thread count: render_image).
template <LitScene Scene, class Camera, class Progress = NoProgress>
    requires Medium<typename Scene::Medium>
[[nodiscard]] Film render_discrete_vpt(const Scene& scene, const Camera& camera, const RenderOptions& opt,
                                       Progress&& progress = {}) {
    const VptOptions vopt = opt.vpt;
    const int cm = opt.camera_medium;
    return render_image(
        camera, [&](const auto& r, Rng& rng) { return discrete_vpt_radiance(scene, r, cm, rng, vopt); }, opt,
        std::forward<Progress>(progress));
}

}  // namespace grainlight
