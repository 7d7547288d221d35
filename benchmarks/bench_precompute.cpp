// Benchmarks of the virtual scatterometer (rays/s per grain preset, single thread unless OpenMP
// uses more: items = incident rays) and of the teleportation-transport medium's sampling
// (items = interactions).
//   bench_precompute --benchmark_filter=Scatterometer
#include <benchmark/benchmark.h>

#include <limits>
#include <map>
#include <memory>
#include <string>

#include "grainlight/media/teleportation.hpp"
#include "grainlight/precompute/scatterometer.hpp"

using namespace grainlight;

namespace {
const char* preset_names[] = {"glass-bead", "flour", "salt", "sand", "snow", "sugar", "brown-sugar", "rice"};

const ScatterometerGrain& cached_grain(int k) {
    static std::map<int, std::unique_ptr<ScatterometerGrain>> cache;
    auto& p = cache[k];
    if (!p) {
        const auto g = grain_preset(preset_names[k]);
        p = std::make_unique<ScatterometerGrain>(ScatterometerGrain::procedural(g.shape, g.radius, g.material, g.seed));
    }
    return *p;
}
}  // namespace

static void BM_Scatterometer(benchmark::State& state) {
    const auto& grain = cached_grain(int(state.range(0)));
    state.SetLabel(preset_names[state.range(0)]);
    ScatterometerConfig cfg;
    cfg.rays = 50000;  // large enough to amortize the per-run table allocation and merge
    std::uint64_t seed = 1;
    for (auto _ : state) {
        cfg.seed = seed++;
        const auto s = run_scatterometer(grain, cfg);
        benchmark::DoNotOptimize(s.hit);
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(cfg.rays));
}
BENCHMARK(BM_Scatterometer)->DenseRange(0, 7)->Unit(benchmark::kMillisecond);

// TT medium: one sample_interaction over an unbounded ray (flights + pass-throughs + teleport).
static void BM_TeleportationSample(benchmark::State& state) {
    static const GrainStats stats = [] {
        ScatterometerConfig cfg;
        cfg.rays = 50000;
        return run_scatterometer(cached_grain(3), cfg);  // sand: coloured, absorbing
    }();
    const TeleportationMedium<float> tt(stats, 0.63, 1.0);
    Rng rng = Rng::from_key(1);
    const Ray<float> ray(Vec3f(0.0f), Vec3f(0, 0, 1));
    for (auto _ : state) {
        const auto it = tt.sample_interaction(ray, std::numeric_limits<float>::infinity(), rng);
        benchmark::DoNotOptimize(it.p);
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TeleportationSample);

// The effective continuous medium of the same grain, for comparison (same interface).
static void BM_EffectiveMediumSample(benchmark::State& state) {
    static const GrainStats stats = [] {
        ScatterometerConfig cfg;
        cfg.rays = 50000;
        return run_scatterometer(cached_grain(3), cfg);
    }();
    const auto medium = make_effective_medium(stats, 0.63, 1.0);
    Rng rng = Rng::from_key(2);
    const Ray<float> ray(Vec3f(0.0f), Vec3f(0, 0, 1));
    for (auto _ : state) {
        const auto it = medium.sample_interaction(ray, std::numeric_limits<float>::infinity(), rng);
        benchmark::DoNotOptimize(it.t);
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EffectiveMediumSample);
