/// @file grainlight/media.hpp
/// Umbrella header for the media layer: the Medium concept, the homogeneous RTE medium, the
/// closed medium set, Meng15's teleportation transport (and its effective RTE parameters, with the
/// GrainStats record), Moon07's shell medium and Guo21's discrete-particle medium (which pulls in
/// the optics layer and Boost.Math). The cheap set is grainlight/grainlight.hpp.
#pragma once

#include "grainlight/media/concepts.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/media/flight_memory.hpp"
#include "grainlight/media/grain_stats.hpp"
#include "grainlight/media/medium_set.hpp"
#include "grainlight/media/shell.hpp"
#include "grainlight/media/teleportation.hpp"
