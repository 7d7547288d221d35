// Colour science for the spectral renders (core/color.hpp) and the ice index (optics/ice_index.hpp).
#include <catch2/catch.hpp>

#include "common/data_dir.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "grainlight/core/color.hpp"
#include "grainlight/optics/ice_index.hpp"

namespace gl = grainlight;

namespace {
std::vector<std::vector<double>> read_csv(const std::string& name) {
    std::ifstream in(grainlight_test::data_dir() + "/" + name);
    std::vector<std::vector<double>> rows;
    std::string line;
    while (std::getline(in, line)) {
        if (line.empty() || !(std::isdigit(static_cast<unsigned char>(line[0])))) continue;
        std::stringstream ss(line);
        std::vector<double> r;
        std::string cell;
        while (std::getline(ss, cell, ',')) r.push_back(std::stod(cell));
        rows.push_back(r);
    }
    return rows;
}
}  // namespace

TEST_CASE("CIE 1931 table equals tests/data/cie1931_2deg_5nm.csv (CIE 15:2004)", "[color]") {
    const auto rows = read_csv("cie1931_2deg_5nm.csv");
    REQUIRE(rows.size() == gl::Cie1931Table::size);
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const gl::Vec3d c = gl::cie1931_cmf(rows[i][0]);
        CHECK(c.x == Approx(rows[i][1]).margin(1e-12));
        CHECK(c.y == Approx(rows[i][2]).margin(1e-12));
        CHECK(c.z == Approx(rows[i][3]).margin(1e-12));
    }
    CHECK(gl::cie1931_cmf(555).y == Approx(1.0));  // y_bar(555 nm) = 1 by definition
    CHECK(gl::cie1931_cmf(379).y == 0.0);
    CHECK(gl::cie1931_cmf(781).x == 0.0);
}

TEST_CASE("CIE Y of the flat unit spectrum and the equal-energy white point", "[color]") {
    // int y_bar dlambda = 106.857 nm (CIE 1931 2-degree; the 1 nm, 360-830 nm table gives
    // 106.856895, the constant pbrt and others normalize by; the 5 nm table truncated at 380-780 nm
    // loses < 1e-5 of it).
    const gl::Vec3d I = gl::cie1931_cmf_integral(380, 780);
    CHECK(I.y == Approx(106.856895).epsilon(2e-5));
    // Illuminant E has chromaticity x = y = 1/3 (its X, Y, Z integrals are equal by construction
    // of the 1931 CMFs).
    CHECK(I.x / (I.x + I.y + I.z) == Approx(1.0 / 3).epsilon(1e-4));
    CHECK(I.y / (I.x + I.y + I.z) == Approx(1.0 / 3).epsilon(1e-4));
    // The bins sum to the whole integral for any N.
    gl::Vec3d s(0.0);
    for (std::size_t i = 0; i < 8; ++i) s += gl::WavelengthBins<8>::xyz_weight(i);
    CHECK(s.y == Approx(I.y).epsilon(1e-12));
    CHECK(gl::WavelengthBins<8>::lambda_nm(0) == Approx(405));
    CHECK(gl::WavelengthBins<8>::lambda_nm(7) == Approx(755));
}

TEST_CASE("sRGB white round-trips through XYZ (IEC 61966-2-1)", "[color]") {
    const gl::Vec3d xyz = gl::linear_srgb_to_xyz(gl::Vec3d(1.0));
    // D65 white of the standard: (0.9505, 1.0000, 1.0890).
    CHECK(xyz.x == Approx(0.9505).margin(1e-4));
    CHECK(xyz.y == Approx(1.0).margin(1e-4));
    CHECK(xyz.z == Approx(1.0890).margin(1e-4));
    const gl::Vec3d back = gl::xyz_to_linear_srgb(xyz);
    for (int a = 0; a < 3; ++a) CHECK(back[a] == Approx(1.0).margin(1e-3));
    // A primary round-trips too.
    const gl::Vec3d red = gl::xyz_to_linear_srgb(gl::linear_srgb_to_xyz(gl::Vec3d(1, 0, 0)));
    CHECK(red.x == Approx(1.0).margin(1e-3));
    CHECK(std::abs(red.y) < 1e-3);
    CHECK(std::abs(red.z) < 1e-3);
}

TEST_CASE("Jakob-Hanika upsampling: reflectances in [0,1] reproduce their RGB", "[color]") {
    const std::vector<gl::Vec3d> colours = {{0.7, 0.7, 0.7}, {0.63, 0.065, 0.05}, {0.14, 0.45, 0.091}, {0.2, 0.3, 0.8},
                                            {0.9, 0.8, 0.1}, {0.05, 0.05, 0.05}, {1.0, 1.0, 1.0}, {0.5, 0.2, 0.6}};
    for (const auto& c : colours) {
        const gl::SigmoidSpectrum s = gl::fit_sigmoid_spectrum(c);
        for (double l = 380; l <= 780; l += 1) {
            const double v = s(l);
            CHECK(v >= 0.0);
            CHECK(v <= 1.0);
        }
        const gl::Vec3d got = gl::balanced_rgb_of_spectrum(s);
        INFO("rgb " << c.x << " " << c.y << " " << c.z << " -> " << got.x << " " << got.y << " " << got.z);
        for (int a = 0; a < 3; ++a) CHECK(got[a] == Approx(c[a]).margin(0.01));
    }
    // A grey is flat: the quadratic and linear coefficients vanish.
    const gl::SigmoidSpectrum g = gl::fit_sigmoid_spectrum(gl::Vec3d(0.4));
    CHECK(g(400) == Approx(0.4).margin(2e-3));
    CHECK(g(700) == Approx(0.4).margin(2e-3));
    // The balanced RGB of the unit spectrum is white.
    const gl::Vec3d w = gl::balanced_rgb_of_spectrum([](double) { return 1.0; });
    for (int a = 0; a < 3; ++a) CHECK(w[a] == Approx(1.0).epsilon(1e-9));
    const auto e = gl::fit_emission_spectrum(gl::Vec3d(12.0));
    CHECK(e(555) == Approx(12.0).epsilon(1e-3));
    CHECK_THROWS_WITH(gl::fit_sigmoid_spectrum(gl::Vec3d(1.5, 0, 0)), Catch::Contains("rgb"));
    CHECK_THROWS_WITH(gl::fit_emission_spectrum(gl::Vec3d(-1, 0, 0)), Catch::Contains("rgb"));
}

TEST_CASE("ice index equals tests/data/ice_warren_brandt_2008.csv (Warren & Brandt 2008)", "[color]") {
    const auto rows = read_csv("ice_warren_brandt_2008.csv");
    REQUIRE(rows.size() == gl::IceIndexTable::size);
    for (const auto& r : rows) {
        const auto m = gl::ice_refractive_index(r[0]);
        CHECK(m.real() == Approx(r[1]).epsilon(1e-12));
        CHECK(m.imag() == Approx(r[2]).epsilon(1e-9));
    }
    // Normal dispersion over the visible: n falls with lambda, 1.319 at 400 nm to 1.306 at 700 nm.
    CHECK(gl::ice_refractive_index(0.4).real() > gl::ice_refractive_index(0.7).real());
    CHECK(gl::ice_refractive_index(0.55).real() == Approx(1.311).margin(0.002));
}
