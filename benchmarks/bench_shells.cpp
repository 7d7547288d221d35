// Benchmarks of Moon07 shell transport: shell steps/s (ShellMedium::step and the Medium-concept
// sample_interaction) against explicit path tracing of the same glass-sphere medium, counted both
// as interface events/s and as equivalent shell steps/s (first exits of chained spheres of the
// same radius r = 8 R), plus the preprocessing kernels (k-NN cell density, NMF).
//   bench_shells --benchmark_filter=Step
#include <benchmark/benchmark.h>

#include <limits>
#include <vector>

#include "grainlight/media/shell.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/precompute/shell_builder.hpp"

using namespace grainlight;

namespace {

struct Setup {
    PeriodicTile tile;
    double R;
    std::vector<double> radii;
    ShellBuildResult built;
    Setup()
        : tile([] {
              Rng r = Rng::from_key(1, 0x7ac);
              return random_sequential_addition(128, 0.3, r, 1.0);
          }()),
          R(tile.radius()) {
        for (int i = 1; i <= 6; ++i) radii.push_back(2.0 * i * R);
        const SpherePackingShellSource src(tile, 1.5, 0.0, 20 * R);
        const ShellSamples s = collect_shell_samples(src, radii, 20000, 1, 256, 12 * R);
        built = build_shell_table(s);
    }
};

const Setup& setup() {
    static const Setup s;
    return s;
}

struct FixedR {
    double r;
    double operator()(const Vec3d&) const noexcept { return r; }
};

// Counts interface events; stops after `limit` events (items = events).
struct EventCounter {
    std::uint64_t events = 0, limit = 1000;
    void begin(const Vec3d&, const Vec3d&) {}
    bool segment(const Vec3d&, const Vec3d&, double, bool e) {
        events += e ? 1 : 0;
        return events < limit;
    }
    void absorbed() {}
};

// Counts first exits of chained spheres of radius r (items = equivalent shell steps).
struct ChainCounter {
    double r = 1;
    int steps = 0, limit = 20;
    Vec3d c{0.0};
    void begin(const Vec3d& x, const Vec3d&) { c = x; }
    bool segment(const Vec3d& o_in, const Vec3d& d, double t, bool) {
        Vec3d o = o_in;
        double left = t;
        while (steps < limit) {
            const Vec3d rel = o - c;
            const double b = glm::dot(rel, d);
            const double s = -b + std::sqrt(std::max(0.0, b * b - (glm::dot(rel, rel) - r * r)));
            if (!(s <= left)) break;
            o += s * d;
            left -= s;
            c = o;
            ++steps;
        }
        return steps < limit;
    }
    void absorbed() {}
};

}  // namespace

static void BM_ShellStep(benchmark::State& state) {
    const auto& s = setup();
    const double r = s.radii[3];
    const ShellMedium<double, Spectrum<1, double>, FixedR> m(s.built.table, FixedR{r * (1 + 1e-9)});
    Rng rng = Rng::from_key(3);
    Vec3d x(0.0), w(0, 0, 1);
    for (auto _ : state) {
        const auto st = m.step(x, w, std::numeric_limits<double>::infinity(), rng, [](const Vec3d&) { return true; });
        x = st.p;
        w = st.w;
        benchmark::DoNotOptimize(x);
    }
    state.SetItemsProcessed(state.iterations());
    state.SetLabel("r = 8 R shell steps");
}
BENCHMARK(BM_ShellStep);

static void BM_ShellSampleInteraction(benchmark::State& state) {
    const auto& s = setup();
    const ShellMedium<double> m(s.built.table);  // infinite: largest shell (12 R)
    Rng rng = Rng::from_key(4);
    Ray<double> ray(Vec3d(0), Vec3d(0, 0, 1));
    for (auto _ : state) {
        const auto it = m.sample_interaction(ray, std::numeric_limits<double>::infinity(), rng);
        ray = Ray<double>(it.p, it.has_direction ? it.w : ray.d);
        benchmark::DoNotOptimize(ray);
    }
    state.SetItemsProcessed(state.iterations());
    state.SetLabel("Medium concept, r = 12 R");
}
BENCHMARK(BM_ShellSampleInteraction);

static void BM_ExplicitInterfaceEvents(benchmark::State& state) {
    const auto& s = setup();
    const SpherePackingShellSource src(s.tile, 1.5, 0.0, 1e-6);
    std::uint64_t total = 0, p = 0;
    for (auto _ : state) {
        Rng rng = Rng::from_key(5, p++);
        EventCounter c;
        src.trace(rng, c);
        total += c.events;
    }
    state.SetItemsProcessed(std::int64_t(total));
    state.SetLabel("explicit glass-sphere interface events");
}
BENCHMARK(BM_ExplicitInterfaceEvents)->Unit(benchmark::kMicrosecond);

static void BM_ExplicitEquivalentShellSteps(benchmark::State& state) {
    const auto& s = setup();
    const SpherePackingShellSource src(s.tile, 1.5, 0.0, 1e-6);
    std::uint64_t total = 0, p = 0;
    for (auto _ : state) {
        Rng rng = Rng::from_key(6, p++);
        ChainCounter c;
        c.r = s.radii[3];
        src.trace(rng, c);
        total += std::uint64_t(c.steps);
    }
    state.SetItemsProcessed(std::int64_t(total));
    state.SetLabel("explicit paths, first exits of chained r = 8 R spheres");
}
BENCHMARK(BM_ExplicitEquivalentShellSteps)->Unit(benchmark::kMicrosecond);

static void BM_KnnCellDensity(benchmark::State& state) {
    const auto& s = setup();
    Rng rng = Rng::from_key(7);
    std::vector<float> pts;
    for (int i = 0; i < int(state.range(0)); ++i)
        pts.insert(pts.end(), {2 * rng.uniform<float>() - 1, rng.uniform<float>(), rng.uniform<float>()});
    (void)s;
    for (auto _ : state) {
        auto g = knn_cell_density_grid(pts, double(state.range(0)), 32, 24, 16, 16);
        benchmark::DoNotOptimize(g.data());
    }
    state.SetItemsProcessed(state.iterations() * state.range(0));
    state.SetLabel("samples");
}
BENCHMARK(BM_KnnCellDensity)->Arg(20000)->Arg(100000)->Unit(benchmark::kMillisecond);

static void BM_Nmf(benchmark::State& state) {
    const auto& s = setup();
    for (auto _ : state) {
        auto f = nmf(s.built.density, int(state.range(0)), 100);
        benchmark::DoNotOptimize(f.relative_error);
    }
    state.SetItemsProcessed(state.iterations() * 100);
    state.SetLabel("NMF iterations on the 144 x 256 glass-sphere density");
}
BENCHMARK(BM_Nmf)->Arg(5)->Unit(benchmark::kMillisecond);
