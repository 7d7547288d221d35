// guo21_fig14_convergence: Guo21 Fig. 14 / Sec. 6.3. Monodisperse ice particles (r = 10 um,
// m = 1.31, lambda = 0.55 um) uniformly in a 0.4 m cube (the paper's DRAGON is a mesh we do not
// have: a cube stands in), N = 1e4 .. 1e6 (quick) or 1e7 (full), rendered as a discrete medium
// (media/discrete_particles.hpp, integrators/discrete_vpt.hpp) beside its paired continuous medium
// with sigma_t = C_t N / V, sigma_s = C_s N / V and the particle's tabulated phase function
// (ForcedCollisionMedium: a homogeneous RTE medium with forced collisions, + integrators/vpt.hpp).
// Black background, one large quad light above the cube (outside the view): the image is the
// medium's scattered light only.
//
//   guo21_fig14_convergence [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                           [--spp N] [--width W] [--counts 1e4,1e5,...] [--query-radius-mm R]
//                           [--sampling member|global] [--checkpoint SECONDS] [--resume]
//
// --sampling global renders the discrete media with Guo21 Sec. 5.5's estimator (free flights from
// the global sigma_t, directions from the global phase, Eq. 24's query-sphere Q; NEE with that Q)
// instead of the default collisions at the query cylinder's members (docs/guo21.md compares them).
//
// On the example harness: with --checkpoint every render keeps a checkpoint in --out, so a killed
// full-quality run (N = 1e7) resumes with --resume where it stopped (images byte-identical to an
// uninterrupted run; the timings of a resumed run count only what it rendered itself).
//
// The query radius is r_c = 2 mm (r_c / r_p = 200; the equivalent k of Eq. 23 is printed): the
// membership rule's mean-extinction factor (1 + r_p/r_c)^2 (1 - e^-c)/c, c = C_t / (pi r_c^2), is
// printed (1.010). Last stdout line: JSON with N, mean_discrete, mean_continuous, rel_diff
// (mean_discrete / mean_continuous - 1), rel_rmse (RMS over pixels of discrete - continuous,
// divided by the continuous reference's mean; the reference is the average of two continuous renders
// with different seeds at 4x the spp), continuous_noise_rmse (the reference's own per-pixel noise,
// |C1 - C2| RMS / 2 / mean), memory per particle. rel_rmse also holds the discrete render's own
// Monte Carlo noise, so it falls with N towards that floor, not to zero.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "common/checkpoint.hpp"
#include "guo21_mpi_render.hpp"
#include "common/harness.hpp"
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

template <class Scene>
void build_scene(Scene& sc, int medium) {
    using Mat = gl::Material<float, S>;
    // Cube [-0.2, 0.2] x [0, 0.4] x [-0.2, 0.2]; a large dim light 1.2 m x 1.2 m at y = 0.9 facing down
    // (outside the view). Large and dim: paths that reach it by phase sampling after near-forward
    // double scattering (the peaked phase of x = 114) carry less weight than with a small bright light.
    sc.add_shape(gl::BoxShape<float>(gl::Vec3f(-0.2f, 0.0f, -0.2f), gl::Vec3f(0.2f, 0.4f, 0.2f)), Mat::index_matched(), medium,
                 -1);
    sc.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-0.6f, 0.9f, -0.6f), gl::Vec3f(1.2f, 0, 0), gl::Vec3f(0, 0, 1.2f)),
                      S(1.25f));
}

double rel_rmse(const gl::Image& a, const gl::Image& b, double mean_b) {
    double s = 0;
    const std::size_t n = std::size_t(a.width) * std::size_t(a.height);
    for (std::size_t i = 0; i < n; ++i) {
        const double d = double(a.rgb[3 * i]) - double(b.rgb[3 * i]);
        s += d * d;
    }
    return std::sqrt(s / double(n)) / mean_b;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_fig14_convergence",
        "Guo21 Fig. 14: discrete media converge to their paired continuous media as N grows",
        "out/guo21_fig14_convergence", [&](gl_examples::Example& ex) {
        const int spp = int(ex.opt<std::uint64_t>("spp", 48, 64, "samples per pixel"));
        const int width = int(ex.opt<std::uint64_t>("width", 80, 512, "image width; height = 3/4 width"));
        const std::vector<double> counts =
            ex.opt<std::vector<double>>("counts", {1e4, 1e5, 1e6}, {1e4, 1e5, 1e6, 1e7}, "particle counts");
        const double r_c = ex.opt<double>("query-radius-mm", 2.0, "query-cylinder radius r_c [mm]") * 1e-3;
        const bool mixture = ex.opt<bool>("mixture", false,
                                          "on: a two-species cloud (half ice r = 10 um, half eta = 1.5 log-normal r_g = 6 um, "
                                          "sigma_g = 1.4 in [2, 20] um) against the continuous medium of the mixed bulk properties");
        const std::string sampling = ex.opt<std::string>(
            "sampling", "member",
            "member: collisions at the query cylinder's members (default); global: Guo21 Sec. 5.5's sampler (global "
            "sigma_t and phase, Eq. 24's sphere Q)");
        ex.checkpointable();
        ex.ready();
        guo21_mpi::quiet_other_ranks(ex);
        if (sampling != "member" && sampling != "global")
            throw gl_examples::cli_error("--sampling = '" + sampling + "' must be member or global");
        const auto& out = ex.out();
        if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
        const int height = width * 3 / 4;
        if (spp < 1 || spp > 65536) throw gl_examples::cli_error("--spp must be in [1, 65536]");
        for (double c : counts)
            if (!(c >= 1 && c < 4e9)) throw gl_examples::cli_error("--counts values must be in [1, 4e9)");
        if (!(r_c > 0 && r_c < 0.1)) throw gl_examples::cli_error("--query-radius-mm must be in (0, 100)");
        const int continuous_spp_factor = 4;
        const double r_um = 10.0, lambda = 0.55, side = 0.4, volume = side * side * side;
        gl::ParticleModel model;
        model.particle_index = {1.31, 0.0};

        const gl::PinholeCamera<float> camera(gl::Vec3f(0.0f, 0.55f, 1.1f), gl::Vec3f(0.0f, 0.2f, 0.0f), gl::Vec3f(0, 1, 0),
                                              32.0f, width, height);
        // Eq. 23 read as a length: r_c = k/2 * pixel footprint at z_med (the nearest medium depth).
        const double z_med = 1.1 - 0.2 - 0.0;  // ~ distance to the cube's front face
        const double footprint = double(camera.spread_angle()) * z_med;
        const double k_equiv = 2 * r_c / footprint;

        // Single-particle optics (the same tables for both media).
        const std::vector<double> wl = {lambda};
        // Mixture (Guo21 Sec. 7's limitation lifted): a second species of another index and PSD, equal
        // number shares. Its continuous pair has the mixed bulk properties: sigma_t = n sum_s w_s <C_t>_s
        // (number-weighted), sigma_s likewise, phase = sum_s w_s <C_s>_s f_s / sum_s w_s <C_s>_s (Eq. 17
        // over the mixed PSD), all from optics/bulk.hpp on one angle grid.
        gl::ParticleModel model2;
        model2.particle_index = {1.5, 0.0};
        const gl::LogNormalPsd psd2(6.0, 1.4, 2.0, 20.0);
        const double share2 = mixture ? 0.5 : 0.0;
        const double r_max_um = mixture ? 20.0 : r_um;
        gl::BulkSettings bs;  // the mixture's species share one angle grid (that of its largest particle)
        if (mixture) bs.theta = gl::forward_peaked_theta_grid(2 * gl::pi_v<double> * r_max_um / lambda);
        const gl::BulkOptics bulk = mixture ? gl::compute_bulk_optics(gl::MonodispersePsd(r_um, 1.0), model, wl, bs)
                                            : gl::compute_bulk_optics(gl::MonodispersePsd(r_um, 1.0), model, wl);
        double C_t = bulk.channels[0].mean_C_t * 1e-12, C_s = bulk.channels[0].mean_C_s * 1e-12;  // m^2
        auto phase = bulk.make_phase<float, S>();
        double C_t1 = C_t, C_t2 = 0;
        if (mixture) {
            const gl::BulkOptics bulk2 = gl::compute_bulk_optics(psd2, model2, wl, bs);
            const auto& c1 = bulk.channels[0];
            const auto& c2 = bulk2.channels[0];
            C_t2 = c2.mean_C_t * 1e-12;
            C_t = (1 - share2) * c1.mean_C_t * 1e-12 + share2 * c2.mean_C_t * 1e-12;
            C_s = (1 - share2) * c1.mean_C_s * 1e-12 + share2 * c2.mean_C_s * 1e-12;
            std::vector<S> mixed(bs.theta.size());
            for (std::size_t i = 0; i < bs.theta.size(); ++i)
                mixed[i] = S(float(((1 - share2) * c1.mean_C_s * c1.phase[i] + share2 * c2.mean_C_s * c2.phase[i]) /
                                   ((1 - share2) * c1.mean_C_s + share2 * c2.mean_C_s)));
            phase = gl::MiePhase<float, S>::from_intensities(bs.theta, mixed);
        }
        const double factor = gl::membership_extinction_factor(r_um * 1e-6, r_c, C_t);

        std::printf("Guo21 Fig. 14 (Sec. 6.3): ice spheres r = %.0f um in a %.1f m cube, C_t = %.4g um^2, albedo %.4f\n", r_um,
                    side, C_t * 1e12, C_s / C_t);
        std::printf("  query radius r_c = %.2f mm (r_c / r_p = %.0f, equivalent k = %.2f at %d px), membership factor "
                    "(1 + r_p/r_c)^2 (1 - e^-c)/c = %.4f\n",
                    r_c * 1e3, r_c / (r_um * 1e-6), k_equiv, width, factor);
        if (mixture)
            std::printf("  mixture: %.0f %% ice r = %.0f um (C_t = %.4g um^2) + %.0f %% eta = 1.5 log-normal r_g = 6 um, sigma_g = 1.4 "
                        "(<C_t> = %.4g um^2); continuous pair: the mixed bulk properties (number-weighted <C_t> = %.4g um^2)\n",
                        100 * (1 - share2), r_um, C_t1 * 1e12, 100 * share2, C_t2 * 1e12, C_t * 1e12);

        gl::RenderOptions opt = gl_examples::render_options(ex, spp, "unused");
        opt.checkpoint = {};  // each render below gets its own checkpoint
        opt.vpt.max_depth = 256;

        std::vector<double> sigma_rel, Ns, mean_d, mean_c, rel_diff, rmse, noise, sigmas, mem_pp, secs_d;
        gl_examples::Csv csv({"N", "sigma_t_per_m", "mean_discrete", "mean_continuous", "rel_diff", "rel_rmse",
                              "continuous_noise_rmse", "seconds_discrete", "bytes_per_particle"});
        std::printf("  %10s %10s %13s %13s %9s %9s %9s %8s %8s\n", "N", "sigma_t", "mean_discrete", "mean_contin.", "rel_diff",
                    "rel_rmse", "cont_noise", "sec", "B/part");
        for (double Nd : counts) {
            const auto N = std::uint64_t(Nd);
            // Continuous pair (two seeds: its own noise).
            using CMed = gl::ForcedCollisionMedium<gl::MiePhase<float, S>>;
            const double sigma_t = C_t * double(N) / volume;
            gl::Scene<CMed> csc;
            build_scene(csc, csc.add_medium(CMed(float(sigma_t), float(C_s / C_t), phase)));
            auto bar_c = ex.progress("continuous N=" + std::to_string(N), std::uint64_t(2 * height));
            gl::RenderOptions opt1 = opt;
            opt1.spp = spp * continuous_spp_factor;
            // Every render: this rank's rows, its checkpoint, gathered on every rank (guo21_mpi_render.hpp).
            auto vpt_c = [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_vpt(csc, camera, o, prog); };
            auto prog_c = [&](int n) { bar_c.advance(std::uint64_t(n)); };
            const gl::Image ci1 = guo21_mpi::render_image(ex, opt1, "continuous1_N" + std::to_string(N), vpt_c, prog_c);
            gl::RenderOptions opt2 = opt1;
            opt2.seed = opt.seed + 1000003;
            const gl::Image ci2 = guo21_mpi::render_image(ex, opt2, "continuous2_N" + std::to_string(N), vpt_c, prog_c);
            bar_c.done();
            gl::Image ci = ci1;  // the reference: the average of the two continuous renders
            for (std::size_t i = 0; i < ci.rgb.size(); ++i) ci.rgb[i] = 0.5f * (ci1.rgb[i] + ci2.rgb[i]);

            // Discrete medium.
            const auto t0 = std::chrono::steady_clock::now();
            auto cloud = std::make_shared<gl::ParticleCloud>(gl::ParticleCloud::generate(
                gl::BoxBoundary(gl::Vec3d(-0.2, 0.0, -0.2), gl::Vec3d(0.2, 0.4, 0.2)), N,
                mixture ? std::vector<gl::CloudSpecies>{gl::cloud_species(gl::MonodispersePsd(r_um), 1 - share2),
                                                        gl::cloud_species(psd2, share2)}
                        : std::vector<gl::CloudSpecies>{gl::cloud_species(gl::MonodispersePsd(r_um))},
                opt.seed * 7919 + N, 1e6));
            gl::ParticleGridSettings gs;
            gs.dilation = r_c;
            // About one particle per voxel, but voxels no smaller than the dilated sphere's diameter
            // (each particle then sits in <= 8 voxels; Sec. 5.3's rule for r_c << voxel).
            const double h1 = std::cbrt(volume / double(N));
            const double h = std::max(h1, 2 * (r_c + r_max_um * 1e-6));
            const int res = int(std::clamp(std::ceil(side / h), 1.0, 4096.0));
            gs.resolution = {res, res, res};
            auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
            gl::DiscreteMediumSettings ms;
            ms.query_radius = r_c;
            ms.wavelength_um = lambda;
            ms.sampling = sampling == "global" ? gl::DiscreteSampling::global : gl::DiscreteSampling::member;
            using DMed = gl::DiscreteParticleMedium<float>;
            gl::Scene<DMed> dsc;
            build_scene(dsc, dsc.add_medium(DMed(grid, mixture ? std::vector<gl::ParticleModel>{model, model2}
                                                               : std::vector<gl::ParticleModel>{model},
                                                 ms)));
            // The realized cloud's sigma_t (sum C_t / V over its particles) against the bulk's n <C_t>.
            sigma_rel.push_back(dsc.medium(0).global_sigma_t() / sigma_t - 1);
            const double bytes_pp = double(dsc.medium(0).memory_bytes()) / double(N);
            auto bar_d = ex.progress("discrete N=" + std::to_string(N), std::uint64_t(height));
            const gl::Image di = guo21_mpi::render_image(
                ex, opt, "discrete_N" + std::to_string(N),
                [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_discrete_vpt(dsc, camera, o, prog); },
                [&](int n) { bar_d.advance(std::uint64_t(n)); });
            bar_d.done();
            const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

            const double md = di.mean(0), mc = ci.mean(0);
            Ns.push_back(double(N));
            mean_d.push_back(md);
            mean_c.push_back(mc);
            rel_diff.push_back(md / mc - 1);
            rmse.push_back(rel_rmse(di, ci, mc));
            noise.push_back(0.5 * rel_rmse(ci2, ci1, mc));  // noise of the average of two renders
            sigmas.push_back(sigma_t);
            mem_pp.push_back(bytes_pp);
            secs_d.push_back(sec);
            std::printf("  %10.0f %10.4g %13.6g %13.6g %+9.4f %9.4f %9.4f %8.1f %8.1f\n", double(N), sigma_t, md, mc,
                        rel_diff.back(), rmse.back(), noise.back(), sec, bytes_pp);
            csv.row({double(N), sigma_t, md, mc, rel_diff.back(), rmse.back(), noise.back(), sec, bytes_pp});
            const double ev = std::log2(0.18 / std::max(mc, 1e-12));
            const std::string tag = "N" + std::to_string(N);
            if (!ex.root()) continue;  // only rank 0 writes
            gl::write_exr(out / ("discrete_" + tag + ".exr"), di);
            gl::write_png(out / ("discrete_" + tag + ".png"), di, {ev});
            gl::write_exr(out / ("continuous_" + tag + ".exr"), ci);
            gl::write_png(out / ("continuous_" + tag + ".png"), ci, {ev});
        }
        if (!ex.root()) return ex.finish({});
        const auto csv_path = out / "guo21_fig14_convergence.csv";
        csv.write(csv_path);
        ex.plot("guo21_fig14_convergence", csv_path, out / "guo21_fig14_convergence_plot.png");
        std::printf("  paper: \"each discrete medium and its paired continuous medium have the same overall brightness\"; "
                    "graininess fades as N grows (N = 1e7 looks like the continuous medium)\n");
        double max_abs_diff = 0;
        bool falls = true;
        for (std::size_t i = 0; i < rel_diff.size(); ++i) {
            max_abs_diff = std::max(max_abs_diff, std::abs(rel_diff[i]));
            if (i > 0 && !(rmse[i] < rmse[i - 1])) falls = false;
        }
        std::printf("  max |rel_diff| = %.4f (issue bound: 5 %% quick, 3 %% full); rel_rmse falls with N: %s\n", max_abs_diff,
                    falls ? "yes" : "no");
        auto j = ex.summary();
        j.integer("width", width)
            .integer("height", height)
            .integer("spp", spp)
            .num("radius_um", r_um)
            .num("query_radius_m", r_c)
            .num("query_radius_over_particle_radius", r_c / (r_um * 1e-6))
            .num("k_equivalent", k_equiv)
            .num("membership_factor", factor)
            .integer("mixture", mixture ? 1 : 0)
            .str("sampling", sampling)
            .num("C_t_species1_um2", C_t1 * 1e12)
            .num("C_t_species2_um2", C_t2 * 1e12)
            .num("share_species2", share2)
            .nums("sigma_t_realized_over_bulk_minus_1", sigma_rel)
            .num("max_abs_sigma_t_realized_over_bulk_minus_1", [&] {
                double m = 0;
                for (double v : sigma_rel) m = std::max(m, std::abs(v));
                return m;
            }())
            .nums("N", Ns)
            .nums("sigma_t", sigmas)
            .nums("mean_discrete", mean_d)
            .nums("mean_continuous", mean_c)
            .nums("rel_diff", rel_diff)
            .nums("rel_rmse", rmse)
            .nums("continuous_noise_rmse", noise)
            .nums("bytes_per_particle", mem_pp)
            .nums("seconds_discrete", secs_d)
            .num("max_abs_rel_diff", max_abs_diff)
            .num("rel_rmse_first", rmse.front())
            .num("rel_rmse_last", rmse.back())
            .integer("rel_rmse_falls", falls ? 1 : 0)
            .num("continuous_noise_max", *std::max_element(noise.begin(), noise.end()))
            .num("bytes_per_particle_max", *std::max_element(mem_pp.begin(), mem_pp.end()))
            .str("csv", csv_path.string());
        guo21_mpi::rank_rows(j, ex, height);
        return ex.finish(j);
    });
}
