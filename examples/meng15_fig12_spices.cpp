// meng15_fig12_spices: Meng15 Fig. 12 -- four heaps of spices (flour as diffuse grains, pink salt,
// brown sugar, cane sugar; procedural grain presets, heaps = make_heap_mesh surfaces of
// revolution) on a ground plane rendered with EPT+VPT+DA (integrators/hybrid.hpp), with what each
// technique contributed (EPT / VPT / DA images), the switch depth (mean EPT grain interactions
// before the switch), an equal-CPU-time EPT inset, and the ttuv speed-ups of EPT+VPT and
// EPT+VPT+DA over EPT beside Table 2's SPICES row.
//
// The hybrid renders one aggregate (one effective medium) at a time, so each heap is its own
// panel (same camera, ground and lights) and the figure is the four panels side by side; its
// ttuv is (mean pixel variance over the panels) x (sum of their CPU times) (meng15_scenes.hpp).
//
//   meng15_fig12_spices [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                       [--width W] [--radius R] [--spp N] [--absorption A] [--exposure E]
//                       [--equal-time-spp N] [--checkpoint SECONDS] [--resume]
//
// --checkpoint / --resume: one checkpoint per technique and heap in --out, and the equal-time
// bundles per pixel beside them. mpirun -np K: rank r renders the rows y % K == r of every panel
// (meng15_scenes.hpp render_hybrid_run). The equal-time inset rests on measured CPU times:
// --equal-time-spp N pins it when images must be reproducible (1 vs K ranks, two runs).
//
// Outputs: fig12_spices.{exr,png} (EPT+VPT+DA), fig12_contrib_{ept,vpt,da}.{exr,png},
// fig12_switch_depth.{exr,png}, fig12_equal_time_ept.{exr,png}, fig12_spices_ept{,_vpt}.{exr,png},
// fig12_figure.png (rows: EPT+VPT+DA | equal-time EPT | EPT | VPT | DA | switch depth),
// meng15_fig12_spices.csv; JSON summary last.
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

// Meng15 Table 2, SPICES: ttuv (s) of EPT, EPT+VPT (P_a = 1), EPT+VPT+DA (P_a = 1); speed-ups.
constexpr double paper_ttuv[3] = {1617.3, 400.3, 219.8};
constexpr double paper_speedup[2] = {4.0, 7.4};
constexpr double paper_speedup_high[2] = {130.8, 2554.0};

gl::Image scaled(const gl::Image& im, double s) {
    gl::Image o = im;
    for (auto& v : o.rgb) v = float(double(v) * s);
    return o;
}

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig12_spices",
               "Meng15 Fig. 12: spice heaps with EPT+VPT+DA, per-technique contributions, switch depth, equal-time EPT",
               [&](Example& ex) {
        const int width = ex.opt<int>("width", 128, 512, "figure width: four panels of width/4 x 3/16 width");
        const double Rh = ex.opt<double>("radius", 30.0, 120.0, "heap base radius in grain radii");
        const int spp = ex.opt<int>("spp", 8, 8, "bundles of 16 paths per pixel (>= 8: the variance batches)");
        const double absorption = ex.opt<double>("absorption", 1e-3, 3e-4, "cane sugar interior absorption per grain radius");
        const double exposure = ex.opt<double>("exposure", 0.0, "PNG exposure in stops");
        const int spp_eq_pin = ex.opt<int>("equal-time-spp", 0,
                                           "bundles per pixel of the equal-time EPT inset (0: from the measured CPU times)");
        ex.checkpointable();  // --checkpoint SECONDS / --resume: one checkpoint per render
        ex.ready();
        meng15::quiet_other_ranks(ex);
        if (spp_eq_pin < 0 || spp_eq_pin > 65536) throw cli_error("--equal-time-spp = " + ex.given_text("equal-time-spp") + " must be in [0, 65536]");
        if (width < 32 || width > 4096) throw cli_error("--width must be in [32, 4096]");
        if (!(Rh >= 5 && Rh <= 5000)) throw cli_error("--radius must be in [5, 5000] grain radii");
        if (spp < 8 || spp > 4096) throw cli_error("--spp must be in [8, 4096] (measuring.md: >= 8 batches)");
        if (!(absorption >= 0 && absorption <= 0.1)) throw cli_error("--absorption must be in [0, 0.1]");
        const int level = ex.full() ? 4 : 3;
        const int pw = width / 4, ph = std::max(6, pw * 3 / 4);

        const auto heaps = meng15::make_spice_panels(Rh, absorption, pw, ph, ex.seed(), ex.full(), level);
        const auto panels = meng15::panels_of(heaps);
        std::printf("Meng15 Fig. 12 stand-in: four heaps of radius %.0f grain radii, height %.0f; %d panels of %dx%d px, %d bundles "
                    "x 16 paths per pixel\n",
                    Rh, 0.55 * Rh, int(heaps.size()), pw, ph, spp);
        for (const auto& h : heaps)
            std::printf("  %-12s %-20s albedo %.4f / %.4f / %.4f, sigma_t %.3f /R, g %.3f, d_DA %.2f R, ~%.3g grains\n",
                        h->name.c_str(), h->grains.preset.paper_column.c_str(), h->grains.stats.alpha_s(0), h->grains.stats.alpha_s(1),
                        h->grains.stats.alpha_s(2), h->grains.rte.sigma_t[1], h->grains.rte.g[1], h->grains.diffusion.d_DA,
                        h->grain_count);

        gl::HybridOptions opt;
        opt.ept.max_events = 4096;
        opt.vpt.max_depth = 4096;
        opt.mode = gl::HybridMode::ept;
        const Composite ept = meng15::render_panels(ex, panels, spp, ex.seed(), opt, "EPT");
        opt.mode = gl::HybridMode::ept_vpt;
        const Composite ev = meng15::render_panels(ex, panels, spp, ex.seed(), opt, "EPT+VPT");
        opt.mode = gl::HybridMode::ept_vpt_da;
        const Composite eva = meng15::render_panels(ex, panels, spp, ex.seed(), opt, "EPT+VPT+DA");
        // Equal-time EPT inset: as many EPT bundles per pixel as EPT+VPT+DA's CPU time buys
        // (measured costs per bundle of the two renders above).
        // Rank 0's choice (the same on every rank), kept for --resume (checkpoint.hpp decided); pinned
        // by --equal-time-spp for reproducible images (the CPU times differ between runs).
        const int spp_eq = spp_eq_pin > 0 ? spp_eq_pin : int(decided(ex, "equal_time_spp", [&] {
            return std::vector<double>{std::max(1.0, double(std::lround(double(spp) * eva.seconds_per_spp / ept.seconds_per_spp)))};
        })[0]);
        opt.mode = gl::HybridMode::ept;
        const Composite ept_eq = meng15::render_panels(ex, panels, spp_eq, ex.seed() + 101, opt, "EPT equal time");

        const auto speed = [&](const Composite& c) { return ept.ttuv() / c.ttuv(); };
        const auto speed_se = [&](const Composite& c) { return speed(c) * std::hypot(ept.ttuv_se() / ept.ttuv(), c.ttuv_se() / c.ttuv()); };
        const auto speed_high = [&](const Composite& c) { return c.ttuv_high() > 0 ? ept.ttuv_high() / c.ttuv_high() : 0.0; };
        const auto bias = [&](const Composite& c) { return (c.mean - ept.mean) / ept.mean; };
        const auto bias_se = [&](const Composite& c) { return std::hypot(c.mean_se, ept.mean_se) / ept.mean; };

        // Per heap: mean, contributions of EPT / VPT / DA (fractions of the EPT+VPT+DA mean),
        // switch depth, DA connections per path, ttuv speed-ups.
        Csv csv({"heap", "mean_ept", "mean_ept_vpt_da", "bias_ept_vpt_da", "share_ept", "share_vpt", "share_da", "switched_fraction",
                 "switch_depth", "da_per_path", "ttuv_ept", "ttuv_ept_vpt", "ttuv_ept_vpt_da", "speedup_ept_vpt", "speedup_ept_vpt_da"});
        std::printf("\n  %-12s %9s %9s %9s %7s %7s %7s %8s %7s %7s %9s %9s\n", "heap", "EPT", "E+V+D", "bias", "EPT", "VPT", "DA",
                    "switched", "depth", "DA/pth", "sp E+V", "sp E+V+D");
        for (std::size_t k = 0; k < heaps.size(); ++k) {
            const gl::HybridImages& a = eva.panels[k];
            const gl::HybridImages& e = ept.panels[k];
            const gl::HybridImages& v = ev.panels[k];
            const double m = meng15::mean3(a.combined()), me = meng15::mean3(e.combined());
            const double se = meng15::mean3(a.ept_image()) / m, sv = meng15::mean3(a.vpt_image()) / m, sd = meng15::mean3(a.da_image()) / m;
            const double paths = double(a.counters.paths);
            const double sw = (double(a.counters.switched) + double(a.counters.rejected)) / paths;
            const double depth = a.counters.switched ? double(a.counters.switch_depth) / double(a.counters.switched) : 0.0;
            const double da = double(a.counters.da) / paths;
            std::printf("  %-12s %9.4f %9.4f %+8.2f%% %6.1f%% %6.1f%% %6.1f%% %8.2f %7.2f %7.3f %8.2fx %8.2fx\n", heaps[k]->name.c_str(), me,
                        m, 100 * (m - me) / me, 100 * se, 100 * sv, 100 * sd, sw, depth, da, e.ttuv() / v.ttuv(), e.ttuv() / a.ttuv());
            csv.row_text({heaps[k]->name, std::to_string(me), std::to_string(m), std::to_string((m - me) / me), std::to_string(se),
                          std::to_string(sv), std::to_string(sd), std::to_string(sw), std::to_string(depth), std::to_string(da),
                          std::to_string(e.ttuv()), std::to_string(v.ttuv()), std::to_string(a.ttuv()),
                          std::to_string(e.ttuv() / v.ttuv()), std::to_string(e.ttuv() / a.ttuv())});
        }
        const gl::Image all = eva.image(Composite::Part::combined);
        const double m_all = meng15::mean3(all);
        const double share_ept = meng15::mean3(eva.image(Composite::Part::ept)) / m_all;
        const double share_vpt = meng15::mean3(eva.image(Composite::Part::vpt)) / m_all;
        const double share_da = meng15::mean3(eva.image(Composite::Part::da)) / m_all;
        const double depth_all = eva.switched > 0 ? eva.switch_depth / eva.switched : 0.0;
        // Equal time: per-pixel variance of the two images (one-bundle variance / spp).
        const double var_hyb = eva.var_total / double(spp), var_eq = ept_eq.var_total / double(spp_eq);
        std::printf("\n  %-22s %11s %11s %14s %10s %18s   Table 2 SPICES ttuv (speed-up, high order)\n", "technique", "ttuv",
                    "ttuv_high", "speed-up", "sp_high", "bias vs EPT");
        std::printf("  %-22s %11.4g %11.4g %14s %10s %18s   %.1f s\n", "EPT", ept.ttuv(), ept.ttuv_high(), "1", "1", "", paper_ttuv[0]);
        const Composite* cs[2] = {&ev, &eva};
        const char* names[2] = {"EPT+VPT (P_a = 1)", "EPT+VPT+DA (P_a = 1)"};
        for (int i = 0; i < 2; ++i)
            std::printf("  %-22s %11.4g %11.4g %7.2fx+-%4.2f %9.1fx %+8.2f%% +- %5.2f%%   %.1f s (%.1fx, %.1fx)\n", names[i], cs[i]->ttuv(),
                        cs[i]->ttuv_high(), speed(*cs[i]), speed_se(*cs[i]), speed_high(*cs[i]), 100 * bias(*cs[i]),
                        100 * bias_se(*cs[i]), paper_ttuv[i + 1], paper_speedup[i], paper_speedup_high[i]);
        std::printf("  Meng15 Fig. 12 caption: EPT+VPT+DA renders the high order 120x faster (34 vs 4148 h), 8x overall at equal "
                    "variance\n");
        std::printf("  EPT+VPT+DA contributions (Fig. 12 middle): EPT %.1f %% | VPT %.1f %% | DA %.1f %%; mean switch depth %.2f grain "
                    "interactions; %.2f DA connections per path\n",
                    100 * share_ept, 100 * share_vpt, 100 * share_da, depth_all, eva.da / eva.paths);
        std::printf("  equal CPU time (Fig. 12 inset): EPT %d bundles/px (%.1f CPU s) vs EPT+VPT+DA %d (%.1f CPU s): pixel variance "
                    "%.4g vs %.4g (%.2fx)\n",
                    spp_eq, ept_eq.cpu(), spp, eva.cpu(), var_eq, var_hyb, var_eq / var_hyb);

        // Images.
        const auto write = [&](const std::string& name, const gl::Image& im) {
            if (ex.root()) gl::write_exr(ex.out() / (name + ".exr"), im);
            if (ex.root()) gl::write_png(ex.out() / (name + ".png"), im, {exposure});
        };
        write("fig12_spices", all);
        write("fig12_spices_ept", ept.image(Composite::Part::combined));
        write("fig12_spices_ept_vpt", ev.image(Composite::Part::combined));
        write("fig12_equal_time_ept", ept_eq.image(Composite::Part::combined));
        write("fig12_contrib_ept", eva.image(Composite::Part::ept));
        write("fig12_contrib_vpt", eva.image(Composite::Part::vpt));
        write("fig12_contrib_da", eva.image(Composite::Part::da));
        const gl::Image depth = eva.image(Composite::Part::switch_depth);
        double dmax = 0;
        for (float v : depth.rgb) dmax = std::max(dmax, double(v));
        if (ex.root()) gl::write_exr(ex.out() / "fig12_switch_depth.exr", depth);
        if (ex.root()) gl::write_png(ex.out() / "fig12_switch_depth.png", scaled(depth, dmax > 0 ? 1.0 / dmax : 1.0), {0.0});
        {
            const gl::Image rows[6] = {all,
                                       ept_eq.image(Composite::Part::combined),
                                       eva.image(Composite::Part::ept),
                                       eva.image(Composite::Part::vpt),
                                       eva.image(Composite::Part::da),
                                       scaled(depth, dmax > 0 ? 1.0 / dmax : 1.0)};
            const int W = rows[0].width, H = rows[0].height;
            gl::Image fig(W, 6 * H);
            for (int r = 0; r < 6; ++r)
                for (int y = 0; y < H; ++y)
                    for (int x = 0; x < W; ++x)
                        for (int c = 0; c < 3; ++c) fig.at(x, r * H + y, c) = rows[r].at(x, y, c);
            if (ex.root()) gl::write_png(ex.out() / "fig12_figure.png", fig, {exposure});
        }
        if (ex.root()) ex.csv("meng15_fig12_spices.csv", csv);
        std::printf("wrote %s/fig12_spices.{exr,png}, fig12_contrib_{ept,vpt,da}, fig12_switch_depth, fig12_equal_time_ept, "
                    "fig12_figure.png (rows: EPT+VPT+DA | equal-time EPT | EPT | VPT | DA | switch depth), meng15_fig12_spices.csv\n",
                    ex.out().c_str());
        Json j = ex.summary();
        j.num("ept_vpt_speedup", speed(ev))
            .num("ept_vpt_speedup_stderr", speed_se(ev))
            .num("ept_vpt_speedup_high_order", speed_high(ev))
            .num("ept_vpt_da_speedup", speed(eva))
            .num("ept_vpt_da_speedup_stderr", speed_se(eva))
            .num("ept_vpt_da_speedup_high_order", speed_high(eva))
            .num("bias_ept_vpt", bias(ev))
            .num("bias_ept_vpt_stderr", bias_se(ev))
            .num("bias_ept_vpt_da", bias(eva))
            .num("bias_ept_vpt_da_stderr", bias_se(eva))
            .num("share_ept", share_ept)
            .num("share_vpt", share_vpt)
            .num("share_da", share_da)
            .num("switch_depth", depth_all)
            .num("da_per_path", eva.da / eva.paths)
            .integer("equal_time_ept_spp", spp_eq)
            .num("equal_time_variance_ratio", var_eq / var_hyb)
            .num("paper_ept_vpt_speedup", paper_speedup[0])
            .num("paper_ept_vpt_da_speedup", paper_speedup[1])
            .num("paper_high_order_hours_ratio", 4148.0 / 34.0)
            .num("radius", Rh)
            .integer("spp", spp);
        meng15::rank_rows(j, ex, ph);
        return ex.finish(j);
    });
}
