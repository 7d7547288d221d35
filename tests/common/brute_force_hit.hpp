// The closest hit of a ray over every triangle of a mesh with the watertight test of
// geometry/bvh.hpp (t in (0, t_max); among equal t the first triangle in mesh order): the
// independent reference of the BVH and cone-walk tests.
#pragma once

#include <cstddef>
#include <cstdint>

#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight_test {

/// Brute-force closest hit: t, prim (mesh index) and barycentrics; invalid if nothing is hit.
inline grainlight::TriangleHit<float> brute_force_hit(const grainlight::TriangleMesh<float>& mesh,
                                                      const grainlight::Vec3f& o, const grainlight::Vec3f& d,
                                                      float t_max) {
    const grainlight::WatertightRay<float> wr(o, d);
    grainlight::TriangleHit<float> best;
    float closest = t_max;
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const auto q = mesh.corners(i);
        float t, b1, b2;
        if (grainlight::intersect_triangle_watertight(wr, q[0], q[1], q[2], 0.0f, closest, t, b1, b2)) {
            closest = t;
            best.t = t;
            best.prim = std::uint32_t(i);
            best.b1 = b1;
            best.b2 = b2;
        }
    }
    return best;
}

}  // namespace grainlight_test
