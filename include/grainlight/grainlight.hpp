/// @file grainlight/grainlight.hpp
/// Top-level umbrella: the light layers (core, phase, media). Heavier layers (optics with
/// Boost.Math, precompute with Eigen, scene with OpenEXR) have their own umbrellas so users
/// of one phase function do not pay for Mie theory.
#pragma once

#include "grainlight/core.hpp"
#include "grainlight/media.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/phase.hpp"
