// Shared set-up of the grain-traversal benchmarks (bench_aggregates, bench_embree): the unit
// periodic tile (200 spheres of radius 1 packed at 0.6 by md_pack, seed 1), the radius of a
// boundary sphere holding n grains, and the two ray sets (camera rays from outside toward the
// inner half, seed 5; interior rays from random points inside in random directions, seed 6).
// Both benchmarks include this one header so they time the same grains and the same rays.
#pragma once

#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/packing/periodic_tile.hpp"

namespace grainlight::bench {

/// The md_pack tile (200 spheres, packing rate 0.6, seed 1) rescaled to sphere radius 1.
inline const PeriodicTile& unit_tile() {
    static const PeriodicTile tile = [] {
        const auto packed = md_pack(200, 0.6, 1);
        const double s = 1.0 / packed.tile.radius();
        std::vector<Vec3d> c = packed.tile.centers();
        for (auto& x : c) x *= s;
        return PeriodicTile(packed.tile.side() * s, 1.0, std::move(c));
    }();
    return tile;
}

/// Radius of the boundary sphere holding about n unit grains at the tile's packing rate.
inline double boundary_radius(double n) { return std::cbrt(n / unit_tile().packing_fraction()); }

/// A set of rays (origins, unit directions).
struct Rays {
    std::vector<Vec3d> o, d;
};

/// Camera-like rays: from 1.5 rb outside toward random points of the inner half (key 5).
inline Rays camera_rays(double rb, std::size_t n) {
    Rays r;
    Rng rng = Rng::from_key(5);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3d o = 1.5 * rb * sample_uniform_sphere(rng.uniform2<double>());
        const Vec3d t = 0.5 * rb * rng.uniform<double>() * sample_uniform_sphere(rng.uniform2<double>());
        r.o.push_back(o);
        r.d.push_back(glm::normalize(t - o));
    }
    return r;
}

/// Interior rays: random points within 0.8 rb, random directions (a path inside the material,
/// between or inside bounding spheres; key 6).
inline Rays interior_rays(double rb, std::size_t n) {
    Rays r;
    Rng rng = Rng::from_key(6);
    for (std::size_t i = 0; i < n; ++i) {
        r.o.push_back(0.8 * rb * std::cbrt(rng.uniform<double>()) * sample_uniform_sphere(rng.uniform2<double>()));
        r.d.push_back(sample_uniform_sphere(rng.uniform2<double>()));
    }
    return r;
}

}  // namespace grainlight::bench
