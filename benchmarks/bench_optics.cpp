// Microbenchmarks of the optics layer (Guo21 Secs. 3-4). items/s = scattering angles per second
// for the single-particle benchmarks (181 angles, 0..180 deg), wavelengths per second for the
// bulk table.
//   BM_MieAllAngles/x         Lorenz-Mie series + S1, S2 at 181 angles, x = 10 .. 10000
//   BM_GoaAllAngles/x         GOA (p <= 3) at the same x and angles, rays solved per call
//   BM_GoaCachedAllAngles/x   GOA with rays cached per angle grid (GoaTable), as bulk.hpp uses it
//   BM_BulkTable8             Eqs. 16-17 for 8 wavelengths, log-normal r_g = 10 um, sigma_g = 2
//   BM_MiePhaseSample         sampling the tabulated Mie phase function (x = 100)
#include <benchmark/benchmark.h>

#include <cmath>
#include <complex>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/optics/bulk.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/phase/mie.hpp"

using namespace grainlight;

namespace {
constexpr double kPi = 3.14159265358979323846;
const std::complex<double> kWater(1.33, 0.0);

std::vector<double> angles() {
    std::vector<double> t(181);
    for (int d = 0; d <= 180; ++d) t[std::size_t(d)] = d * kPi / 180;
    return t;
}

void BM_MieAllAngles(benchmark::State& state) {
    const double x = double(state.range(0));
    const auto th = angles();
    std::vector<double> mu(th.size());
    for (std::size_t i = 0; i < th.size(); ++i) mu[i] = std::cos(th[i]);
    for (auto _ : state) {
        const LorenzMie mie(kWater, x);
        double acc = 0;
        for (double u : mu) {
            const auto s = mie.amplitudes(u);
            acc += std::abs(s.S1) + std::abs(s.S2);
        }
        benchmark::DoNotOptimize(acc);
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(mu.size()));
}
BENCHMARK(BM_MieAllAngles)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

void BM_GoaAllAngles(benchmark::State& state) {
    const double x = double(state.range(0));
    const auto th = angles();
    for (auto _ : state) {
        const Goa goa(kWater, x);
        double acc = 0;
        for (double t : th) {
            const auto s = goa.amplitudes_at_angle(t);
            acc += std::abs(s.S1) + std::abs(s.S2);
        }
        benchmark::DoNotOptimize(acc);
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(th.size()));
}
BENCHMARK(BM_GoaAllAngles)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

void BM_GoaCachedAllAngles(benchmark::State& state) {
    const double x = double(state.range(0));
    const auto th = angles();
    const GoaTable table(kWater, 3, th);
    std::vector<double> out(th.size());
    for (auto _ : state) {
        table.intensities(x, out);
        benchmark::DoNotOptimize(out.data());
    }
    state.SetItemsProcessed(state.iterations() * std::int64_t(th.size()));
}
BENCHMARK(BM_GoaCachedAllAngles)->Arg(10)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

void BM_BulkTable8(benchmark::State& state) {
    const LogNormalPsd psd(10.0, 2.0, 0.1, 2000.0, 1e6);
    ParticleModel ice;
    ice.particle_index = {1.31, 0.0};
    std::vector<double> wl;
    for (int i = 0; i < 8; ++i) wl.push_back(0.4 + 0.05 * i);
    for (auto _ : state) {
        auto b = compute_bulk_optics(psd, ice, wl);
        benchmark::DoNotOptimize(b.channels.data());
    }
    state.SetItemsProcessed(state.iterations() * 8);
}
BENCHMARK(BM_BulkTable8)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_MiePhaseSample(benchmark::State& state) {
    const auto p = MiePhase<float, Spectrum<1, float>>::from_mie(kWater, 100.0);
    auto rng = Pcg32::from_key(3);
    const Vec3<float> w_in(0.f, 0.f, 1.f);
    for (auto _ : state) {
        auto s = p.sample(w_in, rng.uniform2<float>());
        benchmark::DoNotOptimize(s);
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_MiePhaseSample);
}  // namespace
