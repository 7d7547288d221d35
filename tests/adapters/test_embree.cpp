// The Embree adapter (adapters/embree.hpp): an aggregate registered as an Embree user geometry
// returns the same hits as Algorithm 1 called directly (GranularAggregate::intersect), with the
// full grain record carried through the extended context; a mesh in front of the aggregate wins
// where it is nearer; occlusion agrees; packets carry one record per lane. Built only when
// find_package(embree 3) succeeds (tests/adapters/ctest.cmake links Embree).
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "grainlight/adapters/embree.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/traversal/aggregate.hpp"

using namespace grainlight;

namespace {

PeriodicTile small_tile(double side = 2.0) {
    Rng rng = Rng::from_key(11, 0, 0);
    return random_sequential_addition(24, 0.3, rng, side);
}

std::vector<GrainExemplar> exemplars() {
    return {GrainExemplar::sphere(0.8, GrainMaterial::make_dielectric(1.5)),
            GrainExemplar::procedural(GrainShape::snow, 1.0, GrainMaterial::make_dielectric(1.31), 7, 3)};
}

struct Embree {
    RTCDevice device = rtcNewDevice(nullptr);
    RTCScene scene = rtcNewScene(device);
    ~Embree() {
        rtcReleaseScene(scene);
        rtcReleaseDevice(device);
    }
};

// One quad (two triangles) z = z0 over [-s, s]^2, facing +z.
unsigned add_ground(const Embree& e, float z0, float s) {
    RTCGeometry g = rtcNewGeometry(e.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4));
    const float vs[12] = {-s, -s, z0, s, -s, z0, s, s, z0, -s, s, z0};
    for (int i = 0; i < 12; ++i) v[i] = vs[i];
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2));
    const unsigned is[6] = {0, 1, 2, 0, 2, 3};
    for (int i = 0; i < 6; ++i) idx[i] = is[i];
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(e.scene, g);
    rtcReleaseGeometry(g);
    return id;
}

RTCRayHit make_ray(const Vec3f& o, const Vec3f& d, float tnear, float tfar) {
    RTCRayHit rh{};
    rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
    rh.ray.tnear = tnear, rh.ray.tfar = tfar;
    rh.ray.mask = 0xFFFFFFFFu, rh.ray.flags = 0, rh.ray.time = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID, rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

}  // namespace

TEST_CASE("Embree user geometry returns Algorithm 1's hits, with the full grain record", "[adapters][embree]") {
    // Far from the origin (anchor 1e6 tiles away): the records must carry 64-bit tiles.
    for (const Vec3i64 anchor : {Vec3i64(0, 0, 0), Vec3i64(1000000, -3000000, 7)}) {
        const SphereBoundary shape(Vec3d(0.1, 0.2, -0.3), 4.3);
        PeriodicTile tile = small_tile();
        const GranularAggregate<SphereBoundary> agg(tile, VoxelizedBoundary<SphereBoundary>(shape, tile.side(), anchor),
                                                    exemplars(), {0.6, 0.4}, 5);
        Embree e;
        const unsigned gid = attach_aggregate(e.device, e.scene, agg);
        rtcCommitScene(e.scene);
        REQUIRE(rtcGetDeviceError(e.device) == RTC_ERROR_NONE);

        // The scene bounds hold the dilated boundary.
        RTCBounds b;
        rtcGetSceneBounds(e.scene, &b);
        CHECK(b.lower_x <= 0.1 - 4.3 - tile.radius());
        CHECK(b.upper_z >= -0.3 + 4.3 + tile.radius());

        Rng rng = Rng::from_key(3, 1, 0);
        int hits = 0, n = 3000;
        for (int i = 0; i < n; ++i) {
            // Rays from a sphere of radius 9 towards random points of the aggregate's bounds, some
            // starting inside (between grains), directions not normalized (Embree allows that).
            const bool inside = i % 4 == 0;
            const Vec3d dir = sample_uniform_sphere(rng.uniform2<double>());
            const Vec3f o = inside ? Vec3f(Vec3d(0.1, 0.2, -0.3) + 2.5 * sample_uniform_sphere(rng.uniform2<double>()))
                                   : Vec3f(9.0 * dir);
            const Vec3d target = Vec3d(0.1, 0.2, -0.3) + 3.0 * sample_uniform_sphere(rng.uniform2<double>());
            const float scale = 0.5f + 2.0f * float(rng.uniform<double>());
            const Vec3f d = scale * Vec3f(glm::normalize(target - Vec3d(o)));

            EmbreeGrainRecord rec;
            EmbreeGrainContext ctx;
            init_grain_context(ctx, &rec);
            RTCRayHit rh = make_ray(o, d, 0.0f, 1e30f);
            rtcIntersect1(e.scene, &ctx.context, &rh);

            const Vec3d od(o), dd(d);
            const double len = glm::length(dd);
            const AggregateHit ref = agg.intersect(od, dd / len, 0.0, 1e30 * len);
            REQUIRE((rh.hit.geomID == gid) == ref.hit);
            REQUIRE(rec.hit == ref.hit);
            if (!ref.hit) continue;
            ++hits;
            REQUIRE(rec.grain.tile == ref.grain.tile);
            REQUIRE(rec.grain.sphere == ref.grain.sphere);
            REQUIRE(rec.grain.exemplar == ref.grain.exemplar);
            REQUIRE(rh.hit.primID == ref.grain.sphere);
            REQUIRE(rec.t * len == Approx(ref.t).epsilon(1e-12));
            REQUIRE(rh.ray.tfar == Approx(float(ref.t / len)).epsilon(1e-6));
            REQUIRE(glm::length(rec.n_world - ref.n) < 1e-12);
            REQUIRE(std::abs(rh.hit.Ng_x - float(ref.n.x)) < 1e-6f);
            // The local record is consistent: the local hit lies on the exemplar's surface (the
            // analytic sphere: |p_local| = 0.8; a mesh grain: within its unit bounding sphere), and
            // rotating the local normal back gives the world normal.
            if (agg.exemplars()[rec.grain.exemplar].is_analytic_sphere())
                REQUIRE(glm::length(rec.p_local) == Approx(0.8).epsilon(1e-6));
            REQUIRE(glm::length(rec.p_local) <= 1.0 + 1e-6);
            REQUIRE(glm::length(rec.grain.rotation.to_world(rec.n_local) - rec.n_world) < 1e-12);
            if (anchor.x != 0) REQUIRE(std::abs(rec.grain.tile.x) > 999990);

            // Occlusion agrees on the segment up to just past the hit, and is clear before it.
            RTCRay shadow = make_ray(o, d, 0.0f, float(rec.t) * 1.001f).ray;
            rtcOccluded1(e.scene, &ctx.context, &shadow);
            REQUIRE(shadow.tfar == -std::numeric_limits<float>::infinity());
            RTCRay clear = make_ray(o, d, 0.0f, float(rec.t) * 0.999f).ray;
            rtcOccluded1(e.scene, &ctx.context, &clear);
            REQUIRE(clear.tfar == Approx(float(rec.t) * 0.999f));
        }
        REQUIRE(hits > n / 2);
        REQUIRE(hits < n);
    }
}

TEST_CASE("a mesh in front of the aggregate is hit where it is nearer", "[adapters][embree]") {
    const SphereBoundary shape(Vec3d(0.0), 3.0);
    PeriodicTile tile = small_tile();
    const GranularAggregate<SphereBoundary> agg(tile, VoxelizedBoundary<SphereBoundary>(shape, tile.side()), exemplars(),
                                                {0.5, 0.5}, 9);
    Embree e;
    const unsigned gid = attach_aggregate(e.device, e.scene, agg);
    const unsigned ground = add_ground(e, 0.5f, 10.0f);  // a plane cutting the aggregate at z = 0.5
    rtcCommitScene(e.scene);
    Rng rng = Rng::from_key(4, 0, 0);
    int on_ground = 0, on_grains = 0;
    for (int i = 0; i < 2000; ++i) {
        const Vec2d u = rng.uniform2<double>();
        const Vec3f o(float(-2.5 + 5 * u.x), float(-2.5 + 5 * u.y), 8.0f);
        const Vec3f d(0.0f, 0.0f, -1.0f);
        EmbreeGrainRecord rec;
        EmbreeGrainContext ctx;
        init_grain_context(ctx, &rec);
        RTCRayHit rh = make_ray(o, d, 0.0f, 1e30f);
        rtcIntersect1(e.scene, &ctx.context, &rh);
        const AggregateHit ref = agg.intersect(Vec3d(o), Vec3d(d), 0.0, 1e30);
        const bool ground_first = !ref.hit || ref.t > 7.5;
        if (ground_first) {
            REQUIRE(rh.hit.geomID == ground);
            REQUIRE(rh.ray.tfar == Approx(7.5f));
            ++on_ground;
        } else {
            REQUIRE(rh.hit.geomID == gid);
            REQUIRE(rh.ray.tfar == Approx(float(ref.t)).epsilon(1e-6));
            REQUIRE(rec.grain.sphere == ref.grain.sphere);
            ++on_grains;
        }
    }
    REQUIRE(on_ground > 200);
    REQUIRE(on_grains > 200);
}

TEST_CASE("packets of 4 rays carry one grain record per lane", "[adapters][embree]") {
    const SphereBoundary shape(Vec3d(0.0), 3.0);
    PeriodicTile tile = small_tile();
    const GranularAggregate<SphereBoundary> agg(tile, VoxelizedBoundary<SphereBoundary>(shape, tile.side()), exemplars(),
                                                {0.5, 0.5}, 2);
    Embree e;
    const unsigned gid = attach_aggregate(e.device, e.scene, agg);
    rtcCommitScene(e.scene);
    Rng rng = Rng::from_key(8, 0, 0);
    for (int p = 0; p < 200; ++p) {
        alignas(16) int valid[4] = {-1, -1, -1, -1};
        alignas(16) RTCRayHit4 rh{};
        Vec3d os[4], ds[4];
        for (int i = 0; i < 4; ++i) {
            os[i] = Vec3d(Vec3f(8.0 * sample_uniform_sphere(rng.uniform2<double>())));
            ds[i] = Vec3d(Vec3f(glm::normalize(2.0 * sample_uniform_sphere(rng.uniform2<double>()) - os[i])));
            rh.ray.org_x[i] = float(os[i].x), rh.ray.org_y[i] = float(os[i].y), rh.ray.org_z[i] = float(os[i].z);
            rh.ray.dir_x[i] = float(ds[i].x), rh.ray.dir_y[i] = float(ds[i].y), rh.ray.dir_z[i] = float(ds[i].z);
            rh.ray.tnear[i] = 0, rh.ray.tfar[i] = 1e30f, rh.ray.mask[i] = 0xFFFFFFFFu;
            rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        }
        EmbreeGrainRecord recs[4];
        EmbreeGrainContext ctx;
        init_grain_context(ctx, recs);
        rtcIntersect4(valid, e.scene, &ctx.context, &rh);
        for (int i = 0; i < 4; ++i) {
            const double len = glm::length(ds[i]);
            const AggregateHit ref = agg.intersect(os[i], ds[i] / len, 0.0, 1e30 * len);
            REQUIRE((rh.hit.geomID[i] == gid) == ref.hit);
            REQUIRE(recs[i].hit == ref.hit);
            if (ref.hit) {
                REQUIRE(recs[i].grain.sphere == ref.grain.sphere);
                REQUIRE(recs[i].grain.tile == ref.grain.tile);
            }
        }
    }
}

TEST_CASE("attach_aggregate rejects a null scene", "[adapters][embree]") {
    const SphereBoundary shape(Vec3d(0.0), 2.0);
    PeriodicTile tile = small_tile();
    const GranularAggregate<SphereBoundary> agg(tile, VoxelizedBoundary<SphereBoundary>(shape, tile.side()), exemplars(),
                                                {0.5, 0.5}, 2);
    Embree e;
    REQUIRE_THROWS_WITH(attach_aggregate(e.device, nullptr, agg), Catch::Contains("scene"));
}
