// wang18_fig24_epsilon: Wang & Holzschuch 2018 (TVCG), Fig. 24 ("Performance and error,
// depending on the Solid Angle Threshold for refinement"): point-based render time and error
// e^2 of the total (per-pixel MSE against the VPT minus the reference's own variance,
// measuring.md) as a function of Alg. 1's eps1 (eps2 = eps1 / 5), against one VPT reference.
// The paper uses its Wax scene; we use the bumpy sphere mesh with the BmpS. material
// (examples/wang18_bumpy.hpp; the VPT of Wax at 20 mean free paths costs too much for a sweep).
// Paper: time grows and error falls as eps1 decreases; sweet spot eps1 ~ 0.1.
//
//   wang18_fig24_epsilon [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                        [--eps LIST] [--vpt-spp N] [--surface-samples N] [--width N] [--radius-mfp R]
//
// Outputs: wang18_fig24_epsilon.csv (+ .png), JSON summary with per-eps1 arrays.
#include <algorithm>
#include <cstdio>
#include <string>

#include "wang18_bumpy.hpp"

namespace gl = grainlight;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_fig24_epsilon", "Wang18 Fig. 24: point-based time and error vs the solid-angle threshold eps1",
        "out/wang18_fig24_epsilon", [&](gl_examples::Example& ex) -> int {
            const std::vector<double> eps = ex.opt<std::vector<double>>("eps", {2.0, 1.0, 0.5, 0.2},
                                                                        {2.0, 1.0, 0.5, 0.2, 0.1, 0.05}, "eps1 values (sr)");
            const int vpt_spp = ex.opt<int>("vpt-spp", 256, 2048, "VPT samples per pixel and channel (multiple of 8)");
            const int n_surface = ex.opt<int>("surface-samples", 6000, 40000, "Poisson-disk light surface samples");
            const int rays = ex.opt<int>("rays", 4, 4, "camera rays per pixel of the point-based render");
            const int W = ex.opt<int>("width", 16, 64, "image width = height in pixels");
            const double R_opt = ex.opt<double>("radius-mfp", 20.0, "sphere radius in green mean free paths");
            ex.checkpointable();
            ex.ready();
            wang18::check_vpt_spp(vpt_spp);
            wang18::check_surface_samples(n_surface);
            wang18::check_render_args(rays, W, R_opt);
            if (eps.empty()) throw gl_examples::cli_error("--eps needs at least one value");
            for (double e : eps)
                if (!(e > 0 && e <= 10)) throw gl_examples::cli_error("--eps values must be in (0, 10]");
            const bool full = ex.full();
            const auto& out = ex.out();
            const std::uint64_t seed = ex.seed();

            const wang18::BumpyScene sc = wang18::make_bumpy_scene(W, float(R_opt), 0.7f);
            double cpu_table = 0;
            bool cached = false;
            const gl::MsTable<3> table = wang18::cached_table(out, sc, full, seed, cpu_table, cached, ex.root());
            const wang18::VptRun vpt = wang18::render_vpt(ex, sc, vpt_spp, seed, "fig24 VPT reference");
            gl_examples::Csv csv({"eps1", "e2_total", "e2_double", "e2_multiple", "cost_render_seconds", "rel_diff_total"});
            std::vector<double> e2, secs, rel;
            if (ex.root()) std::printf("Wang18 Fig. 24: time and error vs eps1, bumpy sphere mesh, radius %.0f green mfp, g 0.7, %d surface "
                        "samples, %d x %d pixels, VPT %d spp (%.2f s)\n",
                        R_opt, n_surface, W, W, vpt_spp, vpt.cpu);
            if (ex.root()) std::printf("  %7s %11s %11s %11s %10s\n", "eps1", "render s", "samples s", "e^2 total", "rel.diff");
            for (double e : eps) {
                gl::PointBasedOptions<float> po = wang18::default_options(sc, full);
                po.cut.eps1 = float(e);
                po.cut.eps2 = 0.2f * float(e);
                char lab[48];
                std::snprintf(lab, sizeof lab, "fig24 eps1=%.2f", e);
                const wang18::PbRun pb = wang18::render_pb(ex, sc, &table, po, n_surface, seed, lab, rays);
                const wang18::Comparison c = wang18::compare(pb, vpt);
                e2.push_back(c.e2[4]);
                secs.push_back(pb.cpu_render);
                rel.push_back(c.rel[4]);
                csv.row({e, c.e2[4], c.e2[1], c.e2[2], pb.cpu_render, c.rel[4]});
                if (ex.root()) std::printf("  %7.2f %11.2f %11.2f %11.3e %+9.1f%%\n", e, pb.cpu_render, pb.cpu_samples, c.e2[4],
                            100 * c.rel[4]);
            }
            if (!ex.root()) return ex.finish({});  // rank 0 writes and prints
            const auto csv_path = ex.csv("wang18_fig24_epsilon.csv", csv);
            ex.plot("wang18_sweep", csv_path, out / "wang18_fig24_epsilon.png",
                    {"eps1 (sr)", "render CPU seconds", "Wang18 Fig. 24: time and error vs eps1", "logx"});
            if (ex.root()) std::printf("  [paper Fig. 24 (Wax): time grows and error falls as eps1 decreases; sweet spot eps1 ~ 0.1]\n");
            gl_examples::Json j = ex.summary();
            wang18::put_rank_rows(ex, j, W);
            j.nums("eps1", eps).nums("e2_total", e2).nums("seconds_render", secs).nums("rel_diff_total", rel);
            j.num("seconds_ratio_smallest_over_largest_eps", secs.front() > 0 ? secs.back() / secs.front() : 0.0)
                .num("seconds_vpt", vpt.cpu)
                .integer("vpt_spp", vpt_spp)
                .str("png", (out / "wang18_fig24_epsilon.png").string());
            return ex.finish(j);
        });
}
