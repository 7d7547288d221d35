/// @file grainlight/diffusion.hpp
/// Umbrella header: diffusion approximations of multiple scattering (docs/diffusion.md): the
/// classical dipole, the improved (d'Eon & Irving 2011 / photon beam diffusion) half-space
/// model and the multipole slab (Donner & Jensen 2005), with their Fresnel boundary terms.
#pragma once

#include "grainlight/diffusion/boundary.hpp"
#include "grainlight/diffusion/dipole.hpp"
#include "grainlight/diffusion/h_function.hpp"
#include "grainlight/diffusion/improved.hpp"
#include "grainlight/diffusion/multipole.hpp"
