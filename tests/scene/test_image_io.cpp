// Film accumulation and EXR/PNG files: round trip, atomic writes, bad input.
#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "grainlight/scene/film.hpp"
#include "grainlight/scene/image_io.hpp"

using namespace grainlight;
namespace fs = std::filesystem;

namespace {
fs::path scratch_dir() {
    const fs::path d = fs::temp_directory_path() / "grainlight_test_scene";
    fs::create_directories(d);
    return d;
}
}  // namespace

TEST_CASE("Film averages the samples of each pixel in double precision", "[film]") {
    Film film(3, 2);
    film.add_sample(1, 0, RGB{1.0f, 2.0f, 3.0f});
    film.add_sample(1, 0, RGB{3.0f, 2.0f, 1.0f});
    film.add_rgb(2, 1, 0.5, 0.25, 0.125);
    // 1e8 + 1 - 1e8 survives in double but not in float.
    film.add_rgb(0, 1, 1e8, 0, 0);
    film.add_rgb(0, 1, 1.0, 0, 0);
    film.add_rgb(0, 1, -1e8, 0, 0);
    CHECK(film.value(1, 0, 0) == 2.0);
    CHECK(film.value(1, 0, 2) == 2.0);
    CHECK(film.weight(1, 0) == 2.0);
    CHECK(film.value(2, 1, 1) == 0.25);
    CHECK(film.value(0, 1, 0) == Approx(1.0 / 3.0));
    CHECK(film.value(0, 0, 0) == 0.0);  // no samples
    const Image img = film.image();
    CHECK(img.at(1, 0, 1) == 2.0f);
    CHECK(img.at(2, 1, 2) == 0.125f);

    Film other(3, 2);
    other.add_rgb(2, 1, 1.5, 0, 0);
    film.merge(other);
    CHECK(film.value(2, 1, 0) == Approx(1.0));
    CHECK_THROWS_AS(film.merge(Film(2, 2)), grainlight::invalid_argument);
    CHECK_THROWS_AS(Film(0, 4), grainlight::invalid_argument);
}

TEST_CASE("EXR float round trip is exact", "[image_io]") {
    Image img(17, 5);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            img.at(x, y, 0) = 1e-6f * float(x + 1) + 3.14159265f * float(y);  // not representable in half
            img.at(x, y, 1) = 65504.0f * 3.0f + float(x);                       // beyond the half range
            img.at(x, y, 2) = -0.125f * float(x * y);
        }
    const fs::path p = scratch_dir() / "roundtrip.exr";
    fs::remove(p);
    write_exr(p, img);
    REQUIRE(fs::exists(p));
    CHECK_FALSE(fs::exists(p.string() + ".tmp"));  // temporary renamed away
    const Image back = read_exr(p);
    REQUIRE(back.width == img.width);
    REQUIRE(back.height == img.height);
    for (std::size_t i = 0; i < img.rgb.size(); ++i) REQUIRE(back.rgb[i] == img.rgb[i]);
}

TEST_CASE("EXR reader rejects missing, foreign and truncated files with the right error", "[image_io]") {
    const fs::path dir = scratch_dir();
    CHECK_THROWS_AS(read_exr(dir / "does_not_exist.exr"), grainlight::io_error);
    try {
        (void)read_exr(dir / "does_not_exist.exr");
    } catch (const grainlight::io_error& e) {
        CHECK(std::string(e.what()).find("does_not_exist.exr") != std::string::npos);
    }
    const fs::path text = dir / "not_an_exr.exr";
    {
        std::ofstream f(text);
        f << "this is not an OpenEXR file\n";
    }
    CHECK_THROWS_AS(read_exr(text), grainlight::format_error);

    // A valid file cut in half: header intact, pixel data truncated.
    Image img(64, 64);
    for (std::size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = float((i * 2654435761u) % 1000u) * 0.37f;
    const fs::path full = dir / "full.exr";
    write_exr(full, img);
    const auto size = fs::file_size(full);
    std::vector<char> bytes(size);
    {
        std::ifstream f(full, std::ios::binary);
        f.read(bytes.data(), std::streamsize(size));
    }
    const fs::path cut = dir / "truncated.exr";
    {
        std::ofstream f(cut, std::ios::binary);
        f.write(bytes.data(), std::streamsize(size / 2));
    }
    CHECK_THROWS_AS(read_exr(cut), grainlight::format_error);
    // Header only, a few bytes past the magic number.
    {
        std::ofstream f(cut, std::ios::binary | std::ios::trunc);
        f.write(bytes.data(), 12);
    }
    CHECK_THROWS_AS(read_exr(cut), grainlight::format_error);
}

TEST_CASE("EXR writer reports an unwritable path", "[image_io]") {
    Image img(2, 2);
    CHECK_THROWS_AS(write_exr(scratch_dir() / "no_such_dir" / "x.exr", img), grainlight::io_error);
    CHECK_THROWS_AS(write_png(scratch_dir() / "no_such_dir" / "x.png", img), grainlight::io_error);
    Image bad;
    CHECK_THROWS_AS(write_exr(scratch_dir() / "bad.exr", bad), grainlight::invalid_argument);
}

TEST_CASE("PNG preview is an 8-bit sRGB PNG of the right size", "[image_io]") {
    Image img(7, 3);
    img.at(0, 0, 0) = 1.0f;     // -> 255
    img.at(1, 0, 0) = 0.5f;     // sRGB(0.5) = 0.7354 -> 188
    img.at(2, 0, 0) = 100.0f;   // clamp -> 255
    img.at(3, 0, 0) = -1.0f;    // clamp -> 0
    const fs::path p = scratch_dir() / "preview.png";
    write_png(p, img);
    std::ifstream f(p, std::ios::binary);
    unsigned char sig[24] = {};
    f.read(reinterpret_cast<char*>(sig), 24);
    const unsigned char magic[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
    for (int i = 0; i < 8; ++i) CHECK(sig[i] == magic[i]);
    // IHDR: width and height big-endian at bytes 16..23.
    CHECK(((sig[16] << 24) | (sig[17] << 16) | (sig[18] << 8) | sig[19]) == 7);
    CHECK(((sig[20] << 24) | (sig[21] << 16) | (sig[22] << 8) | sig[23]) == 3);
    CHECK(detail::srgb_encode(0.5) == Approx(0.735357).epsilon(1e-5));
    CHECK(detail::srgb_encode(0.001) == Approx(0.01292));
}
