/// @file grainlight/scene/unbounded_medium.hpp
/// The one unbounded-medium scene: no surfaces, all of space filled with one medium (index 0). A
/// model of WalkScene for photon walks in an infinite homogeneous (or any) medium: the
/// precomputations of the shell tables (Moon07) and the multiple-scattering table (Wang18), the
/// k-NN density tests and the infinite-medium moments all use it.
#pragma once

#include "grainlight/core/ray.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// All of space filled with medium 0 (`medium(i)` returns it for any index); never a surface hit.
/// Holds a pointer to the medium: the medium must outlive the scene.
template <Medium M>
struct UnboundedMediumScene {
    using Float = typename M::Float;        ///< the medium's float type
    using Spectrum = typename M::Spectrum;  ///< the medium's spectrum type
    using Medium = M;                       ///< the one medium type
    const M* m = nullptr;                   ///< the medium (not owned)

    UnboundedMediumScene() = default;
    /// The medium filling space (not copied: keep it alive while the scene is used).
    explicit UnboundedMediumScene(const M& medium) noexcept : m(&medium) {}
    /// The same from a pointer (the form the shell builder used: `UnboundedMediumScene<M>{&m}`).
    explicit UnboundedMediumScene(const M* medium) noexcept : m(medium) {}
    /// No surfaces: every ray misses.
    [[nodiscard]] SurfaceHit<Float, Spectrum> intersect(const Ray<Float>&) const noexcept { return {}; }
    /// The medium, whatever the index.
    [[nodiscard]] const M& medium(int) const noexcept { return *m; }
};

}  // namespace grainlight
