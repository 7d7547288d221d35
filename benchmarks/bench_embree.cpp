// Grain traversal against Embree 3 (the kernels issue, item 4): the same procedural snow grains
// (one exemplar mesh, 320 triangles, randomly rotated per grain), once as Meng15 Algorithm 1
// (traversal/aggregate.hpp: O(1) memory in the grain count) and once instanced in Embree (one
// RTC_GEOMETRY_TYPE_INSTANCE per grain over a sub-scene holding the exemplar mesh: Embree's
// two-level BVH, the standard way to put many copies of a mesh into an Embree scene), the same
// rays, one thread, single incoherent rays (rtcIntersect1), hits checked equal.
// Built only when find_package(embree 3) succeeds (Debian: libembree-dev).
//
//   taskset -c 1 bench_embree --benchmark_filter='/[56]$'   1e5 and 1e6 grains
//   taskset -c 1 bench_embree --benchmark_filter='/7$'      1e7 grains (Embree ~3.6 GB, 10-20 s build)
//
// Second part (the discrete-media issue's Fig. 20 baseline): the first sphere entered by a ray in
// Guo21 Fig. 20's cloud (hard 1000 um spheres in the Cornell box's 0.7 m cube, N = 1e5 / 1e6), through
// the library's particle grid (GridSphereLookup, what ExplicitSphereMedium uses), the scalar
// binary BVH of examples/guo21_sphere_bvh.hpp (guo21_fig20_time_vs_n's EPT-BVH baseline), and
// Embree's RTC_GEOMETRY_TYPE_SPHERE_POINT (a production BVH over spheres); rays start at uniform
// points of the cube outside every sphere, in uniform directions (EPT's path segments). The grid
// runs with its automatic prefetch setting (Spheres_grid) and forced to the plain and the
// software-pipelined walk (Spheres_grid_plain / _pipelined; ParticleGridSettings::prefetch).
//   taskset -c 1 bench_embree --benchmark_filter='Spheres'
//
// Counters: memory_MB (Algorithm 1: its own count of tile + voxels + exemplar BVH bytes; Embree:
// the growth of the process's resident size while the instances are built and committed),
// build_s, grains, hit_rate; BM_EmbreeCheckSameHits: mismatches among 8192 rays (first grain
// differs, or the distance beyond float round-off, 1e-4 (1 + t), over the cosine of incidence).
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <algorithm>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/traversal/aggregate.hpp"

#include "common/aggregate_rays.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/traversal/particle_grid.hpp"
#include "embree/guo21_embree_spheres.hpp"
#include "guo21_sphere_bvh.hpp"

using namespace grainlight;

namespace {

using Agg = GranularAggregate<SphereBoundary>;
constexpr std::uint64_t kGrainSeed = 7;
constexpr int kGrainLevel = 2;

/// Resident set size of this process in bytes (Linux /proc/self/statm).
double resident_bytes() {
    std::ifstream f("/proc/self/statm");
    double pages_total = 0, pages_resident = 0;
    f >> pages_total >> pages_resident;
    return pages_resident * 4096.0;
}

using bench::boundary_radius;
using bench::camera_rays;
using bench::interior_rays;
using bench::Rays;
using bench::unit_tile;

const TriangleMesh<float>& exemplar_mesh() {
    static const TriangleMesh<float> m = make_grain_mesh<float>(GrainShape::snow, 1.0f, kGrainSeed, kGrainLevel);
    return m;
}

const Agg& aggregate(int lg) {
    static std::map<int, std::unique_ptr<Agg>> cache;
    auto& p = cache[lg];
    if (!p) {
        const double rb = boundary_radius(std::pow(10.0, lg));
        std::vector<Grain> ex = {Grain::mesh(exemplar_mesh(), GrainMaterial::make_dielectric(1.31))};
        p = std::make_unique<Agg>(unit_tile(), VoxelizedBoundary<SphereBoundary>(SphereBoundary(Vec3d(0.0), rb), unit_tile().side()),
                                  ex, std::vector<double>{1.0}, 3);
    }
    return *p;
}

/// The same grains instanced in Embree.
struct EmbreeGrains {
    RTCDevice device = nullptr;
    RTCScene mesh_scene = nullptr, scene = nullptr;
    std::vector<AggregateGrain> grains;  // instID -> grain
    double build_seconds = 0, memory_bytes = 0;

    explicit EmbreeGrains(const Agg& agg, double rb) {
        const double rss0 = resident_bytes();
        const auto t0 = std::chrono::steady_clock::now();
        device = rtcNewDevice("threads=1");
        mesh_scene = rtcNewScene(device);
        const auto& m = exemplar_mesh();
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                              3 * sizeof(float), m.vertices.size()));
        for (std::size_t i = 0; i < m.vertices.size(); ++i) {
            v[3 * i] = m.vertices[i].x;
            v[3 * i + 1] = m.vertices[i].y;
            v[3 * i + 2] = m.vertices[i].z;
        }
        auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                  3 * sizeof(unsigned), m.triangles.size()));
        for (std::size_t i = 0; i < m.triangles.size(); ++i)
            for (int k = 0; k < 3; ++k) ix[3 * i + std::size_t(k)] = m.triangles[i][k];
        rtcCommitGeometry(g);
        rtcAttachGeometry(mesh_scene, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(mesh_scene);

        scene = rtcNewScene(device);
        const double R = agg.grain_radius();
        agg.for_each_grain(Vec3d(-rb - 2), Vec3d(rb + 2), [&](const AggregateGrain& gr, const Vec3d& c) {
            RTCGeometry inst = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
            rtcSetGeometryInstancedScene(inst, mesh_scene);
            // x_world = c + R * rotation.to_world(x_unit): columns R r0, R r1, R r2, c.
            const float xfm[12] = {float(R * gr.rotation.r0.x), float(R * gr.rotation.r0.y), float(R * gr.rotation.r0.z),
                                   float(R * gr.rotation.r1.x), float(R * gr.rotation.r1.y), float(R * gr.rotation.r1.z),
                                   float(R * gr.rotation.r2.x), float(R * gr.rotation.r2.y), float(R * gr.rotation.r2.z),
                                   float(c.x),                  float(c.y),                  float(c.z)};
            rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
            rtcCommitGeometry(inst);
            rtcAttachGeometryByID(scene, inst, unsigned(grains.size()));
            rtcReleaseGeometry(inst);
            grains.push_back(gr);
        });
        rtcCommitScene(scene);
        build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        memory_bytes = resident_bytes() - rss0;
    }
    ~EmbreeGrains() {
        if (scene) rtcReleaseScene(scene);
        if (mesh_scene) rtcReleaseScene(mesh_scene);
        if (device) rtcReleaseDevice(device);
    }
    /// First hit: (grain index or -1, t).
    [[nodiscard]] std::pair<long long, double> intersect(const Vec3d& o, const Vec3d& d) const noexcept {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRayHit rh{};
        rh.ray.org_x = float(o.x);
        rh.ray.org_y = float(o.y);
        rh.ray.org_z = float(o.z);
        rh.ray.dir_x = float(d.x);
        rh.ray.dir_y = float(d.y);
        rh.ray.dir_z = float(d.z);
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = 1e30f;
        rh.ray.mask = 0xffffffffu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &ctx, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {-1, 0.0};
        return {(long long)rh.hit.instID[0], double(rh.ray.tfar)};
    }
};

const EmbreeGrains& embree(int lg) {
    static std::map<int, std::unique_ptr<EmbreeGrains>> cache;
    auto& p = cache[lg];
    if (!p) p = std::make_unique<EmbreeGrains>(aggregate(lg), boundary_radius(std::pow(10.0, lg)));
    return *p;
}

template <bool Interior>
void BM_Algorithm1(benchmark::State& st) {
    const int lg = int(st.range(0));
    const Agg& agg = aggregate(lg);
    const double rb = boundary_radius(std::pow(10.0, lg));
    const Rays rays = Interior ? interior_rays(rb, 4096) : camera_rays(rb, 4096);
    std::size_t i = 0, hits = 0;
    for (auto _ : st) {
        const AggregateHit h = agg.intersect(rays.o[i], rays.d[i], 0.0, 1e30);
        hits += h.hit;
        benchmark::DoNotOptimize(h);
        i = (i + 1) % rays.o.size();
    }
    st.SetItemsProcessed(std::int64_t(st.iterations()));
    st.counters["memory_MB"] = double(agg.memory_bytes()) / 1e6;
    st.counters["hit_rate"] = double(hits) / double(st.iterations());
}

template <bool Interior>
void BM_Embree(benchmark::State& st) {
    const int lg = int(st.range(0));
    const EmbreeGrains& e = embree(lg);
    const double rb = boundary_radius(std::pow(10.0, lg));
    const Rays rays = Interior ? interior_rays(rb, 4096) : camera_rays(rb, 4096);
    std::size_t i = 0, hits = 0;
    for (auto _ : st) {
        const auto h = e.intersect(rays.o[i], rays.d[i]);
        hits += h.first >= 0;
        benchmark::DoNotOptimize(h);
        i = (i + 1) % rays.o.size();
    }
    st.SetItemsProcessed(std::int64_t(st.iterations()));
    st.counters["memory_MB"] = e.memory_bytes / 1e6;
    st.counters["build_s"] = e.build_seconds;
    st.counters["grains"] = double(e.grains.size());
    st.counters["hit_rate"] = double(hits) / double(st.iterations());
}

/// Not timed: both return the same first grain at the same distance (float round-off) for 4096
/// camera and 4096 interior rays.
void BM_EmbreeCheckSameHits(benchmark::State& st) {
    const int lg = int(st.range(0));
    const Agg& agg = aggregate(lg);
    const EmbreeGrains& e = embree(lg);
    const double rb = boundary_radius(std::pow(10.0, lg));
    std::int64_t mismatches = 0, hits = 0;
    for (auto _ : st) {
        mismatches = hits = 0;
        for (const Rays& rays : {camera_rays(rb, 4096), interior_rays(rb, 4096)})
            for (std::size_t k = 0; k < rays.o.size(); ++k) {
                const AggregateHit a = agg.intersect(rays.o[k], rays.d[k], 0.0, 1e30);
                const auto b = e.intersect(rays.o[k], rays.d[k]);
                hits += a.hit;
                bool same = a.hit == (b.first >= 0);
                if (same && a.hit) {
                    const AggregateGrain& g = e.grains[std::size_t(b.first)];
                    // A float round-off in the instance transform moves a hit along the ray by
                    // that round-off over the cosine of incidence: grazing hits get that slack.
                    const double cos_i = std::max(std::abs(glm::dot(a.n, rays.d[k])), 1e-3);
                    same = g.sphere == a.grain.sphere && g.tile == a.grain.tile &&
                           std::abs(b.second - a.t) <= 1e-4 * (1.0 + a.t) / cos_i;
                }
                mismatches += !same;
            }
    }
    st.counters["rays"] = 8192;
    st.counters["hits"] = double(hits);
    st.counters["mismatches"] = double(mismatches);
}

// ---- Guo21 Fig. 20's sphere cloud: grid vs scalar BVH vs Embree spheres ----

struct SphereCloud {
    std::shared_ptr<const ParticleCloud> cloud;
    std::unique_ptr<GridSphereLookup> grid;        // prefetch automatic (what the renders use)
    std::unique_ptr<GridSphereLookup> grid_plain;  // the plain walk
    std::unique_ptr<GridSphereLookup> grid_piped;  // the software-pipelined walk
    std::unique_ptr<guo21_bvh::SphereBvhLookup> bvh;
    std::unique_ptr<guo21_embree::EmbreeSphereLookup> embree;
    std::vector<Vec3<float>> o, d, points;  // rays (outside every sphere) and probe points (any)
};

const SphereCloud& sphere_cloud(int lg) {
    static std::map<int, std::unique_ptr<SphereCloud>> cache;
    auto& c = cache[lg];
    if (c) return *c;
    c = std::make_unique<SphereCloud>();
    const BoxBoundary box(Vec3d(0.15, 0.05, 0.15), Vec3d(0.85, 0.75, 0.85));
    const std::vector<CloudSpecies> species{cloud_species(MonodispersePsd(1000.0))};
    c->cloud = std::make_shared<ParticleCloud>(
        ParticleCloud::generate_non_overlapping(box, std::uint64_t(std::pow(10.0, lg)), species, 20 + lg, 1e6));
    c->grid = std::make_unique<GridSphereLookup>(std::make_shared<ParticleGrid>(*c->cloud, ParticleGridSettings{}));
    ParticleGridSettings plain, piped;
    plain.prefetch = 0;
    piped.prefetch = 1;
    c->grid_plain = std::make_unique<GridSphereLookup>(std::make_shared<ParticleGrid>(*c->cloud, plain));
    c->grid_piped = std::make_unique<GridSphereLookup>(std::make_shared<ParticleGrid>(*c->cloud, piped));
    c->bvh = std::make_unique<guo21_bvh::SphereBvhLookup>(c->cloud);
    c->embree = std::make_unique<guo21_embree::EmbreeSphereLookup>(c->cloud);
    Rng rng = Rng::from_key(99, std::uint64_t(lg));
    while (c->o.size() < 4096) {
        const Vec3<float> p = Vec3<float>(0.15f, 0.05f, 0.15f) + 0.7f * rng.uniform3<float>();
        if (c->grid->containing(p) >= 0) continue;
        c->o.push_back(p);
        c->d.push_back(sample_uniform_sphere(rng.uniform2<float>()));
    }
    // Probe points: half near sphere centres (inside), half uniform.
    const auto& ps = c->cloud->particles();
    for (int k = 0; k < 4096; ++k) {
        if (k % 2 == 0) {
            const CloudParticle& q = ps[std::size_t(rng.uniform<double>() * double(ps.size())) % ps.size()];
            const Vec3<float> u = sample_uniform_sphere(rng.uniform2<float>());
            c->points.push_back(q.center() + (0.999f * q.r * std::cbrt(rng.uniform<float>())) * u);
        } else {
            c->points.push_back(Vec3<float>(0.15f, 0.05f, 0.15f) + 0.7f * rng.uniform3<float>());
        }
    }
    return *c;
}

template <int Kind>  // 0: grid (automatic prefetch), 1: scalar BVH, 2: Embree, 3: grid plain walk, 4: grid pipelined walk
void BM_Spheres(benchmark::State& st) {
    const SphereCloud& c = sphere_cloud(int(st.range(0)));
    std::size_t i = 0, hits = 0;
    const GridSphereLookup* grid = Kind == 3 ? c.grid_plain.get() : Kind == 4 ? c.grid_piped.get() : c.grid.get();
    for (auto _ : st) {
        float t = 0;
        constexpr float inf = std::numeric_limits<float>::infinity();
        const std::int64_t h = Kind == 1   ? c.bvh->first_hit(c.o[i], c.d[i], inf, t)
                               : Kind == 2 ? c.embree->first_hit(c.o[i], c.d[i], inf, t)
                                           : grid->first_hit(c.o[i], c.d[i], inf, t);
        hits += h >= 0;
        benchmark::DoNotOptimize(t);
        i = (i + 1) % c.o.size();
    }
    st.SetItemsProcessed(std::int64_t(st.iterations()));
    st.counters["spheres"] = double(c.cloud->particles().size());
    st.counters["hit_rate"] = double(hits) / double(st.iterations());
}

/// Not timed: the three return the same first sphere at the same distance for 4096 rays, and the
/// same containing sphere for 4096 points (half of them inside a sphere).
void BM_SpheresCheckSameHits(benchmark::State& st) {
    const SphereCloud& c = sphere_cloud(int(st.range(0)));
    std::int64_t mismatches = 0, hits = 0, inside = 0, containing_mismatches = 0;
    for (auto _ : st) {
        mismatches = hits = inside = containing_mismatches = 0;
        for (const Vec3<float>& p : c.points) {
            const auto a = c.grid->containing(p), b = c.bvh->containing(p), e = c.embree->containing(p);
            inside += a >= 0;
            containing_mismatches += !(a == b && a == e);
        }
        for (std::size_t k = 0; k < c.o.size(); ++k) {
            float ta = 0, tb = 0, te = 0;
            const auto a = c.grid->first_hit(c.o[k], c.d[k], std::numeric_limits<float>::infinity(), ta);
            const auto b = c.bvh->first_hit(c.o[k], c.d[k], std::numeric_limits<float>::infinity(), tb);
            const auto e = c.embree->first_hit(c.o[k], c.d[k], std::numeric_limits<float>::infinity(), te);
            float tp = 0, tq = 0;
            const auto p = c.grid_plain->first_hit(c.o[k], c.d[k], std::numeric_limits<float>::infinity(), tp);
            const auto q = c.grid_piped->first_hit(c.o[k], c.d[k], std::numeric_limits<float>::infinity(), tq);
            hits += a >= 0;
            mismatches += !(a == b && ta == tb && a == e && (a < 0 || std::abs(te - ta) <= 1e-5f * (1 + ta)));
            mismatches += !(p == a && q == a && tp == ta && tq == ta);
        }
    }
    st.counters["rays"] = double(c.o.size());
    st.counters["hits"] = double(hits);
    st.counters["mismatches"] = double(mismatches);
    st.counters["points_inside"] = double(inside);
    st.counters["containing_mismatches"] = double(containing_mismatches);
}
}  // namespace

BENCHMARK_TEMPLATE(BM_Spheres, 0)->Name("Spheres_grid")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Spheres, 1)->Name("Spheres_bvh")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Spheres, 2)->Name("Spheres_embree")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Spheres, 3)->Name("Spheres_grid_plain")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Spheres, 4)->Name("Spheres_grid_pipelined")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SpheresCheckSameHits)->Arg(5)->Arg(6)->Iterations(1);
BENCHMARK_TEMPLATE(BM_Algorithm1, false)->Name("Algorithm1_camera")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Embree, false)->Name("Embree_camera")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Algorithm1, true)->Name("Algorithm1_interior")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Embree, true)->Name("Embree_interior")->Arg(5)->Arg(6)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EmbreeCheckSameHits)->Arg(5)->Iterations(1);
// 1e7 grains: run with --benchmark_filter='/7' (Embree needs ~3.6 GB and 10-20 s to build).
BENCHMARK_TEMPLATE(BM_Algorithm1, false)->Name("Algorithm1_camera")->Arg(7)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Embree, false)->Name("Embree_camera")->Arg(7)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Algorithm1, true)->Name("Algorithm1_interior")->Arg(7)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Embree, true)->Name("Embree_interior")->Arg(7)->Unit(benchmark::kMicrosecond);
