// Benchmarks of the Meng15 Sec. 5 hybrid integrator (integrators/hybrid.hpp): camera paths/s of
// lock-step bundles (N = 16) into a sphere of 20 grain radii of slightly absorbing ice-like
// grains (MD packing, f = 0.6) under a quad light and a sky, for EPT only, EPT -> VPT and
// EPT -> VPT -> DA (EPT -> VPT with and without flight memory); DA connections/s (semi-infinite
// dipole vs App. A multipole); Eq. 5's spread; one free flight / shadow segment with and without
// flight memory.
//
//   bench_hybrid                            (items/s = camera paths/s, connections/s, points/s)
//   bench_hybrid --benchmark_filter=Bundle
#include <benchmark/benchmark.h>

#include <array>
#include <memory>
#include <optional>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/integrators/hybrid.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/flight_memory.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/precompute/scatterometer.hpp"
#include "grainlight/scene/scene.hpp"

using namespace grainlight;

namespace {

using Medium = ContinuousMedium<TabulatedPhase<float, RGB>, RGB>;
using SceneT = Scene<Medium>;
constexpr double Rb = 20.0;

struct Fixture {
    std::optional<PeriodicTile> tile;
    SphereBoundary shape{Vec3d(0.0), Rb};
    std::unique_ptr<GranularAggregate<SphereBoundary>> agg;
    std::optional<HybridDiffusion> diffusion;
    SceneT ept, vpt;
    int medium = -1, boundary = -1;
};

const Fixture& fixture() {
    static const Fixture* f = [] {
        auto* x = new Fixture{};
        const auto packed = md_pack(200, 0.6, 1);
        const double s = 1.0 / packed.tile.radius();
        std::vector<Vec3d> c = packed.tile.centers();
        for (auto& p : c) p *= s;
        x->tile.emplace(packed.tile.side() * s, 1.0, std::move(c));
        const GrainMaterial mat = GrainMaterial::make_absorbing_dielectric(1.31, RGBd{0.02, 0.01, 0.005});
        x->agg = std::make_unique<GranularAggregate<SphereBoundary>>(
            *x->tile, VoxelizedBoundary<SphereBoundary>(x->shape, x->tile->side()), std::vector<GrainExemplar>{GrainExemplar::sphere(1.0, mat)},
            std::vector<double>{1.0}, 3);
        ScatterometerConfig cfg;
        cfg.rays = 50000;
        const GrainStats stats = run_scatterometer(ScatterometerGrain::sphere(1.0, mat), cfg);
        x->diffusion.emplace(make_hybrid_diffusion(effective_rte_params(stats, x->tile->packing_fraction(), 1.0)));
        const float R = float(Rb);
        x->ept.add_shape(QuadShape<float>(Vec3f(-6 * R, -R, -6 * R), Vec3f(0, 0, 12 * R), Vec3f(12 * R, 0, 0)),
                         Material<float, RGB>::diffuse(RGB(0.5f)));
        x->ept.add_quad_light(QuadShape<float>(Vec3f(-0.4f * R, 2.5f * R, -0.4f * R), Vec3f(0.8f * R, 0, 0), Vec3f(0, 0, 0.8f * R)),
                              RGB(40.0f));
        x->ept.add_light(Light<float, RGB>::environment_light(RGB(0.05f)));
        x->vpt = x->ept;
        x->medium = x->vpt.add_medium(make_effective_medium<float, RGB>(stats, x->tile->packing_fraction(), 1.0));
        x->boundary = x->vpt.add_shape(SphereShape<float>(Vec3f(0.0f), R), Material<float, RGB>::index_matched(), x->medium, -1);
        return x;
    }();
    return *f;
}

void BM_Bundle(benchmark::State& state, HybridMode mode, int flight_memory) {
    const Fixture& f = fixture();
    const HybridContext<BoundaryDistance<SphereBoundary>> ctx{f.medium, f.boundary, {f.shape}, &*f.diffusion};
    HybridOptions opt;
    opt.mode = mode;
    opt.flight_memory = flight_memory;
    std::array<Ray<float>, 16> rays;
    std::array<Rng, 16> rngs;
    std::uint64_t k = 0, switched = 0, da = 0, paths = 0;
    for (auto _ : state) {
        Rng g = Rng::from_key(9, k, 0);
        const Vec3d o = 3.0 * Rb * sample_uniform_sphere(g.uniform2<double>());
        const Vec3d target = 0.7 * Rb * sample_uniform_sphere(g.uniform2<double>());
        for (std::size_t i = 0; i < 16; ++i) {
            rngs[i] = Rng::from_key(9, k, i + 1);
            const Vec3d t = target + 0.5 * Vec3d(g.uniform<double>() - 0.5, g.uniform<double>() - 0.5, 0.0);
            rays[i] = Ray<float>(Vec3f(o), Vec3f(glm::normalize(t - o)));
        }
        const auto b = hybrid_bundle(f.ept, f.vpt, *f.agg, ctx, rays.data(), rngs.data(), 16, opt);
        benchmark::DoNotOptimize(b.path[0].low);
        switched += b.counters.switched;
        da += b.counters.da;
        paths += 16;
        ++k;
    }
    state.SetItemsProcessed(std::int64_t(paths));
    state.counters["switched_fraction"] = double(switched) / double(paths);
    state.counters["da_per_path"] = double(da) / double(paths);
}
BENCHMARK_CAPTURE(BM_Bundle, EPT, HybridMode::ept, 0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Bundle, EPT_VPT, HybridMode::ept_vpt, HybridOptions{}.flight_memory)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Bundle, EPT_VPT_memoryless, HybridMode::ept_vpt, 0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Bundle, EPT_VPT_DA, HybridMode::ept_vpt_da, HybridOptions{}.flight_memory)->Unit(benchmark::kMicrosecond);

// One free flight / one shadow segment of the effective medium with and without flight memory
// (media/flight_memory.hpp): the path came 3 grain radii up the z axis and leaves at a random
// direction, i.e. the first flight after a switch; `memory` 0 is the base medium.
void BM_FlightMemoryFlight(benchmark::State& state, int memory, bool shadow) {
    const Fixture& f = fixture();
    const Medium& base = f.vpt.medium(f.medium);
    FlightMemory mem0;
    mem0.radius = 1.0;
    mem0.push(Vec3d(0, 0, -6), Vec3d(0, 0, -3));
    mem0.push(Vec3d(0, 0, -3), Vec3d(0, 0, 0));
    mem0.remembered = memory;
    Rng rng = Rng::from_key(5, 0, 0);
    std::int64_t n = 0;
    for (auto _ : state) {
        FlightMemory mem = mem0;
        const FlightMemoryMedium<Medium> m(base, memory > 0 ? &mem : nullptr);
        const Ray<float> ray(Vec3f(0.0f), Vec3f(sample_uniform_sphere(rng.uniform2<double>())));
        if (shadow)
            benchmark::DoNotOptimize(m.transmittance(ray, 8.0f, rng));
        else
            benchmark::DoNotOptimize(m.sample_interaction(ray, 8.0f, rng));
        ++n;
    }
    state.SetItemsProcessed(n);
}
BENCHMARK_CAPTURE(BM_FlightMemoryFlight, flight_base, 0, false);
BENCHMARK_CAPTURE(BM_FlightMemoryFlight, flight_memory4, 4, false);
BENCHMARK_CAPTURE(BM_FlightMemoryFlight, shadow_base, 0, true);
BENCHMARK_CAPTURE(BM_FlightMemoryFlight, shadow_memory4, 4, true);

void BM_DiffusionConnection(benchmark::State& state, bool multipole) {
    const Fixture& f = fixture();
    const HybridContext<BoundaryDistance<SphereBoundary>> ctx{f.medium, f.boundary, {f.shape}, &*f.diffusion};
    Rng rng = Rng::from_key(3, 0, 0);
    std::int64_t n = 0;
    for (auto _ : state) {
        const Vec3d x = 0.5 * Rb * sample_uniform_sphere(rng.uniform2<double>());
        SurfaceHit<float, RGB> h;
        RGB w;
        benchmark::DoNotOptimize(sample_diffusion_connection(f.vpt, ctx, x, rng, h, w, multipole));
        benchmark::DoNotOptimize(w);
        ++n;
    }
    state.SetItemsProcessed(n);
}
BENCHMARK_CAPTURE(BM_DiffusionConnection, dipole, false);
BENCHMARK_CAPTURE(BM_DiffusionConnection, multipole, true);

void BM_BundleSpread(benchmark::State& state) {
    std::array<Vec3d, 16> x;
    Rng rng = Rng::from_key(1, 2, 3);
    for (auto& p : x) p = rng.uniform3<double>();
    for (auto _ : state) benchmark::DoNotOptimize(bundle_spread(x.data(), 16));
    state.SetItemsProcessed(std::int64_t(state.iterations()) * 16);
}
BENCHMARK(BM_BundleSpread);

}  // namespace
