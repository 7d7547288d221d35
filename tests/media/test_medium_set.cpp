// MediumSet<Ms...>: one scene holding two medium kinds (a continuous HG medium and Meng15's
// teleportation medium) renders each exactly as a scene of that medium alone: an opaque wall
// separates the two spheres, so a camera path on one side never meets the other medium, and the
// keyed random streams make the pixels on each side bit-identical to the single-kind render.
#include <catch2/catch.hpp>

#include <cstring>

#include "grainlight/integrators/render.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/medium_set.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/scatterometer.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/scene.hpp"

using namespace grainlight;

namespace {

using CM = ContinuousMedium<HenyeyGreenstein<float, RGB>, RGB>;
using TM = TeleportationMedium<float>;
using Set = MediumSet<CM, TM>;

static_assert(Medium<Set>);
static_assert(PhaseMedium<Set>);
static_assert(PhaseFunction<PhaseSet<float, RGB, CM, TM>>);

const Vec3f kA(-1.6f, 0.0f, 0.0f), kB(1.6f, 0.0f, 0.0f);

template <class SceneT>
void add_wall_and_light(SceneT& s) {
    // Opaque absorbing wall in the plane x = 0 from far below to z = 3 (the camera is at z = 6).
    s.add_shape(BoxShape<float>(Vec3f(-0.02f, -50.0f, -50.0f), Vec3f(0.02f, 50.0f, 3.0f)),
                SceneT::MaterialT::absorber());
    s.add_light(SceneT::LightT::environment_light(RGB{0.9f, 0.7f, 0.5f}));
}

CM continuous() { return CM(RGB{3.0f, 2.0f, 1.5f}, RGB{0.95f, 0.9f, 0.8f}, HenyeyGreenstein<float, RGB>(0.5f)); }

TM teleportation() {
    ScatterometerConfig c;
    c.rays = 20000;
    c.seed = 3;
    const GrainStats st = run_scatterometer(ScatterometerGrain::sphere(0.8, GrainMaterial::make_absorbing_dielectric(1.5, RGBd{0.1, 0.3, 0.6})), c);
    return TM(st, 0.55, 0.1);
}

PinholeCamera<float> camera() { return PinholeCamera<float>(Vec3f(0, 0, 6), Vec3f(0, 0, 0), Vec3f(0, 1, 0), 50.0f, 40, 20); }

}  // namespace

TEST_CASE("MediumSet: two medium kinds in one scene render like each alone", "[media][medium_set]") {
    RenderOptions opt;
    opt.spp = 3;
    opt.seed = 7;
    opt.threads = 1;

    Scene<CM> a;
    add_wall_and_light(a);
    a.add_shape(SphereShape<float>(kA, 1.0f), Scene<CM>::MaterialT::dielectric(1.33f), a.add_medium(continuous()), -1);

    Scene<TM> b;
    add_wall_and_light(b);
    b.add_shape(SphereShape<float>(kB, 1.0f), Scene<TM>::MaterialT::index_matched(), b.add_medium(teleportation()), -1);

    Scene<Set> both;
    add_wall_and_light(both);
    both.add_shape(SphereShape<float>(kA, 1.0f), Scene<Set>::MaterialT::dielectric(1.33f), both.add_medium(Set(continuous())), -1);
    both.add_shape(SphereShape<float>(kB, 1.0f), Scene<Set>::MaterialT::index_matched(), both.add_medium(Set(teleportation())), -1);
    REQUIRE(both.medium(0).index() == 0);
    REQUIRE(both.medium(1).index() == 1);

    const auto cam = camera();
    const Image ia = render_vpt(a, cam, opt).image();
    const Image ib = render_vpt(b, cam, opt).image();
    const Image ik = render_vpt(both, cam, opt).image();
    const int w = cam.width(), h = cam.height();
    int same_a = 0, same_b = 0, lit_a = 0, lit_b = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (x >= w / 2 - 1 && x <= w / 2) continue;  // jittered rays of the middle columns may go either way
            const std::size_t i = 3 * (std::size_t(y) * std::size_t(w) + std::size_t(x));
            const bool left = x < w / 2;
            const Image& ref = left ? ia : ib;
            bool eq = true;
            for (int c = 0; c < 3; ++c) eq = eq && ik.rgb[i + c] == ref.rgb[i + c];
            (left ? same_a : same_b) += eq ? 1 : 0;
            // The medium really shows: the pixel differs from the other kind's render.
            const Image& other = left ? ib : ia;
            (left ? lit_a : lit_b) += ref.rgb[i] != other.rgb[i] ? 1 : 0;
        }
    const int half = (w / 2 - 1) * h;
    CHECK(same_a == half);
    CHECK(same_b == half);
    CHECK(lit_a > half / 10);  // each sphere covers about 1/7 of its half of the image
    CHECK(lit_b > half / 10);
}

TEST_CASE("MediumSet forwards the phase function and albedo of the active kind", "[media][medium_set]") {
    const Set s = continuous();
    const Vec3f w(0, 0, 1), v = glm::normalize(Vec3f(0.3f, 0.1f, 0.9f));
    const auto e1 = s.phase().eval(w, v);
    const auto e2 = continuous().phase().eval(w, v);
    REQUIRE(e1.pdf == e2.pdf);
    REQUIRE(e1.value == e2.value);
    REQUIRE(s.phase().mean_cosine() == RGB(0.5f));
    REQUIRE(s.get_if<CM>() != nullptr);
    REQUIRE(s.get_if<TM>() == nullptr);
    const Set t = teleportation();
    REQUIRE(t.phase().eval(w, v).pdf == 0.0f);  // a kind that chooses its own directions has no phase
    REQUIRE(t.to_string().find("kind 1 of 2") != std::string::npos);
}
