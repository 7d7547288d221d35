// Render driver robustness: non-finite samples are counted per pixel (never dropped silently, never
// poisoning a pixel), and checkpoints: a render stopped after some rows and resumed from its
// checkpoint is bit-identical to an uninterrupted render; a checkpoint of another render is refused.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <limits>

#include "grainlight/integrators/render.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/film_checkpoint.hpp"
#include "grainlight/scene/scene.hpp"

using namespace grainlight;

namespace {

using Grey = Spectrum<1, float>;

// A defective phase function: Henyey-Greenstein whose sampled weight is NaN for backward
// scattering (cos < -0.5). A path that takes such a bounce carries NaN radiance: the
// "NaN-producing configuration" whose samples the driver must count.
struct NanBackwardPhase {
    using Float = float;
    using Spectrum = Grey;
    HenyeyGreenstein<float, Grey> hg{0.3f};
    [[nodiscard]] PhaseEval<float, Grey> eval(const Vec3f& wi, const Vec3f& wo) const noexcept { return hg.eval(wi, wo); }
    [[nodiscard]] PhaseSample<float, Grey> sample(const Vec3f& wi, Vec2f u) const noexcept {
        auto s = hg.sample(wi, u);
        if (dot(wi, s.w) < -0.5f) s.weight = Grey(std::numeric_limits<float>::quiet_NaN());
        return s;
    }
    [[nodiscard]] Grey mean_cosine() const noexcept { return hg.mean_cosine(); }
};
static_assert(PhaseFunction<NanBackwardPhase>);

using NanMedium = ContinuousMedium<NanBackwardPhase, Grey>;
using NanScene = Scene<NanMedium>;

NanScene nan_scene() {
    NanScene s;
    const int m = s.add_medium(NanMedium(2.0f, 0.9f, NanBackwardPhase{}));
    s.add_shape(SphereShape<float>(Vec3f(0.0f), 1.0f), Material<float, Grey>::index_matched(), m, -1);
    s.add_light(NanScene::LightT::environment_light(Grey(0.5f)));
    return s;
}

PinholeCamera<float> camera(int w, int h) {
    return PinholeCamera<float>(Vec3f(0, 0, 4), Vec3f(0, 0, 0), Vec3f(0, 1, 0), 35.0f, w, h);
}

std::filesystem::path scratch(const char* name) {
    const auto dir = std::filesystem::temp_directory_path() / "grainlight_test_render_driver";
    std::filesystem::create_directories(dir);
    return dir / name;
}

}  // namespace

TEST_CASE("Non-finite samples are counted per pixel and replaced by zero", "[render][nan]") {
    // A camera whose rays carry their film position in the origin, so the radiance function knows
    // the pixel: NaN in every third column, +Inf on row 5, 0.25 elsewhere. The count is exact.
    struct PixelCamera {
        using Float = float;
        [[nodiscard]] int width() const noexcept { return 16; }
        [[nodiscard]] int height() const noexcept { return 12; }
        [[nodiscard]] Ray<float> generate_ray(float px, float py) const noexcept {
            return Ray<float>(Vec3f(px, py, 0.0f), Vec3f(0, 0, 1));
        }
    };
    RenderOptions opt;
    opt.spp = 3;
    opt.threads = 2;
    const Film bad = render_image(
        PixelCamera{},
        [](const Ray<float>& ray, Rng&) {
            const int x = int(std::floor(ray.o.x)), y = int(std::floor(ray.o.y));
            if (y == 5) return Grey(std::numeric_limits<float>::infinity());
            if (x % 3 == 0) return Grey(std::numeric_limits<float>::quiet_NaN());
            return Grey(0.25f);
        },
        opt);
    std::uint64_t expected = 0;
    for (int y = 0; y < 12; ++y)
        for (int x = 0; x < 16; ++x) expected += (y == 5 || x % 3 == 0) ? 3 : 0;
    CHECK(bad.nonfinite_samples() == expected);
    CHECK(bad.nonfinite(0, 0) == 3);
    CHECK(bad.nonfinite(1, 0) == 0);
    CHECK(bad.nonfinite(1, 5) == 3);
    const Image img = bad.image();
    for (float v : img.rgb) REQUIRE(std::isfinite(v));
    CHECK(img.at(1, 0, 0) == Approx(0.25f));
    CHECK(img.at(0, 0, 0) == 0.0f);  // a bad sample counts as a zero sample
    Film merged(16, 12);
    merged.merge(bad);
    merged.merge(bad);
    CHECK(merged.nonfinite_samples() == 2 * expected);
}

TEST_CASE("A NaN-producing medium: the film's count equals a serial recount of the bad samples", "[render][nan]") {
    const NanScene scene = nan_scene();
    const auto cam = camera(20, 16);
    RenderOptions opt;
    opt.spp = 4;
    opt.threads = 2;
    const Film film = render_vpt(scene, cam, opt);
    // Independent recount: the same (seed, pixel, sample) generators, serially.
    std::uint64_t recount = 0;
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 20; ++x)
            for (int s = 0; s < opt.spp; ++s) {
                Rng rng = Rng::from_key(opt.seed, std::uint64_t(y) * 20 + std::uint64_t(x), std::uint64_t(s));
                const Vec2f u = rng.uniform2<float>();
                const auto ray = cam.generate_ray(float(x) + u.x, float(y) + u.y);
                if (!vpt_radiance(scene, ray, -1, rng, opt.vpt).is_finite()) ++recount;
            }
    INFO("non-finite samples: " << film.nonfinite_samples() << " of " << 20 * 16 * opt.spp);
    CHECK(recount > 20);  // the configuration does produce NaNs
    CHECK(film.nonfinite_samples() == recount);
    for (float v : film.image().rgb) REQUIRE(std::isfinite(v));
}

TEST_CASE("A render resumed from its checkpoint is bit-identical to an uninterrupted one", "[render][checkpoint]") {
    const NanScene scene = nan_scene();  // includes non-finite counts in what must survive
    const auto cam = camera(24, 18);
    RenderOptions opt;
    opt.spp = 3;
    opt.seed = 5;
    opt.threads = 2;
    const Film reference = render_vpt(scene, cam, opt);

    const auto path = scratch("resume.fckp");
    std::filesystem::remove(path);
    // A partial render: the checkpoint a killed run would have left after 7 rows, built from
    // the rows of an independent render (rows are independent by construction).
    {
        FilmCheckpoint ck;
        ck.seed = opt.seed;
        ck.spp = std::uint64_t(opt.spp);
        ck.key = 42;
        ck.rows_done.assign(18, 0);
        std::vector<double> sums(3 * 24 * 18, 0.0), weights(24 * 18, 0.0);
        std::vector<std::uint32_t> nonfinite(24 * 18, 0u);
        for (int y : {0, 3, 4, 5, 9, 16, 17}) {
            ck.rows_done[std::size_t(y)] = 1;
            for (int x = 0; x < 24; ++x) {
                const std::size_t i = std::size_t(y) * 24 + std::size_t(x);
                for (int c = 0; c < 3; ++c) sums[3 * i + std::size_t(c)] = reference.sums()[3 * i + std::size_t(c)];
                weights[i] = reference.weights()[i];
                nonfinite[i] = reference.nonfinite_counts()[i];
            }
        }
        ck.films = {Film::from_accumulators(24, 18, sums, weights, nonfinite)};
        ck.save(path);
    }
    RenderOptions ro = opt;
    ro.checkpoint.path = path;
    ro.checkpoint.resume = true;
    ro.checkpoint.key = 42;
    ro.checkpoint.interval_seconds = 0.0;  // write after every row: exercises concurrent snapshots
    ro.checkpoint.remove_when_done = false;
    const Film resumed = render_image(
        cam,
        [&](const auto& ray, Rng& rng) {
            return vpt_radiance(scene, ray, -1, rng, ro.vpt);
        },
        ro);
    REQUIRE(resumed.sums().size() == reference.sums().size());
    for (std::size_t i = 0; i < reference.sums().size(); ++i) REQUIRE(resumed.sums()[i] == reference.sums()[i]);
    for (std::size_t i = 0; i < reference.weights().size(); ++i) REQUIRE(resumed.weights()[i] == reference.weights()[i]);
    CHECK(resumed.nonfinite_samples() == reference.nonfinite_samples());
    // The last checkpoint written holds the whole finished film.
    const FilmCheckpoint last = FilmCheckpoint::load(path);
    CHECK(last.rows_finished() == 18);
    for (std::size_t i = 0; i < reference.sums().size(); ++i) REQUIRE(last.films[0].sums()[i] == reference.sums()[i]);

    SECTION("a checkpoint of another render is refused with a message naming the mismatch") {
        RenderOptions other = ro;
        other.checkpoint.key = 43;
        CHECK_THROWS_WITH(render_vpt(scene, cam, other), Catch::Contains("key 42, this render 43"));
        other = ro;
        other.spp = 4;
        CHECK_THROWS_WITH(render_vpt(scene, cam, other), Catch::Contains("spp 3, this render 4"));
        other = ro;
        other.seed = 6;
        CHECK_THROWS_WITH(render_vpt(scene, cam, other), Catch::Contains("seed"));
        CHECK_THROWS_WITH(render_vpt(scene, camera(25, 18), ro), Catch::Contains("width 24, this render 25"));
    }
    SECTION("without resume the checkpoint is ignored and overwritten; it is removed when done") {
        RenderOptions fresh = opt;
        fresh.checkpoint.path = path;
        fresh.checkpoint.interval_seconds = 0.0;
        const Film f = render_vpt(scene, cam, fresh);
        for (std::size_t i = 0; i < reference.sums().size(); ++i) REQUIRE(f.sums()[i] == reference.sums()[i]);
        CHECK_FALSE(std::filesystem::exists(path));
    }
    SECTION("bad checkpoint options") {
        RenderOptions b = ro;
        b.checkpoint.interval_seconds = -1.0;
        CHECK_THROWS_WITH(render_vpt(scene, cam, b), Catch::Contains("checkpoint.interval_seconds"));
    }
    std::filesystem::remove(path);
}

TEST_CASE("Row shares (one per MPI rank) put together give the whole render bit for bit", "[render][mpi]") {
    const NanScene scene = nan_scene();
    const auto cam = camera(18, 13);
    RenderOptions opt;
    opt.spp = 2;
    const Film whole = render_vpt(scene, cam, opt);
    Film sum(18, 13);
    for (int r = 0; r < 3; ++r) {
        RenderOptions share = opt;
        share.row_offset = r;
        share.row_stride = 3;
        const Film part = render_vpt(scene, cam, share);
        for (int y = 0; y < 13; ++y)  // rows of other shares stay empty
            if (y % 3 != r) REQUIRE(part.weight(0, y) == 0.0);
        sum.merge(part);  // disjoint rows: the merge is a placement (x + 0 == x exactly)
    }
    for (std::size_t i = 0; i < whole.sums().size(); ++i) REQUIRE(sum.sums()[i] == whole.sums()[i]);
    CHECK(sum.nonfinite_samples() == whole.nonfinite_samples());
    RenderOptions bad = opt;
    bad.row_stride = 2;
    bad.row_offset = 2;
    CHECK_THROWS_WITH(render_vpt(scene, cam, bad), Catch::Contains("row_offset"));
    bad.row_stride = 0;
    CHECK_THROWS_WITH(render_vpt(scene, cam, bad), Catch::Contains("row_stride"));
}
