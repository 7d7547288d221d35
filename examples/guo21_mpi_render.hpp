// guo21_mpi_render.hpp: one render of a Guo21 example over MPI ranks and checkpoints. Every render
// of the Guo21 programs goes through `render_film`: this rank renders the rows y with
// y % ranks == rank (RenderOptions::row_offset / row_stride), with its own checkpoint file in --out
// (--checkpoint SECONDS / --resume; checkpoint.hpp), and the ranks' rows are then assembled on
// *every* rank (`allgather_film_rows`: rank 0's gather_film_rows, then a broadcast), so the code
// that follows a render (means, variances, the next render's parameters) runs unchanged on every
// rank and only rank 0 writes. The assembled film is a placement of rows, not a sum: an image made
// by K ranks is byte-identical to the single-process image with the same seed.
//
// Timing: `RankClock` measures this rank's own process CPU seconds around the renders only (the
// gathers, where MPI busy-waits, are excluded); `sum_over_ranks` adds the ranks' values (the CPU
// cost of a render on K ranks is the sum of theirs, comparable to one process's).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "common/mpi.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/scene/film.hpp"

#if defined(GRAINLIGHT_EXAMPLES_MPI)
#include <mpi.h>
#endif

namespace guo21_mpi {

namespace gl = grainlight;

namespace detail {
#if defined(GRAINLIGHT_EXAMPLES_MPI)
/// Broadcast `count` items of `type` from rank 0 in chunks below 2^30 items (MPI's int counts).
template <class T>
void bcast(T* data, std::size_t count, MPI_Datatype type) {
    constexpr std::size_t chunk = std::size_t(1) << 30;
    for (std::size_t off = 0; off < count; off += chunk)
        MPI_Bcast(data + off, int(std::min(chunk, count - off)), type, 0, MPI_COMM_WORLD);
}
#endif
}  // namespace detail

/// The film of a render whose rows were split with row_offset = rank, row_stride = ranks, complete
/// on every rank (row y from rank y % ranks). One rank: the film itself.
[[nodiscard]] inline gl::Film allgather_film_rows(const gl_examples::MpiSession& mpi, const gl::Film& local) {
    if (mpi.size() == 1) return local;
    gl::Film full = mpi.gather_film_rows(local);  // complete on rank 0, empty elsewhere
#if defined(GRAINLIGHT_EXAMPLES_MPI)
    const int w = local.width(), h = local.height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    std::vector<double> sums(3 * n), weights(n);
    std::vector<std::uint32_t> nonfinite(n);
    if (mpi.root()) {
        std::memcpy(sums.data(), full.sums().data(), sums.size() * sizeof(double));
        std::memcpy(weights.data(), full.weights().data(), weights.size() * sizeof(double));
        std::memcpy(nonfinite.data(), full.nonfinite_counts().data(), nonfinite.size() * sizeof(std::uint32_t));
    }
    detail::bcast(sums.data(), sums.size(), MPI_DOUBLE);
    detail::bcast(weights.data(), weights.size(), MPI_DOUBLE);
    detail::bcast(nonfinite.data(), nonfinite.size(), MPI_UINT32_T);
    if (mpi.root()) return full;
    return gl::Film::from_accumulators(w, h, std::move(sums), std::move(weights), std::move(nonfinite));
#else
    return full;
#endif
}

/// The sum of `v` over the ranks, on every rank (v itself on one rank).
[[nodiscard]] inline double sum_over_ranks(const gl_examples::MpiSession& mpi, double v) {
#if defined(GRAINLIGHT_EXAMPLES_MPI)
    if (mpi.size() > 1) {
        double s = 0;
        MPI_Allreduce(&v, &s, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
        return s;
    }
#else
    (void)mpi;
#endif
    return v;
}

/// The maximum of `v` over the ranks, on every rank (the wall time of a split render).
[[nodiscard]] inline double max_over_ranks(const gl_examples::MpiSession& mpi, double v) {
#if defined(GRAINLIGHT_EXAMPLES_MPI)
    if (mpi.size() > 1) {
        double s = 0;
        MPI_Allreduce(&v, &s, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        return s;
    }
#else
    (void)mpi;
#endif
    return v;
}

/// This rank's process CPU seconds accumulated over the intervals between start() and stop().
struct RankClock {
    double cpu = 0;
    std::clock_t c0 = 0;
    void start() { c0 = std::clock(); }
    void stop() { cpu += double(std::clock() - c0) / CLOCKS_PER_SEC; }
};

/// One render of a harness example: `opt` as the caller set it (spp, seed, integrator options),
/// with this rank's rows and the checkpoint `stem` (checkpoint_for; none when `stem` is empty)
/// filled in; `render(opt, progress)` returns this rank's film; the result is the complete film on
/// every rank. `clock`, when given, accumulates this rank's CPU seconds of the render alone.
template <class Render, class Progress>
[[nodiscard]] gl::Film render_film(const gl_examples::Example& ex, gl::RenderOptions opt, const std::string& stem,
                                   Render&& render, Progress&& progress, RankClock* clock = nullptr) {
    opt.row_offset = ex.rank();
    opt.row_stride = ex.ranks();
    opt.checkpoint = stem.empty() ? gl::CheckpointOptions{} : gl_examples::checkpoint_for(ex, stem);
    if (clock) clock->start();
    gl::Film local = render(static_cast<const gl::RenderOptions&>(opt), progress);
    if (clock) clock->stop();
    return allgather_film_rows(ex.mpi(), local);
}

/// render_film's image.
template <class Render, class Progress>
[[nodiscard]] gl::Image render_image(const gl_examples::Example& ex, const gl::RenderOptions& opt, const std::string& stem,
                                     Render&& render, Progress&& progress, RankClock* clock = nullptr) {
    return render_film(ex, opt, stem, std::forward<Render>(render), std::forward<Progress>(progress), clock).image();
}

/// Ranks other than 0 print nothing (their text would interleave with rank 0's and could follow
/// its JSON line): their stdout goes to /dev/null. Call once after ex.ready().
inline void quiet_other_ranks(const gl_examples::Example& ex) {
    if (!ex.root()) (void)std::freopen("/dev/null", "w", stdout);
}

/// The JSON fields every Guo21 render reports about its split: which rows each rank renders and
/// how many.
inline void rank_rows(gl_examples::Json& j, const gl_examples::Example& ex, int height) {
    j.str("rank_rows", "rank r renders the rows y with y % ranks == r").nums("rank_row_counts", ex.mpi().row_counts(height));
}

}  // namespace guo21_mpi
