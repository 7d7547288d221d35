/// @file grainlight/core.hpp
/// Umbrella header for the core layer (cheap: GLM and the standard library only).
#pragma once

#include "grainlight/core/color.hpp"
#include "grainlight/core/config.hpp"
#include "grainlight/core/distribution.hpp"
#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/parallel.hpp"
#include "grainlight/core/quadrature.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/serialization.hpp"
#include "grainlight/core/warp.hpp"
