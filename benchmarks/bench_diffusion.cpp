// Microbenchmarks of the diffusion profiles (items/s = profile evaluations/s): the classical
// dipole R(r), the improved point-source profile (what Meng15's VPT -> DA switch evaluates per
// connection), its beam-integrated profile (a depth quadrature of ~100-300 point evaluations),
// and the multipole slab point profiles (2 n + 1 image pairs each).
#include <benchmark/benchmark.h>

#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/diffusion.hpp"
#include "grainlight/diffusion/grid.hpp"
#include "grainlight/scene/shapes.hpp"

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

// The point-based far field's solve (diffusion/grid.hpp): a sphere of radius R cells, the Robin
// data of a point source at its centre (Milk-like: sigma_a / sigma_t' = 3e-4), conjugate gradients
// to a relative residual of 1e-7. Items = inside cells per solve.
void BM_DiffusionGridSolve(benchmark::State& s) {
    const double R = double(s.range(0));
    const SphereShape<double> sph(Vec3<double>(0.0), R);
    const DiffusionGrid<double> grid(sph, Aabb<double>(Vec3<double>(-R), Vec3<double>(R)), 1.0);
    const double D = 1.0 / 0.9, sa = 3e-4 / 0.9 * 0.3, A = 2.5;
    std::vector<double> g(grid.faces().size());
    for (std::size_t i = 0; i < g.size(); ++i) g[i] = 1.0 / glm::length(grid.faces()[i].s);
    DiffusionSolveInfo info;
    for (auto _ : s) {
        const auto u = grid.solve(D, sa, A, {}, g, &info);
        benchmark::DoNotOptimize(u.data());
    }
    s.counters["iterations"] = info.iterations;
    s.SetItemsProcessed(s.iterations() * std::int64_t(grid.inside_count()));
}
BENCHMARK(BM_DiffusionGridSolve)->Arg(10)->Arg(20)->Unit(benchmark::kMillisecond);

BENCHMARK(BM_dipole_R);
BENCHMARK(BM_dipole_R_float);
BENCHMARK(BM_improved_point_R);
BENCHMARK(BM_improved_beam_R);
BENCHMARK(BM_multipole_point_R);
BENCHMARK(BM_multipole_point_T);
BENCHMARK(BM_multipole_point_totals);
BENCHMARK(BM_fresnel_moments_construct);
