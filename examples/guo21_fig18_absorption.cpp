// guo21_fig18_absorption: Guo21 Fig. 18 / Sec. 6.6, absorbing particles. Particles of index
// eta = 1.5 + i eta_i (eta_r = 1.5 fixed, eta_i swept), log-normal PSD r_g = 800 um, sigma_g = 4
// (truncated to [1, 2000] um, Sec. 6's r_max), N = 3e5 (the paper's count, quick and full),
// uniformly in a 1 m cube (the paper's STAIRCASE is a mesh scene we do not have: the fig14 cube,
// scaled to 1 m so that the optical depth across it is ~2, stands in), lit by a large quad light
// above it (outside the view), black background. Each eta_i is rendered as a discrete medium
// (media/discrete_particles.hpp, integrators/discrete_vpt.hpp; GOA absorption of App. C, whose
// weak-absorption limit is Eq. 13) beside its continuous pair: a homogeneous medium with the same
// particles' global sigma_t = sum C_t / V, albedo sum C_s / sum C_t and the bulk phase function of
// the PSD (Eq. 17, optics/bulk.hpp).
//
//   guo21_fig18_absorption [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                          [--spp N] [--width W] [--count N] [--eta-i 0,1e-5,...] [--query-radius-um R]
//                          [--checkpoint SECONDS] [--resume]
//
// Every render is split by rows over MPI ranks (mpirun -np K: byte-identical EXRs) and resumable
// (--checkpoint / --resume: one checkpoint per render in --out).
//
// Paper: "an increase of eta_i will increasingly dim the intensity of scattering" (no numbers; the
// eta_i of the figure's panels are not in the text). Default -FD (ray optics, C_t = pi r^2): with
// r_c = 20 um << r_p the members are opaque and the membership rule's extinction factor is ~1.04
// (printed); with diffraction (--diffraction on) it is ~0.52 (an opaque member of a thin cylinder
// blocks its geometric area only; docs/guo21.md). Last stdout line: JSON with the lists eta_i,
// albedo (single-scattering albedo sum C_s / sum C_t of the rendered particles, Eq. 16 over the
// cloud), albedo_bulk_with_diffraction (the PSD's bulk albedo with diffraction, optics/bulk.hpp),
// mean_discrete, mean_continuous, rel_diff, C_a of a 1000 um particle by App. C vs Eq. 13, and the
// flags albedo_falls / mean_discrete_falls.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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
#include "grainlight/optics/goa.hpp"
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

std::string tag_of(double eta_i) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "eta_i_%.0e", eta_i);
    return buf;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_fig18_absorption", "Guo21 Fig. 18: absorbing particles (eta = 1.5 + i eta_i) dim the scattering",
        "out/guo21_fig18_absorption", [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 64, 256, "samples per pixel");
            const int width = ex.opt<int>("width", 128, 512, "image width (height = 3/4 width)");
            const auto count = ex.opt<std::uint64_t>("count", 300000, 300000, "particle count (paper: 3e5)");
            const std::vector<double> etas = ex.opt<std::vector<double>>(
                "eta-i", std::vector<double>{0, 1e-6, 1e-5, 1e-4, 1e-3}, std::vector<double>{0, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 1e-3},
                "imaginary parts eta_i of the particle index (ascending, each in [0, 0.1])");
            const double r_c_um = ex.opt<double>("query-radius-um", 20.0, "query-cylinder radius r_c [um]");
            const bool diffraction =
                ex.opt<bool>("diffraction", false, "off: Guo21's -FD (ray optics, C_t = pi r^2); on: with Fraunhofer diffraction");
            ex.checkpointable();
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 1 || spp > 65536) throw gl_examples::cli_error("--spp must be in [1, 65536]");
            if (!(count >= 1000 && count < 4000000000ull)) throw gl_examples::cli_error("--count must be in [1000, 4e9)");
            if (etas.empty()) throw gl_examples::cli_error("--eta-i needs at least one value");
            for (std::size_t i = 0; i < etas.size(); ++i) {
                if (!(etas[i] >= 0 && etas[i] <= 0.1)) throw gl_examples::cli_error("--eta-i values must be in [0, 0.1]");
                if (i > 0 && !(etas[i] > etas[i - 1])) throw gl_examples::cli_error("--eta-i values must be ascending");
            }
            if (!(r_c_um > 0 && r_c_um <= 1e4)) throw gl_examples::cli_error("--query-radius-um must be in (0, 1e4]");
            const bool full = ex.full();
            const auto& out = ex.out();
            const int height = width * 3 / 4;
            const double r_g = 800, sigma_g = 4, r_min = 1, r_max = 2000, lambda = 0.55, eta_r = 1.5;
            const double r_c = r_c_um * 1e-6, volume = kSide * kSide * kSide;
            const gl::LogNormalPsd psd(r_g, sigma_g, r_min, r_max);

            const gl::PinholeCamera<float> camera = guo21_cube::camera(width, height);
            gl::RenderOptions opt;
            opt.spp = spp;
            opt.threads = ex.threads();
            opt.seed = ex.seed();
            opt.vpt.max_depth = 256;

            // One cloud and grid for every eta_i (only the optics change).
            const auto tc0 = std::chrono::steady_clock::now();
            auto cloud = std::make_shared<gl::ParticleCloud>(
                gl::ParticleCloud::generate(guo21_cube::cube_boundary(), count,
                                            {gl::cloud_species(psd)}, ex.seed() * 7919 + 18, 1e6));
            // About one particle per voxel, voxels no smaller than the largest dilated sphere's diameter.
            const gl::ParticleGridSettings gs = guo21_cube::grid_settings(count, r_c, r_max * 1e-6);
            auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
            const double r_max_cloud = guo21_cube::max_radius_um(*cloud);
            const double build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tc0).count();

            std::printf("Guo21 Fig. 18 (Sec. 6.6): N = %llu particles, eta = %.1f + i eta_i, log-normal r_g = %.0f um, "
                        "sigma_g = %.0f in [%.0f, %.0f] um, %.0f m cube, lambda = %.2f um\n",
                        (unsigned long long)count, eta_r, r_g, sigma_g, r_min, r_max, kSide, lambda);
            std::printf("  query radius r_c = %.0f um, grid %d^3, cloud + grid built in %.2f s, %s\n", r_c_um, gs.resolution[0],
                        build_seconds, diffraction ? "with diffraction" : "-FD (ray optics, C_t = pi r^2)");

            std::vector<double> v_mcf, v_rdf, v_eta, v_alb, v_alb_p, v_md, v_mc, v_rd, v_sig, v_fac, v_ca1000, v_eq13, v_secd, v_secc;
            gl_examples::Csv csv({"eta_i", "albedo_bulk_with_diffraction", "albedo", "sigma_t_per_m", "sigma_t_bulk_with_diffraction_per_m",
                                  "membership_factor", "mean_discrete", "mean_continuous", "rel_diff", "mean_continuous_membership", "rel_diff_membership", "C_a_1000um_goa_um2",
                                  "C_a_1000um_eq13_um2", "seconds_discrete", "seconds_continuous"});
            std::printf("  %8s %8s %8s %9s %8s %13s %13s %9s %9s %12s %12s\n", "eta_i", "alb_bulk", "albedo", "sigma_t", "m.factor",
                        "mean_discrete", "mean_contin.", "rel_diff", "rd_memb.", "C_a(1mm)", "Eq.13");
            double ev = 0;
            for (std::size_t e = 0; e < etas.size(); ++e) {
                const double eta_i = etas[e];
                gl::ParticleModel model;
                model.particle_index = {eta_r, eta_i};
                // Bulk (continuous) optics of the PSD: albedo (Eq. 16) and the phase function (Eq. 17).
                const gl::BulkOptics bulk = gl::compute_bulk_optics(psd, model, std::vector<double>{lambda});
                const auto& ch = bulk.channels[0];
                const double albedo_bulk = ch.mean_C_s / ch.mean_C_t;
                const double sigma_t_bulk = ch.mean_C_t * 1e-12 * double(count) / volume;
                // C_a of one 1000 um particle: App. C ray optics (GOA) beside Eq. 13.
                const double x1000 = 2 * gl::pi_v<double> * 1000.0 / lambda;
                const gl::Goa goa1000(model.relative_index(), x1000, model.p_max);
                const double ca_goa = goa1000.qabs() * gl::pi_v<double> * 1e6;
                const double ca_eq13 = eta_i > 0 ? gl::goa_absorption_cross_section_eq13(1000.0, model.relative_index(), lambda) : 0.0;

                // Discrete medium.
                gl::DiscreteMediumSettings ms;
                ms.query_radius = r_c;
                ms.wavelength_um = lambda;
                ms.diffraction = diffraction;
                using DMed = gl::DiscreteParticleMedium<float>;
                const auto t0 = std::chrono::steady_clock::now();
                gl::Scene<DMed> dsc;
                build_scene(dsc, dsc.add_medium(DMed(grid, {model}, ms)));
                const DMed& dm = dsc.medium(0);
                auto bar_d = ex.progress("discrete " + tag_of(eta_i), std::uint64_t(height));
                // Every render: this rank's rows, its checkpoint, gathered on every rank (guo21_mpi_render.hpp).
                const gl::Image di = guo21_mpi::render_image(
                    ex, opt, "discrete_" + tag_of(eta_i),
                    [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_discrete_vpt(dsc, camera, o, prog); },
                    [&](int n) { bar_d.advance(std::uint64_t(n)); });
                bar_d.done();
                const double sec_d = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

                // Continuous pair: the same particles' global sigma_t = sum C_t / V and albedo, and their
                // ensemble phase function (Eq. 17 as a sum over the realized particles, with the medium's
                // per-bin optics: sum over bins of (sum of the bin's C_s) f_bin).
                // The membership rule's Poisson average (extinction-weighted factor) too (guo21_cube_scene.hpp).
                const auto t1 = std::chrono::steady_clock::now();
                const guo21_cube::ContinuousPair cp =
                    guo21_cube::continuous_pair(dm, *cloud, model, r_c, lambda, diffraction, r_max_cloud, ms.theta_nodes_tail);
                const double factor = cp.factor;
                const double sigma_t = cp.sigma_t, albedo_p = cp.albedo;
                using CMed = gl::ForcedCollisionMedium<gl::MiePhase<float, S>>;
                gl::Scene<CMed> csc;
                build_scene(csc, csc.add_medium(CMed(float(sigma_t), float(albedo_p), cp.phase)));
                auto bar_c = ex.progress("continuous " + tag_of(eta_i), std::uint64_t(height));
                const gl::Image ci = guo21_mpi::render_image(
                    ex, opt, "continuous_" + tag_of(eta_i),
                    [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_vpt(csc, camera, o, prog); },
                    [&](int n) { bar_c.advance(std::uint64_t(n)); });
                bar_c.done();
                const double sec_c = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();

                // The membership rule's Poisson average: each particle's C_t (and C_s) scaled by
                // membership_extinction_factor, albedo unchanged.
                gl::Scene<CMed> fsc;
                build_scene(fsc, fsc.add_medium(CMed(float(sigma_t * factor), float(albedo_p), cp.phase_factor)));
                const gl::Image cf = guo21_mpi::render_image(
                    ex, opt, "membership_" + tag_of(eta_i),
                    [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_vpt(fsc, camera, o, prog); }, [](int) {});
                const double md = di.mean(0), mc = ci.mean(0), mcf = cf.mean(0);
                v_mcf.push_back(mcf);
                v_rdf.push_back(md / mcf - 1);
                if (e == 0) ev = std::log2(0.18 / std::max(mc, 1e-12));  // one exposure for all: the dimming shows
                v_eta.push_back(eta_i);
                v_alb.push_back(albedo_bulk);
                v_alb_p.push_back(albedo_p);
                v_md.push_back(md);
                v_mc.push_back(mc);
                v_rd.push_back(md / mc - 1);
                v_sig.push_back(sigma_t);
                v_fac.push_back(factor);
                v_ca1000.push_back(ca_goa);
                v_eq13.push_back(ca_eq13);
                v_secd.push_back(sec_d);
                v_secc.push_back(sec_c);
                std::printf("  %8.1e %8.4f %8.4f %9.4g %8.4f %13.6g %13.6g %+9.4f %+9.4f %12.5g %12.5g\n", eta_i, albedo_bulk,
                            albedo_p, sigma_t, factor, md, mc, md / mc - 1, md / mcf - 1, ca_goa, ca_eq13);
                csv.row({eta_i, albedo_bulk, albedo_p, sigma_t, sigma_t_bulk, factor, md, mc, md / mc - 1, mcf, md / mcf - 1, ca_goa, ca_eq13,
                         sec_d, sec_c});
                const std::string tag = tag_of(eta_i);
                if (!ex.root()) continue;  // only rank 0 writes
                gl::write_exr(out / ("discrete_" + tag + ".exr"), di);
                gl::write_png(out / ("discrete_" + tag + ".png"), di, {ev});
                gl::write_exr(out / ("continuous_" + tag + ".exr"), ci);
                gl::write_png(out / ("continuous_" + tag + ".png"), ci, {ev});
            }
            if (!ex.root()) return ex.finish({});
            const auto csv_path = ex.csv("guo21_fig18_absorption.csv", csv);
            ex.plot("guo21_fig18_absorption", csv_path, out / "guo21_fig18_absorption.png");

            bool albedo_falls = true, mean_falls = true;
            double max_abs_rd = 0, max_abs_rdf = 0;
            for (double d : v_rdf) max_abs_rdf = std::max(max_abs_rdf, std::abs(d));
            for (std::size_t i = 0; i < v_eta.size(); ++i) {
                max_abs_rd = std::max(max_abs_rd, std::abs(v_rd[i]));
                if (i > 0 && !(v_alb_p[i] < v_alb_p[i - 1])) albedo_falls = false;
                if (i > 0 && !(v_md[i] < v_md[i - 1])) mean_falls = false;
            }
            std::printf("  paper: \"an increase of eta_i will increasingly dim the intensity of scattering\" (Fig. 18, no "
                        "numbers); ours: albedo falls with eta_i: %s, discrete mean falls: %s, max |discrete / continuous - 1| "
                        "= %.3f (vs the membership-scaled continuous medium: %.3f)\n",
                        albedo_falls ? "yes" : "no", mean_falls ? "yes" : "no", max_abs_rd, max_abs_rdf);
            gl_examples::Json j = ex.summary();
            j.integer("width", width)
                .integer("height", height)
                .integer("spp", spp)
                .integer("count", (long long)count)
                .num("eta_r", eta_r)
                .num("r_g_um", r_g)
                .num("sigma_g", sigma_g)
                .num("query_radius_um", r_c_um)
                .integer("diffraction", diffraction ? 1 : 0)
                .nums("eta_i", v_eta)
                .nums("albedo", v_alb_p)
                .nums("albedo_bulk_with_diffraction", v_alb)
                .nums("sigma_t", v_sig)
                .nums("membership_factor", v_fac)
                .nums("mean_discrete", v_md)
                .nums("mean_continuous", v_mc)
                .nums("rel_diff", v_rd)
                .nums("mean_continuous_membership", v_mcf)
                .nums("rel_diff_membership", v_rdf)
                .nums("C_a_1000um_goa_um2", v_ca1000)
                .nums("C_a_1000um_eq13_um2", v_eq13)
                .nums("seconds_discrete", v_secd)
                .nums("seconds_continuous", v_secc)
                .integer("albedo_falls", albedo_falls ? 1 : 0)
                .integer("mean_discrete_falls", mean_falls ? 1 : 0)
                .num("max_abs_rel_diff", max_abs_rd)
                .num("max_abs_rel_diff_membership", max_abs_rdf)
                .num("mean_discrete_last_over_first", v_md.back() / v_md.front())
                .str("csv", csv_path.string());
            guo21_mpi::rank_rows(j, ex, height);
            (void)full;
            return ex.finish(j);
        });
}
