// grainlight::IsotropicHFunction against published values.
#include <catch2/catch.hpp>

#include <cmath>

#include "grainlight/diffusion/h_function.hpp"

TEST_CASE("H-function reproduces the tabulated half-space values", "[diffusion][hfunction]") {
    // Source: tests/data/halfspace_albedo.md (Chandrasekhar, Radiative Transfer 1960 ch. V; values
    // from a 400-point Gauss-Legendre fixed point converged to 1e-12): a, H(1), R(1), R(0.5).
    const double rows[2][4] = {{0.5, 1.251260, 0.115226, 0.160144}, {0.8, 1.598220, 0.285255, 0.367970}};
    for (const auto& r : rows) {
        INFO("a = " << r[0]);
        const grainlight::IsotropicHFunction h(r[0]);
        CHECK(h(1.0) == Approx(r[1]).margin(2e-6));
        CHECK(h.reflectance(1.0) == Approx(r[2]).margin(2e-6));
        CHECK(h.reflectance(0.5) == Approx(r[3]).margin(2e-6));
        // Zeroth moment identity alpha_0 = (2/a)(1 - sqrt(1 - a)) (Chandrasekhar 1960, ch. V).
        CHECK(h.moment0() == Approx(2 / r[0] * (1 - std::sqrt(1 - r[0]))).epsilon(1e-9));
    }
    // No scattering: H = 1, nothing reflected.
    CHECK(grainlight::IsotropicHFunction(0.0).reflectance(1.0) == Approx(0.0).margin(1e-15));
    CHECK_THROWS_AS(grainlight::IsotropicHFunction(1.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(grainlight::IsotropicHFunction(-0.1), grainlight::invalid_argument);
}
