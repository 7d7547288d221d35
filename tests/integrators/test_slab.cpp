// Slab reflectance/transmittance from the library's walk kernel (scene/slab.hpp, the same code the
// `slab` example runs) against independent values:
//  - Chandrasekhar's H-function for the isotropic semi-infinite index-matched half-space,
//    R(mu0) = 1 - H(mu0) sqrt(1 - a) (Chandrasekhar, Radiative Transfer, 1960, ch. V), with H
//    solved here by fixed-point iteration on Gauss-Legendre nodes, and the tabulated values of
//    tests/data/halfspace_albedo.md;
//  - Prahl's adding-doubling values (Prahl, van Gemert & Welch, Appl. Opt. 32(4), 1993; `ad`
//    program, 32 quadrature points) for index-matched and n = 1.4 slabs
//    (tests/data/halfspace_albedo.md);
//  - closed forms: a purely absorbing slab with Fresnel multiple reflections; R + T = 1 for a
//    conservative slab;
//  - an independent plane-parallel Monte Carlo written in this file (own RNG, own Fresnel, own
//    HG sampling, depth/cosine state only) for refractive slabs n = 1.33 and 1.5 that have no
//    published value at hand.
// Tolerance (halfspace_albedo.md): 3 standard errors + 0.002.
#include <catch2/catch.hpp>

#include "common/data_dir.hpp"

#include "grainlight/diffusion/h_function.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <limits>
#include <random>
#include <vector>

#include "grainlight/integrators/slab.hpp"

using namespace grainlight;

namespace {

constexpr double inf = std::numeric_limits<double>::infinity();

struct Estimate {
    double R, T, R_se, T_se;
};

// The library estimator, parallel over fixed blocks merged in order (as examples/slab.cpp).
Estimate run_library(double a, double B, double g, double n, double mu0, std::uint64_t paths, std::uint64_t seed) {
    SlabParams p;
    p.albedo = a;
    p.optical_depth = B;
    p.g = g;
    p.ior = n;
    p.mu0 = mu0;
    const SlabProblem problem(p);
    const std::uint64_t block = 8192, n_blocks = (paths + block - 1) / block;
    std::vector<SlabTally> tallies(n_blocks);
#pragma omp parallel for schedule(dynamic, 1)
    for (long long b = 0; b < (long long)n_blocks; ++b) {
        const std::uint64_t first = std::uint64_t(b) * block;
        tallies[std::size_t(b)] = problem.run(first, std::min(block, paths - first), seed);
    }
    SlabTally t;
    for (const auto& x : tallies) t.merge(x);
    return {t.R.mean(), t.T.mean(), t.R.standard_error(), t.T.standard_error()};
}

// ---- independent plane-parallel Monte Carlo (shares no code with the library) -----------------
// Unpolarized Fresnel reflectance from index n_i into n_t at incidence cosine c_i (Born & Wolf).
double fresnel_toy(double n_i, double n_t, double c_i) {
    const double s_t = n_i / n_t * std::sqrt(std::max(0.0, 1 - c_i * c_i));
    if (s_t >= 1) return 1.0;
    const double c_t = std::sqrt(1 - s_t * s_t);
    const double rs = (n_i * c_i - n_t * c_t) / (n_i * c_i + n_t * c_t);
    const double rp = (n_t * c_i - n_i * c_t) / (n_t * c_i + n_i * c_t);
    return 0.5 * (rs * rs + rp * rp);
}

Estimate run_toy(double a, double B, double g, double n, double mu0, std::uint64_t paths, std::uint64_t seed) {
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    double sr = 0, sr2 = 0, st = 0, st2 = 0;
    const double R0 = fresnel_toy(1.0, n, mu0);
    const double mu_t = std::sqrt(1 - (1 - mu0 * mu0) / (n * n));
    for (std::uint64_t i = 0; i < paths; ++i) {
        double r = 0, t = 0;
        if (U(gen) < R0) {
            r = 1;
        } else {
            double x = 0, mu = mu_t;  // optical depth below the top face; mu > 0 = going down
            for (;;) {
                x += -std::log(1 - U(gen)) * mu;
                if (x < 0) {  // reaches the top face from inside
                    if (U(gen) < fresnel_toy(n, 1.0, -mu)) {
                        x = 0;
                        mu = -mu;
                        continue;
                    }
                    r = 1;
                    break;
                }
                if (x > B) {
                    if (U(gen) < fresnel_toy(n, 1.0, mu)) {
                        x = B;
                        mu = -mu;
                        continue;
                    }
                    t = 1;
                    break;
                }
                if (U(gen) >= a) break;  // absorbed
                double c;
                if (std::abs(g) < 1e-6) {
                    c = 2 * U(gen) - 1;
                } else {
                    const double s = (1 - g * g) / (1 - g + 2 * g * U(gen));
                    c = (1 + g * g - s * s) / (2 * g);
                }
                c = std::clamp(c, -1.0, 1.0);
                const double phi = 2 * M_PI * U(gen);
                mu = mu * c + std::sqrt(std::max(0.0, 1 - mu * mu)) * std::sqrt(std::max(0.0, 1 - c * c)) * std::cos(phi);
                mu = std::clamp(mu, -1.0, 1.0);
            }
        }
        sr += r;
        sr2 += r * r;
        st += t;
        st2 += t * t;
    }
    const double N = double(paths);
    auto se = [N](double s, double s2) { return std::sqrt(std::max(0.0, (s2 - s * s / N) / (N - 1)) / N); };
    return {sr / N, st / N, se(sr, sr2), se(st, st2)};
}

void check_against(const Estimate& e, double R_ref, double T_ref) {
    INFO("R = " << e.R << " +- " << e.R_se << " (reference " << R_ref << ")");
    INFO("T = " << e.T << " +- " << e.T_se << " (reference " << T_ref << ")");
    CHECK(std::abs(e.R - R_ref) <= 3 * e.R_se + 0.002);
    CHECK(std::abs(e.T - T_ref) <= 3 * e.T_se + 0.002);
}

void check_agree(const Estimate& e, const Estimate& f) {
    INFO("library R = " << e.R << " +- " << e.R_se << ", T = " << e.T << " +- " << e.T_se);
    INFO("toy     R = " << f.R << " +- " << f.R_se << ", T = " << f.T << " +- " << f.T_se);
    CHECK(std::abs(e.R - f.R) <= 3 * std::hypot(e.R_se, f.R_se) + 0.002);
    CHECK(std::abs(e.T - f.T) <= 3 * std::hypot(e.T_se, f.T_se) + 0.002);
}

// Rows of the first markdown table after the heading that starts with `heading` in
// tests/data/halfspace_albedo.md ("semi-infinite" reads as inf). The reference values live in
// that file only (with their sources), so the test and the documented table cannot drift apart.
std::vector<std::vector<double>> reference_table(const std::string& heading) {
    std::ifstream f(grainlight_test::data_dir() + "/halfspace_albedo.md");
    REQUIRE(f.good());
    std::vector<std::vector<double>> rows;
    std::string line;
    bool in_section = false, in_table = false;
    while (std::getline(f, line)) {
        if (line.rfind("## ", 0) == 0) {
            if (in_section) break;
            in_section = line.rfind("## " + heading, 0) == 0;
            continue;
        }
        if (!in_section) continue;
        if (line.rfind("|", 0) != 0) {
            if (in_table) break;
            continue;
        }
        in_table = true;
        std::vector<double> row;
        std::stringstream ss(line.substr(1));
        std::string cell;
        bool numeric = true;
        while (std::getline(ss, cell, '|')) {
            const auto b = cell.find_first_not_of(' '), e = cell.find_last_not_of(' ');
            if (b == std::string::npos) continue;
            cell = cell.substr(b, e - b + 1);
            if (cell == "semi-infinite") {
                row.push_back(inf);
                continue;
            }
            char* end = nullptr;
            const double v = std::strtod(cell.c_str(), &end);
            if (end == cell.c_str() || *end != '\0') {
                numeric = false;
                break;
            }
            row.push_back(v);
        }
        if (numeric && !row.empty()) rows.push_back(row);
    }
    return rows;
}

constexpr std::uint64_t kPaths = 400000;

}  // namespace

TEST_CASE("H-function solver reproduces the tabulated H(1) and R(mu0)", "[slab][hfunction]") {
    // tests/data/halfspace_albedo.md: a, H(1), R(mu0 = 1), R(mu0 = 0.5) (Chandrasekhar 1960 ch. V;
    // 400-point Gauss-Legendre fixed point). Our solver: 200 nodes.
    const auto table = reference_table("Semi-infinite");
    REQUIRE(table.size() == 2);
    for (const auto& r : table) {
        REQUIRE(r.size() == 4);
        const IsotropicHFunction h(r[0], 200);
        INFO("a = " << r[0]);
        CHECK(h(1.0) == Approx(r[1]).margin(2e-6));
        CHECK(h.reflectance(1.0) == Approx(r[2]).margin(2e-6));
        CHECK(h.reflectance(0.5) == Approx(r[3]).margin(2e-6));
        // Zeroth moment (Chandrasekhar 1960, ch. V): alpha_0 = int_0^1 H dmu = (2/a)(1 - sqrt(1 - a)).
        CHECK(h.moment0() == Approx(2 / h.albedo() * (1 - std::sqrt(1 - h.albedo()))).epsilon(1e-9));
    }
}

TEST_CASE("Semi-infinite isotropic half-space matches Chandrasekhar's H-function", "[slab][hfunction]") {
    // The tabulated values (tests/data/halfspace_albedo.md) ...
    std::uint64_t seed = 10;
    for (const auto& r : reference_table("Semi-infinite")) {
        INFO("table: a = " << r[0]);
        check_against(run_library(r[0], inf, 0.0, 1.0, 1.0, kPaths, seed++), r[2], 0.0);
        check_against(run_library(r[0], inf, 0.0, 1.0, 0.5, kPaths, seed++), r[3], 0.0);
    }
    // ... and a higher albedo from our own H-function solution.
    for (const double mu0 : {1.0, 0.5}) {
        const IsotropicHFunction h(0.95, 200);
        INFO("a = 0.95, mu0 = " << mu0);
        check_against(run_library(0.95, inf, 0.0, 1.0, mu0, kPaths, seed++), h.reflectance(mu0), 0.0);
    }
}

TEST_CASE("Index-matched finite slabs match Prahl's adding-doubling values", "[slab][adding-doubling]") {
    // tests/data/halfspace_albedo.md "Finite slab" table: g, a, b, mu0, R, T.
    const auto table = reference_table("Finite slab");
    REQUIRE(table.size() == 5);
    std::uint64_t seed = 100;
    for (const auto& r : table) {
        REQUIRE(r.size() == 6);
        INFO("g = " << r[0] << ", a = " << r[1] << ", b = " << r[2] << ", mu0 = " << r[3]);
        check_against(run_library(r[1], r[2], r[0], 1.0, r[3], kPaths, seed++), r[4], r[5]);
    }
}

TEST_CASE("Refractive slabs (n = 1.4) match Prahl's adding-doubling values", "[slab][adding-doubling][fresnel]") {
    // tests/data/halfspace_albedo.md "Slab of relative index 1.4" table: g, a, b, R, T (mu0 = 1).
    const auto table = reference_table("Slab of relative index 1.4");
    REQUIRE(table.size() == 3);
    std::uint64_t seed = 200;
    for (const auto& r : table) {
        REQUIRE(r.size() == 5);
        INFO("g = " << r[0] << ", a = " << r[1] << ", b = " << r[2]);
        check_against(run_library(r[1], r[2], r[0], 1.4, 1.0, kPaths, seed++), r[3], r[4]);
    }
}

TEST_CASE("Absorbing-only slabs match the closed form with Fresnel multiple reflections", "[slab][fresnel]") {
    // a = 0: R = R1 + (1-R1)^2 R1 e^{-2 tau} / (1 - R1^2 e^{-2 tau}),
    //        T = (1-R1)^2 e^{-tau} / (1 - R1^2 e^{-2 tau}),  tau = B / mu_t (refracted cosine),
    // R1 = Fresnel(mu0) = the internal reflectance at mu_t (Stokes relations).
    for (double n : {1.0, 1.33, 1.5}) {
        for (double mu0 : {1.0, 0.5}) {
            for (double B : {1.0, 4.0, inf}) {
                const double R1 = fresnel_toy(1.0, n, mu0);
                const double mu_t = std::sqrt(1 - (1 - mu0 * mu0) / (n * n));
                const double e1 = std::isinf(B) ? 0.0 : std::exp(-B / mu_t);
                const double den = 1 - R1 * R1 * e1 * e1;
                const double R = R1 + (1 - R1) * (1 - R1) * R1 * e1 * e1 / den;
                const double T = (1 - R1) * (1 - R1) * e1 / den;
                INFO("n = " << n << ", mu0 = " << mu0 << ", B = " << B);
                check_against(run_library(0.0, B, 0.0, n, mu0, 100000, 300), R, T);
            }
        }
    }
}

TEST_CASE("Conservative slabs conserve energy: R + T = 1", "[slab][conservation]") {
    for (double n : {1.0, 1.33, 1.5}) {
        const Estimate e = run_library(1.0, 4.0, 0.9, n, 0.5, 50000, 400);
        INFO("n = " << n << ": R = " << e.R << ", T = " << e.T);
        CHECK(e.R + e.T == Approx(1.0).margin(1e-12));
        CHECK(e.R > 0.01);
        CHECK(e.T > 0.01);
    }
}

TEST_CASE("Refractive slabs n = 1.33 and 1.5 agree with an independent plane-parallel Monte Carlo",
          "[slab][fresnel][independent]") {
    struct Case {
        double a, B, g, n, mu0;
    };
    const Case cases[] = {
        {0.9, 1.0, 0.0, 1.33, 1.0},  {0.9, 4.0, 0.5, 1.33, 0.5}, {0.95, inf, 0.0, 1.33, 1.0},
        {0.9, 1.0, 0.9, 1.5, 0.5},   {0.95, 4.0, 0.7, 1.5, 1.0}, {0.9, inf, 0.5, 1.5, 0.5},
        {0.99, 4.0, 0.9, 1.0, 0.5},  // index-matched, strongly forward, oblique
        {0.9, 2.0, 0.5, 0.75, 0.8},  // slab of lower index than outside (a bubble layer)
        {0.95, inf, 0.7, 1.0, 0.5},  // index-matched forward-scattering half-space, oblique
    };
    int k = 0;
    for (const Case& c : cases) {
        INFO("a = " << c.a << ", B = " << c.B << ", g = " << c.g << ", n = " << c.n << ", mu0 = " << c.mu0);
        const Estimate lib = run_library(c.a, c.B, c.g, c.n, c.mu0, 200000, 500 + k);
        const Estimate toy = run_toy(c.a, c.B, c.g, c.n, c.mu0, 200000, 900 + k);
        ++k;
        check_agree(lib, toy);
    }
}

TEST_CASE("Slab estimates do not depend on how paths are split into batches", "[slab][determinism]") {
    SlabParams p;
    p.albedo = 0.9;
    p.optical_depth = 2.0;
    p.ior = 1.5;
    p.g = 0.5;
    const SlabProblem problem(p);
    const SlabTally whole = problem.run(0, 5000, 42);
    SlabTally parts = problem.run(0, 1234, 42);
    parts.merge(problem.run(1234, 5000 - 1234, 42));
    CHECK(whole.R.mean() == Approx(parts.R.mean()).epsilon(1e-12));
    CHECK(whole.T.mean() == Approx(parts.T.mean()).epsilon(1e-12));
}

TEST_CASE("Bad slab parameters throw invalid_argument naming the parameter", "[slab][errors]") {
    auto message_of = [](SlabParams p) -> std::string {
        try {
            SlabProblem sp(p);
        } catch (const grainlight::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    SlabParams p;
    p.albedo = 1.5;
    CHECK(message_of(p).find("albedo") != std::string::npos);
    p = {};
    p.g = 1.0;
    CHECK(message_of(p).find("g = 1") != std::string::npos);
    p = {};
    p.mu0 = 0.0;
    CHECK(message_of(p).find("mu0") != std::string::npos);
    p = {};
    p.optical_depth = -1;
    CHECK(message_of(p).find("optical_depth") != std::string::npos);
    p = {};
    p.ior = 0.0;
    CHECK(message_of(p).find("ior") != std::string::npos);
    p.ior = 12.0;
    CHECK(message_of(p).find("ior") != std::string::npos);
    p = {};
    p.optical_depth = std::nan("");
    CHECK(message_of(p).find("optical_depth") != std::string::npos);
}
