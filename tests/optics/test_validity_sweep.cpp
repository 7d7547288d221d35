// The optics' validity range end to end (issue 15, item 4; table in docs/optics_validity.md).
// Lorenz-Mie over m in {1.0001, 1.05, 1.33, 1.33 + 1e-8 i, 1.5 + 0.1 i, 2.5 + i, 4 + 0.01 i, 10 + 10 i,
// 0.75} and x = 1e-3 .. 1e5; GOA over the same indices for r = 2 um .. 2 mm at 0.55 um. Checked:
// every output finite, 0 <= Qsca <= Qext, Qabs >= 0, |g| <= 1; the optical theorem; energy
// conservation for real m; the Rayleigh limit; Qext -> 2 where the phase shift rho = 2 x |m - 1|
// >= 200 (bounded by the edge term and the anomalous-diffraction ripple); van de Hulst's
// anomalous-diffraction formula for m -> 1 (van de Hulst 1957, Light Scattering by Small
// Particles, Sec. 11.22; e.g. Qext = 1.8233 at m = 1.0001, x = 1e5, rho = 20); GOA: where valid,
// within 15 % of Mie and its Qext -> 2; bubbles (m = 0.75) and strongly absorbing spheres
// against Mie.
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

std::vector<C> sweep_indices() {
    return {C(1.0001, 0), C(1.05, 0), C(1.33, 0), C(1.33, 1e-8), C(1.5, 0.1),
            C(2.5, 1),    C(4, 0.01), C(10, 10),  C(0.75, 0)};
}

std::vector<double> sweep_size_parameters() {
    return {1e-3, 1e-2, 0.1, 0.5, 1, 3, 10, 30, 100, 300, 1e3, 3e3, 1e4, 3e4, 1e5};
}

/// van de Hulst's anomalous-diffraction extinction efficiency (1957, Sec. 11.22), m = n + i k:
/// Q = 2 - 4 e^{-rho tan b} (cos b / rho) sin(rho - b) - 4 e^{-rho tan b} (cos b / rho)^2 cos(rho - 2b)
///     + 4 (cos b / rho)^2 cos 2b,  rho = 2 x (n - 1), tan b = k / (n - 1).
double anomalous_diffraction_qext(C m, double x) {
    const double rho = 2 * x * (m.real() - 1), tb = m.imag() / (m.real() - 1);
    const double b = std::atan(tb), cb = std::cos(b), e = std::exp(-rho * tb), u = cb / rho;
    return 2 - 4 * e * u * std::sin(rho - b) - 4 * e * u * u * std::cos(rho - 2 * b) + 4 * u * u * std::cos(2 * b);
}

/// Bound on |Qext - 2| for a large sphere: the edge term (~2 x^(-2/3); 3 x^(-2/3) covers the
/// metal-like 10 + 10 i) plus the anomalous-diffraction ripple 4/rho + 8/rho^2; bubbles (n < 1)
/// add the oscillation of critical-angle scattering, measured below x^(-1/2) (0.0022 at x = 1e5).
double large_sphere_bound(C m, double x, double rho) {
    return 3 * std::pow(x, -2.0 / 3.0) + 4 / rho + 8 / (rho * rho) + (m.real() < 1 ? 1 / std::sqrt(x) : 0.0);
}

/// Relative tolerance of ray-optics absorption against Mie: Mie's Qabs has an edge term too
/// (surface waves; measured 9 % at x = 57 for 1.5 + 0.1 i, 5 % at x = 1000 for 10 + 10 i).
double qabs_tolerance(double x) { return 0.02 + 6 * std::pow(x, -2.0 / 3.0); }
}  // namespace

TEST_CASE("Validity sweep, Lorenz-Mie: x = 1e-3 .. 1e5 for every index", "[optics][mie][validity]") {
    for (const C m : sweep_indices()) {
        for (const double x : sweep_size_parameters()) {
            INFO("m = " << m << ", x = " << x);
            const LorenzMie mie(m, x);
            const auto q = mie.efficiencies();
            const auto s0 = mie.amplitudes(1.0), s180 = mie.amplitudes(-1.0), s90 = mie.amplitudes(0.0);
            for (double v : {q.qext, q.qsca, q.qabs, q.qback, q.g, s0.S1.real(), s0.S1.imag(), s180.S1.real(),
                             s180.S1.imag(), s90.S1.real(), s90.S2.imag()})
                REQUIRE(std::isfinite(v));
            CHECK(q.qsca >= 0);
            CHECK(q.qsca <= q.qext * (1 + 1e-9));
            CHECK(q.qabs >= -1e-9 * q.qext);
            CHECK(std::abs(q.g) <= 1.0);
            // Optical theorem (Eq. 3): Qext = 4 Re S(0) / x^2, S1(0) = S2(0).
            CHECK(4 * s0.S1.real() / (x * x) == Approx(q.qext).epsilon(1e-9));
            CHECK(std::abs(s0.S1 - s0.S2) <= 1e-9 * std::abs(s0.S1));
            // Backward: S2(180) = -S1(180).
            CHECK(std::abs(s180.S1 + s180.S2) <= 1e-9 * std::abs(s180.S1) + 1e-300);
            // Real index: no absorption, Qext = Qsca from two different series.
            if (m.imag() == 0) CHECK(q.qsca == Approx(q.qext).epsilon(1e-8));
            // Rayleigh limit: Qsca = 8/3 x^4 |(m^2 - 1)/(m^2 + 2)|^2 (Bohren & Huffman Eq. 5.8).
            if (x * std::abs(m) <= 0.02) {
                const double a = std::norm((m * m - 1.0) / (m * m + 2.0));
                CHECK(q.qsca == Approx(8.0 / 3.0 * std::pow(x, 4) * a).epsilon(0.03));
            }
            // Large spheres: Qext -> 2 where rho = 2 x |m - 1| >= 200.
            const double rho = 2 * x * std::abs(m - 1.0);
            if (rho >= 200) CHECK(std::abs(q.qext - 2) <= large_sphere_bound(m, x, rho));
        }
    }
}

TEST_CASE("Validity sweep: Mie -> van de Hulst's anomalous diffraction for m -> 1", "[optics][mie][validity]") {
    // The example: m = 1.0001, x = 1e5, rho = 20: Qext = 1.8233 (formula; Mie 1.82351).
    CHECK(anomalous_diffraction_qext(C(1.0001, 0), 1e5) == Approx(1.82333).epsilon(2e-5));
    CHECK(LorenzMie(C(1.0001, 0), 1e5).efficiencies().qext == Approx(anomalous_diffraction_qext(C(1.0001, 0), 1e5)).epsilon(3e-4));
    // The formula is exact as |m - 1| -> 0 with x >> 1; its error is O(|m - 1|) (measured ~1e-4 at
    // m = 1.0001 and ~1e-3 at m = 1.001 for x >= 1000), so tolerance 3 |m - 1| + 1/x.
    for (const C m : {C(1.0001, 0), C(1.001, 0), C(1.0001, 1e-4), C(1.001, 1e-3)}) {
        for (const double x : {1e3, 3e3, 1e4, 3e4, 1e5}) {
            INFO("m = " << m << ", x = " << x << ", rho = " << 2 * x * (m.real() - 1));
            const double mie = LorenzMie(m, x).efficiencies().qext, adt = anomalous_diffraction_qext(m, x);
            CHECK(std::abs(mie - adt) <= (3 * std::abs(m - 1.0) + 1 / x) * mie);
        }
    }
}

TEST_CASE("Validity sweep, GOA: r = 2 um .. 2 mm at 0.55 um for every index", "[optics][goa][validity]") {
    const double lambda = 0.55;
    for (const C m : sweep_indices()) {
        int n_valid = 0;
        for (const double r : {2.0, 5.0, 20.0, 50.0, 200.0, 500.0, 2000.0}) {
            const double x = 2 * kPi * r / lambda, rho = 2 * x * std::abs(m - 1.0);
            INFO("m = " << m << ", r = " << r << " um, x = " << x << ", rho = " << rho);
            const Goa goa(m, x);
            const auto v = goa_validity(m, x);
            GoaEfficiencies e;
            try {
                e = goa_efficiencies(goa);
            } catch (const invalid_argument&) {
                // Refused only where GOA's Qext would be negative, which only happens outside its range.
                CHECK_FALSE(v.valid);
                CHECK(goa.qext() < 0);
                continue;
            }
            REQUIRE(std::isfinite(e.qext));
            REQUIRE(std::isfinite(e.qabs));
            CHECK(e.qext >= 0);
            CHECK(e.qabs >= 0);
            CHECK(e.qsca >= 0);
            CHECK(e.qsca <= e.qext);
            CHECK(e.validity.valid == v.valid);
            if (r <= 200) {  // quadrature of |S|^2 costs ~x: the largest sphere skips it
                const double g = goa_asymmetry_parameter(goa);
                REQUIRE(std::isfinite(g));
                CHECK(std::abs(g) <= 1.0);
            }
            if (!v.valid) continue;
            ++n_valid;
            const auto q = LorenzMie(m, x).efficiencies();
            CHECK(std::abs(e.qext - q.qext) <= 0.15 * q.qext);
            if (rho >= 200) CHECK(std::abs(e.qext - 2) <= 4 / rho + 8 / (rho * rho) + 1e-6);
            // Absorption by ray optics against Mie (Qabs is smooth in x: no ripple).
            if (m.imag() * x >= 1) CHECK(std::abs(e.qabs - q.qabs) <= qabs_tolerance(x) * q.qabs);
        }
        INFO("m = " << m);
        if (m == C(1.0001, 0)) {
            CHECK(n_valid == 0);  // valid only from x = 30000 (r = 2.6 mm)
        } else {
            CHECK(n_valid >= 4);
        }
    }
}

TEST_CASE("Validity sweep, GOA: bubble and strongly absorbing spheres against Mie", "[optics][goa][validity]") {
    // Bubble m = 0.75 (total internal reflection, no absorption): Qabs = 0, Qext and g close to Mie.
    for (const double x : {500.0, 2000.0}) {
        INFO("bubble x = " << x);
        const Goa goa(C(0.75, 0), x);
        const auto e = goa_efficiencies(goa);
        const auto q = LorenzMie(C(0.75, 0), x).efficiencies();
        CHECK(e.validity.valid);
        CHECK(e.qabs == 0);
        CHECK(e.qext == Approx(q.qext).epsilon(0.03));
        CHECK(goa_asymmetry_parameter(goa) == Approx(q.g).epsilon(0.03));
    }
    // Strongly absorbing: all transmitted light is absorbed, Qabs = 1 - (hemispherical reflectance).
    for (const C m : {C(2.5, 1), C(10, 10), C(1.5, 0.1)}) {
        for (const double x : {1000.0, 5000.0}) {
            INFO("m = " << m << ", x = " << x);
            const auto e = goa_efficiencies(Goa(m, x));
            const auto q = LorenzMie(m, x).efficiencies();
            CHECK(e.validity.valid);
            CHECK(std::abs(e.qabs - q.qabs) <= qabs_tolerance(x) * q.qabs);
            CHECK(e.qext == Approx(q.qext).epsilon(0.03));
            CHECK(e.qsca == Approx(q.qsca).epsilon(0.05));
        }
    }
}
