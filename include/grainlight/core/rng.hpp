/// @file grainlight/core/rng.hpp
/// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
/// Algorithms for Random Number Generation") with counter-based seeding: a generator is a pure
/// function of (seed, pixel/path index, sample index), so an image or estimate does not depend on
/// the thread count or on the order work is scheduled in.
///
/// Streams that differ only in the increment are correlated, so the key is hashed into both the
/// state and the stream selector (toolchain.md).
#pragma once

#include <concepts>
#include <cstdint>

#include "grainlight/core/config.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// 64-bit finalizer (SplitMix64 / Stafford variant 13): a bijective avalanche mix.
[[nodiscard]] GRAINLIGHT_HOST_DEVICE constexpr std::uint64_t mix64(std::uint64_t z) noexcept {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/// Hash any number of 64-bit words into one.
template <class... Ts>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE constexpr std::uint64_t hash_words(std::uint64_t first, Ts... rest) noexcept {
    std::uint64_t h = mix64(first);
    ((h = mix64(h ^ static_cast<std::uint64_t>(rest))), ...);
    return h;
}

/// PCG32 random number generator (O'Neill 2014, XSH-RR output, 64-bit state): small, fast and
/// splittable by stream. One instance per path or per thread; not thread-safe when shared.
/// Use from_key(seed, pixel, sample) for results independent of the thread count.
class Pcg32 {
public:
    /// Default initial state (the PCG reference value).
    static constexpr std::uint64_t default_state = 0x853c49e6748fea9bull;
    /// Default stream increment (the PCG reference value).
    static constexpr std::uint64_t default_stream = 0xda3e39cb94b95bdbull;
    /// 64-bit LCG multiplier of the state update.
    static constexpr std::uint64_t multiplier = 0x5851f42d4c957f2dull;

    /// Generator with the reference default state and stream.
    constexpr Pcg32() noexcept : state_(default_state), inc_(default_stream) {}
    /// Generator seeded with `init_state` on stream `stream` (see seed()).
    constexpr Pcg32(std::uint64_t init_state, std::uint64_t stream) noexcept { seed(init_state, stream); }

    /// Counter-based construction: the generator for (seed, a, b), e.g. (seed, pixel, sample) or
    /// (seed, path index, 0). Different keys give statistically independent streams.
    [[nodiscard]] static constexpr Pcg32 from_key(std::uint64_t seed, std::uint64_t a = 0, std::uint64_t b = 0) noexcept {
        const std::uint64_t h = hash_words(seed, a, b);
        return Pcg32(mix64(h ^ 0x6a09e667f3bcc909ull), h);
    }

    /// Re-seed: `init_state` sets the starting point, `stream` selects one of 2^63 independent sequences.
    constexpr void seed(std::uint64_t init_state, std::uint64_t stream) noexcept {
        state_ = 0u;
        inc_ = (stream << 1u) | 1u;
        next_u32();
        state_ += init_state;
        next_u32();
    }

    /// Uniform 32-bit integer.
    GRAINLIGHT_HOST_DEVICE constexpr std::uint32_t next_u32() noexcept {
        const std::uint64_t old = state_;
        state_ = old * multiplier + inc_;
        const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
        const auto rot = static_cast<std::uint32_t>(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
    }
    /// Uniform integer in [0, bound) without modulo bias.
    GRAINLIGHT_HOST_DEVICE constexpr std::uint32_t next_u32(std::uint32_t bound) noexcept {
        const std::uint32_t threshold = (~bound + 1u) % bound;
        for (;;) {
            const std::uint32_t r = next_u32();
            if (r >= threshold) return r % bound;
        }
    }
    /// Uniform 64-bit integer (two consecutive 32-bit outputs, high word first).
    GRAINLIGHT_HOST_DEVICE constexpr std::uint64_t next_u64() noexcept {
        return (std::uint64_t(next_u32()) << 32) | next_u32();
    }
    /// Uniform float in [0, 1) with 24 random bits.
    GRAINLIGHT_HOST_DEVICE constexpr float next_float() noexcept {
        return float(next_u32() >> 8) * 0x1p-24f;
    }
    /// Uniform double in [0, 1) with 53 random bits.
    GRAINLIGHT_HOST_DEVICE constexpr double next_double() noexcept {
        return double(next_u64() >> 11) * 0x1p-53;
    }
    /// Uniform in [0, 1) of type F (24 bits for float, 53 for double).
    template <std::floating_point F>
    GRAINLIGHT_HOST_DEVICE constexpr F uniform() noexcept {
        if constexpr (sizeof(F) <= 4)
            return next_float();
        else
            return F(next_double());
    }
    /// Two consecutive uniform [0, 1) values of type F (x drawn first), for 2D warps.
    template <std::floating_point F>
    GRAINLIGHT_HOST_DEVICE Vec2<F> uniform2() noexcept {
        const F a = uniform<F>();
        const F b = uniform<F>();
        return Vec2<F>(a, b);
    }
    /// Three consecutive uniform [0, 1) values of type F (x, then y, then z), e.g. a uniform point
    /// of a box. Use this (or uniform2) instead of `Vec3(rng.uniform<F>(), ...)`: the order in which
    /// a function's arguments are evaluated is unspecified, so such an expression draws the numbers
    /// in a compiler-dependent order (right to left under g++, left to right under clang).
    template <std::floating_point F>
    GRAINLIGHT_HOST_DEVICE Vec3<F> uniform3() noexcept {
        const F a = uniform<F>();
        const F b = uniform<F>();
        const F c = uniform<F>();
        return Vec3<F>(a, b, c);
    }
    /// Skip ahead by delta steps (Brown 1994, arbitrary-stride LCG jump).
    constexpr void advance(std::int64_t delta_) noexcept {
        std::uint64_t cur_mult = multiplier, cur_plus = inc_, acc_mult = 1u, acc_plus = 0u;
        auto delta = static_cast<std::uint64_t>(delta_);
        while (delta > 0) {
            if (delta & 1) {
                acc_mult *= cur_mult;
                acc_plus = acc_plus * cur_mult + cur_plus;
            }
            cur_plus = (cur_mult + 1) * cur_plus;
            cur_mult *= cur_mult;
            delta /= 2;
        }
        state_ = acc_mult * state_ + acc_plus;
    }

private:
    std::uint64_t state_{};
    std::uint64_t inc_{};
};

/// The generator every kernel takes by reference (`Rng&`).
using Rng = Pcg32;

/// Anything with `uniform<F>()` can drive grainlight's samplers.
template <class R, class F>
concept UniformRandomSource = requires(R& r) {
    { r.template uniform<F>() } -> std::convertible_to<F>;
};

}  // namespace grainlight
