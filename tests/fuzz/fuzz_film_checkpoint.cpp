// libFuzzer target: FilmCheckpoint::load (kind FCKP, render checkpoints). See fuzz_common.hpp.
#include "fuzz_common.hpp"
#include "grainlight/scene/film_checkpoint.hpp"

using namespace grainlight;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
    gl_fuzz::seed_corpus(*argc, *argv, true, [](const std::filesystem::path& p) {
        FilmCheckpoint c;
        c.seed = 3;
        c.spp = 16;
        c.key = 0x1234;
        c.films = {Film(5, 4)};
        c.films[0].add_rgb(1, 2, 0.5, 0.25, 0.125);
        c.films[0].add_nonfinite(3, 1);
        c.rows_done = {1, 0, 1, 0};
        c.save(p);
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return gl_fuzz::run_container_loader(data, size, FilmCheckpoint::file_kind, FilmCheckpoint::file_kind_version,
                                         [](const std::filesystem::path& p) { (void)FilmCheckpoint::load(p); });
}
