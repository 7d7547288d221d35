// diffusion_profiles: radial reflectance profiles R(r) of a semi-infinite, index-matched medium
// under a normally incident pencil beam: the classical dipole (Jensen et al. 2001, corrected
// profile of Donner & Jensen 2005), improved diffusion (d'Eon & Irving 2011 / photon beam
// diffusion, Habel et al. 2013; the model Meng15 Sec. 3.4 / App. A switches to) and the multipole
// slab (Donner & Jensen 2005, improved terms, thickness 50 reduced mean free paths) against a
// Monte Carlo radial profile from the library's walk kernel (scene/slab.hpp SlabScene with an
// infinite thickness, ContinuousMedium, Henyey-Greenstein phase, analog photon walks).
//
// Cases: albedo 0.99 and 0.9, g = 0 and 0.8, sigma_t = 1; the diffusion models get the reduced
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

#include "common/cli.hpp"
#include "common/output.hpp"
#include "common/progress.hpp"
#include "grainlight/diffusion.hpp"
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
    std::vector<std::uint64_t> counts = std::vector<std::uint64_t>(n_bins, 0);
    std::uint64_t reflected = 0, paths = 0;
    void merge(const RadialTally& o) {
        for (int i = 0; i < n_bins; ++i) counts[std::size_t(i)] += o.counts[std::size_t(i)];
        reflected += o.reflected;
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
            if (st_.ray.d.z <= 0) return;
            ++t->reflected;
            const double r = std::hypot(st_.ray.o.x, st_.ray.o.y) * st;  // in reduced mfp
            if (r < r_lo || r >= r_hi) return;
            const int b = std::min(n_bins - 1, int(std::log(r / r_lo) / std::log(r_hi / r_lo) * n_bins));
            ++t->counts[std::size_t(b)];
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

// Exact R(mu0 = 1) of the isotropic half-space, 1 - H(1) sqrt(1 - a) (Chandrasekhar 1960 ch. V),
// H by fixed-point iteration on 200 Gauss-Legendre nodes.
double exact_halfspace(double a) {
    const int n = 200;
    std::vector<double> x, w;
    for (int i = 1; i <= n; ++i) {
        double z = std::cos(M_PI * (i - 0.25) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1, p1 = z;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1);
            const double dz = p1 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-15) break;
        }
        x.push_back(0.5 * (1 - z));
        w.push_back(1.0 / ((1 - z * z) * dp * dp));
    }
    const double s = std::sqrt(1 - a);
    std::vector<double> h(x.size(), 1.0), nh(h.size());
    auto eval = [&](double mu) {
        double acc = 0;
        for (std::size_t j = 0; j < h.size(); ++j) acc += w[j] * x[j] * h[j] / (mu + x[j]);
        return 1.0 / (s + 0.5 * a * acc);
    };
    for (int it = 0; it < 100000; ++it) {
        double change = 0;
        for (std::size_t i = 0; i < h.size(); ++i) {
            nh[i] = eval(x[i]);
            change = std::max(change, std::abs(nh[i] - h[i]));
        }
        h.swap(nh);
        if (change < 1e-12) break;
    }
    return 1 - eval(1.0) * s;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run_main("diffusion_profiles", [&]() -> int {
        gl_examples::Cli cli(argc, argv, "diffusion_profiles",
                             "dipole / improved / multipole R(r) vs a Monte Carlo radial profile (semi-infinite medium)");
        cli.option("paths", "photon paths per case (>= 1000)", "200000 quick, 2000000 full").common_options("out");
        cli.finish();
        const bool full = cli.full_quality();
        const std::uint64_t paths = cli.integer("paths", full ? 2000000 : 200000);
        if (paths < 1000) throw gl_examples::cli_error("--paths = " + std::to_string(paths) + " must be >= 1000");
        const std::uint64_t seed = cli.seed();
        const int threads = cli.threads();
        (void)threads;
        const auto out = cli.out_dir();

        struct Case {
            double a, g;
        };
        const Case cases[] = {{0.99, 0.0}, {0.9, 0.0}, {0.99, 0.8}, {0.9, 0.8}};
        gl_examples::Csv csv({"albedo", "g", "r_reduced", "r", "R_mc", "R_mc_stderr", "R_classical", "R_improved",
                              "R_multipole"});
        std::vector<std::string> json_lines;
        std::printf("%-6s %-4s | %-17s | %-9s %-9s %-9s | %-9s | %s\n", "albedo", "g", "MC R (+- se)", "classical",
                    "improved", "multipole", "exact", "seconds");
        for (const Case& c : cases) {
            const double sigma_t = 1.0, ss = c.a * (1 - c.g) * sigma_t, sa = (1 - c.a) * sigma_t, st = ss + sa;
            const SceneT scene(MediumT(sigma_t, c.a, Phase(c.g)), std::numeric_limits<double>::infinity(), 1.0);
            const ClassicalDipole<double> dip(ss, sa, 1.0);
            const ImprovedDiffusion<double> imp(ss, sa, 1.0);
            const MultipoleSlab<double> mp(ss, sa, 1.0, 50.0 / st, DiffusionModel::improved);

            // Fixed-size blocks reduced in block order: identical numbers for any thread count.
            const std::uint64_t block = 4096, n_blocks = (paths + block - 1) / block;
            std::vector<RadialTally> tallies(n_blocks);
            char label[64];
            std::snprintf(label, sizeof label, "a=%.2f g=%.1f", c.a, c.g);
            gl_examples::ProgressBar bar(label, n_blocks);
            const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for schedule(dynamic, 1)
            for (long long b = 0; b < (long long)n_blocks; ++b) {
                const std::uint64_t first = std::uint64_t(b) * block;
                tallies[std::size_t(b)] = run_block(scene, st, first, std::min(block, paths - first), seed);
                bar.advance();
            }
            bar.done();
            RadialTally t;
            for (const auto& x : tallies) t.merge(x);
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

            for (int i = 0; i < n_bins; ++i) {
                const double r0 = bin_edge(i) / st, r1 = bin_edge(i + 1) / st;  // physical units
                const double area = M_PI * (r1 * r1 - r0 * r0);
                const double p = double(t.counts[std::size_t(i)]) / double(t.paths);
                const double r = std::sqrt(r0 * r1);
                csv.row({c.a, c.g, r * st, r, p / area, std::sqrt(p * (1 - p) / double(t.paths)) / area, dip.R(r),
                         imp.R(r), mp.R(r)});
            }
            const double R_mc = double(t.reflected) / double(t.paths);
            const double R_se = std::sqrt(R_mc * (1 - R_mc) / double(t.paths));
            const double exact = c.g == 0.0 ? exact_halfspace(c.a) : std::nan("");
            std::printf("%-6.2f %-4.1f | %.5f +- %.5f | %.5f   %.5f   %.5f   | %-9s | %.1f\n", c.a, c.g, R_mc, R_se,
                        dip.total_reflectance(), imp.total_reflectance(), mp.totals().R,
                        c.g == 0.0 ? std::to_string(exact).substr(0, 7).c_str() : "-", seconds);
            gl_examples::Json j;
            j.num("albedo", c.a)
                .num("g", c.g)
                .num("R_mc", R_mc)
                .num("R_mc_stderr", R_se)
                .num("R_classical", dip.total_reflectance())
                .num("R_improved", imp.total_reflectance())
                .num("R_multipole", mp.totals().R)
                .num("R_exact", exact)
                .integer("paths", (long long)t.paths)
                .num("seconds", seconds);
            json_lines.push_back(j.str());
        }
        std::printf("(classical = Jensen 2001 dipole; improved = d'Eon & Irving 2011 / PBD beam; multipole = Donner & "
                    "Jensen 2005 with improved terms, d = 50 / sigma_t'; exact = 1 - H(1) sqrt(1 - a), g = 0 only)\n");
        csv.write(out / "diffusion_profiles.csv");
        const std::string script = R"(
d = read_csv(r''')" + (out / "diffusion_profiles.csv").string() + R"(''')
a = np.array(d['albedo']); g = np.array(d['g']); x = np.array(d['r_reduced'])
fig, axes = plt.subplots(2, 2, figsize=(10, 8))
for ax, (aa, gg) in zip(axes.flat, [(0.99, 0.0), (0.9, 0.0), (0.99, 0.8), (0.9, 0.8)]):
    m = (np.abs(a - aa) < 1e-9) & (np.abs(g - gg) < 1e-9)
    st = (aa * (1 - gg) + (1 - aa))
    scale = 1.0 / st**2  # R in units of sigma_t'^2
    ax.errorbar(x[m], np.array(d['R_mc'])[m] * scale, yerr=np.array(d['R_mc_stderr'])[m] * scale, fmt='k.', ms=3, label='Monte Carlo')
    ax.loglog(x[m], np.array(d['R_classical'])[m] * scale, label='classical dipole')
    ax.loglog(x[m], np.array(d['R_improved'])[m] * scale, label='improved (PBD)')
    ax.loglog(x[m], np.array(d['R_multipole'])[m] * scale, '--', label='multipole, d = 50 mfp\'')
    ax.set_title(f'albedo {aa}, g = {gg}')
    ax.set_xlabel("r sigma_t'"); ax.set_ylabel("R(r) / sigma_t'^2")
    ax.set_ylim(1e-7, 1e2)
    ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig(png, dpi=110)
)";
        gl_examples::plot_with_matplotlib(out / "diffusion_profiles_plot.py", script, out / "diffusion_profiles.png");
        for (const auto& l : json_lines) std::cout << l << "\n";
        std::cout.flush();
        return 0;
    });
}
