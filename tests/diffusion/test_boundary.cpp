// Fresnel moments and boundary coefficients (diffusion/boundary.hpp) against:
//  - exact values at eta = 1 (no reflection: C1 = C2 = 0, A = 1, C_phi = 1/4, C_E = 1/2);
//  - a brute-force midpoint rule in mu with 2e6 points (a different quadrature of the same
//    integral; the critical-angle kink limits it to ~1e-7);
//  - the Egan & Hilgeman fit F_dr = -1.440/eta^2 + 0.710/eta + 0.668 + 0.0636 eta (as quoted by
//    Jensen et al. 2001), accurate to a few 1e-3 for 1 < eta < 1.6;
//  - grainlight::fresnel_diffuse_reflectance (optics/fresnel.hpp, 256-point midpoint in mu^2);
//  - the identity 2 A C_phi + C_E = 1 (energy conservation of the improved boundary condition).
#include <catch2/catch.hpp>

#include <cmath>

#include "grainlight/diffusion/boundary.hpp"

using namespace grainlight;

namespace {
double brute_moment(int i, double eta) {
    const int n = 2000000;
    double acc = 0;
    for (int k = 0; k < n; ++k) {
        const double mu = (k + 0.5) / n;
        acc += fresnel_dielectric(mu, 1.0 / eta) * std::pow(mu, i);
    }
    return acc / n;
}
}  // namespace

TEST_CASE("Fresnel moments are exactly zero at eta = 1", "[diffusion][boundary]") {
    CHECK(fresnel_moment(1, 1.0) == 0.0);
    CHECK(fresnel_moment(2, 1.0) == 0.0);
    CHECK(boundary_A(1.0) == 1.0);
    CHECK(boundary_A_classical(1.0) == 1.0);
    const auto w = exitance_weights(1.0);
    CHECK(w.C_phi == 0.25);
    CHECK(w.C_E == 0.5);
    CHECK(fresnel_moment(1, 1.0f) == 0.0f);
}

TEST_CASE("Fresnel moments match a brute-force quadrature", "[diffusion][boundary]") {
    for (double eta : {0.7, 0.9, 1.1, 1.33, 1.5, 2.5}) {
        for (int i : {0, 1, 2}) {
            INFO("eta = " << eta << ", i = " << i);
            CHECK(fresnel_moment(i, eta) == Approx(brute_moment(i, eta)).margin(2e-7));
        }
    }
    // C_0 above the critical angle: at eta = 1.5 the TIR part alone is mu_c = sqrt(1 - 1/eta^2).
    CHECK(fresnel_moment(0, 1.5) > std::sqrt(1 - 1 / 2.25));
}

TEST_CASE("F_dr matches the Egan-Hilgeman fit and the optics helper", "[diffusion][boundary]") {
    for (double eta : {1.1, 1.2, 1.3, 1.4, 1.5}) {
        INFO("eta = " << eta);
        const double fit = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
        CHECK(diffuse_fresnel_reflectance(eta) == Approx(fit).margin(3e-3));
        CHECK(diffuse_fresnel_reflectance(eta) == Approx(fresnel_diffuse_reflectance(eta)).margin(2e-3));
    }
}

TEST_CASE("Improved boundary condition conserves energy: 2 A C_phi + C_E = 1", "[diffusion][boundary]") {
    for (double eta : {0.6, 1.0, 1.2, 1.4, 2.0}) {
        const auto w = exitance_weights(eta);
        CHECK(2 * boundary_A(eta) * w.C_phi + w.C_E == Approx(1.0).epsilon(1e-12));
        CHECK(boundary_A(eta) >= 1.0);
        CHECK(boundary_A_classical(eta) >= 1.0);
    }
    // A grows with the index mismatch (more internal reflection).
    CHECK(boundary_A(1.5) > boundary_A(1.3));
    CHECK(boundary_A(1.3) > boundary_A(1.1));
}
