// Voxelized aggregate boundary (Meng15 Sec. 3.2): classification of tile-sized voxels against
// analytic shapes and triangle meshes, point-inside tests, memory of 2 bits per voxel, errors.
#include <catch2/catch.hpp>

#include <cmath>

#include "grainlight/core/rng.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"

using namespace grainlight;

namespace {

template <class Shape, class Truth>
void check_classes_against(const VoxelizedBoundary<Shape>& vb, Truth&& truth_inside, int samples_per_voxel,
                           std::uint64_t seed) {
    // Every corner and random samples of an "inside" voxel are inside the analytic truth; those of
    // an "outside" voxel are outside; a "partial" voxel has both (checked on the analytic shape
    // only when it is exact; here: at least it must not be classified wrongly the other way).
    const auto& d = vb.dims();
    const auto& lo = vb.grid_lo();
    const double L = vb.tile_side();
    Rng rng = Rng::from_key(seed, 1, 2);
    std::size_t checked = 0;
    for (std::int64_t k = 0; k < d[2]; ++k)
        for (std::int64_t j = 0; j < d[1]; ++j)
            for (std::int64_t i = 0; i < d[0]; ++i) {
                const Vec3i64 t = vb.anchor() + Vec3i64(lo[0] + i, lo[1] + j, lo[2] + k);
                const VoxelClass c = vb.classify(t);
                if (c == VoxelClass::partial) continue;
                const Vec3d corner = L * Vec3d(double(lo[0] + i), double(lo[1] + j), double(lo[2] + k));
                for (int s = 0; s < 8 + samples_per_voxel; ++s) {
                    Vec3d q;
                    if (s < 8)
                        q = corner + L * Vec3d(s & 1, (s >> 1) & 1, (s >> 2) & 1);
                    else
                        q = corner + L * rng.uniform3<double>();
                    const bool in = truth_inside(q);
                    if (c == VoxelClass::inside && s >= 8) REQUIRE(in);
                    if (c == VoxelClass::outside && s >= 8) REQUIRE_FALSE(in);
                    ++checked;
                }
            }
    REQUIRE(checked > 0);
}

}  // namespace

TEST_CASE("voxelized sphere: classes agree with the analytic sphere and 2 bits per voxel", "[aggregates][voxel]") {
    const SphereBoundary s(Vec3d(0.3, -0.2, 0.1), 5.3);
    const VoxelizedBoundary<SphereBoundary> vb(s, 1.0);
    check_classes_against(vb, [&](const Vec3d& p) { return glm::length(p - s.center) < s.radius; }, 4, 1);
    // Inside voxel count is close to the sphere volume (fraction of voxels inside ~ volume).
    const double vol = 4.0 / 3.0 * 3.14159265358979 * std::pow(s.radius, 3);
    REQUIRE(double(vb.inside_count()) < vol);
    REQUIRE(double(vb.inside_count() + vb.partial_count()) > vol);
    // Every voxel whose farthest corner is inside must be 'inside' (exact classification).
    REQUIRE(vb.classify(Vec3i64(0, 0, 0)) == VoxelClass::inside);
    REQUIRE(vb.classify(Vec3i64(100, 0, 0)) == VoxelClass::outside);
    // Memory: 2 bits per voxel (32 voxels per 64-bit word).
    REQUIRE(vb.memory_bytes() == (vb.voxel_count() + 31) / 32 * 8);
    REQUIRE(double(vb.memory_bytes()) * 8.0 / double(vb.voxel_count()) < 2.0 + 64.0 / double(vb.voxel_count()));
}

TEST_CASE("voxelized union of sphere and box: point_inside matches the analytic shapes", "[aggregates][voxel]") {
    using U = UnionBoundary<SphereBoundary, BoxBoundary>;
    const U u{SphereBoundary(Vec3d(0.0), 3.0), BoxBoundary(Vec3d(2.0, -1.0, -1.0), Vec3d(7.5, 1.5, 2.0))};
    const VoxelizedBoundary<U> vb(u, 0.7, Vec3i64(1000000, -2000000, 3));
    check_classes_against(vb, [&](const Vec3d& p) { return u.inside(p); }, 2, 2);
    Rng rng = Rng::from_key(3, 4, 5);
    for (int i = 0; i < 20000; ++i) {
        const Vec3d p(-4 + 13 * rng.uniform<double>(), -4 + 8 * rng.uniform<double>(), -4 + 8 * rng.uniform<double>());
        // Express p as (absolute tile, local offset) relative to the far-away anchor.
        const Vec3i64 rel(std::int64_t(std::floor(p.x / 0.7)), std::int64_t(std::floor(p.y / 0.7)),
                          std::int64_t(std::floor(p.z / 0.7)));
        const Vec3d local = p - 0.7 * Vec3d(rel);
        REQUIRE(vb.point_inside(vb.anchor() + rel, local) == u.inside(p));
        REQUIRE(vb.refined());
    }
}

TEST_CASE("voxelized mesh: icosphere vs the analytic sphere, majority-parity point test", "[aggregates][voxel]") {
    TriangleMesh<float> ico = make_icosphere<float>(4);
    const float R = 6.0f;
    for (auto& v : ico.vertices) v = R * v + Vec3f(0.25f, 0.5f, -0.125f);
    ico.compute_face_normals();
    const MeshBoundary mb(ico);
    const VoxelizedBoundary<MeshBoundary> vb(mb, 1.0);
    // The icosphere lies between its inscribed radius (~0.9995 R at level 4 -> use 0.995 R) and R.
    const Vec3d c(0.25, 0.5, -0.125);
    const double r_in = 0.995 * R;
    auto sure_inside = [&](const Vec3d& p) { return glm::length(p - c) < r_in; };
    auto sure_outside = [&](const Vec3d& p) { return glm::length(p - c) > double(R); };
    const auto& d = vb.dims();
    const auto& lo = vb.grid_lo();
    std::size_t n_in = 0, n_out = 0, n_part = 0;
    for (std::int64_t k = 0; k < d[2]; ++k)
        for (std::int64_t j = 0; j < d[1]; ++j)
            for (std::int64_t i = 0; i < d[0]; ++i) {
                const Vec3i64 t(lo[0] + i, lo[1] + j, lo[2] + k);
                const VoxelClass cl = vb.classify(t);
                const Vec3d corner(t);
                int in = 0, out = 0;
                for (int s = 0; s < 8; ++s) {
                    const Vec3d q = corner + Vec3d(s & 1, (s >> 1) & 1, (s >> 2) & 1);
                    in += sure_inside(q);
                    out += sure_outside(q);
                }
                if (cl == VoxelClass::inside) {
                    ++n_in;
                    REQUIRE(out == 0);
                }
                if (cl == VoxelClass::outside) {
                    ++n_out;
                    REQUIRE(in == 0);
                }
                if (cl == VoxelClass::partial) ++n_part;
                // A voxel with all corners surely inside is fully inside (the sphere is convex).
                if (in == 8) REQUIRE(cl == VoxelClass::inside);
            }
    REQUIRE(n_in > 0);
    REQUIRE(n_out > 0);
    REQUIRE(n_part > 0);
    // Point test, including points on voxel-centre rows and at mesh vertices' coordinates.
    Rng rng = Rng::from_key(7, 8, 9);
    int tested = 0;
    for (int i = 0; i < 5000; ++i) {
        Vec3d p = c + 7.0 * Vec3d(2 * rng.uniform<double>() - 1, 2 * rng.uniform<double>() - 1, 2 * rng.uniform<double>() - 1);
        if (i % 5 == 0) p = Vec3d(std::floor(p.x) + 0.5, std::floor(p.y) + 0.5, p.z);  // grid-aligned rays
        // The voxelized test (2-bit voxel, 4^3 sub-voxels of partial voxels, then the mesh).
        const Vec3i64 t(std::int64_t(std::floor(p.x)), std::int64_t(std::floor(p.y)), std::int64_t(std::floor(p.z)));
        const bool v_in = vb.point_inside(t, p - Vec3d(t));
        if (sure_inside(p)) {
            REQUIRE(mb.inside(p));
            REQUIRE(v_in);
            ++tested;
        } else if (sure_outside(p)) {
            REQUIRE_FALSE(mb.inside(p));
            REQUIRE_FALSE(v_in);
            ++tested;
        }
    }
    REQUIRE(tested > 4000);
    REQUIRE(vb.refined());
    // 16 bytes of sub-voxel classes per partial voxel, 4 bytes of rank per 64-bit word of classes,
    // and the partial voxels' triangle lists.
    REQUIRE(vb.partial_surface().ref_inside.size() == vb.partial_count());
    REQUIRE(vb.refinement_bytes() ==
            vb.partial_count() * 16 + vb.memory_bytes() / 2 + vb.partial_surface().memory_bytes());
}

TEST_CASE("voxelized mesh: the local point test in partial voxels agrees with the mesh's own", "[aggregates][voxel]") {
    // In a partial voxel the point test is the parity of the segment from the voxel's reference
    // point against the voxel's triangles (PartialVoxelSurface). Checked against MeshBoundary::
    // inside (three parity rays through the whole mesh, majority) at points within 0.3 voxel of
    // the surface, where both the sub-voxels and the local test are used; every reference point's
    // stored side is checked too. Two meshes: an icosphere off the grid and a box whose faces lie
    // on voxel faces and centres.
    TriangleMesh<float> ico = make_icosphere<float>(3);
    for (auto& v : ico.vertices) v = 5.3f * v + Vec3f(0.37f, -0.21f, 0.11f);
    ico.compute_face_normals();
    TriangleMesh<float> box;  // [-3, 3] x [-2.5, 2] x [-4, 3.5]: faces on voxel faces and mid-planes
    for (int c = 0; c < 8; ++c)
        box.vertices.push_back(Vec3f(c & 1 ? 3.0f : -3.0f, c & 2 ? 2.0f : -2.5f, c & 4 ? 3.5f : -4.0f));
    box.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                     {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    box.compute_face_normals();
    for (const TriangleMesh<float>* mesh : {&ico, &box}) {
        const MeshBoundary mb(*mesh);
        const VoxelizedBoundary<MeshBoundary> vb(mb, 1.0);
        const PartialVoxelSurface& ps = vb.partial_surface();
        REQUIRE(ps.ref_inside.size() == vb.partial_count());
        REQUIRE(ps.tri_start.size() == vb.partial_count() + 1);
        // Every reference point's side.
        const auto& d = vb.dims();
        const auto& lo = vb.grid_lo();
        const Vec3d origin = Vec3d(double(lo[0]), double(lo[1]), double(lo[2]));
        std::size_t r = 0;
        for (std::int64_t k = 0; k < d[2]; ++k)
            for (std::int64_t j = 0; j < d[1]; ++j)
                for (std::int64_t i = 0; i < d[0]; ++i) {
                    if (vb.classify(Vec3i64(lo[0] + i, lo[1] + j, lo[2] + k)) != VoxelClass::partial) continue;
                    const Vec3d ref = MeshBoundary::reference_point(origin, 1.0, i, j, k);
                    REQUIRE((ps.ref_inside[r] != 0) == mb.inside(ref));
                    REQUIRE(ps.tri_start[r + 1] > ps.tri_start[r]);  // a partial voxel has triangles
                    ++r;
                }
        // Points near the surface: random vertices pushed along their normals by up to 0.3.
        Rng rng = Rng::from_key(11, 12);
        int in = 0, out = 0;
        for (int n = 0; n < 20000; ++n) {
            const auto& tri = mesh->triangles[rng.next_u32(std::uint32_t(mesh->triangles.size()))];
            const Vec2d u = rng.uniform2<double>();
            const double a = std::sqrt(u.x);
            const Vec3d v0(mesh->vertices[tri[0]]), v1(mesh->vertices[tri[1]]), v2(mesh->vertices[tri[2]]);
            const Vec3d on = (1 - a) * v0 + a * (1 - u.y) * v1 + a * u.y * v2;
            const Vec3d nrm = glm::normalize(glm::cross(v1 - v0, v2 - v0));
            const Vec3d p = on + (0.6 * rng.uniform<double>() - 0.3) * nrm +
                            0.05 * Vec3d(rng.uniform<double>() - 0.5, rng.uniform<double>() - 0.5, rng.uniform<double>() - 0.5);
            const Vec3i64 t(std::int64_t(std::floor(p.x)), std::int64_t(std::floor(p.y)), std::int64_t(std::floor(p.z)));
            const bool want = mb.inside(p);
            REQUIRE(vb.point_inside(t, p - Vec3d(t)) == want);
            (want ? in : out) += 1;
        }
        CHECK(in > 5000);
        CHECK(out > 5000);
    }
}

TEST_CASE("voxelized boundary: bad input is a clear error", "[aggregates][voxel]") {
    TriangleMesh<float> ico = make_icosphere<float>(2);
    SECTION("non-watertight mesh") {
        ico.triangles.pop_back();
        REQUIRE_THROWS_AS(MeshBoundary(ico), grainlight::invalid_argument);
        try {
            (void)MeshBoundary(ico);
        } catch (const grainlight::invalid_argument& e) {
            REQUIRE(std::string(e.what()).find("watertight") != std::string::npos);
        }
    }
    SECTION("inside-out mesh") {
        for (auto& t : ico.triangles) std::swap(t[1], t[2]);
        REQUIRE_THROWS_AS(MeshBoundary(ico), grainlight::invalid_argument);
    }
    SECTION("bad tile side / radius") {
        REQUIRE_THROWS_AS(VoxelizedBoundary<SphereBoundary>(SphereBoundary(Vec3d(0.0), 1.0), 0.0),
                          grainlight::invalid_argument);
        REQUIRE_THROWS_AS(SphereBoundary(Vec3d(0.0), -1.0), grainlight::invalid_argument);
    }
}
