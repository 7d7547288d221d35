// TabulatedPhase sampling through the guide tables of core/distribution.hpp (issue 13): chi-square
// of the sampler against its own pdf on large tables (16384 nodes, float and double), linear and
// histogram interpolation, grey and spectral.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "common/chi2.hpp"
#include "grainlight/phase.hpp"

using namespace grainlight;

namespace {
double theta_warp(double s) { return pi_v<double> * (s < 0.5 ? 2 * s * s : 1 - 2 * (1 - s) * (1 - s)); }

template <class P>
gl_test::Chi2Result chi2_phase(const P& p, std::uint64_t seed, std::size_t n = 300000) {
    using F = typename P::Float;
    const Vec3<F> w_in(0, 0, 1);
    return gl_test::chi2_directions(
        [&](double u1, double u2, Vec3d& w) {
            auto s = p.sample(w_in, Vec2<F>(F(u1), F(u2)));
            w = Vec3d(s.w);
            return bool(s);
        },
        [&](const Vec3d& w) { return double(p.eval(w_in, Vec3<F>(w)).pdf); }, n, 40, 12, seed, theta_warp);
}

// HG(0.9) on a grid dense toward mu = 1 (bench_phase's table), nodes on [-1, 1].
void grid(std::size_t nodes, std::vector<double>& mu, std::vector<double>& v, double g = 0.9) {
    mu.clear();
    v.clear();
    for (std::size_t i = 0; i < nodes; ++i) {
        const double t = double(i) / double(nodes - 1);
        mu.push_back(1.0 - 2.0 * (1.0 - t) * (1.0 - t));
        v.push_back(henyey_greenstein_cos_pdf(mu.back(), g));
    }
    mu.front() = -1.0;
    mu.back() = 1.0;
}
}  // namespace

TEST_CASE("TabulatedPhase on 16384 nodes passes chi-square (guide-table sampling)", "[phase][tabulated][chi2][guide]") {
    std::vector<double> mu, v;
    grid(16384, mu, v);
    const double alpha = gl_test::sidak(0.01, 4);
    {
        const auto tab = TabulatedPhase<float, Spectrum<1, float>>::from_values(mu, v);
        const auto r = chi2_phase(tab, 501);
        INFO("float linear: " << r.describe());
        CHECK(r.p_value > alpha);
    }
    {
        const auto tab = TabulatedPhase<double, Spectrum<1, double>>::from_values(mu, v);
        const auto r = chi2_phase(tab, 502);
        INFO("double linear: " << r.describe());
        CHECK(r.p_value > alpha);
    }
    {
        std::vector<double> counts(v.begin(), v.end() - 1);
        for (std::size_t i = 0; i < counts.size(); ++i) counts[i] *= mu[i + 1] - mu[i];
        const auto tab = TabulatedPhase<double, Spectrum<1, double>>::from_histogram(mu, counts);
        const auto r = chi2_phase(tab, 503);
        INFO("histogram: " << r.describe());
        CHECK(r.p_value > alpha);
    }
    {
        // spectral: three channels with different peaks (one-sample MIS over channels)
        std::vector<double> m2, v1, v2, v3;
        grid(16384, m2, v1, 0.5);
        grid(16384, m2, v2, 0.9);
        grid(16384, m2, v3, -0.3);
        std::vector<RGBd> vals(m2.size());
        for (std::size_t i = 0; i < m2.size(); ++i) vals[i] = RGBd{v1[i], v2[i], v3[i]};
        const auto tab = TabulatedPhase<double, RGBd>::from_values(m2, std::span<const RGBd>(vals));
        const auto r = chi2_phase(tab, 504);
        INFO("RGB linear: " << r.describe());
        CHECK(r.p_value > alpha);
    }
}
