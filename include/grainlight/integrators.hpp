/// @file grainlight/integrators.hpp
/// Umbrella header: the walk kernel, the volumetric path tracer and the render driver.
#pragma once

#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/integrators/walk.hpp"
