// diffusion_profiles: radial reflectance profiles R(r) of a semi-infinite, index-matched medium
// under a normally incident pencil beam: the classical dipole (Jensen et al. 2001, corrected
// profile of Donner & Jensen 2005), improved diffusion (d'Eon & Irving 2011 / photon beam
// diffusion, Habel et al. 2013; the model Meng15 Sec. 3.4 / App. A switches to) and the multipole
// slab (Donner & Jensen 2005, improved terms, thickness 50 reduced mean free paths) against a
// Monte Carlo radial profile from the library's walk kernel (scene/slab.hpp SlabScene with an
// infinite thickness, ContinuousMedium, Henyey-Greenstein phase, analog photon walks).
//
// Cases: albedo 0.99 and 0.9, g = 0 and 0.8, sigma_t = 1, half-space; plus a slab of optical
// depth 4 (albedo 0.99, g = 0) with R(r) and T(r) against the multipole. The diffusion models get the reduced
// parameters sigma_s' = a (1 - g) sigma_t, sigma_a = (1 - a) sigma_t (Meng15 Sec. 4.2.3).
// The MC counts every path leaving the surface (single scattering included), binned in
// log-spaced annuli of r sigma_t' (R = count / (paths * annulus area)).
//
//   diffusion_profiles [--quality quick|full] [--paths P] [--out DIR] [--seed S] [--threads N]
//
// Writes DIR/diffusion_profiles.csv, DIR/diffusion_profiles.png; prints the totals side by side
// with the exact half-space albedo where one is known (isotropic scattering: Chandrasekhar's
// H-function, shared/reference/halfspace_albedo.md), and one JSON line per case.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <limits>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/diffusion.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/slab.hpp"

namespace {

using namespace grainlight;
using S = Spectrum<1, double>;
using Phase = HenyeyGreenstein<double, S>;
using MediumT = ContinuousMedium<Phase, S>;
using SceneT = SlabScene<MediumT>;

constexpr int n_bins = 48;
constexpr double r_lo = 0.01, r_hi = 100.0;  // in units of 1 / sigma_t'

double bin_edge(int i) { return r_lo * std::pow(r_hi / r_lo, double(i) / n_bins); }

struct RadialTally {
    std::vector<std::uint64_t> counts_R = std::vector<std::uint64_t>(n_bins, 0);
    std::vector<std::uint64_t> counts_T = std::vector<std::uint64_t>(n_bins, 0);
    std::uint64_t reflected = 0, transmitted = 0, paths = 0;
    void merge(const RadialTally& o) {
        for (int i = 0; i < n_bins; ++i) {
            counts_R[std::size_t(i)] += o.counts_R[std::size_t(i)];
            counts_T[std::size_t(i)] += o.counts_T[std::size_t(i)];
        }
        reflected += o.reflected;
        transmitted += o.transmitted;
        paths += o.paths;
    }
};

// Photon paths [first, first + count): pencil beam at the origin, travelling along -z.
RadialTally run_block(const SceneT& scene, double sigma_t_prime, std::uint64_t first, std::uint64_t count,
                      std::uint64_t seed) {
    struct Scorer {
        RadialTally* t;
        double st;
        void on_escape(const PathState<double, S>& st_) noexcept {
            const bool up = st_.ray.d.z > 0;
            ++(up ? t->reflected : t->transmitted);
            const double r = std::hypot(st_.ray.o.x, st_.ray.o.y) * st;  // in reduced mfp
            if (r < r_lo || r >= r_hi) return;
            const int b = std::min(n_bins - 1, int(std::log(r / r_lo) / std::log(r_hi / r_lo) * n_bins));
            ++(up ? t->counts_R : t->counts_T)[std::size_t(b)];
        }
    };
    RadialTally tally;
    WalkOptions<double> opt;
    opt.mode = TransportMode::importance;
    for (std::uint64_t i = first; i < first + count; ++i) {
        Rng rng = Rng::from_key(seed, i, 0);
        Scorer sc{&tally, sigma_t_prime};
        PathState<double, S> st = start_path<double, S>(Ray<double>(Vec3<double>(0, 0, 1), Vec3<double>(0, 0, -1)), -1);
        (void)walk(scene, st, rng, sc, opt);
        ++tally.paths;
    }
    return tally;
}

// Exact R(mu0 = 1) of the isotropic half-space, 1 - H(1) sqrt(1 - a) (Chandrasekhar 1960 ch. V).
double exact_halfspace(double a) { return grainlight::IsotropicHFunction(a, 200).reflectance(1.0); }

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(argc, argv, "diffusion_profiles",
                            "dipole / improved / multipole R(r) vs a Monte Carlo radial profile (semi-infinite medium)",
                            [&](gl_examples::Example& ex) -> int {
        const auto paths = ex.opt<std::uint64_t>("paths", 200000, 2000000, "photon paths per case (>= 1000)");
        ex.ready();
        if (paths < 1000) throw gl_examples::cli_error("--paths = " + std::to_string(paths) + " must be >= 1000");
        const std::uint64_t seed = ex.seed();
        const auto& out = ex.out();

        struct Case {
            double a, g, B;  // albedo, HG g, optical depth sigma_t d (inf = half-space)
        };
        const double inf = std::numeric_limits<double>::infinity();
        const Case cases[] = {{0.99, 0.0, inf}, {0.9, 0.0, inf}, {0.99, 0.8, inf}, {0.9, 0.8, inf}, {0.99, 0.0, 4.0}};
        gl_examples::Csv csv({"case", "albedo", "g", "optical_depth", "face", "r_reduced", "r", "mc", "mc_stderr",
                              "dipole", "improved", "multipole_classical", "multipole_improved"});
        std::vector<std::string> json_lines;
        std::printf("%-6s %-4s %-4s %-2s | %-17s | %-8s %-8s %-8s %-8s | %-8s | %s\n", "albedo", "g", "B", "", "MC (+- se)",
                    "dipole", "improved", "mp_class", "mp_impr", "exact", "seconds");
        int case_index = 0;
        for (const Case& c : cases) {
            const double sigma_t = 1.0, ss = c.a * (1 - c.g) * sigma_t, sa = (1 - c.a) * sigma_t, st = ss + sa;
            const bool slab = std::isfinite(c.B);
            const double d = slab ? c.B / sigma_t : 50.0 / st;  // half-space: multipole at 50 mfp'
            const SceneT scene(MediumT(sigma_t, c.a, Phase(c.g)), slab ? c.B / sigma_t : inf, 1.0);
            const ClassicalDipole<double> dip(ss, sa, 1.0);
            const ImprovedDiffusion<double> imp(ss, sa, 1.0);
            const MultipoleSlab<double> mpc(ss, sa, 1.0, d, DiffusionModel::classical);
            const MultipoleSlab<double> mpi(ss, sa, 1.0, d, DiffusionModel::improved);

            // Fixed-size blocks reduced in block order: identical numbers for any thread count.
            char label[64];
            std::snprintf(label, sizeof label, "a=%.2f g=%.1f B=%g", c.a, c.g, c.B);
            const auto t0 = std::chrono::steady_clock::now();
            const RadialTally t = ex.parallel<RadialTally>(
                label, paths, 4096,
                [&](std::uint64_t, std::uint64_t first, std::uint64_t end) { return run_block(scene, st, first, end - first, seed); },
                [](RadialTally& acc, const RadialTally& x) { acc.merge(x); });
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

            for (int face = 0; face < (slab ? 2 : 1); ++face) {
                const auto& counts = face == 0 ? t.counts_R : t.counts_T;
                for (int i = 0; i < n_bins; ++i) {
                    const double r0 = bin_edge(i) / st, r1 = bin_edge(i + 1) / st;  // physical units
                    const double area = M_PI * (r1 * r1 - r0 * r0);
                    const double p = double(counts[std::size_t(i)]) / double(t.paths);
                    const double r = std::sqrt(r0 * r1);
                    csv.row({double(case_index), c.a, c.g, slab ? c.B : -1.0, double(face), r * st, r, p / area,
                             std::sqrt(p * (1 - p) / double(t.paths)) / area, face == 0 ? dip.R(r) : 0.0,
                             face == 0 ? imp.R(r) : 0.0, face == 0 ? mpc.R(r) : mpc.T(r), face == 0 ? mpi.R(r) : mpi.T(r)});
                }
            }
            const double n = double(t.paths);
            const double R_mc = double(t.reflected) / n, R_se = std::sqrt(R_mc * (1 - R_mc) / n);
            // diffuse T: the unscattered beam e^{-B} leaves at r = 0 and is not a diffusion quantity
            const double T_mc = double(t.transmitted) / n, T_se = std::sqrt(T_mc * (1 - T_mc) / n);
            const double T_ball = slab ? std::exp(-c.B) : 0.0;
            const double exact = (c.g == 0.0 && !slab) ? exact_halfspace(c.a) : std::nan("");
            const auto tc = mpc.totals(), ti = mpi.totals();
            char exact_str[32] = "-";
            if (std::isfinite(exact)) std::snprintf(exact_str, sizeof exact_str, "%.5f", exact);
            std::printf("%-6.2f %-4.1f %-4g R  | %.5f +- %.5f | %.5f  %.5f  %.5f  %.5f  | %-8s | %.1f\n", c.a, c.g, c.B,
                        R_mc, R_se, dip.total_reflectance(), imp.total_reflectance(), tc.R, ti.R, exact_str, seconds);
            if (slab)
                std::printf("%-6s %-4s %-4s T  | %.5f +- %.5f | %-8s %-8s %.5f  %.5f  | %-8s |\n", "", "", "",
                            T_mc - T_ball, T_se, "-", "-", tc.T, ti.T, "-");
            gl_examples::Json j = ex.summary();
            j.num("albedo", c.a)
                .num("g", c.g)
                .num("optical_depth", c.B)
                .num("R_mc", R_mc)
                .num("R_mc_stderr", R_se)
                .num("T_diffuse_mc", T_mc - T_ball)
                .num("T_mc_stderr", T_se)
                .num("R_dipole", dip.total_reflectance())
                .num("R_improved", imp.total_reflectance())
                .num("R_multipole_classical", tc.R)
                .num("R_multipole_improved", ti.R)
                .num("T_multipole_classical", tc.T)
                .num("T_multipole_improved", ti.T)
                .num("R_exact", exact)
                .integer("paths", (long long)t.paths)
                .num("seconds", seconds);
            json_lines.push_back(j.str());
            ++case_index;
        }
        std::printf("(dipole = Jensen 2001 classical dipole; improved = d'Eon & Irving 2011 / PBD beam, half-space;\n"
                    " mp_class / mp_impr = Donner & Jensen 2005 multipole with classical / improved terms, slab of B\n"
                    " (d = 50 / sigma_t' for the half-space rows); T rows: diffuse transmittance, MC minus e^{-B};\n"
                    " exact = 1 - H(1) sqrt(1 - a), isotropic half-space only)\n");
        const auto csv_path = ex.csv("diffusion_profiles.csv", csv);
        ex.plot("diffusion_profiles", csv_path, out / "diffusion_profiles.png");
        for (const auto& l : json_lines) std::cout << l << "\n";
        std::cout.flush();
        return 0;
    });
}
