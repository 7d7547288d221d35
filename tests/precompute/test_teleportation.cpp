// Tests of the teleportation-transport medium and the effective RTE parameters (Meng15 Eqs. 1-4,
// Sec. 4.2.3).
#include <catch2/catch.hpp>

#include <vector>

#include "grainlight/media/teleportation.hpp"
#include "grainlight/precompute/scatterometer.hpp"

using namespace grainlight;

namespace {
GrainStats stats_of(double rho, GrainMaterial m, std::uint64_t rays = 60000, std::uint64_t seed = 21) {
    ScatterometerConfig c;
    c.rays = rays;
    c.seed = seed;
    return run_scatterometer(ScatterometerGrain::sphere(rho, m), c);
}
}  // namespace

TEST_CASE("Eqs. 1 and 3 in closed form", "[teleportation]") {
    // Eq. 1 at f = 0.63, R = 1: sigma_b = 3 * 0.63 / (4 * 0.37).
    CHECK(bounding_sphere_sigma_b(0.63, 1.0) == Approx(1.89 / 1.48));
    CHECK(bounding_sphere_sigma_b(0.5, 2.0) == Approx(0.375));
    // Eq. 3 is the sum of Eq. 2's series: check against the partial sums.
    const double lb = 0.8, ld = 0.9, beta = 0.4;
    double series = 0;
    for (int i = 0; i < 2000; ++i) series += beta * std::pow(1 - beta, i) * (i * (lb + ld) + lb);
    CHECK(lambda_beta_eq3(lb, ld, beta) == Approx(series).epsilon(1e-10));
    CHECK(lambda_beta_eq3(lb, ld, 1.0) == Approx(lb));
    CHECK_THROWS_AS(bounding_sphere_sigma_b(0.0, 1.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(bounding_sphere_sigma_b(1.0, 1.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(bounding_sphere_sigma_b(0.6, 0.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(bounding_sphere_sigma_b(0.6, -1.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(lambda_beta_eq3(1, 1, 0.0), grainlight::invalid_argument);
}

TEST_CASE("effective RTE parameters scale with f and R without recomputation", "[teleportation]") {
    const auto s = stats_of(0.7, GrainMaterial::make_absorbing_dielectric(1.5, RGBd{0.1, 0.4, 1.0}), 40000);
    const auto p1 = effective_rte_params(s, 0.6, 1.0);
    const auto p2 = effective_rte_params(s, 0.6, 3.0);
    for (std::size_t c = 0; c < 3; ++c) {
        // Every length scales with R, so every coefficient scales with 1/R.
        CHECK(p2.sigma_t[c] == Approx(p1.sigma_t[c] / 3.0));
        CHECK(p2.sigma_tr[c] == Approx(p1.sigma_tr[c] / 3.0));
        CHECK(p2.alpha_s_reduced[c] == Approx(p1.alpha_s_reduced[c]));
        // Eq. 4 and Sec. 4.2.3 by hand.
        const double lt = p1.lambda_beta + s.alpha_s(c) * s.lambda_s(c);
        CHECK(p1.sigma_t[c] == Approx(1.0 / lt));
        const double ss = s.alpha_s(c) / lt, sa = 1.0 / lt - ss, ssr = (1 - s.g(c)) * ss;
        CHECK(p1.sigma_t_reduced[c] == Approx(ssr + sa));
        CHECK(p1.alpha_s_reduced[c] == Approx(ssr / (ssr + sa)));
    }
    CHECK(p1.alpha_s[0] > p1.alpha_s[2]);
    const auto medium = make_effective_medium(s, 0.6, 1.0);
    CHECK(double(medium.sigma_t()[1]) == Approx(p1.sigma_t[1]).epsilon(1e-6));
    CHECK(double(medium.albedo()[2]) == Approx(p1.alpha_s[2]).epsilon(1e-6));
    CHECK_THROWS_AS(effective_rte_params(s, 0.7, 0.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(effective_rte_params(s, 1.5, 1.0), grainlight::invalid_argument);
}

TEST_CASE("TT medium: mean free flight between exit points equals 1/sigma_t of Eq. 4", "[teleportation]") {
    // The TT process flies Exp(sigma_b) to a bounding sphere, passes through with probability
    // 1 - beta (adding a chord), and on a hit adds the teleport (0 if absorbed). Its mean
    // displacement along the ray is Eq. 4's lambda_beta + alpha_s lambda_s (for grains whose mean
    // teleport points forward). Binning the tables into cells costs < 1 %.
    struct Case {
        double rho;
        GrainMaterial m;
    };
    for (const Case& k : {Case{1.0, GrainMaterial::make_dielectric(1.5)}, Case{0.6, GrainMaterial::make_dielectric(1.33)},
                          Case{0.8, GrainMaterial::make_absorbing_dielectric(1.5, RGBd(0.5))}}) {
        const auto s = stats_of(k.rho, k.m);
        for (double R : {1.0, 0.25}) {
            const TeleportationMedium<float> tt(s, 0.63, R);
            Rng rng = Rng::from_key(99, std::uint64_t(k.rho * 100));
            const Ray<float> ray(Vec3f(0.0f), Vec3f(0, 0, 1));
            const int n = 200000;
            double sum = 0, sum2 = 0;
            int absorbed = 0;
            for (int i = 0; i < n; ++i) {
                const auto it = tt.sample_interaction(ray, std::numeric_limits<float>::infinity(), rng);
                REQUIRE(!it.is_escape());
                const double z = double(it.p.z);  // displacement along the incident direction
                sum += z;
                sum2 += z * z;
                absorbed += it.is_absorb();
                if (it.is_scatter()) {
                    REQUIRE(std::abs(glm::length(it.w) - 1.0f) < 1e-4f);
                    REQUIRE(it.nee == NeeKind::none);
                    REQUIRE(it.has_direction);
                }
            }
            const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean) / std::sqrt(double(n));
            const double expected = 1.0 / tt.params().sigma_t[0];
            CHECK(mean == Approx(expected).margin(4 * sd + 0.01 * expected));
            CHECK(double(absorbed) / n == Approx(1.0 - s.alpha_s(0)).margin(0.005));
        }
    }
}

TEST_CASE("TT medium: spectral weights average to alpha_s per channel; transmittance", "[teleportation]") {
    const RGBd sigma{0.05, 0.5, 2.0};
    const auto s = stats_of(1.0, GrainMaterial::make_absorbing_dielectric(1.5, sigma), 40000);
    const TeleportationMedium<float> tt(s, 0.6, 1.0);
    Rng rng = Rng::from_key(5);
    const Ray<float> ray(Vec3f(0.0f), Vec3f(1, 0, 0));
    const int n = 200000;
    RGBd acc(0.0);
    for (int i = 0; i < n; ++i) {
        const auto it = tt.sample_interaction(ray, 1e30f, rng);
        for (std::size_t c = 0; c < 3; ++c) acc[c] += it.is_scatter() ? double(it.weight[c]) : 0.0;
    }
    for (std::size_t c = 0; c < 3; ++c) CHECK(acc[c] / n == Approx(s.alpha_s(c)).margin(0.01));
    // beta = 1: the transmittance over distance d is exp(-sigma_b d) exactly (Eq. 1).
    double tr = 0;
    const float d = 1.5f;
    for (int i = 0; i < n; ++i) tr += double(tt.transmittance(ray, d, rng)[0]);
    CHECK(tr / n == Approx(std::exp(-tt.sigma_b() * d)).margin(4 * std::sqrt(0.25 / n)));
    // escape when t_max is tiny
    const auto e = tt.sample_interaction(ray, 1e-6f, rng);
    CHECK(e.is_escape());
}

TEST_CASE("TT medium: sampled exit directions reproduce the scatterometer's mean cosine", "[teleportation]") {
    // The teleport's direction is drawn from the recorded joint table; its mean cosine must match
    // the exact sample mean g of the scatterometer up to the table's binning (24 theta-uniform
    // bins, values uniform in cos theta within a bin).
    for (double rho : {1.0, 0.5}) {
        const auto s = stats_of(rho, GrainMaterial::make_dielectric(1.5), 60000, 8);
        const TeleportationMedium<float> tt(s, 0.5, 1.0);
        Rng rng = Rng::from_key(17);
        const Ray<float> ray(Vec3f(0.0f), Vec3f(0, 1, 0));
        double sum = 0;
        int n = 0;
        for (int i = 0; i < 200000; ++i) {
            const auto it = tt.sample_interaction(ray, 1e30f, rng);
            if (!it.is_scatter()) continue;
            sum += double(it.w.y);
            ++n;
        }
        CHECK(sum / n == Approx(s.g(0)).margin(0.01));
    }
}

TEST_CASE("TT medium: direction_pdf is the density of the sampled exit directions", "[teleportation]") {
    // If w is drawn with solid-angle density p(w) > 0 everywhere, E[1 / p(w)] = 4 pi. A glass
    // bead scatters into every direction (Fresnel reflection covers the sphere), so every cos
    // theta bin of the table has mass.
    const auto s = stats_of(1.0, GrainMaterial::make_dielectric(1.5), 100000, 12);
    const TeleportationMedium<float> tt(s, 0.6, 1.0);
    Rng rng = Rng::from_key(23);
    const Ray<float> ray(Vec3f(0.0f), glm::normalize(Vec3f(1, 2, 3)));
    double acc = 0, acc2 = 0;
    int n = 0;
    for (int i = 0; i < 400000; ++i) {
        const auto it = tt.sample_interaction(ray, 1e30f, rng);
        REQUIRE(it.is_scatter());
        REQUIRE(it.direction_pdf > 0.0f);
        const double v = 1.0 / double(it.direction_pdf);
        acc += v;
        acc2 += v * v;
        ++n;
    }
    const double mean = acc / n, se = std::sqrt((acc2 / n - mean * mean) / n);
    CHECK(mean == Approx(4 * pi_v<double>).margin(4 * se));
}

TEST_CASE("relative azimuth of exit direction and offset: planar for spheres, reproduced by TT", "[teleportation]") {
    // A sphere's paths stay in the plane of w_i and the entry point, so the exit direction's
    // perpendicular part is parallel or antiparallel to the offset's: dphi = 0 or pi, the
    // centres of bins n/2 and 0. A crystal has no such constraint.
    const auto s = stats_of(1.0, GrainMaterial::make_dielectric(1.5), 40000, 6);
    const auto& g = s.grid;
    double planar = 0, total = 0;
    for (std::size_t i = 0; i < s.tt_table[0].size(); ++i) {
        const auto k = i % g.tt_dphi_bins;
        total += s.tt_table[0][i];
        if (k == 0 || k == g.tt_dphi_bins / 2) planar += s.tt_table[0][i];
    }
    CHECK(planar / total == Approx(1.0).margin(1e-9));
    ScatterometerConfig c;
    c.rays = 20000;
    const auto crystal = run_scatterometer(
        ScatterometerGrain::procedural(GrainShape::crystal, 1.0, GrainMaterial::make_dielectric(1.5), 1, 3), c);
    double p2 = 0, t2 = 0;
    for (std::size_t i = 0; i < crystal.tt_table[0].size(); ++i) {
        const auto k = i % g.tt_dphi_bins;
        t2 += crystal.tt_table[0][i];
        if (k == 0 || k == g.tt_dphi_bins / 2) p2 += crystal.tt_table[0][i];
    }
    CHECK(p2 / t2 < 0.9);
    // TT samples reproduce the relative azimuth: measure it from the sampled (p, w).
    const TeleportationMedium<float> tt(s, 0.6, 1.0);
    Rng rng = Rng::from_key(77);
    const Vec3f d = glm::normalize(Vec3f(-1, 2, 0.5f));
    const Ray<float> ray(Vec3f(0.0f), d);
    int near_planar = 0, n = 0;
    for (int i = 0; i < 100000; ++i) {
        const auto it = tt.sample_interaction(ray, 1e30f, rng);
        if (!it.is_scatter()) continue;
        const Vec3d wi(d), off = Vec3d(it.p) - Vec3d(ray(it.t));
        const Vec3d perp = off - glm::dot(off, wi) * wi, wp = Vec3d(it.w) - glm::dot(Vec3d(it.w), wi) * wi;
        if (glm::length(perp) < 1e-3 || glm::length(wp) < 1e-3) continue;
        const Vec3d e1 = glm::normalize(perp), e2 = glm::cross(wi, e1);
        const double dphi = std::atan2(glm::dot(wp, e2), glm::dot(wp, e1));
        // within half a bin (22.5 degrees) of 0 or pi
        if (std::abs(dphi) <= pi_v<double> / 8 + 1e-3 || std::abs(dphi) >= pi_v<double> * 7 / 8 - 1e-3) ++near_planar;
        ++n;
    }
    CHECK(double(near_planar) / n > 0.995);
}
