// guo21_ept_embree: Guo21 Fig. 20's comparison against an EPT whose spheres sit in a production
// BVH. The paper's EPT instances the particles as balls in Mitsuba, which traverses them in a BVH;
// the library's EPT (ExplicitSphereMedium) walks the uniform particle grid the discrete medium also
// uses. Here the same explicit-sphere EPT runs through the grid and through Embree 3's sphere
// points (embree/guo21_embree_spheres.hpp), beside ours (the discrete medium with diffraction), in
// the Fig. 12 Cornell box (1000 um ice spheres, hard-sphere cloud, r_c = r_p / 20), each render split
// into 8 seeded batches: CPU seconds, the time to unit variance (measuring.md) and the masked means.
// Built only when find_package(embree 3) succeeds (Debian: libembree-dev).
//
//   guo21_ept_embree [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                    [--width W] [--counts 1e5,1e6]
//
// Paper: EPT / ours 1.2x at N = 1e5 (Table 1), 2x at 1e6 (Fig. 20). Last stdout line: JSON with
// lists N, cpu_seconds_ept_grid / _ept_embree / _discrete, time_ratio_embree and
// time_ratio_grid (EPT / ours at equal spp), ttuv_speedup_embree / _grid, mean_ept_grid,
// mean_ept_embree, rel_diff_embree_vs_grid (with its standard error) and embree_build_seconds.
// Timings are reported, never asserted.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "embree/guo21_embree_spheres.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/traversal/particle_grid.hpp"
#include "guo21_cornell_scene.hpp"

namespace gl = grainlight;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_ept_embree", "Guo21 Fig. 20 against EPT with the spheres in Embree's BVH",
        "out/guo21_ept_embree", [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 32, 128, "samples per pixel (8 seeded batches)");
            const int width = ex.opt<int>("width", 32, 128, "image width = height");
            const std::vector<double> counts =
                ex.opt<std::vector<double>>("counts", {1e5, 1e6}, {1e5, 1e6, 3e6}, "particle counts");
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 8 || spp > 65536) throw gl_examples::cli_error("--spp must be in [8, 65536]");
            if (counts.empty()) throw gl_examples::cli_error("--counts needs at least one value");
            for (double c : counts)
                if (!(c >= 1 && c <= 1e8)) throw gl_examples::cli_error("--counts values must be in [1, 1e8]");
            const guo21_cornell::Fig20Setup setup(ex, width, spp, 0.05);
            const std::vector<char>& mask = setup.mask;
            const std::size_t npix = setup.npix;
            const int batches = setup.batches;
            std::printf("Guo21 Fig. 20 against EPT in Embree's BVH: ice spheres r = %.0f um (hard spheres) in the Fig. 12 Cornell box, "
                        "%dx%d, %d spp, r_c = r_p / 20; CPU seconds per render, %d threads\n",
                        guo21_cornell::kRadiusUm, width, width, spp, ex.threads());
            std::printf("  %9s %10s %11s %8s %12s %12s %12s %12s %14s\n", "N", "EPT grid s", "EPT Embree s", "ours s",
                        "grid/ours", "Embree/ours", "ttuv grid", "ttuv Embree", "Embree vs grid");
            std::vector<double> v_n, v_tg, v_te, v_to, v_rg, v_re, v_ttg, v_tte, v_mg, v_me, v_rd, v_rd_se, v_build;
            gl_examples::Csv csv({"N", "cpu_seconds_ept_grid", "cpu_seconds_ept_embree", "cpu_seconds_discrete", "time_ratio_grid",
                                  "time_ratio_embree", "ttuv_speedup_grid", "ttuv_speedup_embree", "mean_ept_grid",
                                  "mean_ept_embree", "rel_diff_embree_vs_grid", "embree_build_seconds"});
            for (double Nd : counts) {
                const auto N = std::uint64_t(Nd);
                const auto cloud = setup.cloud(N);
                const std::string tag = "N=" + std::to_string(N);
                const guo21_cornell::Run grid_run = setup.ept_grid(*cloud, "EPT grid " + tag);
                guo21_cornell::Run embree_run;
                {
                    guo21_embree::EmbreeSphereLookup lookup(cloud);
                    v_build.push_back(lookup.build_seconds());
                    embree_run = setup.ept(std::move(lookup), "EPT Embree " + tag);
                }
                const guo21_cornell::Run ours_run = setup.ours(*cloud, true, 0.5, "ours " + tag);
                const double mg = guo21_cornell::masked_mean(grid_run.img, mask), me = guo21_cornell::masked_mean(embree_run.img, mask);
                const double tt_g = grid_run.ttuv(npix), tt_e = embree_run.ttuv(npix), tt_o = ours_run.ttuv(npix);
                v_n.push_back(double(N));
                v_tg.push_back(grid_run.cpu_seconds);
                v_te.push_back(embree_run.cpu_seconds);
                v_to.push_back(ours_run.cpu_seconds);
                v_rg.push_back(grid_run.cpu_seconds / ours_run.cpu_seconds);
                v_re.push_back(embree_run.cpu_seconds / ours_run.cpu_seconds);
                v_ttg.push_back(tt_g / tt_o);
                v_tte.push_back(tt_e / tt_o);
                v_mg.push_back(mg);
                v_me.push_back(me);
                v_rd.push_back(me / mg - 1);
                v_rd_se.push_back(std::hypot(grid_run.mean_se, embree_run.mean_se) / mg);
                std::printf("  %9.3g %10.2f %11.2f %8.2f %11.2fx %11.2fx %11.2fx %11.2fx %+9.4f +- %.4f   (Embree build %.2f s wall)\n",
                            double(N), grid_run.cpu_seconds, embree_run.cpu_seconds, ours_run.cpu_seconds, v_rg.back(), v_re.back(),
                            v_ttg.back(), v_tte.back(), v_rd.back(), v_rd_se.back(), v_build.back());
                csv.row({double(N), grid_run.cpu_seconds, embree_run.cpu_seconds, ours_run.cpu_seconds, v_rg.back(), v_re.back(),
                         v_ttg.back(), v_tte.back(), mg, me, v_rd.back(), v_build.back()});
            }
            if (!ex.root()) return ex.finish({});
            const auto csv_path = ex.csv("guo21_ept_embree.csv", csv);
            std::printf("  paper: EPT / ours = 1.2x at N = 1e5 (Table 1), 2x at N = 1e6 (Fig. 20); against EPT in Embree, ours at "
                        "equal spp %.2fx .. %.2fx, per unit variance %.2fx .. %.2fx\n",
                        *std::min_element(v_re.begin(), v_re.end()), *std::max_element(v_re.begin(), v_re.end()),
                        *std::min_element(v_tte.begin(), v_tte.end()), *std::max_element(v_tte.begin(), v_tte.end()));
            double max_abs_rd = 0, max_z = 0;
            for (std::size_t i = 0; i < v_rd.size(); ++i) {
                max_abs_rd = std::max(max_abs_rd, std::abs(v_rd[i]));
                max_z = std::max(max_z, std::abs(v_rd[i]) / std::max(v_rd_se[i], 1e-12));
            }
            auto j = ex.summary();
            j.integer("width", width)
                .integer("spp", spp)
                .integer("batches", batches)
                .num("radius_um", guo21_cornell::kRadiusUm)
                .num("rc_over_rp", 0.05)
                .nums("N", v_n)
                .nums("cpu_seconds_ept_grid", v_tg)
                .nums("cpu_seconds_ept_embree", v_te)
                .nums("cpu_seconds_discrete", v_to)
                .nums("time_ratio_grid", v_rg)
                .nums("time_ratio_embree", v_re)
                .nums("ttuv_speedup_grid", v_ttg)
                .nums("ttuv_speedup_embree", v_tte)
                .nums("mean_ept_grid", v_mg)
                .nums("mean_ept_embree", v_me)
                .nums("rel_diff_embree_vs_grid", v_rd)
                .nums("rel_diff_embree_vs_grid_se", v_rd_se)
                .nums("embree_build_seconds", v_build)
                .num("max_abs_rel_diff_embree_vs_grid", max_abs_rd)
                .num("max_z_embree_vs_grid", max_z)
                .num("paper_time_ratio_1e5", 1.2)
                .num("paper_time_ratio_1e6", 2.0)
                .str("csv", csv_path.string())
                .str("cpu_seconds_note", "process CPU seconds of the renders, summed over the ranks");
            guo21_mpi::rank_rows(j, ex, width);
            return ex.finish(j);
        });
}
