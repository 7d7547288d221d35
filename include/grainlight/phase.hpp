/// @file grainlight/phase.hpp
/// Umbrella header: every phase function (direction convention in phase/concepts.hpp).
#pragma once

#include "grainlight/phase/concepts.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/phase/isotropic.hpp"
#include "grainlight/phase/tabulated.hpp"
