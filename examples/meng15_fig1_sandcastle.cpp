// meng15_fig1_sandcastle: Meng15 Fig. 1 -- a sandcastle of sand grains (the `sand` preset: a
// dielectric grain enclosing a scattering, absorbing medium, effective albedo ~0.68) whose
// boundary is a closed mesh: four corner towers (cylinders with cone roofs), crenellated curtain
// walls (boxes) and a central keep on a sand base, their CSG union as a heightfield
// (geometry/procedural_boundaries.hpp make_sandcastle_mesh). The packing is tiled, so the grain
// count is the volume / grain volume: ~2e9 grains at full quality (castle 5200 grain radii wide).
// The top half of the image is rendered with EPT+VPT+DA, the bottom half with EPT (the paper's
// split); both techniques render the whole image to measure the high-order and total CPU times,
// the pixel variances and the ttuv speed-ups, printed beside Fig. 1's caption and Table 2's
// SANDCASTLE row. An equal-time EPT render is the inset.
//
//   meng15_fig1_sandcastle [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                          [--width W] [--castle-size C] [--spp N] [--exposure E] [--equal-time-spp N]
//                          [--checkpoint SECONDS] [--resume]
//
// --checkpoint / --resume: one checkpoint per render in --out, and the equal-time bundles per pixel
// beside them. mpirun -np K: rank r renders the rows y % K == r (meng15_scenes.hpp
// render_hybrid_run). The equal-time inset rests on measured CPU times: --equal-time-spp N pins it
// when images must be reproducible (1 vs K ranks, two runs).
//
// Outputs: fig1_sandcastle.{exr,png} (top EPT+VPT+DA | bottom EPT), fig1_sandcastle_{ept,ept_vpt_da}.{exr,png},
// fig1_equal_time_ept.{exr,png}, fig1_switch_depth.exr, meng15_fig1_sandcastle.csv; JSON last.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "meng15_scenes.hpp"

namespace gl = grainlight;
using namespace gl_examples;
using meng15::Composite;

namespace {

// Meng15 Fig. 1 caption: high-order / total render time in hours, "over 12x (50 vs. 628 hrs)"
// for the high order; Table 2 SANDCASTLE: ttuv (s) EPT 30.7, EPT+VPT+DA 13.9 (2.2x); high order
// 11.8 vs 0.4 (26.5x).
constexpr double paper_high_hours[2] = {628.0, 50.0};  // EPT, EPT+VPT+DA
constexpr double paper_ttuv[2] = {30.7, 13.9};
constexpr double paper_speedup = 2.2, paper_speedup_high = 26.5;

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig1_sandcastle",
               "Meng15 Fig. 1: sandcastle of sand grains, top half EPT+VPT+DA, bottom half EPT, times and variances",
               [&](Example& ex) {
        const int width = ex.opt<int>("width", 96, 512, "image width (height = 9/16 width)");
        const double castle = ex.opt<double>("castle-size", 60.0, 5200.0,
                                             "castle width in grain radii (5200: ~2e9 sand grains, Fig. 1's scale)");
        const int spp = ex.opt<int>("spp", 8, 8, "bundles of 16 paths per pixel (>= 8: the variance batches)");
        const double exposure = ex.opt<double>("exposure", 0.0, "PNG exposure in stops");
        const int spp_eq_pin = ex.opt<int>("equal-time-spp", 0,
                                           "bundles per pixel of the equal-time EPT inset (0: from the measured CPU times)");
        ex.checkpointable();  // --checkpoint SECONDS / --resume: one checkpoint per render
        ex.ready();
        meng15::quiet_other_ranks(ex);
        if (spp_eq_pin < 0 || spp_eq_pin > 65536) throw cli_error("--equal-time-spp = " + ex.given_text("equal-time-spp") + " must be in [0, 65536]");
        if (width < 16 || width > 4096) throw cli_error("--width must be in [16, 4096]");
        if (!(castle >= 10 && castle <= 1e5)) throw cli_error("--castle-size must be in [10, 1e5] grain radii");
        if (spp < 8 || spp > 4096) throw cli_error("--spp must be in [8, 4096] (measuring.md: >= 8 batches)");
        const int height = std::max(8, width * 9 / 16);
        const int level = ex.full() ? 4 : 3;

        const auto sc = meng15::make_sandcastle_panel(0.5 * castle, width, height, ex.seed(), ex.full(), level);
        const auto panels = meng15::panels_of(sc);
        const meng15::MeshPanel& p = *sc[0];
        std::printf("Meng15 Fig. 1 stand-in: sandcastle %.0f grain radii wide, %.0f tall (%zu triangles), ~%.3g sand grains "
                    "(paper: ~2e9); grain albedo %.3f / %.3f / %.3f (Table 1 sand: 0.68), sigma_t %.3f /R, g %.3f, d_DA %.2f R; "
                    "%dx%d px, %d bundles x 16 paths per pixel\n",
                    castle, 0.57 * castle, p.mesh.triangle_count(), p.grain_count, p.grains.stats.alpha_s(0), p.grains.stats.alpha_s(1),
                    p.grains.stats.alpha_s(2), p.grains.rte.sigma_t[1], p.grains.rte.g[1], p.grains.diffusion.d_DA, width, height, spp);

        gl::HybridOptions opt;
        opt.ept.max_events = 4096;
        opt.vpt.max_depth = 4096;
        opt.mode = gl::HybridMode::ept;
        const Composite ept = meng15::render_panels(ex, panels, spp, ex.seed(), opt, "EPT");
        opt.mode = gl::HybridMode::ept_vpt_da;
        const Composite eva = meng15::render_panels(ex, panels, spp, ex.seed(), opt, "EPT+VPT+DA");
        // Rank 0's choice (the same on every rank), kept for --resume (checkpoint.hpp decided); pinned
        // by --equal-time-spp for reproducible images (the CPU times differ between runs).
        const int spp_eq = spp_eq_pin > 0 ? spp_eq_pin : int(decided(ex, "equal_time_spp", [&] {
            return std::vector<double>{std::max(1.0, double(std::lround(double(spp) * eva.seconds_per_spp / ept.seconds_per_spp)))};
        })[0]);
        opt.mode = gl::HybridMode::ept;
        const Composite ept_eq = meng15::render_panels(ex, panels, spp_eq, ex.seed() + 101, opt, "EPT equal time");

        const double speed = ept.ttuv() / eva.ttuv();
        const double speed_se = speed * std::hypot(ept.ttuv_se() / ept.ttuv(), eva.ttuv_se() / eva.ttuv());
        const double speed_high = eva.ttuv_high() > 0 ? ept.ttuv_high() / eva.ttuv_high() : 0.0;
        const double bias = (eva.mean - ept.mean) / ept.mean, bias_se = std::hypot(eva.mean_se, ept.mean_se) / ept.mean;
        const double var_ept = ept.var_total / double(spp), var_eva = eva.var_total / double(spp);
        const double high_ept = ept.high_seconds_per_spp * spp, high_eva = eva.high_seconds_per_spp * spp;
        // The high-order time EPT would need for EPT+VPT+DA's high-order variance (equal variance):
        // (ttuv_high ratio) x the hybrid's high-order seconds.
        std::printf("\n  %-12s %12s %12s %12s %12s %14s %10s %18s\n", "technique", "high CPU s", "total CPU s", "pixel var", "ttuv",
                    "speed-up", "sp_high", "bias vs EPT");
        std::printf("  %-12s %12.1f %12.1f %12.4g %12.4g %14s %10s %18s\n", "EPT", high_ept, ept.cpu(), var_ept, ept.ttuv(), "1", "1", "");
        std::printf("  %-12s %12.1f %12.1f %12.4g %12.4g %7.2fx+-%4.2f %9.1fx %+8.2f%% +- %5.2f%%\n", "EPT+VPT+DA", high_eva, eva.cpu(),
                    var_eva, eva.ttuv(), speed, speed_se, speed_high, 100 * bias, 100 * bias_se);
        std::printf("  Meng15 Fig. 1: high order EPT %.0f h vs EPT+VPT+DA %.0f h (over 12x); Table 2 SANDCASTLE ttuv %.1f s vs %.1f s "
                    "(%.1fx), high order %.1fx\n",
                    paper_high_hours[0], paper_high_hours[1], paper_ttuv[0], paper_ttuv[1], paper_speedup, paper_speedup_high);
        std::printf("  equal CPU time (inset): EPT %d bundles/px (%.1f CPU s) vs EPT+VPT+DA %d (%.1f CPU s): pixel variance %.4g vs %.4g "
                    "(%.2fx); %.2f of the paths switch, %.3f DA connections per path\n",
                    spp_eq, ept_eq.cpu(), spp, eva.cpu(), ept_eq.var_total / spp_eq, var_eva, (ept_eq.var_total / spp_eq) / var_eva,
                    eva.switched / eva.paths, eva.da / eva.paths);

        const gl::Image top = eva.image(Composite::Part::combined), bottom = ept.image(Composite::Part::combined);
        gl::Image split = top;
        for (int y = height / 2; y < height; ++y)
            for (int x = 0; x < width; ++x)
                for (int c = 0; c < 3; ++c) split.at(x, y, c) = bottom.at(x, y, c);
        const auto write = [&](const std::string& name, const gl::Image& im) {
            if (ex.root()) gl::write_exr(ex.out() / (name + ".exr"), im);
            if (ex.root()) gl::write_png(ex.out() / (name + ".png"), im, {exposure});
        };
        write("fig1_sandcastle", split);
        write("fig1_sandcastle_ept", bottom);
        write("fig1_sandcastle_ept_vpt_da", top);
        write("fig1_equal_time_ept", ept_eq.image(Composite::Part::combined));
        if (ex.root()) gl::write_exr(ex.out() / "fig1_switch_depth.exr", eva.image(Composite::Part::switch_depth));
        Csv csv({"technique", "spp", "high_cpu_seconds", "total_cpu_seconds", "pixel_variance", "ttuv", "ttuv_high", "speedup",
                 "speedup_high", "mean", "bias", "bias_stderr", "paper_high_hours", "paper_ttuv"});
        csv.row_text({"EPT", std::to_string(spp), std::to_string(high_ept), std::to_string(ept.cpu()), std::to_string(var_ept),
                      std::to_string(ept.ttuv()), std::to_string(ept.ttuv_high()), "1", "1", std::to_string(ept.mean), "0",
                      std::to_string(ept.mean_se / ept.mean), std::to_string(paper_high_hours[0]), std::to_string(paper_ttuv[0])});
        csv.row_text({"EPT+VPT+DA", std::to_string(spp), std::to_string(high_eva), std::to_string(eva.cpu()), std::to_string(var_eva),
                      std::to_string(eva.ttuv()), std::to_string(eva.ttuv_high()), std::to_string(speed), std::to_string(speed_high),
                      std::to_string(eva.mean), std::to_string(bias), std::to_string(bias_se), std::to_string(paper_high_hours[1]),
                      std::to_string(paper_ttuv[1])});
        csv.row_text({"EPT equal time", std::to_string(spp_eq), std::to_string(ept_eq.high_seconds_per_spp * spp_eq),
                      std::to_string(ept_eq.cpu()), std::to_string(ept_eq.var_total / spp_eq), std::to_string(ept_eq.ttuv()),
                      std::to_string(ept_eq.ttuv_high()), "", "", std::to_string(ept_eq.mean), "", "", "", ""});
        if (ex.root()) ex.csv("meng15_fig1_sandcastle.csv", csv);
        std::printf("wrote %s/fig1_sandcastle.{exr,png} (top half EPT+VPT+DA, bottom half EPT), fig1_sandcastle_{ept,ept_vpt_da}, "
                    "fig1_equal_time_ept, fig1_switch_depth.exr, meng15_fig1_sandcastle.csv\n",
                    ex.out().c_str());
        Json j = ex.summary();
        j.num("grains", p.grain_count)
            .num("high_cpu_seconds_ept", high_ept)
            .num("high_cpu_seconds_ept_vpt_da", high_eva)
            .num("total_cpu_seconds_ept", ept.cpu())
            .num("total_cpu_seconds_ept_vpt_da", eva.cpu())
            .num("pixel_variance_ept", var_ept)
            .num("pixel_variance_ept_vpt_da", var_eva)
            .num("ept_vpt_da_speedup", speed)
            .num("ept_vpt_da_speedup_stderr", speed_se)
            .num("ept_vpt_da_speedup_high_order", speed_high)
            .num("bias_ept_vpt_da", bias)
            .num("bias_ept_vpt_da_stderr", bias_se)
            .num("switched_fraction", eva.switched / eva.paths)
            .integer("equal_time_ept_spp", spp_eq)
            .num("equal_time_variance_ratio", (ept_eq.var_total / spp_eq) / var_eva)
            .num("paper_ept_vpt_da_speedup", paper_speedup)
            .num("paper_high_order_hours_ratio", paper_high_hours[0] / paper_high_hours[1])
            .num("castle_size", castle)
            .integer("spp", spp);
        meng15::rank_rows(j, ex, height);
        return ex.finish(j);
    });
}
