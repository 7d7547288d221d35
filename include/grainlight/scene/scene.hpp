/// @file grainlight/scene/scene.hpp
/// A deliberately small scene for the examples and tests: shapes (scene/shapes.hpp) with a
/// material and the media on their two sides, lights (scene/lights.hpp) and media. Models the
/// WalkScene and LitScene concepts (scene/concepts.hpp), which is all integrators see of it.
///
/// Nested media: a shape's `medium_inside` / `medium_outside` name the media on the two sides of
/// its surface (-1 = vacuum). A dielectric sphere enclosing a ContinuousMedium is
/// `add_shape(SphereShape, Material::dielectric(1.5), /*inside*/ m, /*outside*/ -1)`; an
/// index-matched closed medium uses Material::index_matched(). Paths start in a medium the
/// caller names (the camera's medium, -1 by default).
///
/// Intersection is a linear loop over shapes (a scene has a handful; meshes carry their own BVH).
#pragma once

#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/optics/microfacet.hpp"
#include "grainlight/scene/concepts.hpp"
#include "grainlight/scene/lights.hpp"
#include "grainlight/scene/shapes.hpp"

namespace grainlight {

/// Surface material: what the walk kernel does at a hit (SurfaceType) and its parameters.
template <std::floating_point F, class S>
struct Material {
    /// What the walk kernel does at a hit.
    SurfaceType type = SurfaceType::diffuse;
    S reflectance = S(F(0.5));  ///< diffuse albedo (diffuse); normal-incidence reflectance F0 (glossy)
    F eta = F(1);           ///< n_inside / n_outside (dielectric)
    F roughness = F(0);     ///< GGX width alpha (glossy)

    /// Lambertian reflector, albedo in [0, 1] per channel.
    [[nodiscard]] static Material diffuse(const S& rho) {
        for (std::size_t c = 0; c < S::size; ++c)
            check_argument(rho[c] >= F(0) && rho[c] <= F(1), "Material::diffuse", "reflectance", rho[c], "[0, 1]");
        return {SurfaceType::diffuse, rho, F(1)};
    }
    /// Smooth dielectric interface of relative index eta = n_inside / n_outside > 0 (eta == 1
    /// behaves as index-matched).
    [[nodiscard]] static Material dielectric(F eta) {
        check_argument(std::isfinite(eta) && eta > F(0), "Material::dielectric", "eta", eta, "(0, inf)");
        return {eta == F(1) ? SurfaceType::passthrough : SurfaceType::dielectric, S(F(0)), eta};
    }
    /// Index-matched medium boundary: no reflection, only the medium changes.
    [[nodiscard]] static Material index_matched() { return {SurfaceType::passthrough, S(F(0)), F(1)}; }
    /// Black, opaque.
    [[nodiscard]] static Material absorber() { return {SurfaceType::absorber, S(F(0)), F(1)}; }
    /// Opaque glossy reflector: GGX microfacets of width `alpha` in [1e-3, 1] with Schlick's
    /// Fresnel on the normal-incidence reflectance `F0` in [0, 1] per channel (optics/microfacet.hpp).
    [[nodiscard]] static Material glossy(const S& F0, F alpha) {
        for (std::size_t c = 0; c < S::size; ++c)
            check_argument(F0[c] >= F(0) && F0[c] <= F(1), "Material::glossy", "F0", F0[c], "[0, 1]");
        check_argument(alpha >= F(glossy_min_alpha) && alpha <= F(1), "Material::glossy", "alpha", alpha, "[0.001, 1]");
        return {SurfaceType::glossy, F0, F(1), alpha};
    }
};

/// The scene. `MediumT` is the one medium type of the scene (a closed set of several kinds can
/// be a std::variant wrapper meeting the Medium concept).
template <Medium MediumT>
class Scene {
public:
    /// The scene's medium type.
    using Medium = MediumT;
    /// Floating-point type.
    using Float = typename MediumT::Float;
    /// Spectrum type.
    using Spectrum = typename MediumT::Spectrum;
    /// Short alias of Float.
    using F = Float;
    /// Short alias of Spectrum.
    using S = Spectrum;
    /// Any of the supported shapes (closed set, static dispatch).
    using Shape = std::variant<SphereShape<F>, BoxShape<F>, QuadShape<F>, MeshShape<F>, InstanceShape<F>>;
    /// Light type of the scene.
    using LightT = Light<F, S>;
    /// Material type of the scene.
    using MaterialT = Material<F, S>;

    /// A shape with its material, the media on both sides and its light (if emitting).
    struct ShapeEntry {
        /// The geometry.
        Shape shape;
        /// Surface behaviour at a hit.
        MaterialT material;
        /// Medium behind the outward normal (-1 = none).
        int medium_inside = -1;
        /// Medium in front of the outward normal (-1 = none).
        int medium_outside = -1;
        /// Index of the area light this shape is (-1 = not an emitter).
        int light = -1;
    };

    /// Add a medium; returns its index.
    int add_medium(Medium m) {
        media_.push_back(std::move(m));
        return int(media_.size()) - 1;
    }
    /// Add a shape with its material and the media on its inside / outside (-1 = none; indices
    /// must name media added before). Returns the shape index.
    int add_shape(Shape s, const MaterialT& mat, int medium_inside = -1, int medium_outside = -1) {
        check_medium(medium_inside, "medium_inside");
        check_medium(medium_outside, "medium_outside");
        shapes_.push_back({std::move(s), mat, medium_inside, medium_outside, -1});
        return int(shapes_.size()) - 1;
    }
    /// Add a light that is not a shape (point, spot, directional, environment). At most one
    /// environment light. Returns the light index.
    int add_light(const LightT& l) {
        check_argument(l.type != LightType::quad, "Scene::add_light", "type", "quad", "use add_quad_light");
        if (l.type == LightType::environment) {
            check_argument(env_ < 0, "Scene::add_light", "environment lights", 2, "at most 1");
            env_ = int(lights_.size());
        }
        lights_.push_back(l);
        return int(lights_.size()) - 1;
    }
    /// Add a one-sided quad area light of radiance L (emitting into the side its normal points
    /// to) as a shape with material `mat` (black by default). Returns the light index.
    int add_quad_light(const QuadShape<F>& q, const S& radiance, const MaterialT& mat = MaterialT::absorber(),
                       int medium_outside = -1) {
        LightT l = LightT::quad_light(q, radiance);
        const int shape = add_shape(q, mat, medium_outside, medium_outside);
        l.shape = shape;
        lights_.push_back(l);
        shapes_[std::size_t(shape)].light = int(lights_.size()) - 1;
        return int(lights_.size()) - 1;
    }

    /// Medium with index i (0 <= i < medium_count(); not checked).
    [[nodiscard]] const Medium& medium(int i) const noexcept { return media_[std::size_t(i)]; }
    /// Number of media added.
    [[nodiscard]] std::size_t medium_count() const noexcept { return media_.size(); }
    /// All shapes in the order added (index = shape index in SurfaceHit).
    [[nodiscard]] const std::vector<ShapeEntry>& shapes() const noexcept { return shapes_; }
    /// All lights in the order added (index = light index).
    [[nodiscard]] const std::vector<LightT>& lights() const noexcept { return lights_; }

    /// Closest hit with t in (0, ray.t_max).
    [[nodiscard]] SurfaceHit<F, S> intersect(const Ray<F>& ray) const noexcept {
        SurfaceHit<F, S> h;
        Ray<F> r = ray;
        int best = -1;
        Vec3<F> best_n(F(0));
        for (std::size_t i = 0; i < shapes_.size(); ++i) {
            F t;
            Vec3<F> n;
            const bool hit = std::visit([&](const auto& s) { return s.intersect(r, t, n); }, shapes_[i].shape);
            if (hit && t < r.t_max) {
                r.t_max = t;
                best = int(i);
                best_n = n;
            }
        }
        if (best < 0) return h;
        const ShapeEntry& e = shapes_[std::size_t(best)];
        h.t = r.t_max;
        h.p = ray(h.t);
        h.n = best_n;
        h.type = e.material.type;
        h.eta = e.material.eta;
        h.reflectance = e.material.reflectance;
        h.roughness = e.material.roughness;
        h.medium_inside = e.medium_inside;
        h.medium_outside = e.medium_outside;
        h.shape = best;
        h.light = e.light;
        return h;
    }
    /// True if any surface lies strictly between p and q (shadow test; every surface occludes).
    /// The segment stops a small scale-aware margin short of q (a light point on a surface does
    /// not occlude itself); p should already be offset off its surface (offset_ray_origin).
    [[nodiscard]] bool occluded(const Vec3<F>& p, const Vec3<F>& q) const noexcept {
        const Vec3<F> v = q - p;
        const F d = glm::length(v);
        if (!(d > F(0))) return false;
        const F eps_abs = (sizeof(F) == 4 ? F(5e-4) : F(3e-9)) * (F(1) + max_abs_component(q));
        const F t_max = d * (F(1) - F(1e-4)) - eps_abs;
        if (t_max <= F(0)) return false;
        const Ray<F> r(p, v / d, t_max);
        return intersect(r).hit();
    }

    /// Pick a light uniformly (u.z) and sample it (u.x, u.y); pdf includes the selection.
    [[nodiscard]] LightSample<F, S> sample_light(const Vec3<F>& ref, const Vec3<F>& u) const noexcept {
        if (lights_.empty()) return {};
        const std::size_t n = lights_.size();
        const std::size_t i = std::min(n - 1, std::size_t(u.z * F(n)));
        LightSample<F, S> ls = lights_[i].sample(ref, Vec2<F>(u.x, u.y));
        ls.pdf /= F(n);
        return ls;
    }
    /// A photon from a light picked uniformly by u_pick (weight includes the selection: the mean
    /// weight is the total power of the scene's point, spot and quad lights). Photon walks start
    /// here (integrators/walk.hpp, TransportMode::importance).
    [[nodiscard]] EmissionSample<F, S> sample_emission(F u_pick, Vec2<F> u_pos, Vec2<F> u_dir) const noexcept {
        if (lights_.empty()) return {};
        const std::size_t n = lights_.size();
        const std::size_t i = std::min(n - 1, std::size_t(u_pick * F(n)));
        EmissionSample<F, S> e = lights_[i].sample_emission(u_pos, u_dir);
        e.weight *= F(n);
        return e;
    }
    /// Solid-angle pdf (with selection probability) that sample_light from `ref` yields direction
    /// `w` reaching `hit` (an emitter, or the environment if `hit` is a miss).
    [[nodiscard]] F light_pdf(const Vec3<F>& ref, const Vec3<F>& w, const SurfaceHit<F, S>& hit) const noexcept {
        if (lights_.empty()) return F(0);
        const F sel = F(1) / F(lights_.size());
        if (!hit.hit()) return env_ >= 0 ? sel * uniform_sphere_pdf<F>() : F(0);
        if (hit.light < 0) return F(0);
        return sel * lights_[std::size_t(hit.light)].pdf(w, glm::length(hit.p - ref));
    }
    /// Radiance emitted by the hit surface toward a path arriving along w.
    [[nodiscard]] S emitted(const SurfaceHit<F, S>& hit, const Vec3<F>& w) const noexcept {
        if (hit.light < 0 || glm::dot(w, hit.n) >= F(0)) return S(F(0));
        return lights_[std::size_t(hit.light)].power;
    }
    /// Radiance of the environment seen along an escaping direction w.
    [[nodiscard]] S environment(const Vec3<F>&) const noexcept {
        return env_ >= 0 ? lights_[std::size_t(env_)].power : S(F(0));
    }

private:
    void check_medium(int i, const char* param) const {
        check_argument(i >= -1 && i < int(media_.size()), "Scene::add_shape", param, i,
                       "-1 (none) or the index of a medium added before");
    }
    std::vector<Medium> media_;
    std::vector<ShapeEntry> shapes_;
    std::vector<LightT> lights_;
    int env_ = -1;
};

}  // namespace grainlight
