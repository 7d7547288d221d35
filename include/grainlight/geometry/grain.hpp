/// @file grainlight/geometry/grain.hpp
/// One grain in its unit bounding sphere (centred at the origin, radius 1): an analytic sphere of
/// radius r <= 1 or a watertight triangle mesh (BVH) with every vertex within the unit sphere, and
/// its material. The one grain type of the library: the virtual scatterometer (Meng15 Sec. 4.1)
/// traces it alone, a granular aggregate (traversal/aggregate.hpp) instances it in every bounding
/// sphere, and EPT walks inside it. A grain larger than its bounding sphere is an error
/// (invalid_argument). `GrainExemplar` and `ScatterometerGrain` are aliases of this type.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/star_mesh.hpp"

namespace grainlight {

/// One grain in its unit frame (bounding sphere of radius <= 1 at the origin): an analytic sphere
/// or a triangle mesh with its BVH, plus the GrainMaterial. Immutable after construction, cheap to
/// copy (the BVH is shared) and safe to query from many threads.
class Grain {
public:
    /// Analytic sphere of radius `radius` in (0, 1].
    [[nodiscard]] static Grain sphere(double radius, const GrainMaterial& material) {
        check_grain_radius("Grain::sphere", "radius", radius);
        material.validate();
        Grain g;
        g.radius_ = radius;
        g.material_ = material;
        return g;
    }
    /// Any watertight mesh with outward normals, inside the unit sphere.
    [[nodiscard]] static Grain mesh(const TriangleMesh<float>& m, const GrainMaterial& material) {
        const double r = check_grain_mesh("Grain::mesh", m);
        material.validate();
        Grain g;
        g.bvh_ = std::make_shared<const Bvh<float>>(m);
        // A mesh star-shaped around the origin (every procedural grain) is also walked cone by
        // cone (geometry/star_mesh.hpp); up to star_walk_max_triangles, where that is faster.
        if (m.triangle_count() <= star_walk_max_triangles)
            if (auto star = StarMesh::build(m)) g.star_ = std::make_shared<const StarMesh>(std::move(*star));
        g.radius_ = r;
        g.material_ = material;
        g.triangles_ = m.triangle_count();
        return g;
    }
    /// Procedural grain (geometry/grains.hpp) of bounding radius in (0, 1] and subdivision `level`;
    /// the sphere shape is the analytic sphere.
    [[nodiscard]] static Grain procedural(GrainShape shape, double radius, const GrainMaterial& material,
                                          std::uint64_t seed = 1, int level = 4) {
        check_grain_radius("Grain::procedural", "radius", radius);
        if (shape == GrainShape::sphere) return sphere(radius, material);
        return mesh(make_grain_mesh<float>(shape, float(radius), seed, level), material);
    }
    /// From a preset of geometry/grains.hpp.
    [[nodiscard]] static Grain from_preset(const GrainPreset& p, int level = 4) {
        return procedural(p.shape, p.radius, p.material, p.seed, level);
    }

    /// The grain's material.
    [[nodiscard]] const GrainMaterial& material() const noexcept { return material_; }
    /// Meshes of at most this many triangles that are star-shaped around the origin are queried by
    /// the cone walk of geometry/star_mesh.hpp first (the BVH finishes rays the walk hands over);
    /// larger ones by the BVH alone. Procedural grains of icosphere level <= 3 (1280 triangles).
    static constexpr std::size_t star_walk_max_triangles = 1280;
    /// Triangles the walk tests before it hands the rest of a ray to the BVH (a bound a grain of at
    /// most 1280 triangles rarely reaches: it guards against long walks, not a tuning).
    static constexpr int star_walk_budget = 64;

    /// True if the mesh is queried by the cone walk (star-shaped, small enough).
    [[nodiscard]] bool uses_star_walk() const noexcept { return bool(star_); }
    /// True for the analytic sphere, false for a mesh.
    [[nodiscard]] bool is_analytic_sphere() const noexcept { return !bvh_; }
    /// Radius of the grain's own (origin-centred) bounding sphere (the sphere's radius).
    [[nodiscard]] double radius() const noexcept { return radius_; }
    /// Number of mesh triangles (0 for the analytic sphere).
    [[nodiscard]] std::size_t triangle_count() const noexcept { return triangles_; }
    /// Bytes of the grain's geometry (BVH nodes + triangles; 0 for the analytic sphere).
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        if (!bvh_) return 0;
        return bvh_->nodes().size() * sizeof(BvhNode<float>) +
               triangles_ * (sizeof(std::array<Vec3f, 3>) + sizeof(Vec3f) + sizeof(std::uint32_t)) +
               (star_ ? star_->memory_bytes() : 0);
    }

    /// Closest hit along o + t d (unit frame, d unit), t in (t_min, t_max): t and the outward unit
    /// normal. Returns false on a miss.
    [[nodiscard]] bool intersect(const Vec3d& o, const Vec3d& d, double t_min, double t_max, double& t,
                                 Vec3d& n) const noexcept {
        if (!bvh_) {
            if (!intersect_sphere_first(o, d, Vec3d(0.0), radius_, t_min, t_max, t)) return false;
            n = glm::normalize(o + t * d);
            return true;
        }
        const Vec3d o2 = o + t_min * d;  // float BVH: start at t_min to keep the offset small
        const auto h = intersect_star_then_bvh(star_.get(), *bvh_, Vec3f(o2), Vec3f(d),
                                               float(std::min(t_max - t_min, 1e30)), star_walk_budget);
        if (!h.valid()) return false;
        t = t_min + double(h.t);
        n = Vec3d(h.n_geom);
        return true;
    }
    /// Closest hit along o + t d, t in (0, t_max): t (+inf on a miss) and the outward unit normal.
    [[nodiscard]] double intersect(const Vec3d& o, const Vec3d& d, double t_max, Vec3d& n) const noexcept {
        double t = 0;
        return intersect(o, d, 0.0, t_max, t, n) ? t : std::numeric_limits<double>::infinity();
    }
    /// Offset used to leave a surface without re-hitting it, in the unit frame (meshes: relative to
    /// their size, well above the float round-off of the watertight test).
    [[nodiscard]] double surface_epsilon() const noexcept { return bvh_ ? 2e-5 * radius_ : 1e-10; }

    /// Human-readable description (sphere or mesh with triangle count, radius, material).
    [[nodiscard]] std::string to_string() const {
        return std::string("Grain[") + (bvh_ ? "mesh, " + std::to_string(triangles_) + " triangles" : "sphere") +
               ", radius " + std::to_string(radius_) + ", " + std::string(grainlight::to_string(material_.kind)) + "]";
    }

private:
    Grain() = default;
    std::shared_ptr<const Bvh<float>> bvh_;
    std::shared_ptr<const StarMesh> star_;
    double radius_ = 1.0;
    std::size_t triangles_ = 0;
    GrainMaterial material_{};
};

}  // namespace grainlight
