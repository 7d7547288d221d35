/// @file grainlight/precompute/ms_table_family.hpp
/// Builds an MsTableFamily (integrators/ms_table_family.hpp) over Henyey-Greenstein materials:
/// one grey multiple-scattering table (precompute/ms_table.hpp) per node of an (albedo, g) grid,
/// all with the same options (grid, particles, seed), as Wang18 Sec. 4.1's 5D table.
#pragma once

#include <cstddef>
#include <vector>

#include "grainlight/core/spectrum.hpp"
#include "grainlight/integrators/ms_table_family.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"

namespace grainlight {

/// The family of HG tables at every (albedos[ia], gs[ig]) with options `opt`. Node lists as
/// MsTableFamily requires (strictly increasing, albedo in (0, 1), g in (-1, 1)); throws
/// invalid_argument otherwise (checked before any table is built).
[[nodiscard]] inline MsTableFamily build_ms_table_family(const std::vector<double>& albedos, const std::vector<double>& gs,
                                                         const MsTableOptions& opt) {
    // Validate the nodes on empty tables' behalf first: a bad list fails before the long build.
    const char* who = "build_ms_table_family";
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
    using Grey = Spectrum<1, float>;
    std::vector<MsTable<1>> tables;
    tables.reserve(albedos.size() * gs.size());
    for (double g : gs)
        for (double a : albedos)
            tables.push_back(MsTable<1>::build(HenyeyGreenstein<float, Grey>(float(g)), Grey(float(a)), opt));
    return MsTableFamily(albedos, gs, std::move(tables));
}

}  // namespace grainlight
