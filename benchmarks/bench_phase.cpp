// Microbenchmarks of the phase-function and continuous-medium kernels (items/s = samples/s).
// The machine is shared: run with --benchmark_repetitions=5 and read the "min" rows.
// BM_Tabulated_Sample/n samples a TabulatedPhase of n nodes through the guide table of
// core/distribution.hpp (issue 13: cost independent of n).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "grainlight/media.hpp"
#include "grainlight/phase.hpp"

using namespace grainlight;

namespace {
double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }
template <class P>
void sample_loop(benchmark::State& state, const P& p) {
    auto rng = Pcg32::from_key(1);
    const Vec3<float> w_in(0.f, 0.f, 1.f);
    for (auto _ : state) {
        auto s = p.sample(w_in, rng.uniform2<float>());
        benchmark::DoNotOptimize(s);
    }
    state.SetItemsProcessed(state.iterations());
}
template <class P>
void eval_loop(benchmark::State& state, const P& p) {
    auto rng = Pcg32::from_key(2);
    std::vector<Vec3<float>> dirs;
    for (int i = 0; i < 1024; ++i) dirs.push_back(sample_uniform_sphere(rng.uniform2<float>()));
    const Vec3<float> w_in(0.f, 0.f, 1.f);
    std::size_t i = 0;
    for (auto _ : state) {
        auto e = p.eval(w_in, dirs[i++ & 1023]);
        benchmark::DoNotOptimize(e);
    }
    state.SetItemsProcessed(state.iterations());
}
TabulatedPhase<float, Spectrum<1, float>> make_table(int nodes) {
    std::vector<double> mu, v;
    for (int i = 0; i < nodes; ++i) {
        const double t = double(i) / (nodes - 1);
        mu.push_back(1.0 - 2.0 * (1.0 - t) * (1.0 - t));  // denser toward mu = 1
        v.push_back(henyey_greenstein_cos_pdf(mu.back(), 0.9));
    }
    mu.front() = -1.0;
    mu.back() = 1.0;
    return TabulatedPhase<float, Spectrum<1, float>>::from_values(mu, v);
}
}  // namespace

static void BM_HG_Sample(benchmark::State& s) { sample_loop(s, HenyeyGreenstein<float>(0.7f)); }
static void BM_HG_Eval(benchmark::State& s) { eval_loop(s, HenyeyGreenstein<float>(0.7f)); }
static void BM_Tabulated_Sample(benchmark::State& s) { sample_loop(s, make_table(int(s.range(0)))); }
static void BM_Tabulated_Eval(benchmark::State& s) { eval_loop(s, make_table(int(s.range(0)))); }
BENCHMARK(BM_HG_Sample)->ComputeStatistics("min", min_of);
BENCHMARK(BM_HG_Eval)->ComputeStatistics("min", min_of);
BENCHMARK(BM_Tabulated_Sample)->Arg(64)->Arg(1024)->Arg(16384)->ComputeStatistics("min", min_of);
BENCHMARK(BM_Tabulated_Eval)->Arg(64)->Arg(1024)->Arg(16384)->ComputeStatistics("min", min_of);

static void BM_FreeFlight_Grey(benchmark::State& state) {
    ContinuousMedium<HenyeyGreenstein<float>> m(1.0f, 0.9f, HenyeyGreenstein<float>(0.5f));
    auto rng = Pcg32::from_key(3);
    const Ray<float> ray(Vec3f(0.f), Vec3f(0.f, 0.f, 1.f));
    for (auto _ : state) benchmark::DoNotOptimize(m.sample_interaction(ray, 2.0f, rng));
    state.SetItemsProcessed(state.iterations());
}
static void BM_FreeFlight_SpectralRGB(benchmark::State& state) {
    using P = HenyeyGreenstein<float, RGB>;
    ContinuousMedium<P> m(RGB{0.5f, 1.0f, 2.0f}, RGB{0.9f, 0.8f, 0.7f}, P(0.5f));
    auto rng = Pcg32::from_key(4);
    const Ray<float> ray(Vec3f(0.f), Vec3f(0.f, 0.f, 1.f));
    for (auto _ : state) benchmark::DoNotOptimize(m.sample_interaction(ray, 2.0f, rng));
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_FreeFlight_Grey)->ComputeStatistics("min", min_of);
BENCHMARK(BM_FreeFlight_SpectralRGB)->ComputeStatistics("min", min_of);
