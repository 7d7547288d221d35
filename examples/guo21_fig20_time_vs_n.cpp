// guo21_fig20_time_vs_n: Guo21 Fig. 20 / Sec. 6.8, render time of EPT and ours against the particle
// count N in the CORNELL BOX scene of Fig. 12 (ice spheres of 1000 um, m = 1.31, lambda = 0.55 um;
// guo21_cornell_scene.hpp). For each N: EPT of explicit dielectric spheres (ExplicitSphereMedium:
// exact ray-sphere hits through the particle grid + Fresnel), ours (discrete medium with
// diffraction) and ours -FD (ray optics), all with r_c = r_p / 20 (as guo21_fig12_cornell's EPT
// comparison), in a cloud of non-overlapping spheres (random sequential addition: explicit-sphere
// EPT is exact only for disjoint spheres; `--non-overlapping off` gives the Poisson cloud, whose
// overlaps at N >= 1e6 darken EPT), each split into 8 seeded batches: process CPU seconds, the time to unit variance
// (per-sample variance x CPU seconds per sample, measuring.md) and the means over the pixels that
// look through the cloud, in one run on the same scene.
//
//   guo21_fig20_time_vs_n [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                         [--width W] [--counts 1e4,1e5,...] [--rc-over-rp F] [--non-overlapping on|off]
//                         [--forced-collision Q]
//                         [--checkpoint SECONDS] [--resume]
//
// Every render is split by rows over MPI ranks and resumable (--checkpoint / --resume: one
// checkpoint per batch in --out); CPU seconds are the renders' process CPU time summed over ranks.
//
// Paper: ours ~1.2x faster than EPT at N = 1e5 (Table 1), 2x at N = 1e6, the gain growing with N
// (Fig. 20; its EPT traverses explicit spheres in a BVH). Last stdout line: JSON with lists N,
// cpu_seconds_ept / _discrete / _discrete_no_diffraction, time_ratio (EPT / ours, equal spp),
// ttuv_speedup (EPT / ours, time to unit variance), mean_ept, mean_discrete(_no_diffraction),
// rel_diff_no_diffraction (ours -FD / EPT - 1) with its standard error, the membership rule's
// predicted extinction factor, and bytes per particle. Timings are reported, never asserted.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/traversal/particle_grid.hpp"
#include "guo21_cornell_scene.hpp"
#include "guo21_sphere_bvh.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_fig20_time_vs_n", "Guo21 Fig. 20: render time of EPT vs ours against the particle count",
        "out/guo21_fig20_time_vs_n", [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 32, 128, "samples per pixel (8 seeded batches)");
            const int width = ex.opt<int>("width", 32, 128, "image width = height");
            const std::vector<double> counts = ex.opt<std::vector<double>>("counts", {1e4, 3e4, 1e5, 3e5, 1e6},
                                                                           {1e4, 3e4, 1e5, 3e5, 1e6, 3e6}, "particle counts");
            const double rc_over_rp = ex.opt<double>("rc-over-rp", 0.05, "query radius r_c / r_p");
            const bool hard = ex.opt<bool>("non-overlapping", true,
                                           "on: hard spheres (random sequential addition; EPT of explicit spheres is exact), "
                                           "off: Poisson centres (overlaps allowed, which EPT does not resolve)");
            const double forced = ex.opt<double>("forced-collision", 0.5,
                                                 "ours: forced-collision floor q_min in [0, 1) (0 = analog free flights, "
                                                 "which stop at the collision)");
            const bool ept_bvh = ex.opt<bool>("ept-bvh", true,
                                              "also render EPT with the spheres in a BVH (the paper's EPT structure; "
                                              "guo21_sphere_bvh.hpp) beside EPT through the particle grid");
            ex.checkpointable();
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 8 || spp > 65536) throw gl_examples::cli_error("--spp must be in [8, 65536]");
            if (counts.empty()) throw gl_examples::cli_error("--counts needs at least one value");
            for (double c : counts)
                if (!(c >= 1 && c <= 1e8)) throw gl_examples::cli_error("--counts values must be in [1, 1e8]");
            if (!(forced >= 0 && forced < 1)) throw gl_examples::cli_error("--forced-collision must be in [0, 1)");
            if (!(rc_over_rp > 0 && rc_over_rp <= 10)) throw gl_examples::cli_error("--rc-over-rp must be in (0, 10]");
            const guo21_cornell::Fig20Setup setup(ex, width, spp, rc_over_rp);
            const double r_p = setup.r_p, r_c = setup.r_c;
            const std::vector<char>& mask = setup.mask;
            const std::size_t npix = setup.npix;
            const int batches = setup.batches;
            const double factor = gl::membership_extinction_factor(r_p, r_c, gl::pi_v<double> * r_p * r_p);
            std::printf("Guo21 Fig. 20 (Sec. 6.8): ice spheres r = %.0f um in the Fig. 12 Cornell box, %dx%d, %d spp, r_c = r_p / %.0f "
                        "(-FD membership factor %.3f); CPU seconds per render, %d threads\n",
                        guo21_cornell::kRadiusUm, width, width, spp, 1 / rc_over_rp, factor, ex.threads());
            std::printf("  %9s %8s %8s %8s %10s %10s %11s %11s %12s %9s %7s\n", "N", "EPT s", "ours s", "-FD s", "EPT/ours",
                        "EPT/-FD", "ttuv E/ours", "ttuv E/-FD", "-FD vs EPT", "+- 1 se", "B/part");
            std::vector<double> v_bvh_build, v_tb, v_ratio_b, v_ratio_b_fd, v_tt_b, v_tt_b_fd, v_mb, v_rd_b;
            std::vector<double> v_n, v_te, v_to, v_tf, v_ratio, v_ratio_fd, v_tt, v_tt_fd, v_me, v_mo, v_mf, v_rd, v_rd_se, v_rdo, v_bpp;
            gl_examples::Csv csv({"N", "cpu_seconds_ept", "cpu_seconds_discrete", "cpu_seconds_discrete_no_diffraction",
                                  "time_ratio", "time_ratio_no_diffraction", "ttuv_speedup", "ttuv_speedup_no_diffraction",
                                  "mean_ept", "mean_discrete", "mean_discrete_no_diffraction", "rel_diff_no_diffraction",
                                  "rel_diff_no_diffraction_se", "bytes_per_particle"});
            for (double Nd : counts) {
                const auto N = std::uint64_t(Nd);
                const auto cloud = setup.cloud(N, hard);
                const std::string tag = "N=" + std::to_string(N);
                const guo21_cornell::Run ept = setup.ept_grid(*cloud, "EPT " + tag);
                guo21_cornell::Run eptb;
                if (ept_bvh) {
                    const auto c0 = std::chrono::steady_clock::now();
                    guo21_bvh::SphereBvhLookup lookup(cloud);
                    v_bvh_build.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count());
                    eptb = setup.ept(std::move(lookup), "EPT-BVH " + tag);
                }
                std::size_t medium_bytes = 0;
                const auto o = setup.ours(*cloud, true, forced, "ours " + tag);
                const auto f = setup.ours(*cloud, false, forced, "ours -FD " + tag, &medium_bytes);
                const double bytes_pp = double(medium_bytes) / double(N);
                const double me = guo21_cornell::masked_mean(ept.img, mask), mo = guo21_cornell::masked_mean(o.img, mask),
                             mf = guo21_cornell::masked_mean(f.img, mask);
                const double tt_e = ept.ttuv(npix), tt_o = o.ttuv(npix), tt_f = f.ttuv(npix);
                const double se = std::hypot(f.mean_se, ept.mean_se) / me;
                v_n.push_back(double(N));
                v_te.push_back(ept.cpu_seconds);
                v_to.push_back(o.cpu_seconds);
                v_tf.push_back(f.cpu_seconds);
                v_ratio.push_back(ept.cpu_seconds / o.cpu_seconds);
                v_ratio_fd.push_back(ept.cpu_seconds / f.cpu_seconds);
                v_tt.push_back(tt_e / tt_o);
                v_tt_fd.push_back(tt_e / tt_f);
                v_me.push_back(me);
                v_mo.push_back(mo);
                v_mf.push_back(mf);
                v_rd.push_back(mf / me - 1);
                v_rd_se.push_back(se);
                v_rdo.push_back(mo / me - 1);
                v_bpp.push_back(bytes_pp);
                if (ept_bvh) {
                    const double mb = guo21_cornell::masked_mean(eptb.img, mask), tt_b = eptb.ttuv(npix);
                    v_tb.push_back(eptb.cpu_seconds);
                    v_ratio_b.push_back(eptb.cpu_seconds / o.cpu_seconds);
                    v_ratio_b_fd.push_back(eptb.cpu_seconds / f.cpu_seconds);
                    v_tt_b.push_back(tt_b / tt_o);
                    v_tt_b_fd.push_back(tt_b / tt_f);
                    v_mb.push_back(mb);
                    v_rd_b.push_back(mb / me - 1);
                }
                std::printf("  %9.3g %8.2f %8.2f %8.2f %9.2fx %9.2fx %10.2fx %10.2fx %+12.4f %9.4f %7.1f\n", double(N), ept.cpu_seconds,
                            o.cpu_seconds, f.cpu_seconds, v_ratio.back(), v_ratio_fd.back(), v_tt.back(), v_tt_fd.back(), mf / me - 1,
                            se, bytes_pp);
                if (ept_bvh)
                    std::printf("  %9s EPT with the spheres in a BVH: %.2f s (build %.2f s wall), EPT-BVH / ours %.2fx, / -FD %.2fx at equal spp; "
                                "ttuv %.2fx / %.2fx; mean vs EPT through the grid %+.2e\n",
                                "", eptb.cpu_seconds, v_bvh_build.back(), v_ratio_b.back(), v_ratio_b_fd.back(), v_tt_b.back(),
                                v_tt_b_fd.back(), v_rd_b.back());
                csv.row({double(N), ept.cpu_seconds, o.cpu_seconds, f.cpu_seconds, v_ratio.back(), v_ratio_fd.back(), v_tt.back(),
                         v_tt_fd.back(), me, mo, mf, mf / me - 1, se, bytes_pp});
            }
            if (!ex.root()) return ex.finish({});  // only rank 0 writes
            const auto csv_path = ex.csv("guo21_fig20_time_vs_n.csv", csv);
            ex.plot("guo21_fig20_time_vs_n", csv_path, ex.out() / "guo21_fig20_time_vs_n.png");
            double max_z = 0;
            for (std::size_t i = 0; i < v_rd.size(); ++i) max_z = std::max(max_z, std::abs(v_rd[i]) / std::max(v_rd_se[i], 1e-12));
            std::printf("  paper: EPT / ours = 1.2x at N = 1e5 (Table 1), 2x at N = 1e6 (Fig. 20), growing with N; ours at equal spp: "
                        "%.2fx .. %.2fx, per unit variance %.2fx .. %.2fx (with diffraction)\n",
                        *std::min_element(v_ratio.begin(), v_ratio.end()), *std::max_element(v_ratio.begin(), v_ratio.end()),
                        *std::min_element(v_tt.begin(), v_tt.end()), *std::max_element(v_tt.begin(), v_tt.end()));
            if (ept_bvh)
                std::printf("  against EPT with a BVH (the paper's EPT structure): ours at equal spp %.2fx .. %.2fx, per unit variance "
                            "%.2fx .. %.2fx (with diffraction)\n",
                            *std::min_element(v_ratio_b.begin(), v_ratio_b.end()), *std::max_element(v_ratio_b.begin(), v_ratio_b.end()),
                            *std::min_element(v_tt_b.begin(), v_tt_b.end()), *std::max_element(v_tt_b.begin(), v_tt_b.end()));
            double max_abs_rd = 0, max_abs_rd_small = 0;
            for (std::size_t i = 0; i < v_rd.size(); ++i) {
                max_abs_rd = std::max(max_abs_rd, std::abs(v_rd[i]));
                if (v_n[i] <= 1e5) max_abs_rd_small = std::max(max_abs_rd_small, std::abs(v_rd[i]));
            }
            auto j = ex.summary();
            j.integer("width", width)
                .integer("spp", spp)
                .integer("batches", batches)
                .num("radius_um", guo21_cornell::kRadiusUm)
                .num("rc_over_rp", rc_over_rp)
                .boolean("non_overlapping", hard)
                .num("forced_collision", forced)
                .num("predicted_extinction_factor", factor)
                .nums("N", v_n)
                .nums("cpu_seconds_ept", v_te)
                .nums("cpu_seconds_discrete", v_to)
                .nums("cpu_seconds_discrete_no_diffraction", v_tf)
                .nums("time_ratio", v_ratio)
                .nums("time_ratio_no_diffraction", v_ratio_fd)
                .nums("ttuv_speedup", v_tt)
                .nums("ttuv_speedup_no_diffraction", v_tt_fd)
                .nums("mean_ept", v_me)
                .nums("mean_discrete", v_mo)
                .nums("mean_discrete_no_diffraction", v_mf)
                .nums("rel_diff_no_diffraction", v_rd)
                .nums("rel_diff_no_diffraction_se", v_rd_se)
                .nums("rel_diff_discrete", v_rdo)
                .nums("bytes_per_particle", v_bpp)
                .num("max_abs_rel_diff_no_diffraction", max_abs_rd)
                .num("max_abs_rel_diff_no_diffraction_n_le_1e5", max_abs_rd_small)
                .num("max_z_no_diffraction", max_z)
                .num("bytes_per_particle_max", *std::max_element(v_bpp.begin(), v_bpp.end()))
                .boolean("ept_bvh", ept_bvh);
            if (ept_bvh) {
                double max_rd_b = 0;
                for (double x : v_rd_b) max_rd_b = std::max(max_rd_b, std::abs(x));
                j.nums("cpu_seconds_ept_bvh", v_tb)
                    .nums("cpu_seconds_bvh_build", v_bvh_build)
                    .nums("time_ratio_bvh", v_ratio_b)
                    .nums("time_ratio_bvh_no_diffraction", v_ratio_b_fd)
                    .nums("ttuv_speedup_bvh", v_tt_b)
                    .nums("ttuv_speedup_bvh_no_diffraction", v_tt_b_fd)
                    .nums("mean_ept_bvh", v_mb)
                    .num("max_abs_rel_diff_ept_bvh_vs_grid", max_rd_b);
            }
            j
                .num("paper_time_ratio_1e5", 1.2)
                .num("paper_time_ratio_1e6", 2.0)
                .str("csv", csv_path.string())
                .str("cpu_seconds_note", "process CPU seconds of the renders, summed over the ranks");
            guo21_mpi::rank_rows(j, ex, width);
            return ex.finish(j);
        });
}
