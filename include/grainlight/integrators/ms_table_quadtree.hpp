/// @file grainlight/integrators/ms_table_quadtree.hpp
/// Quadtree compression of the multiple-scattering table over its (rho, z) grid (Wang18 Sec. 5.2:
/// "we discard nodes with no scattering events"). The (z, rho) cell grid, padded to a power of
/// two, is split into quadrants until a quadrant holds no value above `tolerance` times the
/// table's largest value (an empty leaf: nothing stored) or is a single cell (a full leaf: its
/// N x n_theta x n_phi lobe values). tolerance = 0 drops exact zeros only, so every value read
/// back equals the dense table's; tolerance > 0 also drops cells whose every value is below it.
/// The paper's density-driven lossy merging of non-empty regions is not done.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/integrators/ms_table.hpp"

namespace grainlight {

/// A quadtree-compressed copy of an MsTable<N> (values by cell and direction bin).
template <std::size_t N>
class MsTableQuadtree {
public:
    /// Compress `t`; `tolerance` >= 0 relative to the table's largest value (0: lossless).
    /// Throws invalid_argument for a negative or non-finite tolerance or an empty table.
    explicit MsTableQuadtree(const MsTable<N>& t, double tolerance = 0.0)
        : grid_(t.grid()), albedo_(t.albedos()), g_(t.mean_cosine()), photons_(t.photons()) {
        check_argument(tolerance >= 0.0 && tolerance < 1.0, "MsTableQuadtree", "tolerance", tolerance, "[0, 1)");
        check_argument(!t.empty(), "MsTableQuadtree", "table size", t.size(), ">= 1");
        nd_ = grid_.directions();
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
        build(t, full, 0, 0, side_);
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
    /// Number of cells whose lobes are stored.
    [[nodiscard]] std::size_t stored_cells() const noexcept { return data_.size() / (N * nd_); }
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
    // Returns the node index; children of a node are stored contiguously.
    std::uint32_t build(const MsTable<N>& t, const std::vector<std::uint8_t>& full, std::uint32_t z0,
                        std::uint32_t r0, std::uint32_t s) {
        const std::uint32_t id = std::uint32_t(nodes_.size());
        nodes_.push_back(Node{});
        bool any = false;
        for (std::uint32_t iz = z0; iz < std::min<std::uint32_t>(z0 + s, grid_.n_z) && !any; ++iz)
            for (std::uint32_t ir = r0; ir < std::min<std::uint32_t>(r0 + s, grid_.n_rho) && !any; ++ir)
                any = full[std::size_t(iz) * grid_.n_rho + ir] != 0;
        if (!any) return id;
        if (s == 1) {
            nodes_[id].child = kLeaf;
            nodes_[id].data = std::uint32_t(data_.size());
            for (std::size_t c = 0; c < N; ++c)
                for (std::size_t j = 0; j < nd_; ++j) data_.push_back(t.values()[t.value_index(c, z0, r0, j)]);
            return id;
        }
        const std::uint32_t first = std::uint32_t(nodes_.size());
        nodes_.resize(nodes_.size() + 4);
        nodes_[id].child = first;
        const std::uint32_t h = s / 2;
        for (std::uint32_t q = 0; q < 4; ++q) {
            // Build each child in place at first + q: build() appends, so build into a temporary
            // subtree and move its root node into the reserved slot.
            const std::uint32_t sub = build(t, full, z0 + (q / 2) * h, r0 + (q % 2) * h, h);
            nodes_[first + q] = nodes_[sub];
            if (sub == std::uint32_t(nodes_.size()) - 1 && nodes_[sub].child >= kLeaf) nodes_.pop_back();
        }
        return id;
    }

    MsTableGrid grid_;
    std::array<double, N> albedo_{};
    double g_ = 0;
    std::uint64_t photons_ = 0;
    std::size_t nd_ = 1;
    float threshold_ = 0.0f;
    std::uint32_t side_ = 1;
    std::vector<Node> nodes_;
    std::vector<float> data_;
};

}  // namespace grainlight
