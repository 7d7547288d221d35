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
/// `intersect` is Meng15 Algorithm 1: a DDA over tile-sized voxels skips voxels that no grain
/// can reach (the voxel and its 26 neighbours fully outside: a bounding sphere of radius < L/2
/// only reaches into neighbouring voxels); in the others the bounding spheres along the ray are
/// visited in order (PeriodicTile::first_hit on the infinite tiling), a sphere counts if its
/// voxel is fully inside or (partial voxel) its centre passes the boundary's point-inside test,
/// and the ray is then transformed into the grain's rotated unit frame and intersected with the
/// exemplar's geometry; a miss continues at the sphere's exit.
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
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/transform.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
#include "grainlight/packing/periodic_tile.hpp"

namespace grainlight {

/// An example grain in its unit bounding sphere (centred at the origin, radius 1): an analytic
/// sphere of radius r <= 1 or a watertight mesh with every vertex within the unit sphere, and
/// its material. A grain larger than its bounding sphere is an error (invalid_argument).
class GrainExemplar {
public:
    [[nodiscard]] static GrainExemplar sphere(double radius, const GrainMaterial& material) {
        check_argument(radius > 0.0 && radius <= 1.0, "GrainExemplar::sphere", "radius", radius,
                       "(0, 1] (the grain must fit in its unit bounding sphere)");
        material.validate();
        GrainExemplar g;
        g.radius_ = radius;
        g.material_ = material;
        return g;
    }
    [[nodiscard]] static GrainExemplar mesh(const TriangleMesh<float>& m, const GrainMaterial& material) {
        m.validate("GrainExemplar::mesh");
        const double r = double(m.max_vertex_radius());
        check_argument(r > 0.0 && r <= 1.0 + 1e-6, "GrainExemplar::mesh", "bounding radius of the mesh", r,
                       "(0, 1] (the grain must fit in its unit bounding sphere)");
        check_argument(m.is_watertight(), "GrainExemplar::mesh", "watertight", "no", "a closed, consistently oriented mesh");
        check_argument(m.signed_volume() > 0.0, "GrainExemplar::mesh", "signed volume", m.signed_volume(),
                       "> 0 (outward normals)");
        material.validate();
        GrainExemplar g;
        g.bvh_ = std::make_shared<const Bvh<float>>(m);
        g.radius_ = r;
        g.material_ = material;
        g.triangles_ = m.triangle_count();
        return g;
    }
    /// Procedural grain (geometry/grains.hpp) of bounding radius in (0, 1]; the sphere shape is
    /// the analytic sphere.
    [[nodiscard]] static GrainExemplar procedural(GrainShape shape, double radius, const GrainMaterial& material,
                                                  std::uint64_t seed = 1, int level = 4) {
        check_argument(radius > 0.0 && radius <= 1.0, "GrainExemplar::procedural", "radius", radius,
                       "(0, 1] (the grain must fit in its unit bounding sphere)");
        if (shape == GrainShape::sphere) return sphere(radius, material);
        return mesh(make_grain_mesh<float>(shape, float(radius), seed, level), material);
    }
    /// From a preset of geometry/grains.hpp.
    [[nodiscard]] static GrainExemplar from_preset(const GrainPreset& p, int level = 4) {
        return procedural(p.shape, p.radius, p.material, p.seed, level);
    }

    [[nodiscard]] const GrainMaterial& material() const noexcept { return material_; }
    [[nodiscard]] bool is_analytic_sphere() const noexcept { return !bvh_; }
    [[nodiscard]] double radius() const noexcept { return radius_; }
    [[nodiscard]] std::size_t triangle_count() const noexcept { return triangles_; }
    /// Bytes of the exemplar's geometry (BVH nodes + triangles; 0 for the analytic sphere).
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        if (!bvh_) return 0;
        return bvh_->nodes().size() * sizeof(BvhNode<float>) +
               triangles_ * (sizeof(std::array<Vec3f, 3>) + sizeof(Vec3f) + sizeof(std::uint32_t));
    }
    /// Closest hit along o + t d (unit frame, d unit), t in (t_min, t_max): t and the outward unit
    /// normal. Returns false on a miss.
    [[nodiscard]] bool intersect(const Vec3d& o, const Vec3d& d, double t_min, double t_max, double& t,
                                 Vec3d& n) const noexcept {
        if (!bvh_) {
            if (!intersect_sphere_first(o, d, Vec3d(0.0), radius_, t_min, t_max, t)) return false;
            n = glm::normalize(o + t * d);
            return true;
        }
        const Vec3d o2 = o + t_min * d;  // float BVH: start at t_min to keep the offset small
        const auto h = bvh_->intersect(Vec3f(o2), Vec3f(d), 0.0f, float(std::min(t_max - t_min, 1e30)));
        if (!h.valid()) return false;
        t = t_min + double(h.t);
        n = Vec3d(h.n_geom);
        return true;
    }

private:
    GrainExemplar() = default;
    std::shared_ptr<const Bvh<float>> bvh_;
    double radius_ = 1.0;
    std::size_t triangles_ = 0;
    GrainMaterial material_{};
};

/// A grain of the aggregate: the bounding sphere (id in the tile, absolute tile index) and its
/// instancing (exemplar index and rotation: x_world = center + R * rotation.to_world(x_unit)).
struct GrainInstance {
    std::uint32_t sphere = 0;
    Vec3i64 tile{0, 0, 0};
    std::uint32_t exemplar = 0;
    Rotation<double> rotation{};
};

/// Result of a ray-grain query. `t` is in units of the ray's (unit) direction; `n` is the grain's
/// outward unit normal at the hit (world frame); `grain` identifies the instance.
struct AggregateHit {
    bool hit = false;
    double t = std::numeric_limits<double>::infinity();
    Vec3d n{0.0, 0.0, 1.0};
    GrainInstance grain{};
    explicit operator bool() const noexcept { return hit; }
};

/// Work counters of a query (for benchmarks): voxels visited, bounding spheres tested,
/// instance (grain geometry) intersections.
struct AggregateCounters {
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
        : tile_(std::move(tile)), boundary_(std::move(boundary)), exemplars_(std::move(exemplars)), seed_(seed) {
        const char* where = "GranularAggregate";
        check_argument(!exemplars_.empty(), where, "exemplars.size()", exemplars_.size(), ">= 1");
        check_argument(!weights.empty(), where, "mixing weights.size()", weights.size(), ">= 1 (one per exemplar)");
        check_argument(weights.size() == exemplars_.size(), where, "mixing weights.size()", weights.size(),
                       "equal to exemplars.size() = " + std::to_string(exemplars_.size()));
        check_argument(std::abs(boundary_.tile_side() - tile_.side()) <= 1e-12 * tile_.side(), where,
                       "boundary tile side", boundary_.tile_side(), "equal to the tile side " + std::to_string(tile_.side()));
        check_argument(tile_.size() > 0, where, "spheres in the tile", tile_.size(), ">= 1");
        mix_ = DiscreteDistribution<double>(std::span<const double>(weights));  // validates the weights
        // Only search spheres up to one tile diagonal per call (every query is bounded anyway).
        tile_.set_max_search_distance(4.0 * tile_.side());
    }

    [[nodiscard]] const PeriodicTile& tile() const noexcept { return tile_; }
    [[nodiscard]] const VoxelizedBoundary<Shape>& boundary() const noexcept { return boundary_; }
    [[nodiscard]] const std::vector<GrainExemplar>& exemplars() const noexcept { return exemplars_; }
    [[nodiscard]] const DiscreteDistribution<double>& mixing() const noexcept { return mix_; }
    [[nodiscard]] std::uint64_t seed() const noexcept { return seed_; }
    /// Bounding-sphere radius R of the grains (world units).
    [[nodiscard]] double grain_radius() const noexcept { return tile_.radius(); }

    /// Bytes used: tile (centres + query grid, estimated) + 2-bit voxels + exemplar geometry.
    /// Independent of the number of grains.
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        const auto m = std::size_t(tile_.grid_resolution());
        std::size_t b = tile_.size() * sizeof(Vec3d) * 2 + m * m * m * sizeof(std::uint32_t) + tile_.size() * 27 * 32;
        b += boundary_.memory_bytes();
        for (const auto& e : exemplars_) b += e.memory_bytes();
        return b;
    }

    /// The deterministic instancing of sphere `sphere` of absolute tile `tile` (Meng15 Sec. 3.1).
    [[nodiscard]] GrainInstance instance(const Vec3i64& tile, std::uint32_t sphere) const noexcept {
        const std::uint64_t h = hash_words(seed_, std::uint64_t(tile.x), std::uint64_t(tile.y), std::uint64_t(tile.z));
        Rng rng = Rng::from_key(seed_ ^ 0x6772616e5f696e73ull, h, sphere);
        GrainInstance g;
        g.sphere = sphere;
        g.tile = tile;
        g.exemplar = std::uint32_t(mix_.sample(rng.uniform<double>()));
        const double u0 = rng.uniform<double>(), u1 = rng.uniform<double>(), u2 = rng.uniform<double>();
        g.rotation = uniform_random_rotation(Vec3d(u0, u1, u2));
        return g;
    }
    /// Is the bounding sphere (tile, sphere) a grain of the aggregate (centre inside the boundary)?
    [[nodiscard]] bool contains_sphere(const Vec3i64& tile, std::uint32_t sphere) const noexcept {
        const VoxelClass c = boundary_.classify(tile);
        if (c == VoxelClass::outside) return false;
        if (c == VoxelClass::inside) return true;
        return boundary_.point_inside(tile, tile_.center(sphere));
    }

    /// Number of grains (bounding spheres with their centre inside the boundary): a loop over the
    /// voxels (fully inside: every sphere of the tile; partial: point tests), not over grains.
    [[nodiscard]] std::uint64_t grain_count() const {
        if constexpr (std::is_same_v<Shape, EverywhereBoundary>) return std::numeric_limits<std::uint64_t>::max();
        std::uint64_t n = 0;
        const Vec3i64 lo = boundary_.tile_lo(), hi = boundary_.tile_hi();
        for (std::int64_t z = lo.z; z <= hi.z; ++z)
            for (std::int64_t y = lo.y; y <= hi.y; ++y)
                for (std::int64_t x = lo.x; x <= hi.x; ++x) {
                    const Vec3i64 t(x, y, z);
                    const VoxelClass c = boundary_.classify(t);
                    if (c == VoxelClass::inside) n += tile_.size();
                    if (c == VoxelClass::partial)
                        for (std::uint32_t s = 0; s < tile_.size(); ++s) n += boundary_.point_inside(t, tile_.center(s));
                }
        return n;
    }

    /// Split a point of the anchor (scene) frame into (absolute tile, offset from its corner).
    void to_tile_frame(const Vec3d& p, Vec3i64& tile, Vec3d& local) const noexcept {
        const double L = tile_.side();
        for (int a = 0; a < 3; ++a) {
            const std::int64_t k = detail::floor_i64(p[a] / L);
            tile[a] = boundary_.anchor()[a] + k;
            local[a] = p[a] - double(k) * L;
        }
    }
    /// World (anchor-frame) centre of a grain's bounding sphere.
    [[nodiscard]] Vec3d sphere_center(const Vec3i64& tile, std::uint32_t sphere) const noexcept {
        return boundary_.to_shape_frame(tile, tile_.center(sphere));
    }

    /// Intersect the ray (origin tile + local origin, unit direction d) with one grain instance
    /// for t in (t_min, t_max). `c_rel` is the grain's centre relative to the ray's origin tile.
    [[nodiscard]] bool intersect_instance(const GrainInstance& g, const Vec3d& o_rel_center, const Vec3d& d, double t_min,
                                          double t_max, double& t, Vec3d& n) const noexcept {
        const double R = tile_.radius();
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
    [[nodiscard]] AggregateHit intersect_grain(const GrainInstance& g, const Vec3d& o, const Vec3d& d, double t_min,
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
        const double L = tile_.side();
        // Clip to the voxel grid (already one voxel larger than the shape).
        const Vec3i64 glo = boundary_.tile_lo(), ghi = boundary_.tile_hi();
        const Vec3d blo = L * Vec3d(glo - otile), bhi = L * Vec3d(ghi - otile + Vec3i64(1));
        double ta = t_min, tb = t_max;
        for (int a = 0; a < 3; ++a) {
            if (d[a] == 0.0) {
                if (olocal[a] < blo[a] || olocal[a] > bhi[a]) return best;
                continue;
            }
            double t0 = (blo[a] - olocal[a]) / d[a], t1 = (bhi[a] - olocal[a]) / d[a];
            if (t0 > t1) std::swap(t0, t1);
            ta = std::max(ta, t0);
            tb = std::min(tb, t1);
        }
        if (!(ta < tb)) return best;
        // Voxel DDA (Amanatides & Woo 1987) from ta, in the ray's tile frame.
        const Vec3d p0 = olocal + ta * d;
        std::array<std::int64_t, 3> v{}, step{};
        std::array<double, 3> t_next{}, t_delta{};
        for (int a = 0; a < 3; ++a) {
            v[a] = detail::floor_i64(p0[a] / L);
            step[a] = d[a] > 0 ? 1 : (d[a] < 0 ? -1 : 0);
            t_delta[a] = step[a] != 0 ? L / std::abs(d[a]) : std::numeric_limits<double>::infinity();
            t_next[a] = step[a] == 0 ? std::numeric_limits<double>::infinity()
                                     : (double(v[a] + (step[a] > 0 ? 1 : 0)) * L - olocal[a]) / d[a];
        }
        double t = t_min;  // sphere search position: every sphere exited before t has been handled
        double tv0 = ta;
        for (int guard = 0; guard < (1 << 26) && tv0 < tb; ++guard) {
            const int axis = (t_next[0] < t_next[1]) ? (t_next[0] < t_next[2] ? 0 : 2) : (t_next[1] < t_next[2] ? 1 : 2);
            const double tv1 = std::min(t_next[axis], tb);
            if (counters) ++counters->voxels;
            const Vec3i64 vt(otile.x + v[0], otile.y + v[1], otile.z + v[2]);
            // Spheres overlapping skipped voxels (all neighbours outside) cannot be grains, so
            // the search may start at the voxel entry.
            t = std::max(t, tv0);
            if (tv1 > t && !unreachable(vt)) {
                // Bounding spheres along the ray entered before the voxel's exit, in order.
                for (int inner = 0; inner < (1 << 20); ++inner) {
                    const TileHit th = tile_.first_hit(otile, olocal, d, t, tv1);
                    if (!th) break;
                    if (counters) ++counters->spheres;
                    if (contains_sphere(th.tile, th.sphere)) {
                        const GrainInstance g = instance(th.tile, th.sphere);
                        const Vec3d c = L * Vec3d(th.tile - otile) + tile_.center(th.sphere);
                        double t_hit;
                        Vec3d n;
                        if (counters) ++counters->instances;
                        const double lo = std::max(t_min, th.t_enter), hi = std::min(th.t_exit, t_max);
                        if (lo < hi && intersect_instance(g, olocal - c, d, lo, hi, t_hit, n)) {
                            best.hit = true;
                            best.t = t_hit;
                            best.n = n;
                            best.grain = g;
                            return best;
                        }
                    }
                    t = th.t_exit;  // exactly: the same sphere is excluded next time (first_hit contract)
                    if (!(t < tv1)) break;
                }
            }
            tv0 = tv1;
            v[axis] += step[axis];
            t_next[axis] += t_delta[axis];
        }
        return best;
    }

    /// Is any grain hit on (t_min, t_max)? (Shadow rays.)
    [[nodiscard]] bool occluded(const Vec3d& o, const Vec3d& d, double t_min, double t_max) const noexcept {
        return intersect(o, d, t_min, t_max).hit;
    }

    /// Brute force reference: every grain overlapping the box [lo, hi] (anchor frame) is listed
    /// (for tests and the explicit-instance benchmark); fn(GrainInstance, centre).
    template <class Fn>
    void for_each_grain(const Vec3d& lo, const Vec3d& hi, Fn&& fn) const {
        // Query the tiling in a frame near the anchor (no precision loss: offsets are small).
        tile_.for_each_overlapping(lo, hi, [&](const TileSphereRef& r) {
            const Vec3i64 abs_tile = r.tile + boundary_.anchor();
            if (!contains_sphere(abs_tile, r.sphere)) return;
            fn(instance(abs_tile, r.sphere), r.center);
        });
    }

private:
    /// True if neither the voxel nor any of its 26 neighbours can hold a grain centre.
    [[nodiscard]] bool unreachable(const Vec3i64& vt) const noexcept {
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    if (boundary_.classify(vt + Vec3i64(dx, dy, dz)) != VoxelClass::outside) return false;
        return true;
    }

    PeriodicTile tile_;
    VoxelizedBoundary<Shape> boundary_;
    std::vector<GrainExemplar> exemplars_;
    DiscreteDistribution<double> mix_;
    std::uint64_t seed_;
};

}  // namespace grainlight
