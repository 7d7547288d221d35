/// @file grainlight/traversal/tiled_packing.hpp
/// Procedural grain instantiation in a tiled sphere packing: Meng15 Algorithm 1
/// (INTERSECTGRAINS) and Sec. 3.2 "Ray tracing grains".
///
/// The aggregate is the infinite tiling of a PeriodicTile, restricted to the grains whose
/// bounding-sphere centre lies inside the aggregate boundary (Meng15 footnote 1). The boundary is
/// seen only through a voxel classifier on the tile grid (one voxel = one tile, Meng15 Sec. 3.2):
/// `classify(tile)` -> outside / inside / partial and `point_inside(tile, local)` for partial
/// voxels (geometry/voxelized_boundary.hpp's VoxelizedBoundary models it; UnboundedAggregate is
/// the whole space). Every sphere gets a deterministic random rotation and exemplar grain from a
/// hash of (seed, tile index, sphere id) (Meng15 Sec. 3.1 "Randomized instantiation"), and the
/// grain geometry is intersected by a user-supplied callback in the grain's local frame, so this
/// header does not depend on any mesh type.
///
/// Traversal (Algorithm 1 with our choices):
/// 1. one walk along the ray over the tile's query grid (PeriodicTile::walk_spheres: an
///    Amanatides-Woo DDA with 64-bit indices whose cells are aligned with the tile-sized voxels);
///    the cells of a voxel are not searched when it and its 26 neighbours are all outside (a
///    sphere whose centre is in a neighbour can reach up to R < L/2 into the voxel);
/// 2. the bounding spheres along the ray come in order of entry (the same spheres and intervals
///    as PeriodicTile::first_hit restarted at each exit); a sphere is kept if its centre's voxel
///    is inside, or partial and point_inside(centre) (Algorithm 1 line 9);
/// 3. the ray is transformed into the grain frame (rotation, then scaling by 1/R so the bounding
///    sphere is the unit sphere) and passed to the intersector (line 10); without a hit the
///    walk continues past the bounding-sphere exit (line 14).
/// Bounding spheres are disjoint, so the first grain hit found is the closest one.
#pragma once

#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/transform.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/traversal/dda.hpp"

namespace grainlight {

namespace detail {
/// Bit sets as words (bit i in word i / 64, position i % 64): dst |= src shifted by s bits toward
/// higher indices (`up`) or lower ones; bits shifted past either end are dropped. dst and src have
/// the same size. Used to dilate TiledPacking's reach grid.
inline void or_shifted_bits(std::vector<std::uint64_t>& dst, const std::vector<std::uint64_t>& src, std::size_t s,
                            bool up) noexcept {
    const std::size_t q = s / 64, r = s % 64, n = src.size();
    for (std::size_t i = 0; i < n; ++i) {
        std::uint64_t v = 0;
        if (up) {
            if (i >= q) v = src[i - q] << r;
            if (r && i >= q + 1) v |= src[i - q - 1] >> (64 - r);
        } else {
            if (i + q < n) v = src[i + q] >> r;
            if (r && i + q + 1 < n) v |= src[i + q + 1] << (64 - r);
        }
        dst[i] |= v;
    }
}
}  // namespace detail

/// A classifier of tile-sized voxels against the aggregate boundary (Meng15 Sec. 3.2): absolute
/// 64-bit tile index -> an enum with members outside / inside / partial; and, for partial voxels,
/// whether a point given as (tile, offset from the tile corner in world units) is inside.
/// Optional: `tile_lo()` / `tile_hi()` (inclusive Vec3i64 range of non-outside voxels), used to
/// clip rays to the aggregate.
template <class B>
concept TileVoxelClassifier = requires(const B& b, const Vec3i64& t, const Vec3d& p) {
    { b.point_inside(t, p) } -> std::convertible_to<bool>;
    { b.classify(t) == decltype(b.classify(t))::outside } -> std::convertible_to<bool>;
    { b.classify(t) == decltype(b.classify(t))::inside } -> std::convertible_to<bool>;
    { b.classify(t) == decltype(b.classify(t))::partial } -> std::convertible_to<bool>;
};

/// The whole space is inside the aggregate (an infinite granular medium, e.g. Meng15 Fig. 9).
struct UnboundedAggregate {
    /// @enum Class
    /// Voxel class of the unbounded aggregate (only inside is ever returned).
    enum class Class : std::uint8_t { outside, inside, partial };
    /// Every tile is inside.
    [[nodiscard]] Class classify(const Vec3i64&) const noexcept { return Class::inside; }
    /// Every point is inside.
    [[nodiscard]] bool point_inside(const Vec3i64&, const Vec3d&) const noexcept { return true; }
};

/// One instantiated grain of the tiling (Meng15 Sec. 3.1 "Randomized instantiation").
struct TiledGrain {
    std::uint32_t sphere = 0;      ///< sphere id in the tile
    Vec3i64 tile{0, 0, 0};         ///< home tile (absolute index) of the bounding sphere
    Vec3d center{0.0};             ///< bounding-sphere centre in the ray's frame (offset from the
                                   ///< corner of the ray's origin tile, world units)
    double radius = 0;             ///< bounding-sphere radius (world units)
    std::uint32_t exemplar = 0;    ///< exemplar grain index, drawn with the mixing weights
    std::uint64_t key = 0;         ///< per-grain random key hash(seed, tile, sphere) for further use
    /// Rotation rows: local = to_local * (world - center) / radius (uniform random rotation).
    std::array<Vec3d, 3> to_local{Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1)};
    /// @var t_enter
    /// Ray parameter where the ray enters the bounding sphere.
    double t_enter = 0, t_exit = 0;  ///< bounding-sphere interval along the ray (ray parameter)

    /// World direction -> grain-local direction (rotation only).
    [[nodiscard]] Vec3d direction_to_local(const Vec3d& w) const noexcept {
        return Vec3d(glm::dot(to_local[0], w), glm::dot(to_local[1], w), glm::dot(to_local[2], w));
    }
    /// Grain-local direction -> world direction.
    [[nodiscard]] Vec3d direction_to_world(const Vec3d& l) const noexcept {
        return l.x * to_local[0] + l.y * to_local[1] + l.z * to_local[2];
    }
    /// Point in the ray's frame -> grain-local point (bounding sphere = unit sphere).
    [[nodiscard]] Vec3d point_to_local(const Vec3d& p) const noexcept { return direction_to_local(p - center) / radius; }
    /// Grain-local point -> point in the ray's frame.
    [[nodiscard]] Vec3d point_to_world(const Vec3d& l) const noexcept { return center + radius * direction_to_world(l); }
};

/// The ray in a grain's local frame: origin o and direction d such that the local point at ray
/// parameter t is o + t d, with the same t as the world ray (d = to_local * d_world / radius).
struct GrainRay {
    /// Ray origin in the grain-local frame.
    Vec3d o{0.0};
    /// Ray direction in the grain-local frame (not unit length: scaled by 1 / radius).
    Vec3d d{0.0, 0.0, 1.0};
};

/// Result of TiledPacking::intersect.
struct TiledHit {
    /// True if a grain was hit.
    bool hit = false;
    double t = std::numeric_limits<double>::infinity();  ///< ray parameter of the grain hit
    TiledGrain grain{};                                 ///< the grain hit
    /// True if a grain was hit.
    explicit operator bool() const noexcept { return hit; }
};

/// Counters for benchmarks and tests.
struct TiledTraversalStats {
    std::uint64_t voxels_visited = 0;   ///< tile-sized voxels entered by the walk
    std::uint64_t voxels_skipped = 0;   ///< of those, skipped as outside (with their neighbours)
    std::uint64_t spheres_tested = 0;   ///< bounding spheres hit by the ray
    std::uint64_t grains_tested = 0;    ///< intersector calls
};

/// A grain intersector: `bool(const TiledGrain& g, const GrainRay& r, double t0, double t1,
/// double& t_hit)`: intersect exemplar g.exemplar with r for t in [t0, t1]; on a hit set t_hit
/// and return true. It may record more (normal, triangle) in its own state.
template <class I>
concept GrainIntersector = requires(I& fn, const TiledGrain& g, const GrainRay& r, double t, double& th) {
    { fn(g, r, t, t, th) } -> std::convertible_to<bool>;
};

/// Meng15's procedural granular aggregate: a tile, a boundary classifier, exemplar mixing weights
/// and a seed. Immutable after construction; queries are const and thread-safe.
template <TileVoxelClassifier Boundary = UnboundedAggregate>
class TiledPacking {
public:
    /// `mixing_weights[i]` >= 0 is the relative frequency of exemplar i (sum > 0).
    /// Throws grainlight::invalid_argument for empty or invalid weights.
    TiledPacking(PeriodicTile tile, Boundary boundary, std::vector<double> mixing_weights = {1.0},
                 std::uint64_t seed = 0)
        : tile_(std::move(tile)),
          boundary_(std::move(boundary)),
          weights_(std::move(mixing_weights)),
          mix_(std::span<const double>(weights_)),
          seed_(seed) {
        build_reach();
    }

    /// The periodic tile of bounding spheres.
    [[nodiscard]] const PeriodicTile& tile() const noexcept { return tile_; }
    /// The voxel classifier of the aggregate boundary.
    [[nodiscard]] const Boundary& boundary() const noexcept { return boundary_; }
    /// Number of exemplar grains (size of the mixing weights).
    [[nodiscard]] std::size_t exemplar_count() const noexcept { return weights_.size(); }
    /// Seed of the per-grain hash.
    [[nodiscard]] std::uint64_t seed() const noexcept { return seed_; }
    /// Can a grain of the aggregate overlap tile `v` (absolute index)? True unless the tile and
    /// its 26 neighbours are all outside (a grain reaches at most R < L / 2 beyond its centre's
    /// tile); the traversal does not search the tiles where this is false. One bit of the
    /// precomputed reach grid when the classifier has a finite tile range, else 27 lookups.
    [[nodiscard]] bool tile_reachable(const Vec3i64& v) const noexcept {
        if (!reach_.empty()) {
            std::int64_t q[3];
            for (int a = 0; a < 3; ++a) {
                q[a] = v[a] - reach_lo_[a];
                if (q[a] < 0 || q[a] >= reach_dims_[a]) return false;
            }
            const auto i = std::size_t((q[2] * reach_dims_[1] + q[1]) * reach_dims_[0] + q[0]);
            return (reach_[i >> 6] >> (i & 63)) & 1u;
        }
        using C = decltype(boundary_.classify(v));
        if (!(boundary_.classify(v) == C::outside)) return true;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    if (!(boundary_.classify(Vec3i64(v.x + dx, v.y + dy, v.z + dz)) == C::outside)) return true;
        return false;
    }

    /// Bytes of the reach grid (one bit per tile of the classifier's range; 0 without one).
    [[nodiscard]] std::size_t reach_bytes() const noexcept { return reach_.size() * sizeof(std::uint64_t); }

    /// Is the grain (sphere, home tile) part of the aggregate (its centre inside the boundary)?
    [[nodiscard]] bool contains(std::uint32_t sphere, const Vec3i64& tile) const noexcept {
        const auto c = boundary_.classify(tile);
        using C = decltype(c);
        if (c == C::inside) return true;
        if (c == C::outside) return false;
        return boundary_.point_inside(tile, tile_.center(sphere));
    }

    /// The deterministic instance of sphere `sphere` in home tile `tile`: rotation (uniform,
    /// Shoemake 1992 "Uniform random rotations", Graphics Gems III) and exemplar from a hash of
    /// (seed, tile, sphere). `center` is given relative to the corner of tile `frame`.
    [[nodiscard]] TiledGrain instance(std::uint32_t sphere, const Vec3i64& tile,
                                         const Vec3i64& frame = Vec3i64(0, 0, 0)) const noexcept {
        return instance(sphere, tile, frame, tile_hash(tile));
    }

    /// The first part of a grain's key, shared by the spheres of a tile:
    /// hash_words(seed, tile.x, tile.y, tile.z) (the key is hash_words(..., sphere)).
    [[nodiscard]] std::uint64_t tile_hash(const Vec3i64& tile) const noexcept {
        return hash_words(seed_, std::uint64_t(tile.x), std::uint64_t(tile.y), std::uint64_t(tile.z));
    }

    /// instance() with the tile's part of the key precomputed (tile_hash(tile)); the same grain.
    [[nodiscard]] TiledGrain instance(std::uint32_t sphere, const Vec3i64& tile, const Vec3i64& frame,
                                      std::uint64_t tile_key) const noexcept {
        TiledGrain g;
        g.sphere = sphere;
        g.tile = tile;
        g.radius = tile_.radius();
        const double L = tile_.side();
        g.center = Vec3d(double(tile.x - frame.x), double(tile.y - frame.y), double(tile.z - frame.z)) * L +
                   tile_.center(sphere);
        g.key = mix64(tile_key ^ std::uint64_t(sphere));  // = hash_words(seed, tile.x, tile.y, tile.z, sphere)
        // The grain's uniform numbers: the SplitMix64 sequence that starts at its key (four
        // independent hashes, no generator state to set up), 53 bits each.
        auto uniform = [&](std::uint64_t i) {
            return double(mix64(g.key + i * 0x9e3779b97f4a7c15ull) >> 11) * 0x1p-53;
        };
        const double u1 = uniform(0), u2 = uniform(1), u3 = uniform(2);
        double sa, ca, sb, cb;
        sincos_2pi(u2, sa, ca);  // sin / cos of 2 pi u without a library call (core/math.hpp)
        sincos_2pi(u3, sb, cb);
        const Rotation<double> r = shoemake_rotation(u1, sa, ca, sb, cb);  // geometry/transform.hpp
        g.to_local = {r.r0, r.r1, r.r2};
        g.exemplar = weights_.size() > 1 ? std::uint32_t(mix_.sample(uniform(3))) : 0u;
        return g;
    }

    /// Meng15 Algorithm 1: first grain hit along o + t d, t in [t_min, t_max]; the origin is
    /// (origin_tile, local_origin) as in PeriodicTile::first_hit and grain centres are reported
    /// in that frame. `grain` is the GrainIntersector. The ray is clipped to the classifier's
    /// tile range if it has one, and to tile().max_search_distance() (a ray along a channel of
    /// a periodic packing may never hit).
    template <class Intersector>
        requires GrainIntersector<std::remove_reference_t<Intersector>>
    [[nodiscard]] TiledHit intersect(const Vec3i64& origin_tile, const Vec3d& local_origin, const Vec3d& d,
                                     double t_min, double t_max, Intersector&& grain,
                                     TiledTraversalStats* stats = nullptr) const {
        TiledHit result;
        const double dlen = std::sqrt(glm::dot(d, d));
        if (!(dlen > 0) || !(t_min <= t_max)) return result;
        const double L = tile_.side();
        if constexpr (requires { boundary_.tile_lo(); boundary_.tile_hi(); }) {
            const Vec3i64 lo = boundary_.tile_lo(), hi = boundary_.tile_hi();
            const Vec3d blo = Vec3d(double(lo.x - 1 - origin_tile.x), double(lo.y - 1 - origin_tile.y),
                                    double(lo.z - 1 - origin_tile.z)) * L;
            const Vec3d bhi = Vec3d(double(hi.x + 2 - origin_tile.x), double(hi.y + 2 - origin_tile.y),
                                    double(hi.z + 2 - origin_tile.z)) * L;
            if (!clip_to_box(local_origin, d, blo, bhi, t_min, t_max)) return result;
        }
        // A ray along a channel of the periodic packing may never hit a sphere: bound the search.
        t_max = std::min(t_max, t_min + tile_.max_search_distance() / dlen);
        Vec3i64 key_tile = origin_tile;
        std::uint64_t tile_key = 0;
        bool have_key = false;
        // One walk over the tile's query grid along the whole ray (PeriodicTile::walk_spheres):
        // the bounding spheres in order of entry, skipping the tiles no grain can reach.
        tile_.walk_spheres(
            origin_tile, local_origin, d, t_min, t_max,
            [&](const Vec3i64& v) {
                if (stats) ++stats->voxels_visited;
                const bool keep = tile_reachable(v);
                if (stats && !keep) ++stats->voxels_skipped;
                return keep;
            },
            [&](const TileHit& h) {
                if (stats) ++stats->spheres_tested;
                if (!contains(h.sphere, h.tile)) return false;
                if (!have_key || !(h.tile == key_tile)) {  // consecutive grains mostly share a tile
                    have_key = true;
                    key_tile = h.tile;
                    tile_key = tile_hash(h.tile);
                }
                TiledGrain g = instance(h.sphere, h.tile, origin_tile, tile_key);
                g.t_enter = h.t_enter;
                g.t_exit = h.t_exit;
                GrainRay r;
                r.o = g.point_to_local(local_origin);
                r.d = g.direction_to_local(d) / g.radius;
                const double t0 = std::max(t_min, h.t_enter), t1 = std::min(t_max, h.t_exit);
                double t_hit = std::numeric_limits<double>::infinity();
                if (stats) ++stats->grains_tested;
                if (t0 <= t1 && grain(g, r, t0, t1, t_hit)) {
                    result.hit = true;
                    result.t = t_hit;
                    result.grain = g;
                    return true;
                }
                return false;
            });
        return result;
    }

    /// intersect() for a ray in world coordinates (tile 0 frame).
    template <std::floating_point F, class Intersector>
        requires GrainIntersector<std::remove_reference_t<Intersector>>
    [[nodiscard]] TiledHit intersect(const Ray<F>& ray, F t_min, F t_max, Intersector&& grain) const {
        return intersect(Vec3i64(0, 0, 0), Vec3d(ray.o), Vec3d(ray.d), double(t_min), double(t_max),
                         std::forward<Intersector>(grain));
    }

private:
    /// The reach grid: one bit per tile of the classifier's range grown by one tile, set when
    /// the tile or one of its 26 neighbours is not outside (what tile_reachable asks). Built on
    /// bits by separable dilation (OR with the bit set shifted by one tile along x, then y, then
    /// z: a 3 x 3 x 3 box is their product), so it costs one classifier call per tile and a few
    /// word operations; two bit sets during the build (n / 4 bytes). Skipped (the 27 lookups
    /// remain) when the classifier has no tile range or the grid exceeds 2^32 tiles.
    void build_reach() {
        if constexpr (requires { boundary_.tile_lo(); boundary_.tile_hi(); }) {
            using C = decltype(boundary_.classify(std::declval<const Vec3i64&>()));
            const Vec3i64 lo = boundary_.tile_lo(), hi = boundary_.tile_hi();
            double cells = 1;
            for (int a = 0; a < 3; ++a) {
                if (hi[a] < lo[a]) return;
                reach_lo_[a] = lo[a] - 1;
                reach_dims_[a] = hi[a] - lo[a] + 3;
                cells *= double(reach_dims_[a]);
            }
            if (cells > double(std::int64_t(1) << 32)) return;
            const std::int64_t nx = reach_dims_[0], ny = reach_dims_[1], nz = reach_dims_[2];
            const auto n = std::size_t(cells);
            const std::size_t words = (n + 63) / 64;
            std::vector<std::uint64_t> a(words, 0), b;
            // The margin tiles (first and last along each axis) stay clear here, so the shifts
            // below never carry a bit from the end of one row (or slice) into the next.
            std::size_t i = 0;
            for (std::int64_t z = 0; z < nz; ++z)
                for (std::int64_t y = 0; y < ny; ++y)
                    for (std::int64_t x = 0; x < nx; ++x, ++i) {
                        if (x == 0 || y == 0 || z == 0 || x + 1 == nx || y + 1 == ny || z + 1 == nz) continue;
                        if (!(boundary_.classify(Vec3i64(reach_lo_[0] + x, reach_lo_[1] + y, reach_lo_[2] + z)) ==
                              C::outside))
                            a[i >> 6] |= std::uint64_t(1) << (i & 63);
                    }
            for (const std::int64_t stride : {std::int64_t(1), nx, nx * ny}) {
                b = a;
                detail::or_shifted_bits(b, a, std::size_t(stride), true);
                detail::or_shifted_bits(b, a, std::size_t(stride), false);
                a.swap(b);
            }
            if (n % 64) a.back() &= (std::uint64_t(1) << (n % 64)) - 1;  // no bits past the grid
            reach_ = std::move(a);
        }
    }
    PeriodicTile tile_;
    Boundary boundary_;
    std::vector<double> weights_;
    DiscreteDistribution<double> mix_;
    std::uint64_t seed_;
    std::vector<std::uint64_t> reach_;      // see build_reach(); empty: ask the classifier
    std::int64_t reach_lo_[3] = {0, 0, 0};  // absolute tile of reach bit 0
    std::int64_t reach_dims_[3] = {0, 0, 0};
};

}  // namespace grainlight
