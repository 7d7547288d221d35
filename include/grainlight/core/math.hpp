/// @file grainlight/core/math.hpp
/// Scalar helpers and constants used across the library.
#pragma once

#include <algorithm>
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
