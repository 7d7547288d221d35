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

#include "common/harness.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/procedural_boundaries.hpp"
#include "grainlight/integrators/hybrid.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/precompute/scatterometer.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {

using Medium = gl::ContinuousMedium<gl::TabulatedPhase<float, gl::RGB>, gl::RGB>;
using SceneT = gl::Scene<Medium>;

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
        ex.ready();
        if (width < 8 || width > 4096) throw cli_error("--width must be in [8, 4096]");
        if (!(size >= 20 && size <= 5000)) throw cli_error("--size must be in [20, 5000] grain radii");
        if (!(budget_arg > 0 && budget_arg <= 1e6)) throw cli_error("--budget must be in (0, 1e6] CPU seconds");
        if (!(absorption >= 0 && absorption <= 0.1)) throw cli_error("--absorption must be in [0, 0.1]");
        if (stride < 1 || stride > 64) throw cli_error("--preview-stride must be in [1, 64]");
        if (level < 1 || level > 5) throw cli_error("--grain-level must be in [1, 5]");
        const int height = std::max(6, width * 3 / 4);
        const double npx = double(width) * double(height);

        // Snow grains (snow preset shape, ior 1.31, absorption red x2 / blue x0.5) in an MD packing at
        // f = 0.6; effective medium (Eq. 4) and App. A's diffusion from the scatterometer statistics.
        const auto packed = gl::md_pack(ex.full() ? 400 : 200, 0.6, ex.seed());
        const double s = 1.0 / packed.tile.radius();
        std::vector<gl::Vec3d> centers = packed.tile.centers();
        for (auto& c : centers) c *= s;
        const gl::PeriodicTile tile(packed.tile.side() * s, 1.0, std::move(centers));
        gl::GrainPreset p = gl::grain_preset("snow");
        p.material = gl::GrainMaterial::make_absorbing_dielectric(1.31, gl::RGBd{2.0 * absorption, absorption, 0.5 * absorption});
        gl::ScatterometerConfig cfg;
        cfg.rays = ex.full() ? 400000 : 100000;
        cfg.seed = ex.seed();
        const gl::GrainStats stats =
            gl::run_scatterometer(gl::ScatterometerGrain::procedural(p.shape, p.radius, p.material, p.seed, level), cfg);
        const gl::EffectiveRteParams rte = gl::effective_rte_params(stats, tile.packing_fraction(), 1.0);
        const gl::HybridDiffusion diffusion = gl::make_hybrid_diffusion(rte);
        const Medium medium = gl::make_effective_medium<float, gl::RGB>(stats, tile.packing_fraction(), 1.0);
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
            const gl::GranularAggregate<gl::MeshBoundary> agg(
                tile, gl::VoxelizedBoundary<gl::MeshBoundary>(shape, tile.side()),
                {gl::GrainExemplar::procedural(p.shape, p.radius, p.material, p.seed, level)}, {1.0}, ex.seed());
            // Ground one grain radius below the flat bottom, a small warm quad light, a dim blue sky.
            const float R = float(0.4 * Hs);
            SceneT ept;
            ept.add_shape(gl::QuadShape<float>(gl::Vec3f(-8 * R, -1.0f, -8 * R), gl::Vec3f(0, 0, 16 * R), gl::Vec3f(16 * R, 0, 0)),
                          gl::Material<float, gl::RGB>::diffuse(gl::RGB{0.45f, 0.45f, 0.45f}));
            ept.add_quad_light(gl::QuadShape<float>(gl::Vec3f(1.2f * R, 4.0f * R, 1.2f * R), gl::Vec3f(0.8f * R, 0, 0),
                                                    gl::Vec3f(0, 0, 0.8f * R)),
                               gl::RGB{60.0f, 57.0f, 52.0f});
            ept.add_light(SceneT::LightT::environment_light(gl::RGB{0.04f, 0.05f, 0.08f}));
            SceneT vpt = ept;
            const int m = vpt.add_medium(medium);
            const gl::HybridContext<gl::MeshDistance> ctx = gl::add_mesh_boundary(vpt, mesh, m, &diffusion);
            const float Hf = float(Hs);
            const gl::PinholeCamera<float> cam(gl::Vec3f(0.0f, 0.55f * Hf, 1.45f * Hf), gl::Vec3f(0.0f, 0.46f * Hf, 0.0f),
                                               gl::Vec3f(0, 1, 0), 36.0f, width, height);
            std::printf("\nscale %s: snowman %.0f grain radii tall (%s), mesh boundary of %zu triangles\n", key.c_str(), Hs,
                        si == 0 ? "Fig. 13 top" : "Fig. 13 bottom: grain radius x10", mesh.triangle_count());

            // 1. Cost preview per technique: CPU seconds of one bundle per pixel.
            Row rows[3];
            gl::HybridOptions opts[3];
            for (int t = 0; t < 3; ++t) {
                opts[t].mode = techs[t].mode;
                opts[t].ept.max_events = 4096;
                opts[t].vpt.max_depth = 4096;
                const gl::HybridImages pv =
                    gl::render_hybrid(ept, vpt, agg, ctx, cam, 2, ex.seed() + 7, ex.threads(), opts[t], stride);
                const double n_pv = double(pv.low.width()) * double(pv.low.height());
                rows[t].cost = (pv.cpu_seconds_low + pv.cpu_seconds_high) / (2.0 * n_pv);
            }
            const double budget = std::max(budget_arg, 2.0 * rows[0].cost * npx);
            if (budget > budget_arg)
                std::printf("  EPT needs %.1f CPU s for 2 bundles per pixel: budget raised from %.1f to %.1f s\n",
                            2.0 * rows[0].cost * npx, budget_arg, budget);
            // 2. Equal-time renders.
            std::printf("  %-11s %7s %11s %9s %9s %17s %12s %12s %11s %14s\n", "technique", "spp", "preview c", "CPU s",
                        "mean", "+- se", "pixel var", "ttuv", "speedup", "Table 2 (P_a=1)");
            gl::Image imgs[3];
            for (int t = 0; t < 3; ++t) {
                Row& r = rows[t];
                r.spp = int(std::clamp(std::lround(budget / (r.cost * npx)), 2L, 65536L));
                ProgressBar bar(key + " " + techs[t].name, std::uint64_t(height));
                const gl::HybridImages img = gl::render_hybrid(ept, vpt, agg, ctx, cam, r.spp, ex.seed(), ex.threads(), opts[t], 1,
                                                               [&](int n) { bar.advance(std::uint64_t(n)); });
                bar.done();
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
                gl::write_exr(ex.out() / (file + ".exr"), imgs[t]);
                gl::write_png(ex.out() / (file + ".png"), imgs[t], {exposure});
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
        gl::write_exr(ex.out() / "fig13_snowman_equal_time.exr", strip);
        gl::write_png(ex.out() / "fig13_snowman_equal_time.png", strip, {exposure});
        const auto csv_path = ex.csv("meng15_fig13_snowman.csv", csv);
        ex.plot("meng15_fig13_snowman", csv_path, ex.out() / "meng15_fig13_snowman.png");
        std::printf("wrote %s/snowman_{1m,10cm}_{ept,ept_vpt,ept_vpt_da}.{exr,png}, fig13_snowman_equal_time.{exr,png} "
                    "(rows 1 m, 10 cm; columns EPT | EPT+VPT | EPT+VPT+DA), meng15_fig13_snowman.{csv,png}\n",
                    ex.out().c_str());
        const std::string meta = ex.summary().num("d_DA", diffusion.d_DA).integer("width", width).str();
        std::cout << "{\"scales\":{" << scales_json << "}," << meta.substr(1) << std::endl;
        return 0;
    });
}
