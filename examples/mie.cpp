// mie: command-line Lorenz-Mie / GOA calculator for one sphere (Guo21 Sec. 3).
//
//   mie --n 1.5 --k 0 --x 10 --angles 0,30,60,90,120,150,180 [--method mie|goa|auto]
//   mie --n 1.33 --radius-um 5 --wavelength-um 0.6 --host-index 1 --method auto
//
// n + i k is the particle's index relative to the host (k >= 0 absorbs); angles in degrees;
// x = 2 pi N R / L with L the vacuum wavelength and N the host index. `auto` uses GOA from
// r = 2 um on (Guo21 Sec. 3.3) where GOA is valid (x >= 45, or 100 for k > 2, and phase shift
// 2 x |m - 1| >= 6; optics/goa.hpp goa_validity) and exact Mie elsewhere; it needs --radius-um.
// `goa` outside that range still computes but prints a warning line on stderr, and refuses
// (exit code 2) where GOA's Qext or Qsca would be negative.
// The last line of stdout is one JSON object:
//   {"qext":..,"qsca":..,"qabs":..,"qback":..,"g":..,"S1":[[re,im],..],"S2":[[re,im],..],"method":..,
//    "goa_valid":..,"phase_shift":..}
// S1, S2 in van de Hulst's convention (Re S(0) = x^2 Qext / 4; optics/lorenz_mie.hpp).
#include <cmath>
#include <complex>
#include <optional>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "common/cli.hpp"
#include "common/output.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/particle.hpp"

namespace {

std::string complex_list(const std::vector<std::complex<double>>& v) {
    std::ostringstream os;
    os.precision(10);
    os << "[";
    for (std::size_t i = 0; i < v.size(); ++i) os << (i ? "," : "") << "[" << v[i].real() << "," << v[i].imag() << "]";
    os << "]";
    return os.str();
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run_main("mie", [&] {
        using gl_examples::cli_error;
        gl_examples::Cli cli(argc, argv, "mie", "Lorenz-Mie / GOA scattering by one sphere (Guo21 Sec. 3)");
        cli.option("n", "real part of the particle index relative to the host (> 0)", "1.5")
            .option("k", "absorption index (imaginary part, >= 0)", "0")
            .option("x", "size parameter 2 pi N R / L (> 0); or give --radius-um")
            .option("radius-um", "particle radius R [um] (> 0)")
            .option("wavelength-um", "vacuum wavelength L [um] (> 0)", "0.6")
            .option("host-index", "host refractive index N (> 0)", "1")
            .option("angles", "scattering angles in degrees, comma-separated, each in [0, 180]",
                    "0,30,60,90,120,150,180")
            .option("method", "mie | goa | auto (auto: GOA from r = 2 um on where GOA is valid, Mie elsewhere; needs --radius-um)", "mie")
            .option("p-max", "highest GOA order p", "3")
            .option("out", "if given: also write DIR/mie.csv (S1, S2 at 0..180 deg, 0.5-deg steps) and DIR/mie.png");
        cli.finish();

        const double n = cli.num("n", 1.5), k = cli.num("k", 0.0);
        if (!(std::isfinite(n) && n > 0)) throw cli_error("--n = " + cli.str("n") + " must be a finite number > 0");
        if (!(std::isfinite(k) && k >= 0)) throw cli_error("--k = " + cli.str("k") + " must be a finite number >= 0");
        const std::string method = cli.str("method", "mie");
        if (method != "mie" && method != "goa" && method != "auto")
            throw cli_error("--method = '" + method + "' is unknown; use mie, goa or auto");
        const auto p_max = cli.integer("p-max", 3);
        if (p_max > 1000) throw cli_error("--p-max = " + cli.str("p-max") + " must be <= 1000");

        double x = 0, radius = -1;
        if (cli.has("x") && cli.has("radius-um")) throw cli_error("give either --x or --radius-um, not both");
        if (cli.has("x")) {
            x = cli.num("x");
            if (!(std::isfinite(x) && x > 0)) throw cli_error("--x = " + cli.str("x") + " must be a finite number > 0");
        } else if (cli.has("radius-um")) {
            radius = cli.num("radius-um");
            const double lambda = cli.num("wavelength-um", 0.6), host = cli.num("host-index", 1.0);
            if (!(std::isfinite(radius) && radius > 0))
                throw cli_error("--radius-um = " + cli.str("radius-um") + " must be a finite number > 0");
            if (!(std::isfinite(lambda) && lambda > 0))
                throw cli_error("--wavelength-um = " + cli.str("wavelength-um") + " must be a finite number > 0");
            if (!(std::isfinite(host) && host > 0))
                throw cli_error("--host-index = " + cli.str("host-index") + " must be a finite number > 0");
            x = 2 * grainlight::pi_v<double> * host * radius / lambda;
        } else {
            throw cli_error("missing --x (or --radius-um with --wavelength-um and --host-index)");
        }
        if (x > 1e6) throw cli_error("size parameter x = " + std::to_string(x) + " is too large (<= 1e6)");

        std::string used = method;
        const std::complex<double> m(n, k);
        if (method == "auto") {
            if (radius < 0) throw cli_error("--method auto needs --radius-um (it switches at r = 2 um)");
            grainlight::ParticleModel model;
            model.particle_index = m;  // --n, --k are relative to the host: host index 1 for m
            model.host_index = 1.0;
            const double lambda_rel = 2 * grainlight::pi_v<double> * radius / x;  // same x as above
            used = model.method_at(radius, lambda_rel) == grainlight::ScatteringMethod::goa ? "goa" : "mie";
        }
        if (used == "goa" && n == 1.0) throw cli_error("--n = 1 has no geometric rays; use --method mie");
        const grainlight::GoaValidity validity = grainlight::goa_validity(m, x);

        const auto angles = cli.list("angles", {0, 30, 60, 90, 120, 150, 180});
        for (double a : angles)
            if (!(a >= 0 && a <= 180)) throw cli_error("--angles: " + std::to_string(a) + " is not in [0, 180] degrees");

        const double pi = grainlight::pi_v<double>;
        std::vector<std::complex<double>> s1, s2;
        grainlight::MieEfficiencies q;
        if (used == "mie") {
            const grainlight::LorenzMie mie(m, x);
            q = mie.efficiencies();
            for (double a : angles) {
                const double mu = a == 0 ? 1.0 : a == 180 ? -1.0 : std::cos(a * pi / 180);
                const auto s = mie.amplitudes(mu);
                s1.push_back(s.S1);
                s2.push_back(s.S2);
            }
        } else {
            const grainlight::Goa goa(m, x, int(p_max));
            if (!validity.valid)
                std::cerr << "mie: warning: GOA is outside its validity range at x = " << x
                          << ", phase shift 2 x |m - 1| = " << validity.phase_shift << " (valid for x >= "
                          << validity.min_size_parameter << " and 2 x |m - 1| >= " << grainlight::goa_valid_phase_shift
                          << "); Qext may be off by more than 15 %: use --method mie or auto\n";
            const auto e = grainlight::goa_efficiencies(goa);  // throws where Qext or Qsca < 0
            q.qext = e.qext;
            q.qabs = e.qabs;
            q.qsca = e.qsca;
            q.qback = 4 * std::norm(goa.amplitudes_at_angle(pi).S1) / (x * x);
            q.g = grainlight::goa_asymmetry_parameter(goa);
            for (double a : angles) {
                const auto s = goa.amplitudes_at_angle(a * pi / 180);
                s1.push_back(s.S1);
                s2.push_back(s.S2);
            }
        }
        if (cli.has("out")) {
            // Angular table and plot of log10 |S1|, |S2| (the calculator's figure).
            const auto dir = cli.out_dir();
            gl_examples::Csv csv({"theta_deg", "re_S1", "im_S1", "re_S2", "im_S2", "intensity"});
            std::optional<grainlight::LorenzMie> mie;
            std::optional<grainlight::Goa> goa;
            if (used == "mie") mie.emplace(m, x); else goa.emplace(m, x, int(p_max));
            for (int i = 0; i <= 360; ++i) {
                const double th = i * pi / 360;
                const auto s = mie ? mie->amplitudes(i == 0 ? 1.0 : i == 360 ? -1.0 : std::cos(th)) : goa->amplitudes_at_angle(th);
                csv.row({0.5 * i, s.S1.real(), s.S1.imag(), s.S2.real(), s.S2.imag(), std::norm(s.S1) + std::norm(s.S2)});
            }
            const auto csv_path = dir / "mie.csv";
            csv.write(csv_path);
            const auto png = dir / "mie.png";
            gl_examples::plot_with_matplotlib(
                dir / "mie.py",
                "d = read_csv(r'''" + csv_path.string() + "''')\n"
                "s1 = np.hypot(d['re_S1'], d['im_S1']); s2 = np.hypot(d['re_S2'], d['im_S2'])\n"
                "fig, ax = plt.subplots(figsize=(6, 4))\n"
                "ax.semilogy(d['theta_deg'], s1, label='|S1|'); ax.semilogy(d['theta_deg'], s2, label='|S2|')\n"
                "ax.set_xlabel('scattering angle [deg]'); ax.legend()\n"
                "ax.set_title('" + used + ": m = " + cli.str("n", "1.5") + " + " + cli.str("k", "0") + " i, x = " +
                    std::to_string(x) + "')\n"
                "fig.tight_layout(); fig.savefig(png, dpi=110)\n",
                png);
        }
        std::cout << "mie: m = " << n << " + " << k << " i, x = " << x << ", method " << used << "\n";
        gl_examples::Json j;
        j.num("qext", q.qext).num("qsca", q.qsca).num("qabs", q.qabs).num("qback", q.qback).num("g", q.g);
        j.raw("S1", complex_list(s1)).raw("S2", complex_list(s2)).str("method", used);
        j.boolean("goa_valid", validity.valid).num("phase_shift", validity.phase_shift);
        std::cout << j.str() << std::endl;
        return 0;
    });
}
