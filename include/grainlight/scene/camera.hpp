/// @file grainlight/scene/camera.hpp
/// Pinhole perspective camera generating rays with a footprint (ray cone).
///
/// Conventions: world space is right-handed; the camera looks from `eye` toward `target`, `up`
/// fixes the roll. Pixel (x, y): x to the right, y *down* (row 0 is the top of the image, as
/// in scene/film.hpp). `fov_y_deg` is the full vertical field of view in degrees. Each camera
/// ray starts at the eye with cone width 0 and spread angle = the angle one pixel subtends at
/// the image centre (2 tan(fov/2) / height), Amanatides 1984 / Akenine-Moller et al. 2021 ray
/// cones, so the footprint at distance t is about t * spread.
#pragma once

#include <cmath>
#include <limits>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// Pinhole (perspective) camera: primary rays from `eye` through a film of width x height pixels
/// with vertical field of view fov_y, each ray carrying a cone of the pixel's spread angle.
/// Immutable after construction; generate_ray and project are thread-safe.
template <std::floating_point F = float>
class PinholeCamera {
public:
    /// Floating-point type of rays.
    using Float = F;

    /// Throws grainlight::invalid_argument on width/height < 1, fov outside (0, 180) degrees,
    /// eye == target, or `up` parallel to the viewing direction.
    PinholeCamera(const Vec3<F>& eye, const Vec3<F>& target, const Vec3<F>& up, F fov_y_deg, int width, int height)
        : eye_(eye), width_(width), height_(height) {
        check_argument(width >= 1, "PinholeCamera", "width", width, ">= 1");
        check_argument(height >= 1, "PinholeCamera", "height", height, ">= 1");
        check_argument(fov_y_deg > F(0) && fov_y_deg < F(180), "PinholeCamera", "fov_y_deg", fov_y_deg, "(0, 180)");
        const Vec3<F> fwd = target - eye;
        const F len = glm::length(fwd);
        check_argument(len > F(0) && std::isfinite(len), "PinholeCamera", "|target - eye|", len, "> 0 and finite");
        forward_ = fwd / len;
        const Vec3<F> r = glm::cross(forward_, up);
        const F rl = glm::length(r);
        check_argument(rl > F(1e-6), "PinholeCamera", "|cross(forward, up)|", rl, "> 1e-6 (up not parallel to view)");
        right_ = r / rl;
        up_ = glm::cross(right_, forward_);
        tan_half_ = std::tan(F(0.5) * fov_y_deg * pi_v<F> / F(180));
        aspect_ = F(width) / F(height);
        spread_ = F(2) * tan_half_ / F(height);
    }

    /// Film width in pixels.
    [[nodiscard]] int width() const noexcept { return width_; }
    /// Film height in pixels.
    [[nodiscard]] int height() const noexcept { return height_; }
    /// Camera position (origin of every primary ray).
    [[nodiscard]] const Vec3<F>& eye() const noexcept { return eye_; }
    /// Unit viewing direction.
    [[nodiscard]] const Vec3<F>& forward() const noexcept { return forward_; }
    /// Pixel spread angle (radians) of the ray cones.
    [[nodiscard]] F spread_angle() const noexcept { return spread_; }

    /// Primary ray through film position (px, py) in pixel units (continuous: pixel (x, y) covers
    /// [x, x+1) x [y, y+1)); a renderer passes (x + u.x, y + u.y). Unit direction.
    [[nodiscard]] Ray<F> generate_ray(F px, F py) const noexcept {
        const F sx = (F(2) * px / F(width_) - F(1)) * tan_half_ * aspect_;
        const F sy = (F(1) - F(2) * py / F(height_)) * tan_half_;
        const Vec3<F> d = glm::normalize(forward_ + sx * right_ + sy * up_);
        return Ray<F>(eye_, d, std::numeric_limits<F>::infinity(), RayCone<F>{F(0), spread_});
    }

    /// Continuous film position (px, py) of world point p, or false if p is behind the camera or
    /// outside the image (used by light tracing and tests).
    [[nodiscard]] bool project(const Vec3<F>& p, F& px, F& py) const noexcept {
        const Vec3<F> v = p - eye_;
        const F z = glm::dot(v, forward_);
        if (z <= F(0)) return false;
        const F sx = glm::dot(v, right_) / (z * tan_half_ * aspect_);
        const F sy = glm::dot(v, up_) / (z * tan_half_);
        px = (sx + F(1)) * F(0.5) * F(width_);
        py = (F(1) - sy) * F(0.5) * F(height_);
        return px >= F(0) && px < F(width_) && py >= F(0) && py < F(height_);
    }

    /// Human-readable description (resolution and tan(fov/2)).
    [[nodiscard]] std::string to_string() const {
        return "PinholeCamera[" + std::to_string(width_) + "x" + std::to_string(height_) +
               ", tan(fov/2) = " + std::to_string(tan_half_) + "]";
    }

private:
    Vec3<F> eye_{F(0)}, forward_{F(0), F(0), F(-1)}, right_{F(1), F(0), F(0)}, up_{F(0), F(1), F(0)};
    int width_ = 1, height_ = 1;
    F tan_half_ = F(1), aspect_ = F(1), spread_ = F(0);
};

}  // namespace grainlight
