// A bounding volume hierarchy over a particle cloud's spheres, as a sphere lookup of
// grainlight::ExplicitSphereMedium (media/discrete_particles.hpp, GridSphereLookup's interface).
// It is the baseline of guo21_fig20_time_vs_n: Guo21's EPT instances the particles as small balls
// in a general renderer, which traverses them in a BVH, while the library's EPT walks the same
// uniform particle grid as the discrete medium. Build: top-down, split at the object median of
// the longest centroid axis (for equal spheres at uniform random positions, what a binned SAH build
// converges to), leaves of at most 4 spheres. Traversal: closest hit, children nearest first, a
// fixed stack; no allocation per query.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <vector>

#include "grainlight/packing/particle_cloud.hpp"

namespace guo21_bvh {

namespace gl = grainlight;

class SphereBvhLookup {
public:
    explicit SphereBvhLookup(std::shared_ptr<const gl::ParticleCloud> cloud) : cloud_(std::move(cloud)) {
        const auto& ps = cloud_->particles();
        std::vector<std::uint32_t> idx(ps.size());
        std::iota(idx.begin(), idx.end(), 0u);
        nodes_.reserve(2 * ps.size() / kLeaf + 2);
        if (!ps.empty()) {
            nodes_.resize(1);
            build(idx, 0, std::uint32_t(idx.size()), 0);
        }
        // Store the spheres in leaf order so a leaf reads contiguous memory; order_ maps back.
        order_ = idx;
        spheres_.resize(ps.size());
        for (std::size_t k = 0; k < idx.size(); ++k) spheres_[k] = ps[idx[k]];
    }

    [[nodiscard]] const gl::CloudParticle* particles() const noexcept { return cloud_->particles().data(); }
    [[nodiscard]] std::size_t bytes() const noexcept {
        return nodes_.size() * sizeof(Node) + spheres_.size() * sizeof(gl::CloudParticle) + order_.size() * 4;
    }

    [[nodiscard]] std::int64_t containing(const gl::Vec3<float>& p) const noexcept {
        if (nodes_.empty()) return -1;
        std::array<std::uint32_t, 64> stack;
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& n = nodes_[stack[--top]];
            if (p.x < n.lo[0] || p.y < n.lo[1] || p.z < n.lo[2] || p.x > n.hi[0] || p.y > n.hi[1] || p.z > n.hi[2]) continue;
            if (n.count > 0) {
                for (std::uint32_t k = n.first; k < n.first + n.count; ++k) {
                    const gl::Vec3<float> v = spheres_[k].center() - p;
                    if (v.x * v.x + v.y * v.y + v.z * v.z < spheres_[k].r * spheres_[k].r) return order_[k];
                }
            } else {
                stack[top++] = n.first;
                stack[top++] = n.first + 1;
            }
        }
        return -1;
    }

    [[nodiscard]] std::int64_t first_hit(const gl::Vec3<float>& o, const gl::Vec3<float>& d, float t_max,
                                         float& t_hit) const noexcept {
        std::int64_t best = -1;
        float best_t = t_max;
        if (nodes_.empty()) {
            t_hit = best_t;
            return best;
        }
        const float inv[3] = {1.0f / d.x, 1.0f / d.y, 1.0f / d.z};
        const float org[3] = {o.x, o.y, o.z};
        std::array<std::uint32_t, 64> stack;
        int top = 0;
        std::uint32_t cur = 0;
        if (box(nodes_[0], org, inv, best_t) < 0.0f) {
            t_hit = best_t;
            return best;
        }
        for (;;) {
            const Node& n = nodes_[cur];
            if (n.count > 0) {
                for (std::uint32_t k = n.first; k < n.first + n.count; ++k) {
                    const gl::CloudParticle& c = spheres_[k];
                    const gl::Vec3<float> v = c.center() - o;
                    const float s = v.x * d.x + v.y * d.y + v.z * d.z;
                    const gl::Vec3<float> perp = v - s * d;
                    const float b2 = perp.x * perp.x + perp.y * perp.y + perp.z * perp.z;
                    if (!(b2 < c.r * c.r)) continue;
                    const float t = s - std::sqrt(std::max(0.0f, c.r * c.r - b2));
                    if (t > 1e-5f * c.r && t <= best_t) best = order_[k], best_t = t;
                }
            } else {
                const float ta = box(nodes_[n.first], org, inv, best_t), tb = box(nodes_[n.first + 1], org, inv, best_t);
                const bool ha = ta >= 0.0f, hb = tb >= 0.0f;
                if (ha && hb) {
                    const bool a_first = ta <= tb;
                    stack[top++] = a_first ? n.first + 1 : n.first;
                    cur = a_first ? n.first : n.first + 1;
                    continue;
                }
                if (ha || hb) {
                    cur = ha ? n.first : n.first + 1;
                    continue;
                }
            }
            // Pop the next node still nearer than the best hit.
            bool next = false;
            while (top > 0) {
                cur = stack[--top];
                if (box(nodes_[cur], org, inv, best_t) >= 0.0f) {
                    next = true;
                    break;
                }
            }
            if (!next) break;
        }
        t_hit = best_t;
        return best;
    }

private:
    static constexpr std::uint32_t kLeaf = 4;
    struct Node {
        float lo[3], hi[3];
        std::uint32_t first = 0;  // leaf: first sphere; inner: first of two children
        std::uint32_t count = 0;  // spheres in a leaf, 0 for an inner node
    };

    // Entry distance of the ray into n's box within [0, t_max], or -1 if missed (slab test).
    static float box(const Node& n, const float* o, const float* inv, float t_max) noexcept {
        float t0 = 0.0f, t1 = t_max;
        for (int a = 0; a < 3; ++a) {
            float tn = (n.lo[a] - o[a]) * inv[a], tf = (n.hi[a] - o[a]) * inv[a];
            if (tn > tf) std::swap(tn, tf);
            t0 = tn > t0 ? tn : t0;
            t1 = tf < t1 ? tf : t1;
        }
        return t0 <= t1 ? t0 : -1.0f;
    }

    // Build the subtree of idx[b, e) into nodes_[slot]; the two children of an inner node are
    // stored next to each other.
    void build(std::vector<std::uint32_t>& idx, std::uint32_t b, std::uint32_t e, std::uint32_t slot) {
        const auto& ps = cloud_->particles();
        Node n;
        float clo[3], chi[3];
        for (int a = 0; a < 3; ++a) {
            n.lo[a] = clo[a] = std::numeric_limits<float>::max();
            n.hi[a] = chi[a] = -std::numeric_limits<float>::max();
        }
        for (std::uint32_t k = b; k < e; ++k) {
            const gl::CloudParticle& c = ps[idx[k]];
            const float x[3] = {c.x, c.y, c.z};
            for (int a = 0; a < 3; ++a) {
                n.lo[a] = std::min(n.lo[a], x[a] - c.r);
                n.hi[a] = std::max(n.hi[a], x[a] + c.r);
                clo[a] = std::min(clo[a], x[a]);
                chi[a] = std::max(chi[a], x[a]);
            }
        }
        if (e - b <= kLeaf) {
            n.first = b;
            n.count = e - b;
            nodes_[slot] = n;
            return;
        }
        int axis = 0;
        for (int a = 1; a < 3; ++a)
            if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
        const std::uint32_t mid = b + (e - b) / 2;
        std::nth_element(idx.begin() + b, idx.begin() + mid, idx.begin() + e, [&](std::uint32_t i, std::uint32_t j) {
            const float xi[3] = {ps[i].x, ps[i].y, ps[i].z}, xj[3] = {ps[j].x, ps[j].y, ps[j].z};
            return xi[axis] < xj[axis];
        });
        n.first = std::uint32_t(nodes_.size());
        n.count = 0;
        nodes_.resize(nodes_.size() + 2);
        nodes_[slot] = n;
        build(idx, b, mid, n.first);
        build(idx, mid, e, n.first + 1);
    }

    std::shared_ptr<const gl::ParticleCloud> cloud_;
    std::vector<Node> nodes_;
    std::vector<gl::CloudParticle> spheres_;
    std::vector<std::uint32_t> order_;
};

}  // namespace guo21_bvh
