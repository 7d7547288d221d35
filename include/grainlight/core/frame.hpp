/// @file grainlight/core/frame.hpp
/// Orthonormal frame around a unit vector (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited"): branchless and continuous except on the -z half-plane seam.
#pragma once

#include <cmath>

#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Orthonormal frame (s, t, n) built from a normal with Duff et al. 2017's branchless construction;
/// converts directions between world space and the local space where n is +z.
template <std::floating_point F>
struct Frame {
    /// @var s
    /// First tangent (local +x).
    /// @var t
    /// Second tangent (local +y).
    /// @var n
    /// Normal (local +z).
    Vec3<F> s, t, n;

    /// Frame whose local +z is the unit vector `normal`.
    explicit Frame(const Vec3<F>& normal) noexcept : n(normal) {
        const F sign = std::copysign(F(1), normal.z);
        const F a = F(-1) / (sign + normal.z);
        const F b = normal.x * normal.y * a;
        s = Vec3<F>(F(1) + sign * normal.x * normal.x * a, sign * b, -sign * normal.x);
        t = Vec3<F>(b, sign + normal.y * normal.y * a, -normal.y);
    }
    /// World direction v in local coordinates (components along s, t, n).
    [[nodiscard]] Vec3<F> to_local(const Vec3<F>& v) const noexcept {
        return Vec3<F>(glm::dot(v, s), glm::dot(v, t), glm::dot(v, n));
    }
    /// Local direction v (x along s, y along t, z along n) back to world space.
    [[nodiscard]] Vec3<F> to_world(const Vec3<F>& v) const noexcept { return s * v.x + t * v.y + n * v.z; }
};

}  // namespace grainlight
