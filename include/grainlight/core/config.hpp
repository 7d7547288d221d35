/// @file grainlight/core/config.hpp
/// Build-wide macros: device annotation, debug assertions, the library version.
#pragma once

#include <cassert>

#define GRAINLIGHT_VERSION_MAJOR 0
#define GRAINLIGHT_VERSION_MINOR 1
#define GRAINLIGHT_VERSION_PATCH 0

#if defined(__CUDACC__)
#define GRAINLIGHT_HOST_DEVICE __host__ __device__
#else
#define GRAINLIGHT_HOST_DEVICE
#endif

/// Debug-only check for kernels (pbrt's DCHECK): kernels assume validated input.
#ifndef NDEBUG
#define GRAINLIGHT_DCHECK(cond) assert(cond)
#else
#define GRAINLIGHT_DCHECK(cond) ((void)0)
#endif

namespace grainlight {
/// Library version as a string.
inline constexpr const char* version_string = "0.1.0";
}  // namespace grainlight
