// Benchmarks of the geometry layer: BVH closest-hit and any-hit ray-triangle throughput on
// procedural grain meshes (items = rays), BVH build, analytic ray-sphere, and the cone walk of
// star-shaped grains (geometry/star_mesh.hpp) against the BVH on the same rays.
//   bench_geometry --benchmark_filter=Bvh
//   bench_geometry --benchmark_filter=GrainQuery
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
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

namespace {
// Rays of a path at a snow grain (unit bounding sphere): entering from the bounding sphere toward
// a random point of the ball (`inside` false), or leaving from just inside its surface in a random
// inward-hemisphere direction (`inside` true: the internal bounces of EPT).
RaySet grain_rays(const Bvh<float>& bvh, bool inside, std::size_t n) {
    RaySet r;
    Pcg32 rng = Pcg32::from_key(inside ? 8 : 7);
    while (r.o.size() < n) {
        Vec3f o = sample_uniform_sphere(rng.uniform2<float>());
        Vec3f d = glm::normalize(std::cbrt(rng.uniform<float>()) * sample_uniform_sphere(rng.uniform2<float>()) - o);
        if (inside) {
            const auto h = bvh.intersect(o, d, 0.0f, 3.0f);
            if (!h.valid()) continue;
            o = o + (h.t + 1e-4f) * d;
            d = sample_uniform_sphere(rng.uniform2<float>());
            if (glm::dot(d, h.n_geom) > 0.0f) d = -d;
        }
        r.o.push_back(o);
        r.d.push_back(d);
    }
    return r;
}
}  // namespace

// One snow grain's closest hit, args: icosphere level, method (0: the BVH alone, the baseline;
// 1: the cone walk with Grain's budget, finished by the BVH, as Grain::intersect does; 2 / 3 / 4:
// the same with a budget of 8 / 16 / no triangle tests: how the budget was chosen), rays (0:
// entering, 1: from inside). Same rays and same hits for every method.
static void BM_GrainQuery(benchmark::State& state) {
    const int level = int(state.range(0));
    const bool walk = state.range(1) >= 1, inside = state.range(2) == 1;
    const int budget = state.range(1) == 1 ? Grain::star_walk_budget : state.range(1) == 2 ? 8 : state.range(1) == 3 ? 16 : -1;
    const auto mesh = make_grain_mesh<float>(GrainShape::snow, 1.0f, 1, level);
    const Bvh<float> bvh(mesh);
    const auto star = StarMesh::build(mesh);
    if (!star) {
        state.SkipWithError("not star-shaped");
        return;
    }
    const RaySet rays = grain_rays(bvh, inside, 4096);
    std::size_t i = 0, hits = 0;
    for (auto _ : state) {
        const TriangleHit<float> h = walk ? intersect_star_then_bvh(&*star, bvh, rays.o[i], rays.d[i], 10.0f, budget)
                                          : bvh.intersect(rays.o[i], rays.d[i], 0.0f, 10.0f);
        hits += h.valid();
        benchmark::DoNotOptimize(h.t);
        i = (i + 1) & 4095;
    }
    state.counters["triangles"] = double(mesh.triangle_count());
    state.counters["hit_rate"] = double(hits) / double(state.iterations());
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_GrainQuery)->ArgsProduct({{1, 2, 3, 4}, {0, 1, 2, 3, 4}, {0, 1}});

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

// Which of 32 points within r of a point near a mesh surface are inside (the flight memory's
// collision disc, media/flight_memory.hpp): MeshDistance::inside_near (one range search, segment
// parity against the near triangles) against the baseline of a parity test per point
// (MeshDistance::inside: three full rays each). Mesh: an icosphere of radius 40 (arg: level),
// r = 1, points within 1 of the surface. Items = 32-point discs.
namespace {
struct DiscSet {
    std::vector<Vec3d> q;
    std::vector<std::array<Vec3d, 32>> x;
};
DiscSet make_discs(std::size_t n) {
    DiscSet s;
    Pcg32 rng = Pcg32::from_key(4);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3d q = (40.0 - rng.uniform<double>()) * sample_uniform_sphere(rng.uniform2<double>());
        std::array<Vec3d, 32> x;
        for (auto& xi : x) xi = q + sample_uniform_sphere(rng.uniform2<double>()) * std::sqrt(rng.uniform<double>());
        s.q.push_back(q);
        s.x.push_back(x);
    }
    return s;
}
MeshDistance big_sphere(int level) {
    TriangleMesh<double> m = make_icosphere<double>(level);
    for (auto& v : m.vertices) v *= 40.0;
    m.compute_face_normals();
    return MeshDistance(m);
}
}  // namespace

static void BM_DiscInsideNear(benchmark::State& state) {
    const MeshDistance md = big_sphere(int(state.range(0)));
    const DiscSet d = make_discs(1024);
    std::size_t i = 0;
    std::array<bool, 32> out{};
    for (auto _ : state) {
        if (!md.inside_near(d.q[i], 1.0, true, d.x[i].data(), 32, out.data()))
            for (std::size_t k = 0; k < 32; ++k) out[k] = md.inside(d.x[i][k]);
        benchmark::DoNotOptimize(out.data());
        i = (i + 1) & 1023;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DiscInsideNear)->Arg(4)->Arg(6);

static void BM_DiscInsidePerPoint(benchmark::State& state) {  // baseline
    const MeshDistance md = big_sphere(int(state.range(0)));
    const DiscSet d = make_discs(1024);
    std::size_t i = 0;
    std::array<bool, 32> out{};
    for (auto _ : state) {
        for (std::size_t k = 0; k < 32; ++k) out[k] = md.inside(d.x[i][k]);
        benchmark::DoNotOptimize(out.data());
        i = (i + 1) & 1023;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DiscInsidePerPoint)->Arg(4)->Arg(6);

// The point test in a partial voxel of a voxelized mesh (Meng15 footnote 1: is a grain centre
// inside the boundary?) on a grid too large for the 4^3 sub-voxels (an icosphere of radius 70
// voxels: 143^3 voxels > 2^20), as Fig. 1's castle is: VoxelizedBoundary::point_inside (parity of
// a segment from the voxel's reference point against the voxel's own triangles) against the
// baseline of the mesh's own test (MeshBoundary::inside: three parity rays through the whole
// mesh), which was the fallback before. Points within half a voxel of the surface; items =
// points; arg: icosphere level.
namespace {
struct VoxelizedSphere {
    MeshBoundary mesh;
    VoxelizedBoundary<MeshBoundary> vox;
    std::vector<Vec3i64> tile;
    std::vector<Vec3d> local;
};
const VoxelizedSphere& voxelized_sphere(int level) {
    static std::map<int, std::unique_ptr<VoxelizedSphere>> cache;
    auto& p = cache[level];
    if (!p) {
        TriangleMesh<double> m = make_icosphere<double>(level);
        for (auto& v : m.vertices) v = 70.0 * v + Vec3d(0.31, -0.17, 0.07);
        m.compute_face_normals();
        MeshBoundary mb(m);
        VoxelizedBoundary<MeshBoundary> vb(mb, 1.0);
        p = std::make_unique<VoxelizedSphere>(VoxelizedSphere{std::move(mb), std::move(vb), {}, {}});
        Pcg32 rng = Pcg32::from_key(5);
        while (p->tile.size() < 4096) {
            const Vec3d q = (70.0 + rng.uniform<double>() - 0.5) * sample_uniform_sphere(rng.uniform2<double>()) +
                            Vec3d(0.31, -0.17, 0.07);
            const Vec3i64 t(std::int64_t(std::floor(q.x)), std::int64_t(std::floor(q.y)), std::int64_t(std::floor(q.z)));
            if (p->vox.classify(t) != VoxelClass::partial) continue;
            p->tile.push_back(t);
            p->local.push_back(q - Vec3d(t));
        }
    }
    return *p;
}
}  // namespace

static void BM_PartialVoxelInsideLocal(benchmark::State& state) {
    const VoxelizedSphere& s = voxelized_sphere(int(state.range(0)));
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(s.vox.point_inside(s.tile[i], s.local[i]));
        i = (i + 1) & 4095;
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["refined"] = s.vox.refined() ? 1 : 0;
}
BENCHMARK(BM_PartialVoxelInsideLocal)->Arg(4)->Arg(6);

static void BM_PartialVoxelInsideWholeMesh(benchmark::State& state) {  // baseline
    const VoxelizedSphere& s = voxelized_sphere(int(state.range(0)));
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(s.mesh.inside(s.vox.to_shape_frame(s.tile[i], s.local[i])));
        i = (i + 1) & 4095;
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PartialVoxelInsideWholeMesh)->Arg(4)->Arg(6);
