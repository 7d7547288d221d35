// tests/common/chi2.hpp: Pearson chi-square goodness-of-fit of a sampler against its own pdf
// (the Mitsuba/pbrt habit). Directions are binned on a (theta, phi) grid around +z; the expected
// count of each bin integrates the pdf with Gauss-Legendre quadrature; bins with expected count
// below 5 are pooled; the p-value comes from the regularized upper incomplete gamma function.
// A chi-square test checks that sample() and pdf() agree; it does not check eval() or the
// direction convention (pitfalls.md): those have their own tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include <boost/math/special_functions/gamma.hpp>

#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"

namespace gl_test {

struct Chi2Result {
    double statistic = 0;
    int dof = 0;
    double p_value = 0;
    std::size_t pooled_bins = 0;
    std::string describe() const {
        std::ostringstream os;
        os << "chi2 = " << statistic << ", dof = " << dof << ", p = " << p_value;
        return os.str();
    }
};

/// Sidak-corrected per-test significance for `tests` tests at family-wise level `alpha`.
inline double sidak(double alpha, int tests) { return 1.0 - std::pow(1.0 - alpha, 1.0 / double(tests)); }

/// Pearson statistic of observed vs expected counts. Cells with expected count below
/// `min_expected` are pooled into one cell (Mitsuba's habit); observations in a cell of zero
/// expectation make the statistic infinite (p = 0).
inline Chi2Result chi2_from_counts(const std::vector<double>& observed, const std::vector<double>& expected,
                                   double min_expected = 5.0) {
    Chi2Result r;
    double pool_obs = 0, pool_exp = 0;
    int cells = 0;
    for (std::size_t k = 0; k < observed.size(); ++k) {
        if (expected[k] < min_expected) {
            pool_obs += observed[k];
            pool_exp += expected[k];
            ++r.pooled_bins;
            continue;
        }
        r.statistic += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
        ++cells;
    }
    if (pool_exp > 0) {
        r.statistic += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
        ++cells;
    } else if (pool_obs > 0) {
        r.statistic = std::numeric_limits<double>::infinity();
    }
    r.dof = std::max(1, cells - 1);
    r.p_value = std::isfinite(r.statistic) ? boost::math::gamma_q(0.5 * r.dof, 0.5 * r.statistic) : 0.0;
    return r;
}

/// Chi-square test of a direction sampler. `sample(u1, u2, w)` returns false for "no sample";
/// `pdf(w)` is the solid-angle density. Directions are binned in (theta, phi) about +z.
/// `theta_warp` (optional) maps theta to a bin coordinate in [0, 1] (monotone) so that peaked
/// distributions get fine bins where they need them; default uniform in theta.
inline Chi2Result chi2_directions(const std::function<bool(double, double, grainlight::Vec3d&)>& sample,
                                  const std::function<double(const grainlight::Vec3d&)>& pdf, std::size_t n_samples,
                                  int theta_res = 30, int phi_res = 30, std::uint64_t seed = 7,
                                  const std::function<double(double)>& theta_of_bincoord = nullptr) {
    using grainlight::pi_v;
    auto theta_at = [&](double s) { return theta_of_bincoord ? theta_of_bincoord(s) : s * pi_v<double>; };
    std::vector<double> obs(std::size_t(theta_res * phi_res), 0.0), expct(obs.size(), 0.0);
    // Bin-coordinate inverse by bisection on theta_at (monotone increasing).
    auto bin_coord = [&](double theta) {
        double lo = 0, hi = 1;
        for (int i = 0; i < 60; ++i) {
            const double mid = 0.5 * (lo + hi);
            (theta_at(mid) < theta ? lo : hi) = mid;
        }
        return 0.5 * (lo + hi);
    };
    auto rng = grainlight::Pcg32::from_key(seed, 0xC41, 0);
    for (std::size_t i = 0; i < n_samples; ++i) {
        grainlight::Vec3d w(0.0);
        const double u1 = rng.uniform<double>(), u2 = rng.uniform<double>();
        if (!sample(u1, u2, w)) continue;
        const double theta = std::acos(std::clamp(w.z, -1.0, 1.0));
        double phi = std::atan2(w.y, w.x);
        if (phi < 0) phi += 2 * pi_v<double>;
        const int ti = std::min(theta_res - 1, int(bin_coord(theta) * theta_res));
        const int pj = std::min(phi_res - 1, int(phi / (2 * pi_v<double>) * phi_res));
        obs[std::size_t(ti * phi_res + pj)] += 1;
    }
    // Expected counts: 8x8-point Gauss-Legendre over each bin in (theta, phi) of pdf * sin(theta).
    // Gauss nodes never touch the bin edges, so a pdf discontinuity on an edge is integrated exactly.
    static const double gx[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                                 0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
    static const double gw[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                                 0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
    for (int ti = 0; ti < theta_res; ++ti) {
        const double t0 = theta_at(double(ti) / theta_res), t1 = theta_at(double(ti + 1) / theta_res);
        for (int pj = 0; pj < phi_res; ++pj) {
            const double p0 = 2 * pi_v<double> * pj / phi_res, p1 = 2 * pi_v<double> * (pj + 1) / phi_res;
            double acc = 0;
            for (int a = 0; a < 8; ++a) {
                const double th = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * gx[a];
                for (int b = 0; b < 8; ++b) {
                    const double ph = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * gx[b];
                    const grainlight::Vec3d w(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
                    acc += gw[a] * gw[b] * pdf(w) * std::sin(th);
                }
            }
            acc *= 0.25 * (t1 - t0) * (p1 - p0);
            expct[std::size_t(ti * phi_res + pj)] = acc * double(n_samples);
        }
    }
    return chi2_from_counts(obs, expct);
}

/// Chi-square test of a 1D sampler on [lo, hi] with `bins` equal bins (cdf(x) gives exact bin
/// probabilities). Samples outside [lo, hi] fall into an overflow cell with probability
/// 1 - (cdf(hi) - cdf(lo)).
inline Chi2Result chi2_1d(const std::function<double(double)>& sample, const std::function<double(double)>& cdf,
                          double lo, double hi, int bins, std::size_t n_samples, std::uint64_t seed = 11) {
    std::vector<double> obs(std::size_t(bins) + 1, 0.0), expct(obs.size(), 0.0);
    auto rng = grainlight::Pcg32::from_key(seed, 0x1D, 0);
    for (std::size_t i = 0; i < n_samples; ++i) {
        const double x = sample(rng.uniform<double>());
        if (x >= lo && x < hi)
            obs[std::min(std::size_t(bins - 1), std::size_t((x - lo) / (hi - lo) * bins))] += 1;
        else
            obs[std::size_t(bins)] += 1;
    }
    double inside = 0;
    for (int b = 0; b < bins; ++b) {
        const double p = cdf(lo + (hi - lo) * (b + 1) / bins) - cdf(lo + (hi - lo) * b / bins);
        expct[std::size_t(b)] = p * double(n_samples);
        inside += p;
    }
    expct[std::size_t(bins)] = std::max(0.0, 1.0 - inside) * double(n_samples);
    return chi2_from_counts(obs, expct);
}

}  // namespace gl_test
