// Tests of optics/goa.hpp: GOA against exact Lorenz-Mie (our own, itself checked against
// Wiscombe's tables in test_lorenz_mie.cpp), closed forms (Eqs. 12-14), ray counting at rainbows,
// conventions, absorption.
#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <vector>

#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"

using namespace grainlight;
using C = std::complex<double>;

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kLambda = 0.6;  // um, Guo21 Figs. 2-6

double size_param(double r_um) { return 2 * kPi * r_um / kLambda; }

struct Errors {
    double pooled_complex;  // sum |S_goa - S_mie|^2 / sum |S_mie|^2 over S1 and S2, 5..175 deg
    double energy_F;        // sum (F_goa - F_mie)^2 / sum F_mie^2, 0..180 deg, F = (|S1|+|S2|)/2
    double relmse_F;        // mean ((F_goa - F_mie)/F_mie)^2, 0..180 deg
};

Errors goa_vs_mie(C m, double r_um) {
    const double x = size_param(r_um);
    const LorenzMie mie(m, x);
    const Goa goa(m, x);
    double pn = 0, pd = 0, en = 0, ed = 0, rel = 0;
    int count = 0;
    for (int d = 0; d <= 180; ++d) {
        const double th = d * kPi / 180;
        const auto sm = mie.amplitudes(d == 0 ? 1.0 : d == 180 ? -1.0 : std::cos(th));
        const auto sg = goa.amplitudes_at_angle(th);
        if (d >= 5 && d <= 175) {
            pn += std::norm(sg.S1 - sm.S1) + std::norm(sg.S2 - sm.S2);
            pd += std::norm(sm.S1) + std::norm(sm.S2);
        }
        const double fm = 0.5 * (std::abs(sm.S1) + std::abs(sm.S2));
        const double fg = 0.5 * (std::abs(sg.S1) + std::abs(sg.S2));
        en += (fg - fm) * (fg - fm);
        ed += fm * fm;
        rel += (fg - fm) * (fg - fm) / (fm * fm);
        ++count;
    }
    return {pn / pd, en / ed, rel / count};
}

int count_rays(C m, int p, double theta_deg) {
    int c = 0;
    goa_rays(m, 3, theta_deg * kPi / 180, [&](const GoaRay& r) { c += r.p == p; });
    return c;
}
}  // namespace

TEST_CASE("GOA complex amplitudes agree with exact Mie at r = 100 um", "[optics][goa]") {
    // Issue 3 acceptance: pooled relative squared error <= 0.03 over 5-175 deg (a correct GOA gives
    // ~0.013; a sign or phase slip in Eqs. 9-10 gives >= 0.2).
    const auto e = goa_vs_mie(C(1.33, 0), 100);
    CHECK(e.pooled_complex <= 0.03);
    CHECK(e.pooled_complex >= 0.001);  // GOA is not exact: catches comparing a method with itself
    CHECK(e.relmse_F <= 0.035);
    // Bubbles (m < 1, total internal reflection) and a weakly absorbing sphere.
    CHECK(goa_vs_mie(C(0.75, 0), 100).pooled_complex <= 0.03);
    CHECK(goa_vs_mie(C(1.33, 1e-4), 100).pooled_complex <= 0.03);
}

TEST_CASE("GOA forward amplitude is within 2 % of Mie at r = 100 um, and low", "[optics][goa]") {
    const double x = size_param(100);
    const auto sm = LorenzMie(C(1.33, 0), x).amplitudes(1.0);
    const auto sg = Goa(C(1.33, 0), x).amplitudes_at_angle(0.0);
    CHECK(std::abs(sg.S1 - sm.S1) <= 0.02 * std::abs(sm.S1));
    CHECK(sg.S1.real() < sm.S1.real());  // GOA lacks the edge term of extinction
    CHECK(sg.S1 == sg.S2);
}

TEST_CASE("GOA error measures of F = (|S1|+|S2|)/2 vs Mie (Guo21 Fig. 6 left)", "[optics][goa]") {
    // Energy-weighted measure: <= 0.03 at r = 2 um, <= 0.01 from r = 5 um on.
    CHECK(goa_vs_mie(C(1.33, 0), 2).energy_F <= 0.03);
    for (double r : {5.0, 10.0, 20.0, 100.0}) {
        INFO("r = " << r);
        CHECK(goa_vs_mie(C(1.33, 0), r).energy_F <= 0.01);
    }
    // The per-angle RelMSE does NOT reach 0.01 at r = 2 um for a correct GOA (~0.2): the
    // paper's "< 0.01 for r >= 2 um" holds only for the energy-weighted measure (docs/guo21.md).
    CHECK(goa_vs_mie(C(1.33, 0), 2).relmse_F > 0.1);
}

TEST_CASE("GOA finds every ray: two near each rainbow", "[optics][goa]") {
    const C w(1.33, 0);
    // Primary rainbow (p = 2) at ~137.5 deg: two rays on its bright side, none in Alexander's band.
    CHECK(count_rays(w, 2, 140) == 2);
    CHECK(count_rays(w, 2, 150) == 2);
    CHECK(count_rays(w, 2, 132) == 0);
    // Secondary rainbow (p = 3) at ~129 deg: two rays below it.
    CHECK(count_rays(w, 3, 120) == 2);
    CHECK(count_rays(w, 3, 132) == 0);
    CHECK(count_rays(w, 0, 60) == 1);
    CHECK(count_rays(w, 1, 60) == 1);
    // m = 1.5: p = 2 has three rays near the back direction (branch crosses pi).
    CHECK(count_rays(C(1.5, 0), 2, 172) == 3);
    // Each found ray really exits at the requested angle.
    goa_rays(w, 3, 150 * kPi / 180, [&](const GoaRay& r) {
        if (r.p == 0) return;
        const double theta_p = 2 * r.p * r.theta_t - 2 * r.theta_i - (r.p - 1) * kPi;
        const double wrapped = std::remainder(theta_p, 2 * kPi);
        CHECK(std::abs(std::abs(wrapped) - 150 * kPi / 180) < 1e-9);
    });
}

TEST_CASE("GOA extinction: Eq. 12 with p = 1 equals Eq. 14; p = 3 barely differs", "[optics][goa]") {
    const double k = 2 * kPi / kLambda;
    // Radii where Eq. 14's sine term is not zero (it vanishes at 5, 10, 50, 100 um for eta = 1.33).
    for (double r : {2.0, 3.0, 7.3}) {
        INFO("r = " << r);
        const double eq14 = goa_extinction_cross_section_eq14(r, 1.33, k);
        CHECK(std::abs(std::sin(2 * k * r * (1 - 1.33))) > 0.1);  // the ripple term is alive here
        const double c1 = Goa(C(1.33, 0), k * r, 1).qext() * kPi * r * r;
        const double c3 = Goa(C(1.33, 0), k * r, 3).qext() * kPi * r * r;
        CHECK(c1 == Approx(eq14).epsilon(1e-10));
        // Guo21 Sec. 3.2: RelMSE (C3 - C1)^2 / C3^2 < 1e-5 for eta = 1.33.
        CHECK((c3 - c1) * (c3 - c1) / (c3 * c3) < 1e-5);
        // Against exact Mie: GOA misses the edge term; still within 20 % at a few um.
        const double cm = LorenzMie(C(1.33, 0), k * r).efficiencies().qext * kPi * r * r;
        CHECK(std::abs(c3 - cm) < 0.2 * cm);
    }
}

TEST_CASE("GOA conventions: S2(180) = -S1(180), S1(0) = S2(0)", "[optics][goa]") {
    const Goa g(C(1.33, 0), 300.0);
    const auto b = g.amplitudes_at_angle(kPi);
    CHECK(std::abs(b.S1 + b.S2) < 1e-9 * std::abs(b.S1));
    const auto f = g.amplitudes_at_angle(0.0);
    CHECK(f.S1 == f.S2);
    // (Signs and phases of all orders against Mie: the pooled complex error test above.)
}

TEST_CASE("GOA diffraction carries pi r^2 and J1 limit", "[optics][goa]") {
    // Our large-argument J1 (Hankel expansion) against Boost.Math, relative to the envelope sqrt(2/(pi z)).
    double worst = 0;
    for (double z = 1.0; z < 2e5; z *= 1.013)
        worst = std::max(worst, std::abs(detail::bessel_j1(z) - boost::math::cyl_bessel_j(1, z)) * std::sqrt(kPi * z / 2));
    CHECK(worst < 1e-10);
    CHECK(fraunhofer_amplitude(100.0, 0.0) == Approx(5000.0));
    CHECK(fraunhofer_amplitude(100.0, 1e-9) == Approx(5000.0).epsilon(1e-12));
    // (1/x^2) int_0^{pi/2} 2 S_D^2 sin theta dtheta -> 1 (diffraction cross section = pi r^2).
    const double x = 200;
    double sum = 0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        const double th = (i + 0.5) * (0.5 * kPi) / n;
        const double s = fraunhofer_amplitude(x, th);
        sum += 2 * s * s * std::sin(th) * (0.5 * kPi / n);
    }
    CHECK(sum / (x * x) == Approx(1.0).epsilon(0.01));
}

TEST_CASE("GOA absorption: ray optics -> Eq. 13 when weak, saturates like Mie", "[optics][goa]") {
    for (double x : {100.0, 1000.0}) {
        const C m(1.33, 1e-6 * 100 / x);  // alpha k = 1e-4: optically thin
        const double qa = Goa(m, x).qabs();
        const double eq13 = goa_absorption_cross_section_eq13(1.0, m, 2 * kPi / x) / kPi;  // r = 1, lambda = 2 pi / x
        CHECK(qa == Approx(eq13).epsilon(1e-3));
    }
    // Strong absorption, x = 1000 and 5000: Mie Qabs = 0.912770 and 0.907582 (Wiscombe 1979).
    CHECK(Goa(C(1.5, 0.1), 1000).qabs() == Approx(0.912770).epsilon(0.01));
    CHECK(Goa(C(1.5, 0.1), 5000).qabs() == Approx(0.907582).epsilon(0.01));
    CHECK(Goa(C(1.5, 0), 1000).qabs() == 0.0);
    // Qsca = Qext - Qabs and both within limits.
    const Goa g(C(1.5, 0.01), 500);
    CHECK(g.qsca() == Approx(g.qext() - g.qabs()));
    CHECK(g.qsca() > 0);
}

TEST_CASE("GOA asymmetry parameter by quadrature approaches Mie's g at large r", "[optics][goa]") {
    const double x = size_param(100);
    const double g_mie = LorenzMie(C(1.33, 0), x).efficiencies().g;
    CHECK(goa_asymmetry_parameter(Goa(C(1.33, 0), x)) == Approx(g_mie).epsilon(2e-3));
    // Eq. 2 by quadrature vs Qext - Qabs: within 2 % at 100 um (GOA is nearly energy-consistent there).
    const auto mom = goa_intensity_moments(Goa(C(1.33, 0), x));
    CHECK(mom.i0 / (x * x) == Approx(Goa(C(1.33, 0), x).qsca()).epsilon(0.02));
}

TEST_CASE("GOA rejects bad input", "[optics][goa]") {
    CHECK_THROWS_AS(Goa(C(1.33, 0), 0.0), invalid_argument);
    CHECK_THROWS_AS(Goa(C(1.0, 0), 10.0), invalid_argument);
    CHECK_THROWS_AS(Goa(C(1.33, -1e-3), 10.0), invalid_argument);
    CHECK_THROWS_AS(Goa(C(1.33, 0), 10.0, -1), invalid_argument);
}
