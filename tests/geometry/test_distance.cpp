// Distance-to-boundary queries (geometry/distance.hpp): nearest point on a triangle and on a mesh
// against brute force, analytic box distance against the same box as a mesh, the icosphere
// against the sphere it is inscribed in, and the property the shell tracer relies on: the
// largest ball that "fits" (radius = distance) never crosses the surface, over random points of
// procedural grain meshes; bad input.
#include <catch2/catch.hpp>

#include <cmath>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/distance.hpp"
#include "grainlight/geometry/grains.hpp"

using namespace grainlight;

namespace {

TriangleMesh<double> box_mesh(const Vec3d& lo, const Vec3d& hi) {
    TriangleMesh<double> m;
    for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    // Outward-oriented faces (two triangles each).
    const std::uint32_t f[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : f) {
        m.triangles.push_back({q[0], q[1], q[2]});
        m.triangles.push_back({q[0], q[2], q[3]});
    }
    return m;
}

double brute_distance(const TriangleMesh<double>& m, const Vec3d& p) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        const auto c = m.corners(i);
        best = std::min(best, glm::length(closest_point_on_triangle(p, c[0], c[1], c[2]) - p));
    }
    return best;
}

}  // namespace

TEST_CASE("closest point on a triangle matches a dense barycentric search", "[geometry][distance]") {
    Rng rng = Rng::from_key(101);
    const Vec3d a(0, 0, 0), b(1.3, 0.1, 0), c(0.2, 0.9, 0.3);
    for (int k = 0; k < 200; ++k) {
        const Vec3d p = rng.uniform3<double>() * 4.0 - Vec3d(1.5);
        const Vec3d q = closest_point_on_triangle(p, a, b, c);
        double dense = std::numeric_limits<double>::infinity();
        const int n = 200;
        for (int i = 0; i <= n; ++i)
            for (int j = 0; i + j <= n; ++j) {
                const Vec3d s = a + (double(i) / n) * (b - a) + (double(j) / n) * (c - a);
                dense = std::min(dense, glm::length(s - p));
            }
        // Exact nearest point: never farther than the grid's best, and at most one grid step closer.
        REQUIRE(glm::length(q - p) <= dense + 1e-12);
        REQUIRE(glm::length(q - p) >= dense - 0.01);
    }
}

TEST_CASE("MeshDistance: tree search equals brute force; box mesh equals BoxDistance", "[geometry][distance]") {
    const Vec3d lo(-1, -0.5, -2), hi(2, 1.5, 0.5);
    const TriangleMesh<double> m = box_mesh(lo, hi);
    const MeshDistance md(m);
    const BoxDistance bd(lo, hi);
    Rng rng = Rng::from_key(102);
    int inside = 0;
    for (int k = 0; k < 2000; ++k) {
        const Vec3d p(-2 + 5 * rng.uniform<double>(), -1.5 + 4 * rng.uniform<double>(), -3 + 4.5 * rng.uniform<double>());
        const NearestPoint np = md.nearest(p);
        REQUIRE(np.distance == Approx(brute_distance(m, p)).margin(1e-12));
        REQUIRE(md(p) == Approx(bd(p)).margin(1e-9));
        inside += bd(p) > 0;
    }
    REQUIRE(inside > 200);
    // Icosphere (vertices on the unit sphere, inscribed): 0 <= sphere - mesh distance <= sagitta.
    const TriangleMesh<double> ico = make_icosphere<double>(3);
    const MeshDistance mi(ico);
    const SphereDistance sd(Vec3d(0.0), 1.0);
    double max_edge = 0;
    for (std::size_t i = 0; i < ico.triangles.size(); ++i) {
        const auto c = ico.corners(i);
        max_edge = std::max({max_edge, glm::length(c[1] - c[0]), glm::length(c[2] - c[1]), glm::length(c[0] - c[2])});
    }
    const double sagitta = 1 - std::sqrt(1 - max_edge * max_edge / 3);  // circumradius of a triangle <= edge/sqrt(3)
    for (int k = 0; k < 500; ++k) {
        const Vec3d p = sample_uniform_sphere(rng.uniform2<double>()) * std::cbrt(rng.uniform<double>()) * 0.98;
        const double d = mi(p);
        REQUIRE(d > 0);
        REQUIRE(sd(p) - d >= -1e-12);
        REQUIRE(sd(p) - d <= sagitta + 1e-12);
        REQUIRE(d == Approx(brute_distance(ico, p)).margin(1e-12));
    }
}

TEST_CASE("the largest ball that fits never crosses a mesh surface (random points of grain meshes)",
          "[geometry][distance][property]") {
    Rng rng = Rng::from_key(103);
    for (GrainShape shape : {GrainShape::snow, GrainShape::crystal, GrainShape::rice, GrainShape::flake}) {
        const TriangleMesh<double> mesh = make_grain_mesh<double>(shape, 1.0, 7, 3);
        const MeshDistance md(mesh);
        const Bvh<double> bvh(mesh);
        const Aabb<double> b = md.bounds();
        int tested = 0, tight = 0;
        for (int k = 0; k < 4000 && tested < 150; ++k) {
            const Vec3d p = b.lo + rng.uniform3<double>() * b.extent();
            if (!md.inside(p)) continue;
            const double d = md(p);
            REQUIRE(d > 0);
            REQUIRE(ball_inside(md, p, d));
            ++tested;
            // No direction reaches the surface within d (ray against the BVH): the ball B(p, d)
            // does not cross the boundary.
            for (int j = 0; j < 200; ++j) {
                const Vec3d w = sample_uniform_sphere(rng.uniform2<double>());
                REQUIRE_FALSE(bvh.intersect(p, w, 0.0, d * (1 - 1e-9)));
                REQUIRE(md.inside(p + w * (d * (1 - 1e-6))));
            }
            // Tight: towards the nearest point the surface is reached at distance d.
            const NearestPoint np = md.nearest(p);
            const Vec3d w = glm::normalize(np.point - p);
            const TriangleHit<double> h = bvh.intersect(p, w, 0.0, 2 * d + 1);
            REQUIRE(bool(h));
            if (std::abs(h.t - d) <= 1e-9 * (1 + d)) ++tight;
        }
        REQUIRE(tested == 150);
        REQUIRE(tight >= 140);  // the ray may hit an adjacent triangle at an edge within rounding
    }
}

TEST_CASE("MeshDistance::inside_near equals the parity inside test per point near the surface", "[geometry][distance][property]") {
    // Independent reference: MeshBoundary's three full parity rays per point (inside()).
    Rng rng = Rng::from_key(104);
    int declined = 0, compared = 0, mixed = 0;
    for (GrainShape shape : {GrainShape::snow, GrainShape::crystal, GrainShape::rice}) {
        const TriangleMesh<double> mesh = make_grain_mesh<double>(shape, 1.0, 11, 3);
        const MeshDistance md(mesh);
        const Aabb<double> b = md.bounds();
        for (int k = 0; k < 300; ++k) {
            const Vec3d q = b.lo + rng.uniform3<double>() * b.extent();
            const double r = 0.03 + 0.12 * rng.uniform<double>();  // facets are ~0.1 across
            if (!md.any_within(q, r)) continue;  // only balls that reach the surface are of interest
            std::array<Vec3d, 32> x;
            for (auto& xi : x) xi = q + sample_uniform_sphere(rng.uniform2<double>()) * (r * std::cbrt(rng.uniform<double>()));
            std::array<bool, 32> out{};
            if (!md.inside_near(q, r, md.inside(q), x.data(), 32, out.data())) {
                ++declined;
                continue;
            }
            int in = 0;
            for (std::size_t i = 0; i < x.size(); ++i) {
                INFO("q = (" << q.x << ", " << q.y << ", " << q.z << "), r = " << r << ", point " << i);
                REQUIRE(out[i] == md.inside(x[i]));
                in += out[i] ? 1 : 0;
                ++compared;
            }
            mixed += in > 0 && in < 32;
        }
    }
    REQUIRE(compared > 5000);
    REQUIRE(mixed > 100);  // the balls do straddle the surface
    REQUIRE(declined < compared / 32 / 4);  // it rarely declines at these radii
    // More triangles within r than it gathers: it declines (the caller asks inside() per point).
    const MeshDistance fine(make_icosphere<double>(5));  // 20480 facets on the unit sphere
    const Vec3d p(0.0, 0.0, 0.9);
    std::array<bool, 1> o{};
    const Vec3d x1(0.0, 0.0, 1.2);
    REQUIRE_FALSE(fine.inside_near(p, 0.5, true, &x1, 1, o.data()));
    REQUIRE(fine.inside_near(p, 0.12, true, &x1, 0, o.data()));
}

TEST_CASE("analytic distances and bad input", "[geometry][distance]") {
    const SlabDistance slab{2.0};
    REQUIRE(slab(Vec3d(0, 0, -0.5)) == Approx(0.5));
    REQUIRE(slab(Vec3d(0, 0, -1.5)) == Approx(0.5));
    REQUIRE(slab(Vec3d(0, 0, 1.0)) == Approx(-1.0));
    const SlabDistance half{std::numeric_limits<double>::infinity()};
    REQUIRE(half(Vec3d(0, 0, -1e6)) == Approx(1e6));
    REQUIRE(SphereDistance(Vec3d(1, 0, 0), 2)(Vec3d(4, 0, 0)) == Approx(-1.0));
    REQUIRE(BoxDistance(Vec3d(0.0), Vec3d(1.0))(Vec3d(2, 2, 0.5)) == Approx(-std::sqrt(2.0)));
    const BoxDistance box(Vec3d(0.0), Vec3d(2, 3, 4));
    REQUIRE(box.normal(Vec3d(0.1, 1.5, 2)) == Vec3d(-1, 0, 0));
    REQUIRE(box.normal(Vec3d(1.9, 1.5, 2)) == Vec3d(1, 0, 0));
    REQUIRE(box.normal(Vec3d(1, 0.05, 2)) == Vec3d(0, -1, 0));
    REQUIRE(box.normal(Vec3d(1, 1.5, 3.99)) == Vec3d(0, 0, 1));
    REQUIRE(box.normal(Vec3d(1, 1.5, 4.01)) == Vec3d(0, 0, 1));  // just outside: still the +z face
    REQUIRE(box.normal(Vec3d(-0.02, 1.5, 2)) == Vec3d(-1, 0, 0));
    Rng rng = Rng::from_key(104);
    for (int i = 0; i < 1000; ++i) {  // the exit point of a ray from inside lies on the face normal() names
        const Vec3d p(2 * rng.uniform<double>(), 3 * rng.uniform<double>(), 4 * rng.uniform<double>());
        const Vec3d w = sample_uniform_sphere(rng.uniform2<double>());
        const Vec3d x = p + box.exit_distance(p, w) * w, n = box.normal(x);
        REQUIRE(glm::dot(n, w) > 0);
        REQUIRE(std::abs(box(x)) < 1e-9);
    }
    REQUIRE_THROWS_WITH(SphereDistance(Vec3d(0.0), -1.0), Catch::Contains("radius"));
    REQUIRE_THROWS_WITH(BoxDistance(Vec3d(0.0), Vec3d(1, 0, 1)), Catch::Contains("hi - lo"));
    TriangleMesh<double> open = box_mesh(Vec3d(0.0), Vec3d(1.0));
    open.triangles.pop_back();  // not closed
    REQUIRE_THROWS_WITH(MeshDistance(open), Catch::Contains("watertight"));
}
