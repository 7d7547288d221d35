/// @file grainlight/scene/slab.hpp
/// A laterally infinite plane-parallel slab as a WalkScene, its parameters and its R/T tallies.
/// The photon-walk estimator that uses them, SlabProblem, is in integrators/slab.hpp (moved there
/// because it runs the walk kernel: the scene layer sits below the integrators; see CHANGELOG.md).
///
/// Geometry: outside index 1 (vacuum, no medium), the slab occupies -thickness < z < 0 and holds
/// one medium (index 0). Light arrives from z > 0 travelling along
/// (sqrt(1 - mu0^2), 0, -mu0). The faces are smooth dielectric interfaces of relative index
/// `ior` = n_slab / n_outside with unpolarized Fresnel reflection (no cover slides), or
/// index-matched pass-through boundaries when ior == 1. A semi-infinite slab (optical depth inf)
/// has no bottom face.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Two parallel planes z = 0 (normal +z) and z = -thickness (normal -z) bounding medium 0.
/// Models WalkScene.
template <Medium MediumT>
class SlabScene {
public:
    /// The slab's medium type.
    using Medium = MediumT;
    /// Floating-point type.
    using Float = typename MediumT::Float;
    /// Spectrum type.
    using Spectrum = typename MediumT::Spectrum;
    /// Short alias of Float.
    using F = Float;

    /// \param medium the slab's medium; \param thickness > 0 (inf: semi-infinite);
    /// \param ior relative index n_slab / n_outside > 0 (1: index-matched pass-through faces).
    SlabScene(Medium medium, F thickness, F ior) : medium_(std::move(medium)), thickness_(thickness), ior_(ior) {
        check_argument(thickness > F(0), "SlabScene", "thickness", thickness, "(0, inf]");
        check_argument(std::isfinite(ior) && ior > F(0), "SlabScene", "ior", ior, "(0, inf)");
    }

    /// The slab's medium (the index is ignored: there is only medium 0).
    [[nodiscard]] const Medium& medium(int) const noexcept { return medium_; }
    /// Thickness (> 0; +inf for a half-space).
    [[nodiscard]] F thickness() const noexcept { return thickness_; }
    /// Relative index n_slab / n_outside of both faces.
    [[nodiscard]] F ior() const noexcept { return ior_; }

    /// Closest face hit with t in (0, ray.t_max).
    [[nodiscard]] SurfaceHit<F, Spectrum> intersect(const Ray<F>& r) const noexcept {
        SurfaceHit<F, Spectrum> h;
        if (r.d.z == F(0)) return h;
        const F t_top = -r.o.z / r.d.z;
        F t = std::numeric_limits<F>::infinity();
        Vec3<F> n(F(0), F(0), F(1));
        if (t_top > F(0) && t_top < r.t_max) t = t_top;
        if (std::isfinite(thickness_)) {
            const F t_bot = (-thickness_ - r.o.z) / r.d.z;
            if (t_bot > F(0) && t_bot < r.t_max && t_bot < t) {
                t = t_bot;
                n = Vec3<F>(F(0), F(0), F(-1));
            }
        }
        if (!(t < std::numeric_limits<F>::infinity())) return h;
        h.t = t;
        h.p = r(t);
        h.p.z = n.z > F(0) ? F(0) : -thickness_;  // snap onto the plane
        h.n = n;
        h.type = ior_ == F(1) ? SurfaceType::passthrough : SurfaceType::dielectric;
        h.eta = ior_;
        h.medium_inside = 0;
        h.medium_outside = -1;
        h.shape = n.z > F(0) ? 0 : 1;
        return h;
    }

private:
    Medium medium_;
    F thickness_;
    F ior_;
};

/// Parameters of a slab problem (the `slab` example's command line).
struct SlabParams {
    double albedo = 0.9;         ///< single-scattering albedo a in [0, 1]
    double optical_depth = 1.0;  ///< B = sigma_t * thickness in (0, inf]; inf = semi-infinite
    double g = 0.0;              ///< Henyey-Greenstein asymmetry in (-1, 1)
    double ior = 1.0;            ///< relative index n_slab / n_outside in (0, 10] (1 = index-matched)
    double mu0 = 1.0;            ///< cosine of the incidence angle outside the slab, in (0, 1]
};

/// Tallies of a batch of slab paths: R and T per-path scores (mergeable in a fixed order).
struct SlabTally {
    /// @var R
    /// Per-path reflectance scores.
    /// @var T
    /// Per-path transmittance scores.
    Welford R, T;
    /// Number of paths traced.
    std::uint64_t paths = 0;
    /// Add another batch's tallies (merge in a fixed order for deterministic results).
    void merge(const SlabTally& o) noexcept {
        R.merge(o.R);
        T.merge(o.T);
        paths += o.paths;
    }
};

}  // namespace grainlight
