/// @file grainlight/phase/isotropic.hpp
/// Isotropic phase function, 1/(4 pi). Direction convention: phase/concepts.hpp.
#pragma once

#include <string>

#include "grainlight/core/math.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/phase/concepts.hpp"

namespace grainlight {

/// Isotropic phase function 1/(4 pi) in every channel: a PhaseFunction (phase/concepts.hpp),
/// stateless and thread-safe.
template <std::floating_point F = float, class S = Spectrum<1, F>>
class IsotropicPhase {
public:
    /// Floating-point type of directions and pdfs.
    using Float = F;
    /// Spectrum type of values and weights.
    using Spectrum = S;

    /// Value and pdf 1/(4 pi) for any pair of directions.
    [[nodiscard]] PhaseEval<F, S> eval(const Vec3<F>&, const Vec3<F>&) const noexcept {
        return {S(inv_four_pi_v<F>), inv_four_pi_v<F>};
    }
    /// u.x -> 1 gives cos(theta) -> +1 (forward).
    [[nodiscard]] PhaseSample<F, S> sample(const Vec3<F>& w_in, Vec2<F> u) const noexcept {
        const F cos_theta = F(2) * u.x - F(1);
        const Vec3<F> w = direction_from_cosine(w_in, cos_theta, F(2) * pi_v<F> * u.y);
        return {w, S(F(1)), inv_four_pi_v<F>};
    }
    /// Density of cos(theta) on [-1, 1] (= 1/2).
    [[nodiscard]] F pdf_cos_theta(F) const noexcept { return F(0.5); }
    /// Mean cosine 0 in every channel.
    [[nodiscard]] S mean_cosine() const noexcept { return S(F(0)); }
    /// Human-readable description, "IsotropicPhase[]".
    [[nodiscard]] std::string to_string() const { return "IsotropicPhase[]"; }
};

}  // namespace grainlight
