// moon07_shell_transport: Moon, Walter & Marschner 2007 (EGSR), "Rendering Discrete Random Media
// Using Precomputed Scattering Solutions": shell transport functions of a discrete random medium
// of glass spheres, and shell stepping (Fig. 5) against explicit path tracing of the spheres.
//
//   moon07_shell_transport [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                          [--fraction F] [--eta N] [--paths N] [--rank K]
//
// 1. Medium: equal glass spheres (relative index eta, default 1.5) in a hard-sphere Poisson (RSA)
//    packing of packing fraction f (default 0.3), infinitely tiled (packing/periodic_tile.hpp).
//    Lengths are in sphere radii R.
// 2. Preprocess (Sec. 4.1): paths traced through the explicit spheres from random frames; first
//    exits of shells r = 2, 4, ..., 12 R; k-NN density on a 24 x 16 x 16 grid per shell; NMF with
//    ranks 1..8 (reconstruction error vs rank); f_a(d) from the first free paths (Fig. 8 bottom);
//    marginal p_r(cos theta_1) per radius (Fig. 8 top).
// 3. Shell stepping vs explicit path tracing in the infinite medium: paths chained through
//    spheres of radius r = 8 R (explicit: the first exit of the sphere around the previous exit
//    point; shells: Fig. 5 steps with the table). Mean-square displacement and mean direction
//    cosine vs number of steps, radial distribution after the last step, and the time per path
//    of both (speedup).
// 4. Fig. 6 / Sec. 4.3: a ball of the medium lit by a small cone light: escapes counted when they
//    hit the light vs Fig. 6's two shadow rays (mean, standard error, efficiency gain).
//
// Output: moon07_shell_transport_{fig8,fa,nmf,steps,radial,direct}.csv + .png plot, the table
// (moon07_shells.shel), and one JSON summary line (last line of stdout).
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/media/shell.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/precompute/shell_builder.hpp"

namespace gl = grainlight;
using gl::Vec3d;

namespace {

double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Recorder for the explicit reference: positions where the path first leaves the sphere of
// radius r around the previous such exit (the first sphere is centred at the start frame).
struct ChainRecorder {
    double r = 1;
    int n_steps = 1;
    std::vector<Vec3d> pos;    // exit points relative to the start, per step
    std::vector<double> cosw;  // direction . omega_0 at each exit
    Vec3d x0{0.0}, omega0{0.0, 0.0, 1.0}, c{0.0};
    std::uint64_t events = 0;
    void begin(const Vec3d& x, const Vec3d& omega) {
        x0 = c = x;
        omega0 = omega;
        pos.clear();
        cosw.clear();
    }
    bool segment(const Vec3d& o_in, const Vec3d& d, double t, bool event_at_end) {
        Vec3d o = o_in;
        double left = t;
        while (int(pos.size()) < n_steps) {
            const Vec3d rel = o - c;
            const double b = glm::dot(rel, d);
            const double s = -b + std::sqrt(std::max(0.0, b * b - (glm::dot(rel, rel) - r * r)));
            if (!(s <= left)) break;
            o += s * d;
            left -= s;
            c = o;
            pos.push_back(c - x0);
            cosw.push_back(glm::dot(d, omega0));
        }
        events += event_at_end ? 1 : 0;
        return int(pos.size()) < n_steps;
    }
    void absorbed() {}
};

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "moon07_shell_transport",
        "Moon07 shell transport functions of glass spheres; shell stepping vs explicit path tracing",
        "out/moon07_shell_transport", [&](gl_examples::Example& ex) -> int {
        const double fraction =
            ex.opt<double>("fraction", 0.3, "packing fraction of the hard-sphere Poisson packing (<= 0.35)");
        const double eta = ex.opt<double>("eta", 1.5, "relative index of the spheres");
        const auto n_paths =
            ex.opt<std::uint64_t>("paths", 40000, 500000, "preprocessing paths (full = the paper's count)");
        const int rank = ex.opt<int>("rank", 5, "NMF rank of the stored table (paper: 4-6)");
        ex.ready();
        const bool full = ex.full();
        const auto out = ex.out();
        const int threads = ex.threads();
        if (!(fraction > 0 && fraction <= gl::rsa_max_fraction))
            throw gl_examples::cli_error("--fraction must be in (0, 0.35]");
        if (!(eta > 0 && eta < 10)) throw gl_examples::cli_error("--eta must be in (0, 10)");
        if (n_paths < 1000 || n_paths > 100000000ull) throw gl_examples::cli_error("--paths must be in [1000, 1e8]");
        if (rank < 1 || rank > 64) throw gl_examples::cli_error("--rank must be in [1, 64]");
        const std::uint64_t seed = ex.seed();

        // Medium: unit tile of 128 spheres; work in units of R.
        gl::Rng prng = gl::Rng::from_key(seed, 0x7ac);
        const gl::PeriodicTile tile = gl::random_sequential_addition(128, fraction, prng, 1.0);
        const double R = tile.radius();
        std::vector<double> radii;
        for (int i = 1; i <= 6; ++i) radii.push_back(2.0 * i * R);
        const gl::SpherePackingShellSource source(tile, eta, 0.0, 20 * R);

        // --- Preprocessing (Sec. 4.1) ---
        std::cerr << "preprocessing " << n_paths << " paths ...\n";
        const double t0 = now_s();
        const gl::ShellSamples samples = gl::collect_shell_samples(source, radii, n_paths, seed, 256, 12 * R);
        const double t1 = now_s();
        gl::ShellBuildOptions bo;
        bo.rank = rank;
        const gl::ShellBuildResult built = gl::build_shell_table(samples, bo);
        const double t2 = now_s();
        const gl::ShellTable& table = built.table;
        table.save(out / "moon07_shells.shel");
        const gl::ShellTable reloaded = gl::ShellTable::load(out / "moon07_shells.shel");
        const gl::ShellMedium<double> medium(reloaded);

        // NMF error vs rank.
        gl_examples::Csv nmf_csv({"rank", "relative_error"});
        std::vector<double> nmf_err;
        for (int k = 1; k <= 8; ++k) {
            nmf_err.push_back(gl::nmf(built.density, k, bo.nmf_iterations, bo.seed).relative_error);
            nmf_csv.row({double(k), nmf_err.back()});
        }
        ex.csv("moon07_shell_transport_nmf.csv", nmf_csv);

        // Fig. 8: marginal p_r(theta_1) per radius (per unit cos theta_1, scattered exits, times
        // p_scattered) and f_a(d) against the exponential with the same mean free path.
        gl_examples::Csv fig8({"cos_theta1", "p_r2", "p_r4", "p_r6", "p_r8", "p_r10", "p_r12"});
        for (int j = 0; j < table.n_c; ++j) {
            const double c = -1 + (j + 0.5) * 2.0 / table.n_c;
            std::vector<double> row{c};
            for (std::size_t i = 0; i < radii.size(); ++i)
                row.push_back(medium.exit_position_density(int(i), c) * 2 * gl::pi_v<double> * radii[i] * radii[i]);
            fig8.row(row);
        }
        ex.csv("moon07_shell_transport_fig8.csv", fig8);
        double mean_free = 0;  // integral of f_a = mean first free path from a typical point
        const std::size_t nfa = table.fa.size();
        for (std::size_t j = 0; j + 1 < nfa; ++j) mean_free += 0.5 * (table.fa[j] + table.fa[j + 1]) * table.fa_d_max / (nfa - 1);
        gl_examples::Csv fa_csv({"d_over_R", "f_a", "exp_same_mean"});
        for (std::size_t j = 0; j < nfa; j += 4) {
            const double d = table.fa_d_max * double(j) / double(nfa - 1);
            fa_csv.row({d / R, table.fa[j], std::exp(-d / mean_free)});
        }
        ex.csv("moon07_shell_transport_fa.csv", fa_csv);

        // --- Shell stepping vs explicit path tracing, r = 8 R ---
        const int shell = 3;
        const double r = radii[shell];
        const int n_steps = full ? 10 : 6;
        const int n_cmp = full ? 20000 : 3000;
        std::vector<gl::Welford> msd_e(n_steps), msd_s(n_steps), cos_e(n_steps), cos_s(n_steps);
        std::vector<double> last_e, last_s;
        std::uint64_t explicit_events = 0;
        auto bar = ex.progress("explicit paths", std::uint64_t(n_cmp));
        const double te0 = now_s();
        for (int p = 0; p < n_cmp; ++p) {
            gl::Rng rng = gl::Rng::from_key(seed, 0xe7, std::uint64_t(p));
            ChainRecorder rec;
            rec.r = r;
            rec.n_steps = n_steps;
            source.trace(rng, rec);
            explicit_events += rec.events;
            for (std::size_t n = 0; n < rec.pos.size(); ++n) {
                msd_e[n].add(glm::dot(rec.pos[n], rec.pos[n]) / (R * R));
                cos_e[n].add(rec.cosw[n]);
            }
            if (int(rec.pos.size()) == n_steps) last_e.push_back(glm::length(rec.pos.back()) / R);
            if ((p & 255) == 255) bar.advance(256);
        }
        bar.done();
        const double te1 = now_s();
        struct FixedR {
            double r;
            double operator()(const Vec3d&) const noexcept { return r; }
        };
        const gl::ShellMedium<double, gl::Spectrum<1, double>, FixedR> stepper(reloaded, FixedR{r * (1 + 1e-9)});
        const int n_shell_paths = n_cmp * 20;
        // Timing of explicit tracing without the burn-in (which only serves to randomize the start
        // frame): chained exits of paths started at uniform host points.
        const gl::SpherePackingShellSource timing_source(tile, eta, 0.0, 1e-6 * R);
        std::uint64_t timed_steps = 0;
        const double tt0 = now_s();
        for (int p = 0; p < n_cmp; ++p) {
            gl::Rng rng = gl::Rng::from_key(seed, 0x71, std::uint64_t(p));
            ChainRecorder rec;
            rec.r = r;
            rec.n_steps = n_steps;
            timing_source.trace(rng, rec);
            timed_steps += rec.pos.size();
        }
        const double tt1 = now_s();
        const double ts0 = now_s();
        for (int p = 0; p < n_shell_paths; ++p) {
            gl::Rng rng = gl::Rng::from_key(seed, 0x5e, std::uint64_t(p));
            Vec3d x(0.0), w(0, 0, 1);
            for (int n = 0; n < n_steps; ++n) {
                const auto s = stepper.step(x, w, std::numeric_limits<double>::infinity(), rng,
                                            [](const Vec3d&) { return true; });
                x = s.p;
                w = s.w;
                msd_s[n].add(glm::dot(x, x) / (R * R));
                cos_s[n].add(w.z);
            }
            last_s.push_back(glm::length(x) / R);
        }
        const double ts1 = now_s();
        (void)te0;
        (void)te1;
        const double per_path_explicit = (tt1 - tt0) / double(timed_steps) * n_steps;
        const double per_path_shell = (ts1 - ts0) / n_shell_paths;
        const double speedup = per_path_explicit / per_path_shell;

        gl_examples::Csv steps({"step", "msd_explicit", "msd_explicit_se", "msd_shells", "msd_shells_se", "cos_explicit",
                                "cos_shells"});
        double max_rel_msd = 0;
        for (int n = 0; n < n_steps; ++n) {
            steps.row({double(n + 1), msd_e[n].mean(), msd_e[n].standard_error(), msd_s[n].mean(),
                       msd_s[n].standard_error(), cos_e[n].mean(), cos_s[n].mean()});
            max_rel_msd = std::max(max_rel_msd, std::abs(msd_s[n].mean() / msd_e[n].mean() - 1));
        }
        ex.csv("moon07_shell_transport_steps.csv", steps);
        // Radial distribution of |X_n| after the last step (normalized histograms).
        const int nb = 30;
        const double rmax = r * n_steps / R;
        gl::Histogram he(0.0, rmax, nb), hs(0.0, rmax, nb);
        for (double v : last_e) he.add(v);
        for (double v : last_s) hs.add(v);
        gl_examples::Csv radial({"radius_over_R", "pdf_explicit", "pdf_shells"});
        for (int b = 0; b < nb; ++b)
            radial.row({(b + 0.5) * rmax / nb, he.density(std::size_t(b)), hs.density(std::size_t(b))});
        ex.csv("moon07_shell_transport_radial.csv", radial);

        ex.plot("moon07_shell_transport", out / "moon07_shell_transport_fig8.csv", out / "moon07_shell_transport.png",
                {(out / "moon07_shell_transport_fa.csv").string(), (out / "moon07_shell_transport_steps.csv").string(),
                 (out / "moon07_shell_transport_radial.csv").string(),
                 (out / "moon07_shell_transport_nmf.csv").string()});

        // --- Fig. 6 / Sec. 4.3: direct illumination from a small light ---
        // A ball of the medium (radius 16 R) lit by a distant cone light (half-angle 3 deg about
        // +z, radiance 1); paths start at the centre along +x. Estimate E[throughput x L] of the
        // escaping paths (a) by waiting for escapes to hit the light, (b) with Fig. 6's two shadow
        // rays toward light samples.
        const double Rb = 16 * R, cos_light = std::cos(3.0 * gl::pi_v<double> / 180.0);
        struct BallB {
            double Rb;
            double operator()(const Vec3d& p) const noexcept { return Rb - glm::length(p); }
        };
        const gl::ShellMedium<double, gl::Spectrum<1, double>, BallB> ball(reloaded, BallB{Rb});
        auto t_surface = [&](const Vec3d& x, const Vec3d& w) {
            const double b = glm::dot(x, w), c = glm::dot(x, x) - Rb * Rb;
            return -b + std::sqrt(std::max(0.0, b * b - c));
        };
        auto light = [&](const Vec3d& w) { return w.z >= cos_light ? 1.0 : 0.0; };
        auto inside_ball = [&](const Vec3d& p) { return glm::length(p) <= Rb; };
        const double light_pdf = gl::uniform_cone_pdf(cos_light);
        const int n_di = full ? 200000 : 40000;
        gl::Welford di_hit, di_nee;
        const double th0 = now_s();
        for (int p = 0; p < n_di; ++p) {
            gl::Rng rng = gl::Rng::from_key(seed, 0xd1, std::uint64_t(p));
            Vec3d x(0.0), w(1, 0, 0);
            double weight = 1, contrib = 0;
            for (int k = 0; k < 100000; ++k) {
                const auto s = ball.step(x, w, t_surface(x, w), rng, inside_ball);
                weight *= s.weight;
                if (s.kind == gl::ShellStepKind::absorbed) break;
                if (s.kind == gl::ShellStepKind::escaped || s.kind == gl::ShellStepKind::exited) {
                    contrib = weight * light(s.w);
                    break;
                }
                x = s.p;
                w = s.w;
            }
            di_hit.add(contrib);
        }
        const double th1 = now_s();
        for (int p = 0; p < n_di; ++p) {
            gl::Rng rng = gl::Rng::from_key(seed, 0xd2, std::uint64_t(p));
            Vec3d x(0.0), w(1, 0, 0);
            double weight = 1, contrib = 0;
            bool dir_from_shell = false;
            for (int k = 0; k < 100000; ++k) {
                const double tb = t_surface(x, w);
                // First shadow ray: leaving through a sampled exit point outside the ball.
                const Vec3d wl = gl::sample_uniform_cone(rng.uniform2<double>(), cos_light);
                contrib += weight * ball.exit_escape_density(x, w, tb, wl) / light_pdf;
                const auto s = ball.step(x, w, tb, rng, inside_ball);
                if (s.kind == gl::ShellStepKind::exited) break;
                if (s.kind == gl::ShellStepKind::escaped) {
                    if (!dir_from_shell) contrib += weight * light(s.w);
                    break;
                }
                weight *= s.weight;
                if (s.kind == gl::ShellStepKind::absorbed) break;
                if (s.kind == gl::ShellStepKind::scattered) {
                    dir_from_shell = true;  // stays true through straight steps
                    // Second shadow ray: continuing toward the light and leaving unimpeded.
                    const Vec3d wl2 = gl::sample_uniform_cone(rng.uniform2<double>(), cos_light);
                    contrib += weight * ball.straight_escape_density(s.shell, x, w, s.p, wl2, t_surface(s.p, wl2)) /
                               light_pdf;
                }
                x = s.p;
                w = s.w;
            }
            di_nee.add(contrib);
        }
        const double th2 = now_s();
        const double eff_hit = 1.0 / (di_hit.variance() * (th1 - th0) / n_di);
        const double eff_nee = 1.0 / (di_nee.variance() * (th2 - th1) / n_di);
        gl_examples::Csv di_csv({"estimator", "mean", "stderr", "seconds"});
        di_csv.row({0.0, di_hit.mean(), di_hit.standard_error(), th1 - th0});
        di_csv.row({1.0, di_nee.mean(), di_nee.standard_error(), th2 - th1});
        ex.csv("moon07_shell_transport_direct.csv", di_csv);

        const double raw_bytes = double(built.density.size()) * 4.0;  // float grid
        const double factored_bytes = double(table.W.size() + table.H.size()) * 4.0;
        std::cout << "Moon07 shell transport, glass spheres eta = " << eta << ", f = " << fraction << ", R = " << R
                  << " (tile side 1), " << n_paths << " preprocessing paths, " << threads << " threads\n";
        std::cout << "  preprocessing: paths " << (t1 - t0) << " s, k-NN + NMF " << (t2 - t1)
                  << " s   [paper: 500k paths ~5 min + density 4 min + NMF 4 min (Pentium 4, MATLAB)]\n";
        std::cout << "  NMF rank " << rank << " relative error " << built.nmf_relative_error << " (rank 1: " << nmf_err[0]
                  << ", rank 8: " << nmf_err[7] << ")   [paper: 4-6 terms]\n";
        std::cout << "  storage: grid " << raw_bytes / 1024 << " KiB -> factors " << factored_bytes / 1024
                  << " KiB (x" << raw_bytes / factored_bytes << ")   [paper: ~30 MB -> 250 KB, x120, 50x50x25 grid]\n";
        std::cout << "  f_a: mean free path " << mean_free / R << " R; f_a(mean) = " << medium.attenuation(mean_free)
                  << " vs exponential 0.368   [paper Fig. 8: non-exponential]\n";
        std::cout << "  p_unscattered(r = 2R .. 12R): ";
        for (double v : table.p_unscattered) std::cout << v << " ";
        std::cout << "\n  shells vs explicit (r = 8 R, " << n_steps << " steps): max |MSD ratio - 1| = " << max_rel_msd
                  << "; <|x|^2>/R^2 after the last step: explicit " << msd_e.back().mean() << " +- "
                  << msd_e.back().standard_error() << ", shells " << msd_s.back().mean() << "\n";
        std::cout << "  time per path of " << n_steps << " steps: explicit " << per_path_explicit * 1e6 << " us ("
                  << double(explicit_events) / n_cmp << " interface events; burn-in excluded), shells " << per_path_shell * 1e6
                  << " us: speedup x" << speedup << "   [paper: high-order image 16x (Fig. 9), >40x (Fig. 11), 11x (Fig. 12) faster overall]\n";

        std::cout << "  Fig. 6 direct light (3 deg cone light, ball of radius 16 R, " << n_di
                  << " paths): hits " << di_hit.mean() << " +- " << di_hit.standard_error() << ", shadow rays "
                  << di_nee.mean() << " +- " << di_nee.standard_error() << "; efficiency gain x" << eff_nee / eff_hit
                  << "   [paper Sec. 4.3: path tracing must wait for rays to hit the source; shells give a smooth"
                     " estimate regardless of the light size]\n";

        gl_examples::Json j = ex.summary();
        j.num("fraction", fraction)
            .num("eta", eta)
            .integer("paths", (long long)n_paths)
            .num("preprocess_seconds", t2 - t0)
            .num("nmf_error", built.nmf_relative_error)
            .nums("nmf_error_by_rank", nmf_err)
            .num("max_msd_rel_diff", max_rel_msd)
            .num("msd_explicit_last", msd_e.back().mean())
            .num("msd_shells_last", msd_s.back().mean())
            .num("explicit_us_per_path", per_path_explicit * 1e6)
            .num("shell_us_per_path", per_path_shell * 1e6)
            .num("speedup", speedup)
            .num("direct_hits", di_hit.mean())
            .num("direct_hits_se", di_hit.standard_error())
            .num("direct_nee", di_nee.mean())
            .num("direct_nee_se", di_nee.standard_error())
            .num("direct_efficiency_gain", eff_nee / eff_hit)
            .nums("p_unscattered", table.p_unscattered)
            .str("png", (out / "moon07_shell_transport.png").string());
        return ex.finish(j);
        });
}
