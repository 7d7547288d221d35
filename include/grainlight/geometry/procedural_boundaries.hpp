/// @file grainlight/geometry/procedural_boundaries.hpp
/// Closed triangle meshes for aggregate boundaries of procedural stand-in scenes (Meng15's
/// scenes are modelled meshes we do not have): surfaces of revolution about +y from a radius
/// profile rho(y), and the snowman of Meng15 Fig. 13 built from it (three overlapping balls, the
/// bottom one cut flat). Watertight with outward normals, so MeshBoundary, MeshDistance and
/// MeshShape accept them (the hybrid's add_mesh_boundary).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// Surface of revolution about +y from y = 0 to y = top: a flat disk of radius rho(0) at y = 0
/// (a single point if rho(0) = 0 is not allowed: rho(0) > 0), `rings` rings at
/// y_k = top sin(pi/2 k / rings) (denser towards the top pole), `segments` vertices per ring,
/// and a pole vertex at (0, top, 0). rho(y) must be > 0 on [0, top) (values below 1e-6 top are
/// raised to it). Throws grainlight::invalid_argument for rings < 2, segments < 3, top <= 0.
[[nodiscard]] inline TriangleMesh<double> make_revolution_mesh(const std::function<double(double)>& rho, double top,
                                                               int rings, int segments) {
    check_argument(rings >= 2, "make_revolution_mesh", "rings", rings, ">= 2");
    check_argument(segments >= 3, "make_revolution_mesh", "segments", segments, ">= 3");
    check_argument(std::isfinite(top) && top > 0, "make_revolution_mesh", "top", top, "(0, inf)");
    TriangleMesh<double> mesh;
    mesh.vertices.push_back(Vec3d(0.0));  // bottom centre
    for (int k = 0; k < rings; ++k) {
        const double y = top * std::sin(0.5 * pi_v<double> * double(k) / double(rings));
        const double r = std::max(rho(y), 1e-6 * top);
        for (int j = 0; j < segments; ++j) {
            const double phi = 2.0 * pi_v<double> * double(j) / double(segments);
            mesh.vertices.emplace_back(r * std::cos(phi), y, r * std::sin(phi));
        }
    }
    mesh.vertices.emplace_back(0.0, top, 0.0);
    const auto ring = [&](int k, int j) { return std::uint32_t(1 + k * segments + (j % segments)); };
    const auto pole = std::uint32_t(mesh.vertices.size() - 1);
    for (int j = 0; j < segments; ++j) mesh.triangles.push_back({0u, ring(0, j), ring(0, j + 1)});
    for (int k = 0; k + 1 < rings; ++k)
        for (int j = 0; j < segments; ++j) {
            mesh.triangles.push_back({ring(k, j), ring(k + 1, j), ring(k + 1, j + 1)});
            mesh.triangles.push_back({ring(k, j), ring(k + 1, j + 1), ring(k, j + 1)});
        }
    for (int j = 0; j < segments; ++j) mesh.triangles.push_back({ring(rings - 1, j), pole, ring(rings - 1, j + 1)});
    if (mesh.signed_volume() < 0)
        for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
    mesh.compute_face_normals();
    mesh.validate("make_revolution_mesh");
    return mesh;
}

/// Radii and centre heights (units of the total height) of the snowman's three balls.
struct SnowmanBalls {
    double radius[3];  ///< ball radii, bottom to top (units of the unscaled height `top`)
    double center[3];  ///< ball centre heights on the y axis (same units)
    double top;  ///< height of the top pole before scaling (the mesh is scaled to height H)
};

/// The snowman's balls: radii 0.23, 0.165, 0.115 (bottom to top), the bottom ball cut at 85 %
/// of its radius below its centre, neighbouring balls overlapping by 20 % of their radius sum.
[[nodiscard]] inline SnowmanBalls snowman_balls() noexcept {
    SnowmanBalls b{{0.23, 0.165, 0.115}, {0, 0, 0}, 0};
    b.center[0] = 0.85 * b.radius[0];
    b.center[1] = b.center[0] + 0.8 * (b.radius[0] + b.radius[1]);
    b.center[2] = b.center[1] + 0.8 * (b.radius[1] + b.radius[2]);
    b.top = b.center[2] + b.radius[2];
    return b;
}

/// Meng15 Fig. 13's snowman as one closed mesh of height H standing on y = 0 (flat bottom),
/// the union of three balls as a surface of revolution about +y (make_revolution_mesh).
[[nodiscard]] inline TriangleMesh<double> make_snowman_mesh(double H, int rings = 96, int segments = 64) {
    check_argument(std::isfinite(H) && H > 0, "make_snowman_mesh", "H", H, "(0, inf)");
    const SnowmanBalls b = snowman_balls();
    const double s = H / b.top;
    auto rho = [&](double y) {
        const double yu = y / s;
        double m = 0;
        for (int i = 0; i < 3; ++i) {
            const double dy = yu - b.center[i];
            m = std::max(m, std::sqrt(std::max(0.0, b.radius[i] * b.radius[i] - dy * dy)));
        }
        return s * m;
    };
    return make_revolution_mesh(rho, H, rings, segments);
}

}  // namespace grainlight
