/// @file grainlight/integrators/render.hpp
/// Render driver for camera-path integrators: rows of pixels distributed over OpenMP threads
/// (the pragma compiles away without OpenMP), one counter-based generator
/// Pcg32::from_key(seed, pixel, sample) per pixel sample, each pixel owned by one thread and its
/// samples added in sample order: the image is bit-identical for any thread count.
///
/// Long renders can checkpoint: with RenderOptions::checkpoint.path set, the driver writes the
/// film's accumulators and the finished rows atomically (scene/film_checkpoint.hpp) whenever a row
/// finishes and `interval_seconds` have passed since the last write, and with `resume` it starts
/// from that file. Each row's samples depend only on (seed, pixel, sample index), so a killed and
/// resumed render is bit-identical to an uninterrupted one. Non-finite samples (NaN/Inf) are
/// counted per pixel in the film (Film::nonfinite_samples) and replaced by zero.
///
/// A camera is anything with `width()`, `height()` and `generate_ray(px, py)` (continuous film
/// coordinates, scene/camera.hpp). A radiance function is `L(ray, rng) -> Spectrum<1 or 3>`.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <mutex>
#include <span>
#include <system_error>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/scene/film_checkpoint.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace grainlight {

/// Checkpointing of a render (see the file comment). Disabled while `path` is empty.
struct CheckpointOptions {
    std::filesystem::path path;      ///< checkpoint file (empty: no checkpoints)
    double interval_seconds = 60.0;  ///< minimum time between two writes (>= 0; 0 = after every row)
    bool resume = false;             ///< start from `path` when it exists (a fresh render otherwise)
    std::uint64_t key = 0;           ///< fingerprint of everything else that fixes the image; a
                                     ///< checkpoint with another key, seed, spp or size is refused
    bool remove_when_done = true;    ///< delete the checkpoint once the render has finished
                                     ///< (false: leave a checkpoint of the whole finished film)
    int abort_after_writes = 0;      ///< test hook: end the process (exit code 86) right after this
                                     ///< many checkpoint writes, as a crash would (0 = never)
};

/// Options of a render.
struct RenderOptions {
    int spp = 16;                ///< samples per pixel (>= 1)
    std::uint64_t seed = 1;      ///< master seed
    int threads = 0;             ///< worker threads (0 = OpenMP default; ignored without OpenMP)
    int camera_medium = -1;      ///< medium the camera sits in (-1 = none)
    VptOptions vpt{};            ///< integrator options (render_vpt)
    CheckpointOptions checkpoint{};  ///< periodic checkpoints and resume (off by default)
    int row_offset = 0;  ///< render only the rows y with y % row_stride == row_offset: one of
    int row_stride = 1;  ///< row_stride processes' share (MPI ranks); other rows stay empty
};

namespace detail {

/// The films a render starts from: a checkpoint's when resuming from a matching one, else black.
/// Throws invalid_argument naming the mismatch when the checkpoint belongs to another render.
inline FilmCheckpoint start_checkpoint(int w, int h, int film_count, const RenderOptions& opt) {
    const auto& c = opt.checkpoint;
    if (!c.path.empty() && c.resume && std::filesystem::exists(c.path)) {
        FilmCheckpoint ck = FilmCheckpoint::load(c.path);
        auto refuse = [&](const std::string& what, std::uint64_t have, std::uint64_t want) {
            raise_error<invalid_argument>("render_image: checkpoint '" + c.path.string() + "' was written by another render (" +
                                          what + " " + std::to_string(have) + ", this render " + std::to_string(want) +
                                          "); delete it or run without resume");
        };
        if (ck.films.size() != std::size_t(film_count)) refuse("films", ck.films.size(), std::uint64_t(film_count));
        if (ck.films[0].width() != w) refuse("width", std::uint64_t(ck.films[0].width()), std::uint64_t(w));
        if (ck.films[0].height() != h) refuse("height", std::uint64_t(ck.films[0].height()), std::uint64_t(h));
        if (ck.seed != opt.seed) refuse("seed", ck.seed, opt.seed);
        if (ck.spp != std::uint64_t(opt.spp)) refuse("spp", ck.spp, std::uint64_t(opt.spp));
        if (ck.key != c.key) refuse("key", ck.key, c.key);
        return ck;
    }
    FilmCheckpoint ck;
    ck.seed = opt.seed;
    ck.spp = std::uint64_t(opt.spp);
    ck.key = c.key;
    ck.rows_done.assign(std::size_t(h), 0);
    for (int k = 0; k < film_count; ++k) ck.films.emplace_back(w, h);
    return ck;
}

/// A snapshot of the finished rows of `films` (rows in flight stay zero), as a checkpoint.
inline FilmCheckpoint snapshot_checkpoint(const std::vector<Film>& films,
                                          const std::vector<std::atomic<std::uint8_t>>& done, const FilmCheckpoint& meta) {
    const int w = films[0].width(), h = films[0].height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    FilmCheckpoint ck;
    ck.seed = meta.seed;
    ck.spp = meta.spp;
    ck.key = meta.key;
    ck.rows_done.assign(std::size_t(h), 0);
    for (int y = 0; y < h; ++y) ck.rows_done[std::size_t(y)] = done[std::size_t(y)].load(std::memory_order_acquire);
    for (const Film& film : films) {
        std::vector<double> sums(3 * n, 0.0), weights(n, 0.0);
        std::vector<std::uint32_t> nonfinite(n, 0u);
        for (int y = 0; y < h; ++y) {
            if (!ck.rows_done[std::size_t(y)]) continue;
            const std::size_t p0 = std::size_t(y) * std::size_t(w);
            for (std::size_t i = p0; i < p0 + std::size_t(w); ++i) {
                for (std::size_t k = 0; k < 3; ++k) sums[3 * i + k] = film.sums()[3 * i + k];
                weights[i] = film.weights()[i];
                nonfinite[i] = film.nonfinite_counts()[i];
            }
        }
        ck.films.push_back(Film::from_accumulators(w, h, std::move(sums), std::move(weights), std::move(nonfinite)));
    }
    return ck;
}

}  // namespace detail

/// A progress sink that ignores progress.
struct NoProgress {
    /// Ignore `rows_done` finished rows.
    void operator()(int /*rows_done*/) const noexcept {}
};

/// The row driver behind render_image and render_ept, for any integrator that renders into one
/// or more films of `width` x `height` pixels: rows over OpenMP threads (dynamic schedule), only
/// the rows of this process's share (RenderOptions::row_offset / row_stride), checkpoints and
/// resume (RenderOptions::checkpoint; the films' rows are snapshot together, so a checkpoint is
/// always consistent). `row(y, films)` renders every sample of row y into each film (it must touch
/// only row y; it is called concurrently for different rows and must not throw);
/// `progress(1)` is called after each row (thread-safe sink required). Returns the films.
template <class RowFn, class Progress = NoProgress>
[[nodiscard]] std::vector<Film> render_rows(int width, int height, int film_count, const RenderOptions& opt, RowFn&& row,
                                            Progress&& progress = {}) {
    check_argument(opt.spp >= 1, "render_image", "spp", opt.spp, ">= 1");
    check_argument(opt.threads >= 0, "render_image", "threads", opt.threads, ">= 0");
    check_argument(film_count >= 1 && film_count <= int(FilmCheckpoint::max_films), "render_rows", "film_count",
                   film_count, "[1, 16]");
    check_argument(opt.checkpoint.interval_seconds >= 0.0, "render_image", "checkpoint.interval_seconds",
                   opt.checkpoint.interval_seconds, ">= 0");
    check_argument(opt.row_stride >= 1, "render_image", "row_stride", opt.row_stride, ">= 1");
    check_argument(opt.row_offset >= 0 && opt.row_offset < opt.row_stride, "render_image", "row_offset",
                   opt.row_offset, "[0, row_stride)");
    using Clock = std::chrono::steady_clock;
    const int w = width, h = height;
    const CheckpointOptions& cko = opt.checkpoint;
    const bool checkpointing = !cko.path.empty();
    FilmCheckpoint start = detail::start_checkpoint(w, h, film_count, opt);
    std::vector<Film> films = std::move(start.films);
    std::vector<std::atomic<std::uint8_t>> done(static_cast<std::size_t>(h));
    for (int y = 0; y < h; ++y) done[std::size_t(y)].store(start.rows_done[std::size_t(y)]);
    std::mutex writer;
    auto last_write = Clock::now();
    int writes = 0;
    std::exception_ptr failure;
    std::atomic<bool> failed{false};
#if defined(_OPENMP)
    const int nt = opt.threads > 0 ? opt.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
#endif
    for (int y = 0; y < h; ++y) {
        if (y % opt.row_stride != opt.row_offset || done[std::size_t(y)].load(std::memory_order_relaxed) ||
            failed.load(std::memory_order_relaxed)) {
            progress(1);
            continue;
        }
        row(y, std::span<Film>(films));
        done[std::size_t(y)].store(1, std::memory_order_release);
        if (checkpointing) {
            std::unique_lock lock(writer, std::try_to_lock);
            if (lock.owns_lock() && !failed.load() &&
                std::chrono::duration<double>(Clock::now() - last_write).count() >= cko.interval_seconds) {
#if GRAINLIGHT_HAS_EXCEPTIONS
                try {  // an exception must not leave the parallel region: rethrown after it
                    detail::snapshot_checkpoint(films, done, start).save(cko.path);
                } catch (...) {
                    failure = std::current_exception();
                    failed.store(true);
                }
#else
                detail::snapshot_checkpoint(films, done, start).save(cko.path);  // aborts on failure
#endif
                last_write = Clock::now();
                if (cko.abort_after_writes > 0 && ++writes >= cko.abort_after_writes) {
                    std::fflush(nullptr);
                    std::_Exit(86);
                }
            }
        }
        progress(1);
    }
#if GRAINLIGHT_HAS_EXCEPTIONS
    if (failure) std::rethrow_exception(failure);
#endif
    if (checkpointing) {
        if (cko.remove_when_done) {
            std::error_code ec;
            std::filesystem::remove(cko.path, ec);
        } else {
            detail::snapshot_checkpoint(films, done, start).save(cko.path);  // the finished films
        }
    }
    return films;
}

/// Render with an arbitrary radiance function L(ray, rng) (render_rows with one film).
/// `progress(1)` is called (from worker threads) after each finished row; it must be thread-safe.
template <class Camera, class Radiance, class Progress = NoProgress>
[[nodiscard]] Film render_image(const Camera& camera, Radiance&& radiance, const RenderOptions& opt,
                                Progress&& progress = {}) {
    using F = typename Camera::Float;
    const int w = camera.width();
    auto films = render_rows(
        w, camera.height(), 1, opt,
        [&](int y, std::span<Film> f) {
            for (int x = 0; x < w; ++x) {
                const std::uint64_t pixel = std::uint64_t(y) * std::uint64_t(w) + std::uint64_t(x);
                for (int s = 0; s < opt.spp; ++s) {
                    Rng rng = Rng::from_key(opt.seed, pixel, std::uint64_t(s));
                    const Vec2<F> u = rng.uniform2<F>();
                    const auto ray = camera.generate_ray(F(x) + u.x, F(y) + u.y);
                    auto L = radiance(ray, rng);
                    if (!L.is_finite()) {  // counted, never allowed to poison a pixel
                        f[0].add_nonfinite(x, y);
                        L = decltype(L)(0);
                    }
                    f[0].add_sample(x, y, L);
                }
            }
        },
        std::forward<Progress>(progress));
    return std::move(films[0]);
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
