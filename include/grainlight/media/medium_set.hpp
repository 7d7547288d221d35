/// @file grainlight/media/medium_set.hpp
/// A closed set of medium kinds, `MediumSet<Ms...>`, over std::variant: one scene can hold a
/// continuous medium in one shape, a teleportation medium in another and a discrete-particle or
/// shell medium in a third, with one scene type and one walk kernel (no virtual calls, no
/// allocation per sample). MediumSet models `Medium`: `sample_interaction` and `transmittance`
/// visit the active alternative once per free flight. It also offers `phase()`, a `PhaseSet`
/// proxy that models `PhaseFunction` by visiting the alternative's phase function, so that the
/// walk kernel and the VPT's next-event estimation treat phase-function media as before; an
/// alternative without a phase function (a medium that chooses its own directions) reports
/// `has_direction` on its events and its proxy returns "no sample" / pdf 0, which the kernels
/// never use for such events.
///
/// Every alternative must have the same Float and Spectrum. A scene of a MediumSet renders each
/// alternative exactly as a scene of that medium alone would (tested bit-for-bit).
///
/// Length units: each alternative keeps its own rule (see docs/architecture.md): continuous and
/// shell media take coefficients per scene unit; the teleportation medium takes its bounding
/// radius in scene units (its statistics are per bounding radius); the optics layer works in
/// micrometres and its bulk tables are converted to scene units by the caller.
#pragma once

#include <concepts>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <variant>

#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/phase/concepts.hpp"

namespace grainlight {

template <Medium... Ms>
class MediumSet;

namespace detail {
template <class M, class S>
concept HasAlbedo = requires(const M& m) {
    { m.albedo() } -> std::convertible_to<S>;
};
}  // namespace detail

/// The phase function of the active alternative of a MediumSet (non-owning; valid while the set
/// lives). Models PhaseFunction.
template <class F, class S, class... Ms>
class PhaseSet {
public:
    /// Floating-point type.
    using Float = F;
    /// Spectrum type.
    using Spectrum = S;

    /// View of the variant `media` (not owned; must outlive this object).
    explicit PhaseSet(const std::variant<Ms...>* media) noexcept : media_(media) {}

    /// Phase value and pdf of the active medium (0 if that medium has no phase function).
    [[nodiscard]] PhaseEval<F, S> eval(const Vec3<F>& w_in, const Vec3<F>& w_out) const noexcept {
        return std::visit(
            [&](const auto& m) -> PhaseEval<F, S> {
                if constexpr (PhaseMedium<std::decay_t<decltype(m)>>)
                    return m.phase().eval(w_in, w_out);
                else
                    return PhaseEval<F, S>{S(F(0)), F(0)};
            },
            *media_);
    }
    /// Direction sample of the active medium's phase function (pdf 0, i.e. no sample, if it has none).
    [[nodiscard]] PhaseSample<F, S> sample(const Vec3<F>& w_in, Vec2<F> u) const noexcept {
        return std::visit(
            [&](const auto& m) -> PhaseSample<F, S> {
                if constexpr (PhaseMedium<std::decay_t<decltype(m)>>)
                    return m.phase().sample(w_in, u);
                else
                    return PhaseSample<F, S>{w_in, S(F(0)), F(0)};
            },
            *media_);
    }
    /// Mean cosine of the active medium's phase function (0 if it has none).
    [[nodiscard]] S mean_cosine() const noexcept {
        return std::visit(
            [&](const auto& m) -> S {
                if constexpr (PhaseMedium<std::decay_t<decltype(m)>>)
                    return m.phase().mean_cosine();
                else
                    return S(F(0));
            },
            *media_);
    }

private:
    const std::variant<Ms...>* media_;
};

/// One medium out of a closed set of kinds. Construct from any alternative:
/// `MediumSet<CM, TM> m = CM(...);`.
template <Medium... Ms>
class MediumSet {
    static_assert(sizeof...(Ms) >= 1, "MediumSet needs at least one medium kind");
    using First = std::tuple_element_t<0, std::tuple<Ms...>>;

public:
    /// Floating-point type (shared by every alternative).
    using Float = typename First::Float;
    /// Spectrum type (shared by every alternative).
    using Spectrum = typename First::Spectrum;
    /// Short alias of Float.
    using F = Float;
    /// Short alias of Spectrum.
    using S = Spectrum;
    static_assert((std::same_as<typename Ms::Float, Float> && ...), "MediumSet: every medium needs the same Float");
    static_assert((std::same_as<typename Ms::Spectrum, Spectrum> && ...), "MediumSet: every medium needs the same Spectrum");

    /// Holds a copy of (or moves in) `m`, one of the alternatives Ms...
    template <class M>
        requires(std::same_as<std::decay_t<M>, Ms> || ...)
    MediumSet(M&& m) : media_(std::forward<M>(m)) {}  // NOLINT: implicit on purpose

    /// Copy.
    MediumSet(const MediumSet& o) : media_(o.media_) {}
    /// Move.
    MediumSet(MediumSet&& o) noexcept : media_(std::move(o.media_)) {}
    /// Copy assignment.
    MediumSet& operator=(const MediumSet& o) {
        media_ = o.media_;
        return *this;
    }
    /// Move assignment.
    MediumSet& operator=(MediumSet&& o) noexcept {
        media_ = std::move(o.media_);
        return *this;
    }

    /// Next event of the active medium along `ray` before `t_max` (static dispatch via std::visit, no virtual call).
    [[nodiscard]] Interaction<F, S> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        return std::visit([&](const auto& m) { return m.sample_interaction(ray, t_max, rng); }, media_);
    }
    /// Transmittance of the active medium along `ray` over [0, t_max].
    [[nodiscard]] S transmittance(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        return std::visit([&](const auto& m) { return m.transmittance(ray, t_max, rng); }, media_);
    }
    /// Single-scattering albedo of the active alternative (only when every kind has one).
    [[nodiscard]] S albedo() const noexcept
        requires(detail::HasAlbedo<Ms, S> && ...)
    {
        return std::visit([](const auto& m) -> S { return m.albedo(); }, media_);
    }
    /// The active alternative's phase function (see PhaseSet).
    [[nodiscard]] PhaseSet<F, S, Ms...> phase() const noexcept { return PhaseSet<F, S, Ms...>(&media_); }

    /// Index of the active kind in Ms...
    [[nodiscard]] std::size_t index() const noexcept { return media_.index(); }
    /// The active alternative if it is an M, else nullptr.
    template <class M>
    [[nodiscard]] const M* get_if() const noexcept {
        return std::get_if<M>(&media_);
    }
    /// Visit the active alternative.
    template <class Visitor>
    decltype(auto) visit(Visitor&& v) const {
        return std::visit(std::forward<Visitor>(v), media_);
    }
    /// Human-readable description: index of the active kind.
    [[nodiscard]] std::string to_string() const {
        return "MediumSet[kind " + std::to_string(media_.index()) + " of " + std::to_string(sizeof...(Ms)) + "]";
    }

private:
    std::variant<Ms...> media_;
};

}  // namespace grainlight
