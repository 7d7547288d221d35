// Microbenchmarks of the diffusion profiles (items/s = profile evaluations/s): the classical
// dipole R(r), the improved point-source profile (what Meng15's VPT -> DA switch evaluates per
// connection), its beam-integrated profile (a depth quadrature of ~100-300 point evaluations),
// and the multipole slab point profiles (2 n + 1 image pairs each).
#include <benchmark/benchmark.h>

#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/diffusion.hpp"

using namespace grainlight;

namespace {
std::vector<double> radii() {
    auto rng = Pcg32::from_key(7);
    std::vector<double> r(1024);
    for (auto& x : r) x = 0.01 + 10.0 * rng.uniform<double>();
    return r;
}

template <class Fn>
void loop(benchmark::State& state, Fn&& f) {
    const auto r = radii();
    std::size_t i = 0;
    for (auto _ : state) {
        const double v = f(r[i++ & 1023]);
        benchmark::DoNotOptimize(v);
    }
    state.SetItemsProcessed(state.iterations());
}

void BM_dipole_R(benchmark::State& s) {
    const ClassicalDipole<double> m(0.99, 0.01, 1.3);
    loop(s, [&](double r) { return m.R(r); });
}
void BM_dipole_R_float(benchmark::State& s) {
    const ClassicalDipole<float> m(0.99f, 0.01f, 1.3f);
    loop(s, [&](double r) { return double(m.R(float(r))); });
}
void BM_improved_point_R(benchmark::State& s) {
    const ImprovedDiffusion<double> m(0.99, 0.01, 1.0);
    loop(s, [&](double r) { return m.point_R(r, 0.7); });
}
void BM_improved_beam_R(benchmark::State& s) {
    const ImprovedDiffusion<double> m(0.99, 0.01, 1.0);
    loop(s, [&](double r) { return m.R(r); });
}
void BM_multipole_point_R(benchmark::State& s) {
    const MultipoleSlab<double> m(0.99, 0.01, 1.0, 4.0, DiffusionModel::improved);
    s.counters["pairs"] = m.n_pairs();
    loop(s, [&](double r) { return m.point_R(r, 0.7); });
}
void BM_multipole_point_T(benchmark::State& s) {
    const MultipoleSlab<double> m(0.99, 0.01, 1.0, 4.0, DiffusionModel::improved);
    loop(s, [&](double r) { return m.point_T(r, 0.7); });
}
void BM_multipole_point_totals(benchmark::State& s) {
    const MultipoleSlab<double> m(0.99, 0.01, 1.0, 4.0, DiffusionModel::improved);
    loop(s, [&](double z) { return m.point_totals(z * 0.39).R; });
}
void BM_fresnel_moments_construct(benchmark::State& s) {
    loop(s, [&](double r) { return ImprovedDiffusion<double>(0.99, 0.01, 1.0 + 0.05 * r).A(); });
}
}  // namespace

BENCHMARK(BM_dipole_R);
BENCHMARK(BM_dipole_R_float);
BENCHMARK(BM_improved_point_R);
BENCHMARK(BM_improved_beam_R);
BENCHMARK(BM_multipole_point_R);
BENCHMARK(BM_multipole_point_T);
BENCHMARK(BM_multipole_point_totals);
BENCHMARK(BM_fresnel_moments_construct);
