// Tests for grainlight/core: RNG, warps, frames, distributions, statistics, spectra, errors.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/chi2.hpp"
#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/quadrature.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/core/warp.hpp"

using namespace grainlight;

// Family-wise significance 0.01 over the chi-square tests of this file (Sidak).
static const double kAlpha = gl_test::sidak(0.01, 8);

TEST_CASE("Pcg32 reproduces the reference stream", "[core][rng]") {
    // Source: M. O'Neill's pcg-c-basic demo (pcg32-demo.c), pcg32_srandom(42u, 54u):
    // first outputs 0xa15c02b7 0x7b47f409 0xba1d3330 0x83d2f293 0xbfa4784b 0xcbed606e.
    Pcg32 r(42u, 54u);
    const std::uint32_t expected[] = {0xa15c02b7u, 0x7b47f409u, 0xba1d3330u, 0x83d2f293u, 0xbfa4784bu, 0xcbed606eu};
    for (auto e : expected) CHECK(r.next_u32() == e);
}

TEST_CASE("Pcg32 advance equals stepping; keys give distinct deterministic streams", "[core][rng]") {
    Pcg32 a(7, 3), b(7, 3);
    for (int i = 0; i < 1000; ++i) (void)a.next_u32();
    b.advance(1000);
    CHECK(a.next_u32() == b.next_u32());

    auto k1 = Pcg32::from_key(1, 2, 3), k2 = Pcg32::from_key(1, 2, 3), k3 = Pcg32::from_key(1, 2, 4),
         k4 = Pcg32::from_key(1, 3, 3);
    const auto x1 = k1.next_u64();
    CHECK(x1 == k2.next_u64());
    CHECK(x1 != k3.next_u64());
    CHECK(x1 != k4.next_u64());

    // Uniforms stay in [0, 1) and the mean of neighbouring keys is uncorrelated-looking.
    Welford m;
    for (std::uint64_t px = 0; px < 20000; ++px) {
        auto r = Pcg32::from_key(99, px, 0);
        const double u = r.uniform<double>();
        REQUIRE(u >= 0.0);
        REQUIRE(u < 1.0);
        m.add(u);
    }
    CHECK(std::abs(m.mean() - 0.5) < 4 * std::sqrt(1.0 / 12.0 / 20000));
    // float path never returns 1
    Pcg32 f(1, 1);
    for (int i = 0; i < 100000; ++i) REQUIRE(f.uniform<float>() < 1.0f);
}

TEST_CASE("uniform2 / uniform3 draw their components in x, y, z order", "[core][rng]") {
    // The reason they exist: in Vec3(rng.uniform(), rng.uniform(), rng.uniform()) the argument
    // evaluation order is unspecified (g++ and clang differ), so a seed would give a
    // compiler-dependent point. The components must be the next values of the stream, in order.
    Rng a = Rng::from_key(5, 6, 7), b = Rng::from_key(5, 6, 7);
    for (int i = 0; i < 50; ++i) {
        const Vec3d v = a.uniform3<double>();
        const double x = b.uniform<double>(), y = b.uniform<double>(), z = b.uniform<double>();
        REQUIRE(v.x == x);
        REQUIRE(v.y == y);
        REQUIRE(v.z == z);
        const Vec2<float> w = a.uniform2<float>();
        const float u = b.uniform<float>(), t = b.uniform<float>();
        REQUIRE(w.x == u);
        REQUIRE(w.y == t);
    }
}

TEST_CASE("sincos_2pi is within a few ulp of the long-double sin and cos", "[core][math]") {
    // Reference: std::sin / std::cos in long double (x87, 64-bit mantissa) of 2 pi u in long
    // double; the exact quarter turns are the closed forms 0, +-1.
    Rng rng = Rng::from_key(41);
    double worst = 0;
    for (int i = 0; i < 200000; ++i) {
        const double u = i < 4 ? 0.25 * i : rng.uniform<double>();
        double s = 0, c = 0;
        sincos_2pi(u, s, c);
        const long double a = 2.0L * 3.141592653589793238462643383279502884L * static_cast<long double>(u);
        worst = std::max({worst, double(std::abs(static_cast<long double>(s) - std::sin(a))),
                          double(std::abs(static_cast<long double>(c) - std::cos(a)))});
        CHECK(s * s + c * c == Approx(1.0).epsilon(1e-15));
    }
    CHECK(worst < 4e-16);  // measured 2.7e-16: a few ulp of values up to 1
    const double quarters[5][2] = {{0, 1}, {1, 0}, {0, -1}, {-1, 0}, {0, 1}};
    for (int k = 0; k <= 4; ++k) {
        double s = 9, c = 9;
        sincos_2pi(0.25 * k, s, c);
        CHECK(s == Approx(quarters[k][0]).margin(1e-16));
        CHECK(c == Approx(quarters[k][1]).margin(1e-16));
    }
}

TEST_CASE("Frame is orthonormal and round-trips", "[core][frame]") {
    auto rng = Pcg32::from_key(5);
    std::vector<Vec3d> normals = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, -1, 0}};
    for (int i = 0; i < 200; ++i) normals.push_back(sample_uniform_sphere(rng.uniform2<double>()));
    for (const auto& n : normals) {
        Frame<double> f(n);
        CHECK(glm::dot(f.s, f.t) == Approx(0).margin(1e-12));
        CHECK(glm::dot(f.s, f.n) == Approx(0).margin(1e-12));
        CHECK(glm::length(f.s) == Approx(1).epsilon(1e-12));
        CHECK(glm::length(f.t) == Approx(1).epsilon(1e-12));
        CHECK(glm::dot(glm::cross(f.s, f.t), f.n) == Approx(1).epsilon(1e-12));  // right-handed
        const Vec3d v(0.3, -0.4, 0.5);
        const Vec3d back = f.to_world(f.to_local(v));
        CHECK(glm::length(back - v) < 1e-12);
    }
}

TEST_CASE("Direction warps match their pdfs (chi-square)", "[core][warp][chi2]") {
    using W = std::function<Vec3d(Vec2d)>;
    struct Case {
        const char* name;
        W warp;
        std::function<double(const Vec3d&)> pdf;
    };
    std::vector<Case> cases = {
        {"uniform sphere", [](Vec2d u) { return sample_uniform_sphere(u); }, [](const Vec3d&) { return uniform_sphere_pdf<double>(); }},
        {"uniform hemisphere", [](Vec2d u) { return sample_uniform_hemisphere(u); },
         [](const Vec3d& w) { return w.z >= 0 ? uniform_hemisphere_pdf<double>() : 0.0; }},
        {"cosine hemisphere", [](Vec2d u) { return sample_cosine_hemisphere(u); },
         [](const Vec3d& w) { return cosine_hemisphere_pdf(w.z); }},
        {"cone 45deg", [](Vec2d u) { return sample_uniform_cone(u, std::cos(pi_v<double> / 4)); },
         [](const Vec3d& w) { return w.z >= std::cos(pi_v<double> / 4) ? uniform_cone_pdf(std::cos(pi_v<double> / 4)) : 0.0; }},
    };
    for (auto& c : cases) {
        INFO(c.name);
        auto res = gl_test::chi2_directions(
            [&](double u1, double u2, Vec3d& w) {
                w = c.warp(Vec2d(u1, u2));
                return true;
            },
            c.pdf, 200000, 24, 24);
        INFO(res.describe());
        CHECK(res.p_value > kAlpha);
    }
}

TEST_CASE("Disk warps are uniform by area", "[core][warp][chi2]") {
    for (int which = 0; which < 2; ++which) {
        // r^2 is uniform on [0, 1) for an area-uniform disk sample; phi uniform.
        auto res = gl_test::chi2_1d(
            [&](double u) {
                static Pcg32 r2 = Pcg32::from_key(3);
                const Vec2d p = which ? sample_uniform_disk_polar(Vec2d(u, r2.uniform<double>()))
                                      : sample_uniform_disk_concentric(Vec2d(u, r2.uniform<double>()));
                return p.x * p.x + p.y * p.y;
            },
            [](double x) { return std::clamp(x, 0.0, 1.0); }, 0.0, 1.0, 50, 100000);
        INFO(res.describe());
        CHECK(res.p_value > kAlpha);
    }
}

TEST_CASE("PiecewiseConstant1D samples, pdf and inversion on a non-uniform grid", "[core][distribution]") {
    const std::vector<double> x = {0.0, 0.1, 0.15, 0.5, 1.0, 3.0};
    const std::vector<double> f = {2.0, 0.0, 5.0, 1.0, 0.25};
    PiecewiseConstant1D<double> d(x, f);
    const double integral = 2 * 0.1 + 0 + 5 * 0.35 + 1 * 0.5 + 0.25 * 2;
    CHECK(d.integral() == Approx(integral));
    CHECK(d.pdf(0.05) == Approx(2 / integral));
    CHECK(d.pdf(0.12) == 0.0);
    for (double u : {0.0, 0.1, 0.33, 0.5, 0.77, 0.999}) {
        const double s = d.sample(u);
        CHECK(d.invert(s) == Approx(u).margin(1e-12));
    }
    auto res = gl_test::chi2_1d([&](double u) { return d.sample(u); }, [&](double t) { return d.invert(t); }, 0.0, 3.0,
                                60, 100000);
    INFO(res.describe());
    CHECK(res.p_value > kAlpha);
}

TEST_CASE("PiecewiseLinear1D exact inversion", "[core][distribution]") {
    const std::vector<double> x = {-1.0, -0.5, 0.0, 0.9, 0.99, 1.0};
    const std::vector<double> f = {0.1, 0.0, 1.0, 3.0, 30.0, 30.0};
    PiecewiseLinear1D<double> d(x, f);
    double trap = 0;
    for (std::size_t i = 0; i + 1 < x.size(); ++i) trap += 0.5 * (f[i] + f[i + 1]) * (x[i + 1] - x[i]);
    CHECK(d.integral() == Approx(trap));
    for (double u : {0.0, 0.01, 0.2, 0.5, 0.8, 0.95, 0.9999}) {
        double pdf = 0;
        const double s = d.sample(u, &pdf);
        CHECK(d.invert(s) == Approx(u).margin(1e-10));
        CHECK(pdf == Approx(d.pdf(s)).epsilon(1e-9));
    }
    auto res = gl_test::chi2_1d([&](double u) { return d.sample(u); }, [&](double t) { return d.invert(t); }, -1.0, 1.0,
                                80, 200000);
    INFO(res.describe());
    CHECK(res.p_value > kAlpha);
}

TEST_CASE("Distributions reject bad tables with a message naming the parameter", "[core][distribution][errors]") {
    const std::vector<double> x = {0.0, 1.0, 2.0};
    CHECK_THROWS_AS(PiecewiseConstant1D<double>(x, std::vector<double>{1.0, -1.0}), grainlight::invalid_argument);
    CHECK_THROWS_WITH(PiecewiseConstant1D<double>(x, std::vector<double>{0.0, 0.0}), Catch::Contains("integral"));
    CHECK_THROWS_WITH(PiecewiseLinear1D<double>(std::vector<double>{0.0, 0.0, 1.0}, std::vector<double>{1, 1, 1}),
                      Catch::Contains("nodes[1]"));
    CHECK_THROWS_WITH(PiecewiseLinear1D<double>(x, std::vector<double>{1.0, std::nan(""), 1.0}), Catch::Contains("values[1]"));
    CHECK_THROWS_AS(DiscreteDistribution<double>(std::vector<double>{}), grainlight::invalid_argument);
    CHECK_THROWS_WITH(DiscreteDistribution<double>(std::vector<double>{0.0, 0.0}), Catch::Contains("sum(weights)"));
}

TEST_CASE("DiscreteDistribution frequencies and remapping", "[core][distribution]") {
    const std::vector<double> w = {1, 0, 3, 6};
    DiscreteDistribution<double> d(w);
    CHECK(d.pmf(0) == Approx(0.1));
    CHECK(d.pmf(1) == 0.0);
    std::vector<double> obs(4, 0.0), exp_(4, 0.0);
    auto rng = Pcg32::from_key(8);
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        double p = 0, ur = 0;
        const auto k = d.sample(rng.uniform<double>(), &p, &ur);
        REQUIRE(ur >= 0.0);
        REQUIRE(ur < 1.0);
        REQUIRE(p == Approx(d.pmf(k)));
        obs[k] += 1;
    }
    for (int k = 0; k < 4; ++k) exp_[std::size_t(k)] = d.pmf(std::size_t(k)) * n;
    auto res = gl_test::chi2_from_counts(obs, exp_);
    CHECK(res.p_value > kAlpha);
    CHECK(obs[1] == 0.0);
}

TEST_CASE("Welford agrees with the two-pass formulas and merges in any split", "[core][statistics]") {
    std::vector<double> xs;
    auto rng = Pcg32::from_key(4);
    for (int i = 0; i < 1000; ++i) xs.push_back(1e6 + rng.uniform<double>());  // large offset: stability
    double mean = 0;
    for (double x : xs) mean += x;
    mean /= double(xs.size());
    double var = 0;
    for (double x : xs) var += (x - mean) * (x - mean);
    var /= double(xs.size() - 1);
    Welford all, a, b;
    for (std::size_t i = 0; i < xs.size(); ++i) {
        all.add(xs[i]);
        (i < 317 ? a : b).add(xs[i]);
    }
    a.merge(b);
    CHECK(all.mean() == Approx(mean).epsilon(1e-14));
    CHECK(all.variance() == Approx(var).epsilon(1e-9));
    CHECK(a.mean() == Approx(all.mean()).epsilon(1e-14));
    CHECK(a.variance() == Approx(all.variance()).epsilon(1e-9));
    CHECK(all.standard_error() == Approx(std::sqrt(var / 1000.0)).epsilon(1e-9));
}

TEST_CASE("Spectrum arithmetic is component-wise", "[core][spectrum]") {
    RGB a{1.f, 2.f, 3.f}, b(2.f);
    CHECK((a * b)[2] == 6.f);
    CHECK((a / b)[0] == 0.5f);
    CHECK((a + 1.f)[1] == 3.f);
    CHECK(a.max_value() == 3.f);
    CHECK(a.average() == Approx(2.f));
    CHECK(exp(RGB(0.f)) == RGB(1.f));
    CHECK(!a.is_black());
    CHECK(RGB(0.f).is_black());
    // Brace-init with one value broadcasts (no initializer-list trap giving (x, 0, 0)).
    const RGB braced{0.5f};
    CHECK(braced == RGB(0.5f));
    static_assert(!std::is_constructible_v<RGB, float, float>, "exactly N values or one broadcast value");
}

TEST_CASE("Errors name the parameter, value and range", "[core][errors]") {
    try {
        check_argument(false, "Thing", "albedo", 1.5, "[0, 1]");
        FAIL("no throw");
    } catch (const grainlight::invalid_argument& e) {
        const std::string m = e.what();
        CHECK(m.find("Thing") != std::string::npos);
        CHECK(m.find("albedo") != std::string::npos);
        CHECK(m.find("1.5") != std::string::npos);
        CHECK(m.find("[0, 1]") != std::string::npos);
    }
    CHECK_THROWS_AS(check_finite("X", "y", std::nan("")), grainlight::invalid_argument);
}

TEST_CASE("Gauss-Legendre rules integrate polynomials of degree 2n-1 exactly", "[core][quadrature]") {
    for (int n : {1, 2, 5, 16, 64}) {
        INFO("n = " << n);
        const auto r = gauss_legendre(n, -1.0, 1.0);
        CHECK(r.integrate([](double) { return 1.0; }) == Approx(2.0).epsilon(1e-14));
        for (int k = 0; k <= 2 * n - 1; ++k) {
            const double exact = (k % 2) ? 0.0 : 2.0 / (k + 1);
            CHECK(r.integrate([&](double x) { return std::pow(x, k); }) == Approx(exact).margin(1e-13));
        }
        for (std::size_t i = 1; i < r.x.size(); ++i) CHECK(r.x[i] > r.x[i - 1]);
    }
    const auto r01 = gauss_legendre(7, 0.0, 3.0);
    CHECK(r01.integrate([](double x) { return x * x; }) == Approx(9.0).epsilon(1e-13));
    CHECK_THROWS_AS(gauss_legendre(0), grainlight::invalid_argument);
    CHECK_THROWS_AS(gauss_legendre(4, 1.0, 1.0), grainlight::invalid_argument);
}

TEST_CASE("Gauss-Legendre nodes are correctly rounded: closed forms, A&S Table 25.4, one source", "[core][quadrature]") {
    // n = 4 in closed form (e.g. Abramowitz & Stegun 25.4.29 / any quadrature text):
    // x = sqrt(3/7 -+ 2/7 sqrt(6/5)), w = (18 +- sqrt(30)) / 36, evaluated in long double and rounded.
    const long double s65 = std::sqrt(6.0L / 5.0L), s30 = std::sqrt(30.0L);
    const double x_in = double(std::sqrt(3.0L / 7.0L - 2.0L / 7.0L * s65));
    const double x_out = double(std::sqrt(3.0L / 7.0L + 2.0L / 7.0L * s65));
    constexpr auto& g4 = gauss_legendre_nodes<4>;
    CHECK(g4.x[2] == x_in);
    CHECK(g4.x[3] == x_out);
    CHECK(g4.x[0] == -x_out);
    CHECK(g4.w[2] == double((18.0L + s30) / 36.0L));
    CHECK(g4.w[3] == double((18.0L - s30) / 36.0L));
    // n = 3: x = sqrt(3/5), w = 5/9, 8/9 (exact centre node).
    constexpr auto& g3 = gauss_legendre_nodes<3>;
    CHECK(g3.x[1] == 0.0);
    CHECK(g3.x[2] == double(std::sqrt(0.6L)));
    CHECK(g3.w[1] == double(8.0L / 9.0L));
    // n = 8, Abramowitz & Stegun Table 25.4 (15 decimals).
    constexpr auto& g8 = gauss_legendre_nodes<8>;
    const double as_x[4] = {0.183434642495650, 0.525532409916329, 0.796666477413627, 0.960289856497536};
    const double as_w[4] = {0.362683783378362, 0.313706645877887, 0.222381034453374, 0.101228536290376};
    for (int i = 0; i < 4; ++i) {
        CHECK(std::abs(g8.x[std::size_t(4 + i)] - as_x[i]) < 1e-15);
        CHECK(std::abs(g8.w[std::size_t(4 + i)] - as_w[i]) < 1e-15);
    }
    // The compile-time table and the run-time rule are the same numbers.
    static_assert(gauss_legendre_nodes<8>.x[7] > 0.96 && gauss_legendre_nodes<8>.x[7] < 0.9603);
    for (int n : {1, 2, 3, 8, 16}) {
        const auto r = gauss_legendre(n);
        auto same = [&](const auto& t) {
            for (std::size_t i = 0; i < r.x.size(); ++i) {
                CHECK(r.x[i] == t.x[i]);
                CHECK(r.w[i] == t.w[i]);
            }
        };
        if (n == 1) same(gauss_legendre_nodes<1>);
        if (n == 2) same(gauss_legendre_nodes<2>);
        if (n == 3) same(gauss_legendre_nodes<3>);
        if (n == 8) same(gauss_legendre_nodes<8>);
        if (n == 16) same(gauss_legendre_nodes<16>);
    }
}
