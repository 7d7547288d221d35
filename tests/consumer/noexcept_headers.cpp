// Compiled with -fno-exceptions: every header outside optics/ (Boost.Math), precompute's Eigen
// shell builder and scene/image_io (OpenEXR) must build without exceptions (validation then
// prints its message and aborts).
#include <grainlight/diffusion.hpp>
#include <grainlight/geometry.hpp>
#include <grainlight/grainlight.hpp>
#include <grainlight/integrators.hpp>
#include <grainlight/media.hpp>
#include <grainlight/packing.hpp>
#include <grainlight/traversal.hpp>
