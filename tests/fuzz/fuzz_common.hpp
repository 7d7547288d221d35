// Shared harness of the libFuzzer targets in tests/fuzz/ (one file per loader; built and run by
// scripts/fuzz.sh with clang++ -fsanitize=fuzzer,address,undefined, not part of the Catch2 glob).
//
// Input layout: byte 0 selects the mode. Even: the rest is the whole file, container header and
// all (exercises the container checks). Odd: the rest is a payload, wrapped into a valid
// container of the loader's kind and version, so that mutations reach the payload parser behind
// the checksums. The loader reads the bytes from a scratch file through its public path API.
// Accepted outcomes: a successful load, grainlight::format_error or grainlight::invalid_argument
// (a clear message); anything else (a crash, a sanitizer report, another exception such as
// std::bad_alloc or std::length_error from a hostile size) is a finding.
//
// Seeds: LLVMFuzzerInitialize writes two seeds made from a valid file (the whole file, and its
// payload) into the corpus directory given on the command line when that directory is empty.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/precompute/serialization.hpp"

namespace gl_fuzz {

/// A per-process scratch file in the temporary directory.
inline const std::filesystem::path& scratch_path() {
    static const std::filesystem::path p =
        std::filesystem::temp_directory_path() / ("grainlight_fuzz_" + std::to_string(::getpid()) + ".bin");
    return p;
}

inline void write_bytes(const std::filesystem::path& path, const unsigned char* data, std::size_t size) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();
    if (size && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
}

inline std::vector<unsigned char> read_bytes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Run `load(path)` on the input (see the layout above); `kind`/`version` of the container.
template <class Load>
int run_container_loader(const std::uint8_t* data, std::size_t size, std::uint32_t kind, std::uint32_t version,
                         Load&& load) {
    if (size == 0) return 0;
    std::vector<unsigned char> bytes;
    if (data[0] & 1)
        bytes = grainlight::encode_container(kind, version, std::vector<unsigned char>(data + 1, data + size));
    else
        bytes.assign(data + 1, data + size);
    write_bytes(scratch_path(), bytes.data(), bytes.size());
    try {
        load(scratch_path());
    } catch (const grainlight::format_error&) {
    } catch (const grainlight::invalid_argument&) {
    }
    return 0;
}

/// The corpus directory of a libFuzzer command line (the first argument that is not a flag).
inline std::filesystem::path corpus_dir(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (argv[i][0] != '-') return argv[i];
    return {};
}

/// If the corpus directory is empty: call `make(path)` to write one valid file and store it as
/// seeds: for container files two (mode 0: whole file; mode 1: payload only), else the file.
template <class Make>
void seed_corpus(int argc, char** argv, bool container, Make&& make) {
    const auto dir = corpus_dir(argc, argv);
    if (dir.empty()) return;
    std::filesystem::create_directories(dir);
    if (!std::filesystem::is_empty(dir)) return;
    const auto tmp = std::filesystem::temp_directory_path() / ("grainlight_fuzz_seed_" + std::to_string(::getpid()));
    make(tmp);
    const auto file = read_bytes(tmp);
    std::filesystem::remove(tmp);
    std::vector<unsigned char> whole;
    if (container) whole.push_back(0);  // mode byte: whole file
    whole.insert(whole.end(), file.begin(), file.end());
    write_bytes(dir / "seed_file", whole.data(), whole.size());
    if (container && file.size() >= grainlight::container_header_size) {
        std::vector<unsigned char> payload{1};
        payload.insert(payload.end(), file.begin() + grainlight::container_header_size, file.end());
        write_bytes(dir / "seed_payload", payload.data(), payload.size());
    }
}

}  // namespace gl_fuzz
