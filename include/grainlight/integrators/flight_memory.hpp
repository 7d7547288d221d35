/// @file grainlight/integrators/flight_memory.hpp
/// A scene view whose one medium remembers the path's flights (media/flight_memory.hpp), so the
/// walk kernel, the VPT callbacks and shadow rays (integrators/walk.hpp, vpt.hpp) run unchanged
/// on a medium with flight memory: `FlightMemoryScene(scene, medium, &memory)` forwards every
/// call to `scene` and returns, for medium index `medium`, a FlightMemoryMedium over the
/// scene's medium and the caller's memory (the other media unchanged, without memory).
///
/// One view per path: the memory is the path's state (no global state). `medium(i)` returns the
/// wrapper by value (it is two pointers), which the kernel binds to a const reference.
#pragma once

#include "grainlight/geometry/distance.hpp"
#include "grainlight/media/flight_memory.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Where an aggregate's grain centres lie, for FlightMemoryMedium: inside its boundary shape
/// (GranularAggregate keeps the grains whose bounding-sphere centre is inside). `distance` is a
/// distance-to-boundary query for the same shape (BoundaryDistance, MeshDistance: anything
/// `ball_inside` takes), used to skip the per-point tests away from the boundary. Holds
/// pointers: both must outlive it.
template <class Shape, class Distance>
struct CentresInside {
    const Shape* shape = nullptr;        ///< the boundary (`inside(x)`)
    const Distance* distance = nullptr;  ///< distance to the boundary
    /// Whether a grain centre may lie at x.
    [[nodiscard]] bool inside(const Vec3d& x) const noexcept { return shape->inside(x); }
    /// Distance from the inside point x to the boundary (the unsigned distance where the query
    /// has one: no parity test).
    [[nodiscard]] double dist(const Vec3d& x) const noexcept {
        if constexpr (requires { { distance->unsigned_distance(x) } -> std::convertible_to<double>; })
            return distance->unsigned_distance(x);
        else
            return (*distance)(x);
    }
    /// out[i] = inside(x[i]) for n points within r of the medium point q (inside by
    /// construction: a point of a flight before it meets the boundary), by the parity of the
    /// segments q -> x[i] against the triangles near q (MeshDistance::inside_near); false (the
    /// caller asks `inside` per point) for other distance queries or too many triangles near q.
    [[nodiscard]] bool classify(const Vec3d& q, double r, const Vec3d* x, int n, bool* out) const noexcept {
        if constexpr (requires { { distance->inside_near(q, r, true, x, n, out) } -> std::convertible_to<bool>; })
            return distance->inside_near(q, r, true, x, n, out);
        else
            return false;
    }
    /// It constrains (see AnyCentre).
    static constexpr bool constrains = true;
};

/// See the file comment. `Scene` must be a LitScene whose Medium has sigma_t(), albedo() and
/// phase() (a homogeneous medium such as ContinuousMedium).
template <LitScene Scene, class Region = AnyCentre>
class FlightMemoryScene {
   public:
    using Float = typename Scene::Float;                                ///< floating-point type
    using Spectrum = typename Scene::Spectrum;                          ///< spectrum type
    using Medium = FlightMemoryMedium<typename Scene::Medium, Region>;  ///< media seen through the view

    /// View of `scene` in which medium index `medium` remembers flights in `*memory` (and, with
    /// a constraining `region`, knows that no grain centre lies outside it).
    FlightMemoryScene(const Scene& scene, int medium, FlightMemory* memory, Region region = {}) noexcept
        : scene_(&scene), medium_(medium), mem_(memory), region_(region) {}

    /// The viewed scene.
    [[nodiscard]] const Scene& base() const noexcept { return *scene_; }
    /// Medium i (with the memory if i is the remembering medium).
    [[nodiscard]] Medium medium(int i) const noexcept {
        return Medium(scene_->medium(i), i == medium_ ? mem_ : nullptr, region_);
    }
    /// Forwarded to the scene.
    [[nodiscard]] SurfaceHit<Float, Spectrum> intersect(const Ray<Float>& r) const noexcept { return scene_->intersect(r); }
    /// Forwarded to the scene.
    [[nodiscard]] bool occluded(const Vec3<Float>& p, const Vec3<Float>& q) const noexcept { return scene_->occluded(p, q); }
    /// Forwarded to the scene.
    [[nodiscard]] LightSample<Float, Spectrum> sample_light(const Vec3<Float>& ref, const Vec3<Float>& u) const noexcept {
        return scene_->sample_light(ref, u);
    }
    /// Forwarded to the scene.
    [[nodiscard]] Float light_pdf(const Vec3<Float>& ref, const Vec3<Float>& w, const SurfaceHit<Float, Spectrum>& hit) const noexcept {
        return scene_->light_pdf(ref, w, hit);
    }
    /// Forwarded to the scene.
    [[nodiscard]] Spectrum emitted(const SurfaceHit<Float, Spectrum>& hit, const Vec3<Float>& w) const noexcept {
        return scene_->emitted(hit, w);
    }
    /// Forwarded to the scene.
    [[nodiscard]] Spectrum environment(const Vec3<Float>& w) const noexcept { return scene_->environment(w); }

   private:
    const Scene* scene_;
    int medium_;
    FlightMemory* mem_;
    Region region_;
};

}  // namespace grainlight
