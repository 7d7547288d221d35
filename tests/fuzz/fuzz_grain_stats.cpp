// libFuzzer target: load_grain_stats (kind SCAT). See fuzz_common.hpp.
#include "fuzz_common.hpp"
#include "grainlight/precompute/scatterometer.hpp"

using namespace grainlight;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
    gl_fuzz::seed_corpus(*argc, *argv, true, [](const std::filesystem::path& p) {
        ScatterometerConfig c;
        c.rays = 2000;
        c.seed = 7;
        save_grain_stats(p, run_scatterometer(ScatterometerGrain::sphere(0.8, GrainMaterial::make_diffuse(RGBd{0.2, 0.5, 0.8})), c));
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return gl_fuzz::run_container_loader(data, size, grain_stats_kind, grain_stats_version,
                                         [](const std::filesystem::path& p) { (void)load_grain_stats(p); });
}
