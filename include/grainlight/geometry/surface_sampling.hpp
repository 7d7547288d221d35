/// @file grainlight/geometry/surface_sampling.hpp
/// Points on triangle meshes: uniform by area (a triangle picked with probability proportional
/// to its area, then a uniform point on it), and blue-noise (Poisson-disk) sets by dart throwing
/// (Wang18 Sec. 3.4.1 uses a blue-noise set of surface samples; Cook 1986, "Stochastic sampling
/// in computer graphics", ACM TOG 5(1)): area-uniform candidates are accepted when no accepted
/// point lies within the Euclidean distance r (a hash grid of cell r answers the query). Every
/// accepted pair is at least r apart by construction; candidates are uniform by area, so the
/// accepted set covers the surface evenly. Also a procedural bumpy sphere (a radially displaced
/// icosphere), the stand-in for the paper's "Bumpy sphere" mesh.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// A point on a mesh: position, the unit geometric normal of its triangle, the triangle index.
template <std::floating_point F>
struct MeshSurfacePoint {
    /// Position on the surface.
    Vec3<F> p{F(0)};
    /// Unit geometric normal of the triangle (outward for a closed, outward-facing mesh).
    Vec3<F> n{F(0), F(0), F(1)};
    /// Index of the triangle in the mesh.
    std::uint32_t triangle = 0;
};

/// Area-uniform points on a mesh: triangle i with probability A_i / A, then a uniform point on it.
template <std::floating_point F>
class MeshAreaSampler {
public:
    /// Build over `mesh` (validated; throws invalid_argument for a mesh of zero area).
    explicit MeshAreaSampler(const TriangleMesh<F>& mesh) : mesh_(&mesh) {
        mesh.validate("MeshAreaSampler");
        std::vector<double> a(mesh.triangles.size());
        normals_.resize(a.size());
        for (std::size_t i = 0; i < a.size(); ++i) {
            const auto c = mesh.corners(i);
            const Vec3d g = glm::cross(Vec3d(c[1]) - Vec3d(c[0]), Vec3d(c[2]) - Vec3d(c[0]));
            const double l = glm::length(g);
            a[i] = 0.5 * l;
            normals_[i] = l > 0 ? Vec3<F>(g / l) : Vec3<F>(F(0), F(0), F(1));
            area_ += a[i];
        }
        check_argument(area_ > 0 && std::isfinite(area_), "MeshAreaSampler", "mesh area", area_, "(0, inf)");
        dist_ = DiscreteDistribution<double>(std::span<const double>(a));
    }
    /// Total area.
    [[nodiscard]] double area() const noexcept { return area_; }
    /// A point for three uniforms in [0, 1) (the first picks the triangle).
    [[nodiscard]] MeshSurfacePoint<F> sample(double u0, F u1, F u2) const noexcept {
        const std::size_t i = dist_.sample(u0);
        const auto c = mesh_->corners(i);
        const Vec2<F> b = sample_uniform_triangle(Vec2<F>(u1, u2));
        MeshSurfacePoint<F> s;
        s.p = b.x * c[0] + b.y * c[1] + (F(1) - b.x - b.y) * c[2];
        s.n = normals_[i];
        s.triangle = std::uint32_t(i);
        return s;
    }
    /// A point from `rng`.
    [[nodiscard]] MeshSurfacePoint<F> sample(Rng& rng) const noexcept {
        const double u0 = rng.uniform<double>();
        const Vec2<F> u = rng.uniform2<F>();
        return sample(u0, u.x, u.y);
    }

private:
    const TriangleMesh<F>* mesh_;
    std::vector<Vec3<F>> normals_;
    DiscreteDistribution<double> dist_;
    double area_ = 0;
};

/// Poisson-disk (blue-noise) points on a mesh by dart throwing: area-uniform candidates, each
/// accepted when no accepted point is closer than `radius` (Euclidean). Stops after
/// `max_points` accepted points or `max_candidates` candidates. Deterministic for `seed`.
/// Throws invalid_argument for radius <= 0, max_points < 1, max_candidates < 1.
template <std::floating_point F>
[[nodiscard]] inline std::vector<MeshSurfacePoint<F>> poisson_disk_mesh_points(const TriangleMesh<F>& mesh, double radius,
                                                                             std::size_t max_points,
                                                                             std::size_t max_candidates,
                                                                             std::uint64_t seed) {
    check_argument(std::isfinite(radius) && radius > 0, "poisson_disk_mesh_points", "radius", radius, "(0, inf)");
    check_argument(max_points >= 1, "poisson_disk_mesh_points", "max_points", max_points, ">= 1");
    check_argument(max_candidates >= 1, "poisson_disk_mesh_points", "max_candidates", max_candidates, ">= 1");
    const MeshAreaSampler<F> sampler(mesh);
    const Aabb<F> b = mesh.bounds();
    const Vec3d lo = Vec3d(b.lo) - Vec3d(radius);
    auto cell = [&](const Vec3d& p, int k) { return std::int64_t(std::floor((p[k] - lo[k]) / radius)); };
    auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
        return (std::uint64_t(x) * 73856093ull) ^ (std::uint64_t(y) * 19349663ull) ^ (std::uint64_t(z) * 83492791ull);
    };
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
    std::vector<MeshSurfacePoint<F>> out;
    const double r2 = radius * radius;
    Rng rng = Rng::from_key(seed, 0x504f4953ull);
    for (std::size_t c = 0; c < max_candidates && out.size() < max_points; ++c) {
        const MeshSurfacePoint<F> s = sampler.sample(rng);
        const Vec3d p(s.p);
        const std::int64_t cx = cell(p, 0), cy = cell(p, 1), cz = cell(p, 2);
        bool ok = true;
        for (std::int64_t dz = -1; dz <= 1 && ok; ++dz)
            for (std::int64_t dy = -1; dy <= 1 && ok; ++dy)
                for (std::int64_t dx = -1; dx <= 1 && ok; ++dx) {
                    const auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
                    if (it == grid.end()) continue;
                    for (std::uint32_t j : it->second) {
                        const Vec3d d = Vec3d(out[j].p) - p;
                        if (glm::dot(d, d) < r2) {
                            ok = false;
                            break;
                        }
                    }
                }
        if (!ok) continue;
        grid[key(cx, cy, cz)].push_back(std::uint32_t(out.size()));
        out.push_back(s);
    }
    return out;
}

/// About `n` Poisson-disk points on a mesh: dart throwing with the radius r = sqrt(0.55 A / n)
/// (random sequential adsorption saturates at ~0.70 A / r^2 points in the plane, so the target
/// is reached before saturation on meshes whose curvature radius is large against r), at most
/// 64 n candidates; returns exactly n points unless the surface saturates first (then fewer).
/// `radius_out` receives r. Throws invalid_argument for n < 1.
template <std::floating_point F>
[[nodiscard]] inline std::vector<MeshSurfacePoint<F>> poisson_disk_mesh_points(const TriangleMesh<F>& mesh, int n,
                                                                             std::uint64_t seed,
                                                                             double* radius_out = nullptr) {
    check_argument(n >= 1, "poisson_disk_mesh_points", "n", n, ">= 1");
    const double r = std::sqrt(0.55 * mesh.area() / double(n));
    if (radius_out) *radius_out = r;
    return poisson_disk_mesh_points(mesh, r, std::size_t(n), std::size_t(n) * 64, seed);
}

/// Bumpy sphere (the stand-in for Wang18's "Bumpy sphere" mesh): the icosphere of `level`
/// (20 4^level triangles) with each vertex v moved to radius
/// radius (1 + amplitude sin(f v_x + 0.4) sin(f v_y + 1.1) sin(f v_z + 2.3)), f = frequency.
/// Closed and outward-facing (a radial displacement with |amplitude| < 1 keeps the orientation).
/// Throws invalid_argument for radius <= 0, |amplitude| >= 0.5, frequency < 0, or a bad level.
template <std::floating_point F = float>
[[nodiscard]] inline TriangleMesh<F> make_bumpy_sphere(int level, double radius, double amplitude, double frequency) {
    check_argument(std::isfinite(radius) && radius > 0, "make_bumpy_sphere", "radius", radius, "(0, inf)");
    check_argument(std::abs(amplitude) < 0.5, "make_bumpy_sphere", "amplitude", amplitude, "(-0.5, 0.5)");
    check_argument(std::isfinite(frequency) && frequency >= 0, "make_bumpy_sphere", "frequency", frequency, "[0, inf)");
    TriangleMesh<double> m = make_icosphere<double>(level);
    for (auto& v : m.vertices) {
        const double h = std::sin(frequency * v.x + 0.4) * std::sin(frequency * v.y + 1.1) * std::sin(frequency * v.z + 2.3);
        v *= radius * (1.0 + amplitude * h);
    }
    TriangleMesh<F> out;
    out.vertices.reserve(m.vertices.size());
    for (const auto& v : m.vertices) out.vertices.emplace_back(Vec3<F>(v));
    out.triangles = m.triangles;
    out.compute_face_normals();
    return out;
}

}  // namespace grainlight
