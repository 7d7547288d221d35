/// @file grainlight/precompute/serialization.hpp
/// Forwarding header (deprecated, kept for one release): the container format moved to
/// grainlight/core/serialization.hpp so that the packing, media and precompute layers can all read
/// and write it without including the precompute layer. See CHANGELOG.md.
#pragma once

#include "grainlight/core/serialization.hpp"
