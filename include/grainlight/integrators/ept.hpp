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
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/warp.hpp"
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
    TransportMode mode = TransportMode::radiance;
};

/// Outcome of a grain sojourn.
struct GrainSojourn {
    enum Kind : std::uint8_t { exited, absorbed } kind = absorbed;
    Vec3d p{0.0};          ///< where the path leaves the grain surface (offset outward)
    Vec3d d{0.0};          ///< direction it leaves in
    Vec3d n{0.0};          ///< outward normal at the last surface event
    bool specular = true;  ///< last event was a delta event (false: Lambertian)
    double pdf = 0;        ///< solid-angle pdf of the last direction (Lambertian), else 0
    int events = 0;        ///< surface + interior scattering events
};

namespace detail {

/// Offset relative to the grain radius used to leave a grain surface.
[[nodiscard]] inline double grain_surface_epsilon(double R) noexcept { return 2e-5 * R; }

}  // namespace detail

/// A path travelling along `d` hits grain `g` of `agg` at `p` (outward normal `n`). Simulate it
/// until it leaves the grain's surface outward (kind = exited) or is absorbed. `throughput`
/// is updated (per channel). `on_diffuse(p, n_facing, throughput)` is called at each
/// Lambertian grain event before the bounce (NEE); `on_segment(a, b)` for every straight piece
/// travelled inside the grain. `events` counts toward a budget of `max_events`.
template <BoundaryShape Shape, class S, class OnDiffuse, class OnSegment>
[[nodiscard]] GrainSojourn grain_sojourn(const GranularAggregate<Shape>& agg, const AggregateGrain& g, Vec3d p, Vec3d d,
                                         Vec3d n, S& throughput, Rng& rng, TransportMode mode, int max_events,
                                         OnDiffuse&& on_diffuse, OnSegment&& on_segment) noexcept {
    using F = typename S::value_type;
    const GrainMaterial& m = agg.exemplars()[g.exemplar].material();
    const double R = agg.grain_radius();
    const double eps = detail::grain_surface_epsilon(R);
    GrainSojourn out;
    // Interior medium (absorbing dielectric), world units.
    double sig_a[3] = {0, 0, 0}, sig_s[3] = {0, 0, 0}, s_max = 0, s_mean = 0;
    const bool medium = m.kind == GrainMaterialKind::absorbing_dielectric;
    if (medium)
        for (int c = 0; c < 3; ++c) {
            sig_a[c] = m.interior_sigma_a[c] / R;
            sig_s[c] = m.interior_sigma_s[c] / R;
            s_max = std::max(s_max, sig_s[c]);
            s_mean += sig_s[c] / 3.0;
        }
    bool inside = false;   // travelling inside the grain
    bool at_surface = true;
    for (; out.events < max_events;) {
        if (at_surface) {
            ++out.events;
            const bool from_outside = glm::dot(d, n) < 0;
            if (m.kind == GrainMaterialKind::diffuse) {
                if (!from_outside) return out;  // cannot happen for an opaque grain: treat as absorbed
                on_diffuse(p, n, throughput);
                const Vec3d local = sample_cosine_hemisphere(rng.uniform2<double>());
                const Vec3d w = glm::normalize(Frame<double>(n).to_world(local));
                for (std::size_t c = 0; c < S::size; ++c) throughput[c] *= F(m.albedo[std::min<std::size_t>(c, 2)]);
                out.kind = GrainSojourn::exited;
                out.p = p + eps * n;
                out.d = w;
                out.n = n;
                out.specular = false;
                out.pdf = cosine_hemisphere_pdf(local.z);
                return out;
            }
            bool refracted = false;
            double eta_rel = 1;
            const Vec3d w = sample_dielectric(d, n, m.ior, rng.uniform<double>(), refracted, eta_rel);
            if (refracted && mode == TransportMode::radiance) throughput /= F(eta_rel * eta_rel);
            inside = refracted ? from_outside : !from_outside;
            d = w;
            p = p + (glm::dot(d, n) >= 0 ? eps : -eps) * n;
            if (!inside) {
                out.kind = GrainSojourn::exited;
                out.p = p;
                out.d = d;
                out.n = n;
                out.specular = true;
                out.pdf = 0;
                return out;
            }
        }
        // Inside the grain: next surface, or an interior event.
        const AggregateHit h = agg.intersect_grain(g, p, d, 0.0, 4.0 * R);
        if (!h) return out;  // leaked through the mesh (not for watertight grains): absorbed
        double t = h.t;
        at_surface = true;
        if (medium && s_max > 0) {
            const double ts = sample_exponential(rng.uniform<double>(), s_max);
            if (ts < t) {
                t = ts;
                at_surface = false;
            }
        }
        if (medium)
            for (std::size_t c = 0; c < S::size; ++c) throughput[c] *= F(std::exp(-sig_a[std::min<std::size_t>(c, 2)] * t));
        const Vec3d q = p + t * d;
        on_segment(p, q);
        p = q;
        if (at_surface) {
            n = h.n;
            continue;
        }
        // Weighted delta tracking against the majorant s_max: real scatter with prob s_mean/s_max.
        const double P = s_mean / s_max;
        if (rng.uniform<double>() < P) {
            ++out.events;
            for (std::size_t c = 0; c < S::size; ++c) throughput[c] *= F(sig_s[std::min<std::size_t>(c, 2)] / (P * s_max));
            const double mu = sample_henyey_greenstein_cos(rng.uniform<double>(), m.interior_g);
            d = glm::normalize(direction_from_cosine(d, mu, 2.0 * pi_v<double> * rng.uniform<double>()));
        } else if (P < 1) {
            for (std::size_t c = 0; c < S::size; ++c)
                throughput[c] *= F((1.0 - sig_s[std::min<std::size_t>(c, 2)] / s_max) / (1.0 - P));
        }
        if (throughput.is_black()) return out;
    }
    return out;
}

/// One complete grain interaction of a photon walk (Meng15 Sec. 4.1's TSDF quantities).
struct GrainInteraction {
    AggregateGrain grain{};
    Vec3d x_i{0.0}, w_i{0.0};  ///< entry point into the bounding sphere and incident direction
    Vec3d x_o{0.0}, w_o{0.0};  ///< exit point from the bounding sphere and exit direction (if not absorbed)
    double flight = 0;         ///< distance from the previous exit point (or walk start) to x_i
    bool absorbed = false;
    RGBd survival{1.0, 1.0, 1.0};  ///< per-channel throughput ratio over the interaction (the
                                   ///< grain's survival weight; 1 for lossless grains)
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
        auto set_survival = [&]() {
            for (std::size_t ch = 0; ch < 3; ++ch) {
                const std::size_t k = std::min<std::size_t>(ch, S::size - 1);
                gi.survival[ch] = before[k] > F(0) ? double(throughput[k]) / double(before[k]) : 0.0;
            }
        };
        for (;;) {
            const GrainSojourn s = grain_sojourn(
                agg, h.grain, q, d, n, throughput, rng, TransportMode::importance, max_events - events,
                [](const Vec3d&, const Vec3d&, S&) {}, [&](const Vec3d& a, const Vec3d& b) {
                    if (!stop && !seg(a, b)) stop = true;
                });
            events += s.events;
            if (stop) return PhotonWalkEnd::stopped;
            if (s.kind == GrainSojourn::absorbed) {
                gi.absorbed = true;
                gi.x_o = q;
                gi.survival = RGBd(0.0);
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
    std::uint64_t samples = 0;
    double mean = 0;        ///< mean of z = flight + (x_o - x_i) . w_i (0 if absorbed)
    double stderr_mean = 0; ///< standard error of the mean
    double mean_flight = 0; ///< mean of the flight part alone (exit -> next entry), for lambda_beta
    std::vector<double> hist;  ///< pdf of z on [0, z_max) in `bins` bins
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
            p = agg.tile().side() * Vec3d(rng.uniform<double>(), rng.uniform<double>(), rng.uniform<double>());
            if (!agg.tile().sphere_containing(p)) break;
        }
        const Vec3d d = sample_uniform_sphere(rng.uniform2<double>());
        struct Cb {
            int skip, per_path;
            std::vector<double>* zs;
            double* sum_f;
            bool on_interaction(const GrainInteraction& gi) {
                if (gi.index > skip) {
                    const double surv = (gi.survival[0] + gi.survival[1] + gi.survival[2]) / 3.0;
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
        const auto b = std::size_t(z / z_max * bins);
        if (z >= 0 && b < st.hist.size()) st.hist[b] += 1.0;
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
    S low{0.0f};
    S high{0.0f};
    std::uint64_t grain_rays = 0;  ///< aggregate traversals (Algorithm 1 calls) made
};

/// Radiance arriving along camera ray (o, d) (scene frame = the aggregate's anchor frame) in a
/// scene `scene` (LitScene: lights, ground, other surfaces; the aggregate is not one of its
/// shapes) containing the aggregate `agg`. The camera is outside every medium and grain.
template <LitScene Scene, BoundaryShape Shape>
[[nodiscard]] EptRadiance<typename Scene::Spectrum> ept_radiance(const Scene& scene, const GranularAggregate<Shape>& agg,
                                                                 const Ray<typename Scene::Float>& ray, Rng& rng,
                                                                 const EptOptions& opt = {}) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    EptRadiance<S> out;
    Vec3d p(ray.o), d(glm::normalize(Vec3d(ray.d)));
    S beta(F(1));
    bool specular = true;
    double last_pdf = 0;
    Vec3d last_p = p;
    int order = 0, events = 0;
    bool have_last_grain = false;
    AggregateGrain last_grain{};
    const double R = agg.grain_radius();

    auto add = [&](const S& L) {
        if (order <= opt.low_order_max)
            out.low += L;
        else
            out.high += L;
    };
    auto mis_emission = [&](const S& Le, const SurfaceHit<F, S>& hit) {
        if (Le.is_black()) return;
        double w = 1;
        if (opt.nee && !specular) {
            const double pl = double(scene.light_pdf(Vec3<F>(last_p), Vec3<F>(d), hit));
            w = power_heuristic(last_pdf, pl);
        }
        add(beta * Le * F(w));
    };
    // NEE from a Lambertian point (n facing the arriving path) with albedo rho.
    auto nee_diffuse = [&](const Vec3d& x, const Vec3d& nf, const S& rho, const S& thr) {
        if (opt.nee) add(detail::ept_nee_lambertian(scene, agg, rng, R, x, nf, rho, thr, out.grain_rays));
    };

    while (events < opt.max_events) {
        const Ray<F> r{Vec3<F>(p), Vec3<F>(d)};
        const SurfaceHit<F, S> sh = scene.intersect(r);
        const double t_s = sh.hit() ? double(sh.t) : 1e30;
        ++out.grain_rays;
        const AggregateHit gh = agg.intersect(p, d, 0.0, t_s);
        if (gh) {
            // A grain interaction (a new one unless the same grain is hit again right away).
            if (!(have_last_grain && last_grain.tile == gh.grain.tile && last_grain.sphere == gh.grain.sphere)) ++order;
            have_last_grain = true;
            last_grain = gh.grain;
            const GrainSojourn s = grain_sojourn(
                agg, gh.grain, p + gh.t * d, d, gh.n, beta, rng, opt.mode, opt.max_events - events,
                [&](const Vec3d& x, const Vec3d& n, S& thr) {
                    const GrainMaterial& m = agg.exemplars()[gh.grain.exemplar].material();
                    S rho;
                    for (std::size_t c = 0; c < S::size; ++c) rho[c] = F(m.albedo[std::min<std::size_t>(c, 2)]);
                    nee_diffuse(x, n, rho, thr);
                },
                [](const Vec3d&, const Vec3d&) {});
            events += s.events;
            if (s.kind == GrainSojourn::absorbed || beta.is_black()) break;
            last_p = s.p;
            p = s.p;
            d = s.d;
            specular = s.specular;
            last_pdf = s.pdf;
        } else if (!sh.hit()) {
            mis_emission(scene.environment(Vec3<F>(d)), SurfaceHit<F, S>{});
            break;
        } else {
            const Vec3d x = p + t_s * d;
            const Vec3d n(sh.n);
            if (sh.light >= 0) mis_emission(scene.emitted(sh, Vec3<F>(d)), sh);
            const bool from_outside = glm::dot(d, n) < 0;
            have_last_grain = false;
            if (sh.type == SurfaceType::absorber) break;
            if (sh.type == SurfaceType::passthrough) {
                p = x + (from_outside ? -1e-5 : 1e-5) * n;
                continue;
            }
            ++events;
            if (sh.type == SurfaceType::diffuse) {
                const Vec3d nf = from_outside ? n : -n;
                nee_diffuse(x, nf, sh.reflectance, beta);
                const Vec3d local = sample_cosine_hemisphere(rng.uniform2<double>());
                d = glm::normalize(Frame<double>(nf).to_world(local));
                beta *= sh.reflectance;
                p = x + 1e-5 * (1.0 + max_abs_component(x)) * nf;
                specular = false;
                last_pdf = cosine_hemisphere_pdf(local.z);
                last_p = x;
            } else {  // smooth dielectric scene surface
                bool refracted = false;
                double eta_rel = 1;
                const Vec3d w = sample_dielectric(d, n, double(sh.eta), rng.uniform<double>(), refracted, eta_rel);
                if (refracted && opt.mode == TransportMode::radiance) beta /= F(eta_rel * eta_rel);
                d = w;
                p = x + (glm::dot(w, n) >= 0 ? 1e-5 : -1e-5) * (1.0 + max_abs_component(x)) * n;
                specular = true;
                last_pdf = 0;
                last_p = x;
            }
            if (beta.is_black()) break;
        }
        // Russian roulette.
        if (events >= opt.rr_depth) {
            const F q = std::min(F(1), beta.max_value());
            if (q < F(1)) {
                if (!(q > F(0)) || rng.uniform<F>() >= q) break;
                beta /= q;
            }
        }
    }
    return out;
}

/// The two images of an EPT render and its ray count.
struct EptImages {
    Film low, high;
    std::uint64_t grain_rays = 0;  ///< Algorithm 1 traversals (camera + shadow rays)
    [[nodiscard]] Image combined() const {
        Image a = low.image();
        const Image b = high.image();
        for (std::size_t i = 0; i < a.rgb.size(); ++i) a.rgb[i] += b.rgb[i];
        return a;
    }
};

/// Render with EPT: rows over OpenMP threads, one counter-based generator per pixel sample
/// (Pcg32::from_key(seed, pixel, sample)): bit-identical images for any thread count.
/// `progress(1)` is called after each row (thread-safe sink required).
template <LitScene Scene, BoundaryShape Shape, class Camera, class Progress = NoProgress>
[[nodiscard]] EptImages render_ept(const Scene& scene, const GranularAggregate<Shape>& agg, const Camera& camera, int spp,
                                   std::uint64_t seed, int threads = 0, const EptOptions& opt = {},
                                   Progress&& progress = {}) {
    check_argument(spp >= 1, "render_ept", "spp", spp, ">= 1");
    check_argument(threads >= 0, "render_ept", "threads", threads, ">= 0");
    check_argument(opt.low_order_max >= 0, "render_ept", "low_order_max", opt.low_order_max, ">= 0");
    using F = typename Camera::Float;
    const int w = camera.width(), h = camera.height();
    EptImages img{Film(w, h), Film(w, h), 0};
    std::vector<std::uint64_t> row_rays(std::size_t(h), 0);
#if defined(_OPENMP)
    const int nt = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
#endif
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const std::uint64_t pixel = std::uint64_t(y) * std::uint64_t(w) + std::uint64_t(x);
            for (int s = 0; s < spp; ++s) {
                Rng rng = Rng::from_key(seed, pixel, std::uint64_t(s));
                const Vec2<F> u = rng.uniform2<F>();
                const auto ray = camera.generate_ray(F(x) + u.x, F(y) + u.y);
                auto L = ept_radiance(scene, agg, ray, rng, opt);
                if (!L.low.is_finite()) L.low = decltype(L.low)(0);
                if (!L.high.is_finite()) L.high = decltype(L.high)(0);
                img.low.add_sample(x, y, L.low);
                img.high.add_sample(x, y, L.high);
                row_rays[std::size_t(y)] += L.grain_rays;
            }
        }
        progress(1);
    }
    for (auto r : row_rays) img.grain_rays += r;
    return img;
}

}  // namespace grainlight
