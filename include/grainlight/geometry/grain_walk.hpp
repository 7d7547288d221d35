/// @file grainlight/geometry/grain_walk.hpp
/// The one walk inside a grain: what happens to a path that hits a grain surface until it leaves
/// that surface outward, is absorbed, or runs out of its event budget. Used by the virtual
/// scatterometer (precompute/scatterometer.hpp, Meng15 Sec. 4.1), by explicit path tracing of
/// aggregates (integrators/ept.hpp, Sec. 3.2) and by any third-party integrator that wants grain
/// transport without including an integrator.
///
/// Physics per material (geometry/grains.hpp):
///  - smooth dielectric: Fresnel reflection with probability F, refraction otherwise
///    (optics/fresnel.hpp `sample_dielectric`, one uniform); radiance is scaled by 1/eta_rel^2 on
///    refraction in TransportMode::radiance;
///  - absorbing dielectric: the same interface around a homogeneous medium with sigma_a, sigma_s
///    (per bounding-sphere radius, divided by the length scale R here) and an HG phase function;
///  - diffuse: opaque Lambertian surface.
///
/// Two estimators of the same transport:
///  - `GrainEstimator::weighted` (EPT): per-channel weights on a `Spectrum` throughput:
///    Lambertian albedo and Beer-Lambert absorption as weights, interior scattering by weighted
///    delta tracking against the majorant max_c sigma_s[c] (real-event probability
///    P = mean_c sigma_s[c] / max_c sigma_s[c]), NEE hook at diffuse events;
///  - `GrainEstimator::analog` (scatterometer): one channel c, every absorption a random event
///    (albedo test at diffuse events, sigma_a / sigma_t at interior collisions sampled with
///    sigma_t[c]); the throughput is never changed, so per-ray tallies are integer counts.
///
/// Geometry comes from a callable `intersect(p, d, t, n) -> bool` (closest surface hit of the
/// grain along p + t d, outward unit normal n) in the frame where the grain has bounding radius
/// `R`; `eps` is the offset used to leave a surface. Kernel rules: no allocation, no exceptions,
/// no virtual calls; randomness only from `rng`.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "grainlight/core/config.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/phase/concepts.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"

namespace grainlight {

/// Which estimator a grain walk uses (see the file comment).
enum class GrainEstimator : std::uint8_t { weighted, analog };

/// Options of a grain walk.
struct GrainWalkOptions {
    /// Weighted (one path, per-channel throughput) or analog (one channel, Russian-roulette events).
    GrainEstimator estimator = GrainEstimator::weighted;
    std::size_t channel = 0;                        ///< analog: the material channel traced
    TransportMode mode = TransportMode::radiance;   ///< radiance scaling at refractions (weighted)
    int max_events = 4096;                          ///< surface + interior events at most
};

/// Outcome of a grain walk (a grain "sojourn").
struct GrainSojourn {
    /// @var kind
    /// How the walk ended (absorbed until the walk sets it).
    ///
    /// @enum Kind
    /// How a grain walk ended.
    enum Kind : std::uint8_t {
        exited,     ///< left the grain's surface outward at p along d
        absorbed,   ///< absorbed (analog), or a diffuse grain hit from inside
        terminated  ///< event budget exhausted, or leaked through a non-watertight mesh
    } kind = absorbed;
    Vec3d p{0.0};          ///< where the path leaves the grain surface (offset outward)
    Vec3d d{0.0};          ///< direction it leaves in
    Vec3d n{0.0};          ///< outward normal at the last surface event
    bool specular = true;  ///< last event was a delta event (false: Lambertian)
    double pdf = 0;        ///< solid-angle pdf of the last direction (Lambertian), else 0
    int events = 0;        ///< surface + interior scattering events
    /// True if the path left the grain (p, d, n are then valid).
    [[nodiscard]] bool is_exited() const noexcept { return kind == exited; }
};

/// A path travelling along unit `d` hits the grain surface at `p` (outward normal `n`). Walk it
/// until it leaves the surface outward (kind = exited) or ends. `throughput` is updated per
/// channel (weighted) or left unchanged (analog). `on_diffuse(p, n_facing, throughput)` is called
/// at each Lambertian event before the bounce (weighted: NEE); `on_segment(a, b)` for every
/// straight piece travelled inside the grain. Requires material.compatible_with(S::size) for the
/// weighted estimator and channel < material.channels() or a grey material for the analog one.
template <SpectrumType S, class Intersect, class OnDiffuse, class OnSegment>
[[nodiscard]] GrainSojourn grain_walk(const GrainMaterial& m, double R, double eps, Intersect&& intersect, Vec3d p,
                                      Vec3d d, Vec3d n, S& throughput, Rng& rng, const GrainWalkOptions& opt,
                                      OnDiffuse&& on_diffuse, OnSegment&& on_segment) noexcept {
    using F = typename S::value_type;
    const bool analog = opt.estimator == GrainEstimator::analog;
    GRAINLIGHT_DCHECK(analog || m.compatible_with(S::size));
    GrainSojourn out;
    // Interior medium (absorbing dielectric), in the walk's length unit: weighted uses one
    // coefficient per spectrum channel and the majorant of sigma_s; analog uses channel c.
    std::array<double, S::size> sig_a{}, sig_s{};
    double s_max = 0, s_mean = 0;
    const bool medium = m.kind == GrainMaterialKind::absorbing_dielectric;
    const double a_sigma_s = m.interior_sigma_s[opt.channel] / R;
    const double a_sigma_t = m.interior_sigma_a[opt.channel] / R + a_sigma_s;
    if (medium && !analog)
        for (std::size_t c = 0; c < S::size; ++c) {
            sig_a[c] = m.interior_sigma_a[c] / R;
            sig_s[c] = m.interior_sigma_s[c] / R;
            s_max = std::max(s_max, sig_s[c]);
            s_mean += sig_s[c] / double(S::size);
        }
    // Collision rate of the interior free flights (0: no interior events).
    const double rate = !medium ? 0.0 : (analog ? a_sigma_t : s_max);
    bool at_surface = true;
    for (; out.events < opt.max_events;) {
        if (at_surface) {
            ++out.events;
            const bool from_outside = glm::dot(d, n) < 0;
            if (m.kind == GrainMaterialKind::diffuse) {
                if (!from_outside) return out;  // cannot happen for an opaque grain: absorbed
                if (analog) {
                    if (rng.uniform<double>() >= m.albedo[opt.channel]) return out;
                } else {
                    on_diffuse(p, n, throughput);
                }
                const Vec3d local = sample_cosine_hemisphere(rng.uniform2<double>());
                const Vec3d w = glm::normalize(Frame<double>(n).to_world(local));
                if (!analog)
                    for (std::size_t c = 0; c < S::size; ++c) throughput[c] *= F(m.albedo[c]);
                out.kind = GrainSojourn::exited;
                out.p = p + eps * n;
                out.d = w;
                out.n = n;
                out.specular = false;
                out.pdf = cosine_hemisphere_pdf(local.z);
                return out;
            }
            const DielectricSample<double> ds = sample_dielectric(d, n, m.ior, rng.uniform<double>());
            if (!analog && ds.refracted && opt.mode == TransportMode::radiance) throughput /= F(ds.eta_rel * ds.eta_rel);
            const bool inside = ds.refracted ? from_outside : !from_outside;
            d = ds.w;
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
        double t = 0;
        Vec3d n_next(0.0);
        if (!intersect(p, d, t, n_next)) {  // leaked through the mesh (not for watertight grains)
            out.kind = GrainSojourn::terminated;
            return out;
        }
        at_surface = true;
        if (rate > 0) {
            const double ts = sample_exponential(rng.uniform<double>(), rate);
            if (ts < t) {
                t = ts;
                at_surface = false;
            }
        }
        if (medium && !analog)
            for (std::size_t c = 0; c < S::size; ++c) throughput[c] *= F(std::exp(-sig_a[c] * t));
        const Vec3d q = p + t * d;
        on_segment(p, q);
        p = q;
        if (at_surface) {
            n = n_next;
            continue;
        }
        if (analog) {
            // Collision with sigma_t[c]: scatter with probability sigma_s / sigma_t, else absorbed.
            if (rng.uniform<double>() * a_sigma_t >= a_sigma_s) return out;
            ++out.events;
        } else {
            // Weighted delta tracking against the majorant s_max: real scatter with prob s_mean/s_max.
            const double P = s_mean / s_max;
            if (rng.uniform<double>() < P) {
                ++out.events;
                for (std::size_t c = 0; c < S::size; ++c) throughput[c] *= F(sig_s[c] / (P * s_max));
            } else {
                if (P < 1)
                    for (std::size_t c = 0; c < S::size; ++c) throughput[c] *= F((1.0 - sig_s[c] / s_max) / (1.0 - P));
                if (throughput.is_black()) return out;
                continue;
            }
        }
        const double mu = sample_henyey_greenstein_cos(rng.uniform<double>(), m.interior_g);
        d = glm::normalize(direction_from_cosine(d, mu, 2.0 * pi_v<double> * rng.uniform<double>()));
        if (throughput.is_black()) return out;
    }
    out.kind = GrainSojourn::terminated;
    return out;
}

}  // namespace grainlight
