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
// Built with MPI, `mpirun -np K slab --method shells ...` splits the shell precomputation's path
// blocks over the ranks (rank 0 merges them in order, builds the table, writes
// DIR/slab_shells.shel when --out is given and solves the slab): the table file and R, T are
// byte-identical to one process.
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
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "grainlight/integrators/shell_tracer.hpp"  // --method shells
#include "grainlight/precompute/shell_builder.hpp"

#include "common/harness.hpp"
#include "grainlight/integrators/slab.hpp"

namespace {
// Shell samples as bytes for the gather on rank 0 (same radii and f_a histogram on every rank).
std::vector<unsigned char> encode_shell_samples(const grainlight::ShellSamples& s) {
    grainlight::ByteWriter w;
    w.put(std::uint64_t(s.n_shells())).put(s.n_paths).put(s.fa_d_max);
    w.put(std::uint64_t(s.radii.size())).put_array(s.radii.data(), s.radii.size());
    w.put(std::uint64_t(s.fa_counts.size())).put_array(s.fa_counts.data(), s.fa_counts.size());
    for (std::size_t i = 0; i < s.n_shells(); ++i) {
        w.put(s.n_unscattered[i]).put(s.n_absorbed[i]).put(std::uint64_t(s.coords[i].size()));
        w.put_array(s.coords[i].data(), s.coords[i].size());
    }
    return w.bytes();
}
grainlight::ShellSamples decode_shell_samples(const std::vector<unsigned char>& bytes) {
    grainlight::ByteReader r(bytes, "shell samples from another rank");
    const auto n = r.get<std::uint64_t>();
    grainlight::ShellSamples s;
    s.n_paths = r.get<std::uint64_t>();
    s.fa_d_max = r.get<double>();
    r.get_array(s.radii, r.get<std::uint64_t>());
    r.get_array(s.fa_counts, r.get<std::uint64_t>());
    if (s.radii.size() != n) r.fail("radius count mismatch");
    s.coords.resize(std::size_t(n));
    s.n_unscattered.resize(std::size_t(n));
    s.n_absorbed.resize(std::size_t(n));
    for (std::size_t i = 0; i < n; ++i) {
        s.n_unscattered[i] = r.get<std::uint64_t>();
        s.n_absorbed[i] = r.get<std::uint64_t>();
        r.get_array(s.coords[i], r.get<std::uint64_t>());
    }
    r.expect_end();
    return s;
}
}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(argc, argv, "slab",
                            "total reflectance and transmittance of a plane-parallel slab (photon walks)",
                            [&](gl_examples::Example& ex) -> int {
        using gl_examples::cli_error;
        grainlight::SlabParams p;
        p.albedo = ex.opt<double>("albedo", 0.9, "single-scattering albedo a in [0, 1]");
        p.optical_depth = ex.opt<double>(
            "optical-depth", 1.0, "optical depth B = sigma_t * thickness in (0, inf]; 'inf' = semi-infinite");
        p.g = ex.opt<double>("g", 0.0, "Henyey-Greenstein asymmetry parameter in (-1, 1)");
        p.ior = ex.opt<double>("ior", 1.0, "relative index n_slab / n_outside in (0, 10] (1 = index-matched)");
        p.mu0 = ex.opt<double>("mu0", 1.0, "cosine of the collimated incidence outside the slab, in (0, 1]");
        const std::uint64_t paths =
            ex.opt<std::uint64_t>("paths", 1000000, 10000000, "number of photon paths (>= 2)");
        const std::string method =
            ex.opt<std::string>("method", "vpt", "vpt (exact walk) | shells (Moon07 shell stepping in the interior)");
        const std::uint64_t shell_paths =
            ex.opt<std::uint64_t>("shell-paths", 200000, "shells: walk-kernel paths for the shell table (>= 1000)");
        const std::vector<double> grid =
            ex.opt<std::vector<double>>("shell-grid", {32, 16, 16}, "shells: k-NN grid cells n_c,n_u,n_v");
        const std::uint64_t n_radii = ex.opt<std::uint64_t>("shell-radii", 12, "shells: number of shell radii");
        const double shell_r0 = ex.opt<double>("shell-r0", 0.75, "shells: smallest shell radius (optical depths, > 0)");
        const double shell_rmax =
            ex.opt<double>("shell-rmax", 8.0, "shells: cap of the largest radius (the slab caps it at B/2)");
        const std::uint64_t shell_rank = ex.opt<std::uint64_t>("shell-rank", 5, "shells: NMF terms");
        const std::uint64_t shell_knn = ex.opt<std::uint64_t>("shell-knn", 32, "shells: k of the k-NN density estimate");
        ex.ready(gl_examples::Example::OutKind::optional_directory);  // DIR/slab.csv only when --out is given

        if (paths < 2) throw cli_error("--paths = " + std::to_string(paths) + " must be >= 2");
        const std::uint64_t seed = ex.seed();
        const grainlight::SlabProblem problem(p);  // throws invalid_argument naming the parameter
        if (method != "vpt" && method != "shells")
            throw cli_error("--method = '" + method + "' must be vpt or shells");
        const bool shells = method == "shells";

        // Shell table from the slab's own medium (Moon07 Sec. 4.1 with a continuous medium).
        double build_seconds = 0, nmf_error = 0;
        std::size_t n_shells = 0;
        std::unique_ptr<grainlight::ShellSlab> shell_slab;
        if (shells) {
            if (shell_paths < 1000)
                throw cli_error("--shell-paths = " + std::to_string(shell_paths) + " must be >= 1000");
            if (grid.size() != 3)
                throw cli_error("--shell-grid needs three values n_c,n_u,n_v (got " + std::to_string(grid.size()) +
                                ")");
            for (double g : grid)
                if (!(g >= 1 && g <= 256 && g == std::floor(g)))
                    throw cli_error("--shell-grid value " + std::to_string(g) + " must be an integer in [1, 256]");
            const auto b0 = std::chrono::steady_clock::now();
            const std::vector<double> radii = grainlight::slab_shell_radii(
                p.optical_depth, int(std::min<std::uint64_t>(n_radii, 100000)), shell_r0, shell_rmax);
            const auto& medium = problem.scene().medium(0);
            const grainlight::ContinuousShellSource<std::decay_t<decltype(medium)>> source(medium);
            // MPI: each rank samples a contiguous range of the path blocks; rank 0 merges them in
            // rank order (integer counts, appended exits: the one-process samples exactly).
            const gl_examples::MpiSession& mpi = ex.mpi();
            const auto [blk0, blk1] = mpi.block_range(grainlight::shell_sample_blocks(shell_paths));
            const grainlight::ShellSamples mine =
                grainlight::collect_shell_sample_blocks(source, radii, shell_paths, seed ^ 0x5e11u, blk0, blk1);
            const auto all = mpi.gather_bytes(encode_shell_samples(mine));
            if (!mpi.root()) return ex.finish({});  // rank 0 builds the table and solves the slab
            grainlight::ShellSamples samples = mine;
            if (mpi.size() > 1) {
                samples = decode_shell_samples(all[0]);
                for (int r = 1; r < mpi.size(); ++r) samples.merge(decode_shell_samples(all[std::size_t(r)]));
            }
            grainlight::ShellBuildOptions bo;
            bo.n_c = int(grid[0]);
            bo.n_u = int(grid[1]);
            bo.n_v = int(grid[2]);
            bo.rank = int(shell_rank);
            bo.k_nn = int(shell_knn);
            grainlight::ShellBuildResult built = grainlight::build_shell_table(samples, bo);
            nmf_error = built.nmf_relative_error;
            if (ex.given("out")) built.table.save(ex.out() / "slab_shells.shel");  // the precomputation's file
            n_shells = built.table.n_shells();
            shell_slab = std::make_unique<grainlight::ShellSlab>(p, std::move(built.table));
            build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - b0).count();
            std::cerr << "slab: shell table " << n_shells << " radii " << radii.front() << ".." << radii.back()
                      << ", grid " << bo.n_c << "x" << bo.n_u << "x" << bo.n_v << ", NMF error " << nmf_error << ", "
                      << build_seconds << " s\n";
        }

        if (!ex.root()) return ex.finish({});  // MPI splits only the shell precomputation
        // Fixed-size blocks, reduced in block order: the same numbers for any thread count.
        struct Part {
            grainlight::SlabTally tally{};
            double shell_steps = 0, exact_steps = 0;
        };
        const auto t0 = std::chrono::steady_clock::now();
        const Part total = ex.parallel<Part>(
            "slab", paths, 8192,
            [&](std::uint64_t, std::uint64_t first, std::uint64_t end) {
                Part part;
                grainlight::ShellSwitchStats steps{};
                part.tally = shells ? shell_slab->run(first, end - first, seed, &steps)
                                    : problem.run(first, end - first, seed);
                part.shell_steps = double(steps.shell_steps);
                part.exact_steps = double(steps.exact_steps);
                return part;
            },
            [](Part& acc, const Part& part) {
                acc.tally.merge(part.tally);
                acc.shell_steps += part.shell_steps;
                acc.exact_steps += part.exact_steps;
            });
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const grainlight::SlabTally& tally = total.tally;

        gl_examples::Json j = ex.summary();
        j.num("R", tally.R.mean())
            .num("T", tally.T.mean())
            .num("R_stderr", tally.R.standard_error())
            .num("T_stderr", tally.T.standard_error())
            .integer("paths", (long long)tally.paths)
            .num("seconds", seconds)
            .str("method", method);
        if (shells)
            j.num("shell_build_seconds", build_seconds)
                .num("shell_steps_per_path", total.shell_steps / double(tally.paths))
                .num("exact_steps_per_path", total.exact_steps / double(tally.paths))
                .num("nmf_error", nmf_error)
                .integer("shells", (long long)n_shells);
        if (shells)  // [begin, end) shell-sampling path-block range of each rank
            j.nums("rank_blocks", ex.mpi().block_ranges(grainlight::shell_sample_blocks(shell_paths)));
        if (ex.given("out")) {  // optional CSV record of the run
            gl_examples::Csv csv({"albedo", "optical_depth", "g", "ior", "mu0", "paths", "seed", "R", "T", "R_stderr",
                                  "T_stderr"});
            csv.row({p.albedo, p.optical_depth, p.g, p.ior, p.mu0, double(tally.paths), double(seed), tally.R.mean(),
                     tally.T.mean(), tally.R.standard_error(), tally.T.standard_error()});
            ex.csv("slab.csv", csv);
        }
        return ex.finish(j);
    });
}
