// A particle cloud's spheres in Embree 3 (RTC_GEOMETRY_TYPE_SPHERE_POINT: a production BVH over
// spheres), as a sphere lookup of grainlight::ExplicitSphereMedium (media/discrete_particles.hpp;
// the interface of GridSphereLookup). Used by guo21_ept_embree (Guo21's EPT over a BVH, the
// paper's EPT structure) and bench_embree's Spheres_* comparison.
//
// containing(p) casts one ray from p along +x: for disjoint spheres the first surface met from a
// point inside sphere k is k's back face, so p is inside the sphere hit iff it is within its
// radius (for overlapping spheres: one of those containing p, as the grid lookup). first_hit keeps
// the grid lookup's rule (entries at t > 1e-5 r; Embree's tnear is 1e-5 of the smallest radius) and
// is called by the medium only from points outside every sphere.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>

#include "grainlight/packing/particle_cloud.hpp"

namespace guo21_embree {

namespace gl = grainlight;

class EmbreeSphereLookup {
public:
    /// Builds the Embree scene of `cloud`'s spheres (not null, not empty); throws
    /// std::runtime_error if Embree fails.
    explicit EmbreeSphereLookup(std::shared_ptr<const gl::ParticleCloud> cloud) : s_(std::make_shared<State>()) {
        s_->cloud = std::move(cloud);
        if (!s_->cloud || s_->cloud->particles().empty())
            throw std::invalid_argument("EmbreeSphereLookup: cloud is null or empty (needs >= 1 particle)");
        const auto t0 = std::chrono::steady_clock::now();
        s_->device = rtcNewDevice(nullptr);
        if (!s_->device) throw std::runtime_error("EmbreeSphereLookup: rtcNewDevice failed");
        s_->scene = rtcNewScene(s_->device);
        RTCGeometry g = rtcNewGeometry(s_->device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        const auto& ps = s_->cloud->particles();
        auto* v = static_cast<float*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), ps.size()));
        if (!v) throw std::runtime_error("EmbreeSphereLookup: vertex buffer allocation failed");
        float r_min = std::numeric_limits<float>::max();
        for (std::size_t i = 0; i < ps.size(); ++i) {
            v[4 * i] = ps[i].x, v[4 * i + 1] = ps[i].y, v[4 * i + 2] = ps[i].z, v[4 * i + 3] = ps[i].r;
            r_min = std::min(r_min, ps[i].r);
        }
        rtcCommitGeometry(g);
        rtcAttachGeometry(s_->scene, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(s_->scene);
        if (rtcGetDeviceError(s_->device) != RTC_ERROR_NONE) throw std::runtime_error("EmbreeSphereLookup: scene build failed");
        s_->tnear = 1e-5f * r_min;
        s_->build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }

    [[nodiscard]] const gl::CloudParticle* particles() const noexcept { return s_->cloud->particles().data(); }
    /// Wall seconds of the Embree build.
    [[nodiscard]] double build_seconds() const noexcept { return s_->build_seconds; }

    [[nodiscard]] std::int64_t containing(const gl::Vec3<float>& p) const noexcept {
        float t = 0;
        const std::int64_t k = cast(p, gl::Vec3<float>(1, 0, 0), 0.0f, std::numeric_limits<float>::infinity(), t);
        if (k < 0) return -1;
        const gl::CloudParticle& c = particles()[std::size_t(k)];
        const gl::Vec3<float> v = c.center() - p;
        return v.x * v.x + v.y * v.y + v.z * v.z < c.r * c.r ? k : -1;
    }

    [[nodiscard]] std::int64_t first_hit(const gl::Vec3<float>& o, const gl::Vec3<float>& d, float t_max,
                                         float& t_hit) const noexcept {
        t_hit = t_max;
        return cast(o, d, s_->tnear, t_max, t_hit);
    }

private:
    struct State {
        std::shared_ptr<const gl::ParticleCloud> cloud;
        RTCDevice device = nullptr;
        RTCScene scene = nullptr;
        float tnear = 0;
        double build_seconds = 0;
        State() = default;
        State(const State&) = delete;
        State& operator=(const State&) = delete;
        ~State() {
            if (scene) rtcReleaseScene(scene);
            if (device) rtcReleaseDevice(device);
        }
    };

    std::int64_t cast(const gl::Vec3<float>& o, const gl::Vec3<float>& d, float tnear, float tfar, float& t) const noexcept {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRayHit rh{};
        rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
        rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
        rh.ray.tnear = tnear;
        rh.ray.tfar = tfar;
        rh.ray.mask = 0xffffffffu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(s_->scene, &ctx, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return -1;
        t = rh.ray.tfar;
        return std::int64_t(rh.hit.primID);
    }

    std::shared_ptr<State> s_;  // shared: the lookup is copied into media and scenes
};

}  // namespace guo21_embree
