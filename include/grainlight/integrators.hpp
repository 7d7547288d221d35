/// @file grainlight/integrators.hpp
/// Umbrella header for the reference integrators: the walk kernel (camera paths and photon
/// walks with per-event callbacks), the volumetric path tracer and its render driver, explicit
/// path tracing of grains (Meng15), the EPT -> VPT -> DA hybrid (Meng15 Sec. 5) and point-based
/// rendering through refractive boundaries (Wang18), the slab estimator and the discrete-particle
/// VPT (Guo21).
#pragma once

#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/integrators/flight_memory.hpp"
#include "grainlight/integrators/hybrid.hpp"
#include "grainlight/integrators/ms_table.hpp"
#include "grainlight/integrators/ms_table_family.hpp"
#include "grainlight/integrators/ms_table_quadtree.hpp"
#include "grainlight/integrators/ms_table_symmetric.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/point_based_surroundings.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/shell_tracer.hpp"
#include "grainlight/integrators/slab.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/integrators/walk.hpp"
