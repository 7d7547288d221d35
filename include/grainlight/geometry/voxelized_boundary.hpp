/// @file grainlight/geometry/voxelized_boundary.hpp
/// The aggregate boundary of Meng15 Sec. 3.2 voxelized on the tile grid: every voxel (one voxel
/// = one instance of the base tile, in size and position) is *fully outside*, *fully inside* or
/// *partially inside* the aggregate shape, stored in two bits per voxel; partial voxels need a
/// point-inside test for the bounding-sphere centres (Meng15 footnote 1: a grain belongs to the
/// aggregate iff its bounding-sphere centre is inside the boundary).
///
/// Frames. Voxel (tile) t (64-bit integer index) covers [t L, (t + 1) L)^3 in the absolute tile
/// frame. The boundary shape is described in the frame of an *anchor* tile: absolute position =
/// anchor L + shape coordinates, so an aggregate placed 1e6 tiles from the origin keeps full
/// precision (the shape's own coordinates stay small; only the integer anchor is large).
///
/// Shapes (the BoundaryShape concept): anything with
///   - `inside(Vec3d p) -> bool`: p strictly inside (shape frame);
///   - `bounds() -> Aabb<double>`: a box containing the shape;
///   - optional `clip(o, d, margin, t0, t1) -> bool`: narrow a ray interval to (a superset of)
///     the part within distance `margin` of the shape (the aggregate clips rays to the shape
///     dilated by the grain radius before Algorithm 1: spheres centred inside cannot lie beyond);
///   - `classify_box(lo, hi) -> VoxelClass`: conservative class of the closed box [lo, hi]
///     (`partial` whenever unsure), or alternatively `classify_grid(origin, side, dims, out)`
///     that classifies a whole grid at once (the triangle mesh does this by rasterizing its
///     triangles and casting parity rays along grid rows).
/// Provided: SphereBoundary, BoxBoundary, UnionBoundary (of two shapes) and MeshBoundary (any
/// watertight, consistently oriented triangle mesh; non-watertight meshes are rejected with
/// grainlight::invalid_argument). MeshBoundary's point test is ray parity against its BVH, made
/// robust by a majority vote of three axis-aligned rays.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// Class of a voxel against the aggregate boundary (the two-bit code stored per voxel).
enum class VoxelClass : std::uint8_t {
    outside = 0,  ///< no point of the voxel is inside the shape
    inside = 1,   ///< every point of the voxel is inside the shape
    partial = 2   ///< the boundary surface passes through the voxel (or the class is uncertain)
};

/// A shape that can be voxelized (see the file comment).
template <class B>
concept BoundaryShape = requires(const B& b, const Vec3d& p) {
    { b.inside(p) } -> std::convertible_to<bool>;
    { b.bounds() } -> std::convertible_to<Aabb<double>>;
};

namespace detail {
/// Slab clip of the ray o + t d to the box [lo, hi]: narrows [t0, t1]; false if empty (a ray
/// only touching the box counts as empty here). geometry/aabb.hpp's clip_ray_to_box.
[[nodiscard]] inline bool clip_ray_to_box(const Vec3d& o, const Vec3d& d, const Vec3d& lo, const Vec3d& hi, double& t0,
                                          double& t1) noexcept {
    return grainlight::clip_ray_to_box<double>(o, d, lo, hi, t0, t1) && t0 < t1;
}
}  // namespace detail

/// Solid sphere |p - center| < radius (radius > 0).
struct SphereBoundary {
    /// Sphere centre (world units, finite).
    Vec3d center{0.0};
    /// Sphere radius (> 0).
    double radius = 1.0;

    /// Sphere at `c` of radius `r` > 0; throws grainlight::invalid_argument otherwise.
    SphereBoundary(const Vec3d& c, double r) : center(c), radius(r) {
        check_argument(std::isfinite(r) && r > 0, "SphereBoundary", "radius", r, "(0, inf)");
        check_argument(std::isfinite(c.x + c.y + c.z), "SphereBoundary", "center", c.x + c.y + c.z, "finite");
    }
    /// True if p is strictly inside.
    [[nodiscard]] bool inside(const Vec3d& p) const noexcept { return glm::dot(p - center, p - center) < radius * radius; }
    /// One-line description.
    [[nodiscard]] std::string to_string() const {
        return "SphereBoundary[center (" + grainlight::detail::to_display(center.x) + ", " + grainlight::detail::to_display(center.y) + ", " + grainlight::detail::to_display(center.z) + "), radius " +
               grainlight::detail::to_display(radius) + "]";
    }
    /// Axis-aligned bounds of the sphere.
    [[nodiscard]] Aabb<double> bounds() const noexcept { return {center - Vec3d(radius), center + Vec3d(radius)}; }
    /// Clip the ray o + t d (unit d) to the shape dilated by `margin`: narrows [t0, t1] to the
    /// part within distance `margin` of the shape; false if nothing remains.
    [[nodiscard]] bool clip(const Vec3d& o, const Vec3d& d, double margin, double& t0, double& t1) const noexcept {
        const auto r = intersect_sphere(o, d, center, radius + margin);
        if (!r) return false;
        t0 = std::max(t0, r.t_near);
        t1 = std::min(t1, r.t_far);
        return t0 < t1;
    }
    /// Exact: outside iff the nearest box point is not inside, inside iff the farthest corner is.
    [[nodiscard]] VoxelClass classify_box(const Vec3d& lo, const Vec3d& hi) const noexcept {
        double dmin = 0, dmax = 0;
        for (int a = 0; a < 3; ++a) {
            const double q = std::clamp(center[a], lo[a], hi[a]);
            dmin += (q - center[a]) * (q - center[a]);
            const double f = std::max(std::abs(lo[a] - center[a]), std::abs(hi[a] - center[a]));
            dmax += f * f;
        }
        const double r2 = radius * radius;
        if (dmin >= r2) return VoxelClass::outside;
        if (dmax < r2) return VoxelClass::inside;
        return VoxelClass::partial;
    }
};

/// Solid axis-aligned box lo < p < hi.
struct BoxBoundary {
    /// @var lo
    /// Lower corner.
    /// @var hi
    /// Upper corner (hi > lo on every axis).
    Vec3d lo{-1.0}, hi{1.0};

    /// Box between `lo_` and `hi_` (hi_ > lo_ on every axis, finite); throws grainlight::invalid_argument otherwise.
    BoxBoundary(const Vec3d& lo_, const Vec3d& hi_) : lo(lo_), hi(hi_) {
        for (int a = 0; a < 3; ++a)
            check_argument(std::isfinite(hi[a] - lo[a]) && hi[a] > lo[a], "BoxBoundary", "hi - lo", hi[a] - lo[a],
                           "(0, inf) on every axis");
    }
    /// True if p is strictly inside.
    [[nodiscard]] bool inside(const Vec3d& p) const noexcept {
        return p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y && p.z > lo.z && p.z < hi.z;
    }
    /// One-line description.
    [[nodiscard]] std::string to_string() const {
        return "BoxBoundary[(" + grainlight::detail::to_display(lo.x) + ", " + grainlight::detail::to_display(lo.y) + ", " + grainlight::detail::to_display(lo.z) + ") - (" + grainlight::detail::to_display(hi.x) + ", " +
               grainlight::detail::to_display(hi.y) + ", " + grainlight::detail::to_display(hi.z) + ")]";
    }
    /// The box itself.
    [[nodiscard]] Aabb<double> bounds() const noexcept { return {lo, hi}; }
    /// Clip to the box grown by `margin` (a superset of the dilated box).
    [[nodiscard]] bool clip(const Vec3d& o, const Vec3d& d, double margin, double& t0, double& t1) const noexcept {
        return detail::clip_ray_to_box(o, d, lo - Vec3d(margin), hi + Vec3d(margin), t0, t1);
    }
    /// Classify the voxel [blo, bhi] exactly: outside, inside (fully contained) or partial.
    [[nodiscard]] VoxelClass classify_box(const Vec3d& blo, const Vec3d& bhi) const noexcept {
        bool contained = true;
        for (int a = 0; a < 3; ++a) {
            if (bhi[a] <= lo[a] || blo[a] >= hi[a]) return VoxelClass::outside;
            if (!(blo[a] > lo[a] && bhi[a] < hi[a])) contained = false;
        }
        return contained ? VoxelClass::inside : VoxelClass::partial;
    }
};

/// Union of two shapes (each with classify_box): inside if in either.
template <BoundaryShape A, BoundaryShape B>
struct UnionBoundary {
    /// First shape.
    A a;
    /// Second shape.
    B b;
    /// True if p is inside a or b.
    [[nodiscard]] bool inside(const Vec3d& p) const noexcept { return a.inside(p) || b.inside(p); }
    /// Union of the two shapes' bounds.
    [[nodiscard]] Aabb<double> bounds() const noexcept {
        Aabb<double> r = a.bounds();
        r.expand(b.bounds());
        return r;
    }
    /// Clip to the hull of the two parts' clipped intervals.
    [[nodiscard]] bool clip(const Vec3d& o, const Vec3d& d, double margin, double& t0, double& t1) const noexcept {
        double a0 = t0, a1 = t1, b0 = t0, b1 = t1;
        const bool ha = a.clip(o, d, margin, a0, a1), hb = b.clip(o, d, margin, b0, b1);
        if (!ha && !hb) return false;
        t0 = std::max(t0, std::min(ha ? a0 : b0, hb ? b0 : a0));
        t1 = std::min(t1, std::max(ha ? a1 : b1, hb ? b1 : a1));
        return t0 < t1;
    }
    /// Inside if either part classifies the box inside, outside if both do outside, else partial (conservative).
    [[nodiscard]] VoxelClass classify_box(const Vec3d& lo, const Vec3d& hi) const noexcept {
        const VoxelClass ca = a.classify_box(lo, hi), cb = b.classify_box(lo, hi);
        if (ca == VoxelClass::inside || cb == VoxelClass::inside) return VoxelClass::inside;
        if (ca == VoxelClass::outside && cb == VoxelClass::outside) return VoxelClass::outside;
        return VoxelClass::partial;
    }
};

namespace detail {

/// Separating-axis test of a triangle against the closed box [c - h, c + h] (Akenine-Moller
/// 2001, "Fast 3D triangle-box overlap testing": the 3 box normals, the triangle normal and the
/// 9 edge cross products). Conservative by a relative tolerance: touching counts as overlap.
[[nodiscard]] inline bool triangle_box_overlap(const Vec3d& c, const Vec3d& h, const Vec3d& a0, const Vec3d& a1,
                                               const Vec3d& a2) noexcept {
    const Vec3d v0 = a0 - c, v1 = a1 - c, v2 = a2 - c;
    const double tol = 1e-9 * (h.x + h.y + h.z);
    for (int a = 0; a < 3; ++a) {
        const double mn = std::min({v0[a], v1[a], v2[a]}), mx = std::max({v0[a], v1[a], v2[a]});
        if (mn > h[a] + tol || mx < -h[a] - tol) return false;
    }
    const Vec3d e[3] = {v1 - v0, v2 - v1, v0 - v2};
    auto separated = [&](const Vec3d& axis) {
        const double p0 = glm::dot(axis, v0), p1 = glm::dot(axis, v1), p2 = glm::dot(axis, v2);
        const double r = h.x * std::abs(axis.x) + h.y * std::abs(axis.y) + h.z * std::abs(axis.z);
        const double l = glm::length(axis);
        return std::min({p0, p1, p2}) > r + tol * l || std::max({p0, p1, p2}) < -r - tol * l;
    };
    const Vec3d n = glm::cross(e[0], e[1]);
    if (separated(n)) return false;
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) {
            Vec3d u(0.0);
            u[a] = 1.0;
            const Vec3d axis = glm::cross(u, e[i]);
            if (glm::dot(axis, axis) > 0 && separated(axis)) return false;
        }
    return true;
}

}  // namespace detail

/// What a shape's classify_grid may also return about the partial voxels (grid order) so that a
/// point test there needs no global query: the triangles overlapping each partial voxel (CSR:
/// entries tri_start[r] up to, not including, tri_start[r + 1] of tri_ids for the r-th partial
/// voxel) and whether the
/// voxel's reference point (MeshBoundary::reference_point) is inside. A point of the voxel is
/// then inside iff the segment from the reference point crosses those triangles an odd number of
/// times relative to it (the segment lies in the voxel, so no other triangle can cross it).
struct PartialVoxelSurface {
    /// One entry per partial voxel: 1 if its reference point is inside.
    std::vector<std::uint8_t> ref_inside;
    /// CSR offsets into tri_ids (partial voxels + 1 entries).
    std::vector<std::uint32_t> tri_start;
    /// Triangle indices overlapping each partial voxel.
    std::vector<std::uint32_t> tri_ids;
    /// Bytes held.
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        return ref_inside.size() + (tri_start.size() + tri_ids.size()) * sizeof(std::uint32_t);
    }
};

/// A watertight, consistently oriented (outward normals) triangle mesh as an aggregate boundary.
/// Throws grainlight::invalid_argument for an invalid, non-watertight or inside-out mesh.
class MeshBoundary {
public:
    /// Copy `mesh` (validated: watertight, outward-facing, positive signed volume) into double precision and build its BVH.
    template <std::floating_point F>
    explicit MeshBoundary(const TriangleMesh<F>& mesh) {
        mesh.validate("MeshBoundary");
        check_argument(mesh.is_watertight(), "MeshBoundary", "watertight", "no",
                       "a closed mesh: every edge shared by exactly two triangles with opposite orientation");
        const double vol = mesh.signed_volume();
        check_argument(vol > 0, "MeshBoundary", "signed volume", vol, "> 0 (outward-facing triangles)");
        TriangleMesh<double> m;
        m.vertices.reserve(mesh.vertices.size());
        for (const auto& v : mesh.vertices) m.vertices.emplace_back(Vec3d(v));
        m.triangles = mesh.triangles;
        m.compute_face_normals();
        bounds_ = m.bounds();
        tris_.reserve(m.triangles.size());
        for (std::size_t i = 0; i < m.triangles.size(); ++i) tris_.push_back(m.corners(i));
        bvh_ = std::make_shared<const Bvh<double>>(m);
    }

    /// Bounds of the mesh.
    [[nodiscard]] Aabb<double> bounds() const noexcept { return bounds_; }
    /// Clip to the mesh bounds grown by `margin` (conservative).
    [[nodiscard]] bool clip(const Vec3d& o, const Vec3d& d, double margin, double& t0, double& t1) const noexcept {
        return detail::clip_ray_to_box(o, d, bounds_.lo - Vec3d(margin), bounds_.hi + Vec3d(margin), t0, t1);
    }
    /// Number of triangles.
    [[nodiscard]] std::size_t triangle_count() const noexcept { return tris_.size(); }
    /// One-line description.
    [[nodiscard]] std::string to_string() const {
        return "MeshBoundary[" + std::to_string(tris_.size()) + " triangles, bounds (" + grainlight::detail::to_display(bounds_.lo.x) + ", " +
               grainlight::detail::to_display(bounds_.lo.y) + ", " + grainlight::detail::to_display(bounds_.lo.z) + ") - (" + grainlight::detail::to_display(bounds_.hi.x) + ", " + grainlight::detail::to_display(bounds_.hi.y) +
               ", " + grainlight::detail::to_display(bounds_.hi.z) + ")]";
    }
    /// Bytes held (triangles copy + BVH estimate).
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        return tris_.size() * sizeof(std::array<Vec3d, 3>) * 2 + bvh_->nodes().size() * sizeof(BvhNode<double>) +
               tris_.size() * (sizeof(Vec3d) + sizeof(std::uint32_t));
    }

    /// Number of surface crossings of the ray p + t d, t > 0 (all hits, in order).
    [[nodiscard]] int crossings(const Vec3d& p, const Vec3d& d) const noexcept {
        int n = 0;
        double t = 0;
        for (int guard = 0; guard < 1 << 20; ++guard) {
            const TriangleHit<double> h = bvh_->intersect(p, d, t, std::numeric_limits<double>::infinity());
            if (!h) break;
            ++n;
            t = h.t;
        }
        return n;
    }
    /// Point-inside test by ray parity, majority of three rays near +x, +y, +z (a ray grazing
    /// an edge or vertex can miscount; two rays rarely do at once). The rays are tilted off the
    /// axes by a few degrees so that they do not run inside the coordinate planes that
    /// modelled meshes (boxes, icospheres) often have edges in.
    [[nodiscard]] bool inside(const Vec3d& p) const noexcept {
        if (!bounds_.contains(p)) return false;
        static constexpr double tilt[3][3] = {{1.0, 0.0331, 0.0527}, {0.0419, 1.0, -0.0283}, {-0.0367, 0.0613, 1.0}};
        int votes = 0;
        for (int a = 0; a < 3; ++a) votes += crossings(p, glm::normalize(Vec3d(tilt[a][0], tilt[a][1], tilt[a][2]))) & 1;
        return votes >= 2;
    }

    /// Classify the grid of `dims` voxels of side `side` starting at `origin` (shape frame),
    /// voxel (i, j, k) at index (k dims.y + j) dims.x + i: voxels overlapped by a triangle are
    /// partial (exact triangle-box test); the others take the inside/outside state of their
    /// interior, from a majority of three parity sweeps along the grid rows of x, y and z.
    /// With `surface`, also the triangles of each partial voxel and the side of its reference
    /// point (a majority of the three parity sweeps, each carried to the reference point by the
    /// parity of a segment inside the voxel), for inside_local.
    void classify_grid(const Vec3d& origin, double side, const std::array<std::int64_t, 3>& dims,
                       std::vector<VoxelClass>& out, PartialVoxelSurface* surface = nullptr) const {
        const std::size_t n = std::size_t(dims[0] * dims[1] * dims[2]);
        out.assign(n, VoxelClass::outside);
        std::vector<std::pair<std::uint64_t, std::uint32_t>> overlaps;  // (voxel, triangle) when `surface`
        auto index = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
            return std::size_t((k * dims[1] + j) * dims[0] + i);
        };
        // Partial voxels: rasterize each triangle over the voxels of its bounding box.
        const Vec3d h(0.5 * side);
        for (const auto& t : tris_) {
            std::array<std::int64_t, 3> a{}, b{};
            for (int ax = 0; ax < 3; ++ax) {
                const double mn = std::min({t[0][ax], t[1][ax], t[2][ax]}), mx = std::max({t[0][ax], t[1][ax], t[2][ax]});
                a[ax] = std::clamp<std::int64_t>(std::int64_t(std::floor((mn - origin[ax]) / side)) - 1, 0, dims[ax] - 1);
                b[ax] = std::clamp<std::int64_t>(std::int64_t(std::floor((mx - origin[ax]) / side)) + 1, 0, dims[ax] - 1);
            }
            for (std::int64_t k = a[2]; k <= b[2]; ++k)
                for (std::int64_t j = a[1]; j <= b[1]; ++j)
                    for (std::int64_t i = a[0]; i <= b[0]; ++i) {
                        const Vec3d c = origin + side * Vec3d(double(i) + 0.5, double(j) + 0.5, double(k) + 0.5);
                        if (detail::triangle_box_overlap(c, h, t[0], t[1], t[2])) {
                            out[index(i, j, k)] = VoxelClass::partial;
                            if (surface) overlaps.emplace_back(std::uint64_t(index(i, j, k)), std::uint32_t(&t - tris_.data()));
                        }
                    }
        }
        // Inside/outside of the remaining voxels: parity along rows of voxel centres.
        std::vector<std::uint8_t> votes(n, 0);
        std::vector<double> hits;
        for (int ax = 0; ax < 3; ++ax) {
            const int u = (ax + 1) % 3, v = (ax + 2) % 3;
            for (std::int64_t jv = 0; jv < dims[v]; ++jv)
                for (std::int64_t ju = 0; ju < dims[u]; ++ju) {
                    std::array<std::int64_t, 3> c{};
                    c[u] = ju;
                    c[v] = jv;
                    // Rows through a generic point of each voxel (not its centre): non-partial
                    // voxels are homogeneous, and off-centre rows avoid the symmetry planes of
                    // modelled meshes.
                    Vec3d p = sweep_point(origin, side, ax, c), d(0.0);
                    d[ax] = 1.0;
                    p[ax] = bounds_.lo[ax] - side;  // start outside the mesh
                    hits.clear();
                    double t = 0;
                    for (int guard = 0; guard < 1 << 20; ++guard) {
                        const TriangleHit<double> hh = bvh_->intersect(p, d, t, std::numeric_limits<double>::infinity());
                        if (!hh) break;
                        hits.push_back(p[ax] + hh.t);
                        t = hh.t;
                    }
                    std::size_t next = 0;
                    for (std::int64_t i = 0; i < dims[ax]; ++i) {
                        c[ax] = i;
                        const double x = sweep_point(origin, side, ax, c)[ax];
                        while (next < hits.size() && hits[next] < x) ++next;
                        if (next & 1) votes[index(c[0], c[1], c[2])] |= std::uint8_t(1u << ax);  // sweep ax says inside
                    }
                }
        }
        for (std::size_t i = 0; i < n; ++i)
            if (out[i] != VoxelClass::partial) out[i] = std::popcount(unsigned(votes[i])) >= 2 ? VoxelClass::inside : VoxelClass::outside;
        if (!surface) return;
        // Partial voxels: their triangles (grid order, CSR) and the side of their reference point.
        std::sort(overlaps.begin(), overlaps.end());
        surface->ref_inside.clear();
        surface->tri_start.assign(1, 0);
        surface->tri_ids.clear();
        surface->tri_ids.reserve(overlaps.size());
        std::size_t q = 0;
        for (std::size_t i = 0; i < n; ++i) {
            if (out[i] != VoxelClass::partial) continue;
            const std::size_t first = surface->tri_ids.size();
            for (; q < overlaps.size() && overlaps[q].first <= i; ++q)
                if (overlaps[q].first == i) surface->tri_ids.push_back(overlaps[q].second);
            surface->tri_start.push_back(std::uint32_t(surface->tri_ids.size()));
            const std::array<std::int64_t, 3> c{std::int64_t(i) % dims[0], (std::int64_t(i) / dims[0]) % dims[1],
                                                std::int64_t(i) / (dims[0] * dims[1])};
            const Vec3d ref = reference_point(origin, side, c[0], c[1], c[2]);
            const std::uint32_t* ids = surface->tri_ids.data() + first;
            const std::size_t m = surface->tri_ids.size() - first;
            int says_inside = 0;
            for (int ax = 0; ax < 3; ++ax)  // sweep ax's point, carried to the reference point
                says_inside += inside_local(sweep_point(origin, side, ax, c), (votes[i] >> ax) & 1u, ref, ids, m);
            surface->ref_inside.push_back(std::uint8_t(says_inside >= 2));
        }
    }

    /// The point of voxel c (grid at `origin`, voxels of side `side`) that classify_grid's parity
    /// sweep along axis `ax` classifies: off-centre by offsets that differ per axis and sweep.
    [[nodiscard]] static Vec3d sweep_point(const Vec3d& origin, double side, int ax,
                                           const std::array<std::int64_t, 3>& c) noexcept {
        const int u = (ax + 1) % 3, v = (ax + 2) % 3;
        Vec3d p(0.0);
        p[ax] = origin[ax] + (double(c[std::size_t(ax)]) + 0.5 + 0.0113 * (ax + 1)) * side;
        p[u] = origin[u] + (double(c[std::size_t(u)]) + 0.5 + 0.0173 * (ax + 1)) * side;
        p[v] = origin[v] + (double(c[std::size_t(v)]) + 0.5 - 0.0291 * (ax + 1)) * side;
        return p;
    }
    /// The reference point of voxel (i, j, k) of a grid at `origin` with voxels of side `side`:
    /// the point of the voxel that classify_grid's sweep along x classifies (sweep_point, ax = 0).
    [[nodiscard]] static Vec3d reference_point(const Vec3d& origin, double side, std::int64_t i, std::int64_t j,
                                               std::int64_t k) noexcept {
        return sweep_point(origin, side, 0, {i, j, k});
    }
    /// Is p inside, given a point `ref` whose side is known (`ref_inside`) and the triangles
    /// `ids[0..m)` that contain every surface crossing of the segment ref -> p (e.g. both points
    /// in one partial voxel and its triangles, PartialVoxelSurface)? The parity of the segment's
    /// crossings, by the watertight test (a crossing through a shared edge counts once).
    [[nodiscard]] bool inside_local(const Vec3d& ref, bool ref_inside, const Vec3d& p, const std::uint32_t* ids,
                                    std::size_t m) const noexcept {
        const Vec3d d = p - ref;
        if (m == 0 || !(glm::dot(d, d) > 0)) return ref_inside;
        const WatertightRay<double> wr(ref, d);
        int crossings = 0;
        double t = 0, b1 = 0, b2 = 0;
        for (std::size_t k = 0; k < m; ++k) {
            const auto& tri = tris_[ids[k]];
            crossings += intersect_triangle_watertight(wr, tri[0], tri[1], tri[2], 0.0, 1.0, t, b1, b2) ? 1 : 0;
        }
        return ref_inside != ((crossings & 1) != 0);
    }

private:
    std::vector<std::array<Vec3d, 3>> tris_;
    std::shared_ptr<const Bvh<double>> bvh_;
    Aabb<double> bounds_;
};

/// The voxelized aggregate boundary: 2 bits per tile-sized voxel (Meng15 Sec. 3.2) plus the
/// shape for point-inside tests in partial voxels. Queries are const, thread-safe and noexcept.
template <BoundaryShape Shape>
class VoxelizedBoundary {
public:
    /// Voxelize `shape` (in the frame of tile `anchor`) on the grid of tiles of side
    /// `tile_side` > 0. The grid covers the tiles overlapping the shape's bounds plus a margin
    /// of one voxel on every side (so every grain whose sphere reaches into the shape is in a
    /// voxel of the grid). Throws grainlight::invalid_argument for a bad side, unbounded or
    /// empty bounds, or more than 2^34 voxels.
    VoxelizedBoundary(Shape shape, double tile_side, const Vec3i64& anchor = Vec3i64(0, 0, 0))
        : shape_(std::move(shape)), side_(tile_side), anchor_(anchor) {
        check_argument(std::isfinite(tile_side) && tile_side > 0, "VoxelizedBoundary", "tile_side", tile_side, "(0, inf)");
        const Aabb<double> b = shape_.bounds();
        for (int a = 0; a < 3; ++a)
            check_argument(std::isfinite(b.lo[a]) && std::isfinite(b.hi[a]) && b.hi[a] >= b.lo[a], "VoxelizedBoundary",
                           "shape bounds extent", b.hi[a] - b.lo[a], "finite, >= 0");
        double total = 1;
        for (int a = 0; a < 3; ++a) {
            lo_[a] = std::int64_t(std::floor(b.lo[a] / side_)) - 1;
            const std::int64_t hi = std::int64_t(std::floor(b.hi[a] / side_)) + 1;
            dims_[a] = hi - lo_[a] + 1;
            total *= double(dims_[a]);
        }
        check_argument(total <= double(std::int64_t(1) << 34), "VoxelizedBoundary", "voxel count", total,
                       "<= 2^34 (use larger tiles)");
        const std::size_t n = std::size_t(total);
        bits_.assign((n + 31) / 32, 0);
        const Vec3d origin = side_ * Vec3d(double(lo_[0]), double(lo_[1]), double(lo_[2]));
        if constexpr (requires(std::vector<VoxelClass>& out, PartialVoxelSurface* ps) {
                          shape_.classify_grid(origin, side_, dims_, out, ps);
                      }) {
            std::vector<VoxelClass> cls;
            shape_.classify_grid(origin, side_, dims_, cls, &surface_);
            for (std::size_t i = 0; i < n; ++i) set(i, cls[i]);
        } else if constexpr (requires(std::vector<VoxelClass>& out) { shape_.classify_grid(origin, side_, dims_, out); }) {
            std::vector<VoxelClass> cls;
            shape_.classify_grid(origin, side_, dims_, cls);
            for (std::size_t i = 0; i < n; ++i) set(i, cls[i]);
        } else {
            static_assert(requires(const Vec3d& p) { shape_.classify_box(p, p); },
                          "a BoundaryShape needs classify_box(lo, hi) or classify_grid(origin, side, dims, out)");
            std::size_t i = 0;
            for (std::int64_t k = 0; k < dims_[2]; ++k)
                for (std::int64_t j = 0; j < dims_[1]; ++j)
                    for (std::int64_t x = 0; x < dims_[0]; ++x, ++i) {
                        const Vec3d lo = origin + side_ * Vec3d(double(x), double(j), double(k));
                        set(i, shape_.classify_box(lo, lo + Vec3d(side_)));
                    }
        }
        for (std::size_t i = 0; i < n; ++i) {
            const VoxelClass c = get(i);
            if (c == VoxelClass::inside) ++n_inside_;
            if (c == VoxelClass::partial) ++n_partial_;
        }
        if (n_partial_ > 0) build_partial_rank();
        refine(origin);
    }

    /// The voxelized shape (in the anchor tile's frame).
    [[nodiscard]] const Shape& shape() const noexcept { return shape_; }
    /// Side of a tile = of a voxel (world units).
    [[nodiscard]] double tile_side() const noexcept { return side_; }
    /// Tile the shape's frame is anchored at.
    [[nodiscard]] const Vec3i64& anchor() const noexcept { return anchor_; }
    /// Grid dimensions (voxels per axis) and its first voxel, relative to the anchor tile.
    [[nodiscard]] const std::array<std::int64_t, 3>& dims() const noexcept { return dims_; }
    /// First voxel of the grid per axis, relative to the anchor tile.
    [[nodiscard]] const std::array<std::int64_t, 3>& grid_lo() const noexcept { return lo_; }
    /// Total number of voxels of the grid.
    [[nodiscard]] std::size_t voxel_count() const noexcept { return std::size_t(dims_[0] * dims_[1] * dims_[2]); }
    /// Number of voxels fully inside the shape.
    [[nodiscard]] std::size_t inside_count() const noexcept { return n_inside_; }
    /// Number of partial voxels (crossed by the surface; point tests needed there).
    [[nodiscard]] std::size_t partial_count() const noexcept { return n_partial_; }
    /// Bytes of the voxel classes (2 bits per voxel, rounded up to 64-bit words); the shape
    /// (e.g. a mesh BVH for the partial-voxel test) and the refinement are separate.
    [[nodiscard]] std::size_t memory_bytes() const noexcept { return bits_.size() * sizeof(std::uint64_t); }
    /// Bytes of the sub-voxel refinement of the partial voxels (16 per partial voxel and 4 per
    /// 32 voxels for the rank index, or 0) and of the partial voxels' triangle lists (meshes).
    [[nodiscard]] std::size_t refinement_bytes() const noexcept {
        return partial_rank_.size() * sizeof(std::uint32_t) + sub_bits_.size() * sizeof(sub_bits_[0]) +
               surface_.memory_bytes();
    }
    /// The partial voxels' triangle lists and reference-point sides (empty unless the shape's
    /// classify_grid provides them: MeshBoundary); point_inside uses them in partial voxels.
    [[nodiscard]] const PartialVoxelSurface& partial_surface() const noexcept { return surface_; }
    /// True if partial voxels carry a 4^3 sub-voxel classification (see point_inside).
    [[nodiscard]] bool refined() const noexcept { return !sub_bits_.empty(); }

    /// Class of the voxel of absolute tile index `tile` (outside for tiles off the grid).
    [[nodiscard]] VoxelClass classify(const Vec3i64& tile) const noexcept {
        std::size_t idx = 0;
        if (!grid_index(tile, idx)) return VoxelClass::outside;
        return get(idx);
    }
    /// Is the point at local offset `local` (world units) from the corner of absolute tile
    /// `tile` inside the shape? Uses the voxel class and, in partial voxels, the shape's own test.
    /// A partial voxel is refined into 4^3 sub-voxels (2 bits each, stored only for partial
    /// voxels): the shape's own (possibly costly: ray parity against a mesh) test runs only in
    /// partial sub-voxels. A mesh's test there is local: the parity of the segment from the
    /// voxel's reference point against the voxel's own triangles (PartialVoxelSurface), not three
    /// rays through the whole mesh. Not a part of Meng15; it makes the partial-voxel test cheap
    /// (grids too large for the sub-voxels, e.g. Fig. 1's castle, rely on the local test alone).
    [[nodiscard]] bool point_inside(const Vec3i64& tile, const Vec3d& local) const noexcept {
        std::size_t idx = 0;
        if (!grid_index(tile, idx)) return false;
        const VoxelClass c = get(idx);
        if (c != VoxelClass::partial) return c == VoxelClass::inside;
        const std::size_t rank = partial_rank(idx);
        if (!sub_bits_.empty()) {
            int q[3];
            for (int a = 0; a < 3; ++a) q[a] = std::clamp(int(local[a] / side_ * sub), 0, sub - 1);
            const auto& w = sub_bits_[rank];
            const int si = (q[2] * sub + q[1]) * sub + q[0];
            const auto sc = VoxelClass((w[std::size_t(si >> 5)] >> (2 * (si & 31))) & 3u);
            if (sc != VoxelClass::partial) return sc == VoxelClass::inside;
        }
        const Vec3d p = to_shape_frame(tile, local);
        if constexpr (requires(const std::uint32_t* ids) { shape_.inside_local(p, true, p, ids, std::size_t(0)); }) {
            if (!surface_.tri_start.empty()) {  // parity from the voxel's reference point, its triangles only
                std::int64_t r[3];
                for (int a = 0; a < 3; ++a) r[a] = tile[a] - anchor_[a] - lo_[a];
                const Vec3d origin = side_ * Vec3d(double(lo_[0]), double(lo_[1]), double(lo_[2]));
                const Vec3d ref = Shape::reference_point(origin, side_, r[0], r[1], r[2]);
                const std::uint32_t b = surface_.tri_start[rank], e = surface_.tri_start[rank + 1];
                return shape_.inside_local(ref, surface_.ref_inside[rank] != 0, p, surface_.tri_ids.data() + b,
                                           std::size_t(e - b));
            }
        }
        return shape_.inside(p);
    }
    /// Shape-frame position of a point given as (absolute tile, local offset).
    [[nodiscard]] Vec3d to_shape_frame(const Vec3i64& tile, const Vec3d& local) const noexcept {
        return Vec3d(double(tile.x - anchor_.x), double(tile.y - anchor_.y), double(tile.z - anchor_.z)) * side_ + local;
    }
    /// Absolute tile range [lo, hi] (inclusive) of the grid.
    [[nodiscard]] Vec3i64 tile_lo() const noexcept { return anchor_ + Vec3i64(lo_[0], lo_[1], lo_[2]); }
    /// Last absolute tile of the grid (inclusive).
    [[nodiscard]] Vec3i64 tile_hi() const noexcept {
        return anchor_ + Vec3i64(lo_[0] + dims_[0] - 1, lo_[1] + dims_[1] - 1, lo_[2] + dims_[2] - 1);
    }

private:
    static constexpr int sub = 4;  // sub-voxels per axis in a refined partial voxel

    /// Classify the 4^3 sub-voxels of every partial voxel: with classify_box, or with one
    /// classify_grid call at 4x resolution when the fine grid has at most 2^26 cells (else no
    /// refinement: the shape's own point test is used in every partial voxel).
    void refine(const Vec3d& origin) {
        if (n_partial_ == 0) return;
        const std::size_t n = voxel_count();
        auto store = [&](auto&& sub_class) {
            sub_bits_.reserve(n_partial_);
            std::size_t i = 0;
            for (std::int64_t k = 0; k < dims_[2]; ++k)
                for (std::int64_t j = 0; j < dims_[1]; ++j)
                    for (std::int64_t x = 0; x < dims_[0]; ++x, ++i) {
                        if (get(i) != VoxelClass::partial) continue;
                        std::array<std::uint64_t, 2> w{0, 0};
                        for (int si = 0; si < sub * sub * sub; ++si) {
                            const int qx = si % sub, qy = (si / sub) % sub, qz = si / (sub * sub);
                            const auto c = std::uint64_t(sub_class(x, j, k, qx, qy, qz));
                            w[std::size_t(si >> 5)] |= c << (2 * (si & 31));
                        }
                        sub_bits_.push_back(w);
                    }
        };
        const double h = side_ / sub;
        if constexpr (requires(std::vector<VoxelClass>& out) { shape_.classify_grid(origin, side_, dims_, out); }) {
            if (double(n) * sub * sub * sub > double(std::int64_t(1) << 26)) return;
            const std::array<std::int64_t, 3> fd{dims_[0] * sub, dims_[1] * sub, dims_[2] * sub};
            std::vector<VoxelClass> fine;
            shape_.classify_grid(origin, h, fd, fine);
            store([&](std::int64_t x, std::int64_t y, std::int64_t z, int qx, int qy, int qz) {
                const std::int64_t fx = x * sub + qx, fy = y * sub + qy, fz = z * sub + qz;
                return fine[std::size_t((fz * fd[1] + fy) * fd[0] + fx)];
            });
        } else {
            store([&](std::int64_t x, std::int64_t y, std::int64_t z, int qx, int qy, int qz) {
                const Vec3d lo = origin + side_ * Vec3d(double(x), double(y), double(z)) + h * Vec3d(qx, qy, qz);
                return shape_.classify_box(lo, lo + Vec3d(h));
            });
        }
    }

    /// Rank index: partial voxels before each 64-bit word of classes (a popcount inside it).
    void build_partial_rank() {
        partial_rank_.resize(bits_.size());
        std::uint32_t before = 0;
        for (std::size_t wi = 0; wi < bits_.size(); ++wi) {
            partial_rank_[wi] = before;
            before += std::uint32_t(std::popcount(partial_lanes(bits_[wi])));
        }
    }

    [[nodiscard]] bool grid_index(const Vec3i64& tile, std::size_t& idx) const noexcept {
        std::int64_t r[3];
        for (int a = 0; a < 3; ++a) {
            r[a] = tile[a] - anchor_[a] - lo_[a];
            if (r[a] < 0 || r[a] >= dims_[a]) return false;
        }
        idx = std::size_t((r[2] * dims_[1] + r[1]) * dims_[0] + r[0]);
        return true;
    }
    /// One bit (the low bit of each 2-bit lane) per partial voxel of a word of classes.
    [[nodiscard]] static std::uint64_t partial_lanes(std::uint64_t w) noexcept {
        return (w >> 1) & ~w & 0x5555555555555555ull;  // class 2 = binary 10
    }
    /// Index of partial voxel i among the partial voxels in grid order (= its sub_bits_ entry):
    /// the word's rank plus the partial voxels before i inside the word. O(1), no search.
    [[nodiscard]] std::size_t partial_rank(std::size_t i) const noexcept {
        const std::uint64_t below = (std::uint64_t(1) << (2 * (i & 31))) - 1;
        return partial_rank_[i >> 5] + std::size_t(std::popcount(partial_lanes(bits_[i >> 5]) & below));
    }
    [[nodiscard]] VoxelClass get(std::size_t i) const noexcept {
        return VoxelClass((bits_[i >> 5] >> (2 * (i & 31))) & 3u);
    }
    void set(std::size_t i, VoxelClass c) noexcept {
        const unsigned s = unsigned(2 * (i & 31));
        bits_[i >> 5] = (bits_[i >> 5] & ~(std::uint64_t(3) << s)) | (std::uint64_t(c) << s);
    }

    Shape shape_;
    double side_;
    Vec3i64 anchor_;
    std::array<std::int64_t, 3> lo_{}, dims_{};
    std::vector<std::uint64_t> bits_;
    std::size_t n_inside_ = 0, n_partial_ = 0;
    std::vector<std::uint32_t> partial_rank_;              // partial voxels before each word of bits_
    std::vector<std::array<std::uint64_t, 2>> sub_bits_;  // 4^3 sub-voxel classes of every partial voxel, 2 bits each, grid order
    PartialVoxelSurface surface_;                          // partial voxels' triangles (shapes whose classify_grid gives them)
};

/// The whole space (an infinite aggregate: Meng15's free-flight and detector-sphere experiments,
/// Secs. 4.2.2-4.2.3). Its voxelization stores nothing: every voxel is fully inside.
struct EverywhereBoundary {
    /// Every point is inside.
    [[nodiscard]] bool inside(const Vec3d&) const noexcept { return true; }
    /// Bounds of +-1e300 on every axis.
    [[nodiscard]] Aabb<double> bounds() const noexcept {
        constexpr double big = 1e300;
        return {Vec3d(-big), Vec3d(big)};
    }
};

/// Voxelization of the whole space: every voxel inside, no memory. The grid range is +-2^40
/// tiles around the anchor (a ray is never clipped in practice).
template <>
class VoxelizedBoundary<EverywhereBoundary> {
public:
    /// Voxelization of the whole space with tiles of side `tile_side` > 0 (throws otherwise) around tile `anchor`.
    explicit VoxelizedBoundary(EverywhereBoundary shape = {}, double tile_side = 1.0, const Vec3i64& anchor = Vec3i64(0, 0, 0))
        : shape_(shape), side_(tile_side), anchor_(anchor) {
        check_argument(std::isfinite(tile_side) && tile_side > 0, "VoxelizedBoundary", "tile_side", tile_side, "(0, inf)");
    }
    /// Half-width of the nominal tile range around the anchor: 2^40 tiles.
    static constexpr std::int64_t half_range = std::int64_t(1) << 40;
    /// The (empty) shape.
    [[nodiscard]] const EverywhereBoundary& shape() const noexcept { return shape_; }
    /// Side of a tile (world units).
    [[nodiscard]] double tile_side() const noexcept { return side_; }
    /// Anchor tile.
    [[nodiscard]] const Vec3i64& anchor() const noexcept { return anchor_; }
    /// 0: nothing is stored.
    [[nodiscard]] std::size_t voxel_count() const noexcept { return 0; }
    /// 0: nothing is stored.
    [[nodiscard]] std::size_t memory_bytes() const noexcept { return 0; }
    /// Every voxel is inside.
    [[nodiscard]] VoxelClass classify(const Vec3i64&) const noexcept { return VoxelClass::inside; }
    /// Every point is inside.
    [[nodiscard]] bool point_inside(const Vec3i64&, const Vec3d&) const noexcept { return true; }
    /// Shape-frame position of a point given as (absolute tile, local offset).
    [[nodiscard]] Vec3d to_shape_frame(const Vec3i64& tile, const Vec3d& local) const noexcept {
        return Vec3d(double(tile.x - anchor_.x), double(tile.y - anchor_.y), double(tile.z - anchor_.z)) * side_ + local;
    }
    /// First tile of the nominal range, anchor - 2^40.
    [[nodiscard]] Vec3i64 tile_lo() const noexcept { return anchor_ - Vec3i64(half_range); }
    /// Last tile of the nominal range, anchor + 2^40.
    [[nodiscard]] Vec3i64 tile_hi() const noexcept { return anchor_ + Vec3i64(half_range); }

private:
    EverywhereBoundary shape_;
    double side_;
    Vec3i64 anchor_;
};

}  // namespace grainlight
