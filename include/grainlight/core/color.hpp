/// @file grainlight/core/color.hpp
/// Colour science for spectral rendering (Guo21 Sec. 6 renders 8 wavelength samples):
///  - the CIE 1931 2-degree standard observer's colour-matching functions x_bar, y_bar, z_bar at
///    5 nm, 380-780 nm (CIE 15:2004, Colorimetry, 3rd ed., the standard tabulation; also
///    distributed by CVRL, cvrl.org; the same numbers as tests/data/cie1931_2deg_5nm.csv),
///    interpolated linearly (0 outside the table);
///  - XYZ <-> linear sRGB with the matrices of IEC 61966-2-1:1999 (D65 white: sRGB (1, 1, 1) is
///    XYZ (0.9505, 1, 1.089));
///  - `WavelengthBins<N>`: N equal bins over 380-780 nm, each sampled at its centre, with the
///    CMFs integrated exactly over each bin (piecewise linear), so a spectrum constant per bin
///    maps to XYZ without quadrature error and a flat spectrum gives the full integrals;
///  - `SigmoidSpectrum` and `fit_sigmoid_spectrum`: RGB -> reflectance upsampling of Jakob &
///    Hanika 2019 ("A Low-Dimensional Function Space for Efficient Spectral Upsampling", Computer
///    Graphics Forum 38(2)): R(lambda) = S(c0 t^2 + c1 t + c2), S(x) = 1/2 + x / (2 sqrt(1 + x^2)),
///    which lies in (0, 1) for any coefficients; the coefficients are fitted here at set-up by a
///    damped Gauss-Newton solve with continuation from grey (their Sec. 4 procedure), not read
///    from their precomputed table. t = (lambda - 380 nm) / 400 nm (an affine reparametrization of
///    their polynomial in lambda). The RGB of a reflectance is defined under an equal-energy
///    illuminant (CIE illuminant E) in linear sRGB balanced so that R = 1 maps to (1, 1, 1)
///    (`balanced_rgb_of_spectrum`); emission colours are upsampled as scale * R with scale =
///    the largest component.
/// Set-up code (allocation and exceptions allowed); the evaluation functions are noexcept.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "grainlight/core/error.hpp"
#include "grainlight/core/vector.hpp"

namespace grainlight {

/// CIE 1931 2-degree colour-matching functions, 5 nm steps from 380 nm (CIE 15:2004).
struct Cie1931Table {
    static constexpr double lambda_min_nm = 380.0;  ///< first wavelength [nm]
    static constexpr double step_nm = 5.0;          ///< wavelength step [nm]
    static constexpr std::size_t size = 81;         ///< rows (380 .. 780 nm)
    /// x_bar(lambda_min + i step)
    static constexpr std::array<double, size> x_bar = {
        0.001368, 0.002236, 0.004243, 0.007650, 0.014310, 0.023190, 0.043510, 0.077630,
        0.134380, 0.214770, 0.283900, 0.328500, 0.348280, 0.348060, 0.336200, 0.318700,
        0.290800, 0.251100, 0.195360, 0.142100, 0.095640, 0.058950, 0.032010, 0.014700,
        0.004900, 0.002400, 0.009300, 0.029100, 0.063270, 0.109600, 0.165500, 0.225750,
        0.290400, 0.359700, 0.433450, 0.512050, 0.594500, 0.678400, 0.762100, 0.842500,
        0.916300, 0.978600, 1.026300, 1.056700, 1.062200, 1.045600, 1.002600, 0.938400,
        0.854450, 0.751400, 0.642400, 0.541900, 0.447900, 0.360800, 0.283500, 0.218700,
        0.164900, 0.121200, 0.087400, 0.063600, 0.046770, 0.032900, 0.022700, 0.015840,
        0.011359, 0.008111, 0.005790, 0.004109, 0.002899, 0.002049, 0.001440, 0.001000,
        0.000690, 0.000476, 0.000332, 0.000235, 0.000166, 0.000117, 0.000083, 0.000059,
        0.000042,
    };
    /// y_bar (y_bar(555 nm) = 1)
    static constexpr std::array<double, size> y_bar = {
        0.000039, 0.000064, 0.000120, 0.000217, 0.000396, 0.000640, 0.001210, 0.002180,
        0.004000, 0.007300, 0.011600, 0.016840, 0.023000, 0.029800, 0.038000, 0.048000,
        0.060000, 0.073900, 0.090980, 0.112600, 0.139020, 0.169300, 0.208020, 0.258600,
        0.323000, 0.407300, 0.503000, 0.608200, 0.710000, 0.793200, 0.862000, 0.914850,
        0.954000, 0.980300, 0.994950, 1.000000, 0.995000, 0.978600, 0.952000, 0.915400,
        0.870000, 0.816300, 0.757000, 0.694900, 0.631000, 0.566800, 0.503000, 0.441200,
        0.381000, 0.321000, 0.265000, 0.217000, 0.175000, 0.138200, 0.107000, 0.081600,
        0.061000, 0.044580, 0.032000, 0.023200, 0.017000, 0.011920, 0.008210, 0.005723,
        0.004102, 0.002929, 0.002091, 0.001484, 0.001047, 0.000740, 0.000520, 0.000361,
        0.000249, 0.000172, 0.000120, 0.000085, 0.000060, 0.000042, 0.000030, 0.000021,
        0.000015,
    };
    /// z_bar
    static constexpr std::array<double, size> z_bar = {
        0.006450, 0.010550, 0.020050, 0.036210, 0.067850, 0.110200, 0.207400, 0.371300,
        0.645600, 1.039050, 1.385600, 1.622960, 1.747060, 1.782600, 1.772110, 1.744100,
        1.669200, 1.528100, 1.287640, 1.041900, 0.812950, 0.616200, 0.465180, 0.353300,
        0.272000, 0.212300, 0.158200, 0.111700, 0.078250, 0.057250, 0.042160, 0.029840,
        0.020300, 0.013400, 0.008750, 0.005750, 0.003900, 0.002750, 0.002100, 0.001800,
        0.001650, 0.001400, 0.001100, 0.001000, 0.000800, 0.000600, 0.000340, 0.000240,
        0.000190, 0.000100, 0.000050, 0.000030, 0.000020, 0.000010, 0.000000, 0.000000,
        0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000,
        0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000,
        0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000,
        0.000000,
    };
};

/// (x_bar, y_bar, z_bar) at lambda [nm]: linear interpolation of the 5 nm table, 0 outside
/// [380, 780] nm.
[[nodiscard]] inline Vec3d cie1931_cmf(double lambda_nm) noexcept {
    const double u = (lambda_nm - Cie1931Table::lambda_min_nm) / Cie1931Table::step_nm;
    if (!(u >= 0) || u > double(Cie1931Table::size - 1)) return Vec3d(0.0);
    const std::size_t i = std::min(std::size_t(u), Cie1931Table::size - 2);
    const double f = u - double(i);
    auto lerp = [&](const std::array<double, Cie1931Table::size>& a) { return a[i] + f * (a[i + 1] - a[i]); };
    return Vec3d(lerp(Cie1931Table::x_bar), lerp(Cie1931Table::y_bar), lerp(Cie1931Table::z_bar));
}

/// Integral of the (linearly interpolated) CMFs over [a, b] nm (exact for the piecewise-linear table).
[[nodiscard]] inline Vec3d cie1931_cmf_integral(double a_nm, double b_nm) noexcept {
    const double lo = std::max(a_nm, Cie1931Table::lambda_min_nm);
    const double hi = std::min(b_nm, Cie1931Table::lambda_min_nm + Cie1931Table::step_nm * double(Cie1931Table::size - 1));
    Vec3d sum(0.0);
    if (!(hi > lo)) return sum;
    // Break points: the table nodes inside (lo, hi); trapezoids are exact for linear pieces.
    double x0 = lo;
    Vec3d f0 = cie1931_cmf(x0);
    for (;;) {
        double x1 = Cie1931Table::lambda_min_nm +
                    Cie1931Table::step_nm * (std::floor((x0 - Cie1931Table::lambda_min_nm) / Cie1931Table::step_nm + 1e-9) + 1);
        if (x1 > hi) x1 = hi;
        const Vec3d f1 = cie1931_cmf(x1);
        sum += 0.5 * (x1 - x0) * (f0 + f1);
        if (x1 >= hi) break;
        x0 = x1;
        f0 = f1;
    }
    return sum;
}

/// XYZ -> linear sRGB (IEC 61966-2-1, D65).
[[nodiscard]] inline Vec3d xyz_to_linear_srgb(const Vec3d& c) noexcept {
    return Vec3d(3.2406 * c.x - 1.5372 * c.y - 0.4986 * c.z, -0.9689 * c.x + 1.8758 * c.y + 0.0415 * c.z,
                 0.0557 * c.x - 0.2040 * c.y + 1.0570 * c.z);
}
/// Linear sRGB -> XYZ (IEC 61966-2-1, D65).
[[nodiscard]] inline Vec3d linear_srgb_to_xyz(const Vec3d& c) noexcept {
    return Vec3d(0.4124 * c.x + 0.3576 * c.y + 0.1805 * c.z, 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z,
                 0.0193 * c.x + 0.1192 * c.y + 0.9505 * c.z);
}

/// N equal wavelength bins over [380, 780] nm, sampled at their centres; `xyz_weight(i)` is the
/// CMF integral over bin i, so XYZ = sum_i L(lambda_i) xyz_weight(i) (exact for a spectrum that is
/// constant per bin).
template <std::size_t N>
struct WavelengthBins {
    static_assert(N >= 1, "at least one bin");
    static constexpr double lo_nm = 380.0;  ///< lower end of the first bin [nm]
    static constexpr double hi_nm = 780.0;  ///< upper end of the last bin [nm]
    /// Centre of bin i [nm].
    [[nodiscard]] static constexpr double lambda_nm(std::size_t i) noexcept {
        return lo_nm + (double(i) + 0.5) * (hi_nm - lo_nm) / double(N);
    }
    /// CMF integral over bin i.
    [[nodiscard]] static Vec3d xyz_weight(std::size_t i) noexcept {
        const double w = (hi_nm - lo_nm) / double(N);
        return cie1931_cmf_integral(lo_nm + double(i) * w, lo_nm + double(i + 1) * w);
    }
    /// XYZ of the sampled spectrum L[0..N).
    [[nodiscard]] static Vec3d to_xyz(const std::array<double, N>& L) noexcept {
        Vec3d s(0.0);
        for (std::size_t i = 0; i < N; ++i) s += L[i] * xyz_weight(i);
        return s;
    }
};

/// Linear sRGB of the equal-energy spectrum 1 (CIE illuminant E) per unit Y; divide by it to
/// balance a render lit by an equal-energy light to white.
[[nodiscard]] inline Vec3d equal_energy_srgb() noexcept {
    const Vec3d xyz = cie1931_cmf_integral(380.0, 780.0);
    return xyz_to_linear_srgb(xyz / xyz.y);
}

/// Jakob-Hanika sigmoid-polynomial spectrum (see the file comment); values in (0, 1).
struct SigmoidSpectrum {
    double c0 = 0;  ///< coefficient of t^2, t = (lambda - 380 nm) / 400 nm
    double c1 = 0;  ///< coefficient of t
    double c2 = 0;  ///< constant term
    /// R(lambda), lambda in nm.
    [[nodiscard]] double operator()(double lambda_nm) const noexcept {
        const double t = (lambda_nm - 380.0) / 400.0;
        const double x = (c0 * t + c1) * t + c2;
        if (std::isinf(x)) return x > 0 ? 1.0 : 0.0;
        return 0.5 + x / (2.0 * std::sqrt(1.0 + x * x));
    }
};

/// Balanced linear sRGB (see the file comment) of the reflectance spectrum R under illuminant E:
/// M_sRGB (int R cmf) / M_sRGB (int cmf), per channel; a reflectance of 1 maps to (1, 1, 1).
template <class Spec>
[[nodiscard]] inline Vec3d balanced_rgb_of_spectrum(const Spec& R) {
    Vec3d xyz(0.0);
    for (std::size_t i = 0; i < Cie1931Table::size; ++i) {
        const double l = Cie1931Table::lambda_min_nm + Cie1931Table::step_nm * double(i);
        const double w = (i == 0 || i + 1 == Cie1931Table::size) ? 0.5 : 1.0;  // trapezoid
        xyz += w * Cie1931Table::step_nm * R(l) * Vec3d(Cie1931Table::x_bar[i], Cie1931Table::y_bar[i], Cie1931Table::z_bar[i]);
    }
    const Vec3d white = xyz_to_linear_srgb(cie1931_cmf_integral(380.0, 780.0));
    const Vec3d rgb = xyz_to_linear_srgb(xyz);
    return Vec3d(rgb.x / white.x, rgb.y / white.y, rgb.z / white.z);
}

/// Fit a SigmoidSpectrum whose balanced_rgb_of_spectrum is `rgb` (each component in [0, 1];
/// components at 0 or 1 are approached to within 1e-4: the sigmoid never reaches them). Damped
/// Gauss-Newton with a finite-difference Jacobian and continuation from grey (0.5, 0.5, 0.5).
[[nodiscard]] inline SigmoidSpectrum fit_sigmoid_spectrum(const Vec3d& rgb) {
    for (int a = 0; a < 3; ++a)
        check_argument(std::isfinite(rgb[a]) && rgb[a] >= 0 && rgb[a] <= 1, "fit_sigmoid_spectrum", "rgb", rgb[a],
                       "[0, 1] per component (reflectances; scale emission first)");
    const Vec3d target = glm::clamp(rgb, Vec3d(1e-4), Vec3d(1 - 1e-4));
    SigmoidSpectrum s;
    constexpr int kSteps = 16;
    for (int step = 1; step <= kSteps; ++step) {
        const double f = double(step) / kSteps;
        const Vec3d goal = Vec3d(0.5) + f * (target - Vec3d(0.5));
        for (int it = 0; it < 40; ++it) {
            const Vec3d r = balanced_rgb_of_spectrum(s) - goal;
            if (glm::length(r) < 1e-7) break;
            // Jacobian by central differences.
            double J[3][3];
            for (int k = 0; k < 3; ++k) {
                SigmoidSpectrum a = s, b = s;
                const double h = 1e-4 * (1 + std::abs(k == 0 ? s.c0 : k == 1 ? s.c1 : s.c2));
                (k == 0 ? a.c0 : k == 1 ? a.c1 : a.c2) += h;
                (k == 0 ? b.c0 : k == 1 ? b.c1 : b.c2) -= h;
                const Vec3d d = (balanced_rgb_of_spectrum(a) - balanced_rgb_of_spectrum(b)) / (2 * h);
                for (int c = 0; c < 3; ++c) J[c][k] = d[c];
            }
            // Solve J dx = -r by Cramer's rule (3x3); damp large steps.
            const double det = J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0]) +
                               J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
            if (!(std::abs(det) > 1e-300)) break;
            double dx[3];
            for (int k = 0; k < 3; ++k) {
                double M[3][3];
                for (int c = 0; c < 3; ++c)
                    for (int q = 0; q < 3; ++q) M[c][q] = q == k ? -r[c] : J[c][q];
                dx[k] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                         M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) /
                        det;
            }
            const double norm = std::sqrt(dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]);
            const double damp = norm > 20 ? 20 / norm : 1.0;
            s.c0 += damp * dx[0];
            s.c1 += damp * dx[1];
            s.c2 += damp * dx[2];
        }
    }
    return s;
}

/// An emission (or any non-negative) colour as scale x SigmoidSpectrum, scale = max component.
struct EmissionSpectrum {
    double scale = 0;       ///< largest RGB component
    SigmoidSpectrum shape;  ///< fitted to rgb / scale
    /// Spectral value at lambda [nm].
    [[nodiscard]] double operator()(double lambda_nm) const noexcept { return scale * shape(lambda_nm); }
};
/// Upsample a non-negative RGB colour (a light's): scale x fit_sigmoid_spectrum(rgb / scale).
[[nodiscard]] inline EmissionSpectrum fit_emission_spectrum(const Vec3d& rgb) {
    const double m = std::max({rgb.x, rgb.y, rgb.z});
    check_argument(std::isfinite(m) && rgb.x >= 0 && rgb.y >= 0 && rgb.z >= 0, "fit_emission_spectrum", "rgb", m,
                   ">= 0 and finite per component");
    EmissionSpectrum e;
    e.scale = m;
    if (m > 0) e.shape = fit_sigmoid_spectrum(rgb / m);
    return e;
}

}  // namespace grainlight
