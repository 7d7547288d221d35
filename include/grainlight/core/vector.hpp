/// @file grainlight/core/vector.hpp
/// Small-vector aliases over GLM. grainlight never defines GLM_FORCE_* macros (they would clash
/// with the user's GLM settings); a default-constructed GLM vector is uninitialized, so always
/// initialize explicitly.
#pragma once

#include <concepts>
#include <glm/glm.hpp>

namespace grainlight {

/// 2-vector of F (glm, so glm::dot, glm::length etc. apply).
template <std::floating_point F>
using Vec2 = glm::vec<2, F, glm::defaultp>;
/// 3-vector of F: points, directions and normals.
template <std::floating_point F>
using Vec3 = glm::vec<3, F, glm::defaultp>;
/// 4-vector of F.
template <std::floating_point F>
using Vec4 = glm::vec<4, F, glm::defaultp>;
/// Single-precision 2-vector (sample pairs in [0,1)^2).
using Vec2f = Vec2<float>;
/// Single-precision 3-vector.
using Vec3f = Vec3<float>;
/// Double-precision 2-vector.
using Vec2d = Vec2<double>;
/// Double-precision 3-vector.
using Vec3d = Vec3<double>;
/// Integer 3-vector (grid cell indices).
using Vec3i = glm::vec<3, int, glm::defaultp>;
/// 64-bit integer 3-vector (cell indices of large or periodic grids).
using Vec3i64 = glm::vec<3, long long, glm::defaultp>;

/// Component of largest absolute value.
template <std::floating_point F>
[[nodiscard]] inline F max_abs_component(const Vec3<F>& v) noexcept {
    return glm::max(glm::max(glm::abs(v.x), glm::abs(v.y)), glm::abs(v.z));
}

/// Reflect `wi` (pointing away from the surface) about the normal n.
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> reflect_about(const Vec3<F>& wi, const Vec3<F>& n) noexcept {
    return F(2) * glm::dot(wi, n) * n - wi;
}

/// Spherical direction from (cos theta, phi) in the frame's local coordinates (z up).
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> spherical_direction(F cos_theta, F phi) noexcept {
    const F sin_theta = std::sqrt(std::max(F(0), F(1) - cos_theta * cos_theta));
    return Vec3<F>(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta);
}

}  // namespace grainlight
