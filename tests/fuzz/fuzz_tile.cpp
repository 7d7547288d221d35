// libFuzzer target: PeriodicTile::load (kind TILE). See fuzz_common.hpp.
#include "fuzz_common.hpp"
#include "grainlight/packing/periodic_tile.hpp"

using namespace grainlight;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
    gl_fuzz::seed_corpus(*argc, *argv, true, [](const std::filesystem::path& p) {
        PeriodicTile(1.0, 0.1, {Vec3d(0.2, 0.2, 0.2), Vec3d(0.7, 0.7, 0.7), Vec3d(0.1, 0.8, 0.5)}).save(p);
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return gl_fuzz::run_container_loader(data, size, PeriodicTile::file_kind, PeriodicTile::file_kind_version,
                                         [](const std::filesystem::path& p) { (void)PeriodicTile::load(p); });
}
