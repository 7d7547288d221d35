/// @file grainlight/precompute/scatterometer.hpp
/// The virtual scatterometer of Meng15 Sec. 4.1-4.2: one grain in its bounding sphere (radius 1),
/// rays distributed uniformly over directions and over the sphere's cross section, a uniformly
/// random grain rotation per ray, paths traced (Fresnel reflection/refraction, interior
/// absorbing/scattering medium, Lambertian surfaces) until they leave the bounding sphere or are
/// absorbed. It records the statistics the teleportation-transport (TT) model and the effective
/// RTE need (Meng15 Sec. 4.2.1-4.2.3, Table 1):
///
///  - beta: hit probability (fraction of incident rays that hit the grain);
///  - lambda_delta: mean pass-through offset |x_o - x_i| of the rays that miss (a chord of the
///    bounding sphere);
///  - alpha_s: effective grain albedo, the fraction of hitting rays that leave the sphere;
///  - lambda_s: length of the mean teleport vector (x_o - x_i) over rays that hit and are not
///    absorbed (Sec. 4.2.2 calls it lambda_t). By the symmetry of the random rotation the mean
///    vector is parallel to the incident direction w_i; we also keep its signed component
///    `teleport_along` = E[(x_o - x_i) . w_i] (negative for grains that mostly back-scatter);
///  - Phi(cos theta): histogram of cos theta = <w_i, w_o> over exiting rays (non-uniform grid,
///    uniform in theta, so both peaks are resolved), per channel;
///  - the joint table of (cos theta, offset along w_i, offset across w_i, relative azimuth) of
///    exiting rays and the pass-through chord histogram, from which media/teleportation.hpp
///    samples TT steps. The relative azimuth is the angle around w_i from the perpendicular part
///    of the offset x_o - x_i to the perpendicular part of w_o (0 or pi for a sphere, whose
///    paths stay in one plane); it keeps the correlation between where and where-to a path exits.
///
/// Everything is per RGB channel (a grey material traces each path once for all channels; a
/// coloured one traces each hitting ray once per channel with its own random stream). All
/// statistics are stored as *per incident ray* expectations (e.g. P(hit and exit and cell)), so
/// the statistics of a mixture of grains (Sec. 4.2.3) are exactly the weighted average of the
/// stored arrays and every derived quantity (alpha_s, lambda_s, Phi, ...) comes out conditioned
/// correctly. Lengths are in units of the bounding-sphere radius.
///
/// Determinism: ray i uses Pcg32::from_key(seed, i, 0) for the incident ray and rotation and
/// Pcg32::from_key(seed, i, 1 + channel) for its path; per-block floating-point partial sums are
/// reduced in block order and histograms are integer counts, so a seed gives bit-identical
/// results on any thread count. OpenMP pragmas compile away without OpenMP.
///
/// Files: `save_grain_stats` / `load_grain_stats` use the shared container of
/// precompute/serialization.hpp (kind "SCAT", version 2): versioned, checksummed, atomic write;
/// the loader throws grainlight::format_error on truncated, corrupted or inconsistent files.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/transform.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/precompute/serialization.hpp"

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
        auto fail = [&](const std::string& what) { detail::raise_error<format_error>(context + ": " + what); };
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

/// A grain placed at the centre of the unit bounding sphere: an analytic sphere of radius R or a
/// triangle mesh (BVH), and its material. Validated at construction: R in (0, 1], mesh vertices
/// within the unit sphere (a grain larger than its bounding sphere is an error).
class ScatterometerGrain {
public:
    /// Analytic sphere of radius `radius` in (0, 1].
    [[nodiscard]] static ScatterometerGrain sphere(double radius, const GrainMaterial& material) {
        check_grain_radius("ScatterometerGrain::sphere", "radius", radius);
        material.validate();
        ScatterometerGrain g;
        g.sphere_radius_ = radius;
        g.material_ = material;
        return g;
    }
    /// Any watertight mesh with outward normals, inside the unit sphere.
    [[nodiscard]] static ScatterometerGrain mesh(const TriangleMesh<float>& mesh, const GrainMaterial& material) {
        const double r = check_grain_mesh("ScatterometerGrain::mesh", mesh);
        material.validate();
        ScatterometerGrain g;
        g.bvh_ = std::make_shared<const Bvh<float>>(mesh);
        g.material_ = material;
        g.mesh_radius_ = r;
        return g;
    }
    /// Procedural grain (geometry/grains.hpp) with bounding radius R in (0, 1]. The sphere shape
    /// uses the analytic sphere.
    [[nodiscard]] static ScatterometerGrain procedural(GrainShape shape, double radius, const GrainMaterial& material,
                                                       std::uint64_t seed = 1, int level = 5) {
        check_grain_radius("ScatterometerGrain::procedural", "grain radius", radius);
        if (shape == GrainShape::sphere) return sphere(radius, material);
        return mesh(make_grain_mesh<float>(shape, float(radius), seed, level), material);
    }

    /// The grain's material.
    [[nodiscard]] const GrainMaterial& material() const noexcept { return material_; }
    /// True for the analytic sphere, false for a mesh.
    [[nodiscard]] bool is_analytic_sphere() const noexcept { return !bvh_; }
    /// Radius of the grain's own (origin-centred) bounding sphere.
    [[nodiscard]] double radius() const noexcept { return bvh_ ? mesh_radius_ : sphere_radius_; }

    /// Closest intersection along o + t d, t in (0, t_max); d unit length. Returns t (or +inf)
    /// and the outward unit normal.
    [[nodiscard]] double intersect(const Vec3d& o, const Vec3d& d, double t_max, Vec3d& n) const noexcept {
        if (!bvh_) {
            double t = 0;
            if (!intersect_sphere_first(o, d, Vec3d(0.0), sphere_radius_, 0.0, t_max, t))
                return std::numeric_limits<double>::infinity();
            n = glm::normalize(o + t * d);
            return t;
        }
        const auto h = bvh_->intersect(Vec3f(o), Vec3f(d), 0.0f, float(std::min(t_max, 1e30)));
        if (!h.valid()) return std::numeric_limits<double>::infinity();
        n = Vec3d(h.n_geom);
        return double(h.t);
    }
    /// Offset used to leave a surface without re-hitting it (meshes: relative to their size, well
    /// above the float round-off of the watertight test).
    [[nodiscard]] double surface_epsilon() const noexcept { return bvh_ ? 2e-5 * mesh_radius_ : 1e-10; }

private:
    ScatterometerGrain() = default;
    std::shared_ptr<const Bvh<float>> bvh_;
    double sphere_radius_ = 1.0;
    double mesh_radius_ = 1.0;
    GrainMaterial material_{};
};

/// Scatterometer settings.
struct ScatterometerConfig {
    std::uint64_t rays = 1000000;  ///< incident rays (>= 1)
    std::uint64_t seed = 1;
    std::uint32_t max_bounces = 10000;  ///< paths longer than this are counted as absorbed (and as `terminated`)
    bool random_rotation = true;        ///< rotate the grain uniformly per ray (Meng15 Sec. 4.1)
    ScatterometerGrid grid{};
    /// Optional progress callback (rays done, total), called from one thread at a time.
    std::function<void(std::uint64_t, std::uint64_t)> progress{};
};

namespace detail {

/// Outcome of tracing one path inside the bounding sphere.
struct ScatterPath {
    enum Kind : std::uint8_t { exited, absorbed, terminated } kind = absorbed;
    Vec3d x_o{0.0};
    Vec3d w_o{0.0};
};

/// Trace a path that has just hit the grain at `p` (outward normal n) travelling along d, for
/// channel c, until it leaves the unit bounding sphere or is absorbed. Analog: absorption and
/// Fresnel choices are random events.
inline ScatterPath trace_grain_path(const ScatterometerGrain& grain, Vec3d p, Vec3d d, Vec3d n, std::size_t c,
                                    std::uint32_t max_bounces, Rng& rng) noexcept {
    const GrainMaterial& m = grain.material();
    const double eps = grain.surface_epsilon();
    const double sigma_a = m.interior_sigma_a[c], sigma_s = m.interior_sigma_s[c], sigma_t = sigma_a + sigma_s;
    const bool medium = m.kind == GrainMaterialKind::absorbing_dielectric && sigma_t > 0;
    ScatterPath out;
    bool on_surface = true;
    for (std::uint32_t bounce = 0; bounce < max_bounces; ++bounce) {
        if (on_surface) {
            // Surface event at p with outward normal n, incoming propagation direction d.
            if (m.kind == GrainMaterialKind::diffuse) {
                if (glm::dot(d, n) > 0 || rng.uniform<double>() >= m.albedo[c]) {
                    out.kind = ScatterPath::absorbed;
                    return out;
                }
                const Frame<double> frame(n);
                d = glm::normalize(frame.to_world(sample_cosine_hemisphere(rng.uniform2<double>())));
            } else {
                const double cos_i = -glm::dot(d, n);  // > 0: arriving from outside
                const double fr = fresnel_dielectric(cos_i, m.ior);
                Vec3d wt(0.0);
                if (rng.uniform<double>() < fr || !refract(-d, n, m.ior, wt)) {
                    d = d - 2.0 * glm::dot(d, n) * n;
                } else {
                    d = glm::normalize(wt);
                }
            }
            p = p + (glm::dot(d, n) >= 0 ? eps : -eps) * n;
        }
        // Inside a dielectric iff moving against the outward normal of the last surface.
        const bool inside = on_surface ? glm::dot(d, n) < 0 : true;
        Vec3d n_next(0.0);
        const double t_hit = grain.intersect(p, d, std::numeric_limits<double>::infinity(), n_next);
        if (inside && medium) {
            const double t_s = sample_exponential(rng.uniform<double>(), sigma_t);
            if (t_s < t_hit) {
                p += t_s * d;
                if (rng.uniform<double>() * sigma_t >= sigma_s) {
                    out.kind = ScatterPath::absorbed;
                    return out;
                }
                const double mu = sample_henyey_greenstein_cos(rng.uniform<double>(), m.interior_g);
                d = glm::normalize(direction_from_cosine(d, mu, 2.0 * pi_v<double> * rng.uniform<double>()));
                on_surface = false;
                continue;
            }
        }
        if (!std::isfinite(t_hit)) {
            if (inside) {  // leaked through the mesh (should not happen for watertight meshes)
                out.kind = ScatterPath::terminated;
                return out;
            }
            // Left the grain: continue to the bounding sphere.
            const auto roots = intersect_sphere(p, d, Vec3d(0.0), 1.0);
            const double t_exit = roots.hit ? std::max(0.0, roots.t_far) : 0.0;
            out.kind = ScatterPath::exited;
            out.x_o = p + t_exit * d;
            out.w_o = d;
            return out;
        }
        p += t_hit * d;
        n = n_next;
        on_surface = true;
    }
    out.kind = ScatterPath::terminated;
    return out;
}

/// Per-block floating-point partial sums (reduced in block order).
struct ScatterBlock {
    double miss_chord = 0, miss_chord2 = 0;
    std::array<double, 3> along{}, along2{}, cos_theta{}, cos_theta2{};
};
/// Integer counts (order-independent reduction).
struct ScatterCounts {
    std::uint64_t hits = 0;
    std::array<std::uint64_t, 3> exits{}, terminated{};
    std::vector<std::uint64_t> chord;
    std::array<std::vector<std::uint64_t>, 3> phase, tt;
    explicit ScatterCounts(const ScatterometerGrid& g) : chord(g.chord_bins) {
        for (std::size_t c = 0; c < 3; ++c) {
            phase[c].assign(g.phase_bins, 0);
            tt[c].assign(g.tt_cells(), 0);
        }
    }
    void add(const ScatterCounts& o) {
        hits += o.hits;
        for (std::size_t c = 0; c < 3; ++c) {
            exits[c] += o.exits[c];
            terminated[c] += o.terminated[c];
            for (std::size_t i = 0; i < phase[c].size(); ++i) phase[c][i] += o.phase[c][i];
            for (std::size_t i = 0; i < tt[c].size(); ++i) tt[c][i] += o.tt[c][i];
        }
        for (std::size_t i = 0; i < chord.size(); ++i) chord[i] += o.chord[i];
    }
};

}  // namespace detail

/// Run the virtual scatterometer (Meng15 Sec. 4.1-4.2) on `grain`. Throws
/// grainlight::invalid_argument for rays == 0 or a bad grid.
[[nodiscard]] inline GrainStats run_scatterometer(const ScatterometerGrain& grain, const ScatterometerConfig& cfg) {
    check_argument(cfg.rays >= 1, "run_scatterometer", "rays", cfg.rays, ">= 1");
    check_argument(cfg.max_bounces >= 1, "run_scatterometer", "max_bounces", cfg.max_bounces, ">= 1");
    cfg.grid.validate();
    const ScatterometerGrid grid = cfg.grid;
    const bool grey = grain.material().is_grey();
    constexpr std::uint64_t block_size = 4096;
    const std::uint64_t n_blocks = (cfg.rays + block_size - 1) / block_size;
    std::vector<detail::ScatterBlock> blocks(static_cast<std::size_t>(n_blocks));
    detail::ScatterCounts total(grid);
    std::uint64_t done = 0;

#if defined(_OPENMP)
#pragma omp parallel
#endif
    {
        detail::ScatterCounts local(grid);
#if defined(_OPENMP)
#pragma omp for schedule(dynamic, 1)
#endif
        for (std::int64_t b = 0; b < std::int64_t(n_blocks); ++b) {
            detail::ScatterBlock& blk = blocks[std::size_t(b)];
            const std::uint64_t begin = std::uint64_t(b) * block_size, end = std::min(cfg.rays, begin + block_size);
            for (std::uint64_t i = begin; i < end; ++i) {
                Rng rng = Rng::from_key(cfg.seed, i, 0);
                // Incident ray: uniform direction, uniform point on the cross-section disk.
                const Vec3d w = sample_uniform_sphere(rng.uniform2<double>());
                const Vec2d q = sample_uniform_disk_concentric(rng.uniform2<double>());
                const Frame<double> frame(w);
                const double r2 = std::min(1.0, q.x * q.x + q.y * q.y);
                const double half_chord = std::sqrt(1.0 - r2);
                Vec3d x_i = frame.to_world(Vec3d(q.x, q.y, -half_chord));
                Vec3d wi = w;
                if (cfg.random_rotation) {
                    const Rotation<double> rot = uniform_random_rotation(
                        Vec3d(rng.uniform<double>(), rng.uniform<double>(), rng.uniform<double>()));
                    x_i = rot.to_local(x_i);  // the grain's frame; all recorded quantities are rotation invariant
                    wi = rot.to_local(wi);
                }
                // Start slightly outside so a grain touching its bounding sphere is not missed.
                const double back = 1e-6;
                Vec3d n(0.0);
                const double t = grain.intersect(x_i - back * wi, wi, 2.0 * half_chord + 2 * back, n);
                if (!std::isfinite(t)) {
                    const double chord = 2.0 * half_chord;
                    blk.miss_chord += chord;
                    blk.miss_chord2 += chord * chord;
                    ++local.chord[grid.uniform_bin(chord, 0.0, ScatterometerGrid::chord_max, grid.chord_bins)];
                    continue;
                }
                ++local.hits;
                const Vec3d p_hit = x_i + (t - back) * wi;
                for (std::size_t c = 0; c < 3; ++c) {
                    if (grey && c > 0) break;
                    Rng path_rng = Rng::from_key(cfg.seed, i, 1 + c);
                    const auto path = detail::trace_grain_path(grain, p_hit, wi, n, grey ? 0 : c, cfg.max_bounces, path_rng);
                    const std::size_t c_end = grey ? 3 : c + 1;
                    for (std::size_t k = c; k < c_end; ++k) {
                        if (path.kind == detail::ScatterPath::terminated) ++local.terminated[k];
                        if (path.kind != detail::ScatterPath::exited) continue;
                        ++local.exits[k];
                        const Vec3d off = path.x_o - x_i;
                        const double a = glm::dot(off, wi);
                        const Vec3d perp = off - a * wi;
                        const double across = glm::length(perp);
                        const double mu = std::clamp(glm::dot(wi, path.w_o), -1.0, 1.0);
                        // Azimuth of the exit direction around w_i relative to the offset's
                        // perpendicular part (0 when either is undefined).
                        const Vec3d w_perp = path.w_o - mu * wi;
                        double dphi = 0.0;
                        if (across > 1e-12 && glm::length(w_perp) > 1e-12) {
                            const Vec3d e1 = perp / across, e2 = glm::cross(wi, e1);
                            dphi = std::atan2(glm::dot(w_perp, e2), glm::dot(w_perp, e1));
                        }
                        blk.along[k] += a;
                        blk.along2[k] += a * a;
                        blk.cos_theta[k] += mu;
                        blk.cos_theta2[k] += mu * mu;
                        ++local.phase[k][ScatterometerGrid::mu_bin(mu, grid.phase_bins)];
                        const std::size_t cell =
                            (std::size_t(ScatterometerGrid::mu_bin(mu, grid.tt_mu_bins)) * grid.tt_along_bins +
                             grid.uniform_bin(a, ScatterometerGrid::along_min, ScatterometerGrid::along_max,
                                              grid.tt_along_bins)) *
                                grid.tt_across_bins +
                            grid.uniform_bin(across, 0.0, ScatterometerGrid::across_max, grid.tt_across_bins);
                        ++local.tt[k][cell * grid.tt_dphi_bins + ScatterometerGrid::dphi_bin(dphi, grid.tt_dphi_bins)];
                    }
                }
            }
            if (cfg.progress) {
#if defined(_OPENMP)
#pragma omp critical(grainlight_scatterometer_progress)
#endif
                {
                    done += end - begin;
                    cfg.progress(done, cfg.rays);
                }
            }
        }
#if defined(_OPENMP)
#pragma omp critical(grainlight_scatterometer_merge)
#endif
        total.add(local);
    }

    // Fixed-order reduction of the floating-point partials.
    detail::ScatterBlock sum;
    for (const auto& b : blocks) {
        sum.miss_chord += b.miss_chord;
        sum.miss_chord2 += b.miss_chord2;
        for (std::size_t c = 0; c < 3; ++c) {
            sum.along[c] += b.along[c];
            sum.along2[c] += b.along2[c];
            sum.cos_theta[c] += b.cos_theta[c];
            sum.cos_theta2[c] += b.cos_theta2[c];
        }
    }
    const double inv_n = 1.0 / double(cfg.rays);
    GrainStats s;
    s.grid = grid;
    s.rays = cfg.rays;
    s.hit = double(total.hits) * inv_n;
    s.miss_chord = sum.miss_chord * inv_n;
    s.miss_chord2 = sum.miss_chord2 * inv_n;
    s.chord_hist.resize(grid.chord_bins);
    for (std::size_t i = 0; i < grid.chord_bins; ++i) s.chord_hist[i] = double(total.chord[i]) * inv_n;
    for (std::size_t c = 0; c < 3; ++c) {
        s.exit[c] = double(total.exits[c]) * inv_n;
        s.terminated[c] = double(total.terminated[c]) * inv_n;
        s.along[c] = sum.along[c] * inv_n;
        s.along2[c] = sum.along2[c] * inv_n;
        s.cos_theta[c] = sum.cos_theta[c] * inv_n;
        s.cos_theta2[c] = sum.cos_theta2[c] * inv_n;
        s.phase_hist[c].resize(grid.phase_bins);
        for (std::size_t i = 0; i < grid.phase_bins; ++i) s.phase_hist[c][i] = double(total.phase[c][i]) * inv_n;
        s.tt_table[c].resize(grid.tt_cells());
        for (std::size_t i = 0; i < grid.tt_cells(); ++i) s.tt_table[c][i] = double(total.tt[c][i]) * inv_n;
    }
    return s;
}

/// Statistics of a mixture of grains (Meng15 Sec. 4.2.3): a bounding sphere holds grain k with
/// probability weights[k] / sum(weights). Because GrainStats stores per-incident-ray
/// expectations, the mixture is the weighted average of the stored arrays; the derived
/// quantities are then the correctly conditioned averages (alpha_s weighted by w_k beta_k,
/// lambda_s and Phi by w_k beta_k alpha_k, lambda_delta by w_k (1 - beta_k)); for grains of
/// equal beta and alpha_s this is the plain weighted average of the paper. Throws
/// grainlight::invalid_argument if the lists are empty or of different sizes, a weight is
/// negative or not finite, the weights do not sum to a positive number, or the grids differ.
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
