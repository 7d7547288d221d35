// Spectral correctness of explicit path tracing: every channel of a Spectrum<8> render uses its
// own grain material value (no channel is folded onto RGB's blue), checked against
//  - energy conservation: lossless grains under a constant environment give 1 in every channel
//    (radiance invariance), and
//  - eight independent 1-channel renders, each with the material value of one channel: the
//    8-channel result of channel c must agree with the 1-channel result within Monte Carlo error.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>

#include "grainlight/integrators/ept.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/scene.hpp"

using namespace grainlight;

namespace {

template <class S>
using SceneOf = Scene<ContinuousMedium<HenyeyGreenstein<float, S>, S>>;
using S8 = Spectrum<8, float>;
using S1 = Spectrum<1, float>;

PeriodicTile spectral_tile() {
    Rng rng = Rng::from_key(5, 0, 0);
    return random_sequential_addition(40, 0.3, rng, 2.0);
}

GranularAggregate<SphereBoundary> aggregate_of(const GrainMaterial& m) {
    const SphereBoundary shape(Vec3d(0.0), 3.0);
    std::vector<GrainExemplar> ex = {GrainExemplar::sphere(0.9, m)};
    return GranularAggregate<SphereBoundary>(spectral_tile(), VoxelizedBoundary<SphereBoundary>(shape, 2.0), ex, {1.0}, 3);
}

/// Mean and standard error per channel of the radiance of `n` rays aimed into the aggregate
/// under a unit environment.
template <class S>
std::pair<std::array<double, S::size>, std::array<double, S::size>> mean_radiance(const GranularAggregate<SphereBoundary>& agg,
                                                                                  int n, std::uint64_t seed) {
    SceneOf<S> scene;
    scene.add_light(Light<float, S>::environment_light(S(1.0f)));
    std::array<double, S::size> s{}, s2{}, mean{}, se{};
    for (int i = 0; i < n; ++i) {
        Rng rng = Rng::from_key(seed, std::uint64_t(i), 0);
        const Vec3d o = 8.0 * sample_uniform_sphere(rng.uniform2<double>());
        const Vec3d target = 2.5 * sample_uniform_sphere(rng.uniform2<double>());
        const Ray<float> r(Vec3f(o), Vec3f(glm::normalize(target - o)));
        const auto L = ept_radiance(scene, agg, r, rng, EptOptions{});
        for (std::size_t c = 0; c < S::size; ++c) {
            const double v = double(L.low[c] + L.high[c]);
            s[c] += v;
            s2[c] += v * v;
        }
    }
    for (std::size_t c = 0; c < S::size; ++c) {
        mean[c] = s[c] / n;
        se[c] = std::sqrt(std::max(0.0, s2[c] / n - mean[c] * mean[c]) / n);
    }
    return {mean, se};
}

}  // namespace

TEST_CASE("EPT with 8 spectral channels: lossless grains give 1 in every channel", "[aggregates][ept][spectral]") {
    SECTION("smooth dielectric") {
        const auto [m, se] = mean_radiance<S8>(aggregate_of(GrainMaterial::make_dielectric(1.5)), 800, 3);
        for (std::size_t c = 0; c < 8; ++c) REQUIRE(m[c] == Approx(1.0).margin(2e-3));
    }
    SECTION("white diffuse grains given as 8 channels") {
        const GrainMaterial white = GrainMaterial::make_diffuse(ChannelValues{1, 1, 1, 1, 1, 1, 1, 1});
        const auto [m, se] = mean_radiance<S8>(aggregate_of(white), 1500, 4);
        for (std::size_t c = 0; c < 8; ++c) {
            INFO("channel " << c << ": " << m[c] << " +- " << se[c]);
            REQUIRE(std::abs(m[c] - 1.0) < 4 * se[c] + 0.01);
        }
    }
}

TEST_CASE("EPT with 8 channels whose albedos differ equals eight 1-channel renders", "[aggregates][ept][spectral]") {
    // Albedos / absorptions chosen so that channels 3..7 differ strongly from channel 2: folding
    // them onto channel 2 (the old min(c, 2) bug) moves their means by many standard errors.
    const std::array<double, 8> albedo{0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.95};
    const std::array<double, 8> sigma_a{2.0, 1.5, 1.0, 0.6, 0.35, 0.2, 0.1, 0.02};
    for (const bool diffuse : {true, false}) {
        const auto make = [&](std::span<const double> v) {
            return diffuse ? GrainMaterial::make_diffuse(ChannelValues(v))
                           : GrainMaterial::make_absorbing_dielectric(1.5, ChannelValues(v), 0.5, 0.3);
        };
        const auto& values = diffuse ? albedo : sigma_a;
        const int n = diffuse ? 3000 : 2500;
        const auto [m8, se8] = mean_radiance<S8>(aggregate_of(make(values)), n, 11);
        for (std::size_t c = 0; c < 8; ++c) {
            const double v = values[c];
            const auto [m1, se1] = mean_radiance<S1>(aggregate_of(make(std::span<const double>(&v, 1))), n, 101 + c);
            const double tol = 4.0 * std::sqrt(se8[c] * se8[c] + se1[0] * se1[0]);
            INFO((diffuse ? "diffuse" : "absorbing dielectric") << " channel " << c << ": 8-channel " << m8[c] << " +- "
                                                                << se8[c] << ", 1-channel " << m1[0] << " +- " << se1[0]);
            REQUIRE(std::abs(m8[c] - m1[0]) < tol);
        }
        // The channels really differ (the test would see a fold onto channel 2).
        REQUIRE(std::abs(m8[7] - m8[2]) > 10.0 * std::sqrt(se8[7] * se8[7] + se8[2] * se8[2]));
    }
}

TEST_CASE("Rendering refuses materials whose channel count does not match the spectrum", "[aggregates][ept][spectral]") {
    const auto agg = aggregate_of(GrainMaterial::make_diffuse(RGBd{0.2, 0.5, 0.8}));
    // A 1-channel render of an RGB material: render_ept names the mismatch.
    SceneOf<S1> scene;
    scene.add_light(Light<float, S1>::environment_light(S1(1.0f)));
    PinholeCamera<float> cam(Vec3f(0, 0, 10), Vec3f(0.0f), Vec3f(0, 1, 0), 30.0f, 4, 4);
    REQUIRE_THROWS_WITH(render_ept(scene, agg, cam, 1, 1), Catch::Contains("material channels") && Catch::Contains("3"));
    // 8 channels: the check every render entry point runs.
    REQUIRE_THROWS_WITH(check_material_channels(agg, 8, "render_ept"), Catch::Contains("material channels"));
    // Grey RGB values are fine in any spectrum.
    const auto grey = aggregate_of(GrainMaterial::make_diffuse(RGBd(0.5)));
    REQUIRE_NOTHROW(render_ept(scene, grey, cam, 1, 1));
    REQUIRE_NOTHROW(check_material_channels(grey, 8, "render_ept"));
    // And a mismatched material definition is rejected where it is made.
    GrainMaterial bad = GrainMaterial::make_absorbing_dielectric(1.5, RGBd{0.1, 0.2, 0.3});
    bad.interior_sigma_s = ChannelValues{0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8};
    REQUIRE_THROWS_WITH(bad.validate(), Catch::Contains("channel counts"));
}
