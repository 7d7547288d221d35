// Wang18 Sec. 3.5.1: camera rays that reach the point-based medium after bounces in a surrounding
// scene (integrators/point_based_surroundings.hpp). Checked against (a) the closed form of the
// irradiance a uniformly bright sphere casts on a floor point (Nusselt: pi L (r/D)^2 cos theta_c
// for a sphere wholly above the horizon), (b) the library's VPT of the same scene with the object
// black (the surroundings part, bit for bit), (c) the renderer's own radiance for rays that hit
// the object first (bit for bit).
#include <catch2/catch.hpp>

#include <cmath>

#include "grainlight/integrators/point_based_surroundings.hpp"
#include "scene_fixture.hpp"

using namespace pb_test;

namespace {

// The object's appearance as a constant radiance (the closed form's uniformly bright sphere).
struct UniformObject {
    float L0 = 1.0f;
    [[nodiscard]] Grey radiance(const Ray<float>&, Rng&) const noexcept { return Grey(L0); }
};

// A 40 x 40 diffuse floor at y = -2 (normal +y) under the unit sphere of the fixture.
QuadShape<float> floor_quad() { return QuadShape<float>(Vec3f(-20.0f, -2.0f, -20.0f), Vec3f(0, 0, 40), Vec3f(40, 0, 0)); }

// The camera ray of the floor point x0 = (1.5, -2, 0): from (4, 3, 0), passing the sphere at 2.24.
Ray<float> floor_ray() {
    const Vec3f o(4.0f, 3.0f, 0.0f), x0(1.5f, -2.0f, 0.0f);
    return Ray<float>(o, glm::normalize(x0 - o));
}

}  // namespace

TEST_CASE("point_based_in_scene: a floor lit by a uniformly bright object matches the closed form",
          "[point_based][surroundings]") {
    SceneT scene;
    scene.add_shape(floor_quad(), Material<float, Grey>::diffuse(Grey(0.5f)));
    const int obj = scene.add_shape(sphere(), Material<float, Grey>::absorber());
    const UniformObject L{1.0f};
    // x0 = (1.5, -2, 0), centre (0, 0, 0): D = 2.5, cos theta_c = 2 / 2.5, r = 1; floor albedo 0.5.
    // Radiance of x0: (rho / pi) E = rho L0 (r / D)^2 cos theta_c.
    const double expected = 0.5 * 1.0 * (1.0 / 6.25) * 0.8;
    const int n = 200000;
    Welford w;
    for (int i = 0; i < n; ++i) {
        Rng rng = Rng::from_key(501, std::uint64_t(i));
        const auto r = point_based_in_scene(scene, obj, L, floor_ray(), rng);
        REQUIRE(r.surroundings[0] == 0.0f);  // no lights, no environment
        w.add(double(r.object[0]));
    }
    INFO("object light at x0: " << w.mean() << " +- " << w.standard_error() << ", closed form " << expected);
    CHECK(std::abs(w.mean() - expected) < 4.0 * w.standard_error());
    CHECK(w.standard_error() < 0.01 * expected);  // the check resolves 4 % of the value
}

TEST_CASE("point_based_in_scene: a glossy floor reflects the object as the BRDF quadrature says",
          "[point_based][surroundings][glossy]") {
    // The object light at x0 through a glossy floor: L0 times the integral of f cos over the
    // directions that reach the sphere (a quadrature of eval_glossy over the hemisphere).
    const float alpha = 0.3f;
    const Grey F0(0.8f);
    SceneT scene;
    scene.add_shape(floor_quad(), Material<float, Grey>::glossy(F0, alpha));
    const int obj = scene.add_shape(sphere(), Material<float, Grey>::absorber());
    const UniformObject L{1.0f};
    const Ray<float> ray = floor_ray();
    const Vec3d x0(1.5, -2.0, 0.0), wo = -Vec3d(ray.d);  // local frame = world (normal +y -> z)
    double expected = 0;
    const int nt = 600, np = 1200;
    for (int i = 0; i < nt; ++i) {
        const double th = (i + 0.5) * 0.5 * pi_v<double> / nt;
        for (int j = 0; j < np; ++j) {
            const double ph = (j + 0.5) * 2 * pi_v<double> / np;
            const Vec3d w(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));  // y up
            // Does the ray x0 + t w meet the unit sphere at the origin?
            const double b = glm::dot(x0, w), c = glm::dot(x0, x0) - 1.0;
            if (b * b - c <= 0 || -b - std::sqrt(b * b - c) <= 0) continue;
            // Local frame with the normal (+y) as z: f depends only on the angles, so swapping y
            // and z (a reflection) leaves it unchanged.
            float pdf = 0;
            const Vec3f wol(float(wo.x), float(wo.z), float(wo.y)), wl(float(w.x), float(w.z), float(w.y));
            expected += double(eval_glossy(wol, wl, F0, alpha, pdf)[0]) * std::sin(th);
        }
    }
    expected *= (0.5 * pi_v<double> / nt) * (2 * pi_v<double> / np);
    const int n = 200000;
    Welford w;
    for (int i = 0; i < n; ++i) {
        Rng rng = Rng::from_key(507, std::uint64_t(i));
        w.add(double(point_based_in_scene(scene, obj, L, ray, rng).object[0]));
    }
    INFO("object light through the glossy floor: " << w.mean() << " +- " << w.standard_error() << ", quadrature " << expected);
    CHECK(std::abs(w.mean() - expected) < 4.0 * w.standard_error() + 2e-3 * expected);
    CHECK(expected > 0.01);
}

TEST_CASE("point_based_in_scene: the surroundings part is the VPT with the object black, bit for bit",
          "[point_based][surroundings]") {
    SceneT scene;
    scene.add_shape(floor_quad(), Material<float, Grey>::diffuse(Grey(0.5f)));
    const int obj = scene.add_shape(sphere(), Material<float, Grey>::absorber());
    scene.add_quad_light(quad(), Grey(1.0f));
    const UniformObject dark{0.0f};
    int lit = 0;
    for (int i = 0; i < 4000; ++i) {
        Rng pick = Rng::from_key(502, std::uint64_t(i));
        const Vec3f o(6.0f * pick.uniform<float>() - 3.0f, 1.5f, 6.0f);
        const Vec3f target(4.0f * pick.uniform<float>() - 2.0f, -2.0f, 4.0f * pick.uniform<float>() - 2.0f);
        const Ray<float> ray(o, glm::normalize(target - o));
        Rng a = Rng::from_key(503, std::uint64_t(i)), b = Rng::from_key(503, std::uint64_t(i));
        const auto r = point_based_in_scene(scene, obj, dark, ray, a);
        const Grey v = vpt_radiance(scene, ray, -1, b);
        REQUIRE(r.surroundings[0] == v[0]);
        REQUIRE(r.object[0] == 0.0f);
        lit += v[0] > 0.0f;
    }
    REQUIRE(lit > 1000);  // the floor is lit (and shadowed by the object elsewhere)
}

TEST_CASE("point_based_in_scene: a ray that hits the object first gets the renderer's radiance",
          "[point_based][surroundings]") {
    PointBasedOptions<float> o;
    o.volume_step = 0.1f;
    o.light_samples = 2;
    o.max_optical_depth = 6.0f;
    o.multiple = false;
    o.bounced = false;
    Rng build = Rng::from_key(504);
    const Renderer pb(medium(), kEta, sphere(), sphere_surface_samples(sphere(), 1500),
                      Light<float, Grey>::quad_light(quad(), Grey(1.0f)), o, build);
    SceneT scene;
    scene.add_shape(floor_quad(), Material<float, Grey>::diffuse(Grey(0.5f)));
    const int obj = scene.add_shape(sphere(), Material<float, Grey>::absorber());
    double sum = 0;
    for (int i = 0; i < 200; ++i) {
        Rng pick = Rng::from_key(505, std::uint64_t(i));
        const Ray<float> ray = patch_ray(Vec2f(0.0f), 0.6f, pick);
        Rng a = Rng::from_key(506, std::uint64_t(i)), b = Rng::from_key(506, std::uint64_t(i));
        const auto r = point_based_in_scene(scene, obj, pb, ray, a);
        const Grey direct = pb.radiance(ray, b);
        REQUIRE(r.object[0] == direct[0]);
        REQUIRE(r.surroundings[0] == 0.0f);
        sum += double(direct[0]);
    }
    REQUIRE(sum > 0.0);
}
