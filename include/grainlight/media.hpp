/// @file grainlight/media.hpp
/// Umbrella header for the media layer.
#pragma once

#include "grainlight/media/concepts.hpp"
#include "grainlight/media/continuous.hpp"
