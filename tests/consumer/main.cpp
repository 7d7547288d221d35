// Consumer smoke test: compose a homogeneous medium with a phase function inside "our own"
// integrator loop (a tiny photon walk in an infinite medium) using only the installed package.
#include <cmath>
#include <cstdio>

#include <grainlight/grainlight.hpp>

int main() {
    using namespace grainlight;
    using Phase = HenyeyGreenstein<double, RGBd>;
    ContinuousMedium<Phase, RGBd> medium(RGBd(1.0), RGBd(0.9), Phase(0.5));
    // Mean number of scattering events in an infinite medium of albedo a is a / (1 - a) = 9.
    double events = 0;
    const int paths = 20000;
    for (int i = 0; i < paths; ++i) {
        auto rng = Pcg32::from_key(1, std::uint64_t(i));
        Ray<double> ray(Vec3d(0), Vec3d(0, 0, 1));
        for (;;) {
            auto it = medium.sample_interaction(ray, std::numeric_limits<double>::infinity(), rng);
            if (!it.is_scatter()) break;
            events += 1;
            auto s = medium.phase().sample(ray.d, rng.uniform2<double>());
            ray = Ray<double>(it.p, s.w);
        }
    }
    const double mean = events / paths;
    std::printf("grainlight %s consumer: mean scattering events %.3f (expected 9)\n", version_string, mean);
    return std::abs(mean - 9.0) < 0.5 ? 0 : 1;
}
