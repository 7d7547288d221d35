// libFuzzer target: ShellTable::load (kind SHEL). See fuzz_common.hpp.
#include "fuzz_common.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/shell.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/shell_builder.hpp"

using namespace grainlight;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
    gl_fuzz::seed_corpus(*argc, *argv, true, [](const std::filesystem::path& p) {
        using HG = HenyeyGreenstein<double>;
        const ContinuousMedium<HG> m(1.0, 0.9, HG(0.6));
        const auto samples = collect_shell_samples(ContinuousShellSource<ContinuousMedium<HG>>(m),
                                                   std::vector<double>{0.5, 1.0}, 5000, 7, 16, 4.0);
        ShellBuildOptions o;
        o.rank = 3;
        build_shell_table(samples, o).table.save(p);
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return gl_fuzz::run_container_loader(data, size, ShellTable::file_kind, ShellTable::file_kind_version,
                                         [](const std::filesystem::path& p) { (void)ShellTable::load(p); });
}
