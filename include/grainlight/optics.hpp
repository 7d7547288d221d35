/// @file grainlight/optics.hpp
/// Umbrella header of the optics layer (Guo21 Secs. 3-4): Lorenz-Mie, the geometrical optics
/// approximation, single particles (Mie below 2 um, GOA above), size distributions and bulk
/// properties, plus the Mie/GOA phase function (phase/mie.hpp). Pulls in Boost.Math (J1, erfc_inv).
#pragma once

#include "grainlight/optics/bulk.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/ice_index.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/particle.hpp"
#include "grainlight/optics/psd.hpp"
#include "grainlight/optics/mie_phase.hpp"
#include "grainlight/phase/mie.hpp"
