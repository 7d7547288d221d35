/// @file grainlight/traversal/octree.hpp
/// Octree over light samples (Wang & Holzschuch 2018, "Point-Based Rendering for Homogeneous
/// Participating Media with Refractive Boundaries", Sec. 3.4.3, Alg. 1, Sec. 4.3).
///
/// Items are weighted points with a direction: volume samples (position x_v, direction of the
/// incoming light d_v, weight = power x segment length) or surface samples (position, normal,
/// weight = power). Each item also carries an axis-aligned `extent` (the box its influence covers:
/// the OBB of a volume sample for single scattering, or just its position).
///
/// Build (Sec. 3.4.3): top-down, regular subdivision of the cube around the items until a cell
/// holds at most `max_leaf_items` (8 in the paper) items (or `max_depth` is reached); bottom-up,
/// each node stores the sum of its items' weights, the weight-averaged position and direction
/// (the length of the averaged unit direction, `coherence`, in [0, 1], measures the direction
/// spread: 1 = all parallel), the bounds of its positions and of its items' extents.
/// Items are reordered so that every node covers a contiguous range [begin, end); each item keeps
/// its caller-side index `id`.
///
/// Tree cuts (Alg. 1): from a receiver point P with outgoing direction o, a node is subdivided if
/// the solid angle it subtends from P exceeds eps1, or exceeds eps2 while the phase function is
/// strongly peaked toward it (p(o, u) > phase_max or p(u, d) > phase_max, the paper's pi/4).
/// The solid angle of a node is approximated by that of its bounding sphere, pi r^2 / |P - c|^2,
/// and is infinite when P lies inside the node's position bounds. A leaf that must be subdivided
/// yields its items one by one. With eps1 = 0 every item is visited individually, so a cut sum
/// equals the brute-force sum over all items (tested).
///
/// Two-step traversal (Sec. 4.3): `coarse_cut` extracts the nodes a cut reaches at a stopping
/// depth into a caller buffer; `tree_cut_from` continues the cut from that buffer. The pair
/// visits exactly the same cut as `tree_cut` (tested); the buffer can be shared between
/// neighbouring receivers (the paper shares it over 2x2 pixels).
///
/// Kernels (`tree_cut`, `coarse_cut`, `tree_cut_from`, `visit_segment`) do not allocate and do
/// not throw; the build validates its input.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/aabb.hpp"

namespace grainlight {

/// One light sample stored in the octree.
template <std::floating_point F, class S>
struct OctreeItem {
    Vec3<F> p{F(0)};                    ///< position x_v (scene units)
    Vec3<F> d{F(0), F(0), F(1)};        ///< unit direction (light propagation, or surface normal)
    S w{F(0)};                          ///< weight: power x length (volume, W m) or power (surface, W)
    Aabb<F> extent{};                   ///< box covered by the item's influence (>= the point itself)
    std::uint32_t id = 0;               ///< caller-side index (items are reordered by the build)
};

/// A node of the octree: aggregates of the items in [begin, end).
template <std::floating_point F, class S>
struct OctreeNode {
    Aabb<F> bounds{};             ///< bounds of the item positions
    Aabb<F> extent{};             ///< bounds of the item extents (single-scattering culling)
    Vec3<F> p{F(0)};              ///< weight-averaged position (channel-average weight)
    Vec3<F> d{F(0), F(0), F(1)};  ///< weight-averaged direction, normalized
    F coherence = F(1);           ///< |weight-averaged unit direction| in [0, 1]
    S w{F(0)};                    ///< sum of item weights
    /// @var begin
    /// First item of the node's range [begin, end).
    std::uint32_t begin = 0, end = 0;   ///< item range
    std::uint32_t first_child = 0;      ///< index of the first child node
    std::uint32_t child_count = 0;      ///< 0 for a leaf
    std::uint32_t depth = 0;            ///< 0 at the root
    /// True for a leaf (no children).
    [[nodiscard]] bool leaf() const noexcept { return child_count == 0; }
};

/// Criterion of Alg. 1 (Wang18): solid-angle thresholds and the phase-function peak threshold.
template <std::floating_point F>
struct CutCriterion {
    F eps1 = F(0.1);                ///< always subdivide above this solid angle (sr); paper: 0.1-0.5
    F eps2 = F(0.01);               ///< subdivide above this solid angle if the phase is peaked (sr)
    F phase_max = pi_v<F> / F(4);   ///< "p > pi/4" of Alg. 1 (phase value, 1/sr)
    /// Skip a node and its subtree when every item position is farther than this from P (the
    /// distance from P to the node's position bounds): a receiver beyond the reach of every
    /// kernel gets nothing from it (not in the paper; infinity = no culling, Alg. 1 as is).
    F max_distance = std::numeric_limits<F>::infinity();
};

/// Squared distance from P to the box b (0 inside).
template <std::floating_point F>
[[nodiscard]] inline F box_distance2(const Aabb<F>& b, const Vec3<F>& P) noexcept {
    const Vec3<F> d = glm::max(glm::max(b.lo - P, P - b.hi), Vec3<F>(F(0)));
    return glm::dot(d, d);
}

/// True if the cut `c` skips node bounds `b` seen from P (CutCriterion::max_distance).
template <std::floating_point F>
[[nodiscard]] inline bool cut_culls(const CutCriterion<F>& c, const Aabb<F>& b, const Vec3<F>& P) noexcept {
    return c.max_distance < std::numeric_limits<F>::infinity() && box_distance2(b, P) > c.max_distance * c.max_distance;
}

/// Density factor k_v of Wang18 Eq. 4: (clamp(A_v / S_v, 1, 8) * clamp(sigma_t, 0.3, 0.8))^2.
/// A_v: bounding-box area of the leaf's volume samples, S_v: area around the surface sample at the
/// origin of the ray (same units); sigma_t in the scene's 1/length as in the paper (the clamp
/// makes the factor depend on the scene scale: see docs/wang18.md).
template <std::floating_point F>
[[nodiscard]] inline F density_factor(F A_v, F S_v, F sigma_t) noexcept {
    const F ratio = S_v > F(0) ? std::clamp(A_v / S_v, F(1), F(8)) : F(8);
    const F k = ratio * std::clamp(sigma_t, F(0.3), F(0.8));
    return k * k;
}

/// Approximate solid angle (sr) subtended from `P` by a box: that of its bounding sphere, clamped
/// to 4 pi; infinite if P is inside the box.
template <std::floating_point F>
[[nodiscard]] inline F node_solid_angle(const Aabb<F>& b, const Vec3<F>& P) noexcept {
    if (b.contains(P)) return std::numeric_limits<F>::infinity();
    const Vec3<F> c = b.center();
    const F r2 = F(0.25) * glm::dot(b.extent(), b.extent());
    const F d2 = glm::dot(P - c, P - c);
    if (d2 <= r2) return F(4) * pi_v<F>;
    return std::min(F(4) * pi_v<F>, pi_v<F> * r2 / d2);
}

/// Octree over light samples (see the file comment).
template <std::floating_point F, class S>
class Octree {
public:
    /// Item type: one light sample.
    using Item = OctreeItem<F, S>;
    /// Node type.
    using Node = OctreeNode<F, S>;

    Octree() = default;

    /// Build over `items`. Throws grainlight::invalid_argument on non-finite positions/directions,
    /// negative or non-finite weights, or bad parameters. An empty item set gives an empty tree
    /// (no nodes).
    /// \param items light samples (moved in; reordered by the build, see items())
    /// \param max_leaf_items >= 1 (paper: 8)
    /// \param max_depth in [1, 30]
    explicit Octree(std::vector<Item> items, int max_leaf_items = 8, int max_depth = 20)
        : items_(std::move(items)) {
        check_argument(max_leaf_items >= 1, "Octree", "max_leaf_items", max_leaf_items, ">= 1");
        check_argument(max_depth >= 1 && max_depth <= 30, "Octree", "max_depth", max_depth, "[1, 30]");
        Aabb<F> box;
        for (std::size_t i = 0; i < items_.size(); ++i) {
            const Item& it = items_[i];
            const bool ok = std::isfinite(double(it.p.x)) && std::isfinite(double(it.p.y)) &&
                            std::isfinite(double(it.p.z)) && std::isfinite(double(glm::dot(it.d, it.d)));
            check_argument(ok, "Octree", "items[" + std::to_string(i) + "].p/d", double(it.p.x), "finite");
            for (std::size_t c = 0; c < S::size; ++c)
                check_argument(std::isfinite(double(it.w[c])) && it.w[c] >= F(0), "Octree",
                               "items[" + std::to_string(i) + "].w", double(it.w[c]), "[0, inf)");
            box.expand(it.p);
        }
        if (items_.empty()) return;
        // Cubical root cell (regular subdivision), slightly padded.
        const Vec3<F> c = box.center();
        const Vec3<F> e = box.extent();
        const F half = F(0.5) * std::max({e.x, e.y, e.z, F(1e-6) * (F(1) + max_abs_component(c))}) * F(1.0001);
        nodes_.reserve(items_.size() / 2 + 8);
        nodes_.push_back(Node{});
        std::vector<Item> scratch(items_.size());
        build(0, 0, std::uint32_t(items_.size()), c, half, 0, std::uint32_t(max_leaf_items), std::uint32_t(max_depth),
              scratch);
    }

    /// The items, reordered by the build (leaf ranges index into this).
    [[nodiscard]] const std::vector<Item>& items() const noexcept { return items_; }
    /// The nodes; the root is nodes()[0] (empty for an empty tree).
    [[nodiscard]] const std::vector<Node>& nodes() const noexcept { return nodes_; }
    /// True if the tree has no nodes (built from no items).
    [[nodiscard]] bool empty() const noexcept { return nodes_.empty(); }
    /// Depth of the deepest node.
    [[nodiscard]] std::uint32_t max_node_depth() const noexcept {
        std::uint32_t m = 0;
        for (const Node& n : nodes_) m = std::max(m, n.depth);
        return m;
    }

    /// Whether Alg. 1 subdivides `n` for receiver P, outgoing direction o; `phase(a, b)` returns the
    /// phase-function value (1/sr) for propagation a then b.
    template <class Phase>
    [[nodiscard]] static bool subdivide(const Node& n, const Vec3<F>& P, const Vec3<F>& o, const CutCriterion<F>& c,
                                        Phase&& phase) noexcept {
        const F omega = node_solid_angle(n.bounds, P);
        if (omega > c.eps1) return true;
        if (omega > c.eps2) {
            Vec3<F> u = P - n.p;  // from the node toward the receiver
            const F len = glm::length(u);
            if (!(len > F(0))) return true;
            u /= len;
            if (phase(u, o) > c.phase_max || phase(n.d, u) > c.phase_max) return true;
        }
        return false;
    }

    /// Alg. 1 tree cut from the root: calls `node_fn(const Node&)` for every accepted node and
    /// `item_fn(const Item&)` for every item of a leaf that still had to be subdivided.
    template <class Phase, class NodeFn, class ItemFn>
    void tree_cut(const Vec3<F>& P, const Vec3<F>& o, const CutCriterion<F>& c, Phase&& phase, NodeFn&& node_fn,
                  ItemFn&& item_fn) const noexcept {
        if (nodes_.empty()) return;
        cut_from(0, P, o, c, phase, node_fn, item_fn);
    }

    /// First step of the two-step traversal: the nodes of the cut that Alg. 1 reaches, stopping
    /// the descent at `stop_depth` (nodes at that depth are stored even if they would be
    /// subdivided). Accepted nodes above stop_depth are stored too. Writes node indices into
    /// `out` (capacity out.size()) and returns the count; if the buffer is too small, returns
    /// out.size() + 1 and the caller should use tree_cut instead.
    template <class Phase>
    [[nodiscard]] std::size_t coarse_cut(const Vec3<F>& P, const Vec3<F>& o, const CutCriterion<F>& c, Phase&& phase,
                                         std::uint32_t stop_depth, std::span<std::uint32_t> out) const noexcept {
        if (nodes_.empty()) return 0;
        std::array<std::uint32_t, 256> stack;
        std::size_t sp = 0, n_out = 0;
        stack[sp++] = 0;
        while (sp > 0) {
            const std::uint32_t ni = stack[--sp];
            const Node& n = nodes_[ni];
            if (cut_culls(c, n.bounds, P)) continue;
            if (n.depth >= stop_depth || n.leaf() || !subdivide(n, P, o, c, phase)) {
                if (n_out >= out.size()) return out.size() + 1;
                out[n_out++] = ni;
                continue;
            }
            for (std::uint32_t k = n.child_count; k-- > 0;) stack[sp++] = n.first_child + k;
        }
        return n_out;
    }

    /// Second step of the two-step traversal: continue Alg. 1 from the nodes in `start`.
    template <class Phase, class NodeFn, class ItemFn>
    void tree_cut_from(std::span<const std::uint32_t> start, const Vec3<F>& P, const Vec3<F>& o,
                       const CutCriterion<F>& c, Phase&& phase, NodeFn&& node_fn, ItemFn&& item_fn) const noexcept {
        for (std::uint32_t ni : start) cut_from(ni, P, o, c, phase, node_fn, item_fn);
    }

    /// Visit every item whose `extent` box the segment o + t d, t in [t0, t1], intersects (top-down,
    /// discarding nodes whose extent the segment misses): `item_fn(const Item&)`.
    template <class ItemFn>
    void visit_segment(const Vec3<F>& org, const Vec3<F>& dir, F t0, F t1, ItemFn&& item_fn) const noexcept {
        if (nodes_.empty()) return;
        const Vec3<F> inv(F(1) / dir.x, F(1) / dir.y, F(1) / dir.z);
        std::array<std::uint32_t, 256> stack;
        std::size_t sp = 0;
        stack[sp++] = 0;
        while (sp > 0) {
            const Node& n = nodes_[stack[--sp]];
            if (!hits(n.extent, org, inv, t0, t1)) continue;
            if (n.leaf()) {
                for (std::uint32_t i = n.begin; i < n.end; ++i)
                    if (hits(items_[i].extent, org, inv, t0, t1)) item_fn(items_[i]);
                continue;
            }
            for (std::uint32_t k = n.child_count; k-- > 0;) stack[sp++] = n.first_child + k;
        }
    }

private:
    static bool hits(const Aabb<F>& b, const Vec3<F>& o, const Vec3<F>& inv, F t0, F t1) noexcept {
        for (int a = 0; a < 3; ++a) {
            F tn = (b.lo[a] - o[a]) * inv[a], tf = (b.hi[a] - o[a]) * inv[a];
            if (std::isnan(tn) || std::isnan(tf)) {  // 0 * inf: ray parallel to and on a slab plane
                if (o[a] < b.lo[a] || o[a] > b.hi[a]) return false;
                continue;
            }
            if (tn > tf) std::swap(tn, tf);
            t0 = std::max(t0, tn);
            t1 = std::min(t1, tf);
            if (t0 > t1) return false;
        }
        return true;
    }

    template <class Phase, class NodeFn, class ItemFn>
    void cut_from(std::uint32_t root, const Vec3<F>& P, const Vec3<F>& o, const CutCriterion<F>& c, Phase& phase,
                  NodeFn& node_fn, ItemFn& item_fn) const noexcept {
        std::array<std::uint32_t, 256> stack;  // depth <= 30, 8 children per level: 30 * 7 + 1 < 256
        std::size_t sp = 0;
        stack[sp++] = root;
        while (sp > 0) {
            const Node& n = nodes_[stack[--sp]];
            if (cut_culls(c, n.bounds, P)) continue;
            if (!subdivide(n, P, o, c, phase)) {
                node_fn(n);
                continue;
            }
            if (n.leaf()) {
                for (std::uint32_t i = n.begin; i < n.end; ++i) item_fn(items_[i]);
                continue;
            }
            for (std::uint32_t k = n.child_count; k-- > 0;) stack[sp++] = n.first_child + k;
        }
    }

    void build(std::uint32_t ni, std::uint32_t begin, std::uint32_t end, Vec3<F> center, F half, std::uint32_t depth,
               std::uint32_t max_leaf, std::uint32_t max_depth, std::vector<Item>& scratch) {
        nodes_[ni].begin = begin;
        nodes_[ni].end = end;
        nodes_[ni].depth = depth;
        if (end - begin > max_leaf && depth < max_depth) {
            // Partition items into the 8 octants (stable counting sort through scratch).
            std::array<std::uint32_t, 9> count{};
            auto octant = [&](const Vec3<F>& p) {
                return std::uint32_t(p.x >= center.x) | (std::uint32_t(p.y >= center.y) << 1) |
                       (std::uint32_t(p.z >= center.z) << 2);
            };
            for (std::uint32_t i = begin; i < end; ++i) ++count[octant(items_[i].p) + 1];
            for (int k = 0; k < 8; ++k) count[k + 1] += count[k];
            std::array<std::uint32_t, 9> pos = count;
            for (std::uint32_t i = begin; i < end; ++i) scratch[begin + pos[octant(items_[i].p)]++] = items_[i];
            std::copy(scratch.begin() + begin, scratch.begin() + end, items_.begin() + begin);
            std::uint32_t nonempty = 0;
            for (int k = 0; k < 8; ++k) nonempty += count[k + 1] > count[k];
            const std::uint32_t first = std::uint32_t(nodes_.size());
            nodes_[ni].first_child = first;
            nodes_[ni].child_count = nonempty;
            nodes_.resize(nodes_.size() + nonempty);
            std::uint32_t child = first;
            const F h = half * F(0.5);
            for (int k = 0; k < 8; ++k) {
                if (count[k + 1] == count[k]) continue;
                const Vec3<F> cc(center.x + ((k & 1) ? h : -h), center.y + ((k & 2) ? h : -h),
                                 center.z + ((k & 4) ? h : -h));
                build(child++, begin + count[k], begin + count[k + 1], cc, h, depth + 1, max_leaf, max_depth, scratch);
            }
        }
        // Bottom-up aggregates.
        Node& n = nodes_[ni];
        Aabb<F> bounds, extent;
        S w(F(0));
        Vec3<F> p(F(0)), d(F(0));
        F wsum = F(0);
        for (std::uint32_t i = begin; i < end; ++i) {
            const Item& it = items_[i];
            bounds.expand(it.p);
            extent.expand(it.extent);
            extent.expand(it.p);
            w += it.w;
            const F wi = F(it.w.average());
            p += wi * it.p;
            d += wi * it.d;
            wsum += wi;
        }
        n.bounds = bounds;
        n.extent = extent;
        n.w = w;
        if (wsum > F(0)) {
            n.p = p / wsum;
            const Vec3<F> dm = d / wsum;  // normalise the mean, not the sum (tiny weights underflow)
            const F len = glm::length(dm);
            n.coherence = std::min(F(1), len);
            n.d = len > F(0) ? dm / len : Vec3<F>(F(0), F(0), F(1));
        } else {
            n.p = bounds.center();
            n.coherence = F(0);
            n.d = Vec3<F>(F(0), F(0), F(1));
        }
    }

    std::vector<Item> items_;
    std::vector<Node> nodes_;
};

}  // namespace grainlight
