// meng15_fig6_ept_free_flight: Meng15 Fig. 6 (bottom) with explicit path tracing of grains:
// free-flight distances between exit points of grain interactions, measured by EPT in an
// infinite procedural aggregate (tiled MD packing at f = 0.63, randomly rotated grains,
// integrators/ept.hpp) for three grains (pink salt, flour, sand), against the analytic
// exponential p_t(z) = sigma_t exp(-sigma_t z) of Eq. 4 with sigma_t from the scatterometer
// statistics of the same grain meshes. The paper's claim: the means match (vertical lines).
//
//   meng15_fig6_ept_free_flight [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//
// z = distance along the path from one interaction's exit point (bounding-sphere exit) to the
// next interaction's entry point, plus the teleport (x_o - x_i) . w_i weighted by the grain's
// channel-mean survival (0 if absorbed) -- the quantity whose mean Eq. 4 models as
// lambda_beta + alpha_s lambda_s. Writes CSV + PNG; prints the means beside Eq. 4 and the
// paper's hit probabilities; last line JSON.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/precompute/scatterometer.hpp"

namespace gl = grainlight;
using namespace gl_examples;

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig6_ept_free_flight",
               "Meng15 Fig. 6 bottom: EPT free flights in an infinite aggregate vs Eq. 4 (f = 0.63)",
               "out/meng15_fig6_ept_free_flight", [&](Example& ex) -> int {
        ex.ready();
        const bool full = ex.full();
        const auto& out = ex.out();
        const int threads = ex.threads();
        const std::uint64_t seed = ex.seed();
        const double f = 0.63;  // Meng15 Fig. 6 caption

        // Tile of unit bounding spheres.
        const auto packed = gl::md_pack(full ? 2000 : 400, f, seed);
        const double scale = 1.0 / packed.tile.radius();
        std::vector<gl::Vec3d> centers = packed.tile.centers();
        for (auto& c : centers) c *= scale;
        const gl::PeriodicTile tile(packed.tile.side() * scale, 1.0, std::move(centers));
        const double f_real = tile.packing_fraction();

        struct G {
            const char* preset;
            const char* label;
            double paper_beta;  // Meng15 Fig. 6 caption
        };
        const G grains[] = {{"salt", "pink salt", 0.53}, {"flour", "flour", 0.66}, {"sand", "sand", 0.63}};
        const int level = 4;  // same mesh for the scatterometer and the aggregate
        const std::uint64_t rays = full ? 1000000 : 100000;
        const std::uint64_t paths = full ? 40000 : 3000;
        const int per_path = 20, skip = 5, bins = 60;
        const double z_max = 8.0;
        std::printf("Meng15 Fig. 6 bottom (EPT), f = %.4f, %zu spheres per tile, %llu photon paths x %d interactions per grain\n",
                    f_real, tile.size(), (unsigned long long)paths, per_path);
        Json j = ex.summary();
        j.num("packing_rate", f_real);
        std::vector<std::string> header{"z"};
        std::vector<std::vector<double>> cols;
        double worst = 0;
        std::vector<std::string> means;  // preset:EPT mean:Eq. 4 mean, for the plot
        for (const auto& g : grains) {
            const gl::GrainPreset p = gl::grain_preset(g.preset);
            gl::ScatterometerConfig cfg;
            cfg.rays = rays;
            cfg.seed = seed;
            const auto stats =
                gl::run_scatterometer(gl::ScatterometerGrain::procedural(p.shape, p.radius, p.material, p.seed, level), cfg);
            const auto prm = gl::effective_rte_params(stats, f_real, 1.0);
            const double lambda_t = (prm.lambda_t[0] + prm.lambda_t[1] + prm.lambda_t[2]) / 3.0;
            using B = gl::EverywhereBoundary;
            const gl::GranularAggregate<B> agg(tile, gl::VoxelizedBoundary<B>({}, tile.side()),
                                               {gl::GrainExemplar::from_preset(p, level)}, {1.0}, seed);
            // Paths in blocks over threads; blocks reduced in order (thread-count independent).
            const std::uint64_t block = 250;
            struct Sums {
                double n = 0, s = 0, s2 = 0;
                std::vector<double> hist;
            };
            const Sums sums = ex.parallel<Sums>(
                std::string("fig6-ept ") + g.preset, paths, block,
                [&](std::uint64_t b, std::uint64_t begin, std::uint64_t end) {
                    Sums part;
                    const gl::FreeFlightStats pt = gl::ept_free_flights(agg, end - begin, skip, per_path,
                                                                        gl::hash_words(seed, b), bins, z_max);
                    const double m = double(pt.samples);
                    part.n = m;
                    part.s = pt.mean * m;
                    part.s2 = (pt.stderr_mean * pt.stderr_mean * m + pt.mean * pt.mean) * m;
                    part.hist.resize(std::size_t(bins));
                    for (int i = 0; i < bins; ++i) part.hist[std::size_t(i)] = pt.hist[std::size_t(i)] * m;
                    return part;
                },
                [&](Sums& acc, const Sums& part) {
                    acc.n += part.n;
                    acc.s += part.s;
                    acc.s2 += part.s2;
                    for (int i = 0; i < bins; ++i) acc.hist[std::size_t(i)] += part.hist[std::size_t(i)];
                },
                Sums{0, 0, 0, std::vector<double>(std::size_t(bins), 0.0)});
            const double n = sums.n, s = sums.s, s2 = sums.s2;
            std::vector<double> hist = sums.hist;
            const double mean = s / n, se = std::sqrt(std::max(0.0, s2 / n - mean * mean) / n);
            for (auto& h : hist) h /= n;
            const double rel = mean / lambda_t - 1.0;
            worst = std::max(worst, std::abs(rel));
            std::printf("%-9s: beta = %.2f (paper %.2f), alpha_s = %.2f; mean free path EPT = %.4f +- %.4f R vs Eq. 4 "
                        "1/sigma_t = %.4f R (%+.1f %%; issue target: within 5 %%)\n",
                        g.label, stats.beta(), g.paper_beta, stats.alpha_s_avg(), mean, se, lambda_t, 100 * rel);
            std::vector<double> ce(bins), ca(bins);
            for (int i = 0; i < bins; ++i) {
                const double z = (i + 0.5) * z_max / bins;
                ce[std::size_t(i)] = hist[std::size_t(i)];
                ca[std::size_t(i)] = std::exp(-z / lambda_t) / lambda_t;
            }
            means.push_back(std::string(g.preset) + ":" + std::to_string(mean) + ":" + std::to_string(lambda_t));
            header.push_back(std::string(g.preset) + "_ept");
            header.push_back(std::string(g.preset) + "_eq4");
            cols.push_back(ce);
            cols.push_back(ca);
            j.num(std::string(g.preset) + "_ept_mean", mean)
                .num(std::string(g.preset) + "_ept_stderr", se)
                .num(std::string(g.preset) + "_eq4_mean", lambda_t)
                .num(std::string(g.preset) + "_beta", stats.beta());
        }
        Csv csv(header);
        for (int i = 0; i < bins; ++i) {
            std::vector<double> row{(i + 0.5) * z_max / bins};
            for (const auto& c : cols) row.push_back(c[std::size_t(i)]);
            csv.row(row);
        }
        const auto csv_path = ex.csv("meng15_fig6_ept_free_flight.csv", csv);
        ex.plot("meng15_fig6_ept_free_flight", csv_path, out / "meng15_fig6_ept_free_flight.png", means);
        j.num("max_rel_mean_error", worst);
        std::printf("wrote %s and meng15_fig6_ept_free_flight.png (%d threads)\n", csv_path.c_str(), threads);
        return ex.finish(j);
    });
}
