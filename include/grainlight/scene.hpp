/// @file grainlight/scene.hpp
/// Umbrella header: the small scene layer (camera, shapes, materials, lights, scene, film, image
/// files, the plane-parallel slab). Pulls in OpenEXR and libpng through scene/image_io.hpp;
/// include the individual headers to avoid that.
#pragma once

#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/concepts.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/scene/film_checkpoint.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/lights.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/scene/shapes.hpp"
#include "grainlight/scene/slab.hpp"
#include "grainlight/scene/unbounded_medium.hpp"
