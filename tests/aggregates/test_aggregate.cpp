// Procedural aggregates (Meng15 Secs. 3.1-3.2, Algorithm 1): first hits against brute force over
// explicitly listed instances, deterministic instancing, bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/traversal/aggregate.hpp"

using namespace grainlight;

namespace {

PeriodicTile small_tile(double side = 2.0) {
    Rng rng = Rng::from_key(11, 0, 0);
    return random_sequential_addition(24, 0.3, rng, side);
}

std::vector<GrainExemplar> three_exemplars() {
    return {GrainExemplar::sphere(0.8, GrainMaterial::make_dielectric(1.5)),
            GrainExemplar::procedural(GrainShape::snow, 1.0, GrainMaterial::make_dielectric(1.31), 7, 3),
            GrainExemplar::procedural(GrainShape::crystal, 0.95, GrainMaterial::make_diffuse(RGBd(0.8)), 3, 3)};
}

struct Explicit {
    AggregateGrain g;
    Vec3d c;
};

/// Brute force: first hit over every listed grain (ray-sphere bound, then the instance).
template <class Agg>
AggregateHit brute_force(const Agg& agg, const std::vector<Explicit>& grains, const Vec3d& o, const Vec3d& d, double t_min,
                         double t_max) {
    AggregateHit best;
    const double R = agg.grain_radius();
    for (const auto& e : grains) {
        const auto roots = intersect_sphere(o, d, e.c, R);
        if (!roots || roots.t_far <= t_min || roots.t_near >= std::min(t_max, best.t)) continue;
        const auto h = agg.intersect_grain(e.g, o, d, std::max(t_min, roots.t_near), std::min({t_max, best.t, roots.t_far}));
        if (h && h.t < best.t) best = h;
    }
    return best;
}

}  // namespace

TEST_CASE("Algorithm 1 finds the same first grain hit as brute force over explicit instances", "[aggregates][alg1]") {
    using U = UnionBoundary<SphereBoundary, BoxBoundary>;
    for (const Vec3i64 anchor : {Vec3i64(0, 0, 0), Vec3i64(1000000, -3000000, 7)}) {
        const U shape{SphereBoundary(Vec3d(0.1, 0.2, -0.3), 4.3), BoxBoundary(Vec3d(2.5, -2.0, -2.0), Vec3d(8.0, 1.0, 1.5))};
        PeriodicTile tile = small_tile();
        GranularAggregate<U> agg(tile, VoxelizedBoundary<U>(shape, tile.side(), anchor), three_exemplars(), {0.5, 0.3, 0.2}, 5);
        std::vector<Explicit> grains;
        agg.for_each_grain(Vec3d(-6.0), Vec3d(10.0, 6.0, 6.0), [&](const AggregateGrain& g, const Vec3d& c) { grains.push_back({g, c}); });
        REQUIRE(grains.size() == agg.grain_count());
        REQUIRE(grains.size() > 300);
        Rng rng = Rng::from_key(21, 22, std::uint64_t(anchor.x));
        int hits = 0, n_rays = 3000;
        for (int i = 0; i < n_rays; ++i) {
            // Half the rays start outside the aggregate, half inside (between or in spheres).
            Vec3d o;
            if (i % 2 == 0)
                o = Vec3d(2.0, 0.0, 0.0) + 14.0 * sample_uniform_sphere(rng.uniform2<double>());
            else
                o = Vec3d(-4 + 12 * rng.uniform<double>(), -4 + 8 * rng.uniform<double>(), -4 + 8 * rng.uniform<double>());
            Vec3d d = sample_uniform_sphere(rng.uniform2<double>());
            if (i % 2 == 0) d = glm::normalize(Vec3d(2.0, 0.0, 0.0) + 3.0 * sample_uniform_sphere(rng.uniform2<double>()) - o);
            if (i % 7 == 0) d = Vec3d(1.0, 0.0, 0.0);  // axis-aligned rays exercise the DDA ties
            const double t_max = (i % 5 == 0) ? 3.0 : 1e3;
            const AggregateHit a = agg.intersect(o, d, 0.0, t_max);
            const AggregateHit b = brute_force(agg, grains, o, d, 0.0, t_max);
            REQUIRE(a.hit == b.hit);
            if (a.hit) {
                ++hits;
                REQUIRE(a.grain.sphere == b.grain.sphere);
                REQUIRE(a.grain.tile == b.grain.tile);
                REQUIRE(a.t == Approx(b.t).margin(1e-9));
            }
        }
        REQUIRE(hits > n_rays / 4);
        REQUIRE(hits < n_rays);
    }
}

TEST_CASE("Algorithm 1 with a triangle-mesh boundary (a lumpy blob) agrees with brute force", "[aggregates][alg1]") {
    // The boundary: a procedural snow-grain mesh scaled to radius 5 (star-shaped, concave lumps).
    TriangleMesh<float> blob = make_grain_mesh<float>(GrainShape::snow, 5.0f, 3, 3);
    PeriodicTile tile = small_tile();
    GranularAggregate<MeshBoundary> agg(tile, VoxelizedBoundary<MeshBoundary>(MeshBoundary(blob), tile.side()),
                                        three_exemplars(), {0.2, 0.5, 0.3}, 8);
    std::vector<Explicit> grains;
    agg.for_each_grain(Vec3d(-7.0), Vec3d(7.0), [&](const AggregateGrain& g, const Vec3d& c) {
        REQUIRE(agg.boundary().shape().inside(c));  // footnote 1: centre inside the mesh
        grains.push_back({g, c});
    });
    REQUIRE(grains.size() == agg.grain_count());
    REQUIRE(grains.size() > 200);
    Rng rng = Rng::from_key(41, 0, 0);
    int hits = 0;
    for (int i = 0; i < 1500; ++i) {
        const Vec3d o = i % 2 ? 12.0 * sample_uniform_sphere(rng.uniform2<double>())
                              : 4.0 * rng.uniform<double>() * sample_uniform_sphere(rng.uniform2<double>());
        const Vec3d d = i % 2 ? glm::normalize(3.0 * sample_uniform_sphere(rng.uniform2<double>()) - o)
                              : sample_uniform_sphere(rng.uniform2<double>());
        const AggregateHit a = agg.intersect(o, d, 0.0, 100.0);
        const AggregateHit b = brute_force(agg, grains, o, d, 0.0, 100.0);
        REQUIRE(a.hit == b.hit);
        if (a.hit) {
            ++hits;
            REQUIRE(a.grain.sphere == b.grain.sphere);
            REQUIRE(a.grain.tile == b.grain.tile);
            REQUIRE(a.t == Approx(b.t).margin(1e-9));
        }
    }
    REQUIRE(hits > 500);
}

TEST_CASE("deterministic instancing: the same grain for a sphere from any ray", "[aggregates][alg1]") {
    PeriodicTile tile = small_tile();
    const SphereBoundary shape(Vec3d(0.0), 5.0);
    GranularAggregate<SphereBoundary> agg(tile, VoxelizedBoundary<SphereBoundary>(shape, tile.side()), three_exemplars(),
                                          {1.0, 1.0, 1.0}, 9);
    Rng rng = Rng::from_key(31, 0, 0);
    int checked = 0;
    std::array<int, 3> exemplar_counts{};
    for (int i = 0; i < 1000; ++i) {
        const Vec3d o = 20.0 * sample_uniform_sphere(rng.uniform2<double>());
        const Vec3d d = glm::normalize(rng.uniform3<double>() - 0.5 - o / 20.0);
        const AggregateHit a = agg.intersect(o, d, 0.0, 100.0);
        if (!a) continue;
        const Vec3d p = o + a.t * d;
        // Re-shoot at the hit point from a different origin (outside the grain's side of the
        // tangent plane): the same grain, the same instance, the same point.
        Vec3d w = sample_uniform_sphere(rng.uniform2<double>());
        if (glm::dot(w, a.n) < 0.2) w = glm::normalize(w + 2.0 * a.n);
        const Vec3d o2 = p + 1e-3 * w;
        const AggregateHit b = agg.intersect(o2, -w, 0.0, 1.0);
        REQUIRE(b.hit);
        REQUIRE(b.grain.tile == a.grain.tile);
        REQUIRE(b.grain.sphere == a.grain.sphere);
        REQUIRE(b.grain.exemplar == a.grain.exemplar);
        REQUIRE(b.grain.rotation.r0 == a.grain.rotation.r0);
        REQUIRE(glm::length(o2 - b.t * w - p) < 1e-4);
        const AggregateGrain again = agg.instance(a.grain.tile, a.grain.sphere);
        REQUIRE(again.rotation.r2 == a.grain.rotation.r2);
        ++exemplar_counts[a.grain.exemplar];
        ++checked;
    }
    REQUIRE(checked > 100);
    // Mixing weights 1:1:1 -> every exemplar appears.
    for (int c : exemplar_counts) REQUIRE(c > 10);
    // Instancing statistics: exemplar frequencies follow the mixing weights (3 sigma binomial).
    GranularAggregate<SphereBoundary> agg2(tile, VoxelizedBoundary<SphereBoundary>(shape, tile.side()), three_exemplars(),
                                           {0.6, 0.3, 0.1}, 4);
    std::array<double, 3> n{};
    const int total = 30000;
    for (int i = 0; i < total; ++i) ++n[agg2.instance(Vec3i64(i, -i / 7, i / 13), std::uint32_t(i % 24)).exemplar];
    const double w[3] = {0.6, 0.3, 0.1};
    for (int k = 0; k < 3; ++k) REQUIRE(std::abs(n[k] / total - w[k]) < 3 * std::sqrt(w[k] * (1 - w[k]) / total) + 1e-3);
}

TEST_CASE("aggregate: memory independent of the grain count, counts scale with volume", "[aggregates][alg1]") {
    PeriodicTile tile = small_tile();
    std::size_t mem_small = 0, mem_big = 0;
    std::uint64_t n_small = 0, n_big = 0;
    {
        GranularAggregate<SphereBoundary> a(tile, VoxelizedBoundary<SphereBoundary>(SphereBoundary(Vec3d(0.0), 4.0), 2.0),
                                            three_exemplars(), {1, 1, 1});
        mem_small = a.memory_bytes() - a.boundary().memory_bytes() - a.boundary().refinement_bytes() - a.packing().reach_bytes();
        n_small = a.grain_count();
    }
    {
        GranularAggregate<SphereBoundary> a(tile, VoxelizedBoundary<SphereBoundary>(SphereBoundary(Vec3d(0.0), 16.0), 2.0),
                                            three_exemplars(), {1, 1, 1});
        mem_big = a.memory_bytes() - a.boundary().memory_bytes() - a.boundary().refinement_bytes() - a.packing().reach_bytes();
        n_big = a.grain_count();
    }
    REQUIRE(mem_small == mem_big);
    // Grain count ~ number density x volume (24 spheres per 8 unit^3 tile).
    const double vol = 4.0 / 3.0 * 3.141592653589793 * 16.0 * 16.0 * 16.0;
    REQUIRE(double(n_big) == Approx(vol * 24.0 / 8.0).epsilon(0.02));
    REQUIRE(double(n_big) / double(n_small) == Approx(64.0).epsilon(0.1));
}

TEST_CASE("aggregate: bad input is a clear error", "[aggregates][alg1]") {
    PeriodicTile tile = small_tile();
    const SphereBoundary shape(Vec3d(0.0), 3.0);
    SECTION("empty mixing weights") {
        REQUIRE_THROWS_AS(GranularAggregate<SphereBoundary>(tile, VoxelizedBoundary<SphereBoundary>(shape, 2.0), three_exemplars(), {}),
                          grainlight::invalid_argument);
    }
    SECTION("weights / exemplars mismatch, negative weight, zero sum") {
        REQUIRE_THROWS_AS(GranularAggregate<SphereBoundary>(tile, VoxelizedBoundary<SphereBoundary>(shape, 2.0), three_exemplars(), {1, 2}),
                          grainlight::invalid_argument);
        REQUIRE_THROWS_AS(
            GranularAggregate<SphereBoundary>(tile, VoxelizedBoundary<SphereBoundary>(shape, 2.0), three_exemplars(), {1, -2, 1}),
            grainlight::invalid_argument);
        REQUIRE_THROWS_AS(
            GranularAggregate<SphereBoundary>(tile, VoxelizedBoundary<SphereBoundary>(shape, 2.0), three_exemplars(), {0, 0, 0}),
            grainlight::invalid_argument);
    }
    SECTION("grain larger than its bounding sphere") {
        REQUIRE_THROWS_AS(GrainExemplar::sphere(1.2, GrainMaterial::make_dielectric(1.5)), grainlight::invalid_argument);
        TriangleMesh<float> big = make_grain_mesh<float>(GrainShape::snow, 1.3f, 1, 2);
        REQUIRE_THROWS_AS(GrainExemplar::mesh(big, GrainMaterial::make_dielectric(1.5)), grainlight::invalid_argument);
    }
    SECTION("boundary voxelized on another grid") {
        REQUIRE_THROWS_AS(GranularAggregate<SphereBoundary>(tile, VoxelizedBoundary<SphereBoundary>(shape, 1.0), three_exemplars(), {1, 1, 1}),
                          grainlight::invalid_argument);
    }
}
