/// @file grainlight/geometry/aabb.hpp
/// Axis-aligned bounding boxes and the robust ray-slab test used by the BVH.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <limits>
#include <utility>

#include "grainlight/core/config.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Axis-aligned box [lo, hi]. A default-constructed box is empty (lo = +inf, hi = -inf), so
/// `expand` of an empty box by a point gives that point.
template <std::floating_point F>
struct Aabb {
    /// Lower corner (+inf when empty).
    Vec3<F> lo{std::numeric_limits<F>::infinity()};
    /// Upper corner (-inf when empty).
    Vec3<F> hi{-std::numeric_limits<F>::infinity()};

    /// The empty box.
    Aabb() = default;
    /// The box [lo_, hi_] (not checked).
    Aabb(const Vec3<F>& lo_, const Vec3<F>& hi_) noexcept : lo(lo_), hi(hi_) {}

    /// True if no point was ever added.
    [[nodiscard]] bool empty() const noexcept { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    /// Grow to contain the point p.
    void expand(const Vec3<F>& p) noexcept {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    /// Grow to contain the box b.
    void expand(const Aabb& b) noexcept {
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    /// hi - lo (0 for an empty box).
    [[nodiscard]] Vec3<F> extent() const noexcept { return empty() ? Vec3<F>(F(0)) : hi - lo; }
    /// Centre (lo + hi) / 2.
    [[nodiscard]] Vec3<F> center() const noexcept { return (lo + hi) * F(0.5); }
    /// Surface area (0 for an empty box); the SAH cost metric.
    [[nodiscard]] F surface_area() const noexcept {
        const Vec3<F> e = extent();
        return F(2) * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
    /// Axis of largest extent (0, 1, 2).
    [[nodiscard]] int largest_axis() const noexcept {
        const Vec3<F> e = extent();
        return (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    }
    /// True if p lies in the closed box.
    [[nodiscard]] bool contains(const Vec3<F>& p) const noexcept {
        return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
    }
};

/// Clip the parameter interval [t0, t1] of o + t d to the closed box [lo, hi] (slab test by
/// division; an axis-parallel ray must start inside the slab of that axis). Returns false if the
/// segment misses the box; otherwise narrows t0 and t1 (a ray touching the box gives t0 == t1 and
/// true). The one ray-box clip of the library; hot loops that keep the reciprocal direction use
/// intersect_aabb below.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline bool clip_ray_to_box(const Vec3<F>& o, const Vec3<F>& d, const Vec3<F>& lo,
                                                                 const Vec3<F>& hi, F& t0, F& t1) noexcept {
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0) {
            if (o[a] < lo[a] || o[a] > hi[a]) return false;
            continue;
        }
        F ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
        if (t0 > t1) return false;
    }
    return true;
}

/// Slab test against a box for a ray with precomputed reciprocal direction `inv_d` (components
/// may be +-inf for axis-parallel rays). Returns true if [t0, t1] overlaps the box's parametric
/// range; `t_enter` receives the entry distance. The far bound is enlarged by 2 gamma(3) (Ize
/// 2013, "Robust BVH Ray Traversal") so round-off cannot make a ray slip between two boxes.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline bool intersect_aabb(const Aabb<F>& b, const Vec3<F>& o, const Vec3<F>& inv_d,
                                                                F t0, F t1, F* t_enter = nullptr) noexcept {
    constexpr F eps = std::numeric_limits<F>::epsilon();
    constexpr F robust = F(1) + F(6) * eps / (F(1) - F(3) * eps);
    for (int a = 0; a < 3; ++a) {
        F tn = (b.lo[a] - o[a]) * inv_d[a];
        F tf = (b.hi[a] - o[a]) * inv_d[a];
        if (tn > tf) std::swap(tn, tf);
        tf *= robust;
        // NaN (0 * inf for an origin on the slab plane) leaves t0/t1 unchanged: max/min written so.
        t0 = tn > t0 ? tn : t0;
        t1 = tf < t1 ? tf : t1;
        if (t0 > t1) return false;
    }
    if (t_enter) *t_enter = t0;
    return true;
}

}  // namespace grainlight
