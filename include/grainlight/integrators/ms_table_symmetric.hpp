/// @file grainlight/integrators/ms_table_symmetric.hpp
/// The symmetric-lobe variant of the multiple-scattering table (Wang18 Sec. 4.1, Fig. 8: "we
/// approximate each lobe by a lobe with symmetry of revolution around the axis joining the source
/// point O and the current point P ... we store material response in a 3D table, indexed by
/// (rho/l, z/l, theta), where theta is the angle between the outgoing direction and the lobe
/// axis"). Built from a full MsTable<N>: in every cell, each direction bin of the full lobe is
/// split into kSub x kSub sub-directions (equal steps in cos theta and phi, so equal solid angles),
/// and each sub-direction's share of the bin's power goes to the bin of its angle to the cell's
/// axis (the direction from the source to the cell centre). The symmetric value of a bin is its
/// power over its solid angle, so every cell keeps its power exactly. Axis bins that no
/// sub-direction reaches (none with a fine enough split) take the nearest filled bin's value.
///
/// `eval` looks a direction up by its cosine to the axis, bilinear in (rho, z) as MsTable;
/// `expand()` writes the symmetric lobes back onto the full table's direction grid (each bin the
/// mean over its sub-directions), so the renderer can read the approximation unchanged and its
/// effect on an image can be measured (wang18_fig12_components --symmetric-lobes).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/integrators/ms_table.hpp"

namespace grainlight {

/// Multiple-scattering lobes with symmetry of revolution about the source-to-point axis.
template <std::size_t N>
class MsSymmetricTable {
public:
    /// Sub-directions per full direction bin and dimension (theta, phi).
    static constexpr int kSub = 4;

    /// From the full table `t` (not empty) with `n_axis` bins of the angle to the axis over
    /// [0, pi] (in [1, 1024]); throws invalid_argument otherwise.
    explicit MsSymmetricTable(const MsTable<N>& t, std::uint32_t n_axis = 32)
        : grid_(t.grid()), n_axis_(n_axis), albedo_(t.albedos()), g_(t.mean_cosine()), photons_(t.photons()) {
        check_argument(!t.empty(), "MsSymmetricTable", "table size", t.size(), ">= 1");
        check_argument(n_axis >= 1 && n_axis <= 1024, "MsSymmetricTable", "n_axis", n_axis, "[1, 1024]");
        const std::size_t nd = grid_.directions(), cells = grid_.cells();
        values_.assign(N * cells * n_axis_, 0.0f);
        std::vector<double> power(N * n_axis_), omega(n_axis_);
        std::vector<std::uint32_t> sub_bin(nd * kSub * kSub);
        for (std::size_t iz = 0; iz < grid_.n_z; ++iz)
            for (std::size_t ir = 0; ir < grid_.n_rho; ++ir) {
                sub_bins(iz, ir, sub_bin);
                std::fill(power.begin(), power.end(), 0.0);
                std::fill(omega.begin(), omega.end(), 0.0);
                for (std::size_t j = 0; j < nd; ++j) {
                    const double dom = ms_bin_solid_angle(grid_, j) / (kSub * kSub);
                    for (int s = 0; s < kSub * kSub; ++s) {
                        const std::uint32_t k = sub_bin[j * kSub * kSub + std::size_t(s)];
                        omega[k] += dom;
                        for (std::size_t c = 0; c < N; ++c) power[c * n_axis_ + k] += dom * double(t.values()[t.value_index(c, iz, ir, j)]);
                    }
                }
                for (std::size_t c = 0; c < N; ++c) {
                    float* out = values_.data() + (c * cells + iz * grid_.n_rho + ir) * n_axis_;
                    for (std::size_t k = 0; k < n_axis_; ++k)
                        out[k] = omega[k] > 0 ? float(power[c * n_axis_ + k] / omega[k]) : -1.0f;
                    fill_empty(out);
                }
            }
    }

    /// The symmetric lobe of channel c at (rho, z) (mean free paths) for an outgoing direction
    /// whose cosine to the source-to-point axis is `cos_axis` (nearest axis bin; bilinear in
    /// rho, z). 0 outside the grid.
    [[nodiscard]] double eval(std::size_t c, double rho, double z, double cos_axis) const noexcept {
        MsCellCorners k;
        if (values_.empty() || !ms_cell_corners(grid_, rho, z, k)) return 0.0;
        const std::size_t b = axis_bin(cos_axis), cells = grid_.cells();
        double s = 0;
        for (int i = 0; i < 4; ++i) s += k.w[i] * double(values_[(c * cells + k.cell[i]) * n_axis_ + b]);
        return s;
    }

    /// The symmetric lobes on the full table's direction grid: bin j of cell (iz, ir) holds the
    /// mean of the symmetric lobe over the bin's sub-directions (cell power kept exactly).
    [[nodiscard]] MsTable<N> expand() const {
        const std::size_t nd = grid_.directions(), cells = grid_.cells();
        std::vector<float> v(N * cells * nd, 0.0f);
        std::vector<std::uint32_t> sub_bin(nd * kSub * kSub);
        for (std::size_t iz = 0; iz < grid_.n_z; ++iz)
            for (std::size_t ir = 0; ir < grid_.n_rho; ++ir) {
                sub_bins(iz, ir, sub_bin);
                for (std::size_t c = 0; c < N; ++c) {
                    const float* sym = values_.data() + (c * cells + iz * grid_.n_rho + ir) * n_axis_;
                    float* out = v.data() + ((c * grid_.n_z + iz) * grid_.n_rho + ir) * nd;
                    for (std::size_t j = 0; j < nd; ++j) {
                        double m = 0;
                        for (int s = 0; s < kSub * kSub; ++s) m += double(sym[sub_bin[j * kSub * kSub + std::size_t(s)]]);
                        out[j] = float(m / (kSub * kSub));
                    }
                }
            }
        return MsTable<N>(grid_, albedo_, g_, photons_, std::move(v));
    }

    /// Number of bins of the angle to the axis.
    [[nodiscard]] std::uint32_t axis_bins() const noexcept { return n_axis_; }
    /// Bytes of the symmetric lobes (N x cells x axis bins floats).
    [[nodiscard]] std::size_t bytes() const noexcept { return values_.size() * sizeof(float); }
    /// The source table's grid.
    [[nodiscard]] const MsTableGrid& grid() const noexcept { return grid_; }

private:
    [[nodiscard]] std::size_t axis_bin(double cos_axis) const noexcept {
        const double th = std::acos(std::clamp(cos_axis, -1.0, 1.0));
        return std::min<std::size_t>(n_axis_ - 1, std::size_t(th / pi_v<double> * n_axis_));
    }
    // Axis bin of every sub-direction of every full bin of cell (iz, ir).
    void sub_bins(std::size_t iz, std::size_t ir, std::vector<std::uint32_t>& out) const noexcept {
        const double rho = (double(ir) + 0.5) * grid_.rho_max / grid_.n_rho;
        const double z = grid_.z_min + (double(iz) + 0.5) * (grid_.z_max - grid_.z_min) / grid_.n_z;
        const double len = std::sqrt(rho * rho + z * z);
        const double ax = rho / len, az = z / len;  // the axis lies in the phi = 0 half-plane
        for (std::size_t j = 0; j < grid_.directions(); ++j) {
            const std::size_t it = j / grid_.n_phi, ip = j % grid_.n_phi;
            const double c0 = std::cos(pi_v<double> * double(it) / grid_.n_theta);
            const double c1 = std::cos(pi_v<double> * double(it + 1) / grid_.n_theta);
            for (int a = 0; a < kSub; ++a) {
                const double ct = c0 + (c1 - c0) * (a + 0.5) / kSub, st = std::sqrt(std::max(0.0, 1 - ct * ct));
                for (int b = 0; b < kSub; ++b) {
                    const double ph = pi_v<double> * (double(ip) + (b + 0.5) / kSub) / grid_.n_phi;
                    out[j * kSub * kSub + std::size_t(a * kSub + b)] = std::uint32_t(axis_bin(st * std::cos(ph) * ax + ct * az));
                }
            }
        }
    }
    // Axis bins no sub-direction reached (marked -1) take the nearest filled bin's value.
    void fill_empty(float* v) const noexcept {
        for (std::size_t k = 0; k < n_axis_; ++k) {
            if (v[k] >= 0.0f) continue;
            for (std::size_t d = 1; d < n_axis_; ++d) {
                if (k >= d && v[k - d] >= 0.0f) {
                    v[k] = v[k - d];
                    break;
                }
                if (k + d < n_axis_ && v[k + d] >= 0.0f) {
                    v[k] = v[k + d];
                    break;
                }
            }
            if (v[k] < 0.0f) v[k] = 0.0f;
        }
    }

    MsTableGrid grid_;
    std::uint32_t n_axis_;
    std::array<double, N> albedo_{};
    double g_ = 0;
    std::uint64_t photons_ = 0;
    std::vector<float> values_;  // ((c cells + cell) n_axis + k)
};

}  // namespace grainlight
