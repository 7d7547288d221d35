/// @file grainlight/core/vector.hpp
/// Small-vector aliases over GLM. grainlight never defines GLM_FORCE_* macros (they would clash
/// with the user's GLM settings); a default-constructed GLM vector is uninitialized, so always
/// initialize explicitly.
#pragma once

#include <concepts>
#include <glm/glm.hpp>

namespace grainlight {

template <std::floating_point F>
using Vec2 = glm::vec<2, F, glm::defaultp>;
template <std::floating_point F>
using Vec3 = glm::vec<3, F, glm::defaultp>;
template <std::floating_point F>
using Vec4 = glm::vec<4, F, glm::defaultp>;
using Vec2f = Vec2<float>;
using Vec3f = Vec3<float>;
using Vec2d = Vec2<double>;
using Vec3d = Vec3<double>;
using Vec3i = glm::vec<3, int, glm::defaultp>;
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
