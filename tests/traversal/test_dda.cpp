// Tests of grainlight/traversal/dda.hpp (Amanatides-Woo) against brute force: the cells a ray
// segment passes through, found by slab-testing every cell of its bounding box.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/traversal/dda.hpp"

using namespace grainlight;

namespace {
struct Visit {
    long long x, y, z;
    double t0, t1;
};
}  // namespace

TEST_CASE("GridDda visits exactly the cells a segment crosses, in order", "[dda]") {
    Rng rng = Rng::from_key(42);
    for (int k = 0; k < 300; ++k) {
        const Vec3d h(0.5 + rng.uniform<double>(), 0.5 + rng.uniform<double>(), 0.5 + rng.uniform<double>());
        const Vec3d o(rng.uniform<double>() * 4 - 2, rng.uniform<double>() * 4 - 2, rng.uniform<double>() * 4 - 2);
        Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>()) * (0.3 + rng.uniform<double>());
        if (k % 10 == 0) d = Vec3d(0.0, d.y, k % 20 == 0 ? 0.0 : d.z);  // axis-parallel components
        const double t0 = rng.uniform<double>() * 2, t1 = t0 + rng.uniform<double>() * 8;
        const Vec3i64 base = k % 2 ? Vec3i64(1000000000000LL, -7, 3) : Vec3i64(0, 0, 0);

        std::vector<Visit> fast;
        for (GridDda<double> dda(base, o, d, h, t0, t1); !dda.done(); dda.step()) {
            REQUIRE(dda.t_exit() >= dda.t_enter());
            if (dda.t_exit() - dda.t_enter() > 1e-9) {
                const Vec3i64 c = dda.cell();
                fast.push_back({c.x - base.x, c.y - base.y, c.z - base.z, dda.t_enter(), dda.t_exit()});
            }
            REQUIRE(fast.size() < 10000);
        }
        // Brute force over the bounding box of the segment.
        std::vector<Visit> brute;
        const Vec3d p0 = o + t0 * d, p1 = o + t1 * d;
        long long lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = (long long)std::floor(std::min(p0[a], p1[a]) / h[a]) - 1;
            hi[a] = (long long)std::floor(std::max(p0[a], p1[a]) / h[a]) + 1;
        }
        for (long long z = lo[2]; z <= hi[2]; ++z)
            for (long long y = lo[1]; y <= hi[1]; ++y)
                for (long long x = lo[0]; x <= hi[0]; ++x) {
                    const Vec3d clo = Vec3d(double(x), double(y), double(z)) * h;
                    double a0 = t0, a1 = t1;
                    if (!clip_to_box(o, d, clo, clo + h, a0, a1)) continue;
                    if (a1 - a0 > 1e-9) brute.push_back({x, y, z, a0, a1});
                }
        std::sort(brute.begin(), brute.end(), [](const Visit& a, const Visit& b) { return a.t0 < b.t0; });
        REQUIRE(fast.size() == brute.size());
        for (std::size_t i = 0; i < fast.size(); ++i) {
            CHECK(std::tie(fast[i].x, fast[i].y, fast[i].z) == std::tie(brute[i].x, brute[i].y, brute[i].z));
            CHECK(fast[i].t0 == Approx(brute[i].t0).margin(1e-9));
            CHECK(fast[i].t1 == Approx(brute[i].t1).margin(1e-9));
        }
    }
}

TEST_CASE("GridDda degenerate inputs", "[dda]") {
    CHECK(GridDda<double>(Vec3i64(0, 0, 0), Vec3d(0.5), Vec3d(0.0), Vec3d(1.0), 0.0, 1.0).done());
    CHECK(GridDda<double>(Vec3i64(0, 0, 0), Vec3d(0.5), Vec3d(1, 0, 0), Vec3d(1.0), 2.0, 1.0).done());
    CHECK(GridDda<double>(Vec3i64(0, 0, 0), Vec3d(0.5), Vec3d(1, 0, 0), Vec3d(0.0), 0.0, 1.0).done());
    // A zero-length segment visits the one cell containing the point.
    GridDda<float> dda(Vec3i64(-4, 0, 0), Vec3f(0.25f), Vec3f(1, 0, 0), Vec3f(1.0f), 0.0f, 0.0f);
    REQUIRE_FALSE(dda.done());
    CHECK(dda.cell() == Vec3i64(-4, 0, 0));
    dda.step();
    CHECK(dda.done());
}
