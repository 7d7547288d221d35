/// @file grainlight/geometry/bvh.hpp
/// Bounding volume hierarchy over a triangle mesh: binned SAH build (Wald 2007, "On fast
/// construction of SAH-based bounding volume hierarchies"), flattened depth-first nodes, and
/// closest-hit / any-hit queries with the watertight ray-triangle test of Woop, Benthin & Wald
/// 2013 ("Watertight Ray/Triangle Intersection", JCGT 2(1)). Queries allocate nothing and throw
/// nothing; the build validates the mesh.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include "grainlight/core/config.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// Result of a ray-triangle query. `b1`, `b2` are the barycentric weights of corners 1 and 2
/// (corner 0 has 1 - b1 - b2); `n_geom` is the unit geometric normal (v1-v0)x(v2-v0) of the
/// original mesh orientation, not flipped toward the ray.
template <std::floating_point F>
struct TriangleHit {
    /// Ray parameter of the hit (+inf if none).
    F t = std::numeric_limits<F>::infinity();
    /// Index of the triangle in the original mesh (max if none).
    std::uint32_t prim = std::numeric_limits<std::uint32_t>::max();
    /// Barycentric weight of corner 1.
    F b1 = F(0);
    /// Barycentric weight of corner 2.
    F b2 = F(0);
    /// Unit geometric normal (mesh orientation).
    Vec3<F> n_geom{F(0), F(0), F(1)};
    /// True if something was hit.
    [[nodiscard]] bool valid() const noexcept { return prim != std::numeric_limits<std::uint32_t>::max(); }
    /// Same as valid().
    explicit operator bool() const noexcept { return valid(); }
};

/// Per-ray constants of the watertight test (shear into the ray's coordinate system).
template <std::floating_point F>
struct WatertightRay {
    /// Ray origin.
    Vec3<F> o;
    /// @var kx
    /// Axis permutation: kz is the dominant axis of the direction.
    /// @var ky
    /// Second axis of the permutation (swapped with kx when d[kz] < 0, to keep the winding).
    /// @var kz
    /// Dominant axis of the direction (largest |d|).
    int kx = 0, ky = 1, kz = 2;
    /// @var sx
    /// Shear constants: sx = d[kx] / d[kz].
    /// @var sy
    /// Shear d[ky] / d[kz].
    /// @var sz
    /// Scale 1 / d[kz].
    F sx = F(0), sy = F(0), sz = F(1);

    /// Precompute for a ray o + t d (d non-zero).
    WatertightRay(const Vec3<F>& origin, const Vec3<F>& d) noexcept : o(origin) {
        const Vec3<F> a = glm::abs(d);
        kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
        kx = (kz + 1) % 3;
        ky = (kx + 1) % 3;
        if (d[kz] < F(0)) std::swap(kx, ky);  // keep the winding direction
        sx = d[kx] / d[kz];
        sy = d[ky] / d[kz];
        sz = F(1) / d[kz];
    }
};

/// Watertight ray-triangle test (Woop et al. 2013, Sec. 3): no ray can slip through the shared
/// edge of two triangles and none hits both. Both faces are hit. Returns true with t in
/// (t_min, t_max) and barycentrics (b1, b2). When an edge function is exactly 0 in float, the
/// three edge functions are recomputed in double as the paper prescribes.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline bool intersect_triangle_watertight(const WatertightRay<F>& r,
                                                                              const Vec3<F>& v0, const Vec3<F>& v1,
                                                                              const Vec3<F>& v2, F t_min, F t_max,
                                                                              F& t, F& b1, F& b2) noexcept {
    const Vec3<F> A = v0 - r.o, B = v1 - r.o, C = v2 - r.o;
    const F ax = A[r.kx] - r.sx * A[r.kz], ay = A[r.ky] - r.sy * A[r.kz];
    const F bx = B[r.kx] - r.sx * B[r.kz], by = B[r.ky] - r.sy * B[r.kz];
    const F cx = C[r.kx] - r.sx * C[r.kz], cy = C[r.ky] - r.sy * C[r.kz];
    F U = cx * by - cy * bx;
    F V = ax * cy - ay * cx;
    F W = bx * ay - by * ax;
    if constexpr (sizeof(F) < sizeof(double)) {
        if (U == F(0) || V == F(0) || W == F(0)) {
            U = F(double(cx) * double(by) - double(cy) * double(bx));
            V = F(double(ax) * double(cy) - double(ay) * double(cx));
            W = F(double(bx) * double(ay) - double(by) * double(ax));
        }
    }
    if ((U < F(0) || V < F(0) || W < F(0)) && (U > F(0) || V > F(0) || W > F(0))) return false;
    const F det = U + V + W;
    if (det == F(0)) return false;
    const F az = r.sz * A[r.kz], bz = r.sz * B[r.kz], cz = r.sz * C[r.kz];
    const F T = U * az + V * bz + W * cz;
    const F inv_det = F(1) / det;
    const F tt = T * inv_det;
    if (!(tt > t_min && tt < t_max)) return false;
    t = tt;
    b1 = V * inv_det;
    b2 = W * inv_det;
    return true;
}

/// A node of the flattened BVH (32 bytes for float). Interior: the left child is the next node,
/// `offset` the right child. Leaf (`count` > 0): triangles [offset, offset + count) of the
/// reordered triangle array.
template <std::floating_point F>
struct BvhNode {
    /// Bounds of the node's triangles.
    Aabb<F> box;
    /// Right child (interior) or first triangle (leaf).
    std::uint32_t offset = 0;
    /// Triangle count (0 for interior nodes).
    std::uint16_t count = 0;
    /// Split axis (interior nodes).
    std::uint8_t axis = 0;
    /// Padding.
    std::uint8_t pad = 0;
};

/// BVH over a triangle mesh (a copy of its triangles is kept, reordered for locality).
template <std::floating_point F>
class Bvh {
public:
    /// Maximum triangles per leaf and SAH bin count.
    static constexpr int max_leaf_size = 4;
    /// Number of SAH bins per axis in the build.
    static constexpr int bin_count = 16;
    /// Maximum tree depth; deeper splits become leaves.
    static constexpr int max_depth = 64;

    /// An empty BVH (every query misses).
    Bvh() = default;

    /// Build over `mesh` (validated; throws grainlight::invalid_argument on bad meshes).
    explicit Bvh(const TriangleMesh<F>& mesh) {
        mesh.validate("Bvh");
        const std::size_t n = mesh.triangles.size();
        check_argument(n < std::size_t(std::numeric_limits<std::uint32_t>::max()), "Bvh", "triangle count", n,
                       "< 2^32 - 1");
        std::vector<BuildPrim> prims(n);
        for (std::size_t i = 0; i < n; ++i) {
            const auto c = mesh.corners(i);
            Aabb<F> b;
            for (const auto& v : c) b.expand(v);
            prims[i] = {b, b.center(), std::uint32_t(i)};
        }
        nodes_.reserve(2 * n);
        build(prims, 0, n, 0);
        tris_.resize(n);
        prim_ids_.resize(n);
        normals_.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            const std::uint32_t id = prims[i].id;
            tris_[i] = mesh.corners(id);
            prim_ids_[i] = id;
            const Vec3<F> g = glm::cross(tris_[i][1] - tris_[i][0], tris_[i][2] - tris_[i][0]);
            const F len = glm::length(g);
            normals_[i] = len > F(0) ? g / len : Vec3<F>(F(0), F(0), F(1));
        }
    }

    /// The flattened nodes (root first).
    [[nodiscard]] const std::vector<BvhNode<F>>& nodes() const noexcept { return nodes_; }
    /// Number of triangles.
    [[nodiscard]] std::size_t triangle_count() const noexcept { return tris_.size(); }
    /// Bounds of the whole mesh.
    [[nodiscard]] Aabb<F> bounds() const noexcept { return nodes_.empty() ? Aabb<F>() : nodes_[0].box; }

    /// Closest hit with t in (t_min, t_max) along o + t d (d need not be normalized; t is in
    /// units of d). Returns an invalid hit (prim = max) when nothing is hit.
    [[nodiscard]] TriangleHit<F> intersect(const Vec3<F>& o, const Vec3<F>& d, F t_min, F t_max) const noexcept {
        TriangleHit<F> hit;
        traverse<false>(o, d, t_min, t_max, hit);
        return hit;
    }
    /// Closest hit along a Ray in (t_min, ray.t_max).
    [[nodiscard]] TriangleHit<F> intersect(const Ray<F>& ray, F t_min = F(0)) const noexcept {
        return intersect(ray.o, ray.d, t_min, ray.t_max);
    }
    /// Any hit with t in (t_min, t_max) (shadow/occlusion query; stops at the first found).
    [[nodiscard]] bool occluded(const Vec3<F>& o, const Vec3<F>& d, F t_min, F t_max) const noexcept {
        TriangleHit<F> hit;
        return traverse<true>(o, d, t_min, t_max, hit);
    }

private:
    struct BuildPrim {
        Aabb<F> box;
        Vec3<F> centroid;
        std::uint32_t id;
    };

    // Slab test with per-ray sign selection (no swaps); returns the entry distance in t_enter.
    static bool box_hit(const Aabb<F>& b, const Vec3<F>& o, const Vec3<F>& inv_d, const int* neg, F t0, F t1,
                        F& t_enter) noexcept {
        constexpr F eps = std::numeric_limits<F>::epsilon();
        constexpr F robust = F(1) + F(6) * eps / (F(1) - F(3) * eps);
        for (int a = 0; a < 3; ++a) {
            const F tn = ((neg[a] ? b.hi[a] : b.lo[a]) - o[a]) * inv_d[a];
            const F tf = ((neg[a] ? b.lo[a] : b.hi[a]) - o[a]) * inv_d[a] * robust;
            t0 = tn > t0 ? tn : t0;  // NaN-safe: a NaN bound leaves t0/t1 unchanged
            t1 = tf < t1 ? tf : t1;
        }
        t_enter = t0;
        return t0 <= t1;
    }

    template <bool AnyHit>
    bool traverse(const Vec3<F>& o, const Vec3<F>& d, F t_min, F t_max, TriangleHit<F>& hit) const noexcept {
        if (nodes_.empty()) return false;
        const WatertightRay<F> wr(o, d);
        const Vec3<F> inv_d(F(1) / d.x, F(1) / d.y, F(1) / d.z);
        const int neg[3] = {inv_d.x < F(0), inv_d.y < F(0), inv_d.z < F(0)};
        struct Entry {
            std::uint32_t node;
            F t;
        };
        Entry stack[max_depth + 2];
        int sp = 0;
        F closest = t_max;
        bool found = false;
        F t_root;
        if (!box_hit(nodes_[0].box, o, inv_d, neg, t_min, closest, t_root)) return false;
        std::uint32_t node = 0;
        for (;;) {
            const BvhNode<F>& nd = nodes_[node];
            if (nd.count > 0) {
                for (std::uint32_t i = nd.offset; i < nd.offset + nd.count; ++i) {
                    F t, b1, b2;
                    if (intersect_triangle_watertight(wr, tris_[i][0], tris_[i][1], tris_[i][2], t_min, closest, t, b1,
                                                      b2)) {
                        found = true;
                        closest = t;
                        hit.t = t;
                        hit.prim = prim_ids_[i];
                        hit.b1 = b1;
                        hit.b2 = b2;
                        hit.n_geom = normals_[i];
                        if constexpr (AnyHit) return true;
                    }
                }
            } else {
                // Visit the nearer child first; remember the other with its entry distance.
                std::uint32_t a = node + 1, b = nd.offset;
                F ta, tb;
                const bool ha = box_hit(nodes_[a].box, o, inv_d, neg, t_min, closest, ta);
                const bool hb = box_hit(nodes_[b].box, o, inv_d, neg, t_min, closest, tb);
                if (ha && hb) {
                    if (tb < ta) {
                        std::swap(a, b);
                        std::swap(ta, tb);
                    }
                    stack[sp++] = {b, tb};
                    node = a;
                    continue;
                }
                if (ha) {
                    node = a;
                    continue;
                }
                if (hb) {
                    node = b;
                    continue;
                }
            }
            // Pop the next node whose box starts before the closest hit so far.
            bool next = false;
            while (sp > 0) {
                const Entry e = stack[--sp];
                if (e.t <= closest) {
                    node = e.node;
                    next = true;
                    break;
                }
            }
            if (!next) break;
        }
        return found;
    }

    void make_leaf(std::uint32_t index, std::size_t begin, std::size_t end) {
        nodes_[index].offset = std::uint32_t(begin);
        nodes_[index].count = std::uint16_t(end - begin);
    }

    // Recursive binned-SAH build of prims[begin, end) into node nodes_.size(); depth-first order.
    void build(std::vector<BuildPrim>& prims, std::size_t begin, std::size_t end, int depth) {
        const auto index = std::uint32_t(nodes_.size());
        nodes_.push_back({});
        Aabb<F> box, cbox;
        for (std::size_t i = begin; i < end; ++i) {
            box.expand(prims[i].box);
            cbox.expand(prims[i].centroid);
        }
        nodes_[index].box = box;
        const std::size_t n = end - begin;
        if (n <= std::size_t(max_leaf_size)) {
            make_leaf(index, begin, end);
            return;
        }
        if (depth >= max_depth - 1) {  // never reached by meshes of < 2^32 triangles with distinct centroids
            check_argument(n <= 65535, "Bvh", "triangles in one leaf at maximum depth", n, "<= 65535");
            make_leaf(index, begin, end);
            return;
        }
        const int axis = cbox.largest_axis();
        const F lo = cbox.lo[axis], ext = cbox.hi[axis] - cbox.lo[axis];
        if (!(ext > F(0))) {  // all centroids coincide: split in the middle of the list
            split_median(prims, begin, end, cbox, index, depth);
            return;
        }
        struct Bin {
            Aabb<F> box;
            std::size_t count = 0;
        };
        std::array<Bin, bin_count> bins{};
        auto bin_of = [&](const BuildPrim& p) {
            int b = int(F(bin_count) * (p.centroid[axis] - lo) / ext);
            return std::clamp(b, 0, bin_count - 1);
        };
        for (std::size_t i = begin; i < end; ++i) {
            Bin& b = bins[std::size_t(bin_of(prims[i]))];
            b.box.expand(prims[i].box);
            ++b.count;
        }
        // Sweep: cost of splitting after bin k = A_left N_left + A_right N_right.
        std::array<F, bin_count - 1> left_cost{};
        Aabb<F> acc;
        std::size_t cnt = 0;
        for (int k = 0; k < bin_count - 1; ++k) {
            acc.expand(bins[std::size_t(k)].box);
            cnt += bins[std::size_t(k)].count;
            left_cost[std::size_t(k)] = cnt ? acc.surface_area() * F(cnt) : F(0);
        }
        acc = Aabb<F>();
        cnt = 0;
        F best = std::numeric_limits<F>::infinity();
        int best_k = -1;
        for (int k = bin_count - 1; k >= 1; --k) {
            acc.expand(bins[std::size_t(k)].box);
            cnt += bins[std::size_t(k)].count;
            const F c = left_cost[std::size_t(k - 1)] + (cnt ? acc.surface_area() * F(cnt) : F(0));
            if (cnt > 0 && cnt < n && c < best) {
                best = c;
                best_k = k;
            }
        }
        // Leaf if splitting does not pay (traversal cost 1 vs intersection cost 1 per prim).
        if (best_k < 0) {
            split_median(prims, begin, end, cbox, index, depth);
            return;
        }
        if (n <= std::size_t(max_leaf_size) * 4 && best + box.surface_area() >= F(n) * box.surface_area()) {
            make_leaf(index, begin, end);
            return;
        }
        auto mid_it = std::partition(prims.begin() + std::ptrdiff_t(begin), prims.begin() + std::ptrdiff_t(end),
                                     [&](const BuildPrim& p) { return bin_of(p) < best_k; });
        const auto mid = std::size_t(mid_it - prims.begin());
        nodes_[index].axis = std::uint8_t(axis);
        build(prims, begin, mid, depth + 1);
        nodes_[index].offset = std::uint32_t(nodes_.size());
        build(prims, mid, end, depth + 1);
    }

    void split_median(std::vector<BuildPrim>& prims, std::size_t begin, std::size_t end, const Aabb<F>& cbox,
                      std::uint32_t index, int depth) {
        const int axis = cbox.largest_axis();
        const std::size_t mid = (begin + end) / 2;
        std::nth_element(prims.begin() + std::ptrdiff_t(begin), prims.begin() + std::ptrdiff_t(mid),
                         prims.begin() + std::ptrdiff_t(end),
                         [axis](const BuildPrim& a, const BuildPrim& b) { return a.centroid[axis] < b.centroid[axis]; });
        nodes_[index].axis = std::uint8_t(axis);
        build(prims, begin, mid, depth + 1);
        nodes_[index].offset = std::uint32_t(nodes_.size());
        build(prims, mid, end, depth + 1);
    }

    std::vector<BvhNode<F>> nodes_;
    std::vector<std::array<Vec3<F>, 3>> tris_;
    std::vector<std::uint32_t> prim_ids_;
    std::vector<Vec3<F>> normals_;
};

}  // namespace grainlight
