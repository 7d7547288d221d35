// Tests for grainlight/phase: normalization, pdf == eval, mean cosine, chi-square of every sampler
// against its own pdf, the direction convention, and bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "common/chi2.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/phase.hpp"

using namespace grainlight;
using G1 = Spectrum<1, double>;

static_assert(PhaseFunction<IsotropicPhase<double>>);
static_assert(PhaseFunction<HenyeyGreenstein<float, RGB>>);
static_assert(PhaseFunction<TabulatedPhase<double, RGBd>>);

namespace {
const std::vector<double> kGs = {-0.95, -0.5, 0.0, 0.3, 0.7, 0.95};
// Chi-square tests in this file: 6 HG + 1 isotropic + 4 tabulated (Sidak at 0.01 family-wise).
const double kAlpha = gl_test::sidak(0.01, 11);

/// Integrate f(cos theta) over the sphere in double (adaptive enough: 20000-point midpoint in
/// cos theta, refined near +-1 by a substitution mu = 1 - 2 s^2 style split).
template <class Fn>
double integrate_mu(Fn f, int n = 200000) {
    double acc = 0;
    for (int i = 0; i < n; ++i) {
        const double mu = -1.0 + 2.0 * (i + 0.5) / n;
        acc += f(mu);
    }
    return acc * 2.0 / n * 2.0 * pi_v<double>;  // d(omega) = 2 pi d(mu)
}

/// theta bin coordinate that refines near theta = 0 (forward peaks) and pi.
double theta_warp(double s) { return pi_v<double> * (s < 0.5 ? 2 * s * s : 1 - 2 * (1 - s) * (1 - s)); }

template <class P>
gl_test::Chi2Result chi2_phase(const P& p, std::uint64_t seed, std::size_t n = 200000) {
    const Vec3<typename P::Float> w_in(0, 0, 1);
    return gl_test::chi2_directions(
        [&](double u1, double u2, Vec3d& w) {
            auto s = p.sample(w_in, Vec2<typename P::Float>(typename P::Float(u1), typename P::Float(u2)));
            w = Vec3d(s.w);
            return bool(s);
        },
        [&](const Vec3d& w) { return double(p.eval(w_in, Vec3<typename P::Float>(w)).pdf); }, n, 40, 12, seed, theta_warp);
}
}  // namespace

TEST_CASE("Henyey-Greenstein: normalized, pdf == value, mean cosine g", "[phase][hg]") {
    for (double g : kGs) {
        INFO("g = " << g);
        HenyeyGreenstein<double, G1> hg(g);
        const Vec3d w_in(0, 0, 1);
        const double norm = integrate_mu([&](double mu) {
            return hg.eval(w_in, direction_from_cosine(w_in, mu, 0.3)).value[0];
        });
        CHECK(norm == Approx(1.0).epsilon(2e-3));
        const double mean_cos = integrate_mu([&](double mu) {
            return mu * hg.eval(w_in, direction_from_cosine(w_in, mu, 0.0)).value[0];
        });
        CHECK(mean_cos == Approx(g).margin(3e-3));
        CHECK(hg.mean_cosine()[0] == g);
        for (double mu : {-0.9, 0.0, 0.5, 0.99}) {
            auto e = hg.eval(w_in, direction_from_cosine(w_in, mu, 1.0));
            CHECK(e.value[0] == Approx(e.pdf));
            // Closed form (Henyey & Greenstein 1941), per steradian.
            CHECK(e.pdf == Approx((1 - g * g) / (4 * pi_v<double> * std::pow(1 + g * g - 2 * g * mu, 1.5))).epsilon(1e-9));
        }
    }
}

TEST_CASE("Henyey-Greenstein sampler passes chi-square for positive and negative g", "[phase][hg][chi2]") {
    std::uint64_t seed = 100;
    for (double g : kGs) {
        INFO("g = " << g);
        auto res = chi2_phase(HenyeyGreenstein<double, G1>(g), seed++);
        INFO(res.describe());
        CHECK(res.p_value > kAlpha);
    }
}

TEST_CASE("Direction convention: u.x -> 1 samples forward, and g > 0 scatters forward", "[phase][convention]") {
    // Convention (phase/concepts.hpp): propagation directions, cos theta = dot(w_in, w_out), +1 forward.
    const Vec3d w_in = glm::normalize(Vec3d(0.3, -0.5, 0.8));
    for (double g : kGs) {
        HenyeyGreenstein<double, G1> hg(g);
        auto fwd = hg.sample(w_in, Vec2d(1 - 1e-9, 0.42));
        CHECK(glm::dot(fwd.w, w_in) > 0.999);
        auto back = hg.sample(w_in, Vec2d(1e-9, 0.42));
        CHECK(glm::dot(back.w, w_in) < -0.999);
    }
    HenyeyGreenstein<double, G1> forward(0.8), backward(-0.8);
    // eval: forward-peaked g > 0 is larger for w_out == w_in than for w_out == -w_in.
    CHECK(forward.eval(w_in, w_in).pdf > 100 * forward.eval(w_in, -w_in).pdf);
    CHECK(backward.eval(w_in, -w_in).pdf > 100 * backward.eval(w_in, w_in).pdf);
    // Monte Carlo mean cosine of samples equals g with the right sign.
    Welford m;
    auto rng = Pcg32::from_key(1);
    for (int i = 0; i < 50000; ++i) m.add(glm::dot(w_in, forward.sample(w_in, rng.uniform2<double>()).w));
    CHECK(m.mean() == Approx(0.8).margin(4 * m.standard_error()));
    // Tabulated from physics-convention data (p(mu) peaked at mu = +1) is forward too.
    const std::vector<double> mu = {-1, 0, 0.9, 1};
    const std::vector<double> v = {0, 0, 0, 10};
    auto tab = TabulatedPhase<double, G1>::from_values(mu, v);
    CHECK(glm::dot(tab.sample(w_in, Vec2d(0.5, 0.1)).w, w_in) > 0.9);
    CHECK(tab.mean_cosine()[0] > 0.9);
}

TEST_CASE("Isotropic phase: value, chi-square", "[phase][isotropic]") {
    IsotropicPhase<double> iso;
    CHECK(iso.eval(Vec3d(0, 0, 1), Vec3d(1, 0, 0)).pdf == Approx(1 / (4 * pi_v<double>)));
    auto res = chi2_phase(iso, 3);
    INFO(res.describe());
    CHECK(res.p_value > kAlpha);
}

TEST_CASE("Tabulated phase from HG values on a non-uniform grid", "[phase][tabulated]") {
    // Grid dense toward mu = 1 (1 - mu spaced geometrically), where forward peaks live.
    std::vector<double> mu;
    for (int i = 0; i <= 60; ++i) mu.push_back(-1.0 + 1.0 * i / 60.0);  // [-1, 0]
    for (int i = 1; i <= 120; ++i) mu.push_back(1.0 - std::pow(10.0, -6.0 * i / 120.0) * 1.0 + 0.0);
    mu.back() = 1.0;
    mu.erase(std::unique(mu.begin(), mu.end()), mu.end());
    std::sort(mu.begin(), mu.end());
    for (double g : {0.5, 0.9, -0.6}) {
        INFO("g = " << g);
        std::vector<double> vals;
        for (double m : mu) vals.push_back(henyey_greenstein_cos_pdf(m, g));
        auto tab = TabulatedPhase<double, G1>::from_values(mu, vals);
        CHECK(tab.mean_cosine()[0] == Approx(g).margin(3e-3));
        const Vec3d w_in(0, 0, 1);
        const double norm = integrate_mu([&](double m) { return tab.eval(w_in, direction_from_cosine(w_in, m, 0.)).value[0]; });
        CHECK(norm == Approx(1.0).epsilon(3e-3));
        auto res = chi2_phase(tab, 200 + std::uint64_t(10 * (g + 1)));
        INFO(res.describe());
        CHECK(res.p_value > kAlpha);
    }
}

TEST_CASE("Tabulated phase from a histogram of samples", "[phase][tabulated]") {
    const double g = 0.6;
    // Non-uniform bin edges, finer forward.
    std::vector<double> edges;
    for (int i = 0; i <= 40; ++i) edges.push_back(-1.0 + 1.8 * i / 40.0);
    for (int i = 1; i <= 20; ++i) edges.push_back(0.8 + 0.2 * i / 20.0);
    std::vector<double> counts(edges.size() - 1, 0.0);
    auto rng = Pcg32::from_key(77);
    const int n = 400000;
    Welford direct;
    for (int i = 0; i < n; ++i) {
        const double m = sample_henyey_greenstein_cos(rng.uniform<double>(), g);
        direct.add(m);
        auto it = std::upper_bound(edges.begin(), edges.end(), m);
        const std::size_t k = std::min<std::size_t>(counts.size() - 1, std::size_t(std::max<std::ptrdiff_t>(0, it - edges.begin() - 1)));
        counts[k] += 1;
    }
    auto tab = TabulatedPhase<double, G1>::from_histogram(edges, counts);
    CHECK(tab.interpolation() == TabulatedPhase<double, G1>::Interpolation::constant);
    // Histogram mean cosine equals the sample mean up to the within-bin discretization.
    CHECK(tab.mean_cosine()[0] == Approx(direct.mean()).margin(5e-3));
    CHECK(direct.mean() == Approx(g).margin(4 * direct.standard_error()));
    auto res = chi2_phase(tab, 300);
    INFO(res.describe());
    CHECK(res.p_value > kAlpha);
}

TEST_CASE("Colour-dependent tabulated phase: mixture sampling with per-channel weights", "[phase][tabulated][spectral]") {
    std::vector<double> mu;
    for (int i = 0; i <= 2000; ++i) mu.push_back(-1.0 + 2.0 * i / 2000.0);
    const double gs[3] = {-0.3, 0.4, 0.85};
    std::vector<RGBd> vals;
    for (double m : mu) vals.push_back(RGBd{henyey_greenstein_cos_pdf(m, gs[0]), henyey_greenstein_cos_pdf(m, gs[1]),
                                            henyey_greenstein_cos_pdf(m, gs[2])});
    auto tab = TabulatedPhase<double, RGBd>::from_values(mu, vals);
    CHECK(!tab.is_grey());
    for (int c = 0; c < 3; ++c) CHECK(tab.mean_cosine()[c] == Approx(gs[c]).margin(3e-3));
    // Weighted samples reproduce each channel's own mean cosine: E[weight_c * mu] = g_c.
    const Vec3d w_in(0, 0, 1);
    Welford m[3];
    auto rng = Pcg32::from_key(9);
    for (int i = 0; i < 200000; ++i) {
        auto s = tab.sample(w_in, rng.uniform2<double>());
        auto e = tab.eval(w_in, s.w);
        REQUIRE(s.pdf == Approx(e.pdf).epsilon(1e-9));
        for (int c = 0; c < 3; ++c) {
            REQUIRE(s.weight[c] == Approx(e.value[c] / e.pdf).epsilon(1e-9));
            m[c].add(s.weight[c] * s.w.z);
        }
    }
    for (int c = 0; c < 3; ++c) CHECK(m[c].mean() == Approx(tab.mean_cosine()[c]).margin(4 * m[c].standard_error()));
    auto res = chi2_phase(tab, 400);
    INFO(res.describe());
    CHECK(res.p_value > kAlpha);
}

TEST_CASE("Phase functions reject bad input", "[phase][errors]") {
    CHECK_THROWS_WITH(HenyeyGreenstein<float>(1.0f), Catch::Contains("g") && Catch::Contains("(-1, 1)"));
    CHECK_THROWS_AS(HenyeyGreenstein<float>(-1.0f), grainlight::invalid_argument);
    CHECK_THROWS_AS(HenyeyGreenstein<double>(std::nan("")), grainlight::invalid_argument);
    const std::vector<double> mu = {-1, 0, 1};
    CHECK_THROWS_WITH((TabulatedPhase<double, G1>::from_values(mu, std::vector<double>{0, 0, 0})), Catch::Contains("integral"));
    CHECK_THROWS_WITH((TabulatedPhase<double, G1>::from_values(std::vector<double>{-0.5, 1}, std::vector<double>{1, 1})),
                      Catch::Contains("mu[0]"));
    CHECK_THROWS_AS((TabulatedPhase<double, G1>::from_values(mu, std::vector<double>{1, -1, 1})), grainlight::invalid_argument);
    CHECK_THROWS_AS((TabulatedPhase<double, G1>::from_histogram(mu, std::vector<double>{1, 1, 1})), grainlight::invalid_argument);
}
