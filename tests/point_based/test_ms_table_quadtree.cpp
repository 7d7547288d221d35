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

TEST_CASE("ms_table_quadtree: noise-aware merging compresses a noisy table and brings it closer to the truth",
          "[ms_quadtree]") {
    // A fine grid filled by few particles (the paper's situation at 1024 x 512 cells) against the
    // same grid from 40x more particles (another seed) as the truth. Merging blocks whose
    // structure is within the table's own noise must store far fewer lobes than the cells and than
    // the bounded merge at 5 %, keep every channel's power, and be no farther from the truth than
    // the noisy dense table (averaging noise removes it).
    MsTableOptions o;
    o.n_rho = 40;
    o.n_z = 80;
    o.n_theta = 6;
    o.n_phi = 4;
    o.rho_max = 10;
    o.z_min = -10;
    o.z_max = 10;
    o.photons = 4000;
    o.seed = 11;
    const RGBPhase phase(0.7f);
    const RGB albedo{0.95f, 0.85f, 0.6f};
    MsTableBuildInfo info;
    const MsTable<3> noisy = build_ms_table(phase, albedo, o, &info);
    o.photons = 160000;
    o.seed = 12;
    const MsTable<3> truth = build_ms_table(phase, albedo, o);
    const std::vector<double> rel = ms_table_cell_relative_noise(info);
    const MsTableQuadtree<3> qn(noisy, 0.0, 0.0, rel);
    const MsTableQuadtree<3> q5(noisy, 0.0, 0.05);
    const MsTableQuadtree<3> q0(noisy, 0.0);
    auto to_truth = [&](const MsTableQuadtree<3>& q, std::size_t c) { return power_error(truth, q, c).l1 / truth.total(c); };
    std::printf("ms_quadtree noise-aware: %zu cells stored dense, %zu lobes merged at 5 %%, %zu noise-aware (%zu merged blocks)\n",
                q0.stored_lobes(), q5.stored_lobes(), qn.stored_lobes(), qn.merged_leaves());
    CHECK(qn.stored_lobes() * 4 < q0.stored_lobes());
    CHECK(qn.stored_lobes() < q5.stored_lobes());
    for (std::size_t c = 0; c < 3; ++c) {
        const double dense = to_truth(q0, c), merged = to_truth(qn, c);
        std::printf("  channel %zu: power-weighted L1 to the truth %.4f dense, %.4f noise-aware merged\n", c, dense, merged);
        CHECK(merged <= dense);
        CHECK(power_error(noisy, qn, c).power == Approx(noisy.total(c)).epsilon(1e-5));
    }
    // A noise factor of 0 is no noise-aware merging.
    CHECK(MsTableQuadtree<3>(noisy, 0.0, 0.0, rel, 0.0).stored_lobes() == q0.stored_lobes());
    // Bad input: wrong size, a negative value, a factor out of range.
    std::vector<double> bad(rel.begin(), rel.end() - 1);
    CHECK_THROWS_AS(MsTableQuadtree<3>(noisy, 0.0, 0.0, bad, 1.0), std::invalid_argument);
    bad = rel;
    bad[3] = -1.0;
    CHECK_THROWS_AS(MsTableQuadtree<3>(noisy, 0.0, 0.0, bad, 1.0), std::invalid_argument);
    CHECK_THROWS_AS(MsTableQuadtree<3>(noisy, 0.0, 0.0, rel, 101.0), std::invalid_argument);
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

TEST_CASE("ms_table_quadtree: the renderer reading a noise-merged table agrees with a converged table",
          "[ms_quadtree][point_based]") {
    // The multiple term through a sphere of radius 12 mfp from (a) a table of 80 000 particles
    // (the truth, another seed), (b) a table of 4000 particles, dense, and (c) the same 4000
    // particles merged where flat within their noise (a few percent of the lobes). Merging
    // keeps every block's power, so (c) must stay within 3 % of (b) and no farther from (a) than
    // (b) is plus 2 % (the noise of (a) and of the 16 camera rays' samples). At albedo 0.99 the
    // 4000-particle table is itself ~6 % low (its heavy-tailed noise), which merging keeps.
    MsTableOptions o;
    o.n_rho = 32;
    o.n_z = 64;
    o.n_theta = 6;
    o.n_phi = 3;
    o.rho_max = 16;
    o.z_min = -16;
    o.z_max = 16;
    o.photons = 80000;
    o.seed = 31;
    const RGBPhase phase(0.5f);
    const RGB albedo{0.99f, 0.95f, 0.8f};
    const MsTable<3> truth = build_ms_table(phase, albedo, o);
    o.photons = 4000;
    o.seed = 32;
    MsTableBuildInfo info;
    const MsTable<3> noisy = build_ms_table(phase, albedo, o, &info);
    const MsTableQuadtree<3> qn(noisy, 0.0, 0.0, ms_table_cell_relative_noise(info));
    const MsTableQuadtree<3> q_noisy(noisy, 0.0);
    auto render = [&](const MsTable<3>& t, const MsTableQuadtree<3>* q) {
        MultipleRenderer pb = multiple_only_renderer(t, 12.0f, albedo, 0.5f, 0.1f, 21);
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
    const auto ref = render(truth, nullptr), dense = render(noisy, &q_noisy), merged = render(noisy, &qn);
    for (std::size_t c = 0; c < 3; ++c) {
        const double e_dense = std::abs(dense[c] / ref[c] - 1), e_merged = std::abs(merged[c] / ref[c] - 1);
        std::printf("ms_quadtree noise-merged render, channel %zu: dense / truth %.4f, noise-merged / truth %.4f (%zu lobes for %zu cells)\n",
                    c, dense[c] / ref[c], merged[c] / ref[c], qn.stored_lobes(), q_noisy.stored_lobes());
        CHECK(ref[c] > 0);
        CHECK(e_merged <= e_dense + 0.02);
        CHECK(merged[c] == Approx(dense[c]).epsilon(0.03));
    }
    CHECK(qn.stored_lobes() * 4 < q_noisy.stored_lobes());
}
