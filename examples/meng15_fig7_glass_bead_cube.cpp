// meng15_fig7_glass_bead_cube: Meng15 Fig. 7 -- the cube of glass beads of Moon et al. [2007,
// Fig. 9] (lossless glass spheres, ior 1.5, random sequential addition at f = 0.3, the cube's side
// from the bead count as in moon07_fig9_cube_shadow: L = cbrt(n 4/3 pi / f) bead radii; a small
// quad light above at 2.2 L (larger than Moon07's, and a dim sky: see below), a black blocker at
// 1.5 L shadowing a third of the top face, no floor), rendered with EPT, EPT+VPT and EPT+VPT+DA (integrators/hybrid.hpp).
// Prints the equal-quality comparison (the EPT bundles per pixel and CPU seconds that reach the
// hybrid's MSE) and writes MSE and variance vs core-seconds curves (CSV + plot) for the three
// techniques, and EPT+VPT's low-order (EPT) and high-order (VPT) contributions (Fig. 7's last
// column).
//
// MSE against EPT without a converged reference: per pixel, the squared difference of the
// technique's mean to EPT's minus both images' variances of the mean is an unbiased estimate of
// the squared bias b^2 (at least the squared bias of the image mean, by Jensen); the MSE of an n-bundle image is then b^2 + V / n (V: the one-bundle pixel
// variance), at CPU time n t (t: CPU seconds per bundle per pixel, all measured in this run). EPT
// is unbiased (b = 0). Points with n <= spp are measured, larger n follow from the same b^2, V, t.
//
//   meng15_fig7_glass_bead_cube [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                               [--beads N] [--width W] [--spp N] [--exposure E] [--checkpoint SECONDS] [--resume]
//
// --checkpoint / --resume: one checkpoint per technique's render in --out. mpirun -np K: rank r
// renders the rows y % K == r (meng15_scenes.hpp render_hybrid_run); EXRs byte-identical to one
// process's.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "meng15_scenes.hpp"

namespace gl = grainlight;
using namespace gl_examples;
using meng15::Composite;

namespace {
// Six significant digits (std::to_string's fixed 6 decimals would floor small variances at 1e-6).
std::string g6(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.6g", v);
    return b;
}
}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig7_glass_bead_cube",
               "Meng15 Fig. 7: glass-bead cube, equal quality EPT vs EPT+VPT, MSE and variance vs core seconds", [&](Example& ex) {
        const double beads = ex.opt<double>("beads", 15000.0, 120000.0, "glass beads in the cube (Moon07 Fig. 9: its side follows)");
        const int width = ex.opt<int>("width", 96, 512, "image width (height = 3/4 width)");
        const int spp = ex.opt<int>("spp", 8, 8, "bundles of 16 paths per pixel (>= 8: the variance batches)");
        const double exposure = ex.opt<double>("exposure", 0.0, "PNG exposure in stops");
        ex.checkpointable();  // --checkpoint SECONDS / --resume: one checkpoint per technique's render
        ex.ready();
        meng15::quiet_other_ranks(ex);
        if (!(beads >= 100 && beads <= 1e9)) throw cli_error("--beads must be in [100, 1e9]");
        if (width < 8 || width > 4096) throw cli_error("--width must be in [8, 4096]");
        if (spp < 8 || spp > 4096) throw cli_error("--spp must be in [8, 4096] (measuring.md: >= 8 batches)");
        const int height = std::max(6, width * 3 / 4);

        const auto cube = meng15::make_glass_bead_cube(beads, width, height, ex.seed(), ex.full());
        const meng15::Grains& g = cube->grains;
        const double L = cube->L;
        const auto panels = cube->panels();
        std::printf("Meng15 Fig. 7 / Moon07 Fig. 9: cube of %.0f glass beads (ior 1.5, RSA f = %.2f), side %.1f bead radii; albedo %.4f, "
                    "sigma_t %.3f /R, g %.3f, d_DA %.2f R; %dx%d px, %d bundles x 16 paths per pixel\n",
                    beads, g.tile.packing_fraction(), L, g.stats.alpha_s(1), g.rte.sigma_t[1], g.rte.g[1], g.diffusion.d_DA, width, height,
                    spp);

        gl::HybridOptions opt;
        opt.ept.max_events = 4096;
        opt.vpt.max_depth = 4096;
        const gl::HybridMode modes[3] = {gl::HybridMode::ept, gl::HybridMode::ept_vpt, gl::HybridMode::ept_vpt_da};
        std::vector<Composite> r;
        for (gl::HybridMode mode : modes) {
            opt.mode = mode;
            r.push_back(meng15::render_panels(ex, panels, spp, ex.seed(), opt, gl::hybrid_mode_name(mode)));
        }
        // Per-pixel squared bias against EPT (unbiased estimate, mean over pixels).
        const gl::Image ref = r[0].image(Composite::Part::combined);
        const gl::HybridImages& e0 = r[0].panels[0];
        const double npx = double(width) * double(height);
        Csv curve({"technique", "spp", "core_seconds", "variance", "mse", "measured"});
        Json j = ex.summary();
        double b2[3] = {0, 0, 0};
        const double V_ept = r[0].var_total, t_ept = r[0].seconds_per_spp;
        std::printf("\n  %-11s %10s %10s %10s %12s %12s %16s %14s\n", "technique", "V (1 spp)", "t (1 spp)", "ttuv", "bias^2", "mean",
                    "vs EPT", "equal quality");
        for (int k = 0; k < 3; ++k) {
            const Composite& c = r[std::size_t(k)];
            const gl::Image im = c.image(Composite::Part::combined);
            const gl::HybridImages& h = c.panels[0];
            double acc = 0;
            if (k > 0)
                for (int y = 0; y < height; ++y)
                    for (int x = 0; x < width; ++x) {
                        double a = 0, e = 0;
                        for (int ch = 0; ch < 3; ++ch) {
                            a += im.at(x, y, ch) / 3.0;
                            e += ref.at(x, y, ch) / 3.0;
                        }
                        acc += (a - e) * (a - e) - (double(h.pixel_variance.at(x, y, 0)) + double(e0.pixel_variance.at(x, y, 0))) / double(spp);
                    }
            // Jensen: the mean of the squared per-pixel bias is at least the square of the image's
            // mean bias (estimated without the noise of both means); the larger of the two.
            const double dm = c.mean - r[0].mean, dm_var = c.mean_se * c.mean_se + r[0].mean_se * r[0].mean_se;
            b2[k] = k > 0 ? std::max({0.0, acc / npx, dm * dm - dm_var}) : 0.0;
            const double V = c.var_total, t = c.seconds_per_spp;
            // Equal quality: EPT bundles per pixel n_eq with V_ept / n_eq = MSE of this technique at spp.
            const double mse = b2[k] + V / double(spp);
            const double n_eq = V_ept / mse, speed_eq = (n_eq * t_ept) / (double(spp) * t);
            const double rel = (c.mean - r[0].mean) / r[0].mean, rel_se = std::hypot(c.mean_se, r[0].mean_se) / r[0].mean;
            std::printf("  %-11s %10.4g %10.4g %10.4g %12.4g %12.4f %+7.2f%%+-%5.2f%% %8.1f spp EPT, %.2fx\n",
                        gl::hybrid_mode_name(modes[k]), V, t, c.ttuv(), b2[k], c.mean, 100 * rel, 100 * rel_se, n_eq, speed_eq);
            for (double n = 1; n <= 64.0 * spp; n *= 2)
                curve.row_text({gl::hybrid_mode_name(modes[k]), std::to_string(int(n)), g6(n * t), g6(V / n), g6(b2[k] + V / n),
                                n <= spp ? "1" : "0"});
            std::string key = gl::hybrid_mode_name(modes[k]);
            for (char& ch : key) ch = ch == '+' ? '_' : char(std::tolower(ch));
            j.num(key + "_ttuv", c.ttuv()).num(key + "_bias2", b2[k]).num(key + "_rel_bias", rel).num(key + "_rel_bias_stderr", rel_se);
            if (k > 0) j.num(key + "_speedup", r[0].ttuv() / c.ttuv()).num(key + "_equal_quality_speedup", speed_eq);
            if (ex.root()) gl::write_exr(ex.out() / ("fig7_" + key + ".exr"), im);
            if (ex.root()) gl::write_png(ex.out() / ("fig7_" + key + ".png"), im, {exposure});
            if (modes[k] == gl::HybridMode::ept_vpt) {
                // Fig. 7's last column: low order (EPT) and high order (VPT) of EPT+VPT.
                if (ex.root()) gl::write_exr(ex.out() / "fig7_ept_vpt_low_order.exr", c.image(Composite::Part::ept));
                if (ex.root()) gl::write_exr(ex.out() / "fig7_ept_vpt_high_order.exr", c.image(Composite::Part::vpt));
                if (ex.root()) gl::write_png(ex.out() / "fig7_ept_vpt_low_order.png", c.image(Composite::Part::ept), {exposure});
                if (ex.root()) gl::write_png(ex.out() / "fig7_ept_vpt_high_order.png", c.image(Composite::Part::vpt), {exposure});
            }
        }
        std::printf("  (Meng15 Fig. 7 shows images and curves only: equal quality EPT vs EPT+VPT, \"similar visual fidelity\" of the "
                    "TT-derived RTE parameters; MSE and variance vs core hours for the three techniques)\n");
        if (ex.root()) {
            const auto csv_path = ex.csv("meng15_fig7_glass_bead_cube.csv", curve);
            ex.plot("meng15_fig7_glass_bead_cube", csv_path, ex.out() / "meng15_fig7_glass_bead_cube.png");
        }
        std::printf("wrote %s/fig7_{ept,ept_vpt,ept_vpt_da}.{exr,png}, fig7_ept_vpt_{low,high}_order.{exr,png}, "
                    "meng15_fig7_glass_bead_cube.{csv,png}\n",
                    ex.out().c_str());
        meng15::rank_rows(j, ex, height);
        return ex.finish(j.num("cube_side", L).num("beads", beads).num("d_DA", g.diffusion.d_DA).integer("spp", spp));
    });
}
