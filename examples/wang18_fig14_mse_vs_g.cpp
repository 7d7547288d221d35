// wang18_fig14_mse_vs_g: Wang & Holzschuch 2018 (TVCG), Fig. 14 ("Mean Square Error of
// single/double/multiple scattering as a function of g for the Bumpy Sphere Scene"): the
// per-component error e^2 (per-pixel MSE against the VPT minus the reference's own variance,
// measuring.md) of the point-based renderer on the bumpy sphere mesh (examples/wang18_bumpy.hpp)
// for HG g in {0, 0.3, 0.5, 0.7, 0.9}, with a constant number of surface samples. Paper: the
// error of each component stays within one order of magnitude from g = 0 to 0.9.
//
//   wang18_fig14_mse_vs_g [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                         [--g LIST] [--vpt-spp N] [--surface-samples N] [--width N] [--radius-mfp R]
//
// Outputs: wang18_fig14_mse_vs_g.csv (+ .png plot), JSON summary (last stdout line) with
// e2_<component> per g (arrays) and the largest/smallest ratio of e^2 over g per component.
#include <algorithm>
#include <cstdio>
#include <string>

#include "wang18_bumpy.hpp"

namespace gl = grainlight;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_fig14_mse_vs_g", "Wang18 Fig. 14: per-component error of the point-based renderer vs HG g",
        "out/wang18_fig14_mse_vs_g", [&](gl_examples::Example& ex) -> int {
            const std::vector<double> gs = ex.opt<std::vector<double>>("g", {0.0, 0.3, 0.5, 0.7, 0.9}, "HG g values");
            const int vpt_spp = ex.opt<int>("vpt-spp", 128, 1024, "VPT samples per pixel and channel (multiple of 8)");
            const int n_surface = ex.opt<int>("surface-samples", 10000, 40000, "Poisson-disk light surface samples");
            const int rays = ex.opt<int>("rays", 4, 4, "camera rays per pixel of the point-based render");
            const int W = ex.opt<int>("width", 20, 64, "image width = height in pixels");
            const double R_opt = ex.opt<double>("radius-mfp", 20.0, "sphere radius in green mean free paths");
            ex.checkpointable();
            ex.ready();
            wang18::check_vpt_spp(vpt_spp);
            wang18::check_surface_samples(n_surface);
            wang18::check_render_args(rays, W, R_opt);
            if (gs.empty()) throw gl_examples::cli_error("--g needs at least one value");
            for (double g : gs)
                if (!(g >= 0 && g < 0.96)) throw gl_examples::cli_error("--g values must be in [0, 0.96)");
            const bool full = ex.full();
            const auto& out = ex.out();
            const std::uint64_t seed = ex.seed();

            gl_examples::Csv csv({"g", "e2_single", "e2_double", "e2_multiple", "e2_bounced", "e2_total", "rel_diff_single",
                                  "rel_diff_double", "rel_diff_multiple", "rel_diff_bounced", "rel_diff_total",
                                  "seconds_pb", "seconds_vpt"});
            std::vector<double> e2[wang18::kComp], rel[wang18::kComp];
            if (ex.root()) std::printf("Wang18 Fig. 14: e^2 per component vs g, bumpy sphere mesh, radius %.0f green mfp, BmpS. albedo, "
                        "%d surface samples, %d x %d pixels, VPT %d spp\n",
                        R_opt, n_surface, W, W, vpt_spp);
            if (ex.root()) std::printf("  %5s %11s %11s %11s %11s %11s   rel.diff total\n", "g", "single", "double", "multiple", "bounced",
                        "total");
            for (double g : gs) {
                const wang18::BumpyScene sc = wang18::make_bumpy_scene(W, float(R_opt), float(g));
                double cpu_table = 0;
                bool cached = false;
                const gl::MsTable<3> table = wang18::cached_table(out, sc, full, seed, cpu_table, cached, ex.root());
                gl::PointBasedOptions<float> po = wang18::default_options(sc, full);
                po.bounce_samples = full ? 2048 : 256;
                char lab[64];
                std::snprintf(lab, sizeof lab, "fig14 g=%.2f", g);
                const wang18::PbRun pb = wang18::render_pb(ex, sc, &table, po, n_surface, seed, std::string(lab) + " point-based", rays);
                const wang18::VptRun vpt = wang18::render_vpt(ex, sc, vpt_spp, seed, std::string(lab) + " VPT");
                const wang18::Comparison c = wang18::compare(pb, vpt);
                std::vector<double> row{g};
                for (int k = 0; k < wang18::kComp; ++k) {
                    e2[k].push_back(c.e2[k]);
                    rel[k].push_back(c.rel[k]);
                    row.push_back(c.e2[k]);
                }
                for (int k = 0; k < wang18::kComp; ++k) row.push_back(c.rel[k]);
                row.push_back(pb.cpu_total());
                row.push_back(vpt.cpu);
                csv.row(row);
                if (ex.root()) std::printf("  %5.2f %11.3e %11.3e %11.3e %11.3e %11.3e   %+.1f%% (+- %.1f%%)\n", g, c.e2[0], c.e2[1], c.e2[2],
                            c.e2[3], c.e2[4], 100 * c.rel[4], 100 * c.rel_se[4]);
            }
            if (!ex.root()) return ex.finish({});  // rank 0 writes and prints
            const auto csv_path = ex.csv("wang18_fig14_mse_vs_g.csv", csv);
            ex.plot("wang18_sweep", csv_path, out / "wang18_fig14_mse_vs_g.png",
                    {"HG g", "-", "Wang18 Fig. 14: error per component vs g (bumpy sphere)"});
            gl_examples::Json j = ex.summary();
            wang18::put_rank_rows(ex, j, W);
            j.nums("g", gs).integer("surface_samples", n_surface).integer("vpt_spp", vpt_spp).integer("width", W);
            if (ex.root()) std::printf("  spread of e^2 over g (max / min) per component:");
            for (int k = 0; k < wang18::kComp; ++k) {
                const std::string nm = wang18::kCompName[k];
                const double mx = *std::max_element(e2[k].begin(), e2[k].end());
                const double mn = *std::min_element(e2[k].begin(), e2[k].end());
                const double spread = mn > 0 ? mx / mn : 0.0;
                double worst = 0;
                for (double r : rel[k]) worst = std::max(worst, std::abs(r));
                j.nums("e2_" + nm, e2[k]).nums("rel_diff_" + nm, rel[k]).num("e2_spread_" + nm, spread).num(
                    "max_abs_rel_diff_" + nm, worst);
                if (ex.root()) std::printf(" %s %.1fx", nm.c_str(), spread);
            }
            if (ex.root()) std::printf("   [paper Fig. 14: within one order of magnitude, MSE ~1e-4..1e-3]\n");
            j.str("png", (out / "wang18_fig14_mse_vs_g.png").string());
            return ex.finish(j);
        });
}
