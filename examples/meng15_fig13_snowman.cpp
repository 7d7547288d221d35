// meng15_fig13_snowman: Meng15 Fig. 13 -- the 1 m snowman and the 10 cm snowman (the same shape
// with the grain radius x 10, i.e. 10x fewer grain radii tall) rendered with EPT, EPT+VPT and
// EPT+VPT+DA (integrators/hybrid.hpp) at EQUAL CPU TIME, the paper's equal-time insets.
//
// Equal time, how: per scale and technique a short preview (every --preview-stride-th pixel in x
// and y, 2 bundles per pixel, the full image's pixel footprint) measures the thread CPU seconds of
// one bundle per pixel, c_t; the final render gets spp_t = round(B / (c_t * pixels)) bundles per
// pixel (at least 2, the variance needs two), with B = --budget CPU seconds per technique. If EPT
// cannot do 2 bundles per pixel within B, B is raised to EPT's predicted 2-spp cost (printed), so
// EPT always sets the floor and the hybrids get the same seconds. The measured CPU seconds of each
// final render are printed and reported (they match B to within the preview's timing noise).
//
// Per technique: CPU seconds, mean radiance (+- standard error), the per-pixel variance of the
// equal-time image (variance of one bundle estimate / spp, mean over pixels), and the time to unit
// variance (Sec. 6: one-bundle variance x CPU seconds per bundle), with its speed-up over EPT,
// beside Table 2's SNOWMAN LG. / SM. rows. The snowman is the procedural stand-in of
// meng15_table2_ttuv (make_snowman_mesh through add_mesh_boundary; snow grains, ior 1.31, faint
// absorption; docs/meng15_hybrid.md).
//
//   meng15_fig13_snowman [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--width W]
//                        [--size H] [--budget B] [--absorption A] [--preview-stride K] [--exposure E]
//                        [--fixed-spp N] [--checkpoint SECONDS] [--resume]
//
// --checkpoint / --resume: one checkpoint per scale and technique in --out, and the cost
// preview's numbers beside them (a resumed run uses the killed run's sample counts). mpirun -np K:
// rank r renders the rows y % K == r (meng15_scenes.hpp render_hybrid_run), rank 0 runs the cost
// previews and sends their numbers to all. Equal time rests on measured CPU times, so two runs
// differ in their sample counts: --fixed-spp N renders every technique with N bundles per pixel
// (no preview) when images must be reproducible (kill + resume, 1 vs K ranks).
//
// Writes per scale and technique EXR + PNG, a combined PNG (rows: 1 m, 10 cm; columns: EPT |
// EPT+VPT | EPT+VPT+DA), a CSV and its plot; last stdout line:
// {"scales": {"snowman_1m": {...}, "snowman_10cm": {...}}, then the run's metadata}.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "meng15_scenes.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {

using meng15::SceneT;

// Meng15 Table 2, rows SNOWMAN LG. (1 m) and SM. (10 cm), P_a = 1: ttuv in seconds of EPT,
// EPT+VPT, EPT+VPT+DA, and the printed speed-ups over EPT.
constexpr double paper_ttuv[2][3] = {{4000.8, 132.0, 16.3}, {2868.4, 171.1, 28.1}};
constexpr double paper_speedup[2][3] = {{1.0, 30.3, 246.0}, {1.0, 16.8, 102.0}};

struct Row {
    int spp = 0;
    double cost = 0, seconds = 0, mean = 0, mean_se = 0, var_one = 0, pixel_var = 0, ttuv = 0, ttuv_se = 0, speed = 1;
    double da_per_path = 0, switched = 0;
};

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig13_snowman",
               "Meng15 Fig. 13: 1 m and 10 cm snowman, EPT | EPT+VPT | EPT+VPT+DA at equal CPU time", [&](Example& ex) {
        const int width = ex.opt<int>("width", 48, 512, "image width (height = 3/4 width)");
        const double size = ex.opt<double>("size", 80.0, 100.0, "1 m snowman height in grain radii (10 cm: size / 10)");
        const double budget_arg = ex.opt<double>("budget", 6.0, 250.0, "CPU seconds per technique and scale");
        const double absorption = ex.opt<double>("absorption", 1e-3, 3e-4, "grain interior absorption per grain radius (green)");
        const int stride = ex.opt<int>("preview-stride", 4, 8, "cost preview: every k-th pixel in x and y");
        const int level = ex.opt<int>("grain-level", 3, 4, "icosphere level of the snow grain mesh");
        const double exposure = ex.opt<double>("exposure", 0.0, "PNG exposure in stops");
        const int fixed_spp = ex.opt<int>("fixed-spp", 0,
                                          "bundles per pixel of every technique instead of equal CPU time (0: equal time; "
                                          ">= 2: no cost preview, reproducible images)");
        ex.checkpointable();  // --checkpoint SECONDS / --resume: one checkpoint per scale and technique
        ex.ready();
        meng15::quiet_other_ranks(ex);
        if (fixed_spp != 0 && (fixed_spp < 2 || fixed_spp > 65536))
            throw cli_error("--fixed-spp = " + ex.given_text("fixed-spp") + " must be 0 or in [2, 65536]");
        if (width < 8 || width > 4096) throw cli_error("--width must be in [8, 4096]");
        if (!(size >= 20 && size <= 5000)) throw cli_error("--size must be in [20, 5000] grain radii");
        if (!(budget_arg > 0 && budget_arg <= 1e6)) throw cli_error("--budget must be in (0, 1e6] CPU seconds");
        if (!(absorption >= 0 && absorption <= 0.1)) throw cli_error("--absorption must be in [0, 0.1]");
        if (stride < 1 || stride > 64) throw cli_error("--preview-stride must be in [1, 64]");
        if (level < 1 || level > 5) throw cli_error("--grain-level must be in [1, 5]");
        const int height = std::max(6, width * 3 / 4);
        const double npx = double(width) * double(height);

        // Snow grains (snow preset shape, ior 1.31, absorption red x2 / blue x0.5) in an MD packing at
        // f = 0.6; effective medium (Eq. 4) and App. A's diffusion from the scatterometer statistics
        // (meng15_scenes.hpp: the same set-up as fig11 and table2).
        const meng15::Grains g = meng15::make_snow_grains(ex.seed(), ex.full(), absorption, level);
        const gl::PeriodicTile& tile = g.tile;
        const gl::GrainStats& stats = g.stats;
        const gl::EffectiveRteParams& rte = g.rte;
        const gl::HybridDiffusion& diffusion = g.diffusion;
        std::printf("Meng15 Fig. 13 stand-in: snow grains (ior 1.31, absorption %.2g /R green), f = %.3f, albedo %.4f, "
                    "sigma_t %.3f /R, d_DA = %.2f R; %dx%d px, equal CPU time %.1f s per technique (requested)\n",
                    absorption, tile.packing_fraction(), stats.alpha_s(1), rte.sigma_t[1], diffusion.d_DA, width, height,
                    budget_arg);

        struct Tech {
            const char* name;
            const char* key;
            gl::HybridMode mode;
        };
        const Tech techs[3] = {{"EPT", "ept", gl::HybridMode::ept},
                               {"EPT+VPT", "ept_vpt", gl::HybridMode::ept_vpt},
                               {"EPT+VPT+DA", "ept_vpt_da", gl::HybridMode::ept_vpt_da}};
        Csv csv({"scale", "technique", "spp", "cpu_seconds", "budget", "mean", "mean_stderr", "variance_one_bundle",
                 "pixel_variance", "ttuv", "ttuv_stderr", "speedup", "paper_ttuv", "paper_speedup", "da_per_path",
                 "switched_fraction"});
        gl::Image strip(3 * width, 2 * height);
        std::string scales_json;
        for (int si = 0; si < 2; ++si) {
            const std::string key = si == 0 ? "snowman_1m" : "snowman_10cm";
            const double Hs = si == 0 ? size : size / 10.0;
            const gl::TriangleMesh<double> mesh = gl::make_snowman_mesh(Hs, ex.full() ? 192 : 96, ex.full() ? 128 : 64);
            const gl::MeshBoundary shape(mesh);
            const gl::GranularAggregate<gl::MeshBoundary> agg = g.aggregate(shape, ex.seed());
            // Ground one grain radius below the flat bottom, a small warm quad light, a dim blue sky.
            const float R = float(0.4 * Hs);
            const SceneT ept = meng15::make_lit_scene(R);
            SceneT vpt = ept;
            const int m = vpt.add_medium(g.medium);
            const gl::HybridContext<gl::MeshDistance> ctx = gl::add_mesh_boundary(vpt, mesh, m, &diffusion);
            const float Hf = float(Hs);
            const gl::PinholeCamera<float> cam(gl::Vec3f(0.0f, 0.55f * Hf, 1.45f * Hf), gl::Vec3f(0.0f, 0.46f * Hf, 0.0f),
                                               gl::Vec3f(0, 1, 0), 36.0f, width, height);
            std::printf("\nscale %s: snowman %.0f grain radii tall (%s), mesh boundary of %zu triangles\n", key.c_str(), Hs,
                        si == 0 ? "Fig. 13 top" : "Fig. 13 bottom: grain radius x10", mesh.triangle_count());

            // 1. Cost preview per technique: CPU seconds of one bundle per pixel (rank 0 measures, every
            // rank gets its numbers; kept for --resume: checkpoint.hpp decided). --fixed-spp skips it.
            Row rows[3];
            gl::HybridOptions opts[3];
            for (int t = 0; t < 3; ++t) {
                opts[t].mode = techs[t].mode;
                opts[t].ept.max_events = 4096;
                opts[t].vpt.max_depth = 4096;
            }
            if (fixed_spp == 0) {
                const std::vector<double> cost = decided(ex, key + ".cost", [&] {
                    std::vector<double> c;
                    for (int t = 0; t < 3; ++t) {
                        const gl::HybridImages pv =
                            gl::render_hybrid(ept, vpt, agg, ctx, cam, 2, ex.seed() + 7, ex.threads(), opts[t], stride);
                        const double n_pv = double(pv.low.width()) * double(pv.low.height());
                        c.push_back((pv.cpu_seconds_low + pv.cpu_seconds_high) / (2.0 * n_pv));
                    }
                    return c;
                });
                for (int t = 0; t < 3; ++t) rows[t].cost = cost[std::size_t(t)];
            }
            const double budget = fixed_spp > 0 ? 0.0 : std::max(budget_arg, 2.0 * rows[0].cost * npx);
            if (fixed_spp == 0 && budget > budget_arg)
                std::printf("  EPT needs %.1f CPU s for 2 bundles per pixel: budget raised from %.1f to %.1f s\n",
                            2.0 * rows[0].cost * npx, budget_arg, budget);
            // 2. Equal-time renders.
            std::printf("  %-11s %7s %11s %9s %9s %17s %12s %12s %11s %14s\n", "technique", "spp", "preview c", "CPU s",
                        "mean", "+- se", "pixel var", "ttuv", "speedup", "Table 2 (P_a=1)");
            gl::Image imgs[3];
            for (int t = 0; t < 3; ++t) {
                Row& r = rows[t];
                r.spp = fixed_spp > 0 ? fixed_spp : int(std::clamp(std::lround(budget / (r.cost * npx)), 2L, 65536L));
                const gl::HybridImages img = meng15::render_hybrid_run(ex, key + "_" + techs[t].key, ept, vpt, agg, ctx, cam, r.spp,
                                                                       ex.seed(), opts[t], key + " " + techs[t].name);
                imgs[t] = img.combined();
                r.seconds = img.cpu_seconds_low + img.cpu_seconds_high;
                r.mean = (imgs[t].mean(0) + imgs[t].mean(1) + imgs[t].mean(2)) / 3.0;
                r.mean_se = std::sqrt(img.var_total / (double(r.spp) * npx));
                r.var_one = img.var_total;
                r.pixel_var = img.var_total / double(r.spp);
                r.ttuv = img.ttuv();
                r.ttuv_se = img.var_total_se * img.seconds_per_spp();
                r.speed = rows[0].ttuv / r.ttuv;
                const double paths = double(img.counters.paths);
                r.da_per_path = double(img.counters.da) / paths;
                r.switched = (double(img.counters.switched) + double(img.counters.rejected)) / paths;
                const std::string file = key + "_" + techs[t].key;
                if (ex.root()) gl::write_exr(ex.out() / (file + ".exr"), imgs[t]);
                if (ex.root()) gl::write_png(ex.out() / (file + ".png"), imgs[t], {exposure});
                for (int y = 0; y < height; ++y)
                    for (int x = 0; x < width; ++x)
                        for (int c = 0; c < 3; ++c) strip.at(t * width + x, si * height + y, c) = imgs[t].at(x, y, c);
                const double sp_se = r.speed * std::hypot(rows[0].ttuv_se / rows[0].ttuv, t == 0 ? 0.0 : r.ttuv_se / r.ttuv);
                std::printf("  %-11s %7d %9.3g s %9.1f %9.4f %+8.2f%% +-%5.2f%% %12.4g %12.4g %6.2fx+-%4.2f %7.1f s (%.1fx)\n",
                            techs[t].name, r.spp, r.cost, r.seconds, r.mean, 100 * (r.mean / rows[0].mean - 1),
                            100 * r.mean_se / rows[0].mean, r.pixel_var, r.ttuv, r.speed, sp_se, paper_ttuv[si][t],
                            paper_speedup[si][t]);
                csv.row_text({key, techs[t].name, std::to_string(r.spp), std::to_string(r.seconds), std::to_string(budget),
                              std::to_string(r.mean), std::to_string(r.mean_se), std::to_string(r.var_one),
                              std::to_string(r.pixel_var), std::to_string(r.ttuv), std::to_string(r.ttuv_se),
                              std::to_string(r.speed), std::to_string(paper_ttuv[si][t]), std::to_string(paper_speedup[si][t]),
                              std::to_string(r.da_per_path), std::to_string(r.switched)});
            }
            std::printf("  (DA connections per path: EPT+VPT+DA %.3f; switched fraction EPT+VPT %.2f; d_DA = %.2f R)\n",
                        rows[2].da_per_path, rows[1].switched, diffusion.d_DA);
            Json j;
            j.num("seconds_ept", rows[0].seconds)
                .num("seconds_ept_vpt", rows[1].seconds)
                .num("seconds_ept_vpt_da", rows[2].seconds)
                .num("mean_ept", rows[0].mean)
                .num("mean_ept_vpt", rows[1].mean)
                .num("mean_ept_vpt_da", rows[2].mean)
                .num("ttuv_speedup_ept_vpt", rows[1].speed)
                .num("ttuv_speedup_ept_vpt_da", rows[2].speed)
                .num("pixel_variance_ept", rows[0].pixel_var)
                .num("pixel_variance_ept_vpt", rows[1].pixel_var)
                .num("pixel_variance_ept_vpt_da", rows[2].pixel_var)
                .num("ttuv_ept", rows[0].ttuv)
                .num("ttuv_ept_vpt", rows[1].ttuv)
                .num("ttuv_ept_vpt_da", rows[2].ttuv)
                .integer("spp_ept", rows[0].spp)
                .integer("spp_ept_vpt", rows[1].spp)
                .integer("spp_ept_vpt_da", rows[2].spp)
                .num("budget_seconds", budget);
            if (!scales_json.empty()) scales_json += ',';
            scales_json += Json::quote(key) + ":" + j.str();
        }
        if (ex.root()) gl::write_exr(ex.out() / "fig13_snowman_equal_time.exr", strip);
        if (ex.root()) gl::write_png(ex.out() / "fig13_snowman_equal_time.png", strip, {exposure});
        if (ex.root()) {
            const auto csv_path = ex.csv("meng15_fig13_snowman.csv", csv);
            ex.plot("meng15_fig13_snowman", csv_path, ex.out() / "meng15_fig13_snowman.png");
        }
        std::printf("wrote %s/snowman_{1m,10cm}_{ept,ept_vpt,ept_vpt_da}.{exr,png}, fig13_snowman_equal_time.{exr,png} "
                    "(rows 1 m, 10 cm; columns EPT | EPT+VPT | EPT+VPT+DA), meng15_fig13_snowman.{csv,png}\n",
                    ex.out().c_str());
        Json meta = ex.summary();
        meta.num("d_DA", diffusion.d_DA).integer("width", width);
        meng15::rank_rows(meta, ex, height);
        return ex.finish_line("{\"scales\":{" + scales_json + "}," + meta.str().substr(1));
    });
}
