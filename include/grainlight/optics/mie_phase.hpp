/// @file grainlight/optics/mie_phase.hpp
/// The exact Lorenz-Mie phase function of one sphere as a grainlight::MiePhase: the optics layer
/// computes |S1|^2 + |S2|^2 (optics/lorenz_mie.hpp) and the phase layer tabulates and samples it
/// (phase/mie.hpp). Lives in optics/ because the phase layer includes nothing from optics/.
#pragma once

#include <cmath>
#include <complex>
#include <concepts>
#include <span>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/phase/mie.hpp"

namespace grainlight {

/// Exact Lorenz-Mie phase function of one sphere (relative index m = n + i k, k >= 0 absorbing;
/// size parameter x = 2 pi r n_medium / lambda > 0), every channel equal, tabulated on `theta`
/// (default forward_peaked_theta_grid(x)). Throws grainlight::invalid_argument for a bad m or x.
template <std::floating_point F = float, class S = Spectrum<1, F>>
[[nodiscard]] MiePhase<F, S> make_mie_phase(std::complex<double> m, double x, std::span<const double> theta = {}) {
    const LorenzMie mie(m, x);
    // Every angle of the grid in one vectorized call (the span overload), as from_amplitudes would
    // evaluate them one at a time.
    const std::vector<double> grid = theta.empty() ? forward_peaked_theta_grid(x) : std::vector<double>(theta.begin(), theta.end());
    std::vector<double> mu(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) mu[i] = i == 0 ? 1.0 : (i + 1 == grid.size() ? -1.0 : std::cos(grid[i]));
    std::vector<ScatteringAmplitudes> amp(grid.size());
    mie.amplitudes(mu, amp);
    std::vector<S> v(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) v[i] = S(F(std::norm(amp[i].S1) + std::norm(amp[i].S2)));
    return MiePhase<F, S>::from_intensities(grid, v);
}

}  // namespace grainlight
