/// @file grainlight/geometry/sphere.hpp
/// Ray-sphere intersection, robust for rays far from the sphere and near-tangent rays.
#pragma once

#include <cmath>
#include <concepts>

#include "grainlight/core/config.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Both roots of |o + t d - c| = r along a ray (d need not be unit length; t is in units of d).
/// `hit` is false if the line misses the sphere (t_near/t_far then undefined). t_near <= t_far;
/// either may be negative (origin inside: t_near < 0 < t_far; sphere behind: both < 0).
template <std::floating_point F>
struct SphereRoots {
    /// True if the line meets the sphere.
    bool hit = false;
    /// Smaller root.
    F t_near = F(0);
    /// Larger root.
    F t_far = F(0);
    /// Same as `hit`.
    explicit operator bool() const noexcept { return hit; }
};

/// Line-sphere roots with the numerically stable formulation of Haines et al. 2019 ("Precision
/// improvements for ray/sphere intersection", Ray Tracing Gems ch. 7): the discriminant is
/// computed from the perpendicular distance of the centre to the line, not from b^2 - 4ac, and
/// the second root from Vieta's formula (no cancellation).
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline SphereRoots<F> intersect_sphere(const Vec3<F>& o, const Vec3<F>& d,
                                                                           const Vec3<F>& center, F radius) noexcept {
    SphereRoots<F> r;
    const Vec3<F> f = o - center;
    const F a = glm::dot(d, d);
    const F b = -glm::dot(f, d);  // half of -b of the textbook quadratic
    const Vec3<F> perp = f + (b / a) * d;
    const F disc = a * (radius * radius - glm::dot(perp, perp));
    if (!(disc >= F(0))) return r;
    const F c = glm::dot(f, f) - radius * radius;
    const F q = b + std::copysign(std::sqrt(disc), b);
    F t0 = c / q, t1 = q / a;
    if (q == F(0)) t0 = t1 = F(0);  // origin at the centre of a zero-size sphere
    if (t0 > t1) std::swap(t0, t1);
    r.hit = true;
    r.t_near = t0;
    r.t_far = t1;
    return r;
}

/// First intersection of a ray with a sphere at distance in (t_min, t_max): the near root if it is
/// in range, otherwise the far root (origin inside). Returns false if neither is.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline bool intersect_sphere_first(const Vec3<F>& o, const Vec3<F>& d,
                                                                        const Vec3<F>& center, F radius, F t_min,
                                                                        F t_max, F& t_hit) noexcept {
    const SphereRoots<F> r = intersect_sphere(o, d, center, radius);
    if (!r) return false;
    if (r.t_near > t_min && r.t_near < t_max) {
        t_hit = r.t_near;
        return true;
    }
    if (r.t_far > t_min && r.t_far < t_max) {
        t_hit = r.t_far;
        return true;
    }
    return false;
}

/// Outward unit normal of the sphere at a point p on (or near) it.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline Vec3<F> sphere_normal(const Vec3<F>& p, const Vec3<F>& center) noexcept {
    return glm::normalize(p - center);
}

/// Length of the chord a line at perpendicular distance `b` from the centre cuts through a sphere
/// of radius r: 2 sqrt(r^2 - b^2) (0 if b >= r).
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline F sphere_chord(F b, F r) noexcept {
    return F(2) * safe_sqrt(r * r - b * b);
}

}  // namespace grainlight
