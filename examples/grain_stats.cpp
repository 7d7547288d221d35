// grain_stats: run the virtual scatterometer (Meng15 Sec. 4.2) on one grain and print its
// statistics {beta, lambda_delta, lambda_s, alpha_s, g} (channel averages, as Meng15 Table 1).
//
//   grain_stats --shape sphere|snow|crystal|rice|flake --material dielectric|diffuse|absorbing-dielectric
//               [--ior N] [--albedo A] [--interior-sigma-a S] [--interior-sigma-s S] [--interior-g G]
//               --grain-radius R --rays P --seed S
//   grain_stats --preset glass-bead|snow|salt|sugar|brown-sugar|sand|flour|rice [--rays P] [--seed S]
//   grain_stats --preset salt,flour --weights 0.7,0.3      (a mixture, Meng15 Sec. 4.2.3)
//   grain_stats --load a.scat[,b.scat --weights wa,wb]     (saved statistics; bad files: clear error)
//
// The packing's bounding sphere has radius 1; the grain is scaled so that its own bounding sphere
// has radius R <= 1. --albedo and --interior-sigma-* take one value or r,g,b. Writes the
// per-channel phase table (CSV), a PNG plot of it and the statistics file (.scat) into --out.
// The last line of stdout is one JSON object:
//   {"beta":..,"lambda_delta":..,"lambda_s":..,"alpha_s":..,"g":..,"ranks":..,"rank_blocks":[..]}
// Built with MPI, `mpirun -np K grain_stats ...` gives rank r a contiguous range of the
// scatterometer's ray blocks; rank 0 appends the ranks' tallies in order, so the .scat file is
// byte-identical to a single-process run with the same seed.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/precompute/scatterometer.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {

gl::RGBd rgb_option(const Cli& cli, const std::string& name, double def) {  // one value or r,g,b
    const auto v = cli.list(name, {def});
    if (v.size() == 1) return gl::RGBd(v[0]);
    if (v.size() == 3) return gl::RGBd{v[0], v[1], v[2]};
    throw cli_error("--" + name + " takes one value or three (r,g,b)");
}

// A tally as bytes (for the gather on rank 0): first block, block partials, then the counts.
std::vector<unsigned char> encode_tally(const gl::ScatterometerTally& t) {
    gl::ByteWriter w;
    w.put(t.first_block).put(std::uint64_t(t.blocks.size()));
    w.put_array(t.blocks.data(), t.blocks.size());
    const auto& c = t.counts;
    w.put(c.hits).put(c.exits).put(c.terminated);
    w.put_array(c.chord.data(), c.chord.size());
    for (std::size_t k = 0; k < 3; ++k) w.put_array(c.phase[k].data(), c.phase[k].size());
    for (std::size_t k = 0; k < 3; ++k) w.put_array(c.tt[k].data(), c.tt[k].size());
    return w.take();
}
gl::ScatterometerTally decode_tally(const std::vector<unsigned char>& bytes, const gl::ScatterometerGrid& grid) {
    gl::ByteReader r(bytes, "scatterometer tally from another rank");
    gl::ScatterometerTally t(grid, r.get<std::uint64_t>());
    r.get_array(t.blocks, r.get<std::uint64_t>());
    auto& c = t.counts;
    c.hits = r.get<std::uint64_t>();
    c.exits = r.get<decltype(c.exits)>();
    c.terminated = r.get<decltype(c.terminated)>();
    r.get_array(c.chord, c.chord.size());
    for (std::size_t k = 0; k < 3; ++k) r.get_array(c.phase[k], c.phase[k].size());
    for (std::size_t k = 0; k < 3; ++k) r.get_array(c.tt[k], c.tt[k].size());
    r.expect_end();
    return t;
}

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "grain_stats", "virtual scatterometer statistics of one grain (Meng15 Sec. 4.2, Table 1)",
               "out/grain_stats", [&](Example& ex) {
        // Options read later through ex.cli() (lists, r,g,b triples, "exactly one of" rules):
        // declared here, all before ready().
        (void)ex.opt_optional<std::string>("preset", "glass-bead|snow|salt|sugar|brown-sugar|sand|flour|rice (a Table 1 grain)");
        (void)ex.opt_optional<std::string>("shape", "sphere|snow|crystal|rice|flake");
        (void)ex.opt_optional<std::string>("material", "dielectric|diffuse|absorbing-dielectric");
        (void)ex.opt_optional<std::string>("ior", "relative index of refraction (dielectrics)", "1.5");
        (void)ex.opt_optional<std::string>("albedo", "Lambertian albedo (diffuse), A or r,g,b", "0.8");
        (void)ex.opt_optional<std::string>("interior-sigma-a", "absorption inside the grain per bounding radius, S or r,g,b", "0");
        (void)ex.opt_optional<std::string>("interior-sigma-s", "scattering inside the grain per bounding radius, S or r,g,b", "0");
        (void)ex.opt_optional<std::string>("interior-g", "HG asymmetry of the interior scattering", "0");
        (void)ex.opt_optional<std::string>("grain-radius", "radius R of the grain's bounding sphere, 0 < R <= 1");
        (void)ex.opt_optional<std::string>("grain-seed", "seed of the procedural shape", "1");
        const auto level = ex.opt<std::uint64_t>("mesh-level", 5, "icosphere subdivision level of mesh grains (20*4^level triangles)");
        const auto rays = ex.opt<std::uint64_t>("rays", 200000, 2000000, "incident rays");
        (void)ex.opt_optional<std::string>("load", "FILE[,FILE...]: statistics saved earlier (.scat) instead of running the scatterometer");
        (void)ex.opt_optional<std::string>("weights", "w1,w2,...: mix the grains of --preset/--load (Meng15 Sec. 4.2.3); w >= 0, positive sum");
        ex.ready();
        const Cli& cli = ex.cli();
        const MpiSession& mpi = ex.mpi();
        const auto& out = ex.out();
        const int threads = ex.threads();

        // Where the statistics come from: saved files (--load), presets (--preset, a list mixes
        // them with --weights), or one grain described on the command line (--shape ...).
        auto split = [](const std::string& v) {
            std::vector<std::string> out;
            std::string item;
            std::stringstream ss(v);
            while (std::getline(ss, item, ',')) out.push_back(item);
            return out;
        };
        std::vector<gl::GrainStats> parts;
        std::vector<std::string> names;
        gl::GrainPreset grain;  // the single grain (for the summary line)
        std::string source;
        double secs = 0;
        gl::ScatterometerConfig cfg;
        cfg.rays = rays;
        cfg.seed = ex.seed();
        if (level > 7) throw cli_error("--mesh-level must be <= 7");
        auto run = [&](const gl::GrainPreset& g) {
            const auto scat = gl::ScatterometerGrain::procedural(g.shape, g.radius, g.material, g.seed, int(level));
            // This rank's contiguous share of the ray blocks (all of them on one rank).
            const auto [b0, b1] = mpi.block_range(gl::scatterometer_blocks(cfg.rays));
            constexpr std::uint64_t bs = gl::ScatterometerTally::block_size;
            auto bar = ex.progress("scatterometer " + g.name, std::min(cfg.rays, b1 * bs) - std::min(cfg.rays, b0 * bs));
            std::uint64_t last = 0;
            cfg.progress = [&](std::uint64_t done, std::uint64_t) {
                bar.advance(done - last);
                last = done;
            };
            const auto mine = gl::run_scatterometer_blocks(scat, cfg, b0, b1);
            const auto all = mpi.gather_bytes(encode_tally(mine));  // rank 0: every rank's, in rank order
            bar.done();
            secs += bar.seconds();
            if (!mpi.root()) return gl::GrainStats{};
            gl::ScatterometerTally tally = mpi.size() == 1 ? mine : decode_tally(all[0], cfg.grid);
            for (int r = 1; r < mpi.size(); ++r) tally.append(decode_tally(all[std::size_t(r)], cfg.grid));
            return gl::finish_scatterometer(cfg, tally);
        };
        const bool by_shape = cli.has("shape");
        if (int(cli.has("load")) + int(cli.has("preset")) + int(by_shape) != 1)
            throw cli_error("give exactly one of --preset, --shape or --load (see --help)");
        if (!by_shape)
            for (const char* o : {"material", "ior", "albedo", "interior-sigma-a", "interior-sigma-s", "interior-g",
                                  "grain-radius", "grain-seed"})
                if (cli.has(o)) throw cli_error(std::string("--") + o + " needs --shape (not --preset or --load)");
        // Check the mixing weights before any work (same rules as mix_grain_stats).
        if (cli.has("weights")) {
            const std::size_t n = cli.has("load")     ? split(cli.str("load")).size()
                                  : cli.has("preset") ? split(cli.str("preset")).size()
                                                      : 1;
            (void)gl::validate_mix_weights(cli.list("weights", {}), n);
        }
        if (cli.has("load")) {
            for (const auto& f : split(cli.str("load"))) {
                parts.push_back(gl::load_grain_stats(f));
                std::string n = std::filesystem::path(f).stem().string();
                if (n.rfind("grain_stats_", 0) == 0) n = n.substr(12);
                names.push_back(n);
            }
            source = "loaded from " + cli.str("load");
        } else if (cli.has("preset")) {
            for (const auto& n : split(cli.str("preset"))) {
                grain = gl::grain_preset(n);
                parts.push_back(run(grain));
                names.push_back(grain.name);
            }
        } else {
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
            parts.push_back(run(grain));
            names.push_back(grain.name);
        }
        if (!ex.root()) return ex.finish({});  // rank 0 mixes, writes and prints
        if (parts.empty()) throw cli_error("nothing to do: empty --preset/--load list");
        if (parts.size() > 1 && !cli.has("weights"))
            throw cli_error("a list of " + std::to_string(parts.size()) + " grains needs --weights (one per grain)");
        const bool mixed = cli.has("weights");
        gl::GrainStats stats;
        std::string label = names[0];
        if (mixed) {
            const auto w = cli.list("weights", {});
            stats = gl::mix_grain_stats(parts, w);  // validates: sizes, w >= 0, positive sum
            label = "mix";
            for (std::size_t k = 0; k < names.size(); ++k) label += "_" + names[k];
        } else {
            stats = parts[0];
        }

        // Files: statistics, per-channel phase table (density of cos theta per channel), plot.
        const std::string stem = "grain_stats_" + label;
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
        ex.plot("grain_stats", csv_path, out / (stem + "_phase.png"), {label});

        if (!source.empty() || mixed) {
            std::printf("grain %s (%s%s), %llu rays%s\n", label.c_str(), source.empty() ? "scatterometer" : source.c_str(),
                        mixed ? (", mixed with --weights " + cli.str("weights")).c_str() : "",
                        (unsigned long long)stats.rays, mixed ? " (smallest component)" : "");
        } else {
            std::printf("grain %s: shape %s, R = %.3f, material %s, %llu rays, seed %llu, %d threads, %.2f s (%.3g rays/s)\n",
                        grain.name.c_str(), std::string(gl::to_string(grain.shape)).c_str(), grain.radius,
                        std::string(gl::to_string(grain.material.kind)).c_str(), (unsigned long long)cfg.rays,
                        (unsigned long long)cfg.seed, threads, secs, double(cfg.rays) / std::max(secs, 1e-9));
        }
        std::printf("  beta         = %.4f +- %.4f\n", stats.beta(), stats.beta_stderr());
        std::printf("  lambda_delta = %.4f +- %.4f\n", stats.lambda_delta(), stats.lambda_delta_stderr());
        for (std::size_t c = 0; c < 3; ++c)
            std::printf("  channel %zu: alpha_s = %.4f +- %.4f, lambda_s = %.4f +- %.4f (signed %+.4f), g = %.4f\n", c,
                        stats.alpha_s(c), stats.alpha_s_stderr(c), stats.lambda_s(c), stats.teleport_along_stderr(c),
                        stats.teleport_along(c), stats.g(c));
        std::printf("  terminated (bounce limit or mesh leak, counted as absorbed): %.2g %.2g %.2g\n", stats.terminated[0],
                    stats.terminated[1], stats.terminated[2]);
        const auto* col = (parts.size() == 1 && source.empty()) ? gl::find_meng15_table1(grain.paper_column) : nullptr;
        if (col) {
            std::printf("  channel average vs Meng15 Table 1 (%s):\n", col->name);
            std::printf("    beta %.2f (paper %.2f), lambda_delta %.2f (paper %.2f), lambda_s %.2f (paper %.2f), alpha_s %.2f (paper %.2f)\n",
                        stats.beta(), col->beta, stats.lambda_delta(), col->lambda_delta, stats.lambda_s_avg(),
                        col->lambda_s, stats.alpha_s_avg(), col->alpha_s);
        }
        std::printf("  wrote %s, %s\n", (out / (stem + ".scat")).c_str(), csv_path.c_str());
        auto j = ex.summary();
        j.num("beta", stats.beta())
            .num("lambda_delta", stats.lambda_delta())
            .num("lambda_s", stats.lambda_s_avg())
            .num("alpha_s", stats.alpha_s_avg())
            .num("g", stats.g_avg());
        if (source.empty()) {          // the scatterometer ran (not --load)
            j.nums("rank_blocks", mpi.block_ranges(gl::scatterometer_blocks(cfg.rays)));  // [begin, end) per rank
        }
        return ex.finish(j);
    });
}
