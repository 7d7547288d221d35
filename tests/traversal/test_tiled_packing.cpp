// Tests of grainlight/traversal/tiled_packing.hpp (Meng15 Algorithm 1) against brute force over
// explicit copies of the tile: every grain whose bounding-sphere centre is inside the boundary
// shape, instanced with the same (seed, tile, sphere) -> rotation/exemplar rule, intersected in
// world space.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/traversal/tiled_packing.hpp"

using namespace grainlight;

namespace {

// Two exemplar "grains" in the unit bounding sphere: 0 = sphere of radius 0.6 at (0.3, 0, 0)
// (off-centre, so the rotation matters), 1 = sphere of radius 0.9 at the origin.
const Vec3d grain_center[2] = {Vec3d(0.3, 0.0, 0.0), Vec3d(0.0)};
const double grain_radius[2] = {0.6, 0.9};

bool ray_sphere(const Vec3d& o, const Vec3d& d, const Vec3d& c, double r, double t0, double t1, double& t) {
    const Vec3d oc = o - c;
    const double A = glm::dot(d, d), B = glm::dot(oc, d), C = glm::dot(oc, oc) - r * r;
    const double disc = B * B - A * C;
    if (disc < 0) return false;
    const double ta = (-B - std::sqrt(disc)) / A, tb = (-B + std::sqrt(disc)) / A;
    if (ta >= t0 && ta <= t1) {
        t = ta;
        return true;
    }
    if (tb >= t0 && tb <= t1) {
        t = tb;
        return true;
    }
    return false;
}

// The intersector under test: works in the grain's local frame.
struct LocalGrains {
    int calls = 0;
    bool operator()(const TiledGrain& g, const GrainRay& r, double t0, double t1, double& t) {
        ++calls;
        return ray_sphere(r.o, r.d, grain_center[g.exemplar], grain_radius[g.exemplar], t0, t1, t);
    }
};

// An exactly classified axis-aligned box of tiles [lo, hi] (absolute tile indices) with a
// spherical bite: inside = in the box and farther than `bite` from the box's min corner.
struct BoxWithBite {
    enum class Class { outside, inside, partial };
    Vec3i64 lo, hi;
    double side, bite;
    [[nodiscard]] bool inside_world(const Vec3d& p) const {
        const Vec3d blo = Vec3d(lo) * side, bhi = Vec3d(hi + Vec3i64(1)) * side;
        for (int a = 0; a < 3; ++a)
            if (!(p[a] > blo[a] && p[a] < bhi[a])) return false;
        return glm::length(p - blo) > bite;
    }
    [[nodiscard]] Class classify(const Vec3i64& t) const {
        for (int a = 0; a < 3; ++a)
            if (t[a] < lo[a] || t[a] > hi[a]) return Class::outside;
        // Voxels within the bite's reach are partial; the rest are inside.
        const Vec3d far = (Vec3d(t - lo) + Vec3d(1.0)) * side;
        return glm::length(Vec3d(t - lo) * side) <= bite + 1e-12 || glm::length(far) <= bite ? Class::partial
                                                                                            : Class::inside;
    }
    [[nodiscard]] bool point_inside(const Vec3i64& t, const Vec3d& local) const {
        return inside_world(Vec3d(t) * side + local);
    }
};

template <class Packing, class InsideFn>
TiledHit brute_force(const Packing& pk, InsideFn&& inside_world, const Vec3d& o, const Vec3d& d, double t_min,
                     double t_max, const Vec3i64& tlo, const Vec3i64& thi, const Vec3i64& frame = Vec3i64(0)) {
    // Tiles t in [tlo, thi] relative to `frame` (absolute tile t + frame); positions in the frame.
    TiledHit best;
    const PeriodicTile& tile = pk.tile();
    for (long long z = tlo.z; z <= thi.z; ++z)
        for (long long y = tlo.y; y <= thi.y; ++y)
            for (long long x = tlo.x; x <= thi.x; ++x)
                for (std::uint32_t s = 0; s < tile.size(); ++s) {
                    const Vec3i64 t(x, y, z);
                    const Vec3d c = Vec3d(t) * tile.side() + tile.center(s);
                    if (!inside_world(c)) continue;
                    const TiledGrain g = pk.instance(s, t + frame, frame);
                    const Vec3d gc = c + tile.radius() * g.direction_to_world(grain_center[g.exemplar]);
                    double th;
                    if (ray_sphere(o, d, gc, tile.radius() * grain_radius[g.exemplar], t_min, t_max, th) &&
                        th < best.t) {
                        best.hit = true;
                        best.t = th;
                        best.grain = g;
                    }
                }
    return best;
}

PeriodicTile test_tile() {
    Rng rng = Rng::from_key(123);
    return random_sequential_addition(40, 0.3, rng, 1.0);
}

}  // namespace

TEST_CASE("grain instances: proper uniform rotations, exemplar frequencies, determinism", "[tiled]") {
    const TiledPacking<> pk(test_tile(), UnboundedAggregate{}, {1.0, 3.0}, 7);
    Vec3d mean_row0(0.0);
    double n1 = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        const TiledGrain g = pk.instance(std::uint32_t(i % 40), Vec3i64(i / 40, -i, 3));
        const auto& R = g.to_local;
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) REQUIRE(glm::dot(R[a], R[b]) == Approx(a == b ? 1.0 : 0.0).margin(1e-12));
        REQUIRE(glm::dot(glm::cross(R[0], R[1]), R[2]) == Approx(1.0));  // det = +1
        mean_row0 += R[0];
        n1 += g.exemplar == 1 ? 1 : 0;
    }
    // Uniform rotations: E[R] = 0 (each entry has variance 1/3 -> sd of the mean 0.004).
    CHECK(glm::length(mean_row0 / double(n)) < 0.02);
    // Exemplar 1 has probability 3/4 (binomial sd 0.003).
    CHECK(n1 / n == Approx(0.75).margin(0.015));
    // Deterministic, and depends on the seed.
    const TiledPacking<> pk2(test_tile(), UnboundedAggregate{}, {1.0, 3.0}, 8);
    CHECK(pk.instance(5, Vec3i64(1, 2, 3)).to_local[0] == pk.instance(5, Vec3i64(1, 2, 3)).to_local[0]);
    CHECK(pk.instance(5, Vec3i64(1, 2, 3)).to_local[0] != pk2.instance(5, Vec3i64(1, 2, 3)).to_local[0]);
    CHECK_THROWS_AS(TiledPacking<>(test_tile(), UnboundedAggregate{}, {}, 1), invalid_argument);
    CHECK_THROWS_AS(TiledPacking<>(test_tile(), UnboundedAggregate{}, {1.0, -1.0}, 1), invalid_argument);
}

TEST_CASE("Algorithm 1 in an unbounded aggregate agrees with brute force", "[tiled]") {
    const TiledPacking<> pk(test_tile(), UnboundedAggregate{}, {1.0, 1.0}, 3);
    Rng rng = Rng::from_key(5);
    int hits = 0;
    for (int k = 0; k < 300; ++k) {
        const Vec3d o(rng.uniform<double>() * 2, rng.uniform<double>() * 2, rng.uniform<double>() * 2);
        const Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>());
        const double t_min = k % 2 ? 0.0 : rng.uniform<double>() * 0.3, t_max = t_min + 1.2 * rng.uniform<double>();
        LocalGrains lg;
        const TiledHit a = pk.intersect(Vec3i64(0, 0, 0), o, d, t_min, t_max, lg);
        const TiledHit b = brute_force(pk, [](const Vec3d&) { return true; }, o, d, t_min, t_max, Vec3i64(-2),
                                       Vec3i64(4));
        REQUIRE(a.hit == b.hit);
        if (!a.hit) continue;
        ++hits;
        CHECK(a.t == Approx(b.t).margin(1e-9));
        CHECK(a.grain.sphere == b.grain.sphere);
        CHECK(a.grain.tile == b.grain.tile);
        CHECK(a.grain.exemplar == b.grain.exemplar);
        CHECK(a.t >= a.grain.t_enter);
        CHECK(a.t <= a.grain.t_exit);
        // The hit point in the grain frame lies on the exemplar's surface.
        const Vec3d pl = a.grain.point_to_local(o + a.t * d);
        CHECK(glm::length(pl - grain_center[a.grain.exemplar]) == Approx(grain_radius[a.grain.exemplar]).epsilon(1e-9));
        CHECK(glm::length(a.grain.point_to_world(pl) - (o + a.t * d)) < 1e-12);
        // The Ray<F> overload agrees.
        if (t_min == 0.0) {
            LocalGrains lg2;
            const TiledHit c = pk.intersect(Rayd(o, d), 0.0, t_max, lg2);
            CHECK(c.t == a.t);
        }
    }
    CHECK(hits > 50);
}

TEST_CASE("Algorithm 1 with a voxelized boundary agrees with brute force", "[tiled]") {
    // Exactly classified box-with-bite and geometry's VoxelizedBoundary<SphereBoundary>, both
    // anchored far from the origin; rays from outside and inside the aggregate.
    const Vec3i64 anchor(1000000, -5, 2);
    const BoxWithBite box{anchor + Vec3i64(-2), anchor + Vec3i64(1), 1.0, 1.7};
    const TiledPacking<BoxWithBite> pk_box(test_tile(), box, {1.0, 1.0}, 11);
    const SphereBoundary shape(Vec3d(0.3, 0.2, -0.1), 2.2);
    const VoxelizedBoundary<SphereBoundary> vox(shape, 1.0, anchor);
    const TiledPacking<VoxelizedBoundary<SphereBoundary>> pk_sph(test_tile(), vox, {2.0, 1.0}, 12);

    Rng rng = Rng::from_key(17);
    int hits_box = 0, hits_sph = 0;
    std::uint64_t skipped = 0;
    for (int k = 0; k < 150; ++k) {
        // Origin in tile `anchor` frame: offsets within +-5 tiles; aim roughly at the aggregate.
        const Vec3d o(rng.uniform<double>() * 10 - 5, rng.uniform<double>() * 10 - 5, rng.uniform<double>() * 10 - 5);
        const Vec3d target(rng.uniform<double>() * 3 - 1.5, rng.uniform<double>() * 3 - 1.5,
                           rng.uniform<double>() * 3 - 1.5);
        const Vec3d d = k % 5 == 0 ? sample_uniform_sphere<double>(rng.uniform2<double>()) : glm::normalize(target - o);
        const double t_max = k % 3 == 0 ? std::numeric_limits<double>::infinity() : 20.0;
        const Vec3d o_world = o;  // brute force works in the anchor frame
        {
            LocalGrains lg;
            TiledTraversalStats st;
            const TiledHit a = pk_box.intersect(anchor, o, d, 0.0, t_max, lg, &st);
            skipped += st.voxels_skipped;
            const TiledHit b = brute_force(
                pk_box, [&](const Vec3d& c) { return box.inside_world(c + Vec3d(anchor) * 1.0); }, o_world, d, 0.0,
                std::min(t_max, 40.0), Vec3i64(-3), Vec3i64(2), anchor);
            REQUIRE(a.hit == b.hit);
            if (a.hit) {
                ++hits_box;
                CHECK(a.t == Approx(b.t).margin(1e-9));
                CHECK(a.grain.sphere == b.grain.sphere);
                CHECK(a.grain.tile == b.grain.tile);
            }
        }
        {
            LocalGrains lg;
            const TiledHit a = pk_sph.intersect(anchor, o, d, 0.0, t_max, lg);
            const TiledHit b = brute_force(pk_sph, [&](const Vec3d& c) { return shape.inside(c); }, o_world, d, 0.0,
                                           std::min(t_max, 40.0), Vec3i64(-4), Vec3i64(3), anchor);
            REQUIRE(a.hit == b.hit);
            if (a.hit) {
                ++hits_sph;
                CHECK(a.t == Approx(b.t).margin(1e-9));
                CHECK(a.grain.sphere == b.grain.sphere);
                CHECK(a.grain.tile == b.grain.tile);
            }
        }
    }
    CHECK(hits_box > 30);
    CHECK(hits_sph > 30);
    CHECK(skipped > 0);  // outside voxels were skipped, and results still match brute force
}

TEST_CASE("the reach grid answers what the 27 neighbour classes say", "[tiled]") {
    // TiledPacking precomputes, for a classifier with a tile range, one bit per tile: is the tile
    // or one of its 26 neighbours not outside? Compared here with the definition, by 27 calls to
    // the classifier, on every tile of the range grown by three, for a voxelized sphere far from
    // the origin and an off-centre one that crosses tile boundaries differently.
    for (const auto& [centre, radius] : {std::pair{Vec3d(0.3, 0.2, -0.1), 2.2}, std::pair{Vec3d(-1.7, 4.1, 0.6), 3.4}}) {
        const Vec3i64 anchor(-7000000, 12, 3);
        const SphereBoundary shape(centre, radius);
        const VoxelizedBoundary<SphereBoundary> vox(shape, 1.0, anchor);
        const TiledPacking<VoxelizedBoundary<SphereBoundary>> pk(test_tile(), vox, {1.0}, 3);
        REQUIRE(pk.reach_bytes() > 0);
        const Vec3i64 lo = vox.tile_lo(), hi = vox.tile_hi();
        std::size_t reachable = 0, total = 0;
        for (std::int64_t z = lo.z - 3; z <= hi.z + 3; ++z)
            for (std::int64_t y = lo.y - 3; y <= hi.y + 3; ++y)
                for (std::int64_t x = lo.x - 3; x <= hi.x + 3; ++x) {
                    bool expect = false;
                    for (int dz = -1; dz <= 1; ++dz)
                        for (int dy = -1; dy <= 1; ++dy)
                            for (int dx = -1; dx <= 1; ++dx)
                                expect |= vox.classify(Vec3i64(x + dx, y + dy, z + dz)) != VoxelClass::outside;
                    REQUIRE(pk.tile_reachable(Vec3i64(x, y, z)) == expect);
                    reachable += expect;
                    ++total;
                }
        CHECK(reachable > 27);
        CHECK(reachable < total);
    }
}

TEST_CASE("bit sets shifted and OR-ed word by word equal the bit-by-bit shift", "[tiled]") {
    // detail::or_shifted_bits dilates the reach grid; checked against a shift of single bits for
    // shifts below, at and above a word (0, 1, 63, 64, 65, 128, 200) in both directions.
    Rng rng = Rng::from_key(31);
    const std::size_t nbits = 64 * 7;
    std::vector<std::uint64_t> src(7), dst0(7);
    for (auto& w : src) w = rng.next_u64() & rng.next_u64();
    for (auto& w : dst0) w = rng.next_u64() & rng.next_u64() & rng.next_u64();
    auto bit = [](const std::vector<std::uint64_t>& v, std::size_t i) { return (v[i / 64] >> (i % 64)) & 1u; };
    for (const std::size_t s : {0u, 1u, 63u, 64u, 65u, 128u, 200u})
        for (const bool up : {true, false}) {
            std::vector<std::uint64_t> got = dst0;
            detail::or_shifted_bits(got, src, s, up);
            for (std::size_t i = 0; i < nbits; ++i) {
                std::uint64_t want = bit(dst0, i);
                if (up && i >= s) want |= bit(src, i - s);
                if (!up && i + s < nbits) want |= bit(src, i + s);
                REQUIRE(bit(got, i) == want);
            }
        }
}
