/// @file grainlight/integrators/ms_table_family.hpp
/// One precomputation for a family of materials (Wang18 Sec. 4.1: "we repeat the computations
/// for multiple values of alpha and g, and store the responses from all materials in a 5D table
/// ... At run-time, we interpolate over alpha and g to extract the table corresponding to the
/// current material"). A family holds grey MsTable<1> tables on one (rho, z) x (theta, phi) grid at
/// the nodes of an (albedo, g) grid; `table(albedo, g)` extracts an MsTable<N> for a material with
/// N channels.
///
/// Interpolation. The table's power grows like s(alpha) = alpha^2 / (1 - alpha) (the scattered
/// power of orders >= 2 per unit source power in an infinite medium), which linear interpolation
/// in alpha follows badly near alpha = 1. So every node table is divided by its s(alpha_i),
/// interpolated linearly in u = -ln(1 - alpha) (the variable in which the diffusion length
/// 1 / sqrt(3 (1 - alpha) (1 - alpha g)) changes smoothly) and in v = -ln(1 - g) (the log of the
/// transport mean free path), and multiplied by s(alpha).
/// At a node the result is that node's table (to float rounding). The error between nodes is
/// measured in tests/point_based/test_ms_table_family.cpp against directly built tables.
/// The builder over a Henyey-Greenstein family is build_ms_table_family in
/// precompute/ms_table_family.hpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/integrators/ms_table.hpp"

namespace grainlight {

/// Grey multiple-scattering tables over an (albedo, g) grid, interpolated per material.
class MsTableFamily {
public:
    MsTableFamily() = default;

    /// Tables at the nodes: `tables[ig * albedos.size() + ia]` was built for albedo albedos[ia]
    /// and mean cosine gs[ig]. Node lists strictly increasing, albedos in (0, 1) (at least one),
    /// gs in (-1, 1) (at least one); every table non-empty, on the same grid, with its node's
    /// albedo and g (to 1e-6). Throws invalid_argument naming the first violation.
    MsTableFamily(std::vector<double> albedos, std::vector<double> gs, std::vector<MsTable<1>> tables)
        : albedos_(std::move(albedos)), gs_(std::move(gs)), tables_(std::move(tables)) {
        const char* who = "MsTableFamily";
        check_nodes(albedos_, gs_, who);
        check_argument(tables_.size() == albedos_.size() * gs_.size(), who, "tables.size()", tables_.size(),
                       "albedos.size() * gs.size()");
        for (std::size_t ig = 0; ig < gs_.size(); ++ig)
            for (std::size_t ia = 0; ia < albedos_.size(); ++ia) {
                const MsTable<1>& t = tables_[ig * albedos_.size() + ia];
                check_argument(!t.empty(), who, "table size", t.size(), ">= 1");
                check_argument(same_grid(t.grid(), tables_[0].grid()), who, "table grid", double(ig * albedos_.size() + ia),
                               "the grid of tables[0]");
                check_argument(std::abs(t.albedo(0) - albedos_[ia]) <= 1e-6, who, "table albedo", t.albedo(0),
                               "its node's albedo");
                check_argument(std::abs(t.mean_cosine() - gs_[ig]) <= 1e-6, who, "table g", t.mean_cosine(), "its node's g");
            }
    }

    /// The table of a material with per-channel albedos `albedo` and mean cosine g, each inside the
    /// node range ([albedos.front(), albedos.back()], [gs.front(), gs.back()]); throws
    /// invalid_argument otherwise. Its photon count is the smallest of the node tables used.
    template <std::size_t N>
    [[nodiscard]] MsTable<N> table(const std::array<double, N>& albedo, double g) const {
        const char* who = "MsTableFamily::table";
        check_argument(!tables_.empty(), who, "family", "empty", "built from tables");
        check_argument(g >= gs_.front() && g <= gs_.back(), who, "g", g, "[first g node, last g node]");
        const MsTableGrid& grid = tables_[0].grid();
        const std::size_t per_channel = grid.cells() * grid.directions();
        std::vector<float> values(N * per_channel, 0.0f);
        std::uint64_t photons = ~std::uint64_t(0);
        const auto [g0, wg] = bracket(gs_, g, [](double x) { return -std::log1p(-x); });
        for (std::size_t c = 0; c < N; ++c) {
            const double a = albedo[c];
            check_argument(a >= albedos_.front() && a <= albedos_.back(), who, "albedo", a,
                           "[first albedo node, last albedo node]");
            const auto [a0, wa] = bracket(albedos_, a, [](double x) { return -std::log1p(-x); });
            float* out = values.data() + c * per_channel;
            for (int kg = 0; kg < 2; ++kg)
                for (int ka = 0; ka < 2; ++ka) {
                    const double w = (kg ? wg : 1 - wg) * (ka ? wa : 1 - wa);
                    if (w == 0.0) continue;
                    const std::size_t ia = std::min(a0 + std::size_t(ka), albedos_.size() - 1);
                    const std::size_t ig = std::min(g0 + std::size_t(kg), gs_.size() - 1);
                    const MsTable<1>& t = tables_[ig * albedos_.size() + ia];
                    photons = std::min(photons, t.photons());
                    const double f = w * scale(a) / scale(albedos_[ia]);
                    const std::vector<float>& v = t.values();
                    for (std::size_t k = 0; k < per_channel; ++k) out[k] += float(f * double(v[k]));
                }
        }
        std::array<double, N> alb{};
        for (std::size_t c = 0; c < N; ++c) alb[c] = albedo[c];
        return MsTable<N>(grid, alb, g, photons, std::move(values));
    }

    /// Throws invalid_argument (naming `who`) unless both node lists are non-empty and strictly
    /// increasing, albedos in (0, 1) and gs in (-1, 1).
    static void check_nodes(const std::vector<double>& albedos, const std::vector<double>& gs, const char* who) {
        check_argument(!albedos.empty(), who, "albedos.size()", albedos.size(), ">= 1");
        check_argument(!gs.empty(), who, "gs.size()", gs.size(), ">= 1");
        for (std::size_t i = 0; i < albedos.size(); ++i) {
            check_argument(albedos[i] > 0 && albedos[i] < 1, who, "albedo node", albedos[i], "(0, 1)");
            if (i > 0) check_argument(albedos[i] > albedos[i - 1], who, "albedo node", albedos[i], "> the previous node");
        }
        for (std::size_t i = 0; i < gs.size(); ++i) {
            check_argument(gs[i] > -1 && gs[i] < 1, who, "g node", gs[i], "(-1, 1)");
            if (i > 0) check_argument(gs[i] > gs[i - 1], who, "g node", gs[i], "> the previous node");
        }
    }

    /// Albedo nodes.
    [[nodiscard]] const std::vector<double>& albedos() const noexcept { return albedos_; }
    /// Mean-cosine nodes.
    [[nodiscard]] const std::vector<double>& mean_cosines() const noexcept { return gs_; }
    /// Node tables, `tables()[ig * albedos().size() + ia]`.
    [[nodiscard]] const std::vector<MsTable<1>>& tables() const noexcept { return tables_; }
    /// Bytes of the node tables' values.
    [[nodiscard]] std::size_t bytes() const noexcept {
        std::size_t b = 0;
        for (const auto& t : tables_) b += t.bytes();
        return b;
    }
    /// s(alpha) = alpha^2 / (1 - alpha): the power of scattering orders >= 2 per unit source power.
    [[nodiscard]] static double scale(double alpha) noexcept { return alpha * alpha / (1 - alpha); }

private:
    static bool same_grid(const MsTableGrid& a, const MsTableGrid& b) noexcept {
        return a.n_rho == b.n_rho && a.n_z == b.n_z && a.n_theta == b.n_theta && a.n_phi == b.n_phi &&
               a.rho_max == b.rho_max && a.z_min == b.z_min && a.z_max == b.z_max;
    }
    // Lower node index and weight of the upper node for x in [nodes.front(), nodes.back()],
    // linear in map(x).
    template <class Map>
    static std::pair<std::size_t, double> bracket(const std::vector<double>& nodes, double x, Map map) noexcept {
        if (nodes.size() == 1) return {0, 0.0};
        std::size_t i = std::size_t(std::upper_bound(nodes.begin(), nodes.end(), x) - nodes.begin());
        i = std::clamp<std::size_t>(i, 1, nodes.size() - 1) - 1;
        const double m0 = map(nodes[i]), m1 = map(nodes[i + 1]);
        return {i, std::clamp((map(x) - m0) / (m1 - m0), 0.0, 1.0)};
    }

    std::vector<double> albedos_, gs_;
    std::vector<MsTable<1>> tables_;
};

}  // namespace grainlight
