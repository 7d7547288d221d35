// meng15_fig6_free_flight: Meng15 Fig. 6 at packing rate f = 0.63.
//  top:    outer chord lengths p_b(z) between packed spheres (Monte Carlo on a periodic MD
//          packing, packing/chord_lengths.hpp) vs Dixmier's exponential (Eq. 1);
//  bottom: the free-flight distribution p_t(z) of the teleportation-transport medium
//          (media/teleportation.hpp) for three grains (pink salt, flour, sand) vs its analytic
//          exponential sigma_t exp(-sigma_t z) with sigma_t from Eq. 4. (The paper's bottom
//          panel compares Eq. 4 with explicit path tracing of grains; that curve joins when an
//          explicit-grain tracer exists.)
//
//   meng15_fig6_free_flight [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//
// z of the bottom panel is the displacement along the incident direction from one grain
// interaction's exit point to the next one's exit point (to the entry point if the grain absorbs
// the path), whose mean is Eq. 4's lambda_beta + alpha_s lambda_s. Writes CSV + PNG, prints the
// means and the paper's hit probabilities, then one JSON line.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/precompute/scatterometer.hpp"
#include "grainlight/packing/chord_lengths.hpp"
#include "grainlight/packing/md_packer.hpp"

namespace gl = grainlight;
using namespace gl_examples;

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig6_free_flight",
               "Meng15 Fig. 6: p_b(z) of the packing and p_t(z) of the TT medium at f = 0.63",
               "out/meng15_fig6_free_flight", [&](Example& ex) -> int {
        ex.ready();
        const bool full = ex.full();
        const auto& out = ex.out();
        const int threads = ex.threads();
        const std::uint64_t seed = ex.seed();
        const double f = 0.63;  // Meng15 Fig. 6: "The packing rate is f = 0.63 for all grain types."

        // ---- top: chords of a packing of unit spheres ------------------------------------------
        const std::size_t n_spheres = full ? 4000 : 500;
        auto bar = ex.progress("fig6", 4);
        const auto packed = gl::md_pack(n_spheres, f, seed);
        const double scale = 1.0 / packed.tile.radius();
        std::vector<gl::Vec3d> centers = packed.tile.centers();
        for (auto& c : centers) c *= scale;
        const gl::PeriodicTile tile(packed.tile.side() * scale, 1.0, std::move(centers));
        const double f_real = tile.packing_fraction();
        const double zmax_b = 6.0;
        const std::size_t bins_b = 60;
        gl::Histogram hb(0.0, zmax_b, bins_b);
        gl::Rng rng_b = gl::Rng::from_key(seed, 0xf16);
        const auto meas = gl::measure_outer_chords(tile, full ? 20000 : 3000, 40.0, rng_b, [&](double z) { hb.add(z); });
        bar.advance();
        const double lambda_b = 1.0 / gl::bounding_sphere_sigma_b(f_real, 1.0);
        Csv top({"z", "p_b_measured", "p_b_dixmier"});
        for (std::size_t i = 0; i < bins_b; ++i) {
            const double z = (double(i) + 0.5) * zmax_b / double(bins_b);
            top.row({z, hb.density(i), std::exp(-z / lambda_b) / lambda_b});
        }
        const auto top_csv = ex.csv("meng15_fig6_top_chords.csv", top);

        // ---- bottom: TT medium free flights for three grains ----------------------------------
        struct G {
            const char* preset;
            const char* label;
            double paper_beta;  // Meng15 Fig. 6 caption
        };
        const G grains[] = {{"salt", "pink salt", 0.53}, {"flour", "flour", 0.66}, {"sand", "sand", 0.63}};
        const double zmax = 8.0;
        const std::size_t bins = 80;
        std::vector<std::string> header{"z"};
        for (const auto& g : grains) {
            header.push_back(std::string(g.preset) + "_tt");
            header.push_back(std::string(g.preset) + "_eq4");
        }
        std::vector<std::vector<double>> cols;
        std::printf("Meng15 Fig. 6, f = %.2f (packing reached %.4f with %zu spheres)\n", f, f_real, n_spheres);
        std::printf("top: mean outer chord measured %.4f vs Dixmier/Eq. 1 lambda_b = 4R(1-f)/(3f) = %.4f (%llu chords)\n",
                    meas.mean(), lambda_b, (unsigned long long)meas.complete_chords);
        Json j = ex.summary();
        j.num("packing_rate", f_real).num("chord_mean", meas.mean()).num("lambda_b", lambda_b);
        const std::uint64_t rays = full ? 1000000 : 100000;
        const int flights = full ? 2000000 : 400000;
        for (const auto& g : grains) {
            const gl::GrainPreset p = gl::grain_preset(g.preset);
            gl::ScatterometerConfig cfg;
            cfg.rays = rays;
            cfg.seed = seed;
            const auto stats = gl::run_scatterometer(gl::ScatterometerGrain::procedural(p.shape, p.radius, p.material, p.seed, 5), cfg);
            const gl::TeleportationMedium<float> tt(stats, f, 1.0);
            const double sigma_t = (tt.params().sigma_t[0] + tt.params().sigma_t[1] + tt.params().sigma_t[2]) / 3.0;
            gl::Histogram h(0.0, zmax, bins);
            gl::Welford mean;
            gl::Rng rng = gl::Rng::from_key(seed, 0x7e1e, std::uint64_t(&g - grains));
            const gl::Ray<float> ray(gl::Vec3f(0.0f), gl::Vec3f(0, 0, 1));
            for (int i = 0; i < flights; ++i) {
                const auto it = tt.sample_interaction(ray, std::numeric_limits<float>::infinity(), rng);
                const double z = double(it.p.z);
                h.add(z);
                mean.add(z);
            }
            std::vector<double> c_tt(bins), c_eq(bins);
            for (std::size_t i = 0; i < bins; ++i) {
                const double z = (double(i) + 0.5) * zmax / double(bins);
                c_tt[i] = h.density(i);
                c_eq[i] = sigma_t * std::exp(-sigma_t * z);
            }
            cols.push_back(c_tt);
            cols.push_back(c_eq);
            std::printf("bottom %-9s: beta = %.2f (paper %.2f), alpha_s = %.2f, mean free flight TT = %.4f +- %.4f vs "
                        "Eq. 4 1/sigma_t = %.4f\n",
                        g.label, stats.beta(), g.paper_beta, stats.alpha_s_avg(), mean.mean(), mean.standard_error(),
                        1.0 / sigma_t);
            j.num(std::string(g.preset) + "_beta", stats.beta())
                .num(std::string(g.preset) + "_tt_mean", mean.mean())
                .num(std::string(g.preset) + "_eq4_mean", 1.0 / sigma_t);
            bar.advance();
        }
        bar.done();
        Csv bottom(header);
        for (std::size_t i = 0; i < bins; ++i) {
            std::vector<double> row{(double(i) + 0.5) * zmax / double(bins)};
            for (const auto& c : cols) row.push_back(c[i]);
            bottom.row(row);
        }
        const auto bottom_csv = ex.csv("meng15_fig6_bottom_free_flight.csv", bottom);
        ex.plot("meng15_fig6_free_flight", top_csv, out / "meng15_fig6_free_flight.png", {bottom_csv.string()});
        std::printf("wrote %s, meng15_fig6_top_chords.csv, meng15_fig6_free_flight.png (%d threads)\n", bottom_csv.c_str(), threads);
        return ex.finish(j);
    });
}
