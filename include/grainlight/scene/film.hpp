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
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/spectrum.hpp"

namespace grainlight {

/// A float RGB image, row-major, top row first, 3 floats per pixel (R, G, B), linear values.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<float> rgb;  ///< size 3 * width * height

    Image() = default;
    /// Black image of the given size (validated: both >= 1, at most 2^15 per side).
    Image(int width_, int height_) : width(width_), height(height_) {
        check_argument(width_ >= 1 && width_ <= 32768, "Image", "width", width_, "[1, 32768]");
        check_argument(height_ >= 1 && height_ <= 32768, "Image", "height", height_, "[1, 32768]");
        rgb.assign(std::size_t(3) * std::size_t(width_) * std::size_t(height_), 0.0f);
    }
    [[nodiscard]] float& at(int x, int y, int c) noexcept {
        return rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)];
    }
    [[nodiscard]] float at(int x, int y, int c) const noexcept {
        return rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)];
    }
    /// Mean of channel c over all pixels (double accumulation).
    [[nodiscard]] double mean(int c) const noexcept {
        double s = 0;
        for (std::size_t i = std::size_t(c); i < rgb.size(); i += 3) s += double(rgb[i]);
        return rgb.empty() ? 0.0 : s / double(rgb.size() / 3);
    }
};

/// Accumulation film: per pixel a double RGB sum and a sample count (box filter: a sample counts
/// only for the pixel it was taken in). Determinism: a pixel's value depends only on the order
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
    }
    [[nodiscard]] int width() const noexcept { return width_; }
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
    /// Add another film of the same size pixel by pixel (for per-pass or per-rank films; call in
    /// a fixed order for reproducible sums).
    void merge(const Film& o) {
        check_argument(o.width_ == width_ && o.height_ == height_, "Film::merge", "other.width x height",
                       o.width_ * o.height_, "same size as this film");
        for (std::size_t i = 0; i < sum_.size(); ++i) sum_[i] += o.sum_[i];
        for (std::size_t i = 0; i < count_.size(); ++i) count_[i] += o.count_[i];
    }
    /// Mean value of channel c at pixel (x, y) (0 where no sample landed).
    [[nodiscard]] double value(int x, int y, int c) const noexcept {
        const std::size_t i = index(x, y);
        return count_[i] > 0 ? sum_[3 * i + std::size_t(c)] / count_[i] : 0.0;
    }
    /// Total filter weight (the sample count for a box filter) at pixel (x, y).
    [[nodiscard]] double weight(int x, int y) const noexcept { return count_[index(x, y)]; }
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
};

}  // namespace grainlight
