// Tests of grainlight/packing/periodic_tile.hpp: validation, queries on the infinite tiling
// against brute force over explicit tile copies, and file round trip / damage.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <tuple>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/packing/poisson.hpp"

using namespace grainlight;

namespace {

using Key = std::tuple<std::uint32_t, long long, long long, long long>;

// Brute force: first sphere along o + t d over explicit copies of the tile in tiles [t0, t1]^3.
TileHit brute_first_hit(const PeriodicTile& tile, const Vec3d& o, const Vec3d& d, double t_min, double t_max, int lo,
                        int hi) {
    TileHit best;
    const double r = tile.radius();
    for (int tz = lo; tz <= hi; ++tz)
        for (int ty = lo; ty <= hi; ++ty)
            for (int tx = lo; tx <= hi; ++tx)
                for (std::size_t s = 0; s < tile.size(); ++s) {
                    const Vec3d c = tile.center(s) + Vec3d(tx, ty, tz) * tile.side();
                    // Textbook quadratic (independent of PeriodicTile::intersect_sphere).
                    const Vec3d oc = o - c;
                    const double A = glm::dot(d, d), B = glm::dot(oc, d), C = glm::dot(oc, oc) - r * r;
                    const double disc = B * B - A * C;
                    if (disc < 0) continue;
                    const double t0 = (-B - std::sqrt(disc)) / A, t1 = (-B + std::sqrt(disc)) / A;
                    if (!(t1 > t_min) || t0 > t_max || !(t0 < best.t_enter)) continue;
                    best.hit = true;
                    best.t_enter = t0;
                    best.t_exit = t1;
                    best.sphere = std::uint32_t(s);
                    best.tile = Vec3i64(tx, ty, tz);
                }
    return best;
}

PeriodicTile small_tile(double fraction, std::size_t n, std::uint64_t seed, double side = 2.0) {
    Rng rng = Rng::from_key(seed);
    return random_sequential_addition(n, fraction, rng, side);
}

}  // namespace

TEST_CASE("PeriodicTile validates its input", "[tile]") {
    std::vector<Vec3d> two{Vec3d(0.1, 0.5, 0.5), Vec3d(0.4, 0.5, 0.5)};
    CHECK_NOTHROW(PeriodicTile(1.0, 0.15, two));  // touching (distance 0.3 = 2R) is allowed
    CHECK_THROWS_AS(PeriodicTile(1.0, 0.16, two), invalid_argument);
    CHECK_THROWS_WITH(PeriodicTile(1.0, 0.16, two), Catch::Contains("overlap"));
    // Overlap across the periodic boundary (minimum image): 0.05 and 0.95 are 0.1 apart.
    std::vector<Vec3d> wrap{Vec3d(0.05, 0.5, 0.5), Vec3d(0.95, 0.5, 0.5)};
    CHECK_THROWS_AS(PeriodicTile(1.0, 0.06, wrap), invalid_argument);
    CHECK_NOTHROW(PeriodicTile(1.0, 0.05, wrap));
    CHECK_THROWS_WITH(PeriodicTile(1.0, 0.0, two), Catch::Contains("radius"));
    CHECK_THROWS_AS(PeriodicTile(1.0, -1.0, two), invalid_argument);
    CHECK_THROWS_AS(PeriodicTile(1.0, std::numeric_limits<double>::quiet_NaN(), two), invalid_argument);
    CHECK_THROWS_AS(PeriodicTile(0.0, 0.1, two), invalid_argument);
    CHECK_THROWS_AS(PeriodicTile(1.0, 0.5, {Vec3d(0.5)}), invalid_argument);  // touches its own image
    CHECK_THROWS_AS(PeriodicTile(1.0, 0.1, {Vec3d(std::numeric_limits<double>::infinity(), 0, 0)}), invalid_argument);
    // Tiny radii (e.g. from a hostile file) must not request a huge cell grid.
    const PeriodicTile tiny(1.0, 1e-12, two);
    CHECK(tiny.grid_resolution() <= 4);
    CHECK(tiny.first_hit(Vec3i64(0, 0, 0), Vec3d(0.0, 0.5, 0.5), Vec3d(1, 0, 0), 0.0, 1.0).sphere == 0);
    CHECK(PeriodicTile(1.0, 1e-300, two).size() == 2);
    // Centres are wrapped into [0, L).
    PeriodicTile t(1.0, 0.1, {Vec3d(-0.25, 1.5, 3.0)});
    CHECK(t.center(0).x == Approx(0.75));
    CHECK(t.center(0).y == Approx(0.5));
    CHECK(t.center(0).z == Approx(0.0).margin(1e-15));
    CHECK(t.packing_fraction() == Approx(4.0 / 3.0 * 3.14159265358979 * 1e-3));
}

TEST_CASE("first_hit agrees with brute force over explicit tile copies", "[tile]") {
    for (double f : {0.05, 0.3}) {
        for (double cell : {0.7, 1.5, 4.0}) {
            PeriodicTile tile(2.0, radius_for_fraction(60, f, 2.0),
                              small_tile(f, 60, 3).centers(), cell);
            Rng rng = Rng::from_key(7, std::uint64_t(f * 100), std::uint64_t(cell * 10));
            int hits = 0;
            for (int k = 0; k < 400; ++k) {
                // Origins in tiles -1..1, rays up to 1.5 tile lengths, explicit copies -3..3.
                const Vec3d o(rng.uniform<double>() * 6 - 3, rng.uniform<double>() * 6 - 3, rng.uniform<double>() * 6 - 3);
                const Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>()) * (0.5 + rng.uniform<double>());
                const double t_min = (k % 3 == 0) ? 0.0 : rng.uniform<double>() * 0.5;
                const double t_max = t_min + 3.0 * rng.uniform<double>();
                const TileHit a = tile.first_hit(Vec3i64(0, 0, 0), o, d, t_min, t_max);
                const TileHit b = brute_first_hit(tile, o, d, t_min, t_max, -5, 5);
                REQUIRE(a.hit == b.hit);
                if (!a.hit) continue;
                ++hits;
                CHECK(a.sphere == b.sphere);
                CHECK(a.tile == b.tile);
                CHECK(a.t_enter == Approx(b.t_enter).margin(1e-9));
                CHECK(a.t_exit == Approx(b.t_exit).margin(1e-9));
                // The same ray expressed from another origin tile gives the same sphere.
                // (origin tile (5, -7, 1e12), local origin o - (5, -7, 0) L): the world point is o
                // shifted by 1e12 tiles along z, so the hit tile shifts by the same amount.
                const TileHit c =
                    tile.first_hit(Vec3i64(5, -7, 1000000000000LL), o - Vec3d(5, -7, 0) * 2.0, d, t_min, t_max);
                CHECK(c.sphere == a.sphere);
                CHECK(c.tile.x == a.tile.x);
                CHECK(c.tile.y == a.tile.y);
                CHECK(c.tile.z == a.tile.z + 1000000000000LL);
            }
            CHECK(hits > 20);
        }
    }
}

TEST_CASE("first_hit terminates on a ray along an empty channel", "[tile]") {
    PeriodicTile tile(1.0, 0.1, {Vec3d(0.5)});
    const TileHit h = tile.first_hit(Vec3i64(0, 0, 0), Vec3d(0.0, 0.05, 0.05), Vec3d(1, 0, 0), 0.0,
                                     std::numeric_limits<double>::infinity());
    CHECK_FALSE(h);
    tile.set_max_search_distance(10.0);
    CHECK(tile.max_search_distance() == 10.0);
    // Slightly tilted: hits eventually (within the search distance) at the right sphere.
    const Vec3d d = glm::normalize(Vec3d(1.0, 0.05, 0.0));
    const TileHit g = tile.first_hit(Vec3i64(0, 0, 0), Vec3d(0.0, 0.05, 0.5), d, 0.0, 1e9);
    REQUIRE(g);
    const Vec3d c = tile.center(0) + Vec3d(g.tile);
    const Vec3d p = Vec3d(0.0, 0.05, 0.5) + g.t_enter * d;
    CHECK(glm::length(p - c) == Approx(0.1));
}

TEST_CASE("first_hit with a float Ray matches the double query", "[tile]") {
    const PeriodicTile tile = small_tile(0.3, 100, 12, 1.0);
    Rng rng = Rng::from_key(13);
    for (int k = 0; k < 100; ++k) {
        const Vec3f o(rng.uniform<float>() * 3, rng.uniform<float>() * 3, rng.uniform<float>() * 3);
        const Vec3f d = sample_uniform_sphere<float>(rng.uniform2<float>());
        const TileHit a = tile.first_hit(Rayf(o, d), 0.0f, 2.0f);
        const TileHit b = tile.first_hit(Vec3i64(0, 0, 0), Vec3d(o), Vec3d(d), 0.0, 2.0);
        REQUIRE(a.hit == b.hit);
        CHECK(a.sphere == b.sphere);
        CHECK(a.t_enter == b.t_enter);
    }
}

TEST_CASE("first_hit continues from t_exit without repeating a sphere", "[tile]") {
    const PeriodicTile tile = small_tile(0.3, 200, 5, 1.0);
    Rng rng = Rng::from_key(9);
    for (int k = 0; k < 200; ++k) {
        const Vec3d o(rng.uniform<double>(), rng.uniform<double>(), rng.uniform<double>());
        const Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>());
        double t = 0;
        std::set<Key> seen;
        for (int step = 0; step < 30; ++step) {
            const TileHit h = tile.first_hit(Vec3i64(0, 0, 0), o, d, t, 10.0);
            if (!h) break;
            CHECK(h.t_exit > t);
            CHECK(seen.insert(Key{h.sphere, h.tile.x, h.tile.y, h.tile.z}).second);
            t = h.t_exit;
        }
    }
}

TEST_CASE("first_hit from inside a sphere reports it; sphere_containing agrees", "[tile]") {
    const PeriodicTile tile = small_tile(0.3, 100, 6, 1.0);
    for (std::size_t s = 0; s < 10; ++s) {
        const Vec3d p = tile.center(s) + Vec3d(3.0, -2.0, 0.0) + Vec3d(0.3 * tile.radius());
        const TileHit h = tile.first_hit(Vec3i64(0, 0, 0), p, Vec3d(0, 0, 1), 0.0, 1.0);
        REQUIRE(h);
        CHECK(h.sphere == s);
        CHECK(h.tile == Vec3i64(3, -2, 0));
        CHECK(h.t_enter < 0);
        const auto c = tile.sphere_containing(p);
        REQUIRE(c);
        CHECK(c->sphere == s);
        CHECK(c->tile == Vec3i64(3, -2, 0));
    }
    // A point in the void: brute force says no sphere contains it.
    Rng rng = Rng::from_key(3);
    for (int k = 0; k < 500; ++k) {
        const Vec3d p(rng.uniform<double>() * 4 - 2, rng.uniform<double>() * 4 - 2, rng.uniform<double>() * 4 - 2);
        bool inside = false;
        for (int tz = -3; tz <= 2; ++tz)
            for (int ty = -3; ty <= 2; ++ty)
                for (int tx = -3; tx <= 2; ++tx)
                    for (std::size_t s = 0; s < tile.size(); ++s) {
                        const Vec3d v = p - (tile.center(s) + Vec3d(tx, ty, tz));
                        inside |= glm::dot(v, v) < tile.radius() * tile.radius();
                    }
        CHECK(inside == bool(tile.sphere_containing(p)));
    }
}

TEST_CASE("box query agrees with brute force over explicit tile copies", "[tile]") {
    for (double cell : {0.8, 1.5, 3.0}) {
        const PeriodicTile base = small_tile(0.25, 80, 8, 1.0);
        const PeriodicTile tile(1.0, base.radius(), base.centers(), cell);
        Rng rng = Rng::from_key(21, std::uint64_t(cell * 10));
        for (int k = 0; k < 60; ++k) {
            Vec3d lo(rng.uniform<double>() * 4 - 2, rng.uniform<double>() * 4 - 2, rng.uniform<double>() * 4 - 2);
            const Vec3d ext(rng.uniform<double>() * 1.3, rng.uniform<double>() * 0.7, rng.uniform<double>() * 1.1);
            const double h = tile.side() / double(tile.grid_resolution());
            if (k == 0) lo = Vec3d(0.0);  // exactly on tile and cell boundaries
            if (k >= 1 && k < 12) lo = Vec3d(double(k - 6), double(2 * k - 13), double(-k)) * h;  // cell boundaries
            Vec3d hi = lo + (k == 0 ? Vec3d(1.0) : ext);
            if (k >= 1 && k < 6) hi = lo + Vec3d(double(k)) * h;  // upper faces on cell boundaries too
            std::set<Key> fast, brute;
            for (const auto& r : tile.spheres_overlapping(lo, hi)) {
                CHECK(fast.insert(Key{r.sphere, r.tile.x, r.tile.y, r.tile.z}).second);  // no duplicates
                const Vec3d c = tile.center(r.sphere) + Vec3d(r.tile) * tile.side();
                CHECK(glm::length(c - r.center) < 1e-12);
            }
            for (int tz = -4; tz <= 4; ++tz)
                for (int ty = -4; ty <= 4; ++ty)
                    for (int tx = -4; tx <= 4; ++tx)
                        for (std::size_t s = 0; s < tile.size(); ++s) {
                            const Vec3d c = tile.center(s) + Vec3d(tx, ty, tz);
                            const Vec3d q = glm::clamp(c, lo, hi);
                            if (glm::dot(q - c, q - c) < tile.radius() * tile.radius())
                                brute.insert(Key{std::uint32_t(s), tx, ty, tz});
                        }
            CHECK(fast == brute);
        }
    }
}

TEST_CASE("tile save/load round trip; damaged tile files are format errors", "[tile]") {
    const PeriodicTile tile = small_tile(0.2, 50, 4, 3.0);
    const auto path = std::filesystem::temp_directory_path() / "grainlight_test_tile.gltile";
    tile.save(path);
    const PeriodicTile back = PeriodicTile::load(path);
    REQUIRE(back.size() == tile.size());
    CHECK(back.side() == tile.side());
    CHECK(back.radius() == tile.radius());
    for (std::size_t i = 0; i < tile.size(); ++i) CHECK(back.center(i) == tile.center(i));

    std::vector<char> good;
    {
        std::ifstream f(path, std::ios::binary);
        good.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    }
    auto write = [&](const std::vector<char>& b) {
        std::ofstream f(path, std::ios::binary | std::ios::trunc);
        f.write(b.data(), std::streamsize(b.size()));
    };
    write(std::vector<char>(good.begin(), good.begin() + 100));
    CHECK_THROWS_AS(PeriodicTile::load(path), format_error);
    auto bad = good;
    bad[200] ^= 1;
    write(bad);
    CHECK_THROWS_AS(PeriodicTile::load(path), format_error);
    bad = good;
    bad[2] = 'x';
    write(bad);
    CHECK_THROWS_AS(PeriodicTile::load(path), format_error);

    // A well-formed container whose tile content is invalid (overlapping spheres, bad radius,
    // count larger than the data) is also a format_error.
    auto payload_with = [&](double radius, std::uint64_t count, std::size_t stored) {
        ByteWriter w;
        w.put(1.0).put(radius).put(count);
        for (std::size_t i = 0; i < stored; ++i) w.put(0.5).put(0.5).put(0.1 * double(i));
        write_container_atomic(path, PeriodicTile::file_kind, PeriodicTile::file_kind_version, w.bytes());
    };
    payload_with(0.1, 2, 2);  // centres 0.1 apart, radius 0.1: overlap
    CHECK_THROWS_WITH(PeriodicTile::load(path), Catch::Contains("overlap"));
    payload_with(-0.01, 2, 2);
    CHECK_THROWS_AS(PeriodicTile::load(path), format_error);
    payload_with(0.01, std::uint64_t(1) << 62, 2);
    CHECK_THROWS_AS(PeriodicTile::load(path), format_error);
    std::filesystem::remove(path);
    CHECK_THROWS_AS(PeriodicTile::load(path), io_error);
}
