/// @file grainlight/core/quadrature.hpp
/// Gauss-Legendre quadrature rules, exact for polynomials of degree 2n - 1: the one source of
/// Gauss-Legendre nodes in the library. Nodes come from Newton's method on the three-term Legendre
/// recurrence carried out in long double and then rounded, so every node and weight is the double
/// nearest the true value (to within the last bit where long double itself rounds). Two forms of
/// the same computation:
/// - `gauss_legendre_nodes<N>`: a constexpr table on [-1, 1] (ascending), evaluated at compile time
///   for the fixed-order panels of the kernels (diffusion beam integrals, PSD moments, GOA);
/// - `gauss_legendre(n, a, b)`: any n at run time on any interval (H-function solver, Mie checks).
#pragma once

#include <array>
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

namespace detail {

/// cos(a) for a in [0, pi] by its Taylor series (constexpr; only the Newton start needs it).
[[nodiscard]] constexpr long double gl_cos(long double a) noexcept {
    long double term = 1, sum = 1;
    for (int k = 1; k < 40; ++k) {
        term *= -a * a / ((2 * k - 1) * (2 * k));
        sum += term;
    }
    return sum;
}

/// The i-th largest root z of P_n (i in [0, n/2)) and its weight on [-1, 1]: Tricomi's start
/// cos(pi (i + 3/4) / (n + 1/2)), then Newton on the recurrence in long double until the step
/// stops shrinking.
struct GlNode {
    long double z = 0, w = 0;
};
[[nodiscard]] constexpr GlNode gl_node(int n, int i) noexcept {
    constexpr long double pi = 3.14159265358979323846264338327950288L;
    long double z = gl_cos(pi * (i + 0.75L) / (n + 0.5L)), dp = 1, last = 1;
    for (int it = 0; it < 100; ++it) {
        long double p0 = 1, p1 = z;
        for (int k = 2; k <= n; ++k) {
            const long double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
            p0 = p1;
            p1 = p2;
        }
        dp = n * (z * p1 - p0) / (z * z - 1);
        const long double dz = p1 / dp;
        z -= dz;
        const long double adz = dz < 0 ? -dz : dz;
        if (adz == 0 || (it > 2 && adz >= last)) break;  // converged to long double round-off
        last = adz;
    }
    return {z, 2 / ((1 - z * z) * dp * dp)};
}

}  // namespace detail

/// The N-point Gauss-Legendre rule on [-1, 1]: nodes `x` ascending, weights `w`.
template <int N>
struct GaussLegendreNodes {
    static_assert(N >= 1 && N <= 64, "constexpr Gauss-Legendre tables are for N in [1, 64]; use gauss_legendre(n)");
    std::array<double, N> x{};  ///< nodes on [-1, 1], ascending
    std::array<double, N> w{};  ///< weights (sum 2)
};

namespace detail {
template <int N>
[[nodiscard]] constexpr GaussLegendreNodes<N> make_gauss_legendre_nodes() noexcept {
    GaussLegendreNodes<N> r;
    for (int i = 0; i < (N + 1) / 2; ++i) {
        const GlNode g = gl_node(N, i);
        r.x[std::size_t(i)] = double(-g.z);
        r.x[std::size_t(N - 1 - i)] = double(g.z);
        r.w[std::size_t(i)] = r.w[std::size_t(N - 1 - i)] = double(g.w);
    }
    if (N % 2 == 1) r.x[std::size_t(N / 2)] = 0.0;  // exact centre node
    return r;
}
}  // namespace detail

/// Compile-time N-point Gauss-Legendre table on [-1, 1] (see the file comment).
template <int N>
inline constexpr GaussLegendreNodes<N> gauss_legendre_nodes = detail::make_gauss_legendre_nodes<N>();

/// n-point Gauss-Legendre rule on [a, b] (default [-1, 1]); n in [1, 100000]. The nodes and
/// weights on [-1, 1] are those of gauss_legendre_nodes<n> (the same long-double computation).
[[nodiscard]] inline QuadratureRule gauss_legendre(int n, double a = -1.0, double b = 1.0) {
    check_argument(n >= 1 && n <= 100000, "gauss_legendre", "n", n, "[1, 100000]");
    check_argument(std::isfinite(a) && std::isfinite(b) && b > a, "gauss_legendre", "b - a", b - a, "> 0");
    QuadratureRule r;
    r.x.resize(std::size_t(n));
    r.w.resize(std::size_t(n));
    const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
    for (int i = 0; i < (n + 1) / 2; ++i) {
        const detail::GlNode g = detail::gl_node(n, i);
        const double z = (n % 2 == 1 && i == n / 2) ? 0.0 : double(g.z);
        const double wi = double(g.w) * half;
        r.x[std::size_t(i)] = mid - half * z;  // ascending
        r.w[std::size_t(i)] = wi;
        r.x[std::size_t(n - 1 - i)] = mid + half * z;
        r.w[std::size_t(n - 1 - i)] = wi;
    }
    return r;
}

}  // namespace grainlight
