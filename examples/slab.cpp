// slab: total reflectance R and transmittance T of a laterally infinite plane-parallel slab under
// collimated incidence, computed with the library's walk kernel, ContinuousMedium,
// Henyey-Greenstein phase and smooth dielectric (Fresnel) boundaries (scene/slab.hpp).
//
//   slab --albedo A --optical-depth B --g G --ior N --mu0 M --paths P --seed S [--threads T]
//        [--quality quick|full (default paths 1e6 | 1e7)] [--out DIR (also writes DIR/slab.csv)]
//
// B may be `inf` (semi-infinite). Prints one JSON line (the last line of stdout):
//   {"R":..,"T":..,"R_stderr":..,"T_stderr":..,"paths":..,"seconds":..}
// R: all light leaving the lit side (specular reflection of the top face included); T: all light
// leaving the far side (unscattered beam included; 0 for inf). Standard errors: sample standard
// deviation of the per-path scores / sqrt(P). Progress goes to stderr.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <iostream>
#include <vector>

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

        // Fixed-size blocks, reduced in block order: the same numbers for any thread count.
        const std::uint64_t block = 8192;
        const std::uint64_t n_blocks = (paths + block - 1) / block;
        std::vector<grainlight::SlabTally> tallies(n_blocks);
        gl_examples::ProgressBar bar("slab", n_blocks);
        const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
        for (long long b = 0; b < (long long)n_blocks; ++b) {
            const std::uint64_t first = std::uint64_t(b) * block;
            const std::uint64_t count = std::min(block, paths - first);
            tallies[std::size_t(b)] = problem.run(first, count, seed);
            bar.advance();
        }
        bar.done();
        grainlight::SlabTally total;
        for (const auto& t : tallies) total.merge(t);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

        gl_examples::Json j;
        j.num("R", total.R.mean())
            .num("T", total.T.mean())
            .num("R_stderr", total.R.standard_error())
            .num("T_stderr", total.T.standard_error())
            .integer("paths", (long long)total.paths)
            .num("seconds", seconds);
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
