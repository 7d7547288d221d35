/// @file grainlight/integrators/ept.hpp
/// Explicit path tracing (EPT) of the grains of a procedural aggregate (Meng15 Sec. 3.2), with
/// the small scene layer's lights, ground and camera (scene/scene.hpp, or any LitScene).
///
/// Pieces, each usable alone:
///   - `grain_sojourn`: what happens to a path that hits a grain surface until it leaves that
///     grain's surface outward (or is absorbed): Fresnel reflection / Snell refraction at smooth
///     dielectric grains (walk.hpp's `sample_dielectric`), the homogeneous interior medium of
///     absorbing dielectrics (Beer-Lambert absorption as a weight, scattering by weighted delta
///     tracking with an HG phase), Lambertian reflection at diffuse grains. Interior
///     coefficients are per bounding-sphere radius (geometry/grains.hpp), i.e. divided by the
///     aggregate's grain radius R here.
///   - `ept_photon_walk`: a photon (importance transport) in an aggregate without other scene
///     surfaces, reporting straight segments and complete grain interactions (entry into the
///     grain's bounding sphere x_i, exit x_o, as in Meng15's scatterometer and Sec. 4.2): the
///     basis of the free-flight measurement (Fig. 6 bottom) and the detector sphere (Fig. 9).
///   - `ept_free_flights`: the free-flight distance between exit points of grain interactions
///     measured in an infinite aggregate, to compare with Eq. 4's 1/sigma_t.
///   - `ept_radiance` / `render_ept`: camera paths (radiance transport) with next-event
///     estimation at diffuse surfaces (diffuse grains and scene surfaces; shadow rays are
///     blocked by every grain, so NEE only helps near the aggregate's surface, Meng15 Sec. 3.2),
///     MIS (power heuristic) between light sampling and cosine sampling for area and environment
///     lights, Russian roulette, and the split of the radiance into low-order (paths with <= k
///     grain interactions; default k = 10, Meng15 Sec. 4.2.3's randomization length) and
///     high-order contributions, rendered to separate films.
///
/// A grain *interaction* starts when a path hits a grain's surface coming from outside it and
/// ends when the path leaves that grain's bounding sphere (a concave grain may be hit again on
/// the way out: that is the same interaction).
///
/// Kernel rules: no allocation, no exceptions, no virtual calls; randomness only from `rng`.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <concepts>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/grain_walk.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/concepts.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/traversal/aggregate.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace grainlight {

/// Options of the explicit path tracer.
struct EptOptions {
    int max_events = 4096;     ///< surface + interior events per path (the path ends beyond)
    int rr_depth = 16;         ///< Russian roulette after this many events
    int low_order_max = 10;    ///< k: paths with <= k grain interactions go to the low-order image
    bool nee = true;           ///< next-event estimation at diffuse surfaces (with MIS)
    /// Radiance (camera paths: 1/eta^2 scaling at refractions) or importance (light paths: none).
    TransportMode mode = TransportMode::radiance;
};

// GrainSojourn (the outcome of a walk inside a grain) is defined in geometry/grain_walk.hpp.

namespace detail {

/// Offset relative to the grain radius used to leave a grain surface.
[[nodiscard]] inline double grain_surface_epsilon(double R) noexcept { return 2e-5 * R; }

}  // namespace detail

/// A path travelling along `d` hits grain `g` of `agg` at `p` (outward normal `n`): the weighted
/// grain walk of geometry/grain_walk.hpp in world units (interior coefficients are per
/// bounding-sphere radius, divided by the aggregate's grain radius R), through the aggregate's
/// instance of the grain. Ends when the path leaves the grain's surface outward (kind = exited),
/// or is absorbed / runs out of events (any other kind). `throughput` is updated per channel.
/// `on_diffuse(p, n_facing, throughput)` is called at each Lambertian grain event before the
/// bounce (NEE); `on_segment(a, b)` for every straight piece travelled inside the grain. `events`
/// counts toward a budget of `max_events`.
template <BoundaryShape Shape, class S, class OnDiffuse, class OnSegment>
[[nodiscard]] GrainSojourn grain_sojourn(const GranularAggregate<Shape>& agg, const AggregateGrain& g, Vec3d p, Vec3d d,
                                         Vec3d n, S& throughput, Rng& rng, TransportMode mode, int max_events,
                                         OnDiffuse&& on_diffuse, OnSegment&& on_segment) noexcept {
    const double R = agg.grain_radius();
    GrainWalkOptions opt;
    opt.estimator = GrainEstimator::weighted;
    opt.mode = mode;
    opt.max_events = max_events;
    auto intersect = [&](const Vec3d& o, const Vec3d& w, double& t, Vec3d& nn) {
        const AggregateHit h = agg.intersect_grain(g, o, w, 0.0, 4.0 * R);
        if (!h) return false;
        t = h.t;
        nn = h.n;
        return true;
    };
    return grain_walk(agg.exemplars()[g.exemplar].material(), R, detail::grain_surface_epsilon(R), intersect, p, d, n,
                      throughput, rng, opt, on_diffuse, on_segment);
}

/// One complete grain interaction of a photon walk (Meng15 Sec. 4.1's TSDF quantities).
struct GrainInteraction {
    /// The grain instance the photon interacted with.
    AggregateGrain grain{};
    /// @var x_i
    /// Entry point into the bounding sphere.
    Vec3d x_i{0.0}, w_i{0.0};  ///< entry point into the bounding sphere and incident direction
    /// @var x_o
    /// Exit point from the bounding sphere (if not absorbed).
    Vec3d x_o{0.0}, w_o{0.0};  ///< exit point from the bounding sphere and exit direction (if not absorbed)
    double flight = 0;         ///< distance from the previous exit point (or walk start) to x_i
    /// True if the photon did not leave the grain (absorbed, or the event budget ran out); x_o is
    /// then the grain-surface point where it last entered the grain and w_o is unused.
    bool absorbed = false;
    ChannelValues survival{1.0};  ///< per-channel throughput ratio over the interaction (the
                                  ///< grain's survival weight; 1 for lossless grains), one value
                                  ///< per channel of the walk's spectrum
    int index = 0;             ///< 1 for the first interaction of the walk
};

/// How a photon walk ended.
enum class PhotonWalkEnd : std::uint8_t { escaped, absorbed, stopped, max_events };

/// A photon walk through the aggregate alone (no other scene surfaces), importance transport.
/// Starts at `p` (outside every grain) along unit `d`. Callbacks (all optional, detected with
/// `requires`): `bool on_segment(const Vec3d& a, const Vec3d& b)` for each straight piece
/// (return false to stop), `bool on_interaction(const GrainInteraction&)` after each complete
/// interaction (false to stop). `throughput` carries the per-channel weight. Russian roulette
/// is analog for grey lossless grains (weights stay 1).
template <BoundaryShape Shape, class S, class Callbacks>
PhotonWalkEnd ept_photon_walk(const GranularAggregate<Shape>& agg, Vec3d p, Vec3d d, S& throughput, Rng& rng,
                              Callbacks& cb, int max_events = 1 << 20, double max_flight = 1e6) noexcept {
    using F = typename S::value_type;
    const double R = agg.grain_radius();
    int events = 0, index = 0;
    auto seg = [&](const Vec3d& a, const Vec3d& b) {
        if constexpr (requires { cb.on_segment(a, b); })
            return cb.on_segment(a, b);
        else
            return true;
    };
    bool stop = false;
    while (events < max_events) {
        const AggregateHit h = agg.intersect(p, d, 0.0, max_flight);
        if (!h) {
            (void)seg(p, p + max_flight * d);
            return PhotonWalkEnd::escaped;
        }
        GrainInteraction gi;
        gi.grain = h.grain;
        gi.index = ++index;
        const Vec3d c = agg.sphere_center(h.grain.tile, h.grain.sphere);
        const auto roots = intersect_sphere(p, d, c, R);
        const double t_in = std::max(0.0, roots.hit ? roots.t_near : 0.0);
        gi.x_i = p + t_in * d;
        gi.w_i = d;
        gi.flight = t_in;
        Vec3d q = p + h.t * d;
        if (!seg(p, q)) return PhotonWalkEnd::stopped;
        Vec3d n = h.n;
        const S before = throughput;
        static_assert(S::size <= ChannelValues::max_channels, "ept_photon_walk: too many spectrum channels");
        auto set_survival = [&]() {
            std::array<double, S::size> ratio{};
            for (std::size_t ch = 0; ch < S::size; ++ch)
                ratio[ch] = before[ch] > F(0) ? double(throughput[ch]) / double(before[ch]) : 0.0;
            gi.survival = ChannelValues(std::span<const double>(ratio));
        };
        for (;;) {
            const GrainSojourn s = grain_sojourn(
                agg, h.grain, q, d, n, throughput, rng, TransportMode::importance, max_events - events,
                [](const Vec3d&, const Vec3d&, S&) {}, [&](const Vec3d& a, const Vec3d& b) {
                    if (!stop && !seg(a, b)) stop = true;
                });
            events += s.events;
            if (stop) return PhotonWalkEnd::stopped;
            if (!s.is_exited()) {
                gi.absorbed = true;
                gi.x_o = q;
                gi.survival = ChannelValues(0.0);
                if constexpr (requires { cb.on_interaction(gi); }) (void)cb.on_interaction(gi);
                return events >= max_events ? PhotonWalkEnd::max_events : PhotonWalkEnd::absorbed;
            }
            // Leave the bounding sphere, unless the same grain is hit again on the way.
            const auto r2 = intersect_sphere(s.p, s.d, c, R);
            const double t_out = r2.hit ? std::max(0.0, r2.t_far) : 0.0;
            const AggregateHit again = agg.intersect_grain(h.grain, s.p, s.d, 0.0, t_out);
            if (again) {
                q = s.p + again.t * s.d;
                if (!seg(s.p, q)) return PhotonWalkEnd::stopped;
                d = s.d;
                n = again.n;
                continue;
            }
            gi.x_o = s.p + t_out * s.d;
            gi.w_o = s.d;
            set_survival();
            if (!seg(s.p, gi.x_o)) return PhotonWalkEnd::stopped;
            p = gi.x_o;
            d = s.d;
            break;
        }
        if constexpr (requires { cb.on_interaction(gi); }) {
            if (!cb.on_interaction(gi)) return PhotonWalkEnd::stopped;
        }
        // Roulette for weighted (coloured / absorbing) walks; analog walks keep weight 1.
        const F q_rr = std::min(F(1), throughput.max_value());
        if (q_rr < F(1)) {
            if (!(q_rr > F(0)) || rng.uniform<F>() >= q_rr) return PhotonWalkEnd::absorbed;
            throughput /= q_rr;
        }
    }
    return PhotonWalkEnd::max_events;
}

/// Result of the free-flight measurement (Meng15 Fig. 6 bottom).
struct FreeFlightStats {
    /// Number of free-flight samples z recorded.
    std::uint64_t samples = 0;
    double mean = 0;        ///< mean of z = flight + (x_o - x_i) . w_i (0 if absorbed)
    double stderr_mean = 0; ///< standard error of the mean
    double mean_flight = 0; ///< mean of the flight part alone (exit -> next entry), for lambda_beta
    std::vector<double> hist;  ///< pdf of z on [0, z_max) in `bins` bins
    /// Upper end of the histogram range of z.
    double z_max = 0;
};

/// Measure free-flight distances between exit points of grain interactions with EPT in an
/// aggregate (typically over EverywhereBoundary): `paths` photons start at uniformly random
/// points between the spheres with uniform directions; the first `skip` interactions of each
/// path are discarded (randomization), the next `per_path` recorded. z per interaction =
/// distance from the previous exit point to the entry point x_i + the teleport component
/// (x_o - x_i) . w_i times the channel-mean survival weight of the interaction (0 if absorbed;
/// 1 for lossless grains): its mean estimates Meng15 Eq. 4's channel-mean lambda_t =
/// lambda_beta + alpha_s lambda_s.
/// Deterministic for a seed; paths are independent (counter-based generators).
template <BoundaryShape Shape>
[[nodiscard]] FreeFlightStats ept_free_flights(const GranularAggregate<Shape>& agg, std::uint64_t paths, int skip,
                                               int per_path, std::uint64_t seed, int bins = 60, double z_max = 0) {
    check_argument(paths >= 1, "ept_free_flights", "paths", paths, ">= 1");
    check_argument(per_path >= 1, "ept_free_flights", "per_path", per_path, ">= 1");
    check_argument(skip >= 1, "ept_free_flights", "skip", skip, ">= 1 (the first flight starts at a random point)");
    check_argument(bins >= 1, "ept_free_flights", "bins", bins, ">= 1");
    const double R = agg.grain_radius();
    if (!(z_max > 0)) z_max = 12.0 * R;
    FreeFlightStats st;
    st.z_max = z_max;
    st.hist.assign(std::size_t(bins), 0.0);
    double sum = 0, sum2 = 0, sum_f = 0;
    std::vector<double> zs;
    for (std::uint64_t i = 0; i < paths; ++i) {
        Rng rng = Rng::from_key(seed, i, 0x66667265ull);
        Vec3d p(0.0);
        for (int k = 0; k < 1000; ++k) {
            p = agg.tile().side() * rng.uniform3<double>();
            if (!agg.tile().sphere_containing(p)) break;
        }
        const Vec3d d = sample_uniform_sphere(rng.uniform2<double>());
        struct Cb {
            int skip, per_path;
            std::vector<double>* zs;
            double* sum_f;
            bool on_interaction(const GrainInteraction& gi) {
                if (gi.index > skip) {
                    const double surv = gi.survival.mean();
                    const double tele = gi.absorbed ? 0.0 : surv * glm::dot(gi.x_o - gi.x_i, gi.w_i);
                    zs->push_back(gi.flight + tele);
                    *sum_f += gi.flight;
                }
                return gi.index < skip + per_path;
            }
        } cb{skip, per_path, &zs, &sum_f};
        RGB w(1.0f);
        (void)ept_photon_walk(agg, p, d, w, rng, cb);
    }
    for (double z : zs) {
        sum += z;
        sum2 += z * z;
        // Negative (teleported back) or beyond z_max: no bin. Cast only inside [0, z_max), where it
        // is defined (a negative or huge double cast to size_t is undefined behaviour).
        if (z >= 0 && z < z_max) {
            const auto b = std::min(std::size_t(z / z_max * bins), st.hist.size() - 1);
            st.hist[b] += 1.0;
        }
    }
    st.samples = zs.size();
    if (st.samples > 0) {
        const double nn = double(st.samples);
        st.mean = sum / nn;
        st.mean_flight = sum_f / nn;
        st.stderr_mean = std::sqrt(std::max(0.0, sum2 / nn - st.mean * st.mean) / nn);
        for (auto& h : st.hist) h /= nn * (z_max / bins);
    }
    return st;
}

namespace detail {
/// Next-event estimation from a Lambertian point x (unit normal nf facing the arriving path,
/// albedo rho, path throughput thr) through a scene and a granular aggregate: one light sample,
/// an Algorithm 1 shadow ray through the grains (counted in `grain_rays`), the scene's
/// transmittance, and the power-heuristic MIS weight against cosine sampling. Returns the
/// contribution (black when the light is not visible). Shared by EPT and the hybrid integrator.
template <LitScene Scene, class Aggregate, class S>
[[nodiscard]] S ept_nee_lambertian(const Scene& scene, const Aggregate& agg, Rng& rng, double R, const Vec3d& x,
                                   const Vec3d& nf, const S& rho, const S& thr, std::uint64_t& grain_rays) noexcept {
    using F = typename Scene::Float;
    constexpr double inf = std::numeric_limits<double>::infinity();
    const Vec3<F> u(rng.uniform<F>(), rng.uniform<F>(), rng.uniform<F>());
    const Vec3d origin = x + grain_surface_epsilon(R) * nf;
    const LightSample<F, S> ls = scene.sample_light(Vec3<F>(origin), u);
    if (!ls || ls.L.is_black()) return S(F(0));
    const Vec3d w(ls.w);
    const double c = glm::dot(w, nf);
    if (c <= 0) return S(F(0));
    const double dist = std::isinf(double(ls.dist)) ? inf : double(ls.dist) * (1 - 1e-4);
    ++grain_rays;
    if (agg.occluded(origin, w, 0.0, std::isinf(dist) ? 1e30 : dist)) return S(F(0));
    const S tr = shadow_transmittance(scene, Vec3<F>(origin), Vec3<F>(w), ls.dist, -1, rng);
    if (tr.is_black()) return S(F(0));
    const double pdf_b = c * inv_pi_v<double>;
    const double wmis = ls.delta ? 1.0 : power_heuristic(double(ls.pdf), pdf_b);
    return thr * rho * tr * ls.L * F(c * inv_pi_v<double> * wmis / double(ls.pdf));
}
}  // namespace detail

/// Radiance of a camera path split into low-order (<= k grain interactions) and high-order parts.
template <class S>
struct EptRadiance {
    /// Low-order part (paths with <= k grain interactions).
    S low{0.0f};
    /// High-order part (paths with more interactions, or past a switch to high order).
    S high{0.0f};
    std::uint64_t grain_rays = 0;  ///< aggregate traversals (Algorithm 1 calls) made
};

/// State of one EPT camera path between steps (the variables of the camera-path loop), public so
/// that integrators built on EPT (the Meng15 hybrid, a user's own) advance a path one event at a
/// time with `ept_step` and stay EPT by construction.
template <class S>
struct EptPathState {
    /// @var p
    /// Current path origin.
    Vec3d p{0.0}, d{0.0, 0.0, 1.0};  ///< current origin and unit direction
    S beta{1.0f};                    ///< path throughput
    bool specular = true;            ///< last bounce was a delta event (no MIS on emission)
    double last_pdf = 0;             ///< solid-angle pdf of the last (non-delta) bounce
    Vec3d last_p{0.0};               ///< where that bounce happened
    int order = 0;                   ///< grain interactions so far
    int events = 0;                  ///< surface + interior events so far
    /// True if last_grain is set (the path last interacted with a grain).
    bool have_last_grain = false;
    /// The grain of the last interaction (not re-hit by the next traversal).
    AggregateGrain last_grain{};
    bool high = false;               ///< contributions go to the high-order part from now on
    int low_order_max = std::numeric_limits<int>::max();  ///< ... and so do those of paths past this order

    /// A camera path starting at `ray` (outside every grain and medium), splitting its radiance at
    /// `low_order_max` grain interactions.
    template <class F>
    [[nodiscard]] static EptPathState start(const Ray<F>& ray, int low_order_max) noexcept {
        EptPathState ps;
        ps.p = Vec3d(ray.o);
        ps.d = glm::normalize(Vec3d(ray.d));
        ps.last_p = ps.p;
        ps.low_order_max = low_order_max;
        return ps;
    }
    /// Whether a contribution now is high order.
    [[nodiscard]] bool contributes_high() const noexcept { return high || order > low_order_max; }
};

/// What `ept_step` did.
enum class EptStep : std::uint8_t {
    next,        ///< the path continues: call ept_step again
    finished,    ///< the path ended (escaped, absorbed, roulette, event budget)
    switch_here  ///< the switch policy chose to leave EPT at the grain hit `x_switch` (not consumed)
};

/// A switch policy's answer at a grain hit.
enum class EptSwitch : std::uint8_t {
    stay,            ///< continue in EPT
    switch_here,     ///< leave EPT here (ept_step returns EptStep::switch_here)
    high_from_here   ///< stay in EPT, but count every later contribution as high order
};

/// The switch policy of plain EPT: never leave.
struct NeverSwitch {
    /// Always EptSwitch::stay.
    template <class S>
    [[nodiscard]] constexpr EptSwitch operator()(const EptPathState<S>&, const Vec3d&, bool) const noexcept {
        return EptSwitch::stay;
    }
};

/// Switch policies: called at every grain hit of a path with its state, the hit point and whether
/// it is the same grain as the previous interaction.
template <class P, class S>
concept EptSwitchPolicy = requires(P& p, const EptPathState<S>& ps, const Vec3d& x, bool same) {
    { p(ps, x, same) } -> std::convertible_to<EptSwitch>;
};

/// One event of an EPT camera path (Meng15 Sec. 3.2): the next scene surface or grain along the
/// path, the grain sojourn or the surface bounce with NEE at diffuse points (MIS, power heuristic)
/// and emission with MIS, then Russian roulette. Contributions go to `low` or `high` by
/// `ps.contributes_high()`; Algorithm 1 traversals are counted in `grain_rays`. `policy` is asked
/// at each grain hit (before it is consumed) whether to switch; on EptSwitch::switch_here the hit
/// is counted as a new interaction, `x_switch` receives the hit point and EptStep::switch_here is
/// returned. Random numbers are consumed in the same order whatever the policy says until it
/// switches, so a path is EPT by construction up to its switch.
template <LitScene Scene, BoundaryShape Shape, class Policy = NeverSwitch>
    requires EptSwitchPolicy<Policy, typename Scene::Spectrum>
[[nodiscard]] EptStep ept_step(const Scene& scene, const GranularAggregate<Shape>& agg,
                               EptPathState<typename Scene::Spectrum>& ps, typename Scene::Spectrum& low,
                               typename Scene::Spectrum& high, std::uint64_t& grain_rays, Rng& rng, const EptOptions& opt,
                               Policy&& policy, Vec3d& x_switch) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    if (ps.events >= opt.max_events) return EptStep::finished;
    const double R = agg.grain_radius();
    Vec3d& p = ps.p;
    Vec3d& d = ps.d;
    S& beta = ps.beta;

    auto add = [&](const S& L) {
        if (ps.contributes_high())
            high += L;
        else
            low += L;
    };
    auto mis_emission = [&](const S& Le, const SurfaceHit<F, S>& hit) {
        if (Le.is_black()) return;
        double w = 1;
        if (opt.nee && !ps.specular) {
            const double pl = double(scene.light_pdf(Vec3<F>(ps.last_p), Vec3<F>(d), hit));
            w = power_heuristic(ps.last_pdf, pl);
        }
        add(beta * Le * F(w));
    };
    // NEE from a Lambertian point (n facing the arriving path) with albedo rho.
    auto nee_diffuse = [&](const Vec3d& x, const Vec3d& nf, const S& rho, const S& thr) {
        if (opt.nee) add(detail::ept_nee_lambertian(scene, agg, rng, R, x, nf, rho, thr, grain_rays));
    };

    const Ray<F> r{Vec3<F>(p), Vec3<F>(d)};
    const SurfaceHit<F, S> sh = scene.intersect(r);
    const double t_s = sh.hit() ? double(sh.t) : 1e30;
    ++grain_rays;
    const AggregateHit gh = agg.intersect(p, d, 0.0, t_s);
    if (gh) {
        // A grain interaction (a new one unless the same grain is hit again right away).
        const bool same = ps.have_last_grain && ps.last_grain.tile == gh.grain.tile && ps.last_grain.sphere == gh.grain.sphere;
        const Vec3d x = p + gh.t * d;
        switch (EptSwitch(policy(std::as_const(ps), x, same))) {
            case EptSwitch::switch_here:
                x_switch = x;
                ++ps.order;
                return EptStep::switch_here;
            case EptSwitch::high_from_here: ps.high = true; break;
            case EptSwitch::stay: break;
        }
        if (!same) ++ps.order;
        ps.have_last_grain = true;
        ps.last_grain = gh.grain;
        const GrainMaterial& m = agg.exemplars()[gh.grain.exemplar].material();
        const GrainSojourn s = grain_sojourn(
            agg, gh.grain, x, d, gh.n, beta, rng, opt.mode, opt.max_events - ps.events,
            [&](const Vec3d& xd, const Vec3d& n, S& thr) { nee_diffuse(xd, n, m.albedo.to_spectrum<S>(), thr); },
            [](const Vec3d&, const Vec3d&) {});
        ps.events += s.events;
        if (!s.is_exited() || beta.is_black()) return EptStep::finished;
        ps.last_p = s.p;
        p = s.p;
        d = s.d;
        ps.specular = s.specular;
        ps.last_pdf = s.pdf;
    } else if (!sh.hit()) {
        mis_emission(scene.environment(Vec3<F>(d)), SurfaceHit<F, S>{});
        return EptStep::finished;
    } else {
        const Vec3d x = p + t_s * d;
        const Vec3d n(sh.n);
        if (sh.light >= 0) mis_emission(scene.emitted(sh, Vec3<F>(d)), sh);
        const bool from_outside = glm::dot(d, n) < 0;
        ps.have_last_grain = false;
        if (sh.type == SurfaceType::absorber) return EptStep::finished;
        if (sh.type == SurfaceType::passthrough) {
            p = x + (from_outside ? -1e-5 : 1e-5) * n;
            return EptStep::next;
        }
        ++ps.events;
        if (sh.type == SurfaceType::diffuse) {
            const Vec3d nf = from_outside ? n : -n;
            nee_diffuse(x, nf, sh.reflectance, beta);
            const Vec3d local = sample_cosine_hemisphere(rng.uniform2<double>());
            d = glm::normalize(Frame<double>(nf).to_world(local));
            beta *= sh.reflectance;
            p = x + 1e-5 * (1.0 + max_abs_component(x)) * nf;
            ps.specular = false;
            ps.last_pdf = cosine_hemisphere_pdf(local.z);
            ps.last_p = x;
        } else if (sh.type == SurfaceType::glossy) {
            // Sampled only (no NEE here): marked specular so the emission it finds counts in full.
            const Vec3d nf = from_outside ? n : -n;
            const Frame<double> fr(nf);
            const auto gs = sample_glossy(fr.to_local(-d), sh.reflectance, double(sh.roughness), rng.uniform2<double>());
            if (!gs.valid) return EptStep::finished;
            d = glm::normalize(fr.to_world(gs.wi));
            beta *= gs.weight;
            p = x + 1e-5 * (1.0 + max_abs_component(x)) * nf;
            ps.specular = true;
            ps.last_pdf = 0;
            ps.last_p = x;
        } else {  // smooth dielectric scene surface
            bool refracted = false;
            double eta_rel = 1;
            const Vec3d w = sample_dielectric(d, n, double(sh.eta), rng.uniform<double>(), refracted, eta_rel);
            if (refracted && opt.mode == TransportMode::radiance) beta /= F(eta_rel * eta_rel);
            d = w;
            p = x + (glm::dot(w, n) >= 0 ? 1e-5 : -1e-5) * (1.0 + max_abs_component(x)) * n;
            ps.specular = true;
            ps.last_pdf = 0;
            ps.last_p = x;
        }
        if (beta.is_black()) return EptStep::finished;
    }
    // Russian roulette.
    if (ps.events >= opt.rr_depth) {
        const F q = std::min(F(1), beta.max_value());
        if (q < F(1)) {
            if (!(q > F(0)) || rng.uniform<F>() >= q) return EptStep::finished;
            beta /= q;
        }
    }
    return EptStep::next;
}

/// Radiance arriving along camera ray (o, d) (scene frame = the aggregate's anchor frame) in a
/// scene `scene` (LitScene: lights, ground, other surfaces; the aggregate is not one of its
/// shapes) containing the aggregate `agg`. The camera is outside every medium and grain. Every
/// grain material must be compatible with the scene's spectrum (GrainMaterial::compatible_with;
/// render_ept checks it).
template <LitScene Scene, BoundaryShape Shape>
[[nodiscard]] EptRadiance<typename Scene::Spectrum> ept_radiance(const Scene& scene, const GranularAggregate<Shape>& agg,
                                                                 const Ray<typename Scene::Float>& ray, Rng& rng,
                                                                 const EptOptions& opt = {}) noexcept {
    using S = typename Scene::Spectrum;
    EptRadiance<S> out;
    auto ps = EptPathState<S>::start(ray, opt.low_order_max);
    Vec3d unused(0.0);
    while (ept_step(scene, agg, ps, out.low, out.high, out.grain_rays, rng, opt, NeverSwitch{}, unused) == EptStep::next) {
    }
    return out;
}

/// Throws grainlight::invalid_argument unless every grain material of `agg` can be rendered with
/// `channels` spectrum channels (no channel is ever folded onto another).
template <BoundaryShape Shape>
inline void check_material_channels(const GranularAggregate<Shape>& agg, std::size_t channels, const char* where) {
    for (const auto& e : agg.exemplars()) e.material().check_channels(channels, where);
}

/// The two images of an EPT render and its ray count.
struct EptImages {
    /// @var low
    /// Low-order image (<= k grain interactions).
    /// @var high
    /// High-order image.
    Film low, high;
    std::uint64_t grain_rays = 0;  ///< Algorithm 1 traversals (camera + shadow rays)
    /// Sum of the low- and high-order images (the full EPT render).
    [[nodiscard]] Image combined() const {
        Image a = low.image();
        const Image b = high.image();
        for (std::size_t i = 0; i < a.rgb.size(); ++i) a.rgb[i] += b.rgb[i];
        return a;
    }
};

/// Render with EPT through the row driver (integrators/render.hpp render_rows): rows over OpenMP
/// threads, one counter-based generator per pixel sample (Pcg32::from_key(seed, pixel, sample)):
/// bit-identical images for any thread count; `ropt` also gives the row share of this process
/// (MPI ranks) and checkpoints / resume (both films in one checkpoint). `grain_rays` counts the
/// traversals of the rows rendered by this call (rows taken from a checkpoint count 0).
/// `progress(1)` is called after each row (thread-safe sink required).
template <LitScene Scene, BoundaryShape Shape, class Camera, class Progress = NoProgress>
[[nodiscard]] EptImages render_ept(const Scene& scene, const GranularAggregate<Shape>& agg, const Camera& camera,
                                   const RenderOptions& ropt, const EptOptions& opt = {}, Progress&& progress = {}) {
    check_argument(ropt.spp >= 1, "render_ept", "spp", ropt.spp, ">= 1");
    check_argument(ropt.threads >= 0, "render_ept", "threads", ropt.threads, ">= 0");
    check_argument(opt.low_order_max >= 0, "render_ept", "low_order_max", opt.low_order_max, ">= 0");
    check_material_channels(agg, Scene::Spectrum::size, "render_ept");
    using F = typename Camera::Float;
    const int w = camera.width(), h = camera.height();
    std::vector<std::uint64_t> row_rays(std::size_t(h), 0);
    auto films = render_rows(
        w, h, 2, ropt,
        [&](int y, std::span<Film> f) {
            for (int x = 0; x < w; ++x) {
                const std::uint64_t pixel = std::uint64_t(y) * std::uint64_t(w) + std::uint64_t(x);
                for (int s = 0; s < ropt.spp; ++s) {
                    Rng rng = Rng::from_key(ropt.seed, pixel, std::uint64_t(s));
                    const Vec2<F> u = rng.uniform2<F>();
                    const auto ray = camera.generate_ray(F(x) + u.x, F(y) + u.y);
                    auto L = ept_radiance(scene, agg, ray, rng, opt);
                    if (!L.low.is_finite()) {  // counted (Film::nonfinite_samples), replaced by zero
                        f[0].add_nonfinite(x, y);
                        L.low = decltype(L.low)(0);
                    }
                    if (!L.high.is_finite()) {
                        f[1].add_nonfinite(x, y);
                        L.high = decltype(L.high)(0);
                    }
                    f[0].add_sample(x, y, L.low);
                    f[1].add_sample(x, y, L.high);
                    row_rays[std::size_t(y)] += L.grain_rays;
                }
            }
        },
        std::forward<Progress>(progress));
    EptImages img{std::move(films[0]), std::move(films[1]), 0};
    for (auto r : row_rays) img.grain_rays += r;
    return img;
}

/// Render with EPT (spp, seed and threads given directly; see the RenderOptions overload).
template <LitScene Scene, BoundaryShape Shape, class Camera, class Progress = NoProgress>
[[nodiscard]] EptImages render_ept(const Scene& scene, const GranularAggregate<Shape>& agg, const Camera& camera, int spp,
                                   std::uint64_t seed, int threads = 0, const EptOptions& opt = {},
                                   Progress&& progress = {}) {
    check_argument(spp >= 1, "render_ept", "spp", spp, ">= 1");
    RenderOptions ropt;
    ropt.spp = spp;
    ropt.seed = seed;
    ropt.threads = threads;
    return render_ept(scene, agg, camera, ropt, opt, std::forward<Progress>(progress));
}

}  // namespace grainlight
