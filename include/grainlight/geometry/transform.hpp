/// @file grainlight/geometry/transform.hpp
/// Rigid transforms for instanced grains: a rotation (orthonormal 3x3 matrix), a uniform scale
/// and a translation, applied as x_world = translation + scale * R x_local. The rotation of a
/// randomly oriented grain is drawn uniformly from SO(3) from three uniform numbers.
#pragma once

#include <cmath>
#include <concepts>

#include "grainlight/core/math.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Rotation as three orthonormal rows r0, r1, r2: to_local(v) = (r0.v, r1.v, r2.v) and
/// to_world(v) = v.x r0 + v.y r1 + v.z r2 (the transpose).
template <std::floating_point F>
struct Rotation {
    /// Row 0 (the local x axis in world coordinates).
    Vec3<F> r0{F(1), F(0), F(0)};
    /// Row 1 (local y).
    Vec3<F> r1{F(0), F(1), F(0)};
    /// Row 2 (local z).
    Vec3<F> r2{F(0), F(0), F(1)};

    /// World -> local: R^T v.
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE Vec3<F> to_local(const Vec3<F>& v) const noexcept {
        return Vec3<F>(glm::dot(r0, v), glm::dot(r1, v), glm::dot(r2, v));
    }
    /// Local -> world: R v.
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE Vec3<F> to_world(const Vec3<F>& v) const noexcept {
        return v.x * r0 + v.y * r1 + v.z * r2;
    }
};

/// The rotation of the unit quaternion q = (w, x, y, z): to_world(v) = q v q* and
/// to_local(v) = q* v q (the rows are the columns of q's rotation matrix). The caller keeps q
/// unit; nothing is normalized here.
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline Rotation<F> rotation_from_quaternion(F w, F x, F y, F z) noexcept {
    Rotation<F> r;
    r.r0 = Vec3<F>(F(1) - F(2) * (y * y + z * z), F(2) * (x * y + w * z), F(2) * (x * z - w * y));
    r.r1 = Vec3<F>(F(2) * (x * y - w * z), F(1) - F(2) * (x * x + z * z), F(2) * (y * z + w * x));
    r.r2 = Vec3<F>(F(2) * (x * z + w * y), F(2) * (y * z - w * x), F(1) - F(2) * (x * x + y * y));
    return r;
}

/// Shoemake's uniform rotation (1992, "Uniform random rotations", Graphics Gems III) from
/// u1 in [0, 1] and the sines and cosines of the two angles a = 2 pi u2, b = 2 pi u3, for callers
/// that compute them their own way (`sincos_2pi`). With Shoemake's unit quaternion
/// q = (w, x, y, z) = (sqrt(u1) cos b, sqrt(1 - u1) sin a, sqrt(1 - u1) cos a, sqrt(u1) sin b)
/// the result maps world to local by q: to_local(v) = q v q*. (q and its conjugate are equally
/// uniform; this orientation is the one every grain and render so far was drawn with.)
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline Rotation<F> shoemake_rotation(F u1, F sin_a, F cos_a, F sin_b,
                                                                          F cos_b) noexcept {
    const F s1 = safe_sqrt(F(1) - u1), s2 = safe_sqrt(u1);
    return rotation_from_quaternion(s2 * cos_b, -(s1 * sin_a), -(s1 * cos_a), -(s2 * sin_b));  // q*
}

/// Uniformly distributed rotation (Haar measure on SO(3)) from u in [0,1)^3, via a uniform unit
/// quaternion (Shoemake 1992, "Uniform random rotations", Graphics Gems III).
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline Rotation<F> uniform_random_rotation(const Vec3<F>& u) noexcept {
    const F a = F(2) * pi_v<F> * u.y, b = F(2) * pi_v<F> * u.z;
    return shoemake_rotation(u.x, std::sin(a), std::cos(a), std::sin(b), std::cos(b));
}

/// Similarity transform x_world = translation + scale * R.to_world(x_local) (scale > 0).
template <std::floating_point F>
struct Transform {
    /// Orientation of the instance.
    Rotation<F> rotation{};
    /// Uniform scale (> 0).
    F scale = F(1);
    /// Position of the local origin in world coordinates.
    Vec3<F> translation{F(0)};

    /// Local point -> world point.
    [[nodiscard]] Vec3<F> point_to_world(const Vec3<F>& p) const noexcept {
        return translation + scale * rotation.to_world(p);
    }
    /// World point -> local point.
    [[nodiscard]] Vec3<F> point_to_local(const Vec3<F>& p) const noexcept {
        return rotation.to_local(p - translation) / scale;
    }
    /// Directions (and normals: a similarity keeps them perpendicular) are only rotated.
    [[nodiscard]] Vec3<F> vector_to_world(const Vec3<F>& v) const noexcept { return rotation.to_world(v); }
    /// World direction -> local direction.
    [[nodiscard]] Vec3<F> vector_to_local(const Vec3<F>& v) const noexcept { return rotation.to_local(v); }
};

}  // namespace grainlight
