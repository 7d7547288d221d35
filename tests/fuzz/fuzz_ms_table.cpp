// libFuzzer target: MsTable<3>::load (kind MSTB). See fuzz_common.hpp.
#include "fuzz_common.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"

using namespace grainlight;
using RGBf = Spectrum<3, float>;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
    gl_fuzz::seed_corpus(*argc, *argv, true, [](const std::filesystem::path& p) {
        MsTableOptions o;
        o.n_rho = 4;
        o.n_z = 4;
        o.n_theta = 2;
        o.n_phi = 2;
        o.rho_max = 4;
        o.z_min = -4;
        o.z_max = 4;
        o.photons = 2000;
        MsTable<3>::build(HenyeyGreenstein<float, RGBf>(0.5f), RGBf{0.3f, 0.5f, 0.7f}, o).save(p);
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return gl_fuzz::run_container_loader(data, size, MsTable<3>::file_kind, MsTable<3>::file_version,
                                         [](const std::filesystem::path& p) { (void)MsTable<3>::load(p); });
}
