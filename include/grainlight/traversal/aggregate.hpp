/// @file grainlight/traversal/aggregate.hpp
/// A procedural granular aggregate (Meng15 Secs. 3.1-3.2): an infinite tiling of a periodic
/// sphere packing (packing/periodic_tile.hpp), clipped by a voxelized boundary
/// (geometry/voxelized_boundary.hpp), with one randomly rotated example grain instanced in every
/// bounding sphere whose centre lies inside the boundary. Nothing is stored per grain: the
/// exemplar and the rotation of the grain in sphere `s` of tile `t` are a deterministic hash of
/// (seed, t, s) (Meng15: "The random seed used for each individual grain is a deterministic
/// function of the three-dimensional tile index and the sphere id"), so memory is independent of
/// the grain count and every ray sees the same grain.
///
/// `intersect` is Meng15 Algorithm 1 as implemented by traversal/tiled_packing.hpp (TiledPacking:
/// a DDA over tile-sized voxels skipping voxels no grain can reach, the bounding spheres along
/// the ray in order, the inside test of partial voxels, the hashed rotation and exemplar); this
/// header supplies the voxelized boundary as its classifier and the exemplar geometry (analytic
/// sphere or mesh BVH) as its grain intersector, and keeps the surface normal of the hit.
///
/// Precision: positions are (64-bit tile index, double offset from that tile's corner); the
/// boundary and the scene live in the frame of the boundary's anchor tile, so an aggregate
/// 1e6+ tiles from the origin behaves exactly as one at the origin.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/grain.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/transform.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/traversal/tiled_packing.hpp"

namespace grainlight {

/// The example grains of an aggregate are grainlight::Grain (geometry/grain.hpp).
/// Deprecated alias, kept for one release.
using GrainExemplar = Grain;

/// A grain of the aggregate: the bounding sphere (id in the tile, absolute tile index) and its
/// instancing (exemplar index and rotation: x_world = center + R * rotation.to_world(x_unit)).
struct AggregateGrain {
    /// Sphere id inside the tile.
    std::uint32_t sphere = 0;
    /// Home tile of the bounding sphere (absolute index).
    Vec3i64 tile{0, 0, 0};
    /// Index of the exemplar grain instanced here.
    std::uint32_t exemplar = 0;
    /// Rotation of the exemplar into the world frame.
    Rotation<double> rotation{};
};

/// Result of a ray-grain query. `t` is in units of the ray's (unit) direction; `n` is the grain's
/// outward unit normal at the hit (world frame); `grain` identifies the instance.
struct AggregateHit {
    /// True if a grain was hit.
    bool hit = false;
    /// Ray parameter of the hit (distance for a unit direction).
    double t = std::numeric_limits<double>::infinity();
    /// Outward unit normal of the grain at the hit (world frame).
    Vec3d n{0.0, 0.0, 1.0};
    /// The grain instance hit.
    AggregateGrain grain{};
    /// True if a grain was hit.
    explicit operator bool() const noexcept { return hit; }
};

/// Work counters of a query (for benchmarks): voxels visited, bounding spheres tested,
/// instance (grain geometry) intersections.
struct AggregateCounters {
    /// @var voxels
    /// Boundary voxels visited.
    /// @var spheres
    /// Bounding spheres tested.
    /// @var instances
    /// Grain geometry (instance) intersections performed.
    std::uint64_t voxels = 0, spheres = 0, instances = 0;
};

/// A procedural aggregate: tile + voxelized boundary + exemplars with mixing weights + seed.
template <BoundaryShape Shape>
class GranularAggregate {
public:
    /// \param tile       periodic packing; its sphere radius R is the grains' bounding radius
    /// \param boundary   voxelized on a grid of side tile.side() (checked)
    /// \param exemplars  example grains (>= 1), each in its unit bounding sphere
    /// \param weights    mixing weights (same count, >= 0, positive sum)
    /// \param seed       instancing seed
    /// Throws grainlight::invalid_argument on empty exemplars/weights, mismatched sizes, bad
    /// weights, or a boundary voxelized with a different tile side.
    GranularAggregate(PeriodicTile tile, VoxelizedBoundary<Shape> boundary, std::vector<GrainExemplar> exemplars,
                      std::vector<double> weights, std::uint64_t seed = 1)
        : packing_(make_packing(std::move(tile), std::move(boundary), exemplars, std::move(weights), seed)),
          exemplars_(std::move(exemplars)),
          seed_(seed) {}

    /// The periodic packing tile.
    [[nodiscard]] const PeriodicTile& tile() const noexcept { return packing_.tile(); }
    /// The voxelized aggregate boundary.
    [[nodiscard]] const VoxelizedBoundary<Shape>& boundary() const noexcept { return packing_.boundary(); }
    /// The exemplar grains (AggregateGrain::exemplar indexes them; same order as the mixing weights).
    [[nodiscard]] const std::vector<GrainExemplar>& exemplars() const noexcept { return exemplars_; }
    /// The Algorithm 1 traversal this aggregate runs on.
    [[nodiscard]] const TiledPacking<VoxelizedBoundary<Shape>>& packing() const noexcept { return packing_; }
    /// Instancing seed (same seed, same grain at every sphere).
    [[nodiscard]] std::uint64_t seed() const noexcept { return seed_; }
    /// Bounding-sphere radius R of the grains (world units).
    [[nodiscard]] double grain_radius() const noexcept { return tile().radius(); }
    /// One-line description: exemplars, grain radius, tile and boundary bounds (no grain count:
    /// counting the grains of a large aggregate is expensive, see grain_count()).
    [[nodiscard]] std::string to_string() const {
        const auto b = boundary().shape().bounds();
        return "GranularAggregate[" + std::to_string(exemplars_.size()) + " exemplar(s), grain radius " +
               grainlight::detail::to_display(grain_radius()) + ", " + tile().to_string() + ", bounds (" + grainlight::detail::to_display(b.lo.x) + ", " + grainlight::detail::to_display(b.lo.y) +
               ", " + grainlight::detail::to_display(b.lo.z) + ") - (" + grainlight::detail::to_display(b.hi.x) + ", " + grainlight::detail::to_display(b.hi.y) + ", " + grainlight::detail::to_display(b.hi.z) + ")]";
    }

    /// Bytes used: tile (centres + query grid, estimated) + 2-bit voxels (+ the sub-voxel
    /// refinement of partial voxels and a mesh boundary's BVH) + exemplar geometry. Independent of
    /// the number of grains (the boundary part grows with the shape's size in tiles).
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        const auto m = std::size_t(tile().grid_resolution());
        std::size_t b = tile().size() * sizeof(Vec3d) * 2 + m * m * m * sizeof(std::uint32_t) + tile().size() * 27 * (32 + 12);  // cell entries + their float SoA copy
        b += boundary().memory_bytes() + packing_.reach_bytes();
        if constexpr (requires { boundary().refinement_bytes(); }) b += boundary().refinement_bytes();
        if constexpr (requires { boundary().shape().memory_bytes(); }) b += boundary().shape().memory_bytes();
        for (const auto& e : exemplars_) b += e.memory_bytes();
        return b;
    }

    /// The deterministic instancing of sphere `sphere` of absolute tile `tile` (Meng15 Sec. 3.1),
    /// as TiledPacking::instance defines it.
    [[nodiscard]] AggregateGrain instance(const Vec3i64& tile, std::uint32_t sphere) const noexcept {
        return from_tiled(packing_.instance(sphere, tile));
    }
    /// Is the bounding sphere (tile, sphere) a grain of the aggregate (centre inside the boundary)?
    [[nodiscard]] bool contains_sphere(const Vec3i64& tile, std::uint32_t sphere) const noexcept {
        return packing_.contains(sphere, tile);
    }

    /// Number of grains (bounding spheres with their centre inside the boundary): a loop over the
    /// voxels (fully inside: every sphere of the tile; partial: point tests), not over grains.
    [[nodiscard]] std::uint64_t grain_count() const {
        if constexpr (std::is_same_v<Shape, EverywhereBoundary>) return std::numeric_limits<std::uint64_t>::max();
        std::uint64_t n = 0;
        const Vec3i64 lo = boundary().tile_lo(), hi = boundary().tile_hi();
        for (std::int64_t z = lo.z; z <= hi.z; ++z)
            for (std::int64_t y = lo.y; y <= hi.y; ++y)
                for (std::int64_t x = lo.x; x <= hi.x; ++x) {
                    const Vec3i64 t(x, y, z);
                    const VoxelClass c = boundary().classify(t);
                    if (c == VoxelClass::inside) n += tile().size();
                    if (c == VoxelClass::partial)
                        for (std::uint32_t s = 0; s < tile().size(); ++s) n += boundary().point_inside(t, tile().center(s));
                }
        return n;
    }

    /// Split a point of the anchor (scene) frame into (absolute tile, offset from its corner).
    void to_tile_frame(const Vec3d& p, Vec3i64& tile_index, Vec3d& local) const noexcept {
        const double L = this->tile().side();
        for (int a = 0; a < 3; ++a) {
            const std::int64_t k = detail::floor_i64(p[a] / L);
            tile_index[a] = boundary().anchor()[a] + k;
            local[a] = p[a] - double(k) * L;
        }
    }
    /// World (anchor-frame) centre of a grain's bounding sphere.
    [[nodiscard]] Vec3d sphere_center(const Vec3i64& tile_index, std::uint32_t sphere) const noexcept {
        return boundary().to_shape_frame(tile_index, this->tile().center(sphere));
    }

    /// Intersect the ray (origin tile + local origin, unit direction d) with one grain instance
    /// for t in (t_min, t_max). `c_rel` is the grain's centre relative to the ray's origin tile.
    [[nodiscard]] bool intersect_instance(const AggregateGrain& g, const Vec3d& o_rel_center, const Vec3d& d, double t_min,
                                          double t_max, double& t, Vec3d& n) const noexcept {
        const double R = tile().radius();
        const Vec3d o_l = g.rotation.to_local(o_rel_center) / R;
        const Vec3d d_l = g.rotation.to_local(d);
        double tl = 0;
        Vec3d nl(0.0);
        if (!exemplars_[g.exemplar].intersect(o_l, d_l, t_min / R, t_max / R, tl, nl)) return false;
        t = tl * R;
        n = g.rotation.to_world(nl);
        return true;
    }
    /// Ray vs a given grain (e.g. a path travelling inside that grain), anchor frame.
    [[nodiscard]] AggregateHit intersect_grain(const AggregateGrain& g, const Vec3d& o, const Vec3d& d, double t_min,
                                               double t_max) const noexcept {
        AggregateHit h;
        double t;
        Vec3d n;
        if (intersect_instance(g, o - sphere_center(g.tile, g.sphere), d, t_min, t_max, t, n)) {
            h.hit = true;
            h.t = t;
            h.n = n;
            h.grain = g;
        }
        return h;
    }

    /// Meng15 Algorithm 1 for a ray in the anchor (scene) frame: origin o, unit direction d.
    [[nodiscard]] AggregateHit intersect(const Vec3d& o, const Vec3d& d, double t_min, double t_max,
                                         AggregateCounters* counters = nullptr) const noexcept {
        Vec3i64 tile;
        Vec3d local;
        to_tile_frame(o, tile, local);
        return intersect(tile, local, d, t_min, t_max, counters);
    }

    /// Meng15 Algorithm 1 for a ray given as (absolute origin tile, offset from its corner, unit
    /// direction): first grain surface hit with t in (t_min, t_max).
    [[nodiscard]] AggregateHit intersect(const Vec3i64& otile, const Vec3d& olocal, const Vec3d& d, double t_min,
                                         double t_max, AggregateCounters* counters = nullptr) const noexcept {
        AggregateHit best;
        Vec3d n_local(0.0);
        auto grain = [&](const TiledGrain& g, const GrainRay& r, double t0, double t1, double& t_hit) {
            // TiledPacking's local ray has |d| = 1 / R and the world parameter t.
            // A grain touching its bounding sphere (a sphere of radius 1, mesh vertices at radius
            // 1) is entered at t0 = the sphere entry; the grain's own root may round to just below
            // it, so the entry bound is widened slightly (never below the query's t_min).
            const double R = g.radius;
            const double lo = t0 > t_min ? std::max(t_min, t0 - 1e-7 * R) : t0;
            double tl = 0;
            if (!exemplars_[g.exemplar].intersect(r.o, r.d * R, lo / R, t1 / R, tl, n_local)) return false;
            t_hit = std::max(tl * R, t0);
            return true;
        };
        // Clip to the boundary dilated by the grain radius (a grain's sphere lies within R of the
        // shape): rays skip the spheres in front of the aggregate without testing them.
        if constexpr (requires(double a, double b) { boundary().shape().clip(olocal, d, 1.0, a, b); }) {
            const Vec3d o_shape = boundary().to_shape_frame(otile, olocal);
            const double R = tile().radius();
            if (!boundary().shape().clip(o_shape, d, R * (1 + 1e-9) + 1e-12, t_min, t_max)) return best;
        }
        TiledTraversalStats stats;
        const TiledHit h = packing_.intersect(otile, olocal, d, t_min, t_max, grain, counters ? &stats : nullptr);
        if (counters) {
            counters->voxels += stats.voxels_visited;
            counters->spheres += stats.spheres_tested;
            counters->instances += stats.grains_tested;
        }
        if (!h) return best;
        best.hit = true;
        best.t = h.t;
        best.grain = from_tiled(h.grain);
        best.n = best.grain.rotation.to_world(n_local);
        return best;
    }

    /// Is any grain hit on (t_min, t_max)? (Shadow rays.)
    [[nodiscard]] bool occluded(const Vec3d& o, const Vec3d& d, double t_min, double t_max) const noexcept {
        return intersect(o, d, t_min, t_max).hit;
    }

    /// Brute force reference: every grain overlapping the box [lo, hi] (anchor frame) is listed
    /// (for tests and the explicit-instance benchmark); fn(AggregateGrain, centre).
    template <class Fn>
    void for_each_grain(const Vec3d& lo, const Vec3d& hi, Fn&& fn) const {
        // Query the tiling in a frame near the anchor (no precision loss: offsets are small).
        tile().for_each_overlapping(lo, hi, [&](const TileSphereRef& r) {
            const Vec3i64 abs_tile = r.tile + boundary().anchor();
            if (!contains_sphere(abs_tile, r.sphere)) return;
            fn(instance(abs_tile, r.sphere), r.center);
        });
    }

private:
    static TiledPacking<VoxelizedBoundary<Shape>> make_packing(PeriodicTile tile, VoxelizedBoundary<Shape> boundary,
                                                               const std::vector<GrainExemplar>& exemplars,
                                                               std::vector<double> weights, std::uint64_t seed) {
        const char* where = "GranularAggregate";
        check_argument(!exemplars.empty(), where, "exemplars.size()", exemplars.size(), ">= 1");
        check_argument(!weights.empty(), where, "mixing weights.size()", weights.size(), ">= 1 (one per exemplar)");
        check_argument(weights.size() == exemplars.size(), where, "mixing weights.size()", weights.size(),
                       "equal to exemplars.size() = " + std::to_string(exemplars.size()));
        check_argument(std::abs(boundary.tile_side() - tile.side()) <= 1e-12 * tile.side(), where, "boundary tile side",
                       boundary.tile_side(), "equal to the tile side " + std::to_string(tile.side()));
        check_argument(tile.size() > 0, where, "spheres in the tile", tile.size(), ">= 1");
        (void)DiscreteDistribution<double>(std::span<const double>(weights));  // validates the weights
        return TiledPacking<VoxelizedBoundary<Shape>>(std::move(tile), std::move(boundary), std::move(weights), seed);
    }
    [[nodiscard]] static AggregateGrain from_tiled(const TiledGrain& t) noexcept {
        AggregateGrain g;
        g.sphere = t.sphere;
        g.tile = t.tile;
        g.exemplar = t.exemplar;
        g.rotation.r0 = t.to_local[0];
        g.rotation.r1 = t.to_local[1];
        g.rotation.r2 = t.to_local[2];
        return g;
    }

    TiledPacking<VoxelizedBoundary<Shape>> packing_;
    std::vector<GrainExemplar> exemplars_;
    std::uint64_t seed_;
};

}  // namespace grainlight
