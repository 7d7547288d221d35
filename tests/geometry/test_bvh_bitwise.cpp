// Every BVH hit must be the scalar watertight test's (Woop et al. 2013), bit for bit: the same t
// and barycentrics as intersect_triangle_watertight on the reported triangle, and the same closest
// t as a brute-force loop over the mesh, including rays through shared edges and vertices (where
// an edge function is exactly 0 and the double-precision path decides). Guards any change of the
// BVH's leaf layout or traversal (a 4-wide leaf test passed it; see docs/performance.md).
#include <catch2/catch.hpp>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "common/brute_force_hit.hpp"
#include "grainlight/geometry.hpp"

using namespace grainlight;

namespace {

// A flat n x n grid of unit quads on z = 0 (two triangles each, integer corners), plus a second
// grid at z = 1 so that rays see several candidate triangles.
TriangleMesh<float> grid_mesh(int n) {
    TriangleMesh<float> m;
    for (int layer = 0; layer < 2; ++layer) {
        const auto base = std::uint32_t(m.vertices.size());
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) m.vertices.emplace_back(float(i), float(j), float(layer));
        auto id = [&](int i, int j) { return base + std::uint32_t(j * (n + 1) + i); };
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
                m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
            }
    }
    m.compute_face_normals();
    return m;
}

struct Counts {
    int rays = 0, hits = 0, mismatches = 0;
};

// Compare one BVH query with the scalar test (bit for bit) and with brute force.
void check_ray(const TriangleMesh<float>& mesh, const Bvh<float>& bvh, const Vec3f& o, const Vec3f& d, float t_max,
               Counts& c) {
    ++c.rays;
    const WatertightRay<float> wr(o, d);
    const auto ref = grainlight_test::brute_force_hit(mesh, o, d, t_max);
    const float best = ref.t;
    const bool any = ref.valid();
    const auto h = bvh.intersect(o, d, 0.0f, t_max);
    if (h.valid() != any || bvh.occluded(o, d, 0.0f, t_max) != any) {
        ++c.mismatches;
        return;
    }
    if (!any) return;
    ++c.hits;
    const auto q = mesh.corners(h.prim);
    float t, b1, b2;
    const bool again = intersect_triangle_watertight(wr, q[0], q[1], q[2], 0.0f, t_max, t, b1, b2);
    if (!again || t != h.t || b1 != h.b1 || b2 != h.b2 || h.t != best) ++c.mismatches;
}

}  // namespace

TEST_CASE("BVH hits are the scalar watertight test's, bit for bit", "[geometry][bvh]") {
    SECTION("procedural grains, random rays") {
        for (GrainShape shape : {GrainShape::snow, GrainShape::crystal, GrainShape::flake}) {
            const auto mesh = make_grain_mesh<float>(shape, 0.9f, 11, 4);
            const Bvh<float> bvh(mesh);
            Pcg32 rng = Pcg32::from_key(7, std::uint64_t(shape));
            Counts c;
            for (int k = 0; k < 3000; ++k) {
                const Vec3f o = (k % 4 == 0 ? 0.2f : 1.5f) * sample_uniform_sphere(rng.uniform2<float>());
                const Vec3f target = 0.6f * (rng.uniform3<float>() -
                                             Vec3f(0.5f));
                const Vec3f d = (k % 2 ? 3.0f : 1.0f) * glm::normalize(target - o);  // non-unit too
                check_ray(mesh, bvh, o, d, k % 3 == 0 ? 0.9f : 100.0f, c);
            }
            CHECK(c.mismatches == 0);
            CHECK(c.hits > 1500);
        }
    }
    SECTION("grid: rays through shared edges and vertices (edge functions exactly 0)") {
        const auto mesh = grid_mesh(6);
        const Bvh<float> bvh(mesh);
        Counts c;
        // Axis-aligned rays through every corner, edge midpoint and diagonal point of the grid,
        // both directions, and slightly tilted rays through the same points.
        for (int j = 0; j <= 24; ++j)
            for (int i = 0; i <= 24; ++i) {
                const float x = float(i) / 4.0f, y = float(j) / 4.0f;
                check_ray(mesh, bvh, Vec3f(x, y, 3.0f), Vec3f(0, 0, -1), 100.0f, c);
                check_ray(mesh, bvh, Vec3f(x, y, -2.0f), Vec3f(0, 0, 2), 100.0f, c);
                check_ray(mesh, bvh, Vec3f(x, y, 0.5f), Vec3f(0, 0, -1), 100.0f, c);
                check_ray(mesh, bvh, Vec3f(x - 0.5f, y - 0.25f, 3.0f), Vec3f(0.25f, 0.125f, -1.5f), 100.0f, c);
            }
        CHECK(c.mismatches == 0);
        CHECK(c.hits > 1500);
    }
}
