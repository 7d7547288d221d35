// Tests of PeriodicTile::walk_spheres (packing/periodic_tile.hpp), the single-walk sphere
// enumeration under Meng15 Algorithm 1 (traversal/tiled_packing.hpp): it must report exactly the
// spheres, in the same order and with bit-identical entry / exit parameters, that the reference
// enumeration reports (PeriodicTile::first_hit restarted at each hit's exit, the documented way to
// continue past a hit), for unit and non-unit directions, finite and infinite t_max, origins far
// from tile 0; a tile filter must only remove spheres (order kept), never one whose chord
// midpoint lies in an accepted tile.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>
#include <type_traits>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/packing/poisson.hpp"

using namespace grainlight;

namespace {

std::vector<TileHit> by_first_hit(const PeriodicTile& tile, const Vec3i64& ot, const Vec3d& o, const Vec3d& d,
                                  double t_min, double t_max, std::size_t cap) {
    std::vector<TileHit> out;
    double s = t_min;
    while (out.size() < cap) {
        const TileHit h = tile.first_hit(ot, o, d, s, t_max);
        if (!h) break;
        out.push_back(h);
        s = h.t_exit;
    }
    return out;
}

bool same(const TileHit& a, const TileHit& b) {
    return a.sphere == b.sphere && a.tile == b.tile && a.t_enter == b.t_enter && a.t_exit == b.t_exit;
}

// What a tile filter may do to the spheres of a walk: `got` (the filtered walk) is a subsequence
// of `all` (repeated first_hit, unfiltered), and every sphere of `all` whose chord midpoint within
// [0, t_max] lies clearly inside a tile the filter accepts is in `got`.
template <class Accepted>
void check_filtered(const std::vector<TileHit>& all, const std::vector<TileHit>& got, const Vec3i64& ot,
                    const Vec3d& o, const Vec3d& d, double t_max, double L, Accepted&& accepted) {
    std::size_t j = 0;
    for (const TileHit& h : got) {
        while (j < all.size() && !same(all[j], h)) ++j;
        REQUIRE(j < all.size());
        ++j;
    }
    for (const TileHit& h : all) {
        const Vec3d p = o + 0.5 * (std::max(h.t_enter, 0.0) + std::min(h.t_exit, t_max)) * d;
        Vec3i64 t = ot;
        bool near_face = false;
        for (int a = 0; a < 3; ++a) {
            const double q = p[a] / L;
            t[a] += static_cast<std::int64_t>(std::floor(q));
            near_face |= std::abs(q - std::round(q)) < 1e-9;
        }
        if (near_face || !accepted(t)) continue;
        bool found = false;
        for (const TileHit& g : got) found |= same(g, h);
        CHECK(found);
    }
}

}  // namespace

TEST_CASE("walk_spheres reports the spheres of repeated first_hit, bit for bit", "[tile][walk]") {
    // Two tiles: dense (0.45, 60 spheres, many spheres per query cell) and sparse (0.2, 20).
    for (const auto& [fraction, n, key] : {std::tuple{0.34, std::size_t(60), 31u}, std::tuple{0.2, std::size_t(20), 32u}}) {
        Rng trng = Rng::from_key(key);
        const PeriodicTile tile = random_sequential_addition(n, fraction, trng, 1.0);
        Rng rng = Rng::from_key(key + 100);
        std::size_t total = 0;
        for (int k = 0; k < 400; ++k) {
            const Vec3i64 ot = k % 2 ? Vec3i64(0) : Vec3i64(1000000007, -42, 3);
            const Vec3d o(rng.uniform<double>() * 3 - 1, rng.uniform<double>() * 3 - 1, rng.uniform<double>() * 3 - 1);
            Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>());
            if (k % 7 == 0) d *= 3.7;                        // non-unit direction
            if (k % 11 == 0) d = Vec3d(0.0, 0.0, d.z);       // along an axis (two zero components)
            const double t_min = k % 5 == 0 ? 0.37 : 0.0;
            const double t_max = k % 3 == 0 ? std::numeric_limits<double>::infinity() : 6.0;
            const std::size_t cap = 60;
            const std::vector<TileHit> ref = by_first_hit(tile, ot, o, d, t_min, t_max, cap);
            // The default candidate list, and lists of 1 and 2 that overflow all the time (the
            // rescan path).
            auto check_walk = [&](auto capacity) {
                std::vector<TileHit> got;
                const bool stopped = tile.template walk_spheres<decltype(capacity)::value>(
                    ot, o, d, t_min, t_max, [](const Vec3i64&) { return true; },
                    [&](const TileHit& h) {
                        got.push_back(h);
                        return got.size() >= cap;
                    });
                CHECK(stopped == (got.size() >= cap));
                REQUIRE(got.size() == ref.size());
                for (std::size_t i = 0; i < ref.size(); ++i) {
                    INFO("ray " << k << " sphere " << i << " list capacity " << decltype(capacity)::value);
                    CHECK(same(got[i], ref[i]));
                }
            };
            check_walk(std::integral_constant<int, 8>{});
            check_walk(std::integral_constant<int, 1>{});
            check_walk(std::integral_constant<int, 2>{});
            total += ref.size();
        }
        CHECK(total > 2000);  // the rays met many spheres (the comparison is not vacuous)
    }
}

TEST_CASE("walk_spheres with a tile filter only drops spheres of rejected tiles", "[tile][walk]") {
    Rng trng = Rng::from_key(41);
    const PeriodicTile tile = random_sequential_addition(50, 0.33, trng, 1.0);
    const double L = tile.side();
    // Reject tiles with an odd coordinate sum (a checkerboard).
    auto accepted = [](const Vec3i64& t) { return ((t.x + t.y + t.z) & 1) == 0; };
    Rng rng = Rng::from_key(42);
    std::size_t dropped = 0, kept = 0, visits_rejected = 0;
    for (int k = 0; k < 300; ++k) {
        const Vec3i64 ot(-5, 17, 123456789);
        const Vec3d o(rng.uniform<double>() * L, rng.uniform<double>() * L, rng.uniform<double>() * L);
        const Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>());
        const std::vector<TileHit> all = by_first_hit(tile, ot, o, d, 0.0, 8.0, 1000);
        std::vector<TileHit> got;
        (void)tile.walk_spheres(
            ot, o, d, 0.0, 8.0,
            [&](const Vec3i64& t) {
                visits_rejected += !accepted(t);
                return accepted(t);
            },
            [&](const TileHit& h) {
                got.push_back(h);
                return false;
            });
        check_filtered(all, got, ot, o, d, 8.0, L, accepted);
        kept += got.size();
        dropped += all.size() - got.size();
    }
    CHECK(kept > 500);
    CHECK(dropped > 100);        // the filter did remove spheres
    CHECK(visits_rejected > 100);
}

TEST_CASE("walk_spheres jumps over rejected tiles: every tile the ray crosses is offered, in order, once",
          "[tile][walk]") {
    // A rejected tile with no pending candidate is crossed in one jump (not cell by cell). The
    // tiles offered to the filter must still be the tiles the ray crosses, in order: found here
    // by sampling the ray every 1e-4 tile sides. Tiles the ray only grazes (a dwell below 1e-3
    // tile sides, e.g. a corner) may be skipped; no other tile may be offered. Half the tiles are
    // rejected (a hash), so runs of rejected tiles alternate with searched ones.
    Rng trng = Rng::from_key(43);
    const PeriodicTile tile = random_sequential_addition(50, 0.33, trng, 1.0);
    const double L = tile.side();
    auto accepted = [](const Vec3i64& t) {
        const std::uint64_t h = (std::uint64_t(t.x) * 0x9E3779B97F4A7C15ull) ^ (std::uint64_t(t.y) * 0xC2B2AE3D27D4EB4Full) ^
                                (std::uint64_t(t.z) * 0x165667B19E3779F9ull);
        return ((h >> 29) & 1u) == 0;
    };
    Rng rng = Rng::from_key(44);
    std::size_t offered_total = 0, rejected_total = 0;
    for (int k = 0; k < 200; ++k) {
        const Vec3i64 ot(3, -9, 987654321);
        const Vec3d o(rng.uniform<double>() * L, rng.uniform<double>() * L, rng.uniform<double>() * L);
        Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>());
        if (k % 10 == 0) d = glm::normalize(Vec3d(1.0, 1e-3 * rng.uniform<double>(), 0.0));  // nearly axis-aligned
        const double t_max = 12.0 * L;
        std::vector<Vec3i64> offered;
        std::vector<TileHit> got;
        (void)tile.walk_spheres(
            ot, o, d, 0.0, t_max,
            [&](const Vec3i64& t) {
                offered.push_back(t);
                return accepted(t);
            },
            [&](const TileHit& h) {
                got.push_back(h);
                return false;
            });
        // The crossed tiles with their entry and dwell lengths, by sampling (past t_max: the walk
        // may offer the tile it steps into when it leaves the last one).
        struct Crossed {
            Vec3i64 tile;
            double t0, dwell;
        };
        std::vector<Crossed> crossed;
        const double dt = 1e-4 * L;
        for (double s = 0; s <= t_max + 2 * L; s += dt) {
            const Vec3d p = o + s * d;
            Vec3i64 t = ot;
            for (int a = 0; a < 3; ++a) t[a] += static_cast<std::int64_t>(std::floor(p[a] / L));
            if (crossed.empty() || !(crossed.back().tile == t)) crossed.push_back({t, s, 0.0});
            crossed.back().dwell += dt;
        }
        std::size_t j = 0;
        for (const auto& [t, t0, dwell] : crossed) {
            const std::size_t j0 = j;
            while (j < offered.size() && !(offered[j] == t)) ++j;
            if (dwell > 1e-3 * L && t0 < t_max - 1e-3 * L) REQUIRE(j < offered.size());  // every crossing, in order
            if (j == offered.size()) j = j0;  // a grazed tile that was not offered
            else ++j;
        }
        for (const Vec3i64& t : offered) {  // nothing else is offered
            bool known = false;
            for (const auto& c : crossed) known |= c.tile == t;
            CHECK(known);
        }
        // The spheres are those of repeated first_hit whose chord meets an accepted tile.
        const std::vector<TileHit> all = by_first_hit(tile, ot, o, d, 0.0, t_max, 4000);
        check_filtered(all, got, ot, o, d, t_max, L, accepted);
        offered_total += offered.size();
        for (const Vec3i64& t : offered) rejected_total += !accepted(t);
    }
    CHECK(offered_total > 1000);
    CHECK(rejected_total > 300);
}

TEST_CASE("floor_i64 is the exact floor, saturated; walk_spheres' tile split agrees with floor_div", "[tile][walk]") {
    // Closed forms: floor of integers, of values just off them, of negatives, saturation.
    using detail::floor_i64;
    CHECK(floor_i64(0.0) == 0);
    CHECK(floor_i64(-0.0) == 0);
    CHECK(floor_i64(2.999) == 2);
    CHECK(floor_i64(-0.5) == -1);
    CHECK(floor_i64(-1.0) == -1);
    CHECK(floor_i64(-1.0000000000000002) == -2);
    CHECK(floor_i64(std::nextafter(3.0, 0.0)) == 2);
    CHECK(floor_i64(-std::ldexp(1.0, 53) + 2) == -(std::int64_t(1) << 53) + 2);
    CHECK(floor_i64(std::ldexp(1.0, 60)) == std::int64_t(1) << 60);
    CHECK(floor_i64(1e19) == std::int64_t(1) << 62);
    CHECK(floor_i64(-1e19) == -(std::int64_t(1) << 62));
    CHECK(floor_i64(std::numeric_limits<double>::quiet_NaN()) == -(std::int64_t(1) << 62));
    Rng rng = Rng::from_key(77);
    for (int i = 0; i < 10000; ++i) {
        const double x = (rng.uniform<double>() - 0.5) * std::ldexp(1.0, int(rng.uniform<double>() * 60));
        REQUIRE(double(floor_i64(x)) == std::floor(x));
    }
    // A ray starting far along its line (t_min of many tiles, negative and positive coordinates)
    // reports the spheres of repeated first_hit: the walk's tile / cell split is floor_div's.
    Rng trng = Rng::from_key(78);
    const PeriodicTile tile = random_sequential_addition(30, 0.3, trng, 1.0);
    for (int k = 0; k < 200; ++k) {
        const Vec3d o(rng.uniform<double>() * 3, rng.uniform<double>() * 3, rng.uniform<double>() * 3);
        const Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>());
        const double t_min = tile.side() * (1 + 40 * rng.uniform<double>()) + (k % 2 ? 0.0 : tile.side() / 7);
        // No cap on the reference: a walk of length 8 here crosses about 14 spheres, sometimes more
        // than 20 (a capped reference was the defect of an earlier version of this test).
        const std::vector<TileHit> ref = by_first_hit(tile, Vec3i64(0), o, d, t_min, t_min + 8, 100000);
        std::vector<TileHit> got;
        tile.walk_spheres(Vec3i64(0), o, d, t_min, t_min + 8, [](const Vec3i64&) { return true; },
                          [&](const TileHit& h) {
                              got.push_back(h);
                              return false;
                          });
        REQUIRE(got.size() == ref.size());
        for (std::size_t i = 0; i < ref.size(); ++i) CHECK(same(got[i], ref[i]));
    }
}
