/// @file grainlight/precompute/shell_builder.hpp
/// Precomputation of Moon07 shell transport functions (Moon, Walter & Marschner, EGSR 2007,
/// Sec. 4.1): trace paths through explicit random geometry (or a continuous medium), record where
/// and in which direction each path *first* exits spheres of radii r_i around its start point,
/// estimate the exit density with k-nearest-neighbour density estimation on
/// (cos theta_1, omega'_u, omega'_v), and compress it with non-negative matrix factorization.
/// The result is a `ShellTable` (media/shell.hpp) that `ShellMedium` samples.
///
/// Pieces (each usable on its own):
///   - `ShellRecorder`: consumes the straight segments of one path and tallies first exits,
///     unscattered exits, absorption and the first free path (for f_a).
///   - Path sources (anything with `void trace(Rng&, ShellRecorder&) const`):
///       * `ContinuousShellSource<Medium>`: the library's walk kernel (integrators/walk.hpp) in an
///         unbounded homogeneous medium; the start point is a fresh start, which is a typical
///         point of a path because free flights are memoryless.
///       * `SpherePackingShellSource`: explicit glass spheres of an infinitely tiled periodic
///         packing (packing/periodic_tile.hpp first_hit), Fresnel reflection / Snell refraction at
///         every interface, optional absorption inside the grains. The start frame (x, omega) is a
///         point reached after a random burn-in path length (Moon07: "a random point and
///         orientation along each path is chosen ... to avoid correlation between the paths and
///         the geometry").
///       * `GrainAggregateShellSource<Shape>`: the grains of a Meng15 procedural aggregate
///         (traversal/aggregate.hpp; any exemplar mix), traced as EPT does (integrators/ept.hpp).
///   - `collect_shell_samples`: runs n paths of a source (OpenMP over fixed blocks; the result is
///     identical for any thread count).
///   - `knn_density_grid`: k-NN (balloon) density at cell centres (Sec. 4.1, the paper's form);
///     `knn_cell_density_grid`: the sample-point k-NN form giving cell averages (the default of
///     build_shell_table: it conserves the mass of narrow peaks, see its comment).
///   - `nmf`: Lee-Seung multiplicative-update NMF [LS00] (Frobenius norm).
///   - `build_shell_table`: all of the above into a ShellTable + a report.
///
/// Conventions: directions are unit propagation directions; "scattered" means at least one event
/// (scattering, reflection or refraction) happened between the start point and the exit.
/// This header uses Eigen (NMF); media/shell.hpp does not.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/media/shell.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/scene/concepts.hpp"
#include "grainlight/scene/unbounded_medium.hpp"

namespace grainlight {

/// Raw tallies of first shell exits over many paths (before density estimation).
struct ShellSamples {
    std::vector<double> radii;                     ///< shell radii, ascending
    std::vector<std::vector<float>> coords;        ///< per shell: (cos theta_1, u, v) triples of scattered exits
    std::vector<std::uint64_t> n_unscattered;      ///< per shell: exits with no event before
    std::vector<std::uint64_t> n_absorbed;         ///< per shell: paths absorbed before exiting
    std::vector<std::uint64_t> fa_counts;          ///< histogram of the first free path over [0, fa_d_max] (+1 overflow bin)
    double fa_d_max = 0;                           ///< range of fa_counts
    std::uint64_t n_paths = 0;                     ///< paths traced

    /// Empty tallies for the given radii and f_a histogram (fa_bins bins on [0, fa_d_max]).
    ShellSamples(std::vector<double> r, int fa_bins, double d_max)
        : radii(std::move(r)), coords(radii.size()), n_unscattered(radii.size(), 0), n_absorbed(radii.size(), 0),
          fa_counts(std::size_t(fa_bins) + 1, 0), fa_d_max(d_max) {}
    ShellSamples() = default;

    /// Number of shells (radii.size()).
    [[nodiscard]] std::size_t n_shells() const noexcept { return radii.size(); }
    /// Number of scattered exits recorded for shell i (coords[i].size() / 3; i < n_shells(), not checked).
    [[nodiscard]] std::uint64_t n_scattered(std::size_t i) const noexcept { return coords[i].size() / 3; }

    /// Append another set of tallies over the same radii (fixed order => deterministic).
    void merge(const ShellSamples& o) {
        for (std::size_t i = 0; i < n_shells(); ++i) {
            coords[i].insert(coords[i].end(), o.coords[i].begin(), o.coords[i].end());
            n_unscattered[i] += o.n_unscattered[i];
            n_absorbed[i] += o.n_absorbed[i];
        }
        for (std::size_t b = 0; b < fa_counts.size(); ++b) fa_counts[b] += o.fa_counts[b];
        n_paths += o.n_paths;
    }
};

/// Records the first exits of one path from the shells around its start frame (x, omega).
/// Feed it the straight segments of the path in order with `segment`; end with `absorbed()` (the
/// path ended inside some shells) or let `done()` become true (every shell exited).
class ShellRecorder {
public:
    /// Recorder appending to `out` (referenced: it must outlive the recorder). Not thread-safe:
    /// one recorder and one ShellSamples per thread (or block), merged afterwards.
    explicit ShellRecorder(ShellSamples& out) noexcept : out_(out) {}

    /// Start a path at x with unit direction omega.
    void begin(const Vec3d& x, const Vec3d& omega) noexcept {
        x_ = x;
        omega_ = omega;
        next_ = 0;
        scattered_ = false;
        fa_open_ = true;
        fa_len_ = 0;
        ++out_.n_paths;
    }

    /// A straight segment from o along unit d of length t (may be +inf). `event_at_end`: the
    /// segment ends in an event (scattering, interface, absorption); the next segment then counts
    /// as scattered. The first free path (start to first event, for f_a) accumulates over the
    /// event-free segments. Returns false once every shell has been exited and the first free
    /// path is known (the caller may then stop the path).
    bool segment(const Vec3d& o, const Vec3d& d, double t, bool event_at_end) noexcept {
        if (fa_open_) {
            fa_len_ += t;
            if (event_at_end || !(fa_len_ <= out_.fa_d_max)) close_fa();
        }
        const Vec3d rel = o - x_;
        const double b = glm::dot(rel, d);
        const double rr = glm::dot(rel, rel);
        while (next_ < out_.n_shells()) {
            const double r = out_.radii[next_];
            const double disc = b * b - (rr - r * r);
            const double s = -b + std::sqrt(std::max(0.0, disc));
            if (!(s <= t)) break;  // this (and every larger) shell is not exited on this segment
            if (scattered_) {
                const Vec3d y = x_ + r * glm::normalize(rel + s * d);
                const ShellCoords<double> c = shell_coords(x_, omega_, y, d);
                auto& v = out_.coords[next_];
                v.push_back(float(c.cos_theta1));
                v.push_back(float(c.u));
                v.push_back(float(c.v));
            } else {
                ++out_.n_unscattered[next_];
            }
            ++next_;
        }
        scattered_ = scattered_ || event_at_end;
        return next_ < out_.n_shells() || fa_open_;
    }

    /// The path was absorbed (or otherwise ended) before exiting the remaining shells.
    void absorbed() noexcept {
        if (fa_open_) close_fa();
        for (std::size_t i = next_; i < out_.n_shells(); ++i) ++out_.n_absorbed[i];
        next_ = out_.n_shells();
    }

    /// True once every shell has been exited and the first free path has ended.
    [[nodiscard]] bool done() const noexcept { return next_ >= out_.n_shells() && !fa_open_; }

private:
    void close_fa() noexcept {
        fa_open_ = false;
        const std::size_t nb = out_.fa_counts.size() - 1;
        const double x = fa_len_ / out_.fa_d_max * double(nb);
        out_.fa_counts[x < double(nb) ? std::size_t(std::max(0.0, x)) : nb] += 1;
    }

    ShellSamples& out_;
    Vec3d x_{0.0}, omega_{0.0, 0.0, 1.0};
    std::size_t next_ = 0;
    bool scattered_ = false;
    bool fa_open_ = false;
    double fa_len_ = 0;
};

// UnboundedMediumScene (a scene with no surfaces filled with one medium) is the library's one
// unbounded-medium scene, scene/unbounded_medium.hpp.

/// Path source: the walk kernel in an unbounded homogeneous medium (analog grey walk assumed:
/// the throughput is not used). The path starts at the origin along +z.
template <Medium M>
class ContinuousShellSource {
public:
    /// Source of paths in `medium` (referenced, not copied: it must outlive the source), each cut
    /// after max_depth events (the shells not yet exited then count as absorbed).
    explicit ContinuousShellSource(const M& medium, int max_depth = 100000) : m_(medium), max_depth_(max_depth) {}

    /// One path from the origin along +z through the walk kernel; its straight segments go to `rec`
    /// in order (begin, segment, and absorbed if it ended before every shell was exited).
    void trace(Rng& rng, ShellRecorder& rec) const noexcept {
        using F = typename M::Float;
        using S = typename M::Spectrum;
        UnboundedMediumScene<M> scene{&m_};
        rec.begin(Vec3d(0.0), Vec3d(0.0, 0.0, 1.0));
        auto st = start_path<F, S>(Ray<F>(Vec3<F>(0), Vec3<F>(0, 0, 1)), 0);
        struct Cb {
            ShellRecorder& rec;
            bool alive = true;
            void on_segment(const PathState<F, S>& s, F t) {
                // Every segment of an unbounded medium ends in an event (or never ends).
                alive = rec.segment(Vec3d(s.ray.o), Vec3d(s.ray.d), double(t), true);
            }
            bool on_scatter(PathState<F, S>&, const Interaction<F, S>&, const M&) { return alive; }
        } cb{rec};
        WalkOptions<F> opt;
        opt.max_depth = max_depth_;
        opt.mode = TransportMode::importance;
        (void)walk(scene, st, rng, cb, opt);
        if (!rec.done()) rec.absorbed();
    }

private:
    const M& m_;
    int max_depth_;
};

/// Path source: explicit dielectric spheres of an infinitely tiled periodic packing in a
/// non-absorbing host (Moon07 Sec. 5's "closely packed glass spheres").
/// \param eta relative index n_sphere / n_host (> 0; 1 = index matched)
/// \param sigma_a absorption coefficient inside the spheres (1/length, >= 0)
/// \param burn_in mean burn-in path length before the start frame (length units; > 0)
class SpherePackingShellSource {
public:
    /// Source over the periodic packing `tile` (>= 1 sphere; referenced, not copied: it must outlive
    /// the source) with the parameters above;
    /// `max_events` caps the interface events of the burn-in and, again, of the recorded path (a
    /// path over the cap counts as absorbed). Throws
    /// grainlight::invalid_argument naming the parameter for a non-finite or out-of-range eta,
    /// sigma_a or burn_in, or an empty tile.
    SpherePackingShellSource(const PeriodicTile& tile, double eta, double sigma_a, double burn_in,
                             int max_events = 1000000)
        : tile_(tile), eta_(eta), sigma_a_(sigma_a), burn_in_(burn_in), max_events_(max_events) {
        constexpr const char* where = "SpherePackingShellSource";
        check_argument(std::isfinite(eta) && eta > 0, where, "eta", eta, "finite, > 0");
        check_argument(std::isfinite(sigma_a) && sigma_a >= 0, where, "sigma_a", sigma_a, "finite, >= 0");
        check_argument(std::isfinite(burn_in) && burn_in > 0, where, "burn_in", burn_in, "finite, > 0");
        check_argument(tile.size() > 0, where, "tile.size()", tile.size(), ">= 1");
    }

    /// One path: `rec` is a ShellRecorder or any type with the same begin / segment / absorbed
    /// members (e.g. a recorder of chained spheres for a reference walk).
    template <class Recorder>
    void trace(Rng& rng, Recorder& rec) const noexcept {
        const double R = tile_.radius();
        State s;
        // Start in the host phase at a uniform point, uniform direction; a random burn-in length
        // U(1, 2) * burn_in decorrelates the start frame from this choice.
        for (int tries = 0; tries < 1000; ++tries) {
            s.p = rng.uniform3<double>() * tile_.side();
            bool in = false;
            tile_.for_each_overlapping(s.p, s.p, [&](const TileSphereRef& ref) {
                if (glm::length(s.p - ref.center) < R) in = true;
            });
            if (!in) break;
        }
        s.d = sample_uniform_sphere(rng.uniform2<double>());
        double remaining = burn_in_ * (1.0 + rng.uniform<double>());
        int events = 0;
        // Burn-in (no absorption, so the start frame has the path-length measure of a lossless walk).
        for (;;) {
            const double t = next_interface(s);
            if (t >= remaining) {
                s.p += remaining * s.d;
                break;
            }
            remaining -= t;
            (void)interface_event(s, t, rng);
            if (++events > max_events_) {
                rec.begin(s.p, s.d);
                rec.absorbed();
                return;
            }
        }
        rec.begin(s.p, s.d);
        for (events = 0; events < max_events_; ++events) {
            const double t = next_interface(s);
            if (s.inside && sigma_a_ > 0) {
                const double ta = sample_exponential(rng.uniform<double>(), sigma_a_);
                if (ta < t) {
                    if (rec.segment(s.p, s.d, ta, true)) rec.absorbed();
                    return;
                }
            }
            // Resolve the interface first (on a copy) to know whether the segment ends in an event.
            if (!std::isfinite(t)) {
                (void)rec.segment(s.p, s.d, t, false);
                return;
            }
            const Vec3d p0 = s.p, d0 = s.d;
            const bool event = interface_event(s, t, rng);
            if (!rec.segment(p0, d0, t, event)) return;
        }
        rec.absorbed();
    }

private:
    struct State {
        Vec3d p{0.0}, d{0.0, 0.0, 1.0};
        bool inside = false;
        Vec3d c{0.0};             ///< centre of the sphere we are in / last touched
        bool has_last = false;    ///< c is the sphere whose surface p lies on
    };

    /// Distance to the next interface from s.p along s.d (inf if none within the search range).
    [[nodiscard]] double next_interface(State& s) const noexcept {
        const double R = tile_.radius();
        if (s.inside) {
            const Vec3d rel = s.p - s.c;
            const double b = glm::dot(rel, s.d);
            const double cc = glm::dot(rel, rel) - R * R;
            return std::max(0.0, -b + std::sqrt(std::max(0.0, b * b - cc)));
        }
        double t_min = 0.0;
        for (int k = 0; k < 4; ++k) {
            const TileHit h = tile_.first_hit(Vec3i64{0, 0, 0}, s.p, s.d, t_min, std::numeric_limits<double>::infinity());
            if (!h) return std::numeric_limits<double>::infinity();
            const Vec3d c = Vec3d(double(h.tile.x), double(h.tile.y), double(h.tile.z)) * tile_.side() +
                            tile_.center(h.sphere);
            // The sphere we just left (or reflected off): skip its grazing re-hit at t ~ 0.
            if (s.has_last && glm::length(c - s.c) < 1e-9 * R && h.t_enter < 1e-7 * R) {
                t_min = h.t_exit;
                continue;
            }
            s.c = c;
            return std::max(0.0, h.t_enter);
        }
        return std::numeric_limits<double>::infinity();
    }

    /// Move by t to the interface and resolve it (Fresnel reflection or Snell refraction).
    /// Returns true if the direction changed (an event; an index-matched crossing is none).
    bool interface_event(State& s, double t, Rng& rng) const noexcept {
        s.p += t * s.d;
        const Vec3d n = glm::normalize(s.p - s.c);  // outward normal of the sphere
        bool refracted = false;
        double eta_rel = 1.0;
        const Vec3d d_old = s.d;
        if (eta_ == 1.0) {
            refracted = true;
        } else {
            s.d = sample_dielectric(s.d, n, eta_, rng.uniform<double>(), refracted, eta_rel);
        }
        if (refracted) s.inside = !s.inside;
        s.has_last = true;
        return glm::dot(s.d, d_old) < 1.0 - 1e-12;
    }

    const PeriodicTile& tile_;
    double eta_, sigma_a_, burn_in_;
    int max_events_;
};

/// Glass fraction of plane crossings in a packing of dielectric spheres (ShellFaceOptics::q of the
/// shell tracer): the probability q(|cos theta|) that a path of the medium crossing a plane at
/// direction cosine cos theta does so inside a sphere, in `cells` equal cells of |cos theta| over
/// [0, 1]. Measured on the paths themselves (SpherePackingShellSource: Fresnel reflection and
/// Snell refraction at every sphere, no absorption, burn-in `burn_in`), `paths` paths of path
/// length `path_length` each, counting every crossing of the planes x, y, z = k R / 2 (R the
/// sphere radius): the crossing-weighted fraction, which differs from the area fraction of glass
/// in a plane (= the volume fraction) because light travels differently inside the spheres.
/// Deterministic in `seed`. Throws grainlight::invalid_argument naming the parameter for cells
/// outside [1, 1024], paths < 1 or a non-finite or non-positive path_length / burn_in; a cell
/// without crossings gets the mean over all crossings.
[[nodiscard]] inline std::vector<double> plane_crossing_glass_fraction(const PeriodicTile& tile, double eta, int cells,
                                                                       std::uint64_t paths, double path_length,
                                                                       double burn_in, std::uint64_t seed) {
    constexpr const char* where = "plane_crossing_glass_fraction";
    check_argument(cells >= 1 && cells <= 1024, where, "cells", cells, "[1, 1024]");
    check_argument(paths >= 1, where, "paths", paths, ">= 1");
    check_argument(std::isfinite(path_length) && path_length > 0, where, "path_length", path_length, "finite, > 0");
    const SpherePackingShellSource src(tile, eta, 0.0, burn_in);
    const double spacing = 0.5 * tile.radius();
    std::vector<double> glass(std::size_t(cells), 0.0), all(std::size_t(cells), 0.0);
    struct Rec {
        const PeriodicTile* tile;
        double spacing, left;
        int cells;
        std::vector<double>*glass, *all;
        void begin(const Vec3d&, const Vec3d&) noexcept {}
        void absorbed() noexcept {}
        bool segment(const Vec3d& p, const Vec3d& d, double t, bool) noexcept {
            if (!std::isfinite(t) || !(left > 0)) return false;
            t = std::min(t, left);
            left -= t;
            const bool in = tile->sphere_containing(p + 0.5 * t * d).has_value();
            const Vec3d q = p + t * d;
            for (int a = 0; a < 3; ++a) {
                const double k = std::abs(std::floor(q[a] / spacing) - std::floor(p[a] / spacing));
                if (k == 0) continue;
                const std::size_t c = std::min(std::size_t(cells - 1), std::size_t(std::abs(d[a]) * double(cells)));
                (*all)[c] += k;
                if (in) (*glass)[c] += k;
            }
            return left > 0;
        }
    };
    for (std::uint64_t i = 0; i < paths; ++i) {
        Rng rng = Rng::from_key(seed, i, 0x51A9Eu);
        Rec rec{&tile, spacing, path_length, cells, &glass, &all};
        src.trace(rng, rec);
    }
    double g_sum = 0, a_sum = 0;
    for (int c = 0; c < cells; ++c) {
        g_sum += glass[std::size_t(c)];
        a_sum += all[std::size_t(c)];
    }
    const double mean = a_sum > 0 ? g_sum / a_sum : 0.0;
    std::vector<double> q(std::size_t(cells), mean);
    for (std::size_t c = 0; c < q.size(); ++c)
        if (all[c] > 0) q[c] = glass[c] / all[c];
    return q;
}

/// Path source: the grains of a procedural granular aggregate (Meng15 grain aggregates,
/// traversal/aggregate.hpp `GranularAggregate`: any exemplar mix, mesh or analytic grains, any
/// GrainMaterial), traced explicitly as EPT does it (integrators/ept.hpp: Algorithm 1 traversal to
/// the next grain, `grain_sojourn` inside it, the same grain hit again on the way out of its
/// bounding sphere). Use an aggregate over the whole space (EverywhereBoundary) for a table of the
/// bulk medium. Start frames are points in the *host* (between grains): a path starts at a uniform
/// host point outside every bounding sphere with a uniform direction, and the frame is where its
/// host path length reaches a burn-in U(1, 2) x `burn_in` (a typical host point of a path under
/// the path-length measure; the shell tracer must switch at host points too). Transport is grey
/// and analog: a path whose throughput drops (absorbing grains) survives each grain with
/// probability equal to its throughput (Russian roulette without reweighting), so only lossless
/// or grey-absorbing materials give exact tables (coloured absorption needs one table per channel).
template <BoundaryShape Shape>
class GrainAggregateShellSource {
public:
    /// Source over `agg` (referenced: it must outlive the source). Throws
    /// grainlight::invalid_argument naming the parameter for a non-finite or non-positive
    /// burn_in, or max_events < 1.
    /// `frames_in_grains`: measure the burn-in along the whole path (host and grain interiors), so
    /// that frames are typical points of the path anywhere, as SpherePackingShellSource's are.
    GrainAggregateShellSource(const GranularAggregate<Shape>& agg, double burn_in, int max_events = 1000000,
                              bool frames_in_grains = false)
        : agg_(agg), burn_in_(burn_in), max_events_(max_events), frames_in_grains_(frames_in_grains) {
        constexpr const char* where = "GrainAggregateShellSource";
        check_argument(std::isfinite(burn_in) && burn_in > 0, where, "burn_in", burn_in, "finite, > 0");
        check_argument(max_events >= 1, where, "max_events", max_events, ">= 1");
    }

    /// One path into `rec` (a ShellRecorder or a type with its begin / segment / absorbed members).
    template <class Recorder>
    void trace(Rng& rng, Recorder& rec) const noexcept {
        // A path that ends during its burn-in (absorbed, lost) is replaced by a new one: the
        // burn-in is lossless, as in SpherePackingShellSource.
        for (int attempt = 0; attempt < 1000; ++attempt)
            if (trace_once(rng, rec)) return;
        rec.begin(Vec3d(0.0), Vec3d(0.0, 0.0, 1.0));
        rec.absorbed();
    }

private:
    /// One attempt; false if the path ended before its start frame (nothing recorded).
    template <class Recorder>
    bool trace_once(Rng& rng, Recorder& rec) const noexcept {
        using S = Spectrum<1, double>;
        const double R = agg_.grain_radius();
        const PeriodicTile& tile = agg_.tile();
        Vec3d p(0.0);
        for (int tries = 0; tries < 1000; ++tries) {
            p = rng.uniform3<double>() * tile.side();
            bool in = false;
            tile.for_each_overlapping(p, p, [&](const TileSphereRef& ref) {
                if (glm::length(p - ref.center) < R) in = true;
            });
            if (!in) break;
        }
        Vec3d d = sample_uniform_sphere(rng.uniform2<double>());
        double burn = burn_in_ * (1.0 + rng.uniform<double>());
        bool started = false, alive = true;
        // A straight piece a -> b (host or in-grain); `event`: a surface event at b.
        const auto piece = [&](const Vec3d& a, const Vec3d& b, bool host, bool event) {
            if (!alive) return;
            const Vec3d ab = b - a;
            const double len = glm::length(ab);
            if (!(len > 0)) return;
            const Vec3d w = ab / len;
            if (!started) {
                const bool counts = host || frames_in_grains_;
                if (!counts || len < burn) {
                    if (counts) burn -= len;
                    return;
                }
                rec.begin(a + burn * w, w);
                started = true;
                alive = rec.segment(a + burn * w, w, len - burn, event);
                return;
            }
            alive = rec.segment(a, w, len, event);
        };
        S beta(1.0);
        int events = 0;
        const double max_flight = 1e6 * R;
        while (events < max_events_ && alive) {
            const AggregateHit h = agg_.intersect(p, d, 0.0, max_flight);
            if (!h) {  // nothing ahead within the search range
                if (!started) {
                    p += burn * d;
                    rec.begin(p, d);
                }
                (void)rec.segment(p, d, std::numeric_limits<double>::infinity(), false);
                return true;
            }
            const Vec3d c = agg_.sphere_center(h.grain.tile, h.grain.sphere);
            Vec3d q = p + h.t * d, n = h.n;
            piece(p, q, true, true);
            for (;;) {
                if (!alive) return true;
                const GrainSojourn s = grain_sojourn(
                    agg_, h.grain, q, d, n, beta, rng, TransportMode::importance, max_events_ - events,
                    [](const Vec3d&, const Vec3d&, S&) {},
                    [&](const Vec3d& a, const Vec3d& b) { piece(a, b, false, true); });
                events += s.events;
                if (!alive) return true;
                if (!s.is_exited()) {
                    if (!started) return false;
                    rec.absorbed();
                    return true;
                }
                // Leave the bounding sphere, unless the same grain is hit again on the way.
                const auto r2 = intersect_sphere(s.p, s.d, c, R);
                const double t_out = r2.hit ? std::max(0.0, r2.t_far) : 0.0;
                const AggregateHit again = agg_.intersect_grain(h.grain, s.p, s.d, 0.0, t_out);
                if (again) {
                    q = s.p + again.t * s.d;
                    piece(s.p, q, true, true);
                    d = s.d;
                    n = again.n;
                    continue;
                }
                p = s.p;
                d = s.d;
                break;
            }
            // Analog roulette on the grain's survival weight (grey; 1 for lossless grains).
            const double q_rr = std::min(1.0, double(beta[0]));
            if (q_rr < 1.0 && started) {
                if (!(q_rr > 0) || rng.uniform<double>() >= q_rr) {
                    rec.absorbed();
                    return true;
                }
            }
            beta = S(1.0);
        }
        if (!started) return false;
        if (alive) rec.absorbed();  // event budget
        return true;
    }

    const GranularAggregate<Shape>& agg_;
    double burn_in_;
    int max_events_;
    bool frames_in_grains_;
};

/// Paths per block of collect_shell_samples (the unit of work split over threads and processes).
inline constexpr std::uint64_t shell_sample_block = 4096;

/// Number of path blocks of a collect_shell_samples run of `n_paths` paths.
[[nodiscard]] constexpr std::uint64_t shell_sample_blocks(std::uint64_t n_paths) noexcept {
    return (n_paths + shell_sample_block - 1) / shell_sample_block;
}

/// The path blocks [block_begin, block_end) of collect_shell_samples(source, radii, n_paths, seed,
/// fa_bins, fa_d_max): the tallies of those paths only, in block order. Tallies of consecutive
/// ranges merged in order (ShellSamples::merge) equal the one-call result exactly (integer counts
/// and appended exit lists), so a run split over processes gives the same table.
template <class Source>
[[nodiscard]] ShellSamples collect_shell_sample_blocks(const Source& source, const std::vector<double>& radii,
                                                       std::uint64_t n_paths, std::uint64_t seed,
                                                       std::uint64_t block_begin, std::uint64_t block_end,
                                                       int fa_bins = 256, double fa_d_max = 0) {
    constexpr const char* where = "collect_shell_samples";
    check_argument(!radii.empty(), where, "radii.size()", radii.size(), ">= 1");
    for (std::size_t i = 0; i < radii.size(); ++i)
        check_argument(std::isfinite(radii[i]) && radii[i] > 0 && (i == 0 || radii[i] > radii[i - 1]), where,
                       "radii[" + std::to_string(i) + "]", radii[i], "finite, > 0, strictly ascending");
    check_argument(n_paths >= 1, where, "n_paths", n_paths, ">= 1");
    check_argument(fa_bins >= 2 && fa_bins <= (1 << 20), where, "fa_bins", fa_bins, "[2, 2^20]");
    if (!(fa_d_max > 0)) fa_d_max = 2.0 * radii.back();
    check_argument(std::isfinite(fa_d_max), where, "fa_d_max", fa_d_max, "finite");
    check_argument(block_begin <= block_end && block_end <= shell_sample_blocks(n_paths), where, "block range end",
                   double(block_end), "block_begin <= block_end <= shell_sample_blocks(n_paths)");
    constexpr std::uint64_t block = shell_sample_block;
    const std::uint64_t n_blocks = block_end - block_begin;
    std::vector<ShellSamples> parts(n_blocks, ShellSamples(radii, fa_bins, fa_d_max));
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (std::int64_t k = 0; k < std::int64_t(n_blocks); ++k) {
        const std::uint64_t b = block_begin + std::uint64_t(k);
        ShellSamples& part = parts[std::size_t(k)];
        ShellRecorder rec(part);
        const std::uint64_t p0 = b * block, p1 = std::min(n_paths, p0 + block);
        for (std::uint64_t p = p0; p < p1; ++p) {
            Rng rng = Rng::from_key(seed, b, p);
            source.trace(rng, rec);
        }
    }
    ShellSamples all(radii, fa_bins, fa_d_max);
    for (const auto& p : parts) all.merge(p);
    return all;
}

/// Run `n_paths` paths of `source` (anything with `void trace(Rng&, ShellRecorder&) const`) and
/// tally their first shell exits. Path p uses Pcg32::from_key(seed, block, p): the result does
/// not depend on the number of OpenMP threads (collect_shell_sample_blocks over every block).
template <class Source>
[[nodiscard]] ShellSamples collect_shell_samples(const Source& source, const std::vector<double>& radii,
                                                 std::uint64_t n_paths, std::uint64_t seed, int fa_bins = 256,
                                                 double fa_d_max = 0) {
    check_argument(n_paths >= 1, "collect_shell_samples", "n_paths", n_paths, ">= 1");
    return collect_shell_sample_blocks(source, radii, n_paths, seed, 0, shell_sample_blocks(n_paths), fa_bins,
                                       fa_d_max);
}

namespace detail {

/// Points of the (cos theta_1, u, v) box scaled to the unit cube, in a k-d tree (median splits,
/// leaves of <= 8 points), for k-th nearest neighbour queries in the L-infinity metric. Robust to
/// strongly clustered samples (a bucket grid is not: forward peaks hold a quarter of all exits).
class KnnPoints {
public:
    explicit KnnPoints(std::span<const float> pts) {
        n_ = pts.size() / 3;
        q_.resize(n_);
        idx_.resize(n_);
        for (std::size_t i = 0; i < n_; ++i) {
            q_[i] = {std::clamp((double(pts[3 * i]) + 1.0) * 0.5, 0.0, 1.0), std::clamp(double(pts[3 * i + 1]), 0.0, 1.0),
                     std::clamp(double(pts[3 * i + 2]), 0.0, 1.0)};
            idx_[i] = std::uint32_t(i);
        }
        if (n_ > 0) build(0, n_);
    }
    [[nodiscard]] std::size_t size() const noexcept { return n_; }
    [[nodiscard]] const std::array<double, 3>& point(std::size_t i) const noexcept { return q_[i]; }

    /// L-infinity distance from x to its kk-th nearest point (1 <= kk <= size()); `best` is scratch.
    [[nodiscard]] double kth_distance(const std::array<double, 3>& x, std::size_t kk, std::vector<double>& best) const {
        best.resize(kk);
        std::size_t have = 0;
        search(0, x, kk, best, have);
        return best[kk - 1];
    }

private:
    struct Node {
        std::uint32_t begin = 0, end = 0;   // point range (leaf) or split range
        std::int32_t left = -1, right = -1; // children (-1: leaf)
        std::int32_t axis = 0;
        double split = 0;
    };

    std::int32_t build(std::size_t b, std::size_t e) {
        const auto id = std::int32_t(nodes_.size());
        nodes_.push_back(Node{std::uint32_t(b), std::uint32_t(e)});
        if (e - b <= 8) return id;
        std::array<double, 3> lo{1, 1, 1}, hi{0, 0, 0};
        for (std::size_t i = b; i < e; ++i)
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min(lo[a], q_[idx_[i]][a]);
                hi[a] = std::max(hi[a], q_[idx_[i]][a]);
            }
        int axis = 0;
        for (int a = 1; a < 3; ++a)
            if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
        if (!(hi[axis] > lo[axis])) return id;  // all points equal: keep as a leaf
        const std::size_t m = (b + e) / 2;
        std::nth_element(idx_.begin() + std::ptrdiff_t(b), idx_.begin() + std::ptrdiff_t(m), idx_.begin() + std::ptrdiff_t(e),
                         [&](std::uint32_t i, std::uint32_t j) { return q_[i][axis] < q_[j][axis]; });
        const double split = q_[idx_[m]][axis];
        const std::int32_t l = build(b, m);
        const std::int32_t r = build(m, e);
        nodes_[std::size_t(id)].left = l;
        nodes_[std::size_t(id)].right = r;
        nodes_[std::size_t(id)].axis = axis;
        nodes_[std::size_t(id)].split = split;
        return id;
    }

    void search(std::int32_t id, const std::array<double, 3>& x, std::size_t kk, std::vector<double>& best,
                std::size_t& have) const {
        const Node& nd = nodes_[std::size_t(id)];
        if (nd.left < 0) {
            for (std::uint32_t m = nd.begin; m < nd.end; ++m) {
                const auto& p = q_[idx_[m]];
                const double dist = std::max({std::abs(p[0] - x[0]), std::abs(p[1] - x[1]), std::abs(p[2] - x[2])});
                if (have == kk && !(dist < best[kk - 1])) continue;
                std::size_t pos = have < kk ? have++ : kk - 1;
                while (pos > 0 && best[pos - 1] > dist) {
                    best[pos] = best[pos - 1];
                    --pos;
                }
                best[pos] = dist;
            }
            return;
        }
        const double diff = x[std::size_t(nd.axis)] - nd.split;
        const std::int32_t near = diff < 0 ? nd.left : nd.right, far = diff < 0 ? nd.right : nd.left;
        search(near, x, kk, best, have);
        if (have < kk || std::abs(diff) <= best[kk - 1]) search(far, x, kk, best, have);
    }

    std::size_t n_ = 0;
    std::vector<std::array<double, 3>> q_;
    std::vector<std::uint32_t> idx_;
    std::vector<Node> nodes_;
};

inline void check_knn_args(const char* where, std::span<const float> pts, double n_total, int k, int n_c, int n_u,
                           int n_v) {
    check_argument(pts.size() % 3 == 0, where, "pts.size()", pts.size(), "a multiple of 3");
    check_argument(k >= 2 && k <= 4096, where, "k", k, "[2, 4096]");
    check_argument(n_c >= 1 && n_u >= 1 && n_v >= 1 && n_c <= 4096 && n_u <= 4096 && n_v <= 4096, where, "grid size",
                   std::min({n_c, n_u, n_v}), "[1, 4096] per axis");
    check_argument(n_total > 0, where, "n_total", n_total, "> 0");
}

}  // namespace detail

/// k-nearest-neighbour density (Moon07 Sec. 4.1, "in the style of photon mapping": the
/// *balloon* estimator) of points in the box [-1,1] x [0,1] x [0,1] of (cos theta_1, u, v),
/// evaluated at the centres of an n_c x n_u x n_v grid. The neighbourhood is the L-infinity cube
/// (in coordinates scaled to the unit cube) reaching the k-th nearest sample, clipped to the
/// domain so the estimate has no boundary loss: density = (k - 1) / (n_total |clipped cube|) per
/// unit (cos theta_1, u, v) volume ((k-1)/(N V) is the unbiased k-NN estimator for a locally
/// uniform density). `n_total` is the number of *paths* (so the density integrates to the
/// scattered fraction). Point values at cell centres miss mass in peaks narrower than a cell
/// (see knn_cell_density_grid). Output index: (j_c * n_v + j_v) * n_u + j_u.
[[nodiscard]] inline std::vector<double> knn_density_grid(std::span<const float> pts, double n_total, int k, int n_c,
                                                          int n_u, int n_v) {
    detail::check_knn_args("knn_density_grid", pts, n_total, k, n_c, n_u, n_v);
    std::vector<double> out(std::size_t(n_c) * n_u * n_v, 0.0);
    const detail::KnnPoints kp(pts);
    if (kp.size() < 2) return out;
    const std::size_t kk = std::min<std::size_t>(std::size_t(k), kp.size());
    std::vector<double> best;
    for (int jc = 0; jc < n_c; ++jc)
        for (int jv = 0; jv < n_v; ++jv)
            for (int ju = 0; ju < n_u; ++ju) {
                const std::array<double, 3> x{(jc + 0.5) / n_c, (ju + 0.5) / n_u, (jv + 0.5) / n_v};
                const double h = kp.kth_distance(x, kk, best);
                double vol = 1.0;
                for (int a = 0; a < 3; ++a) vol *= std::min(1.0, x[a] + h) - std::max(0.0, x[a] - h);
                // Unit-cube density -> per unit (cos theta_1, u, v) volume: cos theta_1 spans 2.
                out[(std::size_t(jc) * n_v + jv) * n_u + ju] = vol > 0 ? double(kk - 1) / (n_total * vol) * 0.5 : 0.0;
            }
    return out;
}

/// Cell-averaged k-NN density: the *sample-point* (adaptive kernel) form of the k-NN estimator.
/// Every sample spreads its mass 1/n_total uniformly over the L-infinity cube reaching its k-th
/// nearest neighbour (clipped to the domain), and each grid cell receives the overlapping mass,
/// divided by its volume. The result integrates exactly to (samples / n_total), follows the
/// local sample spacing like the balloon estimator, and gives cell *averages*, which is what
/// piecewise-constant sampling of the table needs: peaks narrower than a cell (forward exits of
/// strongly forward-scattering media) keep their mass. Same units and index as knn_density_grid.
[[nodiscard]] inline std::vector<double> knn_cell_density_grid(std::span<const float> pts, double n_total, int k,
                                                               int n_c, int n_u, int n_v) {
    detail::check_knn_args("knn_cell_density_grid", pts, n_total, k, n_c, n_u, n_v);
    std::vector<double> out(std::size_t(n_c) * n_u * n_v, 0.0);
    const detail::KnnPoints kp(pts);
    if (kp.size() == 0) return out;
    // k-th neighbour not counting the sample itself.
    const std::size_t kk = std::min<std::size_t>(std::size_t(k) + 1, kp.size());
    const int dims[3] = {n_c, n_u, n_v};
    // Bandwidths in parallel (each is a pure function of the points: thread-count independent).
    std::vector<double> bandwidth(kp.size(), 0.5);
    if (kp.size() > 1) {
#if defined(_OPENMP)
#pragma omp parallel
#endif
        {
            std::vector<double> scratch;
#if defined(_OPENMP)
#pragma omp for schedule(static)
#endif
            for (std::int64_t i = 0; i < std::int64_t(kp.size()); ++i)
                bandwidth[std::size_t(i)] = kp.kth_distance(kp.point(std::size_t(i)), kk, scratch);
        }
    }
    std::array<std::vector<double>, 3> frac;
    std::array<int, 3> lo{}, hi{};
    for (std::size_t i = 0; i < kp.size(); ++i) {
        const auto& x = kp.point(i);
        const double h = std::max(bandwidth[i], 1e-9);
        for (int a = 0; a < 3; ++a) {
            const double a0 = std::max(0.0, x[a] - h), a1 = std::min(1.0, x[a] + h);
            lo[a] = std::clamp(int(a0 * dims[a]), 0, dims[a] - 1);
            hi[a] = std::clamp(int(a1 * dims[a]), 0, dims[a] - 1);
            frac[a].assign(std::size_t(hi[a] - lo[a] + 1), 0.0);
            const double len = a1 - a0;
            for (int c = lo[a]; c <= hi[a]; ++c) {
                const double c0 = double(c) / dims[a], c1 = double(c + 1) / dims[a];
                const double ov = std::max(0.0, std::min(a1, c1) - std::max(a0, c0));
                frac[a][std::size_t(c - lo[a])] = len > 0 ? ov / len : (c == lo[a] ? 1.0 : 0.0);
            }
        }
        for (int jc = lo[0]; jc <= hi[0]; ++jc)
            for (int jv = lo[2]; jv <= hi[2]; ++jv)
                for (int ju = lo[1]; ju <= hi[1]; ++ju)
                    out[(std::size_t(jc) * n_v + jv) * n_u + ju] +=
                        frac[0][std::size_t(jc - lo[0])] * frac[1][std::size_t(ju - lo[1])] * frac[2][std::size_t(jv - lo[2])];
    }
    const double cell_volume = 2.0 / (double(n_c) * n_u * n_v);
    for (double& v : out) v /= n_total * cell_volume;
    return out;
}

/// Result of a non-negative matrix factorization V ~ W H.
struct NmfResult {
    Eigen::MatrixXd W;             ///< rows x rank, >= 0
    Eigen::MatrixXd H;             ///< rank x cols, >= 0
    double relative_error = 0;     ///< ||V - W H||_F / ||V||_F
};

/// Lee & Seung multiplicative updates for min ||V - W H||_F with W, H >= 0 [LS00], from a seeded
/// random positive start. V must be non-negative and finite.
[[nodiscard]] inline NmfResult nmf(const Eigen::MatrixXd& V, int rank, int iterations, std::uint64_t seed = 1) {
    constexpr const char* where = "nmf";
    check_argument(rank >= 1 && rank <= 1024, where, "rank", rank, "[1, 1024]");
    check_argument(iterations >= 0, where, "iterations", iterations, ">= 0");
    check_argument(V.rows() >= 1 && V.cols() >= 1, where, "V.size()", V.size(), ">= 1");
    check_argument(V.allFinite() && V.minCoeff() >= 0.0, where, "min(V)", V.minCoeff(), "finite, >= 0");
    const double mean = std::max(V.mean(), 1e-300);
    const double scale = std::sqrt(mean / rank);
    Rng rng = Rng::from_key(seed, 0x4e4d46);
    NmfResult r;
    r.W.resize(V.rows(), rank);
    r.H.resize(rank, V.cols());
    for (Eigen::Index i = 0; i < r.W.size(); ++i) r.W.data()[i] = scale * (0.1 + rng.uniform<double>());
    for (Eigen::Index i = 0; i < r.H.size(); ++i) r.H.data()[i] = scale * (0.1 + rng.uniform<double>());
    constexpr double eps = 1e-300;
    // lazyProduct: coefficient-wise products, never Eigen's OpenMP-parallel GEMM (which for these
    // thin matrices is slower, and 60x slower on a loaded machine).
    for (int it = 0; it < iterations; ++it) {
        const Eigen::MatrixXd Wt = r.W.transpose();
        const Eigen::MatrixXd WtV = Wt.lazyProduct(V);
        const Eigen::MatrixXd WtW = Wt.lazyProduct(r.W);
        const Eigen::MatrixXd WtWH = WtW.lazyProduct(r.H);
        r.H = r.H.cwiseProduct(WtV).cwiseQuotient(WtWH.array().max(eps).matrix());
        const Eigen::MatrixXd Ht = r.H.transpose();
        const Eigen::MatrixXd VHt = V.lazyProduct(Ht);
        const Eigen::MatrixXd HHt = r.H.lazyProduct(Ht);
        const Eigen::MatrixXd WHHt = r.W.lazyProduct(HHt);
        r.W = r.W.cwiseProduct(VHt).cwiseQuotient(WHHt.array().max(eps).matrix());
    }
    const double nv = V.norm();
    r.relative_error = nv > 0 ? (V - r.W.lazyProduct(r.H)).norm() / nv : 0.0;
    return r;
}

/// Options of build_shell_table.
struct ShellBuildOptions {
    int n_c = 24;            ///< cells in cos theta_1 (paper: 50x50x25 grid per shell)
    int n_u = 16;            ///< cells in omega'_u
    int n_v = 16;            ///< cells in omega'_v
    int k_nn = 32;           ///< neighbours of the k-NN estimate
    int rank = 4;            ///< NMF terms (paper: 4-6)
    /// Multiplicative-update iterations of the NMF.
    int nmf_iterations = 400;
    std::uint64_t seed = 1;  ///< NMF start
    /// true: cell-averaged sample-point k-NN (knn_cell_density_grid, conserves mass);
    /// false: the paper's balloon k-NN at cell centres (knn_density_grid).
    bool cell_average = true;
    /// true: NMF of the rows scaled by 1/sqrt(row mass), rows rescaled to their k-NN mass
    /// afterwards (exact position marginal); false: plain NMF of the density and no rescaling
    /// (the paper's factorization; its Frobenius fit favours the forward peak, which biased the
    /// mean exit cosine of glass spheres (r = 8 R, rank 5) by +0.023 vs -0.014 for the unfactored
    /// grid and -0.023 with the weighting).
    bool row_weighted_nmf = true;
    /// Layout of the cos theta_1 cells. uniform_angle (default): equal widths in theta_1, so the
    /// forward peak of small shells keeps its shape (with equal cos cells, 24 of them, the glass
    /// spheres' r = 2 R table lost 0.04 of the mean cosine between entry and exit direction, the
    /// cause of most of Fig. 9's shell bias at quick, docs/moon07.md); the k-NN runs in the cell
    /// coordinate.
    ShellCosCells cos_cells = ShellCosCells::uniform_angle;
};

/// A built table and what it cost in accuracy.
struct ShellBuildResult {
    /// The built shell table (validated).
    ShellTable table;
    Eigen::MatrixXd density;               ///< k-NN density V: rows (shell, cos cell), cols (u, v) cells; per path, per (cos, u, v) volume
    std::vector<double> knn_integral;      ///< per shell: integral of the raw k-NN density (should be p_scattered)
    double nmf_relative_error = 0;         ///< ||V - W H||_F / ||V||_F of the stored factors
};

/// The k-NN density matrix V of `s` (rows (shell i, cos cell j) = i n_c + j, cols u + n_u v) and
/// its per-shell integrals.
[[nodiscard]] inline Eigen::MatrixXd shell_density_matrix(const ShellSamples& s, const ShellBuildOptions& o,
                                                          std::vector<double>* integrals = nullptr) {
    const std::size_t ns = s.n_shells(), nd = std::size_t(o.n_u) * o.n_v;
    Eigen::MatrixXd V(Eigen::Index(ns * o.n_c), Eigen::Index(nd));
    if (integrals) integrals->assign(ns, 0.0);
    const double cell = 2.0 / (double(o.n_c) * nd);
    std::vector<float> warped;
    for (std::size_t i = 0; i < ns; ++i) {
        // The k-NN runs in the cell coordinate 2 t - 1 of the table's cos layout (t of
        // ShellTable::cos_cell_coordinate): equal cells there, so V is per unit of that coordinate
        // (only row masses and within-row ratios are used by ShellMedium).
        std::span<const float> pts(s.coords[i]);
        if (o.cos_cells != ShellCosCells::uniform_cos) {
            warped.assign(s.coords[i].begin(), s.coords[i].end());
            for (std::size_t q = 0; q < warped.size(); q += 3)
                warped[q] = float(2.0 * ShellTable::cos_cell_coordinate(o.cos_cells, double(warped[q])) - 1.0);
            pts = std::span<const float>(warped);
        }
        const std::vector<double> g =
            o.cell_average ? knn_cell_density_grid(pts, double(s.n_paths), o.k_nn, o.n_c, o.n_u, o.n_v)
                           : knn_density_grid(pts, double(s.n_paths), o.k_nn, o.n_c, o.n_u, o.n_v);
        for (std::size_t j = 0; j < std::size_t(o.n_c); ++j)
            for (std::size_t q = 0; q < nd; ++q) {
                V(Eigen::Index(i * o.n_c + j), Eigen::Index(q)) = g[j * nd + q];
                if (integrals) (*integrals)[i] += g[j * nd + q] * cell;
            }
    }
    return V;
}

/// Moon07 Sec. 4.1 preprocessing: k-NN density on the grid, NMF, f_a from the first free paths.
[[nodiscard]] inline ShellBuildResult build_shell_table(const ShellSamples& s, const ShellBuildOptions& o = {}) {
    constexpr const char* where = "build_shell_table";
    check_argument(s.n_paths >= 1, where, "n_paths", s.n_paths, ">= 1");
    check_argument(o.n_c >= 1 && o.n_u >= 1 && o.n_v >= 1, where, "grid size", std::min({o.n_c, o.n_u, o.n_v}), ">= 1");
    ShellBuildResult res;
    res.density = shell_density_matrix(s, o, &res.knn_integral);
    // Row-weighted NMF: rows (shell, cos cell) scaled by 1/sqrt(row mass) (for Poisson-like
    // counts this evens out the noise level across rows, so the weak backward cells are fitted
    // too), then each row's mass is restored exactly: the exit-position marginal p_r(y) of the
    // stored factors equals the k-NN one.
    const Eigen::VectorXd row_mass = res.density.rowwise().sum();
    Eigen::MatrixXd cond = res.density;
    if (o.row_weighted_nmf)
        for (Eigen::Index r = 0; r < cond.rows(); ++r)
            if (row_mass(r) > 0) cond.row(r) /= std::sqrt(row_mass(r));
    NmfResult f = nmf(cond, o.rank, o.nmf_iterations, o.seed);
    const Eigen::VectorXd h_sum = f.H.rowwise().sum();
    for (Eigen::Index r = 0; r < f.W.rows() && o.row_weighted_nmf; ++r) {
        const double m = f.W.row(r).dot(h_sum);
        if (m > 0) f.W.row(r) *= row_mass(r) / m;
    }
    const double nv = res.density.norm();
    res.nmf_relative_error = nv > 0 ? (res.density - f.W.lazyProduct(f.H)).norm() / nv : 0.0;
    ShellTable& t = res.table;
    t.radii = s.radii;
    t.n_c = o.n_c;
    t.n_u = o.n_u;
    t.n_v = o.n_v;
    t.rank = o.rank;
    t.cos_cells = o.cos_cells;
    t.n_paths = s.n_paths;
    const double N = double(s.n_paths);
    for (std::size_t i = 0; i < s.n_shells(); ++i) {
        t.p_unscattered.push_back(double(s.n_unscattered[i]) / N);
        t.p_absorbed.push_back(double(s.n_absorbed[i]) / N);
        // From the integer count of scattered paths: exactly 0 when none scattered (1 - p_u - p_a
        // in floating point can leave a round-off residue such as 5.6e-17).
        const std::uint64_t n_done = std::uint64_t(s.n_unscattered[i]) + std::uint64_t(s.n_absorbed[i]);
        const std::uint64_t n_scat = s.n_paths > n_done ? s.n_paths - n_done : 0;
        t.p_scattered.push_back(double(n_scat) / N);
    }
    t.W.resize(std::size_t(f.W.size()));
    for (Eigen::Index r = 0; r < f.W.rows(); ++r)
        for (Eigen::Index k = 0; k < f.W.cols(); ++k) t.W[std::size_t(r * f.W.cols() + k)] = std::max(0.0, f.W(r, k));
    t.H.resize(std::size_t(f.H.size()));
    for (Eigen::Index k = 0; k < f.H.rows(); ++k)
        for (Eigen::Index q = 0; q < f.H.cols(); ++q) t.H[std::size_t(k * f.H.cols() + q)] = std::max(0.0, f.H(k, q));
    // f_a(d_j) = P(first free path > d_j), d_j = j d_max / nb.
    const std::size_t nb = s.fa_counts.size() - 1;
    t.fa_d_max = s.fa_d_max;
    t.fa.assign(nb + 1, 0.0);
    std::uint64_t above = 0;
    for (std::size_t j = nb + 1; j-- > 0;) {
        if (j < nb) above += s.fa_counts[j];  // counts in [d_j, d_{j+1})
        t.fa[j] = double(above + s.fa_counts[nb]) / N;
    }
    t.fa[0] = 1.0;
    t.validate();
    return res;
}

}  // namespace grainlight
