// Tests of phase/mie.hpp: the PhaseFunction concept, chi-square of the sampler against its own
// pdf (shared helper tests/common/chi2.hpp), eval == pdf and normalization, the forward peak
// against exact Mie, mean cosine against the Mie series g.
#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <vector>

#include "common/chi2.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/mie_phase.hpp"
#include "grainlight/phase/concepts.hpp"
#include "grainlight/phase/mie.hpp"

using namespace grainlight;
using C = std::complex<double>;
using Grey = Spectrum<1, double>;

static_assert(PhaseFunction<MiePhase<double, Grey>>);
static_assert(PhaseFunction<MiePhase<float, RGB>>);

namespace {
constexpr double kPi = 3.14159265358979323846;

gl_test::Chi2Result chi2_of(const MiePhase<double, Grey>& p, double theta_scale) {
    const Vec3d w_in(0, 0, 1);
    // Bin coordinate s in [0,1] -> theta: quadratic warp concentrates bins near forward.
    auto theta_of = [&](double s) { return kPi * std::pow(s, theta_scale); };
    return gl_test::chi2_directions(
        [&](double u1, double u2, Vec3d& w) {
            const auto smp = p.sample(w_in, Vec2<double>(u1, u2));
            w = smp.w;
            return bool(smp);
        },
        [&](const Vec3d& w) { return p.eval(w_in, w).pdf; }, 200000, 40, 12, 7, theta_of);
}
}  // namespace

TEST_CASE("MiePhase: chi-square of the sampler, eval == pdf, normalization", "[optics][phase]") {
    const auto mie = MiePhase<double, Grey>::from_mie(C(1.33, 0), 20.0);
    const auto r = chi2_of(mie, 3.0);
    INFO(r.describe());
    CHECK(r.p_value > 1e-3);
    // GOA particle (r = 10 um, lambda = 0.6 um) through from_intensities.
    const double x = 2 * kPi * 10 / 0.6;
    const auto grid = forward_peaked_theta_grid(x);
    const Goa goa(C(1.33, 0), x);
    std::vector<Grey> v(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) {
        const auto s = goa.amplitudes_at_angle(grid[i]);
        v[i] = Grey(std::norm(s.S1) + std::norm(s.S2));
    }
    const auto gp = MiePhase<double, Grey>::from_intensities(grid, v);
    const auto r2 = chi2_of(gp, 4.0);
    INFO(r2.describe());
    CHECK(r2.p_value > 1e-3);
    // eval value == pdf (grey), integral over the sphere = 1.
    double integral = 0;
    bool value_is_pdf = true;
    const int n = 400000;
    for (int i = 0; i < n; ++i) {
        const double mu = -1 + (i + 0.5) * 2.0 / n;
        const Vec3d w(std::sqrt(1 - mu * mu), 0, mu);
        const auto e = mie.eval(Vec3d(0, 0, 1), w);
        value_is_pdf = value_is_pdf && e.value[0] == e.pdf;
        integral += 2 * kPi * e.pdf * 2.0 / n;
    }
    CHECK(value_is_pdf);
    CHECK(integral == Approx(1.0).epsilon(1e-4));
}

TEST_CASE("MiePhase: forward peak resolved, mean cosine = Mie g, sample direction convention", "[optics][phase]") {
    // x = 1000: the table's shape across the diffraction peak follows exact Mie.
    const double x = 1000;
    const LorenzMie mie(C(1.33, 0), x);
    const auto p = make_mie_phase<double, Grey>(C(1.33, 0), x);
    auto exact = [&](double th) {
        const auto s = mie.amplitudes(std::cos(th));
        return std::norm(s.S1) + std::norm(s.S2);
    };
    for (double th : {0.5 / x, 1.0 / x, 2.0 / x, 3.0 / x}) {
        INFO("theta = " << th);
        const double ratio_table = p.pdf_cos_theta(std::cos(th)) / p.pdf_cos_theta(1.0);
        CHECK(ratio_table == Approx(exact(th) / exact(0.0)).epsilon(0.01));
    }
    // Mean cosine of the table vs the Mie series g (x = 5 and 50: fringes resolved by 600 tail nodes).
    for (double xx : {5.0, 50.0}) {
        const auto q = LorenzMie(C(1.33, 0), xx).efficiencies();
        CHECK(make_mie_phase<double, Grey>(C(1.33, 0), xx).mean_cosine()[0] == Approx(q.g).margin(2e-3));
    }
    // Convention: u.x -> 1 samples forward (cos theta -> +1) around w_in.
    const Vec3d w_in(1, 0, 0);
    const auto s = p.sample(w_in, Vec2<double>(0.999999, 0.3));
    CHECK(glm::dot(s.w, w_in) > 0.999);
    const std::vector<double> bad_grid = {0.0, 1.0};  // does not end at pi
    const std::vector<Grey> bad_values(2, Grey(1.0));
    CHECK_THROWS_AS((MiePhase<double, Grey>::from_intensities(bad_grid, bad_values)), invalid_argument);
}
