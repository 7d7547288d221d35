// grain_stats: run the virtual scatterometer (Meng15 Sec. 4.2) on one grain and print its
// statistics {beta, lambda_delta, lambda_s, alpha_s, g} (channel averages, as Meng15 Table 1).
//
//   grain_stats --shape sphere|snow|crystal|rice|flake --material dielectric|diffuse|absorbing-dielectric
//               [--ior N] [--albedo A] [--interior-sigma-a S] [--interior-sigma-s S] [--interior-g G]
//               --grain-radius R --rays P --seed S
//   grain_stats --preset glass-bead|snow|salt|sugar|brown-sugar|sand|flour|rice [--rays P] [--seed S]
//
// The packing's bounding sphere has radius 1; the grain is scaled so that its own bounding sphere
// has radius R <= 1. --albedo and --interior-sigma-* take one value or r,g,b. Writes the
// per-channel phase table (CSV), a PNG plot of it and the statistics file (.scat) into --out.
// The last line of stdout is one JSON object:
//   {"beta":..,"lambda_delta":..,"lambda_s":..,"alpha_s":..,"g":..}
#include <cstdio>
#include <iostream>
#include <string>

#include "common/cli.hpp"
#include "common/output.hpp"
#include "common/progress.hpp"
#include "grainlight/precompute/scatterometer.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {

gl::RGBd rgb_option(const Cli& cli, const std::string& name, double def) {
    const auto v = cli.list(name, {def});
    if (v.size() == 1) return gl::RGBd(v[0]);
    if (v.size() == 3) return gl::RGBd{v[0], v[1], v[2]};
    throw cli_error("--" + name + " takes one value or three (r,g,b)");
}

}  // namespace

int main(int argc, char** argv) {
    return run_main("grain_stats", [&] {
        Cli cli(argc, argv, "grain_stats", "virtual scatterometer statistics of one grain (Meng15 Sec. 4.2, Table 1)");
        cli.common_options("out/grain_stats");
        cli.option("preset", "glass-bead|snow|salt|sugar|brown-sugar|sand|flour|rice (a Table 1 grain)")
            .option("shape", "sphere|snow|crystal|rice|flake")
            .option("material", "dielectric|diffuse|absorbing-dielectric")
            .option("ior", "relative index of refraction (dielectrics)", "1.5")
            .option("albedo", "Lambertian albedo (diffuse), A or r,g,b", "0.8")
            .option("interior-sigma-a", "absorption inside the grain per bounding radius, S or r,g,b", "0")
            .option("interior-sigma-s", "scattering inside the grain per bounding radius, S or r,g,b", "0")
            .option("interior-g", "HG asymmetry of the interior scattering", "0")
            .option("grain-radius", "radius R of the grain's bounding sphere, 0 < R <= 1")
            .option("grain-seed", "seed of the procedural shape", "1")
            .option("mesh-level", "icosphere subdivision level of mesh grains (20*4^level triangles)", "5")
            .option("rays", "incident rays", "200000 (quick) / 2000000 (full)");
        cli.finish();
        const bool full = cli.full_quality();
        const auto out = cli.out_dir("out/grain_stats");
        const int threads = cli.threads();

        gl::GrainPreset grain;
        if (cli.has("preset")) {
            for (const char* o : {"shape", "material", "ior", "albedo", "interior-sigma-a", "interior-sigma-s",
                                  "interior-g", "grain-radius", "grain-seed"})
                if (cli.has(o)) throw cli_error(std::string("--") + o + " cannot be combined with --preset");
            grain = gl::grain_preset(cli.str("preset"));
        } else {
            if (!cli.has("shape")) throw cli_error("give --preset or --shape (see --help)");
            if (!cli.has("material")) throw cli_error("--shape needs --material");
            if (!cli.has("grain-radius")) throw cli_error("--shape needs --grain-radius");
            grain.name = cli.str("shape");
            grain.shape = gl::grain_shape_from_string(cli.str("shape"));
            grain.radius = cli.num("grain-radius");
            grain.seed = cli.integer("grain-seed", 1);
            const std::string mat = cli.str("material");
            const double ior = cli.num("ior", 1.5);
            if (mat == "dielectric") {
                grain.material = gl::GrainMaterial::make_dielectric(ior);
            } else if (mat == "diffuse") {
                grain.material = gl::GrainMaterial::make_diffuse(rgb_option(cli, "albedo", 0.8));
            } else if (mat == "absorbing-dielectric") {
                grain.material = gl::GrainMaterial::make_absorbing_dielectric(
                    ior, rgb_option(cli, "interior-sigma-a", 0.0), rgb_option(cli, "interior-sigma-s", 0.0),
                    cli.num("interior-g", 0.0));
            } else {
                throw cli_error("--material = '" + mat + "' must be dielectric, diffuse or absorbing-dielectric");
            }
        }
        const auto level = cli.integer("mesh-level", 5);
        if (level > 7) throw cli_error("--mesh-level must be <= 7");
        const auto scat = gl::ScatterometerGrain::procedural(grain.shape, grain.radius, grain.material, grain.seed, int(level));

        gl::ScatterometerConfig cfg;
        cfg.rays = cli.integer("rays", full ? 2000000 : 200000);
        cfg.seed = cli.seed();
        ProgressBar bar("scatterometer " + grain.name, cfg.rays);
        std::uint64_t last = 0;
        cfg.progress = [&](std::uint64_t done, std::uint64_t) {
            bar.advance(done - last);
            last = done;
        };
        const auto stats = gl::run_scatterometer(scat, cfg);
        bar.done();
        const double secs = bar.seconds();

        // Files: statistics, per-channel phase table (density of cos theta per channel), plot.
        const std::string stem = "grain_stats_" + grain.name;
        gl::save_grain_stats(out / (stem + ".scat"), stats);
        const auto phase = stats.phase<double, gl::RGBd>();
        const auto edges = phase.grid();
        Csv csv({"mu_lo", "mu_hi", "theta_deg", "p_r", "p_g", "p_b"});
        for (std::size_t i = 0; i + 1 < edges.size(); ++i) {
            const double mid = 0.5 * (edges[i] + edges[i + 1]);
            csv.row({edges[i], edges[i + 1], std::acos(mid) * 180.0 / gl::pi_v<double>, phase.pdf_cos_theta(mid, 0),
                     phase.pdf_cos_theta(mid, 1), phase.pdf_cos_theta(mid, 2)});
        }
        const auto csv_path = out / (stem + "_phase.csv");
        csv.write(csv_path);
        plot_with_matplotlib(out / (stem + "_phase.py"),
                             "d = read_csv(r'''" + csv_path.string() + "''')\n"
                             "fig, ax = plt.subplots(figsize=(6,4))\n"
                             "for k, c in (('p_r','r'),('p_g','g'),('p_b','b')):\n"
                             "    ax.semilogy(d['theta_deg'], np.array(d[k]) / (2*np.pi), color=c, label=k)\n"
                             "ax.set_xlabel('scattering angle theta [deg]'); ax.set_ylabel('Phi [1/sr]')\n"
                             "ax.set_title('" + grain.name + ": scatterometer phase function (Meng15 Sec. 4.2.1)')\n"
                             "ax.legend(); fig.tight_layout(); fig.savefig(png, dpi=120)\n",
                             out / (stem + "_phase.png"));

        std::printf("grain %s: shape %s, R = %.3f, material %s, %llu rays, seed %llu, %d threads, %.2f s (%.3g rays/s)\n",
                    grain.name.c_str(), std::string(gl::to_string(grain.shape)).c_str(), grain.radius,
                    std::string(gl::to_string(grain.material.kind)).c_str(), (unsigned long long)cfg.rays,
                    (unsigned long long)cfg.seed, threads, secs, double(cfg.rays) / std::max(secs, 1e-9));
        std::printf("  beta         = %.4f +- %.4f\n", stats.beta(), stats.beta_stderr());
        std::printf("  lambda_delta = %.4f +- %.4f\n", stats.lambda_delta(), stats.lambda_delta_stderr());
        for (std::size_t c = 0; c < 3; ++c)
            std::printf("  channel %zu: alpha_s = %.4f +- %.4f, lambda_s = %.4f +- %.4f (signed %+.4f), g = %.4f\n", c,
                        stats.alpha_s(c), stats.alpha_s_stderr(c), stats.lambda_s(c), stats.teleport_along_stderr(c),
                        stats.teleport_along(c), stats.g(c));
        std::printf("  terminated (bounce limit or mesh leak, counted as absorbed): %.2g %.2g %.2g\n", stats.terminated[0],
                    stats.terminated[1], stats.terminated[2]);
        if (const auto* col = gl::find_meng15_table1(grain.paper_column)) {
            std::printf("  channel average vs Meng15 Table 1 (%s):\n", col->name);
            std::printf("    beta %.2f (paper %.2f), lambda_delta %.2f (paper %.2f), lambda_s %.2f (paper %.2f), alpha_s %.2f (paper %.2f)\n",
                        stats.beta(), col->beta, stats.lambda_delta(), col->lambda_delta, stats.lambda_s_avg(),
                        col->lambda_s, stats.alpha_s_avg(), col->alpha_s);
        }
        std::printf("  wrote %s, %s\n", (out / (stem + ".scat")).c_str(), csv_path.c_str());
        Json j;
        j.num("beta", stats.beta())
            .num("lambda_delta", stats.lambda_delta())
            .num("lambda_s", stats.lambda_s_avg())
            .num("alpha_s", stats.alpha_s_avg())
            .num("g", stats.g_avg());
        std::cout << j.str() << std::endl;
        return 0;
    });
}
