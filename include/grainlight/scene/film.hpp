/// @file grainlight/scene/film.hpp
/// A double-precision accumulation film (box pixel filter) and the plain float RGB image it
/// resolves to. No file formats here: EXR/PNG output lives in scene/image_io.hpp, so code that
/// only renders does not pull in OpenEXR or libpng.
///
/// Conventions: pixel (x, y) with x to the right and y *down* (row 0 is the top row of the
/// image, as in EXR and PNG files); values are linear-sRGB radiance (W sr^-1 m^-2 per channel,
/// or whatever unit the integrator's lights use), no tone mapping.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/spectrum.hpp"

namespace grainlight {

/// A float RGB image, row-major, top row first, 3 floats per pixel (R, G, B), linear values.
struct Image {
    int width = 0;           ///< pixels per row
    int height = 0;          ///< rows
    std::vector<float> rgb;  ///< size 3 * width * height

    Image() = default;
    /// Black image of the given size (validated: both >= 1, at most 2^15 per side).
    Image(int width_, int height_) : width(width_), height(height_) {
        check_argument(width_ >= 1 && width_ <= 32768, "Image", "width", width_, "[1, 32768]");
        check_argument(height_ >= 1 && height_ <= 32768, "Image", "height", height_, "[1, 32768]");
        rgb.assign(std::size_t(3) * std::size_t(width_) * std::size_t(height_), 0.0f);
    }
    /// Channel c of pixel (x, y) (no bounds check).
    [[nodiscard]] float& at(int x, int y, int c) noexcept {
        return rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)];
    }
    /// Channel c of pixel (x, y) (no bounds check).
    [[nodiscard]] float at(int x, int y, int c) const noexcept {
        return rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)];
    }
    /// One-line description: size and mean RGB.
    [[nodiscard]] std::string to_string() const {
        return "Image[" + std::to_string(width) + "x" + std::to_string(height) + ", mean (" +
               grainlight::detail::to_display(mean(0)) + ", " + grainlight::detail::to_display(mean(1)) + ", " +
               grainlight::detail::to_display(mean(2)) + ")]";
    }
    /// Mean of channel c over all pixels (double accumulation).
    [[nodiscard]] double mean(int c) const noexcept {
        double s = 0;
        for (std::size_t i = std::size_t(c); i < rgb.size(); i += 3) s += double(rgb[i]);
        return rgb.empty() ? 0.0 : s / double(rgb.size() / 3);
    }
};

/// Accumulation film: per pixel a double RGB sum and a sample count (box filter: a sample counts
/// only for the pixel it was taken in), plus a count of the samples that were not finite (NaN or
/// infinite radiance: a render driver records them with add_nonfinite and adds a zero in their
/// place, so a defect is counted and reported instead of poisoning or silently leaving the pixel).
/// Determinism: a pixel's value depends only on the order
/// its own samples are added in; a render driver that gives each pixel to one worker and adds
/// its samples in sample-index order gets the same image for any thread count.
class Film {
public:
    Film() = default;
    /// A black film of width x height pixels (each side in [1, 32768]).
    Film(int width, int height) : width_(width), height_(height) {
        check_argument(width >= 1 && width <= 32768, "Film", "width", width, "[1, 32768]");
        check_argument(height >= 1 && height <= 32768, "Film", "height", height, "[1, 32768]");
        sum_.assign(std::size_t(3) * std::size_t(width) * std::size_t(height), 0.0);
        count_.assign(std::size_t(width) * std::size_t(height), 0.0);
        nonfinite_.assign(std::size_t(width) * std::size_t(height), 0u);
    }
    /// A film from its raw accumulators (checkpoints, scene/film_checkpoint.hpp): `sums` holds
    /// 3 * width * height RGB sums, `weights` and `nonfinite` width * height values, row-major.
    /// Throws invalid_argument when a size does not match.
    [[nodiscard]] static Film from_accumulators(int width, int height, std::vector<double> sums,
                                                std::vector<double> weights, std::vector<std::uint32_t> nonfinite) {
        Film f(width, height);
        const std::size_t n = std::size_t(width) * std::size_t(height);
        check_argument(sums.size() == 3 * n, "Film::from_accumulators", "sums.size()", sums.size(), "3 * width * height");
        check_argument(weights.size() == n, "Film::from_accumulators", "weights.size()", weights.size(), "width * height");
        check_argument(nonfinite.size() == n, "Film::from_accumulators", "nonfinite.size()", nonfinite.size(),
                       "width * height");
        f.sum_ = std::move(sums);
        f.count_ = std::move(weights);
        f.nonfinite_ = std::move(nonfinite);
        return f;
    }
    /// Pixels per row.
    [[nodiscard]] int width() const noexcept { return width_; }
    /// Rows.
    [[nodiscard]] int height() const noexcept { return height_; }

    /// Add one sample of value `v` with filter weight `w` (1 for a box filter) to pixel (x, y).
    /// Not thread-safe for the same pixel; distinct pixels may be written concurrently.
    template <std::size_t N, class F>
    void add_sample(int x, int y, const Spectrum<N, F>& v, double w = 1.0) noexcept {
        static_assert(N == 1 || N == 3, "Film::add_sample takes grey (N = 1) or RGB (N = 3) values");
        const std::size_t i = index(x, y);
        for (std::size_t c = 0; c < 3; ++c) sum_[3 * i + c] += w * double(v[N == 1 ? 0 : c]);
        count_[i] += w;
    }
    /// Add a plain RGB triple.
    void add_rgb(int x, int y, double r, double g, double b, double w = 1.0) noexcept {
        const std::size_t i = index(x, y);
        sum_[3 * i + 0] += w * r;
        sum_[3 * i + 1] += w * g;
        sum_[3 * i + 2] += w * b;
        count_[i] += w;
    }
    /// Count one non-finite sample at pixel (x, y) (the driver adds a zero sample in its place).
    void add_nonfinite(int x, int y) noexcept { ++nonfinite_[index(x, y)]; }
    /// Add another film of the same size pixel by pixel (for per-pass or per-rank films; call in
    /// a fixed order for reproducible sums).
    void merge(const Film& o) {
        check_argument(o.width_ == width_ && o.height_ == height_, "Film::merge", "other.width x height",
                       o.width_ * o.height_, "same size as this film");
        for (std::size_t i = 0; i < sum_.size(); ++i) sum_[i] += o.sum_[i];
        for (std::size_t i = 0; i < count_.size(); ++i) count_[i] += o.count_[i];
        for (std::size_t i = 0; i < nonfinite_.size(); ++i) nonfinite_[i] += o.nonfinite_[i];
    }
    /// Mean value of channel c at pixel (x, y) (0 where no sample landed).
    [[nodiscard]] double value(int x, int y, int c) const noexcept {
        const std::size_t i = index(x, y);
        return count_[i] > 0 ? sum_[3 * i + std::size_t(c)] / count_[i] : 0.0;
    }
    /// Total filter weight (the sample count for a box filter) at pixel (x, y).
    [[nodiscard]] double weight(int x, int y) const noexcept { return count_[index(x, y)]; }
    /// Number of non-finite samples recorded at pixel (x, y).
    [[nodiscard]] std::uint32_t nonfinite(int x, int y) const noexcept { return nonfinite_[index(x, y)]; }
    /// Number of non-finite samples recorded over the whole film.
    [[nodiscard]] std::uint64_t nonfinite_samples() const noexcept {
        std::uint64_t n = 0;
        for (const auto c : nonfinite_) n += c;
        return n;
    }
    /// One-line description: size, total weight and the non-finite sample count.
    [[nodiscard]] std::string to_string() const {
        double w = 0;
        for (const double c : count_) w += c;
        return "Film[" + std::to_string(width_) + "x" + std::to_string(height_) + ", total weight " +
               grainlight::detail::to_display(w) + ", " + std::to_string(nonfinite_samples()) + " non-finite samples]";
    }
    /// Raw RGB sums (3 per pixel, row-major), for checkpoints.
    [[nodiscard]] std::span<const double> sums() const noexcept { return sum_; }
    /// Raw filter-weight sums (1 per pixel, row-major), for checkpoints.
    [[nodiscard]] std::span<const double> weights() const noexcept { return count_; }
    /// Raw non-finite sample counts (1 per pixel, row-major), for checkpoints.
    [[nodiscard]] std::span<const std::uint32_t> nonfinite_counts() const noexcept { return nonfinite_; }
    /// The resolved image (per-pixel means, converted to float).
    [[nodiscard]] Image image() const {
        Image img(width_, height_);
        for (int y = 0; y < height_; ++y)
            for (int x = 0; x < width_; ++x)
                for (int c = 0; c < 3; ++c) img.at(x, y, c) = float(value(x, y, c));
        return img;
    }

private:
    [[nodiscard]] std::size_t index(int x, int y) const noexcept {
        return std::size_t(y) * std::size_t(width_) + std::size_t(x);
    }
    int width_ = 0, height_ = 0;
    std::vector<double> sum_;
    std::vector<double> count_;
    std::vector<std::uint32_t> nonfinite_;
};

}  // namespace grainlight
