/// @file grainlight/geometry/star_mesh.hpp
/// First-hit queries on a closed mesh that is star-shaped around the origin, by walking the
/// cones of its triangles along the ray.
///
/// Every procedural grain (geometry/grains.hpp) is a subdivided icosahedron whose vertices are
/// pushed along their directions: seen from the origin, each triangle covers a cone (the positive
/// span of its three vertices), and the cones of all triangles tile space without overlap. Inside
/// the cone of triangle f the only surface is f itself. A ray o + t d therefore meets the cones in
/// order of t, and the first triangle hit is found by testing one triangle per cone along the ray,
/// stopping at the first hit: the triangles tested are those the ray passes over (seen from the
/// origin), not the branches of a tree. For a ray entering a grain from its bounding sphere, the
/// hit is usually in the first or second cone.
///
/// The walk is combinatorial, so round-off cannot make it skip a cone: the ray and the origin span
/// a plane with normal m = o x d; every vertex gets the side sign(m . v) once per query (0 counts
/// as +), and a cone is left through the one edge of it, other than the entry edge, whose vertices
/// have opposite signs. This is the walk of a slightly perturbed plane, the same for the
/// neighbouring triangles. Triangles the float ray test could still report (a vertex within
/// round-off of the plane) are tested as a whole fan around that vertex. The triangle test is
/// the watertight one of geometry/bvh.hpp on the same float ray, so a hit found here has the bits
/// the BVH reports for the same triangle.
///
/// `StarMesh::build` checks that a mesh has this structure (closed 2-manifold, every triangle
/// oriented counter-clockwise seen from the origin, cones covering the sphere once) and returns
/// an empty optional otherwise; `intersect` returns `false` when it cannot decide (a ray through
/// the origin, a walk longer than its step budget) so the caller can ask its BVH instead.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// Cone-walk index of a closed triangle mesh star-shaped around the origin (see the file comment).
/// Immutable after `build`; queries are const and thread-safe.
class StarMesh {
public:
    /// Cube-map resolution of the start-triangle lookup (per face side).
    static constexpr int lookup_resolution = 8;

    /// The index of `mesh`, or nothing if the mesh is not a closed 2-manifold whose triangles are
    /// all counter-clockwise seen from the origin with cones that cover the sphere exactly once
    /// (total solid angle 4 pi).
    [[nodiscard]] static std::optional<StarMesh> build(const TriangleMesh<float>& mesh) {
        const std::size_t nt = mesh.triangles.size(), nv = mesh.vertices.size();
        if (nt < 4 || nv < 4 || nt >= std::size_t(1) << 30) return std::nullopt;
        StarMesh s;
        s.vertex_.resize(nv);
        for (std::size_t i = 0; i < nv; ++i) {
            s.vertex_[i] = Vec3d(mesh.vertices[i]);
            s.vertex_len2_.push_back(glm::dot(s.vertex_[i], s.vertex_[i]));
            if (!(glm::dot(s.vertex_[i], s.vertex_[i]) > 0) || !std::isfinite(glm::dot(s.vertex_[i], s.vertex_[i])))
                return std::nullopt;
        }
        s.tri_.resize(nt);
        s.corner_.resize(nt);
        s.normal_.resize(nt);
        s.edge_normal_.resize(nt);
        double solid_angle = 0;
        for (std::size_t f = 0; f < nt; ++f) {
            const auto& t = mesh.triangles[f];
            for (int k = 0; k < 3; ++k)
                if (t[std::size_t(k)] >= nv) return std::nullopt;
            s.tri_[f] = t;
            s.corner_[f] = mesh.corners(f);
            const Vec3<float> g = glm::cross(s.corner_[f][1] - s.corner_[f][0], s.corner_[f][2] - s.corner_[f][0]);
            const float len = glm::length(g);
            s.normal_[f] = len > 0.0f ? g / len : Vec3<float>(0.0f, 0.0f, 1.0f);
            const Vec3d a = s.vertex_[t[0]], b = s.vertex_[t[1]], c = s.vertex_[t[2]];
            // The triangle lies within its farthest vertex's distance of the origin (with a margin
            // far above the float round-off of the ray test).
            s.reach2_.push_back(std::max({glm::dot(a, a), glm::dot(b, b), glm::dot(c, c)}) * (1 + 1e-5));
            // Counter-clockwise seen from the origin <=> positive triple product (a, b, c).
            const double det = glm::dot(glm::cross(a, b), c);
            if (!(det > 0)) return std::nullopt;
            // Inward normals of the cone's three faces: n_k = v_k x v_{k+1}.
            s.edge_normal_[f] = {glm::cross(a, b), glm::cross(b, c), glm::cross(c, a)};
            // Solid angle of the cone (Van Oosterom & Strackee 1983).
            const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
            const double den = la * lb * lc + glm::dot(a, b) * lc + glm::dot(a, c) * lb + glm::dot(b, c) * la;
            solid_angle += 2 * std::atan2(det, den);
        }
        if (!(std::abs(solid_angle - 4 * 3.14159265358979323846) < 1e-6 * 4 * 3.14159265358979323846))
            return std::nullopt;
        // Neighbours across each edge: edge k of f is (v_k, v_{k+1}); its twin is (v_{k+1}, v_k).
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::pair<std::uint32_t, std::uint8_t>> half;
        for (std::size_t f = 0; f < nt; ++f)
            for (int k = 0; k < 3; ++k) {
                const auto key = std::make_pair(s.tri_[f][std::size_t(k)], s.tri_[f][std::size_t((k + 1) % 3)]);
                if (!half.emplace(key, std::make_pair(std::uint32_t(f), std::uint8_t(k))).second) return std::nullopt;
            }
        s.neighbor_.resize(nt);
        for (std::size_t f = 0; f < nt; ++f)
            for (int k = 0; k < 3; ++k) {
                const auto it =
                    half.find(std::make_pair(s.tri_[f][std::size_t((k + 1) % 3)], s.tri_[f][std::size_t(k)]));
                if (it == half.end()) return std::nullopt;  // open or non-manifold
                const std::uint32_t g = it->second.first;
                const std::uint8_t j = it->second.second;
                s.neighbor_[f][std::size_t(k)] = {g, s.tri_[g][std::size_t((j + 2) % 3)], j};
            }
        // Vertex fans (triangles around each vertex), compressed rows.
        s.fan_start_.assign(nv + 1, 0);
        for (const auto& t : s.tri_)
            for (auto v : t) ++s.fan_start_[v + 1];
        for (std::size_t v = 0; v < nv; ++v) s.fan_start_[v + 1] += s.fan_start_[v];
        s.fan_.resize(3 * nt);
        std::vector<std::uint32_t> fill(s.fan_start_.begin(), s.fan_start_.end() - 1);
        for (std::size_t f = 0; f < nt; ++f)
            for (auto v : s.tri_[f]) s.fan_[fill[v]++] = std::uint32_t(f);
        // Start triangles: for each cube-map cell, a triangle whose cone holds the cell's centre.
        s.lookup_.resize(6 * lookup_resolution * lookup_resolution);
        for (int face = 0; face < 6; ++face)
            for (int j = 0; j < lookup_resolution; ++j)
                for (int i = 0; i < lookup_resolution; ++i) {
                    const double u = (i + 0.5) / lookup_resolution * 2 - 1, w = (j + 0.5) / lookup_resolution * 2 - 1;
                    Vec3d p(0.0);
                    const int axis = face >> 1;
                    p[axis] = (face & 1) ? -1.0 : 1.0;
                    p[(axis + 1) % 3] = u;
                    p[(axis + 2) % 3] = w;
                    std::uint32_t best = 0;
                    double best_margin = -std::numeric_limits<double>::infinity();
                    for (std::size_t f = 0; f < nt; ++f) {
                        double margin = std::numeric_limits<double>::infinity();
                        for (const auto& n : s.edge_normal_[f]) margin = std::min(margin, glm::dot(n, p) / glm::length(n));
                        if (margin > best_margin) {
                            best_margin = margin;
                            best = std::uint32_t(f);
                        }
                    }
                    s.lookup_[std::size_t((face * lookup_resolution + j) * lookup_resolution + i)] = best;
                }
        s.max_steps_ = int(std::min<std::size_t>(4 * nt + 64, 1u << 20));
        return s;
    }

    /// Number of triangles.
    [[nodiscard]] std::size_t triangle_count() const noexcept { return tri_.size(); }
    /// Bytes of the index (vertices, triangles, cone normals, neighbours, fans, lookup).
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        return vertex_.size() * (sizeof(Vec3d) + sizeof(double)) + reach2_.size() * sizeof(double) +
               tri_.size() * (sizeof(tri_[0]) + sizeof(corner_[0]) + sizeof(normal_[0]) + sizeof(edge_normal_[0]) +
                              sizeof(neighbor_[0])) +
               fan_.size() * sizeof(std::uint32_t) + fan_start_.size() * sizeof(std::uint32_t) +
               lookup_.size() * sizeof(std::uint32_t);
    }

    /// Closest hit with t in (0, t_max) along o + t d (t in units of d), as Bvh<float>::intersect
    /// reports it (`prim` is the mesh's triangle index). Returns true when the walk decided: then
    /// `hit.valid()` tells whether a triangle was hit. Returns false when it did not: the ray
    /// passes through the origin (`t_resume` = 0, `hit` invalid), or more than `max_steps`
    /// triangles were tested (`max_steps` < 0: no limit but the mesh's own bound); then every hit with t below
    /// `t_resume` is already in `hit` (the closest of them, if any), and the caller finishes the
    /// query on (t_resume, hit.t or t_max) with its BVH. Cones whose triangle lies entirely nearer
    /// the origin than the ray's line are crossed without a test and do not count.
    [[nodiscard]] bool intersect(const Vec3<float>& o, const Vec3<float>& d, float t_max, TriangleHit<float>& hit,
                                 float& t_resume, int max_steps = -1) const noexcept {
        hit = TriangleHit<float>{};
        t_resume = 0.0f;
        const Vec3d od(o), dd(d);
        const Vec3d m = glm::cross(od, dd);
        const double mm = glm::dot(m, m), oo = glm::dot(od, od), ddd = glm::dot(dd, dd);
        // A plane through the origin needs the ray to miss the origin by more than round-off.
        if (!(mm > 1e-18 * oo * ddd) || !(oo > 1e-24)) return false;
        std::uint32_t f = 0;
        if (!locate(od, f)) return false;
        const WatertightRay<float> wr(o, d);
        float closest = t_max;
        // p_far: the ray point at the closest hit so far (slightly beyond it): a later cone can
        // hold a nearer hit only if p_far lies beyond the current cone's exit face.
        Vec3d p_far = od + double(closest) * (1 + 1e-6) * dd;
        auto test = [&](std::uint32_t tri) {
            float t, b1, b2;
            const auto& c = corner_[tri];
            if (intersect_triangle_watertight(wr, c[0], c[1], c[2], 0.0f, closest, t, b1, b2)) {
                closest = t;
                hit.t = t;
                hit.prim = tri;
                hit.b1 = b1;
                hit.b2 = b2;
                hit.n_geom = normal_[tri];
                p_far = od + double(t) * (1 + 1e-6) * dd;
            }
        };
        // Vertex side s = m . v (its sign; 0 counts as +); a vertex within round-off of the plane
        // has its whole fan tested.
        const double near2 = near_tolerance * near_tolerance * mm;
        auto side = [&](std::uint32_t v) {
            const double s = glm::dot(m, vertex_[v]);
            if (s * s <= near2 * vertex_len2_[v])
                for (std::uint32_t k = fan_start_[v]; k < fan_start_[v + 1]; ++k) test(fan_[k]);
            return s >= 0;
        };
        // Start cone: of its two straddling faces, leave through the first one crossed going
        // forward (a face the line never crosses forward is not an exit).
        std::array<bool, 3> sd{};
        for (int k = 0; k < 3; ++k) sd[std::size_t(k)] = side(tri_[f][std::size_t(k)]);
        // When the line crosses face k of cone tri going forward (+inf if it never does).
        auto exit_time = [&](std::uint32_t tri, int k) {
            const Vec3d& n = edge_normal_[tri][std::size_t(k)];
            const double rate = glm::dot(n, dd);
            return rate < 0 ? std::max(0.0, -glm::dot(n, od) / rate) : std::numeric_limits<double>::infinity();
        };
        int exit = -1;
        double t_exit = std::numeric_limits<double>::infinity();
        int straddling = 0;
        for (int k = 0; k < 3; ++k) {
            if (sd[std::size_t(k)] == sd[std::size_t((k + 1) % 3)]) continue;
            ++straddling;
            const double te = exit_time(f, k);
            if (exit < 0 || te < t_exit) {
                exit = k;
                t_exit = te;
            }
        }
        if (straddling != 2) return false;  // the plane grazes a vertex of the start cone
        // Side of vertex tri_[f][exit]: the walk carries it (the shared edge's signs are known).
        bool side_exit_start = sd[std::size_t(exit)];
        const int budget = max_steps < 0 ? max_steps_ : max_steps;
        // A ray whose line passes farther from the origin than a triangle's farthest vertex cannot
        // hit it: such cones are crossed without a test (most of the walk of a ray that misses).
        const double line2 = mm / ddd;
        int tested = 0;
        for (int step = 0;; ++step) {
            if (line2 <= reach2_[f]) {
                test(f);
                ++tested;
            }
            // Every later cone starts on the exit face: continue only if the closest hit so far
            // lies beyond it.
            if (!(glm::dot(edge_normal_[f][std::size_t(exit)], p_far) < 0)) break;
            if (tested > budget || step >= max_steps_) {
                // The cones up to this one are done: resume at its exit face, a little before.
                const double te = exit_time(f, exit);
                t_resume = te < std::numeric_limits<double>::infinity() ? float(te * (1 - 1e-6)) : 0.0f;
                return false;
            }
            const Neighbor& nb = neighbor_[f][std::size_t(exit)];
            // In g the shared edge is j = (b, a) with a = tri_[f][exit]; the third vertex c
            // decides which other face straddles: (a, c) if c is on the other side of a, else (c, b).
            const bool side_a = side_exit_start;
            const bool side_c = side(nb.opposite);
            static constexpr int next[3] = {1, 2, 0}, prev[3] = {2, 0, 1};
            if (side_c != side_a) {
                exit = next[nb.edge];  // face (a, c): its first vertex is a
            } else {
                exit = prev[nb.edge];  // face (c, b): its first vertex is c
                side_exit_start = side_c;
            }
            f = nb.triangle;
        }
        return true;
    }

private:
    /// Relative distance of a vertex from the ray's plane below which its whole fan is tested.
    static constexpr double near_tolerance = 1e-5;

    // The cone holding direction p: a cube-map guess, then a visibility walk.
    [[nodiscard]] bool locate(const Vec3d& p, std::uint32_t& f) const noexcept {
        const Vec3d a = glm::abs(p);
        const int axis = (a.x >= a.y) ? (a.x >= a.z ? 0 : 2) : (a.y >= a.z ? 1 : 2);
        const double inv = 1.0 / a[axis];
        const int face = 2 * axis + (p[axis] < 0 ? 1 : 0);
        auto cell = [](double x) {
            const int i = int((x + 1) * 0.5 * lookup_resolution);
            return std::clamp(i, 0, lookup_resolution - 1);
        };
        const int i = cell(p[(axis + 1) % 3] * inv), j = cell(p[(axis + 2) % 3] * inv);
        f = lookup_[std::size_t((face * lookup_resolution + j) * lookup_resolution + i)];
        for (int step = 0; step < 64; ++step) {
            int worst = -1;
            double worst_s = 0;
            for (int k = 0; k < 3; ++k) {
                const double s = glm::dot(edge_normal_[f][std::size_t(k)], p);
                if (s < worst_s) {
                    worst_s = s;
                    worst = k;
                }
            }
            if (worst < 0) return true;
            f = neighbor_[f][std::size_t(worst)].triangle;
        }
        return false;
    }

    std::vector<Vec3d> vertex_;
    std::vector<double> vertex_len2_;
    std::vector<double> reach2_;
    std::vector<std::array<std::uint32_t, 3>> tri_;
    std::vector<std::array<Vec3<float>, 3>> corner_;
    std::vector<Vec3<float>> normal_;
    std::vector<std::array<Vec3d, 3>> edge_normal_;
    // The triangle across a face of a cone, the index of that face in it, and its vertex opposite.
    struct Neighbor {
        std::uint32_t triangle = 0, opposite = 0;
        std::uint8_t edge = 0;
    };
    std::vector<std::array<Neighbor, 3>> neighbor_;
    std::vector<std::uint32_t> fan_start_, fan_;
    std::vector<std::uint32_t> lookup_;
    int max_steps_ = 0;
};

/// The closest hit of a mesh with its BVH and, if the mesh is star-shaped, its cone walk
/// (`star` may be null): the walk with a budget of `max_steps` triangle tests, then the BVH on the
/// part of the ray the walk handed over (or the whole ray). The same hit as `bvh.intersect(o, d,
/// 0, t_max)` except at exact vertex / edge ties (see StarMesh::intersect).
[[nodiscard]] inline TriangleHit<float> intersect_star_then_bvh(const StarMesh* star, const Bvh<float>& bvh,
                                                               const Vec3<float>& o, const Vec3<float>& d, float t_max,
                                                               int max_steps) noexcept {
    TriangleHit<float> h;
    float t_resume = 0.0f;
    if (star && star->intersect(o, d, t_max, h, t_resume, max_steps)) return h;
    const auto hb = bvh.intersect(o, d, t_resume, h.valid() ? h.t : t_max);
    return hb.valid() ? hb : h;
}

}  // namespace grainlight
