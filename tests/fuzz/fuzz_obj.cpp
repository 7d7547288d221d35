// libFuzzer target: load_obj (Wavefront OBJ text). The whole input is the file (no mode byte
// semantics: byte 0 is part of the text too). See fuzz_common.hpp.
#include "fuzz_common.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

using namespace grainlight;

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
    gl_fuzz::seed_corpus(*argc, *argv, false, [](const std::filesystem::path& p) {
        std::ofstream f(p);
        f << "# unit cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
             "vn 0 0 1\nvt 0 0\nf 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\n"
             "f 3/1 4/1 8/1\nf 3//1 8//1 7//1\nf -8 -4 -1 -5\n";
    });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    gl_fuzz::write_bytes(gl_fuzz::scratch_path(), data, size);
    try {
        (void)load_obj<float>(gl_fuzz::scratch_path().string());
    } catch (const format_error&) {
    } catch (const invalid_argument&) {
    }
    return 0;
}
