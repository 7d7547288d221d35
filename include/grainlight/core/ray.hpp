/// @file grainlight/core/ray.hpp
/// Rays with an optional footprint (a ray cone), as Guo21's query cylinder (Eq. 23) and
/// level-of-detail decisions need.
#pragma once

#include <limits>

#include "grainlight/core/vector.hpp"

namespace grainlight {

/// A ray cone: footprint width at the origin and its spread angle (radians, full-angle rate:
/// width(t) = width + t * spread).
template <std::floating_point F>
struct RayCone {
    /// Footprint width at the ray origin (scene length units).
    F width = F(0);
    /// Width growth per unit distance along the ray (>= 0; 0 for a pinhole ray of zero width).
    F spread = F(0);
    /// Footprint width after distance t: width + t * spread.
    [[nodiscard]] F width_at(F t) const noexcept { return width + t * spread; }
    /// The cone after travelling distance t (new origin there).
    [[nodiscard]] RayCone advanced(F t) const noexcept { return {width_at(t), spread}; }
};

/// A ray o + t d, t in [0, t_max]. `d` is expected to be unit length.
template <std::floating_point F>
struct Ray {
    /// Origin.
    Vec3<F> o{F(0)};
    /// Direction (expected unit length; t is then a distance).
    Vec3<F> d{F(0), F(0), F(1)};
    /// Largest valid parameter; intersection routines ignore hits beyond it.
    F t_max = std::numeric_limits<F>::infinity();
    /// Footprint cone for level-of-detail decisions (zero width by default).
    RayCone<F> cone{};

    /// Ray from the origin along +z, unbounded.
    Ray() = default;
    /// Ray from `o_` along `d_` (unit length expected), valid for t in [0, `t_max_`], with footprint `cone_`.
    Ray(const Vec3<F>& o_, const Vec3<F>& d_, F t_max_ = std::numeric_limits<F>::infinity(),
        RayCone<F> cone_ = {}) noexcept
        : o(o_), d(d_), t_max(t_max_), cone(cone_) {}

    /// Point at parameter t: o + t d.
    [[nodiscard]] Vec3<F> operator()(F t) const noexcept { return o + t * d; }
};

/// Single-precision ray.
using Rayf = Ray<float>;
/// Double-precision ray.
using Rayd = Ray<double>;

/// Offset a point along the normal to avoid self-intersection (scale-aware epsilon).
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> offset_ray_origin(const Vec3<F>& p, const Vec3<F>& n, const Vec3<F>& w) noexcept {
    const F scale = F(1) + glm::max(glm::max(glm::abs(p.x), glm::abs(p.y)), glm::abs(p.z));
    const F eps = (sizeof(F) == 4 ? F(2e-4) : F(1e-9)) * scale;
    return p + (glm::dot(n, w) >= F(0) ? eps : -eps) * n;
}

}  // namespace grainlight
