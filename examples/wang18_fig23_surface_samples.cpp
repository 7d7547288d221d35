// wang18_fig23_surface_samples: Wang & Holzschuch 2018 (TVCG), Fig. 23 ("Performance and error,
// depending on the number of Surface Samples"): point-based CPU time (sample pass + render) and
// error e^2 of the total (per-pixel MSE against the VPT minus the reference's own variance,
// measuring.md) as a function of the number of Poisson-disk light surface samples on the bumpy
// sphere mesh (examples/wang18_bumpy.hpp), against one VPT reference. Paper: error and time both
// fall from 7 K samples to a sweet spot near 66 K, above which time grows with no gain in error.
//
//   wang18_fig23_surface_samples [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                                [--counts LIST] [--vpt-spp N] [--width N] [--radius-mfp R]
//
// Outputs: wang18_fig23_surface_samples.csv (+ .png), JSON summary with per-count arrays.
#include <algorithm>
#include <cstdio>
#include <string>

#include "wang18_bumpy.hpp"

namespace gl = grainlight;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_fig23_surface_samples",
        "Wang18 Fig. 23: point-based time and error vs the number of surface samples", "out/wang18_fig23_surface_samples",
        [&](gl_examples::Example& ex) -> int {
            const std::vector<double> counts = ex.opt<std::vector<double>>(
                "counts", {1000, 2000, 4000, 8000, 16000}, {7000, 16000, 33000, 66000, 132000},
                "light surface sample counts");
            const int vpt_spp = ex.opt<int>("vpt-spp", 256, 2048, "VPT samples per pixel and channel (multiple of 8)");
            const int rays = ex.opt<int>("rays", 4, 4, "camera rays per pixel of the point-based render");
            const int W = ex.opt<int>("width", 20, 64, "image width = height in pixels");
            const double R_opt = ex.opt<double>("radius-mfp", 20.0, "sphere radius in green mean free paths");
            ex.checkpointable();
            ex.ready();
            wang18::check_vpt_spp(vpt_spp);
            wang18::check_render_args(rays, W, R_opt);
            if (counts.empty()) throw gl_examples::cli_error("--counts needs at least one value");
            for (double n : counts)
                if (!(n >= 16 && n <= 1e7)) throw gl_examples::cli_error("--counts values must be in [16, 1e7]");
            const bool full = ex.full();
            const auto& out = ex.out();
            const std::uint64_t seed = ex.seed();

            const wang18::BumpyScene sc = wang18::make_bumpy_scene(W, float(R_opt), 0.7f);
            double cpu_table = 0;
            bool cached = false;
            const gl::MsTable<3> table = wang18::cached_table(out, sc, full, seed, cpu_table, cached, ex.root());
            const wang18::VptRun vpt = wang18::render_vpt(ex, sc, vpt_spp, seed, "fig23 VPT reference");
            const gl::PointBasedOptions<float> po = wang18::default_options(sc, full);
            gl_examples::Csv csv({"surface_samples", "e2_total", "e2_multiple", "cost_seconds", "cost_render_seconds",
                                  "rel_diff_total", "volume_samples"});
            std::vector<double> e2, secs, rel;
            if (ex.root()) std::printf("Wang18 Fig. 23: time and error vs surface samples, bumpy sphere mesh, radius %.0f green mfp, g 0.7, "
                        "%d x %d pixels, VPT %d spp (%.2f s)\n",
                        R_opt, W, W, vpt_spp, vpt.cpu);
            if (ex.root()) std::printf("  %9s %13s %11s %11s %11s %10s\n", "samples", "volume samp.", "CPU s", "render s", "e^2 total",
                        "rel.diff");
            for (double n : counts) {
                const wang18::PbRun pb = wang18::render_pb(ex, sc, &table, po, int(n), seed,
                                                           "fig23 " + std::to_string(int(n)) + " samples", rays);
                const wang18::Comparison c = wang18::compare(pb, vpt);
                e2.push_back(c.e2[4]);
                secs.push_back(pb.cpu_total());
                rel.push_back(c.rel[4]);
                csv.row({double(pb.surface_samples), c.e2[4], c.e2[2], pb.cpu_total(), pb.cpu_render, c.rel[4],
                         double(pb.volume_samples)});
                if (ex.root()) std::printf("  %9d %13zu %11.2f %11.2f %11.3e %+9.1f%%\n", pb.surface_samples, pb.volume_samples,
                            pb.cpu_total(), pb.cpu_render, c.e2[4], 100 * c.rel[4]);
            }
            if (!ex.root()) return ex.finish({});  // rank 0 writes and prints
            const auto csv_path = ex.csv("wang18_fig23_surface_samples.csv", csv);
            ex.plot("wang18_sweep", csv_path, out / "wang18_fig23_surface_samples.png",
                    {"light surface samples", "CPU seconds", "Wang18 Fig. 23: time and error vs surface samples", "logx"});
            if (ex.root()) std::printf("  [paper Fig. 23: error and time fall until ~66 K samples, then time grows with no gain]\n");
            gl_examples::Json j = ex.summary();
            wang18::put_rank_rows(ex, j, W);
            j.nums("surface_samples", counts).nums("e2_total", e2).nums("seconds", secs).nums("rel_diff_total", rel);
            j.num("e2_first_over_last", e2.back() > 0 ? e2.front() / e2.back() : 0.0)
                .num("seconds_vpt", vpt.cpu)
                .integer("vpt_spp", vpt_spp)
                .str("png", (out / "wang18_fig23_surface_samples.png").string());
            return ex.finish(j);
        });
}
