/// @file grainlight/precompute/scatterometer.hpp
/// The virtual scatterometer of Meng15 Sec. 4.1-4.2: one grain in its bounding sphere (radius 1),
/// rays distributed uniformly over directions and over the sphere's cross section, a uniformly
/// random grain rotation per ray, paths traced (Fresnel reflection/refraction, interior
/// absorbing/scattering medium, Lambertian surfaces) until they leave the bounding sphere or are
/// absorbed. It records the statistics the teleportation-transport (TT) model and the effective
/// RTE need (Meng15 Sec. 4.2.1-4.2.3, Table 1):
///
///  - beta: hit probability (fraction of incident rays that hit the grain);
///  - lambda_delta: mean pass-through offset |x_o - x_i| of the rays that miss (a chord of the
///    bounding sphere);
///  - alpha_s: effective grain albedo, the fraction of hitting rays that leave the sphere;
///  - lambda_s: length of the mean teleport vector (x_o - x_i) over rays that hit and are not
///    absorbed (Sec. 4.2.2 calls it lambda_t). By the symmetry of the random rotation the mean
///    vector is parallel to the incident direction w_i; we also keep its signed component
///    `teleport_along` = E[(x_o - x_i) . w_i] (negative for grains that mostly back-scatter);
///  - Phi(cos theta): histogram of cos theta = <w_i, w_o> over exiting rays (non-uniform grid,
///    uniform in theta, so both peaks are resolved), per channel;
///  - the joint table of (cos theta, offset along w_i, offset across w_i, relative azimuth) of
///    exiting rays and the pass-through chord histogram, from which media/teleportation.hpp
///    samples TT steps. The relative azimuth is the angle around w_i from the perpendicular part
///    of the offset x_o - x_i to the perpendicular part of w_o (0 or pi for a sphere, whose
///    paths stay in one plane); it keeps the correlation between where and where-to a path exits.
///
/// Everything is per RGB channel (a grey material traces each path once for all channels; a
/// coloured one traces each hitting ray once per channel with its own random stream). All
/// statistics are stored as *per incident ray* expectations (e.g. P(hit and exit and cell)), so
/// the statistics of a mixture of grains (Sec. 4.2.3) are exactly the weighted average of the
/// stored arrays and every derived quantity (alpha_s, lambda_s, Phi, ...) comes out conditioned
/// correctly. Lengths are in units of the bounding-sphere radius.
///
/// Determinism: ray i uses Pcg32::from_key(seed, i, 0) for the incident ray and rotation and
/// Pcg32::from_key(seed, i, 1 + channel) for its path; per-block floating-point partial sums are
/// reduced in block order and histograms are integer counts, so a seed gives bit-identical
/// results on any thread count. OpenMP pragmas compile away without OpenMP.
///
/// Files: `save_grain_stats` / `load_grain_stats` use the shared container of
/// core/serialization.hpp (kind "SCAT", version 2): versioned, checksummed, atomic write;
/// the loader throws grainlight::format_error on truncated, corrupted or inconsistent files.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/grain.hpp"
#include "grainlight/geometry/grain_walk.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/transform.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/core/serialization.hpp"
#include "grainlight/media/grain_stats.hpp"

namespace grainlight {

/// The scatterometer traces one grainlight::Grain (geometry/grain.hpp) placed at the centre of
/// the unit bounding sphere. Deprecated alias, kept for one release. (Grain::procedural's default
/// subdivision level is 4; ScatterometerGrain::procedural's was 5: pass the level explicitly.)
using ScatterometerGrain = Grain;

/// Scatterometer settings.
struct ScatterometerConfig {
    std::uint64_t rays = 1000000;  ///< incident rays (>= 1)
    /// Seed of the counter-based generators (ray i uses Pcg32::from_key(seed, i, ...)): same seed, same statistics on any thread count.
    std::uint64_t seed = 1;
    std::uint32_t max_bounces = 10000;  ///< paths longer than this are counted as absorbed (and as `terminated`)
    bool random_rotation = true;        ///< rotate the grain uniformly per ray (Meng15 Sec. 4.1)
    /// Binning of the recorded statistics (phase, TT table, chords).
    ScatterometerGrid grid{};
    /// Optional progress callback (rays done, total), called from one thread at a time.
    std::function<void(std::uint64_t, std::uint64_t)> progress{};
};

namespace detail {

/// Outcome of tracing one path inside the bounding sphere.
struct ScatterPath {
    enum Kind : std::uint8_t { exited, absorbed, terminated } kind = absorbed;
    Vec3d x_o{0.0};
    Vec3d w_o{0.0};
};

/// Trace a path that has just hit the grain at `p` (outward normal n) travelling along d, for
/// channel c, until it leaves the unit bounding sphere or is absorbed: the analog grain walk of
/// geometry/grain_walk.hpp (absorption and Fresnel choices are random events), re-entered when a
/// path leaving the surface meets the same (concave) grain again. `max_bounces` bounds the
/// surface + interior events of the whole path.
inline ScatterPath trace_grain_path(const Grain& grain, Vec3d p, Vec3d d, Vec3d n, std::size_t c,
                                    std::uint32_t max_bounces, Rng& rng) noexcept {
    constexpr double inf = std::numeric_limits<double>::infinity();
    auto intersect = [&](const Vec3d& o, const Vec3d& w, double& t, Vec3d& nn) {
        return grain.intersect(o, w, 0.0, inf, t, nn);
    };
    auto no_diffuse = [](const Vec3d&, const Vec3d&, Spectrum<1, double>&) {};
    auto no_segment = [](const Vec3d&, const Vec3d&) {};
    GrainWalkOptions opt;
    opt.estimator = GrainEstimator::analog;
    opt.channel = c;
    opt.mode = TransportMode::importance;
    ScatterPath out;
    Spectrum<1, double> unused(1.0);
    int budget = int(std::min<std::uint32_t>(max_bounces, std::uint32_t(std::numeric_limits<int>::max())));
    for (;;) {
        opt.max_events = budget;
        const GrainSojourn s = grain_walk(grain.material(), 1.0, grain.surface_epsilon(), intersect, p, d, n, unused, rng,
                                          opt, no_diffuse, no_segment);
        budget -= s.events;
        if (s.kind == GrainSojourn::absorbed) {
            out.kind = ScatterPath::absorbed;
            return out;
        }
        if (s.kind == GrainSojourn::terminated || budget <= 0) {
            out.kind = ScatterPath::terminated;
            return out;
        }
        // Left the surface outward: the same grain again (concave), or the bounding sphere.
        double t = 0;
        Vec3d n_next(0.0);
        if (grain.intersect(s.p, s.d, 0.0, inf, t, n_next)) {
            p = s.p + t * s.d;
            d = s.d;
            n = n_next;
            continue;
        }
        const auto roots = intersect_sphere(s.p, s.d, Vec3d(0.0), 1.0);
        const double t_exit = roots.hit ? std::max(0.0, roots.t_far) : 0.0;
        out.kind = ScatterPath::exited;
        out.x_o = s.p + t_exit * s.d;
        out.w_o = s.d;
        return out;
    }
}

/// Per-block floating-point partial sums (reduced in block order).
struct ScatterBlock {
    double miss_chord = 0, miss_chord2 = 0;
    std::array<double, 3> along{}, along2{}, cos_theta{}, cos_theta2{};
};
/// Integer counts (order-independent reduction).
struct ScatterCounts {
    std::uint64_t hits = 0;
    std::array<std::uint64_t, 3> exits{}, terminated{};
    std::vector<std::uint64_t> chord;
    std::array<std::vector<std::uint64_t>, 3> phase, tt;
    explicit ScatterCounts(const ScatterometerGrid& g) : chord(g.chord_bins) {
        for (std::size_t c = 0; c < 3; ++c) {
            phase[c].assign(g.phase_bins, 0);
            tt[c].assign(g.tt_cells(), 0);
        }
    }
    void add(const ScatterCounts& o) {
        hits += o.hits;
        for (std::size_t c = 0; c < 3; ++c) {
            exits[c] += o.exits[c];
            terminated[c] += o.terminated[c];
            for (std::size_t i = 0; i < phase[c].size(); ++i) phase[c][i] += o.phase[c][i];
            for (std::size_t i = 0; i < tt[c].size(); ++i) tt[c][i] += o.tt[c][i];
        }
        for (std::size_t i = 0; i < chord.size(); ++i) chord[i] += o.chord[i];
    }
};

}  // namespace detail

/// The raw tally of a contiguous range of the scatterometer's ray blocks: the floating-point
/// partial sums of every block (kept per block so that they are summed in block order, whoever
/// computed them) and the integer counts (order-independent). Splitting a run into block ranges
/// (threads, processes, MPI ranks), concatenating the ranges in order with `append` and calling
/// finish_scatterometer gives bit-identical statistics to one run_scatterometer call.
struct ScatterometerTally {
    /// Rays per block: ray i belongs to block i / block_size.
    static constexpr std::uint64_t block_size = 4096;
    std::uint64_t first_block = 0;              ///< index of blocks[0]
    std::vector<detail::ScatterBlock> blocks;   ///< per-block floating-point partials, in block order
    detail::ScatterCounts counts;               ///< integer counts of the whole range

    /// An empty tally starting at block `first` for `grid`.
    ScatterometerTally(const ScatterometerGrid& grid, std::uint64_t first) : first_block(first), counts(grid) {}
    /// One past the last block covered.
    [[nodiscard]] std::uint64_t end_block() const noexcept { return first_block + blocks.size(); }
    /// Append the tally of the next block range (must start where this one ends; same grid).
    void append(const ScatterometerTally& next) {
        check_argument(next.first_block == end_block(), "ScatterometerTally::append", "next.first_block",
                       next.first_block, "== this tally's end_block()");
        check_argument(next.counts.chord.size() == counts.chord.size() &&
                           next.counts.tt[0].size() == counts.tt[0].size() &&
                           next.counts.phase[0].size() == counts.phase[0].size(),
                       "ScatterometerTally::append", "next grid", next.counts.tt[0].size(), "the same grid");
        blocks.insert(blocks.end(), next.blocks.begin(), next.blocks.end());
        counts.add(next.counts);
    }
};

/// Number of ray blocks of a scatterometer run of `rays` rays.
[[nodiscard]] constexpr std::uint64_t scatterometer_blocks(std::uint64_t rays) noexcept {
    return (rays + ScatterometerTally::block_size - 1) / ScatterometerTally::block_size;
}

/// Trace the ray blocks [block_begin, block_end) of the scatterometer run `cfg` (rays keyed by
/// their global index, so the result does not depend on how the run is split). Throws
/// grainlight::invalid_argument for rays == 0, a bad grid or a block range outside the run.
[[nodiscard]] inline ScatterometerTally run_scatterometer_blocks(const ScatterometerGrain& grain,
                                                                 const ScatterometerConfig& cfg,
                                                                 std::uint64_t block_begin, std::uint64_t block_end) {
    check_argument(cfg.rays >= 1, "run_scatterometer", "rays", cfg.rays, ">= 1");
    check_argument(cfg.max_bounces >= 1, "run_scatterometer", "max_bounces", cfg.max_bounces, ">= 1");
    grain.material().check_channels(GrainStats::channels, "run_scatterometer");
    cfg.grid.validate();
    const std::uint64_t all_blocks = scatterometer_blocks(cfg.rays);
    check_argument(block_begin <= block_end && block_end <= all_blocks, "run_scatterometer_blocks", "block range end",
                   block_end, "block_begin <= block_end <= scatterometer_blocks(rays)");
    const ScatterometerGrid grid = cfg.grid;
    const bool grey = grain.material().is_grey();
    constexpr std::uint64_t block_size = ScatterometerTally::block_size;
    const std::uint64_t n_blocks = block_end - block_begin;
    ScatterometerTally tally(grid, block_begin);
    tally.blocks.resize(static_cast<std::size_t>(n_blocks));
    std::vector<detail::ScatterBlock>& blocks = tally.blocks;
    detail::ScatterCounts& total = tally.counts;
    std::uint64_t done = 0;

#if defined(_OPENMP)
#pragma omp parallel
#endif
    {
        detail::ScatterCounts local(grid);
#if defined(_OPENMP)
#pragma omp for schedule(dynamic, 1)
#endif
        for (std::int64_t b = 0; b < std::int64_t(n_blocks); ++b) {
            detail::ScatterBlock& blk = blocks[std::size_t(b)];
            const std::uint64_t begin = (block_begin + std::uint64_t(b)) * block_size,
                                end = std::min(cfg.rays, begin + block_size);
            for (std::uint64_t i = begin; i < end; ++i) {
                Rng rng = Rng::from_key(cfg.seed, i, 0);
                // Incident ray: uniform direction, uniform point on the cross-section disk.
                const Vec3d w = sample_uniform_sphere(rng.uniform2<double>());
                const Vec2d q = sample_uniform_disk_concentric(rng.uniform2<double>());
                const Frame<double> frame(w);
                const double r2 = std::min(1.0, q.x * q.x + q.y * q.y);
                const double half_chord = std::sqrt(1.0 - r2);
                Vec3d x_i = frame.to_world(Vec3d(q.x, q.y, -half_chord));
                Vec3d wi = w;
                if (cfg.random_rotation) {
                    const Rotation<double> rot = uniform_random_rotation(
                        rng.uniform3<double>());
                    x_i = rot.to_local(x_i);  // the grain's frame; all recorded quantities are rotation invariant
                    wi = rot.to_local(wi);
                }
                // Start slightly outside so a grain touching its bounding sphere is not missed.
                const double back = 1e-6;
                Vec3d n(0.0);
                const double t = grain.intersect(x_i - back * wi, wi, 2.0 * half_chord + 2 * back, n);
                if (!std::isfinite(t)) {
                    const double chord = 2.0 * half_chord;
                    blk.miss_chord += chord;
                    blk.miss_chord2 += chord * chord;
                    ++local.chord[grid.uniform_bin(chord, 0.0, ScatterometerGrid::chord_max, grid.chord_bins)];
                    continue;
                }
                ++local.hits;
                const Vec3d p_hit = x_i + (t - back) * wi;
                for (std::size_t c = 0; c < 3; ++c) {
                    if (grey && c > 0) break;
                    Rng path_rng = Rng::from_key(cfg.seed, i, 1 + c);
                    const auto path = detail::trace_grain_path(grain, p_hit, wi, n, grey ? 0 : c, cfg.max_bounces, path_rng);
                    const std::size_t c_end = grey ? 3 : c + 1;
                    for (std::size_t k = c; k < c_end; ++k) {
                        if (path.kind == detail::ScatterPath::terminated) ++local.terminated[k];
                        if (path.kind != detail::ScatterPath::exited) continue;
                        ++local.exits[k];
                        const Vec3d off = path.x_o - x_i;
                        const double a = glm::dot(off, wi);
                        const Vec3d perp = off - a * wi;
                        const double across = glm::length(perp);
                        const double mu = std::clamp(glm::dot(wi, path.w_o), -1.0, 1.0);
                        // Azimuth of the exit direction around w_i relative to the offset's
                        // perpendicular part (0 when either is undefined).
                        const Vec3d w_perp = path.w_o - mu * wi;
                        double dphi = 0.0;
                        if (across > 1e-12 && glm::length(w_perp) > 1e-12) {
                            const Vec3d e1 = perp / across, e2 = glm::cross(wi, e1);
                            dphi = std::atan2(glm::dot(w_perp, e2), glm::dot(w_perp, e1));
                        }
                        blk.along[k] += a;
                        blk.along2[k] += a * a;
                        blk.cos_theta[k] += mu;
                        blk.cos_theta2[k] += mu * mu;
                        ++local.phase[k][ScatterometerGrid::mu_bin(mu, grid.phase_bins)];
                        const std::size_t cell =
                            (std::size_t(ScatterometerGrid::mu_bin(mu, grid.tt_mu_bins)) * grid.tt_along_bins +
                             grid.uniform_bin(a, ScatterometerGrid::along_min, ScatterometerGrid::along_max,
                                              grid.tt_along_bins)) *
                                grid.tt_across_bins +
                            grid.uniform_bin(across, 0.0, ScatterometerGrid::across_max, grid.tt_across_bins);
                        ++local.tt[k][cell * grid.tt_dphi_bins + ScatterometerGrid::dphi_bin(dphi, grid.tt_dphi_bins)];
                    }
                }
            }
            if (cfg.progress) {
#if defined(_OPENMP)
#pragma omp critical(grainlight_scatterometer_progress)
#endif
                {
                    done += end - begin;
                    cfg.progress(done, std::min(cfg.rays, block_end * block_size) - block_begin * block_size);
                }
            }
        }
#if defined(_OPENMP)
#pragma omp critical(grainlight_scatterometer_merge)
#endif
        total.add(local);
    }
    return tally;
}

/// The statistics of a complete run from its tally (all blocks, in order). Throws
/// grainlight::invalid_argument when the tally does not cover every block of `cfg`.
[[nodiscard]] inline GrainStats finish_scatterometer(const ScatterometerConfig& cfg, const ScatterometerTally& tally) {
    check_argument(tally.first_block == 0 && tally.end_block() == scatterometer_blocks(cfg.rays),
                   "finish_scatterometer", "tally blocks", tally.end_block() - tally.first_block,
                   "every block of the run, from block 0");
    const ScatterometerGrid grid = cfg.grid;
    const detail::ScatterCounts& total = tally.counts;
    // Fixed-order reduction of the floating-point partials.
    detail::ScatterBlock sum;
    for (const auto& b : tally.blocks) {
        sum.miss_chord += b.miss_chord;
        sum.miss_chord2 += b.miss_chord2;
        for (std::size_t c = 0; c < 3; ++c) {
            sum.along[c] += b.along[c];
            sum.along2[c] += b.along2[c];
            sum.cos_theta[c] += b.cos_theta[c];
            sum.cos_theta2[c] += b.cos_theta2[c];
        }
    }
    const double inv_n = 1.0 / double(cfg.rays);
    GrainStats s;
    s.grid = grid;
    s.rays = cfg.rays;
    s.hit = double(total.hits) * inv_n;
    s.miss_chord = sum.miss_chord * inv_n;
    s.miss_chord2 = sum.miss_chord2 * inv_n;
    s.chord_hist.resize(grid.chord_bins);
    for (std::size_t i = 0; i < grid.chord_bins; ++i) s.chord_hist[i] = double(total.chord[i]) * inv_n;
    for (std::size_t c = 0; c < 3; ++c) {
        s.exit[c] = double(total.exits[c]) * inv_n;
        s.terminated[c] = double(total.terminated[c]) * inv_n;
        s.along[c] = sum.along[c] * inv_n;
        s.along2[c] = sum.along2[c] * inv_n;
        s.cos_theta[c] = sum.cos_theta[c] * inv_n;
        s.cos_theta2[c] = sum.cos_theta2[c] * inv_n;
        s.phase_hist[c].resize(grid.phase_bins);
        for (std::size_t i = 0; i < grid.phase_bins; ++i) s.phase_hist[c][i] = double(total.phase[c][i]) * inv_n;
        s.tt_table[c].resize(grid.tt_cells());
        for (std::size_t i = 0; i < grid.tt_cells(); ++i) s.tt_table[c][i] = double(total.tt[c][i]) * inv_n;
    }
    return s;
}

/// Run the virtual scatterometer (Meng15 Sec. 4.1-4.2) on `grain`. Throws
/// grainlight::invalid_argument for rays == 0 or a bad grid.
[[nodiscard]] inline GrainStats run_scatterometer(const ScatterometerGrain& grain, const ScatterometerConfig& cfg) {
    return finish_scatterometer(cfg, run_scatterometer_blocks(grain, cfg, 0, scatterometer_blocks(cfg.rays)));
}

}  // namespace grainlight
