// The multiple-scattering far field (PointBasedOptions::ms_far_field = diffusion, our addition to
// Wang18's Eq. 7): the table within its grid, the infinite-medium diffusion kernel beyond it, and
// the bounded-medium correction of diffusion theory on a grid (diffusion/grid.hpp, checked on its
// own against the sphere's closed forms in tests/diffusion/test_grid.cpp).
//
// Independent reference: the VPT of the same scene (all scattering orders, boundary reflections
// included), in a sphere of 12 mean free paths with albedo 0.99 (diffusion length 8 mean free
// paths), where a table of +-4 mean free paths misses most of the multiple scattering.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include "scene_fixture.hpp"

using namespace pb_test;

namespace {

constexpr float kThickSigma = 12.0f;  // sphere radius 1 = 12 mean free paths
constexpr float kThickAlbedo = 0.99f;
constexpr float kThickG = 0.5f;

MediumT thick_medium() { return MediumT(kThickSigma, kThickAlbedo, Phase(kThickG)); }

// Every path that scattered at least once and then reached the light.
struct Scattered {
    const SceneT& scene;
    int count = 0;
    float L = 0;
    bool on_scatter(PathState<float, Grey>&, const Interaction<float, Grey>&, const MediumT&) noexcept {
        ++count;
        return true;
    }
    bool on_surface(PathState<float, Grey>& st, const SurfaceHit<float, Grey>& hit) noexcept {
        if (hit.light >= 0 && count >= 1) L += (st.throughput * scene.emitted(hit, st.ray.d))[0];
        return true;
    }
};

const MsTable<1>& small_table() {
    static const MsTable<1> t = [] {
        MsTableOptions o;
        o.n_rho = 16;
        o.n_z = 32;
        o.n_theta = 8;
        o.n_phi = 4;
        o.rho_max = 4;
        o.z_min = -4;
        o.z_max = 4;
        o.photons = 20000;
        return MsTable<1>::build(Phase(kThickG), Grey(kThickAlbedo), o);
    }();
    return t;
}

PointBasedOptions<float> options(MsFarField ff) {
    PointBasedOptions<float> o;
    o.volume_step = 0.25f / kThickSigma;
    o.light_samples = 1;
    o.light_bounces = 0;
    o.camera_bounces = 0;
    o.max_optical_depth = 8.0f;
    o.k_max = 3;
    o.bounce_samples = 400;
    o.bounce_rays = 2;
    o.bounce_k_max = 2;
    o.cut = CutCriterion<float>{0.5f, 0.1f, pi_v<float> / 4};
    o.two_step_depth = 3;
    o.ms_far_field = ff;
    return o;
}

}  // namespace

TEST_CASE("far field: a thick high-albedo sphere against the VPT", "[point_based][far-field]") {
    SceneT scene;
    const int mi = scene.add_medium(thick_medium());
    scene.add_shape(sphere(), Material<float, Grey>::dielectric(kEta), mi, -1);
    scene.add_quad_light(quad(), Grey(1.0f));
    // Reference: the image mean over the patch |x|, |y| < 0.8 of the z = 0 plane.
    const Vec2f c(0.0f, 0.0f);
    const float h = 0.8f;
    Welford ref;
    WalkOptions<float> wo;
    for (int i = 0; i < 60000; ++i) {
        Rng rng = Rng::from_key(77, std::uint64_t(i));
        Scattered cb{scene};
        PathState<float, Grey> st = start_path<float, Grey>(patch_ray(c, h, rng), -1);
        (void)walk(scene, st, rng, cb, wo);
        ref.add(double(cb.L));
    }
    double pb[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
        const MsFarField ff = k == 0 ? MsFarField::none : MsFarField::diffusion;
        Rng lrng = Rng::from_key(5);
        const Renderer r(thick_medium(), kEta, sphere(), sphere_surface_samples(sphere(), 2000),
                         Light<float, Grey>::quad_light(quad(), Grey(1.0f)), options(ff), lrng, &small_table(),
                         sphere_surface_samples(sphere(), 400));
        if (ff == MsFarField::diffusion) {
            REQUIRE(r.far_field_grid() != nullptr);
            CHECK(r.far_field_grid()->inside_count() > 1000);
        } else {
            CHECK(r.far_field_grid() == nullptr);
        }
        Welford w;
        for (int i = 0; i < 1500; ++i) {
            Rng rng = Rng::from_key(31, std::uint64_t(i));
            w.add(double(r.radiance(patch_ray(c, h, rng), rng)[0]));
        }
        pb[k] = w.mean();
    }
    const double rel_none = pb[0] / ref.mean() - 1, rel_far = pb[1] / ref.mean() - 1;
    const double se = ref.standard_error() / ref.mean();
    std::printf("far field: VPT %.5f +- %.1f%%; Eq. 7 (table of +-4 mfp) %+.1f%%; with the diffusion far field %+.1f%%\n",
                ref.mean(), 100 * se, 100 * rel_none, 100 * rel_far);
    // The table alone misses the light that diffuses beyond its 4 mean free paths.
    CHECK(rel_none < -0.15);
    // With the far field the image mean is within 6 % (+ 3 standard errors of the reference).
    CHECK(std::abs(rel_far) < 0.06 + 3 * se);
}

TEST_CASE("far field: bad input", "[point_based][far-field]") {
    Rng lrng = Rng::from_key(5);
    auto o = options(MsFarField::diffusion);
    const auto samples = sphere_surface_samples(sphere(), 200);
    const auto light = Light<float, Grey>::quad_light(quad(), Grey(1.0f));
    CHECK_THROWS_WITH(Renderer(thick_medium(), kEta, sphere(), samples, light, o, lrng, nullptr),
                      Catch::Contains("ms table"));
    o.diffusion_cell = 0.0f;
    CHECK_THROWS_WITH(Renderer(thick_medium(), kEta, sphere(), samples, light, o, lrng, &small_table()),
                      Catch::Contains("diffusion_cell"));
    o.diffusion_cell = 0.5f;
    o.diffusion_opening = 3.0f;
    CHECK_THROWS_WITH(Renderer(thick_medium(), kEta, sphere(), samples, light, o, lrng, &small_table()),
                      Catch::Contains("diffusion_opening"));
    o.diffusion_opening = 0.5f;
    o.bounce_cut_scale = 0.5f;
    CHECK_THROWS_WITH(Renderer(thick_medium(), kEta, sphere(), samples, light, o, lrng, &small_table()),
                      Catch::Contains("bounce_cut_scale"));
    o.bounce_cut_scale = 1.0f;
    o.ms_cut_eps1 = -1.0f;
    CHECK_THROWS_WITH(Renderer(thick_medium(), kEta, sphere(), samples, light, o, lrng, &small_table()),
                      Catch::Contains("ms_cut_eps1"));
}
