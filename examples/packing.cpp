// packing: generate a periodic tile of equal spheres at a packing rate with the event-driven MD
// packer (Lubachevsky-Stillinger growth, Skoge et al. 2006; Meng15 Sec. 3.1), check it, measure
// its mean outer chord and compare with 4R(1-f)/(3f) (Meng15 Eq. 1, exact mean for equal spheres).
//
//   packing --fraction F --spheres N --seed S [--out FILE] [--quality quick|full] [--threads T]
//
// F must be in (0, 0.64). A rate the packer cannot reach stops at jamming with a warning on
// stderr; the reported fraction is the one achieved. Spheres have unit radius (the tile side
// follows from N and the rate). --out names the tile FILE to write (grainlight container, kind
// TILE); without it nothing is written. Prints one JSON line (the last line of stdout):
//   {"fraction":..,"spheres":..,"min_center_distance_over_diameter":..,"mean_chord":..,
//    "dixmier_mean_chord":..,"seconds":..}
// seconds is the packing time; mean_chord is measured on the tile's infinite tiling along random
// lines (ratio estimator: void length / sphere entries).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/packing.hpp"

int main(int argc, char** argv) {
    const gl_examples::OutOption out_option{"", "tile FILE to write (grainlight container, kind TILE); none without it"};
    return gl_examples::run(argc, argv, "packing",
                            "periodic tile of equal spheres by event-driven MD (Skoge et al. 2006), checked", out_option,
                            [&](gl_examples::Example& ex) -> int {
        const double fraction = ex.opt<double>("fraction", 0.63, "packing rate in (0, 0.64)");
        const std::uint64_t n = ex.opt<std::uint64_t>("spheres", 2000, "number of spheres in the tile (>= 2)");
        grainlight::MdPackerOptions opt;
        opt.growth_rate =
            ex.opt<double>("growth-rate", 0.03, "dimensionless Lubachevsky-Stillinger growth rate (> 0)");
        ex.ready(gl_examples::Example::OutKind::file);  // --out names the tile FILE
        if (!(fraction > 0 && fraction < grainlight::md_max_fraction))
            throw gl_examples::cli_error("--fraction = " + (ex.given("fraction") ? ex.given_text("fraction") : "0.63") +
                                         " is outside (0, 0.64) (random close packing is ~0.64)");
        if (n < 2 || n > 50000000)
            throw gl_examples::cli_error("--spheres = " + std::to_string(n) + " must be in [2, 5e7]");
        if (!(opt.growth_rate > 0 && std::isfinite(opt.growth_rate)))
            throw gl_examples::cli_error("--growth-rate = " + ex.given_text("growth-rate") + " must be > 0");
        const std::uint64_t seed = ex.seed();
        const bool full = ex.full();
        const std::string out_file = ex.out().string();

        // ---- pack (progress: rate reached so far) ---------------------------------------------
        const auto t0 = std::chrono::steady_clock::now();
        gl_examples::ProgressBar bar("packing", 1000);
        std::uint64_t shown = 0;
        const double f_start = std::min(opt.initial_fraction, 0.8 * fraction);  // md_pack's RSA start
        auto progress = [&](double f) {
            const double u = (f - f_start) / (fraction - f_start);
            const auto now = static_cast<std::uint64_t>(std::clamp(u, 0.0, 1.0) * 1000.0);
            if (now > shown) {
                bar.advance(now - shown);
                shown = now;
            }
        };
        const grainlight::MdPackResult res = grainlight::md_pack(std::size_t(n), fraction, seed, opt, 1.0, progress);
        bar.done();
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (!res.reached_target)
            std::cerr << "packing: warning: the packing jammed at f = " << res.fraction << " (reduced pressure "
                      << res.reduced_pressure << ") below the requested " << fraction
                      << "; reporting the rate achieved\n";

        // Unit-radius spheres: rescale the unit-cube tile by 1/R.
        const double s = 1.0 / res.tile.radius();
        std::vector<grainlight::Vec3d> centers = res.tile.centers();
        for (auto& c : centers) c *= s;
        const grainlight::PeriodicTile tile(res.tile.side() * s, 1.0, std::move(centers));
        if (!out_file.empty()) tile.save(out_file);

        // ---- checks: minimum distance and mean outer chord ------------------------------------
        const double dmin_over_d = tile.min_center_distance() / (2.0 * tile.radius());
        const double f = tile.packing_fraction();
        const double exact = grainlight::dixmier_mean_chord(1.0, f);
        const int blocks = 64;
        const std::uint64_t lines_per_block = full ? 500 : 100;
        const grainlight::ChordMeasurement total = ex.parallel<grainlight::ChordMeasurement>(
            "chords", std::uint64_t(blocks), 1,
            [&](std::uint64_t b, std::uint64_t, std::uint64_t) {
                grainlight::Rng rng = grainlight::Rng::from_key(seed, 0x63686f7264ull /* "chord" */, b);
                return grainlight::measure_outer_chords(tile, lines_per_block, 50.0 * exact, rng);
            },
            [](grainlight::ChordMeasurement& acc, const grainlight::ChordMeasurement& p) { acc.merge(p); });

        std::cerr << "packing: " << n << " spheres, f = " << f << " (requested " << fraction << "), "
                  << res.collisions << " collisions, " << seconds << " s; mean outer chord " << total.mean()
                  << " R vs 4R(1-f)/(3f) = " << exact << " R (" << 100.0 * (total.mean() / exact - 1.0)
                  << " %), " << total.entries << " chords\n";
        gl_examples::Json j = ex.summary();
        j.num("fraction", f)
            .integer("spheres", (long long)n)
            .num("min_center_distance_over_diameter", dmin_over_d)
            .num("mean_chord", total.mean())
            .num("dixmier_mean_chord", exact)
            .num("seconds", seconds)
            .num("requested_fraction", fraction)
            .boolean("reached_target", res.reached_target)
            .num("reduced_pressure", res.reduced_pressure)
            .num("shrink_factor", res.shrink_factor)
            .integer("collisions", (long long)res.collisions)
            .integer("chords", (long long)total.entries);
        return ex.finish(j);
    });
}
