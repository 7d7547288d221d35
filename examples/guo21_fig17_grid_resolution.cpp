// guo21_fig17_grid_resolution: Guo21 Fig. 17 / Sec. 6.5. Render time of the discrete-particle
// medium against the particle grid's resolution. Stand-in for the paper's BENCH mesh: a
// 0.6 x 0.3 x 0.3 m slab of 2e5 log-normal ice particles (r_g = 800 um, sigma_g = 4 as in the
// caption, truncated to [200, 3000] um) on a diffuse floor under a square area light; query radius
// from Eq. 23 with k = 0.01 by default (r_c = 85 um at 64 px, ~1/75 of the voxel at one particle per
// voxel: the regime of Sec. 5.3, "the radius of the cross section is more than two orders of
// magnitude smaller than the side length of the voxel"; --k 0.5 gives fat cylinders, r_c ~ voxel,
// where the optimum moves to coarser grids, docs/guo21.md). Also a query benchmark (free flights +
// shadow transmittances of random rays in the slab, one thread): the grid-dependent cost alone. The grid is set by its mean number of
// particles per voxel (ParticleGridSettings::particles_per_voxel, 1/16 .. 16); every render uses
// the same cloud, seed and spp, so only the traversal cost changes (the images are the same up to
// the order of gathering). Time = process CPU seconds of the render (the best of two passes,
// swept forwards then backwards, against load from other processes).
//
//   guo21_fig17_grid_resolution [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                               [--count N] [--spp N] [--width W] [--checkpoint SECONDS] [--resume]
//
// Under mpirun every render is split by rows over the ranks and gathered (the EXR is byte-identical
// to one process's); its CPU seconds are summed over the ranks; the query benchmark runs on every
// rank and rank 0's is reported. --checkpoint / --resume keep one checkpoint per render (a resumed
// sweep's times count only the rows it rendered itself: time a sweep without resuming).
//
// Last stdout line: JSON with particles_per_voxel, resolution_x/y/z, cpu_seconds (lists over the
// sweep), fastest_particles_per_voxel, fastest_resolution and the paper's 60^3 at 2e5 particles.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <time.h>
#include <memory>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "guo21_mpi_render.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/optics/ice_index.hpp"
#include "grainlight/optics/psd.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

namespace {
/// CPU seconds of the calling thread (CLOCK_THREAD_CPUTIME_ID; measuring.md).
double thread_cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}
}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(argc, argv, "guo21_fig17_grid_resolution",
                            "Guo21 Fig. 17: render time vs particle-grid resolution (minimum near one particle per voxel)",
                            [&](gl_examples::Example& ex) {
        const auto count = ex.opt<std::uint64_t>("count", 200000, 200000, "number of particles (paper: 2e5)");
        const auto spp = ex.opt<std::uint64_t>("spp", 16, 64, "samples per pixel");
        const auto width = ex.opt<std::uint64_t>("width", 64, 256, "image width (height = 3/4 width)");
        const auto k_eq23 = ex.opt<double>("k", 0.01, 0.01,
                                            "query radius parameter k of Eq. 23 (default: r_c ~ voxel / 75, the paper's regime; paper's renders: 0.5-1)");
        const auto rays = ex.opt<std::uint64_t>("rays", 100000, 2000000, "rays of the query benchmark per resolution");
        const auto passes = ex.opt<std::uint64_t>("passes", 3, 3, "sweeps (forwards, backwards, ...); the best time counts");
        ex.checkpointable();
        ex.ready();
        guo21_mpi::quiet_other_ranks(ex);
        if (count < 1000 || count > 50000000) throw gl_examples::cli_error("--count must be in [1000, 5e7]");
        if (spp < 1 || spp > 65536) throw gl_examples::cli_error("--spp must be in [1, 65536]");
        if (width < 16 || width > 4096) throw gl_examples::cli_error("--width must be in [16, 4096]");
        const int W = int(width), H = int(width) * 3 / 4;

        const gl::Vec3d lo(-0.3, 0.0, -0.15), hi(0.3, 0.3, 0.15);
        const gl::LogNormalPsd psd(800.0, 4.0, 200.0, 3000.0);
        auto cloud = std::make_shared<gl::ParticleCloud>(
            gl::ParticleCloud::generate(gl::BoxBoundary(lo, hi), count, {gl::cloud_species(psd)}, ex.seed() * 17 + 3, 1e6));
        gl::ParticleModel model;
        model.particle_index = gl::ice_refractive_index(0.55);

        const gl::PinholeCamera<float> camera(gl::Vec3f(0.0f, 0.45f, 1.4f), gl::Vec3f(0.0f, 0.12f, 0.0f), gl::Vec3f(0, 1, 0),
                                              36.0f, W, H);
        const double z_med = 1.4 - hi.z;
        if (!(k_eq23 > 0 && k_eq23 <= 4)) throw gl_examples::cli_error("--k must be in (0, 4]");
        if (passes < 1 || passes > 8) throw gl_examples::cli_error("--passes must be in [1, 8]");
        const double r_c = gl::query_radius_eq23(k_eq23, double(camera.spread_angle()), 1.0, z_med);

        gl::RenderOptions opt;
        opt.spp = int(spp);
        opt.threads = ex.threads();
        opt.seed = ex.seed();
        opt.vpt.max_depth = 256;

        // A ray of the query benchmark and the work count: from a uniform point of the slab in a
        // uniform direction; t1 = its distance to the slab's exit (false if it misses the slab).
        auto slab_ray = [&](gl::Rng& rng, gl::Vec3f& o, gl::Vec3f& d, float& t1) {
            const double ux = rng.uniform<double>(), uy = rng.uniform<double>(), uz = rng.uniform<double>();  // in this order
            o = gl::Vec3f(float(lo.x + (hi.x - lo.x) * ux), float(lo.y + (hi.y - lo.y) * uy), float(lo.z + (hi.z - lo.z) * uz));
            d = gl::sample_uniform_sphere(rng.uniform2<float>());
            float t0 = 0;
            t1 = 1e30f;
            return gl::clip_to_box(o, d, gl::Vec3f(lo), gl::Vec3f(hi), t0, t1);
        };
        const std::uint64_t work_rays = std::min<std::uint64_t>(rays, 20000);  // rays of the work count
        const std::vector<double> ppv_target = {1.0 / 16, 1.0 / 8, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0};
        struct Point {
            std::array<int, 3> res{};
            double ppv = 0, refs_per_particle = 0, build_seconds = 0, cpu_seconds = 1e300, mean = 0, query_ns = 1e300;
            double steps_per_ray = 0, tests_per_ray = 0, members = 0;
            std::size_t memory = 0;
        };
        std::vector<Point> pts(ppv_target.size());
        gl::Image first_img;
        std::printf("Guo21 Fig. 17 (Sec. 6.5): %llu ice particles (log-normal r_g = 800 um, sigma_g = 4), %dx%d, %d spp,"
                    " r_c = %.3f mm (k = %.3g)\n",
                    (unsigned long long)count, W, H, int(spp), r_c * 1e3, k_eq23);
        gl_examples::ProgressBar bar("grid sweep", passes * ppv_target.size() * std::uint64_t(H), !ex.root());
        for (int pass = 0; pass < int(passes); ++pass)
            for (std::size_t q = 0; q < ppv_target.size(); ++q) {
                const std::size_t k = pass == 0 ? q : ppv_target.size() - 1 - q;
                gl::ParticleGridSettings gs;
                gs.dilation = r_c;
                gs.particles_per_voxel = ppv_target[k];
                const std::clock_t b0 = std::clock();
                auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
                const double build = double(std::clock() - b0) / CLOCKS_PER_SEC;
                gl::DiscreteMediumSettings ms;
                ms.query_radius = r_c;
                using M = gl::DiscreteParticleMedium<float>;
                gl::Scene<M> sc;
                const int med = sc.add_medium(M(grid, {model}, ms));
                using Mat = gl::Material<float, S>;
                sc.add_shape(gl::QuadShape<float>(gl::Vec3f(-2, 0, -2), gl::Vec3f(4, 0, 0), gl::Vec3f(0, 0, 4)),
                             Mat::diffuse(S(0.6f)));
                sc.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-0.3f, 1.2f, -0.3f), gl::Vec3f(0.6f, 0, 0), gl::Vec3f(0, 0, 0.6f)),
                                  S(8.0f));
                const float m = float(r_c + 3.1e-3);
                sc.add_shape(gl::BoxShape<float>(gl::Vec3f(lo) - gl::Vec3f(m), gl::Vec3f(hi) + gl::Vec3f(m)), Mat::index_matched(),
                             med, -1);
                // Query benchmark (one thread, thread CPU time): free flights and shadow transmittances
                // of rays from uniform points in the slab in uniform directions to the slab's exit: the
                // part of the cost the grid resolution changes.
                {
                    const M& med_ref = sc.medium(med);
                    double sink = 0;
                    const double q0 = thread_cpu_seconds();
                    for (std::uint64_t r = 0; r < rays; ++r) {
                        gl::Rng rng = gl::Rng::from_key(ex.seed(), 7, r);
                        gl::Vec3f o, d;
                        float t1 = 0;
                        if (!slab_ray(rng, o, d, t1)) continue;
                        const gl::Ray<float> ray(o, d, t1);
                        const auto it = med_ref.sample_interaction(ray, t1, rng);
                        sink += double(it.t) + double(med_ref.transmittance(ray, t1, rng)[0]);
                    }
                    const double qs = thread_cpu_seconds() - q0;
                    pts[k].query_ns = std::min(pts[k].query_ns, qs * 1e9 / double(rays));
                    if (sink == -1) std::printf(" ");
                }
                // Work count (deterministic, pass 0): the same kind of rays walked over the whole slab
                // chord through the grid alone. DDA steps (cells crossed, empty ones included), particle
                // references tested, and cylinder members found, which must not depend on the grid.
                if (pass == 0) {
                    const auto& rs = grid->resolution();
                    auto cell_xyz = [&](const gl::Vec3f& p, std::int64_t out[3]) {
                        const std::int64_t c = grid->cell_of(p);
                        out[0] = c % rs[0];
                        out[1] = (c / rs[0]) % rs[1];
                        out[2] = c / (std::int64_t(rs[0]) * rs[1]);
                    };
                    double steps = 0, tests = 0, members = 0;
                    for (std::uint64_t r = 0; r < work_rays; ++r) {
                        gl::Rng rng = gl::Rng::from_key(ex.seed(), 11, r);
                        gl::Vec3f o, d;
                        float t1 = 0;
                        if (!slab_ray(rng, o, d, t1)) continue;
                        std::int64_t a[3], e[3];
                        cell_xyz(o, a);
                        cell_xyz(o + t1 * d, e);
                        steps += 1.0 + double(std::abs(e[0] - a[0]) + std::abs(e[1] - a[1]) + std::abs(e[2] - a[2]));
                        grid->walk_voxels(o, d, 0.0f, t1, [&](std::span<const std::uint32_t> refs, float, float) {
                            tests += double(refs.size());
                            return true;
                        });
                        grid->for_each_in_cylinder(o, d, 0.0f, t1, float(r_c), [&](std::uint32_t, float, float) {
                            members += 1;
                            return true;
                        });
                    }
                    pts[k].steps_per_ray = steps / double(work_rays);
                    pts[k].tests_per_ray = tests / double(work_rays);
                    pts[k].members = members;
                }
                guo21_mpi::RankClock clock;
                const gl::Image img = guo21_mpi::render_image(
                    ex, opt, "ppv" + std::to_string(k) + ".pass" + std::to_string(pass),
                    [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_discrete_vpt(sc, camera, o, prog); },
                    [&](int n) { bar.advance(std::uint64_t(n)); }, &clock);
                const double cpu = guo21_mpi::sum_over_ranks(ex.mpi(), clock.cpu);
                Point& p = pts[k];
                p.res = grid->resolution();
                p.ppv = double(count) / double(grid->cell_count());
                p.refs_per_particle = double(grid->reference_count()) / double(count);
                p.build_seconds = build;
                p.memory = grid->memory_bytes();
                p.cpu_seconds = std::min(p.cpu_seconds, cpu);
                double s = 0;
                for (std::size_t i = 0; i < img.rgb.size(); i += 3) s += img.rgb[i];
                p.mean = s / double(img.rgb.size() / 3);
                if (pass == 0 && k == 4 && ex.root()) {
                    first_img = img;
                    gl::write_exr(ex.out() / "render_ppv1.exr", img);
                    gl::write_png(ex.out() / "render_ppv1.png", img);
                }
            }
        bar.done();

        std::size_t best = 0, best_q = 0;
        for (std::size_t k = 1; k < pts.size(); ++k) {
            if (pts[k].cpu_seconds < pts[best].cpu_seconds) best = k;
            if (pts[k].query_ns < pts[best_q].query_ns) best_q = k;
        }
        gl_examples::Csv csv({"particles_per_voxel", "resolution_x", "resolution_y", "resolution_z", "refs_per_particle",
                              "cpu_seconds", "query_ns_per_ray", "build_seconds", "grid_mb", "mean_radiance"});
        std::printf("  %10s %16s %10s %12s %12s %10s %10s\n", "ppv", "resolution", "refs/part", "render CPU s", "query ns/ray",
                    "build s", "grid MB");
        std::vector<double> v_ppv, v_rx, v_ry, v_rz, v_sec, v_q, v_steps, v_tests;
        for (const auto& p : pts) {
            std::printf("  %10.3f %5d x%4d x%4d %10.2f %12.2f %12.0f %10.2f %10.1f%s%s\n", p.ppv, p.res[0], p.res[1], p.res[2],
                        p.refs_per_particle, p.cpu_seconds, p.query_ns, p.build_seconds, double(p.memory) / 1048576.0,
                        &p == &pts[best_q] ? "  <- fastest queries" : "", &p == &pts[best] ? "  <- fastest render" : "");
            csv.row({p.ppv, double(p.res[0]), double(p.res[1]), double(p.res[2]), p.refs_per_particle, p.cpu_seconds, p.query_ns,
                     p.build_seconds, double(p.memory) / 1048576.0, p.mean});
            v_q.push_back(p.query_ns);
            v_steps.push_back(p.steps_per_ray);
            v_tests.push_back(p.tests_per_ray);
            v_ppv.push_back(p.ppv);
            v_rx.push_back(p.res[0]);
            v_ry.push_back(p.res[1]);
            v_rz.push_back(p.res[2]);
            v_sec.push_back(p.cpu_seconds);
        }
        const Point& b = pts[best];
        // The sweep point nearest to one particle per voxel, and the finest grid, against the fastest.
        std::size_t one = 0;
        for (std::size_t k = 1; k < pts.size(); ++k)
            if (std::abs(std::log(pts[k].ppv)) < std::abs(std::log(pts[one].ppv))) one = k;
        const double one_over_fastest = pts[one].cpu_seconds / b.cpu_seconds;
        const double finest_over_fastest = pts[0].cpu_seconds / b.cpu_seconds;
        std::printf("  render time at %.2f particles per voxel / fastest = %.3f; finest grid (%.3f per voxel) / fastest = %.3f\n",
                    pts[one].ppv, one_over_fastest, pts[0].ppv, finest_over_fastest);
        std::printf("  fastest: %d x %d x %d = %.2f particles per voxel (paper: 60^3 for 2e5 particles = %.2f per voxel;\n"
                    "  'roughly one particle per voxel')\n",
                    b.res[0], b.res[1], b.res[2], b.ppv, 2e5 / (60.0 * 60 * 60));
        // The two sides of the trade-off, counted rather than timed (the same on any machine): a
        // finer grid walks more cells, a coarser one tests more particle references per ray; the
        // particles found in the query cylinders are the same at every resolution.
        bool members_equal = true;
        for (const auto& p : pts) members_equal = members_equal && p.members == pts[0].members;
        const Point& coarsest = pts.back();
        std::printf("  work per ray (slab chords, no timing): DDA steps %.1f (finest) .. %.1f (coarsest); particle tests"
                    " %.1f .. %.1f; cylinder members %.3f at every resolution: %s\n",
                    pts[0].steps_per_ray, coarsest.steps_per_ray, pts[0].tests_per_ray, coarsest.tests_per_ray,
                    pts[0].members / double(work_rays), members_equal ? "yes" : "NO");
        if (!ex.root()) return ex.finish({});  // only rank 0 writes
        const auto csv_path = ex.csv("guo21_fig17_grid_resolution.csv", csv);
        ex.plot("guo21_fig17_grid_resolution", csv_path, ex.out() / "guo21_fig17_grid_resolution.png");
        auto j = ex.summary();
        guo21_mpi::rank_rows(j, ex, H);
        j.str("cpu_seconds_note", "process CPU seconds of the renders, summed over the ranks");
        return ex.finish(j.integer("count", (long long)count)
                             .integer("spp", (long long)spp)
                             .num("query_radius_m", r_c)
                             .nums("particles_per_voxel", v_ppv)
                             .nums("resolution_x", v_rx)
                             .nums("resolution_y", v_ry)
                             .nums("resolution_z", v_rz)
                             .nums("cpu_seconds", v_sec)
                             .nums("query_ns_per_ray", v_q)
                             .num("fastest_particles_per_voxel", b.ppv)
                             .num("fastest_particles_per_voxel_queries", pts[best_q].ppv)
                             .nums("dda_steps_per_ray", v_steps)
                             .nums("particle_tests_per_ray", v_tests)
                             .integer("members_equal_across_grids", members_equal ? 1 : 0)
                             .num("dda_steps_finest_over_coarsest", pts[0].steps_per_ray / coarsest.steps_per_ray)
                             .num("particle_tests_coarsest_over_finest", coarsest.tests_per_ray / pts[0].tests_per_ray)
                             .num("time_at_one_over_fastest", one_over_fastest)
                             .num("finest_over_fastest", finest_over_fastest)
                             .str("fastest_resolution",
                                  std::to_string(b.res[0]) + "x" + std::to_string(b.res[1]) + "x" + std::to_string(b.res[2]))
                             .num("paper_fastest_particles_per_voxel", 2e5 / (60.0 * 60 * 60)));
    });
}
