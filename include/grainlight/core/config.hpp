/// @file grainlight/core/config.hpp
/// Build-wide macros: device annotation, debug assertions, the library version.
#pragma once

#include <cassert>

/// Library major version (API-breaking changes).
#define GRAINLIGHT_VERSION_MAJOR 0
/// Library minor version (additions).
#define GRAINLIGHT_VERSION_MINOR 1
/// Library patch version (fixes).
#define GRAINLIGHT_VERSION_PATCH 0

#if defined(__CUDACC__)
#define GRAINLIGHT_HOST_DEVICE __host__ __device__
#else
/// Function annotation for code that may also run on a GPU: `__host__ __device__` under nvcc, empty otherwise.
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
