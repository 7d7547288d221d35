// Shared fixture of the point_based tests: a glass-bounded homogeneous sphere under a quad light,
// the point-based renderer over it, and a VPT restricted to an exact number of scattering events
// (walk-kernel callbacks) as the independent reference.
#pragma once

#include <cmath>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/phase/isotropic.hpp"
#include "grainlight/precompute/ms_table.hpp"
#include "grainlight/scene/scene.hpp"

namespace pb_test {

using namespace grainlight;
using Grey = Spectrum<1, float>;
using Phase = HenyeyGreenstein<float, Grey>;
using MediumT = ContinuousMedium<Phase, Grey>;
using SceneT = Scene<MediumT>;
using Renderer = PointBasedRenderer<Phase, SphereShape<float>>;

constexpr float kEta = 1.33f;
constexpr float kSigmaT = 1.0f;
constexpr float kAlbedo = 0.8f;
constexpr float kG = 0.3f;

inline MediumT medium() { return MediumT(kSigmaT, kAlbedo, Phase(kG)); }
inline SphereShape<float> sphere() { return SphereShape<float>(Vec3f(0.0f), 1.0f); }
// 6 x 6 quad light at y = 2 facing down, radiance 1 (large: the VPT reference must hit it).
inline QuadShape<float> quad() { return QuadShape<float>(Vec3f(-3.0f, 2.0f, -3.0f), Vec3f(6, 0, 0), Vec3f(0, 0, 6)); }

inline SceneT vpt_scene() {
    SceneT s;
    const int m = s.add_medium(medium());
    s.add_shape(sphere(), Material<float, Grey>::dielectric(kEta), m, -1);
    s.add_quad_light(quad(), Grey(1.0f));
    return s;
}

// Walk callbacks: count scattering events; add the emission of the light only when exactly
// `events` scatterings happened; stop the walk beyond.
struct ExactEvents {
    const SceneT& scene;
    int events;
    bool no_bounce_between = false;  // kill paths with a boundary reflection between two scatterings
    int count = 0;
    float L = 0;
    bool on_scatter(PathState<float, Grey>& st, const Interaction<float, Grey>&, const MediumT&) noexcept {
        ++count;
        // After a scattering event `specular` is false; only a Fresnel event (reflection; a
        // refraction would have left the medium) sets it again before the next scattering.
        if (no_bounce_between && count >= 2 && st.specular) return false;
        return count <= events;
    }
    bool on_surface(PathState<float, Grey>& st, const SurfaceHit<float, Grey>& hit) noexcept {
        if (hit.light >= 0 && count == events) L += (st.throughput * scene.emitted(hit, st.ray.d))[0];
        return true;
    }
};

inline Ray<float> camera_ray(float x, float y) {
    const Vec3f eye(0.0f, 0.0f, 5.0f);
    return Ray<float>(eye, glm::normalize(Vec3f(x, y, 0.0f) - eye));
}

// A camera ray through a uniform point of the square patch (centre c, half size h) of the z = 0
// plane.
inline Ray<float> patch_ray(Vec2f c, float h, Rng& rng) {
    const Vec2f u = rng.uniform2<float>();
    return camera_ray(c.x + h * (2 * u.x - 1), c.y + h * (2 * u.y - 1));
}

// Mean and standard error of the radiance over a patch from paths with exactly `events`
// scatterings (optionally without boundary reflections between them).
inline void vpt_exact(const SceneT& scene, Vec2f c, float h, int events, bool no_bounce_between, int paths,
                      std::uint64_t seed, double& mean, double& se) {
    Welford w;
    WalkOptions<float> opt;
    opt.rr_depth = 1 << 20;
    for (int i = 0; i < paths; ++i) {
        Rng rng = Rng::from_key(seed, std::uint64_t(events), std::uint64_t(i));
        ExactEvents cb{scene, events, no_bounce_between};
        const Ray<float> ray = patch_ray(c, h, rng);
        PathState<float, Grey> st = start_path<float, Grey>(ray, -1);
        (void)walk(scene, st, rng, cb, opt);
        w.add(double(cb.L));
    }
    mean = w.mean();
    se = w.standard_error();
}

}  // namespace pb_test
