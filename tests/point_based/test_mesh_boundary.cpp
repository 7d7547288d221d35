// Mesh boundaries of the point-based renderer (Wang18 Sec. 3.4.1, issue 11 item 3):
// ClosedMeshShape (geometry/closed_mesh.hpp), Poisson-disk surface samples on meshes
// (geometry/surface_sampling.hpp) and the renderer over a mesh against the analytic sphere.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

#include "grainlight/geometry/closed_mesh.hpp"
#include "grainlight/geometry/distance.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/surface_sampling.hpp"
#include "scene_fixture.hpp"

using namespace pb_test;

namespace {

using MeshRenderer = PointBasedRenderer<Phase, ClosedMeshShape<float>>;

// Chi-square statistic of per-triangle counts against the area shares `share` (sum 1).
double chi_square(const std::vector<double>& count, const std::vector<double>& share, double n) {
    double x2 = 0;
    for (std::size_t i = 0; i < count.size(); ++i) {
        const double e = n * share[i];
        x2 += (count[i] - e) * (count[i] - e) / e;
    }
    return x2;
}

}  // namespace

TEST_CASE("closed_mesh: open and inside-out meshes are rejected with a clear error", "[point_based][mesh]") {
    TriangleMesh<float> m = make_icosphere<float>(2);
    CHECK_NOTHROW(ClosedMeshShape<float>(m));
    TriangleMesh<float> open = m;
    open.triangles.pop_back();
    open.compute_face_normals();
    CHECK_THROWS_AS(ClosedMeshShape<float>(open), grainlight::invalid_argument);
    try {
        (void)ClosedMeshShape<float>(open);
    } catch (const std::exception& e) {
        CHECK(std::string(e.what()).find("closed mesh") != std::string::npos);
    }
    TriangleMesh<float> flipped = m;
    for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
    flipped.compute_face_normals();
    CHECK_THROWS_AS(ClosedMeshShape<float>(flipped), grainlight::invalid_argument);
    TriangleMesh<float> empty;
    CHECK_THROWS_AS(ClosedMeshShape<float>(empty), grainlight::invalid_argument);
    CHECK_THROWS_AS(make_bumpy_sphere<float>(2, 1.0, 0.7, 3.0), grainlight::invalid_argument);
    CHECK_THROWS_AS(mesh_surface_samples(ClosedMeshShape<float>(m), 0, 1), grainlight::invalid_argument);
}

TEST_CASE("closed_mesh: pseudo-normal inside test agrees with ray parity; tangent planes of a sphere are radial",
          "[point_based][mesh]") {
    const TriangleMesh<float> bumpy = make_bumpy_sphere<float>(3, 1.0, 0.15, 5.0);
    const ClosedMeshShape<float> shape(bumpy);
    const MeshDistance parity(bumpy);  // independent: majority of three ray-parity counts
    Rng rng = Rng::from_key(5);
    int disagree = 0, inside = 0;
    const int n = 4000;
    for (int i = 0; i < n; ++i) {
        const Vec3f p = 1.3f * (2.0f * rng.uniform3<float>() - 1.0f);
        const bool a = shape.inside(p), b = parity.inside(Vec3d(p));
        disagree += a != b;
        inside += a;
    }
    INFO("inside " << inside << " of " << n << ", disagreements " << disagree);
    CHECK(disagree == 0);
    CHECK(inside > n / 6);  // ~ volume share 4.2 / 17.6
    // Icosphere (level 5): q on the unit sphere, n along p, for inside and outside points.
    const ClosedMeshShape<float> ico(make_icosphere<float>(5));
    for (int i = 0; i < 200; ++i) {
        const Vec3f d = glm::normalize(2.0f * rng.uniform3<float>() - 1.0f);
        const float r = 0.2f + 1.4f * rng.uniform<float>();
        Vec3f q(0.0f), nn(0.0f);
        const bool in = ico.tangent_plane(r * d, q, nn);
        CHECK(in == (r < 0.999f));
        CHECK(glm::length(q) == Approx(1.0).margin(2e-3));
        if (std::abs(r - 1.0f) > 0.01f) CHECK(glm::dot(nn, d) > 0.999f);
    }
    // Ray queries: the outward normal from both sides; t equals the sphere's within the facets' sag.
    for (int i = 0; i < 100; ++i) {
        const Vec3f d = glm::normalize(2.0f * rng.uniform3<float>() - 1.0f);
        float t = 0;
        Vec3f nn(0.0f);
        REQUIRE(ico.intersect(Ray<float>(Vec3f(0.0f), d), t, nn));
        CHECK(t == Approx(1.0).margin(2e-3));
        CHECK(glm::dot(nn, d) > 0.999f);
        REQUIRE(ico.intersect(Ray<float>(3.0f * d, -d), t, nn));
        CHECK(t == Approx(2.0).margin(2e-3));
        CHECK(glm::dot(nn, d) > 0.999f);
    }
}

TEST_CASE("surface_sampling: Poisson-disk points keep the minimum distance and cover the mesh by area (chi-square)",
          "[point_based][mesh]") {
    // A strongly bumped coarse sphere: triangle areas differ by a factor ~3, so a sampler that
    // ignored the areas would fail the chi-square test below (checked with the equal-share
    // alternative).
    const TriangleMesh<float> m = make_bumpy_sphere<float>(2, 1.0, 0.3, 3.0);
    const ClosedMeshShape<float> shape(m);
    const int n = 16000;
    double r = 0;
    const auto pts = poisson_disk_mesh_points(m, n, 7, &r);
    REQUIRE(pts.size() == std::size_t(n));
    // Minimum distance: brute force over all pairs.
    double dmin2 = 1e30;
    for (std::size_t i = 0; i < pts.size(); ++i)
        for (std::size_t j = i + 1; j < pts.size(); ++j) {
            const Vec3d d = Vec3d(pts[i].p) - Vec3d(pts[j].p);
            dmin2 = std::min(dmin2, glm::dot(d, d));
        }
    CHECK(std::sqrt(dmin2) >= r * (1 - 1e-6));
    // Every point on its triangle (inside/outside distance ~ 0) with that triangle's normal.
    for (std::size_t i = 0; i < pts.size(); i += 97) {
        const auto c = m.corners(pts[i].triangle);
        CHECK(std::abs(glm::dot(pts[i].p - c[0], m.face_normals[pts[i].triangle])) < 1e-5f);
    }
    // Coverage: counts per triangle against the area shares.
    std::vector<double> count(m.triangles.size(), 0.0), share(m.triangles.size()), equal(m.triangles.size());
    for (const auto& p : pts) count[p.triangle] += 1;
    double amin = 1e30, amax = 0;
    for (std::size_t i = 0; i < share.size(); ++i) {
        const auto c = m.corners(i);
        share[i] = 0.5 * double(glm::length(glm::cross(c[1] - c[0], c[2] - c[0]))) / m.area();
        equal[i] = 1.0 / double(share.size());
        amin = std::min(amin, share[i]);
        amax = std::max(amax, share[i]);
    }
    const double dof = double(share.size() - 1);
    const double crit = dof + 4 * std::sqrt(2 * dof);  // ~ p = 1e-4 upper tail
    const double x2 = chi_square(count, share, n), x2_equal = chi_square(count, equal, n);
    std::printf("poisson disk: %d points, r = %.4f, min distance %.4f, chi2 = %.1f (dof %.0f, critical %.1f), "
                "equal-share chi2 = %.1f, area ratio %.2f\n",
                n, r, std::sqrt(dmin2), x2, dof, crit, x2_equal, amax / amin);
    CHECK(x2 < crit);
    CHECK(x2_equal > 1.5 * crit);  // the test has power against a sampler that ignores the areas
    // Blue noise: the counts vary less than Poisson's (chi2 below its dof).
    CHECK(x2 < dof);
    // The renderer's samples carry the area A / n.
    const auto ss = mesh_surface_samples(shape, 2000, 3);
    double a = 0;
    for (const auto& s : ss) a += s.area;
    CHECK(a == Approx(m.area()).epsilon(1e-5));
}

TEST_CASE("point_based: the mesh path over a finely tessellated sphere equals the analytic sphere path",
          "[point_based][mesh]") {
    // Same medium, light, options; the boundary once a SphereShape with Fibonacci samples, once a
    // level-5 icosphere (20480 facets, normals within 1.2 deg of the sphere's) with Poisson-disk
    // samples. A directional light (no light-point noise), so the two differ by the geometry and
    // by their sample sets. Every component (single, double, multiple from a small table,
    // bounced) over three patches with the same camera rays for both (paired differences).
    MsTableOptions to;
    to.n_rho = 24;
    to.n_z = 48;
    to.n_theta = 8;
    to.n_phi = 4;
    to.rho_max = 6;
    to.z_min = -6;
    to.z_max = 6;
    to.photons = 40000;
    const auto table = MsTable<1>::build(Phase(kG), Grey(kAlbedo), to);
    PointBasedOptions<float> o;
    o.volume_step = 0.1f;
    o.max_optical_depth = 6.0f;
    o.k_max = 4;
    o.cut.eps1 = 0.3f;
    o.cut.eps2 = 0.06f;
    o.bounce_samples = 128;
    o.bounce_rays = 4;
    o.bounce_k_max = 2;
    const auto light = Light<float, Grey>::directional_light(glm::normalize(Vec3f(0.3f, -1.0f, -0.2f)), Grey(1.0f));
    const ClosedMeshShape<float> ico(make_icosphere<float>(5));
    Rng r1 = Rng::from_key(100), r2 = Rng::from_key(200);
    const Renderer rs(medium(), kEta, sphere(), sphere_surface_samples(sphere(), 1500), light, o, r1, &table,
                      sphere_surface_samples(sphere(), o.bounce_samples));
    const MeshRenderer rm(medium(), kEta, ico, mesh_surface_samples(ico, 1500, 10), light, o, r2, &table,
                          mesh_surface_samples(ico, o.bounce_samples, 20));
    const float h = 0.2f;
    for (const auto& c : {Vec2f(0.0f, 0.0f), Vec2f(0.0f, 0.5f), Vec2f(-0.4f, -0.3f)}) {
        Welford ws[4], wm[4], wd[4];
        for (int i = 0; i < 32; ++i) {
            Rng rng = Rng::from_key(31, std::uint64_t(i));
            const Ray<float> ray = patch_ray(c, h, rng);
            Rng g1 = rng, g2 = rng;
            const auto a = rs.radiance_components(ray, g1), b = rm.radiance_components(ray, g2);
            const double va[4] = {a.single[0], a.double_[0], a.multiple[0], a.bounced[0]};
            const double vb[4] = {b.single[0], b.double_[0], b.multiple[0], b.bounced[0]};
            for (int k = 0; k < 4; ++k) {
                ws[k].add(va[k]);
                wm[k].add(vb[k]);
                wd[k].add(vb[k] - va[k]);
            }
        }
        for (int k = 0; k < 4; ++k) {
            // 4 standard errors of the paired difference + 5 %: the facets (~1 %) and the
            // light-sample sets (Fibonacci vs Poisson disk; build-to-build spread measured 1-5 %).
            const double ms = ws[k].mean(), mm = wm[k].mean();
            const double tol = 4 * wd[k].standard_error() + 0.05 * ms;
            std::printf("mesh vs sphere comp %d (%.1f, %.1f): mesh %.5f sphere %.5f diff %+.2f%% +- %.2f%%\n", k, c.x,
                        c.y, mm, ms, 100 * (mm - ms) / ms, 100 * wd[k].standard_error() / ms);
            INFO("component " << k << " patch (" << c.x << ", " << c.y << "): mesh " << mm << ", sphere " << ms
                              << ", s.e. of the difference " << wd[k].standard_error());
            CHECK(ms > 0);
            CHECK(std::abs(mm - ms) < tol);
        }
    }
    // Empty sample set: a clear error.
    Rng r = Rng::from_key(1);
    CHECK_THROWS_AS(MeshRenderer(medium(), kEta, ico, {}, light, o, r, &table), grainlight::invalid_argument);
}
