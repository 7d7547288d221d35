// Scene layer: shape intersections and normals, mesh (BVH) vs analytic box, camera rays and
// projection, light sampling pdfs against a closed-form irradiance, bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "grainlight/core/statistics.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/isotropic.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/scene.hpp"

using namespace grainlight;
namespace fs = std::filesystem;

namespace {
using MediumT = ContinuousMedium<IsotropicPhase<double, RGBd>, RGBd>;
using SceneT = Scene<MediumT>;

fs::path write_cube_obj(double h) {
    const fs::path d = fs::temp_directory_path() / "grainlight_test_scene";
    fs::create_directories(d);
    const fs::path p = d / "cube.obj";
    std::ofstream f(p);
    // Cube [-h, h]^3; each face's corner order is flipped if needed so that faces are
    // counter-clockwise seen from outside (outward normals).
    auto corner = [h](int i) { return Vec3d((i & 1) ? h : -h, (i & 2) ? h : -h, (i & 4) ? h : -h); };
    for (int i = 0; i < 8; ++i) f << "v " << corner(i).x << " " << corner(i).y << " " << corner(i).z << "\n";
    const int quads[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
    for (const auto& q : quads) {
        const Vec3d c = 0.25 * (corner(q[0]) + corner(q[1]) + corner(q[2]) + corner(q[3]));
        const Vec3d nq = glm::cross(corner(q[1]) - corner(q[0]), corner(q[2]) - corner(q[0]));
        if (glm::dot(nq, c) > 0)
            f << "f " << q[0] + 1 << " " << q[1] + 1 << " " << q[2] + 1 << " " << q[3] + 1 << "\n";
        else
            f << "f " << q[3] + 1 << " " << q[2] + 1 << " " << q[1] + 1 << " " << q[0] + 1 << "\n";
    }
    return p;
}
}  // namespace

TEST_CASE("Analytic shapes: closest hit, inside hits and outward normals", "[scene][shapes]") {
    double t;
    Vec3d n;
    const SphereShape<double> sph(Vec3d(0, 0, 0), 2.0);
    REQUIRE(sph.intersect(Rayd(Vec3d(0, 0, 5), Vec3d(0, 0, -1)), t, n));
    CHECK(t == Approx(3.0));
    CHECK(n.z == Approx(1.0));
    REQUIRE(sph.intersect(Rayd(Vec3d(0, 0, 0), Vec3d(1, 0, 0)), t, n));  // from inside
    CHECK(t == Approx(2.0));
    CHECK(n.x == Approx(1.0));  // still outward
    CHECK_FALSE(sph.intersect(Rayd(Vec3d(0, 0, 5), Vec3d(0, 0, -1), 2.9), t, n));  // t_max

    const BoxShape<double> box(Vec3d(-1, -2, -3), Vec3d(1, 2, 3));
    REQUIRE(box.intersect(Rayd(Vec3d(0, 5, 0), Vec3d(0, -1, 0)), t, n));
    CHECK(t == Approx(3.0));
    CHECK(n.y == Approx(1.0));
    REQUIRE(box.intersect(Rayd(Vec3d(0, 0, 0), Vec3d(0, 0, -1)), t, n));
    CHECK(t == Approx(3.0));
    CHECK(n.z == Approx(-1.0));
    CHECK_FALSE(box.intersect(Rayd(Vec3d(5, 5, 0), Vec3d(0, -1, 0)), t, n));
    CHECK(box.area() == Approx(2 * (2 * 4 + 4 * 6 + 6 * 2)));

    const QuadShape<double> quad(Vec3d(0, 0, 0), Vec3d(2, 0, 0), Vec3d(0, 3, 0));
    CHECK(quad.area() == Approx(6.0));
    CHECK(quad.normal.z == Approx(1.0));
    REQUIRE(quad.intersect(Rayd(Vec3d(1, 1, 2), Vec3d(0, 0, -1)), t, n));
    CHECK(t == Approx(2.0));
    CHECK_FALSE(quad.intersect(Rayd(Vec3d(2.5, 1, 2), Vec3d(0, 0, -1)), t, n));
    CHECK_THROWS_AS(SphereShape<double>(Vec3d(0), -1.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(QuadShape<double>(Vec3d(0), Vec3d(1, 0, 0), Vec3d(2, 0, 0)), grainlight::invalid_argument);
}

TEST_CASE("Triangle-mesh shape through the BVH agrees with the analytic box", "[scene][mesh]") {
    const auto mesh = MeshShape<double>::from_obj(write_cube_obj(1.0).string(), 0.5, Vec3d(0.25, 0, 0));
    const BoxShape<double> box(Vec3d(-0.25, -0.5, -0.5), Vec3d(0.75, 0.5, 0.5));
    CHECK(mesh.area() == Approx(6.0));
    Rng rng = Rng::from_key(5);
    int hits = 0;
    for (int i = 0; i < 2000; ++i) {
        const Vec3d o = 3.0 * sample_uniform_sphere(rng.uniform2<double>());
        const Vec3d target(rng.uniform<double>() - 0.5, rng.uniform<double>() - 0.5, rng.uniform<double>() - 0.5);
        const Rayd r(o, glm::normalize(target - o));
        double t1 = 0, t2 = 0;
        Vec3d n1(0.0), n2(0.0);
        const bool b1 = mesh.intersect(r, t1, n1), b2 = box.intersect(r, t2, n2);
        REQUIRE(b1 == b2);
        if (b1) {
            ++hits;
            REQUIRE(t1 == Approx(t2).margin(1e-9));
            REQUIRE(glm::dot(n1, n2) == Approx(1.0).margin(1e-9));  // outward on both
        }
    }
    CHECK(hits > 500);
}

TEST_CASE("Mesh instances under a similarity transform match the transformed mesh", "[scene][mesh][instance]") {
    const auto base = MeshShape<double>::from_obj(write_cube_obj(1.0).string());
    Transform<double> xf;
    xf.rotation = uniform_random_rotation(Vec3d(0.3, 0.7, 0.1));
    xf.scale = 0.4;
    xf.translation = Vec3d(0.2, -0.1, 0.3);
    const InstanceShape<double> inst(base, xf);
    // Reference: the same cube with its vertices moved to world space, with its own BVH.
    TriangleMesh<double> moved = load_obj<double>(write_cube_obj(1.0).string());
    for (auto& v : moved.vertices) v = xf.point_to_world(v);
    const MeshShape<double> ref(moved);
    CHECK(inst.area() == Approx(ref.area()));
    Rng rng = Rng::from_key(6);
    int hits = 0;
    for (int i = 0; i < 2000; ++i) {
        const Vec3d o = 3.0 * sample_uniform_sphere(rng.uniform2<double>());
        const Vec3d target = xf.translation + 0.5 * sample_uniform_sphere(rng.uniform2<double>());
        const Rayd r(o, glm::normalize(target - o));
        double t1 = 0, t2 = 0;
        Vec3d n1(0.0), n2(0.0);
        const bool b1 = inst.intersect(r, t1, n1), b2 = ref.intersect(r, t2, n2);
        REQUIRE(b1 == b2);
        if (b1) {
            ++hits;
            REQUIRE(t1 == Approx(t2).margin(1e-9));
            REQUIRE(glm::dot(n1, n2) == Approx(1.0).margin(1e-9));
        }
    }
    CHECK(hits > 500);
    Transform<double> bad;
    bad.scale = 0.0;
    CHECK_THROWS_AS(InstanceShape<double>(base, bad), grainlight::invalid_argument);
}

TEST_CASE("Unreadable or malformed mesh files give a clear exception", "[scene][mesh][errors]") {
    const std::string missing = "/nonexistent/dir/grain.obj";
    try {
        (void)MeshShape<float>::from_obj(missing);
        FAIL("no exception");
    } catch (const grainlight::io_error& e) {
        CHECK(std::string(e.what()).find(missing) != std::string::npos);
    }
    const fs::path bad = fs::temp_directory_path() / "grainlight_test_scene" / "bad.obj";
    fs::create_directories(bad.parent_path());
    {
        std::ofstream f(bad);
        f << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
    }
    CHECK_THROWS_AS(MeshShape<float>::from_obj(bad.string()), grainlight::format_error);
    CHECK_THROWS_AS(MeshShape<float>::from_obj(write_cube_obj(1.0).string(), -1.0f), grainlight::invalid_argument);
}

TEST_CASE("Pinhole camera: centre ray, field of view, projection round trip, ray cone", "[scene][camera]") {
    const PinholeCamera<double> cam(Vec3d(0, 0, 5), Vec3d(0, 0, 0), Vec3d(0, 1, 0), 90.0, 200, 100);
    const Rayd c = cam.generate_ray(100.0, 50.0);
    CHECK(c.d.z == Approx(-1.0));
    // Top edge of the image at 45 degrees above the axis (vertical fov 90).
    const Rayd top = cam.generate_ray(100.0, 0.0);
    CHECK(std::atan2(top.d.y, -top.d.z) == Approx(pi_v<double> / 4));
    // Right edge: aspect 2 -> tan = 2.
    const Rayd right = cam.generate_ray(200.0, 50.0);
    CHECK(right.d.x / -right.d.z == Approx(2.0));
    CHECK(cam.spread_angle() == Approx(2.0 / 100.0));
    double px, py;
    REQUIRE(cam.project(c.o + 3.0 * cam.generate_ray(37.25, 81.5).d, px, py));
    CHECK(px == Approx(37.25));
    CHECK(py == Approx(81.5));
    CHECK_FALSE(cam.project(Vec3d(0, 0, 10), px, py));  // behind
    CHECK_THROWS_AS(PinholeCamera<double>(Vec3d(0), Vec3d(0), Vec3d(0, 1, 0), 45.0, 10, 10), grainlight::invalid_argument);
    CHECK_THROWS_AS(PinholeCamera<double>(Vec3d(0, 0, 1), Vec3d(0), Vec3d(0, 0, 1), 45.0, 10, 10),
                    grainlight::invalid_argument);
}

TEST_CASE("Quad area light: sampled irradiance matches the closed form; pdfs agree", "[scene][lights]") {
    // Square of side 2a at height h above a point on its axis, facing down, radiance L:
    // E = 4 L A / sqrt(1 + A^2) atan(A / sqrt(1 + A^2)), A = a / h (differential-area-to-
    // rectangle view factor, e.g. Howell's catalogue of configuration factors, case B-3).
    const double a = 1.0, h = 1.5, L = 2.0;
    SceneT s;
    s.add_quad_light(QuadShape<double>(Vec3d(-a, h, -a), Vec3d(2 * a, 0, 0), Vec3d(0, 0, 2 * a)), RGBd(L));
    const Vec3d ref(0, 0, 0), nrm(0, 1, 0);
    Welford e;
    Rng rng = Rng::from_key(9);
    for (int i = 0; i < 200000; ++i) {
        const Vec3d u(rng.uniform<double>(), rng.uniform<double>(), rng.uniform<double>());
        const auto ls = s.sample_light(ref, u);
        if (!ls) {
            e.add(0);
            continue;
        }
        e.add(ls.L[0] * std::max(0.0, glm::dot(ls.w, nrm)) / ls.pdf);
        if (i < 1000) {  // light_pdf of the hit equals the sampling pdf
            const auto hit = s.intersect(Rayd(ref, ls.w));
            REQUIRE(hit.light == 0);
            REQUIRE(s.light_pdf(ref, ls.w, hit) == Approx(ls.pdf).epsilon(1e-9));
            REQUIRE(s.emitted(hit, ls.w)[0] == L);
            REQUIRE(s.emitted(hit, -ls.w)[0] == 0.0);  // one-sided
        }
    }
    const double A = a / h, s1 = std::sqrt(1 + A * A);
    const double E = 4 * L * A / s1 * std::atan(A / s1);
    CHECK(std::abs(e.mean() - E) < 4 * e.standard_error());

    // Point and spot lights: inverse-square law, spot falloff.
    SceneT p;
    p.add_light(SceneT::LightT::point_light(Vec3d(0, 2, 0), RGBd(8.0)));
    const auto lp = p.sample_light(Vec3d(0), Vec3d(0.5));
    CHECK(lp.delta);
    CHECK(lp.L[0] == Approx(2.0));
    CHECK(lp.dist == Approx(2.0));
    SceneT sp;
    sp.add_light(SceneT::LightT::spot_light(Vec3d(0, 2, 0), Vec3d(0, -1, 0), RGBd(8.0), 10.0, 20.0));
    CHECK(sp.sample_light(Vec3d(0), Vec3d(0.5)).L[0] == Approx(2.0));
    CHECK(sp.sample_light(Vec3d(2, 0, 0), Vec3d(0.5)).L[0] == 0.0);  // 45 degrees: outside the cone
    CHECK_THROWS_AS(SceneT::LightT::point_light(Vec3d(0), RGBd(-1.0)), grainlight::invalid_argument);
    SceneT env;
    env.add_light(SceneT::LightT::environment_light(RGBd(1.0)));
    CHECK_THROWS_AS(env.add_light(SceneT::LightT::environment_light(RGBd(1.0))), grainlight::invalid_argument);
}

TEST_CASE("Scene validates medium indices and reports nested media on hits", "[scene]") {
    SceneT s;
    const auto matched = Material<double, RGBd>::index_matched();
    CHECK_THROWS_AS(s.add_shape(SphereShape<double>(Vec3d(0), 1.0), matched, 0, -1), grainlight::invalid_argument);
    const int m = s.add_medium(MediumT(RGBd(1.0), RGBd(0.5), IsotropicPhase<double, RGBd>()));
    s.add_shape(SphereShape<double>(Vec3d(0), 1.0), Material<double, RGBd>::dielectric(1.5), m, -1);
    const auto hit = s.intersect(Rayd(Vec3d(0, 0, 3), Vec3d(0, 0, -1)));
    REQUIRE(hit.hit());
    CHECK(hit.type == SurfaceType::dielectric);
    CHECK(hit.eta == 1.5);
    CHECK(hit.medium_inside == m);
    CHECK(hit.medium_outside == -1);
    CHECK(s.occluded(Vec3d(0, 0, 3), Vec3d(0, 0, -3)));
    CHECK_FALSE(s.occluded(Vec3d(0, 3, 3), Vec3d(0, 3, -3)));
    using Mat = Material<double, RGBd>;
    CHECK_THROWS_AS(Mat::diffuse(RGBd(1.5)), grainlight::invalid_argument);
}

#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/unbounded_medium.hpp"

TEST_CASE("Unbounded medium scene: photon walks match the infinite-medium closed forms", "[scene][unbounded]") {
    // In an infinite medium of albedo a every photon is eventually absorbed after a geometric
    // number of scatterings: E[scatterings] = a / (1 - a); the first free flight has mean 1/sigma_t.
    using Grey = grainlight::Spectrum<1, double>;
    using HG = grainlight::HenyeyGreenstein<double, Grey>;
    using M = grainlight::ContinuousMedium<HG, Grey>;
    const double sigma_t = 2.5, a = 0.8;
    const M medium(Grey(sigma_t), Grey(a), HG(0.4));
    const grainlight::UnboundedMediumScene<M> scene(medium);
    static_assert(grainlight::WalkScene<grainlight::UnboundedMediumScene<M>>);
    struct Count {
        long scatters = 0;
        double first = -1;
        grainlight::Vec3d start{0.0};
        bool on_scatter(grainlight::PathState<double, Grey>& st, const grainlight::Interaction<double, Grey>& it, const M&) {
            if (first < 0) first = glm::length(it.p - start);
            ++scatters;
            (void)st;
            return true;
        }
    };
    const int n = 40000;
    double scat = 0, scat2 = 0, flight = 0;
    grainlight::WalkOptions<double> wo;
    wo.mode = grainlight::TransportMode::importance;
    for (int i = 0; i < n; ++i) {
        grainlight::Rng rng = grainlight::Rng::from_key(11, std::uint64_t(i));
        auto st = grainlight::start_path(grainlight::Ray<double>(grainlight::Vec3d(0.0), grainlight::Vec3d(0, 0, 1)), 0,
                                         Grey(1.0));
        Count c;
        const auto end = grainlight::walk(scene, st, rng, c, wo);
        REQUIRE(end == grainlight::WalkEnd::absorbed);
        scat += double(c.scatters);
        scat2 += double(c.scatters) * double(c.scatters);
        flight += c.first >= 0 ? c.first : 0.0;
    }
    const double mean = scat / n, var = scat2 / n - mean * mean;
    INFO("mean scatterings " << mean << " vs " << a / (1 - a) << ", mean first flight " << flight / n);
    CHECK(std::abs(mean - a / (1 - a)) < 4 * std::sqrt(var / n));
    // First flight (to the first scattering, a fraction a of the photons; absorbed ones count 0):
    // E = a / sigma_t, standard error below 1 / (sigma_t sqrt(n)).
    CHECK(std::abs(flight / n - a / sigma_t) < 4.0 / (sigma_t * std::sqrt(double(n))));
}
