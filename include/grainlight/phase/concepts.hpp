/// @file grainlight/phase/concepts.hpp
/// The PhaseFunction concept and its result records.
///
/// ## Direction convention (the one place it is defined)
/// Both directions are *propagation* directions: `w_in` is the direction the light (or the
/// path) travels when it reaches the scattering point, `w_out` the direction it travels after
/// scattering. The scattering angle is theta with cos(theta) = dot(w_in, w_out); cos(theta) = +1
/// is forward scattering (no deflection), as in physics tables (Mie, scatterometer histograms).
/// This differs from pbrt/Mitsuba, which pass both vectors pointing away from the scattering
/// point (pitfalls.md). All phase functions here depend on cos(theta) only, hence are reciprocal:
/// a camera path may pass its own travel direction as `w_in`.
///
/// Phase values are per unit solid angle: integral over the sphere of eval(w_in, .).value = 1
/// (per channel). `sample(w_in, u)` draws w_out; u.x selects cos(theta) by inversion and u.x -> 1
/// goes to cos(theta) -> +1 (forward), u.x -> 0 backward; u.y selects the azimuth.
#pragma once

#include <concepts>

#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Result of PhaseFunction::eval: the per-channel phase value and the pdf (solid angle) with
/// which `sample` would produce the same w_out. For a grey phase function value == pdf.
template <std::floating_point F, class S>
struct PhaseEval {
    /// Phase value per unit solid angle in each channel [1/sr].
    S value;
    /// Solid-angle density [1/sr] with which sample() produces the same w_out (mixture pdf for chromatic tables).
    F pdf;
};

/// Result of PhaseFunction::sample: direction, weight = value / pdf (per channel), and pdf.
/// A pdf of 0 means "no sample" (never produced by the phase functions of this library).
template <std::floating_point F, class S>
struct PhaseSample {
    /// Sampled outgoing propagation direction (unit length).
    Vec3<F> w;
    /// Per-channel Monte Carlo weight value / pdf (1 in every channel for grey phase functions).
    S weight;
    /// Solid-angle density of w [1/sr]; 0 means no sample.
    F pdf;
    /// True if the sample is valid (pdf > 0).
    [[nodiscard]] explicit operator bool() const noexcept { return pdf > F(0); }
};

/// A phase function over spectrum type `Spectrum` (RGB, Spectrum<N>): see the file comment for
/// the direction convention. `mean_cosine()` is per channel (the asymmetry parameter g).
template <class P>
concept PhaseFunction = requires(const P& p, const Vec3<typename P::Float>& w, Vec2<typename P::Float> u) {
    typename P::Float;
    typename P::Spectrum;
    { p.eval(w, w) } -> std::same_as<PhaseEval<typename P::Float, typename P::Spectrum>>;
    { p.sample(w, u) } -> std::same_as<PhaseSample<typename P::Float, typename P::Spectrum>>;
    { p.mean_cosine() } -> std::same_as<typename P::Spectrum>;
};

/// Build w_out from w_in, the cosine of the scattering angle and the azimuth.
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> direction_from_cosine(const Vec3<F>& w_in, F cos_theta, F phi) noexcept;

}  // namespace grainlight

#include "grainlight/core/frame.hpp"

namespace grainlight {
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> direction_from_cosine(const Vec3<F>& w_in, F cos_theta, F phi) noexcept {
    return Frame<F>(w_in).to_world(spherical_direction(cos_theta, phi));
}
}  // namespace grainlight
