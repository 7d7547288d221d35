// Benchmarks of procedural aggregates (Meng15 Sec. 3.2, Algorithm 1): first-hit rays/s through a
// sphere-shaped aggregate of 1e3 .. 1e9 randomly rotated snow grains (procedural: tile + 2-bit
// voxels + hashed instancing, memory independent of the grain count) versus a two-level BVH over
// explicit instances of the same grains (top level: a median-split BVH over instance bounds;
// bottom level: the exemplar mesh's own BVH, the ray transformed per instance; near child
// first), built only where
// it fits in memory (<= 1e6 grains). Both see identical grains (the explicit list is enumerated
// from the procedural aggregate), so they return identical hits.
//
//   bench_aggregates                      (items/s = rays/s; counters: grains, memory_MB)
//   bench_aggregates --benchmark_filter=Procedural
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/traversal/aggregate.hpp"

#include "common/aggregate_rays.hpp"

using namespace grainlight;

namespace {

using Agg = GranularAggregate<SphereBoundary>;
using bench::boundary_radius;
using bench::Rays;
using bench::unit_tile;
constexpr auto make_rays = bench::camera_rays;
constexpr auto make_interior_rays = bench::interior_rays;

const Agg& aggregate(int log10n) {
    static std::map<int, std::unique_ptr<Agg>> cache;
    auto& p = cache[log10n];
    if (!p) {
        const double rb = boundary_radius(std::pow(10.0, log10n));
        const PeriodicTile& tile = unit_tile();
        std::vector<GrainExemplar> ex = {
            GrainExemplar::procedural(GrainShape::snow, 1.0, GrainMaterial::make_dielectric(1.31), 7, 2)};
        p = std::make_unique<Agg>(tile, VoxelizedBoundary<SphereBoundary>(SphereBoundary(Vec3d(0.0), rb), tile.side()), ex,
                                  std::vector<double>{1.0}, 3);
    }
    return *p;
}

/// Two-level BVH over explicit grain instances.
class InstanceBvh {
public:
    struct Inst {
        AggregateGrain g;
        Vec3f c;
    };
    InstanceBvh(const Agg& agg, double rb) : agg_(agg), r_(float(agg.grain_radius())) {
        agg.for_each_grain(Vec3d(-rb - 2), Vec3d(rb + 2), [&](const AggregateGrain& g, const Vec3d& c) {
            inst_.push_back({g, Vec3f(c)});
        });
        std::vector<std::uint32_t> idx(inst_.size());
        std::iota(idx.begin(), idx.end(), 0u);
        nodes_.reserve(2 * inst_.size() / 2 + 1);
        build(idx, 0, idx.size());
        std::vector<Inst> sorted;
        sorted.reserve(inst_.size());
        for (auto i : idx) sorted.push_back(inst_[i]);
        inst_ = std::move(sorted);
    }
    [[nodiscard]] std::size_t size() const noexcept { return inst_.size(); }
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        std::size_t b = inst_.size() * sizeof(Inst) + nodes_.size() * sizeof(Node);
        for (const auto& e : agg_.exemplars()) b += e.memory_bytes();
        return b;
    }
    [[nodiscard]] AggregateHit intersect(const Vec3d& o, const Vec3d& d, double t_max) const noexcept {
        AggregateHit best;
        best.t = t_max;
        const Vec3f of(o), inv(1.0f / float(d.x), 1.0f / float(d.y), 1.0f / float(d.z));
        std::uint32_t stack[128];
        int sp = 0;
        std::uint32_t node = 0;
        for (;;) {
            const Node& n = nodes_[node];
            if (intersect_aabb(n.box, of, inv, 0.0f, float(best.t))) {
                if (n.count > 0) {
                    for (std::uint32_t i = n.offset; i < n.offset + n.count; ++i) {
                        const Inst& e = inst_[i];
                        const auto roots = intersect_sphere(o, d, Vec3d(e.c), double(r_));
                        if (!roots || roots.t_far <= 0 || roots.t_near >= best.t) continue;
                        const AggregateHit h = agg_.intersect_grain(e.g, o, d, std::max(0.0, roots.t_near - 1e-7),
                                                                    std::min(best.t, roots.t_far));
                        if (h && h.t < best.t) best = h;
                    }
                    if (sp == 0) break;
                    node = stack[--sp];
                } else if (d[n.axis] < 0) {  // near child first
                    stack[sp++] = node + 1;
                    node = n.offset;
                } else {
                    stack[sp++] = n.offset;
                    node = node + 1;
                }
            } else {
                if (sp == 0) break;
                node = stack[--sp];
            }
        }
        if (!best.hit) best.t = std::numeric_limits<double>::infinity();
        return best;
    }

private:
    struct Node {
        Aabb<float> box;
        std::uint32_t offset = 0, count = 0;
        int axis = 0;
    };
    void build(std::vector<std::uint32_t>& idx, std::size_t b, std::size_t e) {
        const auto me = std::uint32_t(nodes_.size());
        nodes_.push_back({});
        Aabb<float> box, cb;
        for (std::size_t i = b; i < e; ++i) {
            box.expand(inst_[idx[i]].c - Vec3f(r_));
            box.expand(inst_[idx[i]].c + Vec3f(r_));
            cb.expand(inst_[idx[i]].c);
        }
        nodes_[me].box = box;
        if (e - b <= 4) {
            nodes_[me].offset = std::uint32_t(b);
            nodes_[me].count = std::uint32_t(e - b);
            return;
        }
        const int ax = cb.largest_axis();
        nodes_[me].axis = ax;
        const std::size_t mid = (b + e) / 2;
        std::nth_element(idx.begin() + std::ptrdiff_t(b), idx.begin() + std::ptrdiff_t(mid), idx.begin() + std::ptrdiff_t(e),
                         [&](std::uint32_t x, std::uint32_t y) { return inst_[x].c[ax] < inst_[y].c[ax]; });
        build(idx, b, mid);
        nodes_[me].offset = std::uint32_t(nodes_.size());
        build(idx, mid, e);
    }
    const Agg& agg_;
    float r_;
    std::vector<Inst> inst_;
    std::vector<Node> nodes_;
};

const InstanceBvh& explicit_bvh(int log10n) {
    static std::map<int, std::unique_ptr<InstanceBvh>> cache;
    auto& p = cache[log10n];
    if (!p) p = std::make_unique<InstanceBvh>(aggregate(log10n), boundary_radius(std::pow(10.0, log10n)));
    return *p;
}

}  // namespace

// Algorithm 1 (procedural); arg: log10 of the grain count.
static void BM_Procedural(benchmark::State& state) {
    const int lg = int(state.range(0));
    const Agg& agg = aggregate(lg);
    const Rays rays = make_rays(boundary_radius(std::pow(10.0, lg)), 4096);
    std::size_t i = 0, hits = 0;
    for (auto _ : state) {
        const AggregateHit h = agg.intersect(rays.o[i], rays.d[i], 0.0, 1e30);
        hits += h.hit;
        benchmark::DoNotOptimize(h);
        i = (i + 1) % rays.o.size();
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()));
    state.counters["grains_nominal"] = std::pow(10.0, lg);
    state.counters["memory_MB"] = double(agg.memory_bytes()) / 1e6;
    state.counters["hit_rate"] = double(hits) / double(state.iterations());
}
BENCHMARK(BM_Procedural)->DenseRange(3, 9, 1)->Unit(benchmark::kMicrosecond);

// Interior rays (paths inside the material); arg: log10 of the grain count.
static void BM_ProceduralInterior(benchmark::State& state) {
    const int lg = int(state.range(0));
    const Agg& agg = aggregate(lg);
    const Rays rays = make_interior_rays(boundary_radius(std::pow(10.0, lg)), 4096);
    std::size_t i = 0;
    for (auto _ : state) {
        const AggregateHit h = agg.intersect(rays.o[i], rays.d[i], 0.0, 1e30);
        benchmark::DoNotOptimize(h);
        i = (i + 1) % rays.o.size();
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()));
    state.counters["memory_MB"] = double(agg.memory_bytes()) / 1e6;
}
BENCHMARK(BM_ProceduralInterior)->Arg(3)->Arg(6)->Arg(9)->Unit(benchmark::kMicrosecond);

static void BM_ExplicitInterior(benchmark::State& state) {
    const int lg = int(state.range(0));
    const InstanceBvh& bvh = explicit_bvh(lg);
    const Rays rays = make_interior_rays(boundary_radius(std::pow(10.0, lg)), 4096);
    std::size_t i = 0;
    for (auto _ : state) {
        const AggregateHit h = bvh.intersect(rays.o[i], rays.d[i], 1e30);
        benchmark::DoNotOptimize(h);
        i = (i + 1) % rays.o.size();
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()));
    state.counters["memory_MB"] = double(bvh.memory_bytes()) / 1e6;
}
BENCHMARK(BM_ExplicitInterior)->Arg(3)->Arg(6)->Unit(benchmark::kMicrosecond);

// Two-level BVH over explicit instances of the same grains (where it fits: <= 1e6 grains).
static void BM_ExplicitInstances(benchmark::State& state) {
    const int lg = int(state.range(0));
    const InstanceBvh& bvh = explicit_bvh(lg);
    const Rays rays = make_rays(boundary_radius(std::pow(10.0, lg)), 4096);
    std::size_t i = 0, hits = 0;
    for (auto _ : state) {
        const AggregateHit h = bvh.intersect(rays.o[i], rays.d[i], 1e30);
        hits += h.hit;
        benchmark::DoNotOptimize(h);
        i = (i + 1) % rays.o.size();
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()));
    state.counters["grains"] = double(bvh.size());
    state.counters["memory_MB"] = double(bvh.memory_bytes()) / 1e6;
    state.counters["hit_rate"] = double(hits) / double(state.iterations());
}
BENCHMARK(BM_ExplicitInstances)->DenseRange(3, 6, 1)->Unit(benchmark::kMicrosecond);

// Consistency guard (not timed): both structures return the same first grain for 256 rays at 1e4.
static void BM_CheckSameHits(benchmark::State& state) {
    const Agg& agg = aggregate(4);
    const InstanceBvh& bvh = explicit_bvh(4);
    const Rays rays = make_rays(boundary_radius(1e4), 256);
    std::int64_t mismatches = 0;
    for (auto _ : state) {
        mismatches = 0;
        for (std::size_t k = 0; k < rays.o.size(); ++k) {
            const AggregateHit a = agg.intersect(rays.o[k], rays.d[k], 0.0, 1e30);
            const AggregateHit b = bvh.intersect(rays.o[k], rays.d[k], 1e30);
            mismatches += (a.hit != b.hit) || (a.hit && (a.grain.sphere != b.grain.sphere || a.grain.tile != b.grain.tile));
        }
    }
    state.counters["mismatches"] = double(mismatches);
}
BENCHMARK(BM_CheckSameHits)->Iterations(1);
