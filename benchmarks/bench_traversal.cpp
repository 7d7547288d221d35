// Benchmarks of the traversal layer: Amanatides-Woo DDA cell steps and Meng15 Algorithm 1
// (TiledPacking::intersect) with an analytic-sphere grain intersector (items = rays), in an
// unbounded aggregate and in a voxelized sphere seen from outside (rays crossing empty tiles
// first); the reach test of the traversal (one bit) against the 27 classifier calls it replaced.
//   bench_traversal
#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <vector>

#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
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

namespace {
// A sphere of radius 150 tiles, voxelized (the tile of BM_TiledPackingIntersect, ~1.4e10 grains).
struct BigSphere {
    PeriodicTile tile = md_pack(2000, 0.63, 1).tile;
    TiledPacking<VoxelizedBoundary<SphereBoundary>> pk{
        tile, VoxelizedBoundary<SphereBoundary>(SphereBoundary(Vec3d(0.0), 150.0 * tile.side()), tile.side()), {1.0}, 5};
};
const BigSphere& big_sphere() {
    static const BigSphere s;
    return s;
}
}  // namespace

// Rays from 1.5 radii away toward random points of the sphere's central half: each crosses about
// 40 empty tiles of the grid before the first grain. items = rays.
static void BM_TiledPackingFromOutside(benchmark::State& state) {
    const BigSphere& s = big_sphere();
    const double R = 150.0 * s.tile.side();
    const SphereGrain grain{0.8};
    Rng rng = Rng::from_key(3);
    std::vector<std::pair<Vec3d, Vec3d>> rays(4096);
    for (auto& r : rays) {
        const Vec3d o = 1.5 * R * sample_uniform_sphere<double>(rng.uniform2<double>());
        const Vec3d t = 0.5 * R * sample_uniform_sphere<double>(rng.uniform2<double>());
        r = {o, glm::normalize(t - o)};
    }
    std::size_t i = 0;
    TiledTraversalStats st;
    for (auto _ : state) {
        const auto& r = rays[i++ & 4095];
        const TiledHit h = s.pk.intersect(Vec3i64(0, 0, 0), r.first, r.second, 0.0, std::numeric_limits<double>::infinity(),
                                          grain, &st);
        benchmark::DoNotOptimize(h.t);
    }
    state.counters["tiles/ray"] = double(st.voxels_visited) / double(state.iterations());
    state.counters["skipped/ray"] = double(st.voxels_skipped) / double(state.iterations());
    state.SetItemsProcessed(std::int64_t(state.iterations()));
}
BENCHMARK(BM_TiledPackingFromOutside);

namespace {
std::vector<Vec3i64> reach_queries() {  // tiles in a shell around the big sphere's surface
    Rng rng = Rng::from_key(4);
    std::vector<Vec3i64> q(4096);
    for (auto& t : q) {
        const Vec3d p = (150.0 + 4.0 * rng.uniform<double>() - 2.0) * sample_uniform_sphere<double>(rng.uniform2<double>());
        t = Vec3i64(std::int64_t(std::floor(p.x)), std::int64_t(std::floor(p.y)), std::int64_t(std::floor(p.z)));
    }
    return q;
}
}  // namespace

// TiledPacking::tile_reachable: one bit of the precomputed reach grid. items = tiles.
static void BM_TileReachable(benchmark::State& state) {
    const BigSphere& s = big_sphere();
    const std::vector<Vec3i64> q = reach_queries();
    std::size_t i = 0;
    for (auto _ : state) benchmark::DoNotOptimize(s.pk.tile_reachable(q[i++ & 4095]));
    state.SetItemsProcessed(std::int64_t(state.iterations()));
}
BENCHMARK(BM_TileReachable);

// Baseline: the same answer from the tile's and its 26 neighbours' classes (what the traversal
// asked before the reach grid). items = tiles.
static void BM_TileReach27Lookups(benchmark::State& state) {
    const BigSphere& s = big_sphere();
    const auto& b = s.pk.boundary();
    const std::vector<Vec3i64> q = reach_queries();
    std::size_t i = 0;
    for (auto _ : state) {
        const Vec3i64& v = q[i++ & 4095];
        bool reach = b.classify(v) != VoxelClass::outside;
        for (int dz = -1; dz <= 1 && !reach; ++dz)
            for (int dy = -1; dy <= 1 && !reach; ++dy)
                for (int dx = -1; dx <= 1 && !reach; ++dx) reach = b.classify(Vec3i64(v.x + dx, v.y + dy, v.z + dz)) != VoxelClass::outside;
        benchmark::DoNotOptimize(reach);
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()));
}
BENCHMARK(BM_TileReach27Lookups);
