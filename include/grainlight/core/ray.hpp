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
    F width = F(0);
    F spread = F(0);
    [[nodiscard]] F width_at(F t) const noexcept { return width + t * spread; }
    /// The cone after travelling distance t (new origin there).
    [[nodiscard]] RayCone advanced(F t) const noexcept { return {width_at(t), spread}; }
};

/// A ray o + t d, t in [0, t_max]. `d` is expected to be unit length.
template <std::floating_point F>
struct Ray {
    Vec3<F> o{F(0)};
    Vec3<F> d{F(0), F(0), F(1)};
    F t_max = std::numeric_limits<F>::infinity();
    RayCone<F> cone{};

    Ray() = default;
    Ray(const Vec3<F>& o_, const Vec3<F>& d_, F t_max_ = std::numeric_limits<F>::infinity(),
        RayCone<F> cone_ = {}) noexcept
        : o(o_), d(d_), t_max(t_max_), cone(cone_) {}

    [[nodiscard]] Vec3<F> operator()(F t) const noexcept { return o + t * d; }
};

using Rayf = Ray<float>;
using Rayd = Ray<double>;

/// Offset a point along the normal to avoid self-intersection (scale-aware epsilon).
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> offset_ray_origin(const Vec3<F>& p, const Vec3<F>& n, const Vec3<F>& w) noexcept {
    const F scale = F(1) + glm::max(glm::max(glm::abs(p.x), glm::abs(p.y)), glm::abs(p.z));
    const F eps = (sizeof(F) == 4 ? F(2e-4) : F(1e-9)) * scale;
    return p + (glm::dot(n, w) >= F(0) ? eps : -eps) * n;
}

}  // namespace grainlight
