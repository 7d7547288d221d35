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
#include <cstdint>
#include <initializer_list>
#include <span>
#include <ostream>

#include "grainlight/core/config.hpp"

namespace grainlight {

/// N-channel spectrum of precision F with component-wise arithmetic (a plain value type: an array
/// of N values, trivially copyable; safe to pass to kernels and copy between threads).
template <std::size_t N, std::floating_point F = float>
struct Spectrum {
    static_assert(N >= 1, "Spectrum needs at least one channel");
    /// Number of channels N.
    static constexpr std::size_t size = N;
    /// Channel value type F.
    using value_type = F;
    /// Channel values.
    std::array<F, N> c{};

    /// All channels 0.
    constexpr Spectrum() noexcept = default;
    /// Every channel = v.
    constexpr explicit Spectrum(F v) noexcept { c.fill(v); }
    /// One value per channel, exactly N of them: RGB{0.1f, 0.2f, 0.3f}. (No initializer-list
    /// constructor: `S{x}` must mean "every channel = x", never "(x, 0, 0)".)
    template <class... Ts>
        requires(sizeof...(Ts) == N && N > 1 && (std::convertible_to<Ts, F> && ...))
    constexpr Spectrum(Ts... values) noexcept : c{static_cast<F>(values)...} {}

    /// Channel i (i < N), writable.
    [[nodiscard]] constexpr F& operator[](std::size_t i) noexcept { return c[i]; }
    /// Channel i (i < N).
    [[nodiscard]] constexpr F operator[](std::size_t i) const noexcept { return c[i]; }

/// Defines the four component-wise operators of one arithmetic operator (undefined after use).
#define GRAINLIGHT_SPECTRUM_OP(op)                                                  \
    /** Component-wise compound assignment with another spectrum, channel by channel. */ \
    constexpr Spectrum& operator op##=(const Spectrum& o) noexcept {                \
        for (std::size_t i = 0; i < N; ++i) c[i] op## = o.c[i];                     \
        return *this;                                                               \
    }                                                                               \
    /** Compound assignment with scalar s applied to every channel. */ \
    constexpr Spectrum& operator op##=(F s) noexcept {                              \
        for (std::size_t i = 0; i < N; ++i) c[i] op## = s;                          \
        return *this;                                                               \
    }                                                                               \
    /** Component-wise result of two spectra. */ \
    friend constexpr Spectrum operator op(Spectrum a, const Spectrum& b) noexcept { \
        return a op## = b;                                                          \
    }                                                                               \
    /** Spectrum combined with scalar s in every channel. */ \
    friend constexpr Spectrum operator op(Spectrum a, F s) noexcept { return a op## = s; }
    GRAINLIGHT_SPECTRUM_OP(+)
    GRAINLIGHT_SPECTRUM_OP(-)
    GRAINLIGHT_SPECTRUM_OP(*)
    GRAINLIGHT_SPECTRUM_OP(/)
#undef GRAINLIGHT_SPECTRUM_OP
    /// Scalar times spectrum, component-wise.
    friend constexpr Spectrum operator*(F s, Spectrum a) noexcept { return a *= s; }
    /// Negation of every channel.
    friend constexpr Spectrum operator-(Spectrum a) noexcept {
        for (auto& v : a.c) v = -v;
        return a;
    }
    /// Exact equality of every channel.
    friend constexpr bool operator==(const Spectrum&, const Spectrum&) = default;

    /// Largest channel value.
    [[nodiscard]] constexpr F max_value() const noexcept { return *std::max_element(c.begin(), c.end()); }
    /// Smallest channel value.
    [[nodiscard]] constexpr F min_value() const noexcept { return *std::min_element(c.begin(), c.end()); }
    /// Arithmetic mean of the channels.
    [[nodiscard]] constexpr F average() const noexcept {
        F s = 0;
        for (F v : c) s += v;
        return s / F(N);
    }
    /// True if every channel is exactly 0 (lets a path stop without tracing).
    [[nodiscard]] constexpr bool is_black() const noexcept {
        for (F v : c)
            if (v != F(0)) return false;
        return true;
    }
    /// True if no channel is NaN or infinite.
    [[nodiscard]] bool is_finite() const noexcept {
        for (F v : c)
            if (!std::isfinite(v)) return false;
        return true;
    }
    /// Prints `[c0, c1, ...]`.
    friend std::ostream& operator<<(std::ostream& os, const Spectrum& s) {
        os << "[";
        for (std::size_t i = 0; i < N; ++i) os << (i ? ", " : "") << s.c[i];
        return os << "]";
    }
};

/// Three-channel linear-sRGB spectrum (Rec. 709 primaries, D65 white).
using RGB = Spectrum<3, float>;
/// Three-channel linear-sRGB spectrum in double precision.
using RGBd = Spectrum<3, double>;

/// Component-wise exponential (e.g. transmittance exp(-sigma_t * t) per channel).
template <std::size_t N, class F>
[[nodiscard]] inline Spectrum<N, F> exp(const Spectrum<N, F>& s) noexcept {
    Spectrum<N, F> r;
    for (std::size_t i = 0; i < N; ++i) r.c[i] = std::exp(s.c[i]);
    return r;
}
/// Component-wise square root (negative channels give NaN).
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

/// Per-channel values of a material (albedo, absorption, ...) whose channel count is chosen by the
/// data, not by the renderer's Spectrum type: one value (grey: the same in every channel of any
/// spectrum), three (RGB) or any count up to `max_channels` (e.g. Guo21's 8 wavelength samples).
/// A renderer with `Spectrum<N>` may use values with 1 or N channels, or any grey values
/// (`compatible_with(N)`); anything else is a mismatch that the render entry points reject with an
/// error instead of folding channels (channel c of an 8-channel render never reads RGB's blue).
class ChannelValues {
public:
    /// Largest number of channels a ChannelValues can hold.
    static constexpr std::size_t max_channels = 16;

    /// Grey 0.
    constexpr ChannelValues() noexcept = default;
    /// Grey: every channel = v.
    constexpr ChannelValues(double v) noexcept : n_(1) { v_[0] = v; }  // NOLINT: implicit on purpose
    /// One value per channel of a Spectrum (RGBd{...} stays valid wherever an RGB value was taken).
    template <std::size_t N, class F>
        requires(N <= max_channels)
    constexpr ChannelValues(const Spectrum<N, F>& s) noexcept : n_(std::uint8_t(N)) {  // NOLINT: implicit on purpose
        for (std::size_t i = 0; i < N; ++i) v_[i] = double(s[i]);
    }
    /// Explicit values, 1..max_channels of them (more are ignored: see size()).
    ChannelValues(std::initializer_list<double> values) noexcept : ChannelValues(std::span<const double>(values.begin(), values.size())) {}
    /// Values from a span: 1..max_channels of them (an empty span gives grey 0; extra values are ignored).
    explicit ChannelValues(std::span<const double> values) noexcept
        : n_(std::uint8_t(std::clamp<std::size_t>(values.size(), 1, max_channels))) {
        for (std::size_t i = 0; i < n_ && i < values.size(); ++i) v_[i] = values[i];
    }

    /// Number of stored channels (1 = grey).
    [[nodiscard]] constexpr std::size_t size() const noexcept { return n_; }
    /// Value in channel c: the grey value for a 1-channel set, else channel c (c < size()).
    [[nodiscard]] constexpr double operator[](std::size_t c) const noexcept {
        const std::size_t last = std::size_t(std::max<std::uint8_t>(n_, 1)) - 1;
        return v_[std::min(c, last)];
    }
    /// Same as operator[]: the grey value for a 1-channel set, else channel c.
    [[nodiscard]] constexpr double at(std::size_t c) const noexcept { return (*this)[c]; }
    /// Every stored channel equal.
    [[nodiscard]] constexpr bool is_grey() const noexcept {
        for (std::size_t i = 1; i < n_; ++i)
            if (v_[i] != v_[0]) return false;
        return true;
    }
    /// Usable by a renderer with `channels` spectrum channels: 1 stored value, exactly `channels`,
    /// or grey.
    [[nodiscard]] constexpr bool compatible_with(std::size_t channels) const noexcept {
        return n_ == 1 || n_ == channels || is_grey();
    }
    /// Arithmetic mean of the stored channels.
    [[nodiscard]] constexpr double mean() const noexcept {
        double s = 0;
        for (std::size_t i = 0; i < n_; ++i) s += v_[i];
        return s / double(n_);
    }
    /// Largest stored channel value.
    [[nodiscard]] constexpr double max_value() const noexcept {
        double m = v_[0];
        for (std::size_t i = 1; i < n_; ++i) m = std::max(m, v_[i]);
        return m;
    }
    /// As a Spectrum<N, F> (requires compatible_with(N); otherwise the last stored channel repeats).
    template <class S>
        requires SpectrumType<S>
    [[nodiscard]] constexpr S to_spectrum() const noexcept {
        S r;
        for (std::size_t i = 0; i < S::size; ++i) r[i] = typename S::value_type((*this)[i]);
        return r;
    }
    /// Equal channel count and exactly equal values (grey 0.5 and RGB (0.5, 0.5, 0.5) differ).
    friend constexpr bool operator==(const ChannelValues& a, const ChannelValues& b) noexcept {
        if (a.n_ != b.n_) return false;
        for (std::size_t i = 0; i < a.n_; ++i)
            if (a.v_[i] != b.v_[i]) return false;
        return true;
    }
    /// Prints `[v0, v1, ...]` with the stored channels.
    friend std::ostream& operator<<(std::ostream& os, const ChannelValues& s) {
        os << "[";
        for (std::size_t i = 0; i < s.n_; ++i) os << (i ? ", " : "") << s.v_[i];
        return os << "]";
    }

private:
    std::array<double, max_channels> v_{};
    std::uint8_t n_ = 1;
};

/// Luminance of a linear-sRGB value (Rec. 709 weights).
template <class F>
[[nodiscard]] inline F luminance(const Spectrum<3, F>& s) noexcept {
    return F(0.2126) * s[0] + F(0.7152) * s[1] + F(0.0722) * s[2];
}

}  // namespace grainlight
