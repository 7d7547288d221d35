// Benchmarks of the packing layer: MD packer time vs N and f, RSA, and ray first-hit / box
// queries through the infinite tiling (items/s).
//   bench_packing --benchmark_filter=FirstHit
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "grainlight/core/warp.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/packing/poisson.hpp"

using namespace grainlight;

namespace {
// Tiles are packed once per (N, f) and shared by the query benchmarks.
const PeriodicTile& cached_tile(std::size_t n, double f) {
    static std::map<std::pair<std::size_t, double>, std::unique_ptr<PeriodicTile>> cache;
    auto& p = cache[{n, f}];
    if (!p) p = std::make_unique<PeriodicTile>(md_pack(n, f, 1).tile);
    return *p;
}
}  // namespace

// Event-driven MD (Lubachevsky-Stillinger) from RSA at 0.3 to f; items = spheres.
static void BM_MdPack(benchmark::State& state) {
    const auto n = std::size_t(state.range(0));
    const double f = double(state.range(1)) / 1000.0;
    std::uint64_t events = 0;
    for (auto _ : state) {
        auto r = md_pack(n, f, 7);
        events = r.events;
        benchmark::DoNotOptimize(r.fraction);
    }
    state.counters["events"] = double(events);
    state.counters["events/s"] = benchmark::Counter(double(events) * double(state.iterations()), benchmark::Counter::kIsRate);
    state.SetItemsProcessed(state.iterations() * std::int64_t(n));
}
BENCHMARK(BM_MdPack)
    ->ArgsProduct({{500, 2000, 8000}, {550, 600, 630}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

static void BM_Rsa(benchmark::State& state) {
    const auto n = std::size_t(state.range(0));
    for (auto _ : state) {
        Rng rng = Rng::from_key(3);
        auto t = random_sequential_addition(n, 0.3, rng);
        benchmark::DoNotOptimize(t.radius());
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(n));
}
BENCHMARK(BM_Rsa)->Arg(2000)->Arg(20000)->Unit(benchmark::kMillisecond);

// First sphere hit along random rays (random origin in the tile, t_max = inf), for several
// query-grid cell sizes (in radii). items = queries.
static void BM_FirstHit(benchmark::State& state) {
    const double f = double(state.range(0)) / 1000.0;
    const double cell = double(state.range(1)) / 10.0;
    const PeriodicTile& base = cached_tile(2000, f);
    const PeriodicTile tile(base.side(), base.radius(), base.centers(), cell);
    Rng rng = Rng::from_key(11);
    std::vector<std::pair<Vec3d, Vec3d>> rays(4096);
    for (auto& r : rays)
        r = {rng.uniform3<double>() * tile.side(),
             sample_uniform_sphere<double>(rng.uniform2<double>())};
    std::size_t i = 0;
    for (auto _ : state) {
        const auto& r = rays[i++ & 4095];
        const TileHit h = tile.first_hit(Vec3i64(0, 0, 0), r.first, r.second, 0.0, std::numeric_limits<double>::infinity());
        benchmark::DoNotOptimize(h.t_enter);
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()));
}
BENCHMARK(BM_FirstHit)->ArgsProduct({{300, 630}, {10, 15, 20, 30}});

// Spheres overlapping a box of one sphere diameter per side. items = queries.
static void BM_BoxQuery(benchmark::State& state) {
    const PeriodicTile& tile = cached_tile(2000, 0.63);
    Rng rng = Rng::from_key(12);
    std::size_t found = 0;
    for (auto _ : state) {
        const Vec3d lo = rng.uniform3<double>() * tile.side();
        tile.for_each_overlapping(lo, lo + Vec3d(2 * tile.radius()), [&](const TileSphereRef&) { ++found; });
    }
    benchmark::DoNotOptimize(found);
    state.SetItemsProcessed(std::int64_t(state.iterations()));
}
BENCHMARK(BM_BoxQuery);
