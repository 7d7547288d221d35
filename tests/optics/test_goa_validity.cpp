// GOA's validity range (optics/goa.hpp goa_validity) and its use by the automatic method
// (optics/particle.hpp): the automatic method stays within 15 % of exact Lorenz-Mie's Qext and
// positive for every index of issue 15 at r = 2-200 um, 0.55 um (the defect: GOA returned Qext =
// -2.0 at m = 1.0001); GOA called outside its range computes but is flagged, and refuses only
// where its Qext or Qsca would be negative. Reference: exact Mie (optics/lorenz_mie.hpp, itself
// checked against Wiscombe's MIEV0 tables in test_lorenz_mie.cpp).
#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <string>
#include <vector>

#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/particle.hpp"

using namespace grainlight;
using C = std::complex<double>;

namespace {
constexpr double kPi = 3.14159265358979323846;

// Issue 15's indices, plus the issue's metal-like case and organic particles in water.
std::vector<C> issue_indices() {
    return {C(1.0001, 0), C(1.05, 0),  C(1.33, 0),  C(1.33, 1e-8), C(1.5, 0.1),  C(2.5, 1),   C(4, 0.01),
            C(10, 10),    C(0.75, 0),  C(1.2, 2),   C(1.01, 0),    C(1.02, 0),   C(1.1, 0)};
}
}  // namespace

TEST_CASE("GOA validity criterion: x >= 45 (100 for k > 2) and 2 x |m - 1| >= 6", "[optics][goa][validity]") {
    CHECK(goa_valid_min_size_parameter(C(1.33, 0)) == Approx(45.0));
    CHECK(goa_valid_min_size_parameter(C(1.2, 2)) == Approx(45.0));     // k = 2 is not > 2
    CHECK(goa_valid_min_size_parameter(C(10, 10)) == Approx(100.0));
    CHECK(goa_valid_min_size_parameter(C(1.05, 0)) == Approx(60.0));    // 6 / (2 * 0.05)
    CHECK(goa_valid_min_size_parameter(C(1.0001, 0)) == Approx(30000.0));
    CHECK(goa_valid_min_size_parameter(C(1.0001, 0.01)) == Approx(6 / (2 * std::abs(C(0.0001, 0.01)))));
    CHECK(std::isinf(goa_valid_min_size_parameter(C(1.0, 0))));
    const auto below = goa_validity(C(1.05, 0), 59.9), above = goa_validity(C(1.05, 0), 60.1);
    CHECK_FALSE(below.valid);
    CHECK(above.valid);
    CHECK(above.phase_shift == Approx(2 * 60.1 * 0.05));
    CHECK(above.size_parameter == 60.1);
    CHECK_FALSE(goa_validity(C(1.33, 0), 44.9).valid);
    CHECK(goa_validity(C(1.33, 0), 45.0).valid);
}

TEST_CASE("Automatic method: within 15 % of Mie's Qext and positive, issue list, r = 2-200 um at 0.55 um",
          "[optics][goa][validity]") {
    const double lambda = 0.55;
    for (const C m : issue_indices()) {
        ParticleModel model;
        model.particle_index = m;
        int n_goa = 0, n = 0;
        double worst = 0, worst_r = 0;
        // 1201 radii, log-spaced (step 0.38 %): >= 10 points per ripple period lambda / (2 |n - 1|)
        // of Qext(r) at r = 2 um for every index here (0.09 um for n = 4).
        const int nr = 1200;
        for (int i = 0; i <= nr; ++i) {
            const double r = 2.0 * std::pow(100.0, double(i) / nr);
            const double x = 2 * kPi * r / lambda;
            const double mie = LorenzMie(m, x).efficiencies().qext;
            double q = 0;
            if (model.method_at(r, lambda) == ScatteringMethod::goa) {
                ++n_goa;
                const auto e = goa_efficiencies(Goa(m, x, model.p_max));
                REQUIRE(e.validity.valid);
                q = e.qext;
            } else {
                q = mie;
            }
            ++n;
            INFO("m = " << m << ", r = " << r << " um, x = " << x << ", auto Qext " << q << ", Mie " << mie);
            REQUIRE(std::isfinite(q));
            REQUIRE(q > 0);
            const double err = std::abs(q - mie) / mie;
            if (err > worst) {
                worst = err;
                worst_r = r;
            }
            CHECK(err <= 0.15);
        }
        INFO("m = " << m << ": worst " << worst << " at r = " << worst_r << " um; GOA used at " << n_goa << "/" << n);
        CHECK(worst <= 0.15);
        // The criterion is not degenerate: GOA is used wherever it is valid in this range.
        if (m == C(1.0001, 0)) {
            CHECK(n_goa == 0);  // valid only from x = 30000 (r ~ 2.6 mm)
        } else {
            CHECK(n_goa > nr / 3);  // m = 1.01: GOA from x = 300 (r = 26 um) on
        }
    }
}

TEST_CASE("Automatic method through SingleParticle: the issue's failing cases now use Mie", "[optics][goa][validity]") {
    const double lambda = 0.55;
    struct Case {
        C m;
        double r;
    };
    // Issue 15: GOA gave -2.0 (1.0001, 2-200 um), -1.9 (1.01, 2 um), 0.61 (1.05, 2 um), 2.0 vs Mie 2.36
    // (1.2 + 2i, 2 um).
    for (const Case c : {Case{C(1.0001, 0), 2.0}, Case{C(1.0001, 0), 200.0}, Case{C(1.01, 0), 2.0},
                         Case{C(1.05, 0), 2.0}, Case{C(1.2, 2), 2.0}}) {
        ParticleModel model;
        model.particle_index = c.m;
        const SingleParticle p(c.r, lambda, model);
        INFO("m = " << c.m << ", r = " << c.r);
        CHECK(p.method() == ScatteringMethod::mie);
        CHECK_FALSE(p.goa_validity().valid);
        const double mie = LorenzMie(c.m, p.size_parameter()).efficiencies().qext;
        CHECK(p.cross_sections().C_t / (kPi * c.r * c.r) == Approx(mie).epsilon(1e-12));
    }
    // Where GOA is valid the automatic method still uses it (Guo21's speed-up is kept).
    ParticleModel water;
    water.particle_index = C(1.33, 0);
    const SingleParticle big(20.0, lambda, water);
    CHECK(big.method() == ScatteringMethod::goa);
    CHECK(big.goa_validity().valid);
    // goa_from_radius_um: the first radius at which automatic switches to GOA.
    for (const C m : {C(1.33, 0), C(1.05, 0), C(10, 10)}) {
        ParticleModel model;
        model.particle_index = m;
        const double r0 = model.goa_from_radius_um(lambda);
        INFO("m = " << m << ", r0 = " << r0);
        CHECK(model.method_at(r0 * (1 + 1e-9), lambda) == ScatteringMethod::goa);
        CHECK(model.method_at(r0 * (1 - 1e-9), lambda) == ScatteringMethod::mie);
    }
    // Guo21's switch radius is still a floor, and the r-only rule is unchanged.
    water.switch_radius_um = 50.0;
    CHECK(water.method_at(20.0, lambda) == ScatteringMethod::mie);
    CHECK(water.goa_from_radius_um(lambda) == 50.0);
    water.switch_radius_um = 2.0;
    CHECK(water.method_at(2.0) == ScatteringMethod::goa);
}

TEST_CASE("GOA outside its range: computes and flags, refuses only negative results", "[optics][goa][validity]") {
    const double x = 2 * kPi * 2.0 / 0.55;  // r = 2 um at 0.55 um
    // m = 1.05: invalid (2 x |m - 1| = 2.3) but positive: computed, flagged (issue: 0.61 vs Mie 2.03).
    const auto e105 = goa_efficiencies(Goa(C(1.05, 0), x));
    CHECK_FALSE(e105.validity.valid);
    CHECK(e105.validity.phase_shift == Approx(2 * x * 0.05));
    CHECK(e105.qext == Approx(0.6116).epsilon(1e-3));
    CHECK(e105.qsca == Approx(e105.qext));
    // Metal-like 1.2 + 2i: computed (2.0) and flagged (x < 45); Mie is 2.36.
    const auto em = goa_efficiencies(Goa(C(1.2, 2), x));
    CHECK_FALSE(em.validity.valid);
    CHECK(em.qext == Approx(2.0).epsilon(1e-3));
    CHECK(em.qabs > 0);
    CHECK(em.qsca >= 0);
    CHECK(std::abs(em.qext - LorenzMie(C(1.2, 2), x).efficiencies().qext) > 0.3);
    // Nearly index-matched: Qext = -2.0 is refused, with a message naming x and the phase shift.
    for (const C m : {C(1.0001, 0), C(1.01, 0)}) {
        INFO("m = " << m);
        CHECK_THROWS_AS(goa_efficiencies(Goa(m, x)), invalid_argument);
        try {
            (void)goa_efficiencies(Goa(m, x));
        } catch (const invalid_argument& err) {
            const std::string what = err.what();
            CHECK(what.find("goa_efficiencies: Qext = -") != std::string::npos);
            CHECK(what.find("rho = 2 x |m - 1|") != std::string::npos);
            CHECK(what.find("use Lorenz-Mie") != std::string::npos);
        }
        // The bare Eq. 12 is still available (Guo21 Fig. 3 plots it where it fails).
        CHECK(Goa(m, x).qext() < 0);
    }
    // Forced GOA in SingleParticle: refused where negative, flagged where merely invalid.
    ParticleModel model;
    model.method = ScatteringMethod::goa;
    model.particle_index = C(1.0001, 0);
    CHECK_THROWS_AS(SingleParticle(2.0, 0.55, model), invalid_argument);
    model.particle_index = C(1.05, 0);
    const SingleParticle p(2.0, 0.55, model);
    CHECK(p.method() == ScatteringMethod::goa);
    CHECK_FALSE(p.goa_validity().valid);
    CHECK(p.cross_sections().C_t / (kPi * 4.0) == Approx(e105.qext).epsilon(1e-12));
    // Valid GOA: flagged valid, and its numbers are those of Goa.
    const auto ok = goa_efficiencies(Goa(C(1.33, 0), 200.0));
    CHECK(ok.validity.valid);
    CHECK(ok.qext == Goa(C(1.33, 0), 200.0).qext());
}
