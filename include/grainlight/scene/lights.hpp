/// @file grainlight/scene/lights.hpp
/// Lights of the small scene layer, one closed set in one record (no virtual calls): point, spot,
/// quad area, directional and constant environment.
///
/// Units and conventions
///  - point / spot: `intensity` I (W sr^-1 per channel); irradiance at distance r on a surface
///    facing the light is I / r^2. Spot: full intensity inside cos_inner, smooth-step falloff to
///    0 at cos_outer (cosines about `direction`, the axis the spot points along).
///  - quad area light: `radiance` L (W sr^-1 m^-2) emitted from the quad's front side (the side
///    its normal cross(edge_u, edge_v) points into); the quad is a shape of the scene.
///  - directional: `irradiance` E (W m^-2) on a surface facing it, light travelling along
///    `direction`.
///  - environment: constant `radiance` L arriving from every direction at infinity.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/scene/concepts.hpp"
#include "grainlight/scene/shapes.hpp"

namespace grainlight {

/// @enum LightType
/// Kind of a Light.
/// @var LightType::point
/// Isotropic point light of intensity I.
/// @var LightType::spot
/// Point light restricted to a cone around an axis.
/// @var LightType::quad
/// One-sided parallelogram area light of radiance L (a scene shape).
/// @var LightType::directional
/// Light from infinitely far along one direction, irradiance E.
/// @var LightType::environment
/// Constant radiance L from every direction at infinity.
enum class LightType : std::uint8_t { point, spot, quad, directional, environment };

/// A photon leaving a light (walks that start from a light: photon tracing, light tracing).
/// `weight` is the power the photon carries (W per channel): Le cos / (pdf_pos pdf_dir), so the
/// mean weight over photons is the light's total emitted power.
template <std::floating_point F, class S>
struct EmissionSample {
    /// Photon origin and unit direction.
    Ray<F> ray;
    /// Power carried by the photon per channel [W].
    S weight{F(0)};
    /// False if no photon was produced (directional and environment lights; a quad direction below its surface).
    bool valid = false;
    /// True if the sample is valid.
    [[nodiscard]] explicit operator bool() const noexcept { return valid; }
};

/// One light. Build with the factory functions (they validate).
template <std::floating_point F, class S>
struct Light {
    /// Which kind of light this is.
    LightType type = LightType::point;
    /// Position (point, spot; a quad light's corner).
    Vec3<F> position{F(0)};
    Vec3<F> direction{F(0), F(0), F(-1)};  ///< spot axis / directional travel direction (unit)
    S power{F(0)};                          ///< I (point, spot), L (quad, environment) or E (directional)
    /// @var cos_inner
    /// Cosine of the spot's inner half-angle (full intensity inside it).
    /// @var cos_outer
    /// Cosine of the spot's outer half-angle (no light outside it).
    F cos_inner = F(1), cos_outer = F(0);
    /// The emitting parallelogram of a quad light.
    QuadShape<F> quad{};
    int shape = -1;  ///< scene shape index of a quad light

    /// Isotropic point light at p with intensity I per channel (>= 0; throws grainlight::invalid_argument otherwise).
    [[nodiscard]] static Light point_light(const Vec3<F>& p, const S& intensity) {
        check_nonnegative(intensity, "point_light", "intensity");
        Light l;
        l.type = LightType::point;
        l.position = p;
        l.power = intensity;
        return l;
    }
    /// Spot light at p pointing along `axis`; inner/outer half-angles in degrees (0 < inner <=
    /// outer < 90).
    [[nodiscard]] static Light spot_light(const Vec3<F>& p, const Vec3<F>& axis, const S& intensity, F inner_deg,
                                          F outer_deg) {
        check_nonnegative(intensity, "spot_light", "intensity");
        check_argument(outer_deg > F(0) && outer_deg < F(90), "spot_light", "outer_deg", outer_deg, "(0, 90)");
        check_argument(inner_deg > F(0) && inner_deg <= outer_deg, "spot_light", "inner_deg", inner_deg,
                       "(0, outer_deg]");
        const F len = glm::length(axis);
        check_argument(std::isfinite(len) && len > F(0), "spot_light", "|axis|", len, "(0, inf)");
        Light l;
        l.type = LightType::spot;
        l.position = p;
        l.direction = axis / len;
        l.power = intensity;
        l.cos_inner = std::cos(inner_deg * pi_v<F> / F(180));
        l.cos_outer = std::cos(outer_deg * pi_v<F> / F(180));
        return l;
    }
    /// One-sided area light over q, emitting radiance L per channel (>= 0) into the side of q's normal.
    [[nodiscard]] static Light quad_light(const QuadShape<F>& q, const S& radiance) {
        check_nonnegative(radiance, "quad_light", "radiance");
        Light l;
        l.type = LightType::quad;
        l.quad = q;
        l.position = q.corner;
        l.direction = q.normal;
        l.power = radiance;
        return l;
    }
    /// Light travelling along `dir` with irradiance E on a surface facing it.
    [[nodiscard]] static Light directional_light(const Vec3<F>& dir, const S& irradiance) {
        check_nonnegative(irradiance, "directional_light", "irradiance");
        const F len = glm::length(dir);
        check_argument(std::isfinite(len) && len > F(0), "directional_light", "|direction|", len, "(0, inf)");
        Light l;
        l.type = LightType::directional;
        l.direction = dir / len;
        l.power = irradiance;
        return l;
    }
    /// Constant radiance L per channel (>= 0) arriving from every direction.
    [[nodiscard]] static Light environment_light(const S& radiance) {
        check_nonnegative(radiance, "environment_light", "radiance");
        Light l;
        l.type = LightType::environment;
        l.power = radiance;
        return l;
    }

    /// True for point, spot and directional lights (cannot be hit by a ray; NEE only).
    [[nodiscard]] bool is_delta() const noexcept {
        return type == LightType::point || type == LightType::spot || type == LightType::directional;
    }

    /// Sample the light from `ref` (u in [0,1)^2); pdf without the light-selection probability.
    [[nodiscard]] LightSample<F, S> sample(const Vec3<F>& ref, Vec2<F> u) const noexcept {
        LightSample<F, S> ls;
        switch (type) {
            case LightType::point:
            case LightType::spot: {
                const Vec3<F> v = position - ref;
                const F d2 = glm::dot(v, v);
                if (!(d2 > F(0))) return ls;
                ls.dist = std::sqrt(d2);
                ls.w = v / ls.dist;
                ls.L = power / d2;
                if (type == LightType::spot) ls.L *= spot_falloff(glm::dot(-ls.w, direction));
                ls.pdf = F(1);
                ls.delta = true;
                return ls;
            }
            case LightType::directional: {
                ls.w = -direction;
                ls.L = power;
                ls.pdf = F(1);
                ls.delta = true;
                return ls;
            }
            case LightType::environment: {
                ls.w = sample_uniform_sphere(u);
                ls.L = power;
                ls.pdf = uniform_sphere_pdf<F>();
                return ls;
            }
            case LightType::quad: {
                const Vec3<F> q = quad.sample(u);
                const Vec3<F> v = q - ref;
                const F d2 = glm::dot(v, v);
                if (!(d2 > F(0))) return ls;
                ls.dist = std::sqrt(d2);
                ls.w = v / ls.dist;
                const F cos_l = -glm::dot(ls.w, quad.normal);
                if (cos_l <= F(0)) return ls;  // back side: emits nothing
                ls.L = power;
                ls.pdf = d2 / (quad.area() * cos_l);
                return ls;
            }
        }
        return ls;
    }

    /// Sample a photon leaving the light (u_pos, u_dir in [0,1)^2): point lights emit uniformly
    /// (weight 4 pi I), spots uniformly inside their outer cone (weight I falloff / pdf), quads
    /// from a uniform point with a cosine-distributed direction into their front side (weight
    /// pi A L). Directional and environment lights need the scene's bounds and are not sampled
    /// here (invalid sample).
    [[nodiscard]] EmissionSample<F, S> sample_emission(Vec2<F> u_pos, Vec2<F> u_dir) const noexcept {
        EmissionSample<F, S> e;
        switch (type) {
            case LightType::point: {
                e.ray = Ray<F>(position, sample_uniform_sphere(u_dir));
                e.weight = power * (F(4) * pi_v<F>);
                e.valid = true;
                return e;
            }
            case LightType::spot: {
                const Vec3<F> local = sample_uniform_cone(u_dir, cos_outer);
                e.ray = Ray<F>(position, glm::normalize(Frame<F>(direction).to_world(local)));
                e.weight = power * (spot_falloff(local.z) / uniform_cone_pdf(cos_outer));
                e.valid = true;
                return e;
            }
            case LightType::quad: {
                const Vec3<F> local = sample_cosine_hemisphere(u_dir);
                const Vec3<F> d = glm::normalize(Frame<F>(quad.normal).to_world(local));
                e.ray = Ray<F>(offset_ray_origin(quad.sample(u_pos), quad.normal, d), d);
                e.weight = power * (pi_v<F> * quad.area());
                e.valid = local.z > F(0);
                return e;
            }
            default:
                return e;
        }
    }

    /// Solid-angle pdf (without selection probability) of `sample` producing direction w from
    /// ref, for a quad light hit at distance `dist` or the environment (other lights: 0).
    [[nodiscard]] F pdf(const Vec3<F>& w, F dist) const noexcept {
        if (type == LightType::environment) return uniform_sphere_pdf<F>();
        if (type != LightType::quad) return F(0);
        const F cos_l = -glm::dot(w, quad.normal);
        if (cos_l <= F(0)) return F(0);
        return dist * dist / (quad.area() * cos_l);
    }

private:
    static void check_nonnegative(const S& s, const char* where, const char* param) {
        for (std::size_t c = 0; c < S::size; ++c)
            check_argument(std::isfinite(double(s[c])) && s[c] >= F(0), where, param, s[c], "[0, inf) per channel");
    }
    [[nodiscard]] F spot_falloff(F cos_theta) const noexcept {
        if (cos_theta >= cos_inner) return F(1);
        if (cos_theta <= cos_outer) return F(0);
        const F x = (cos_theta - cos_outer) / (cos_inner - cos_outer);
        return x * x * (F(3) - F(2) * x);
    }
};

}  // namespace grainlight
