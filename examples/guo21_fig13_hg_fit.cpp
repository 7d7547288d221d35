// guo21_fig13_hg_fit: Guo21 Fig. 13 / Sec. 6.2. The scene of Fig. 12 (1e5 ice spheres of
// 1000 um, m = 1.31, lambda = 0.55 um, in the Cornell box of guo21_cornell_scene.hpp) rendered with
// our tabulated phase function (the particles' GOA phase with Fraunhofer diffraction, Eqs. 4-11,
// optics/bulk.hpp) and with best-fit Henyey-Greenstein phases (phase/henyey_greenstein.hpp), all
// else equal: (a) HG with the same g (moment fit), (b) HG least-squares fit of ln p over the sphere
// (weights sin theta dtheta). The phase is the only change, so the renders use the continuous
// medium of the cloud (sigma_t = N C_t / V, albedo 1: ForcedCollisionMedium), not the grainy
// discrete medium (whose per-particle phase would be replaced the same way).
//
//   guo21_fig13_hg_fit [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                      [--width W] [--count N] [--checkpoint SECONDS] [--resume]
//
// Every render is split by rows over MPI ranks (mpirun -np K: byte-identical EXRs) and resumable
// (--checkpoint / --resume: one checkpoint per batch in --out); CPU seconds are summed over ranks.
//
// Paper: "the HG phase function cannot faithfully encode the scattering pattern from these
// relatively large particles", renders "slightly different" (closeups; no numbers). Printed and in
// the JSON: g of the table and of both fits, the phase values at a few angles, the mean radiance of
// each render over the pixels that look through the cloud, the relative mean differences, and the
// per-pixel RMS difference (over the tabulated render's mean) with the renders' Monte Carlo noise
// (from 8 seeded batches) removed in quadrature. Outputs: tabulated, hg_same_g, hg_lsq .{exr,png},
// diff_hg_same_g.png, guo21_fig13_phase.csv (phase curves), guo21_fig13_hg_fit.png (plot).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/optics/bulk.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/image_io.hpp"
#include "guo21_cornell_scene.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

namespace {

/// Per-pixel variance of the batch mean image over the masked pixels, relative to mean^2: the
/// squared relative noise of a render from its batch variance (Run::var_per_sample / spp).
double rel_noise2(const guo21_cornell::Run& r, double mean) { return r.var_per_sample / double(r.spp) / (mean * mean); }

double masked_rel_rmse(const gl::Image& a, const gl::Image& b, const std::vector<char>& mask, double mean_b) {
    double s = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < mask.size(); ++i)
        if (mask[i]) {
            const double d = double(a.rgb[3 * i]) - double(b.rgb[3 * i]);
            s += d * d;
            ++n;
        }
    return n ? std::sqrt(s / double(n)) / mean_b : 0.0;
}

/// The same over blocks of b x b pixels (block means of the masked pixels): the low-frequency
/// difference, with the per-pixel noise averaged down by ~b; also the squared relative noise of
/// the block means of `r` (from its batches), returned in `noise2`.
double block_rel_rmse(const gl::Image& a, const gl::Image& ref, const std::vector<char>& mask, int width, int bsz, double mean_b) {
    const int nb = width / bsz;
    double s = 0;
    int n = 0;
    for (int by = 0; by < nb; ++by)
        for (int bx = 0; bx < nb; ++bx) {
            double sa = 0, sr = 0;
            int k = 0;
            for (int y = by * bsz; y < (by + 1) * bsz; ++y)
                for (int x = bx * bsz; x < (bx + 1) * bsz; ++x) {
                    const std::size_t i = std::size_t(y) * std::size_t(width) + std::size_t(x);
                    if (!mask[i]) continue;
                    sa += a.rgb[3 * i];
                    sr += ref.rgb[3 * i];
                    ++k;
                }
            if (k < bsz * bsz) continue;  // whole blocks inside the cloud's pixels only
            const double d = (sa - sr) / k;
            s += d * d;
            ++n;
        }
    return n ? std::sqrt(s / n) / mean_b : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_fig13_hg_fit", "Guo21 Fig. 13: our tabulated phase vs best-fit Henyey-Greenstein in the Fig. 12 scene",
        "out/guo21_fig13_hg_fit", [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 512, 2048, "samples per pixel (8 seeded batches)");
            const int width = ex.opt<int>("width", 64, 512, "image width = height");
            const auto count = ex.opt<std::uint64_t>("count", 100000, "particle count (paper: 1e5)");
            ex.checkpointable();
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 8 || spp > 65536) throw gl_examples::cli_error("--spp must be in [8, 65536]");
            if (!(count >= 1 && count <= 100000000)) throw gl_examples::cli_error("--count must be in [1, 1e8]");
            const auto& out = ex.out();
            const double lambda = 0.55, r_um = guo21_cornell::kRadiusUm;
            gl::ParticleModel model;
            model.particle_index = {1.31, 0.0};
            const std::vector<double> wl = {lambda};
            const auto bulk = gl::compute_bulk_optics(gl::MonodispersePsd(r_um, 1.0), model, wl);
            const auto& ch = bulk.channels[0];
            const gl::Vec3d ext = guo21_cornell::kHi - guo21_cornell::kLo;
            const double volume = ext.x * ext.y * ext.z;
            const double sigma_t = ch.mean_C_t * 1e-12 * double(count) / volume;
            const double albedo = ch.mean_C_s / ch.mean_C_t;
            const auto phase_tab = bulk.make_phase<float, S>();
            const double g_tab = ch.g;

            // Least-squares HG fit of ln p over the sphere: minimize sum_i w_i (ln p_tab - ln p_HG(g))^2,
            // w_i = sin theta_i dtheta_i, by golden-section search over g in [0, 0.9999].
            const auto& th = bulk.theta;
            std::vector<double> p_tab(th.size()), w(th.size(), 0.0);
            for (std::size_t i = 0; i < th.size(); ++i) p_tab[i] = ch.phase[i] / ch.phase_integral;
            for (std::size_t i = 0; i + 1 < th.size(); ++i) {
                const double h = 0.5 * (th[i + 1] - th[i]);
                w[i] += h * std::sin(th[i]);
                w[i + 1] += h * std::sin(th[i + 1]);
            }
            auto hg = [](double mu, double g) {
                return (1 - g * g) / (4 * gl::pi_v<double> * std::pow(1 + g * g - 2 * g * mu, 1.5));
            };
            auto cost = [&](double g) {
                double c = 0;
                for (std::size_t i = 0; i < th.size(); ++i)
                    if (p_tab[i] > 0) {
                        const double d = std::log(p_tab[i]) - std::log(hg(std::cos(th[i]), g));
                        c += w[i] * d * d;
                    }
                return c;
            };
            double a = 0, b = 0.9999;
            const double gr = 0.5 * (std::sqrt(5.0) - 1);
            for (int it = 0; it < 100; ++it) {
                const double c1 = b - gr * (b - a), c2 = a + gr * (b - a);
                if (cost(c1) < cost(c2)) b = c2;
                else a = c1;
            }
            const double g_lsq = 0.5 * (a + b);

            const auto camera = guo21_cornell::camera(width);
            const std::vector<char> mask = guo21_cornell::cloud_mask(camera, width);
            gl::RenderOptions opt;
            opt.spp = spp;
            opt.threads = ex.threads();
            opt.seed = ex.seed();
            opt.vpt.max_depth = 256;
            const int batches = 8;
            const double margin = 1.5 * r_um * 1e-6;
            auto render = [&](const auto& phase, const std::string& label) {
                using P = std::decay_t<decltype(phase)>;
                using CMed = gl::ForcedCollisionMedium<P>;
                gl::Scene<CMed> sc;
                guo21_cornell::build_cornell(sc, sc.add_medium(CMed(float(sigma_t), float(albedo), phase)), margin);
                return guo21_cornell::render_batches(ex, batches, opt, mask, label, width, [&](const gl::RenderOptions& o, auto&& prog) {
                    return gl::render_vpt(sc, camera, o, prog);
                });
            };
            std::printf("Guo21 Fig. 13 (Sec. 6.2): %llu ice spheres r = %.0f um in the Fig. 12 Cornell box (continuous medium "
                        "sigma_t = %.4g / m, albedo %.4f), %dx%d, %d spp\n",
                        (unsigned long long)count, r_um, sigma_t, albedo, width, width, spp);
            std::printf("  g: tabulated %.4f, HG same g %.4f, HG least-squares (ln p) %.4f\n", g_tab, g_tab, g_lsq);
            const auto r_tab = render(phase_tab, "tabulated");
            const auto r_hg = render(gl::HenyeyGreenstein<float, S>(float(g_tab)), "HG same g");
            const auto r_lsq = render(gl::HenyeyGreenstein<float, S>(float(g_lsq)), "HG lsq");
            const double m_tab = guo21_cornell::masked_mean(r_tab.img, mask), m_hg = guo21_cornell::masked_mean(r_hg.img, mask),
                         m_lsq = guo21_cornell::masked_mean(r_lsq.img, mask);
            auto structure = [&](const guo21_cornell::Run& r) {
                const double raw = masked_rel_rmse(r.img, r_tab.img, mask, m_tab);
                return std::sqrt(std::max(0.0, raw * raw - rel_noise2(r, m_tab) - rel_noise2(r_tab, m_tab)));
            };
            const double px_hg = structure(r_hg), px_lsq = structure(r_lsq);
            // Low-frequency difference over 8x8-pixel blocks: the pixel noise averages down by 8 (noise
            // of a block mean ~ pixel noise / 8, removed in quadrature as above).
            const int bsz = 8;
            auto block_structure = [&](const guo21_cornell::Run& r) {
                const double raw = block_rel_rmse(r.img, r_tab.img, mask, width, bsz, m_tab);
                const double n2 = (rel_noise2(r, m_tab) + rel_noise2(r_tab, m_tab)) / double(bsz * bsz);
                return std::sqrt(std::max(0.0, raw * raw - n2));
            };
            const double blk_hg = block_structure(r_hg), blk_lsq = block_structure(r_lsq);
            const double blk_noise = std::sqrt((rel_noise2(r_tab, m_tab) + rel_noise2(r_hg, m_tab)) / double(bsz * bsz));
            const double noise = std::sqrt(rel_noise2(r_tab, m_tab) + rel_noise2(r_hg, m_tab));
            const double se_hg = std::hypot(r_hg.mean_se, r_tab.mean_se) / m_tab, se_lsq = std::hypot(r_lsq.mean_se, r_tab.mean_se) / m_tab;

            std::printf("  %-24s %8s %12s %10s %12s %12s %12s\n", "render", "g", "mean", "vs tab.", "+- (1 se)", "pixel diff",
                        "8x8 diff");
            std::printf("  %-24s %8.4f %12.6g %10s %12s %12s %12s\n", "tabulated (ours)", g_tab, m_tab, "", "", "", "");
            std::printf("  %-24s %8.4f %12.6g %+10.4f %12.4f %12.4f %12.4f\n", "HG, same g", g_tab, m_hg, m_hg / m_tab - 1, se_hg, px_hg,
                        blk_hg);
            std::printf("  %-24s %8.4f %12.6g %+10.4f %12.4f %12.4f %12.4f\n", "HG, least squares ln p", g_lsq, m_lsq, m_lsq / m_tab - 1,
                        se_lsq, px_lsq, blk_lsq);
            std::printf("  (pixel diff: RMS over the cloud's pixels of HG - tabulated over the tabulated mean, both renders' noise "
                        "removed; the noise itself is %.4f per pixel, %.4f per 8x8 block)\n",
                        noise, blk_noise);
            std::printf("  paper: the best-fit HG renders slightly differently (closeups, no numbers)\n");

            gl_examples::Csv pc({"theta_deg", "phase_tabulated", "phase_hg_same_g", "phase_hg_lsq"});
            for (std::size_t i = 0; i < th.size(); ++i)
                pc.row({th[i] * 180 / gl::pi_v<double>, p_tab[i], hg(std::cos(th[i]), g_tab), hg(std::cos(th[i]), g_lsq)});
            if (!ex.root()) return ex.finish({});  // only rank 0 writes
            const auto phase_csv = ex.csv("guo21_fig13_phase.csv", pc);
            ex.plot("guo21_fig13_hg_fit", phase_csv, out / "guo21_fig13_hg_fit.png");
            const double ev = std::log2(0.18 / std::max(m_tab, 1e-12));
            gl::write_exr(out / "tabulated.exr", r_tab.img);
            gl::write_png(out / "tabulated.png", r_tab.img, {ev});
            gl::write_exr(out / "hg_same_g.exr", r_hg.img);
            gl::write_png(out / "hg_same_g.png", r_hg.img, {ev});
            gl::write_exr(out / "hg_lsq.exr", r_lsq.img);
            gl::write_png(out / "hg_lsq.png", r_lsq.img, {ev});
            gl::Image d = r_tab.img;
            for (std::size_t i = 0; i < d.rgb.size(); ++i) d.rgb[i] = std::abs(r_hg.img.rgb[i] - r_tab.img.rgb[i]);
            gl::write_png(out / "diff_hg_same_g.png", d, {ev + 3});
            // Phase values at a few angles (forward peak, 10, 90, 138 = the primary rainbow, 180 deg).
            std::vector<double> angles = {0, 10, 90, 138, 180}, v_tab, v_hg;
            for (double a_deg : angles) {
                const double mu = std::cos(a_deg * gl::pi_v<double> / 180);
                const gl::Vec3f win(0, 0, 1), wout(float(std::sqrt(std::max(0.0, 1 - mu * mu))), 0, float(mu));
                v_tab.push_back(double(phase_tab.eval(win, wout).value[0]));
                v_hg.push_back(hg(mu, g_tab));
            }
            auto j = ex.summary();
            j.integer("width", width)
                .integer("spp", spp)
                .integer("count", (long long)count)
                .num("radius_um", r_um)
                .num("sigma_t", sigma_t)
                .num("albedo", albedo)
                .num("g_tabulated", g_tab)
                .num("g_hg_lsq", g_lsq)
                .num("g_tabulated_phase_object", double(phase_tab.mean_cosine()[0]))
                .nums("phase_angles_deg", angles)
                .nums("phase_tabulated_at", v_tab)
                .nums("phase_hg_same_g_at", v_hg)
                .num("mean_tabulated", m_tab)
                .num("mean_hg_same_g", m_hg)
                .num("mean_hg_lsq", m_lsq)
                .num("rel_diff_hg_same_g", m_hg / m_tab - 1)
                .num("rel_diff_hg_lsq", m_lsq / m_tab - 1)
                .num("rel_diff_hg_same_g_se", se_hg)
                .num("rel_diff_hg_lsq_se", se_lsq)
                .num("pixel_diff_hg_same_g", px_hg)
                .num("pixel_diff_hg_lsq", px_lsq)
                .num("pixel_noise", noise)
                .num("block8_diff_hg_same_g", blk_hg)
                .num("block8_diff_hg_lsq", blk_lsq)
                .num("block8_noise", blk_noise)
                .num("forward_peak_ratio_tab_over_hg", v_tab[0] / v_hg[0])
                .num("rainbow_138_ratio_tab_over_hg", v_tab[3] / v_hg[3])
                .num("cpu_seconds_tabulated", r_tab.cpu_seconds)
                .num("cpu_seconds_hg", r_hg.cpu_seconds)
                .str("cpu_seconds_note", "process CPU seconds of the renders, summed over the ranks");
            guo21_mpi::rank_rows(j, ex, width);
            gl_examples::Example::nonfinite(j, r_tab.nonfinite + r_hg.nonfinite + r_lsq.nonfinite);
            return ex.finish(j);
        });
}
