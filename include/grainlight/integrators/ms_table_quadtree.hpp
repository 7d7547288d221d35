/// @file grainlight/integrators/ms_table_quadtree.hpp
/// Quadtree compression of the multiple-scattering table over its (rho, z) grid (Wang18 Sec. 5.2:
/// "we compress this representation using a quadtree, depending on particle density. We discard
/// nodes with no scattering events"). The (z, rho) cell grid, padded to a power of two, is split
/// into quadrants until a quadrant
///   - holds no value above `tolerance` times the table's largest value: an empty leaf, nothing
///     stored (tolerance = 0 drops exact zeros only);
///   - or, with `merge_tolerance` > 0, is smooth enough to be one lobe: a merged leaf storing the
///     volume-weighted mean lobe of its cells (so the block's power in every direction bin is kept
///     exactly), taken when for every channel c its error in emitted power,
///         sum_cells vol sum_j dOmega_j |v - mean_j|,
///     is at most merge_tolerance * P_c * vol(block) / vol(grid), P_c = MsTable::total(c). The
///     budget is proportional to volume, so summed over the whole tree the power-weighted L1 error
///     of the merged table is at most merge_tolerance * P_c. Noisy, sparse cells far from the
///     source carry little power and merge into large nodes; cells near the source stay fine: the
///     density-driven subdivision the paper describes, with an error bound;
///   - or is a single cell: a full leaf with its N x n_theta x n_phi lobe values.
/// merge_tolerance = 0 (the default) merges nothing, and with tolerance = 0 every value read back
/// equals the dense table's.
///
/// Noise-aware merging (optional): given each cell's relative noise r_k (per channel, the
/// relative standard error of the cell's tallied power; precompute/ms_table.hpp's
/// ms_table_cell_relative_noise), a block is also merged when its cells' powers
/// T_k = vol_k sum_j dOmega_j v_k,j do not differ from a constant density beyond their noise: with
/// the block's mean density d = sum T_k / sum vol_k, T^_k = d vol_k and
/// var_k = max((r_k T_k)^2, w T^_k) (w = sum (r_k T_k)^2 / sum T_k, the block's mean weight of
/// one effective particle: a Poisson floor for cells with few or no events),
///     chi^2 = sum_k (T_k - T^_k)^2 / var_k  <=  dof + noise_factor sqrt(2 dof),  dof = cells - 1,
/// in every channel. A block passing it has no structure its noise can resolve, so its mean lobe
/// is as close to the true table as its cells were (closer: averaging removes noise) while
/// storing one lobe. Its error against the dense table is not bounded by merge_tolerance: it is
/// the noise that merging removed. This is what lets a finely gridded table built from few
/// particles (the paper's 1024 x 512 grid) compress by orders of magnitude.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/integrators/ms_table.hpp"

namespace grainlight {

/// A quadtree-compressed copy of an MsTable<N> (values by cell and direction bin).
template <std::size_t N>
class MsTableQuadtree {
public:
    /// Compress `t`: cells whose values are all below `tolerance` times the table's largest value
    /// are dropped, and blocks within `merge_tolerance` (relative power-weighted L1 error, see the
    /// file comment) are merged into one lobe. Both 0: lossless.
    /// Throws invalid_argument for a tolerance outside [0, 1) or an empty table.
    explicit MsTableQuadtree(const MsTable<N>& t, double tolerance = 0.0, double merge_tolerance = 0.0)
        : MsTableQuadtree(t, tolerance, merge_tolerance, {}, 0.0) {}
    /// As above, and also merge blocks whose cells' powers agree with a constant density within
    /// their noise: a chi-square test passed at `noise_factor` standard deviations of the
    /// chi-square (see the file comment; 0 turns it off); `cell_relative_noise` has one value per
    /// channel and cell, index c n_z n_rho + iz n_rho + ir (ms_table_cell_relative_noise).
    /// Throws invalid_argument for a tolerance outside [0, 1), a noise factor outside [0, 100], a
    /// noise array of the wrong size or with a negative / non-finite value, or an empty table.
    MsTableQuadtree(const MsTable<N>& t, double tolerance, double merge_tolerance,
                    std::span<const double> cell_relative_noise, double noise_factor = 2.0)
        : grid_(t.grid()), albedo_(t.albedos()), g_(t.mean_cosine()), photons_(t.photons()) {
        check_argument(tolerance >= 0.0 && tolerance < 1.0, "MsTableQuadtree", "tolerance", tolerance, "[0, 1)");
        check_argument(merge_tolerance >= 0.0 && merge_tolerance < 1.0, "MsTableQuadtree", "merge_tolerance",
                       merge_tolerance, "[0, 1)");
        check_argument(!t.empty(), "MsTableQuadtree", "table size", t.size(), ">= 1");
        check_argument(noise_factor >= 0.0 && noise_factor <= 100.0, "MsTableQuadtree", "noise_factor", noise_factor,
                       "[0, 100]");
        if (!cell_relative_noise.empty()) {
            check_argument(cell_relative_noise.size() == N * t.grid().cells(), "MsTableQuadtree",
                           "cell_relative_noise.size()", cell_relative_noise.size(), "channels * n_z * n_rho");
            for (const double r : cell_relative_noise)
                check_argument(std::isfinite(r) && r >= 0.0, "MsTableQuadtree", "cell relative noise", r, "[0, inf)");
            noise_ = cell_relative_noise;
            noise_factor_ = noise_factor;
            tk_.resize(t.grid().cells());
        }
        nd_ = grid_.directions();
        merge_tolerance_ = merge_tolerance;
        if (merge_tolerance > 0.0 || noise_factor_ > 0.0) {
            // Cell volumes (by rho ring) and bin solid angles as in MsTable::total.
            vol_.resize(grid_.n_rho);
            for (std::size_t ir = 0; ir < grid_.n_rho; ++ir) vol_[ir] = ms_cell_volume(grid_, ir);
            dom_.resize(nd_);
            for (std::size_t j = 0; j < nd_; ++j) dom_[j] = ms_bin_solid_angle(grid_, j);
            double vgrid = 0;
            for (double v : vol_) vgrid += v * grid_.n_z;
            for (std::size_t c = 0; c < N; ++c) budget_per_volume_[c] = merge_tolerance * t.total(c) / vgrid;
            mean_.resize(N * nd_);
        }
        float vmax = 0.0f;
        for (float v : t.values()) vmax = std::max(vmax, v);
        threshold_ = float(tolerance * double(vmax));
        side_ = 1;
        while (side_ < grid_.n_z || side_ < grid_.n_rho) side_ *= 2;
        // Per-cell flag: does the cell hold a value above the threshold (any channel, any bin)?
        std::vector<std::uint8_t> full(std::size_t(grid_.n_z) * grid_.n_rho, 0);
        for (std::size_t iz = 0; iz < grid_.n_z; ++iz)
            for (std::size_t ir = 0; ir < grid_.n_rho; ++ir) {
                bool any = false;
                for (std::size_t c = 0; c < N && !any; ++c)
                    for (std::size_t j = 0; j < nd_ && !any; ++j) any = t.values()[t.value_index(c, iz, ir, j)] > threshold_;
                full[iz * grid_.n_rho + ir] = any ? 1 : 0;
            }
        nodes_.push_back(Node{});
        nodes_[0] = build(t, full, 0, 0, side_);
        noise_ = {};  // the caller's array is not kept
        tk_ = {};
    }

    /// The stored value of channel c, cell (iz, ir), direction bin j; 0 in a dropped region.
    [[nodiscard]] float value(std::size_t c, std::size_t iz, std::size_t ir, std::size_t j) const noexcept {
        if (iz >= grid_.n_z || ir >= grid_.n_rho || c >= N || j >= nd_) return 0.0f;
        std::uint32_t n = 0, z0 = 0, r0 = 0, s = side_;
        for (;;) {
            const Node& nd = nodes_[n];
            if (nd.child == kEmpty) return 0.0f;
            if (nd.child == kLeaf) return data_[std::size_t(nd.data) + c * nd_ + j];
            s /= 2;
            const std::uint32_t qz = iz >= z0 + s ? 1u : 0u, qr = ir >= r0 + s ? 1u : 0u;
            z0 += qz * s;
            r0 += qr * s;
            n = nd.child + qz * 2 + qr;
        }
    }
    /// The N x directions() lobe values of cell (iz, ir) (channel-major), nullptr in a dropped
    /// region or outside the grid.
    [[nodiscard]] const float* cell(std::size_t iz, std::size_t ir) const noexcept {
        if (iz >= grid_.n_z || ir >= grid_.n_rho) return nullptr;
        std::uint32_t n = 0, z0 = 0, r0 = 0, s = side_;
        for (;;) {
            const Node& nd = nodes_[n];
            if (nd.child == kEmpty) return nullptr;
            if (nd.child == kLeaf) return data_.data() + nd.data;
            s /= 2;
            const std::uint32_t qz = iz >= z0 + s ? 1u : 0u, qr = ir >= r0 + s ? 1u : 0u;
            z0 += qz * s;
            r0 += qr * s;
            n = nd.child + qz * 2 + qr;
        }
    }
    /// Direction lookup on the table's grid (as MsTable::direction).
    [[nodiscard]] MsDirection direction(double cos_theta, double phi, bool interpolate) const noexcept {
        return ms_direction(grid_, cos_theta, phi, interpolate);
    }
    /// The table's value at (rho, z) (mean free paths) for the direction lookup d, channel c:
    /// bilinear in (rho, z) over the stored cells (0 for dropped ones), as MsTable::eval_dir.
    [[nodiscard]] double eval_dir(std::size_t c, double rho, double z, const MsDirection& d) const noexcept {
        MsCellCorners k;
        if (nodes_.empty() || !ms_cell_corners(grid_, rho, z, k)) return 0.0;
        double s = 0;
        for (int i = 0; i < 4; ++i) {
            if (k.w[i] == 0.0) continue;
            const float* v = cell(k.cell[i] / grid_.n_rho, k.cell[i] % grid_.n_rho);
            if (!v) continue;
            v += c * nd_;
            double x = 0;
            for (int j = 0; j < d.count; ++j) x += d.weight[std::size_t(j)] * double(v[d.bin[std::size_t(j)]]);
            s += k.w[i] * x;
        }
        return s;
    }
    /// Single-scattering albedo of channel c of the source table.
    [[nodiscard]] double albedo(std::size_t c) const noexcept { return albedo_[c]; }
    /// Mean cosine g of the source table's phase function.
    [[nodiscard]] double mean_cosine() const noexcept { return g_; }
    /// Source particles of the source table.
    [[nodiscard]] std::uint64_t photons() const noexcept { return photons_; }
    /// Bytes the dense table would hold (N x cells x directions floats).
    [[nodiscard]] std::size_t dense_bytes() const noexcept { return N * grid_.cells() * nd_ * sizeof(float); }
    /// Bytes held: nodes plus the stored lobes.
    [[nodiscard]] std::size_t bytes() const noexcept { return nodes_.size() * sizeof(Node) + data_.size() * sizeof(float); }
    /// Number of grid cells that read a stored lobe (in a full or a merged leaf).
    [[nodiscard]] std::size_t stored_cells() const noexcept { return covered_cells_; }
    /// Number of lobes stored (one per full leaf and one per merged leaf).
    [[nodiscard]] std::size_t stored_lobes() const noexcept { return data_.size() / (N * nd_); }
    /// Number of merged leaves (blocks of more than one cell stored as one lobe).
    [[nodiscard]] std::size_t merged_leaves() const noexcept { return merged_leaves_; }
    /// The merge tolerance the tree was built with.
    [[nodiscard]] double merge_tolerance() const noexcept { return merge_tolerance_; }
    /// Absolute threshold below which a whole cell was dropped.
    [[nodiscard]] float threshold() const noexcept { return threshold_; }
    /// The grid of the source table.
    [[nodiscard]] const MsTableGrid& grid() const noexcept { return grid_; }

private:
    static constexpr std::uint32_t kEmpty = 0xffffffffu, kLeaf = 0xfffffffeu;
    struct Node {
        std::uint32_t child = kEmpty;  ///< first of 4 children, or kEmpty / kLeaf
        std::uint32_t data = 0;        ///< offset of a leaf's lobe values
    };
    // Can the in-grid cells of block (z0, r0, s) be one lobe (see the file comment)? On success
    // mean_ holds the volume-weighted mean lobe.
    bool mergeable(const MsTable<N>& t, std::uint32_t z0, std::uint32_t r0, std::uint32_t s) {
        const std::uint32_t z1 = std::min<std::uint32_t>(z0 + s, grid_.n_z), r1 = std::min<std::uint32_t>(r0 + s, grid_.n_rho);
        std::fill(mean_.begin(), mean_.end(), 0.0);
        double vb = 0;
        for (std::uint32_t iz = z0; iz < z1; ++iz)
            for (std::uint32_t ir = r0; ir < r1; ++ir) {
                vb += vol_[ir];
                for (std::size_t c = 0; c < N; ++c) {
                    const float* v = t.values().data() + t.value_index(c, iz, ir, 0);
                    double* m = mean_.data() + c * nd_;
                    for (std::size_t j = 0; j < nd_; ++j) m[j] += vol_[ir] * double(v[j]);
                }
            }
        for (double& m : mean_) m /= vb;
        if (noise_factor_ > 0.0 && flat_within_noise(t, z0, z1, r0, r1, vb)) return true;
        for (std::size_t c = 0; c < N; ++c) {
            const double budget = budget_per_volume_[c] * vb;
            if (!(budget > 0.0)) return false;
            const double* m = mean_.data() + c * nd_;
            double err = 0;
            for (std::uint32_t iz = z0; iz < z1; ++iz)
                for (std::uint32_t ir = r0; ir < r1; ++ir) {
                    const float* v = t.values().data() + t.value_index(c, iz, ir, 0);
                    double e = 0;
                    for (std::size_t j = 0; j < nd_; ++j) e += dom_[j] * std::abs(double(v[j]) - m[j]);
                    err += vol_[ir] * e;
                    if (err > budget) return false;
                }
        }
        return true;
    }
    // The noise-aware test of the file comment over the in-grid cells [z0, z1) x [r0, r1) of
    // volume vb, every channel.
    bool flat_within_noise(const MsTable<N>& t, std::uint32_t z0, std::uint32_t z1, std::uint32_t r0, std::uint32_t r1,
                           double vb) {
        const std::size_t cells = grid_.cells();
        const double n = double(z1 - z0) * double(r1 - r0);
        if (n < 2) return false;
        const double dof = n - 1.0, limit = dof + noise_factor_ * std::sqrt(2.0 * dof);
        for (std::size_t c = 0; c < N; ++c) {
            double sum_t = 0, sum_var = 0;
            for (std::uint32_t iz = z0; iz < z1; ++iz)
                for (std::uint32_t ir = r0; ir < r1; ++ir) {
                    const float* v = t.values().data() + t.value_index(c, iz, ir, 0);
                    double l1 = 0;
                    for (std::size_t j = 0; j < nd_; ++j) l1 += dom_[j] * double(v[j]);
                    const double tk = vol_[ir] * l1, r = noise_[c * cells + std::size_t(iz) * grid_.n_rho + ir];
                    tk_[std::size_t(iz - z0) * (r1 - r0) + (ir - r0)] = tk;
                    sum_t += tk;
                    sum_var += (r * tk) * (r * tk);
                }
            if (!(sum_t > 0.0)) continue;  // an all-zero channel is flat
            const double d = sum_t / vb, w = sum_var / sum_t;
            if (!(w > 0.0)) return false;  // power without a noise estimate: keep the detail
            double chi2 = 0;
            for (std::uint32_t iz = z0; iz < z1; ++iz)
                for (std::uint32_t ir = r0; ir < r1; ++ir) {
                    const double tk = tk_[std::size_t(iz - z0) * (r1 - r0) + (ir - r0)];
                    const double r = noise_[c * cells + std::size_t(iz) * grid_.n_rho + ir];
                    const double expect = d * vol_[ir];
                    const double var = std::max((r * tk) * (r * tk), w * expect);
                    chi2 += (tk - expect) * (tk - expect) / var;
                    if (chi2 > limit) return false;
                }
        }
        return true;
    }
    // The node of block (z0, r0, s); its subtree (children stored contiguously) and lobes are
    // appended to nodes_ and data_.
    Node build(const MsTable<N>& t, const std::vector<std::uint8_t>& full, std::uint32_t z0, std::uint32_t r0,
               std::uint32_t s) {
        if (z0 >= grid_.n_z || r0 >= grid_.n_rho) return Node{};
        const std::uint32_t z1 = std::min<std::uint32_t>(z0 + s, grid_.n_z), r1 = std::min<std::uint32_t>(r0 + s, grid_.n_rho);
        bool any = false;
        for (std::uint32_t iz = z0; iz < z1 && !any; ++iz)
            for (std::uint32_t ir = r0; ir < r1 && !any; ++ir) any = full[std::size_t(iz) * grid_.n_rho + ir] != 0;
        if (!any) return Node{};
        if (s == 1) {
            const Node leaf{kLeaf, std::uint32_t(data_.size())};
            for (std::size_t c = 0; c < N; ++c)
                for (std::size_t j = 0; j < nd_; ++j) data_.push_back(t.values()[t.value_index(c, z0, r0, j)]);
            ++covered_cells_;
            return leaf;
        }
        if ((merge_tolerance_ > 0.0 || noise_factor_ > 0.0) && mergeable(t, z0, r0, s)) {
            const Node leaf{kLeaf, std::uint32_t(data_.size())};
            for (double m : mean_) data_.push_back(float(m));
            covered_cells_ += std::size_t(z1 - z0) * (r1 - r0);
            ++merged_leaves_;
            return leaf;
        }
        const std::uint32_t first = std::uint32_t(nodes_.size()), h = s / 2;
        nodes_.resize(nodes_.size() + 4);
        for (std::uint32_t q = 0; q < 4; ++q) {
            const Node child = build(t, full, z0 + (q / 2) * h, r0 + (q % 2) * h, h);
            nodes_[first + q] = child;
        }
        return Node{first, 0};
    }

    MsTableGrid grid_;
    std::array<double, N> albedo_{};
    double g_ = 0;
    std::uint64_t photons_ = 0;
    std::size_t nd_ = 1;
    float threshold_ = 0.0f;
    std::uint32_t side_ = 1;
    double merge_tolerance_ = 0;
    std::span<const double> noise_;  // per channel and cell: relative noise (noise-aware merging; only during construction)
    double noise_factor_ = 0;        // standard deviations of the chi-square allowed (0: off)
    std::vector<double> tk_;         // scratch: the block's cell powers
    std::array<double, N> budget_per_volume_{};
    std::vector<double> vol_, dom_, mean_;  // cell volume by rho ring, bin solid angle, scratch lobe
    std::size_t covered_cells_ = 0, merged_leaves_ = 0;
    std::vector<Node> nodes_;
    std::vector<float> data_;
};

}  // namespace grainlight
