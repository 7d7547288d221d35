// Quadtree compression of the multiple-scattering table (integrators/ms_table_quadtree.hpp): the
// compressed table must give back the dense one (lossless at tolerance 0, within the tolerance
// otherwise), hold less memory when the grid has empty regions, and reject bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include "grainlight/integrators/ms_table_quadtree.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"

using namespace grainlight;

namespace {
using Grey = Spectrum<1, float>;
using RGBPhase = HenyeyGreenstein<float, RGB>;

MsTable<3> sparse_table() {
    // Few particles over a grid much wider than they reach: the far cells stay empty.
    MsTableOptions t;
    t.n_rho = 24;
    t.n_z = 40;
    t.n_theta = 4;
    t.n_phi = 2;
    t.rho_max = 24;
    t.z_min = -24;
    t.z_max = 24;
    t.photons = 3000;
    t.seed = 7;
    return MsTable<3>::build(RGBPhase(0.7f), RGB{0.9f, 0.6f, 0.4f}, t);
}
}  // namespace

TEST_CASE("ms_table_quadtree: lossless at tolerance 0, smaller than the dense table", "[ms_quadtree]") {
    const MsTable<3> t = sparse_table();
    const MsTableQuadtree<3> q(t, 0.0);
    const auto& g = t.grid();
    std::size_t empty_cells = 0, mismatches = 0;
    for (std::size_t iz = 0; iz < g.n_z; ++iz)
        for (std::size_t ir = 0; ir < g.n_rho; ++ir) {
            bool any = false;
            for (std::size_t c = 0; c < 3; ++c)
                for (std::size_t j = 0; j < g.directions(); ++j) {
                    const float d = t.values()[t.value_index(c, iz, ir, j)];
                    any = any || d > 0.0f;
                    if (q.value(c, iz, ir, j) != d) ++mismatches;
                }
            if (!any) ++empty_cells;
        }
    std::printf("ms_quadtree: %zu of %zu cells empty; dense %zu B, quadtree %zu B (%zu cells stored)\n", empty_cells,
                std::size_t(g.n_z) * g.n_rho, t.bytes(), q.bytes(), q.stored_cells());
    CHECK(mismatches == 0);
    REQUIRE(empty_cells > 0);
    CHECK(q.stored_cells() == std::size_t(g.n_z) * g.n_rho - empty_cells);
    CHECK(q.bytes() < t.bytes());
    CHECK(q.value(0, g.n_z, 0, 0) == 0.0f);  // outside the grid
}

TEST_CASE("ms_table_quadtree: lossy tolerance drops only cells below it", "[ms_quadtree]") {
    const MsTable<3> t = sparse_table();
    const MsTableQuadtree<3> q0(t, 0.0), q(t, 1e-3);
    const auto& g = t.grid();
    std::size_t bad = 0;
    for (std::size_t c = 0; c < 3; ++c)
        for (std::size_t iz = 0; iz < g.n_z; ++iz)
            for (std::size_t ir = 0; ir < g.n_rho; ++ir)
                for (std::size_t j = 0; j < g.directions(); ++j) {
                    const float d = t.values()[t.value_index(c, iz, ir, j)], v = q.value(c, iz, ir, j);
                    // Either kept exactly, or the whole cell was dropped and this value is below the threshold.
                    if (!(v == d || (v == 0.0f && d <= q.threshold()))) ++bad;
                }
    CHECK(bad == 0);
    CHECK(q.threshold() > 0.0f);
    CHECK(q.bytes() <= q0.bytes());
}

namespace {
// Power-weighted L1 distance sum_cells vol sum_j dOmega_j |q - v| of channel c between the
// quadtree and its dense table, and the quadtree's own power (as MsTable::total), computed here
// from the grid's geometry (not from the quadtree's internals).
struct PowerError {
    double l1 = 0, power = 0;
};
PowerError power_error(const MsTable<3>& t, const MsTableQuadtree<3>& q, std::size_t c) {
    const auto& g = t.grid();
    const double pi = 3.14159265358979323846, dr = g.rho_max / g.n_rho, dz = (g.z_max - g.z_min) / g.n_z;
    PowerError e;
    for (std::size_t iz = 0; iz < g.n_z; ++iz)
        for (std::size_t ir = 0; ir < g.n_rho; ++ir) {
            const double vol = pi * dz * dr * dr * double(2 * ir + 1);
            for (std::size_t j = 0; j < g.directions(); ++j) {
                const double it = double(j / g.n_phi);
                const double dom = 2 * pi / g.n_phi * (std::cos(pi * it / g.n_theta) - std::cos(pi * (it + 1) / g.n_theta));
                const double v = q.value(c, iz, ir, j);
                e.l1 += vol * dom * std::abs(v - double(t.values()[t.value_index(c, iz, ir, j)]));
                e.power += vol * dom * v;
            }
        }
    return e;
}
MsTable<3> dense_noisy_table() {
    // A high-albedo table with many particles near the source and few far away: the far cells are
    // noisy and carry little power (what the density-driven merge is for).
    MsTableOptions t;
    t.n_rho = 32;
    t.n_z = 64;
    t.n_theta = 6;
    t.n_phi = 3;
    t.rho_max = 16;
    t.z_min = -16;
    t.z_max = 16;
    t.photons = 20000;
    t.seed = 5;
    return MsTable<3>::build(RGBPhase(0.5f), RGB{0.99f, 0.95f, 0.8f}, t);
}
}  // namespace

TEST_CASE("ms_table_quadtree: merging keeps the power-weighted L1 error within its tolerance and the power exact",
          "[ms_quadtree]") {
    const MsTable<3> t = dense_noisy_table();
    const MsTableQuadtree<3> q0(t, 0.0);
    std::size_t last_lobes = q0.stored_lobes();
    for (double tol : {0.01, 0.05, 0.2}) {
        const MsTableQuadtree<3> q(t, 0.0, tol);
        std::printf("ms_quadtree merge %.2f: %zu lobes for %zu cells (%zu merged leaves), %zu B of %zu B dense\n", tol,
                    q.stored_lobes(), q.stored_cells(), q.merged_leaves(), q.bytes(), q.dense_bytes());
        for (std::size_t c = 0; c < 3; ++c) {
            const PowerError e = power_error(t, q, c);
            const double total = t.total(c);
            INFO("tolerance " << tol << " channel " << c << ": L1 " << e.l1 << ", total " << total);
            CHECK(e.l1 <= tol * total * (1 + 1e-6));
            // The volume-weighted mean lobe keeps every merged block's power in every bin.
            CHECK(e.power == Approx(total).epsilon(1e-5));
        }
        CHECK(q.merged_leaves() > 0);
        CHECK(q.stored_cells() >= q0.stored_cells());  // merging drops nothing (a merged block also covers its empty cells)
        CHECK(q.stored_lobes() < q.stored_cells());
        // A larger tolerance can only merge more (every block mergeable before still is).
        CHECK(q.stored_lobes() < last_lobes);
        last_lobes = q.stored_lobes();
    }
    // Merging with tolerance 0 is off: lossless.
    const MsTableQuadtree<3> q00(t, 0.0, 0.0);
    CHECK(q00.merged_leaves() == 0);
    CHECK(power_error(t, q00, 1).l1 == 0.0);
}

TEST_CASE("ms_table_quadtree: bad input", "[ms_quadtree]") {
    const MsTable<3> t = sparse_table();
    CHECK_THROWS_AS(MsTableQuadtree<3>(t, -0.1), std::invalid_argument);
    CHECK_THROWS_AS(MsTableQuadtree<3>(t, std::nan("")), std::invalid_argument);
    CHECK_THROWS_AS(MsTableQuadtree<3>(MsTable<3>{}, 0.0), std::invalid_argument);
    CHECK_THROWS_AS(MsTableQuadtree<3>(t, 0.0, -0.01), std::invalid_argument);
    CHECK_THROWS_AS(MsTableQuadtree<3>(t, 0.0, 1.0), std::invalid_argument);
    CHECK_THROWS_AS(MsTableQuadtree<3>(t, 0.0, std::nan("")), std::invalid_argument);
}

namespace {
using MultipleRenderer = PointBasedRenderer<RGBPhase, SphereShape<float>>;
// The point-based renderer of the two renderer tests: the unit sphere of a medium with extinction
// sigma_t, `albedo` and HG g (the table's), index 1.33, 400 light surface samples lit by a 6 x 6
// quad light above it, only the multiple term (read from `t`), volume samples every
// `volume_step`, light points drawn from Rng::from_key(seed).
MultipleRenderer multiple_only_renderer(const MsTable<3>& t, float sigma_t, const RGB& albedo, float g, float volume_step,
                                        std::uint64_t seed) {
    const ContinuousMedium<RGBPhase, RGB> medium(RGB(sigma_t), albedo, RGBPhase(g));
    const SphereShape<float> sphere(Vec3f(0.0f), 1.0f);
    const QuadShape<float> quad(Vec3f(-3.0f, 2.0f, -3.0f), Vec3f(6, 0, 0), Vec3f(0, 0, 6));
    PointBasedOptions<float> o;
    o.single = false;
    o.double_ = false;
    o.bounced = false;
    o.volume_step = volume_step;
    Rng rng = Rng::from_key(seed);
    return MultipleRenderer(medium, 1.33f, sphere, sphere_surface_samples(sphere, 400), Light<float, RGB>::quad_light(quad, RGB(1.0f)),
                            o, rng, &t);
}
}  // namespace

TEST_CASE("ms_table_quadtree: eval_dir equals the dense table's; the renderer reading it gives the same image",
          "[ms_quadtree][point_based]") {
    const MsTable<3> t = sparse_table();
    const MsTableQuadtree<3> q(t, 0.0);
    Rng rng = Rng::from_key(3);
    for (int i = 0; i < 2000; ++i) {
        const double rho = 25.0 * rng.uniform<double>(), z = -25.0 + 50.0 * rng.uniform<double>();
        const double ct = 2 * rng.uniform<double>() - 1, ph = 3.2 * rng.uniform<double>();
        for (bool interp : {false, true}) {
            const MsDirection d = t.direction(ct, ph, interp), dq = q.direction(ct, ph, interp);
            REQUIRE(d.count == dq.count);
            for (std::size_t c = 0; c < 3; ++c) CHECK(q.eval_dir(c, rho, z, dq) == Approx(t.eval_dir(c, rho, z, d)).margin(1e-12));
        }
    }
    CHECK(q.dense_bytes() == t.bytes());
    // The renderer: multiple scattering from the dense table and from the quadtree, same samples.
    MultipleRenderer pb = multiple_only_renderer(t, 2.0f, RGB{0.9f, 0.6f, 0.4f}, 0.7f, 0.2f, 9);
    double dense = 0, comp = 0;
    for (int pass = 0; pass < 2; ++pass) {
        pb.use_compressed_table(pass == 0 ? nullptr : &q);
        for (int i = 0; i < 16; ++i) {
            Rng g = Rng::from_key(11, std::uint64_t(i));
            const Ray<float> ray(Vec3f(0.05f * float(i % 4), 0.05f * float(i / 4), 5.0f), Vec3f(0, 0, -1));
            (pass == 0 ? dense : comp) += double(pb.radiance_components(ray, g).multiple.average());
        }
    }
    CHECK(dense > 0);
    CHECK(comp == Approx(dense).epsilon(1e-6));
    MsTableOptions few;
    few.photons = 2000;
    const MsTable<3> other = MsTable<3>::build(RGBPhase(0.7f), RGB{0.8f, 0.6f, 0.4f}, few);
    const MsTableQuadtree<3> wrong(other, 0.0);
    CHECK_THROWS_AS(pb.use_compressed_table(&wrong), grainlight::invalid_argument);
}

TEST_CASE("ms_table_quadtree: the renderer reading a merged table stays within its tolerance of the dense one",
          "[ms_quadtree][point_based]") {
    const MsTable<3> t = dense_noisy_table();
    MultipleRenderer pb = multiple_only_renderer(t, 12.0f, RGB{0.99f, 0.95f, 0.8f}, 0.5f, 0.1f, 21);  // radius 12 mfp
    auto render = [&](const MsTableQuadtree<3>* q) {
        pb.use_compressed_table(q);
        std::array<double, 3> s{};
        for (int i = 0; i < 16; ++i) {
            Rng g = Rng::from_key(23, std::uint64_t(i));
            const Ray<float> ray(Vec3f(0.1f * float(i % 4) - 0.15f, 0.1f * float(i / 4) - 0.15f, 5.0f), Vec3f(0, 0, -1));
            const RGB m = pb.radiance_components(ray, g).multiple;
            for (int c = 0; c < 3; ++c) s[std::size_t(c)] += double(m[c]);
        }
        return s;
    };
    const auto dense = render(nullptr);
    for (double tol : {0.05, 0.2}) {
        const MsTableQuadtree<3> q(t, 0.0, tol);
        const auto merged = render(&q);
        for (int c = 0; c < 3; ++c) {
            std::printf("ms_quadtree render: merge %.2f, channel %d: merged / dense multiple term = %.6f (%zu lobes for %zu cells)\n",
                        tol, c, merged[std::size_t(c)] / dense[std::size_t(c)], q.stored_lobes(), q.stored_cells());
            CHECK(dense[std::size_t(c)] > 0);
            CHECK(merged[std::size_t(c)] == Approx(dense[std::size_t(c)]).epsilon(tol));
        }
    }
}
