// Benchmarks of the geometry layer: BVH closest-hit and any-hit ray-triangle throughput on
// procedural grain meshes (items = rays), BVH build, analytic ray-sphere.
//   bench_geometry --benchmark_filter=Bvh
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry.hpp"

using namespace grainlight;

namespace {
struct RaySet {
    std::vector<Vec3f> o, d;
};
// Rays from a sphere of radius 1.2 toward random points of the unit ball (most hit the grain).
RaySet make_rays(std::size_t n) {
    RaySet r;
    Pcg32 rng = Pcg32::from_key(3);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3f o = 1.2f * sample_uniform_sphere(rng.uniform2<float>());
        const Vec3f t = 0.6f * sample_uniform_sphere(rng.uniform2<float>()) * rng.uniform<float>();
        r.o.push_back(o);
        r.d.push_back(glm::normalize(t - o));
    }
    return r;
}
const Bvh<float>& cached_bvh(int shape, int level) {
    static std::map<std::pair<int, int>, std::unique_ptr<Bvh<float>>> cache;
    auto& p = cache[{shape, level}];
    if (!p) p = std::make_unique<Bvh<float>>(make_grain_mesh<float>(GrainShape(shape), 1.0f, 1, level));
    return *p;
}
}  // namespace

// Closest hit; args: shape (1 snow, 2 crystal), icosphere level (triangles 20 * 4^level).
static void BM_BvhClosestHit(benchmark::State& state) {
    const auto& bvh = cached_bvh(int(state.range(0)), int(state.range(1)));
    const RaySet rays = make_rays(4096);
    std::size_t i = 0;
    for (auto _ : state) {
        const auto h = bvh.intersect(rays.o[i], rays.d[i], 0.0f, 10.0f);
        benchmark::DoNotOptimize(h.t);
        i = (i + 1) & 4095;
    }
    state.counters["triangles"] = double(bvh.triangle_count());
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BvhClosestHit)->Args({1, 3})->Args({1, 5})->Args({2, 5})->Args({1, 7});

static void BM_BvhAnyHit(benchmark::State& state) {
    const auto& bvh = cached_bvh(1, int(state.range(0)));
    const RaySet rays = make_rays(4096);
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(bvh.occluded(rays.o[i], rays.d[i], 0.0f, 10.0f));
        i = (i + 1) & 4095;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BvhAnyHit)->Arg(5);

// Build time; items = triangles.
static void BM_BvhBuild(benchmark::State& state) {
    const auto mesh = make_grain_mesh<float>(GrainShape::snow, 1.0f, 1, int(state.range(0)));
    for (auto _ : state) {
        Bvh<float> bvh(mesh);
        benchmark::DoNotOptimize(bvh.nodes().data());
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(mesh.triangle_count()));
}
BENCHMARK(BM_BvhBuild)->Arg(5)->Unit(benchmark::kMillisecond);

static void BM_RaySphere(benchmark::State& state) {
    const RaySet rays = make_rays(4096);
    std::size_t i = 0;
    for (auto _ : state) {
        const auto r = intersect_sphere(rays.o[i], rays.d[i], Vec3f(0.0f), 0.7f);
        benchmark::DoNotOptimize(r.t_near);
        i = (i + 1) & 4095;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RaySphere);
