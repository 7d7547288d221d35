// Lorenz-Mie amplitudes at the hardware limit, side by side with a plain implementation compiled
// with the same flags in the same binary (issue 13, item 1).
//   BM_MiePlain/x          plain angles-inner baseline (below): the same recurrences as the
//                          library (D_n downward from a continued fraction, psi_n upward / by
//                          downward ratios, chi_n upward), std::complex arithmetic, then the
//                          pi_n / tau_n recurrence with the angle loop innermost (SoA arrays,
//                          `#pragma omp simd`), division by n as in the recurrence
//   BM_MiePlainNoDiv/x     the same with 1/n hoisted out of the angle loop (a stronger baseline)
//   BM_MieSpan/x           LorenzMie(m, x) + amplitudes(span, span): the library
//   BM_MieSeries/x         LorenzMie(m, x) alone (coefficients a_n, b_n)
//   BM_MiePerAngle/x       LorenzMie(m, x) + amplitudes(mu) called once per angle
//   BM_MieKernel/x         amplitudes(span, span) alone on a built series; the counter
//                          time_per_lane_term = time / (lanes evaluated x N) measures the angle kernel
//                          against its operation count (11 multiply/FMA + 1 add per angle and term)
// All: m = 1.33, 180 angles theta_i = pi i / 179 (mu_i = cos theta_i), x = 1e3, 1e4 (1e5 for the
// library). items/s = angles per second. The counter max_rel_diff is max_i |S - S_plain| / max|S|
// between the library and the plain version (checked once, before timing).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <vector>

#include "grainlight/optics/lorenz_mie.hpp"

using namespace grainlight;

namespace {
constexpr double kPi = 3.14159265358979323846;
const std::complex<double> kWater(1.33, 0.0);

// The machine is shared: run with --benchmark_repetitions=N and read the "min" rows (the least
// disturbed repetition), for every benchmark alike.
double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

std::vector<double> grid180() {
    std::vector<double> mu(180);
    for (int i = 0; i < 180; ++i) mu[std::size_t(i)] = std::cos(kPi * i / 179);
    return mu;
}

// ---- the plain baseline -----------------------------------------------------------------------
template <bool kHoistDivision>
void plain_mie(std::complex<double> m, double x, const std::vector<double>& mu, std::vector<double>& s1r,
               std::vector<double>& s1i, std::vector<double>& s2r, std::vector<double>& s2i,
               std::vector<double>& pi0, std::vector<double>& pi1) {
    using C = std::complex<double>;
    const std::size_t N = mie_num_terms(x);
    const C mx = m * x;
    const std::size_t nstart = std::max<std::size_t>(N, std::size_t(std::abs(mx))) + 16;
    std::vector<C> D(N + 1);
    C d = detail::riccati_ratio_cf(nstart, mx) - double(nstart) / mx;
    for (std::size_t n = nstart; n > N; --n) d = double(n) / mx - 1.0 / (d + double(n) / mx);
    D[N] = d;
    for (std::size_t n = N; n >= 1; --n) D[n - 1] = double(n) / mx - 1.0 / (D[n] + double(n) / mx);
    const std::size_t nup = std::min<std::size_t>(N, std::size_t(x));
    std::vector<double> r(N + 2, 0.0);
    if (nup < N) {
        double rr = detail::riccati_ratio_cf(N + 1, C(x, 0)).real();
        for (std::size_t n = N; n > nup; --n) r[n] = rr = double(2 * n + 1) / x - 1.0 / rr;
    }
    const std::size_t K = mu.size();
    for (std::size_t k = 0; k < K; ++k) {
        s1r[k] = s1i[k] = s2r[k] = s2i[k] = 0;
        pi0[k] = 0;
        pi1[k] = 1;
    }
    double psi_prev = std::sin(x), chi_prev = std::cos(x), psi_pp = std::cos(x), chi_pp = -std::sin(x);
    for (std::size_t n = 1; n <= N; ++n) {
        const double dn = double(n);
        const double psi = n <= nup ? double(2 * n - 1) / x * psi_prev - psi_pp : psi_prev / r[n];
        const double chi = double(2 * n - 1) / x * chi_prev - chi_pp;
        const C xi(psi, -chi), xi_prev(psi_prev, -chi_prev);
        const C da = D[n] / m + dn / x, db = D[n] * m + dn / x;
        const double w = (2 * dn + 1) / (dn * (dn + 1));
        const C a = w * std::conj((da * psi - psi_prev) / (da * xi - xi_prev));
        const C b = w * std::conj((db * psi - psi_prev) / (db * xi - xi_prev));
        const double ar = a.real(), ai = a.imag(), br = b.real(), bi = b.imag();
        const double c1 = 2 * dn + 1, c2 = dn + 1, inv_n = 1 / dn;
        double* p0 = pi0.data();
        double* p1 = pi1.data();
        double* a1r = s1r.data();
        double* a1i = s1i.data();
        double* a2r = s2r.data();
        double* a2i = s2i.data();
        const double* u = mu.data();
#pragma omp simd
        for (std::size_t k = 0; k < K; ++k) {
            const double tau = dn * u[k] * p1[k] - c2 * p0[k];
            a1r[k] += ar * p1[k] + br * tau;
            a1i[k] += ai * p1[k] + bi * tau;
            a2r[k] += ar * tau + br * p1[k];
            a2i[k] += ai * tau + bi * p1[k];
            const double p2 = kHoistDivision ? (c1 * u[k] * p1[k] - c2 * p0[k]) * inv_n
                                             : (c1 * u[k] * p1[k] - c2 * p0[k]) / dn;
            p0[k] = p1[k];
            p1[k] = p2;
        }
        psi_pp = psi_prev;
        psi_prev = psi;
        chi_pp = chi_prev;
        chi_prev = chi;
    }
}

struct PlainBuffers {
    std::vector<double> s1r, s1i, s2r, s2i, p0, p1;
    explicit PlainBuffers(std::size_t K) : s1r(K), s1i(K), s2r(K), s2i(K), p0(K), p1(K) {}
};

double max_rel_diff(double x) {
    const auto mu = grid180();
    PlainBuffers b(mu.size());
    plain_mie<false>(kWater, x, mu, b.s1r, b.s1i, b.s2r, b.s2i, b.p0, b.p1);
    std::vector<ScatteringAmplitudes> out(mu.size());
    LorenzMie(kWater, x).amplitudes(mu, out);
    double smax = 0, dmax = 0;
    for (std::size_t k = 0; k < mu.size(); ++k) {
        const std::complex<double> p1(b.s1r[k], b.s1i[k]), p2(b.s2r[k], b.s2i[k]);
        smax = std::max({smax, std::abs(p1), std::abs(p2)});
        dmax = std::max({dmax, std::abs(out[k].S1 - p1), std::abs(out[k].S2 - p2)});
    }
    return dmax / smax;
}

template <bool kHoist>
void BM_Plain(benchmark::State& state) {
    const double x = double(state.range(0));
    const auto mu = grid180();
    PlainBuffers b(mu.size());
    for (auto _ : state) {
        plain_mie<kHoist>(kWater, x, mu, b.s1r, b.s1i, b.s2r, b.s2i, b.p0, b.p1);
        benchmark::DoNotOptimize(b.s1r.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(mu.size()));
}
void BM_MiePlain(benchmark::State& state) { BM_Plain<false>(state); }
void BM_MiePlainNoDiv(benchmark::State& state) { BM_Plain<true>(state); }
BENCHMARK(BM_MiePlain)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);
BENCHMARK(BM_MiePlainNoDiv)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);

void BM_MieSpan(benchmark::State& state) {
    const double x = double(state.range(0));
    const auto mu = grid180();
    std::vector<ScatteringAmplitudes> out(mu.size());
    for (auto _ : state) {
        const LorenzMie mie(kWater, x);
        mie.amplitudes(mu, out);
        benchmark::DoNotOptimize(out.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(mu.size()));
    if (x <= 1e4) state.counters["max_rel_diff"] = max_rel_diff(x);
    bool finite = true;
    for (const auto& s : out) finite = finite && std::isfinite(std::abs(s.S1)) && std::isfinite(std::abs(s.S2));
    state.counters["finite"] = finite ? 1 : 0;
}
BENCHMARK(BM_MieSpan)->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);

void BM_MieKernel(benchmark::State& state) {
    const double x = double(state.range(0));
    const auto mu = grid180();
    std::vector<ScatteringAmplitudes> out(mu.size());
    const LorenzMie mie(kWater, x);
    for (auto _ : state) {
        mie.amplitudes(mu, out);
        benchmark::DoNotOptimize(out.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(mu.size()));
    // 180 angles pair into 90 evaluated lanes, padded to whole blocks
    const double lanes = double((90 + detail::kMieLanes - 1) / detail::kMieLanes * detail::kMieLanes);
    const double terms = double(mie.num_terms() + mie.num_terms() % 2);
    state.counters["time_per_lane_term"] =
        benchmark::Counter(lanes * terms, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
    state.counters["lanes_per_block"] = double(detail::kMieLanes);
}
BENCHMARK(BM_MieKernel)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);

void BM_MieSeries(benchmark::State& state) {
    const double x = double(state.range(0));
    for (auto _ : state) {
        const LorenzMie mie(kWater, x);
        benchmark::DoNotOptimize(mie.a().data());
    }
}
BENCHMARK(BM_MieSeries)->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);

void BM_MiePerAngle(benchmark::State& state) {
    const double x = double(state.range(0));
    const auto mu = grid180();
    std::vector<ScatteringAmplitudes> out(mu.size());
    for (auto _ : state) {
        const LorenzMie mie(kWater, x);
        for (std::size_t k = 0; k < mu.size(); ++k) out[k] = mie.amplitudes(mu[k]);
        benchmark::DoNotOptimize(out.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(mu.size()));
}
BENCHMARK(BM_MiePerAngle)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);
}  // namespace
