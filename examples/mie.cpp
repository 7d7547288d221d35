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

#include "common/harness.hpp"
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
    const gl_examples::OutOption out_option{
        "", "if given: also write DIR/mie.csv (S1, S2 at 0..180 deg, 0.5-deg steps) and DIR/mie.png"};
    return gl_examples::run(argc, argv, "mie", "Lorenz-Mie / GOA scattering by one sphere (Guo21 Sec. 3)", out_option,
                            [&](gl_examples::Example& ex) -> int {
        using gl_examples::cli_error;
        const double n = ex.opt<double>("n", 1.5, "real part of the particle index relative to the host (> 0)");
        const double k = ex.opt<double>("k", 0.0, "absorption index (imaginary part, >= 0)");
        const auto x_arg = ex.opt_optional<double>("x", "size parameter 2 pi N R / L (> 0); or give --radius-um");
        const auto radius_arg = ex.opt_optional<double>("radius-um", "particle radius R [um] (> 0)");
        const double lambda = ex.opt<double>("wavelength-um", 0.6, "vacuum wavelength L [um] (> 0)");
        const double host = ex.opt<double>("host-index", 1.0, "host refractive index N (> 0)");
        const auto angles = ex.opt<std::vector<double>>(
            "angles", {0, 30, 60, 90, 120, 150, 180}, "scattering angles in degrees, comma-separated, each in [0, 180]");
        const std::string method = ex.opt<std::string>(
            "method", "mie",
            "mie | goa | auto (auto: GOA from r = 2 um on where GOA is valid, Mie elsewhere; needs --radius-um)");
        const auto p_max = ex.opt<std::uint64_t>("p-max", 3, "highest GOA order p");
        ex.ready(gl_examples::Example::OutKind::optional_directory);

        if (!(std::isfinite(n) && n > 0)) throw cli_error("--n = " + ex.given_text("n") + " must be a finite number > 0");
        if (!(std::isfinite(k) && k >= 0)) throw cli_error("--k = " + ex.given_text("k") + " must be a finite number >= 0");
        if (method != "mie" && method != "goa" && method != "auto")
            throw cli_error("--method = '" + method + "' is unknown; use mie, goa or auto");
        if (p_max > 1000) throw cli_error("--p-max = " + ex.given_text("p-max") + " must be <= 1000");

        double x = 0, radius = -1;
        if (x_arg && radius_arg) throw cli_error("give either --x or --radius-um, not both");
        if (x_arg) {
            x = *x_arg;
            if (!(std::isfinite(x) && x > 0)) throw cli_error("--x = " + ex.given_text("x") + " must be a finite number > 0");
        } else if (radius_arg) {
            radius = *radius_arg;
            if (!(std::isfinite(radius) && radius > 0))
                throw cli_error("--radius-um = " + ex.given_text("radius-um") + " must be a finite number > 0");
            if (!(std::isfinite(lambda) && lambda > 0))
                throw cli_error("--wavelength-um = " + ex.given_text("wavelength-um") + " must be a finite number > 0");
            if (!(std::isfinite(host) && host > 0))
                throw cli_error("--host-index = " + ex.given_text("host-index") + " must be a finite number > 0");
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
        if (ex.given("out")) {
            // Angular table and plot of log10 |S1|, |S2| (the calculator's figure).
            gl_examples::Csv csv({"theta_deg", "re_S1", "im_S1", "re_S2", "im_S2", "intensity"});
            std::optional<grainlight::LorenzMie> mie;
            std::optional<grainlight::Goa> goa;
            if (used == "mie") mie.emplace(m, x); else goa.emplace(m, x, int(p_max));
            for (int i = 0; i <= 360; ++i) {
                const double th = i * pi / 360;
                const auto s = mie ? mie->amplitudes(i == 0 ? 1.0 : i == 360 ? -1.0 : std::cos(th)) : goa->amplitudes_at_angle(th);
                csv.row({0.5 * i, s.S1.real(), s.S1.imag(), s.S2.real(), s.S2.imag(), std::norm(s.S1) + std::norm(s.S2)});
            }
            const auto csv_path = ex.csv("mie.csv", csv);
            const std::string n_text = ex.given("n") ? ex.given_text("n") : "1.5";
            const std::string k_text = ex.given("k") ? ex.given_text("k") : "0";
            ex.plot("mie", csv_path, ex.out() / "mie.png",
                    {used + ": m = " + n_text + " + " + k_text + " i, x = " + std::to_string(x)});
        }
        std::cout << "mie: m = " << n << " + " << k << " i, x = " << x << ", method " << used << "\n";
        gl_examples::Json j = ex.summary();
        j.num("qext", q.qext).num("qsca", q.qsca).num("qabs", q.qabs).num("qback", q.qback).num("g", q.g);
        j.raw("S1", complex_list(s1)).raw("S2", complex_list(s2)).str("method", used);
        j.boolean("goa_valid", validity.valid).num("phase_shift", validity.phase_shift);
        return ex.finish(j);
    });
}
