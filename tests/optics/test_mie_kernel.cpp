// Tests of the blocked SIMD amplitude kernel of optics/lorenz_mie.hpp (issue 13; and the GOA
// ray-phase sincos of optics/goa.hpp at the end): the span
// overload, its theta / pi - theta pairing and the per-angle calls against an independent
// textbook evaluation of the same series (Bohren & Huffman 1983 Eqs. 4.74, 4.46-4.47: the
// pi_n / tau_n upward recurrence with the division by n, one angle at a time).
#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"

using grainlight::LorenzMie;
using grainlight::ScatteringAmplitudes;
using C = std::complex<double>;

namespace {
constexpr double kPi = 3.14159265358979323846;

// S1, S2 from the coefficients a_n, b_n by the textbook recurrence (independent of the kernel).
ScatteringAmplitudes textbook(const LorenzMie& mie, double mu) {
    C s1 = 0, s2 = 0;
    double pi0 = 0, pi1 = 1;
    const auto a = mie.a(), b = mie.b();
    for (std::size_t i = 0; i < a.size(); ++i) {
        const double n = double(i + 1);
        const double tau = n * mu * pi1 - (n + 1) * pi0;
        const double w = (2 * n + 1) / (n * (n + 1));
        s1 += w * (a[i] * pi1 + b[i] * tau);
        s2 += w * (a[i] * tau + b[i] * pi1);
        const double pi2 = ((2 * n + 1) * mu * pi1 - (n + 1) * pi0) / n;
        pi0 = pi1;
        pi1 = pi2;
    }
    return {s1, s2};
}

double max_abs(const std::vector<ScatteringAmplitudes>& s) {
    double m = 0;
    for (const auto& v : s) m = std::max({m, std::abs(v.S1), std::abs(v.S2)});
    return m;
}
}  // namespace

TEST_CASE("Mie kernel: 180-angle grid (pairs symmetric to round-off) matches the textbook series", "[optics][mie]") {
    std::vector<double> mu(180);
    for (int i = 0; i < 180; ++i) mu[std::size_t(i)] = std::cos(kPi * i / 179);
    for (auto [m, x] : {std::pair{C(1.33, 0.0), 1000.0}, std::pair{C(1.5, 0.1), 300.0}, std::pair{C(0.75, 0.0), 37.0},
                        std::pair{C(1.33, 1e-5), 2.5}}) {
        INFO("m = " << m << ", x = " << x);
        const LorenzMie mie(m, x);
        std::vector<ScatteringAmplitudes> out(mu.size()), ref(mu.size());
        mie.amplitudes(mu, out);
        for (std::size_t k = 0; k < mu.size(); ++k) ref[k] = textbook(mie, mu[k]);
        const double smax = max_abs(ref);
        double worst = 0;
        for (std::size_t k = 0; k < mu.size(); ++k) {
            worst = std::max({worst, std::abs(out[k].S1 - ref[k].S1), std::abs(out[k].S2 - ref[k].S2)});
            // the per-angle call runs the same kernel: bit-identical for the angles evaluated
            // directly, within round-off for the mirrored ones
            const auto one = mie.amplitudes(mu[k]);
            CHECK(std::abs(one.S1 - out[k].S1) <= 1e-13 * smax);
            CHECK(std::abs(one.S2 - out[k].S2) <= 1e-13 * smax);
        }
        CHECK(worst <= 1e-12 * smax);
    }
}

TEST_CASE("Mie kernel: pairing handles exact, near and missing mirrors, duplicates and short spans", "[optics][mie]") {
    const LorenzMie mie(C(1.33, 0.001), 60);
    const double e = std::numeric_limits<double>::epsilon();
    const std::vector<double> mu = {0.3,  -0.3,      0.7, -0.7 + 2 * e, 0.0, 1.0, -1.0, 0.25, 0.25, -0.25,
                                    0.91, -0.5,      0.6, -0.6 - 3 * e, 0.1, -0.1 + 64 * e,  // not a pair (64 eps)
                                    -0.999, 0.999, 0.42};
    for (std::size_t K : {std::size_t(1), std::size_t(2), std::size_t(5), std::size_t(17), mu.size()}) {
        std::vector<double> m(mu.begin(), mu.begin() + std::ptrdiff_t(K));
        std::vector<ScatteringAmplitudes> out(K);
        mie.amplitudes(m, out);
        double smax = 0;
        for (double u : m) {
            const auto r = textbook(mie, u);
            smax = std::max({smax, std::abs(r.S1), std::abs(r.S2)});
        }
        for (std::size_t k = 0; k < K; ++k) {
            INFO("K = " << K << ", mu = " << m[k]);
            const auto r = textbook(mie, m[k]);
            CHECK(std::abs(out[k].S1 - r.S1) <= 1e-12 * smax);
            CHECK(std::abs(out[k].S2 - r.S2) <= 1e-12 * smax);
        }
    }
    // out shorter than the angles: only out.size() are written
    std::vector<ScatteringAmplitudes> two(2);
    mie.amplitudes(mu, two);
    CHECK(std::abs(two[1].S1 - textbook(mie, -0.3).S1) <= 1e-12 * std::abs(textbook(mie, 1.0).S1));
}

TEST_CASE("Mie kernel: x = 1e5 is finite and obeys the optical theorem and the 180-degree symmetry", "[optics][mie]") {
    const LorenzMie mie(C(1.33, 0.0), 1e5);
    std::vector<double> mu(180);
    for (int i = 0; i < 180; ++i) mu[std::size_t(i)] = std::cos(kPi * i / 179);
    std::vector<ScatteringAmplitudes> out(mu.size());
    mie.amplitudes(mu, out);
    for (const auto& s : out) {
        CHECK(std::isfinite(s.S1.real()));
        CHECK(std::isfinite(s.S1.imag()));
        CHECK(std::isfinite(s.S2.real()));
        CHECK(std::isfinite(s.S2.imag()));
    }
    const auto q = mie.efficiencies();
    // Qext = 4 Re S(0) / x^2 (B&H Eq. 4.76) and S1(180) = -S2(180) (B&H Sec. 4.4.4)
    CHECK(4 * out[0].S1.real() / (1e5 * 1e5) == Approx(q.qext).epsilon(1e-10));
    CHECK(std::abs(out[0].S1 - out[0].S2) <= 1e-12 * std::abs(out[0].S1));
    CHECK(std::abs(out[179].S1 + out[179].S2) <= 1e-10 * std::abs(out[179].S1));
    CHECK(q.qext == Approx(2.0).margin(0.01));
}

TEST_CASE("GOA ray-phase sincos agrees with std::sin / std::cos", "[optics][goa]") {
    // The inline reduction + polynomial used for the GOA ray phases (optics/goa.hpp) against the
    // C library on |x| from 1e-8 to 8e5 rad (the phases of alpha up to ~1e5) and at multiples of
    // pi/2 (the quadrant boundaries of the reduction), and the std fallback beyond.
    auto rng = grainlight::Pcg32::from_key(77);
    double worst = 0;
    for (double scale : {1e-8, 1e-3, 1.0, 10.0, 1e3, 1e5, 7.9e5, 1e7}) {
        for (int i = 0; i < 200000; ++i) {
            const double x = scale * (2 * rng.uniform<double>() - 1);
            double s, c;
            grainlight::detail::goa_sincos(x, s, c);
            worst = std::max({worst, std::abs(s - std::sin(x)), std::abs(c - std::cos(x))});
        }
    }
    for (int k = -20000; k <= 20000; ++k) {
        const double x = k * 1.5707963267948966;
        double s, c;
        grainlight::detail::goa_sincos(x, s, c);
        worst = std::max({worst, std::abs(s - std::sin(x)), std::abs(c - std::cos(x))});
    }
    CHECK(worst <= 5e-16);
}
