// Render checkpoint files (scene/film_checkpoint.hpp): exact round trip of every accumulator, and
// hostile files (truncated, bad flags, non-finite sums, size fields that announce more than the
// file holds) rejected with format_error naming the problem.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <limits>

#include "grainlight/scene/film_checkpoint.hpp"

using namespace grainlight;

namespace {
FilmCheckpoint sample_checkpoint() {
    FilmCheckpoint c;
    c.seed = 11;
    c.spp = 64;
    c.key = 0xfeedbeefull;
    c.films = {Film(7, 3), Film(7, 3)};
    c.films[0].add_rgb(0, 0, 0.1, 0.2, 0.30000000000000004);
    c.films[0].add_rgb(6, 2, 1e-300, 3.5, 7.25, 2.0);
    c.films[0].add_nonfinite(6, 2);
    c.films[1].add_rgb(3, 1, 9.0, 8.0, 7.0);
    c.rows_done = {1, 0, 1};
    return c;
}
std::filesystem::path scratch(const char* name) {
    const auto dir = std::filesystem::temp_directory_path() / "grainlight_test_film_checkpoint";
    std::filesystem::create_directories(dir);
    return dir / name;
}
}  // namespace

TEST_CASE("Film checkpoints round-trip every accumulator exactly", "[film][checkpoint]") {
    const FilmCheckpoint c = sample_checkpoint();
    const auto path = scratch("round_trip.fckp");
    c.save(path);
    const FilmCheckpoint r = FilmCheckpoint::load(path);
    CHECK(r.seed == 11);
    CHECK(r.spp == 64);
    CHECK(r.key == 0xfeedbeefull);
    CHECK(r.rows_done == c.rows_done);
    CHECK(r.rows_finished() == 2);
    REQUIRE(r.films.size() == 2);
    for (std::size_t k = 0; k < 2; ++k) {
        REQUIRE(r.films[k].width() == 7);
        REQUIRE(r.films[k].height() == 3);
        for (std::size_t i = 0; i < c.films[k].sums().size(); ++i) CHECK(r.films[k].sums()[i] == c.films[k].sums()[i]);
        for (std::size_t i = 0; i < c.films[k].weights().size(); ++i)
            CHECK(r.films[k].weights()[i] == c.films[k].weights()[i]);
    }
    CHECK(r.films[0].nonfinite(6, 2) == 1);
    CHECK(r.films[0].nonfinite_samples() == 1);
    CHECK(r.films[0].value(6, 2, 1) == 3.5);  // weight-2 sample: (2 * 3.5) / 2
    CHECK(r.films[1].value(3, 1, 0) == 9.0);
    std::filesystem::remove(path);
}

TEST_CASE("Hostile checkpoint payloads are rejected with a clear format_error", "[film][checkpoint][errors]") {
    const auto good = sample_checkpoint().encode();
    auto decode = [](std::vector<unsigned char> p) { return FilmCheckpoint::decode(p, "test checkpoint"); };
    REQUIRE_NOTHROW(decode(good));
    // Truncated anywhere.
    for (std::size_t cut : {std::size_t(0), std::size_t(3), std::size_t(20), good.size() / 2, good.size() - 1})
        CHECK_THROWS_AS(decode(std::vector<unsigned char>(good.begin(), good.begin() + std::ptrdiff_t(cut))), format_error);
    // Trailing bytes.
    auto longer = good;
    longer.push_back(0);
    CHECK_THROWS_WITH(decode(longer), Catch::Contains("trailing"));
    // A size field announcing a huge film (must not allocate it).
    auto huge = good;
    const std::uint32_t big = 30000;
    std::memcpy(huge.data(), &big, 4);
    std::memcpy(huge.data() + 4, &big, 4);
    CHECK_THROWS_WITH(decode(huge), Catch::Contains("exceeds the data"));
    auto zero = good;
    const std::uint32_t z = 0;
    std::memcpy(zero.data(), &z, 4);
    CHECK_THROWS_WITH(decode(zero), Catch::Contains("outside [1, 32768]"));
    auto films = good;
    const std::uint32_t seventeen = 17;
    std::memcpy(films.data() + 32, &seventeen, 4);
    CHECK_THROWS_WITH(decode(films), Catch::Contains("film count 17"));
    // A row flag that is not 0/1.
    auto flag = good;
    flag[8 + 24 + 4 + 1] = 7;
    CHECK_THROWS_WITH(decode(flag), Catch::Contains("row flag 7"));
    // A NaN pixel sum.
    auto nan = good;
    const double q = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(nan.data() + 8 + 24 + 4 + 3, &q, 8);  // first sum of film 0
    CHECK_THROWS_WITH(decode(nan), Catch::Contains("non-finite pixel sum"));
    // A file of another kind.
    const auto path = scratch("wrong_kind.bin");
    write_container_atomic(path, fourcc("TILE"), 1, good);
    CHECK_THROWS_WITH(FilmCheckpoint::load(path), Catch::Contains("expected 'FCKP'"));
    std::filesystem::remove(path);
    CHECK_THROWS_AS(FilmCheckpoint::load(scratch("missing.fckp")), io_error);
}
