/// @file grainlight/core/spectrum.hpp
/// Fixed-size spectra: `Spectrum<N, F>` holds N channel values (RGB is N = 3). Arithmetic is
/// component-wise. Which wavelengths the channels stand for is the caller's business (Guo21 uses
/// 8 samples, converted to RGB through CIE matching; see optics/).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <ostream>

#include "grainlight/core/config.hpp"

namespace grainlight {

template <std::size_t N, std::floating_point F = float>
struct Spectrum {
    static_assert(N >= 1, "Spectrum needs at least one channel");
    static constexpr std::size_t size = N;
    using value_type = F;
    std::array<F, N> c{};

    constexpr Spectrum() noexcept = default;
    /// Every channel = v.
    constexpr explicit Spectrum(F v) noexcept { c.fill(v); }
    /// One value per channel, exactly N of them: RGB{0.1f, 0.2f, 0.3f}. (No initializer-list
    /// constructor: `S{x}` must mean "every channel = x", never "(x, 0, 0)".)
    template <class... Ts>
        requires(sizeof...(Ts) == N && N > 1 && (std::convertible_to<Ts, F> && ...))
    constexpr Spectrum(Ts... values) noexcept : c{static_cast<F>(values)...} {}

    [[nodiscard]] constexpr F& operator[](std::size_t i) noexcept { return c[i]; }
    [[nodiscard]] constexpr F operator[](std::size_t i) const noexcept { return c[i]; }

#define GRAINLIGHT_SPECTRUM_OP(op)                                                  \
    constexpr Spectrum& operator op##=(const Spectrum& o) noexcept {                \
        for (std::size_t i = 0; i < N; ++i) c[i] op## = o.c[i];                     \
        return *this;                                                               \
    }                                                                               \
    constexpr Spectrum& operator op##=(F s) noexcept {                              \
        for (std::size_t i = 0; i < N; ++i) c[i] op## = s;                          \
        return *this;                                                               \
    }                                                                               \
    friend constexpr Spectrum operator op(Spectrum a, const Spectrum& b) noexcept { \
        return a op## = b;                                                          \
    }                                                                               \
    friend constexpr Spectrum operator op(Spectrum a, F s) noexcept { return a op## = s; }
    GRAINLIGHT_SPECTRUM_OP(+)
    GRAINLIGHT_SPECTRUM_OP(-)
    GRAINLIGHT_SPECTRUM_OP(*)
    GRAINLIGHT_SPECTRUM_OP(/)
#undef GRAINLIGHT_SPECTRUM_OP
    friend constexpr Spectrum operator*(F s, Spectrum a) noexcept { return a *= s; }
    friend constexpr Spectrum operator-(Spectrum a) noexcept {
        for (auto& v : a.c) v = -v;
        return a;
    }
    friend constexpr bool operator==(const Spectrum&, const Spectrum&) = default;

    [[nodiscard]] constexpr F max_value() const noexcept { return *std::max_element(c.begin(), c.end()); }
    [[nodiscard]] constexpr F min_value() const noexcept { return *std::min_element(c.begin(), c.end()); }
    [[nodiscard]] constexpr F average() const noexcept {
        F s = 0;
        for (F v : c) s += v;
        return s / F(N);
    }
    [[nodiscard]] constexpr bool is_black() const noexcept {
        for (F v : c)
            if (v != F(0)) return false;
        return true;
    }
    [[nodiscard]] bool is_finite() const noexcept {
        for (F v : c)
            if (!std::isfinite(v)) return false;
        return true;
    }
    friend std::ostream& operator<<(std::ostream& os, const Spectrum& s) {
        os << "[";
        for (std::size_t i = 0; i < N; ++i) os << (i ? ", " : "") << s.c[i];
        return os << "]";
    }
};

/// Three-channel linear-sRGB spectrum (Rec. 709 primaries, D65 white).
using RGB = Spectrum<3, float>;
using RGBd = Spectrum<3, double>;

template <std::size_t N, class F>
[[nodiscard]] inline Spectrum<N, F> exp(const Spectrum<N, F>& s) noexcept {
    Spectrum<N, F> r;
    for (std::size_t i = 0; i < N; ++i) r.c[i] = std::exp(s.c[i]);
    return r;
}
template <std::size_t N, class F>
[[nodiscard]] inline Spectrum<N, F> sqrt(const Spectrum<N, F>& s) noexcept {
    Spectrum<N, F> r;
    for (std::size_t i = 0; i < N; ++i) r.c[i] = std::sqrt(s.c[i]);
    return r;
}

/// Type trait: is T a grainlight::Spectrum?
template <class T>
struct is_spectrum : std::false_type {};
template <std::size_t N, class F>
struct is_spectrum<Spectrum<N, F>> : std::true_type {};
template <class T>
concept SpectrumType = is_spectrum<T>::value;

/// Luminance of a linear-sRGB value (Rec. 709 weights).
template <class F>
[[nodiscard]] inline F luminance(const Spectrum<3, F>& s) noexcept {
    return F(0.2126) * s[0] + F(0.7152) * s[1] + F(0.0722) * s[2];
}

}  // namespace grainlight
