/// @file grainlight/media/concepts.hpp
/// The Medium concept and the Interaction record shared by all media (continuous RTE,
/// teleportation, shells, discrete particles).
///
/// `sample_interaction(ray, t_max, rng)` advances a path through the medium along `ray` up to
/// distance `t_max` (the next boundary) and reports what happened:
///   - `scatter`: the integrator should continue from `p` with a new direction. If the medium
///     chose the direction itself (`has_direction`: teleportation, shells), use `w` (its pdf is
///     `direction_pdf`, weight already in `weight`); otherwise sample the medium's phase function
///     (`medium.phase()`), and NEE uses `phase().eval` (`nee == NeeKind::phase`).
///   - `absorb`: the path ends.
///   - `null`: a pass-through/null event: continue from `p` in the same direction (delta tracking,
///     Meng15's pass-through of a bounding sphere).
///   - `escape`: no event before t_max; the path reaches the boundary at ray(t_max).
/// `weight` multiplies the path throughput in every case (spectral free-flight sampling and
/// survival probabilities go there; a grey analog medium always gives weight 1).
#pragma once

#include <algorithm>
#include <concepts>
#include <cstdint>

#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"

namespace grainlight {

/// @enum EventKind
/// What happened at the end of a free flight (see the file comment for the integrator's response).
/// @var EventKind::scatter
/// Real scattering event at p: continue with a new direction.
/// @var EventKind::absorb
/// The path ends.
/// @var EventKind::null
/// Pass-through (null) event: continue from p in the same direction.
/// @var EventKind::escape
/// No event before t_max: the path reaches the boundary at ray(t_max).
enum class EventKind : std::uint8_t { scatter, absorb, null, escape };

/// How next-event estimation works at an event.
enum class NeeKind : std::uint8_t {
    phase,  ///< connect with the medium's phase function (phase().eval)
    none,   ///< no shadow connection possible (e.g. teleportation's recorded exit directions)
    custom  ///< the medium provides its own (Moon07's p_r and f_a(d))
};

/// Result of Medium::sample_interaction: the event kind, where it happened, an optional
/// medium-chosen direction, and the throughput weight (see the file comment). A plain value.
template <std::floating_point F, class S>
struct Interaction {
    /// Event kind (escape by default).
    EventKind kind = EventKind::escape;
    F t = F(0);                ///< distance travelled along the ray
    Vec3<F> p{F(0)};           ///< position of the event (may differ from ray(t): teleports)
    Vec3<F> w{F(0)};           ///< new direction if `has_direction`
    F direction_pdf = F(0);    ///< pdf of `w` (solid angle) if `has_direction`
    S weight = S(F(1));        ///< throughput multiplier
    /// True if the medium chose the new direction `w` itself (teleportation, shells); false: sample phase().
    bool has_direction = false;
    /// How next-event estimation connects at this event.
    NeeKind nee = NeeKind::phase;

    /// True for a scattering event.
    [[nodiscard]] bool is_scatter() const noexcept { return kind == EventKind::scatter; }
    /// True if no event happened before t_max.
    [[nodiscard]] bool is_escape() const noexcept { return kind == EventKind::escape; }
    /// True if the path was absorbed.
    [[nodiscard]] bool is_absorb() const noexcept { return kind == EventKind::absorb; }
};

/// Ends a collision whose scattering weight per channel is `w_scatter` (sigma_s T / pdf, the
/// albedo in a grey medium): scatter with probability q = min(1, largest channel of w_scatter),
/// weight w_scatter / q, NEE by the phase function; else absorb (weight 0). Every channel then
/// carries w_c / q <= 1 per event (media/continuous.hpp says why the largest channel, not the mean).
template <std::floating_point F, class S>
inline void resolve_collision(Interaction<F, S>& it, const S& w_scatter, Rng& rng) noexcept {
    const F q = std::min(F(1), w_scatter.max_value());
    if (q > F(0) && rng.uniform<F>() < q) {
        it.kind = EventKind::scatter;
        it.weight = w_scatter / q;
        it.nee = NeeKind::phase;
    } else {
        it.kind = EventKind::absorb;
        it.weight = S(F(0));
    }
}

/// A participating medium usable by the walk kernel.
template <class M>
concept Medium = requires(const M& m, const Ray<typename M::Float>& r, typename M::Float t, Rng& rng) {
    typename M::Float;
    typename M::Spectrum;
    { m.sample_interaction(r, t, rng) } -> std::same_as<Interaction<typename M::Float, typename M::Spectrum>>;
    { m.transmittance(r, t, rng) } -> std::same_as<typename M::Spectrum>;
};

/// A medium whose scattering events are handled by sampling a phase function.
template <class M>
concept PhaseMedium = Medium<M> && requires(const M& m) { m.phase(); };

}  // namespace grainlight
