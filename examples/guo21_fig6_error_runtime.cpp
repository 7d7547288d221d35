// guo21_fig6_error_runtime: Guo21 Fig. 6. Left: the error of F = (|S1| + |S2|)/2, GOA (p <= 3)
// vs exact Lorenz-Mie, as a function of r for several relative indices, by three error measures:
//   relmse  = mean over angles of ((F_goa - F_mie) / F_mie)^2        (per-angle relative MSE)
//   energy  = sum (F_goa - F_mie)^2 / sum F_mie^2                    (energy-weighted sum ratio)
//   logerr  = mean over angles of (log10 F_goa - log10 F_mie)^2      (log error)
// at 1-degree steps 0..180 deg, lambda = 0.6 um. Right: the runtime ratio t_Mie / t_GOA for the
// same 181 angles, measured side by side in this run (thread CPU time, minimum of repeated,
// interleaved timings),
// from r = 1 to 1000 um; GOA both solving its rays per call and with rays cached per angle grid
// (optics/goa.hpp GoaTable, as the bulk integration uses it). t_Mie is the series plus the
// angle-span kernel (LorenzMie::amplitudes(span, span), issue 13); the per-angle loop over
// amplitudes(mu) is timed beside it (t_mie_per_angle_s) for reference.
//
//   guo21_fig6_error_runtime [--quality quick|full] [--out DIR] [--threads T]
//
// Paper: "GOA exhibits errors of less than 0.01 compared with exact Lorenz-Mie calculations when
// r >= 2 um" and "t_Mie/t_GOA grows linearly with r ... two orders of magnitude".
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kLambda = 0.6;

struct Err {
    double relmse = 0, energy = 0, logerr = 0;
};

Err errors(double eta, double r) {
    const double x = 2 * kPi * r / kLambda;
    const std::complex<double> m(eta, 0);
    const grainlight::LorenzMie mie(m, x);
    const grainlight::Goa goa(m, x);
    std::vector<double> mu(181);
    std::vector<grainlight::ScatteringAmplitudes> smie(181);
    for (int d = 0; d <= 180; ++d) mu[std::size_t(d)] = d == 0 ? 1.0 : d == 180 ? -1.0 : std::cos(d * kPi / 180);
    mie.amplitudes(mu, smie);
    Err e;
    double num = 0, den = 0;
    for (int d = 0; d <= 180; ++d) {
        const double th = d * kPi / 180;
        const auto sm = smie[std::size_t(d)];
        const auto sg = goa.amplitudes_at_angle(th);
        const double fm = 0.5 * (std::abs(sm.S1) + std::abs(sm.S2));
        const double fg = 0.5 * (std::abs(sg.S1) + std::abs(sg.S2));
        e.relmse += (fg - fm) * (fg - fm) / (fm * fm);
        num += (fg - fm) * (fg - fm);
        den += fm * fm;
        const double lg = std::log10(std::max(fg, 1e-300)) - std::log10(std::max(fm, 1e-300));
        e.logerr += lg * lg;
    }
    e.relmse /= 181;
    e.logerr /= 181;
    e.energy = num / den;
    return e;
}

double cpu_now() {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Thread CPU time of one call of f (shared/reference/measuring.md: not wall time, which the
/// other processes on a shared machine inflate), minimum over `reps` timings; each timing runs f
/// often enough to last >= 0.2 ms (reading the thread clock costs ~1 us).
template <class Fn>
double min_time(Fn&& f, int reps) {
    double t0 = cpu_now();
    f();
    const double est = cpu_now() - t0;
    const int inner = std::max(1, int(2e-4 / std::max(est, 1e-9)));
    double best = 1e300;
    for (int i = 0; i < reps; ++i) {
        t0 = cpu_now();
        for (int k = 0; k < inner; ++k) f();
        best = std::min(best, (cpu_now() - t0) / inner);
    }
    return best;
}
}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(argc, argv, "guo21_fig6_error_runtime",
                            "Guo21 Fig. 6: GOA vs Mie error of (|S1|+|S2|)/2 and runtime ratio vs r",
                            [&](gl_examples::Example& ex) -> int {
        ex.ready();
        const bool full = ex.full();
        const auto& out = ex.out();

        // ---- left: errors -------------------------------------------------------------------
        const std::vector<double> etas = {1.33, 1.5, 1.2, 0.75};
        std::vector<double> radii;
        if (full) {
            for (int i = 0; i <= 48; ++i) radii.push_back(std::pow(10.0, -0.3 + 2.6 * i / 48.0));  // 0.5 .. 200 um
        } else {
            radii = {0.5, 1, 1.5, 2, 3, 5, 7, 10, 20, 50, 100};
        }
        // One (eta, r) pair per block on the example's threads, appended in order.
        const std::vector<Err> err = ex.parallel<std::vector<Err>>(
            "errors", etas.size() * radii.size(), 1,
            [&](std::uint64_t k, std::uint64_t, std::uint64_t) {
                return std::vector<Err>{errors(etas[std::size_t(k) / radii.size()], radii[std::size_t(k) % radii.size()])};
            },
            [](std::vector<Err>& acc, const std::vector<Err>& part) { acc.insert(acc.end(), part.begin(), part.end()); });
        gl_examples::Csv ecsv({"eta", "r_um", "relmse", "energy", "logerr"});
        for (std::size_t i = 0; i < etas.size(); ++i)
            for (std::size_t j = 0; j < radii.size(); ++j) {
                const auto& e = err[i * radii.size() + j];
                ecsv.row({etas[i], radii[j], e.relmse, e.energy, e.logerr});
            }
        const auto error_csv = ex.csv("guo21_fig6_error.csv", ecsv);

        // ---- right: runtime ratio (serial, interleaved, minimum of repeats) -------------------
        const std::vector<double> rt = full ? std::vector<double>{1, 2, 5, 10, 20, 50, 100, 200, 500, 1000}
                                            : std::vector<double>{1, 2, 5, 10, 20, 50, 100, 200, 500, 1000};
        std::vector<double> theta(181), mu(181);
        for (int d = 0; d <= 180; ++d) {
            theta[std::size_t(d)] = d * kPi / 180;
            mu[std::size_t(d)] = d == 0 ? 1.0 : d == 180 ? -1.0 : std::cos(theta[std::size_t(d)]);
        }
        const std::complex<double> water(1.33, 0);
        const grainlight::GoaTable table(water, 3, theta);  // built once: r-independent
        volatile double sink = 0;
        // F = (|S1| + |S2|)/2 per angle on every side, |S| as sqrt(norm S) (std::abs is hypot, whose
        // overflow guard would cost as much as the cached GOA evaluation itself).
        gl_examples::Csv tcsv({"r_um", "t_mie_s", "t_goa_s", "ratio", "t_goa_cached_s", "ratio_cached",
                               "t_mie_per_angle_s"});
        struct Row {
            double r, tm, tg, tc, tp;
        };
        std::vector<grainlight::ScatteringAmplitudes> smie(mu.size());
        std::vector<Row> rows;
        auto tbar = ex.progress("runtime", rt.size());
        for (double r : rt) {
            const double x = 2 * kPi * r / kLambda;
            const int reps = full ? 15 : (r >= 500 ? 3 : 7);
            double tm = 1e300, tg = 1e300, tc = 1e300, tp = 1e300;
            for (int rep = 0; rep < reps; ++rep) {  // interleave so load changes hit both alike
                tm = std::min(tm, min_time([&] {
                                  const grainlight::LorenzMie mie(water, x);
                                  mie.amplitudes(mu, smie);
                                  double acc = 0;
                                  for (const auto& s : smie) acc += 0.5 * (std::sqrt(std::norm(s.S1)) + std::sqrt(std::norm(s.S2)));
                                  sink = acc;
                              }, 1));
                if (rep < 3)
                    tp = std::min(tp, min_time([&] {
                                      const grainlight::LorenzMie mie(water, x);
                                      double acc = 0;
                                      for (double u : mu) {
                                          const auto s = mie.amplitudes(u);
                                          acc += 0.5 * (std::sqrt(std::norm(s.S1)) + std::sqrt(std::norm(s.S2)));
                                      }
                                      sink = acc;
                                  }, 1));
                tg = std::min(tg, min_time([&] {
                                  const grainlight::Goa goa(water, x);
                                  double acc = 0;
                                  for (double t : theta) {
                                      const auto s = goa.amplitudes_at_angle(t);
                                      acc += 0.5 * (std::sqrt(std::norm(s.S1)) + std::sqrt(std::norm(s.S2)));
                                  }
                                  sink = acc;
                              }, 3));
                tc = std::min(tc, min_time([&] {
                                  double acc = 0;
                                  for (std::size_t i = 0; i < theta.size(); ++i) {
                                      const auto s = table.amplitudes(x, i);
                                      acc += 0.5 * (std::sqrt(std::norm(s.S1)) + std::sqrt(std::norm(s.S2)));
                                  }
                                  sink = acc;
                              }, 3));
            }
            rows.push_back({r, tm, tg, tc, tp});
            tcsv.row({r, tm, tg, tm / tg, tc, tm / tc, tp});
            tbar.advance();
        }
        tbar.done();
        (void)sink;
        const auto runtime_csv = ex.csv("guo21_fig6_runtime.csv", tcsv);
        ex.plot("guo21_fig6_error_runtime", error_csv, out / "guo21_fig6_error_runtime.png", {runtime_csv.string()});

        auto at = [&](double eta, double r) -> const Err& {
            std::size_t i = std::size_t(std::find(etas.begin(), etas.end(), eta) - etas.begin());
            std::size_t j = 0;
            for (std::size_t k = 0; k < radii.size(); ++k)
                if (std::abs(radii[k] - r) < std::abs(radii[j] - r)) j = k;
            return err[i * radii.size() + j];
        };
        std::printf("Guo21 Fig. 6 (left): error of (|S1|+|S2|)/2, GOA (p <= 3) vs Mie, lambda = 0.6 um, 1-deg steps\n");
        std::printf("  %-6s %8s %10s %10s %10s\n", "eta", "r [um]", "relmse", "energy", "logerr");
        for (double eta : etas)
            for (double r : {1.0, 2.0, 5.0, 10.0, 100.0}) {
                const auto& e = at(eta, r);
                std::printf("  %-6.2f %8.1f %10.4f %10.4f %10.4f\n", eta, r, e.relmse, e.energy, e.logerr);
            }
        std::printf("  paper: 'errors of less than 0.01 when r >= 2 um' -> the energy-weighted measure gives %.4f at "
                    "2 um and %.4f at 5 um (eta 1.33);\n  the per-angle RelMSE gives %.3f at 2 um and %.3f at 100 um: "
                    "only the energy-weighted measure matches (from r ~ 4-5 um on).\n",
                    at(1.33, 2).energy, at(1.33, 5).energy, at(1.33, 2).relmse, at(1.33, 100).relmse);
        std::printf("Guo21 Fig. 6 (right): runtime ratio t_Mie / t_GOA (181 angles, this build, side by side;\n"
                    "  t_Mie = series + angle-span kernel, t_Mie(1x1) = the same with one amplitudes(mu) call per angle)\n");
        std::printf("  %8s %12s %12s %8s %14s %8s %14s\n", "r [um]", "t_Mie [s]", "t_GOA [s]", "ratio", "t_GOAcache [s]",
                    "ratio", "t_Mie(1x1) [s]");
        for (const auto& row : rows)
            std::printf("  %8.0f %12.3g %12.3g %8.1f %14.3g %8.1f %14.3g\n", row.r, row.tm, row.tg, row.tm / row.tg,
                        row.tc, row.tm / row.tc, row.tp);
        std::printf("  paper: the ratio grows linearly with r and reaches two orders of magnitude; GOA's cost is flat.\n");
        auto row_at = [&](double r) {
            for (const auto& row : rows)
                if (row.r == r) return row;
            return rows.back();
        };
        gl_examples::Json j = ex.summary();
        j.num("energy_err_eta133_r2", at(1.33, 2).energy)
            .num("energy_err_eta133_r5", at(1.33, 5).energy)
            .num("energy_err_eta133_r10", at(1.33, 10).energy)
            .num("relmse_eta133_r2", at(1.33, 2).relmse)
            .num("relmse_eta133_r100", at(1.33, 100).relmse)
            .num("ratio_r1", row_at(1).tm / row_at(1).tg)
            .num("ratio_r100", row_at(100).tm / row_at(100).tg)
            .num("ratio_r1000", row_at(1000).tm / row_at(1000).tg)
            .num("ratio_cached_r100", row_at(100).tm / row_at(100).tc)
            .num("ratio_cached_r1000", row_at(1000).tm / row_at(1000).tc)
            .num("t_mie_r1000", row_at(1000).tm)
            .num("t_mie_per_angle_r1000", row_at(1000).tp)
            .num("t_goa_r1", row_at(1).tg)
            .num("t_goa_r1000", row_at(1000).tg);
        return ex.finish(j);
    });
}
