// Crash-safe writers: every writer (EXR, PNG, binary container, text through write_file_atomic,
// which the examples' CSV/JSON writers use) writes a temporary file and renames it over the
// target, so a process killed at any moment leaves under the target path either the old complete
// file or the new complete one.
//
// Two hidden test cases are driven by tests/scene/crash_writers.sh (ctest `crash_safe_writers`):
// `[.crash_writer]` rewrites the four files in a loop (version k = 0, 1, 2, ...) until it is killed
// with SIGKILL at a seeded pseudo-random moment; `[.crash_verify]` then checks that each target is
// a complete, valid file of a single version. The directory is $GRAINLIGHT_CRASH_DIR; the writer
// stops by itself after $GRAINLIGHT_CRASH_ROUNDS rounds (default: effectively never).
// The visible test case checks the verifier itself rejects a truncated file of each kind.
#include <catch2/catch.hpp>
#include <png.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "grainlight/core/serialization.hpp"
#include "grainlight/scene/image_io.hpp"

using namespace grainlight;
namespace fs = std::filesystem;

namespace {

constexpr int kW = 384, kH = 256;
constexpr std::uint32_t kKind = fourcc("CRSH");
constexpr std::size_t kPayloadWords = 1 << 17;  // 1 MiB container payload
constexpr std::size_t kTextBytes = 1 << 19;     // 512 KiB text file

// Linear pixel value of version k: an 8-bit ramp so that the PNG bytes are exactly predictable.
double pattern(std::uint64_t k, int x, int y, int c) {
    return double((k * 37 + std::uint64_t(x) * 3 + std::uint64_t(y) * 5 + std::uint64_t(c) * 11) % 256) / 255.0;
}

Image version_image(std::uint64_t k) {
    Image img(kW, kH);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = float(pattern(k, x, y, c));
    return img;
}

std::string version_text(std::uint64_t k) {
    std::string head = "{\"version\": " + std::to_string(k) + ", \"padding\": \"";
    std::string s = head + std::string(kTextBytes - head.size() - 3, char('a' + k % 26)) + "\"}\n";
    return s;
}

fs::path dir_from_env() {
    const char* d = std::getenv("GRAINLIGHT_CRASH_DIR");
    return d ? fs::path(d) : fs::temp_directory_path() / "grainlight_crash_writers";
}

void write_version(const fs::path& dir, std::uint64_t k) {
    write_exr(dir / "image.exr", version_image(k));
    write_png(dir / "image.png", version_image(k));
    std::vector<unsigned char> payload(kPayloadWords * 8);
    for (std::size_t i = 0; i < kPayloadWords; ++i) std::memcpy(payload.data() + 8 * i, &k, 8);
    write_container_atomic(dir / "table.bin", kKind, 1, payload);
    const std::string text = version_text(k);
    write_file_atomic(dir / "summary.json", text.data(), text.size());
}

// Each verifier returns "" for a complete file of one version, else what is wrong.
std::string verify_exr(const fs::path& p) {
    Image img;
    try {
        img = read_exr(p);
    } catch (const std::exception& e) {
        return e.what();
    }
    if (img.width != kW || img.height != kH) return "wrong size";
    const auto k0 = std::uint64_t(std::lround(img.at(0, 0, 0) * 255.0));  // (37 k) mod 256
    for (std::uint64_t k = 0; k < 256; ++k) {
        if ((k * 37) % 256 != k0) continue;
        bool all = true;
        for (int y = 0; y < kH && all; ++y)
            for (int x = 0; x < kW && all; ++x)
                for (int c = 0; c < 3 && all; ++c) all = img.at(x, y, c) == float(pattern(k, x, y, c));
        if (all) return "";
    }
    return "pixels of more than one version";
}

std::string verify_png(const fs::path& p) {
    png_image im{};
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&im, p.c_str())) return std::string("png header: ") + im.message;
    im.format = PNG_FORMAT_RGB;
    std::vector<unsigned char> px(PNG_IMAGE_SIZE(im));
    if (!png_image_finish_read(&im, nullptr, px.data(), 0, nullptr)) return std::string("png data: ") + im.message;
    if (im.width != unsigned(kW) || im.height != unsigned(kH)) return "wrong size";
    for (std::uint64_t k = 0; k < 256; ++k) {
        bool all = true;
        for (int y = 0; y < kH && all; ++y)
            for (int x = 0; x < kW && all; ++x)
                for (int c = 0; c < 3 && all; ++c)
                    all = px[(std::size_t(y) * kW + std::size_t(x)) * 3 + std::size_t(c)] ==
                          std::lround(detail::srgb_encode(pattern(k, x, y, c)) * 255.0);
        if (all) return "";
    }
    return "pixels of more than one version";
}

std::string verify_container(const fs::path& p) {
    std::vector<unsigned char> payload;
    try {
        payload = read_container(p, kKind, 1);
    } catch (const std::exception& e) {
        return e.what();
    }
    if (payload.size() != kPayloadWords * 8) return "wrong payload size";
    for (std::size_t i = 1; i < kPayloadWords; ++i)
        if (std::memcmp(payload.data(), payload.data() + 8 * i, 8) != 0) return "payload of more than one version";
    return "";
}

std::string verify_text(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    const std::string s((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const auto a = s.find(": "), b = s.find(',');
    if (a == std::string::npos || b == std::string::npos || b < a) return "no version field";
    const std::uint64_t k = std::stoull(s.substr(a + 2, b - a - 2));
    return s == version_text(k) ? "" : "text is not one complete version";
}

void verify_all(const fs::path& dir) {
    for (const char* name : {"image.exr", "image.png", "table.bin", "summary.json"}) REQUIRE(fs::exists(dir / name));
    INFO("directory " << dir);
    CHECK(verify_exr(dir / "image.exr") == "");
    CHECK(verify_png(dir / "image.png") == "");
    CHECK(verify_container(dir / "table.bin") == "");
    CHECK(verify_text(dir / "summary.json") == "");
}

}  // namespace

TEST_CASE("crash writer loop (driven by crash_writers.sh)", "[.crash_writer]") {
    const fs::path dir = dir_from_env();
    fs::create_directories(dir);
    const char* r = std::getenv("GRAINLIGHT_CRASH_ROUNDS");
    const std::uint64_t rounds = r ? std::stoull(r) : (1ull << 40);
    const char* s = std::getenv("GRAINLIGHT_CRASH_START");
    const std::uint64_t start = s ? std::stoull(s) : 0;
    for (std::uint64_t k = start; k < start + rounds; ++k) write_version(dir, k);
    SUCCEED();
}

TEST_CASE("crash verifier (driven by crash_writers.sh)", "[.crash_verify]") { verify_all(dir_from_env()); }

TEST_CASE("The crash verifier accepts whole files and rejects truncated ones of each kind", "[image_io][crash]") {
    const fs::path dir = fs::temp_directory_path() / "grainlight_crash_verifier_selftest";
    fs::remove_all(dir);
    fs::create_directories(dir);
    write_version(dir, 3);
    verify_all(dir);
    for (const char* name : {"image.exr", "image.png", "table.bin", "summary.json"}) {
        const fs::path p = dir / name;
        const auto size = fs::file_size(p);
        fs::resize_file(p, size - size / 3);  // what a non-atomic writer killed mid-way leaves
    }
    CHECK(verify_exr(dir / "image.exr") != "");
    CHECK(verify_png(dir / "image.png") != "");
    CHECK(verify_container(dir / "table.bin") != "");
    CHECK(verify_text(dir / "summary.json") != "");
    // No temporary file is left behind by a completed write.
    int leftovers = 0;
    for (const auto& e : fs::directory_iterator(dir)) leftovers += e.path().string().find(".tmp") != std::string::npos;
    CHECK(leftovers == 0);
    fs::remove_all(dir);
}
