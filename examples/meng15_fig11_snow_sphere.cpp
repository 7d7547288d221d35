// meng15_fig11_snow_sphere: Meng15 Fig. 11 -- a sphere of snow grains rendered with the five
// technique combinations of integrators/hybrid.hpp side by side: VPT | VPT+DA | EPT+VPT |
// EPT+VPT+DA | EPT (HybridMode vpt, vpt_da, ept_vpt, ept_vpt_da, ept), same camera, lights and
// samples. Prints per technique the mean radiance and its difference to EPT (with the standard
// error of both), the time to unit variance (Sec. 6) and its speedup over EPT, and the "detail"
// error: the RMS per-pixel difference to EPT after subtracting both images' noise (what the paper
// shows: VPT alone loses the grain-scale look near the surface, a few EPT bounces first recover it).
// Writes the strip (EXR + PNG), each technique's image, Fig. 12's per-technique contributions of
// EPT+VPT+DA, a CSV and the JSON summary.
//
//   meng15_fig11_snow_sphere [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                            [--radius R] [--width W] [--spp N] [--absorption A]
//                            [--checkpoint SECONDS] [--resume]
//
// --checkpoint / --resume: one checkpoint per technique's render in --out. mpirun -np K: rank r
// renders the rows y % K == r of every render (meng15_scenes.hpp render_hybrid_run); the EXRs
// are byte-identical to a single process's, the JSON says "ranks": K and each rank's rows.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "meng15_scenes.hpp"

namespace gl = grainlight;
using namespace gl_examples;

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig11_snow_sphere",
               "Meng15 Fig. 11: VPT | VPT+DA | EPT+VPT | EPT+VPT+DA | EPT on a sphere of snow grains", [&](Example& ex) {
        const double Rb = ex.opt<double>("radius", 24.0, 80.0, "sphere radius in grain radii");
        const int width = ex.opt<int>("width", 64, 160, "width of each image (height = 3/4 width)");
        const int spp = ex.opt<int>("spp", 8, 16, "bundles of 16 paths per pixel (>= 8)");
        const double absorption = ex.opt<double>("absorption", 1e-3, 3e-4, "grain interior absorption per grain radius (green)");
        const double exposure = ex.opt<double>("exposure", 0.0, "PNG exposure in stops");
        ex.checkpointable();  // --checkpoint SECONDS / --resume: one checkpoint per technique's render
        ex.ready();
        meng15::quiet_other_ranks(ex);
        if (!(Rb >= 4 && Rb <= 2000)) throw cli_error("--radius must be in [4, 2000] grain radii");
        if (width < 8 || width > 2048) throw cli_error("--width must be in [8, 2048]");
        if (spp < 8 || spp > 4096) throw cli_error("--spp must be in [8, 4096]");
        if (!(absorption >= 0 && absorption <= 0.1)) throw cli_error("--absorption must be in [0, 0.1]");
        const int height = std::max(6, width * 3 / 4);
        const int level = ex.full() ? 4 : 3;

        // Snow grains (the snow preset's shape, ior 1.31) with a faint ice-like absorption (red x2,
        // blue x0.5) in an MD packing at f = 0.6; the effective medium from their scatterometer
        // statistics (Eq. 4) and the diffusion of App. A; the ground, light and sky of
        // meng15_scenes.hpp (the same set-up as fig13 and table2).
        const meng15::Grains g = meng15::make_snow_grains(ex.seed(), ex.full(), absorption, level);
        const gl::PeriodicTile& tile = g.tile;
        const gl::GrainStats& stats = g.stats;
        const gl::EffectiveRteParams& rte = g.rte;
        const gl::HybridDiffusion& diffusion = g.diffusion;
        using SceneT = meng15::SceneT;
        const gl::SphereBoundary shape(gl::Vec3d(0.0, Rb, 0.0), Rb);
        const gl::GranularAggregate<gl::SphereBoundary> agg = g.aggregate(shape, ex.seed());
        const float R = float(Rb);
        const SceneT ept = meng15::make_lit_scene(R);
        SceneT vpt = ept;
        const int m = vpt.add_medium(g.medium);
        const int b = vpt.add_shape(gl::SphereShape<float>(gl::Vec3f(0.0f, R, 0.0f), R), gl::Material<float, gl::RGB>::index_matched(),
                                    m, -1);
        const gl::HybridContext<gl::BoundaryDistance<gl::SphereBoundary>> ctx{m, b, {shape}, &diffusion};
        const gl::PinholeCamera<float> cam(gl::Vec3f(0.0f, 1.4f * R, 3.6f * R), gl::Vec3f(0.0f, 1.0f * R, 0.0f),
                                           gl::Vec3f(0, 1, 0), 36.0f, width, height);
        std::printf("Meng15 Fig. 11: sphere of %.0f grain radii of snow grains (albedo %.4f, f = %.3f, sigma_t %.3f /R, "
                    "g %.3f, d_DA = %.2f R); %dx%d px per image, %d bundles x 16 paths per pixel\n",
                    Rb, stats.alpha_s(1), tile.packing_fraction(), rte.sigma_t[1], rte.g[1], diffusion.d_DA, width, height, spp);

        const gl::HybridMode modes[5] = {gl::HybridMode::vpt, gl::HybridMode::vpt_da, gl::HybridMode::ept_vpt,
                                         gl::HybridMode::ept_vpt_da, gl::HybridMode::ept};
        std::vector<gl::HybridImages> imgs;
        for (gl::HybridMode mode : modes) {
            gl::HybridOptions opt;
            opt.mode = mode;
            opt.ept.max_events = 4096;
            opt.vpt.max_depth = 4096;
            // One checkpoint per technique; this rank's rows, the films shared by all ranks.
            std::string stem = gl::hybrid_mode_name(mode);
            for (char& ch : stem) ch = ch == '+' ? '_' : char(std::tolower(ch));
            imgs.push_back(meng15::render_hybrid_run(ex, stem, ept, vpt, agg, ctx, cam, spp, ex.seed(), opt, gl::hybrid_mode_name(mode)));
        }
        const gl::HybridImages& ref = imgs[4];
        const gl::Image ref_img = ref.combined();
        const double npx = double(width) * double(height);
        auto mean3 = [](const gl::Image& im) { return (im.mean(0) + im.mean(1) + im.mean(2)) / 3.0; };
        const double ref_mean = mean3(ref_img), ref_se = std::sqrt(ref.var_total / (double(spp) * npx));
        gl::Image strip(5 * width, height);
        Csv csv({"technique", "mean", "rel_diff_vs_ept", "rel_diff_stderr", "detail_rms", "ttuv", "speedup", "ttuv_high",
                 "speedup_high", "da_per_path", "switch_depth"});
        Json j = ex.summary();
        std::printf("\n  %-11s %9s %18s %11s %10s %9s %9s %7s\n", "technique", "mean", "vs EPT", "detail RMS", "ttuv", "speedup",
                    "sp_high", "DA/pth");
        for (int t = 0; t < 5; ++t) {
            const gl::HybridImages& h = imgs[std::size_t(t)];
            const gl::Image all = h.combined();
            const double mean = mean3(all), se = std::sqrt(h.var_total / (double(spp) * npx));
            const double rel = (mean - ref_mean) / ref_mean, rel_se = std::hypot(se, t == 4 ? 0.0 : ref_se) / ref_mean;
            // Detail error: per-pixel squared difference to EPT minus both images' variance of
            // the pixel mean (channel mean), as a fraction of the mean radiance.
            double d2 = 0;
            for (int y = 0; y < height; ++y)
                for (int x = 0; x < width; ++x) {
                    double a = 0, r = 0;
                    for (int c = 0; c < 3; ++c) {
                        a += all.at(x, y, c) / 3.0;
                        r += ref_img.at(x, y, c) / 3.0;
                    }
                    const double noise = (double(h.pixel_variance.at(x, y, 0)) + double(ref.pixel_variance.at(x, y, 0))) / double(spp);
                    d2 += (a - r) * (a - r) - (t == 4 ? 0.0 : noise);
                }
            const double detail = t == 4 ? 0.0 : std::sqrt(std::max(0.0, d2 / npx)) / ref_mean;
            const double speed = ref.ttuv() / h.ttuv();
            const double speed_high = h.ttuv_high() > 0 ? ref.ttuv_high() / h.ttuv_high() : 0.0;
            const double da = double(h.counters.da) / double(h.counters.paths);
            const double depth = h.counters.switched ? double(h.counters.switch_depth) / double(h.counters.switched) : 0.0;
            const std::string name = gl::hybrid_mode_name(modes[t]);
            std::printf("  %-11s %9.4f %+8.2f%% +- %5.2f%% %10.2f%% %10.4g %8.2fx %8.1fx %7.3f\n", name.c_str(), mean, 100 * rel,
                        100 * rel_se, 100 * detail, h.ttuv(), speed, speed_high, da);
            for (int y = 0; y < height; ++y)
                for (int x = 0; x < width; ++x)
                    for (int c = 0; c < 3; ++c) strip.at(t * width + x, y, c) = all.at(x, y, c);
            std::string file = name;
            for (char& ch : file) ch = ch == '+' ? '_' : char(std::tolower(ch));
            if (ex.root()) gl::write_exr(ex.out() / ("fig11_" + file + ".exr"), all);
            if (ex.root()) gl::write_png(ex.out() / ("fig11_" + file + ".png"), all, {exposure});
            if (modes[t] == gl::HybridMode::ept_vpt_da) {
                // Fig. 12 (middle / bottom right): what each technique gathered, and the switch depth.
                if (ex.root()) gl::write_exr(ex.out() / "fig11_ept_vpt_da_contrib_ept.exr", h.ept_image());
                if (ex.root()) gl::write_exr(ex.out() / "fig11_ept_vpt_da_contrib_vpt.exr", h.vpt_image());
                if (ex.root()) gl::write_exr(ex.out() / "fig11_ept_vpt_da_contrib_da.exr", h.da_image());
                if (ex.root()) gl::write_png(ex.out() / "fig11_ept_vpt_da_contrib_ept.png", h.ept_image(), {exposure});
                if (ex.root()) gl::write_png(ex.out() / "fig11_ept_vpt_da_contrib_vpt.png", h.vpt_image(), {exposure});
                if (ex.root()) gl::write_png(ex.out() / "fig11_ept_vpt_da_contrib_da.png", h.da_image(), {exposure});
                if (ex.root()) gl::write_exr(ex.out() / "fig11_switch_depth.exr", h.switch_depth);
                std::printf("  %11s contributions of EPT / VPT / DA to the mean: %.4f / %.4f / %.4f; switch depth %.2f grain "
                            "interactions\n",
                            "", mean3(h.ept_image()), mean3(h.vpt_image()), mean3(h.da_image()), depth);
            }
            csv.row_text({name, std::to_string(mean), std::to_string(rel), std::to_string(rel_se), std::to_string(detail),
                          std::to_string(h.ttuv()), std::to_string(speed), std::to_string(h.ttuv_high()),
                          std::to_string(speed_high), std::to_string(da), std::to_string(depth)});
            std::string key = file;
            j.num(key + "_rel_diff", rel).num(key + "_rel_diff_stderr", rel_se).num(key + "_detail_rms", detail).num(key + "_speedup", speed);
        }
        std::printf("  (Meng15 Fig. 11 shows images only: VPT and VPT+DA alone miss the grain-scale detail that a few EPT "
                    "bounces before the switch recover; EPT is the reference)\n");
        if (ex.root()) gl::write_exr(ex.out() / "fig11_strip.exr", strip);
        if (ex.root()) gl::write_png(ex.out() / "fig11_strip.png", strip, {exposure});
        if (ex.root()) ex.csv("meng15_fig11_snow_sphere.csv", csv);
        std::printf("wrote %s/fig11_strip.{exr,png} (VPT | VPT+DA | EPT+VPT | EPT+VPT+DA | EPT), fig11_*.{exr,png}, "
                    "meng15_fig11_snow_sphere.csv\n",
                    ex.out().c_str());
        meng15::rank_rows(j, ex, height);
        return ex.finish(j.num("d_DA", diffusion.d_DA).num("radius", Rb).integer("spp", spp));
    });
}
