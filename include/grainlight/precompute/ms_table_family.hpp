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
    MsTableFamily::check_nodes(albedos, gs, "build_ms_table_family");  // before the long build
    using Grey = Spectrum<1, float>;
    std::vector<MsTable<1>> tables;
    tables.reserve(albedos.size() * gs.size());
    for (double g : gs)
        for (double a : albedos)
            tables.push_back(MsTable<1>::build(HenyeyGreenstein<float, Grey>(float(g)), Grey(float(a)), opt));
    return MsTableFamily(albedos, gs, std::move(tables));
}

}  // namespace grainlight
