/// @file grainlight/optics/bulk.hpp
/// Bulk optical properties of a cloud of spheres with a size distribution (Guo21 Sec. 4.2,
/// Eqs. 16-17): sigma_t = int C_t(r) N(r) dr, sigma_s, sigma_a likewise, and the ensemble phase
/// function f(theta) = int (|S1|^2 + |S2|^2) N(r) dr / (2 k^2 sigma_s), per wavelength.
///
/// Units: radii and wavelengths (vacuum) in um, cross sections in um^2, the PSD's number density
/// N_0 in particles per cubic metre, sigma in 1/m (sigma = N_0 \<C\> 1e-12). The phase function is
/// per steradian, tabulated on a theta grid dense near forward (phase/mie.hpp) and turned into a
/// PhaseFunction by `make_phase`.
///
/// Quadrature: adaptive Gauss-Kronrod (7/15) in ln r over the PSD's segments (split at its
/// breakpoints and at the Mie/GOA switch radius, where C(r) jumps), refining the panel with the
/// largest error until C_t, C_s (and, 100x more loosely, the intensity at three probe angles)
/// reach `rel_tol`. Each node evaluates one particle at every table angle: Mie from its series,
/// GOA from rays cached per wavelength (optics/goa.hpp GoaTable), so a table for 8 wavelengths
/// and a log-normal PSD takes about a second.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/particle.hpp"
#include "grainlight/optics/psd.hpp"
#include "grainlight/phase/mie.hpp"

namespace grainlight {

/// Controls of compute_bulk_optics.
struct BulkSettings {
    std::vector<double> theta;  ///< table angles (ascending 0..pi); empty: forward_peaked_theta_grid(x_max)
    double rel_tol = 1e-3;      ///< relative accuracy of sigma_t, sigma_s
    int max_panels = 256;       ///< per wavelength
    /// Minimum number of initial Gauss-Kronrod panels per PSD segment (>= 1).
    int min_panels_per_segment = 3;
    /// Weight of the probe-angle intensities in the error estimate (relative to C_t, C_s): the
    /// intensity at a fixed angle oscillates with r (interference), so it is held only to
    /// rel_tol / probe_weight.
    double probe_weight = 0.01;
};

/// Bulk properties at one wavelength.
struct BulkChannel {
    /// Vacuum wavelength [um].
    double wavelength_um = 0;
    /// @var mean_C_t
    /// PSD average of the extinction cross section [um^2].
    /// @var mean_C_s
    /// PSD average of the scattering cross section [um^2].
    double mean_C_t = 0, mean_C_s = 0, mean_C_a = 0;  ///< PSD averages \<C\> [um^2]
    /// @var sigma_t
    /// Extinction coefficient N_0 \<C_t\> [1/m] (Eq. 16).
    /// @var sigma_s
    /// Scattering coefficient N_0 \<C_s\> [1/m] (Eq. 16).
    double sigma_t = 0, sigma_s = 0, sigma_a = 0;     ///< N_0 \<C\> [1/m] (Eq. 16)
    std::vector<double> mean_intensity;               ///< \<|S1|^2 + |S2|^2\>(theta_i) over the PSD
    std::vector<double> phase;                        ///< Eq. 17 [1/sr] at theta_i
    double g = 0;                                     ///< mean cosine of the tabulated phase
    double phase_integral = 0;  ///< 2 pi int phase dmu (1 for Mie; GOA's C_s is analytic: ~1)
    int evaluations = 0;        ///< particle evaluations used
};

/// Bulk properties over wavelengths, sharing one angle grid.
struct BulkOptics {
    /// Table angles theta_i [rad], ascending from 0 to pi, shared by every channel's phase.
    std::vector<double> theta;
    /// One entry per wavelength, in the order requested.
    std::vector<BulkChannel> channels;

    /// The ensemble phase functions as a PhaseFunction with one channel per wavelength
    /// (S::size must equal channels.size(), or 1 to use channel 0 only).
    template <std::floating_point F, class S>
    [[nodiscard]] MiePhase<F, S> make_phase() const {
        check_argument(S::size == channels.size() || S::size == 1, "BulkOptics::make_phase", "Spectrum::size",
                       S::size, "number of wavelengths = " + std::to_string(channels.size()) + " (or 1)");
        std::vector<S> v(theta.size());
        for (std::size_t i = 0; i < theta.size(); ++i)
            for (std::size_t c = 0; c < S::size; ++c) v[i][c] = F(channels[c].phase[i]);
        return MiePhase<F, S>::from_intensities(theta, v);
    }
    /// sigma_t per channel [1/m] (S::size == channels.size()), e.g. for ContinuousMedium.
    template <SpectrumType S>
    [[nodiscard]] S sigma_t_spectrum() const {
        check_argument(S::size == channels.size(), "BulkOptics::sigma_t_spectrum", "Spectrum::size", S::size,
                       "number of wavelengths = " + std::to_string(channels.size()));
        S s;
        for (std::size_t c = 0; c < S::size; ++c) s[c] = typename S::value_type(channels[c].sigma_t);
        return s;
    }
    /// Single-scattering albedo sigma_s / sigma_t per channel.
    template <SpectrumType S>
    [[nodiscard]] S albedo_spectrum() const {
        check_argument(S::size == channels.size(), "BulkOptics::albedo_spectrum", "Spectrum::size", S::size,
                       "number of wavelengths = " + std::to_string(channels.size()));
        S s;
        for (std::size_t c = 0; c < S::size; ++c)
            s[c] = typename S::value_type(channels[c].mean_C_t > 0 ? channels[c].mean_C_s / channels[c].mean_C_t : 0.0);
        return s;
    }
};

namespace detail {

/// Gauss-Kronrod 7/15 nodes (non-negative half) and weights.
inline constexpr double gk15_x[8] = {0.991455371120812639, 0.949107912342758525, 0.864864423359769073,
                                     0.741531185599394440, 0.586087235467691130, 0.405845151377397167,
                                     0.207784955007898468, 0.0};
inline constexpr double gk15_wk[8] = {0.022935322010529225, 0.063092092629978553, 0.104790010322250184,
                                      0.140653259715525919, 0.169004726639267903, 0.190350578064785410,
                                      0.204432940075298892, 0.209482141084727828};
inline constexpr double g7_w[4] = {0.129484966168869693, 0.279705391489276668, 0.381830050505118945,
                                   0.417959183673469388};  // at gk15_x[1], [3], [5], [7]

/// Evaluates [C_t, C_s, I(theta_0..)] for one radius at one wavelength.
class BulkIntegrand {
public:
    BulkIntegrand(const ParticleModel& model, double lambda_um, std::span<const double> theta)
        : model_(model), lambda_um_(lambda_um), theta_(theta.begin(), theta.end()), mu_(theta.size()) {
        for (std::size_t i = 0; i < theta_.size(); ++i)
            mu_[i] = i == 0 && theta_[i] == 0 ? 1.0 : (theta_[i] >= pi_v<double> ? -1.0 : std::cos(theta_[i]));
        k_ = 2 * pi_v<double> * model.host_index / lambda_um;
        if (model.method != ScatteringMethod::mie) goa_.emplace(model.relative_index(), model.p_max, theta_);
    }
    [[nodiscard]] double wavenumber() const noexcept { return k_; }
    [[nodiscard]] std::size_t size() const noexcept { return theta_.size() + 2; }
    /// out[0] = C_t, out[1] = C_s [um^2], out[2 + i] = |S1|^2 + |S2|^2 at theta_i.
    void operator()(double r, std::span<double> out) const {
        const double x = k_ * r, geo = pi_v<double> * r * r;
        const auto m = model_.relative_index();
        // The automatic method: GOA only where it is valid (optics/particle.hpp, method_at).
        if (model_.method_at(r, lambda_um_) == ScatteringMethod::mie) {
            const LorenzMie mie(m, x);
            const auto q = mie.efficiencies();
            out[0] = q.qext * geo;
            out[1] = q.qsca * geo;
            // All angles in one call: the vectorized span overload (theta / pi - theta pairs).
            std::vector<ScatteringAmplitudes> s(mu_.size());
            mie.amplitudes(mu_, s);
            for (std::size_t i = 0; i < mu_.size(); ++i) out[2 + i] = std::norm(s[i].S1) + std::norm(s[i].S2);
        } else {
            const Goa goa(m, x, model_.p_max);
            out[0] = goa.qext() * geo;
            out[1] = out[0] - goa.qabs() * geo;
            goa_->intensities(x, out.subspan(2));
        }
    }

private:
    ParticleModel model_;
    double lambda_um_;
    std::vector<double> theta_, mu_;
    double k_ = 0;
    std::optional<GoaTable> goa_;
};

}  // namespace detail

namespace detail {
/// Mean cosine and 2 pi int phase dmu of a phase table on `theta` (linear in mu, as TabulatedPhase).
inline void finish_bulk_channel(BulkChannel& ch, std::span<const double> theta, double k) {
    const std::size_t nt = theta.size();
    ch.phase.resize(nt);
    for (std::size_t i = 0; i < nt; ++i) ch.phase[i] = ch.mean_intensity[i] / (2 * k * k * ch.mean_C_s);
    double i0 = 0, i1 = 0;
    for (std::size_t i = 0; i + 1 < nt; ++i) {
        const double a = std::cos(theta[i + 1]), b = std::cos(theta[i]);  // a < b
        const double fa = ch.phase[i + 1], fb = ch.phase[i], h = b - a;
        i0 += 0.5 * h * (fa + fb);
        i1 += h * (a * (2 * fa + fb) + b * (fa + 2 * fb)) / 6.0;
    }
    ch.phase_integral = 2 * pi_v<double> * i0;
    ch.g = i0 > 0 ? i1 / i0 : 0.0;
}

/// One wavelength's channel from the PSD-averaged integrands `total` = (<C_t>, <C_s>, <I(theta_k)>...)
/// and the number density n0 (in the units that make n0 <C> a coefficient in 1/m): Eqs. 16-17.
inline BulkChannel make_bulk_channel(double lambda, int evaluations, std::span<const double> total,
                                     double n0, std::span<const double> theta, double k) {
    BulkChannel ch;
    ch.wavelength_um = lambda;
    ch.evaluations = evaluations;
    ch.mean_C_t = total[0];
    ch.mean_C_s = total[1];
    ch.mean_C_a = total[0] - total[1];
    ch.sigma_t = n0 * ch.mean_C_t;
    ch.sigma_s = n0 * ch.mean_C_s;
    ch.sigma_a = n0 * ch.mean_C_a;
    ch.mean_intensity.assign(total.begin() + 2, total.end());
    finish_bulk_channel(ch, theta, k);
    return ch;
}
}  // namespace detail

/// Monodisperse medium: sigma = N_0 C(r_0) and the particle's own phase function (no quadrature).
[[nodiscard]] inline BulkOptics compute_bulk_optics(const MonodispersePsd& psd, const ParticleModel& model,
                                                    std::span<const double> wavelengths_um, BulkSettings settings = {}) {
    const char* who = "compute_bulk_optics";
    model.validate();
    check_argument(!wavelengths_um.empty(), who, "wavelengths_um.size()", wavelengths_um.size(), ">= 1");
    for (double l : wavelengths_um)
        check_argument(std::isfinite(l) && l > 0, who, "wavelength_um", l, "> 0 (finite)");
    BulkOptics out;
    const double lambda_min = *std::min_element(wavelengths_um.begin(), wavelengths_um.end());
    out.theta = settings.theta.empty()
                    ? forward_peaked_theta_grid(2 * pi_v<double> * model.host_index * psd.radius() / lambda_min)
                    : settings.theta;
    for (double lambda : wavelengths_um) {
        const detail::BulkIntegrand f(model, lambda, out.theta);
        std::vector<double> v(f.size());
        f(psd.radius(), v);
        out.channels.push_back(
            detail::make_bulk_channel(lambda, 1, v, psd.number_density() * 1e-12, out.theta, f.wavenumber()));
    }
    return out;
}

/// Eqs. 16-17 for PSD `psd` and particles `model` at each vacuum wavelength (um).
template <SizeDistribution Psd>
[[nodiscard]] BulkOptics compute_bulk_optics(const Psd& psd, const ParticleModel& model,
                                             std::span<const double> wavelengths_um, BulkSettings settings = {}) {
    const char* who = "compute_bulk_optics";
    model.validate();
    check_argument(!wavelengths_um.empty(), who, "wavelengths_um.size()", wavelengths_um.size(), ">= 1");
    for (double l : wavelengths_um)
        check_argument(std::isfinite(l) && l > 0, who, "wavelength_um", l, "> 0 (finite)");
    check_argument(settings.rel_tol > 0, who, "rel_tol", settings.rel_tol, "> 0");
    check_argument(settings.max_panels >= 1, who, "max_panels", settings.max_panels, ">= 1");

    // Segments in r: PSD breakpoints plus the switch radius.
    std::vector<double> cuts = psd.breakpoints();
    const double lo = std::max(cuts.front(), 1e-6 * cuts.back()), hi = cuts.back();
    if (model.method == ScatteringMethod::automatic) {
        // The Mie -> GOA switch of every wavelength is a kink of the integrand: a panel edge.
        if (model.switch_radius_um > lo && model.switch_radius_um < hi) cuts.push_back(model.switch_radius_um);
        for (double l : wavelengths_um) {
            const double r_goa = model.goa_from_radius_um(l);
            if (std::isfinite(r_goa) && r_goa > lo && r_goa < hi) cuts.push_back(r_goa);
        }
    }
    for (auto& c : cuts) c = std::clamp(c, lo, hi);
    std::sort(cuts.begin(), cuts.end());
    cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
    check_argument(cuts.size() >= 2, who, "PSD support", hi, "an interval of positive length");

    BulkOptics out;
    const double lambda_min = *std::min_element(wavelengths_um.begin(), wavelengths_um.end());
    out.theta = settings.theta.empty()
                    ? forward_peaked_theta_grid(2 * pi_v<double> * model.host_index * hi / lambda_min)
                    : settings.theta;
    const std::size_t nt = out.theta.size();
    // Probe angles for the error estimate: ~30, 90, 150 degrees.
    std::size_t probes[3];
    for (int j = 0; j < 3; ++j) {
        const double target = pi_v<double> * (1 + 2 * j) / 6;
        probes[j] = std::size_t(std::lower_bound(out.theta.begin(), out.theta.end(), target) - out.theta.begin());
        probes[j] = std::min(probes[j], nt - 1);
    }

    for (double lambda : wavelengths_um) {
        const detail::BulkIntegrand f(model, lambda, out.theta);
        const std::size_t nv = f.size();
        std::vector<double> node(nv);
        struct Panel {
            double a, b;            // in ln r
            std::vector<double> k;  // Kronrod integral of pdf * value * r over [a, b]
            std::vector<double> g;  // Gauss (7-point) estimate of C_t, C_s and the probes
        };
        int evaluations = 0;
        auto integrate = [&](double a, double b) {
            Panel p{a, b, std::vector<double>(nv, 0.0), std::vector<double>(5, 0.0)};
            const double c = 0.5 * (a + b), h = 0.5 * (b - a);
            // Nodes: -x_0..-x_6, 0, x_6..x_0.
            for (int i = 0; i < 15; ++i) {
                const int j = i <= 7 ? i : 14 - i;
                const double t = c + (i <= 7 ? -1.0 : 1.0) * h * detail::gk15_x[j];
                const double r = std::exp(t);
                const double w = psd.pdf(r) * r * h;
                if (w <= 0) continue;
                f(r, node);
                ++evaluations;
                const double wk = detail::gk15_wk[j] * w;
                for (std::size_t v = 0; v < nv; ++v) p.k[v] += wk * node[v];
                if (j % 2 == 1) {
                    const double wg = detail::g7_w[j / 2] * w;
                    p.g[0] += wg * node[0];
                    p.g[1] += wg * node[1];
                    for (int q = 0; q < 3; ++q) p.g[2 + q] += wg * node[2 + probes[q]];
                }
            }
            return p;
        };
        std::vector<Panel> panels;
        for (std::size_t s = 0; s + 1 < cuts.size(); ++s) {
            const double a = std::log(cuts[s]), b = std::log(cuts[s + 1]);
            const int n = std::max(1, settings.min_panels_per_segment);
            for (int i = 0; i < n; ++i) panels.push_back(integrate(a + (b - a) * i / n, a + (b - a) * (i + 1) / n));
        }
        auto panel_error = [&](const Panel& p, const std::vector<double>& total) {
            double e = 0;
            e = std::max(e, std::abs(p.k[0] - p.g[0]) / std::max(std::abs(total[0]), 1e-300));
            e = std::max(e, std::abs(p.k[1] - p.g[1]) / std::max(std::abs(total[1]), 1e-300));
            for (int q = 0; q < 3; ++q)
                e = std::max(e, settings.probe_weight * std::abs(p.k[2 + probes[q]] - p.g[2 + q]) /
                                    std::max(std::abs(total[2 + probes[q]]), 1e-300));
            return e;
        };
        std::vector<double> total(nv);
        while (true) {
            std::fill(total.begin(), total.end(), 0.0);
            for (const auto& p : panels)
                for (std::size_t v = 0; v < nv; ++v) total[v] += p.k[v];
            double err_sum = 0, worst = -1;
            std::size_t worst_i = 0;
            for (std::size_t i = 0; i < panels.size(); ++i) {
                const double e = panel_error(panels[i], total);
                err_sum += e;
                if (e > worst) {
                    worst = e;
                    worst_i = i;
                }
            }
            if (err_sum <= settings.rel_tol || int(panels.size()) >= settings.max_panels) break;
            const Panel old = panels[worst_i];
            const double mid = 0.5 * (old.a + old.b);
            panels[worst_i] = integrate(old.a, mid);
            panels.push_back(integrate(mid, old.b));
        }
        out.channels.push_back(
            detail::make_bulk_channel(lambda, evaluations, total, psd.number_density() * 1e-12, out.theta, f.wavenumber()));
    }
    return out;
}

}  // namespace grainlight
