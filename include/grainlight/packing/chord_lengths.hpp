/// @file grainlight/packing/chord_lengths.hpp
/// Outer (void) chord lengths of sphere packings: Dixmier's exponential model (Meng15 Eq. 1)
/// and a Monte Carlo measurement along random lines through the infinite tiling of a
/// PeriodicTile (Meng15 Fig. 6, top).
///
/// Eq. 1: p_b(z) = sigma_b exp(-sigma_b z), sigma_b = (3 / (4R)) f / (1 - f), so the mean
/// distance between bounding-sphere interactions is lambda_b = 1 / sigma_b = 4R(1-f)/(3f).
/// That mean is exact for any packing of equal non-overlapping spheres: the mean chord of a
/// phase of volume fraction (1 - f) bounded by interface area per volume s_v is 4(1-f)/s_v
/// (a stereological identity for isotropic uniform random lines), and s_v = 3f/R. The
/// exponential shape is only approximate (fewer very short chords than exponential at high f;
/// Torquato & Lu 1993).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/packing/periodic_tile.hpp"

namespace grainlight {

/// Meng15 Eq. 1: Dixmier's outer-chord extinction sigma_b = 3 f / (4 R (1 - f)) [1/length].
/// Throws grainlight::invalid_argument for R <= 0 or f outside (0, 1).
[[nodiscard]] inline double dixmier_sigma_b(double radius, double fraction) {
    check_argument(std::isfinite(radius) && radius > 0, "dixmier_sigma_b", "radius", radius, "finite, > 0");
    check_argument(fraction > 0 && fraction < 1, "dixmier_sigma_b", "fraction", fraction, "(0, 1)");
    return 3.0 * fraction / (4.0 * radius * (1.0 - fraction));
}

/// Mean outer chord lambda_b = 1 / sigma_b = 4 R (1 - f) / (3 f) (exact for equal spheres).
[[nodiscard]] inline double dixmier_mean_chord(double radius, double fraction) {
    return 1.0 / dixmier_sigma_b(radius, fraction);
}

/// Dixmier's chord-length density p_b(z) = sigma_b exp(-sigma_b z), z >= 0 (Meng15 Eq. 1).
[[nodiscard]] inline double dixmier_pdf(double z, double radius, double fraction) {
    const double s = dixmier_sigma_b(radius, fraction);
    return z < 0 ? 0.0 : s * std::exp(-s * z);
}

/// Cumulative distribution of dixmier_pdf.
[[nodiscard]] inline double dixmier_cdf(double z, double radius, double fraction) {
    const double s = dixmier_sigma_b(radius, fraction);
    return z <= 0 ? 0.0 : -std::expm1(-s * z);
}

/// Totals of an outer-chord measurement. mean() = void length / number of sphere entries is the
/// consistent (ratio) estimator of the mean chord; complete chords (both ends seen) are also
/// passed to the caller's callback for histograms.
struct ChordMeasurement {
    double void_length = 0;              ///< total length of the lines outside spheres
    std::uint64_t entries = 0;           ///< number of sphere entries along the lines
    std::uint64_t complete_chords = 0;   ///< chords whose both ends lie on the lines
    /// Mean outer chord void_length / entries (NaN when no sphere was entered).
    [[nodiscard]] double mean() const noexcept {
        return entries ? void_length / double(entries) : std::numeric_limits<double>::quiet_NaN();
    }
    /// Add another measurement's totals (merge per-block results in a fixed order).
    void merge(const ChordMeasurement& o) noexcept {
        void_length += o.void_length;
        entries += o.entries;
        complete_chords += o.complete_chords;
    }
};

/// Measure outer chords along `lines` random lines of length `line_length` (world units) through
/// the infinite tiling of `tile`: each line starts at a uniform point of the tile in a uniform
/// direction. `on_chord(z)` receives every complete outer chord length z. Deterministic for the
/// state of `rng`. Throws grainlight::invalid_argument for line_length <= 0.
template <class OnChord>
ChordMeasurement measure_outer_chords(const PeriodicTile& tile, std::uint64_t lines, double line_length, Rng& rng,
                                      OnChord&& on_chord) {
    check_argument(std::isfinite(line_length) && line_length > 0, "measure_outer_chords", "line_length", line_length,
                   "finite, > 0");
    ChordMeasurement m;
    const double side = tile.side();
    for (std::uint64_t l = 0; l < lines; ++l) {
        const Vec3d o = rng.uniform3<double>() * side;
        const Vec3d d = sample_uniform_sphere<double>(rng.uniform2<double>());
        double t = 0;
        bool after_exit = false;  // is t the exit point of a sphere (start of a complete chord)?
        for (;;) {
            const TileHit h = tile.first_hit(Vec3i64(0, 0, 0), o, d, t, line_length);
            if (!h) {
                m.void_length += line_length - t;
                break;
            }
            if (h.t_enter > t) {
                m.void_length += h.t_enter - t;
                ++m.entries;
                if (after_exit) {
                    ++m.complete_chords;
                    on_chord(h.t_enter - t);
                }
            }
            t = h.t_exit;
            after_exit = true;
            if (t >= line_length) break;
        }
    }
    return m;
}

/// measure_outer_chords without a per-chord callback.
inline ChordMeasurement measure_outer_chords(const PeriodicTile& tile, std::uint64_t lines, double line_length,
                                             Rng& rng) {
    return measure_outer_chords(tile, lines, line_length, rng, [](double) {});
}

}  // namespace grainlight
