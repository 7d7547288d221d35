// libFuzzer target: PackingLibrary::load (kind TLIB, tiles nested inside). See fuzz_common.hpp.
#include "fuzz_common.hpp"
#include "grainlight/packing/packing_library.hpp"

using namespace grainlight;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
    gl_fuzz::seed_corpus(*argc, *argv, true, [](const std::filesystem::path& p) {
        PackingLibrary lib;
        lib.add(PeriodicTile(1.0, 0.1, {Vec3d(0.2, 0.2, 0.2), Vec3d(0.7, 0.7, 0.7)}));
        lib.add(PeriodicTile(2.0, 0.3, {Vec3d(0.5, 1.5, 0.5)}));
        lib.save(p);
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return gl_fuzz::run_container_loader(data, size, PackingLibrary::file_kind, PackingLibrary::file_kind_version,
                                         [](const std::filesystem::path& p) { (void)PackingLibrary::load(p); });
}
