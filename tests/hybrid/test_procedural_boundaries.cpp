// Procedural aggregate boundaries of the Meng15 stand-in scenes (geometry/procedural_boundaries.hpp):
// the spice heaps of Fig. 12 and the heightfield sandcastle of Fig. 1 are closed, outward-oriented
// meshes whose volumes match the closed forms / an independent integration of the height function,
// and MeshDistance (the DA switch's query) sees them as solids.
#include <catch2/catch.hpp>

#include <cmath>

#include "grainlight/geometry/distance.hpp"
#include "grainlight/geometry/procedural_boundaries.hpp"

using namespace grainlight;

TEST_CASE("Heap mesh: closed, volume 0.4 pi r^2 h", "[hybrid][mesh][procedural]") {
    const double r = 30, h = 20;
    const TriangleMesh<double> m = make_heap_mesh(r, h, 128, 128);
    REQUIRE(m.is_watertight());
    // int_0^h pi r^2 (1 - y/h)^1.5 dy = pi r^2 h / 2.5 (closed form); the inscribed 128-gon loses
    // 0.04 % of the area, the rings (sin-spaced) a few 0.1 % of the profile's curvature.
    REQUIRE(m.signed_volume() == Approx(0.4 * pi_v<double> * r * r * h).epsilon(0.01));
    REQUIRE(m.bounds().hi.y == Approx(h));
    const MeshDistance md(m);
    REQUIRE(md.inside(Vec3d(0, 0.5 * h, 0)));
    REQUIRE_FALSE(md.inside(Vec3d(0, 1.01 * h, 0)));
    REQUIRE_FALSE(md.inside(Vec3d(0.8 * r, 0.5 * h, 0)));  // rho(h/2) = r 0.5^0.75 = 0.59 r
    REQUIRE(md.inside(Vec3d(0.55 * r, 0.5 * h, 0)));
    REQUIRE_THROWS_WITH(make_heap_mesh(0.0, 1.0), Catch::Contains("radius"));
    REQUIRE_THROWS_WITH(make_heap_mesh(1.0, -1.0), Catch::Contains("height"));
}

TEST_CASE("Heightfield mesh: closed, exact volume for a linear height", "[hybrid][mesh][procedural]") {
    // h = 1 + 0.3 x + 0.2 z over [0, 2] x [0, 1]: the triangulation is exact for a linear h;
    // volume = 2 + 0.3 * 2 + 0.2 * 2 * 0.5 = 2.8.
    const TriangleMesh<double> m = make_heightfield_mesh([](double x, double z) { return 1 + 0.3 * x + 0.2 * z; }, 0, 2, 0, 1, 7, 5);
    REQUIRE(m.is_watertight());
    REQUIRE(m.signed_volume() == Approx(2.8).epsilon(1e-12));
    REQUIRE(m.triangle_count() == std::size_t(4 * 7 * 5 + 4 * (7 + 5)));
    const MeshDistance md(m);
    REQUIRE(md.inside(Vec3d(1, 0.5, 0.5)));
    REQUIRE_FALSE(md.inside(Vec3d(1, 2.0, 0.5)));
    // Distance from (1, 0.5, 0.5) to the solid's boundary: the faces z = 0, z = 1 at 0.5 and the
    // bottom at 0.5 are nearest (top: >= (1.3 + 0.1 - 0.5) / |grad| > 0.8; sides x: 1).
    REQUIRE(md(Vec3d(1, 0.5, 0.5)) == Approx(0.5).epsilon(1e-9));
    REQUIRE_THROWS_WITH(make_heightfield_mesh([](double, double) { return 1.0; }, 0, 1, 0, 1, 0, 3), Catch::Contains("nx"));
    REQUIRE_THROWS_WITH(make_heightfield_mesh([](double, double) { return 1.0; }, 1, 1, 0, 1, 2, 3), Catch::Contains("x1 - x0"));
}

TEST_CASE("Sandcastle mesh: closed, the union of its towers, walls and keep", "[hybrid][mesh][procedural]") {
    const double S = 100;
    const TriangleMesh<double> m = make_sandcastle_mesh(S, 256);
    REQUIRE(m.is_watertight());
    // Independent: midpoint integration of sandcastle_height on a 2000 x 2000 grid. The mesh
    // interpolates across the vertical walls of towers and walls (one 2S/256 cell wide), which
    // changes the volume by O(perimeter x cell x height / 2), about 1-2 % here.
    const int n = 2000;
    double V = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double x = -1 + 2 * (i + 0.5) / n, z = -1 + 2 * (j + 0.5) / n;
            V += sandcastle_height(x, z) * (4.0 / (double(n) * n));
        }
    V *= S * S * S;
    REQUIRE(m.signed_volume() == Approx(V).epsilon(0.03));
    REQUIRE(m.bounds().hi.y == Approx(1.14 * S).epsilon(0.01));
    const MeshDistance md(m);
    REQUIRE(md.inside(Vec3d(0, 0.5 * S, 0)));           // keep
    REQUIRE(md.inside(Vec3d(0.62 * S, 0.7 * S, 0.62 * S)));  // corner tower below its roof apex
    REQUIRE(md.inside(Vec3d(0.62 * S, 0.3 * S, 0)));    // curtain wall
    REQUIRE_FALSE(md.inside(Vec3d(0.4 * S, 0.3 * S, 0.4 * S)));  // courtyard above the base
    REQUIRE_FALSE(md.inside(Vec3d(0, 1.2 * S, 0)));
    REQUIRE_THROWS_WITH(make_sandcastle_mesh(0.0), Catch::Contains("half_width"));
}
