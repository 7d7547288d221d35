// meng15_hybrid_convergence: Meng15 Sec. 5-6 (Table 2, Figs. 11-13) -- a sphere of grains on a
// diffuse ground under a small quad light, rendered with explicit path tracing (EPT), EPT -> VPT
// and EPT -> VPT -> DA (integrators/hybrid.hpp), each with P_a = 1 and with the optimal
// acceptance probability of Eq. 8 estimated on a preview of every 10th pixel in x and y (1% of
// the pixels). Prints the time to unit variance (ttuv, Sec. 6) of the whole image and of its
// high-order part, the speedups over EPT beside the paper's Table 2 speedups, the relative
// difference of each image's mean radiance to the EPT reference, the switch statistics and
// d_DA.
//
//   meng15_hybrid_convergence [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                             [--spp N] [--radius R] [--absorption A] [--width W] [--exposure EV]
//                             [--pa-estimator paper|moments] [--preview-stride K] [--pa VALUE]
//                             [--checkpoint SECONDS] [--resume]
//
// --checkpoint / --resume: one checkpoint per technique's render in --out (render_hybrid's
// HybridOptions::checkpoint); the P_a a timed preview chose is kept beside them (checkpoint.hpp
// decided), so a resumed run renders the "P_a opt" techniques with the killed run's P_a. Two
// uninterrupted runs may differ there (the preview measures timings): pin --pa to compare them.
// mpirun -np K: rank r renders the rows y % K == r of every render, rank 0 runs the previews and
// sends their P_a to all; images and statistics are the single-process ones (bit-identical EXRs).
//
// The effective medium comes from the virtual scatterometer of the same grain
// (precompute/scatterometer.hpp, make_effective_medium). Writes EXR + PNG per technique, a CSV of
// the table, a bar plot of the speedups (ours vs the paper's), and a JSON summary line.
#include <chrono>
#include <functional>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "meng15_scenes.hpp"
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

struct Technique {
    std::string name;
    gl::HybridMode mode;
    bool optimal_pa;
    // Meng15 Table 2 speedups over EPT (combined; high order) for SPICES, SANDCASTLE, SNOWMAN LG.,
    // SNOWMAN SM.
    double paper_total[4];
    double paper_high[4];
};

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_hybrid_convergence",
               "Meng15 Table 2: time to unit variance of EPT, EPT+VPT and EPT+VPT+DA (P_a = 1 and Eq. 8)",
               "out/meng15_hybrid_convergence", [&](Example& ex) {
        const auto spp = ex.opt<std::uint64_t>("spp", 2, 8, "bundles of 16 paths per pixel (>= 2)");
        const double Rb = ex.opt<double>("radius", 20.0, 40.0, "radius of the sphere of grains in grain radii");
        const double absorption =
            ex.opt<double>("absorption", 0.01, "interior absorption of the ice-like grains per grain radius (green)");
        const auto width_arg = ex.opt<std::uint64_t>("width", 120, 240, "image width in pixels (height = 3/4 width)");
        const std::string pa_estimator = ex.opt<std::string>(
            "pa-estimator", "safe",
            "safe (robust moments, 1 unless the gain is resolved) | robust | paper (Eq. 8 with Eq. 6's variances) | "
            "moments (exact roulette variance)");
        const auto preview_stride = ex.opt<std::uint64_t>(
            "preview-stride", 10, "P_a preview: every k-th pixel in x and y (Meng15: 10, i.e. 1% of the pixels)");
        const auto pa_given =
            ex.opt_optional<double>("pa", "pin P_a of the 'P_a opt' techniques to this value in (0, 1] (no preview; reproducible output)");
        const double exposure = ex.opt<double>("exposure", 0.0, "PNG exposure in stops");
        ex.checkpointable();  // --checkpoint SECONDS / --resume: one checkpoint per technique's render
        ex.ready();
        meng15::quiet_other_ranks(ex);
        const bool full = ex.full();
        const auto& out = ex.out();
        const int threads = ex.threads();
        const std::uint64_t seed = ex.seed();
        if (spp < 2 || spp > 4096)
            throw cli_error("--spp = " + std::to_string(spp) + " must be in [2, 4096] (ttuv needs a sample variance)");
        if (!(Rb >= 4.0 && Rb <= 200.0)) throw cli_error("--radius = " + ex.given_text("radius") + " must be in [4, 200] grain radii");
        if (!(absorption >= 0.0 && absorption <= 1.0))
            throw cli_error("--absorption = " + ex.given_text("absorption") + " must be in [0, 1]");
        if (preview_stride < 1 || preview_stride > 100)
            throw cli_error("--preview-stride = " + std::to_string(preview_stride) + " must be in [1, 100]");
        const double pa_pinned = pa_given ? *pa_given : 0.0;
        if (pa_given && !(pa_pinned > 0.0 && pa_pinned <= 1.0))
            throw cli_error("--pa = " + ex.given_text("pa") + " must be in (0, 1]");
        if (pa_estimator != "paper" && pa_estimator != "moments" && pa_estimator != "robust" && pa_estimator != "safe")
            throw cli_error("--pa-estimator = '" + pa_estimator + "' must be safe, robust, paper or moments");
        if (width_arg < 8 || width_arg > 4096) throw cli_error("--width = " + std::to_string(width_arg) + " must be in [8, 4096]");
        const int width = int(width_arg), height = std::max(6, int(width_arg * 3 / 4));

        // Packing (MD, f = 0.6, grain bounding radius 1), grain (ice-like sphere, slightly
        // absorbing, bluish), its scatterometer statistics and the effective medium (Eq. 4).
        const auto t_setup0 = std::chrono::steady_clock::now();
        const auto packed = gl::md_pack(full ? 400 : 200, 0.6, seed);
        const double s = 1.0 / packed.tile.radius();
        std::vector<gl::Vec3d> centers = packed.tile.centers();
        for (auto& c : centers) c *= s;
        const gl::PeriodicTile tile(packed.tile.side() * s, 1.0, std::move(centers));
        const gl::GrainMaterial mat =
            gl::GrainMaterial::make_absorbing_dielectric(1.31, gl::RGBd{2.0 * absorption, absorption, 0.5 * absorption});
        const gl::SphereBoundary shape(gl::Vec3d(0.0), Rb);
        gl::GranularAggregate<gl::SphereBoundary> agg(tile, gl::VoxelizedBoundary<gl::SphereBoundary>(shape, tile.side()),
                                                      {gl::GrainExemplar::sphere(1.0, mat)}, {1.0}, seed);
        gl::ScatterometerConfig cfg;
        cfg.rays = full ? 400000 : 100000;
        cfg.seed = seed;
        const gl::GrainStats stats = gl::run_scatterometer(gl::ScatterometerGrain::sphere(1.0, mat), cfg);
        const gl::EffectiveRteParams rte = gl::effective_rte_params(stats, tile.packing_fraction(), 1.0);
        const gl::HybridDiffusion diffusion = gl::make_hybrid_diffusion(rte);
        using Medium = gl::ContinuousMedium<gl::TabulatedPhase<float, gl::RGB>, gl::RGB>;
        const Medium medium = gl::make_effective_medium<float, gl::RGB>(stats, tile.packing_fraction(), 1.0);

        // Scenes: EPT (ground + lights) and VPT (+ the boundary sphere holding the effective medium).
        using Scene = gl::Scene<Medium>;
        Scene scene_ept;
        const float R = float(Rb);
        scene_ept.add_shape(gl::QuadShape<float>(gl::Vec3f(-6 * R, -R, -6 * R), gl::Vec3f(0, 0, 12 * R), gl::Vec3f(12 * R, 0, 0)),
                            gl::Material<float, gl::RGB>::diffuse(gl::RGB{0.5f, 0.45f, 0.4f}));
        scene_ept.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-0.4f * R, 2.5f * R, -0.4f * R), gl::Vec3f(0.8f * R, 0, 0),
                                                      gl::Vec3f(0, 0, 0.8f * R)),
                                 gl::RGB{40.0f, 38.0f, 35.0f});
        scene_ept.add_light(Scene::LightT::environment_light(gl::RGB{0.03f, 0.04f, 0.06f}));
        Scene scene_vpt = scene_ept;
        const int m_eff = scene_vpt.add_medium(medium);
        const int boundary_shape = scene_vpt.add_shape(gl::SphereShape<float>(gl::Vec3f(0.0f), R),
                                                       gl::Material<float, gl::RGB>::index_matched(), m_eff, -1);
        const gl::HybridContext<gl::BoundaryDistance<gl::SphereBoundary>> ctx{m_eff, boundary_shape, {shape}, &diffusion};
        const gl::PinholeCamera<float> camera(gl::Vec3f(0.0f, 0.7f * R, 3.4f * R), gl::Vec3f(0.0f, -0.15f * R, 0.0f),
                                              gl::Vec3f(0, 1, 0), 42.0f, width, height);
        const double setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_setup0).count();

        std::printf("Meng15 Table 2 (hybrid EPT -> VPT -> DA): sphere of %.0f grain radii, ice-like grains (ior 1.31, "
                    "albedo %.3f %.3f %.3f), f = %.3f\n",
                    Rb, stats.alpha_s(0), stats.alpha_s(1), stats.alpha_s(2), tile.packing_fraction());
        std::printf("  effective medium: sigma_t %.4f /R, g %.3f, sigma_t' %.4f /R, d_DA = %.2f R (Sec. 5), %dx%d px, %llu "
                    "bundles x 16 paths per pixel, setup %.1f s\n",
                    rte.sigma_t[1], rte.g[1], rte.sigma_t_reduced[1], diffusion.d_DA, width, height,
                    (unsigned long long)spp, setup_s);

        const std::vector<Technique> techniques = {
            {"EPT", gl::HybridMode::ept, false, {1, 1, 1, 1}, {1, 1, 1, 1}},
            {"EPT+VPT Pa=1", gl::HybridMode::ept_vpt, false, {4.0, 2.1, 30.3, 16.8}, {130.8, 206.8, 404.6, 381.5}},
            {"EPT+VPT Pa=opt", gl::HybridMode::ept_vpt, true, {6.5, 2.2, 101.0, 54.4}, {137.8, 230.0, 385.3, 271.4}},
            {"EPT+VPT+DA Pa=1", gl::HybridMode::ept_vpt_da, false, {7.4, 2.2, 246.0, 102.0}, {2554.0, 26.5, 8473.0, 6431.0}},
            {"EPT+VPT+DA Pa=opt", gl::HybridMode::ept_vpt_da, true, {8.0, 2.2, 260.0, 114.0}, {1968.0, 242.0, 7394.0, 4997.0}},
        };
        Csv csv({"technique", "P_a", "ttuv", "ttuv_high", "speedup", "speedup_high", "paper_speedup_min", "paper_speedup_max",
                 "paper_speedup_high_min", "paper_speedup_high_max", "mean_radiance", "rel_diff_vs_ept", "rel_diff_sigma",
                 "switched_fraction", "mean_switch_interactions", "da_per_path", "cpu_seconds"});
        double ept_ttuv = 0, ept_ttuv_high = 0, ept_mean = 0, ept_mean_err = 0;
        // Side by side (P_a = 1): EPT | EPT+VPT | EPT+VPT+DA.
        gl::Image strip(3 * width, height);
        int strip_slot = 0;
        Json json = ex.summary();
        std::printf("\n  %-18s %6s %11s %11s %9s %10s %19s %19s %9s %9s %7s %6s\n", "technique", "P_a", "ttuv", "ttuv_high",
                    "speedup", "sp_high", "paper speedup", "paper sp_high", "mean", "rel.diff", "switch", "DA/pth");
        for (const Technique& t : techniques) {
            gl::HybridOptions opt;
            opt.mode = t.mode;
            opt.ept.max_events = full ? 4096 : 1024;
            double Pa = 1.0;
            std::string stem = t.name;  // file-name-safe label of this technique's render
            for (char& c : stem) c = (c == ' ' || c == '+' || c == '=') ? '_' : char(std::tolower(c));
            if (t.optimal_pa && pa_pinned > 0.0) {
                Pa = pa_pinned;
                std::printf("  %-18s P_a pinned by --pa: %.3f\n", t.name.c_str(), Pa);
            } else if (t.optimal_pa) {
                // Rank 0 runs the timed preview; its P_a goes to every rank and, with --checkpoint,
                // into --out, so that --resume renders with the killed run's P_a.
                Pa = decided(ex, stem + ".pa", [&] {
                    const gl::AcceptanceEstimate a = gl::estimate_optimal_acceptance(scene_ept, scene_vpt, agg, ctx, camera, int(spp),
                                                                                     seed + 1, threads, opt, int(preview_stride));
                    const double P = pa_estimator == "paper"     ? a.P_a
                                     : pa_estimator == "moments" ? a.P_a_moments
                                     : pa_estimator == "robust"  ? a.P_a_robust
                                                                 : a.P_a_safe;
                    std::printf("  %-18s preview (every %dth pixel): V_L %.4g V_H %.4g t_L %.3g s t_H %.3g s -> P_a %.3f (Eq. 8), "
                                "%.3f (moments), %.3f (robust, gain %.2f +- %.2f), %.3f (safe)\n",
                                t.name.c_str(), int(preview_stride), a.V_L, a.V_H, a.t_L, a.t_H, a.P_a, a.P_a_moments,
                                a.P_a_robust, a.gain, a.gain_se, a.P_a_safe);
                    return std::vector<double>{P};
                })[0];
            }
            opt.acceptance = Pa;
            // One checkpoint per technique (its key mixed with P_a), this rank's rows, films shared
            // by all ranks (meng15_scenes.hpp).
            const gl::HybridImages img =
                meng15::render_hybrid_run(ex, stem, scene_ept, scene_vpt, agg, ctx, camera, int(spp), seed, opt, t.name);
            const gl::Image all = img.combined();
            const double mean = (all.mean(0) + all.mean(1) + all.mean(2)) / 3.0;
            const double npx = double(width) * double(height);
            const double mean_err = std::sqrt(img.var_total / (double(spp) * npx));
            if (t.mode == gl::HybridMode::ept) {
                ept_ttuv = img.ttuv();
                ept_ttuv_high = img.ttuv_high();
                ept_mean = mean;
                ept_mean_err = mean_err;
            }
            const double speed = ept_ttuv / img.ttuv();
            const double speed_high = img.ttuv_high() > 0 ? ept_ttuv_high / img.ttuv_high() : 0.0;
            const double rel = (mean - ept_mean) / ept_mean;
            const double rel_sigma = std::hypot(mean_err, t.mode == gl::HybridMode::ept ? 0.0 : ept_mean_err) / ept_mean;
            const double paths = double(img.counters.paths);
            const double sw_frac = (double(img.counters.switched) + double(img.counters.rejected)) / paths;
            const double sw_depth = img.counters.switched ? double(img.counters.switch_depth) / double(img.counters.switched) : 0.0;
            const double da = double(img.counters.da) / paths;
            const double pmin = *std::min_element(t.paper_total, t.paper_total + 4), pmax = *std::max_element(t.paper_total, t.paper_total + 4);
            const double hmin = *std::min_element(t.paper_high, t.paper_high + 4), hmax = *std::max_element(t.paper_high, t.paper_high + 4);
            std::printf("  %-18s %6.3f %11.4g %11.4g %8.2fx %9.1fx %8.1f-%7.1fx %8.1f-%7.1fx %9.4f %+8.2f%% %6.2f %6.2f\n",
                        t.name.c_str(), Pa, img.ttuv(), img.ttuv_high(), speed, speed_high, pmin, pmax, hmin, hmax, mean,
                        100.0 * rel, sw_frac, da);
            std::string file = t.name;
            for (char& c : file) c = (c == ' ' || c == '+' || c == '=') ? '_' : char(std::tolower(c));
            if (ex.root()) gl::write_exr(out / ("hybrid_" + file + ".exr"), all);
            if (ex.root()) gl::write_png(out / ("hybrid_" + file + ".png"), all, {exposure});
            if (ex.root()) gl::write_exr(out / ("hybrid_" + file + "_high.exr"), img.high.image());
            if (t.mode == gl::HybridMode::ept_vpt && !t.optimal_pa) {
                // Switch depth (Meng15 Fig. 12, bottom right): grain interactions in EPT before the switch.
                gl::Image d = img.switch_depth;
                float dmax = 0;
                for (float v : d.rgb) dmax = std::max(dmax, v);
                if (ex.root()) gl::write_exr(out / "hybrid_switch_depth.exr", d);
                if (dmax > 0)
                    for (float& v : d.rgb) v /= dmax;
                if (ex.root()) gl::write_png(out / "hybrid_switch_depth.png", d);
                std::printf("  %18s switch depth: mean over pixels %.2f, max %.2f grain interactions "
                            "(hybrid_switch_depth.png, white = max)\n",
                            "", img.switch_depth.mean(0), double(dmax));
            }
            if (!t.optimal_pa && strip_slot < 3) {
                for (int y = 0; y < height; ++y)
                    for (int x = 0; x < width; ++x)
                        for (int c = 0; c < 3; ++c) strip.at(strip_slot * width + x, y, c) = all.at(x, y, c);
                ++strip_slot;
            }
            csv.row_text({t.name, std::to_string(Pa), std::to_string(img.ttuv()), std::to_string(img.ttuv_high()),
                          std::to_string(speed), std::to_string(speed_high), std::to_string(pmin), std::to_string(pmax),
                          std::to_string(hmin), std::to_string(hmax), std::to_string(mean), std::to_string(rel),
                          std::to_string(rel_sigma), std::to_string(sw_frac), std::to_string(sw_depth), std::to_string(da),
                          std::to_string(img.cpu_seconds_low + img.cpu_seconds_high)});
            std::string key = file;
            json.num(key + "_ttuv", img.ttuv()).num(key + "_speedup", speed).num(key + "_rel_diff", rel).num(key + "_P_a", Pa);
            if (t.mode != gl::HybridMode::ept) {
                std::printf("  %18s rel. diff %+.2f%% +- %.2f%% (1 sigma, MC of both), %.2f grain interactions in EPT before the "
                            "switch\n",
                            "", 100.0 * rel, 100.0 * rel_sigma, sw_depth);
                if (!t.optimal_pa) {
                    // Eq. 8 with this full render's own statistics (what a perfect preview would give).
                    const double np = npx * double(spp);
                    const double tl = img.cpu_seconds_low / np, th = img.cpu_seconds_high / np;
                    std::printf("  %18s full-image V_L %.4g V_H %.4g t_L %.3g s t_H %.3g s -> Eq. 8 P_a %.3f, moments %.3f\n", "",
                                img.var_low, img.var_high, tl, th, gl::optimal_acceptance(img.var_low, img.var_high, tl, th),
                                gl::optimal_acceptance(img.var_total - img.m2_high, img.m2_high, tl, th));
                }
            }
        }
        std::printf("  (paper: Table 2 speedups over EPT across SPICES, SANDCASTLE, SNOWMAN LG./SM.; ttuv in CPU seconds x "
                    "variance, our units: scene radiance^2 x core-seconds)\n");
        if (ex.root()) gl::write_exr(out / "hybrid_side_by_side.exr", strip);
        if (ex.root()) gl::write_png(out / "hybrid_side_by_side.png", strip, {exposure});
        if (ex.root()) {
            const auto csv_path = ex.csv("meng15_hybrid_convergence.csv", csv);
            ex.plot("meng15_hybrid_convergence", csv_path, out / "meng15_hybrid_convergence.png");
        }
        std::printf("wrote %s/hybrid_*.{exr,png} (hybrid_side_by_side: EPT | EPT+VPT | EPT+VPT+DA), meng15_hybrid_convergence.{csv,png}\n", out.c_str());
        json.num("d_DA", diffusion.d_DA).integer("spp", (long long)spp);
        meng15::rank_rows(json, ex, height);
        return ex.finish(json);
    });
}
