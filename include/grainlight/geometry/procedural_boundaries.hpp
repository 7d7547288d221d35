/// @file grainlight/geometry/procedural_boundaries.hpp
/// Closed triangle meshes for aggregate boundaries of procedural stand-in scenes (Meng15's
/// scenes are modelled meshes we do not have): surfaces of revolution about +y from a radius
/// profile rho(y), and the snowman of Meng15 Fig. 13 built from it (three overlapping balls, the
/// bottom one cut flat), spice heaps (Fig. 12) and a heightfield sandcastle (Fig. 1). Watertight with outward normals, so MeshBoundary, MeshDistance and
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

/// A heap of granular material (Meng15 Fig. 12's spice heaps) of base radius `radius` and
/// height `height` standing on y = 0: the surface of revolution rho(y) = radius (1 - y /
/// height)^0.75, a cone whose apex is rounded (the slope flattens towards the top) and whose
/// flank near the ground is at about atan(4/3 height / radius) to the horizontal. Throws
/// grainlight::invalid_argument for radius or height not in (0, inf).
[[nodiscard]] inline TriangleMesh<double> make_heap_mesh(double radius, double height, int rings = 64, int segments = 64) {
    check_argument(std::isfinite(radius) && radius > 0, "make_heap_mesh", "radius", radius, "(0, inf)");
    check_argument(std::isfinite(height) && height > 0, "make_heap_mesh", "height", height, "(0, inf)");
    auto rho = [&](double y) { return radius * std::pow(std::max(0.0, 1.0 - y / height), 0.75); };
    return make_revolution_mesh(rho, height, rings, segments);
}

/// Closed mesh of the solid 0 <= y <= h(x, z) over the rectangle [x0, x1] x [z0, z1]: a top grid
/// of (nx + 1) x (nz + 1) vertices at y = h(x, z), a flat bottom grid at y = 0 and four vertical
/// side walls; outward normals. A union of shapes that are "vertically convex" (cylinders, cones,
/// boxes standing on the ground) is the heightfield of the maximum of their heights, so this is
/// CSG union for a sandcastle. h must be > 0 on the rectangle (values below 1e-6 of the larger
/// side are raised to it). Throws grainlight::invalid_argument for nx or nz < 1 or an empty
/// rectangle.
[[nodiscard]] inline TriangleMesh<double> make_heightfield_mesh(const std::function<double(double, double)>& h, double x0,
                                                                double x1, double z0, double z1, int nx, int nz) {
    check_argument(nx >= 1, "make_heightfield_mesh", "nx", nx, ">= 1");
    check_argument(nz >= 1, "make_heightfield_mesh", "nz", nz, ">= 1");
    check_argument(std::isfinite(x0) && std::isfinite(x1) && x1 > x0, "make_heightfield_mesh", "x1 - x0", x1 - x0, "(0, inf)");
    check_argument(std::isfinite(z0) && std::isfinite(z1) && z1 > z0, "make_heightfield_mesh", "z1 - z0", z1 - z0, "(0, inf)");
    const double hmin = 1e-6 * std::max(x1 - x0, z1 - z0);
    TriangleMesh<double> mesh;
    const int sx = nx + 1, sz = nz + 1;
    const auto top = [&](int i, int j) { return std::uint32_t(i * sz + j); };
    const auto bot = [&](int i, int j) { return std::uint32_t(sx * sz + i * sz + j); };
    for (int layer = 0; layer < 2; ++layer)
        for (int i = 0; i < sx; ++i)
            for (int j = 0; j < sz; ++j) {
                const double x = x0 + (x1 - x0) * double(i) / double(nx), z = z0 + (z1 - z0) * double(j) / double(nz);
                mesh.vertices.emplace_back(x, layer == 0 ? std::max(h(x, z), hmin) : 0.0, z);
            }
    for (int i = 0; i < nx; ++i)
        for (int j = 0; j < nz; ++j) {
            // Top: normal +y; bottom: normal -y.
            mesh.triangles.push_back({top(i, j), top(i + 1, j + 1), top(i + 1, j)});
            mesh.triangles.push_back({top(i, j), top(i, j + 1), top(i + 1, j + 1)});
            mesh.triangles.push_back({bot(i, j), bot(i + 1, j), bot(i + 1, j + 1)});
            mesh.triangles.push_back({bot(i, j), bot(i + 1, j + 1), bot(i, j + 1)});
        }
    // Side walls: quads between the border edges of the top and bottom grids, each triangle
    // oriented so that its normal points along the wall's outward axis.
    const auto wall = [&](std::uint32_t ta, std::uint32_t tb, std::uint32_t ba, std::uint32_t bb, const Vec3d& out) {
        const auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
            const Vec3d n = glm::cross(mesh.vertices[b] - mesh.vertices[a], mesh.vertices[c] - mesh.vertices[a]);
            if (glm::dot(n, out) >= 0)
                mesh.triangles.push_back({a, b, c});
            else
                mesh.triangles.push_back({a, c, b});
        };
        add(ba, bb, tb);
        add(ba, tb, ta);
    };
    for (int i = 0; i < nx; ++i) {
        wall(top(i, 0), top(i + 1, 0), bot(i, 0), bot(i + 1, 0), Vec3d(0, 0, -1));
        wall(top(i, nz), top(i + 1, nz), bot(i, nz), bot(i + 1, nz), Vec3d(0, 0, 1));
    }
    for (int j = 0; j < nz; ++j) {
        wall(top(0, j), top(0, j + 1), bot(0, j), bot(0, j + 1), Vec3d(-1, 0, 0));
        wall(top(nx, j), top(nx, j + 1), bot(nx, j), bot(nx, j + 1), Vec3d(1, 0, 0));
    }
    mesh.compute_face_normals();
    mesh.validate("make_heightfield_mesh");
    return mesh;
}

/// Height (units of the castle's half-width, before scaling) of the procedural sandcastle of
/// Meng15 Fig. 1's stand-in at (x, z) in [-1, 1]^2: a low sand base (0.06), a square curtain
/// wall (boxes 0.12 thick, 0.38 high, crenellated: +0.06 on alternate 0.1-wide merlons) between
/// four corner towers (cylinders of radius 0.17, 0.62 high, cone roofs 0.28 high) and a central
/// keep (radius 0.26, 0.8 high, cone roof 0.34 high): the maximum of the shapes' heights (CSG
/// union of vertically convex shapes).
[[nodiscard]] inline double sandcastle_height(double x, double z) noexcept {
    double h = (std::abs(x) < 0.95 && std::abs(z) < 0.95) ? 0.06 : 0.02;
    const auto tower = [&](double cx, double cz, double r, double body, double roof) {
        const double d = std::hypot(x - cx, z - cz);
        if (d < r) h = std::max(h, body + roof * (1.0 - d / r));
    };
    const double c = 0.62, half = 0.06;
    // Curtain walls along the square |x| = c or |z| = c, between the towers.
    const auto merlon = [](double t) { return (int(std::floor(t / 0.1)) & 1) ? 0.06 : 0.0; };
    if (std::abs(std::abs(x) - c) < half && std::abs(z) < c) h = std::max(h, 0.38 + merlon(z + 1.0));
    if (std::abs(std::abs(z) - c) < half && std::abs(x) < c) h = std::max(h, 0.38 + merlon(x + 1.0));
    for (double sx : {-c, c})
        for (double sz : {-c, c}) tower(sx, sz, 0.17, 0.62, 0.28);
    tower(0.0, 0.0, 0.26, 0.80, 0.34);
    return h;
}

/// The procedural sandcastle (sandcastle_height) as one closed mesh: footprint [-S, S]^2 with S
/// = `half_width`, heights scaled by S, standing on y = 0; an n x n heightfield grid
/// (make_heightfield_mesh). Its total height is 1.14 S.
[[nodiscard]] inline TriangleMesh<double> make_sandcastle_mesh(double half_width, int n = 192) {
    check_argument(std::isfinite(half_width) && half_width > 0, "make_sandcastle_mesh", "half_width", half_width, "(0, inf)");
    const double s = half_width;
    return make_heightfield_mesh([s](double x, double z) { return s * sandcastle_height(x / s, z / s); }, -s, s, -s, s, n, n);
}

}  // namespace grainlight
