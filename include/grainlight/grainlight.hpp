/// @file grainlight/grainlight.hpp
/// Top-level umbrella, the cheap set: core, every phase function, the Medium concept with the
/// homogeneous continuous medium and the closed medium set, and smooth-dielectric Fresnel. Heavy
/// media (Meng15 teleportation, Moon07 shells, discrete particles) come through
/// `grainlight/media.hpp` or their own headers; optics with Boost.Math, precompute with Eigen and
/// scene with OpenEXR have their own umbrellas, so users of one phase function do not pay for Mie
/// theory, a scatterometer or a BVH.
#pragma once

#include "grainlight/core.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/medium_set.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/phase.hpp"
