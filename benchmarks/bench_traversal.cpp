// Benchmarks of the traversal layer: Amanatides-Woo DDA cell steps and Meng15 Algorithm 1
// (TiledPacking::intersect) with an analytic-sphere grain intersector (items = rays).
//   bench_traversal
#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <vector>

#include "grainlight/core/warp.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/traversal/dda.hpp"
#include "grainlight/traversal/tiled_packing.hpp"

using namespace grainlight;

// DDA over 256 cells per ray; items = cells visited.
static void BM_DdaSteps(benchmark::State& state) {
    Rng rng = Rng::from_key(1);
    std::vector<Vec3d> dirs(1024);
    for (auto& d : dirs) d = sample_uniform_sphere<double>(rng.uniform2<double>());
    std::size_t i = 0;
    std::int64_t cells = 0;
    for (auto _ : state) {
        GridDda<double> dda(Vec3i64(0, 0, 0), Vec3d(0.3, 0.6, 0.1), dirs[i++ & 1023], Vec3d(1.0), 0.0, 150.0);
        for (; !dda.done(); dda.step()) ++cells;
        benchmark::DoNotOptimize(cells);
    }
    state.SetItemsProcessed(cells);
}
BENCHMARK(BM_DdaSteps);

namespace {
// A grain = sphere of radius `r` (in bounding-sphere units) at the centre.
struct SphereGrain {
    double r;
    bool operator()(const TiledGrain&, const GrainRay& ray, double t0, double t1, double& t) const {
        const double A = glm::dot(ray.d, ray.d), B = glm::dot(ray.o, ray.d), C = glm::dot(ray.o, ray.o) - r * r;
        const double disc = B * B - A * C;
        if (disc < 0) return false;
        const double ta = (-B - std::sqrt(disc)) / A;
        if (ta < t0 || ta > t1) return false;
        t = ta;
        return true;
    }
};
}  // namespace

// First grain hit in an unbounded aggregate at f = 0.63 (N = 2000 tile), grain radius 0.8 R
// (state.range(0) / 10 is the grain radius in R). items = rays.
static void BM_TiledPackingIntersect(benchmark::State& state) {
    static const PeriodicTile tile = md_pack(2000, 0.63, 1).tile;
    const TiledPacking<> pk(tile, UnboundedAggregate{}, {1.0, 1.0}, 5);
    const SphereGrain grain{double(state.range(0)) / 10.0};
    Rng rng = Rng::from_key(2);
    std::vector<std::pair<Vec3d, Vec3d>> rays(4096);
    for (auto& r : rays)
        r = {rng.uniform3<double>(),
             sample_uniform_sphere<double>(rng.uniform2<double>())};
    std::size_t i = 0;
    TiledTraversalStats st;
    for (auto _ : state) {
        const auto& r = rays[i++ & 4095];
        const TiledHit h = pk.intersect(Vec3i64(0, 0, 0), r.first, r.second, 0.0,
                                        std::numeric_limits<double>::infinity(), grain, &st);
        benchmark::DoNotOptimize(h.t);
    }
    state.counters["spheres/ray"] = double(st.spheres_tested) / double(state.iterations());
    state.SetItemsProcessed(std::int64_t(state.iterations()));
}
BENCHMARK(BM_TiledPackingIntersect)->Arg(10)->Arg(8)->Arg(5);
