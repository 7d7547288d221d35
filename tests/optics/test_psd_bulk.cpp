// Tests of optics/particle.hpp, optics/psd.hpp and optics/bulk.hpp: closed-form moments, sampler
// chi-square against the CDF, the Mie/GOA switch, phase normalization, bulk = N C for one radius,
// bulk quadrature against an independent brute-force sum.
#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <vector>

#include "common/chi2.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/optics/bulk.hpp"
#include "grainlight/optics/particle.hpp"
#include "grainlight/optics/psd.hpp"

using namespace grainlight;
using C = std::complex<double>;

namespace {
constexpr double kPi = 3.14159265358979323846;

// Independent quadrature: trapezoid in ln r with n nodes over [a, b].
template <class Fn>
double integrate_log(Fn&& f, double a, double b, int n = 20000) {
    const double la = std::log(a), lb = std::log(b), h = (lb - la) / n;
    double s = 0;
    for (int i = 0; i <= n; ++i) {
        const double r = std::exp(la + i * h);
        s += (i == 0 || i == n ? 0.5 : 1.0) * f(r) * r * h;
    }
    return s;
}
}  // namespace

TEST_CASE("Log-normal PSD: Eq. 15, normalization and moments", "[optics][psd]") {
    // Untruncated: E[r^k] = r_g^k exp(k^2 ln^2 sigma_g / 2).
    const LogNormalPsd full(10.0, 2.0);
    for (double k : {1.0, 2.0, 3.0}) {
        const double s = std::log(2.0);
        CHECK(full.moment(k) == Approx(std::pow(10.0, k) * std::exp(0.5 * k * k * s * s)).epsilon(1e-12));
    }
    // Eq. 15 written out (N_0 = 1) equals pdf.
    const double r = 7.0, s = std::log(2.0);
    const double eq15 = 1 / (std::sqrt(2 * kPi) * r * s) * std::exp(-0.5 * std::pow((std::log(r) - std::log(10.0)) / s, 2));
    CHECK(full.pdf(r) == Approx(eq15).epsilon(1e-12));
    // Truncated (Guo21 Sec. 6: r_max = 2000): pdf integrates to 1; moments against quadrature.
    const LogNormalPsd t(100.0, 4.0, 1.0, 2000.0, 3e6);
    CHECK(integrate_log([&](double x) { return t.pdf(x); }, 1.0, 2000.0) == Approx(1.0).epsilon(1e-6));
    for (double k : {1.0, 2.0, 3.0})
        CHECK(integrate_log([&](double x) { return std::pow(x, k) * t.pdf(x); }, 1.0, 2000.0) ==
              Approx(t.moment(k)).epsilon(1e-6));
    CHECK(t.density(50.0) == Approx(3e6 * t.pdf(50.0)));
    CHECK(t.pdf(0.5) == 0.0);
    CHECK(t.pdf(3000.0) == 0.0);
    // Inversion: cdf(sample(u)) = u.
    for (double u : {0.0, 0.1, 0.5, 0.9, 0.999}) CHECK(t.cdf(t.sample(u)) == Approx(u).margin(1e-9));
    const auto chi = gl_test::chi2_1d([&](double u) { return t.sample(u); }, [&](double x) { return t.cdf(x); }, 1.0,
                                      2000.0, 40, 200000);
    INFO(chi.describe());
    CHECK(chi.p_value > 1e-3);
}

TEST_CASE("Bimodal and tabulated PSDs", "[optics][psd]") {
    // Guo21 Sec. 6.7: 1.99e7 particles with r_g = 100, sigma_g = 1 (we need > 1: 1.1) and 1e5 with
    // r_g = 1000, sigma_g = 1.2.
    const BimodalLogNormalPsd b(100.0, 1.1, 1000.0, 1.2, 1.99e7 / 2e7, 1.0, 2000.0, 2e7);
    CHECK(integrate_log([&](double x) { return b.pdf(x); }, 1.0, 2000.0, 200000) == Approx(1.0).epsilon(1e-6));
    CHECK(integrate_log([&](double x) { return x * x * b.pdf(x); }, 1.0, 2000.0, 200000) ==
          Approx(b.moment(2)).epsilon(1e-6));
    CHECK(b.weight1() == Approx(0.995).epsilon(1e-4));  // mode 2's tail above 2000 um is tiny
    const auto chi = gl_test::chi2_1d([&](double u) { return b.sample(u); }, [&](double x) { return b.cdf(x); }, 1.0,
                                      2000.0, 50, 200000);
    INFO(chi.describe());
    CHECK(chi.p_value > 1e-3);
    // Tabulated: uniform density on [1, 3]: E[r] = 2, E[r^2] = 13/3, E[r^3] = 10.
    const std::vector<double> rr = {1.0, 2.0, 3.0}, dd = {5.0, 5.0, 5.0};
    const TabulatedPsd u(rr, dd, 10.0);
    CHECK(u.moment(1) == Approx(2.0).epsilon(1e-12));
    CHECK(u.moment(2) == Approx(13.0 / 3.0).epsilon(1e-12));
    CHECK(u.moment(3) == Approx(10.0).epsilon(1e-12));
    CHECK(u.pdf(1.5) == Approx(0.5));
    CHECK(u.cdf(2.5) == Approx(0.75));
    CHECK_THROWS_AS(LogNormalPsd(10.0, 1.0), invalid_argument);
    CHECK_THROWS_AS(LogNormalPsd(-1.0, 2.0), invalid_argument);
    CHECK_THROWS_AS(LogNormalPsd(10.0, 2.0, 5.0, 4.0), invalid_argument);
    CHECK_THROWS_AS(TabulatedPsd(std::vector<double>{2.0, 1.0}, std::vector<double>{1.0, 1.0}), invalid_argument);
}

TEST_CASE("SingleParticle: Mie below 2 um, GOA from 2 um where valid, Eqs. 1-3", "[optics][particle]") {
    ParticleModel model;
    model.particle_index = {1.33, 0.0};
    // GOA is valid from x = 45 (test_goa_validity.cpp): r = 5 um at 0.6 um is x = 52.
    const SingleParticle small(1.5, 0.6, model), large(5.0, 0.6, model);
    CHECK(small.method() == ScatteringMethod::mie);
    CHECK(large.method() == ScatteringMethod::goa);
    CHECK(small.size_parameter() == Approx(2 * kPi * 1.5 / 0.6));
    // Eq. 3: C_t = 4 pi Re S(0) / k^2.
    for (const auto* p : {&small, &large}) {
        const auto cs = p->cross_sections();
        const double k = p->wavenumber();
        CHECK(cs.C_t == Approx(4 * kPi * p->amplitudes_at_angle(0.0).S1.real() / (k * k)).epsilon(1e-12));
        CHECK(cs.C_a == Approx(0.0).margin(1e-12 * cs.C_t));
        // Eq. 1 normalized by Eq. 2: integral over the sphere = 1 (Mie exactly, GOA within 3 %).
        double integral = 0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
            const double th = (i + 0.5) * kPi / n;
            integral += 2 * kPi * p->phase(th) * std::sin(th) * kPi / n;
        }
        if (p->method() == ScatteringMethod::mie) {
            CHECK(integral == Approx(1.0).epsilon(1e-6));
        } else {
            CHECK(integral == Approx(1.0).epsilon(1e-3));
        }
    }
    // Host index: water host, glass particle: x = 2 pi n_host r / lambda, m = 1.5 / 1.33.
    ParticleModel glass_in_water;
    glass_in_water.particle_index = {1.5, 0.0};
    glass_in_water.host_index = 1.33;
    const SingleParticle g(1.0, 0.5, glass_in_water);
    CHECK(g.size_parameter() == Approx(2 * kPi * 1.33 / 0.5));
    CHECK(g.cross_sections().C_t ==
          Approx(LorenzMie(C(1.5 / 1.33, 0), 2 * kPi * 1.33 / 0.5).efficiencies().qext * kPi).epsilon(1e-12));
    // Absorbing particle: C_a > 0 for both methods.
    ParticleModel dust;
    dust.particle_index = {1.5, 0.01};
    CHECK(SingleParticle(1.0, 0.6, dust).cross_sections().C_a > 0);
    CHECK(SingleParticle(10.0, 0.6, dust).cross_sections().C_a > 0);
    CHECK_THROWS_AS(SingleParticle(-1.0, 0.6, model), invalid_argument);
    CHECK_THROWS_AS(SingleParticle(1.0, 0.0, model), invalid_argument);
    ParticleModel bad;
    bad.particle_index = {1.5, -0.1};
    CHECK_THROWS_AS(SingleParticle(1.0, 0.6, bad), invalid_argument);
}

TEST_CASE("Bulk properties: monodisperse = N C, narrow PSD -> monodisperse", "[optics][bulk]") {
    ParticleModel model;
    model.particle_index = {1.31, 0.001};
    const std::vector<double> wl = {0.45, 0.55, 0.65};
    for (double r0 : {1.0, 5.0}) {
        INFO("r0 = " << r0);
        const MonodispersePsd mono(r0, 1e9);
        const auto b = compute_bulk_optics(mono, model, wl);
        for (std::size_t c = 0; c < wl.size(); ++c) {
            const auto cs = SingleParticle(r0, wl[c], model).cross_sections();
            CHECK(b.channels[c].sigma_t == Approx(1e9 * cs.C_t * 1e-12).epsilon(1e-12));
            CHECK(b.channels[c].sigma_s == Approx(1e9 * cs.C_s * 1e-12).epsilon(1e-12));
            CHECK(b.channels[c].sigma_a == Approx(1e9 * cs.C_a * 1e-12).epsilon(1e-9));
        }
        // A very narrow log-normal through the adaptive quadrature gives the same numbers.
        const LogNormalPsd narrow(r0, 1.0005, 0.0, 1e9, 1e9);
        const auto n = compute_bulk_optics(narrow, model, wl);
        for (std::size_t c = 0; c < wl.size(); ++c) {
            CHECK(n.channels[c].sigma_t == Approx(b.channels[c].sigma_t).epsilon(5e-3));
            CHECK(n.channels[c].sigma_s == Approx(b.channels[c].sigma_s).epsilon(5e-3));
            CHECK(n.channels[c].g == Approx(b.channels[c].g).epsilon(5e-3));
        }
    }
}

TEST_CASE("Bulk properties: adaptive quadrature vs brute force, phase normalized (Eqs. 16-17)", "[optics][bulk]") {
    // Small particles (all Mie): bulk C_s and g against a brute-force trapezoid over 400 radii.
    ParticleModel model;
    model.particle_index = {1.33, 0.0};
    const LogNormalPsd psd(0.3, 1.6, 0.05, 1.9, 1.0);
    const std::vector<double> wl = {0.5};
    const auto b = compute_bulk_optics(psd, model, wl);
    const auto& ch = b.channels[0];
    const double k = 2 * kPi / 0.5;
    double cs = 0, gcs = 0, ct = 0;
    const int n = 400;
    const double la = std::log(0.05), lb = std::log(1.9), h = (lb - la) / n;
    for (int i = 0; i <= n; ++i) {
        const double r = std::exp(la + i * h), w = (i == 0 || i == n ? 0.5 : 1.0) * psd.pdf(r) * r * h;
        const auto q = LorenzMie(C(1.33, 0), k * r).efficiencies();
        ct += w * q.qext * kPi * r * r;
        cs += w * q.qsca * kPi * r * r;
        gcs += w * q.g * q.qsca * kPi * r * r;
    }
    CHECK(ch.mean_C_t == Approx(ct).epsilon(2e-3));
    CHECK(ch.mean_C_s == Approx(cs).epsilon(2e-3));
    CHECK(ch.g == Approx(gcs / cs).epsilon(5e-3));
    CHECK(ch.phase_integral == Approx(1.0).epsilon(2e-3));
    CHECK(ch.sigma_t == Approx(ch.mean_C_t * 1e-12));  // N_0 = 1 per m^3
    // Mixed Mie/GOA PSD over 8 wavelengths (Guo21 Sec. 6: 8 spectral samples): finite, normalized.
    const LogNormalPsd snow(10.0, 2.0, 0.1, 2000.0, 1e6);
    std::vector<double> wl8;
    for (int i = 0; i < 8; ++i) wl8.push_back(0.4 + 0.05 * i);
    const auto s = compute_bulk_optics(snow, model, wl8);
    REQUIRE(s.channels.size() == 8);
    for (const auto& c : s.channels) {
        CHECK(c.mean_C_t == Approx(2 * kPi * snow.moment(2)).epsilon(0.02));  // large particles: Q_ext -> 2
        CHECK(c.phase_integral == Approx(1.0).epsilon(0.03));
        CHECK(c.g > 0.85);
        CHECK(c.g < 0.95);
    }
    const auto phase = s.make_phase<double, Spectrum<8, double>>();
    CHECK(phase.mean_cosine()[0] == Approx(s.channels[0].g).epsilon(1e-3));
    CHECK_THROWS_AS((s.make_phase<double, Spectrum<3, double>>()), invalid_argument);
    // The bulk table drives a continuous medium (Guo21 Sec. 5.5: global properties for sampling).
    using S8 = Spectrum<8, double>;
    const ContinuousMedium<MiePhase<double, S8>> medium(s.sigma_t_spectrum<S8>(), s.albedo_spectrum<S8>(), phase);
    (void)medium;
    CHECK(s.albedo_spectrum<S8>()[0] == Approx(1.0).margin(1e-9));
    CHECK(s.sigma_t_spectrum<S8>()[3] == Approx(s.channels[3].sigma_t));
}
