// wang18_fig22_cost_vs_g: Wang & Holzschuch 2018 (TVCG), Fig. 22 ("Cost per ray of
// single/double/multiple scattering as a function of g for the Bumpy sphere scene"): CPU time per
// camera ray that reaches the medium, for each component rendered alone (a renderer with only
// that component on; double and multiple each pay their own tree cut), and for all components
// together (the bounced term's cost is the total minus the other three), on the bumpy sphere mesh
// (examples/wang18_bumpy.hpp) with a constant number of surface samples, HG g in
// {0, 0.3, 0.5, 0.7, 0.9}. Paper: single roughly constant; double and multiple grow linearly
// with g (its eps2 depends on g); the cost per ray does not depend on albedo or mean free path.
// Our Alg. 1 uses fixed eps1, eps2 (CutCriterion) and the lobe test p > pi/4, so the g dependence
// comes from the lobe test alone.
//
//   wang18_fig22_cost_vs_g [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                          [--g LIST] [--surface-samples N] [--width N] [--radius-mfp R]
//
// Outputs: wang18_fig22_cost_vs_g.csv (+ .png), JSON summary with cost_<component>_us arrays.
#include <algorithm>
#include <cstdio>
#include <string>

#include "wang18_bumpy.hpp"

namespace gl = grainlight;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_fig22_cost_vs_g", "Wang18 Fig. 22: CPU cost per camera ray of each component vs HG g",
        "out/wang18_fig22_cost_vs_g", [&](gl_examples::Example& ex) -> int {
            const std::vector<double> gs = ex.opt<std::vector<double>>("g", {0.0, 0.3, 0.5, 0.7, 0.9}, "HG g values");
            const int n_surface = ex.opt<int>("surface-samples", 6000, 40000, "Poisson-disk light surface samples");
            const int W = ex.opt<int>("width", 16, 64, "image width = height in pixels");
            const int rays = ex.opt<int>("rays", 4, 4, "camera rays per pixel");
            const double R_opt = ex.opt<double>("radius-mfp", 20.0, "sphere radius in green mean free paths");
            ex.checkpointable();
            ex.ready();
            wang18::check_surface_samples(n_surface);
            wang18::check_render_args(rays, W, R_opt);
            if (gs.empty()) throw gl_examples::cli_error("--g needs at least one value");
            for (double g : gs)
                if (!(g >= 0 && g < 0.96)) throw gl_examples::cli_error("--g values must be in [0, 0.96)");
            const bool full = ex.full();
            const auto& out = ex.out();
            const std::uint64_t seed = ex.seed();

            const char* names[5] = {"single", "double", "multiple", "bounced", "all"};
            std::vector<double> cost[5];
            gl_examples::Csv csv({"g", "cost_single", "cost_double", "cost_multiple", "cost_bounced", "cost_all"});
            if (ex.root()) std::printf("Wang18 Fig. 22: CPU microseconds per camera ray reaching the medium, bumpy sphere mesh, radius %.0f "
                        "green mfp, %d surface samples, %d x %d pixels x %d rays\n",
                        R_opt, n_surface, W, W, rays);
            if (ex.root()) std::printf("  %5s %10s %10s %10s %10s %10s\n", "g", "single", "double", "multiple", "bounced", "all");
            for (double g : gs) {
                const wang18::BumpyScene sc = wang18::make_bumpy_scene(W, float(R_opt), float(g));
                // Camera rays that reach the medium (the pixel-centre ray of each pixel hits or not).
                int hits = 0;
                for (int y = 0; y < W; ++y)
                    for (int x = 0; x < W; ++x) {
                        float t;
                        gl::Vec3f n;
                        hits += sc.shape.intersect(sc.camera.generate_ray(float(x) + 0.5f, float(y) + 0.5f), t, n) ? 1 : 0;
                    }
                double cpu_table = 0;
                bool cached = false;
                const gl::MsTable<3> table = wang18::cached_table(out, sc, full, seed, cpu_table, cached, ex.root());
                double c[5]{};
                for (int k = 0; k < 5; ++k) {
                    gl::PointBasedOptions<float> po = wang18::default_options(sc, full);
                    po.bounce_samples = full ? 2048 : 256;
                    if (k < 3) {
                        po.single = k == 0;
                        po.double_ = k == 1;
                        po.multiple = k == 2;
                        po.bounced = false;
                    }
                    if (k == 3) continue;  // bounced: all minus the three primary components
                    char lab[64];
                    std::snprintf(lab, sizeof lab, "fig22 g=%.2f %s", g, names[k]);
                    const wang18::PbRun pb = wang18::render_pb(ex, sc, &table, po, n_surface, seed, lab, rays);
                    c[k] = 1e6 * pb.cpu_render / (double(rays) * std::max(1, hits));
                }
                c[3] = std::max(0.0, c[4] - c[0] - c[1] - c[2]);
                std::vector<double> row{g};
                for (int k = 0; k < 5; ++k) {
                    cost[k].push_back(c[k]);
                    row.push_back(c[k]);
                }
                csv.row(row);
                if (ex.root()) std::printf("  %5.2f %10.1f %10.1f %10.1f %10.1f %10.1f\n", g, c[0], c[1], c[2], c[3], c[4]);
            }
            if (!ex.root()) return ex.finish({});  // rank 0 writes and prints
            const auto csv_path = ex.csv("wang18_fig22_cost_vs_g.csv", csv);
            ex.plot("wang18_sweep", csv_path, out / "wang18_fig22_cost_vs_g.png",
                    {"HG g", "CPU microseconds per camera ray", "Wang18 Fig. 22: cost per ray vs g (bumpy sphere)"});
            if (ex.root()) std::printf("  [paper Fig. 22: single roughly constant, double and multiple growing linearly with g]\n");
            gl_examples::Json j = ex.summary();
            wang18::put_rank_rows(ex, j, W);
            j.nums("g", gs).integer("surface_samples", n_surface).integer("width", W);
            for (int k = 0; k < 5; ++k) {
                j.nums(std::string("cost_") + names[k] + "_us", cost[k]);
                j.num(std::string("max_cost_") + names[k] + "_us", *std::max_element(cost[k].begin(), cost[k].end()));
            }
            j.str("png", (out / "wang18_fig22_cost_vs_g.png").string());
            return ex.finish(j);
        });
}
