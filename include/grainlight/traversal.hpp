/// @file grainlight/traversal.hpp
/// Umbrella header of the traversal layer: Amanatides-Woo DDA with 64-bit cells, Meng15
/// Algorithm 1 over tiled periodic packings, and the granular-aggregate glue (boundary +
/// tiled packing + instanced grain exemplars).
#pragma once

#include "grainlight/traversal/aggregate.hpp"
#include "grainlight/traversal/dda.hpp"
#include "grainlight/traversal/particle_grid.hpp"
#include "grainlight/traversal/tiled_packing.hpp"
