/// @file grainlight/precompute/ms_table.hpp
/// Builder and file I/O of the multiple-scattering table of Wang & Holzschuch 2018 (Sec. 3.5.4
/// and 5.2, used by Eq. 7). The record `MsTable<N>` and its lookup live in
/// integrators/ms_table.hpp (included here, so code that includes this header keeps working);
/// `MsTable<N>::build / save / load` forward to `build_ms_table`, `save_ms_table` and
/// `load_ms_table` below.
///
/// Simulation (units of the mean free path): a unit of power is scattered at the origin by light
/// travelling along +z (the phase function picks the first direction); particles then propagate
/// in an infinite medium of albedo alpha_c per channel and sigma_t = 1 with the library's walk
/// kernel (integrators/walk.hpp) and ContinuousMedium. Every scattering event after the first
/// collision is histogrammed by cell and incoming direction, weighted by the power it scatters
/// (the throughput at the event includes its albedo). The channels share the flights; a
/// collision scatters with probability alpha_max, the largest albedo, so the k-th event of a path
/// weighs (alpha_c / alpha_max)^k in channel c, never above 1 (ContinuousMedium's roulette).
/// (Until 2026-12-06 that roulette survived with the mean albedo and weighted channel c by
/// alpha_c / mean: a channel of albedo above the mean gained a factor per event whose square over
/// the survival probability exceeds 1, so its variance grew geometrically with the path length;
/// for BmpS. (0.95, 0.68, 0.46) the red table's total moved by 25 % between seeds at 2e5
/// particles.) The incoming-direction histograms are convolved with the phase function
/// after the walk (a precomputed bin-to-bin phase matrix, the phase function averaged over the
/// incoming bin, both mirror images, and the outgoing bin: ms_table_phase_matrix) and divided by
/// the cell volume and the photon count. Particles farther than
/// `escape_radius` mean free paths from the origin are dropped (they rarely return).
///
/// Closed-form check (tests): integrating L_o over the grid and all directions gives the scattered
/// power of orders >= 2, alpha^2 / (1 - alpha) per unit source power, minus what leaves the grid.
///
/// File: the shared container (core/serialization.hpp), kind "MSTB", version 1. Payload:
/// u32 channels, n_rho, n_z, n_theta, n_phi; f64 rho_max, z_min, z_max, mean_cosine; f64
/// albedo[channels]; u64 photons; u64 count; f32 values[count] (layout: integrators/ms_table.hpp).
#pragma once

#include <algorithm>
#include <atomic>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <type_traits>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/integrators/ms_table.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/scene/unbounded_medium.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/core/serialization.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Version of the table builder's estimator. A table built by another version has other noise
/// (or, for version 1, far more of it in the channels of high albedo: see the file comment), so
/// programs that cache tables on disk keyed by their parameters put this number in the key.
/// 1: collisions absorbed by roulette on the mean albedo; 2: the analog walk of the largest
/// albedo with per-channel weights (alpha_c / alpha_max)^k; 3: the same walk, and the phase
/// matrix averaged over the bins (ms_table_phase_matrix) instead of read at their centres.
inline constexpr int ms_table_estimator_version = 3;

/// How build_ms_table accumulates the histogram of scattering events (both give the same table
/// on any thread count; they differ in memory and in the last bits of the values).
enum class MsTableTally : std::uint8_t {
    /// `per_block` while opt.blocks histograms of doubles fit in ms_table_block_budget bytes,
    /// `shared` above.
    automatic,
    /// One double histogram per source-particle block, summed in block order (what
    /// build_ms_table_blocks returns to split a build over processes). Memory: blocks x 8 bytes
    /// per table value.
    per_block,
    /// One histogram for the whole build, every event added atomically in 32.32 fixed point
    /// (integer addition is associative, so the sum is exact and independent of the order the
    /// threads add in). Memory: 8 bytes per table value. A deposit is rounded to 2^-32 of the
    /// source power (the walks' weights are at most ~1; a bin overflows only past 4e9 unit
    /// deposits).
    shared,
};

/// Largest memory (bytes) the `automatic` tally gives to the per-block histograms.
inline constexpr std::size_t ms_table_block_budget = std::size_t(1) << 30;

/// What a table build measured besides the table (build_ms_table's optional output).
struct MsTableBuildInfo {
    /// The tally used (never `automatic`).
    MsTableTally tally = MsTableTally::per_block;
    /// Bytes of the histograms held during the build.
    std::size_t histogram_bytes = 0;
    /// Tallied scattering events per (z, rho) cell (index iz n_rho + ir), all source particles.
    std::vector<std::uint64_t> cell_events;
    /// Per (z, rho) cell and channel (index (c n_z + iz) n_rho + ir): the tallied power (sum of
    /// the event weights, in units of the source power; the cell's histogram summed over bins).
    std::vector<double> cell_weight;
    /// Per (z, rho) cell and channel (same index): the sum over source particles of the square
    /// of each particle's deposit in the cell, sum_p X_p^2, in units of the squared source
    /// power: the variance estimate of the cell's tallied power (particles are independent; the
    /// events of one particle are not, so they are summed before squaring).
    std::vector<double> cell_weight2;
    /// Per channel: the relative noise of the tallied power, power-weighted over the cells,
    ///     sum_cells sqrt(sum_p X_p^2) / sum_cells sum_p X_p,
    /// i.e. the relative standard error of a cell's power averaged with the cell's power as
    /// weight. (The square root of a variance estimate is low on average where a cell holds few
    /// particles, so this summary is a little low for small builds; cell_weight2 itself is
    /// unbiased.)
    std::vector<double> relative_noise;
};

/// Per channel and (z, rho) cell (index c n_z n_rho + iz n_rho + ir): the relative standard
/// error of the cell's tallied power, sqrt(cell_weight2) / cell_weight (0 in cells without
/// events), the input of MsTableQuadtree's noise-aware merging.
[[nodiscard]] inline std::vector<double> ms_table_cell_relative_noise(const MsTableBuildInfo& info) {
    check_argument(info.cell_weight.size() == info.cell_weight2.size(), "ms_table_cell_relative_noise",
                   "cell_weight2.size()", info.cell_weight2.size(), "cell_weight.size()");
    std::vector<double> r(info.cell_weight.size(), 0.0);
    for (std::size_t i = 0; i < r.size(); ++i)
        if (info.cell_weight[i] > 0.0) r[i] = std::sqrt(info.cell_weight2[i]) / info.cell_weight[i];
    return r;
}

/// Options of the table precomputation.
struct MsTableOptions {
    int n_rho = 32;             ///< radial cells (paper: 1024)
    int n_z = 64;               ///< axial cells (paper: 512)
    int n_theta = 16;           ///< polar direction bins (paper: 18)
    int n_phi = 8;              ///< azimuth bins over [0, pi] (paper: 36 over [0, 2 pi])
    double rho_max = 8.0;       ///< radial extent (mean free paths)
    double z_min = -8.0;        ///< axial extent (mean free paths)
    /// Upper axial extent (mean free paths; > z_min).
    double z_max = 8.0;
    std::uint64_t photons = 200000;  ///< source particles
    double escape_radius = 24.0;     ///< particles beyond this distance (mfp) are dropped
    /// Seed of the walks: source particle i draws from Rng::from_key(seed, stream, i), so a seed gives the
    /// same table on any thread count.
    std::uint64_t seed = 1;
    int blocks = 16;            ///< fixed number of tally blocks (deterministic for any thread count)
    /// How the events are accumulated (MsTableTally): `automatic` (default) keeps one double
    /// histogram per block while those fit in ms_table_block_budget bytes, and otherwise one
    /// shared fixed-point histogram (the paper's 1024 x 512 x 18 x 36 grid needs 16 x 4 GB per
    /// block, 4 GB shared).
    MsTableTally tally = MsTableTally::automatic;
};

/// File kind of a stored MsTable in the shared container.
inline constexpr std::uint32_t ms_table_file_kind = fourcc("MSTB");
static_assert(ms_table_file_kind == MsTable<1>::file_kind, "MsTable::file_kind must match the container kind");

/// An infinite homogeneous medium as a WalkScene: the library's one unbounded-medium scene
/// (scene/unbounded_medium.hpp). Kept under this name for one release.
template <class M>
using InfiniteMediumScene = UnboundedMediumScene<M>;

namespace detail {
/// Table bin of a scattering event at p with incoming direction d: the value index of channel 0
/// and the (z, rho) cell; false when the event is outside the grid.
template <std::size_t N>
inline bool ms_table_event_bin(const MsTable<N>& t, const Vec3<double>& p, const Vec3<double>& d, std::size_t& index0,
                               std::size_t& cell) noexcept {
    const MsTableGrid& g = t.grid();
    const double rho = std::sqrt(p.x * p.x + p.y * p.y);
    if (rho >= g.rho_max || p.z < g.z_min || p.z >= g.z_max) return false;
    const std::size_t ir = std::min<std::size_t>(g.n_rho - 1, std::size_t(rho / g.rho_max * g.n_rho));
    const std::size_t iz = std::min<std::size_t>(g.n_z - 1, std::size_t((p.z - g.z_min) / (g.z_max - g.z_min) * g.n_z));
    double ex = 1, ey = 0;
    if (rho > 0) {
        ex = p.x / rho;
        ey = p.y / rho;
    }
    const double lx = d.x * ex + d.y * ey, ly = -d.x * ey + d.y * ex;
    const std::size_t j = t.direction_bin(d.z, std::atan2(std::abs(ly), lx));
    index0 = t.value_index(0, iz, ir, j);
    cell = iz * g.n_rho + ir;
    return true;
}

/// 32.32 fixed point of the shared tally.
inline constexpr double ms_table_fixed_scale = 4294967296.0;

/// Walk callbacks of the table builder: histogram scattering events of order >= 2 by cell and
/// incoming direction, into a per-block double histogram (`h`) or, when `shared` is set, into
/// the build's one fixed-point histogram (atomic adds). `events` (optional, per cell) counts
/// the events; `weight` and `weight2` (optional together, per cell and channel) sum their
/// weights and squared weights.
template <std::size_t N, class F, class S>
struct MsTableEventTally {
    const MsTable<N>& t;
    std::vector<double>* h = nullptr;
    std::uint64_t* shared = nullptr;
    std::uint64_t* events = nullptr;
    double* weight = nullptr;
    double* weight2 = nullptr;
    double escape2 = 0;
    // Per-particle sums per cell (with `weight`): the cells the current particle touched and its
    // deposits there, squared into weight2 at end_particle().
    std::vector<double> particle_sum;
    std::vector<std::uint32_t> touched;
    template <class M>
    bool on_scatter(PathState<F, S>& st, const Interaction<F, S>& it, const M&) noexcept {
        const Vec3<double> p(it.p);
        if (glm::dot(p, p) > escape2) return false;
        if (st.depth < 2) return true;
        std::size_t i0 = 0, cell = 0;
        if (!ms_table_event_bin(t, p, Vec3<double>(st.ray.d), i0, cell)) return true;
        const std::size_t stride = t.grid().cells() * t.grid().directions();  // one channel
        bool first = false;
        if (weight) {
            first = true;
            for (std::size_t c = 0; c < N && first; ++c) first = particle_sum[cell * N + c] == 0.0;
        }
        for (std::size_t c = 0; c < N; ++c) {
            const double w = double(st.throughput[c]);
            if (shared) {
                const auto q = std::uint64_t(std::llround(w * ms_table_fixed_scale));
                std::atomic_ref<std::uint64_t>(shared[i0 + c * stride]).fetch_add(q, std::memory_order_relaxed);
            } else {
                (*h)[i0 + c * stride] += w;
            }
            if (weight) {
                weight[c * t.grid().cells() + cell] += w;
                particle_sum[cell * N + c] += w;
            }
        }
        if (first) touched.push_back(std::uint32_t(cell));
        if (events) ++events[cell];
        return true;
    }
    /// Close the current particle: add the square of its sum in every touched cell to weight2.
    void end_particle() noexcept {
        if (!weight) return;
        const std::size_t cells = t.grid().cells();
        for (const std::uint32_t cell : touched)
            for (std::size_t c = 0; c < N; ++c) {
                double& x = particle_sum[std::size_t(cell) * N + c];
                weight2[c * cells + cell] += x * x;
                x = 0.0;
            }
        touched.clear();
    }
};
}  // namespace detail

/// The incoming-direction histograms of a contiguous range of the table build's source-particle
/// blocks (build_ms_table_blocks), one per block. Ranges computed apart (threads, processes, MPI
/// ranks) are appended in block order and summed in that order by finish_ms_table, so the table
/// does not depend on how the build was split.
struct MsTableHistograms {
    std::uint64_t first_block = 0;               ///< index of blocks[0] in the build
    std::vector<std::vector<double>> blocks;     ///< per-block histogram (channel, cell, direction bin)
    /// One past the last block held.
    [[nodiscard]] std::uint64_t end_block() const noexcept { return first_block + blocks.size(); }
    /// Append the blocks that follow this range (next.first_block == end_block()).
    void append(MsTableHistograms&& next) {
        check_argument(next.first_block == end_block(), "MsTableHistograms::append", "next.first_block",
                       double(next.first_block), "end_block() = " + std::to_string(end_block()));
        for (auto& h : next.blocks) {
            check_argument(blocks.empty() || h.size() == blocks.front().size(), "MsTableHistograms::append",
                           "block size", double(h.size()), "the size of the blocks held");
            blocks.push_back(std::move(h));
        }
    }
};

namespace detail {
/// The table grid of `opt`, validated (throws invalid_argument naming the option).
inline MsTableGrid ms_table_grid(const MsTableOptions& opt) {
    MsTableGrid grid;
    check_argument(opt.n_rho >= 1 && opt.n_rho <= 4096, "MsTable::build", "n_rho", opt.n_rho, "[1, 4096]");
    check_argument(opt.n_z >= 1 && opt.n_z <= 4096, "MsTable::build", "n_z", opt.n_z, "[1, 4096]");
    check_argument(opt.n_theta >= 1 && opt.n_theta <= 256, "MsTable::build", "n_theta", opt.n_theta, "[1, 256]");
    check_argument(opt.n_phi >= 1 && opt.n_phi <= 256, "MsTable::build", "n_phi", opt.n_phi, "[1, 256]");
    grid.n_rho = std::uint32_t(opt.n_rho);
    grid.n_z = std::uint32_t(opt.n_z);
    grid.n_theta = std::uint32_t(opt.n_theta);
    grid.n_phi = std::uint32_t(opt.n_phi);
    grid.rho_max = opt.rho_max;
    grid.z_min = opt.z_min;
    grid.z_max = opt.z_max;
    grid.check("MsTable::build");
    check_argument(opt.photons >= 1, "MsTable::build", "photons", double(opt.photons), ">= 1");
    check_argument(opt.blocks >= 1 && opt.blocks <= 1024, "MsTable::build", "blocks", opt.blocks, "[1, 1024]");
    check_argument(opt.escape_radius > 0, "MsTable::build", "escape_radius", opt.escape_radius, "(0, inf)");
    return grid;
}

/// Albedo per channel as doubles, each checked to lie in [0, 1).
template <std::size_t N, class F>
std::array<double, N> ms_table_albedo(const Spectrum<N, F>& albedo) {
    std::array<double, N> alb{};
    for (std::size_t c = 0; c < N; ++c) {
        check_argument(albedo[c] >= F(0) && albedo[c] < F(1), "MsTable::build", "albedo", double(albedo[c]), "[0, 1)");
        alb[c] = double(albedo[c]);
    }
    return alb;
}

/// The table's layout (grid, no values): the tally and the finish step use its index helpers.
template <std::size_t N, class Phase>
MsTable<N> ms_table_shape(const Phase& phase, const std::array<double, N>& alb, const MsTableGrid& grid,
                          const MsTableOptions& opt) {
    return MsTable<N>::layout(grid, alb, double(phase.mean_cosine()[0]), opt.photons);
}

template <std::size_t N, class Phase>
void check_ms_table_phase() {
    using F = typename Phase::Float;
    static_assert(std::is_same_v<typename Phase::Spectrum, Spectrum<N, F>>,
                  "build_ms_table: the phase function's spectrum must be Spectrum<N, F>");
}
}  // namespace detail

/// Number of source-particle blocks of the build `opt` (opt.blocks, validated).
[[nodiscard]] inline std::uint64_t ms_table_blocks(const MsTableOptions& opt) {
    (void)detail::ms_table_grid(opt);
    return std::uint64_t(opt.blocks);
}

namespace detail {
/// Trace source particles [p0, p1) of the build `opt` (particle i draws from
/// Rng::from_key(opt.seed, "MST", i)) through `scene`, reporting to `tally`.
template <class Scene, class Phase, class Tally>
void ms_table_walk_particles(const Scene& scene, const Phase& phase, const MsTableOptions& opt, std::uint64_t p0,
                             std::uint64_t p1, Tally& tally) {
    using F = typename Phase::Float;
    using S = typename Phase::Spectrum;
    WalkOptions<F> wopt;
    wopt.mode = TransportMode::importance;
    wopt.rr_depth = 1 << 20;
    for (std::uint64_t i = p0; i < p1; ++i) {
        Rng rng = Rng::from_key(opt.seed, 0x4d5354ull, i);
        const auto ps = phase.sample(Vec3<F>(F(0), F(0), F(1)), rng.template uniform2<F>());
        if (!(ps.pdf > F(0))) continue;
        PathState<F, S> st = start_path<F, S>(Ray<F>(Vec3<F>(F(0)), ps.w), 0, S(F(1)) * ps.weight);
        (void)walk(scene, st, rng, tally, wopt);
        if constexpr (requires { tally.end_particle(); }) tally.end_particle();
    }
}

/// Incoming and outgoing sub-directions per dimension of ms_table_phase_matrix's quadrature.
inline constexpr int ms_table_phase_sub_in = 8;
inline constexpr int ms_table_phase_sub_out = 32;

/// Phase matrix between direction bins (row i: incoming bin, column j: outgoing; value per
/// steradian of the outgoing bin): the phase function averaged over the incoming bin (its
/// mirror images +phi and -phi included) and over the outgoing bin. Quadrature: the incoming
/// directions on a sub_in x sub_in midpoint grid of the bin, equal in cos theta and phi (equal
/// solid angle), each with sub_out x sub_out outgoing directions from the phase function's own
/// sampling at the midpoints of a (u1, u2) grid, counted with their sampling weight into the
/// outgoing bin they fall in and divided by its solid angle. Every row therefore integrates to
/// the phase function's norm (1) over the outgoing bins, whatever the lobe's width: the power a
/// table cell tallies is the power it emits. (Until 2026-12-06 the matrix was the phase function
/// at the bin centres, p(c_i, c_j), whose rows integrate to ~p(1) Omega_bin for a lobe narrower
/// than a bin: 1.00-1.03 at g = 0.7 on 12 x 6 bins, 1.25-2.5 at g = 0.9, 4.2-18.8 at g = 0.95 on
/// 8 x 4, the excess scattered mostly into the incoming bin.) Deterministic.
template <std::size_t N, class Phase>
std::vector<double> ms_table_phase_matrix(const Phase& phase, const MsTable<N>& shape,
                                          int sub_in = ms_table_phase_sub_in, int sub_out = ms_table_phase_sub_out) {
    using F = typename Phase::Float;
    const MsTableGrid& g = shape.grid();
    const std::size_t n_dir = g.directions();
    std::vector<double> pm(n_dir * n_dir, 0.0);
    std::vector<double> inv_dom(n_dir);
    for (std::size_t j = 0; j < n_dir; ++j) inv_dom[j] = 1.0 / ms_bin_solid_angle(g, j);
    const double per_dir = 1.0 / (2.0 * double(sub_in) * sub_in * double(sub_out) * sub_out);
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1) if (n_dir * n_dir > 4096)
#endif
    for (std::int64_t ii = 0; ii < std::int64_t(n_dir); ++ii) {
        const std::size_t i = std::size_t(ii);
        double* row = pm.data() + i * n_dir;
        for (int a = 0; a < sub_in; ++a)
            for (int b = 0; b < sub_in; ++b)
                for (int mirror = 0; mirror < 2; ++mirror) {
                    const Vec3<F> wi(ms_bin_point(g, i, (a + 0.5) / sub_in, (b + 0.5) / sub_in, mirror == 1));
                    // A Cranley-Patterson shift of the outgoing grid per incoming direction (a
                    // Weyl sequence): the grids of the incoming directions interleave instead of
                    // repeating one pattern, which would alias against the bin edges.
                    const int k = (a * sub_in + b) * 2 + mirror;
                    const double s1 = std::fmod(0.5 + 0.7548776662466927 * k, 1.0), s2 = std::fmod(0.5 + 0.5698402909980532 * k, 1.0);
                    for (int u = 0; u < sub_out; ++u)
                        for (int v = 0; v < sub_out; ++v) {
                            const Vec2<F> uv(F(std::fmod((u + s1) / sub_out, 1.0)), F(std::fmod((v + s2) / sub_out, 1.0)));
                            const auto ps = phase.sample(wi, uv);
                            const double wgt = double(ps.weight[0]);
                            if (!(wgt > 0.0)) continue;
                            const Vec3<double> wo = glm::normalize(Vec3<double>(ps.w));
                            const std::size_t j = shape.direction_bin(wo.z, std::atan2(std::abs(wo.y), wo.x));
                            row[j] += wgt * per_dir * inv_dom[j];
                        }
                }
    }
    return pm;
}

/// The table values from the incoming-direction histogram sum(k) (k a value index): each cell's
/// histogram times the phase matrix, over the cell volume and the photon count. Cells with an
/// empty histogram stay 0. The terms are added in increasing incoming bin (the same doubles for
/// any thread count).
template <std::size_t N, class Sum>
std::vector<float> ms_table_values(const MsTable<N>& shape, const std::vector<double>& pm, std::uint64_t photons,
                                   const Sum& sum) {
    const MsTableGrid& grid = shape.grid();
    const std::size_t n_dir = grid.directions();
    std::vector<float> values(N * grid.cells() * n_dir, 0.0f);
    const double dr = grid.rho_max / grid.n_rho, dz = (grid.z_max - grid.z_min) / grid.n_z;
    const std::int64_t rows = std::int64_t(N) * grid.n_z;
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 4) if (rows * std::int64_t(grid.n_rho) * std::int64_t(n_dir) > (1 << 22))
#endif
    for (std::int64_t row = 0; row < rows; ++row) {
        const std::size_t c = std::size_t(row) / grid.n_z, iz = std::size_t(row) % grid.n_z;
        std::vector<double> acc(n_dir);
        for (std::size_t ir = 0; ir < grid.n_rho; ++ir) {
            const double r0 = double(ir) * dr, r1 = r0 + dr;
            const double vol = pi_v<double> * (r1 * r1 - r0 * r0) * dz;
            const std::size_t base = shape.value_index(c, iz, ir, 0);
            std::fill(acc.begin(), acc.end(), 0.0);
            bool any = false;
            for (std::size_t i = 0; i < n_dir; ++i) {
                const double si = sum(base + i);
                if (si == 0.0) continue;  // adds +0 to every term: skipping it changes no bit
                any = true;
                const double* row_i = pm.data() + i * n_dir;
                for (std::size_t j = 0; j < n_dir; ++j) acc[j] += si * row_i[j];
            }
            if (!any) continue;
            for (std::size_t j = 0; j < n_dir; ++j) values[base + j] = float(acc[j] / (double(photons) * vol));
        }
    }
    return values;
}

/// Per-block event statistics of a build (MsTableBuildInfo's cell_events and cell_weight2 before
/// they are summed in block order).
struct MsTableBlockStats {
    std::vector<std::vector<std::uint64_t>> events;
    std::vector<std::vector<double>> weight, weight2;
};

/// Trace the source-particle blocks [b0, b1) of the build `opt` on this process's threads, into
/// per-block double histograms (`hist`, one per block, sized here) or into the shared 32.32
/// fixed-point histogram `shared` (exactly one of them non-null); `stats` (optional) gets each
/// block's event counts and squared weights per cell.
template <std::size_t N, class Phase>
void ms_table_trace_blocks(const Phase& phase, const Spectrum<N, typename Phase::Float>& albedo,
                           const MsTableOptions& opt, const MsTable<N>& shape, std::uint64_t b0, std::uint64_t b1,
                           std::vector<std::vector<double>>* hist, std::uint64_t* shared, MsTableBlockStats* stats) {
    using F = typename Phase::Float;
    using S = Spectrum<N, F>;
    using Medium = ContinuousMedium<Phase, S>;
    const Medium medium(S(F(1)), albedo, phase);
    const InfiniteMediumScene<Medium> scene{medium};
    const std::size_t n_all = N * shape.grid().cells() * shape.grid().directions();
    const std::size_t cells = shape.grid().cells();
    const std::int64_t n_blocks = std::int64_t(b1 - b0);
    if (stats) {
        stats->events.resize(std::size_t(n_blocks));
        stats->weight.resize(std::size_t(n_blocks));
        stats->weight2.resize(std::size_t(n_blocks));
    }
    const std::uint64_t per_block = (opt.photons + std::uint64_t(opt.blocks) - 1) / std::uint64_t(opt.blocks);
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (std::int64_t k = 0; k < n_blocks; ++k) {
        const std::uint64_t b = b0 + std::uint64_t(k);
        MsTableEventTally<N, F, S> tally{shape, nullptr, nullptr, nullptr, nullptr, nullptr, 0.0, {}, {}};
        if (hist) {
            (*hist)[std::size_t(k)].assign(n_all, 0.0);
            tally.h = &(*hist)[std::size_t(k)];
        }
        tally.shared = shared;
        if (stats) {
            stats->events[std::size_t(k)].assign(cells, 0);
            stats->weight[std::size_t(k)].assign(N * cells, 0.0);
            stats->weight2[std::size_t(k)].assign(N * cells, 0.0);
            tally.events = stats->events[std::size_t(k)].data();
            tally.weight = stats->weight[std::size_t(k)].data();
            tally.weight2 = stats->weight2[std::size_t(k)].data();
            tally.particle_sum.assign(N * cells, 0.0);
            tally.touched.reserve(cells);  // a particle touches each cell once at most: no allocation in the walk
        }
        tally.escape2 = opt.escape_radius * opt.escape_radius;
        const std::uint64_t p0 = std::min(opt.photons, b * per_block);
        const std::uint64_t p1 = std::min(opt.photons, p0 + per_block);
        ms_table_walk_particles(scene, phase, opt, p0, p1, tally);
    }
}
}  // namespace detail

/// Trace the source-particle blocks [block_begin, block_end) of the table build `opt` (particles
/// keyed by their global index: the result does not depend on how the build is split) and return
/// their histograms. Throws invalid_argument on bad options or a block range outside the build.
template <std::size_t N, class Phase>
[[nodiscard]] MsTableHistograms build_ms_table_blocks(const Phase& phase,
                                                      const Spectrum<N, typename Phase::Float>& albedo,
                                                      const MsTableOptions& opt, std::uint64_t block_begin,
                                                      std::uint64_t block_end) {
    detail::check_ms_table_phase<N, Phase>();
    const MsTableGrid grid = detail::ms_table_grid(opt);
    const std::array<double, N> alb = detail::ms_table_albedo(albedo);
    check_argument(block_begin <= block_end && block_end <= std::uint64_t(opt.blocks), "build_ms_table_blocks",
                   "block range end", double(block_end), "block_begin <= block_end <= opt.blocks");
    const MsTable<N> shape = detail::ms_table_shape(phase, alb, grid, opt);
    MsTableHistograms out;
    out.first_block = block_begin;
    out.blocks.resize(std::size_t(block_end - block_begin));
    detail::ms_table_trace_blocks(phase, albedo, opt, shape, block_begin, block_end, &out.blocks, nullptr, nullptr);
    return out;
}

/// The table from the histograms of every block of the build `opt` ([0, opt.blocks), appended in
/// order), summed in block order: the same table for any split of the build.
template <std::size_t N, class Phase>
[[nodiscard]] MsTable<N> finish_ms_table(const Phase& phase, const Spectrum<N, typename Phase::Float>& albedo,
                                         const MsTableOptions& opt, const MsTableHistograms& hist) {
    detail::check_ms_table_phase<N, Phase>();
    const MsTableGrid grid = detail::ms_table_grid(opt);
    const std::array<double, N> alb = detail::ms_table_albedo(albedo);
    check_argument(hist.first_block == 0 && hist.end_block() == std::uint64_t(opt.blocks), "finish_ms_table",
                   "histogram blocks", double(hist.blocks.size()), "every block [0, opt.blocks) of the build");
    const std::size_t n_dir = grid.directions();
    const std::size_t n_all = N * grid.cells() * n_dir;
    for (const auto& h : hist.blocks)
        check_argument(h.size() == n_all, "finish_ms_table", "block histogram size", double(h.size()),
                       std::to_string(n_all) + " (the grid of opt)");
    const MsTable<N> shape = detail::ms_table_shape(phase, alb, grid, opt);
    std::vector<double> sum(n_all, 0.0);
    for (const auto& h : hist.blocks)
        for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += h[i];

    std::vector<float> values = detail::ms_table_values(shape, detail::ms_table_phase_matrix(phase, shape), opt.photons,
                                                        [&sum](std::size_t k) { return sum[k]; });
    return MsTable<N>(grid, alb, double(phase.mean_cosine()[0]), opt.photons, std::move(values));
}

/// Precompute the table with the walk kernel (every block of the build on this process's threads;
/// build_ms_table_blocks + finish_ms_table split it over processes). `phase` is any PhaseFunction
/// with Spectrum<N, F>; `albedo` per channel in [0, 1). Throws invalid_argument on bad options.
/// opt.tally picks how the events are accumulated (MsTableTally); `info` (optional) receives
/// the tally used, its memory, the events and squared weights per cell and the table's relative
/// noise per channel.
template <std::size_t N, class Phase>
[[nodiscard]] MsTable<N> build_ms_table(const Phase& phase, const Spectrum<N, typename Phase::Float>& albedo,
                                        const MsTableOptions& opt, MsTableBuildInfo* info = nullptr) {
    detail::check_ms_table_phase<N, Phase>();
    const MsTableGrid grid = detail::ms_table_grid(opt);
    const std::array<double, N> alb = detail::ms_table_albedo(albedo);
    const std::size_t n_all = N * grid.cells() * grid.directions();
    MsTableTally tally = opt.tally;
    if (tally == MsTableTally::automatic)
        tally = double(n_all) * sizeof(double) * double(opt.blocks) <= double(ms_table_block_budget) ? MsTableTally::per_block
                                                                                                      : MsTableTally::shared;
    detail::MsTableBlockStats stats;
    detail::MsTableBlockStats* st = info ? &stats : nullptr;
    MsTable<N> table;
    if (tally == MsTableTally::per_block) {
        MsTableHistograms hist;
        hist.blocks.resize(std::size_t(opt.blocks));
        const MsTable<N> shape = detail::ms_table_shape(phase, alb, grid, opt);
        detail::ms_table_trace_blocks(phase, albedo, opt, shape, 0, std::uint64_t(opt.blocks), &hist.blocks, nullptr, st);
        table = finish_ms_table(phase, albedo, opt, hist);
        if (info) info->histogram_bytes = n_all * sizeof(double) * std::size_t(opt.blocks);
    } else {
        std::vector<std::uint64_t> shared(n_all, 0);
        detail::ms_table_trace_blocks(phase, albedo, opt, detail::ms_table_shape(phase, alb, grid, opt), 0,
                                      std::uint64_t(opt.blocks), nullptr, shared.data(), st);
        const MsTable<N> shape = detail::ms_table_shape(phase, alb, grid, opt);
        std::vector<float> values =
            detail::ms_table_values(shape, detail::ms_table_phase_matrix(phase, shape), opt.photons,
                                    [&shared](std::size_t k) { return double(shared[k]) / detail::ms_table_fixed_scale; });
        shared = std::vector<std::uint64_t>();  // free the histogram before the table is checked
        table = MsTable<N>(grid, alb, double(phase.mean_cosine()[0]), opt.photons, std::move(values));
        if (info) info->histogram_bytes = n_all * sizeof(std::uint64_t);
    }
    if (info) {
        info->tally = tally;
        const std::size_t cells = grid.cells();
        info->cell_events.assign(cells, 0);
        info->cell_weight.assign(N * cells, 0.0);
        info->cell_weight2.assign(N * cells, 0.0);
        for (std::size_t b = 0; b < stats.events.size(); ++b) {  // block order: the same sums on any thread count
            for (std::size_t i = 0; i < cells; ++i) info->cell_events[i] += stats.events[b][i];
            for (std::size_t i = 0; i < N * cells; ++i) {
                info->cell_weight[i] += stats.weight[b][i];
                info->cell_weight2[i] += stats.weight2[b][i];
            }
        }
        info->relative_noise.assign(N, 0.0);
        for (std::size_t c = 0; c < N; ++c) {
            double noise = 0, power = 0;
            for (std::size_t i = 0; i < cells; ++i) {
                noise += std::sqrt(info->cell_weight2[c * cells + i]);
                power += info->cell_weight[c * cells + i];
            }
            info->relative_noise[c] = power > 0 ? noise / power : 0.0;
        }
    }
    return table;
}

/// Save atomically in the shared container (kind "MSTB"). Throws io_error.
template <std::size_t N>
void save_ms_table(const MsTable<N>& t, const std::filesystem::path& path) {
    const MsTableGrid& g = t.grid();
    ByteWriter w;
    w.put(std::uint32_t(N));
    w.put(g.n_rho);
    w.put(g.n_z);
    w.put(g.n_theta);
    w.put(g.n_phi);
    w.put(g.rho_max);
    w.put(g.z_min);
    w.put(g.z_max);
    w.put(t.mean_cosine());
    for (std::size_t c = 0; c < N; ++c) w.put(t.albedo(c));
    w.put(t.photons());
    w.put(std::uint64_t(t.size()));
    w.put_array(t.values().data(), t.size());
    write_container_atomic(path, ms_table_file_kind, MsTable<N>::file_version, w.bytes());
}

/// Load; throws io_error if unreadable, format_error on a corrupt/truncated/mismatched file.
template <std::size_t N>
[[nodiscard]] MsTable<N> load_ms_table(const std::filesystem::path& path,
                                       std::type_identity<MsTable<N>> = {}) {
    const auto payload = read_container(path, ms_table_file_kind, MsTable<N>::file_version);
    ByteReader r(payload, "MsTable '" + path.string() + "'");
    const auto ch = r.get<std::uint32_t>();
    if (ch != N) r.fail("has " + std::to_string(ch) + " channels, expected " + std::to_string(N));
    MsTableGrid g;
    g.n_rho = r.get<std::uint32_t>();
    g.n_z = r.get<std::uint32_t>();
    g.n_theta = r.get<std::uint32_t>();
    g.n_phi = r.get<std::uint32_t>();
    auto dim_ok = [](std::uint32_t n, std::uint32_t hi) { return n >= 1 && n <= hi; };
    if (!dim_ok(g.n_rho, 4096) || !dim_ok(g.n_z, 4096) || !dim_ok(g.n_theta, 256) || !dim_ok(g.n_phi, 256))
        r.fail("grid dimensions out of range");
    g.rho_max = r.get<double>();
    g.z_min = r.get<double>();
    g.z_max = r.get<double>();
    const double mc = r.get<double>();
    if (!(std::isfinite(g.rho_max) && g.rho_max > 0 && std::isfinite(g.z_min) && std::isfinite(g.z_max) &&
          g.z_max > g.z_min && std::isfinite(mc) && mc > -1 && mc < 1))
        r.fail("grid extent out of range");
    std::array<double, N> alb{};
    for (std::size_t c = 0; c < N; ++c) {
        alb[c] = r.get<double>();
        if (!(alb[c] >= 0 && alb[c] <= 1)) r.fail("albedo out of [0, 1]");
    }
    const auto photons = r.get<std::uint64_t>();
    const auto count = r.get<std::uint64_t>();
    const std::uint64_t expect = std::uint64_t(N) * g.n_rho * g.n_z * std::uint64_t(g.n_theta) * g.n_phi;
    if (count != expect) r.fail("value count " + std::to_string(count) + " != " + std::to_string(expect));
    std::vector<float> values;
    r.get_array(values, count);
    r.expect_end();
    for (float v : values)
        if (!(std::isfinite(v) && v >= 0.0f)) r.fail("negative or non-finite value");
    return MsTable<N>(g, alb, mc, photons, std::move(values));
}

}  // namespace grainlight
