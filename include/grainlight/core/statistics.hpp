/// @file grainlight/core/statistics.hpp
/// Running statistics: Welford mean/variance (numerically stable, mergeable in a fixed order so
/// parallel reductions are deterministic) and a fixed-range histogram.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "grainlight/core/error.hpp"

namespace grainlight {

/// Welford's online mean and variance, with Chan et al.'s parallel merge.
class Welford {
public:
    /// Add one sample x.
    void add(double x) noexcept {
        ++n_;
        const double d = x - mean_;
        mean_ += d / double(n_);
        m2_ += d * (x - mean_);
    }
    /// Merge another accumulator (Chan, Golub & LeVeque 1979). Merging in a fixed order gives
    /// the same result regardless of how many threads produced the parts.
    void merge(const Welford& o) noexcept {
        if (o.n_ == 0) return;
        if (n_ == 0) {
            *this = o;
            return;
        }
        const double n = double(n_ + o.n_);
        const double d = o.mean_ - mean_;
        mean_ += d * double(o.n_) / n;
        m2_ += o.m2_ + d * d * double(n_) * double(o.n_) / n;
        n_ += o.n_;
    }
    /// Number of samples added (including merged ones).
    [[nodiscard]] std::uint64_t count() const noexcept { return n_; }
    /// Sample mean (0 when empty).
    [[nodiscard]] double mean() const noexcept { return mean_; }
    /// Unbiased sample variance.
    [[nodiscard]] double variance() const noexcept { return n_ > 1 ? m2_ / double(n_ - 1) : 0.0; }
    /// Square root of variance() (sample standard deviation).
    [[nodiscard]] double stddev() const noexcept { return std::sqrt(variance()); }
    /// Standard error of the mean: stddev / sqrt(n).
    [[nodiscard]] double standard_error() const noexcept { return n_ > 0 ? stddev() / std::sqrt(double(n_)) : 0.0; }

private:
    std::uint64_t n_ = 0;
    double mean_ = 0, m2_ = 0;
};

/// Histogram with `bins` equal bins on [lo, hi); out-of-range samples are counted separately.
class Histogram {
public:
    /// Histogram of `bins` >= 1 equal bins on [lo, hi) (finite, hi > lo); throws std::invalid_argument otherwise.
    Histogram(double lo, double hi, std::size_t bins) : lo_(lo), hi_(hi), counts_(bins, 0.0) {
        check_argument(bins >= 1, "Histogram", "bins", bins, ">= 1");
        check_argument(std::isfinite(lo) && std::isfinite(hi) && hi > lo, "Histogram", "hi - lo", hi - lo, "> 0");
    }
    /// Add sample x with weight w; x outside [lo, hi) (or NaN) only counts in total() and outside().
    void add(double x, double w = 1.0) noexcept {
        total_ += w;
        if (!(x >= lo_ && x < hi_)) {
            outside_ += w;
            return;
        }
        auto i = static_cast<std::size_t>((x - lo_) / (hi_ - lo_) * double(counts_.size()));
        if (i >= counts_.size()) i = counts_.size() - 1;
        counts_[i] += w;
    }
    /// Add another histogram's counts bin by bin (same binning expected; extra bins of `o` are ignored).
    void merge(const Histogram& o) noexcept {
        for (std::size_t i = 0; i < counts_.size() && i < o.counts_.size(); ++i) counts_[i] += o.counts_[i];
        total_ += o.total_;
        outside_ += o.outside_;
    }
    /// Number of bins.
    [[nodiscard]] std::size_t bins() const noexcept { return counts_.size(); }
    /// Width of one bin, (hi - lo) / bins.
    [[nodiscard]] double bin_width() const noexcept { return (hi_ - lo_) / double(counts_.size()); }
    /// Centre of bin i.
    [[nodiscard]] double bin_center(std::size_t i) const noexcept { return lo_ + (double(i) + 0.5) * bin_width(); }
    /// Weight accumulated in bin i.
    [[nodiscard]] double count(std::size_t i) const noexcept { return counts_[i]; }
    /// Total weight added, inside and outside the range.
    [[nodiscard]] double total() const noexcept { return total_; }
    /// Weight of the samples that fell outside [lo, hi).
    [[nodiscard]] double outside() const noexcept { return outside_; }
    /// Estimated density in bin i (normalized by all samples, including those outside).
    [[nodiscard]] double density(std::size_t i) const noexcept {
        return total_ > 0 ? counts_[i] / (total_ * bin_width()) : 0.0;
    }

private:
    double lo_, hi_;
    std::vector<double> counts_;
    double total_ = 0, outside_ = 0;
};

}  // namespace grainlight
