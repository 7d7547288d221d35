/// @file grainlight/adapters/embree.hpp
/// A GranularAggregate (traversal/aggregate.hpp) as an Embree 3 user geometry: an Embree-based
/// renderer gets procedural grains (Meng15 Algorithm 1, O(1) memory in the grain count) next to
/// its own meshes, in one rtcIntersect1 / rtcOccluded1 call.
///
/// Registration: `attach_aggregate(device, scene, aggregate)` creates an RTC_GEOMETRY_TYPE_USER
/// geometry of one primitive whose bounds are the aggregate boundary's bounds dilated by the grain
/// radius, and whose intersect / occluded callbacks run GranularAggregate::intersect / occluded.
/// The aggregate must outlive the geometry (Embree keeps a pointer to it).
///
/// Grain records. Embree 3 returns a 32-bit primID, which cannot name a grain of a billion-grain
/// aggregate (64-bit tile index + sphere id). The full record (tile, sphere id, exemplar, the
/// grain's rotation, hit point and normal in the grain's unit frame, world normal, t in double)
/// is written through an extended intersect context: pass an `EmbreeGrainContext` (its first
/// member is the RTCIntersectContext) to rtcIntersect1. The ray's own fields are set as for any
/// Embree hit: tfar (t in units of the ray's direction), Ng (world normal, unnormalized float),
/// u = v = 0, primID = sphere id within the tile, geomID = the user geometry.
///
/// Requirements: every rtcIntersect*/rtcOccluded* call on a scene holding an aggregate passes an
/// EmbreeGrainContext (plain RTCIntersectContexts would be read past their end); rtcIntersect1 or
/// packets (rtcIntersect4/8/16: record[lane]); ray streams are not supported for the records
/// (hits are still correct). No intersection filter functions are called for grain hits.
/// Precision: Embree rays are float; the adapter converts origin and direction to double, runs
/// Algorithm 1 in double with a unit direction and converts t back, so t equals
/// GranularAggregate::intersect's t for the same (float) ray up to the direction's normalization.
#pragma once

#include <embree3/rtcore.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>

#include "grainlight/core/error.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/traversal/aggregate.hpp"

namespace grainlight {

/// What the adapter knows about a grain hit, beyond Embree's 32-bit ids.
struct EmbreeGrainRecord {
    bool hit = false;           ///< set by the adapter for the closest grain hit of the call
    unsigned int geom_id = RTC_INVALID_GEOMETRY_ID;  ///< the aggregate's geometry (several may be attached)
    double t = std::numeric_limits<double>::infinity();  ///< ray parameter in units of the ray's direction
    AggregateGrain grain{};     ///< tile (64-bit), sphere id, exemplar, rotation
    Vec3d n_world{0.0, 0.0, 1.0};  ///< outward unit normal, world frame
    Vec3d p_local{0.0};         ///< hit point in the grain's unit bounding-sphere frame
    Vec3d n_local{0.0, 0.0, 1.0};  ///< outward unit normal in the grain's frame
};

/// The extended intersect context: Embree passes it to the callbacks unchanged. `records` has one
/// entry per ray of the call (1 for rtcIntersect1, the packet width for packets) or is null.
struct EmbreeGrainContext {
    RTCIntersectContext context;            ///< Embree's context (must stay the first member)
    EmbreeGrainRecord* records = nullptr;  ///< one record per ray of the call, or null
};

/// Initialize an extended context (rtcInitIntersectContext + the record pointer).
inline void init_grain_context(EmbreeGrainContext& c, EmbreeGrainRecord* records) noexcept {
    rtcInitIntersectContext(&c.context);
    c.records = records;
}

namespace detail {

template <class Aggregate>
struct EmbreeAggregateCallbacks {
    static void bounds(const RTCBoundsFunctionArguments* args) {
        const auto* agg = static_cast<const Aggregate*>(args->geometryUserPtr);
        const Aabb<double> b = agg->boundary().shape().bounds();
        const double R = agg->grain_radius();
        constexpr float inf = std::numeric_limits<float>::infinity();
        auto lo = [&](double v) { return std::nextafter(float(v - R), -inf); };
        auto hi = [&](double v) { return std::nextafter(float(v + R), inf); };
        RTCBounds* o = args->bounds_o;
        o->lower_x = lo(b.lo.x), o->lower_y = lo(b.lo.y), o->lower_z = lo(b.lo.z);
        o->upper_x = hi(b.hi.x), o->upper_y = hi(b.hi.y), o->upper_z = hi(b.hi.z);
    }

    static void intersect(const RTCIntersectFunctionNArguments* args) {
        const auto* agg = static_cast<const Aggregate*>(args->geometryUserPtr);
        auto* ctx = reinterpret_cast<EmbreeGrainContext*>(args->context);
        const unsigned N = args->N;
        RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, N);
        RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, N);
        for (unsigned i = 0; i < N; ++i) {
            if (args->valid[i] == 0) continue;
            const Vec3d o(RTCRayN_org_x(ray, N, i), RTCRayN_org_y(ray, N, i), RTCRayN_org_z(ray, N, i));
            const Vec3d d(RTCRayN_dir_x(ray, N, i), RTCRayN_dir_y(ray, N, i), RTCRayN_dir_z(ray, N, i));
            const double len = glm::length(d);
            if (!(len > 0)) continue;
            const double tnear = RTCRayN_tnear(ray, N, i), tfar = RTCRayN_tfar(ray, N, i);
            const AggregateHit h = agg->intersect(o, d / len, tnear * len, tfar * len);
            if (!h) continue;
            const double t = h.t / len;
            const float tf = float(t);
            if (!(tf < RTCRayN_tfar(ray, N, i))) continue;  // round-off: keep Embree's nearer hit
            RTCRayN_tfar(ray, N, i) = tf;
            RTCHitN_Ng_x(hit, N, i) = float(h.n.x);
            RTCHitN_Ng_y(hit, N, i) = float(h.n.y);
            RTCHitN_Ng_z(hit, N, i) = float(h.n.z);
            RTCHitN_u(hit, N, i) = 0.0f;
            RTCHitN_v(hit, N, i) = 0.0f;
            RTCHitN_primID(hit, N, i) = h.grain.sphere;
            RTCHitN_geomID(hit, N, i) = args->geomID;
            RTCHitN_instID(hit, N, i, 0) = args->context->instID[0];
            if (ctx->records) {
                EmbreeGrainRecord& r = ctx->records[i];
                r.hit = true;
                r.geom_id = args->geomID;
                r.t = t;
                r.grain = h.grain;
                r.n_world = h.n;
                const Vec3d c = agg->sphere_center(h.grain.tile, h.grain.sphere);
                const Vec3d p = o + h.t * (d / len);
                r.p_local = h.grain.rotation.to_local((p - c) / agg->grain_radius());
                r.n_local = h.grain.rotation.to_local(h.n);
            }
        }
    }

    static void occluded(const RTCOccludedFunctionNArguments* args) {
        const auto* agg = static_cast<const Aggregate*>(args->geometryUserPtr);
        const unsigned N = args->N;
        RTCRayN* ray = args->ray;
        for (unsigned i = 0; i < N; ++i) {
            if (args->valid[i] == 0) continue;
            const Vec3d o(RTCRayN_org_x(ray, N, i), RTCRayN_org_y(ray, N, i), RTCRayN_org_z(ray, N, i));
            const Vec3d d(RTCRayN_dir_x(ray, N, i), RTCRayN_dir_y(ray, N, i), RTCRayN_dir_z(ray, N, i));
            const double len = glm::length(d);
            if (!(len > 0)) continue;
            const double tnear = RTCRayN_tnear(ray, N, i), tfar = RTCRayN_tfar(ray, N, i);
            if (agg->occluded(o, d / len, tnear * len, tfar * len))
                RTCRayN_tfar(ray, N, i) = -std::numeric_limits<float>::infinity();
        }
    }
};

}  // namespace detail

/// Attach `aggregate` to `scene` as a committed Embree user geometry and return its geomID (the
/// scene itself still needs rtcCommitScene). The geometry is released by the scene. Raises
/// grainlight::invalid_argument for a null device or scene, std::runtime_error when Embree fails.
template <BoundaryShape Shape>
unsigned int attach_aggregate(RTCDevice device, RTCScene scene, const GranularAggregate<Shape>& aggregate) {
    check_argument(device != nullptr, "attach_aggregate", "device", std::string_view("null"), "an RTCDevice from rtcNewDevice");
    check_argument(scene != nullptr, "attach_aggregate", "scene", std::string_view("null"), "an RTCScene from rtcNewScene");
    using CB = detail::EmbreeAggregateCallbacks<GranularAggregate<Shape>>;
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    if (!geom)
        raise_error<std::runtime_error>("attach_aggregate: rtcNewGeometry failed (Embree error " +
                                        std::to_string(int(rtcGetDeviceError(device))) + ")");
    rtcSetGeometryUserPrimitiveCount(geom, 1);
    rtcSetGeometryUserData(geom, const_cast<GranularAggregate<Shape>*>(&aggregate));
    rtcSetGeometryBoundsFunction(geom, &CB::bounds, nullptr);
    rtcSetGeometryIntersectFunction(geom, &CB::intersect);
    rtcSetGeometryOccludedFunction(geom, &CB::occluded);
    rtcCommitGeometry(geom);
    const unsigned int id = rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    if (id == RTC_INVALID_GEOMETRY_ID)
        raise_error<std::runtime_error>("attach_aggregate: rtcAttachGeometry failed (Embree error " +
                                        std::to_string(int(rtcGetDeviceError(device))) + ")");
    return id;
}

}  // namespace grainlight
