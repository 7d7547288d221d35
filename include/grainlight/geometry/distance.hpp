/// @file grainlight/geometry/distance.hpp
/// Distance-to-boundary queries: "how far is the surface of this volume from p", i.e. the
/// radius of the largest ball centred at p that stays inside. Moon07's shell tracer picks the
/// largest shell that fits with it (Sec. 4.2, Fig. 5: "max shell radius fitting around x_i"),
/// and hybrid schemes that switch methods with the depth below a surface need the same query.
///
/// Every query here is a *signed* distance functor `double operator()(const Vec3d& p)`: the
/// Euclidean distance from p to the surface, positive inside, negative outside (0 on it). Hence
/// the ball B(p, r) lies inside the closed volume iff `distance(p) >= r` (`ball_inside`).
///   - `SphereDistance`, `BoxDistance` (axis-aligned), `SlabDistance` (-thickness < z < 0,
///     thickness may be +inf): analytic.
///   - `MeshDistance`: a closed, consistently oriented triangle mesh. The unsigned distance is the
///     exact nearest point over all triangles (Ericson, *Real-Time Collision Detection*, 2005,
///     Sec. 5.1.5), found by branch-and-bound over a bounding-box tree of the triangles; the sign
///     comes from MeshBoundary's ray-parity inside test (its triangle BVH, geometry/bvh.hpp).
///     `nearest(p)` also returns the nearest point and triangle; `ball_inside(p, r)` is the
///     conservative "no triangle within r and p inside" query with early exit (Meng15 Sec. 5's
///     DA switch); `auxiliary_thickness(p, w)` is App. A's slab thickness z_r + z_a.
/// Each also has `exit_distance(p, w)`: the distance along the unit direction w from p to the
/// first surface crossing (the "distance to surface along omega" of Moon07 Fig. 5).
/// Queries are const, thread-safe, allocation-free and noexcept; constructors validate.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"

namespace grainlight {

/// True if the closed ball of radius r about p lies inside the volume of the signed distance
/// query `dist` (see the file comment).
/// Queries with a member `ball_inside(p, r)` (MeshDistance: stops at the first triangle closer
/// than r) use it; the others compare the signed distance.
template <class Distance>
[[nodiscard]] inline bool ball_inside(const Distance& dist, const Vec3d& p, double r) noexcept {
    if constexpr (requires { { dist.ball_inside(p, r) } -> std::convertible_to<bool>; })
        return dist.ball_inside(p, r);
    else
        return dist(p) >= r;
}

/// Signed distance to a sphere surface (positive inside).
struct SphereDistance {
    Vec3d center{0.0};  ///< sphere centre
    double radius = 1.0;  ///< sphere radius (> 0)
    /// Throws grainlight::invalid_argument for a non-finite centre or radius <= 0.
    SphereDistance(const Vec3d& c, double r) : center(c), radius(r) {
        check_argument(std::isfinite(r) && r > 0, "SphereDistance", "radius", r, "(0, inf)");
        check_argument(std::isfinite(c.x + c.y + c.z), "SphereDistance", "center", c.x + c.y + c.z, "finite");
    }
    /// Signed distance (positive inside).
    [[nodiscard]] double operator()(const Vec3d& p) const noexcept { return radius - glm::length(p - center); }
    /// Distance along unit w from p (inside) to the surface (0 if p is outside and w points away).
    [[nodiscard]] double exit_distance(const Vec3d& p, const Vec3d& w) const noexcept {
        const Vec3d rel = p - center;
        const double b = glm::dot(rel, w), c = glm::dot(rel, rel) - radius * radius;
        return std::max(0.0, -b + std::sqrt(std::max(0.0, b * b - c)));
    }
};

/// Signed distance to the surface of the axis-aligned box [lo, hi] (positive inside).
struct BoxDistance {
    Vec3d lo{-1.0};  ///< lower corner
    Vec3d hi{1.0};   ///< upper corner
    /// Throws grainlight::invalid_argument unless hi > lo on every axis.
    BoxDistance(const Vec3d& lo_, const Vec3d& hi_) : lo(lo_), hi(hi_) {
        for (int a = 0; a < 3; ++a)
            check_argument(std::isfinite(hi[a] - lo[a]) && hi[a] > lo[a], "BoxDistance", "hi - lo", hi[a] - lo[a],
                           "(0, inf) on every axis");
    }
    /// Signed distance (positive inside; outside: the Euclidean distance to the box, negated).
    [[nodiscard]] double operator()(const Vec3d& p) const noexcept {
        double inside = std::numeric_limits<double>::infinity(), out2 = 0;
        bool outside = false;
        for (int a = 0; a < 3; ++a) {
            const double dl = p[a] - lo[a], dh = hi[a] - p[a];
            inside = std::min({inside, dl, dh});
            const double e = std::max({0.0, -dl, -dh});
            if (e > 0) outside = true;
            out2 += e * e;
        }
        return outside ? -std::sqrt(out2) : inside;
    }
    /// Distance along unit w from p (inside) to the surface where the ray leaves the box.
    [[nodiscard]] double exit_distance(const Vec3d& p, const Vec3d& w) const noexcept {
        double t = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a) {
            if (w[a] > 0) t = std::min(t, (hi[a] - p[a]) / w[a]);
            if (w[a] < 0) t = std::min(t, (lo[a] - p[a]) / w[a]);
        }
        return std::max(0.0, t);
    }
    /// Outward unit normal of the face nearest to p (the face a path at p leaves through, for p on
    /// or near the surface; ties go to the lowest axis, the lo face before the hi face).
    [[nodiscard]] Vec3d normal(const Vec3d& p) const noexcept {
        int best = 0;
        double dmin = std::numeric_limits<double>::infinity(), sgn = 1;
        for (int a = 0; a < 3; ++a) {
            if (std::abs(p[a] - lo[a]) < dmin) { dmin = std::abs(p[a] - lo[a]); best = a; sgn = -1; }
            if (std::abs(hi[a] - p[a]) < dmin) { dmin = std::abs(hi[a] - p[a]); best = a; sgn = 1; }
        }
        Vec3d n(0.0);
        n[best] = sgn;
        return n;
    }
};

/// Signed distance to the faces of the slab -thickness < z < 0 (thickness > 0, may be +inf:
/// the half-space z < 0).
struct SlabDistance {
    double thickness = 1.0;  ///< slab thickness (> 0; +inf: half-space)
    /// Signed distance to the nearer face (positive inside).
    [[nodiscard]] double operator()(const Vec3d& p) const noexcept {
        const double top = -p.z;
        return std::isfinite(thickness) ? std::min(top, p.z + thickness) : top;
    }
    /// Distance along unit w from p (inside) to the face the ray leaves through (+inf if parallel).
    [[nodiscard]] double exit_distance(const Vec3d& p, const Vec3d& w) const noexcept {
        if (w.z > 0) return std::max(0.0, -p.z / w.z);
        if (w.z < 0 && std::isfinite(thickness)) return std::max(0.0, (-thickness - p.z) / w.z);
        return std::numeric_limits<double>::infinity();
    }
};

/// Nearest point of the triangle (a, b, c) to p (Ericson 2005, Sec. 5.1.5: Voronoi regions of
/// the vertices, edges and face). Degenerate triangles give a point of their edges.
[[nodiscard]] inline Vec3d closest_point_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                                     const Vec3d& c) noexcept {
    const Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const Vec3d bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
    const Vec3d cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    const double den = va + vb + vc;
    if (!(std::abs(den) > 0)) {  // degenerate: nearest of the three edges
        auto seg = [&](const Vec3d& u, const Vec3d& v) {
            const Vec3d e = v - u;
            const double l2 = glm::dot(e, e);
            const double t = l2 > 0 ? std::clamp(glm::dot(p - u, e) / l2, 0.0, 1.0) : 0.0;
            return u + t * e;
        };
        Vec3d best = seg(a, b);
        for (const Vec3d& q : {seg(b, c), seg(c, a)})
            if (glm::dot(q - p, q - p) < glm::dot(best - p, best - p)) best = q;
        return best;
    }
    const double v = vb / den, w = vc / den;
    return a + v * ab + w * ac;
}

/// Squared distance from p to the closed box b (0 inside).
[[nodiscard]] inline double distance2_to_box(const Aabb<double>& b, const Vec3d& p) noexcept {
    double s = 0;
    for (int a = 0; a < 3; ++a) {
        const double e = std::max({0.0, b.lo[a] - p[a], p[a] - b.hi[a]});
        s += e * e;
    }
    return s;
}

/// Nearest surface point of a mesh.
struct NearestPoint {
    Vec3d point{0.0};                                         ///< nearest point on the surface
    double distance = std::numeric_limits<double>::infinity(); ///< its (unsigned) distance
    std::uint32_t triangle = std::numeric_limits<std::uint32_t>::max();  ///< triangle index in the mesh
};

/// Signed distance to a closed triangle mesh (see the file comment). Throws
/// grainlight::invalid_argument for an invalid, non-watertight or inside-out mesh (MeshBoundary's
/// checks). Copies share the immutable tree.
class MeshDistance {
public:
    /// Build the distance tree (and MeshBoundary's ray BVH) over a closed mesh.
    template <std::floating_point F>
    explicit MeshDistance(const TriangleMesh<F>& mesh) : inside_(mesh) {
        auto d = std::make_shared<Data>();
        const std::size_t n = mesh.triangles.size();
        d->tris.resize(n);
        d->ids.resize(n);
        std::vector<Vec3d> centroid(n);
        for (std::size_t i = 0; i < n; ++i) {
            const auto c = mesh.corners(i);
            d->tris[i] = {Vec3d(c[0]), Vec3d(c[1]), Vec3d(c[2])};
            d->ids[i] = std::uint32_t(i);
            centroid[i] = (d->tris[i][0] + d->tris[i][1] + d->tris[i][2]) / 3.0;
        }
        std::vector<std::uint32_t> order(n);
        for (std::size_t i = 0; i < n; ++i) order[i] = std::uint32_t(i);
        d->nodes.reserve(2 * n / leaf_size + 2);
        build(*d, order, centroid, 0, n);
        std::vector<std::array<Vec3d, 3>> tris(n);
        for (std::size_t i = 0; i < n; ++i) {
            tris[i] = d->tris[order[i]];
            d->ids[i] = order[i];
        }
        d->tris = std::move(tris);
        TriangleMesh<double> md;
        md.vertices.reserve(mesh.vertices.size());
        for (const auto& v : mesh.vertices) md.vertices.emplace_back(Vec3d(v));
        md.triangles = mesh.triangles;
        d->bvh = Bvh<double>(md);
        data_ = std::move(d);
    }

    /// Distance along unit w from p to the first surface crossing (+inf if none).
    [[nodiscard]] double exit_distance(const Vec3d& p, const Vec3d& w) const noexcept {
        const TriangleHit<double> h = data_->bvh.intersect(p, w, 0.0, std::numeric_limits<double>::infinity());
        return h ? h.t : std::numeric_limits<double>::infinity();
    }

    /// Nearest point of the surface to p (exact over all triangles).
    [[nodiscard]] NearestPoint nearest(const Vec3d& p) const noexcept {
        NearestPoint best;
        double best2 = std::numeric_limits<double>::infinity();
        // The pruning radius shrinks to the best triangle so far.
        (void)visit_within(p, best2, [&](std::uint32_t i, const Vec3d& q, double d2) {
            if (d2 < best2) {
                best2 = d2;
                best.point = q;
                best.triangle = data_->ids[i];
            }
            return false;
        });
        best.distance = std::sqrt(best2);
        return best;
    }

    /// True if some surface point is closer to p than r (branch-and-bound that stops at the
    /// first triangle found within r; cheaper than nearest() when the answer is yes).
    [[nodiscard]] bool any_within(const Vec3d& p, double r) const noexcept {
        if (!(r > 0)) return false;
        // Prune boxes with a slightly larger radius (never skip a triangle within r by rounding);
        // decide on triangles with the same sqrt as nearest(), so ball_inside(p, (*this)(p)) holds.
        const double r2 = r * r * (1.0 + 1e-12);
        // Stopped at a triangle within r, or (conservative) out of stack.
        return visit_within(p, r2, [&](std::uint32_t, const Vec3d&, double d2) { return d2 < r2 && std::sqrt(d2) < r; }) !=
               Visit::completed;
    }
    /// The conservative "is the closed ball B(p, r) inside the volume" query (Meng15 Sec. 5's
    /// VPT -> DA criterion "no triangle within d_DA", Moon07's largest shell that fits): true iff
    /// p is inside and no surface point is closer than r. Same answer as `(*this)(p) >= r`, but
    /// the triangle search stops early and the (costlier) parity test runs only when no triangle
    /// is near.
    [[nodiscard]] bool ball_inside(const Vec3d& p, double r) const noexcept {
        if (!bounds().contains(p)) return false;
        if (any_within(p, r)) return false;
        return inside(p);
    }
    /// Meng15 App. A's slab thickness from an interior point p along the unit direction w of the
    /// DA connection: z_r = depth of p below the tangent plane at the exit point x_s = p + t_s w,
    /// z_a = depth below the tangent plane at x_a = p - t_a w (the auxiliary ray), thickness
    /// z_r + z_a. Returns +inf when either ray misses or leaves at a grazing/wrong-facing
    /// triangle (callers then use the semi-infinite profile).
    [[nodiscard]] double auxiliary_thickness(const Vec3d& p, const Vec3d& w) const noexcept {
        constexpr double inf = std::numeric_limits<double>::infinity();
        const TriangleHit<double> hs = data_->bvh.intersect(p, w, 0.0, inf);
        const TriangleHit<double> ha = data_->bvh.intersect(p, -w, 0.0, inf);
        if (!hs || !ha) return inf;
        const double z_r = hs.t * glm::dot(w, hs.n_geom), z_a = ha.t * glm::dot(-w, ha.n_geom);
        if (!(z_r > 0) || !(z_a > 0)) return inf;
        return z_r + z_a;
    }

    /// Most triangles `inside_near` gathers (it declines beyond).
    static constexpr int near_capacity = 64;
    /// Which of the points x[0..n) lie inside, for points within r of p (|x[i] - p| <= r) whose
    /// own side is `p_inside`: out[i] = p_inside xor (the segment p -> x[i] crosses the surface
    /// an odd number of times), counted against the triangles within r of p only (one range
    /// search for all points instead of `inside`'s three full parity rays per point; the
    /// watertight test counts a crossing through a shared edge once). Returns false, leaving
    /// `out` unspecified, when more than `near_capacity` triangles lie within r (ask `inside` per
    /// point then). Used by the flight memory's collision disc near a mesh boundary
    /// (integrators/flight_memory.hpp).
    [[nodiscard]] bool inside_near(const Vec3d& p, double r, bool p_inside, const Vec3d* x, int n, bool* out) const noexcept {
        std::array<std::uint32_t, near_capacity> near;
        int m = 0;
        const double r2 = r * r * (1.0 + 1e-9);  // never miss a triangle within r by rounding
        const Visit v = visit_within(p, r2, [&](std::uint32_t i, const Vec3d&, double d2) {
            if (d2 >= r2) return false;
            if (m == near_capacity) return true;  // one more than it gathers: decline
            near[std::size_t(m++)] = i;
            return false;
        });
        if (v != Visit::completed) return false;
        for (int i = 0; i < n; ++i) {
            const Vec3d d = x[i] - p;
            int crossings = 0;
            if (m > 0 && glm::dot(d, d) > 0) {
                const WatertightRay<double> wr(p, d);
                double t = 0, b1 = 0, b2 = 0;
                for (int k = 0; k < m; ++k) {
                    const auto& tri = data_->tris[near[std::size_t(k)]];
                    crossings += intersect_triangle_watertight(wr, tri[0], tri[1], tri[2], 0.0, 1.0, t, b1, b2) ? 1 : 0;
                }
            }
            out[i] = p_inside != ((crossings & 1) != 0);
        }
        return true;
    }

    /// Unsigned distance from p to the surface.
    [[nodiscard]] double unsigned_distance(const Vec3d& p) const noexcept { return nearest(p).distance; }
    /// p strictly inside (ray parity, MeshBoundary::inside).
    [[nodiscard]] bool inside(const Vec3d& p) const noexcept { return inside_.inside(p); }
    /// Signed distance: positive inside, negative outside.
    [[nodiscard]] double operator()(const Vec3d& p) const noexcept {
        const double d = unsigned_distance(p);
        return inside(p) ? d : -d;
    }
    /// Bounding box of the mesh.
    [[nodiscard]] Aabb<double> bounds() const noexcept { return inside_.bounds(); }
    /// Number of triangles.
    [[nodiscard]] std::size_t triangle_count() const noexcept { return data_->tris.size(); }

private:
    /// How visit_within ended.
    enum class Visit { completed, stopped, out_of_stack };
    /// Visits the triangles (index into data_->tris, nearest point to p, its squared distance) of every leaf whose box
    /// is closer to p than sqrt(r2), the nearer child first, until `fn` returns true. `r2` is read
    /// at every node, so `fn` may shrink it (nearest: the best distance so far).
    template <class Fn>
    [[nodiscard]] Visit visit_within(const Vec3d& p, const double& r2, Fn&& fn) const noexcept {
        const auto& nodes = data_->nodes;
        std::uint32_t stack[128];
        int sp = 0;
        stack[sp++] = 0;
        while (sp > 0) {
            const Node& nd = nodes[stack[--sp]];
            if (distance2_to_box(nd.box, p) >= r2) continue;
            if (nd.count > 0) {
                for (std::uint32_t i = nd.first; i < nd.first + nd.count; ++i) {
                    const auto& t = data_->tris[i];
                    const Vec3d q = closest_point_on_triangle(p, t[0], t[1], t[2]);
                    if (fn(i, q, glm::dot(q - p, q - p))) return Visit::stopped;
                }
                continue;
            }
            if (sp + 2 > 128) return Visit::out_of_stack;  // cannot happen for balanced trees
            const std::uint32_t a = nd.first, b = nd.first + 1;
            if (distance2_to_box(nodes[a].box, p) < distance2_to_box(nodes[b].box, p)) {
                stack[sp++] = b;
                stack[sp++] = a;
            } else {
                stack[sp++] = a;
                stack[sp++] = b;
            }
        }
        return Visit::completed;
    }

    static constexpr std::size_t leaf_size = 4;
    struct Node {
        Aabb<double> box;
        std::uint32_t first = 0;  ///< leaf: first triangle; interior: left child (right = first + 1)
        std::uint32_t count = 0;  ///< triangles (0: interior)
    };
    struct Data {
        std::vector<Node> nodes;
        std::vector<std::array<Vec3d, 3>> tris;
        std::vector<std::uint32_t> ids;
        Bvh<double> bvh;  ///< ray queries (exit_distance)
    };

    // Median split on the largest centroid axis; children of a node are stored next to each other.
    static void build(Data& d, std::vector<std::uint32_t>& order, const std::vector<Vec3d>& centroid, std::size_t b,
                      std::size_t e) {
        struct Item {
            std::uint32_t node;
            std::size_t b, e;
        };
        d.nodes.push_back({});
        std::vector<Item> todo{{0, b, e}};
        while (!todo.empty()) {
            const Item it = todo.back();
            todo.pop_back();
            Aabb<double> box, cbox;
            for (std::size_t i = it.b; i < it.e; ++i) {
                for (const Vec3d& v : d.tris[order[i]]) box.expand(v);
                cbox.expand(centroid[order[i]]);
            }
            d.nodes[it.node].box = box;
            if (it.e - it.b <= leaf_size) {
                d.nodes[it.node].first = std::uint32_t(it.b);
                d.nodes[it.node].count = std::uint32_t(it.e - it.b);
                continue;
            }
            const int axis = cbox.largest_axis();
            const std::size_t m = (it.b + it.e) / 2;
            std::nth_element(order.begin() + std::ptrdiff_t(it.b), order.begin() + std::ptrdiff_t(m),
                             order.begin() + std::ptrdiff_t(it.e), [&](std::uint32_t x, std::uint32_t y) {
                                 return centroid[x][axis] < centroid[y][axis];
                             });
            const auto left = std::uint32_t(d.nodes.size());
            d.nodes.push_back({});
            d.nodes.push_back({});
            d.nodes[it.node].first = left;
            d.nodes[it.node].count = 0;
            todo.push_back({left, it.b, m});
            todo.push_back({left + 1, m, it.e});
        }
    }

    MeshBoundary inside_;
    std::shared_ptr<const Data> data_;
};

}  // namespace grainlight
