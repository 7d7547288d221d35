// guo21_fig19_psd: Guo21 Fig. 19 / Sec. 6.7, the impact of the global PSD. Ice particles
// (eta = 1.31, lambda = 0.55 um), radii truncated to [1, 2000] um, uniformly in a 1 m cube (the
// paper's HOUSE is a mesh scene we do not have: the fig18 cube stands in), under a large quad light
// above it (outside the view), black background. Three sweeps, as the figure's rows:
//   row 1: log-normal r_g = 50, 100, 200, 400 um at sigma_g = 2;
//   row 2: sigma_g = 1.2, 2, 4 at r_g = 100 um;
//   row 3: bimodal, 99.5 % small particles (r_g1 = 100 or 200 um, sigma_g1 = 1.2) and 0.5 % large
//          (r_g2 = 1000 um, sigma_g2 = 1.2): the paper's 1.99e7 + 1e5 (its sigma_g1 = 1 is a
//          degenerate log-normal; our log-normal needs sigma_g > 1, so 1.2).
// N = 1e6 per PSD at quick, the paper's 4e6 (rows 1-2) and 2e7 (row 3) at full. Each PSD is
// rendered as a discrete medium beside its continuous pair (the same particles' sum C_t / V,
// albedo and ensemble phase function, Eq. 17 over the realized particles); default -FD (ray
// optics) with r_c from Eq. 23 at k = 0.25 (r_c = k/2 x the pixel footprint at the cube, so the
// graininess is that of a pixel-sized fat ray; the membership factor is printed).
//
//   guo21_fig19_psd [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                   [--width W] [--count N] [--k K] [--diffraction on|off] [--checkpoint SECONDS] [--resume]
//
// Every render is split by rows over MPI ranks (mpirun -np K: byte-identical EXRs) and resumable
// (--checkpoint / --resume: one checkpoint per render in --out).
//
// Paper: scattering grows with r_g (sigma_s grows with the radius); a larger sigma_g gives
// stronger graininess; the bimodal cloud shows haze from the small and grains from the large
// particles (pictures, no numbers). Last stdout line: JSON with the lists psd, sigma_t,
// mean_discrete, mean_continuous, rel_diff, graininess (per-pixel RMS of discrete - continuous over
// the continuous mean, with both renders' Monte Carlo noise, from two seeded halves each, removed
// in quadrature), g (of the rendered particles' ensemble phase) and g_bulk (the PSD's bulk g
// with diffraction, optics/bulk.hpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "guo21_cube_scene.hpp"
#include "guo21_mpi_render.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/optics/bulk.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

namespace {

using guo21_cube::build_scene;
using guo21_cube::kSide;
using guo21_cube::rel_rmse;

struct PsdCase {
    std::string name, row;
    gl::CloudSpecies species;
    std::function<gl::BulkOptics(const gl::ParticleModel&, const std::vector<double>&)> bulk;
    double count_factor;  // N relative to --count (full: the bimodal row has 5x the particles)
};

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_fig19_psd", "Guo21 Fig. 19: the look of a discrete medium changes with the PSD",
        "out/guo21_fig19_psd", [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 16, 32, "samples per pixel (two seeded halves; the continuous pairs: 4x)");
            const int width = ex.opt<int>("width", 64, 512, "image width (height = 3/4 width)");
            const auto count = ex.opt<std::uint64_t>("count", 1000000, 4000000, "particles per PSD (paper: 4e6; bimodal 5x at full)");
            const double k_q = ex.opt<double>("k", 0.25, "query-cylinder scale k of Eq. 23 (r_c = k/2 x the pixel footprint at the cube)");
            const bool diffraction =
                ex.opt<bool>("diffraction", false, "off: Guo21's -FD (ray optics, C_t = pi r^2); on: with Fraunhofer diffraction");
            ex.checkpointable();
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 1 || spp > 65536) throw gl_examples::cli_error("--spp must be in [1, 65536]");
            if (!(count >= 1000 && count < 800000000ull)) throw gl_examples::cli_error("--count must be in [1000, 8e8)");
            if (!(k_q > 0 && k_q <= 10)) throw gl_examples::cli_error("--k must be in (0, 10]");
            const bool full = ex.full();
            const auto& out = ex.out();
            const int height = width * 3 / 4;
            const double r_min = 1, r_max = 2000, lambda = 0.55;
            gl::ParticleModel model;
            model.particle_index = {1.31, 0.0};
            const std::vector<double> wl = {lambda};

            std::vector<PsdCase> cases;
            auto lognormal = [&](const std::string& name, const std::string& row, double rg, double sg) {
                const gl::LogNormalPsd psd(rg, sg, r_min, r_max);
                cases.push_back({name, row, gl::cloud_species(psd),
                                 [psd](const gl::ParticleModel& m, const std::vector<double>& w) { return gl::compute_bulk_optics(psd, m, w); },
                                 1.0});
            };
            for (double rg : {50.0, 100.0, 200.0, 400.0}) lognormal("rg" + std::to_string(int(rg)) + "_sg2", "r_g", rg, 2.0);
            lognormal("rg100_sg1.2", "sigma_g", 100, 1.2);
            lognormal("rg100_sg4", "sigma_g", 100, 4.0);  // sigma_g = 2 is row 1's rg100_sg2
            for (double rg1 : {100.0, 200.0}) {
                const gl::BimodalLogNormalPsd psd(rg1, 1.2, 1000.0, 1.2, 0.995, r_min, r_max);
                cases.push_back({"bimodal_rg1_" + std::to_string(int(rg1)), "bimodal", gl::cloud_species(psd),
                                 [psd](const gl::ParticleModel& m, const std::vector<double>& w) { return gl::compute_bulk_optics(psd, m, w); },
                                 full ? 5.0 : 1.0});
            }

            const gl::PinholeCamera<float> camera = guo21_cube::camera(width, height);
            // Eq. 23 (read as a length): r_c = k/2 x the pixel footprint at the cube's front (z_med = 2.4 m).
            const double z_med = guo21_cube::kZMed;
            const double r_c = gl::query_radius_eq23(k_q, double(camera.spread_angle()), 1.0, z_med);
            const double r_c_um = r_c * 1e6;
            gl::RenderOptions opt;
            opt.spp = std::max(1, spp / 2);
            opt.threads = ex.threads();
            opt.seed = ex.seed();
            opt.vpt.max_depth = 256;

            std::printf("Guo21 Fig. 19 (Sec. 6.7): ice eta = 1.31, radii in [%.0f, %.0f] um, %.0f m cube, lambda = %.2f um, "
                        "r_c = %.0f um, %s\n",
                        r_min, r_max, kSide, lambda, r_c_um, diffraction ? "with diffraction" : "-FD (ray optics, C_t = pi r^2)");
            std::printf("  %-18s %9s %9s %8s %8s %13s %13s %9s %9s %9s %9s %8s %8s %7s\n", "PSD", "N", "sigma_t", "albedo", "m.factor",
                        "mean_discrete", "mean_contin.", "rel_diff", "rd_memb.", "grainy", "d.noise", "g", "g_bulk", "sec");
            gl_examples::Csv csv({"case", "N", "sigma_t_per_m", "albedo", "membership_factor", "mean_discrete",
                                  "mean_continuous", "rel_diff", "mean_continuous_membership", "rel_diff_membership", "graininess", "rel_rmse", "discrete_noise", "continuous_noise", "g", "g_bulk_with_diffraction",
                                  "seconds_discrete", "bytes_per_particle"});
            std::vector<std::string> names;
            std::vector<double> v_mcf, v_rdf, v_noise_d, v_rmse, v_n, v_sig, v_alb, v_fac, v_md, v_mc, v_rd, v_gr, v_noise, v_g, v_gb, v_sec, v_bpp;
            for (std::size_t c = 0; c < cases.size(); ++c) {
                const PsdCase& pc = cases[c];
                const auto N = std::uint64_t(double(count) * pc.count_factor);
                const auto t0 = std::chrono::steady_clock::now();
                auto cloud = std::make_shared<gl::ParticleCloud>(
                    gl::ParticleCloud::generate(guo21_cube::cube_boundary(), N,
                                                {pc.species}, ex.seed() * 7919 + 19 + c, 1e6));
                const double r_max_cloud = guo21_cube::max_radius_um(*cloud);
                const gl::ParticleGridSettings gs = guo21_cube::grid_settings(N, r_c, r_max_cloud * 1e-6);
                auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
                gl::DiscreteMediumSettings ms;
                ms.query_radius = r_c;
                ms.wavelength_um = lambda;
                ms.diffraction = diffraction;
                using DMed = gl::DiscreteParticleMedium<float>;
                gl::Scene<DMed> dsc;
                build_scene(dsc, dsc.add_medium(DMed(grid, {model}, ms)));
                const DMed& dm = dsc.medium(0);
                const double bytes_pp = double(dm.memory_bytes()) / double(N);
                // Two seeded halves of the spp on the same particles: their difference is the render's own
                // Monte Carlo noise, which the graininess estimate removes.
                auto bar_d = ex.progress("discrete " + pc.name, std::uint64_t(2 * height));
                // Every render: this rank's rows, its checkpoint, gathered on every rank (guo21_mpi_render.hpp).
                auto dvpt = [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_discrete_vpt(dsc, camera, o, prog); };
                auto prog_d = [&](int n) { bar_d.advance(std::uint64_t(n)); };
                const gl::Image d1 = guo21_mpi::render_image(ex, opt, "discrete_" + pc.name + ".a", dvpt, prog_d);
                gl::RenderOptions od2 = opt;
                od2.seed = opt.seed + 2000003;
                const gl::Image d2 = guo21_mpi::render_image(ex, od2, "discrete_" + pc.name + ".b", dvpt, prog_d);
                bar_d.done();
                gl::Image di = d1;
                for (std::size_t i = 0; i < di.rgb.size(); ++i) di.rgb[i] = 0.5f * (d1.rgb[i] + d2.rgb[i]);
                const double sec_d = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

                // Continuous pair: the same particles (sum C_t / V, albedo, Eq. 17 over the realized
                // particles with the medium's per-bin optics), two seeds at 4x spp (its own noise).
                const guo21_cube::ContinuousPair cp =
                    guo21_cube::continuous_pair(dm, *cloud, model, r_c, lambda, diffraction, r_max_cloud, ms.theta_nodes_tail);
                const double factor = cp.factor;
                const auto& phase = cp.phase;
                const auto& phase_f = cp.phase_factor;
                const double g = double(phase.mean_cosine()[0]);
                const double sigma_t = dm.global_sigma_t(), albedo = dm.global_sigma_s() / sigma_t;
                using CMed = gl::ForcedCollisionMedium<gl::MiePhase<float, S>>;
                gl::Scene<CMed> csc;
                build_scene(csc, csc.add_medium(CMed(float(sigma_t), float(albedo), phase)));
                auto bar_c = ex.progress("continuous " + pc.name, std::uint64_t(2 * height));
                gl::RenderOptions o1 = opt;
                o1.spp = 4 * opt.spp;
                auto cvpt = [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_vpt(csc, camera, o, prog); };
                auto prog_c = [&](int n) { bar_c.advance(std::uint64_t(n)); };
                const gl::Image c1 = guo21_mpi::render_image(ex, o1, "continuous_" + pc.name + ".a", cvpt, prog_c);
                gl::RenderOptions o2 = o1;
                o2.seed = opt.seed + 1000003;
                const gl::Image c2 = guo21_mpi::render_image(ex, o2, "continuous_" + pc.name + ".b", cvpt, prog_c);
                bar_c.done();
                // The membership rule's prediction: the Poisson average of T_A is Beer-Lambert with each
                // particle's extinction scaled by membership_extinction_factor (scattering alike, albedo
                // unchanged), so a continuous medium with those scaled coefficients is the placement
                // average of the discrete render.
                gl::Scene<CMed> fsc;
                build_scene(fsc, fsc.add_medium(CMed(float(sigma_t * factor), float(albedo), phase_f)));
                const gl::Image cf = guo21_mpi::render_image(
                    ex, o1, "membership_" + pc.name,
                    [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_vpt(fsc, camera, o, prog); }, [](int) {});
                gl::Image ci = c1;
                for (std::size_t i = 0; i < ci.rgb.size(); ++i) ci.rgb[i] = 0.5f * (c1.rgb[i] + c2.rgb[i]);
                const double g_bulk = pc.bulk(model, wl).channels[0].g;

                const double md = di.mean(0), mc = ci.mean(0), mcf = cf.mean(0);
                v_mcf.push_back(mcf);
                v_rdf.push_back(md / mcf - 1);
                const double rmse = rel_rmse(di, ci, mc), noise = 0.5 * rel_rmse(c2, c1, mc);
                const double noise_d = 0.5 * rel_rmse(d2, d1, mc);
                // Graininess: the per-pixel RMS of discrete - continuous with both renders' Monte Carlo
                // noise removed in quadrature (E|a - b|^2 = structure^2 + noise_a^2 + noise_b^2).
                const double grain = std::sqrt(std::max(0.0, rmse * rmse - noise * noise - noise_d * noise_d));
                names.push_back(pc.name);
                v_n.push_back(double(N));
                v_sig.push_back(sigma_t);
                v_alb.push_back(albedo);
                v_fac.push_back(factor);
                v_md.push_back(md);
                v_mc.push_back(mc);
                v_rd.push_back(md / mc - 1);
                v_gr.push_back(grain);
                v_noise.push_back(noise);
                v_noise_d.push_back(noise_d);
                v_rmse.push_back(rmse);
                v_g.push_back(g);
                v_gb.push_back(g_bulk);
                v_sec.push_back(sec_d);
                v_bpp.push_back(bytes_pp);
                std::printf("  %-18s %9.3g %9.4g %8.4f %8.4f %13.6g %13.6g %+9.4f %+9.4f %9.4f %9.4f %8.4f %8.4f %7.1f\n", pc.name.c_str(),
                            double(N), sigma_t, albedo, factor, md, mc, md / mc - 1, md / mcf - 1, grain, noise_d, g, g_bulk, sec_d);
                {
                    std::vector<std::string> cells = {pc.name};
                    for (double v : {double(N), sigma_t, albedo, factor, md, mc, md / mc - 1, mcf, md / mcf - 1, grain, rmse, noise_d, noise, g, g_bulk, sec_d, bytes_pp}) {
                        char buf[32];
                        std::snprintf(buf, sizeof buf, "%.9g", v);
                        cells.push_back(buf);
                    }
                    csv.row_text(cells);
                }
                // Each image exposed for its own continuous mean (the look, not the brightness, is compared).
                const double ev_c = std::log2(0.18 / std::max(mc, 1e-12));
                if (!ex.root()) continue;  // only rank 0 writes
                gl::write_exr(out / ("discrete_" + pc.name + ".exr"), di);
                gl::write_png(out / ("discrete_" + pc.name + ".png"), di, {ev_c});
                gl::write_exr(out / ("continuous_" + pc.name + ".exr"), ci);
                gl::write_png(out / ("continuous_" + pc.name + ".png"), ci, {ev_c});
            }
            if (!ex.root()) return ex.finish({});
            const auto csv_path = ex.csv("guo21_fig19_psd.csv", csv);
            ex.plot("guo21_fig19_psd", csv_path, out / "guo21_fig19_psd.png");

            // Row 1: scattering (mean radiance) grows with r_g; row 2: graininess grows with sigma_g.
            const bool mean_grows_rg = v_md[0] < v_md[1] && v_md[1] < v_md[2] && v_md[2] < v_md[3];
            const bool grain_grows_sg = v_gr[4] < v_gr[1] && v_gr[1] < v_gr[5];
            double max_abs_rd = 0, max_g_dev = 0, max_abs_rdf = 0;
            for (double d : v_rdf) max_abs_rdf = std::max(max_abs_rdf, std::abs(d));
            for (std::size_t i = 0; i < v_g.size(); ++i) max_g_dev = std::max(max_g_dev, std::abs(v_g[i] - (2 * v_gb[i] - 1)));
            for (double d : v_rd) max_abs_rd = std::max(max_abs_rd, std::abs(d));
            std::printf("  paper: scattering grows with r_g (ours: %s), graininess grows with sigma_g (ours: %s; 1.2 / 2 / 4: "
                        "%.3f / %.3f / %.3f), bimodal = haze + grains (pictures, no numbers); max |discrete / continuous - 1| = "
                        "%.3f (the membership rule's factor; vs the factor-scaled continuous medium: %.3f); -FD g vs 2 g_bulk - 1: max deviation %.4f\n",
                        mean_grows_rg ? "yes" : "no", grain_grows_sg ? "yes" : "no", v_gr[4], v_gr[1], v_gr[5], max_abs_rd, max_abs_rdf, max_g_dev);
            gl_examples::Json j = ex.summary();
            j.integer("width", width)
                .integer("height", height)
                .integer("spp", spp)
                .num("query_radius_um", r_c_um)
                .integer("diffraction", diffraction ? 1 : 0)
                .raw("psd", [&] {
                    std::string a = "[";
                    for (std::size_t i = 0; i < names.size(); ++i) a += (i ? "," : "") + gl_examples::Json::quote(names[i]);
                    return a + "]";
                }())
                .nums("N", v_n)
                .nums("sigma_t", v_sig)
                .nums("albedo", v_alb)
                .nums("membership_factor", v_fac)
                .nums("mean_discrete", v_md)
                .nums("mean_continuous", v_mc)
                .nums("rel_diff", v_rd)
                .nums("mean_continuous_membership", v_mcf)
                .nums("rel_diff_membership", v_rdf)
                .nums("graininess", v_gr)
                .nums("rel_rmse", v_rmse)
                .nums("discrete_noise", v_noise_d)
                .nums("continuous_noise", v_noise)
                .nums("g", v_g)
                .nums("g_bulk", v_gb)
                .nums("g_no_diffraction_predicted", [&] {
                    std::vector<double> v;  // large particles: Q_ext = 2, half of it a forward lobe with g = 1
                    for (double gb : v_gb) v.push_back(2 * gb - 1);
                    return v;
                }())
                .num("k", k_q)
                .nums("seconds_discrete", v_sec)
                .nums("bytes_per_particle", v_bpp)
                .integer("mean_grows_with_rg", mean_grows_rg ? 1 : 0)
                .integer("graininess_grows_with_sigma_g", grain_grows_sg ? 1 : 0)
                .num("max_abs_rel_diff", max_abs_rd)
                .num("max_abs_rel_diff_membership", max_abs_rdf)
                .num("max_abs_g_minus_no_diffraction_prediction", max_g_dev)
                .str("csv", csv_path.string());
            guo21_mpi::rank_rows(j, ex, height);
            return ex.finish(j);
        });
}
