// guo21_fig5_mie_vs_goa: Guo21 Fig. 5 / Sec. 3.3. A smooth (continuous) medium of monodisperse
// particles, eta = 1.33, r = 1 and 2 um (lambda = 0.55 um), rendered twice with the same
// extinction coefficient (the paper's constant 0.6, here 0.6 / m in the 1 m cube of
// guo21_cube_scene.hpp: optical depth 0.6 across it; albedo 1) and two phase functions: exact
// Lorenz-Mie (optics/lorenz_mie.hpp) and GOA (optics/goa.hpp, Eqs. 4-11, diffraction included),
// both as the tabulated ensemble phase of optics/bulk.hpp on one angle grid. The paper's scene (a
// mesh under an environment light) is not available: the cube under a quad light stands in.
//
//   guo21_fig5_mie_vs_goa [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                         [--spp N] [--width W] [--radii 1,2] [--sigma-t S] [--checkpoint SECONDS] [--resume]
//
// Every render is split by rows over MPI ranks (mpirun -np K: byte-identical EXRs) and resumable
// (--checkpoint / --resume: one checkpoint per half-render in --out).
//
// Paper: at r = 1 um the Mie and GOA phases give visibly different images; at 2 um the difference
// "almost disappears" (pictures). Printed and in the JSON for each radius: g of both phases, the
// total-variation distance of the phases (1/2 int |p_Mie - p_GOA| dw), the mean radiance of both
// images, their relative difference, and the per-pixel difference (RMS over the Mie image's mean)
// with both renders' Monte Carlo noise (from two seeded halves each) removed in quadrature.
// Outputs: mie_r*.{exr,png}, goa_r*.{exr,png}, diff_r*.png, guo21_fig5_phase.csv (the phase
// curves), guo21_fig5_mie_vs_goa.csv (the image statistics), guo21_fig5_mie_vs_goa.png (plot).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/optics/bulk.hpp"
#include "grainlight/scene/image_io.hpp"
#include "guo21_cube_scene.hpp"
#include "guo21_mpi_render.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

namespace {

/// Render a homogeneous forced-collision medium in the cube twice (seeds s and s + 1000003):
/// returns both halves.
std::pair<gl::Image, gl::Image> render_pair(gl_examples::Example& ex, const gl::RenderOptions& opt, double sigma_t,
                                            const gl::MiePhase<float, S>& phase, const gl::PinholeCamera<float>& camera,
                                            const std::string& label, int height) {
    using CMed = gl::ForcedCollisionMedium<gl::MiePhase<float, S>>;
    gl::Scene<CMed> sc;
    guo21_cube::build_scene(sc, sc.add_medium(CMed(float(sigma_t), 1.0f, phase)));
    auto bar = ex.progress(label, std::uint64_t(2 * height));
    // Split by rows over the MPI ranks, gathered on every rank; one checkpoint per half.
    auto vpt = [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_vpt(sc, camera, o, prog); };
    auto prog = [&](int n) { bar.advance(std::uint64_t(n)); };
    const gl::Image a = guo21_mpi::render_image(ex, opt, label + ".a", vpt, prog);
    gl::RenderOptions o2 = opt;
    o2.seed = opt.seed + 1000003;
    const gl::Image b = guo21_mpi::render_image(ex, o2, label + ".b", vpt, prog);
    bar.done();
    return {a, b};
}

using guo21_cube::average;

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_fig5_mie_vs_goa", "Guo21 Fig. 5: a smooth medium rendered with Mie and with GOA phase functions",
        "out/guo21_fig5_mie_vs_goa", [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 1024, 4096, "samples per pixel (two seeded halves)");
            const int width = ex.opt<int>("width", 96, 512, "image width (height = 3/4 width)");
            const std::vector<double> radii = ex.opt<std::vector<double>>("radii", {1.0, 2.0}, "particle radii [um]");
            const double sigma_t = ex.opt<double>("sigma-t", 0.6, "extinction coefficient [1/m] (paper: 0.6)");
            ex.checkpointable();
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 2 || spp > 65536) throw gl_examples::cli_error("--spp must be in [2, 65536]");
            if (radii.empty()) throw gl_examples::cli_error("--radii needs at least one value");
            for (double r : radii)
                if (!(r >= 0.1 && r <= 100)) throw gl_examples::cli_error("--radii values must be in [0.1, 100] um");
            if (!(sigma_t > 0 && sigma_t <= 100)) throw gl_examples::cli_error("--sigma-t must be in (0, 100] per m");
            const auto& out = ex.out();
            const int height = width * 3 / 4;
            const double lambda = 0.55, eta = 1.33;
            const std::vector<double> wl = {lambda};
            const auto camera = guo21_cube::camera(width, height);
            gl::RenderOptions opt;
            opt.spp = spp / 2;
            opt.threads = ex.threads();
            opt.seed = ex.seed();
            opt.vpt.max_depth = 256;

            std::printf("Guo21 Fig. 5 (Sec. 3.3): smooth medium, eta = %.2f, lambda = %.2f um, sigma_t = %.2f / m in a %.0f m cube, "
                        "albedo 1, %dx%d, %d spp per image\n",
                        eta, lambda, sigma_t, guo21_cube::kSide, width, height, spp);
            std::printf("  %6s %8s %8s %10s %13s %13s %9s %10s %10s\n", "r[um]", "g_Mie", "g_GOA", "TV(phase)", "mean_Mie",
                        "mean_GOA", "rel_diff", "pixel_diff", "noise");
            std::vector<double> v_r, v_gm, v_gg, v_tv, v_mm, v_mg, v_rd, v_px, v_noise, v_int_m, v_int_g;
            std::vector<std::vector<double>> curves;  // theta_deg, then p_Mie, p_GOA per radius, on one grid
            const double x_max = 2 * gl::pi_v<double> * *std::max_element(radii.begin(), radii.end()) / lambda;
            gl::BulkSettings bs;
            bs.theta = gl::forward_peaked_theta_grid(x_max);
            curves.push_back({});
            for (double t : bs.theta) curves[0].push_back(t * 180 / gl::pi_v<double>);
            gl_examples::Csv csv({"r_um", "g_mie", "g_goa", "tv_distance", "phase_integral_mie", "phase_integral_goa", "mean_mie",
                                  "mean_goa", "rel_diff", "pixel_diff", "noise"});
            for (double r : radii) {
                gl::ParticleModel mie, goa;
                mie.particle_index = goa.particle_index = {eta, 0.0};
                mie.method = gl::ScatteringMethod::mie;
                goa.method = gl::ScatteringMethod::goa;
                const auto bm = gl::compute_bulk_optics(gl::MonodispersePsd(r, 1.0), mie, wl, bs);
                const auto bg = gl::compute_bulk_optics(gl::MonodispersePsd(r, 1.0), goa, wl, bs);
                const auto& cm = bm.channels[0];
                const auto& cg = bg.channels[0];
                // Phases normalized to 1 over the sphere (GOA's C_s of Eq. 2 is not the integral of its
                // intensities; the renders' MiePhase normalizes the same way).
                std::vector<double> fm(cm.phase), fg(cg.phase);
                for (auto& v : fm) v /= cm.phase_integral;
                for (auto& v : fg) v /= cg.phase_integral;
                // Total-variation distance of the phases (trapezoid in theta, dw = 2 pi sin theta dtheta).
                double tv = 0;
                for (std::size_t i = 0; i + 1 < bs.theta.size(); ++i) {
                    const double t0 = bs.theta[i], t1 = bs.theta[i + 1];
                    const double f0 = std::abs(fm[i] - fg[i]) * std::sin(t0);
                    const double f1 = std::abs(fm[i + 1] - fg[i + 1]) * std::sin(t1);
                    tv += 0.5 * (f0 + f1) * (t1 - t0);
                }
                tv *= gl::pi_v<double>;  // 1/2 * 2 pi
                curves.push_back(fm);
                curves.push_back(fg);
                const auto pm = bm.template make_phase<float, S>();
                const auto pg = bg.template make_phase<float, S>();
                char tag[32];
                std::snprintf(tag, sizeof tag, "r%g", r);
                const auto [m1, m2] = render_pair(ex, opt, sigma_t, pm, camera, std::string("Mie ") + tag, height);
                const auto [g1, g2] = render_pair(ex, opt, sigma_t, pg, camera, std::string("GOA ") + tag, height);
                const gl::Image mi = average(m1, m2), gi = average(g1, g2);
                const double mm = mi.mean(0), mg = gi.mean(0);
                // Per-pixel difference with both renders' noise removed: E|a - b|^2 = D^2 + n_a^2 + n_b^2,
                // the noise of an average of two halves being |h1 - h2| / 2.
                const double raw = guo21_cube::rel_rmse(mi, gi, mm);
                const double nm = 0.5 * guo21_cube::rel_rmse(m1, m2, mm), ng = 0.5 * guo21_cube::rel_rmse(g1, g2, mm);
                const double px = std::sqrt(std::max(0.0, raw * raw - nm * nm - ng * ng));
                const double noise = std::hypot(nm, ng);
                v_r.push_back(r);
                v_gm.push_back(cm.g);
                v_gg.push_back(cg.g);
                v_tv.push_back(tv);
                v_int_m.push_back(cm.phase_integral);
                v_int_g.push_back(cg.phase_integral);
                v_mm.push_back(mm);
                v_mg.push_back(mg);
                v_rd.push_back(mg / mm - 1);
                v_px.push_back(px);
                v_noise.push_back(noise);
                std::printf("  %6g %8.4f %8.4f %10.4f %13.6g %13.6g %+9.4f %10.4f %10.4f\n", r, cm.g, cg.g, tv, mm, mg, mg / mm - 1, px,
                            noise);
                csv.row({r, cm.g, cg.g, tv, cm.phase_integral, cg.phase_integral, mm, mg, mg / mm - 1, px, noise});
                const double ev = std::log2(0.18 / std::max(mm, 1e-12));
                if (!ex.root()) continue;  // only rank 0 writes
                gl::write_exr(out / (std::string("mie_") + tag + ".exr"), mi);
                gl::write_png(out / (std::string("mie_") + tag + ".png"), mi, {ev});
                gl::write_exr(out / (std::string("goa_") + tag + ".exr"), gi);
                gl::write_png(out / (std::string("goa_") + tag + ".png"), gi, {ev});
                gl::Image d = mi;
                for (std::size_t i = 0; i < d.rgb.size(); ++i) d.rgb[i] = std::abs(mi.rgb[i] - gi.rgb[i]);
                gl::write_png(out / (std::string("diff_") + tag + ".png"), d, {ev + 2});
            }
            if (!ex.root()) return ex.finish({});
            {
                std::vector<std::string> cols = {"theta_deg"};
                for (double r : radii) {
                    char a[40], b[40];
                    std::snprintf(a, sizeof a, "phase_mie_r%g", r);
                    std::snprintf(b, sizeof b, "phase_goa_r%g", r);
                    cols.push_back(a);
                    cols.push_back(b);
                }
                gl_examples::Csv pc(cols);
                for (std::size_t i = 0; i < bs.theta.size(); ++i) {
                    std::vector<double> row;
                    for (const auto& c : curves) row.push_back(c[i]);
                    pc.row(row);
                }
                const auto phase_csv = ex.csv("guo21_fig5_phase.csv", pc);
                ex.plot("guo21_fig5_mie_vs_goa", phase_csv, out / "guo21_fig5_mie_vs_goa.png");
            }
            const auto csv_path = ex.csv("guo21_fig5_mie_vs_goa.csv", csv);
            const bool shrinks = v_tv.size() >= 2 && v_tv.back() < v_tv.front();
            const bool img_shrinks = v_px.size() >= 2 && v_px.back() < v_px.front();
            std::printf("  paper: r = 1 um, Mie and GOA images differ; r = 2 um, the difference almost disappears (pictures).\n"
                        "  ours: phase TV distance %s from r = %g to %g um (%.4f -> %.4f), per-pixel image difference %.4f -> %.4f "
                        "(noise removed; noise %.4f)\n",
                        shrinks ? "falls" : "does not fall", v_r.front(), v_r.back(), v_tv.front(), v_tv.back(), v_px.front(),
                        v_px.back(), v_noise.back());
            auto j = ex.summary();
            j.integer("width", width)
                .integer("height", height)
                .integer("spp", spp)
                .num("eta", eta)
                .num("sigma_t", sigma_t)
                .nums("radius_um", v_r)
                .nums("g_mie", v_gm)
                .nums("g_goa", v_gg)
                .nums("tv_distance", v_tv)
                .nums("phase_integral_mie", v_int_m)
                .nums("phase_integral_goa", v_int_g)
                .nums("mean_mie", v_mm)
                .nums("mean_goa", v_mg)
                .nums("rel_diff", v_rd)
                .nums("pixel_diff", v_px)
                .nums("noise", v_noise)
                .num("tv_first", v_tv.front())
                .num("tv_last", v_tv.back())
                .num("pixel_diff_first", v_px.front())
                .num("pixel_diff_last", v_px.back())
                .num("abs_rel_diff_first", std::abs(v_rd.front()))
                .num("abs_rel_diff_last", std::abs(v_rd.back()))
                .num("max_abs_phase_integral_mie_minus_1", [&] {
                    double m = 0;
                    for (double v : v_int_m) m = std::max(m, std::abs(v - 1));
                    return m;
                }())
                .integer("tv_shrinks", shrinks ? 1 : 0)
                .integer("pixel_diff_shrinks", img_shrinks ? 1 : 0)
                .str("csv", csv_path.string());
            guo21_mpi::rank_rows(j, ex, height);
            return ex.finish(j);
        });
}
