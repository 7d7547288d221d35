/// @file grainlight/precompute/ms_table.hpp
/// Builder and file I/O of the multiple-scattering table of Wang & Holzschuch 2018 (Sec. 3.5.4
/// and 5.2, used by Eq. 7). The record `MsTable<N>` and its lookup live in
/// integrators/ms_table.hpp (included here, so code that includes this header keeps working);
/// `MsTable<N>::build / save / load` forward to `build_ms_table`, `save_ms_table` and
/// `load_ms_table` below.
///
/// Simulation (units of the mean free path): a unit of power is scattered at the origin by light
/// travelling along +z (the phase function picks the first direction); particles then propagate
/// in an infinite medium of albedo alpha with the library's walk kernel (integrators/walk.hpp)
/// and ContinuousMedium. Every scattering event after the first collision is histogrammed by
/// cell and incoming direction (the throughput at the event includes its albedo, so the tally is
/// the scattered power); the incoming-direction histograms are convolved with the phase function
/// after the walk (a precomputed bin-to-bin phase matrix, averaged over the two mirror images of
/// a bin) and divided by the cell volume and the photon count. Particles farther than
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
};

/// File kind of a stored MsTable in the shared container.
inline constexpr std::uint32_t ms_table_file_kind = fourcc("MSTB");
static_assert(ms_table_file_kind == MsTable<1>::file_kind, "MsTable::file_kind must match the container kind");

/// An infinite homogeneous medium as a WalkScene: the library's one unbounded-medium scene
/// (scene/unbounded_medium.hpp). Kept under this name for one release.
template <class M>
using InfiniteMediumScene = UnboundedMediumScene<M>;

namespace detail {
/// Walk callbacks of the table builder: histogram scattering events of order >= 2 by cell and
/// incoming direction.
template <std::size_t N, class F, class S>
struct MsTableTally {
    const MsTable<N>& t;
    std::vector<double>& h;
    double escape2;
    template <class M>
    bool on_scatter(PathState<F, S>& st, const Interaction<F, S>& it, const M&) noexcept {
        const Vec3<double> p(it.p);
        if (glm::dot(p, p) > escape2) return false;
        if (st.depth < 2) return true;
        const MsTableGrid& g = t.grid();
        const double rho = std::sqrt(p.x * p.x + p.y * p.y);
        if (rho >= g.rho_max || p.z < g.z_min || p.z >= g.z_max) return true;
        const std::size_t ir = std::min<std::size_t>(g.n_rho - 1, std::size_t(rho / g.rho_max * g.n_rho));
        const std::size_t iz =
            std::min<std::size_t>(g.n_z - 1, std::size_t((p.z - g.z_min) / (g.z_max - g.z_min) * g.n_z));
        const Vec3<double> d(st.ray.d);
        double ex = 1, ey = 0;
        if (rho > 0) {
            ex = p.x / rho;
            ey = p.y / rho;
        }
        const double lx = d.x * ex + d.y * ey, ly = -d.x * ey + d.y * ex;
        const std::size_t j = t.direction_bin(d.z, std::atan2(std::abs(ly), lx));
        for (std::size_t c = 0; c < N; ++c) h[t.value_index(c, iz, ir, j)] += double(st.throughput[c]);
        return true;
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

/// A zero table with the final grid: the tally and the finish step use its index helpers.
template <std::size_t N, class Phase>
MsTable<N> ms_table_shape(const Phase& phase, const std::array<double, N>& alb, const MsTableGrid& grid,
                          const MsTableOptions& opt) {
    const std::size_t n_all = N * grid.cells() * grid.directions();
    return MsTable<N>(grid, alb, double(phase.mean_cosine()[0]), opt.photons, std::vector<float>(n_all, 0.0f));
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

/// Trace the source-particle blocks [block_begin, block_end) of the table build `opt` (particles
/// keyed by their global index: the result does not depend on how the build is split) and return
/// their histograms. Throws invalid_argument on bad options or a block range outside the build.
template <std::size_t N, class Phase>
[[nodiscard]] MsTableHistograms build_ms_table_blocks(const Phase& phase,
                                                      const Spectrum<N, typename Phase::Float>& albedo,
                                                      const MsTableOptions& opt, std::uint64_t block_begin,
                                                      std::uint64_t block_end) {
    using F = typename Phase::Float;
    using S = Spectrum<N, F>;
    detail::check_ms_table_phase<N, Phase>();
    const MsTableGrid grid = detail::ms_table_grid(opt);
    const std::array<double, N> alb = detail::ms_table_albedo(albedo);
    check_argument(block_begin <= block_end && block_end <= std::uint64_t(opt.blocks), "build_ms_table_blocks",
                   "block range end", double(block_end), "block_begin <= block_end <= opt.blocks");
    const std::size_t n_all = N * grid.cells() * grid.directions();
    const MsTable<N> shape = detail::ms_table_shape(phase, alb, grid, opt);

    using Medium = ContinuousMedium<Phase, S>;
    const Medium medium(S(F(1)), albedo, phase);
    const InfiniteMediumScene<Medium> scene{medium};
    MsTableHistograms out;
    out.first_block = block_begin;
    out.blocks.resize(std::size_t(block_end - block_begin));
    const std::uint64_t per_block = (opt.photons + std::uint64_t(opt.blocks) - 1) / std::uint64_t(opt.blocks);
    const std::int64_t n_blocks = std::int64_t(block_end - block_begin);
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (std::int64_t k = 0; k < n_blocks; ++k) {
        const std::uint64_t b = block_begin + std::uint64_t(k);
        std::vector<double>& h = out.blocks[std::size_t(k)];
        h.assign(n_all, 0.0);
        const std::uint64_t p0 = std::min(opt.photons, b * per_block);
        const std::uint64_t p1 = std::min(opt.photons, p0 + per_block);
        detail::MsTableTally<N, F, S> tally{shape, h, opt.escape_radius * opt.escape_radius};
        WalkOptions<F> wopt;
        wopt.mode = TransportMode::importance;
        wopt.rr_depth = 1 << 20;
        for (std::uint64_t i = p0; i < p1; ++i) {
            Rng rng = Rng::from_key(opt.seed, 0x4d5354ull, i);
            const auto ps = phase.sample(Vec3<F>(F(0), F(0), F(1)), rng.template uniform2<F>());
            if (!(ps.pdf > F(0))) continue;
            PathState<F, S> st = start_path<F, S>(Ray<F>(Vec3<F>(F(0)), ps.w), 0, S(F(1)) * ps.weight);
            (void)walk(scene, st, rng, tally, wopt);
        }
    }
    return out;
}

/// The table from the histograms of every block of the build `opt` ([0, opt.blocks), appended in
/// order), summed in block order: the same table for any split of the build.
template <std::size_t N, class Phase>
[[nodiscard]] MsTable<N> finish_ms_table(const Phase& phase, const Spectrum<N, typename Phase::Float>& albedo,
                                         const MsTableOptions& opt, const MsTableHistograms& hist) {
    using F = typename Phase::Float;
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

    // Phase matrix between direction bins, averaged over the mirror images (+phi, -phi).
    std::vector<double> pm(n_dir * n_dir);
    for (std::size_t i = 0; i < n_dir; ++i) {
        const Vec3<double> wi = shape.bin_direction(i, false), wi2 = shape.bin_direction(i, true);
        for (std::size_t j = 0; j < n_dir; ++j) {
            const Vec3<double> wj = shape.bin_direction(j, false);
            const auto a = phase.eval(Vec3<F>(wi), Vec3<F>(wj)).value[0];
            const auto b = phase.eval(Vec3<F>(wi2), Vec3<F>(wj)).value[0];
            pm[i * n_dir + j] = 0.5 * (double(a) + double(b));
        }
    }
    std::vector<float> values(n_all, 0.0f);
    const double dr = grid.rho_max / grid.n_rho, dz = (grid.z_max - grid.z_min) / grid.n_z;
    for (std::size_t c = 0; c < N; ++c)
        for (std::size_t iz = 0; iz < grid.n_z; ++iz)
            for (std::size_t ir = 0; ir < grid.n_rho; ++ir) {
                const double r0 = double(ir) * dr, r1 = r0 + dr;
                const double vol = pi_v<double> * (r1 * r1 - r0 * r0) * dz;
                const std::size_t base = shape.value_index(c, iz, ir, 0);
                for (std::size_t j = 0; j < n_dir; ++j) {
                    double acc = 0;
                    for (std::size_t i = 0; i < n_dir; ++i) acc += sum[base + i] * pm[i * n_dir + j];
                    values[base + j] = float(acc / (double(opt.photons) * vol));
                }
            }
    return MsTable<N>(grid, alb, double(phase.mean_cosine()[0]), opt.photons, std::move(values));
}

/// Precompute the table with the walk kernel (every block of the build on this process's threads;
/// build_ms_table_blocks + finish_ms_table split it over processes). `phase` is any PhaseFunction
/// with Spectrum<N, F>; `albedo` per channel in [0, 1). Throws invalid_argument on bad options.
template <std::size_t N, class Phase>
[[nodiscard]] MsTable<N> build_ms_table(const Phase& phase, const Spectrum<N, typename Phase::Float>& albedo,
                                        const MsTableOptions& opt) {
    return finish_ms_table(phase, albedo, opt, build_ms_table_blocks(phase, albedo, opt, 0, ms_table_blocks(opt)));
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
