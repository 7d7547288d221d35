// The glossy reflector (optics/microfacet.hpp): GGX distribution normalised (int D(h) cos dh = 1,
// quadrature), visible-normal sampling against its own pdf (chi-square), the sample weight equal
// to eval / pdf, reciprocity of f, energy: the mean weight equals the quadrature of f cos over the
// hemisphere, is <= 1 with F0 = 1 and -> 1 for a near-mirror (no energy made or lost by the
// sampler), and the Schlick term at normal and grazing incidence (Schlick 1994: F0 and 1).
#include <catch2/catch.hpp>

#include <cmath>

#include "common/chi2.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/optics/microfacet.hpp"

using namespace grainlight;
using Grey = Spectrum<1, double>;

namespace {
Vec3d dir(double theta, double phi) {
    return Vec3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}
// Midpoint quadrature over the upper hemisphere of g(w) dw.
template <class G>
double hemisphere(G&& g, int nt = 400, int np = 400) {
    double s = 0;
    for (int i = 0; i < nt; ++i) {
        const double th = (i + 0.5) * 0.5 * pi_v<double> / nt;
        for (int j = 0; j < np; ++j) s += g(dir(th, (j + 0.5) * 2 * pi_v<double> / np)) * std::sin(th);
    }
    return s * (0.5 * pi_v<double> / nt) * (2 * pi_v<double> / np);
}
}  // namespace

TEST_CASE("GGX: D is normalised over projected microfacet area", "[optics][microfacet]") {
    for (double a : {0.05, 0.2, 0.6, 1.0}) {
        const Ggx<double> g{a};
        INFO("alpha " << a);
        CHECK(hemisphere([&](const Vec3d& h) { return g.D(h) * h.z; }, 1200, 8) == Approx(1.0).epsilon(2e-3));
        // Visible normals of wo integrate to 1 too: int G1(wo) max(0, wo.h) D(h) / wo.z dh = 1.
        const Vec3d wo = dir(1.1, 0.3);
        CHECK(hemisphere([&](const Vec3d& h) { return g.G1(wo) * std::max(0.0, glm::dot(wo, h)) * g.D(h) / wo.z; }, 1200, 400) ==
              Approx(1.0).epsilon(3e-3));
    }
}

TEST_CASE("Glossy sampling: chi-square against the pdf, weight = eval / pdf", "[optics][microfacet][chi2]") {
    int tests = 0;
    for (double a : {0.1, 0.35, 0.8})
        for (double th_o : {0.2, 1.0, 1.4}) {
            ++tests;
            const Vec3d wo = dir(th_o, 0.7);
            const Grey F0(0.6);
            auto sample = [&](double u1, double u2, Vec3d& w) {
                const auto s = sample_glossy(wo, F0, a, Vec2d(u1, u2));
                if (!s.valid) return false;
                double pdf = 0;
                const Grey f = eval_glossy(wo, s.wi, F0, a, pdf);
                REQUIRE(pdf == Approx(s.pdf).epsilon(1e-9));
                REQUIRE(s.weight[0] == Approx(f[0] / pdf).epsilon(1e-9));
                REQUIRE(s.weight[0] <= 1.0 + 1e-12);
                w = s.wi;
                return true;
            };
            auto pdf = [&](const Vec3d& w) {
                double p = 0;
                (void)eval_glossy(wo, w, F0, a, p);
                return p;
            };
            // Bins in cos(theta)^(1/2)-like coordinates resolve the peak near the mirror direction.
            const auto r = gl_test::chi2_directions(sample, pdf, 200000, 40, 40, 11 + std::uint64_t(tests),
                                                    [](double s) { return 0.5 * pi_v<double> * s; });
            INFO("alpha " << a << ", theta_o " << th_o << ": " << r.describe());
            CHECK(r.p_value > gl_test::sidak(0.01, 9));
        }
}

TEST_CASE("Glossy BRDF: reciprocity, energy, Schlick limits", "[optics][microfacet]") {
    Rng rng = Rng::from_key(77);
    const Grey one(1.0);
    for (int k = 0; k < 200; ++k) {
        const double a = 0.05 + 0.9 * rng.uniform<double>();
        const Vec3d wo = dir(1.5 * rng.uniform<double>(), 6.28 * rng.uniform<double>());
        const Vec3d wi = dir(1.5 * rng.uniform<double>(), 6.28 * rng.uniform<double>());
        double p1 = 0, p2 = 0;
        const double f_oi = eval_glossy(wo, wi, one, a, p1)[0] / wi.z, f_io = eval_glossy(wi, wo, one, a, p2)[0] / wo.z;
        REQUIRE(f_oi == Approx(f_io).epsilon(1e-9));
    }
    // Energy: the sampler's mean weight equals the quadrature of f cos (F0 = 1: the single-scattering
    // albedo, <= 1; ~1 for a near-mirror at normal incidence).
    for (double a : {0.02, 0.3, 0.9})
        for (double th_o : {0.0, 0.8, 1.3}) {
            const Vec3d wo = dir(th_o, 0.0);
            Welford w;
            Rng r2 = Rng::from_key(78, std::uint64_t(a * 100), std::uint64_t(th_o * 10));
            for (int i = 0; i < 200000; ++i) {
                const auto s = sample_glossy(wo, one, a, r2.uniform2<double>());
                w.add(s.valid ? s.weight[0] : 0.0);
            }
            const double quad = hemisphere([&](const Vec3d& wi) {
                double p = 0;
                return eval_glossy(wo, wi, one, a, p)[0];
            }, a < 0.05 ? 3000 : 600, a < 0.05 ? 1200 : 600);
            INFO("alpha " << a << ", theta_o " << th_o << ": sampled " << w.mean() << " +- " << w.standard_error() << ", quadrature " << quad);
            CHECK(w.mean() <= 1.0 + 1e-12);
            CHECK(std::abs(w.mean() - quad) < 4 * w.standard_error() + 3e-3);
            if (a <= 0.02 && th_o == 0.0) CHECK(w.mean() > 0.995);
            if (a >= 0.9 && th_o >= 1.3) CHECK(w.mean() < 0.9);  // single-scattering microfacets lose energy
        }
    CHECK(fresnel_schlick(Grey(0.04), 1.0)[0] == Approx(0.04));
    CHECK(fresnel_schlick(Grey(0.04), 0.0)[0] == Approx(1.0));
}
