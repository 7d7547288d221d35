/// @file grainlight/media/shell.hpp
/// Moon07 shell transport functions (Moon, Walter & Marschner, EGSR 2007, Secs. 3.3-4.3): the
/// factored table `ShellTable` (what precompute/shell_builder.hpp produces and saves) and the
/// medium policy `ShellMedium` that advances paths in large strides with it (Fig. 5).
///
/// ## Shell transport function (Sec. 3.3)
/// For a path passing through x in direction omega, T_r(y, omega') is the density of the point y
/// where it *first* exits the sphere S_r of radius r centred at x and of its direction omega' there,
/// per unit area dA(y) times projected solid angle d mu(omega') about the outward normal n = (y-x)/r.
/// In a homogeneous isotropic medium it depends on three coordinates only:
///   - cos theta_1 = dot(n, omega)                        (where on the shell, +1 = straight ahead);
///   - (omega'_u, omega'_v) in [0,1]^2: omega' in the local frame (e1, e2, n) at y, with e1 the unit
///     tangent toward omega (e1 = normalize(omega - cos theta_1 n)), e2 = n x e1, projected to the
///     unit disk (a, b) = (omega'.e1, omega'.e2) and mapped to the square by the inverse of the
///     Shirley-Chiu concentric map [SC97]. Both maps preserve area up to a constant, so
///     d mu = pi d omega'_u d omega'_v and dA = r^2 d cos theta_1 d phi.
/// The table splits the fate of a path started at (x, omega) at every shell radius r_i into:
///   - p_unscattered = f_a(r_i): it reaches the shell with no event (Fig. 5's straight step),
///   - p_scattered: it first exits after at least one event; the exit density is stored,
///   - p_absorbed: it is absorbed before it exits (our addition; the paper's media do not absorb).
/// p_unscattered + p_scattered + p_absorbed = 1.
///
/// ## Factored storage (Sec. 4.1)
/// The scattered-exit density on a grid of n_c x n_u x n_v cells (cell-centred values, piecewise
/// constant) is stored as a non-negative factorization V ~ W H (NMF [LS00]): rows of V are
/// (shell i, cos theta_1 cell j), columns are (omega'_u, omega'_v) cells. W is
/// (n_shells n_c) x rank, H is rank x (n_u n_v). Sampling uses the factors directly: a cos theta_1
/// cell from the marginal p_r(y), then a term k with probability W_jk |H_k| / sum, then a direction
/// cell from H_k (this draws exactly from the normalized product W H).
///
/// ## Attenuation f_a(d) (Sec. 4.1)
/// f_a(d) is the probability that a ray from a typical point of a path continues unimpeded (no
/// scattering, refraction or absorption event) for a distance d, tabulated on a uniform grid in
/// [0, fa_d_max] and interpolated linearly.
///
/// Units: lengths in the units the table was built in (e.g. grain radii or 1/sigma_t).
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/core/serialization.hpp"

namespace grainlight {

namespace detail {

// inverse_disk_concentric moved to core/warp.hpp (next to sample_uniform_disk_concentric).
using ::grainlight::inverse_disk_concentric;

/// Tangent e1 of the Moon07 exit frame at a shell point with unit normal n, for the start
/// direction omega (unit): normalize(omega - dot(n, omega) n), or any unit tangent if n ~ +-omega.
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> shell_exit_tangent(const Vec3<F>& n, const Vec3<F>& omega) noexcept {
    const Vec3<F> t = omega - glm::dot(n, omega) * n;
    const F l2 = glm::dot(t, t);
    if (l2 > F(1e-20)) return t / std::sqrt(l2);
    return Frame<F>(n).s;
}

}  // namespace detail

/// Coordinates of a shell exit (Moon07 Sec. 4.1): cos theta_1 in [-1, 1] and (u, v) in [0,1]^2.
template <std::floating_point F>
struct ShellCoords {
    /// cos theta_1 = n . omega, n = (y - x) / r the exit point's outward shell normal, in [-1, 1].
    F cos_theta1 = F(0);
    /// First concentric-disk coordinate in [0, 1] of the exit direction's projection on the tangent
    /// plane at y (axes e1 = the tangent part of omega, e2 = n x e1).
    F u = F(0.5);
    /// Second concentric-disk coordinate in [0, 1] of the exit direction (see u).
    F v = F(0.5);
};

/// The Moon07 exit coordinates of exit point y (|y - x| = r) and outgoing unit direction w_out
/// for a path that passed through x in unit direction omega (see the file comment).
template <std::floating_point F>
[[nodiscard]] inline ShellCoords<F> shell_coords(const Vec3<F>& x, const Vec3<F>& omega, const Vec3<F>& y,
                                                 const Vec3<F>& w_out) noexcept {
    const Vec3<F> n = glm::normalize(y - x);
    const Vec3<F> e1 = detail::shell_exit_tangent(n, omega);
    const Vec3<F> e2 = glm::cross(n, e1);
    ShellCoords<F> c;
    c.cos_theta1 = std::clamp(glm::dot(n, omega), F(-1), F(1));
    Vec2<F> disk(glm::dot(w_out, e1), glm::dot(w_out, e2));
    const F l2 = disk.x * disk.x + disk.y * disk.y;
    if (l2 > F(1)) disk /= std::sqrt(l2);
    const Vec2<F> uv = detail::inverse_disk_concentric(disk);
    c.u = uv.x;
    c.v = uv.y;
    return c;
}

/// Inverse of shell_coords: the exit point y and direction w_out for coordinates `c` and the
/// azimuth phi of y about omega (uniform in [0, 2 pi) by symmetry).
template <std::floating_point F>
inline void shell_exit_from_coords(const Vec3<F>& x, const Vec3<F>& omega, F r, const ShellCoords<F>& c, F phi,
                                   Vec3<F>& y, Vec3<F>& w_out) noexcept {
    const Frame<F> fr(omega);
    const F s = safe_sqrt(F(1) - c.cos_theta1 * c.cos_theta1);
    const Vec3<F> n = fr.to_world(Vec3<F>(s * std::cos(phi), s * std::sin(phi), c.cos_theta1));
    y = x + r * n;
    const Vec3<F> e1 = detail::shell_exit_tangent(n, omega);
    const Vec3<F> e2 = glm::cross(n, e1);
    const Vec2<F> d = sample_uniform_disk_concentric(Vec2<F>(c.u, c.v));
    const F z = safe_sqrt(F(1) - d.x * d.x - d.y * d.y);
    w_out = glm::normalize(d.x * e1 + d.y * e2 + z * n);
}

/// How the n_c cells of a shell table divide cos theta_1 in [-1, 1].
enum class ShellCosCells : std::int32_t {
    /// Equal widths in cos theta_1 (SHEL v1 tables): the forward cell spans theta_1 up to
    /// acos(1 - 2 / n_c) (23.6 deg at n_c = 24), wider than the forward peak of small shells in
    /// strongly forward-scattering media.
    uniform_cos = 0,
    /// Equal widths in theta_1 (edges cos(pi j / n_c)): 180 / n_c deg everywhere, so the forward
    /// peak is resolved with the same number of cells (the default of build_shell_table).
    uniform_angle = 1
};

/// The factored shell transport table of Moon07 (see the file comment). Plain data; `validate`
/// checks every invariant, `save`/`load` use the grainlight container (kind SHEL v2; v1 files,
/// which have equal cos theta_1 cells, still load).
struct ShellTable {
    /// Container kind of a saved table ("SHEL").
    static constexpr std::uint32_t file_kind = fourcc("SHEL");
    /// Container version of the saved layout (2: v1 + the cos-cell layout), checked by load.
    static constexpr std::uint32_t file_kind_version = 2;

    std::vector<double> radii;          ///< shell radii r_i, strictly ascending, > 0
    std::int32_t n_c = 0;               ///< cells in cos theta_1 over [-1, 1]
    std::int32_t n_u = 0;               ///< cells in omega'_u over [0, 1]
    std::int32_t n_v = 0;               ///< cells in omega'_v over [0, 1]
    std::int32_t rank = 0;              ///< number of NMF terms
    /// How the n_c cells divide cos theta_1 (the density is constant per unit cos theta_1 inside a cell).
    ShellCosCells cos_cells = ShellCosCells::uniform_cos;
    std::vector<double> p_unscattered;  ///< per shell: P(reach r_i with no event) = f_a(r_i)
    std::vector<double> p_scattered;    ///< per shell: P(first exit after >= 1 event)
    std::vector<double> p_absorbed;     ///< per shell: P(absorbed before the exit)
    std::vector<double> W;              ///< (n_shells n_c) x rank, row-major, >= 0
    std::vector<double> H;              ///< rank x (n_u n_v), row-major, >= 0
    double fa_d_max = 0;                ///< f_a is tabulated on [0, fa_d_max]
    std::vector<double> fa;             ///< f_a(j fa_d_max / (size-1)), non-increasing, fa[0] = 1
    std::uint64_t n_paths = 0;          ///< paths the table was estimated from (information)

    /// Number of shells (radii.size()).
    [[nodiscard]] std::size_t n_shells() const noexcept { return radii.size(); }
    /// Number of direction cells n_u n_v (columns of H).
    [[nodiscard]] std::size_t n_dir() const noexcept { return std::size_t(n_u) * std::size_t(n_v); }

    /// Coordinate in [0, 1] (cell j covers [j / n_c, (j + 1) / n_c)) of cos theta_1 under the
    /// table's cell layout; 1 is straight ahead.
    [[nodiscard]] static double cos_cell_coordinate(ShellCosCells layout, double cos_theta1) noexcept {
        const double c = std::clamp(cos_theta1, -1.0, 1.0);
        return layout == ShellCosCells::uniform_angle ? 1.0 - std::acos(c) / pi_v<double> : 0.5 * (c + 1.0);
    }
    /// cos theta_1 at cell coordinate t in [0, 1] (inverse of cos_cell_coordinate).
    [[nodiscard]] static double cos_from_cell_coordinate(ShellCosCells layout, double t) noexcept {
        t = std::clamp(t, 0.0, 1.0);
        return layout == ShellCosCells::uniform_angle ? -std::cos(pi_v<double> * t) : 2.0 * t - 1.0;
    }
    /// cos theta_1 at the lower edge of cos cell j in [0, n_c] (edge n_c is +1).
    [[nodiscard]] double cos_cell_edge(int j) const noexcept {
        if (j <= 0) return -1.0;
        if (j >= n_c) return 1.0;
        return cos_from_cell_coordinate(cos_cells, double(j) / double(n_c));
    }
    /// Index of the cos cell holding cos theta_1.
    [[nodiscard]] std::size_t cos_cell(double cos_theta1) const noexcept {
        const double t = cos_cell_coordinate(cos_cells, cos_theta1);
        if (!(t > 0)) return 0;
        return std::min(std::size_t(n_c) - 1, std::size_t(t * double(n_c)));
    }

    /// Throws grainlight::invalid_argument naming the first violated invariant.
    void validate() const {
        constexpr const char* where = "ShellTable";
        check_argument(!radii.empty() && radii.size() < 4096, where, "radii.size()", radii.size(), "[1, 4096)");
        for (std::size_t i = 0; i < radii.size(); ++i) {
            check_argument(std::isfinite(radii[i]) && radii[i] > 0 && (i == 0 || radii[i] > radii[i - 1]), where,
                           "radii[" + std::to_string(i) + "]", radii[i], "finite, > 0, strictly ascending");
        }
        check_argument(n_c >= 1 && n_c <= 4096, where, "n_c", n_c, "[1, 4096]");
        check_argument(n_u >= 1 && n_u <= 4096, where, "n_u", n_u, "[1, 4096]");
        check_argument(n_v >= 1 && n_v <= 4096, where, "n_v", n_v, "[1, 4096]");
        check_argument(rank >= 1 && rank <= 1024, where, "rank", rank, "[1, 1024]");
        check_argument(cos_cells == ShellCosCells::uniform_cos || cos_cells == ShellCosCells::uniform_angle, where,
                       "cos_cells", std::int32_t(cos_cells), "0 (uniform_cos) or 1 (uniform_angle)");
        const std::size_t ns = n_shells();
        check_argument(p_unscattered.size() == ns && p_scattered.size() == ns && p_absorbed.size() == ns, where,
                       "probability arrays size", p_scattered.size(), "== number of shells");
        for (std::size_t i = 0; i < ns; ++i) {
            const double a = p_unscattered[i], b = p_scattered[i], c = p_absorbed[i];
            check_argument(a >= 0 && b >= 0 && c >= 0 && std::abs(a + b + c - 1.0) < 1e-6, where,
                           "p_unscattered + p_scattered + p_absorbed of shell " + std::to_string(i), a + b + c,
                           "1 with every term >= 0");
        }
        check_argument(W.size() == ns * std::size_t(n_c) * std::size_t(rank), where, "W.size()", W.size(),
                       "n_shells * n_c * rank");
        check_argument(H.size() == std::size_t(rank) * n_dir(), where, "H.size()", H.size(), "rank * n_u * n_v");
        for (double w : W) check_argument(std::isfinite(w) && w >= 0, where, "W entry", w, "finite, >= 0");
        for (double h : H) check_argument(std::isfinite(h) && h >= 0, where, "H entry", h, "finite, >= 0");
        for (std::size_t i = 0; i < ns; ++i) {
            if (p_scattered[i] <= 0) continue;
            double m = 0;
            for (std::size_t j = 0; j < std::size_t(n_c); ++j)
                for (std::size_t k = 0; k < std::size_t(rank); ++k) m += W[(i * n_c + j) * rank + k];
            check_argument(m > 0, where, "W block of shell " + std::to_string(i), m,
                           "> 0 when p_scattered > 0 (the exit density must not vanish)");
        }
        check_argument(std::isfinite(fa_d_max) && fa_d_max > 0, where, "fa_d_max", fa_d_max, "finite, > 0");
        check_argument(fa.size() >= 2 && fa.size() <= (1u << 24), where, "fa.size()", fa.size(), "[2, 2^24]");
        for (std::size_t j = 0; j < fa.size(); ++j)
            check_argument(fa[j] >= 0 && fa[j] <= 1 && (j == 0 || fa[j] <= fa[j - 1]), where,
                           "fa[" + std::to_string(j) + "]", fa[j], "[0, 1], non-increasing");
    }

    /// Serialize (layout v2: u32 n_shells, i32 n_c, n_u, n_v, rank, cos_cells, u64 n_paths, f64
    /// fa_d_max, u64 fa size, then f64 arrays radii, p_unscattered, p_scattered, p_absorbed, W, H,
    /// fa; v1 had no cos_cells field and equal cos cells).
    [[nodiscard]] std::vector<unsigned char> to_payload() const {
        validate();
        ByteWriter w;
        w.put(std::uint32_t(n_shells()));
        w.put(n_c);
        w.put(n_u);
        w.put(n_v);
        w.put(rank);
        w.put(std::int32_t(cos_cells));
        w.put(n_paths);
        w.put(fa_d_max);
        w.put(std::uint64_t(fa.size()));
        for (const auto* v : {&radii, &p_unscattered, &p_scattered, &p_absorbed, &W, &H, &fa})
            w.put_array(v->data(), v->size());
        return w.take();
    }

    /// Parse and validate a payload (layout `version` 2, or 1: equal cos cells);
    /// grainlight::format_error on any malformed content.
    [[nodiscard]] static ShellTable from_payload(const std::vector<unsigned char>& payload,
                                                 const std::string& context = "shell table",
                                                 std::uint32_t version = file_kind_version) {
        ByteReader r(payload, context);
        ShellTable t;
        const auto ns = r.get<std::uint32_t>();
        t.n_c = r.get<std::int32_t>();
        t.n_u = r.get<std::int32_t>();
        t.n_v = r.get<std::int32_t>();
        t.rank = r.get<std::int32_t>();
        if (version >= 2) {
            const auto layout = r.get<std::int32_t>();
            if (layout != 0 && layout != 1) r.fail("unknown cos-cell layout " + std::to_string(layout));
            t.cos_cells = ShellCosCells(layout);
        }
        t.n_paths = r.get<std::uint64_t>();
        t.fa_d_max = r.get<double>();
        const auto nfa = r.get<std::uint64_t>();
        if (ns == 0 || ns >= 4096 || t.n_c < 1 || t.n_c > 4096 || t.n_u < 1 || t.n_u > 4096 || t.n_v < 1 ||
            t.n_v > 4096 || t.rank < 1 || t.rank > 1024)
            r.fail("table dimensions out of range");
        r.get_array(t.radii, ns);
        r.get_array(t.p_unscattered, ns);
        r.get_array(t.p_scattered, ns);
        r.get_array(t.p_absorbed, ns);
        r.get_array(t.W, std::uint64_t(ns) * std::uint64_t(t.n_c) * std::uint64_t(t.rank));
        r.get_array(t.H, std::uint64_t(t.rank) * std::uint64_t(t.n_u) * std::uint64_t(t.n_v));
        r.get_array(t.fa, nfa);
        r.expect_end();
#if GRAINLIGHT_HAS_EXCEPTIONS
        try {
            t.validate();
        } catch (const invalid_argument& e) {
            raise_error<format_error>(context + ": invalid content: " + e.what());
        }
#else
        t.validate();
#endif
        return t;
    }

    /// Write atomically to `path` (container kind SHEL v1). Throws invalid_argument if the table
    /// is invalid, io_error if the file cannot be written.
    void save(const std::filesystem::path& path) const {
        write_container_atomic(path, file_kind, file_kind_version, to_payload());
    }
    /// Load a table (SHEL v2, or v1 with equal cos cells); format_error on truncated/corrupt/
    /// wrong-kind files, io_error if unreadable.
    [[nodiscard]] static ShellTable load(const std::filesystem::path& path) {
        const std::string context = "shell table '" + path.string() + "'";
#if GRAINLIGHT_HAS_EXCEPTIONS
        try {
            return from_payload(read_container(path, file_kind, file_kind_version), context);
        } catch (const format_error& e) {
            // A v1 file (equal cos cells): only if the container says exactly that.
            std::vector<unsigned char> v1;
            try {
                v1 = read_container(path, file_kind, 1);
            } catch (const format_error&) {
                throw e;
            }
            return from_payload(v1, context, 1);
        }
#else
        return from_payload(read_container(path, file_kind, file_kind_version), context);
#endif
    }
};

/// Distance-to-boundary query of an unbounded medium (always +inf).
template <std::floating_point F>
struct InfiniteBoundary {
    /// +inf for every point (no boundary).
    [[nodiscard]] F operator()(const Vec3<F>&) const noexcept { return std::numeric_limits<F>::infinity(); }
};

/// What `ShellMedium::step` did (Moon07 Fig. 5, one call of advanceRayUsingShells).
enum class ShellStepKind : std::uint8_t {
    straight,   ///< no event within the shell: moved by r along omega (probability f_a)
    scattered,  ///< exit point and direction sampled from T_r
    absorbed,   ///< analog absorption inside the shell (only with analog_absorption)
    escaped,    ///< a straight step reached the boundary (distance t_boundary < r)
    exited      ///< the sampled exit point lies outside the volume: leave along y - x (Fig. 5)
};

/// Result of one shell step.
template <std::floating_point F>
struct ShellStep {
    /// What the step did.
    ShellStepKind kind = ShellStepKind::straight;
    int shell = 0;             ///< index of the shell used
    F r = F(0);                ///< its radius
    Vec3<F> p{F(0)};           ///< new position
    Vec3<F> w{F(0)};           ///< new direction
    Vec3<F> w_table{F(0)};     ///< direction sampled from T_r (differs from w for `exited`: w = y - x there)
    F weight = F(1);           ///< throughput factor (1 - P(absorbed | event)) unless analog
    F direction_pdf = F(0);    ///< solid-angle pdf of w given p (scattered steps)
};

/// Moon07's shell medium (Fig. 5): from a point, use the largest shell radius r_i that fits
/// (r_i <= boundary(p), the user's distance-to-boundary query; the smallest shell r_0 if none
/// fits), go straight by r with probability f_a(min(r, t_boundary)), otherwise sample the exit
/// point and direction from T_r. Absorption inside the shell is carried as the throughput factor
/// 1 - P_a / (P_a + P_s) (or, with `analog_absorption`, as an absorption event with that
/// probability).
///
/// Medium concept: `sample_interaction(ray, t_max, rng)` reports a straight step as a `null`
/// event at ray(r), a straight step that reaches t_max < r as `escape`, a sampled exit as
/// `scatter` with `has_direction` (the exit direction and its solid-angle pdf) and
/// `nee = NeeKind::custom` (use attenuation / exit_position_density / exit_direction_density),
/// absorption as `absorb`. Limitation of the concept: a sampled exit point outside the medium
/// (possible only when even r_0 does not fit) cannot be expressed as a teleport out of the medium;
/// it is reported as `escape` at t_max (the path leaves along its old direction), whereas Moon07
/// Fig. 5 leaves along y - x. `step()` implements the paper's rule when given an inside test.
///
/// Thread-safe const queries; no allocation or exceptions per sample.
template <std::floating_point F = double, SpectrumType S = Spectrum<1, F>, class Boundary = InfiniteBoundary<F>>
class ShellMedium {
public:
    /// Floating-point type.
    using Float = F;
    /// Spectrum type of weights.
    using Spectrum = S;

    /// \param table validated Moon07 table (invalid_argument otherwise)
    /// \param boundary distance-to-boundary query F(const Vec3<F>&) (>= 0 inside; < 0 outside)
    /// \param analog_absorption absorb with probability P_a/(P_a+P_s) instead of weighting
    explicit ShellMedium(ShellTable table, Boundary boundary = {}, bool analog_absorption = false)
        : t_(std::move(table)), boundary_(std::move(boundary)), analog_(analog_absorption) {
        t_.validate();
        const std::size_t ns = t_.n_shells(), nc = std::size_t(t_.n_c), K = std::size_t(t_.rank);
        const std::size_t nd = t_.n_dir();
        h_sum_.assign(K, 0.0);
        for (std::size_t k = 0; k < K; ++k) {
            for (std::size_t q = 0; q < nd; ++q) h_sum_[k] += t_.H[k * nd + q];
            if (h_sum_[k] > 0)
                h_dist_.emplace_back(std::span<const double>(t_.H.data() + k * nd, nd));
            else
                h_dist_.emplace_back();  // dead term: never chosen (its weight below is 0)
        }
        row_mass_.assign(ns * nc, 0.0);
        shell_mass_.assign(ns, 0.0);
        std::vector<double> wk(K);
        for (std::size_t i = 0; i < ns; ++i) {
            for (std::size_t j = 0; j < nc; ++j) {
                const std::size_t row = i * nc + j;
                for (std::size_t k = 0; k < K; ++k) {
                    wk[k] = t_.W[row * K + k] * h_sum_[k];
                    row_mass_[row] += wk[k];
                }
                if (row_mass_[row] > 0)
                    term_dist_.emplace_back(std::span<const double>(wk));
                else
                    term_dist_.emplace_back();  // never chosen (zero marginal)
                shell_mass_[i] += row_mass_[row];
            }
            if (shell_mass_[i] > 0)
                c_dist_.emplace_back(std::span<const double>(row_mass_.data() + i * nc, nc));
            else
                c_dist_.emplace_back();  // p_scattered = 0: never sampled
        }
    }

    /// The shell table (validated).
    [[nodiscard]] const ShellTable& table() const noexcept { return t_; }
    /// The distance-to-boundary query.
    [[nodiscard]] const Boundary& boundary() const noexcept { return boundary_; }

    /// Index of the largest shell with r_i <= dist (0 if none fits).
    [[nodiscard]] int select_shell(F dist) const noexcept {
        int best = 0;
        for (std::size_t i = 0; i < t_.n_shells(); ++i)
            if (F(t_.radii[i]) <= dist) best = int(i);
        return best;
    }

    /// f_a(d): probability of continuing unimpeded for a distance d >= 0 (linear interpolation;
    /// beyond fa_d_max an exponential tail fitted to the last quarter of the table).
    [[nodiscard]] F attenuation(F d) const noexcept {
        const std::size_t n = t_.fa.size();
        if (!(d > F(0))) return F(1);
        const F dx = F(t_.fa_d_max) / F(n - 1);
        const F x = d / dx;
        if (x < F(n - 1)) {
            const auto j = std::size_t(x);
            const F a = x - F(j);
            return F(t_.fa[j]) * (F(1) - a) + F(t_.fa[j + 1]) * a;
        }
        const std::size_t j0 = (3 * (n - 1)) / 4;
        const F f1 = F(t_.fa[n - 1]), f0 = F(t_.fa[j0]);
        if (!(f1 > F(0)) || !(f0 > f1)) return f1;
        const F kappa = std::log(f0 / f1) / (F(n - 1 - j0) * dx);
        return f1 * std::exp(-kappa * (d - F(t_.fa_d_max)));
    }

    /// Marginal exit-position density p_r(y) of shell i per unit area of S_r (scattered exits,
    /// including their probability p_scattered): Moon07 Sec. 4.3's p_r(y = x_l).
    [[nodiscard]] F exit_position_density(int i, F cos_theta1) const noexcept {
        const std::size_t nc = std::size_t(t_.n_c);
        const std::size_t j = t_.cos_cell(double(cos_theta1));
        const double m = shell_mass_[std::size_t(i)];
        if (!(m > 0)) return F(0);
        const F dc = F(t_.cos_cell_edge(int(j) + 1) - t_.cos_cell_edge(int(j)));  // cell width in cos theta_1
        const F r = F(t_.radii[std::size_t(i)]);
        return F(t_.p_scattered[std::size_t(i)] * row_mass_[std::size_t(i) * nc + j] / m) /
               (dc * F(2) * pi_v<F> * r * r);
    }

    /// Conditional exit-direction density p_r(omega' | y) of shell i per unit *projected* solid
    /// angle about the shell normal (Moon07 Sec. 4.3's p_r(omega_l | x_{i+1})).
    [[nodiscard]] F exit_direction_density(int i, const ShellCoords<F>& c) const noexcept {
        const std::size_t nc = std::size_t(t_.n_c), K = std::size_t(t_.rank), nd = t_.n_dir();
        const std::size_t row = std::size_t(i) * nc + t_.cos_cell(double(c.cos_theta1));
        const double m = row_mass_[row];
        if (!(m > 0)) return F(0);
        const std::size_t q = cell(c.v, std::size_t(t_.n_v)) * std::size_t(t_.n_u) + cell(c.u, std::size_t(t_.n_u));
        double val = 0;
        for (std::size_t k = 0; k < K; ++k) val += t_.W[row * K + k] * t_.H[k * nd + q];
        const F cell_area = F(1) / F(nd);
        return F(val / m) / (cell_area * pi_v<F>);
    }

    /// Sample a scattered exit of shell i for a path at x with direction omega (unit): position
    /// y, direction w_out and the solid-angle pdf of w_out given y. Uses 6 uniforms from rng.
    void sample_exit(int i, const Vec3<F>& x, const Vec3<F>& omega, Rng& rng, Vec3<F>& y, Vec3<F>& w_out,
                     F& dir_pdf) const noexcept {
        const std::size_t nc = std::size_t(t_.n_c), nu = std::size_t(t_.n_u), nv = std::size_t(t_.n_v);
        const std::size_t j = c_dist_[std::size_t(i)].sample(double(rng.uniform<F>()));
        const std::size_t row = std::size_t(i) * nc + j;
        const std::size_t k = term_dist_[row].sample(double(rng.uniform<F>()));
        const std::size_t q = h_dist_[k].sample(double(rng.uniform<F>()));
        ShellCoords<F> c;
        // uniform in cos theta_1 inside the cell (the density is constant per unit area there)
        const F c_lo = F(t_.cos_cell_edge(int(j))), c_hi = F(t_.cos_cell_edge(int(j) + 1));
        c.cos_theta1 = std::clamp(c_lo + rng.uniform<F>() * (c_hi - c_lo), F(-1), F(1));
        c.u = (F(q % nu) + rng.uniform<F>()) / F(nu);
        c.v = (F(q / nu) + rng.uniform<F>()) / F(nv);
        const F phi = F(2) * pi_v<F> * rng.uniform<F>();
        shell_exit_from_coords(x, omega, F(t_.radii[std::size_t(i)]), c, phi, y, w_out);
        const F cos_out = std::max(F(0), glm::dot(w_out, glm::normalize(y - x)));
        dir_pdf = exit_direction_density(i, c) * cos_out;
    }

    /// Sample an exit direction from p_r(omega' | y) of shell i for a given exit point y of the
    /// shell around x (start direction omega); returns it and its solid-angle pdf in `dir_pdf`.
    /// Uses 4 uniforms. (For MIS of Fig. 6's second shadow ray.)
    [[nodiscard]] Vec3<F> sample_direction_at(int i, const Vec3<F>& x, const Vec3<F>& omega, const Vec3<F>& y,
                                              Rng& rng, F& dir_pdf) const noexcept {
        const std::size_t nc = std::size_t(t_.n_c), nu = std::size_t(t_.n_u), nv = std::size_t(t_.n_v);
        const Vec3<F> n = glm::normalize(y - x);
        const F c1 = std::clamp(glm::dot(n, omega), F(-1), F(1));
        const std::size_t row = std::size_t(i) * nc + t_.cos_cell(double(c1));
        dir_pdf = F(0);
        if (!(row_mass_[row] > 0)) return n;
        const std::size_t k = term_dist_[row].sample(double(rng.uniform<F>()));
        const std::size_t q = h_dist_[k].sample(double(rng.uniform<F>()));
        ShellCoords<F> c;
        c.cos_theta1 = c1;
        c.u = (F(q % nu) + rng.uniform<F>()) / F(nu);
        c.v = (F(q / nu) + rng.uniform<F>()) / F(nv);
        const Vec3<F> e1 = detail::shell_exit_tangent(n, omega);
        const Vec3<F> e2 = glm::cross(n, e1);
        const Vec2<F> d = sample_uniform_disk_concentric(Vec2<F>(c.u, c.v));
        const F z = safe_sqrt(F(1) - d.x * d.x - d.y * d.y);
        const Vec3<F> w = glm::normalize(d.x * e1 + d.y * e2 + z * n);
        dir_pdf = exit_direction_density(i, c) * std::max(F(0), glm::dot(w, n));
        return w;
    }

    /// One call of Moon07 Fig. 5 (advanceRayUsingShells) from x along unit omega.
    /// \param x start point (inside the medium)
    /// \param omega unit direction of travel at x
    /// \param t_boundary distance to the medium surface along omega (inf if none)
    /// \param rng random numbers of the path
    /// \param inside optional inside test bool(const Vec3<F>&) for the "outside the volume" rule:
    ///        a sampled exit point outside gets direction normalize(y - x) and kind exited.
    template <class Inside>
    [[nodiscard]] ShellStep<F> step(const Vec3<F>& x, const Vec3<F>& omega, F t_boundary, Rng& rng,
                                    const Inside& inside) const noexcept {
        ShellStep<F> s;
        s.shell = select_shell(boundary_(x));
        s.r = F(t_.radii[std::size_t(s.shell)]);
        const bool near = t_boundary < s.r;
        const F d = near ? t_boundary : s.r;
        const F pu = near ? attenuation(d) : F(t_.p_unscattered[std::size_t(s.shell)]);
        if (rng.uniform<F>() < pu) {
            s.kind = near ? ShellStepKind::escaped : ShellStepKind::straight;
            s.p = x + (near ? t_boundary : s.r) * omega;
            s.w = omega;
            return s;
        }
        const double pa_raw = t_.p_absorbed[std::size_t(s.shell)], ps_raw = t_.p_scattered[std::size_t(s.shell)];
        const F pa = pa_raw + ps_raw > 0 ? F(pa_raw / (pa_raw + ps_raw)) : F(1);
        if (pa >= F(1) || (analog_ && rng.uniform<F>() < pa)) {
            s.kind = ShellStepKind::absorbed;
            s.p = x;
            s.w = omega;
            s.weight = F(0);
            return s;
        }
        if (!analog_) s.weight = F(1) - pa;
        sample_exit(s.shell, x, omega, rng, s.p, s.w, s.direction_pdf);
        s.w_table = s.w;
        s.kind = ShellStepKind::scattered;
        if (!inside(s.p)) {
            s.kind = ShellStepKind::exited;
            s.w = glm::normalize(s.p - x);
        }
        return s;
    }
    /// Fig. 5 step in a medium whose boundary query says where the outside is (boundary(p) < 0).
    [[nodiscard]] ShellStep<F> step(const Vec3<F>& x, const Vec3<F>& omega, F t_boundary, Rng& rng) const noexcept {
        return step(x, omega, t_boundary, rng, [this](const Vec3<F>& p) { return !(boundary_(p) < F(0)); });
    }

    /// Medium concept: one shell step along `ray` (see the class comment).
    [[nodiscard]] Interaction<F, S> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        Interaction<F, S> it;
        const ShellStep<F> s = step(ray.o, ray.d, t_max, rng, [](const Vec3<F>&) { return true; });
        it.weight = S(s.weight);
        switch (s.kind) {
            case ShellStepKind::straight:
                it.kind = EventKind::null;
                it.t = s.r;
                it.p = s.p;
                return it;
            case ShellStepKind::escaped:
            case ShellStepKind::exited:
                it.kind = EventKind::escape;
                it.t = t_max;
                it.p = ray(t_max);
                return it;
            case ShellStepKind::absorbed:
                it.kind = EventKind::absorb;
                it.t = F(0);
                it.p = ray.o;
                it.weight = S(F(0));
                return it;
            case ShellStepKind::scattered:
                if (boundary_(s.p) < F(0)) {  // teleport out of the medium: see the class comment
                    it.kind = EventKind::escape;
                    it.t = t_max;
                    it.p = ray(t_max);
                    return it;
                }
                it.kind = EventKind::scatter;
                it.t = s.r;
                it.p = s.p;
                it.w = s.w;
                it.direction_pdf = s.direction_pdf;
                it.has_direction = true;
                it.nee = NeeKind::custom;
                return it;
        }
        return it;
    }

    /// Moon07 Fig. 6, first shadow ray: solid-angle density (about x) with which a step from x
    /// along omega (t_boundary: distance to the surface along omega) leaves the medium through a
    /// sampled exit point outside the volume in direction w_l, times the expected throughput
    /// factor: (1 - f_a) P_s / (P_s + P_a) p_r(y_l) / P_s r^2 with y_l = x + r w_l, zero if y_l is
    /// inside (boundary(y_l) >= 0). Multiply by the light's radiance / its pdf for an estimate.
    [[nodiscard]] F exit_escape_density(const Vec3<F>& x, const Vec3<F>& omega, F t_boundary,
                                        const Vec3<F>& w_l) const noexcept {
        const int i = select_shell(boundary_(x));
        const F r = F(t_.radii[std::size_t(i)]);
        const Vec3<F> y = x + r * w_l;
        if (!(boundary_(y) < F(0))) return F(0);
        const F pu = t_boundary < r ? attenuation(t_boundary) : F(t_.p_unscattered[std::size_t(i)]);
        const double pe = t_.p_scattered[std::size_t(i)] + t_.p_absorbed[std::size_t(i)];
        if (!(pe > 0)) return F(0);
        return (F(1) - pu) / F(pe) * exit_position_density(i, glm::dot(w_l, omega)) * r * r;
    }

    /// Probability that steps from p along w go straight (no event) until they leave the medium
    /// at distance t_boundary: the product of p_unscattered of every full straight step (each
    /// with the largest shell fitting at its start) and f_a of the last, partial one. For an
    /// exponential f_a this is f_a(t_boundary); for a discrete medium it is what the shell
    /// process does.
    [[nodiscard]] F straight_chain_transmittance(const Vec3<F>& p, const Vec3<F>& w, F t_boundary) const noexcept {
        F T = F(1);
        Vec3<F> q = p;
        F left = t_boundary;
        for (int k = 0; k < (1 << 20) && T > F(0); ++k) {
            const int i = select_shell(boundary_(q));
            const F r = F(t_.radii[std::size_t(i)]);
            if (left < r) return T * attenuation(left);
            T *= F(t_.p_unscattered[std::size_t(i)]);
            q += r * w;
            left -= r;
        }
        return T;
    }

    /// Moon07 Fig. 6, second shadow ray: after a scattered step from (x, omega) with shell `shell`
    /// landed at y, the solid-angle density with which the path continues along w_l *and* leaves
    /// the medium without another event: p_r(w_l | y) cos straight_chain_transmittance(y, w_l,
    /// d_l), d_l the distance from y to the surface along w_l (the paper writes f_a(d_l), equal
    /// for exponential f_a). An integrator that adds this must not count, by hitting, the
    /// straight escapes of paths whose direction was last set by a scattered step.
    [[nodiscard]] F straight_escape_density(int shell, const Vec3<F>& x, const Vec3<F>& omega, const Vec3<F>& y,
                                            const Vec3<F>& w_l, F d_l) const noexcept {
        const Vec3<F> n = glm::normalize(y - x);
        const F cos_out = glm::dot(w_l, n);
        if (!(cos_out > F(0))) return F(0);
        return exit_direction_density(shell, shell_coords(x, omega, y, w_l)) * cos_out *
               straight_chain_transmittance(y, w_l, d_l);
    }

    /// Medium concept: f_a(t) in every channel (rng unused).
    [[nodiscard]] S transmittance(const Ray<F>&, F t, Rng&) const noexcept { return S(attenuation(t)); }

private:
    [[nodiscard]] static std::size_t cell(F x01, std::size_t n) noexcept {
        if (!(x01 > F(0))) return 0;
        return std::min(n - 1, std::size_t(x01 * F(n)));
    }

    ShellTable t_;
    Boundary boundary_;
    bool analog_ = false;
    std::vector<double> h_sum_, row_mass_, shell_mass_;
    std::vector<DiscreteDistribution<double>> h_dist_, term_dist_, c_dist_;
};

}  // namespace grainlight
