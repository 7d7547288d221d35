/// @file grainlight/core/distribution.hpp
/// One-dimensional distributions on (possibly non-uniform) grids, each with sample / pdf /
/// invert: `DiscreteDistribution`, `PiecewiseConstant1D` (density constant per interval) and
/// `PiecewiseLinear1D` (density linear between nodes). Non-uniform grids matter: a 100 um
/// particle's diffraction peak lives in 1 - cos(theta) < 1e-5.
///
/// Construction validates (throws grainlight::invalid_argument); sampling is noexcept.
///
/// Sampling finds the CDF interval through a guide table (Chen & Asau 1974, "cutpoint method";
/// Devroye 1986 Sec. III.2.4): one cell per interval in u, each holding the range of intervals
/// its u can fall in, then a branchless search inside that range (almost always empty). The cost
/// is O(1) expected, independent of the node count, and the interval found is exactly the one
/// the binary search over the whole CDF finds: the mapping u -> x stays the monotone inverse CDF
/// (bit-identical to the plain search), so `invert` is still its inverse. `pdf`, `eval` and
/// `invert` find the node interval of x the same way (a guide uniform in x; same interval as the
/// binary search).
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"

namespace grainlight {

namespace detail {

/// Guide table over a non-decreasing CDF 0 = c_0 <= ... <= c_n = 1: cell j of G covers
/// u in [j/G, (j+1)/G) (widened by a few ulp for the rounding of u G) and stores the first and
/// last candidate of the interval search there. find(u) returns the largest i <= n - 1 with
/// c_i <= u (0 if none), the same as find_interval over the whole CDF.
class CdfGuide {
public:
    CdfGuide() = default;
    template <std::floating_point F>
    explicit CdfGuide(std::span<const F> cdf) {
        const std::size_t n = cdf.size();
        if (n < 2) return;
        const std::size_t G = n - 1;
        cells_.resize(G);
        const double eps = 4 * double(std::numeric_limits<F>::epsilon());
        auto last_le = [&](double v, std::size_t from) {  // largest i in [from, n-2] with cdf[i] <= v
            std::size_t i = from;
            while (i + 1 <= n - 2 && double(cdf[i + 1]) <= v) ++i;
            return i;
        };
        std::size_t lo = 0, hi = 0;
        for (std::size_t j = 0; j < G; ++j) {
            const double low = double(j) / double(G) * (1 - eps);
            const double high = double(j + 1) / double(G) * (1 + eps);
            lo = last_le(low, lo);
            hi = last_le(high, std::max(hi, lo));
            cells_[j] = {std::uint32_t(lo), std::uint32_t(hi)};
        }
    }
    template <std::floating_point F>
    [[nodiscard]] std::size_t find(const F* cdf, std::size_t n, F u) const noexcept {
        if (cells_.empty()) return find_interval(n, [&](std::size_t k) { return cdf[k] <= u; });
        if (!(u >= F(0))) return 0;  // u < 0 or NaN: no c_i <= u but c_0 = 0 (as find_interval)
        const std::size_t G = cells_.size();
        const F s = u * F(G);
        const std::size_t j = s >= F(1) ? std::min(std::size_t(s), G - 1) : 0;
        const std::size_t lo = cells_[j].lo, hi = cells_[j].hi;
        return lo + find_interval(hi - lo + 2, [&](std::size_t k) { return cdf[lo + k] <= u; });
    }
    [[nodiscard]] std::size_t size() const noexcept { return cells_.size(); }

private:
    struct Cell {
        std::uint32_t lo, hi;
    };
    std::vector<Cell> cells_;
};

/// Guide table over strictly increasing nodes x_0 < ... < x_{n-1}, cells uniform in x (widened
/// by 8 eps (|x_0| + |x_{n-1}|) for the rounding of the cell index): find(v) returns the largest
/// i <= n - 2 with x_i <= v (0 if none), the same as find_interval over all nodes, in O(1)
/// expected for v uniform on [x_0, x_{n-1}] (used by pdf / eval / invert).
class NodeGuide {
public:
    NodeGuide() = default;
    template <std::floating_point F>
    explicit NodeGuide(std::span<const F> x) {
        const std::size_t n = x.size();
        if (n < 2) return;
        const std::size_t G = n - 1;
        cells_.resize(G);
        x0_ = double(x[0]);
        const double range = double(x[n - 1]) - x0_;
        scale_ = double(G) / range;
        const double delta = 8 * double(std::numeric_limits<F>::epsilon()) * (std::abs(x0_) + std::abs(double(x[n - 1])));
        auto last_le = [&](double v, std::size_t from) {  // largest i in [from, n-2] with x[i] <= v
            std::size_t i = from;
            while (i + 1 <= n - 2 && double(x[i + 1]) <= v) ++i;
            return i;
        };
        std::size_t lo = 0, hi = 0;
        for (std::size_t j = 0; j < G; ++j) {
            lo = last_le(x0_ + range * double(j) / double(G) - delta, lo);
            hi = last_le(x0_ + range * double(j + 1) / double(G) + delta, std::max(hi, lo));
            cells_[j] = {std::uint32_t(lo), std::uint32_t(hi)};
        }
    }
    template <std::floating_point F>
    [[nodiscard]] std::size_t find(const F* x, std::size_t n, F v) const noexcept {
        if (cells_.empty()) return find_interval(n, [&](std::size_t k) { return x[k] <= v; });
        const std::size_t G = cells_.size();
        const double s = (double(v) - x0_) * scale_;
        const std::size_t j = s >= 1 ? std::min(std::size_t(std::min(s, 4e18)), G - 1) : 0;  // NaN -> 0
        const std::size_t lo = cells_[j].lo, hi = cells_[j].hi;
        return lo + find_interval(hi - lo + 2, [&](std::size_t k) { return x[lo + k] <= v; });
    }

private:
    struct Cell {
        std::uint32_t lo, hi;
    };
    std::vector<Cell> cells_;
    double x0_ = 0, scale_ = 0;
};

}  // namespace detail

/// Discrete distribution over {0, ..., n-1} with non-negative weights.
template <std::floating_point F = double>
class DiscreteDistribution {
public:
    DiscreteDistribution() = default;
    /// Build from non-negative weights (need not sum to 1); throws std::invalid_argument if `weights`
    /// is empty, has a negative or non-finite entry, or sums to 0. O(n) setup, O(1) expected sampling.
    explicit DiscreteDistribution(std::span<const F> weights) {
        check_argument(!weights.empty(), "DiscreteDistribution", "weights.size()", weights.size(), ">= 1");
        cdf_.resize(weights.size() + 1);
        cdf_[0] = 0;
        double acc = 0;
        for (std::size_t i = 0; i < weights.size(); ++i) {
            check_argument(std::isfinite(double(weights[i])) && weights[i] >= F(0), "DiscreteDistribution",
                           "weights[" + std::to_string(i) + "]", weights[i], "finite and >= 0");
            acc += double(weights[i]);
            cdf_[i + 1] = F(acc);
        }
        check_argument(acc > 0, "DiscreteDistribution", "sum(weights)", acc, "> 0");
        total_ = F(acc);
        for (auto& c : cdf_) c = F(double(c) / acc);
        cdf_.back() = F(1);
        guide_ = detail::CdfGuide(std::span<const F>(cdf_));
    }
    /// Number of outcomes n (0 for a default-constructed distribution).
    [[nodiscard]] std::size_t size() const noexcept { return cdf_.empty() ? 0 : cdf_.size() - 1; }
    /// Sum of the weights as given (before normalization).
    [[nodiscard]] F total() const noexcept { return total_; }
    /// Probability of outcome i (normalized weight); i < size().
    [[nodiscard]] F pmf(std::size_t i) const noexcept { return cdf_[i + 1] - cdf_[i]; }
    /// Index for u in [0, 1); optionally the pmf and u re-scaled to [0, 1) within the chosen bin.
    [[nodiscard]] std::size_t sample(F u, F* pmf_out = nullptr, F* u_remapped = nullptr) const noexcept {
        const std::size_t i = guide_.find(cdf_.data(), cdf_.size(), u);
        const F p = cdf_[i + 1] - cdf_[i];
        if (pmf_out) *pmf_out = p;
        if (u_remapped) *u_remapped = p > 0 ? std::min((u - cdf_[i]) / p, F(1) - std::numeric_limits<F>::epsilon()) : F(0);
        return i;
    }
    /// Normalized CDF, size() + 1 entries from 0 to exactly 1.
    [[nodiscard]] std::span<const F> cdf() const noexcept { return cdf_; }

private:
    std::vector<F> cdf_;
    detail::CdfGuide guide_;
    F total_ = 0;
};

/// Piecewise-constant density on nodes x_0 < ... < x_n with values f_0..f_{n-1} per interval.
template <std::floating_point F = double>
class PiecewiseConstant1D {
public:
    PiecewiseConstant1D() = default;
    /// Uniform grid on [a, b].
    PiecewiseConstant1D(std::span<const F> values, F a, F b) : PiecewiseConstant1D(uniform_nodes(values.size(), a, b), values) {}
    /// Non-uniform grid: nodes.size() == values.size() + 1, strictly increasing.
    PiecewiseConstant1D(std::span<const F> nodes, std::span<const F> values) { build(nodes, values); }

    /// Integral of the un-normalized values over [min(), max()].
    [[nodiscard]] F integral() const noexcept { return integral_; }
    /// First node x_0 (lower end of the support).
    [[nodiscard]] F min() const noexcept { return x_.front(); }
    /// Last node x_n (upper end of the support).
    [[nodiscard]] F max() const noexcept { return x_.back(); }
    /// Number of intervals n.
    [[nodiscard]] std::size_t size() const noexcept { return f_.size(); }
    /// The n + 1 nodes.
    [[nodiscard]] std::span<const F> nodes() const noexcept { return x_; }
    /// The n un-normalized interval values.
    [[nodiscard]] std::span<const F> values() const noexcept { return f_; }

    /// Normalized density at x (0 outside [min, max]).
    [[nodiscard]] F pdf(F x) const noexcept {
        if (!(x >= x_.front() && x <= x_.back())) return 0;
        const std::size_t i = xguide_.find(x_.data(), x_.size(), x);
        return f_[i] / integral_;
    }
    /// Sample x for u in [0, 1) by exact inversion of the CDF.
    [[nodiscard]] F sample(F u, F* pdf_out = nullptr, std::size_t* index = nullptr) const noexcept {
        const std::size_t i = guide_.find(cdf_.data(), cdf_.size(), u);
        const F dcdf = cdf_[i + 1] - cdf_[i];
        F t = dcdf > 0 ? (u - cdf_[i]) / dcdf : F(0);
        t = std::clamp(t, F(0), F(1));
        if (pdf_out) *pdf_out = f_[i] / integral_;
        if (index) *index = i;
        return std::clamp(x_[i] + t * (x_[i + 1] - x_[i]), x_[i], x_[i + 1]);
    }
    /// CDF at x: the u that sample() maps to x.
    [[nodiscard]] F invert(F x) const noexcept {
        if (x <= x_.front()) return 0;
        if (x >= x_.back()) return 1;
        const std::size_t i = xguide_.find(x_.data(), x_.size(), x);
        const F t = (x - x_[i]) / (x_[i + 1] - x_[i]);
        return cdf_[i] + t * (cdf_[i + 1] - cdf_[i]);
    }

private:
    static std::vector<F> uniform_nodes(std::size_t n, F a, F b) {
        check_argument(n >= 1, "PiecewiseConstant1D", "values.size()", n, ">= 1");
        check_argument(std::isfinite(a) && std::isfinite(b) && b > a, "PiecewiseConstant1D", "b - a", b - a, "> 0 (finite a < b)");
        std::vector<F> x(n + 1);
        for (std::size_t i = 0; i <= n; ++i) x[i] = a + (b - a) * F(i) / F(n);
        x[n] = b;
        return x;
    }
    void build(std::span<const F> nodes, std::span<const F> values) {
        const char* who = "PiecewiseConstant1D";
        check_argument(values.size() >= 1, who, "values.size()", values.size(), ">= 1");
        check_argument(nodes.size() == values.size() + 1, who, "nodes.size()", nodes.size(), "values.size() + 1");
        x_.assign(nodes.begin(), nodes.end());
        f_.assign(values.begin(), values.end());
        cdf_.resize(x_.size());
        cdf_[0] = 0;
        double acc = 0;
        for (std::size_t i = 0; i < f_.size(); ++i) {
            check_argument(std::isfinite(double(x_[i + 1])) && x_[i + 1] > x_[i], who, "nodes[" + std::to_string(i + 1) + "]",
                           x_[i + 1], "strictly increasing, finite");
            check_argument(std::isfinite(double(f_[i])) && f_[i] >= 0, who, "values[" + std::to_string(i) + "]", f_[i],
                           "finite and >= 0");
            acc += double(f_[i]) * double(x_[i + 1] - x_[i]);
            cdf_[i + 1] = F(acc);
        }
        check_argument(acc > 0 && std::isfinite(acc), who, "integral", acc, "> 0 (the table must be normalizable)");
        integral_ = F(acc);
        for (auto& c : cdf_) c = F(double(c) / acc);
        cdf_.back() = 1;
        guide_ = detail::CdfGuide(std::span<const F>(cdf_));
        xguide_ = detail::NodeGuide(std::span<const F>(x_));
    }
    std::vector<F> x_, f_, cdf_;
    detail::CdfGuide guide_;
    detail::NodeGuide xguide_;
    F integral_ = 0;
};

/// Piecewise-linear density through (x_i, f_i), x strictly increasing, f_i >= 0.
template <std::floating_point F = double>
class PiecewiseLinear1D {
public:
    PiecewiseLinear1D() = default;
    /// Density through (nodes[i], values[i]): at least 2 strictly increasing finite nodes and as many
    /// finite values >= 0 with a positive integral; throws std::invalid_argument otherwise.
    PiecewiseLinear1D(std::span<const F> nodes, std::span<const F> values) {
        const char* who = "PiecewiseLinear1D";
        check_argument(nodes.size() >= 2, who, "nodes.size()", nodes.size(), ">= 2");
        check_argument(values.size() == nodes.size(), who, "values.size()", values.size(), "nodes.size()");
        x_.assign(nodes.begin(), nodes.end());
        f_.assign(values.begin(), values.end());
        cdf_.resize(x_.size());
        cdf_[0] = 0;
        double acc = 0;
        for (std::size_t i = 0; i < f_.size(); ++i) {
            check_argument(std::isfinite(double(f_[i])) && f_[i] >= 0, who, "values[" + std::to_string(i) + "]", f_[i],
                           "finite and >= 0");
            if (i + 1 < x_.size()) {
                check_argument(std::isfinite(double(x_[i + 1])) && x_[i + 1] > x_[i], who,
                               "nodes[" + std::to_string(i + 1) + "]", x_[i + 1], "strictly increasing, finite");
                acc += 0.5 * (double(f_[i]) + double(f_[i + 1])) * double(x_[i + 1] - x_[i]);
                cdf_[i + 1] = F(acc);
            }
        }
        check_argument(acc > 0 && std::isfinite(acc), who, "integral", acc, "> 0 (the table must be normalizable)");
        integral_ = F(acc);
        for (auto& c : cdf_) c = F(double(c) / acc);
        cdf_.back() = 1;
        guide_ = detail::CdfGuide(std::span<const F>(cdf_));
        xguide_ = detail::NodeGuide(std::span<const F>(x_));
    }
    /// Integral of the un-normalized piecewise-linear function (trapezoid rule, exact).
    [[nodiscard]] F integral() const noexcept { return integral_; }
    /// First node (lower end of the support).
    [[nodiscard]] F min() const noexcept { return x_.front(); }
    /// Last node (upper end of the support).
    [[nodiscard]] F max() const noexcept { return x_.back(); }
    /// The nodes x_i.
    [[nodiscard]] std::span<const F> nodes() const noexcept { return x_; }
    /// The un-normalized values f_i at the nodes.
    [[nodiscard]] std::span<const F> values() const noexcept { return f_; }

    /// Un-normalized value (linear interpolation), 0 outside the support.
    [[nodiscard]] F eval(F x) const noexcept {
        if (!(x >= x_.front() && x <= x_.back())) return 0;
        const std::size_t i = xguide_.find(x_.data(), x_.size(), x);
        const F t = (x - x_[i]) / (x_[i + 1] - x_[i]);
        return f_[i] + t * (f_[i + 1] - f_[i]);
    }
    /// Normalized density at x (0 outside [min(), max()]).
    [[nodiscard]] F pdf(F x) const noexcept { return eval(x) / integral_; }
    /// Exact inversion: inside an interval the CDF is quadratic in t.
    [[nodiscard]] F sample(F u, F* pdf_out = nullptr) const noexcept {
        const std::size_t i = guide_.find(cdf_.data(), cdf_.size(), u);
        const F h = x_[i + 1] - x_[i];
        const F f0 = f_[i], f1 = f_[i + 1];
        // Solve (f0 t + (f1 - f0) t^2 / 2) h = (u - cdf_i) * integral for t in [0, 1].
        const F target = (u - cdf_[i]) * integral_ / h;
        F t;
        const F a = F(0.5) * (f1 - f0);
        if (std::abs(a) < F(1e-7) * std::max(f0, f1)) {
            t = f0 > 0 ? target / f0 : F(0.5);
            if (std::abs(a) > 0 && f0 > 0) t = target / (f0 + a * t);  // one refinement
        } else {
            // Stable root of a t^2 + f0 t - target = 0.
            const F disc = std::max(F(0), f0 * f0 + F(4) * a * target);
            t = F(2) * target / (f0 + std::sqrt(disc));
        }
        t = std::clamp(t, F(0), F(1));
        const F x = x_[i] + t * h;
        if (pdf_out) *pdf_out = (f0 + t * (f1 - f0)) / integral_;
        return x;
    }
    /// CDF at x (0 below min(), 1 above max()): the u that sample() maps to x.
    [[nodiscard]] F invert(F x) const noexcept {
        if (x <= x_.front()) return 0;
        if (x >= x_.back()) return 1;
        const std::size_t i = xguide_.find(x_.data(), x_.size(), x);
        const F h = x_[i + 1] - x_[i];
        const F t = (x - x_[i]) / h;
        const F part = h * (f_[i] * t + F(0.5) * (f_[i + 1] - f_[i]) * t * t);
        return cdf_[i] + part / integral_;
    }

private:
    std::vector<F> x_, f_, cdf_;
    detail::CdfGuide guide_;
    detail::NodeGuide xguide_;
    F integral_ = 0;
};

}  // namespace grainlight
