/// @file grainlight/core/warp.hpp
/// Warps from the unit square to directions and disks, each with its pdf (pbrt's sample_x /
/// x_pdf naming). Solid-angle pdfs for directions, area pdfs for disks.
#pragma once

#include <algorithm>
#include <cmath>

#include "grainlight/core/math.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Uniform direction on the unit sphere; pdf = 1/(4 pi).
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> sample_uniform_sphere(Vec2<F> u) noexcept {
    const F z = F(1) - F(2) * u.x;
    const F r = safe_sqrt(F(1) - z * z);
    const F phi = F(2) * pi_v<F> * u.y;
    return Vec3<F>(r * std::cos(phi), r * std::sin(phi), z);
}
/// Solid-angle pdf of sample_uniform_sphere: 1/(4 pi).
template <std::floating_point F>
[[nodiscard]] constexpr F uniform_sphere_pdf() noexcept {
    return inv_four_pi_v<F>;
}

/// Uniform direction on the +z hemisphere; pdf = 1/(2 pi).
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> sample_uniform_hemisphere(Vec2<F> u) noexcept {
    const F z = u.x;
    const F r = safe_sqrt(F(1) - z * z);
    const F phi = F(2) * pi_v<F> * u.y;
    return Vec3<F>(r * std::cos(phi), r * std::sin(phi), z);
}
/// Solid-angle pdf of sample_uniform_hemisphere: 1/(2 pi).
template <std::floating_point F>
[[nodiscard]] constexpr F uniform_hemisphere_pdf() noexcept {
    return inv_two_pi_v<F>;
}

/// Uniform point on the unit disk, concentric mapping (Shirley & Chiu 1997): area pdf 1/pi.
template <std::floating_point F>
[[nodiscard]] inline Vec2<F> sample_uniform_disk_concentric(Vec2<F> u) noexcept {
    const Vec2<F> o(F(2) * u.x - F(1), F(2) * u.y - F(1));
    if (o.x == F(0) && o.y == F(0)) return Vec2<F>(F(0), F(0));
    F r, theta;
    if (std::abs(o.x) > std::abs(o.y)) {
        r = o.x;
        theta = (pi_v<F> / F(4)) * (o.y / o.x);
    } else {
        r = o.y;
        theta = pi_v<F> / F(2) - (pi_v<F> / F(4)) * (o.x / o.y);
    }
    return Vec2<F>(r * std::cos(theta), r * std::sin(theta));
}
/// Inverse of sample_uniform_disk_concentric (Shirley & Chiu 1997): a point of the closed unit
/// disk to [0,1]^2. Round trip exact up to rounding.
template <std::floating_point F>
[[nodiscard]] inline Vec2<F> inverse_disk_concentric(Vec2<F> p) noexcept {
    const F r = std::sqrt(p.x * p.x + p.y * p.y);
    if (!(r > F(0))) return Vec2<F>(F(0.5), F(0.5));
    constexpr F q = pi_v<F> / F(4);
    F phi = std::atan2(p.y, p.x);  // (-pi, pi]
    if (phi < -q) phi += F(2) * pi_v<F>;  // [-pi/4, 7pi/4)
    F ox, oy;
    if (phi < q) {
        ox = r;
        oy = ox * phi / q;
    } else if (phi < F(3) * q) {
        oy = r;
        ox = oy * (F(2) * q - phi) / q;
    } else if (phi < F(5) * q) {
        ox = -r;
        oy = ox * (phi - pi_v<F>) / q;
    } else {
        oy = -r;
        ox = oy * (F(2) * q - (phi - pi_v<F>)) / q;
    }
    return Vec2<F>(std::clamp((ox + F(1)) / F(2), F(0), F(1)), std::clamp((oy + F(1)) / F(2), F(0), F(1)));
}

/// Uniform point on the unit disk, polar mapping: area pdf 1/pi.
template <std::floating_point F>
[[nodiscard]] inline Vec2<F> sample_uniform_disk_polar(Vec2<F> u) noexcept {
    const F r = std::sqrt(u.x);
    const F theta = F(2) * pi_v<F> * u.y;
    return Vec2<F>(r * std::cos(theta), r * std::sin(theta));
}
/// Area pdf of the uniform disk samplers: 1/pi.
template <std::floating_point F>
[[nodiscard]] constexpr F uniform_disk_pdf() noexcept {
    return inv_pi_v<F>;
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method); pdf = cos(theta)/pi.
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> sample_cosine_hemisphere(Vec2<F> u) noexcept {
    const Vec2<F> d = sample_uniform_disk_concentric(u);
    const F z = safe_sqrt(F(1) - d.x * d.x - d.y * d.y);
    return Vec3<F>(d.x, d.y, z);
}
/// Solid-angle pdf of sample_cosine_hemisphere: max(cos_theta, 0)/pi.
template <std::floating_point F>
[[nodiscard]] inline F cosine_hemisphere_pdf(F cos_theta) noexcept {
    return std::max(cos_theta, F(0)) * inv_pi_v<F>;
}

/// Uniform direction in the cone of half-angle acos(cos_theta_max) around +z; pdf = 1/(2 pi (1 - cos_max)).
template <std::floating_point F>
[[nodiscard]] inline Vec3<F> sample_uniform_cone(Vec2<F> u, F cos_theta_max) noexcept {
    const F cos_theta = (F(1) - u.x) + u.x * cos_theta_max;
    const F sin_theta = safe_sqrt(F(1) - cos_theta * cos_theta);
    const F phi = F(2) * pi_v<F> * u.y;
    return Vec3<F>(std::cos(phi) * sin_theta, std::sin(phi) * sin_theta, cos_theta);
}
/// Solid-angle pdf of sample_uniform_cone: 1/(2 pi (1 - cos_theta_max)).
template <std::floating_point F>
[[nodiscard]] inline F uniform_cone_pdf(F cos_theta_max) noexcept {
    return F(1) / (F(2) * pi_v<F> * (F(1) - cos_theta_max));
}

/// Exponential distance with rate `a`: t = -ln(1 - u)/a; pdf a exp(-a t).
template <std::floating_point F>
[[nodiscard]] inline F sample_exponential(F u, F a) noexcept {
    return -std::log1p(-u) / a;
}
/// Pdf of sample_exponential at distance t >= 0 with rate a > 0: a exp(-a t).
template <std::floating_point F>
[[nodiscard]] inline F exponential_pdf(F t, F a) noexcept {
    return a * std::exp(-a * t);
}

/// Uniform barycentrics on a triangle (Heitz 2019 low-distortion map would be nicer; this is
/// the classic square-root warp): returns (b0, b1), b2 = 1 - b0 - b1.
template <std::floating_point F>
[[nodiscard]] inline Vec2<F> sample_uniform_triangle(Vec2<F> u) noexcept {
    const F su0 = std::sqrt(u.x);
    return Vec2<F>(F(1) - su0, u.y * su0);
}

/// Multiple importance sampling: power heuristic weight (beta = 2) of a strategy with pdf a against
/// one with pdf b (Veach 1997); 0 when both pdfs are 0.
template <std::floating_point F>
[[nodiscard]] inline F power_heuristic(F a, F b) noexcept {
    const F a2 = a * a, b2 = b * b;
    return a2 + b2 > F(0) ? a2 / (a2 + b2) : F(0);
}

}  // namespace grainlight
