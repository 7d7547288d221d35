/// @file grainlight/core/math.hpp
/// Scalar helpers and constants used across the library.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <concepts>
#include <cstdint>

#include "grainlight/core/config.hpp"

namespace grainlight {

/// Pi in precision F.
template <std::floating_point F>
inline constexpr F pi_v = F(3.14159265358979323846264338327950288);
/// 1/pi in precision F.
template <std::floating_point F>
inline constexpr F inv_pi_v = F(0.318309886183790671537767526745028724);
/// 1/(2 pi) in precision F.
template <std::floating_point F>
inline constexpr F inv_two_pi_v = F(0.159154943091895335768883763372514362);
/// 1/(4 pi) in precision F (the isotropic phase function's value).
template <std::floating_point F>
inline constexpr F inv_four_pi_v = F(0.0795774715459476678844418816862571810);

/// x^2.
template <class T>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE constexpr T sqr(T x) noexcept {
    return x * x;
}

/// sqrt(max(x, 0)): guards against round-off making a non-negative quantity slightly negative.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline F safe_sqrt(F x) noexcept {
    return std::sqrt(std::max(x, F(0)));
}

/// acos clamped to [-1, 1].
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline F safe_acos(F x) noexcept {
    return std::acos(std::clamp(x, F(-1), F(1)));
}

/// sin(2 pi u) and cos(2 pi u) for u in [0, 1], without a library call: u is reduced exactly to
/// the nearest quarter turn k / 4 and theta = 2 pi (u - k / 4) in [-pi/4, pi/4], where the Taylor
/// series truncated after theta^15 (sin) and theta^16 (cos) is below 5e-17; the quadrant is
/// applied by swapping and negating. Within a few ulp of std::sin / std::cos (tests/core). Used
/// where a rotation is drawn per grain in a traversal (glibc's sincos was 6 % of a camera ray).
GRAINLIGHT_HOST_DEVICE inline void sincos_2pi(double u, double& s, double& c) noexcept {
    const int k = int(4.0 * u + 0.5);           // nearest quarter turn (u >= 0)
    const double r = 4.0 * u - double(k);       // exact (Sterbenz), in [-1/2, 1/2]
    const double t = r * (0.5 * pi_v<double>);  // theta in [-pi/4, pi/4]
    const double x = t * t, x2 = x * x, x4 = x2 * x2;
    // 1 / n! for the odd (sin) and even (cos) terms, evaluated by Estrin's scheme (short
    // dependency chains: two quadrants' worth of Horner steps would be latency-bound).
    const double sp = (1.0 + x * (-1.0 / 6)) + x2 * (1.0 / 120 + x * (-1.0 / 5040)) +
                      x4 * ((1.0 / 362880 + x * (-1.0 / 39916800)) + x2 * (1.0 / 6227020800.0 + x * (-1.0 / 1307674368000.0)));
    const double cp = (1.0 + x * (-0.5)) + x2 * (1.0 / 24 + x * (-1.0 / 720)) +
                      x4 * ((1.0 / 40320 + x * (-1.0 / 3628800)) + x2 * (1.0 / 479001600.0 + x * (-1.0 / 87178291200.0)) +
                            x4 * (1.0 / 20922789888000.0));
    const double st = t * sp;
    // Quadrant without a branch (k is random in a traversal): odd k swaps sin and cos; bit 1
    // of k negates the sine, bit 1 of k + 1 the cosine.
    const std::uint64_t swap = std::uint64_t(0) - std::uint64_t(k & 1);
    const std::uint64_t bs = std::bit_cast<std::uint64_t>(st), bc = std::bit_cast<std::uint64_t>(cp);
    const std::uint64_t sin_bits = ((bc & swap) | (bs & ~swap)) ^ (std::uint64_t(k & 2) << 62);
    const std::uint64_t cos_bits = ((bs & swap) | (bc & ~swap)) ^ (std::uint64_t((k + 1) & 2) << 62);
    s = std::bit_cast<double>(sin_bits);
    c = std::bit_cast<double>(cos_bits);
}

/// Linear interpolation (1 - t) a + t b; t = 0 gives a, t = 1 gives b (not clamped).
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE constexpr F lerp(F t, F a, F b) noexcept {
    return (F(1) - t) * a + t * b;
}

/// Largest index i in [0, size-2] with pred(i) true, for a monotone predicate (pbrt's
/// FindInterval contract: clamps to 0 and size-2). Branchless halving so that lookups in large
/// tables do not pay one branch misprediction per level.
template <class Pred>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline std::size_t find_interval(std::size_t size, Pred pred) noexcept {
    if (size < 2) return 0;
    std::size_t base = 0, len = size - 1;  // candidates [0, size-2]
    while (len > 1) {
        const std::size_t half = len >> 1;
        base = pred(base + half) ? base + half : base;
        len -= half;
    }
    return base;
}

}  // namespace grainlight
