/// @file grainlight/media/grain_stats.hpp
/// The record the virtual scatterometer (precompute/scatterometer.hpp, Meng15 Sec. 4.1-4.2) fills
/// and the teleportation medium (media/teleportation.hpp) reads: per-incident-ray statistics of
/// one grain or a mixture (beta, lambda_delta, alpha_s, lambda_s, Phi(cos theta), the TT joint
/// table and the pass-through chord histogram), the mixture rule of Sec. 4.2.3, and its file I/O
/// (container kind "SCAT", version 2, core/serialization.hpp: versioned, checksummed, atomic
/// write; the loader throws grainlight::format_error on truncated, corrupted or inconsistent
/// files). The record lives here, below its builder, so that a renderer that loads statistics
/// from a file never includes the scatterometer or the BVH. Lengths are in units of the
/// bounding-sphere radius.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/serialization.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/phase/tabulated.hpp"

namespace grainlight {

/// Resolution of the scatterometer's tables. Ranges are fixed by the geometry of the unit
/// bounding sphere: offsets along w_i in [-2, 2], across in [0, 2], pass-through chords in [0, 2].
struct ScatterometerGrid {
    std::uint32_t phase_bins = 180;     ///< Phi histogram bins, uniform in theta (1 degree)
    std::uint32_t tt_mu_bins = 24;      ///< TT table: bins in cos theta (uniform in theta)
    std::uint32_t tt_along_bins = 32;   ///< TT table: bins of (x_o - x_i) . w_i on [-2, 2]
    std::uint32_t tt_across_bins = 16;  ///< TT table: bins of |(x_o - x_i) x w_i| on [0, 2]
    std::uint32_t tt_dphi_bins = 8;     ///< TT table: bins of the relative azimuth on [-pi, pi) (see GrainStats)
    std::uint32_t chord_bins = 64;      ///< pass-through chord histogram on [0, 2]

    /// Fixed table ranges (unit bounding sphere).
    /// @var along_min
    /// Lower end of the TT table's along range (x_o - x_i) . w_i.
    /// @var along_max
    /// Upper end of the along range.
    /// @var across_max
    /// Upper end of the across range |(x_o - x_i) x w_i| (from 0).
    /// @var chord_max
    /// Upper end of the pass-through chord histogram (from 0; the bounding sphere's diameter).
    static constexpr double along_min = -2.0, along_max = 2.0, across_max = 2.0, chord_max = 2.0;

    /// Number of cells of the TT table.
    [[nodiscard]] std::size_t tt_cells() const noexcept {
        return std::size_t(tt_mu_bins) * tt_along_bins * tt_across_bins * tt_dphi_bins;
    }
    /// Same resolution.
    friend bool operator==(const ScatterometerGrid&, const ScatterometerGrid&) = default;

    /// Throws grainlight::invalid_argument for zero or absurd bin counts.
    void validate() const {
        const char* w = "ScatterometerGrid";
        check_argument(phase_bins >= 2 && phase_bins <= 100000, w, "phase_bins", phase_bins, "[2, 100000]");
        check_argument(tt_mu_bins >= 1 && tt_mu_bins <= 1024, w, "tt_mu_bins", tt_mu_bins, "[1, 1024]");
        check_argument(tt_along_bins >= 1 && tt_along_bins <= 1024, w, "tt_along_bins", tt_along_bins, "[1, 1024]");
        check_argument(tt_across_bins >= 1 && tt_across_bins <= 1024, w, "tt_across_bins", tt_across_bins, "[1, 1024]");
        check_argument(tt_dphi_bins >= 1 && tt_dphi_bins <= 64, w, "tt_dphi_bins", tt_dphi_bins, "[1, 64]");
        check_argument(tt_cells() <= (std::size_t(1) << 24), w, "tt cells", tt_cells(), "<= 2^24");
        check_argument(chord_bins >= 1 && chord_bins <= 100000, w, "chord_bins", chord_bins, "[1, 100000]");
    }
    /// Non-throwing form of validate() for loaders: true if every bin count is in range.
    [[nodiscard]] bool valid() const noexcept {
        return phase_bins >= 2 && phase_bins <= 100000 && tt_mu_bins >= 1 && tt_mu_bins <= 1024 && tt_along_bins >= 1 &&
               tt_along_bins <= 1024 && tt_across_bins >= 1 && tt_across_bins <= 1024 && tt_dphi_bins >= 1 &&
               tt_dphi_bins <= 64 &&
               tt_cells() <= (std::size_t(1) << 24) && chord_bins >= 1 && chord_bins <= 100000;
    }
    /// Bin of cos theta on a grid uniform in theta with n bins, ordered by increasing cos theta
    /// (bin 0 = backward). Edges: mu_k = cos(pi (n - k) / n).
    [[nodiscard]] static std::uint32_t mu_bin(double mu, std::uint32_t n) noexcept {
        const double theta = safe_acos(mu);  // [0, pi], 0 = forward
        const auto k = std::uint32_t(std::min(double(n) - 1.0, std::floor(theta / pi_v<double> * double(n))));
        return n - 1 - k;
    }
    /// The n + 1 bin edges of mu_bin, increasing from -1 to 1.
    /// Bin of a relative azimuth dphi in [-pi, pi] among n bins *centred* on -pi + 2 pi k / n
    /// (wrapping around), so that dphi = 0 and pi (planar paths) fall in bin centres for even n.
    [[nodiscard]] static std::uint32_t dphi_bin(double dphi, std::uint32_t n) noexcept {
        const double u = (dphi + pi_v<double>) / (2.0 * pi_v<double>) * double(n) + 0.5;
        const auto k = static_cast<std::int64_t>(std::floor(u));
        return std::uint32_t(((k % std::int64_t(n)) + std::int64_t(n)) % std::int64_t(n));
    }
    /// Centre of dphi bin k: -pi + 2 pi k / n.
    [[nodiscard]] static double dphi_center(std::uint32_t k, std::uint32_t n) noexcept {
        return -pi_v<double> + 2.0 * pi_v<double> * double(k) / double(n);
    }
    /// Edges of n bins of cos theta on [-1, 1], uniform in theta (n + 1 values, ascending from -1 to 1).
    [[nodiscard]] static std::vector<double> mu_edges(std::uint32_t n) {
        std::vector<double> e(n + 1);
        for (std::uint32_t k = 0; k <= n; ++k) e[k] = std::cos(pi_v<double> * double(n - k) / double(n));
        e.front() = -1.0;
        e.back() = 1.0;
        return e;
    }
    /// Bin of x among n equal bins on [lo, hi] (clamped).
    [[nodiscard]] static std::uint32_t uniform_bin(double x, double lo, double hi, std::uint32_t n) noexcept {
        const double u = (x - lo) / (hi - lo) * double(n);
        return std::uint32_t(std::clamp(u, 0.0, double(n) - 1.0));
    }
};

/// Statistics of one grain (or of a mixture) per RGB channel, as per-incident-ray expectations
/// (see the file comment). Use the accessors for the physical quantities.
struct GrainStats {
    /// RGB.
    static constexpr std::size_t channels = 3;
    /// One value per channel.
    using ChannelArray = std::array<double, channels>;

    /// Table resolution.
    ScatterometerGrid grid{};
    std::uint64_t rays = 0;     ///< incident rays traced (for a mixture: the smallest component count)
    double hit = 0;             ///< P(hit) = beta
    double miss_chord = 0;      ///< E[chord * 1{miss}]
    double miss_chord2 = 0;     ///< E[chord^2 * 1{miss}]
    ChannelArray exit{};        ///< P(hit and exit)
    ChannelArray along{};       ///< E[(x_o - x_i) . w_i * 1{exit}]
    ChannelArray along2{};      ///< E[((x_o - x_i) . w_i)^2 * 1{exit}]
    ChannelArray cos_theta{};   ///< E[cos theta * 1{exit}]
    ChannelArray cos_theta2{};  ///< E[cos^2 theta * 1{exit}]
    ChannelArray terminated{};  ///< P(path cut at the bounce limit or leaked through the mesh) (diagnostic; counted as absorbed)
    std::vector<double> chord_hist;                  ///< P(miss and chord bin)
    std::array<std::vector<double>, channels> phase_hist;  ///< P(exit and cos theta bin), per channel
    std::array<std::vector<double>, channels> tt_table;    ///< P(exit and (mu, along, across, dphi) cell), per channel; index ((mu * along_bins + along) * across_bins + across) * dphi_bins + dphi

    /// One-line description: rays and the channel-averaged Meng15 Table 1 quantities.
    [[nodiscard]] std::string to_string() const {
        return "GrainStats[" + std::to_string(rays) + " rays, beta " + grainlight::detail::to_display(beta()) + ", lambda_delta " +
               grainlight::detail::to_display(lambda_delta()) + ", alpha_s " + grainlight::detail::to_display(alpha_s_avg()) + ", lambda_s " + grainlight::detail::to_display(lambda_s_avg()) + ", g " +
               grainlight::detail::to_display(g_avg()) + "]";
    }
    /// Hit probability beta (Meng15 Sec. 4.2.2).
    [[nodiscard]] double beta() const noexcept { return hit; }
    /// Mean pass-through offset lambda_delta (0 if no ray missed).
    [[nodiscard]] double lambda_delta() const noexcept { return hit < 1.0 && miss_chord > 0 ? miss_chord / (1.0 - hit) : 0.0; }
    /// Effective grain albedo alpha_s = P(exit | hit) for channel c.
    [[nodiscard]] double alpha_s(std::size_t c) const noexcept { return hit > 0 ? exit[c] / hit : 0.0; }
    /// Signed mean teleport component E[(x_o - x_i) . w_i | exit] for channel c.
    [[nodiscard]] double teleport_along(std::size_t c) const noexcept { return exit[c] > 0 ? along[c] / exit[c] : 0.0; }
    /// lambda_s = |E[x_o - x_i | exit]| (the perpendicular mean vanishes by symmetry).
    [[nodiscard]] double lambda_s(std::size_t c) const noexcept { return std::abs(teleport_along(c)); }
    /// Mean cosine g of Phi for channel c (from the exact samples, not the histogram).
    [[nodiscard]] double g(std::size_t c) const noexcept { return exit[c] > 0 ? cos_theta[c] / exit[c] : 0.0; }

    // Channel averages, as Table 1 reports them.
    /// Channel mean of alpha_s (Table 1).
    [[nodiscard]] double alpha_s_avg() const noexcept { return avg([&](std::size_t c) { return alpha_s(c); }); }
    /// Channel mean of lambda_s (Table 1).
    [[nodiscard]] double lambda_s_avg() const noexcept { return avg([&](std::size_t c) { return lambda_s(c); }); }
    /// Channel mean of the signed teleport.
    [[nodiscard]] double teleport_along_avg() const noexcept { return avg([&](std::size_t c) { return teleport_along(c); }); }
    /// Channel mean of g.
    [[nodiscard]] double g_avg() const noexcept { return avg([&](std::size_t c) { return g(c); }); }

    // Monte Carlo standard errors (binomial / sample-variance estimates over `rays` incident rays).
    /// Standard error of beta.
    [[nodiscard]] double beta_stderr() const noexcept { return rays ? std::sqrt(hit * (1 - hit) / double(rays)) : 0.0; }
    /// Standard error of lambda_delta.
    [[nodiscard]] double lambda_delta_stderr() const noexcept {
        const double n = (1.0 - hit) * double(rays);
        if (n < 2) return 0.0;
        const double m = lambda_delta(), m2 = miss_chord2 / (1.0 - hit);
        return std::sqrt(std::max(0.0, m2 - m * m) / n);
    }
    /// Standard error of alpha_s(c).
    [[nodiscard]] double alpha_s_stderr(std::size_t c) const noexcept {
        const double n = hit * double(rays), a = alpha_s(c);
        return n > 0 ? std::sqrt(a * (1 - a) / n) : 0.0;
    }
    /// Standard error of teleport_along(c) (and lambda_s(c)).
    [[nodiscard]] double teleport_along_stderr(std::size_t c) const noexcept {
        const double n = exit[c] * double(rays);
        if (n < 2) return 0.0;
        const double m = teleport_along(c), m2 = along2[c] / exit[c];
        return std::sqrt(std::max(0.0, m2 - m * m) / n);
    }
    /// Standard error of g(c).
    [[nodiscard]] double g_stderr(std::size_t c) const noexcept {
        const double n = exit[c] * double(rays);
        if (n < 2) return 0.0;
        const double m = g(c), m2 = cos_theta2[c] / exit[c];
        return std::sqrt(std::max(0.0, m2 - m * m) / n);
    }

    /// The tabulated phase function Phi per channel (histogram on the theta-uniform grid,
    /// normalized per channel). A channel without any exiting ray (alpha_s = 0, where Phi does
    /// not matter) gets an isotropic table.
    template <std::floating_point F = float, class S = RGB>
    [[nodiscard]] TabulatedPhase<F, S> phase() const {
        static_assert(S::size == channels, "the scatterometer records RGB (3 channels)");
        const auto edges = ScatterometerGrid::mu_edges(grid.phase_bins);
        std::vector<S> counts(grid.phase_bins);
        for (std::size_t c = 0; c < channels; ++c) {
            double total = 0;
            for (double v : phase_hist[c]) total += v;
            for (std::size_t i = 0; i < grid.phase_bins; ++i)
                counts[i][c] = total > 0 ? F(phase_hist[c][i] / total) : F((edges[i + 1] - edges[i]) / 2.0);
        }
        return TabulatedPhase<F, S>::from_histogram(std::span<const double>(edges), std::span<const S>(counts));
    }

    /// Check internal consistency (sizes, ranges, sums); throws grainlight::format_error with
    /// `context` (used by the loader) on any violation.
    void check_consistency(const std::string& context) const {
        auto fail = [&](const std::string& what) { raise_error<format_error>(context + ": " + what); };
        if (!grid.valid()) fail("bad grid (bin counts out of range)");
        if (chord_hist.size() != grid.chord_bins) fail("chord histogram size mismatch");
        const double tol = 1e-9;
        auto prob = [&](double p, const char* name) {
            if (!(std::isfinite(p) && p >= -tol && p <= 1 + tol)) fail(std::string(name) + " is not a probability");
        };
        prob(hit, "beta");
        if (!(std::isfinite(miss_chord) && miss_chord >= -tol && miss_chord <= 2 + tol)) fail("miss chord out of range");
        if (!(std::isfinite(miss_chord2) && miss_chord2 >= -tol && miss_chord2 <= 4 + tol)) fail("miss chord^2 out of range");
        for (std::size_t c = 0; c < channels; ++c) {
            if (phase_hist[c].size() != grid.phase_bins) fail("phase histogram size mismatch");
            if (tt_table[c].size() != grid.tt_cells()) fail("TT table size mismatch");
            prob(exit[c], "P(exit)");
            prob(terminated[c], "P(terminated)");
            if (exit[c] > hit + tol) fail("P(exit) exceeds P(hit)");
            if (!(std::isfinite(along[c]) && std::abs(along[c]) <= 2 + tol)) fail("teleport sum out of range");
            if (!(std::isfinite(along2[c]) && along2[c] >= -tol && along2[c] <= 4 + tol)) fail("teleport^2 sum out of range");
            if (!(std::isfinite(cos_theta[c]) && std::abs(cos_theta[c]) <= 1 + tol)) fail("cos sum out of range");
            if (!(std::isfinite(cos_theta2[c]) && cos_theta2[c] >= -tol && cos_theta2[c] <= 1 + tol)) fail("cos^2 sum out of range");
            double s = 0, t = 0;
            for (double v : phase_hist[c]) {
                if (!(std::isfinite(v) && v >= 0)) fail("negative or non-finite phase histogram entry");
                s += v;
            }
            for (double v : tt_table[c]) {
                if (!(std::isfinite(v) && v >= 0)) fail("negative or non-finite TT table entry");
                t += v;
            }
            if (std::abs(s - exit[c]) > 1e-6 || std::abs(t - exit[c]) > 1e-6) fail("histogram sums disagree with P(exit)");
        }
        double m = 0;
        for (double v : chord_hist) {
            if (!(std::isfinite(v) && v >= 0)) fail("negative or non-finite chord histogram entry");
            m += v;
        }
        if (std::abs(m - (1.0 - hit)) > 1e-6) fail("chord histogram sum disagrees with 1 - beta");
    }

private:
    template <class Fn>
    [[nodiscard]] static double avg(Fn&& f) noexcept {
        double s = 0;
        for (std::size_t c = 0; c < channels; ++c) s += f(c);
        return s / double(channels);
    }
};

/// Validate mixing weights for `count` grains (as mix_grain_stats does): sizes equal, every
/// weight finite and >= 0, positive sum. Returns the sum; throws grainlight::invalid_argument.
inline double validate_mix_weights(std::span<const double> weights, std::size_t count) {
    const char* who = "mix_grain_stats";
    check_argument(count >= 1, who, "number of grains", count, ">= 1");
    check_argument(weights.size() == count, who, "weights.size()", weights.size(),
                   "equal to the number of grains (" + std::to_string(count) + ")");
    double wsum = 0;
    for (std::size_t k = 0; k < weights.size(); ++k) {
        check_argument(std::isfinite(weights[k]) && weights[k] >= 0.0, who, "weights[" + std::to_string(k) + "]",
                       weights[k], "finite and >= 0");
        wsum += weights[k];
    }
    check_argument(wsum > 0.0 && std::isfinite(wsum), who, "sum of weights", wsum, "> 0");
    return wsum;
}

/// Statistics of a mixture of grains (Meng15 Sec. 4.2.3): a bounding sphere holds grain k with
/// probability weights[k] / sum(weights). Because GrainStats stores per-incident-ray
/// expectations, the mixture is the weighted average of the stored arrays; the derived
/// quantities are then the correctly conditioned averages (alpha_s weighted by w_k beta_k,
/// lambda_s and Phi by w_k beta_k alpha_k, lambda_delta by w_k (1 - beta_k)); for grains of
/// equal beta and alpha_s this is the plain weighted average of the paper. Throws
/// grainlight::invalid_argument if the lists are empty or of different sizes, a weight is
/// negative or not finite, the weights do not sum to a positive number, or the grids differ.
[[nodiscard]] inline GrainStats mix_grain_stats(std::span<const GrainStats> stats, std::span<const double> weights) {
    const char* who = "mix_grain_stats";
    const double wsum = validate_mix_weights(weights, stats.size());
    GrainStats m;
    m.grid = stats[0].grid;
    m.rays = std::numeric_limits<std::uint64_t>::max();
    m.chord_hist.assign(m.grid.chord_bins, 0.0);
    for (std::size_t c = 0; c < 3; ++c) {
        m.phase_hist[c].assign(m.grid.phase_bins, 0.0);
        m.tt_table[c].assign(m.grid.tt_cells(), 0.0);
    }
    for (std::size_t k = 0; k < stats.size(); ++k) {
        const GrainStats& s = stats[k];
        check_argument(s.grid == m.grid, who, "grid of grain " + std::to_string(k), k, "the same ScatterometerGrid for all grains");
        const double w = weights[k] / wsum;
        if (weights[k] > 0) m.rays = std::min(m.rays, s.rays);
        m.hit += w * s.hit;
        m.miss_chord += w * s.miss_chord;
        m.miss_chord2 += w * s.miss_chord2;
        for (std::size_t i = 0; i < m.chord_hist.size(); ++i) m.chord_hist[i] += w * s.chord_hist[i];
        for (std::size_t c = 0; c < 3; ++c) {
            m.exit[c] += w * s.exit[c];
            m.along[c] += w * s.along[c];
            m.along2[c] += w * s.along2[c];
            m.cos_theta[c] += w * s.cos_theta[c];
            m.cos_theta2[c] += w * s.cos_theta2[c];
            m.terminated[c] += w * s.terminated[c];
            for (std::size_t i = 0; i < m.phase_hist[c].size(); ++i) m.phase_hist[c][i] += w * s.phase_hist[c][i];
            for (std::size_t i = 0; i < m.tt_table[c].size(); ++i) m.tt_table[c][i] += w * s.tt_table[c][i];
        }
    }
    return m;
}

/// Container kind and version of scatterometer files.
inline constexpr std::uint32_t grain_stats_kind = fourcc("SCAT");
/// Payload layout version of SCAT files.
inline constexpr std::uint32_t grain_stats_version = 2;

/// Serialize to the container payload (see save_grain_stats).
[[nodiscard]] inline std::vector<unsigned char> encode_grain_stats(const GrainStats& s) {
    ByteWriter w;
    const auto& g = s.grid;
    w.put(g.phase_bins).put(g.tt_mu_bins).put(g.tt_along_bins).put(g.tt_across_bins).put(g.tt_dphi_bins).put(g.chord_bins);
    w.put(s.rays).put(s.hit).put(s.miss_chord).put(s.miss_chord2);
    for (const auto* a : {&s.exit, &s.along, &s.along2, &s.cos_theta, &s.cos_theta2, &s.terminated})
        w.put_array(a->data(), a->size());
    w.put_array(s.chord_hist.data(), s.chord_hist.size());
    for (std::size_t c = 0; c < 3; ++c) w.put_array(s.phase_hist[c].data(), s.phase_hist[c].size());
    for (std::size_t c = 0; c < 3; ++c) w.put_array(s.tt_table[c].data(), s.tt_table[c].size());
    return w.take();
}

/// Parse a payload; throws grainlight::format_error (naming `context`) on any inconsistency.
[[nodiscard]] inline GrainStats decode_grain_stats(const std::vector<unsigned char>& payload, const std::string& context) {
    ByteReader r(payload, context);
    GrainStats s;
    auto& g = s.grid;
    g.phase_bins = r.get<std::uint32_t>();
    g.tt_mu_bins = r.get<std::uint32_t>();
    g.tt_along_bins = r.get<std::uint32_t>();
    g.tt_across_bins = r.get<std::uint32_t>();
    g.tt_dphi_bins = r.get<std::uint32_t>();
    g.chord_bins = r.get<std::uint32_t>();
    if (!g.valid()) r.fail("bad grid (bin counts out of range)");
    s.rays = r.get<std::uint64_t>();
    s.hit = r.get<double>();
    s.miss_chord = r.get<double>();
    s.miss_chord2 = r.get<double>();
    for (auto* a : {&s.exit, &s.along, &s.along2, &s.cos_theta, &s.cos_theta2, &s.terminated}) {
        std::vector<double> tmp;
        r.get_array(tmp, 3);
        std::copy(tmp.begin(), tmp.end(), a->begin());
    }
    r.get_array(s.chord_hist, g.chord_bins);
    for (std::size_t c = 0; c < 3; ++c) r.get_array(s.phase_hist[c], g.phase_bins);
    for (std::size_t c = 0; c < 3; ++c) r.get_array(s.tt_table[c], g.tt_cells());
    r.expect_end();
    if (s.rays == 0) r.fail("zero rays");
    s.check_consistency(context);
    return s;
}

/// Save statistics to `path` (container kind "SCAT" v2, checksummed, written atomically).
/// Throws grainlight::io_error if the file cannot be written.
inline void save_grain_stats(const std::filesystem::path& path, const GrainStats& s) {
    write_container_atomic(path, grain_stats_kind, grain_stats_version, encode_grain_stats(s));
}

/// Load statistics saved by save_grain_stats. Throws grainlight::io_error if the file cannot be
/// read and grainlight::format_error if it is truncated, corrupted, of another kind/version, or
/// internally inconsistent.
[[nodiscard]] inline GrainStats load_grain_stats(const std::filesystem::path& path) {
    const auto payload = read_container(path, grain_stats_kind, grain_stats_version);
    return decode_grain_stats(payload, "'" + path.string() + "'");
}

}  // namespace grainlight
