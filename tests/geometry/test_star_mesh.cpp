// StarMesh (geometry/star_mesh.hpp): the cone walk over a mesh star-shaped around the origin must
// report the closest hit of a brute-force loop over every triangle (same watertight test), for
// rays entering from outside, rays starting inside, far rays, and rays aimed exactly at vertices
// and edge midpoints (where neighbouring triangles tie); it must hand over to the BVH correctly
// at any step budget (intersect_star_then_bvh), and refuse meshes whose triangle cones do not
// tile the sphere once.
#include <catch2/catch.hpp>

#include <cmath>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "common/brute_force_hit.hpp"
#include "grainlight/geometry.hpp"

using namespace grainlight;

TEST_CASE("StarMesh: the cone walk finds the brute-force closest hit on procedural grains", "[geometry][star]") {
    const GrainShape shapes[] = {GrainShape::snow, GrainShape::crystal, GrainShape::rice, GrainShape::flake};
    for (const GrainShape shape : shapes)
        for (int level = 0; level <= 3; ++level) {
            const auto mesh = make_grain_mesh<float>(shape, 1.0f, 3, level);
            const auto star = StarMesh::build(mesh);
            REQUIRE(star.has_value());
            CHECK(star->triangle_count() == mesh.triangle_count());
            const Bvh<float> bvh(mesh);
            Rng rng = Rng::from_key(std::uint64_t(17 + 5 * level + 100 * int(shape)));
            int rays = 0, hits = 0, wrong = 0, undecided = 0, resumed = 0;
            for (int kind = 0; kind < 4; ++kind)
                for (int i = 0; i < 600; ++i) {
                    Vec3d o, d;
                    if (kind == 0) {  // from the bounding sphere toward the inside
                        o = sample_uniform_sphere(rng.uniform2<double>());
                        d = glm::normalize(0.9 * std::cbrt(rng.uniform<double>()) *
                                               sample_uniform_sphere(rng.uniform2<double>()) - o);
                    } else if (kind == 1) {  // from inside (mostly inside the grain), any direction
                        o = 0.6 * std::cbrt(rng.uniform<double>()) * sample_uniform_sphere(rng.uniform2<double>());
                        d = sample_uniform_sphere(rng.uniform2<double>());
                    } else if (kind == 2) {  // from far away, any direction (mostly misses)
                        o = 3.0 * sample_uniform_sphere(rng.uniform2<double>());
                        d = sample_uniform_sphere(rng.uniform2<double>());
                    } else {  // exactly at a vertex or an edge midpoint: neighbouring triangles tie
                        const auto& tri = mesh.triangles[std::size_t(rng.uniform<double>() * double(mesh.triangles.size()))];
                        const Vec3d v0(mesh.vertices[tri[0]]), v1(mesh.vertices[tri[1]]);
                        const Vec3d target = rng.uniform<double>() < 0.5 ? v0 : 0.5 * (v0 + v1);
                        o = 2.0 * sample_uniform_sphere(rng.uniform2<double>());
                        d = glm::normalize(target - o);
                    }
                    const Vec3f of(o), df(d);
                    const float t_max = 10.0f;
                    const auto ref = grainlight_test::brute_force_hit(mesh, of, df, t_max);
                    const int budget = int(rng.uniform<double>() * 10);  // 0 .. 9 cones, then the BVH
                    TriangleHit<float> unlimited;
                    float t_resume = 0;
                    const bool decided = star->intersect(of, df, t_max, unlimited, t_resume);
                    undecided += !decided;
                    // The walk with that budget, finished by the BVH as Grain does.
                    TriangleHit<float> tmp;
                    t_resume = -1;
                    if (!star->intersect(of, df, t_max, tmp, t_resume, budget)) {
                        ++resumed;
                        REQUIRE(t_resume >= 0.0f);
                    }
                    const auto h = intersect_star_then_bvh(&*star, bvh, of, df, t_max, budget);
                    ++rays;
                    hits += ref.valid();
                    bool ok = h.valid() == ref.valid();
                    if (ok && ref.valid()) {
                        // Bit-equal away from ties; at a shared vertex or edge the triangles' own
                        // roots may differ in the last bits.
                        ok = kind < 3 ? h.t == ref.t : std::abs(h.t - ref.t) <= 1e-6f * ref.t;
                        // The reported triangle really is hit there.
                        const auto c = mesh.corners(h.prim);
                        float t, b1, b2;
                        ok = ok && intersect_triangle_watertight(WatertightRay<float>(of, df), c[0], c[1], c[2], 0.0f,
                                                                 t_max, t, b1, b2) &&
                             t == h.t;
                    }
                    if (decided && ok && ref.valid())
                        ok = unlimited.valid() &&
                             (kind < 3 ? unlimited.t == h.t : std::abs(unlimited.t - ref.t) <= 1e-6f * ref.t);
                    if (!ok) UNSCOPED_INFO("ray kind " << kind << ": t " << h.t << " (walk alone " << unlimited.t
                                                       << "), brute force " << ref.t);
                    wrong += !ok;
                }
            INFO("shape " << to_string(shape) << ", level " << level << ": " << rays << " rays, " << hits
                          << " hits, " << resumed << " handed to the BVH");
            CHECK(wrong == 0);
            CHECK(undecided == 0);  // no ray of these sets passes through the origin
            CHECK(hits > rays / 4);
            CHECK(resumed > 0);
        }
}

TEST_CASE("StarMesh: rays through the origin are handed to the BVH", "[geometry][star]") {
    const auto mesh = make_grain_mesh<float>(GrainShape::snow, 1.0f, 1, 2);
    const auto star = StarMesh::build(mesh);
    REQUIRE(star.has_value());
    TriangleHit<float> h;
    float t_resume = -1;
    CHECK_FALSE(star->intersect(Vec3f(0.0f, 0.0f, -2.0f), Vec3f(0.0f, 0.0f, 1.0f), 10.0f, h, t_resume));
    CHECK(t_resume == 0.0f);
    CHECK_FALSE(star->intersect(Vec3f(0.0f), Vec3f(0.3f, 0.4f, 0.5f), 10.0f, h, t_resume));
    CHECK(t_resume == 0.0f);
    // Grain finishes them with its BVH: the same hit as brute force.
    const Grain g = Grain::mesh(mesh, GrainMaterial::make_dielectric(1.5));
    double t = 0;
    Vec3d n(0.0);
    REQUIRE(g.intersect(Vec3d(0.0, 0.0, -2.0), Vec3d(0.0, 0.0, 1.0), 0.0, 10.0, t, n));
    CHECK(float(t) == grainlight_test::brute_force_hit(mesh, Vec3f(0.0f, 0.0f, -2.0f), Vec3f(0.0f, 0.0f, 1.0f), 10.0f).t);
}

TEST_CASE("StarMesh: meshes whose cones do not tile the sphere once are refused", "[geometry][star]") {
    const auto sphere = make_icosphere<float>(2);
    REQUIRE(StarMesh::build(sphere).has_value());
    // The origin outside the mesh: the cones cover part of the sphere, some of them backwards.
    auto shifted = sphere;
    for (auto& v : shifted.vertices) v += Vec3f(3.0f, 0.0f, 0.0f);
    CHECK_FALSE(StarMesh::build(shifted).has_value());
    // One triangle flipped (inward-facing).
    auto flipped = sphere;
    std::swap(flipped.triangles[5][1], flipped.triangles[5][2]);
    CHECK_FALSE(StarMesh::build(flipped).has_value());
    // Open: one triangle removed.
    auto open = sphere;
    open.triangles.pop_back();
    CHECK_FALSE(StarMesh::build(open).has_value());
    // Two nested spheres around the origin: every direction is covered twice.
    auto twice = sphere;
    const auto nv = std::uint32_t(sphere.vertices.size());
    for (const auto& v : sphere.vertices) twice.vertices.push_back(0.5f * v);
    for (const auto& t : sphere.triangles) twice.triangles.push_back({t[0] + nv, t[1] + nv, t[2] + nv});
    CHECK_FALSE(StarMesh::build(twice).has_value());
    // A star-shaped mesh whose origin is off-centre but inside still qualifies.
    auto off = sphere;
    for (auto& v : off.vertices) v += Vec3f(0.3f, -0.2f, 0.1f);
    CHECK(StarMesh::build(off).has_value());
}
