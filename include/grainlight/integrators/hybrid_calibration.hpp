/// @file grainlight/integrators/hybrid_calibration.hpp
/// How many explicit grain interactions the hybrid (integrators/hybrid.hpp) must keep before it
/// may switch to VPT, measured for a grain kind and packing in a half-space of those grains.
///
/// Why: near a boundary the effective medium (Meng15 Eq. 4) misstates the light that comes back
/// from the first grain layers of a dense packing. With grains of low albedo (sand, brown sugar)
/// most reflected light is of that kind, and a hybrid that switches after one interaction
/// (Meng15 Sec. 6) renders such an aggregate several per cent too dark (measured: the sandcastle
/// at -6.8 %, a half-space of the same sand at -7.9 % at normal incidence; with high-albedo
/// grains the same half-space agrees within 1 %). The teleportation-transport model of Sec. 4.1
/// (media/teleportation.hpp) loses the light too, so it is not the reduction to the RTE but the
/// memoryless flights between grains that miss it (docs/meng15_hybrid.md, examples/
/// meng15_halfspace_switch.cpp). The deficit halves with every further explicit interaction.
///
/// `calibrate_min_ept_interactions` traces paths into a half-space of the grains (a box of side
/// 2H and depth D in grain radii under a white sky: each path returns the directional-
/// hemispherical reflectance) by EPT and, from the same EPT prefix, forks at the first grain hit
/// inside the boundary after k = 1..max_k interactions into the hybrid's own VPT continuation
/// (hybrid_vpt_continuation, its own random stream). The paired difference gives the relative
/// bias of switching after k interactions with its standard error, averaged over the incidence
/// angles of the options (0 and 60 degrees by default). The choice is the smallest k whose
/// |bias| <= `tolerance` (max_k if none). It proceeds in rounds of paths (each twice the last:
/// long high-albedo paths settle in the first) and stops when the choice is resolved (its
/// |bias| + 2 standard errors within the tolerance, every smaller k's |bias| - 2 standard errors
/// outside it) or at `max_paths`. Deterministic for a seed on any thread count (blocks merged in
/// order, the stopping rule evaluated on the merged sums).
///
/// Cost: a few seconds for sand (short paths); grains of albedo ~1 have long paths but a small
/// paired variance, so the first rounds settle on k = 1.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/parallel.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/integrators/hybrid.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/scene/shapes.hpp"
#include "grainlight/traversal/aggregate.hpp"

namespace grainlight {

/// Options of calibrate_min_ept_interactions.
struct SwitchCalibrationOptions {
    int max_k = 6;                         ///< largest number of explicit interactions tried (1..32)
    double tolerance = 0.03;               ///< accepted |relative bias| (with 2 standard errors)
    std::uint64_t round_paths = 1000;      ///< paths per incidence angle in the first round (doubling after each)
    std::uint64_t max_paths = 100000;      ///< paths per incidence angle at most
    std::vector<double> incidence_deg{0.0, 60.0};  ///< incidence angles averaged (each in [0, 89))
    double half_width = 300.0;             ///< half-space box half-width, grain radii
    double depth = 300.0;                  ///< half-space box depth, grain radii
    std::uint64_t seed = 1;                ///< path seed
    int threads = 0;                       ///< OpenMP threads (<= 0: default)
    /// The continuation's flight memory (HybridOptions::flight_memory; 0: memoryless VPT). Must
    /// match the render's, whose bias is being calibrated.
    int flight_memory = HybridOptions{}.flight_memory;
    int flight_memory_flights = HybridOptions{}.flight_memory_flights;  ///< HybridOptions::flight_memory_flights
    bool flight_memory_boundary = HybridOptions{}.flight_memory_boundary;  ///< HybridOptions::flight_memory_boundary
};

/// Bias of switching after k explicit interactions (the mean over the incidence angles).
struct SwitchBias {
    int k = 1;                       ///< explicit grain interactions before the switch
    double rel_diff = 0;             ///< (hybrid - EPT) / EPT reflectance
    double stderr_rel = 0;           ///< its standard error (paired)
    double switched_fraction = 0;    ///< paths that reached the switch
};

/// Result of calibrate_min_ept_interactions.
struct SwitchCalibration {
    int min_ept_interactions = 1;    ///< the chosen k (HybridOptions::min_ept_interactions)
    bool resolved = false;           ///< the choice is settled at 2 standard errors (else: the point estimates' choice at max_paths)
    double reflectance_ept = 0;      ///< EPT reflectance, mean over the incidence angles
    std::uint64_t paths = 0;         ///< paths traced per incidence angle
    std::vector<SwitchBias> by_k;    ///< k = 1..max_k
    /// One-line description.
    [[nodiscard]] std::string to_string() const {
        std::string s = "SwitchCalibration[k = " + std::to_string(min_ept_interactions) + (resolved ? "" : " (unresolved)") +
                        ", " + std::to_string(paths) + " paths per angle, bias by k:";
        for (const auto& b : by_k)
            s += " " + std::to_string(b.k) + ": " + detail::to_display(100 * b.rel_diff) + " +- " +
                 detail::to_display(100 * b.stderr_rel) + " %";
        return s + "]";
    }
};

namespace detail {

/// Paired sums of one incidence angle.
struct SwitchCalibrationSums {
    double n = 0, ept = 0;
    std::vector<double> diff, diff2, switched;  ///< per k
    void resize(int kmax) {
        diff.assign(std::size_t(kmax), 0.0);
        diff2.assign(std::size_t(kmax), 0.0);
        switched.assign(std::size_t(kmax), 0.0);
    }
    void add(const SwitchCalibrationSums& o) {
        n += o.n;
        ept += o.ept;
        for (std::size_t k = 0; k < diff.size(); ++k) {
            diff[k] += o.diff[k];
            diff2[k] += o.diff2[k];
            switched[k] += o.switched[k];
        }
    }
};

}  // namespace detail

/// See the file comment. `tile`, `exemplars`, `weights`, `grain_seed`: the grains and packing of
/// the aggregate to render (GranularAggregate's arguments); `effective`: its effective medium
/// (make_effective_medium). Throws grainlight::invalid_argument for options out of range.
template <class Medium>
[[nodiscard]] SwitchCalibration calibrate_min_ept_interactions(const PeriodicTile& tile, const std::vector<GrainExemplar>& exemplars,
                                                               const std::vector<double>& weights, std::uint64_t grain_seed,
                                                               const Medium& effective, const SwitchCalibrationOptions& o) {
    constexpr const char* where = "calibrate_min_ept_interactions";
    check_argument(o.max_k >= 1 && o.max_k <= 32, where, "max_k", o.max_k, "[1, 32]");
    check_argument(o.tolerance > 0.0 && o.tolerance < 1.0, where, "tolerance", o.tolerance, "(0, 1)");
    check_argument(o.round_paths >= 100, where, "round_paths", o.round_paths, ">= 100");
    check_argument(o.max_paths >= o.round_paths, where, "max_paths", o.max_paths, ">= round_paths");
    check_argument(!o.incidence_deg.empty(), where, "incidence_deg.size()", o.incidence_deg.size(), ">= 1");
    for (double a : o.incidence_deg) check_argument(a >= 0.0 && a < 89.0, where, "incidence_deg", a, "[0, 89)");
    check_argument(o.half_width >= 20.0 && std::isfinite(o.half_width), where, "half_width", o.half_width, "[20, inf) grain radii");
    check_argument(o.depth >= 20.0 && std::isfinite(o.depth), where, "depth", o.depth, "[20, inf) grain radii");

    using SceneT = Scene<Medium>;
    using S = typename SceneT::Spectrum;
    using F = typename SceneT::Float;
    const double R = tile.radius();
    const BoxBoundary shape(Vec3d(-o.half_width * R, -o.depth * R, -o.half_width * R), Vec3d(o.half_width * R, 0.0, o.half_width * R));
    const GranularAggregate<BoxBoundary> agg(tile, VoxelizedBoundary<BoxBoundary>(shape, tile.side()), exemplars, weights, grain_seed);
    SceneT ept;
    ept.add_light(SceneT::LightT::environment_light(S(F(1))));
    SceneT vpt = ept;
    const int m = vpt.add_medium(effective);
    const int b = vpt.add_shape(BoxShape<F>(Vec3<F>(shape.lo), Vec3<F>(shape.hi)), Material<F, S>::index_matched(), m, -1);
    const HybridContext<BoundaryDistance<BoxBoundary>> ctx{m, b, {shape}, nullptr};
    HybridOptions hopt;
    hopt.mode = HybridMode::ept_vpt;
    hopt.vpt.max_depth = 1 << 20;  // no truncation: the reference is not truncated either
    hopt.flight_memory = o.flight_memory;
    hopt.flight_memory_flights = o.flight_memory_flights;
    hopt.flight_memory_boundary = o.flight_memory_boundary;
    hopt.validate(where);
    const bool memory = hopt.uses_flight_memory();
    const CentresInside<BoxBoundary, BoundaryDistance<BoxBoundary>> region{&shape, &ctx.distance};
    EptOptions eopt;
    eopt.max_events = 1 << 20;
    const int K = o.max_k;
    const std::size_t na = o.incidence_deg.size();

    auto trace = [&](std::size_t ai, std::uint64_t begin, std::uint64_t end) {
        detail::SwitchCalibrationSums part;
        part.resize(K);
        const double th = o.incidence_deg[ai] * pi_v<double> / 180.0;
        const Vec3d d0(std::sin(th), -std::cos(th), 0.0);
        const double W = 0.25 * o.half_width * R;
        std::vector<S> est(static_cast<std::size_t>(K));
        std::vector<char> forked(static_cast<std::size_t>(K));
        for (std::uint64_t i = begin; i < end; ++i) {
            Rng rng = Rng::from_key(o.seed, i, 0x63616c69ull + ai);
            const Vec3d org((2 * rng.uniform<double>() - 1) * W, 2.0 * R, (2 * rng.uniform<double>() - 1) * W);
            auto ps = EptPathState<S>::start(Ray<F>(Vec3<F>(org), Vec3<F>(d0)), std::numeric_limits<int>::max());
            S low(F(0)), high(F(0));
            std::uint64_t grain_rays = 0;
            std::fill(forked.begin(), forked.end(), char(0));
            FlightMemory history;
            history.radius = R;
            auto policy = [&](const EptPathState<S>& st, const Vec3d& x, bool same) {
                if (memory && !same) history.push(st.p, x);
                if (same || !shape.inside(x)) return EptSwitch::stay;
                for (int k = 1; k <= K && k <= st.order; ++k) {
                    if (forked[std::size_t(k - 1)]) continue;
                    Rng r = Rng::from_key(o.seed ^ 0x6b666f726bull, i, std::uint64_t(k) * 64 + ai);
                    est[std::size_t(k - 1)] = low + high + hybrid_vpt_continuation(vpt, ctx, x, st.d, st.beta, r, hopt, nullptr, nullptr,
                                                                                   memory ? &history : nullptr, region);
                    forked[std::size_t(k - 1)] = 1;
                }
                return EptSwitch::stay;
            };
            Vec3d unused(0.0);
            while (ept_step(ept, agg, ps, low, high, grain_rays, rng, eopt, policy, unused) == EptStep::next) {
            }
            const S total = low + high;
            double y0 = 0;
            for (std::size_t c = 0; c < S::size; ++c) y0 += double(total[c]) / double(S::size);
            part.n += 1;
            part.ept += y0;
            for (int k = 0; k < K; ++k) {
                if (!forked[std::size_t(k)]) continue;  // never switched: EPT's own path, difference 0
                double y = 0;
                for (std::size_t c = 0; c < S::size; ++c) y += double(est[std::size_t(k)][c]) / double(S::size);
                part.diff[std::size_t(k)] += y - y0;
                part.diff2[std::size_t(k)] += (y - y0) * (y - y0);
                part.switched[std::size_t(k)] += 1;
            }
        }
        return part;
    };

    std::vector<detail::SwitchCalibrationSums> sums(na);
    for (auto& s : sums) s.resize(K);
    SwitchCalibration out;
    std::uint64_t done = 0, round = o.round_paths;
    for (;;) {
        const std::uint64_t next = std::min(o.max_paths, done + round);
        round *= 2;
        for (std::size_t ai = 0; ai < na; ++ai) {
            detail::SwitchCalibrationSums init;
            init.resize(K);
            const auto r = parallel_blocks<detail::SwitchCalibrationSums>(
                next - done, 250, o.threads,
                [&](std::uint64_t, std::uint64_t b0, std::uint64_t b1) { return trace(ai, done + b0, done + b1); },
                [](detail::SwitchCalibrationSums& acc, const detail::SwitchCalibrationSums& p) { acc.add(p); }, init);
            sums[ai].add(r);
        }
        done = next;
        // Relative bias per k: mean over angles of (mean diff / mean EPT), variances added.
        out.by_k.assign(std::size_t(K), SwitchBias{});
        out.reflectance_ept = 0;
        for (const auto& s : sums) out.reflectance_ept += s.ept / s.n / double(na);
        for (int k = 0; k < K; ++k) {
            double rel = 0, var = 0, sw = 0;
            for (const auto& s : sums) {
                const double r0 = s.ept / s.n, md = s.diff[std::size_t(k)] / s.n;
                const double v = std::max(0.0, s.diff2[std::size_t(k)] / s.n - md * md) / s.n;
                rel += md / r0 / double(na);
                var += v / (r0 * r0) / double(na * na);
                sw += s.switched[std::size_t(k)] / s.n / double(na);
            }
            out.by_k[std::size_t(k)] = SwitchBias{k + 1, rel, std::sqrt(var), sw};
        }
        out.paths = done;
        // The first k whose bias is within the tolerance; resolved when it is so by 2 standard
        // errors and every smaller k is outside it by 2 standard errors.
        int first = K;
        for (int k = 0; k < K; ++k)
            if (std::abs(out.by_k[std::size_t(k)].rel_diff) <= o.tolerance) {
                first = k + 1;
                break;
            }
        const auto& bf = out.by_k[std::size_t(first - 1)];
        out.resolved = std::abs(bf.rel_diff) + 2.0 * bf.stderr_rel <= o.tolerance;
        for (int k = 0; k + 1 < first; ++k) {
            const auto& bk = out.by_k[std::size_t(k)];
            if (!(std::abs(bk.rel_diff) - 2.0 * bk.stderr_rel > o.tolerance)) out.resolved = false;
        }
        out.min_ept_interactions = first;
        if (out.resolved || done >= o.max_paths) break;
    }
    return out;
}

}  // namespace grainlight
