/// @file grainlight/phase/tabulated.hpp
/// A phase function tabulated in cos(theta) on a non-uniform grid, one table per spectral channel
/// (Meng15's per-channel scatterometer Phi, Guo21's per-wavelength ensemble phase functions).
///
/// Two interpolations:
///  - `from_values`: values p_c(mu_i) at nodes, linear in mu between nodes (exactly inverted when
///    sampling: the CDF is quadratic per interval);
///  - `from_histogram`: counts per bin [mu_i, mu_{i+1}), constant density per bin.
/// Each channel is normalized separately so that int p_c(mu) dmu = 1 (the solid-angle value is
/// p_c / (2 pi)). cos(theta) = dot(w_in, w_out), +1 forward (phase/concepts.hpp).
///
/// Spectral sampling: a channel is picked uniformly (u.x re-used after re-scaling), cos(theta) is
/// drawn from that channel's table, and the pdf is the one-sample-MIS mixture
/// pdf = (1/N) sum_c p_c(mu) / (2 pi); weight_c = value_c / pdf. A grey table (all channels equal)
/// gives weight 1 exactly.
#pragma once

#include <cmath>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/phase/concepts.hpp"

namespace grainlight {

/// Phase function tabulated over mu = cos theta on [-1, 1], one table per channel of S: either
/// piecewise linear through node values (from_values) or piecewise constant per bin (from_histogram,
/// e.g. a scatterometer's output). Every channel is normalized separately; directions are drawn by
/// exact inversion of one channel's CDF chosen uniformly (a single table when all channels agree,
/// is_grey()), so eval's pdf is the channel mixture and sample's weight is value / pdf per channel.
/// A PhaseFunction (phase/concepts.hpp); immutable after construction, thread-safe for reads.
template <std::floating_point F = float, class S = Spectrum<1, F>>
class TabulatedPhase {
public:
    /// Floating-point type of directions and pdfs.
    using Float = F;
    /// Spectrum type of values and weights.
    using Spectrum = S;
    /// Number of channels of S, i.e. of separate tables.
    static constexpr std::size_t channels = S::size;
    /// @enum Interpolation
    /// How values between grid points are reconstructed.
    /// @var Interpolation::linear
    /// Piecewise linear between node values (from_values).
    /// @var Interpolation::constant
    /// Constant per bin (from_histogram).
    enum class Interpolation { linear, constant };

    TabulatedPhase() = default;

    /// Values at nodes mu_0 = -1 < ... < mu_n = 1 (linear interpolation). values[i][c] >= 0 is
    /// the (un-normalized) phase at mu_i for channel c.
    [[nodiscard]] static TabulatedPhase from_values(std::span<const double> mu, std::span<const S> values) {
        TabulatedPhase t;
        t.mode_ = Interpolation::linear;
        check_grid(mu, "mu");
        check_argument(values.size() == mu.size(), "TabulatedPhase::from_values", "values.size()", values.size(),
                       "equal to mu.size() = " + std::to_string(mu.size()));
        std::vector<double> v(mu.size());
        for (std::size_t c = 0; c < channels; ++c) {
            for (std::size_t i = 0; i < mu.size(); ++i) v[i] = double(values[i][c]);
            t.lin_.emplace_back(mu, std::span<const double>(v));
        }
        t.finish();
        return t;
    }
    /// Grey convenience overload: one value per node.
    [[nodiscard]] static TabulatedPhase from_values(std::span<const double> mu, std::span<const double> values) {
        std::vector<S> sv(values.size());
        for (std::size_t i = 0; i < values.size(); ++i) sv[i] = S(F(values[i]));
        return from_values(mu, std::span<const S>(sv));
    }
    /// Histogram of cos(theta) samples: bin edges -1 = e_0 < ... < e_n = 1 and per-channel
    /// (weighted) counts per bin; the density is count / (total * width).
    [[nodiscard]] static TabulatedPhase from_histogram(std::span<const double> edges, std::span<const S> counts) {
        TabulatedPhase t;
        t.mode_ = Interpolation::constant;
        check_grid(edges, "edges");
        check_argument(counts.size() + 1 == edges.size(), "TabulatedPhase::from_histogram", "counts.size()",
                       counts.size(), "edges.size() - 1 = " + std::to_string(edges.size() - 1));
        std::vector<double> dens(counts.size());
        for (std::size_t c = 0; c < channels; ++c) {
            for (std::size_t i = 0; i < counts.size(); ++i) dens[i] = double(counts[i][c]) / (edges[i + 1] - edges[i]);
            t.pc_.emplace_back(edges, std::span<const double>(dens));
        }
        t.finish();
        return t;
    }
    /// Grey convenience overload: one (weighted) count per bin, the same in every channel.
    [[nodiscard]] static TabulatedPhase from_histogram(std::span<const double> edges, std::span<const double> counts) {
        std::vector<S> sv(counts.size());
        for (std::size_t i = 0; i < counts.size(); ++i) sv[i] = S(F(counts[i]));
        return from_histogram(edges, std::span<const S>(sv));
    }

    /// Normalized density of cos(theta) for channel c (integrates to 1 over [-1, 1]).
    [[nodiscard]] double pdf_cos_theta(double mu, std::size_t c = 0) const noexcept {
        return mode_ == Interpolation::linear ? lin_[c].pdf(mu) : pc_[c].pdf(mu);
    }
    /// Mixture density of cos(theta) used by `sample`.
    [[nodiscard]] double mixture_pdf_cos_theta(double mu) const noexcept {
        if (grey_) return pdf_cos_theta(mu, 0);
        double p = 0;
        for (std::size_t c = 0; c < channels; ++c) p += pdf_cos_theta(mu, c);
        return p / double(channels);
    }

    /// Per-channel phase value [1/sr] and mixture pdf for propagation directions w_in, w_out.
    [[nodiscard]] PhaseEval<F, S> eval(const Vec3<F>& w_in, const Vec3<F>& w_out) const noexcept {
        const double mu = std::clamp(double(glm::dot(w_in, w_out)), -1.0, 1.0);
        if (grey_) {
            const F p = F(pdf_cos_theta(mu, 0) * inv_two_pi_v<double>);
            return {S(p), p};
        }
        S value;
        double sum = 0;
        for (std::size_t c = 0; c < channels; ++c) {
            const double pc = pdf_cos_theta(mu, c);
            value[c] = F(pc * inv_two_pi_v<double>);
            sum += pc;
        }
        return {value, F(sum / double(channels) * inv_two_pi_v<double>)};
    }

    /// Draw w_out around w_in: u.x picks the channel (when not grey) and then mu by exact inversion,
    /// u.y the azimuth; weight = per-channel value / mixture pdf.
    [[nodiscard]] PhaseSample<F, S> sample(const Vec3<F>& w_in, Vec2<F> u) const noexcept {
        double ux = double(u.x);
        std::size_t c = 0;
        if (!grey_ && channels > 1) {
            const double scaled = ux * double(channels);
            c = std::min(std::size_t(scaled), channels - 1);
            ux = scaled - double(c);
        }
        double pdf_c = 0;
        const double mu =
            mode_ == Interpolation::linear ? lin_[c].sample(ux, &pdf_c) : pc_[c].sample(ux, &pdf_c);
        const Vec3<F> w = direction_from_cosine(w_in, F(mu), F(2) * pi_v<F> * u.y);
        S weight(F(1));
        const double pdf = grey_ ? pdf_c : mixture_pdf_cos_theta(mu);
        if (!grey_) {
            for (std::size_t k = 0; k < channels; ++k) weight[k] = pdf > 0 ? F(pdf_cos_theta(mu, k) / pdf) : F(0);
        }
        return {w, weight, F(pdf * inv_two_pi_v<double>)};
    }

    /// Per-channel mean cosine g_c = int mu p_c(mu) dmu (exact for the interpolant).
    [[nodiscard]] S mean_cosine() const noexcept { return mean_cosine_; }
    /// Interpolation mode: linear (from_values) or constant (from_histogram).
    [[nodiscard]] Interpolation interpolation() const noexcept { return mode_; }
    /// True if all channels' normalized tables are identical (to 1e-12): then eval's pdf equals every channel's value.
    [[nodiscard]] bool is_grey() const noexcept { return grey_; }
    /// Grid nodes (linear) or bin edges (histogram).
    [[nodiscard]] std::span<const double> grid() const noexcept {
        return mode_ == Interpolation::linear ? lin_[0].nodes() : pc_[0].nodes();
    }
    /// Human-readable description: mode, grid size and per-channel g.
    [[nodiscard]] std::string to_string() const {
        std::string s = "TabulatedPhase[";
        s += mode_ == Interpolation::linear ? "linear, " : "histogram, ";
        s += std::to_string(grid().size()) + " nodes, g0 = " + std::to_string(double(mean_cosine_[0])) + "]";
        return s;
    }

private:
    static void check_grid(std::span<const double> x, const char* name) {
        const char* who = "TabulatedPhase";
        check_argument(x.size() >= 2, who, std::string(name) + ".size()", x.size(), ">= 2");
        check_argument(std::abs(x.front() + 1.0) < 1e-12, who, std::string(name) + "[0]", x.front(), "-1 (grid spans [-1, 1])");
        check_argument(std::abs(x.back() - 1.0) < 1e-12, who, std::string(name) + ".back()", x.back(), "1 (grid spans [-1, 1])");
    }
    void finish() {
        for (std::size_t c = 0; c < channels; ++c) {
            double g = 0;
            if (mode_ == Interpolation::linear) {
                const auto x = lin_[c].nodes();
                const auto f = lin_[c].values();
                for (std::size_t i = 0; i + 1 < x.size(); ++i) {
                    const double a = x[i], b = x[i + 1], h = b - a;
                    g += h * (a * (2 * f[i] + f[i + 1]) + b * (f[i] + 2 * f[i + 1])) / 6.0;
                }
                g /= lin_[c].integral();
            } else {
                const auto x = pc_[c].nodes();
                const auto f = pc_[c].values();
                for (std::size_t i = 0; i + 1 < x.size(); ++i) g += f[i] * (x[i + 1] * x[i + 1] - x[i] * x[i]) / 2.0;
                g /= pc_[c].integral();
            }
            mean_cosine_[c] = F(g);
        }
        // Grey when every channel's normalized table is identical.
        grey_ = true;
        for (std::size_t c = 1; c < channels && grey_; ++c) {
            const auto& a = mode_ == Interpolation::linear ? lin_[0].values() : pc_[0].values();
            const auto& b = mode_ == Interpolation::linear ? lin_[c].values() : pc_[c].values();
            const double ia = mode_ == Interpolation::linear ? lin_[0].integral() : pc_[0].integral();
            const double ib = mode_ == Interpolation::linear ? lin_[c].integral() : pc_[c].integral();
            for (std::size_t i = 0; i < a.size(); ++i)
                if (std::abs(a[i] / ia - b[i] / ib) > 1e-12 * (a[i] / ia)) {
                    grey_ = false;
                    break;
                }
        }
    }

    Interpolation mode_ = Interpolation::linear;
    std::vector<PiecewiseLinear1D<double>> lin_;
    std::vector<PiecewiseConstant1D<double>> pc_;
    S mean_cosine_{};
    bool grey_ = true;
};

}  // namespace grainlight
