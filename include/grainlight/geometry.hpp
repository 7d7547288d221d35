/// @file grainlight/geometry.hpp
/// Umbrella header of the geometry layer: boxes, transforms, spheres, triangle meshes, the BVH,
/// procedural grains and the voxelized aggregate boundary (Meng15 Sec. 3.2).
#pragma once

#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/bvh.hpp"
#include "grainlight/geometry/distance.hpp"
#include "grainlight/geometry/grain.hpp"
#include "grainlight/geometry/grain_walk.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/procedural_boundaries.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/geometry/star_mesh.hpp"
#include "grainlight/geometry/transform.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
