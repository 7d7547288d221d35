// to_string() on the public types a user prints while debugging a scene: each names the type and
// its defining parameters (values checked, not only the type name).
#include <catch2/catch.hpp>

#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
#include "grainlight/media/grain_stats.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/particle.hpp"
#include "grainlight/optics/psd.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/traversal/aggregate.hpp"

using namespace grainlight;
using Catch::Contains;

TEST_CASE("to_string names the type and its parameters", "[to_string]") {
    CHECK_THAT(LorenzMie({1.33, 0.01}, 10.0).to_string(), Contains("LorenzMie[m = 1.33 + 0.01i, x = 10"));
    CHECK_THAT(Goa({1.5, 0.0}, 200.0, 3).to_string(), Contains("Goa[m = 1.5 + 0i, alpha = 200, orders 0..3"));
    ParticleModel pm;
    pm.particle_index = {1.31, 0.0};
    CHECK_THAT(pm.to_string(), Contains("particle index 1.31 + 0i") && Contains("method automatic"));
    CHECK_THAT(LogNormalPsd(10.0, 2.0, 0.1, 2000.0, 1e6).to_string(), Contains("r_g = 10 um, sigma_g = 2"));
    CHECK_THAT(MonodispersePsd(5.0, 3.0).to_string(), Contains("MonodispersePsd[r = 5 um, N = 3]"));
    const auto mesh = make_icosphere<float>(1);
    CHECK_THAT(mesh.to_string(), Contains("TriangleMesh[42 vertices, 80 triangles"));
    CHECK_THAT(SphereBoundary(Vec3d(1, 2, 3), 4.0).to_string(), Contains("center (1, 2, 3), radius 4"));
    CHECK_THAT(BoxBoundary(Vec3d(0.0), Vec3d(1.0, 2.0, 3.0)).to_string(), Contains("BoxBoundary[(0, 0, 0) - (1, 2, 3)]"));
    const PeriodicTile tile(4.0, 1.0, std::vector<Vec3d>{Vec3d(1.0), Vec3d(3.0)});
    CHECK_THAT(tile.to_string(), Contains("PeriodicTile[2 spheres, side 4, radius 1"));
    Film film(4, 3);
    film.add_rgb(0, 0, 1, 1, 1);
    film.add_nonfinite(1, 1);
    CHECK_THAT(film.to_string(), Contains("Film[4x3, total weight 1, 1 non-finite samples]"));
    CHECK_THAT(film.image().to_string(), Contains("Image[4x3, mean (0.0833333"));
    GrainStats gs;
    gs.rays = 10;
    gs.hit = 0.5;
    CHECK_THAT(gs.to_string(), Contains("GrainStats[10 rays, beta 0.5"));
    const GranularAggregate<SphereBoundary> agg(tile, VoxelizedBoundary<SphereBoundary>(SphereBoundary(Vec3d(0.0), 10.0), 4.0),
                                                 std::vector<Grain>{Grain::sphere(0.9, GrainMaterial::make_dielectric(1.5))},
                                                 std::vector<double>{1.0}, 1);
    CHECK_THAT(agg.to_string(), Contains("GranularAggregate[1 exemplar(s), grain radius 1, PeriodicTile[2 spheres") &&
                                    Contains("bounds (-10, -10, -10) - (10, 10, 10)"));
}
