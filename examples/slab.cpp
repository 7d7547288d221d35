// slab: total reflectance R and transmittance T of a laterally infinite plane-parallel slab under
// collimated incidence, computed with the library's walk kernel, ContinuousMedium,
// Henyey-Greenstein phase and smooth dielectric (Fresnel) boundaries (scene/slab.hpp).
//
//   slab --albedo A --optical-depth B --g G --ior N --mu0 M --paths P --seed S [--threads T]
//        [--quality quick|full (default paths 1e6 | 1e7)] [--out DIR (also writes DIR/slab.csv)]
//        [--method vpt|shells] [--shell-paths N] [--shell-grid NC,NU,NV] [--shell-radii N]
//        [--shell-r0 R0] [--shell-rmax RMAX] [--shell-rank K] [--shell-knn K]
//
// --method shells (Moon07 shells, integrators/shell_tracer.hpp): builds a shell table from the
// slab's own medium (sigma_t = 1, its albedo and g; precompute/shell_builder.hpp, walk-kernel
// paths from a point: --shell-paths of them, --shell-radii radii from --shell-r0 to
// min(--shell-rmax, B/2), k-NN grid --shell-grid, NMF rank --shell-rank) and solves the slab by
// stepping with the largest shell that fits between the faces, with exact steps within r0 of a
// face. --paths keeps meaning slab photons.
//
// B may be `inf` (semi-infinite). Prints one JSON line (the last line of stdout):
//   {"R":..,"T":..,"R_stderr":..,"T_stderr":..,"paths":..,"seconds":..}
// plus, for --method shells, shell_build_seconds, shell_steps_per_path, exact_steps_per_path,
// nmf_error, shells.
// R: all light leaving the lit side (specular reflection of the top face included); T: all light
// leaving the far side (unscattered beam included; 0 for inf). Standard errors: sample standard
// deviation of the per-path scores / sqrt(P). Progress goes to stderr.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "grainlight/integrators/shell_tracer.hpp"  // --method shells
#include "grainlight/precompute/shell_builder.hpp"

#include "common/cli.hpp"
#include "common/output.hpp"
#include "common/progress.hpp"
#include "grainlight/integrators/slab.hpp"

int main(int argc, char** argv) {
    return gl_examples::run_main("slab", [&]() -> int {
        gl_examples::Cli cli(argc, argv, "slab",
                             "total reflectance and transmittance of a plane-parallel slab (photon walks)");
        cli.option("albedo", "single-scattering albedo a in [0, 1]", "0.9")
            .option("optical-depth", "optical depth B = sigma_t * thickness in (0, inf]; 'inf' = semi-infinite", "1")
            .option("g", "Henyey-Greenstein asymmetry parameter in (-1, 1)", "0")
            .option("ior", "relative index n_slab / n_outside in (0, 10] (1 = index-matched)", "1")
            .option("mu0", "cosine of the collimated incidence outside the slab, in (0, 1]", "1")
            .option("paths", "number of photon paths (>= 2)", "1000000 quick, 10000000 full")
            .option("method", "vpt (exact walk) | shells (Moon07 shell stepping in the interior)", "vpt")
            .option("shell-paths", "shells: walk-kernel paths for the shell table (>= 1000)", "200000")
            .option("shell-grid", "shells: k-NN grid cells n_c,n_u,n_v", "32,16,16")
            .option("shell-radii", "shells: number of shell radii", "12")
            .option("shell-r0", "shells: smallest shell radius (optical depths, > 0)", "0.75")
            .option("shell-rmax", "shells: cap of the largest radius (the slab caps it at B/2)", "8")
            .option("shell-rank", "shells: NMF terms", "5")
            .option("shell-knn", "shells: k of the k-NN density estimate", "32")
            .common_options("out");
        cli.finish();

        grainlight::SlabParams p;
        p.albedo = cli.num("albedo", 0.9);
        p.optical_depth = cli.num("optical-depth", 1.0);
        p.g = cli.num("g", 0.0);
        p.ior = cli.num("ior", 1.0);
        p.mu0 = cli.num("mu0", 1.0);
        const bool full = cli.full_quality();
        const std::uint64_t paths = cli.integer("paths", full ? 10000000 : 1000000);
        if (paths < 2) throw gl_examples::cli_error("--paths = " + std::to_string(paths) + " must be >= 2");
        const std::uint64_t seed = cli.seed();
        const int threads = cli.threads();
        (void)threads;
        const grainlight::SlabProblem problem(p);  // throws invalid_argument naming the parameter
        const std::string method = cli.str("method", "vpt");
        if (method != "vpt" && method != "shells")
            throw gl_examples::cli_error("--method = '" + method + "' must be vpt or shells");
        const bool shells = method == "shells";

        // Shell table from the slab's own medium (Moon07 Sec. 4.1 with a continuous medium).
        double build_seconds = 0, nmf_error = 0;
        std::size_t n_shells = 0;
        std::unique_ptr<grainlight::ShellSlab> shell_slab;
        if (shells) {
            const std::uint64_t shell_paths = cli.integer("shell-paths", 200000);
            if (shell_paths < 1000)
                throw gl_examples::cli_error("--shell-paths = " + std::to_string(shell_paths) + " must be >= 1000");
            const std::vector<double> grid = cli.list("shell-grid", {32, 16, 16});
            if (grid.size() != 3)
                throw gl_examples::cli_error("--shell-grid needs three values n_c,n_u,n_v (got " +
                                             std::to_string(grid.size()) + ")");
            for (double g : grid)
                if (!(g >= 1 && g <= 256 && g == std::floor(g)))
                    throw gl_examples::cli_error("--shell-grid value " + std::to_string(g) + " must be an integer in [1, 256]");
            const auto n_radii = cli.integer("shell-radii", 12);
            const auto b0 = std::chrono::steady_clock::now();
            const std::vector<double> radii = grainlight::slab_shell_radii(
                p.optical_depth, int(std::min<std::uint64_t>(n_radii, 100000)), cli.num("shell-r0", 0.75),
                cli.num("shell-rmax", 8.0));
            const auto& medium = problem.scene().medium(0);
            const grainlight::ContinuousShellSource<std::decay_t<decltype(medium)>> source(medium);
            const grainlight::ShellSamples samples =
                grainlight::collect_shell_samples(source, radii, shell_paths, seed ^ 0x5e11u);
            grainlight::ShellBuildOptions bo;
            bo.n_c = int(grid[0]);
            bo.n_u = int(grid[1]);
            bo.n_v = int(grid[2]);
            bo.rank = int(cli.integer("shell-rank", 5));
            bo.k_nn = int(cli.integer("shell-knn", 32));
            grainlight::ShellBuildResult built = grainlight::build_shell_table(samples, bo);
            nmf_error = built.nmf_relative_error;
            n_shells = built.table.n_shells();
            shell_slab = std::make_unique<grainlight::ShellSlab>(p, std::move(built.table));
            build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - b0).count();
            std::cerr << "slab: shell table " << n_shells << " radii " << radii.front() << ".." << radii.back()
                      << ", grid " << bo.n_c << "x" << bo.n_u << "x" << bo.n_v << ", NMF error " << nmf_error << ", "
                      << build_seconds << " s\n";
        }

        // Fixed-size blocks, reduced in block order: the same numbers for any thread count.
        const std::uint64_t block = 8192;
        const std::uint64_t n_blocks = (paths + block - 1) / block;
        std::vector<grainlight::SlabTally> tallies(n_blocks);
        std::vector<grainlight::ShellSwitchStats> steps(n_blocks);
        gl_examples::ProgressBar bar("slab", n_blocks);
        const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
        for (long long b = 0; b < (long long)n_blocks; ++b) {
            const std::uint64_t first = std::uint64_t(b) * block;
            const std::uint64_t count = std::min(block, paths - first);
            tallies[std::size_t(b)] = shells ? shell_slab->run(first, count, seed, &steps[std::size_t(b)])
                                             : problem.run(first, count, seed);
            bar.advance();
        }
        bar.done();
        grainlight::SlabTally total;
        for (const auto& t : tallies) total.merge(t);
        double shell_steps = 0, exact_steps = 0;
        for (const auto& s : steps) {
            shell_steps += double(s.shell_steps);
            exact_steps += double(s.exact_steps);
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

        gl_examples::Json j;
        j.num("R", total.R.mean())
            .num("T", total.T.mean())
            .num("R_stderr", total.R.standard_error())
            .num("T_stderr", total.T.standard_error())
            .integer("paths", (long long)total.paths)
            .num("seconds", seconds)
            .str("method", method);
        if (shells)
            j.num("shell_build_seconds", build_seconds)
                .num("shell_steps_per_path", shell_steps / double(total.paths))
                .num("exact_steps_per_path", exact_steps / double(total.paths))
                .num("nmf_error", nmf_error)
                .integer("shells", (long long)n_shells);
        if (cli.has("out")) {  // optional CSV record of the run
            gl_examples::Csv csv({"albedo", "optical_depth", "g", "ior", "mu0", "paths", "seed", "R", "T", "R_stderr",
                                  "T_stderr"});
            csv.row({p.albedo, p.optical_depth, p.g, p.ior, p.mu0, double(total.paths), double(seed), total.R.mean(),
                     total.T.mean(), total.R.standard_error(), total.T.standard_error()});
            csv.write(cli.out_dir() / "slab.csv");
        }
        std::cout << j.str() << std::endl;
        return 0;
    });
}
