/// @file grainlight/integrators/slab.hpp
/// The photon-walk estimator of a plane-parallel slab's total reflectance R and transmittance T
/// under collimated incidence (the `slab` example and tests/integrators/test_slab.cpp both call
/// SlabProblem::run). The slab itself (SlabScene, SlabParams, SlabTally) is in scene/slab.hpp.
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
#include <algorithm>
#include <cstdint>

#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/slab.hpp"

namespace grainlight {

/// Walk callbacks of a slab photon: R collects what leaves the lit side (z > 0 going up), T what
/// leaves the far side. Scorers with more callbacks derive from it.
template <class F, class S>
struct SlabScorer {
    double r = 0;  ///< weight that left the lit side
    double t = 0;  ///< weight that left the far side
    /// Walk callback: score an escaping path by the side it leaves.
    void on_escape(const PathState<F, S>& st) noexcept {
        if (st.ray.d.z > 0)
            r += st.throughput[0];
        else
            t += st.throughput[0];
    }
};

/// Photon paths [first, first + count) through a slab scene under collimated incidence at
/// cos(theta) = mu0, importance transport, generators Pcg32::from_key(seed, path, 0): the result for
/// a path index does not depend on how the caller splits the range. `make_scorer()` returns a
/// fresh scorer (a SlabScorer or one derived from it) per path.
template <WalkScene Scene, class MakeScorer>
[[nodiscard]] SlabTally run_slab_paths(const Scene& scene, double mu0, std::uint64_t first, std::uint64_t count,
                                       std::uint64_t seed, MakeScorer&& make_scorer) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    SlabTally tally;
    const Vec3<F> d(std::sqrt(std::max(0.0, 1.0 - mu0 * mu0)), 0.0, -mu0);
    WalkOptions<F> opt;
    opt.mode = TransportMode::importance;
    for (std::uint64_t i = first; i < first + count; ++i) {
        Rng rng = Rng::from_key(seed, i, 0);
        auto sc = make_scorer();
        PathState<F, S> st = start_path<F, S>(Ray<F>(Vec3<F>(0.0, 0.0, 1.0), d), -1);
        (void)walk(scene, st, rng, sc, opt);
        tally.R.add(sc.r);
        tally.T.add(sc.t);
        ++tally.paths;
    }
    return tally;
}

/// The slab problem: validated parameters, the medium (sigma_t = 1, so thickness = B), the
/// scene, and the photon-walk estimator.
class SlabProblem {
public:
    /// Floating-point type (double).
    using F = double;
    /// One-channel spectrum of doubles.
    using S = Spectrum<1, double>;
    /// Henyey-Greenstein phase function of the slab.
    using Phase = HenyeyGreenstein<double, S>;
    /// The slab's homogeneous medium type.
    using MediumType = ContinuousMedium<Phase, S>;
    /// The slab scene type.
    using SceneType = SlabScene<MediumType>;

    /// Throws grainlight::invalid_argument naming the parameter (albedo, optical_depth, g, ior,
    /// mu0) when it is out of range.
    explicit SlabProblem(const SlabParams& p) : params_(validate(p)), scene_(make_scene(params_)) {}

    /// The validated parameters.
    [[nodiscard]] const SlabParams& params() const noexcept { return params_; }
    /// The slab scene (medium, thickness, index) built from params().
    [[nodiscard]] const SceneType& scene() const noexcept { return scene_; }

    /// Trace paths [first, first + count) with the counter-based generators
    /// Pcg32::from_key(seed, path, 0): the result for a path index does not depend on how the
    /// caller splits the range into batches or threads.
    [[nodiscard]] SlabTally run(std::uint64_t first, std::uint64_t count, std::uint64_t seed) const noexcept {
        return run_slab_paths(scene_, params_.mu0, first, count, seed, [] { return SlabScorer<F, S>{}; });
    }

private:
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
