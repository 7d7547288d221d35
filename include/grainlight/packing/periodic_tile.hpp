/// @file grainlight/packing/periodic_tile.hpp
/// A periodic cubic tile of equal, non-overlapping spheres (Meng15 Sec. 3.1, "Tiled sphere
/// packings") and queries on the infinite tiling it generates: spheres overlapping a box, the
/// first sphere hit along a ray, the sphere containing a point.
///
/// Conventions. The tile is the cube [0, L)^3; tile (i, j, k) (64-bit integers) of the infinite
/// tiling occupies [i L, (i+1) L) x ... and holds a copy of every sphere shifted by (i, j, k) L.
/// A sphere of the tiling is named by (sphere id in the tile, tile index). Overlap checks use the
/// minimum-image convention, so spheres near a face do not overlap images across it.
///
/// Ray queries use a uniform cell grid inside the tile (each cell lists the spheres, with their
/// periodic image, whose bounding box overlaps it) and an Amanatides-Woo DDA across cells of the
/// infinite tiling with 64-bit cell indices. A ray may be given as (origin tile, local origin) so
/// positions in billion-grain aggregates keep full precision.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/serialization.hpp"

namespace grainlight {

/// A sphere of the infinite tiling: its id inside the tile, the tile it belongs to, and its
/// centre in world coordinates (tile * L + centre in the tile).
struct TileSphereRef {
    /// Sphere id inside the tile.
    std::uint32_t sphere = 0;
    /// Tile the sphere belongs to (absolute index).
    Vec3i64 tile{0, 0, 0};
    /// Sphere centre in world coordinates.
    Vec3d center{0.0};
};

/// Result of a ray query on the tiling: the sphere hit, the ray parameters where the ray enters
/// and leaves it (t_enter may be below the query's t_min when the ray starts inside the sphere).
struct TileHit {
    /// True if a sphere was hit.
    bool hit = false;
    /// Ray parameter where the ray enters the sphere (may be below t_min if it starts inside).
    double t_enter = std::numeric_limits<double>::infinity();
    /// Ray parameter where the ray leaves the sphere.
    double t_exit = std::numeric_limits<double>::infinity();
    /// Id of the sphere hit inside the tile.
    std::uint32_t sphere = 0;
    /// Tile of the sphere hit (absolute index).
    Vec3i64 tile{0, 0, 0};
    /// True if a sphere was hit.
    explicit operator bool() const noexcept { return hit; }
};

namespace detail {

/// floor(a / b) for b > 0 on 64-bit integers.
[[nodiscard]] constexpr std::int64_t floor_div(std::int64_t a, std::int64_t b) noexcept {
    const std::int64_t q = a / b;
    return (a % b != 0 && (a < 0)) ? q - 1 : q;
}

/// floor(x) as a 64-bit integer, saturated to +-2^62 (so far-away boxes cannot overflow).
[[nodiscard]] inline std::int64_t floor_i64(double x) noexcept {
    constexpr double lim = 4.6e18;
    if (!(x > -lim)) return -(std::int64_t(1) << 62);
    if (!(x < lim)) return std::int64_t(1) << 62;
    // Truncate, then step down for negative non-integers: exact, and no library call (std::floor
    // is one without SSE4.1, several per traced ray).
    const auto i = static_cast<std::int64_t>(x);
    return i - (static_cast<double>(i) > x ? 1 : 0);
}

/// Cells per axis of a cell grid over a periodic cube of side `side` whose cells are at least
/// `min_width` wide, for `n` points: floor(side / min_width), but at most max(4, (16 n)^(1/3))
/// and 256, so tiny radii (or hostile files) cannot request huge grids. Wider cells keep every
/// neighbour search correct.
[[nodiscard]] inline std::int64_t grid_cells_per_axis(double side, double min_width, std::size_t n) noexcept {
    const double cap = std::min(256.0, std::max(4.0, std::floor(std::cbrt(16.0 * double(n)))));
    const double m = side / min_width;
    return static_cast<std::int64_t>(std::clamp(std::isfinite(m) ? std::floor(m) : cap, 1.0, cap));
}

/// Calls fn(i, j, r_ij) for every pair of centres (i < j, and also i == j never) whose
/// minimum-image-compatible displacement r_ij = c_j + shift - c_i has |r_ij| < cutoff, in a
/// periodic cube of side `side`. Requires cutoff <= side / 1 (cells of width >= cutoff). With
/// fewer than three cells per axis a pair may be reported more than once (through different
/// images); callers that need minima are unaffected.
template <class Fn>
void for_each_close_pair(const std::vector<Vec3d>& c, double side, double cutoff, Fn&& fn) {
    const std::size_t n = c.size();
    if (n < 2) return;
    const std::int64_t m = grid_cells_per_axis(side, cutoff, n);
    const double w = side / double(m);
    std::vector<std::uint32_t> head(static_cast<std::size_t>(m * m * m), UINT32_MAX), next(n, UINT32_MAX);
    std::vector<std::array<std::int64_t, 3>> cell(n);
    for (std::size_t i = 0; i < n; ++i) {
        std::array<std::int64_t, 3> k{};
        for (int a = 0; a < 3; ++a) k[a] = std::clamp<std::int64_t>(floor_i64(c[i][a] / w), 0, m - 1);
        cell[i] = k;
        const auto id = static_cast<std::size_t>((k[2] * m + k[1]) * m + k[0]);
        next[i] = head[id];
        head[id] = std::uint32_t(i);
    }
    const double cut2 = cutoff * cutoff;
    for (std::size_t i = 0; i < n; ++i) {
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const std::array<std::int64_t, 3> q{cell[i][0] + dx, cell[i][1] + dy, cell[i][2] + dz};
                    Vec3d shift(0.0);
                    std::array<std::int64_t, 3> qw{};
                    for (int a = 0; a < 3; ++a) {
                        const std::int64_t t = floor_div(q[a], m);
                        qw[a] = q[a] - t * m;
                        shift[a] = double(t) * side;
                    }
                    const auto id = static_cast<std::size_t>((qw[2] * m + qw[1]) * m + qw[0]);
                    for (std::uint32_t j = head[id]; j != UINT32_MAX; j = next[j]) {
                        if (j <= i) continue;
                        const Vec3d r = c[j] + shift - c[i];
                        const double d2 = glm::dot(r, r);
                        if (d2 < cut2) fn(std::uint32_t(i), j, r);
                    }
                }
    }
}

}  // namespace detail

/// A periodic cubic tile of N equal non-overlapping spheres (Meng15 Sec. 3.1) with the
/// acceleration structure for queries on its infinite tiling.
///
/// Invariants (checked at construction; grainlight::invalid_argument otherwise): side L > 0,
/// radius R > 0 with 2R < L, all centres finite (they are wrapped into [0, L)), and no two
/// spheres overlap under the minimum-image convention (centre distance >= 2R; touching is
/// allowed). Queries are const, thread-safe, allocation-free (except spheres_overlapping, which
/// returns a vector) and never throw.
class PeriodicTile {
public:
    /// Payload type code and version of the tile file format (see serialization.hpp).
    static constexpr std::uint32_t file_kind = fourcc("TILE");
    /// Version of the tile payload layout.
    static constexpr std::uint32_t file_kind_version = 1;

    /// Build and validate a tile. `cell_size_in_radii` sets the ray-query grid cell width
    /// (about that many radii; the grid has at least one cell per axis).
    PeriodicTile(double side, double radius, std::vector<Vec3d> centers, double cell_size_in_radii = 1.5)
        : side_(side), radius_(radius), centers_(std::move(centers)) {
        constexpr const char* where = "PeriodicTile";
        check_argument(std::isfinite(side) && side > 0, where, "side", side, "finite, > 0");
        check_argument(std::isfinite(radius) && radius > 0, where, "radius", radius, "finite, > 0");
        check_argument(2 * radius < side, where, "radius / side", radius / side, "< 0.5 (a sphere must not touch its own image)");
        check_argument(centers_.size() < std::size_t(UINT32_MAX), where, "number of spheres", centers_.size(), "< 2^32 - 1");
        check_argument(std::isfinite(cell_size_in_radii) && cell_size_in_radii > 0, where, "cell_size_in_radii",
                       cell_size_in_radii, "finite, > 0");
        for (std::size_t i = 0; i < centers_.size(); ++i) {
            auto& c = centers_[i];
            for (int a = 0; a < 3; ++a) {
                check_argument(std::isfinite(c[a]), where, "centers[" + std::to_string(i) + "]", c[a], "finite");
                c[a] -= side * std::floor(c[a] / side);
                if (c[a] >= side) c[a] = 0.0;  // round-off of the wrap
            }
        }
        // No overlaps (minimum image): every pair at distance < 2R is an error.
        const double d2min = sqr(2 * radius);
        detail::for_each_close_pair(centers_, side, 2 * radius, [&](std::uint32_t i, std::uint32_t j, const Vec3d& r) {
            const double d2 = glm::dot(r, r);
            if (d2 < d2min)
                raise_invalid_argument(where, "centers (spheres " + std::to_string(i) + " and " + std::to_string(j) +
                                                  " overlap; centre distance / 2R)",
                                       std::sqrt(d2) / (2 * radius), ">= 1 for every pair");
        });
        max_search_ = 4096.0 * side;
        build_grid(cell_size_in_radii);
    }

    /// Tile side L (world units).
    [[nodiscard]] double side() const noexcept { return side_; }
    /// Sphere radius R (world units).
    [[nodiscard]] double radius() const noexcept { return radius_; }
    /// Number of spheres N in the tile.
    [[nodiscard]] std::size_t size() const noexcept { return centers_.size(); }
    /// Centre of sphere i in the tile, in [0, L)^3.
    [[nodiscard]] const Vec3d& center(std::size_t i) const noexcept { return centers_[i]; }
    /// All centres, in [0, L)^3.
    [[nodiscard]] const std::vector<Vec3d>& centers() const noexcept { return centers_; }
    /// Packing rate f = N (4/3) pi R^3 / L^3.
    [[nodiscard]] double packing_fraction() const noexcept {
        return double(centers_.size()) * (4.0 / 3.0) * pi_v<double> * radius_ * radius_ * radius_ /
               (side_ * side_ * side_);
    }
    /// Cells per axis of the query grid.
    [[nodiscard]] std::int64_t grid_resolution() const noexcept { return m_; }
    /// Smallest centre distance over all pairs (minimum image), or +inf with fewer than 2 spheres
    /// or when every pair is farther apart than L / 2.
    [[nodiscard]] double min_center_distance() const {
        double best = std::numeric_limits<double>::infinity();
        const double cutoff = std::min(side_ * 0.5, std::max(4 * radius_, side_ / 64));
        detail::for_each_close_pair(centers_, side_, cutoff, [&](std::uint32_t, std::uint32_t, const Vec3d& r) {
            best = std::min(best, std::sqrt(glm::dot(r, r)));
        });
        return best;
    }
    /// Distance beyond which first_hit stops searching when t_max is infinite: a ray along a
    /// channel of a periodic packing may never hit a sphere. Default 4096 L.
    [[nodiscard]] double max_search_distance() const noexcept { return max_search_; }
    /// One-line description: sphere count, side, radius and packing fraction.
    [[nodiscard]] std::string to_string() const {
        return "PeriodicTile[" + std::to_string(size()) + " spheres, side " + grainlight::detail::to_display(side_) + ", radius " +
               grainlight::detail::to_display(radius_) + ", packing fraction " + grainlight::detail::to_display(packing_fraction()) + "]";
    }
    /// Set max_search_distance() to d > 0 (world units); throws grainlight::invalid_argument otherwise. Not thread-safe: call before sharing the tile.
    void set_max_search_distance(double d) {
        check_argument(d > 0, "PeriodicTile::set_max_search_distance", "d", d, "> 0");
        max_search_ = d;
    }

    // ---- file I/O --------------------------------------------------------------------------

    /// Serialize into a container payload (side, radius, count, centres as f64).
    [[nodiscard]] std::vector<unsigned char> to_payload() const {
        ByteWriter w;
        w.put(side_).put(radius_).put(std::uint64_t(centers_.size()));
        for (const auto& c : centers_) w.put(c.x).put(c.y).put(c.z);
        return w.take();
    }
    /// Parse a payload; a malformed or invalid one throws grainlight::format_error.
    [[nodiscard]] static PeriodicTile from_payload(const std::vector<unsigned char>& payload,
                                                   const std::string& context = "tile") {
        ByteReader r(payload, context);
        const auto side = r.get<double>();
        const auto radius = r.get<double>();
        const auto n = r.get<std::uint64_t>();
        if (n > r.remaining() / (3 * sizeof(double)))
            r.fail("sphere count " + std::to_string(n) + " exceeds the data");
        std::vector<double> raw;
        r.get_array(raw, 3 * n);
        r.expect_end();
        std::vector<Vec3d> c(static_cast<std::size_t>(n));
        for (std::size_t i = 0; i < c.size(); ++i) c[i] = Vec3d(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);
#if GRAINLIGHT_HAS_EXCEPTIONS
        try {
            return PeriodicTile(side, radius, std::move(c));
        } catch (const invalid_argument& e) {
            raise_error<format_error>(context + ": invalid tile: " + e.what());
        }
#else
        return PeriodicTile(side, radius, std::move(c));
#endif
    }
    /// Write the tile to `path` atomically (grainlight container, kind TILE v1).
    void save(const std::filesystem::path& path) const {
        write_container_atomic(path, file_kind, file_kind_version, to_payload());
    }
    /// Load a tile; grainlight::format_error on truncated/corrupt/wrong-version/invalid files,
    /// grainlight::io_error if the file cannot be read.
    [[nodiscard]] static PeriodicTile load(const std::filesystem::path& path) {
        return from_payload(read_container(path, file_kind, file_kind_version), "'" + path.string() + "'");
    }

    // ---- queries on the infinite tiling ------------------------------------------------------

    /// Calls fn(const TileSphereRef&) once for every sphere of the infinite tiling whose ball
    /// intersects the axis-aligned box [lo, hi] (world coordinates; closed box, open ball).
    template <class Fn>
    void for_each_overlapping(const Vec3d& lo, const Vec3d& hi, Fn&& fn) const {
        if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) return;
        // Cells overlapping the box, widened by a round-off margin so the reference cell
        // (computed in the sphere's home frame below) is always visited.
        std::array<std::int64_t, 3> g0{}, g1{};
        for (int a = 0; a < 3; ++a) {
            const double eps = 1e-7 * h_ + 1e-12 * (std::abs(lo[a]) + std::abs(hi[a]));
            g0[a] = detail::floor_i64((lo[a] - eps) / h_);
            g1[a] = detail::floor_i64((hi[a] + eps) / h_);
        }
        const double r2 = radius_ * radius_;
        for (std::int64_t gz = g0[2]; gz <= g1[2]; ++gz)
            for (std::int64_t gy = g0[1]; gy <= g1[1]; ++gy)
                for (std::int64_t gx = g0[0]; gx <= g1[0]; ++gx) {
                    const std::array<std::int64_t, 3> g{gx, gy, gz};
                    std::array<std::int64_t, 3> t{}, j{};
                    for (int a = 0; a < 3; ++a) {
                        t[a] = detail::floor_div(g[a], m_);
                        j[a] = g[a] - t[a] * m_;
                    }
                    const auto cell = static_cast<std::size_t>((j[2] * m_ + j[1]) * m_ + j[0]);
                    for (std::uint32_t e = cell_start_[cell]; e < cell_start_[cell + 1]; ++e) {
                        const Entry& en = entries_[e];
                        const Vec3d& c = centers_[en.sphere];
                        std::array<std::int64_t, 3> s{};
                        double d2 = 0;
                        bool is_ref = true;
                        for (int a = 0; a < 3; ++a) {
                            s[a] = t[a] + en.image[a];
                            const double base = double(s[a]) * side_;
                            const double lo_s = lo[a] - base, hi_s = hi[a] - base;
                            const double q = std::clamp(c[a], lo_s, hi_s);
                            d2 += sqr(q - c[a]);
                            // Reference cell (home frame): the cell of the lower corner of
                            // (sphere bbox ∩ box); report the sphere only from that cell.
                            const double p = std::max(c[a] - radius_, lo_s);
                            const std::int64_t k = std::clamp(detail::floor_i64(p / h_),
                                                              detail::floor_i64((c[a] - radius_) / h_),
                                                              detail::floor_i64((c[a] + radius_) / h_));
                            if (s[a] * m_ + k != g[a]) is_ref = false;
                        }
                        if (!is_ref || !(d2 < r2)) continue;
                        TileSphereRef ref;
                        ref.sphere = en.sphere;
                        ref.tile = Vec3i64(s[0], s[1], s[2]);
                        ref.center = Vec3d(double(s[0]) * side_ + c.x, double(s[1]) * side_ + c.y,
                                           double(s[2]) * side_ + c.z);
                        fn(ref);
                    }
                }
    }
    /// All spheres of the infinite tiling intersecting the box [lo, hi] (see for_each_overlapping).
    [[nodiscard]] std::vector<TileSphereRef> spheres_overlapping(const Vec3d& lo, const Vec3d& hi) const {
        std::vector<TileSphereRef> out;
        for_each_overlapping(lo, hi, [&](const TileSphereRef& r) { out.push_back(r); });
        return out;
    }

    /// First sphere of the infinite tiling along the ray o + t d (o given as origin tile index and
    /// a local offset from that tile's corner; d need not be unit length, t is in units of d)
    /// whose interval [t_enter, t_exit] satisfies t_exit > t_min and t_enter <= t_max.
    /// A ray starting inside a sphere reports that sphere (t_enter < t_min). To continue past a
    /// hit, call again with t_min = hit.t_exit (exactly that value: the same sphere is then
    /// excluded because its recomputed t_exit is bit-identical). With t_max = inf the search
    /// stops after max_search_distance() / |d| (a ray along a channel may never hit).
    [[nodiscard]] TileHit first_hit(const Vec3i64& origin_tile, const Vec3d& local_origin, const Vec3d& d,
                                    double t_min, double t_max) const noexcept {
        TileHit best;
        const double dlen = std::sqrt(glm::dot(d, d));
        if (centers_.empty() || !(dlen > 0) || !(t_min <= t_max)) return best;
        const double t_end = std::min(t_max, t_min + max_search_ / dlen);
        // Re-centre the frame on the tile containing the origin. The frame depends on the ray
        // only (not on t_min), so a sphere's t_enter/t_exit are bit-identical across calls.
        Vec3d o = local_origin;
        Vec3i64 frame = origin_tile;
        for (int a = 0; a < 3; ++a) {
            const std::int64_t k = detail::floor_i64(o[a] / side_);
            frame[a] += k;
            o[a] -= double(k) * side_;
        }
        const Vec3d p0 = o + t_min * d;
        std::array<std::int64_t, 3> r{}, step{};
        std::array<double, 3> t_next{};
        for (int a = 0; a < 3; ++a) {
            r[a] = detail::floor_i64(p0[a] / h_);
            step[a] = d[a] > 0 ? 1 : (d[a] < 0 ? -1 : 0);
            t_next[a] = next_crossing(r[a], step[a], o[a], d[a]);
        }
        const double a_dd = dlen * dlen;
        const double r2 = radius_ * radius_;
        double t_cell = t_min;
        while (t_cell <= t_end) {
            const int axis = (t_next[0] < t_next[1]) ? (t_next[0] < t_next[2] ? 0 : 2) : (t_next[1] < t_next[2] ? 1 : 2);
            const double t_exit_cell = t_next[axis];
            std::array<std::int64_t, 3> tile{}, j{};
            for (int a = 0; a < 3; ++a) {
                tile[a] = detail::floor_div(r[a], m_);
                j[a] = r[a] - tile[a] * m_;
            }
            const auto cell = static_cast<std::size_t>((j[2] * m_ + j[1]) * m_ + j[0]);
            for (std::uint32_t e = cell_start_[cell]; e < cell_start_[cell + 1]; ++e) {
                const Entry& en = entries_[e];
                // Centre from the sphere's home tile (unique per sphere of the tiling).
                const std::array<std::int64_t, 3> home{tile[0] + en.image[0], tile[1] + en.image[1],
                                                       tile[2] + en.image[2]};
                const Vec3d c(double(home[0]) * side_ + en.c.x, double(home[1]) * side_ + en.c.y,
                              double(home[2]) * side_ + en.c.z);
                double t0, t1;
                if (!intersect_sphere(o, d, a_dd, c, r2, t0, t1)) continue;
                if (!(t1 > t_min) || t0 > t_end || !(t0 < best.t_enter)) continue;
                best.hit = true;
                best.t_enter = t0;
                best.t_exit = t1;
                best.sphere = en.sphere;
                best.tile = Vec3i64(frame.x + home[0], frame.y + home[1], frame.z + home[2]);
            }
            if (best.hit && std::max(best.t_enter, t_min) <= t_exit_cell) break;
            if (!(t_exit_cell < std::numeric_limits<double>::infinity())) break;
            r[axis] += step[axis];
            t_next[axis] = next_crossing(r[axis], step[axis], o[axis], d[axis]);
            t_cell = t_exit_cell;
        }
        if (best.hit && best.t_enter > t_end) best = TileHit{};
        return best;
    }
    /// The spheres of the infinite tiling along o + t d, in order of entry, in one walk over the
    /// query grid: calls visit(const TileHit&) for every sphere whose interval satisfies
    /// t_exit > t_min and t_enter <= t_max (the spheres, with bit-identical t_enter / t_exit,
    /// that repeated first_hit calls return when each restarts at the previous hit's t_exit), and
    /// stops as soon as visit returns true (walk_spheres then returns true; false when the ray is
    /// exhausted). With t_max = inf the walk stops after max_search_distance() / |d|.
    /// `tile_filter(const Vec3i64& tile)` is called once each time the walk enters a tile
    /// (absolute index, the origin tile included); while it returns false the cells of that tile
    /// are not searched, so a sphere is reported only if its chord meets a tile the filter
    /// accepted (the caller asserts it wants no sphere overlapping a rejected tile). The order and
    /// the intervals of the spheres reported do not depend on the filter. No allocation; throws
    /// only what the callbacks throw.
    ///
    /// Cost: one Amanatides-Woo step per grid cell (the tile index and the cell id are updated
    /// incrementally, no division or floor per step); per listed sphere a division-free cull
    /// (the sphere lies before the last reported exit, after t_max, behind the current nearest
    /// candidate, or farther than R from the ray line, each with a conservative round-off
    /// margin), and intersect_sphere (the exact test of first_hit) only on the survivors.
    ///
    /// `MaxCandidates` (>= 1) is the capacity of the list of spheres found ahead of the walk (see
    /// the body); any capacity gives the same spheres, a small one only rescans cells more often.
    template <int MaxCandidates = 8, class TileFilter, class Visit>
        requires(MaxCandidates >= 1)
    bool walk_spheres(const Vec3i64& origin_tile, const Vec3d& local_origin, const Vec3d& d, double t_min,
                      double t_max, TileFilter&& tile_filter, Visit&& visit) const
        noexcept(noexcept(tile_filter(std::declval<const Vec3i64&>())) && noexcept(visit(std::declval<const TileHit&>()))) {
        const double dlen = std::sqrt(glm::dot(d, d));
        if (centers_.empty() || !(dlen > 0) || !(t_min <= t_max)) return false;
        const double t_end = std::min(t_max, t_min + max_search_ / dlen);
        // The same frame as first_hit (it depends on the ray only), so the intervals are identical.
        Vec3d o = local_origin;
        Vec3i64 frame = origin_tile;
        for (int a = 0; a < 3; ++a) {
            const std::int64_t k = detail::floor_i64(o[a] / side_);
            frame[a] += k;
            o[a] -= double(k) * side_;
        }
        const Vec3d p0 = o + t_min * d;
        std::array<std::int64_t, 3> r{}, step{}, tile{}, j{};
        std::array<double, 3> t_next{};
        // base[a][i + 1]: corner coordinate of the home tile of image i of the current tile
        // (double(home) * side, exactly as first_hit computes it).
        std::array<std::array<double, 3>, 3> base{};
        auto set_base = [&](int a) {
            for (int i = 0; i < 3; ++i) base[a][i] = double(tile[a] + i - 1) * side_;
        };
        for (int a = 0; a < 3; ++a) {
            r[a] = detail::floor_i64(p0[a] / h_);
            step[a] = d[a] > 0 ? 1 : (d[a] < 0 ? -1 : 0);
            t_next[a] = next_crossing(r[a], step[a], o[a], d[a]);
            // tile = floor(r / m) without a 64-bit integer division: the tile of p0, corrected
            // by the cell index (the two floors may disagree by one at a tile face).
            constexpr std::int64_t near = std::int64_t(1) << 40;  // far rays: the plain division
            tile[a] = r[a] > -near && r[a] < near ? detail::floor_i64(p0[a] / side_) : detail::floor_div(r[a], m_);
            j[a] = r[a] - tile[a] * m_;
            while (j[a] < 0) {
                --tile[a];
                j[a] += m_;
            }
            while (j[a] >= m_) {
                ++tile[a];
                j[a] -= m_;
            }
            set_base(a);
        }
        const double a_dd = dlen * dlen;
        const double r2 = radius_ * radius_;
        double cursor = t_min;             // every sphere exiting at or before this was reported
        // The candidates found since the list was last cleared: spheres of the scanned cells hit by
        // the ray with t1 > cursor and t0 <= t_end, ascending t0, each sphere once. While nothing
        // was dropped the list holds every such sphere, so after a visit the next one is its
        // front and the cell is not scanned again (most rays). A full list drops its last
        // candidate and becomes lossy: the next visit clears it and rescans the current cell,
        // which is always complete (a sphere whose entry point lies in an earlier cell was visited
        // before the walk left that cell; one whose entry lies ahead is listed in a later cell).
        struct Candidate {
            double t0, t1;
            const Entry* e;
            std::array<std::int64_t, 3> home;
        };
        constexpr int max_candidates = MaxCandidates;
        std::array<Candidate, max_candidates> cand;
        int n_cand = 0;
        bool lossy = false;
        auto insert = [&](const Candidate& c) {
            for (int i = 0; i < n_cand; ++i)  // the same sphere through another cell
                if (cand[std::size_t(i)].e->sphere == c.e->sphere && cand[std::size_t(i)].home == c.home) return;
            int i = n_cand;
            if (n_cand == max_candidates) {
                lossy = true;
                if (!(c.t0 < cand[max_candidates - 1].t0)) return;
                i = max_candidates - 1;
            } else {
                ++n_cand;
            }
            for (; i > 0 && c.t0 < cand[std::size_t(i - 1)].t0; --i) cand[std::size_t(i)] = cand[std::size_t(i - 1)];
            cand[std::size_t(i)] = c;
        };
        // Cull in float over the cell's candidates (structure of arrays, 8 lanes, vectorized by
        // the compiler), relative to the ray point at the cell entry so the magnitudes stay a
        // few cells: g = centre - P, s = g . u (u = d / |d|). A sphere survives unless it ends
        // before the cursor (s + R < (cursor - t_cell) |d|), starts after t_end, or lies farther
        // than R from the ray line (|g|^2 - s^2 > R^2); the margins (1e-4 L, 1e-4 L^2) are
        // orders of magnitude above the float round-off, so no sphere first_hit would report is
        // culled. Survivors get the exact double test of first_hit.
        const float ux = float(d.x / dlen), uy = float(d.y / dlen), uz = float(d.z / dlen);
        const double tol = 1e-4 * side_;
        const float lim = float(r2 + tol * side_);
        auto scan = [&](std::size_t cell, double t_ref) {
            const Vec3d P = o + t_ref * d;
            const float qx = float(base[0][1] - P.x), qy = float(base[1][1] - P.y), qz = float(base[2][1] - P.z);
            const float lo = float((cursor - t_ref) * dlen - radius_ - tol);
            const float hi = float((t_end - t_ref) * dlen + radius_ + tol);
            const std::uint32_t e_end = cell_start_[cell + 1];
            for (std::uint32_t e0 = cell_start_[cell]; e0 < e_end; e0 += cull_lanes) {
                const float* px = cx_.data() + e0;
                const float* py = cy_.data() + e0;
                const float* pz = cz_.data() + e0;
                std::uint32_t mask = 0;
                for (unsigned k = 0; k < cull_lanes; ++k) {  // branch-free: vectorized at -O3
                    const float gx = px[k] + qx, gy = py[k] + qy, gz = pz[k] + qz;
                    const float sp = gx * ux + gy * uy + gz * uz;
                    const float gg = gx * gx + gy * gy + gz * gz;
                    const bool keep = (sp >= lo) & (sp <= hi) & (gg - sp * sp <= lim);
                    mask |= keep ? lane_bit[k] : 0u;
                }
                if (e_end - e0 < cull_lanes) mask &= (1u << (e_end - e0)) - 1u;
                while (mask) {
                    const Entry* en = entries_.data() + e0 + unsigned(std::countr_zero(mask));
                    mask &= mask - 1;
                    const Vec3d c(base[0][en->image[0] + 1] + en->c.x, base[1][en->image[1] + 1] + en->c.y,
                                  base[2][en->image[2] + 1] + en->c.z);
                    double t0, t1;
                    if (!intersect_sphere(o, d, a_dd, c, r2, t0, t1)) continue;
                    if (!(t1 > cursor) || t0 > t_end) continue;
                    insert(Candidate{t0, t1, en, {tile[0] + en->image[0], tile[1] + en->image[1], tile[2] + en->image[2]}});
                }
            }
        };
        bool searched = tile_filter(Vec3i64(frame.x + tile[0], frame.y + tile[1], frame.z + tile[2]));
        auto cell = static_cast<std::size_t>((j[2] * m_ + j[1]) * m_ + j[0]);
        double t_cell = t_min;
        while (t_cell <= t_end) {
            if (!searched && n_cand == 0) {
                // A rejected tile with nothing pending: none of its cells is scanned, so the walk
                // jumps to the cell where the ray leaves it instead of stepping through its cells.
                // The exit is computed with next_crossing on the tile's last cell per axis (the
                // times the cell-by-cell walk would reach), the other axes' cells from the exit
                // point, corrected so that each cell's crossings bracket the exit time.
                int ax = -1;
                double tx = std::numeric_limits<double>::infinity();
                for (int a = 0; a < 3; ++a) {
                    if (step[a] == 0) continue;
                    const double ta = next_crossing(tile[a] * m_ + (step[a] > 0 ? m_ - 1 : 0), step[a], o[a], d[a]);
                    if (ta < tx) {
                        tx = ta;
                        ax = a;
                    }
                }
                if (ax < 0 || !(tx <= t_end)) break;  // the ray ends in this tile: nothing to report
                for (int a = 0; a < 3; ++a) {
                    if (step[a] == 0) continue;
                    std::int64_t ra;
                    if (a == ax) {
                        ra = step[a] > 0 ? (tile[a] + 1) * m_ : tile[a] * m_ - 1;
                    } else {
                        ra = detail::floor_i64((o[a] + tx * d[a]) / h_);
                        ra = step[a] > 0 ? std::max(ra, r[a]) : std::min(ra, r[a]);  // never backwards
                        for (int k = 0; k < 4 && next_crossing(ra, step[a], o[a], d[a]) <= tx; ++k) ra += step[a];
                        for (int k = 0; k < 4 && ra != r[a] && next_crossing(ra - step[a], step[a], o[a], d[a]) > tx; ++k)
                            ra -= step[a];
                    }
                    r[a] = ra;
                    t_next[a] = next_crossing(ra, step[a], o[a], d[a]);
                    const std::int64_t ta = detail::floor_div(ra, m_);
                    j[a] = ra - ta * m_;
                    if (ta != tile[a]) {
                        tile[a] = ta;
                        set_base(a);
                    }
                }
                cell = static_cast<std::size_t>((j[2] * m_ + j[1]) * m_ + j[0]);
                t_cell = tx;
                searched = tile_filter(Vec3i64(frame.x + tile[0], frame.y + tile[1], frame.z + tile[2]));
                continue;
            }
            const int axis = (t_next[0] < t_next[1]) ? (t_next[0] < t_next[2] ? 0 : 2) : (t_next[1] < t_next[2] ? 1 : 2);
            const double t_exit_cell = t_next[axis];
            if (searched) scan(cell, t_cell);
            // Every sphere entering before this cell's exit overlaps a cell visited so far: the
            // nearest candidate is final.
            while (n_cand > 0 && std::max(cand[0].t0, t_min) <= t_exit_cell) {
                const Candidate& b = cand[0];
                TileHit h;
                h.hit = true;
                h.t_enter = b.t0;
                h.t_exit = b.t1;
                h.sphere = b.e->sphere;
                h.tile = Vec3i64(frame.x + b.home[0], frame.y + b.home[1], frame.z + b.home[2]);
                cursor = b.t1;
                if (visit(static_cast<const TileHit&>(h))) return true;
                if (lossy) {
                    n_cand = 0;
                    lossy = false;
                    if (searched) scan(cell, t_cell);
                } else if constexpr (max_candidates > 1) {  // drop the front and what the cursor passed
                    int k = 0;
                    for (int i = 1; i < n_cand; ++i)
                        if (cand[std::size_t(i)].t1 > cursor) cand[std::size_t(k++)] = cand[std::size_t(i)];
                    n_cand = k;
                } else {
                    n_cand = 0;
                }
            }
            if (!(t_exit_cell < std::numeric_limits<double>::infinity())) break;
            r[axis] += step[axis];
            j[axis] += step[axis];
            bool new_tile = false;
            if (j[axis] == m_) {
                j[axis] = 0;
                ++tile[axis];
                new_tile = true;
            } else if (j[axis] < 0) {
                j[axis] = m_ - 1;
                --tile[axis];
                new_tile = true;
            }
            if (new_tile) {
                set_base(axis);
                searched = tile_filter(Vec3i64(frame.x + tile[0], frame.y + tile[1], frame.z + tile[2]));
            }
            cell = static_cast<std::size_t>((j[2] * m_ + j[1]) * m_ + j[0]);
            t_next[axis] = next_crossing(r[axis], step[axis], o[axis], d[axis]);
            t_cell = t_exit_cell;
        }
        return false;
    }
    /// first_hit for a ray in world coordinates (tile 0 frame).
    template <std::floating_point F>
    [[nodiscard]] TileHit first_hit(const Ray<F>& ray, F t_min, F t_max) const noexcept {
        return first_hit(Vec3i64(0, 0, 0), Vec3d(ray.o), Vec3d(ray.d), double(t_min), double(t_max));
    }

    /// The sphere of the infinite tiling containing the world point p (strictly inside), if any.
    [[nodiscard]] std::optional<TileSphereRef> sphere_containing(const Vec3d& p) const noexcept {
        std::array<std::int64_t, 3> t{}, j{};
        for (int a = 0; a < 3; ++a) {
            const std::int64_t g = detail::floor_i64(p[a] / h_);
            t[a] = detail::floor_div(g, m_);
            j[a] = g - t[a] * m_;
        }
        const auto cell = static_cast<std::size_t>((j[2] * m_ + j[1]) * m_ + j[0]);
        const double r2 = radius_ * radius_;
        for (std::uint32_t e = cell_start_[cell]; e < cell_start_[cell + 1]; ++e) {
            const Entry& en = entries_[e];
            const Vec3d c(double(t[0] + en.image[0]) * side_ + en.c.x, double(t[1] + en.image[1]) * side_ + en.c.y,
                          double(t[2] + en.image[2]) * side_ + en.c.z);
            const Vec3d v = p - c;
            if (glm::dot(v, v) < r2) {
                TileSphereRef ref;
                ref.sphere = en.sphere;
                ref.tile = Vec3i64(t[0] + en.image[0], t[1] + en.image[1], t[2] + en.image[2]);
                ref.center = c;
                return ref;
            }
        }
        return std::nullopt;
    }

    /// Ray-sphere intersection used by the queries (numerically robust form, Haines et al.,
    /// Ray Tracing Gems ch. 7): t0 <= t1 are the entry/exit parameters of o + t d.
    [[nodiscard]] static bool intersect_sphere(const Vec3d& o, const Vec3d& d, double dd, const Vec3d& c, double r2,
                                               double& t0, double& t1) noexcept {
        const Vec3d f = o - c;
        const double b = -glm::dot(f, d);           // half of -B
        const Vec3d l = f + (b / dd) * d;           // perpendicular offset from the centre
        const double disc = dd * (r2 - glm::dot(l, l));
        if (disc < 0) return false;
        const double cc = glm::dot(f, f) - r2;
        const double q = b + std::copysign(std::sqrt(disc), b);
        if (q == 0) {
            t0 = t1 = 0;
            return disc > 0 || cc <= 0;
        }
        const double ta = cc / q, tb = q / dd;
        t0 = std::min(ta, tb);
        t1 = std::max(ta, tb);
        return true;
    }

private:
    struct Entry {
        Vec3d c;                     // centre in the sphere's home tile (copy of centers_[sphere])
        std::uint32_t sphere;        // sphere id
        std::array<std::int8_t, 3> image;  // sphere's home tile = cell's tile + image
    };

    [[nodiscard]] double next_crossing(std::int64_t r, std::int64_t step, double o, double d) const noexcept {
        if (step == 0) return std::numeric_limits<double>::infinity();
        const double boundary = double(r + (step > 0 ? 1 : 0)) * h_;
        return (boundary - o) / d;
    }

    void build_grid(double cell_size_in_radii) {
        const double target = cell_size_in_radii * radius_;
        m_ = detail::grid_cells_per_axis(side_, target, centers_.size());
        h_ = side_ / double(m_);
        const auto ncell = static_cast<std::size_t>(m_ * m_ * m_);
        std::vector<std::uint32_t> counts(ncell + 1, 0);
        // Two passes: count, then fill (CSR layout).
        auto visit = [&](auto&& emit) {
            for (std::size_t s = 0; s < centers_.size(); ++s) {
                const Vec3d& c = centers_[s];
                std::array<std::int64_t, 3> k0{}, k1{};
                for (int a = 0; a < 3; ++a) {
                    k0[a] = detail::floor_i64((c[a] - radius_) / h_);
                    k1[a] = detail::floor_i64((c[a] + radius_) / h_);
                }
                for (std::int64_t kz = k0[2]; kz <= k1[2]; ++kz)
                    for (std::int64_t ky = k0[1]; ky <= k1[1]; ++ky)
                        for (std::int64_t kx = k0[0]; kx <= k1[0]; ++kx) {
                            const std::array<std::int64_t, 3> k{kx, ky, kz};
                            std::array<std::int64_t, 3> off{}, j{};
                            for (int a = 0; a < 3; ++a) {
                                off[a] = detail::floor_div(k[a], m_);
                                j[a] = k[a] - off[a] * m_;
                            }
                            emit(static_cast<std::size_t>((j[2] * m_ + j[1]) * m_ + j[0]), std::uint32_t(s), off);
                        }
            }
        };
        visit([&](std::size_t cell, std::uint32_t, const std::array<std::int64_t, 3>&) { ++counts[cell + 1]; });
        for (std::size_t i = 0; i < ncell; ++i) counts[i + 1] += counts[i];
        cell_start_ = counts;
        entries_.resize(cell_start_[ncell]);
        std::vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
        visit([&](std::size_t cell, std::uint32_t s, const std::array<std::int64_t, 3>& off) {
            Entry e;
            e.sphere = s;
            for (int a = 0; a < 3; ++a) {
                e.image[a] = static_cast<std::int8_t>(-off[a]);
                e.c[a] = centers_[s][a];
            }
            entries_[fill[cell]++] = e;
        });
        cx_.assign(entries_.size() + cull_lanes, 0.0f);
        cy_.assign(entries_.size() + cull_lanes, 0.0f);
        cz_.assign(entries_.size() + cull_lanes, 0.0f);
        for (std::size_t i = 0; i < entries_.size(); ++i) {
            cx_[i] = float(entries_[i].c.x + double(entries_[i].image[0]) * side_);
            cy_[i] = float(entries_[i].c.y + double(entries_[i].image[1]) * side_);
            cz_[i] = float(entries_[i].c.z + double(entries_[i].image[2]) * side_);
        }
    }

    double side_;
    double radius_;
    std::vector<Vec3d> centers_;
    std::int64_t m_ = 1;
    double h_ = 1;
    double max_search_ = 0;
    std::vector<std::uint32_t> cell_start_;
    std::vector<Entry> entries_;
    // Float copies of the entries' centres in the frame of the cell's tile (centre + image L),
    // padded by cull_lanes so walk_spheres reads whole lanes.
    static constexpr unsigned cull_lanes = 8;
    static constexpr std::uint32_t lane_bit[cull_lanes] = {1u, 2u, 4u, 8u, 16u, 32u, 64u, 128u};
    std::vector<float> cx_, cy_, cz_;
};

}  // namespace grainlight
