// A closed triangle mesh (OBJ) as the aggregate boundary of the hybrid (integrators/hybrid.hpp
// add_mesh_boundary, geometry/distance.hpp MeshDistance::ball_inside): the VPT -> DA switch
// never fires closer to the mesh than d_DA (property test against a brute-force distance and a
// brute-force parity test over all triangles), and EPT -> VPT (-> DA) on a mesh-shaped aggregate
// agrees with EPT on the same aggregate; the five technique combinations of Meng15 Fig. 11 and
// the per-technique films.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "grainlight/geometry/distance.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/procedural_boundaries.hpp"
#include "grainlight/integrators/hybrid.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/precompute/scatterometer.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/scene.hpp"

using namespace grainlight;

namespace {

using TabMedium = ContinuousMedium<TabulatedPhase<float, RGB>, RGB>;
using TabScene = Scene<TabMedium>;

// Brute force over every triangle: the unsigned distance (Ericson's closest point, checked
// against a dense barycentric search in tests/geometry/test_distance.cpp) ...
double brute_distance(const TriangleMesh<double>& m, const Vec3d& p) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        const auto c = m.corners(i);
        const Vec3d q = closest_point_on_triangle(p, c[0], c[1], c[2]);
        best = std::min(best, glm::length(q - p));
    }
    return best;
}

// ... and inside by ray parity (Moller-Trumbore against every triangle), majority of 3 rays in
// generic directions.
bool brute_inside(const TriangleMesh<double>& m, const Vec3d& p) {
    const Vec3d dirs[3] = {glm::normalize(Vec3d(0.813, 0.342, 0.471)), glm::normalize(Vec3d(-0.291, 0.905, -0.311)),
                           glm::normalize(Vec3d(0.127, -0.433, 0.892))};
    int votes = 0;
    for (const Vec3d& d : dirs) {
        int n = 0;
        for (std::size_t i = 0; i < m.triangles.size(); ++i) {
            const auto c = m.corners(i);
            const Vec3d e1 = c[1] - c[0], e2 = c[2] - c[0], pv = glm::cross(d, e2);
            const double det = glm::dot(e1, pv);
            if (std::abs(det) < 1e-14) continue;
            const Vec3d tv = p - c[0];
            const double u = glm::dot(tv, pv) / det;
            if (u < 0 || u > 1) continue;
            const Vec3d qv = glm::cross(tv, e1);
            const double v = glm::dot(d, qv) / det;
            if (v < 0 || u + v > 1) continue;
            if (glm::dot(e2, qv) / det > 0) ++n;
        }
        votes += n & 1;
    }
    return votes >= 2;
}

// The procedural "bunny-like blob": a snow-grain mesh (sum of Gaussian lobes on a sphere) scaled
// to `radius`, written to and read back from an OBJ file (the user's path).
TriangleMesh<double> blob_obj(double radius, const std::string& name) {
    const TriangleMesh<double> m = make_grain_mesh<double>(GrainShape::snow, radius, 11, 3);
    const auto path = std::filesystem::temp_directory_path() / name;
    {
        std::ofstream f(path);
        f.precision(17);
        for (const auto& v : m.vertices) f << "v " << v.x << ' ' << v.y << ' ' << v.z << '\n';
        for (const auto& t : m.triangles) f << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
    }
    TriangleMesh<double> back = load_obj<double>(path.string());
    std::filesystem::remove(path);
    return back;
}

// Records the points where the DA switch fired (the hybrid asks ball_inside(x, d_DA)).
// Records the DA criterion's queries (radius d_DA; the flight memory also asks, at the grain radius).
struct RecordingDistance {
    const MeshDistance* mesh = nullptr;
    std::vector<Vec3d>* fired = nullptr;
    std::uint64_t* asked = nullptr;
    double r_da = 0;  ///< the DA switch's radius: only its queries are recorded
    [[nodiscard]] double operator()(const Vec3d& p) const noexcept { return (*mesh)(p); }
    [[nodiscard]] bool ball_inside(const Vec3d& p, double r) const noexcept {
        const bool b = mesh->ball_inside(p, r);
        if (r != r_da) return b;
        ++*asked;
        if (b && fired->size() < fired->capacity()) fired->push_back(p);
        return b;
    }
};

// A mesh region without `classify`: MeshBoundary's parity test per disc point.
struct PerPointRegion {
    const CentresInside<MeshBoundary, MeshDistance>* r;
    [[nodiscard]] bool inside(const Vec3d& x) const noexcept { return r->inside(x); }
    [[nodiscard]] double dist(const Vec3d& x) const noexcept { return (*r->distance)(x); }
    static constexpr bool constrains = true;
};

}  // namespace

TEST_CASE("MeshDistance::ball_inside: never true closer to the mesh than r (brute force over all triangles)",
          "[hybrid][mesh][property]") {
    const TriangleMesh<double> mesh = blob_obj(10.0, "grainlight_test_blob_a.obj");
    const MeshDistance md(mesh);
    Rng rng = Rng::from_key(2024, 1, 0);
    const Aabb<double> b = md.bounds();
    int yes = 0, no_inside = 0, tested = 0;
    for (int k = 0; k < 1500; ++k) {
        const Vec3d p = b.lo + rng.uniform3<double>() * b.extent();
        const double r = 4.0 * rng.uniform<double>();  // d_DA-like radii up to 40 % of the blob
        const bool in = brute_inside(mesh, p);
        const double d = brute_distance(mesh, p);
        const bool fired = ball_inside(md, p, r);
        ++tested;
        if (fired) {
            ++yes;
            INFO("p " << p.x << " " << p.y << " " << p.z << " r " << r << " brute distance " << d);
            REQUIRE(in);
            REQUIRE(d >= r);
        } else if (in) {
            ++no_inside;
            // Not overly conservative either: a ball clearly inside is reported inside.
            if (d > r * (1 + 1e-9)) REQUIRE(false);
        }
        // The member query equals the signed-distance form.
        REQUIRE(fired == (md(p) >= r));
    }
    REQUIRE(yes > 100);
    REQUIRE(no_inside > 50);
    // App. A's slab thickness: z_r + z_a <= the chord and > 0 from interior points.
    for (int k = 0; k < 200; ++k) {
        const Vec3d p = 0.3 * Vec3d(rng.uniform<double>() - 0.5, rng.uniform<double>() - 0.5, rng.uniform<double>() - 0.5) *
                        b.extent();
        if (!md.inside(p)) continue;
        const Vec3d w = sample_uniform_sphere(rng.uniform2<double>());
        const double th = md.auxiliary_thickness(p, w);
        if (!std::isfinite(th)) continue;
        REQUIRE(th > 0);
        REQUIRE(th <= md.exit_distance(p, w) + md.exit_distance(p, -w) + 1e-9);
        REQUIRE(th >= 2 * md(p) - 1e-9);  // each side's depth >= the distance to the surface
    }
}

TEST_CASE("Flight memory near a mesh boundary: the disc classified at once equals per-point parity tests",
          "[hybrid][mesh][flight-memory]") {
    // CentresInside<MeshBoundary, MeshDistance> classifies the collision disc by segment parity
    // against the triangles near its centre (MeshDistance::inside_near); the same region without
    // `classify` asks MeshBoundary's full parity test per disc point. Both must give the same
    // shadowed fraction, with and without remembered flights.
    const TriangleMesh<double> mesh = blob_obj(10.0, "grainlight_test_blob_fm.obj");
    const MeshBoundary shape(mesh);
    const MeshDistance md(mesh);
    const CentresInside<MeshBoundary, MeshDistance> fast{&shape, &md};
    const PerPointRegion slow{&fast};
    Rng rng = Rng::from_key(2024, 7, 0);
    const Aabb<double> b = md.bounds();
    int edge = 0, partial = 0;
    FlightMemory wanderer;  // keeps its safe ball (FlightMemory::boundary_distance) from point to point
    for (int k = 0; k < 4000 && edge < 400; ++k) {
        const Vec3d q = b.lo + rng.uniform3<double>() * b.extent();
        if (!md.inside(q)) continue;
        const double R = 0.2 + 0.6 * rng.uniform<double>();
        FlightMemory mem;
        mem.radius = R;
        if (k % 2) mem.push(q - 3.0 * R * sample_uniform_sphere(rng.uniform2<double>()), q);
        const Frame<double> fr(sample_uniform_sphere(rng.uniform2<double>()));
        const double f_fast = mem.shadowed_fraction(q, fr.s, fr.t, fast);
        const double f_slow = mem.shadowed_fraction(q, fr.s, fr.t, slow);
        INFO("q " << q.x << " " << q.y << " " << q.z << " R " << R);
        REQUIRE(f_fast == f_slow);
        // The safe ball of earlier queries (other points, other radii) changes nothing.
        FlightMemory fresh = mem;
        fresh.forget_region();
        wanderer.radius = R;
        wanderer.count = 0;
        if (mem.count > 0) wanderer.push(mem.from[0], mem.to[0]);
        REQUIRE(wanderer.shadowed_fraction(q, fr.s, fr.t, fast) == fresh.shadowed_fraction(q, fr.s, fr.t, slow));
        REQUIRE(fast.dist(q) == Approx(slow.dist(q)).margin(1e-12));
        if (!ball_inside(md, q, R)) {
            ++edge;
            partial += f_slow > 0 && f_slow < 1;
        }
    }
    REQUIRE(edge >= 100);
    REQUIRE(partial >= 50);
}

TEST_CASE("Mesh-boundary hybrid: the DA switch fires only >= d_DA from the mesh; EPT+VPT(+DA) vs EPT",
          "[hybrid][mesh][diffusion]") {
    // Weakly absorbing glass grains (RSA tile, f = 0.3, grain radius ~0.12) in the blob of
    // bounding radius 16 (~130 grain radii; d_DA ~ 13 grain radii ~ 1.6), under a constant sky.
    Rng trng = Rng::from_key(7, 0, 0);
    const PeriodicTile tile = random_sequential_addition(40, 0.3, trng, 1.0);
    const GrainMaterial mat = GrainMaterial::make_absorbing_dielectric(1.5, RGBd{0.005, 0.01, 0.03});
    const TriangleMesh<double> mesh = blob_obj(16.0, "grainlight_test_blob_b.obj");
    const MeshBoundary shape(mesh);
    GranularAggregate<MeshBoundary> agg(tile, VoxelizedBoundary<MeshBoundary>(shape, tile.side()),
                                        {GrainExemplar::sphere(1.0, mat)}, {1.0}, 9);
    ScatterometerConfig cfg;
    cfg.rays = 40000;
    cfg.seed = 8;
    const GrainStats stats = run_scatterometer(ScatterometerGrain::sphere(1.0, mat), cfg);
    const EffectiveRteParams rte = effective_rte_params(stats, tile.packing_fraction(), tile.radius());
    const HybridDiffusion diff = make_hybrid_diffusion(rte);
    TabScene ept;
    ept.add_light(Light<float, RGB>::environment_light(RGB(1.0f)));
    TabScene vpt = ept;
    const int m = vpt.add_medium(make_effective_medium<float, RGB>(stats, tile.packing_fraction(), tile.radius()));
    const HybridContext<MeshDistance> mctx = add_mesh_boundary(vpt, mesh, m, &diff);
    std::vector<Vec3d> fired;
    fired.reserve(100000);
    std::uint64_t asked = 0;
    const HybridContext<RecordingDistance> ctx{mctx.medium, mctx.boundary_shape,
                                               RecordingDistance{&mctx.distance, &fired, &asked, diff.d_DA}, &diff};
    HybridOptions da;
    da.mode = HybridMode::ept_vpt_da;
    HybridOptions eo = da, vo = da;
    eo.mode = HybridMode::ept;
    vo.mode = HybridMode::ept_vpt;
    double sd = 0, sd2 = 0, se = 0, se2 = 0, sv = 0, sv2 = 0;
    std::uint64_t n = 0, connections = 0;
    std::vector<Ray<float>> rays(16);
    std::vector<Rng> r1(16), r2(16), r3(16);
    for (int k = 0; k < 250; ++k) {
        Rng g = Rng::from_key(77, std::uint64_t(k), 1);
        const Vec3d o = 3.0 * 16.0 * sample_uniform_sphere(g.uniform2<double>());
        const Vec3d target = 5.0 * sample_uniform_sphere(g.uniform2<double>());
        for (std::size_t i = 0; i < 16; ++i) {
            r1[i] = Rng::from_key(77, std::uint64_t(k), i + 16);
            r2[i] = r1[i];
            r3[i] = r1[i];
            const Vec3d tj = target + 0.5 * Vec3d(g.uniform<double>() - 0.5, g.uniform<double>() - 0.5, 0.0);
            rays[i] = Ray<float>(Vec3f(o), Vec3f(glm::normalize(tj - o)));
        }
        const auto a = hybrid_bundle(ept, vpt, agg, ctx, rays.data(), r1.data(), 16, da);
        const auto e = hybrid_bundle(ept, vpt, agg, ctx, rays.data(), r2.data(), 16, eo);
        const auto v = hybrid_bundle(ept, vpt, agg, ctx, rays.data(), r3.data(), 16, vo);
        connections += a.counters.da;
        for (std::size_t i = 0; i < 16; ++i) {
            const double va = double(a.path[i].low[1] + a.path[i].high[1]);
            const double ve = double(e.path[i].low[1] + e.path[i].high[1]);
            const double vv = double(v.path[i].low[1] + v.path[i].high[1]);
            REQUIRE(v.path[i].da[1] == 0.0f);  // no DA without DA
            sv += vv;
            sv2 += vv * vv;
            sd += va;
            sd2 += va * va;
            se += ve;
            se2 += ve * ve;
            ++n;
        }
    }
    INFO("d_DA " << diff.d_DA << ", DA connections " << connections << ", asked " << asked << ", fired " << fired.size());
    REQUIRE(connections > 200);
    REQUIRE(fired.size() == connections);  // every connection is one fired criterion
    REQUIRE(asked > 2 * connections);      // and most vertices were refused
    // Every fired point: inside and at least d_DA from every triangle (brute force).
    for (std::size_t i = 0; i < fired.size(); i += 1 + fired.size() / 400) {
        REQUIRE(brute_inside(mesh, fired[i]));
        REQUIRE(brute_distance(mesh, fired[i]) >= diff.d_DA);
    }
    const double md = sd / double(n), me = se / double(n), mv = sv / double(n);
    const double err = std::sqrt((sd2 / double(n) - md * md + se2 / double(n) - me * me) / double(n));
    const double err_v = std::sqrt((sv2 / double(n) - mv * mv + se2 / double(n) - me * me) / double(n));
    INFO("EPT+VPT+DA " << md << ", EPT+VPT " << mv << ", EPT " << me << " +- " << err);
    // Tolerances as for the analytic sphere (test_hybrid_render.cpp): effective medium 6 %, DA 15 %.
    REQUIRE(std::abs(mv - me) < 0.06 * me + 3 * err_v);
    REQUIRE(std::abs(md - me) < 0.15 * me + 3 * err);
}

TEST_CASE("Fig. 11's five combinations and Fig. 12's per-technique films on a mesh boundary", "[hybrid][mesh][render]") {
    Rng trng = Rng::from_key(5, 0, 0);
    const PeriodicTile tile = random_sequential_addition(40, 0.3, trng, 1.0);
    const GrainMaterial mat = GrainMaterial::make_absorbing_dielectric(1.5, RGBd{0.005, 0.01, 0.03});
    const TriangleMesh<double> mesh = blob_obj(12.0, "grainlight_test_blob_c.obj");
    const MeshBoundary shape(mesh);
    GranularAggregate<MeshBoundary> agg(tile, VoxelizedBoundary<MeshBoundary>(shape, tile.side()),
                                        {GrainExemplar::sphere(1.0, mat)}, {1.0}, 3);
    ScatterometerConfig cfg;
    cfg.rays = 20000;
    cfg.seed = 4;
    const GrainStats stats = run_scatterometer(ScatterometerGrain::sphere(1.0, mat), cfg);
    const EffectiveRteParams rte = effective_rte_params(stats, tile.packing_fraction(), tile.radius());
    const HybridDiffusion diff = make_hybrid_diffusion(rte);
    TabScene ept;
    ept.add_light(Light<float, RGB>::environment_light(RGB(1.0f)));
    TabScene vpt = ept;
    const int m = vpt.add_medium(make_effective_medium<float, RGB>(stats, tile.packing_fraction(), tile.radius()));
    const HybridContext<MeshDistance> ctx = add_mesh_boundary(vpt, mesh, m, &diff);
    const PinholeCamera<float> cam(Vec3f(0, 0, 40), Vec3f(0, 0, 0), Vec3f(0, 1, 0), 30.0f, 10, 8);
    double mean[5];
    int k = 0;
    for (HybridMode mode : {HybridMode::vpt, HybridMode::vpt_da, HybridMode::ept_vpt, HybridMode::ept_vpt_da, HybridMode::ept}) {
        HybridOptions opt;
        opt.mode = mode;
        opt.bundle_size = 8;
        const HybridImages img = render_hybrid(ept, vpt, agg, ctx, cam, 2, 5, 1, opt);
        const Image all = img.combined(), e = img.ept_image(), v = img.vpt_image(), d = img.da_image();
        // The three contributions add up to the image.
        for (std::size_t i = 0; i < all.rgb.size(); ++i)
            REQUIRE(e.rgb[i] + v.rgb[i] + d.rgb[i] == Approx(all.rgb[i]).margin(1e-5));
        const bool has_da = hybrid_uses_da(mode), has_ept = hybrid_uses_ept(mode);
        INFO(hybrid_mode_name(mode) << ": EPT " << e.mean(1) << " VPT " << v.mean(1) << " DA " << d.mean(1) << " DA conn "
                                    << img.counters.da);
        REQUIRE((img.counters.da > 0) == has_da);
        REQUIRE((d.mean(1) > 0) == has_da);
        REQUIRE((e.mean(1) > 0) == has_ept);
        REQUIRE((v.mean(1) > 0) == (mode != HybridMode::ept));
        if (!has_ept) REQUIRE(img.counters.switched == 0);
        REQUIRE(img.switch_depth.mean(0) >= 0);
        mean[k++] = all.mean(1);
    }
    // All five see the same object under the same sky (means within the DA / medium tolerances).
    for (int i = 0; i < 4; ++i) REQUIRE(mean[i] == Approx(mean[4]).epsilon(0.25));
    REQUIRE_THROWS_WITH(add_mesh_boundary(vpt, TriangleMesh<double>{}, m, &diff), Catch::Contains("MeshBoundary"));
}

TEST_CASE("Snowman boundary mesh (geometry/procedural_boundaries.hpp): closed, the union of its balls", "[hybrid][mesh]") {
    const double H = 100;
    const TriangleMesh<double> m = make_snowman_mesh(H, 96, 64);
    REQUIRE(m.is_watertight());
    REQUIRE(m.signed_volume() > 0);
    const SnowmanBalls b = snowman_balls();
    const double s = H / b.top;
    // Volume of the union of the balls above y = 0: int pi rho(y)^2 dy (midpoint rule, 2e5 steps).
    double V = 0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        const double yu = b.top * (double(i) + 0.5) / double(n);
        double r2 = 0;
        for (int k = 0; k < 3; ++k) r2 = std::max(r2, b.radius[k] * b.radius[k] - (yu - b.center[k]) * (yu - b.center[k]));
        V += pi_v<double> * r2 * b.top / double(n);
    }
    V *= s * s * s;
    // Inscribed polygons of 64 sides lose ~0.16 % of the area per ring; rings cut the necks.
    REQUIRE(m.signed_volume() == Approx(V).epsilon(0.01));
    REQUIRE(m.bounds().hi.y == Approx(H));
    REQUIRE(m.bounds().lo.y == Approx(0.0).margin(1e-12));
    const MeshDistance md(m);
    for (int k = 0; k < 3; ++k) REQUIRE(md.inside(Vec3d(0, s * b.center[k], 0)));
    REQUIRE_FALSE(md.inside(Vec3d(0, -1, 0)));
    REQUIRE_FALSE(md.inside(Vec3d(s * b.radius[0] * 1.01, s * b.center[0], 0)));
    // Centre of the bottom ball: nearest surface is the flat cut 0.85 r below.
    REQUIRE(md(Vec3d(0, s * b.center[0], 0)) == Approx(s * b.center[0]).epsilon(1e-9));
    // Centre of the top ball: the ball's own radius (polygon: within 0.2 %).
    REQUIRE(md(Vec3d(0, s * b.center[2], 0)) == Approx(s * b.radius[2]).epsilon(0.003));
    REQUIRE_THROWS_WITH(make_snowman_mesh(-1.0), Catch::Contains("H"));
    REQUIRE_THROWS_WITH(make_revolution_mesh([](double) { return 1.0; }, 1.0, 1, 8), Catch::Contains("rings"));
}
