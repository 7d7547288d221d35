/// @file grainlight/integrators/render.hpp
/// Render driver for camera-path integrators: rows of pixels distributed over OpenMP threads
/// (the pragma compiles away without OpenMP), one counter-based generator
/// Pcg32::from_key(seed, pixel, sample) per pixel sample, each pixel owned by one thread and its
/// samples added in sample order: the image is bit-identical for any thread count.
///
/// A camera is anything with `width()`, `height()` and `generate_ray(px, py)` (continuous film
/// coordinates, scene/camera.hpp). A radiance function is `L(ray, rng) -> Spectrum<1 or 3>`.
#pragma once

#include <cstdint>
#include <utility>

#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/scene/film.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace grainlight {

/// Options of a render.
struct RenderOptions {
    int spp = 16;                ///< samples per pixel (>= 1)
    std::uint64_t seed = 1;      ///< master seed
    int threads = 0;             ///< worker threads (0 = OpenMP default; ignored without OpenMP)
    int camera_medium = -1;      ///< medium the camera sits in (-1 = none)
    VptOptions vpt{};            ///< integrator options (render_vpt)
};

/// A progress sink that ignores progress.
struct NoProgress {
    void operator()(int /*rows_done*/) const noexcept {}
};

/// Render with an arbitrary radiance function L(ray, rng). `progress(1)` is called (from worker
/// threads) after each finished row; it must be thread-safe.
template <class Camera, class Radiance, class Progress = NoProgress>
[[nodiscard]] Film render_image(const Camera& camera, Radiance&& radiance, const RenderOptions& opt,
                                Progress&& progress = {}) {
    check_argument(opt.spp >= 1, "render_image", "spp", opt.spp, ">= 1");
    check_argument(opt.threads >= 0, "render_image", "threads", opt.threads, ">= 0");
    using F = typename Camera::Float;
    const int w = camera.width(), h = camera.height();
    Film film(w, h);
#if defined(_OPENMP)
    const int nt = opt.threads > 0 ? opt.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
#endif
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const std::uint64_t pixel = std::uint64_t(y) * std::uint64_t(w) + std::uint64_t(x);
            for (int s = 0; s < opt.spp; ++s) {
                Rng rng = Rng::from_key(opt.seed, pixel, std::uint64_t(s));
                const Vec2<F> u = rng.uniform2<F>();
                const auto ray = camera.generate_ray(F(x) + u.x, F(y) + u.y);
                auto L = radiance(ray, rng);
                if (!L.is_finite()) L = decltype(L)(0);  // never let one NaN sample poison a pixel
                film.add_sample(x, y, L);
            }
        }
        progress(1);
    }
    return film;
}

/// Render `scene` through `camera` with the volumetric path tracer (integrators/vpt.hpp).
template <LitScene Scene, class Camera, class Progress = NoProgress>
    requires Medium<typename Scene::Medium>
[[nodiscard]] Film render_vpt(const Scene& scene, const Camera& camera, const RenderOptions& opt,
                              Progress&& progress = {}) {
    check_argument(opt.camera_medium >= -1, "render_vpt", "camera_medium", opt.camera_medium, ">= -1");
    const VptOptions vopt = opt.vpt;
    const int cm = opt.camera_medium;
    return render_image(
        camera, [&](const auto& ray, Rng& rng) { return vpt_radiance(scene, ray, cm, rng, vopt); }, opt,
        std::forward<Progress>(progress));
}

}  // namespace grainlight
