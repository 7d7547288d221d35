/// @file grainlight/scene/shapes.hpp
/// Shapes of the small scene layer: sphere, axis-aligned box, quad (parallelogram), triangle
/// mesh (through the SAH BVH of geometry/bvh.hpp) and instances of a mesh placed by a similarity
/// transform (geometry/transform.hpp; the BVH is shared). Each shape answers
/// `intersect(ray, t, n)`: the closest hit with t in (0, ray.t_max) and the unit geometric normal
/// pointing to the shape's *outside* (outward for closed shapes; for a quad, cross(edge_u,
/// edge_v) / |..|). Queries allocate nothing and throw nothing; constructors validate.
#pragma once

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/transform.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// A sphere (center, radius > 0); outward normal.
template <std::floating_point F>
struct SphereShape {
    /// Centre.
    Vec3<F> center{F(0)};
    /// Radius (> 0).
    F radius = F(1);

    /// Unit sphere at the origin.
    SphereShape() = default;
    /// Sphere at `c` with radius `r` > 0; throws grainlight::invalid_argument otherwise.
    SphereShape(const Vec3<F>& c, F r) : center(c), radius(r) {
        check_argument(std::isfinite(r) && r > F(0), "SphereShape", "radius", r, "(0, inf)");
    }
    /// Closest hit t in (0, r.t_max) and its outward unit normal n; false if none.
    [[nodiscard]] bool intersect(const Ray<F>& r, F& t, Vec3<F>& n) const noexcept {
        if (!intersect_sphere_first(r.o, r.d, center, radius, F(0), r.t_max, t)) return false;
        n = sphere_normal(r(t), center);
        return true;
    }
    /// Surface area 4 pi r^2.
    [[nodiscard]] F area() const noexcept { return F(4) * pi_v<F> * radius * radius; }
};

/// An axis-aligned box [lo, hi] (hi > lo in every axis); outward face normals.
template <std::floating_point F>
struct BoxShape {
    /// @var lo
    /// Lower corner.
    /// @var hi
    /// Upper corner.
    Vec3<F> lo{F(-1)}, hi{F(1)};

    /// The box [-1, 1]^3.
    BoxShape() = default;
    /// Box [lo_, hi_] (hi_ > lo_ on every axis; throws grainlight::invalid_argument otherwise).
    BoxShape(const Vec3<F>& lo_, const Vec3<F>& hi_) : lo(lo_), hi(hi_) {
        for (int a = 0; a < 3; ++a)
            check_argument(std::isfinite(hi[a] - lo[a]) && hi[a] > lo[a], "BoxShape", "hi - lo", hi[a] - lo[a],
                           "(0, inf) on every axis");
    }
    /// Closest hit t in (0, r.t_max) (entry, or exit from inside) and the outward face normal n.
    [[nodiscard]] bool intersect(const Ray<F>& r, F& t, Vec3<F>& n) const noexcept {
        F t0 = -std::numeric_limits<F>::infinity(), t1 = std::numeric_limits<F>::infinity();
        int a0 = -1, a1 = -1;
        for (int a = 0; a < 3; ++a) {
            if (r.d[a] == F(0)) {
                if (r.o[a] < lo[a] || r.o[a] > hi[a]) return false;
                continue;
            }
            const F inv = F(1) / r.d[a];
            F tn = (lo[a] - r.o[a]) * inv, tf = (hi[a] - r.o[a]) * inv;
            if (tn > tf) std::swap(tn, tf);
            if (tn > t0) {
                t0 = tn;
                a0 = a;
            }
            if (tf < t1) {
                t1 = tf;
                a1 = a;
            }
        }
        if (t0 > t1) return false;
        int axis;
        if (t0 > F(0) && t0 < r.t_max) {
            t = t0;
            axis = a0;
        } else if (t1 > F(0) && t1 < r.t_max) {
            t = t1;
            axis = a1;
        } else {
            return false;
        }
        if (axis < 0) return false;
        const Vec3<F> p = r(t);
        n = Vec3<F>(F(0));
        n[axis] = std::abs(p[axis] - lo[axis]) < std::abs(p[axis] - hi[axis]) ? F(-1) : F(1);
        return true;
    }
    /// Surface area of the six faces.
    [[nodiscard]] F area() const noexcept {
        const Vec3<F> e = hi - lo;
        return F(2) * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
};

/// A parallelogram corner + s edge_u + t edge_v, (s, t) in [0, 1]^2; normal
/// cross(edge_u, edge_v) normalized (the emitting side of a quad light).
template <std::floating_point F>
struct QuadShape {
    /// @var corner
    /// Corner at (s, t) = (0, 0).
    /// @var edge_u
    /// First edge (s direction).
    /// @var edge_v
    /// Second edge (t direction).
    Vec3<F> corner{F(0)}, edge_u{F(1), F(0), F(0)}, edge_v{F(0), F(1), F(0)};
    /// Unit normal normalize(cross(edge_u, edge_v)).
    Vec3<F> normal{F(0), F(0), F(1)};
    /// Area |cross(edge_u, edge_v)| (cached).
    F area_ = F(1);

    /// Unit square in the z = 0 plane, normal +z.
    QuadShape() = default;
    /// Parallelogram at corner `c` with edges `u`, `v` (not parallel; throws grainlight::invalid_argument otherwise).
    QuadShape(const Vec3<F>& c, const Vec3<F>& u, const Vec3<F>& v) : corner(c), edge_u(u), edge_v(v) {
        const Vec3<F> cr = glm::cross(u, v);
        area_ = glm::length(cr);
        check_argument(std::isfinite(area_) && area_ > F(0), "QuadShape", "|edge_u x edge_v|", area_, "(0, inf)");
        normal = cr / area_;
    }
    /// Hit t in (0, r.t_max) from either side; n is always the quad's normal.
    [[nodiscard]] bool intersect(const Ray<F>& r, F& t, Vec3<F>& n) const noexcept {
        const F denom = glm::dot(normal, r.d);
        if (denom == F(0)) return false;
        const F th = glm::dot(normal, corner - r.o) / denom;
        if (!(th > F(0) && th < r.t_max)) return false;
        const Vec3<F> q = r(th) - corner;
        // Coordinates in the (possibly non-orthogonal) edge basis.
        const F uu = glm::dot(edge_u, edge_u), uv = glm::dot(edge_u, edge_v), vv = glm::dot(edge_v, edge_v);
        const F qu = glm::dot(q, edge_u), qv = glm::dot(q, edge_v);
        const F det = uu * vv - uv * uv;
        const F s = (qu * vv - qv * uv) / det, tt = (qv * uu - qu * uv) / det;
        if (s < F(0) || s > F(1) || tt < F(0) || tt > F(1)) return false;
        t = th;
        n = normal;
        return true;
    }
    /// Surface area.
    [[nodiscard]] F area() const noexcept { return area_; }
    /// Point for unit-square sample u (uniform in area; pdf 1 / area).
    [[nodiscard]] Vec3<F> sample(Vec2<F> u) const noexcept { return corner + u.x * edge_u + u.y * edge_v; }
};

/// A triangle mesh behind a SAH BVH (geometry/bvh.hpp). Face orientation defines the outside
/// (counter-clockwise seen from outside). The BVH is shared between copies.
template <std::floating_point F>
struct MeshShape {
    /// The mesh's BVH (shared by copies; null for a default-constructed shape).
    std::shared_ptr<const Bvh<F>> bvh;
    /// Total triangle area (cached).
    double area_ = 0;

    /// Empty shape (no BVH; do not intersect).
    MeshShape() = default;
    /// Build over `mesh` (validated by the BVH build).
    explicit MeshShape(const TriangleMesh<F>& mesh)
        : bvh(std::make_shared<const Bvh<F>>(mesh)), area_(mesh.area()) {}

    /// Load a Wavefront OBJ file and place it: v' = scale * v + offset. Throws io_error (naming
    /// the path) when the file cannot be opened, format_error when it is malformed, and
    /// invalid_argument for scale <= 0.
    [[nodiscard]] static MeshShape from_obj(const std::string& path, F scale = F(1), const Vec3<F>& offset = Vec3<F>(F(0))) {
        check_argument(std::isfinite(scale) && scale > F(0), "MeshShape::from_obj", "scale", scale, "(0, inf)");
        TriangleMesh<F> mesh = load_obj<F>(path);
        for (auto& v : mesh.vertices) v = scale * v + offset;
        mesh.compute_face_normals();
        return MeshShape(mesh);
    }
    /// Closest hit t in (0, r.t_max) and the triangle's geometric normal (outward for a consistently oriented mesh).
    [[nodiscard]] bool intersect(const Ray<F>& r, F& t, Vec3<F>& n) const noexcept {
        const TriangleHit<F> h = bvh->intersect(r.o, r.d, F(0), r.t_max);
        if (!h) return false;
        t = h.t;
        n = h.n_geom;
        return true;
    }
    /// Total triangle area.
    [[nodiscard]] F area() const noexcept { return F(area_); }
};

/// An instance of a mesh placed by a similarity transform x_world = translation + scale R x_local
/// (geometry/transform.hpp). Copies share the mesh's BVH, so thousands of instanced grains cost
/// one BVH. Rays are moved into the mesh's frame; t and normals come back in world units.
template <std::floating_point F>
struct InstanceShape {
    /// The instanced mesh (its BVH is shared).
    MeshShape<F> mesh;
    /// Local-to-world similarity transform.
    Transform<F> xf;

    /// Empty instance (no mesh; do not intersect).
    InstanceShape() = default;
    /// Throws invalid_argument if the mesh has no BVH or the scale is not in (0, inf).
    InstanceShape(MeshShape<F> m, const Transform<F>& t) : mesh(std::move(m)), xf(t) {
        check_argument(mesh.bvh != nullptr, "InstanceShape", "mesh", "empty", "a built MeshShape");
        check_argument(std::isfinite(t.scale) && t.scale > F(0), "InstanceShape", "scale", t.scale, "(0, inf)");
    }
    /// Closest hit t in (0, r.t_max) in world units and the world-space unit normal.
    [[nodiscard]] bool intersect(const Ray<F>& r, F& t, Vec3<F>& n) const noexcept {
        const Ray<F> local(xf.point_to_local(r.o), xf.vector_to_local(r.d), r.t_max / xf.scale);
        F tl;
        Vec3<F> nl;
        if (!mesh.intersect(local, tl, nl)) return false;
        t = tl * xf.scale;
        n = glm::normalize(xf.vector_to_world(nl));
        return true;
    }
    /// World-space area: mesh area times scale^2.
    [[nodiscard]] F area() const noexcept { return mesh.area() * xf.scale * xf.scale; }
};

}  // namespace grainlight
