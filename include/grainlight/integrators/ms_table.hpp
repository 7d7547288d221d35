/// @file grainlight/integrators/ms_table.hpp
/// The multiple-scattering table of Wang & Holzschuch 2018 (Sec. 3.5.4 and 5.2, used by Eq. 7):
/// the record and its lookup, next to its consumer (integrators/point_based.hpp). The builder (a
/// walk-kernel simulation), `save` and `load` live in precompute/ms_table.hpp; the members
/// `MsTable::build`, `save` and `load` below forward to them, so include that header to build
/// or store a table (a call without it does not compile: "no matching function build_ms_table").
///
/// Meaning (units of the mean free path l = 1/sigma_t, so one table serves every sigma_t): a unit
/// of power is scattered at the origin by light travelling along +z (the phase function picks the
/// first direction); the particles propagate in an infinite medium of albedo alpha. Every
/// scattering event after the first collision (order >= 2 after the source, i.e. >= 3 events in
/// all when the source is itself a scattering event: Wang18's "multiple" term; the first
/// collision is the double-scattering term of Eq. 6) contributes to the in-scattering emission
/// density
///
///     L_o(rho, z, omega) = sigma_s int p(omega', omega) L_ms(x, omega') d omega'
///
/// stored in 1 / (l^3 sr) per unit source power on a cylindrical grid (rho in [0, rho_max], z in
/// [z_min, z_max], cell centres, bilinear lookup) times a direction grid (theta of omega to +z,
/// phi of omega to the radial direction folded into [0, pi] by mirror symmetry; nearest bin or
/// bilinear between bin centres, `DirectionLookup`).
///
/// Physical use (Eq. 7): a source of scattered power P_s = sigma_s Phi Delta at x_v with incoming
/// direction d_v gives emission density P_s sigma_t^3 L_o(rho sigma_t, z sigma_t, omega) at P,
/// with z = (P - x_v).d_v, rho = |P - x_v - z d_v|. Outside the grid: 0.
///
/// Value layout: index ((c n_z + iz) n_rho + ir) n_theta n_phi + it n_phi + ip.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <type_traits>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/scene/unbounded_medium.hpp"

namespace grainlight {

struct MsTableOptions;

/// Grid of an MsTable: cylindrical cells (rho, z) in mean free paths times direction bins.
struct MsTableGrid {
    /// @var n_rho
    /// Radial cells over [0, rho_max] ([1, 4096]).
    /// @var n_z
    /// Axial cells over [z_min, z_max] ([1, 4096]).
    /// @var n_theta
    /// Polar direction bins over [0, pi] ([1, 256]).
    /// @var n_phi
    /// Azimuth bins over [0, pi] (folded by mirror symmetry; [1, 256]).
    std::uint32_t n_rho = 32, n_z = 64, n_theta = 16, n_phi = 8;
    /// @var rho_max
    /// Radial extent of the grid [mean free paths] (> 0).
    /// @var z_min
    /// Lower axial bound of the grid [mean free paths].
    /// @var z_max
    /// Upper axial bound of the grid [mean free paths] (> z_min).
    double rho_max = 8.0, z_min = -8.0, z_max = 8.0;
    /// Number of direction bins n_theta n_phi.
    [[nodiscard]] std::size_t directions() const noexcept { return std::size_t(n_theta) * n_phi; }
    /// Number of spatial cells n_rho n_z.
    [[nodiscard]] std::size_t cells() const noexcept { return std::size_t(n_rho) * n_z; }
    /// Throws invalid_argument naming the first bad field.
    void check(const char* who) const {
        check_argument(n_rho >= 1 && n_rho <= 4096, who, "n_rho", n_rho, "[1, 4096]");
        check_argument(n_z >= 1 && n_z <= 4096, who, "n_z", n_z, "[1, 4096]");
        check_argument(n_theta >= 1 && n_theta <= 256, who, "n_theta", n_theta, "[1, 256]");
        check_argument(n_phi >= 1 && n_phi <= 256, who, "n_phi", n_phi, "[1, 256]");
        check_argument(std::isfinite(rho_max) && rho_max > 0, who, "rho_max", rho_max, "(0, inf)");
        check_argument(std::isfinite(z_min) && std::isfinite(z_max) && z_max > z_min, who, "z_max", z_max,
                       "(z_min, inf)");
    }
};

/// Up to four direction bins with bilinear weights (or one bin with weight 1: nearest lookup),
/// computed once per (source, receiver) pair and shared by all channels.
struct MsDirection {
    /// Direction-bin indices j = it n_phi + ip (the first `count` are used).
    std::array<std::size_t, 4> bin{};
    /// Bilinear weights of the bins (sum 1 over the first `count`).
    std::array<double, 4> weight{};
    /// Number of bins used: 1 (nearest lookup) to 4 (bilinear).
    int count = 0;
};

/// The four (z, rho) cells around a point of an MsTableGrid and their bilinear weights (cell
/// index iz n_rho + ir; weights between cell centres, clamped at the grid's edges).
struct MsCellCorners {
    std::size_t cell[4];  ///< cell indices
    double w[4];          ///< bilinear weights (sum 1)
};

/// Bilinear corners of (rho, z) (mean free paths) on `grid`; false outside the grid.
[[nodiscard]] inline bool ms_cell_corners(const MsTableGrid& grid, double rho, double z, MsCellCorners& k) noexcept {
    if (grid.n_rho == 0 || grid.n_z == 0 || !(rho >= 0) || rho > grid.rho_max || z < grid.z_min || z > grid.z_max)
        return false;
    const double fr = rho * (grid.n_rho / grid.rho_max) - 0.5, fz = (z - grid.z_min) * (grid.n_z / (grid.z_max - grid.z_min)) - 0.5;
    const int r0 = int(std::floor(fr)), z0 = int(std::floor(fz));
    const double ar = fr - r0, az = fz - z0;
    const int ra = std::max(r0, 0), rb = std::min(r0 + 1, int(grid.n_rho) - 1);
    const int za = std::max(z0, 0), zb = std::min(z0 + 1, int(grid.n_z) - 1);
    const std::size_t nr = grid.n_rho;
    k.cell[0] = std::size_t(za) * nr + std::size_t(ra);
    k.cell[1] = std::size_t(za) * nr + std::size_t(rb);
    k.cell[2] = std::size_t(zb) * nr + std::size_t(ra);
    k.cell[3] = std::size_t(zb) * nr + std::size_t(rb);
    k.w[0] = (1 - az) * (1 - ar);
    k.w[1] = (1 - az) * ar;
    k.w[2] = az * (1 - ar);
    k.w[3] = az * ar;
    return true;
}

/// Solid angle of direction bin j = it n_phi + ip on `grid`, counting both mirror images of the
/// folded azimuth range (the bins of all j cover 4 pi).
[[nodiscard]] inline double ms_bin_solid_angle(const MsTableGrid& grid, std::size_t j) noexcept {
    const std::size_t it = j / grid.n_phi;
    const double th0 = pi_v<double> * double(it) / grid.n_theta, th1 = pi_v<double> * double(it + 1) / grid.n_theta;
    return 2.0 * pi_v<double> / grid.n_phi * (std::cos(th0) - std::cos(th1));
}
/// A direction inside direction bin j = it n_phi + ip on `grid`: the fraction fc of the bin's
/// cos theta range (0 at its edge nearer theta = 0) and fp of its phi range, so that uniform
/// (fc, fp) are uniform in solid angle; `mirror` gives the image at -phi.
[[nodiscard]] inline Vec3<double> ms_bin_point(const MsTableGrid& grid, std::size_t j, double fc, double fp,
                                               bool mirror) noexcept {
    const std::size_t it = j / grid.n_phi, ip = j % grid.n_phi;
    const double c0 = std::cos(pi_v<double> * double(it) / grid.n_theta);
    const double c1 = std::cos(pi_v<double> * double(it + 1) / grid.n_theta);
    const double ct = c0 + (c1 - c0) * fc, st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
    const double ph = pi_v<double> * (double(ip) + fp) / grid.n_phi * (mirror ? -1.0 : 1.0);
    return {st * std::cos(ph), st * std::sin(ph), ct};
}
/// Volume of a cell of radial index ir on `grid` (a ring of height (z_max - z_min) / n_z) [l^3].
[[nodiscard]] inline double ms_cell_volume(const MsTableGrid& grid, std::size_t ir) noexcept {
    const double dr = grid.rho_max / grid.n_rho, dz = (grid.z_max - grid.z_min) / grid.n_z;
    const double r0 = double(ir) * dr, r1 = r0 + dr;
    return pi_v<double> * (r1 * r1 - r0 * r0) * dz;
}

/// Index of the direction bin of (cos_theta, phi) on `grid` (nearest bin).
[[nodiscard]] inline std::size_t ms_direction_bin(const MsTableGrid& grid, double cos_theta, double phi) noexcept {
    const double theta = std::acos(std::clamp(cos_theta, -1.0, 1.0));
    const std::size_t it = std::min<std::size_t>(grid.n_theta - 1, std::size_t(theta / pi_v<double> * grid.n_theta));
    const std::size_t ip = std::min<std::size_t>(
        grid.n_phi - 1, std::size_t(std::clamp(phi, 0.0, pi_v<double>) / pi_v<double> * grid.n_phi));
    return it * grid.n_phi + ip;
}

/// Direction lookup on `grid`: the nearest bin, or (interpolate) the four bins around
/// (theta, phi) with bilinear weights between bin centres (clamped at the poles and at
/// phi = 0, pi, where the mirror image of a bin is the bin itself).
[[nodiscard]] inline MsDirection ms_direction(const MsTableGrid& grid, double cos_theta, double phi, bool interpolate) noexcept {
    MsDirection d;
    if (!interpolate) {
        d.bin[0] = ms_direction_bin(grid, cos_theta, phi);
        d.weight[0] = 1.0;
        d.count = 1;
        return d;
    }
    const double theta = std::acos(std::clamp(cos_theta, -1.0, 1.0));
    const double ft = theta / pi_v<double> * grid.n_theta - 0.5;
    const double fp = std::clamp(phi, 0.0, pi_v<double>) / pi_v<double> * grid.n_phi - 0.5;
    const int t0 = int(std::floor(ft)), p0 = int(std::floor(fp));
    const double at = ft - t0, ap = fp - p0;
    const int ta = std::max(t0, 0), tb = std::min(t0 + 1, int(grid.n_theta) - 1);
    const int pa = std::max(p0, 0), pb = std::min(p0 + 1, int(grid.n_phi) - 1);
    const int ts[2] = {ta, tb}, ps[2] = {pa, pb};
    const double wt[2] = {1 - at, at}, wp[2] = {1 - ap, ap};
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            d.bin[std::size_t(2 * i + j)] = std::size_t(ts[i]) * grid.n_phi + std::size_t(ps[j]);
            d.weight[std::size_t(2 * i + j)] = wt[i] * wp[j];
        }
    d.count = 4;
    return d;
}

/// The table (see the file comment). N = number of channels.
template <std::size_t N>
class MsTable {
public:
    /// Version of the table's container layout (core/serialization.hpp), checked by load.
    static constexpr std::uint32_t file_version = 1;
    /// Container kind "MSTB" (the same value as precompute/ms_table.hpp's ms_table_file_kind).
    static constexpr std::uint32_t file_kind = std::uint32_t('M') | (std::uint32_t('S') << 8) |
                                               (std::uint32_t('T') << 16) | (std::uint32_t('B') << 24);
    /// Deprecated (one release): the infinite-medium walk scene is now
    /// grainlight::UnboundedMediumScene (scene/unbounded_medium.hpp).
    template <class M>
    using InfiniteMediumScene = grainlight::UnboundedMediumScene<M>;

    MsTable() = default;

    /// A table from its grid and values (layout in the file comment); used by the builder and the
    /// loader. Throws invalid_argument on a bad grid, a wrong value count, an albedo outside
    /// [0, 1], or a negative / non-finite value.
    MsTable(const MsTableGrid& grid, const std::array<double, N>& albedo, double mean_cosine,
            std::uint64_t photons, std::vector<float> values)
        : grid_(grid), g_(mean_cosine), albedo_(albedo), photons_(photons), values_(std::move(values)) {
        grid.check("MsTable");
        check_argument(values_.size() == N * grid.cells() * grid.directions(), "MsTable", "values.size()",
                       values_.size(), "channels * n_rho * n_z * n_theta * n_phi");
        check_argument(std::isfinite(g_) && g_ > -1 && g_ < 1, "MsTable", "mean_cosine", g_, "(-1, 1)");
        for (std::size_t c = 0; c < N; ++c)
            check_argument(albedo_[c] >= 0 && albedo_[c] <= 1, "MsTable", "albedo", albedo_[c], "[0, 1]");
        for (float v : values_) check_argument(std::isfinite(v) && v >= 0.0f, "MsTable", "value", v, "[0, inf)");
        inv_dr_ = grid_.n_rho / grid_.rho_max;
        inv_dz_ = grid_.n_z / (grid_.z_max - grid_.z_min);
    }

    /// A table with `grid` and no values (empty(); eval returns 0): the layout the builder indexes
    /// its histograms with (value_index, direction_bin, bin_direction). Throws invalid_argument on
    /// a bad grid.
    [[nodiscard]] static MsTable layout(const MsTableGrid& grid, const std::array<double, N>& albedo, double mean_cosine,
                                        std::uint64_t photons) {
        grid.check("MsTable::layout");
        MsTable t;
        t.grid_ = grid;
        t.g_ = mean_cosine;
        t.albedo_ = albedo;
        t.photons_ = photons;
        t.inv_dr_ = grid.n_rho / grid.rho_max;
        t.inv_dz_ = grid.n_z / (grid.z_max - grid.z_min);
        return t;
    }

    /// Precompute with the walk kernel (defined in precompute/ms_table.hpp; include it).
    template <class Phase>
    [[nodiscard]] static MsTable build(const Phase& phase, const Spectrum<N, typename Phase::Float>& albedo,
                                       const MsTableOptions& opt) {
        return build_ms_table<N>(phase, albedo, opt);  // ADL on Phase: found at instantiation
    }
    /// Save in the shared container (precompute/ms_table.hpp; include it). Throws io_error.
    template <class Path = std::filesystem::path>
    void save(const Path& path) const {
        save_ms_table(*this, std::filesystem::path(path));
    }
    /// Load (precompute/ms_table.hpp; include it). Throws io_error / format_error.
    template <class Path = std::filesystem::path>
    [[nodiscard]] static MsTable load(const Path& path) {
        return load_ms_table(std::filesystem::path(path), std::type_identity<MsTable>{});
    }

    /// Emission density L_o (1 / (l^3 sr) per unit source power) of channel c at cylindrical
    /// coordinates (rho, z) in mean free paths, for outgoing direction with cosine `cos_theta` to
    /// the axis and azimuth `phi` in [0, pi] to the radial direction (nearest direction bin).
    /// 0 outside the grid.
    [[nodiscard]] double eval(std::size_t c, double rho, double z, double cos_theta, double phi) const noexcept {
        if (values_.empty()) return 0.0;
        return eval_bin(c, rho, z, direction_bin(cos_theta, phi));
    }
    /// As eval, bilinear between direction-bin centres.
    [[nodiscard]] double eval_interpolated(std::size_t c, double rho, double z, double cos_theta,
                                           double phi) const noexcept {
        if (values_.empty()) return 0.0;
        return eval_dir(c, rho, z, direction(cos_theta, phi, true));
    }

    /// Index of the direction bin of (cos_theta, phi) (nearest bin).
    [[nodiscard]] std::size_t direction_bin(double cos_theta, double phi) const noexcept {
        return ms_direction_bin(grid_, cos_theta, phi);
    }

    /// Direction lookup: the nearest bin, or (interpolate) the four bins around (theta, phi) with
    /// bilinear weights between bin centres (clamped at the poles and at phi = 0, pi, where the
    /// mirror image of a bin is the bin itself).
    [[nodiscard]] MsDirection direction(double cos_theta, double phi, bool interpolate) const noexcept {
        return ms_direction(grid_, cos_theta, phi, interpolate);
    }

    /// As eval, with the direction bin j = direction_bin(cos_theta, phi) (bilinear in rho, z).
    [[nodiscard]] double eval_bin(std::size_t c, double rho, double z, std::size_t j) const noexcept {
        Corners k;
        if (!corners(rho, z, k)) return 0.0;
        const std::size_t nd = grid_.directions();
        const float* base = values_.data() + c * grid_.cells() * nd + j;
        double s = 0;
        for (int i = 0; i < 4; ++i) s += k.w[i] * double(base[k.cell[i] * nd]);
        return s;
    }

    /// As eval_bin with a (possibly interpolated) direction lookup.
    [[nodiscard]] double eval_dir(std::size_t c, double rho, double z, const MsDirection& d) const noexcept {
        Corners k;
        if (!corners(rho, z, k)) return 0.0;
        const std::size_t nd = grid_.directions();
        const float* base = values_.data() + c * grid_.cells() * nd;
        double s = 0;
        for (int i = 0; i < 4; ++i) {
            const float* cell = base + k.cell[i] * nd;
            double v = 0;
            for (int j = 0; j < d.count; ++j) v += d.weight[std::size_t(j)] * double(cell[d.bin[std::size_t(j)]]);
            s += k.w[i] * v;
        }
        return s;
    }

    /// Integral of L_o over the grid volume and all directions for channel c (per unit source
    /// power): the scattered power of orders >= 2 that stays on the grid.
    [[nodiscard]] double total(std::size_t c) const noexcept {
        double s = 0;
        for (std::size_t iz = 0; iz < grid_.n_z; ++iz)
            for (std::size_t ir = 0; ir < grid_.n_rho; ++ir) {
                const double vol = ms_cell_volume(grid_, ir);
                for (std::size_t it = 0; it < grid_.n_theta; ++it) {
                    const double dom = ms_bin_solid_angle(grid_, it * grid_.n_phi);  // the same for every phi bin
                    for (std::size_t ip = 0; ip < grid_.n_phi; ++ip)
                        s += vol * dom * values_[value_index(c, iz, ir, it * grid_.n_phi + ip)];
                }
            }
        return s;
    }

    /// Centre direction of bin j in the local frame (x = radial, z = axis); `mirror` flips phi.
    [[nodiscard]] Vec3<double> bin_direction(std::size_t j, bool mirror) const noexcept {
        const double th = pi_v<double> * (double(j / grid_.n_phi) + 0.5) / grid_.n_theta;
        const double ph = pi_v<double> * (double(j % grid_.n_phi) + 0.5) / grid_.n_phi * (mirror ? -1.0 : 1.0);
        return {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
    }
    /// Flat index of channel c, cell (iz, ir) and direction bin j in values() (layout in the file comment; not range-checked).
    [[nodiscard]] std::size_t value_index(std::size_t c, std::size_t iz, std::size_t ir, std::size_t j) const noexcept {
        return ((c * grid_.n_z + iz) * grid_.n_rho + ir) * grid_.directions() + j;
    }

    /// The table's grid.
    [[nodiscard]] const MsTableGrid& grid() const noexcept { return grid_; }
    /// Single-scattering albedo of channel c (< N; not checked) the table was built for.
    [[nodiscard]] double albedo(std::size_t c) const noexcept { return albedo_[c]; }
    /// Albedos of all channels.
    [[nodiscard]] const std::array<double, N>& albedos() const noexcept { return albedo_; }
    /// Mean cosine g of the phase function the table was built with.
    [[nodiscard]] double mean_cosine() const noexcept { return g_; }
    /// Number of source particles traced to build the table.
    [[nodiscard]] std::uint64_t photons() const noexcept { return photons_; }
    /// Number of stored values (N n_rho n_z n_theta n_phi; 0 for a default-constructed table).
    [[nodiscard]] std::size_t size() const noexcept { return values_.size(); }
    /// True for a default-constructed (empty) table.
    [[nodiscard]] bool empty() const noexcept { return values_.empty(); }
    /// The values in 1 / (l^3 sr) per unit source power (layout in the file comment).
    [[nodiscard]] const std::vector<float>& values() const noexcept { return values_; }
    /// Memory held by the values, in bytes.
    [[nodiscard]] std::size_t bytes() const noexcept { return values_.size() * sizeof(float); }

private:
    using Corners = MsCellCorners;
    bool corners(double rho, double z, Corners& k) const noexcept {
        return !values_.empty() && ms_cell_corners(grid_, rho, z, k);
    }

    MsTableGrid grid_{};
    double g_ = 0;
    std::array<double, N> albedo_{};
    std::uint64_t photons_ = 0;
    std::vector<float> values_;
    double inv_dr_ = 1, inv_dz_ = 1;
};

}  // namespace grainlight
