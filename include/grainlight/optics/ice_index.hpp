/// @file grainlight/optics/ice_index.hpp
/// Complex refractive index of water ice (-7 C), n + i k, 0.35-1.0 um vacuum wavelength: Warren &
/// Brandt 2008, "Optical constants of ice from the ultraviolet to the microwave: A revised
/// compilation", J. Geophys. Res. 113, D14220, doi:10.1029/2007JD009744 (as tabulated by the
/// refractiveindex.info database, main/H2O/Warren-2008, CC0; the same numbers as
/// tests/data/ice_warren_brandt_2008.csv). n is interpolated linearly in lambda, k
/// log-linearly; outside the table the end values are kept. Guo21 Sec. 6 takes ice's index from
/// Frisvad et al. 2007; this compilation is the current standard.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstddef>

namespace grainlight {

/// Ice index table (lambda [um], n, k).
struct IceIndexTable {
    /// One row of the table.
    struct Row {
        double lambda_um;  ///< vacuum wavelength [um]
        double n;          ///< real part
        double k;          ///< imaginary part (>= 0 absorbing)
    };
    /// Number of rows.
    static constexpr std::size_t size = 47;
    /// Rows in increasing wavelength.
    static constexpr std::array<Row, size> rows = {{
        {0.350, 1.3249, 2.0E-011},
        {0.390, 1.3203, 2.0E-011},
        {0.400, 1.3194, 2.365E-011},
        {0.410, 1.3185, 2.669E-011},
        {0.420, 1.3177, 3.135E-011},
        {0.430, 1.3170, 4.140E-011},
        {0.440, 1.3163, 6.268E-011},
        {0.450, 1.3157, 9.239E-011},
        {0.460, 1.3151, 1.325E-010},
        {0.470, 1.3145, 1.956E-010},
        {0.480, 1.3140, 2.861E-010},
        {0.490, 1.3135, 4.172E-010},
        {0.500, 1.3130, 5.889E-010},
        {0.510, 1.3126, 8.036E-010},
        {0.520, 1.3121, 1.076E-009},
        {0.530, 1.3117, 1.409E-009},
        {0.540, 1.3114, 1.813E-009},
        {0.550, 1.3110, 2.289E-009},
        {0.560, 1.3106, 2.839E-009},
        {0.570, 1.3103, 3.461E-009},
        {0.580, 1.3100, 4.159E-009},
        {0.590, 1.3097, 4.930E-009},
        {0.600, 1.3094, 5.730E-009},
        {0.610, 1.3091, 6.890E-009},
        {0.620, 1.3088, 8.580E-009},
        {0.630, 1.3085, 1.040E-008},
        {0.640, 1.3083, 1.220E-008},
        {0.650, 1.3080, 1.430E-008},
        {0.660, 1.3078, 1.660E-008},
        {0.670, 1.3076, 1.890E-008},
        {0.680, 1.3073, 2.090E-008},
        {0.690, 1.3071, 2.400E-008},
        {0.700, 1.3069, 2.900E-008},
        {0.710, 1.3067, 3.440E-008},
        {0.720, 1.3065, 4.030E-008},
        {0.730, 1.3062, 4.300E-008},
        {0.740, 1.3060, 4.920E-008},
        {0.750, 1.3059, 5.870E-008},
        {0.760, 1.3057, 7.080E-008},
        {0.770, 1.3055, 8.580E-008},
        {0.780, 1.3053, 1.020E-007},
        {0.790, 1.3051, 1.180E-007},
        {0.800, 1.3049, 1.340E-007},
        {0.850, 1.3040, 1.830E-007},
        {0.900, 1.3032, 4.200E-007},
        {0.950, 1.3023, 6.020E-007},
        {1.000, 1.3015, 1.620E-006},
    }};
};

/// Complex index n + i k of ice at the vacuum wavelength lambda [um] (k >= 0 absorbing).
[[nodiscard]] inline std::complex<double> ice_refractive_index(double lambda_um) noexcept {
    const auto& t = IceIndexTable::rows;
    if (!(lambda_um > t.front().lambda_um)) return {t.front().n, t.front().k};
    if (lambda_um >= t.back().lambda_um) return {t.back().n, t.back().k};
    std::size_t i = 0;
    while (t[i + 1].lambda_um < lambda_um) ++i;
    const double f = (lambda_um - t[i].lambda_um) / (t[i + 1].lambda_um - t[i].lambda_um);
    const double n = t[i].n + f * (t[i + 1].n - t[i].n);
    const double k = std::exp(std::log(t[i].k) + f * (std::log(t[i + 1].k) - std::log(t[i].k)));
    return {n, k};
}

}  // namespace grainlight
