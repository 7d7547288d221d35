// guo21_fig8_phase: Guo21 Fig. 8 (top), ensemble phase functions (Eq. 17) of ice particles
// (eta = 1.31 in air, Sec. 6) for a few size distributions, at three wavelengths, computed with
// the bulk integration of optics/bulk.hpp (Mie below r = 2 um, GOA above, Eqs. 16-17).
//
//   guo21_fig8_phase [--quality quick|full] [--out DIR]
//
// PSDs: radii uniform in [0.1, 1], [1, 10] and [10, 100] um (the paper samples radii uniformly
// between r_min and r_max, its footnote 7), and a log-normal r_g = 10 um, sigma_g = 2 truncated to
// [0.1, 2000] um (Sec. 6's r_max). The paper shows these as pictures without numbers; printed
// here: sigma_t / N, single-scattering albedo, g and the phase function at 0, 90, 180 deg, plus
// the computing time (Sec. 4: bulk properties fast enough to evaluate on the fly).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/optics/bulk.hpp"

int main(int argc, char** argv) {
    return gl_examples::run(argc, argv, "guo21_fig8_phase",
                            "Guo21 Fig. 8: ensemble phase functions of a few PSDs",
                            [&](gl_examples::Example& ex) -> int {
        ex.ready();
        const bool full = ex.full();
        const auto& out = ex.out();
        grainlight::ParticleModel ice;
        ice.particle_index = {1.31, 0.0};
        const std::vector<double> wl = {0.45, 0.55, 0.65};
        grainlight::BulkSettings settings;
        if (full) settings.rel_tol = 1e-4;
        struct Case {
            std::string name;
            grainlight::BulkOptics bulk;
            double seconds;
        };
        std::vector<Case> cases;
        auto run = [&](const std::string& name, const auto& psd) {
            const auto t0 = std::chrono::steady_clock::now();
            auto b = grainlight::compute_bulk_optics(psd, ice, wl, settings);
            cases.push_back({name, std::move(b), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()});
        };
        auto uniform = [](double a, double b) {
            const std::vector<double> r = {a, b}, d = {1.0, 1.0};
            return grainlight::TabulatedPsd(r, d);
        };
        run("uniform_0.1_1", uniform(0.1, 1.0));
        run("uniform_1_10", uniform(1.0, 10.0));
        run("uniform_10_100", uniform(10.0, 100.0));
        run("lognormal_10_2", grainlight::LogNormalPsd(10.0, 2.0, 0.1, 2000.0));

        // All cases share one wavelength set but each has its own theta grid: resample onto a common
        // plotting grid by linear interpolation in theta.
        std::vector<double> grid;
        for (int i = 0; i <= 400; ++i) grid.push_back(std::pow(10.0, -3 + std::log10(180.0e3) * i / 400.0));  // 1e-3 .. 180 deg
        std::vector<std::string> header = {"theta_deg"};
        for (const auto& c : cases) header.push_back("phase_" + c.name + "_550nm");
        gl_examples::Csv csv(header);
        auto interp = [](const std::vector<double>& x, const std::vector<double>& y, double t) {
            std::size_t i = std::size_t(std::lower_bound(x.begin(), x.end(), t) - x.begin());
            if (i == 0) return y.front();
            if (i >= x.size()) return y.back();
            const double w = (t - x[i - 1]) / (x[i] - x[i - 1]);
            return y[i - 1] + w * (y[i] - y[i - 1]);
        };
        const double pi = 3.14159265358979323846;
        for (double deg : grid) {
            std::vector<double> row = {deg};
            for (const auto& c : cases) row.push_back(interp(c.bulk.theta, c.bulk.channels[1].phase, std::min(deg, 180.0) * pi / 180));
            csv.row(row);
        }
        const auto csv_path = ex.csv("guo21_fig8_phase.csv", csv);
        ex.plot("guo21_fig8_phase", csv_path, out / "guo21_fig8_phase.png");

        std::printf("Guo21 Fig. 8: ensemble phase functions, ice eta = 1.31, wavelengths 450/550/650 nm\n");
        std::printf("  %-16s %6s %12s %8s %8s %12s %12s %12s %8s\n", "PSD", "lambda", "<C_t> um^2", "albedo", "g",
                    "p(0) [1/sr]", "p(90)", "p(180)", "time[s]");
        gl_examples::Json j = ex.summary();
        for (const auto& c : cases) {
            for (const auto& ch : c.bulk.channels) {
                const double p90 = interp(c.bulk.theta, ch.phase, pi / 2);
                std::printf("  %-16s %6.2f %12.4g %8.4f %8.4f %12.4g %12.4g %12.4g %8.2f\n", c.name.c_str(),
                            ch.wavelength_um, ch.mean_C_t, ch.mean_C_s / ch.mean_C_t, ch.g, ch.phase.front(), p90,
                            ch.phase.back(), c.seconds);
            }
            j.num("g_" + c.name + "_550nm", c.bulk.channels[1].g).num("seconds_" + c.name, c.seconds);
        }
        std::printf("  paper: phase functions become more forward-peaked as radii grow (Fig. 8 top); no numbers given.\n");
        return ex.finish(j);
    });
}
