// Tests of the shared container format (grainlight/core/serialization.hpp): round trip,
// and every corruption a loader must reject with grainlight::format_error.
#include <catch2/catch.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "grainlight/core/serialization.hpp"

using namespace grainlight;

namespace {
std::vector<unsigned char> sample_payload() {
    ByteWriter w;
    w.put(std::uint64_t(3)).put(1.5).put(-2.25).put(7.0);
    return w.take();
}
std::filesystem::path temp_file(const std::string& name) {
    return std::filesystem::temp_directory_path() / ("grainlight_test_" + name);
}
std::vector<unsigned char> read_all(const std::filesystem::path& p) {
    std::ifstream f(p, std::ios::binary);
    return std::vector<unsigned char>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}
void write_all(const std::filesystem::path& p, const std::vector<unsigned char>& b) {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}
constexpr std::uint32_t kind = fourcc("TEST");
}  // namespace

TEST_CASE("FNV-1a 64 matches the published test vectors", "[serialization]") {
    // Reference values: the FNV test suite (Fowler/Noll/Vo, isthe.com/chongo/tech/comp/fnv):
    // FNV-1a 64 of "" = cbf29ce484222325, of "a" = af63dc4c8601ec8c, of "foobar" = 85944171f73967e8.
    CHECK(fnv1a64("", 0) == 0xcbf29ce484222325ull);
    CHECK(fnv1a64("a", 1) == 0xaf63dc4c8601ec8cull);
    CHECK(fnv1a64("foobar", 6) == 0x85944171f73967e8ull);
}

TEST_CASE("container round trip and atomic write", "[serialization]") {
    const auto path = temp_file("roundtrip.bin");
    const auto payload = sample_payload();
    write_container_atomic(path, kind, 2, payload);
    CHECK(std::filesystem::file_size(path) == container_header_size + payload.size());
    // No temporary file is left next to the target.
    for (const auto& e : std::filesystem::directory_iterator(path.parent_path()))
        CHECK(e.path().filename().string().rfind("grainlight_test_roundtrip.bin.tmp", 0) == std::string::npos);
    const auto back = read_container(path, kind, 2);
    REQUIRE(back == payload);
    ByteReader r(back);
    CHECK(r.get<std::uint64_t>() == 3);
    CHECK(r.get<double>() == 1.5);
    std::vector<double> rest;
    r.get_array(rest, 2);
    CHECK(rest[1] == 7.0);
    r.expect_end();
    CHECK_THROWS_AS(r.get<double>(), format_error);
    std::filesystem::remove(path);
}

TEST_CASE("container loader rejects damaged files with format_error", "[serialization]") {
    const auto path = temp_file("damaged.bin");
    write_container_atomic(path, kind, 1, sample_payload());
    const auto good = read_all(path);

    SECTION("every truncation") {
        for (std::size_t n = 0; n < good.size(); ++n) {
            write_all(path, std::vector<unsigned char>(good.begin(), good.begin() + std::ptrdiff_t(n)));
            CHECK_THROWS_AS(read_container(path, kind, 1), format_error);
        }
    }
    SECTION("every single-byte corruption") {
        for (std::size_t i = 0; i < good.size(); ++i) {
            auto bad = good;
            bad[i] ^= 0x5a;
            write_all(path, bad);
            CHECK_THROWS_AS(read_container(path, kind, 1), format_error);
        }
    }
    SECTION("trailing bytes") {
        auto bad = good;
        bad.push_back(0);
        write_all(path, bad);
        CHECK_THROWS_AS(read_container(path, kind, 1), format_error);
    }
    SECTION("wrong magic, kind or version") {
        auto bad = good;
        bad[0] = 'X';
        write_all(path, bad);
        CHECK_THROWS_WITH(read_container(path, kind, 1), Catch::Contains("magic"));
        write_all(path, good);
        CHECK_THROWS_WITH(read_container(path, fourcc("TILE"), 1), Catch::Contains("expected 'TILE'"));
        CHECK_THROWS_WITH(read_container(path, kind, 2), Catch::Contains("version"));
    }
    SECTION("hostile header announcing a huge payload (valid header checksum)") {
        ContainerHeader h;
        h.kind = kind;
        h.kind_version = 1;
        h.payload_size = std::uint64_t(1) << 60;
        const auto hb = detail::encode_header(h);
        write_all(path, std::vector<unsigned char>(hb.begin(), hb.end()));
        CHECK_THROWS_WITH(read_container(path, kind, 1), Catch::Contains("truncated"));
    }
    SECTION("missing file is an io_error") {
        std::filesystem::remove(path);
        CHECK_THROWS_AS(read_container(path, kind, 1), io_error);
    }
    std::filesystem::remove(path);
}

TEST_CASE("ByteReader checks array counts before allocating", "[serialization]") {
    const auto payload = sample_payload();
    ByteReader r(payload);
    std::vector<double> out;
    CHECK_THROWS_AS(r.get_array(out, std::uint64_t(1) << 61), format_error);
    CHECK(out.empty());
}
