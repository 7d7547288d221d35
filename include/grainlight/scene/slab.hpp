/// @file grainlight/scene/slab.hpp
/// A laterally infinite plane-parallel slab as a WalkScene, and the photon-walk estimator of its
/// total reflectance R and transmittance T under collimated incidence (the `slab` example and
/// tests/integrators/test_slab.cpp both call SlabProblem::run).
///
/// Geometry: outside index 1 (vacuum, no medium), the slab occupies -thickness < z < 0 and holds
/// one medium (index 0). Light arrives from z > 0 travelling along
/// (sqrt(1 - mu0^2), 0, -mu0). The faces are smooth dielectric interfaces of relative index
/// `ior` = n_slab / n_outside with unpolarized Fresnel reflection (no cover slides), or
/// index-matched pass-through boundaries when ior == 1. A semi-infinite slab (optical depth inf)
/// has no bottom face.
///
/// Estimator: each photon path starts above the slab with weight 1 and is walked by the library's
/// walk kernel (integrators/walk.hpp: ContinuousMedium free flights, Henyey-Greenstein phase
/// sampling, Fresnel reflect/refract chosen with probability F / 1 - F, analog absorption).
/// R counts every path leaving the lit side (the specular reflection of the top face included),
/// T every path leaving the far side (the unscattered beam included). Per-path contributions are
/// 0 or 1 (grey analog walk), so R and T are means of per-path scores with Welford standard
/// errors.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Two parallel planes z = 0 (normal +z) and z = -thickness (normal -z) bounding medium 0.
/// Models WalkScene.
template <class MediumT>
class SlabScene {
public:
    using Medium = MediumT;
    using Float = typename MediumT::Float;
    using Spectrum = typename MediumT::Spectrum;
    using F = Float;

    /// \param medium the slab's medium; \param thickness > 0 (inf: semi-infinite);
    /// \param ior relative index n_slab / n_outside > 0 (1: index-matched pass-through faces).
    SlabScene(Medium medium, F thickness, F ior) : medium_(std::move(medium)), thickness_(thickness), ior_(ior) {
        check_argument(thickness > F(0), "SlabScene", "thickness", thickness, "(0, inf]");
        check_argument(std::isfinite(ior) && ior > F(0), "SlabScene", "ior", ior, "(0, inf)");
    }

    [[nodiscard]] const Medium& medium(int) const noexcept { return medium_; }
    [[nodiscard]] F thickness() const noexcept { return thickness_; }
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
    Welford R, T;
    std::uint64_t paths = 0;
    void merge(const SlabTally& o) noexcept {
        R.merge(o.R);
        T.merge(o.T);
        paths += o.paths;
    }
};

/// The slab problem: validated parameters, the medium (sigma_t = 1, so thickness = B), the
/// scene, and the photon-walk estimator.
class SlabProblem {
public:
    using F = double;
    using S = Spectrum<1, double>;
    using Phase = HenyeyGreenstein<double, S>;
    using MediumType = ContinuousMedium<Phase, S>;
    using SceneType = SlabScene<MediumType>;

    /// Throws grainlight::invalid_argument naming the parameter (albedo, optical_depth, g, ior,
    /// mu0) when it is out of range.
    explicit SlabProblem(const SlabParams& p) : params_(validate(p)), scene_(make_scene(params_)) {}

    [[nodiscard]] const SlabParams& params() const noexcept { return params_; }
    [[nodiscard]] const SceneType& scene() const noexcept { return scene_; }

    /// Trace paths [first, first + count) with the counter-based generators
    /// Pcg32::from_key(seed, path, 0): the result for a path index does not depend on how the
    /// caller splits the range into batches or threads.
    [[nodiscard]] SlabTally run(std::uint64_t first, std::uint64_t count, std::uint64_t seed) const noexcept {
        SlabTally tally;
        const double mu0 = params_.mu0;
        const Vec3<F> d(std::sqrt(std::max(0.0, 1.0 - mu0 * mu0)), 0.0, -mu0);
        WalkOptions<F> opt;
        opt.mode = TransportMode::importance;
        for (std::uint64_t i = first; i < first + count; ++i) {
            Rng rng = Rng::from_key(seed, i, 0);
            Scorer sc;
            PathState<F, S> st = start_path<F, S>(Ray<F>(Vec3<F>(0.0, 0.0, 1.0), d), -1);
            (void)walk(scene_, st, rng, sc, opt);
            tally.R.add(sc.r);
            tally.T.add(sc.t);
            ++tally.paths;
        }
        return tally;
    }

private:
    struct Scorer {
        double r = 0, t = 0;
        void on_escape(const PathState<F, S>& st) noexcept {
            if (st.ray.d.z > 0)
                r += st.throughput[0];
            else
                t += st.throughput[0];
        }
    };
    static SlabParams validate(const SlabParams& p) {
        check_argument(p.albedo >= 0.0 && p.albedo <= 1.0, "slab", "albedo", p.albedo, "[0, 1]");
        check_argument(p.optical_depth > 0.0, "slab", "optical_depth", p.optical_depth, "(0, inf] (inf = semi-infinite)");
        check_argument(p.g > -1.0 && p.g < 1.0, "slab", "g", p.g, "(-1, 1)");
        check_argument(p.ior > 0.0 && p.ior <= 10.0, "slab", "ior", p.ior, "(0, 10]");
        check_argument(p.mu0 > 0.0 && p.mu0 <= 1.0, "slab", "mu0", p.mu0, "(0, 1]");
        if (std::isinf(p.optical_depth))
            check_argument(p.albedo < 1.0, "slab", "albedo", p.albedo, "[0, 1) for a semi-infinite slab");
        return p;
    }
    static SceneType make_scene(const SlabParams& p) {
        return SceneType(MediumType(1.0, p.albedo, Phase(p.g)), p.optical_depth, p.ior);
    }
    SlabParams params_;
    SceneType scene_;
};

}  // namespace grainlight
