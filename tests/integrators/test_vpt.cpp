// Volumetric path tracer and render driver: white furnace (energy conservation and the radiance
// invariance L/n^2 across dielectric boundaries), NEE + MIS against pure path tracing (two
// estimators of the same image), determinism for 1 and 2 threads.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/scene.hpp"

using namespace grainlight;

namespace {

using Phase = HenyeyGreenstein<float, RGB>;
using MediumT = ContinuousMedium<Phase, RGB>;
using SceneT = Scene<MediumT>;
using Grey = Spectrum<1, float>;
using GreyMedium = ContinuousMedium<HenyeyGreenstein<float, Grey>, Grey>;
using GreyScene = Scene<GreyMedium>;

const RGB kEnv{0.7f, 0.5f, 0.3f};
const float kGreyEnv = 0.7f;

// Closed medium sphere (radius 1, sigma_t = 3, HG g = 0.6) under a constant environment.
// The RGB version has a chromatic sigma_t (spectral free-flight sampling with MIS weights).
SceneT furnace_scene(const Material<float, RGB>& boundary, float albedo) {
    SceneT s;
    const int m = s.add_medium(MediumT(RGB{2.0f, 3.0f, 4.0f}, RGB(albedo), Phase(0.6f)));
    s.add_shape(SphereShape<float>(Vec3f(0.0f), 1.0f), boundary, m, -1);
    s.add_light(SceneT::LightT::environment_light(kEnv));
    return s;
}
GreyScene grey_furnace_scene(const Material<float, Grey>& boundary, float albedo) {
    GreyScene s;
    const int m = s.add_medium(GreyMedium(3.0f, albedo, HenyeyGreenstein<float, Grey>(0.6f)));
    s.add_shape(SphereShape<float>(Vec3f(0.0f), 1.0f), boundary, m, -1);
    s.add_light(GreyScene::LightT::environment_light(Grey(kGreyEnv)));
    return s;
}

PinholeCamera<float> furnace_camera(int w, int h) {
    // The sphere fills the central part of the view; the rest sees the environment directly.
    return PinholeCamera<float>(Vec3f(0, 0, 4), Vec3f(0, 0, 0), Vec3f(0, 1, 0), 35.0f, w, h);
}

// Mean and standard error of per-pixel values of channel c (pixels are independent estimates).
struct MeanSe {
    double mean, se;
};
MeanSe pixel_stats(const Image& img, int c) {
    const std::size_t n = img.rgb.size() / 3;
    double s = 0, s2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const double v = img.rgb[3 * i + std::size_t(c)];
        s += v;
        s2 += v * v;
    }
    const double m = s / double(n);
    return {m, std::sqrt(std::max(0.0, (s2 / double(n) - m * m) / double(n - 1)))};
}

}  // namespace

TEST_CASE("White furnace, index-matched closed medium: pure path tracing returns L_env exactly", "[vpt][furnace]") {
    const GreyScene scene = grey_furnace_scene(Material<float, Grey>::index_matched(), 1.0f);
    RenderOptions opt;
    opt.spp = 4;
    opt.vpt.nee = false;
    opt.vpt.max_depth = 1 << 20;
    const Image img = render_vpt(scene, furnace_camera(24, 24), opt).image();
    // Albedo 1, grey weight-1 walks: every path escapes with throughput exactly 1 (Russian
    // roulette never kills at weight 1), so every pixel is L_env up to float rounding.
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            for (int c = 0; c < 3; ++c) REQUIRE(img.at(x, y, c) == Approx(kGreyEnv).epsilon(1e-5));
}

TEST_CASE("White furnace with NEE + MIS conserves energy", "[vpt][furnace]") {
    const SceneT scene = furnace_scene(Material<float, RGB>::index_matched(), 1.0f);
    RenderOptions opt;
    opt.spp = 16;
    opt.vpt.max_depth = 1 << 20;
    const Image img = render_vpt(scene, furnace_camera(32, 32), opt).image();
    for (int c = 0; c < 3; ++c) {
        const MeanSe st = pixel_stats(img, c);
        INFO("channel " << c << ": mean " << st.mean << " +- " << st.se << " vs L_env " << kEnv[std::size_t(c)]);
        CHECK(std::abs(st.mean - kEnv[std::size_t(c)]) <= 4 * st.se + 1e-4);
        CHECK(st.se < 0.02 * kEnv[std::size_t(c)]);  // the test has resolving power
    }
}

TEST_CASE("White furnace behind a dielectric boundary (n = 1.5): L/n^2 invariance", "[vpt][furnace][dielectric]") {
    // Entering multiplies radiance-mode throughput by 1/n^2, leaving by n^2: a closed conservative
    // system under a constant environment shows L_env everywhere (Kirchhoff).
    RenderOptions opt;
    opt.spp = 16;
    opt.vpt.max_depth = 1 << 20;
    for (float eta : {1.5f, 1.0f / 1.5f}) {
        const GreyScene scene = grey_furnace_scene(Material<float, Grey>::dielectric(eta), 1.0f);
        const Image img = render_vpt(scene, furnace_camera(32, 32), opt).image();
        const MeanSe st = pixel_stats(img, 0);
        INFO("eta " << eta << ": mean " << st.mean << " +- " << st.se << " vs L_env " << kGreyEnv);
        CHECK(std::abs(st.mean - kGreyEnv) <= 4 * st.se + 1e-4);
    }
    const SceneT rgb = furnace_scene(Material<float, RGB>::dielectric(1.5f), 1.0f);
    const Image img = render_vpt(rgb, furnace_camera(32, 32), opt).image();
    for (int c = 0; c < 3; ++c) {
        const MeanSe st = pixel_stats(img, c);
        INFO("RGB channel " << c << ": mean " << st.mean << " +- " << st.se << " vs L_env " << kEnv[std::size_t(c)]);
        CHECK(std::abs(st.mean - kEnv[std::size_t(c)]) <= 4 * st.se + 1e-4);
    }
    // An absorbing interior must darken the sphere: the furnace test can fail.
    const GreyScene grey = grey_furnace_scene(Material<float, Grey>::dielectric(1.5f), 0.5f);
    const Image img2 = render_vpt(grey, furnace_camera(32, 32), opt).image();
    CHECK(pixel_stats(img2, 0).mean < 0.9 * kGreyEnv);
}

TEST_CASE("Radiance inside a dielectric is n^2 times the environment's (radiance-mode scaling)",
          "[vpt][dielectric]") {
    // A camera inside a closed lossless dielectric sphere (eta = 1.5) under a constant
    // environment sees n^2 L_env in every direction (L/n^2 is invariant along rays; Fresnel
    // reflections only delay the exit). Without the 1/eta^2 factor of radiance mode it sees L_env.
    GreyScene s;
    s.add_shape(SphereShape<float>(Vec3f(0.0f), 1.0f), Material<float, Grey>::dielectric(1.5f), -1, -1);
    s.add_light(GreyScene::LightT::environment_light(Grey(kGreyEnv)));
    const PinholeCamera<float> cam(Vec3f(0.0f, 0.0f, 0.3f), Vec3f(0.0f, 0.2f, -1.0f), Vec3f(0, 1, 0), 60.0f, 16, 16);
    RenderOptions opt;
    opt.spp = 4;
    opt.vpt.max_depth = 1 << 20;
    opt.vpt.rr_depth = 1 << 20;  // no roulette: every path exits with weight exactly n^2
    const Image img = render_vpt(s, cam, opt).image();
    for (std::size_t i = 0; i < img.rgb.size(); ++i) REQUIRE(img.rgb[i] == Approx(2.25f * kGreyEnv).epsilon(1e-4));

    // The same with a conservative medium filling the sphere and the camera inside it.
    GreyScene m;
    const int med = m.add_medium(GreyMedium(2.0f, 1.0f, HenyeyGreenstein<float, Grey>(0.3f)));
    m.add_shape(SphereShape<float>(Vec3f(0.0f), 1.0f), Material<float, Grey>::dielectric(1.5f), med, -1);
    m.add_light(GreyScene::LightT::environment_light(Grey(kGreyEnv)));
    opt.camera_medium = med;
    const Image img2 = render_vpt(m, cam, opt).image();
    for (std::size_t i = 0; i < img2.rgb.size(); ++i) REQUIRE(img2.rgb[i] == Approx(2.25f * kGreyEnv).epsilon(1e-4));
}

namespace {
SceneT lit_scene() {
    SceneT s;
    const int m = s.add_medium(MediumT(RGB{2.0f, 3.0f, 4.0f}, RGB(0.85f), Phase(0.3f)));
    const int m2 = s.add_medium(MediumT(RGB{4.0f, 4.5f, 5.0f}, RGB{0.9f, 0.7f, 0.5f}, Phase(0.0f)));
    // Ground, an index-matched medium sphere, a dielectric sphere with a medium, an area light.
    s.add_shape(QuadShape<float>(Vec3f(-4, 0, -4), Vec3f(0, 0, 8), Vec3f(8, 0, 0)),
                Material<float, RGB>::diffuse(RGB{0.6f, 0.6f, 0.5f}));
    s.add_shape(SphereShape<float>(Vec3f(-0.8f, 0.7f, 0.0f), 0.7f), Material<float, RGB>::index_matched(), m, -1);
    s.add_shape(SphereShape<float>(Vec3f(0.9f, 0.6f, 0.2f), 0.6f), Material<float, RGB>::dielectric(1.33f), m2, -1);
    s.add_quad_light(QuadShape<float>(Vec3f(-1, 3, -1), Vec3f(2, 0, 0), Vec3f(0, 0, 2)), RGB(6.0f));
    s.add_light(SceneT::LightT::environment_light(RGB(0.1f)));
    return s;
}
// The lit scene with a glossy ground and a near-mirror glossy ball.
SceneT lit_scene_glossy() {
    SceneT s;
    const int m = s.add_medium(MediumT(RGB{2.0f, 3.0f, 4.0f}, RGB(0.85f), Phase(0.3f)));
    s.add_shape(QuadShape<float>(Vec3f(-4, 0, -4), Vec3f(0, 0, 8), Vec3f(8, 0, 0)),
                Material<float, RGB>::glossy(RGB{0.7f, 0.6f, 0.4f}, 0.3f));
    s.add_shape(SphereShape<float>(Vec3f(-0.8f, 0.7f, 0.0f), 0.7f), Material<float, RGB>::index_matched(), m, -1);
    s.add_shape(SphereShape<float>(Vec3f(0.9f, 0.6f, 0.2f), 0.6f), Material<float, RGB>::glossy(RGB(0.9f), 0.05f));
    s.add_quad_light(QuadShape<float>(Vec3f(-1, 3, -1), Vec3f(2, 0, 0), Vec3f(0, 0, 2)), RGB(6.0f));
    s.add_light(SceneT::LightT::environment_light(RGB(0.1f)));
    return s;
}
PinholeCamera<float> lit_camera(int w, int h) {
    return PinholeCamera<float>(Vec3f(0, 1.5f, 5), Vec3f(0, 0.6f, 0), Vec3f(0, 1, 0), 40.0f, w, h);
}
}  // namespace

namespace {
// NEE + MIS (64 spp, `seed`) and pure path tracing (`pt_spp`, seed + 1) render `scene`; per channel
// the per-pixel differences are independent with mean 0 if both estimators are unbiased.
void check_nee_matches_path_tracing(const SceneT& scene, std::uint64_t seed, int pt_spp) {
    const auto cam = lit_camera(32, 24);
    RenderOptions a;
    a.spp = 64;
    a.seed = seed;
    RenderOptions b = a;
    b.seed = seed + 1;
    b.vpt.nee = false;
    b.spp = pt_spp;
    const Image ia = render_vpt(scene, cam, a).image();
    const Image ib = render_vpt(scene, cam, b).image();
    for (int c = 0; c < 3; ++c) {
        Image d(ia.width, ia.height);
        for (std::size_t i = 0; i < d.rgb.size(); ++i) d.rgb[i] = ia.rgb[i] - ib.rgb[i];
        const MeanSe st = pixel_stats(d, c);
        const double level = pixel_stats(ia, c).mean;
        INFO("channel " << c << ": mean(NEE - PT) = " << st.mean << " +- " << st.se << ", image mean " << level);
        CHECK(std::abs(st.mean) <= 4 * st.se + 1e-3 * level);
        CHECK(level > 0.05);
    }
}
}  // namespace

TEST_CASE("NEE + MIS and pure path tracing estimate the same image", "[vpt][nee][mis]") {
    check_nee_matches_path_tracing(lit_scene(), 3, 256);
}

TEST_CASE("Glossy surfaces: NEE + MIS and pure path tracing estimate the same image", "[vpt][nee][mis][glossy]") {
    check_nee_matches_path_tracing(lit_scene_glossy(), 5, 512);
    REQUIRE_THROWS_WITH((Material<float, RGB>::glossy(RGB(0.5f), 0.0f)), Catch::Contains("alpha"));
    REQUIRE_THROWS_WITH((Material<float, RGB>::glossy(RGB{0.5f, 1.5f, 0.5f}, 0.2f)), Catch::Contains("F0"));
}

TEST_CASE("Render is identical for 1 and 2 threads", "[vpt][determinism]") {
    const SceneT scene = lit_scene();
    const auto cam = lit_camera(24, 16);
    RenderOptions o;
    o.spp = 4;
    o.threads = 1;
    const Image one = render_vpt(scene, cam, o).image();
    o.threads = 2;
    const Image two = render_vpt(scene, cam, o).image();
    REQUIRE(one.rgb.size() == two.rgb.size());
    for (std::size_t i = 0; i < one.rgb.size(); ++i) REQUIRE(one.rgb[i] == two.rgb[i]);
    o.seed = 99;
    const Image other = render_vpt(scene, cam, o).image();
    bool differs = false;
    for (std::size_t i = 0; i < one.rgb.size(); ++i) differs = differs || one.rgb[i] != other.rgb[i];
    CHECK(differs);  // the seed matters
}

TEST_CASE("Walk kernel callbacks see every event of a photon walk", "[walk]") {
    // A medium sphere lit from outside: count scatter events and escapes through callbacks; the
    // mean number of collisions of a photon entering a sphere of optical radius tau along a
    // diameter with albedo 0 is 1 - exp(-2 tau) (each path collides at most once).
    SceneT s;
    const int m = s.add_medium(MediumT(RGB(1.0f), RGB(0.0f), Phase(0.0f)));
    s.add_shape(SphereShape<float>(Vec3f(0.0f), 1.0f), Material<float, RGB>::index_matched(), m, -1);
    struct Counter {
        int escapes = 0, absorbs = 0, surfaces = 0;
        void on_escape(const PathState<float, RGB>&) { ++escapes; }
        void on_absorb(const PathState<float, RGB>&) { ++absorbs; }
        bool on_surface(PathState<float, RGB>&, const SurfaceHit<float, RGB>&) {
            ++surfaces;
            return true;
        }
    } cnt;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        Rng rng = Rng::from_key(7, std::uint64_t(i));
        auto st = start_path<float, RGB>(Ray<float>(Vec3f(0, 0, 5), Vec3f(0, 0, -1)), -1);
        WalkOptions<float> wo;
        wo.mode = TransportMode::importance;
        (void)walk(s, st, rng, cnt, wo);
    }
    const double p_abs = 1 - std::exp(-2.0);
    CHECK(cnt.escapes + cnt.absorbs == n);
    CHECK(double(cnt.absorbs) / n == Approx(p_abs).margin(4 * std::sqrt(p_abs * (1 - p_abs) / n)));
    CHECK(cnt.surfaces == n + cnt.escapes);  // enter once; escapers cross once more
}

TEST_CASE("Photon walks from lights: flux on a patch matches the closed-form flux", "[walk][lights]") {
    // Lights h = 1.5 above an absorbing square patch (side 0.6) centred below them. Expected flux:
    // point/spot: I * Omega, Omega = 4 asin(p^2 / (p^2 + h^2)) for the square of half-side p on
    // the axis; quad (half-side a, radiance L): the patch integral of the irradiance, E(x, z) from
    // the corner-rectangle view factor (Howell's catalogue, case B-3) summed with signs over the
    // four corners, by a 40 x 40 midpoint rule.
    using MD = ContinuousMedium<HenyeyGreenstein<double, RGBd>, RGBd>;
    using SD = Scene<MD>;
    const double h = 1.5, a = 1.0, L = 2.0, I = 3.0, side = 0.6, p = side / 2;
    struct PatchCounter {
        int patch;
        double flux = 0;
        bool on_surface(PathState<double, RGBd>& st, const SurfaceHit<double, RGBd>& hit) {
            if (hit.shape == patch) flux += st.throughput[0];
            return true;
        }
    };
    auto measure = [&](const SD& s, int patch, int n) {
        PatchCounter pc{patch};
        for (int i = 0; i < n; ++i) {
            Rng rng = Rng::from_key(17, std::uint64_t(i));
            const auto e = s.sample_emission(rng.uniform<double>(), rng.uniform2<double>(), rng.uniform2<double>());
            if (!e) continue;
            auto st = start_path<double, RGBd>(e.ray, -1, e.weight);
            WalkOptions<double> wo;
            wo.mode = TransportMode::importance;
            (void)walk(s, st, rng, pc, wo);
        }
        return pc.flux / n;
    };
    const auto patch_shape = QuadShape<double>(Vec3d(-p, 0, -p), Vec3d(0, 0, side), Vec3d(side, 0, 0));
    const auto black = Material<double, RGBd>::absorber();
    const int n = 4000000;
    const double omega = 4 * std::asin(p * p / (p * p + h * h));
    {
        SD s;
        const int patch = s.add_shape(patch_shape, black);
        s.add_quad_light(QuadShape<double>(Vec3d(-a, h, -a), Vec3d(2 * a, 0, 0), Vec3d(0, 0, 2 * a)), RGBd(L));
        auto corner = [&](double X, double Z) {  // odd in X and Z
            const double sx = std::sqrt(X * X + h * h), sz = std::sqrt(Z * Z + h * h);
            return 0.5 * L * (X / sx * std::atan(Z / sx) + Z / sz * std::atan(X / sz));
        };
        double expected = 0;
        const int m = 40;
        for (int i = 0; i < m; ++i)
            for (int j = 0; j < m; ++j) {
                const double x = -p + side * (i + 0.5) / m, z = -p + side * (j + 0.5) / m;
                const double E = corner(a - x, a - z) - corner(-a - x, a - z) - corner(a - x, -a - z) + corner(-a - x, -a - z);
                expected += E * (side / m) * (side / m);
            }
        // Bernoulli-like estimator: relative standard error ~ 1/sqrt(hits).
        const double hits = expected / (L * pi_v<double> * 4 * a * a) * n;
        CHECK(measure(s, patch, n) == Approx(expected).epsilon(4 / std::sqrt(hits)));
    }
    {
        SD s;
        const int patch = s.add_shape(patch_shape, black);
        s.add_light(SD::LightT::point_light(Vec3d(0, h, 0), RGBd(I)));
        const double hits = omega / (4 * pi_v<double>) * n;
        CHECK(measure(s, patch, n) == Approx(I * omega).epsilon(4 / std::sqrt(hits)));
    }
    {
        SD s;
        const int patch = s.add_shape(patch_shape, black);
        // Inner cone 20 deg covers the patch corners (atan(0.3 sqrt 2 / 1.5) = 15.8 deg).
        s.add_light(SD::LightT::spot_light(Vec3d(0, h, 0), Vec3d(0, -1, 0), RGBd(I), 20.0, 30.0));
        const double hits = omega / (2 * pi_v<double> * (1 - std::cos(pi_v<double> / 6))) * n;
        CHECK(measure(s, patch, n) == Approx(I * omega).epsilon(4 / std::sqrt(hits)));
    }
}

TEST_CASE("Delta lights on a diffuse plane: NEE gives the closed-form radiance", "[vpt][lights]") {
    // Lambertian plane (albedo rho) lit by a directional light (irradiance E at normal incidence,
    // arriving at 60 degrees) or a point light (intensity I at height h): L = rho/pi * E cos(theta)
    // and L = rho/pi * I cos(theta) / r^2. Nothing else in the scene, so every sample is exact.
    const float rho = 0.5f, E = 2.0f, I = 3.0f, h = 2.0f;
    const Vec3f view_from(0.3f, 1.0f, 1.0f);
    auto radiance_at_origin = [&](const SceneT& s) {
        Rng rng = Rng::from_key(3);
        const Ray<float> r(view_from, glm::normalize(-view_from));
        return vpt_radiance(s, r, -1, rng)[1];
    };
    SceneT a;
    a.add_shape(QuadShape<float>(Vec3f(-5, 0, -5), Vec3f(0, 0, 10), Vec3f(10, 0, 0)), Material<float, RGB>::diffuse(RGB(rho)));
    a.add_light(SceneT::LightT::directional_light(Vec3f(std::sqrt(3.0f) / 2, -0.5f, 0.0f), RGB(E)));
    CHECK(radiance_at_origin(a) == Approx(rho / pi_v<float> * E * 0.5f).epsilon(1e-4));
    SceneT b;
    b.add_shape(QuadShape<float>(Vec3f(-5, 0, -5), Vec3f(0, 0, 10), Vec3f(10, 0, 0)), Material<float, RGB>::diffuse(RGB(rho)));
    b.add_light(SceneT::LightT::point_light(Vec3f(1.0f, h, 0.0f), RGB(I)));
    const float r2 = 1.0f + h * h, cos_t = h / std::sqrt(r2);
    CHECK(radiance_at_origin(b) == Approx(rho / pi_v<float> * I * cos_t / r2).epsilon(1e-4));
}
