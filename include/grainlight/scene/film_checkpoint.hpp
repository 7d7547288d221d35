/// @file grainlight/scene/film_checkpoint.hpp
/// A checkpoint of a render in progress: the accumulators (double RGB sums, weights, non-finite
/// counts) of its films (one, or several for integrators with separate images, e.g. EPT's low and
/// high order), which rows are finished, and what the render was (seed, samples per pixel
/// and the caller's fingerprint of everything else that determines the image). A render driver
/// (integrators/render.hpp) writes one atomically every few seconds and resumes from it; because a
/// row's samples depend only on (seed, pixel, sample index), a resumed render is bit-identical to
/// an uninterrupted one.
///
/// File: a grainlight container (core/serialization.hpp) of kind `FCKP`, version 1. Payload:
/// u32 width, u32 height, u64 seed, u64 spp, u64 key, u32 film count (1..16), u8[height] rows_done
/// (0 or 1), then per film f64[3 * width * height] sums, f64[width * height] weights,
/// u32[width * height] nonfinite.
/// The loader validates every field (sizes against the remaining bytes before allocating, flags
/// 0/1, finite non-negative weights, finite sums) and throws format_error otherwise.
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "grainlight/core/serialization.hpp"
#include "grainlight/scene/film.hpp"

namespace grainlight {

/// A render checkpoint (see the file comment for the format).
struct FilmCheckpoint {
    /// Container kind of checkpoint files.
    static constexpr std::uint32_t file_kind = fourcc("FCKP");
    /// Payload layout version.
    static constexpr std::uint32_t file_kind_version = 1;

    std::uint64_t seed = 0;              ///< master seed of the render
    std::uint64_t spp = 0;               ///< samples per pixel of the render
    std::uint64_t key = 0;               ///< caller's fingerprint of the scene and options
    std::vector<std::uint8_t> rows_done; ///< 1 for every finished row (size = film height)
    std::vector<Film> films;             ///< accumulators, all of one size; rows not done are zero

    /// Largest number of films in one checkpoint.
    static constexpr std::uint32_t max_films = 16;

    /// Number of finished rows.
    [[nodiscard]] int rows_finished() const noexcept {
        int n = 0;
        for (const auto r : rows_done) n += r ? 1 : 0;
        return n;
    }

    /// Encode the payload.
    [[nodiscard]] std::vector<unsigned char> encode() const {
        check_argument(!films.empty() && films.size() <= max_films, "FilmCheckpoint::encode", "films.size()",
                       films.size(), "[1, 16]");
        const Film& f0 = films.front();
        for (const Film& f : films)
            check_argument(f.width() == f0.width() && f.height() == f0.height(), "FilmCheckpoint::encode",
                           "film size", f.width(), "the same for every film");
        check_argument(rows_done.size() == std::size_t(f0.height()), "FilmCheckpoint::encode", "rows_done.size()",
                       rows_done.size(), "film height");
        ByteWriter w;
        w.put(std::uint32_t(f0.width())).put(std::uint32_t(f0.height())).put(seed).put(spp).put(key);
        w.put(std::uint32_t(films.size()));
        w.put_array(rows_done.data(), rows_done.size());
        for (const Film& f : films) {
            w.put_array(f.sums().data(), f.sums().size());
            w.put_array(f.weights().data(), f.weights().size());
            w.put_array(f.nonfinite_counts().data(), f.nonfinite_counts().size());
        }
        return w.take();
    }
    /// Write atomically (temporary file + rename). Throws io_error.
    void save(const std::filesystem::path& path) const {
        write_container_atomic(path, file_kind, file_kind_version, encode());
    }
    /// Decode a payload (`context` names it in messages). Throws format_error.
    [[nodiscard]] static FilmCheckpoint decode(const std::vector<unsigned char>& payload, const std::string& context) {
        ByteReader r(payload, context);
        const auto width = r.get<std::uint32_t>();
        const auto height = r.get<std::uint32_t>();
        if (width < 1 || width > 32768 || height < 1 || height > 32768)
            r.fail("film size " + std::to_string(width) + " x " + std::to_string(height) +
                   " outside [1, 32768] per side");
        FilmCheckpoint c;
        c.seed = r.get<std::uint64_t>();
        c.spp = r.get<std::uint64_t>();
        c.key = r.get<std::uint64_t>();
        const std::uint64_t n = std::uint64_t(width) * height;
        const auto count = r.get<std::uint32_t>();
        if (count < 1 || count > max_films) r.fail("film count " + std::to_string(count) + " outside [1, 16]");
        r.get_array(c.rows_done, height);
        for (const auto v : c.rows_done)
            if (v > 1) r.fail("row flag " + std::to_string(v) + " is not 0 or 1");
        for (std::uint32_t k = 0; k < count; ++k) {
            std::vector<double> sums, weights;
            std::vector<std::uint32_t> nonfinite;
            r.get_array(sums, 3 * n);
            r.get_array(weights, n);
            r.get_array(nonfinite, n);
            for (const double s : sums)
                if (!std::isfinite(s)) r.fail("non-finite pixel sum");
            for (const double wt : weights)
                if (!(wt >= 0.0) || !std::isfinite(wt)) r.fail("pixel weight outside [0, inf)");
            c.films.push_back(Film::from_accumulators(int(width), int(height), std::move(sums), std::move(weights),
                                                      std::move(nonfinite)));
        }
        r.expect_end();
        return c;
    }
    /// Read and validate a checkpoint file. Throws io_error / format_error.
    [[nodiscard]] static FilmCheckpoint load(const std::filesystem::path& path) {
        return decode(read_container(path, file_kind, file_kind_version), "film checkpoint '" + path.string() + "'");
    }
};

}  // namespace grainlight
