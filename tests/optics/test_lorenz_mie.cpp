// Tests of optics/lorenz_mie.hpp against published values and physical laws.
#include <catch2/catch.hpp>

#include "grainlight/core/quadrature.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <vector>

#include "grainlight/optics/lorenz_mie.hpp"

using grainlight::LorenzMie;
using C = std::complex<double>;

namespace {

struct AngleRow {
    double deg;
    C s1, s2;
};
struct RefCase {
    C m;  // n + i k (k >= 0 absorbs); the source writes n - i k
    double x, qext, qsca, gqsca;
    std::vector<AngleRow> rows;
};

// Source: W. J. Wiscombe, "Mie scattering calculations: advances in technique and fast,
// vector-speed computer codes", NCAR TN-140+STR (1979, rev. 1996), MIEV0 test problems, as
// collected in ../shared/reference/mie_reference.md (copied into tests/data/mie_reference.md).
// Convention of the source: m = n - i k, S in van de Hulst's convention (ours, see the header).
std::vector<RefCase> wiscombe_cases() {
    return {
        {C(0.75, 0), 10.0, 2.232265, 2.232265, 2.001164,
         {{0, {55.80662, -9.758097}, {55.80662, -9.758097}},
          {30, {-7.672879, 10.87317}, {-10.92923, 9.629667}},
          {60, {3.587894, -1.756177}, {3.427411, 0.08082691}},
          {90, {-1.785905, -0.05232828}, {-0.5148748, -0.7027288}},
          {120, {1.537971, -0.08329374}, {-0.6908338, 0.2152693}},
          {150, {-0.4140427, 0.1876851}, {0.5247557, -0.1923391}},
          {180, {-1.078568, -0.03608807}, {1.078568, 0.03608807}}}},
        {C(1.33, 1e-5), 1.0, 0.09395198, 0.0939233, 0.01733048,
         {{0, {0.023488, 0.2281705}, {0.023488, 0.2281705}},
          {30, {0.02341722, 0.2217102}, {0.0203483, 0.1938171}},
          {60, {0.02322408, 0.2046815}, {0.01181704, 0.1075976}},
          {90, {0.02296081, 0.1828349}, {0.0002729533, 0.006702879}},
          {120, {0.0226982, 0.1625401}, {-0.01114466, -0.07646326}},
          {150, {0.02250635, 0.148617}, {-0.019423, -0.1271557}},
          {180, {0.02243622, 0.1437106}, {-0.02243622, -0.1437106}}}},
        {C(1.33, 1e-5), 100.0, 2.101321, 2.096594, 1.821854,
         {{0, {5253.302, -124.3188}, {5253.302, -124.3188}},
          {30, {-55.34573, -29.71881}, {-84.67204, -19.9947}},
          {60, {17.10488, -15.20096}, {33.10764, -2.709787}},
          {90, {-3.655758, 8.76986}, {-6.550512, -4.67537}},
          {120, {2.414318, 0.5380874}, {6.039011, -11.69971}},
          {150, {-1.222996, 32.83917}, {-9.653812, 14.74455}},
          {180, {-56.59205, 46.50974}, {56.59205, -46.50974}}}},
        {C(1.5, 1.0), 1.0, 2.336321, 0.6634538, 0.1274736,
         {{0, {0.5840802, 0.1905153}, {0.5840802, 0.1905153}},
          {30, {0.565702, 0.1871997}, {0.500161, 0.1456112}},
          {60, {0.5175251, 0.1784426}, {0.2879639, 0.04105398}},
          {90, {0.4563396, 0.1671665}, {0.03622847, -0.06182646}},
          {120, {0.4002117, 0.1566427}, {-0.174875, -0.1229586}},
          {150, {0.3621572, 0.149391}, {-0.3056823, -0.143846}},
          {180, {0.3488438, 0.1468286}, {-0.3488438, -0.1468286}}}},
        {C(1.5, 1.0), 100.0, 2.097502, 1.283697, 1.091466,
         {{0, {5243.754, -293.4167}, {5243.754, -293.4167}},
          {30, {40.49055, -18.98456}, {20.19198, 3.110731}},
          {60, {-26.46835, -19.29564}, {9.152743, -7.470202}},
          {90, {12.6889, 23.97474}, {-12.32914, -7.823167}},
          {120, {5.149886, 22.90736}, {-7.173357, -16.55464}},
          {150, {-16.05395, 14.18642}, {14.48052, -13.93594}},
          {180, {-20.2936, 4.384435}, {20.2936, -4.384435}}}},
        // MIEV0 built-in self-test (same source).
        {C(1.5, 0.1), 10.0, 2.459791, 1.235144, 1.139235,
         {{0, {61.49476, -3.177994}, {61.49476, -3.177994}},
          {140, {-0.1548380, -1.128972}, {0.05669755, 0.5425681}},
          {180, {1.493434, 0.2963657}, {-1.493434, -0.2963657}}}},
    };
}

double deg2mu(double deg) {
    if (deg == 0) return 1;
    if (deg == 180) return -1;
    return std::cos(deg * 3.14159265358979323846 / 180);
}

}  // namespace

TEST_CASE("Lorenz-Mie matches Wiscombe's MIEV0 test cases", "[optics][mie]") {
    for (const auto& c : wiscombe_cases()) {
        INFO("m = " << c.m << ", x = " << c.x);
        const LorenzMie mie(c.m, c.x);
        const auto q = mie.efficiencies();
        CHECK(q.qext == Approx(c.qext).epsilon(2e-6));
        CHECK(q.qsca == Approx(c.qsca).epsilon(2e-6));
        CHECK(q.g == Approx(c.gqsca / c.qsca).epsilon(2e-6));
        double smax = 0;
        for (const auto& r : c.rows) smax = std::max({smax, std::abs(r.s1), std::abs(r.s2)});
        for (const auto& r : c.rows) {
            INFO("angle " << r.deg);
            const auto s = mie.amplitudes(deg2mu(r.deg));
            CHECK(std::abs(s.S1 - r.s1) <= 2e-5 * smax);
            CHECK(std::abs(s.S2 - r.s2) <= 2e-5 * smax);
        }
        // Optical theorem: Qext = 4 Re S(0) / x^2 (independent of the Qext series sum).
        CHECK(4 * mie.amplitudes(1.0).S1.real() / (c.x * c.x) == Approx(q.qext).epsilon(1e-12));
        // Qback = 4 |S1(180)|^2 / x^2.
        CHECK(4 * std::norm(mie.amplitudes(-1.0).S1) / (c.x * c.x) == Approx(q.qback).epsilon(1e-10));
    }
}

TEST_CASE("Lorenz-Mie matches Bohren & Huffman's example sphere", "[optics][mie]") {
    // Bohren & Huffman 1983, App. A (BHMIE example output): m = 1.55, x = 2 pi 0.525 / 0.6328.
    const double x = 2 * 3.14159265358979323846 * 0.525 / 0.6328;
    const auto q = LorenzMie(C(1.55, 0), x).efficiencies();
    CHECK(q.qext == Approx(3.10543).epsilon(3e-6));
    CHECK(q.qsca == Approx(3.10543).epsilon(3e-6));
    CHECK(q.qback == Approx(2.92534).epsilon(3e-6));
    CHECK(q.g == Approx(0.63314).epsilon(1e-5));
}

TEST_CASE("Lorenz-Mie matches Wiscombe's large-x efficiencies and S11", "[optics][mie]") {
    // Source: Wiscombe NCAR TN-140 (1979), appendix test cases (as tabulated e.g. in the test
    // suite of MIEX, Wolf & Voshchinnikov 2004): m = 1.5 and 1.5 - 0.1 i (source convention),
    // Qext, Qsca, g; S11 = (|S1|^2 + |S2|^2)/2 at 0, 5, 95 and 180 degrees.
    struct Row {
        C m;
        double x, qext, qsca, g, s11_0, s11_5, s11_95, s11_180;
    };
    const Row rows[] = {
        {C(1.5, 0), 10, 2.881999, 2.881999, 0.742913, 0.520856e04, 0.428132e04, 0.963035e01, 0.423766e02},
        {C(1.5, 0), 100, 2.094388, 2.094388, 0.818246, 0.275508e08, 0.106440e06, 0.507283e03, 0.434048e04},
        {C(1.5, 0), 1000, 2.013945, 2.013945, 0.827882, 0.253568e12, 0.482785e07, 0.214530e05, 0.257577e07},
        {C(1.5, 0), 5000, 2.008650, 2.008650, 0.829592, 0.157609e15, 0.394653e08, 0.323205e06, 0.237786e09},
        {C(1.5, 0.1), 10, 2.459791, 1.235144, 0.922350, 0.379171e04, 0.300320e04, 0.209544e01, 0.231818e01},
        {C(1.5, 0.1), 100, 2.089822, 1.132134, 0.950392, 0.273645e08, 0.911574e05, 0.123599e03, 0.103837e03},
        {C(1.5, 0.1), 1000, 2.019703, 1.106932, 0.950880, 0.255002e12, 0.103489e07, 0.123601e05, 0.103834e05},
        {C(1.5, 0.1), 5000, 2.006775, 1.099193, 0.950650, 0.157315e15, 0.772728e07, 0.309020e06, 0.259585e06},
    };
    for (const auto& r : rows) {
        INFO("m = " << r.m << ", x = " << r.x);
        const LorenzMie mie(r.m, r.x);
        const auto q = mie.efficiencies();
        CHECK(q.qext == Approx(r.qext).epsilon(2e-6));
        CHECK(q.qsca == Approx(r.qsca).epsilon(2e-6));
        CHECK(q.g == Approx(r.g).epsilon(2e-6));
        auto s11 = [&](double deg) {
            const auto s = mie.amplitudes(deg2mu(deg));
            return 0.5 * (std::norm(s.S1) + std::norm(s.S2));
        };
        CHECK(s11(0) == Approx(r.s11_0).epsilon(1e-5));
        CHECK(s11(5) == Approx(r.s11_5).epsilon(1e-5));
        CHECK(s11(95) == Approx(r.s11_95).epsilon(1e-5));
        CHECK(s11(180) == Approx(r.s11_180).epsilon(1e-5));
    }
}

TEST_CASE("Lorenz-Mie Rayleigh limit", "[optics][mie]") {
    // Qsca -> 8/3 x^4 |K|^2, Qabs -> 4 x Im K, K = (m^2 - 1)/(m^2 + 2) (B&H Eqs. 5.8-5.9),
    // corrections O(x^2).
    for (C m : {C(1.5, 0), C(1.33, 0), C(1.5, 0.1), C(0.75, 0), C(2.0, 1.0)}) {
        const double x = 1e-3;
        const C K = (m * m - 1.0) / (m * m + 2.0);
        const auto q = LorenzMie(m, x).efficiencies();
        INFO("m = " << m);
        CHECK(q.qsca == Approx(8.0 / 3.0 * std::pow(x, 4) * std::norm(K)).epsilon(1e-4));
        if (m.imag() > 0) {
            CHECK(q.qabs == Approx(4 * x * K.imag()).epsilon(1e-4));
        }
        CHECK(std::abs(q.g) < 1e-5);
    }
}

TEST_CASE("Lorenz-Mie: Qext -> 2 for large x, energy, integral forms", "[optics][mie]") {
    // Extinction paradox: Qext = 2 + O(x^(-2/3)).
    for (C m : {C(1.33, 0), C(1.5, 0.1), C(0.75, 0)}) {
        const auto q = LorenzMie(m, 1e4).efficiencies();
        INFO("m = " << m);
        CHECK(q.qext == Approx(2.0).margin(0.01));
        CHECK(q.qabs >= -1e-9);
        CHECK(q.qsca <= q.qext + 1e-9);
        if (m.imag() == 0) CHECK(q.qabs == Approx(0.0).margin(1e-9));
    }
    // Qsca = (1/x^2) int_{-1}^{1} (|S1|^2 + |S2|^2) dmu and g Qsca = (1/x^2) int mu (...) dmu:
    // quadrature of the amplitudes checks the series sums for Qsca and g independently.
    std::vector<double> mu, w;
    for (auto [m, x] : {std::pair{C(1.5, 0.0), 10.0}, std::pair{C(1.33, 0.01), 30.0}, std::pair{C(0.75, 0.0), 5.0}}) {
        const auto rule = grainlight::gauss_legendre(400);
        mu = rule.x;
        w = rule.w;
        const LorenzMie mie(m, x);
        double sca = 0, gs = 0;
        for (std::size_t i = 0; i < mu.size(); ++i) {
            const auto s = mie.amplitudes(mu[i]);
            const double f = std::norm(s.S1) + std::norm(s.S2);
            sca += w[i] * f;
            gs += w[i] * mu[i] * f;
        }
        const auto q = mie.efficiencies();
        INFO("m = " << m << " x = " << x);
        CHECK(sca / (x * x) == Approx(q.qsca).epsilon(1e-9));
        CHECK(gs / (x * x) == Approx(q.g * q.qsca).epsilon(1e-9));
    }
}

TEST_CASE("Lorenz-Mie is stable at x = 1e5", "[optics][mie]") {
    // Lossless m = 1.5: energy exact, Qext -> 2 from above, g continues Wiscombe's x = 5000 value
    // (0.829592), and the glory backscatter Qback ~ 471 (../shared/reference/pitfalls.md, Lorenz-Mie).
    const auto q = LorenzMie(C(1.5, 0), 1e5).efficiencies();
    CHECK(q.qext > 2.0);
    CHECK(q.qext < 2.003);
    CHECK(q.qsca == Approx(q.qext).epsilon(1e-9));
    CHECK(q.g == Approx(0.8296).margin(0.002));
    CHECK(q.qback == Approx(471).epsilon(0.01));
    // Absorbing: Qabs continues Wiscombe's x = 5000 value (0.907582) toward the ray-optics limit.
    const auto qa = LorenzMie(C(1.5, 0.1), 1e5).efficiencies();
    CHECK(qa.qabs == Approx(0.9062).margin(0.002));
    CHECK(qa.qext == Approx(2.0).margin(0.002));
}

TEST_CASE("Lorenz-Mie: amplitudes_pair and the angle-span overload agree with single evaluation", "[optics][mie]") {
    const LorenzMie mie(C(1.33, 0.001), 50);
    for (double mu : {0.9, 0.3, 0.0, 1.0}) {
        grainlight::ScatteringAmplitudes a, b;
        mie.amplitudes_pair(mu, a, b);
        const auto ra = mie.amplitudes(mu), rb = mie.amplitudes(-mu);
        CHECK(std::abs(a.S1 - ra.S1) <= 1e-10 * std::abs(ra.S1) + 1e-12);
        CHECK(std::abs(b.S2 - rb.S2) <= 1e-10 * std::abs(rb.S2) + 1e-12);
    }
    std::vector<double> mus = {1, 0.5, -0.5};
    std::vector<grainlight::ScatteringAmplitudes> out(3);
    mie.amplitudes(mus, out);
    CHECK(out[1].S1 == mie.amplitudes(0.5).S1);
}

TEST_CASE("Lorenz-Mie rejects bad input", "[optics][mie]") {
    CHECK_THROWS_AS(LorenzMie(C(1.5, 0), 0.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(LorenzMie(C(1.5, 0), -1.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(LorenzMie(C(1.5, 0), std::nan("")), grainlight::invalid_argument);
    CHECK_THROWS_AS(LorenzMie(C(0.0, 0), 1.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(LorenzMie(C(1.5, -0.1), 1.0), grainlight::invalid_argument);
}
