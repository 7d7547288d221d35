/// @file grainlight/geometry/closed_mesh.hpp
/// A closed triangle mesh as the refractive boundary of a medium (Wang18 Sec. 3.4.1: "any
/// closed mesh"): closest-hit ray queries with the outward geometric normal (the SAH BVH of
/// geometry/bvh.hpp), the nearest surface point and the tangent plane seen from a point (the
/// exact nearest point of geometry/distance.hpp's MeshDistance), and an inside test from the
/// angle-weighted pseudo-normal of the nearest feature (Baerentzen & Aanaes 2005, "Signed
/// distance computation using the angle weighted pseudonormal", IEEE TVCG 11(3)): p is inside
/// iff (p - q) . N < 0 for the nearest point q and the pseudo-normal N of the face, edge or
/// vertex q lies on; one nearest-point query instead of ray parity.
///
/// The shape satisfies the Boundary requirements of integrators/point_based.hpp
/// (`intersect(Ray, t&, n&)`) and its `TangentPlaneBoundary` customization point
/// (`boundary_tangent_plane`, below). Copies share the immutable data.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/distance.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// A closed, consistently oriented triangle mesh (outward normals) as a medium boundary. Throws
/// grainlight::invalid_argument for an invalid or open mesh (an edge not shared by exactly two
/// triangles of opposite orientation) and for an inside-out one (signed volume <= 0).
template <std::floating_point F>
class ClosedMeshShape {
public:
    /// An empty shape (every ray misses; not a valid boundary).
    ClosedMeshShape() = default;

    /// Validate `mesh` (closed, outward-facing) and build its BVH, nearest-point tree and
    /// pseudo-normals.
    explicit ClosedMeshShape(const TriangleMesh<F>& mesh) {
        mesh.validate("ClosedMeshShape");
        check_argument(mesh.is_watertight(), "ClosedMeshShape", "mesh", "open or inconsistently oriented",
                       "a closed mesh: every edge shared by exactly two triangles with opposite orientation");
        const double vol = mesh.signed_volume();
        check_argument(vol > 0, "ClosedMeshShape", "signed volume", vol, "> 0 (outward-facing triangles)");
        auto d = std::make_shared<Data>(mesh);
        d->area = mesh.area();
        d->volume = vol;
        d->mesh.compute_face_normals();
        const std::size_t nt = mesh.triangles.size(), nv = mesh.vertices.size();
        // Angle-weighted vertex normals and per-edge normals (sum of the two face normals).
        std::vector<Vec3d> vn(nv, Vec3d(0.0));
        std::vector<Vec3d> fn(nt);
        std::map<std::pair<std::uint32_t, std::uint32_t>, Vec3d> en;
        for (std::size_t i = 0; i < nt; ++i) {
            const auto& t = mesh.triangles[i];
            const Vec3d a(mesh.vertices[t[0]]), b(mesh.vertices[t[1]]), c(mesh.vertices[t[2]]);
            const Vec3d g = glm::cross(b - a, c - a);
            const double len = glm::length(g);
            fn[i] = len > 0 ? g / len : Vec3d(0, 0, 1);
            const Vec3d p[3] = {a, b, c};
            for (int k = 0; k < 3; ++k) {
                const Vec3d e1 = glm::normalize(p[(k + 1) % 3] - p[k]), e2 = glm::normalize(p[(k + 2) % 3] - p[k]);
                const double ang = std::acos(std::clamp(glm::dot(e1, e2), -1.0, 1.0));
                vn[t[k]] += ang * fn[i];
                en[std::minmax(t[k], t[(k + 1) % 3])] += fn[i];
            }
        }
        d->face_n = fn;
        d->tri_edge_n.resize(nt);
        d->tri_vertex_n.resize(nt);
        for (std::size_t i = 0; i < nt; ++i) {
            const auto& t = mesh.triangles[i];
            for (int k = 0; k < 3; ++k) {
                d->tri_edge_n[i][std::size_t(k)] = en[std::minmax(t[k], t[(k + 1) % 3])];
                d->tri_vertex_n[i][std::size_t(k)] = vn[t[k]];
            }
        }
        data_ = std::move(d);
    }

    /// Closest hit t in (0, r.t_max) and the unit outward geometric normal of the hit triangle
    /// (from either side).
    [[nodiscard]] bool intersect(const Ray<F>& r, F& t, Vec3<F>& n) const noexcept {
        const TriangleHit<F> h = data_->bvh.intersect(r.o, r.d, F(0), r.t_max);
        if (!h) return false;
        t = h.t;
        n = h.n_geom;
        return true;
    }

    /// Nearest surface point q of p, the outward normal n of the tangent plane there (the unit
    /// vector from p to q for an inside p, from q to p outside; the face normal on the surface),
    /// and whether p is inside (pseudo-normal test, see the file comment).
    bool tangent_plane(const Vec3<F>& p, Vec3<F>& q, Vec3<F>& n) const noexcept {
        const Vec3d pd(p);
        const NearestPoint np = data_->dist.nearest(pd);
        const std::uint32_t ti = np.triangle;
        const Vec3d qd = np.point;
        const Vec3d N = pseudo_normal(ti, qd);
        const Vec3d dq = pd - qd;
        const bool in = glm::dot(dq, N) < 0;
        q = Vec3<F>(qd);
        const double l = glm::length(dq);
        n = l > 1e-9 * (1.0 + glm::length(qd)) ? Vec3<F>(in ? -dq / l : dq / l) : Vec3<F>(data_->face_n[ti]);
        return in;
    }

    /// p inside the closed mesh (pseudo-normal sign of the nearest point).
    [[nodiscard]] bool inside(const Vec3<F>& p) const noexcept {
        Vec3<F> q, n;
        return tangent_plane(p, q, n);
    }

    /// The validated mesh (with face normals).
    [[nodiscard]] const TriangleMesh<F>& mesh() const noexcept { return data_->mesh; }
    /// Total surface area.
    [[nodiscard]] double area() const noexcept { return data_->area; }
    /// Enclosed volume.
    [[nodiscard]] double volume() const noexcept { return data_->volume; }
    /// Number of triangles.
    [[nodiscard]] std::size_t triangle_count() const noexcept { return data_->mesh.triangles.size(); }
    /// Bounds of the mesh.
    [[nodiscard]] Aabb<F> bounds() const noexcept { return data_->bvh.bounds(); }
    /// Unit outward normal of triangle i.
    [[nodiscard]] Vec3<F> face_normal(std::size_t i) const noexcept { return Vec3<F>(data_->face_n[i]); }

private:
    /// Pseudo-normal of the feature of triangle ti that q lies on (face, edge or vertex), from
    /// the barycentric coordinates of q.
    [[nodiscard]] Vec3d pseudo_normal(std::uint32_t ti, const Vec3d& q) const noexcept {
        const auto c = data_->mesh.corners(ti);
        const Vec3d a(c[0]), b(c[1]), cc(c[2]);
        const Vec3d v0 = b - a, v1 = cc - a, v2 = q - a;
        const double d00 = glm::dot(v0, v0), d01 = glm::dot(v0, v1), d11 = glm::dot(v1, v1);
        const double d20 = glm::dot(v2, v0), d21 = glm::dot(v2, v1);
        const double den = d00 * d11 - d01 * d01;
        if (!(den > 0)) return data_->face_n[ti];
        const double w1 = (d11 * d20 - d01 * d21) / den, w2 = (d00 * d21 - d01 * d20) / den;
        const double bc[3] = {1.0 - w1 - w2, w1, w2};
        constexpr double eps = 1e-7;
        int zeros = 0, nz = -1, z = -1;
        for (int k = 0; k < 3; ++k) {
            if (bc[k] <= eps) {
                ++zeros;
                z = k;
            } else {
                nz = k;
            }
        }
        if (zeros == 0) return data_->face_n[ti];
        if (zeros >= 2) return data_->tri_vertex_n[ti][std::size_t(nz)];  // at the vertex nz
        // On the edge opposite corner z: edge (z + 1, z + 2) is stored as edge index z + 1.
        return data_->tri_edge_n[ti][std::size_t((z + 1) % 3)];
    }

    struct Data {
        explicit Data(const TriangleMesh<F>& m) : mesh(m), bvh(m), dist(m) {}
        TriangleMesh<F> mesh;
        Bvh<F> bvh;
        MeshDistance dist;
        std::vector<Vec3d> face_n;
        std::vector<std::array<Vec3d, 3>> tri_edge_n;    ///< edge k = (corner k, corner k + 1)
        std::vector<std::array<Vec3d, 3>> tri_vertex_n;  ///< angle-weighted normal of corner k
        double area = 0, volume = 0;
    };
    std::shared_ptr<const Data> data_;
};

/// Nearest boundary point q and outward tangent-plane normal n of a closed mesh seen from p: the
/// `TangentPlaneBoundary` customization point of the point-based renderer (found by ADL).
template <std::floating_point F>
inline void boundary_tangent_plane(const ClosedMeshShape<F>& m, const Vec3<F>& p, Vec3<F>& q, Vec3<F>& n) noexcept {
    (void)m.tangent_plane(p, q, n);
}

}  // namespace grainlight
