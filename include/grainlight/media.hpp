/// @file grainlight/media.hpp
/// Umbrella header for the media layer: the Medium concept, the homogeneous RTE medium, Meng15's
/// teleportation transport (and its effective RTE parameters) and Moon07's shell medium.
#pragma once

#include "grainlight/media/concepts.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/shell.hpp"
#include "grainlight/media/teleportation.hpp"
