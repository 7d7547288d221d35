/// @file grainlight/packing.hpp
/// Umbrella header of the packing layer: periodic tiles of equal spheres, random sequential
/// addition, the event-driven MD packer (Skoge et al. 2006), the tile library, and outer chord
/// lengths (Dixmier's model, Meng15 Eq. 1).
#pragma once

#include "grainlight/packing/chord_lengths.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/packing/packing_library.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/core/serialization.hpp"
