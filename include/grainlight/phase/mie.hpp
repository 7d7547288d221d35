/// @file grainlight/phase/mie.hpp
/// Phase functions of spherical particles from their amplitudes S1, S2 (Guo21 Eqs. 1 and 17):
/// p(theta) proportional to |S1|^2 + |S2|^2, tabulated on a non-uniform grid that is dense near
/// cos(theta) = 1 so the forward diffraction peak (width ~ 1/x rad) is resolved, and sampled
/// exactly from that table (grainlight::TabulatedPhase: linear in cos(theta), exact inversion).
///
/// The table is the phase function: eval and sample agree exactly with it (chi-square tested),
/// and the mean cosine is that of the table. How close the table is to the continuous
/// |S1|^2 + |S2|^2 depends on the grid: `forward_peaked_theta_grid(x_max)` resolves the
/// diffraction peak of size parameters up to x_max with >= 30 nodes; single-particle fringes
/// beyond it (period ~ pi/x) are resolved only for x below ~ n_tail/2 and are sampled (not
/// averaged) above; ensemble tables (optics/bulk.hpp) are smooth and need no more.
///
/// Direction convention: phase/concepts.hpp (propagation directions, cos theta = +1 forward).
/// Sources of the intensities: any tabulated |S1|^2 + |S2|^2 via `from_intensities` (GOA,
/// particle.hpp; ensembles, bulk.hpp), or exact Lorenz-Mie through `optics/mie_phase.hpp`
/// (`make_mie_phase`). This header includes nothing from optics/ (layer order: phase < optics);
/// the deprecated `MiePhase::from_mie` is a template that needs optics/lorenz_mie.hpp included
/// where it is called.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/phase/tabulated.hpp"

namespace grainlight {

class LorenzMie;  // optics/lorenz_mie.hpp (only MiePhase::from_mie uses it)

/// Scattering angles theta in [0, pi] (ascending, theta_0 = 0, last = pi): n_peak nodes spaced
/// geometrically from 0.05/x_max to 0.2 rad (the diffraction peak of any x <= x_max gets >= 30
/// nodes within its first minimum 3.83/x), then n_tail uniform nodes up to pi.
[[nodiscard]] inline std::vector<double> forward_peaked_theta_grid(double x_max, std::size_t n_peak = 400,
                                                                   std::size_t n_tail = 600) {
    check_argument(std::isfinite(x_max) && x_max > 0, "forward_peaked_theta_grid", "x_max", x_max, "> 0 (finite)");
    check_argument(n_peak >= 2, "forward_peaked_theta_grid", "n_peak", n_peak, ">= 2");
    check_argument(n_tail >= 2, "forward_peaked_theta_grid", "n_tail", n_tail, ">= 2");
    const double pi = pi_v<double>;
    const double t_switch = 0.2;
    const double t_first = std::min(0.05 / x_max, 0.5 * t_switch);
    std::vector<double> theta;
    theta.reserve(n_peak + n_tail + 1);
    theta.push_back(0.0);
    const double ratio = std::pow(t_switch / t_first, 1.0 / double(n_peak - 1));
    double t = t_first;
    for (std::size_t i = 0; i + 1 < n_peak; ++i, t *= ratio) theta.push_back(t);
    for (std::size_t i = 0; i < n_tail; ++i) theta.push_back(t_switch + (pi - t_switch) * double(i) / double(n_tail - 1));
    theta.back() = pi;
    return theta;
}

/// Phase function of a particle or an ensemble tabulated from |S1|^2 + |S2|^2: a PhaseFunction
/// (phase/concepts.hpp) with one table per spectral channel (e.g. Guo21's 8 wavelengths).
template <std::floating_point F = float, class S = Spectrum<1, F>>
class MiePhase {
public:
    /// Floating-point type of directions and pdfs.
    using Float = F;
    /// Spectrum type of values and weights.
    using Spectrum = S;

    MiePhase() = default;

    /// theta: ascending angles from 0 to pi [rad]; intensity[i][c] >= 0 proportional to
    /// |S1|^2 + |S2|^2 of channel c at theta[i] (any common scale per channel: each channel is
    /// normalized so that its integral over the sphere is 1).
    [[nodiscard]] static MiePhase from_intensities(std::span<const double> theta, std::span<const S> intensity) {
        const char* who = "MiePhase::from_intensities";
        check_argument(theta.size() >= 2, who, "theta.size()", theta.size(), ">= 2");
        check_argument(intensity.size() == theta.size(), who, "intensity.size()", intensity.size(),
                       "equal to theta.size() = " + std::to_string(theta.size()));
        check_argument(theta.front() == 0.0, who, "theta[0]", theta.front(), "0");
        check_argument(std::abs(theta.back() - pi_v<double>) < 1e-12, who, "theta.back()", theta.back(), "pi");
        for (std::size_t i = 1; i < theta.size(); ++i)
            check_argument(theta[i] > theta[i - 1], who, "theta[" + std::to_string(i) + "]", theta[i], "increasing");
        // Ascending mu = cos(theta) for the table: reverse order; exact ends.
        const std::size_t n = theta.size();
        std::vector<double> mu(n);
        std::vector<S> v(n);
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t j = n - 1 - i;
            mu[i] = std::cos(theta[j]);
            v[i] = intensity[j];
        }
        mu.front() = -1.0;
        mu.back() = 1.0;
        // Drop nodes that collapse in double (theta < ~1e-8 next to theta = 0).
        std::vector<double> mu2;
        std::vector<S> v2;
        for (std::size_t i = 0; i < n; ++i) {
            if (!mu2.empty() && mu[i] <= mu2.back()) {
                if (i == n - 1) {  // keep mu = 1 exactly with the forward value
                    mu2.back() = 1.0;
                    v2.back() = v[i];
                }
                continue;
            }
            mu2.push_back(mu[i]);
            v2.push_back(v[i]);
        }
        MiePhase p;
        p.table_ = TabulatedPhase<F, S>::from_values(mu2, std::span<const S>(v2));
        p.theta_.assign(theta.begin(), theta.end());
        return p;
    }

    /// Phase function from a callable `amplitudes(mu) -> {S1, S2}` (complex scattering amplitudes
    /// at cos(theta) = mu, e.g. LorenzMie::amplitudes), tabulated on `theta` (default
    /// forward_peaked_theta_grid(x)); every channel equal. The end nodes use mu = +-1 exactly.
    template <class Amplitudes>
    [[nodiscard]] static MiePhase from_amplitudes(Amplitudes&& amplitudes, double x, std::span<const double> theta = {}) {
        std::vector<double> grid = theta.empty() ? forward_peaked_theta_grid(x) : std::vector<double>(theta.begin(), theta.end());
        std::vector<S> v(grid.size());
        for (std::size_t i = 0; i < grid.size(); ++i) {
            const double mu = i == 0 ? 1.0 : (i + 1 == grid.size() ? -1.0 : std::cos(grid[i]));
            const auto s = amplitudes(mu);
            v[i] = S(F(std::norm(s.S1) + std::norm(s.S2)));
        }
        return from_intensities(grid, v);
    }

    /// Exact Lorenz-Mie phase function of one sphere (m = n + i k, k >= 0; size parameter x), every
    /// channel equal, on `theta` (default forward_peaked_theta_grid(x)).
    /// Deprecated (kept for one release): use make_mie_phase (optics/mie_phase.hpp). The solver is a
    /// template parameter so that this header does not include the optics layer; include
    /// optics/lorenz_mie.hpp (or optics/mie_phase.hpp) where you call it.
    template <class Solver = LorenzMie>
    [[nodiscard]] static MiePhase from_mie(std::complex<double> m, double x, std::span<const double> theta = {}) {
        const Solver mie(m, x);
        return from_amplitudes([&](double mu) { return mie.amplitudes(mu); }, x, theta);
    }

    /// Per-channel phase value and mixture pdf for propagation directions w_in, w_out (see TabulatedPhase::eval).
    [[nodiscard]] PhaseEval<F, S> eval(const Vec3<F>& w_in, const Vec3<F>& w_out) const noexcept {
        return table_.eval(w_in, w_out);
    }
    /// Draw w_out around w_in from the tables (see TabulatedPhase::sample); the weight corrects for the channel mixture.
    [[nodiscard]] PhaseSample<F, S> sample(const Vec3<F>& w_in, Vec2<F> u) const noexcept {
        return table_.sample(w_in, u);
    }
    /// Per-channel asymmetry parameter g (mean cosine) of the tabulated phase.
    [[nodiscard]] S mean_cosine() const noexcept { return table_.mean_cosine(); }
    /// Normalized density of cos(theta) for channel c (integral over [-1, 1] is 1).
    [[nodiscard]] double pdf_cos_theta(double mu, std::size_t c = 0) const noexcept { return table_.pdf_cos_theta(mu, c); }
    /// The underlying per-channel table over cos theta.
    [[nodiscard]] const TabulatedPhase<F, S>& table() const noexcept { return table_; }
    /// Angles theta_i [rad] (ascending, 0 to pi) the table was built on.
    [[nodiscard]] std::span<const double> theta_grid() const noexcept { return theta_; }
    /// Human-readable description including the table's.
    [[nodiscard]] std::string to_string() const { return "MiePhase[" + table_.to_string() + "]"; }

private:
    TabulatedPhase<F, S> table_;
    std::vector<double> theta_;
};

}  // namespace grainlight
