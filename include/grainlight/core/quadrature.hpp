/// @file grainlight/core/quadrature.hpp
/// Gauss-Legendre quadrature rules (nodes by Newton iteration on the Legendre recurrence,
/// converged to double precision): exact for polynomials of degree 2n - 1. Used by the
/// H-function solver, Mie integral checks, diffusion moments and table integrals.
#pragma once

#include <cmath>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"

namespace grainlight {

/// An n-point rule on an interval: nodes `x` (ascending) and weights `w`.
struct QuadratureRule {
    /// @var x
    /// Nodes on the rule's interval, ascending.
    /// @var w
    /// Weights, one per node.
    std::vector<double> x, w;
    /// sum_i w_i f(x_i).
    template <class Fn>
    [[nodiscard]] double integrate(Fn&& f) const {
        double acc = 0;
        for (std::size_t i = 0; i < x.size(); ++i) acc += w[i] * f(x[i]);
        return acc;
    }
};

/// n-point Gauss-Legendre rule on [a, b] (default [-1, 1]); n in [1, 100000].
[[nodiscard]] inline QuadratureRule gauss_legendre(int n, double a = -1.0, double b = 1.0) {
    check_argument(n >= 1 && n <= 100000, "gauss_legendre", "n", n, "[1, 100000]");
    check_argument(std::isfinite(a) && std::isfinite(b) && b > a, "gauss_legendre", "b - a", b - a, "> 0");
    QuadratureRule r;
    r.x.resize(std::size_t(n));
    r.w.resize(std::size_t(n));
    const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
    for (int i = 0; i < (n + 1) / 2; ++i) {
        // Initial guess (Tricomi), then Newton on P_n.
        double z = std::cos(pi_v<double> * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1, p1 = z;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1);
            const double dz = p1 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-16) break;
        }
        const double wi = 2 / ((1 - z * z) * dp * dp) * half;
        r.x[std::size_t(i)] = mid - half * z;  // ascending
        r.w[std::size_t(i)] = wi;
        r.x[std::size_t(n - 1 - i)] = mid + half * z;
        r.w[std::size_t(n - 1 - i)] = wi;
    }
    return r;
}

}  // namespace grainlight
