/// @file grainlight/integrators/point_based.hpp
/// Point-based rendering of a homogeneous medium behind a smooth refractive boundary (Wang &
/// Holzschuch 2018, TVCG 24(10), Sec. 3.4-3.5, 4.3, 5.1).
///
/// Pipeline
///  1. Light surface samples (Sec. 3.4.1): points with area on the boundary (`SurfaceSample`;
///     `sphere_surface_samples` gives a Fibonacci lattice, a deterministic blue-noise-like set).
///  2. Light volume samples (Sec. 3.4.3): each surface sample is connected to the light
///     (`light_samples` points on an area light, stratified by `rng`), the transmitted power
///     Phi = E S_s (1 - F) enters along the refracted direction d and is followed inside,
///     including `light_bounces` internal Fresnel reflections (deterministic split). Every
///     `volume_step` Delta (jittered) a volume sample stores x_v, d_v, its weight w_v = Phi(u) Delta
///     (power x length; Phi(u) includes exp(-sigma_t u)) and its volume of influence: an oriented
///     box, Delta long along d, with a square cross-section of area S_s |cos theta_t| (the
///     refracted ray tube at the entry). The samples go into an Octree (traversal/octree.hpp).
///  3. Camera rays (Sec. 3.5.1, 5.1): a camera ray hitting the boundary is refracted (weight
///     (1 - F) / eta^2: radiance mode) and followed inside with `camera_bounces` internal Fresnel
///     reflections; on every inside segment the components below are gathered.
///
/// Components along an inside segment (origin o, direction omega, length d_max, prefix weight):
///  - single (Eq. 5): sum over volume samples whose box the segment crosses of
///        sigma_s p(d_v, -omega) (w_v / V_v) / k_v  int_{d_near}^{d_far} exp(-sigma_t t) dt,
///    i.e. alpha p I_v / k_v (e^{-sigma_t d_near} - e^{-sigma_t d_far}) with I_v = w_v sigma_t / V_v
///    ... written per unit length: a box-kernel density estimate, consistent as the samples get
///    dense. k_v = 1 by default; `use_density_factor` applies Eq. 4.
///  - camera samples (Eq. 10): k_max depths d_k at the quantiles (k + xi) / k_max of the pdf
///    proportional to exp(-sigma_t t) on [0, d_max] (sigma_t = channel average; xi one uniform
///    per segment), each weighted by exp(-sigma_t,c d_k) / (k_max pdf(d_k)): a stratified,
///    unbiased quadrature of int_0^{d_max} exp(-sigma_t t) f(t) dt. (Eq. 9 writes the factor
///    exp(-sigma_t d_k) on samples that Eq. 10 already distributes like exp(-sigma_t t); we make
///    the weight explicit so the transmittance is counted once.)
///  - double (Eq. 6) at P_k, over the Alg. 1 tree cut (or the two-step cut of Sec. 4.3):
///        sigma_s^2 sum_i w_i exp(-sigma_t r_i) / r_i^2 p(d_i, r^_i) p(r^_i, -omega),
///    with the weak 1/r^2 singularity handled by averaging 1/r^2 over a ball of radius r_min
///    around the sample (instead of a plain clamp). For aggregated nodes of a WidenableLobePhase
///    (HG) the lobes are widened by the node's direction spread and the cone it subtends
///    (`widen_lobes`).
///  - multiple (Eq. 7) at P_k, same cut: sigma_s w_i sigma_t^3 L_o(rho sigma_t, z sigma_t, -omega)
///    from an MsTable (integrators/ms_table.hpp; built by precompute/ms_table.hpp) per channel.
///  - bounced (Sec. 3.5.5, Eq. 8) at P_k: `bounce_samples` surface samples store the light that
///    reaches them from inside times the inside Fresnel reflectance as an exitance M_j;
///    sigma_s sum_j (M_j / pi) f(cos_j) Omega_j exp(-sigma_t q_j) p(q^_j, -omega) over their own
///    octree and Alg. 1 cut (Omega_j: the solid angle of the sample, bounded by that of a disk of
///    its area; f = 1 for the paper's diffuse storage, the Fresnel lobe F_in / F_dr for the
///    default specular one, BounceReflection), plus Eqs. 6 and 7 from secondary volume samples
///    along rays from the surface samples (cosine-distributed, or the gather rays' mirror images)
///    (the events after the first one that follows the reflection); `bounce_generations` = 2 adds
///    the light reflected twice (see build_bounce_samples).
///  - full solution (Eq. 9): L = single + sum_k weight_k (double(P_k) + mult(P_k) + bounced(P_k)).
///
/// Direction convention (phase/concepts.hpp): phase arguments are propagation directions; d_v is
/// the direction the light travels, -omega the direction toward the camera.
///
/// Light that reaches the boundary after interactions with the environment (Sec. 3.4.2) enters
/// as `EnteringLight` records (one light ray each; integrators/point_based_environment.hpp
/// gathers them with photons).
///
/// Not included (see docs/wang18.md): visibility between samples, reflections beyond the second
/// between two events. The boundary must be convex (a single refraction in, as in the paper's Sec. 3.3). The Fresnel-reflected light on
/// the outside of the boundary and unscattered light are not part of the result.
///
/// The renderer is deterministic for a seed: light samples come from `rng` at construction,
/// camera rays draw from the Rng passed per ray (integrators/render.hpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/closed_mesh.hpp"
#include "grainlight/geometry/surface_sampling.hpp"
#include "grainlight/integrators/ms_table.hpp"
#include "grainlight/integrators/ms_table_quadtree.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/diffusion/boundary.hpp"
#include "grainlight/diffusion/grid.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/phase/concepts.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/lights.hpp"
#include "grainlight/scene/shapes.hpp"
#include "grainlight/traversal/octree.hpp"

namespace grainlight {

/// Widened lobe of a Henyey-Greenstein phase: the lobe averaged over incoming directions spread
/// with mean cosine c is approximated by HG with g c (exact first moment: the mean cosine of a
/// lobe convolved with a spread of mean cosine c is g c). Value per unit solid angle at the
/// scattering cosine `cos_theta`. The customization point of `WidenableLobePhase` (found by ADL):
/// a phase type of another namespace opts in by providing its own `widened_phase_value`.
template <std::floating_point F, class S>
[[nodiscard]] inline F widened_phase_value(const HenyeyGreenstein<F, S>& p, F cos_theta, F c) noexcept {
    return henyey_greenstein_cos_pdf(cos_theta, F(p.g()) * std::clamp(c, F(0), F(1))) * inv_two_pi_v<F>;
}

/// A phase function that can report its lobe blurred by a spread of incoming directions of mean
/// cosine c in [0, 1] (c = 1: the lobe itself), as `widened_phase_value(phase, cos_theta, c)`.
/// The point-based renderer uses it for aggregated tree-cut nodes; other phase functions are
/// evaluated at the node's mean direction.
template <class P>
concept WidenableLobePhase = PhaseFunction<P> && requires(const P& p, typename P::Float x) {
    { widened_phase_value(p, x, x) } -> std::convertible_to<typename P::Float>;
};

namespace detail {
/// Deprecated (one release): the old sniffing trait, now the capability WidenableLobePhase.
template <class P>
using is_henyey_greenstein = std::bool_constant<WidenableLobePhase<P>>;
}  // namespace detail

/// Nearest boundary point and outward normal of a sphere seen from an inside point p: the local
/// tangent plane used by the boundary image of the multiple-scattering term. The customization
/// point of `TangentPlaneBoundary` (found by ADL; a convex mesh boundary provides its own).
template <std::floating_point F>
inline void boundary_tangent_plane(const SphereShape<F>& s, const Vec3<F>& p, Vec3<F>& q, Vec3<F>& n) noexcept {
    const Vec3<F> r = p - s.center;
    const F l = glm::length(r);
    n = l > F(0) ? r / l : Vec3<F>(F(0), F(0), F(1));
    q = s.center + s.radius * n;
}

/// A boundary that can report the tangent plane nearest to an inside point.
template <class B, class F>
concept TangentPlaneBoundary = requires(const B& b, const Vec3<F>& p, Vec3<F>& q, Vec3<F>& n) {
    boundary_tangent_plane(b, p, q, n);
};

/// A light surface sample on the boundary: position, unit outward normal, area it represents.
template <std::floating_point F>
struct SurfaceSample {
    /// Position on the boundary [scene units].
    Vec3<F> p{F(0)};
    /// Unit outward normal of the boundary at p.
    Vec3<F> n{F(0), F(0), F(1)};
    /// Boundary area the sample stands for [scene units^2] (> 0; a set of samples should cover the
    /// boundary: areas summing to its area, as sphere_surface_samples gives).
    F area = F(0);
};

/// Light that enters the medium through a patch of its boundary, already refracted (Sec. 3.4.2:
/// light that reached the boundary after interactions with the environment, e.g. reflections on
/// a glossy or diffuse floor or refractions through an enclosing glass, gathered by photons;
/// `environment_entering_light` in integrators/point_based_environment.hpp builds these). The
/// renderer follows one light ray per patch, as for a light surface sample connected to the light.
template <std::floating_point F, class S>
struct EnteringLight {
    /// Point on the boundary where the light enters [scene units].
    Vec3<F> p{F(0)};
    /// Unit outward normal of the boundary at p.
    Vec3<F> n{F(0), F(0), F(1)};
    /// Unit propagation direction inside the medium (dot(d, n) < 0).
    Vec3<F> d{F(0), F(0), -F(1)};
    /// Power transmitted into the medium through the patch (after the boundary's Fresnel) [W].
    S power{F(0)};
    /// Area of the patch [scene units^2] (> 0): the light ray's tube has the cross-section
    /// area |d . n|.
    F area = F(0);
};

/// `n` surface samples on a sphere: a Fibonacci lattice (even, low-discrepancy cover), each with
/// area 4 pi r^2 / n. Throws invalid_argument if n < 1.
template <std::floating_point F>
[[nodiscard]] inline std::vector<SurfaceSample<F>> sphere_surface_samples(const SphereShape<F>& s, int n) {
    check_argument(n >= 1, "sphere_surface_samples", "n", n, ">= 1");
    std::vector<SurfaceSample<F>> out(static_cast<std::size_t>(n));
    const double golden = pi_v<double> * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < n; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / n;
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        const double ph = golden * i;
        const Vec3<F> nn(F(r * std::cos(ph)), F(r * std::sin(ph)), F(z));
        out[std::size_t(i)] = {s.center + s.radius * nn, nn, s.area() / F(n)};
    }
    return out;
}

/// About `n` blue-noise (Poisson-disk, dart throwing) surface samples on a closed mesh boundary
/// (Sec. 3.4.1), each with the area A / count and its triangle's outward normal; deterministic for
/// `seed`. `radius_out` receives the Poisson-disk radius. Throws invalid_argument if n < 1 or if
/// no sample could be placed.
template <std::floating_point F>
[[nodiscard]] inline std::vector<SurfaceSample<F>> mesh_surface_samples(const ClosedMeshShape<F>& m, int n,
                                                                       std::uint64_t seed, double* radius_out = nullptr) {
    check_argument(n >= 1, "mesh_surface_samples", "n", n, ">= 1");
    const auto pts = poisson_disk_mesh_points(m.mesh(), n, seed, radius_out);
    check_argument(!pts.empty(), "mesh_surface_samples", "samples placed", pts.size(), ">= 1");
    std::vector<SurfaceSample<F>> out(pts.size());
    const F a = F(m.area() / double(pts.size()));
    for (std::size_t i = 0; i < pts.size(); ++i) out[i] = {pts[i].p, pts[i].n, a};
    return out;
}

/// How a bounce surface sample stores the light it reflects back into the medium (Sec. 3.5.5).
enum class BounceReflection : std::uint8_t {
    /// The paper's: a diffuse exitance M_j. Eq. 8 emits a cosine lobe (radiance M_j / pi) and the
    /// secondary samples leave along cosine-distributed rays, each carrying A_j M_j / bounce_rays.
    diffuse,
    /// Specular Fresnel reflection (our refinement, same cost). The secondary samples leave along
    /// the mirror images of the gather rays, each carrying the light that ray brought in times its
    /// Fresnel reflectance (so together A_j M_j, as in `diffuse`); Eq. 8 emits the lobe of an
    /// isotropic inside radiance reflected by Fresnel, M_j F_in(cos) / (pi F_dr) with F_dr the
    /// hemispherical mean of F_in. Internal reflection is strongest at grazing angles (total beyond
    /// the critical angle), so the reflected light enters shallower than a cosine lobe: on the
    /// 20-mfp BmpS. sphere the diffuse storage left the bounced term 13 % low (docs/wang18.md).
    specular,
};

/// How the camera samples of Eq. 10 are placed along an inside segment when the extinction
/// differs between channels (Eq. 10 is written for one sigma_t; every choice below is an unbiased
/// quadrature of int_0^{d_max} exp(-sigma_t,c t) f(t) dt in every channel c, and they agree when
/// the channels' sigma_t are equal).
enum class DepthSampling : std::uint8_t {
    /// Quantiles of exp(-sigma t) with sigma the channel average (Eq. 10 with the mean
    /// extinction). A channel with sigma_t,c < sigma / 2 has unbounded weights (infinite variance
    /// without the segment's end); between sigma / 2 and sigma its deep samples carry large ones.
    average_extinction,
    /// Quantiles of exp(-sigma_min t): every channel's weight exp(-(sigma_t,c - sigma_min) t) is
    /// at most one, so no channel's tail is undersampled.
    min_extinction,
    /// Quantiles of the mixture (1/N) sum_c exp(-sigma_t,c t) (each truncated to the segment):
    /// the balance heuristic over the channels (one-sample MIS, Veach 1997, Sec. 9.2.4). Every
    /// weight is at most N / (k_max p_c) of that channel's own density, and every channel gets the
    /// samples its own sigma_t would place.
    channel_mixture,
};

/// Depth d_k and per-channel weights w_c = exp(-sigma_t,c d_k) / (k_max pdf(d_k)) of the camera
/// samples of Eq. 10 on a segment of length d_max (see DepthSampling). The weights are computed
/// relative to exp(-sigma_min d) so that nothing underflows on optically long segments.
template <class S>
class CameraDepthSampler {
public:
    using F = typename S::value_type;         ///< scalar type
    static constexpr std::size_t N = S::size;  ///< number of channels

    /// Sampler for a segment of length `d_max` in a medium of extinction `sigma_t` (per channel).
    CameraDepthSampler(const S& sigma_t, F d_max, DepthSampling mode) noexcept
        : sig_(sigma_t), dmax_(d_max), mode_(mode) {
        smin_ = sigma_t.min_value();
        // A channel without extinction (sigma_t = 0) leaves the bounded modes nothing to follow:
        // they sample the segment uniformly (weights exp(-sigma_t,c d) d_max / k_max <= d_max / k_max).
        uniform_ = mode != DepthSampling::average_extinction && !(smin_ > F(0));
        sbar_ = mode == DepthSampling::average_extinction ? sigma_t.average() : smin_;
        if (mode == DepthSampling::channel_mixture && !uniform_)  // only the mixture reads them
            for (std::size_t c = 0; c < N; ++c) norm_[c] = -std::expm1(-sig_[c] * d_max);
        norm_bar_ = -std::expm1(-sbar_ * d_max);
    }
    /// False when there is no sample to take: an empty segment, or (Eq. 10 with the mean
    /// sigma_t) no extinction in any channel.
    [[nodiscard]] bool valid() const noexcept { return uniform_ ? dmax_ > F(0) : norm_bar_ > F(0); }

    /// The depth at quantile q in [0, 1) of the sampling density; `w` gets the weights of one of
    /// `k_max` stratified samples.
    F sample(F q, int k_max, S& w) const noexcept {
        F d;
        if (uniform_) {
            d = std::min(dmax_, q * dmax_);
            for (std::size_t c = 0; c < N; ++c) w[c] = std::exp(-sig_[c] * d) * dmax_ / F(k_max);
            return d;
        }
        if (mode_ != DepthSampling::channel_mixture) {
            d = std::min(dmax_, -std::log1p(-q * norm_bar_) / sbar_);
            // exp(-sigma_t,c d) / (k_max pdf(d)) with pdf = sbar exp(-sbar d) / norm, written
            // without the two exponentials.
            for (std::size_t c = 0; c < N; ++c)
                w[c] = std::exp(-(sig_[c] - sbar_) * d) * norm_bar_ / (sbar_ * F(k_max));
            return d;
        }
        d = invert_mixture(q);
        // pdf(d) = (1/N) sum_j sigma_j exp(-sigma_j d) / norm_j; both sides scaled by exp(sigma_min d).
        F p = 0;
        for (std::size_t j = 0; j < N; ++j) p += sig_[j] * std::exp(-(sig_[j] - smin_) * d) / norm_[j];
        p /= F(N);
        for (std::size_t c = 0; c < N; ++c) w[c] = std::exp(-(sig_[c] - smin_) * d) / (F(k_max) * p);
        return d;
    }

private:
    // CDF of the mixture: (1/N) sum_c (1 - exp(-sigma_c t)) / norm_c. It lies between the CDFs of
    // the fastest and the slowest channel, so their quantiles bracket the root; the CDF is
    // increasing and concave, so Newton's method from the left end stays left of the root and
    // converges monotonically (the bracket guards against rounding).
    [[nodiscard]] F invert_mixture(F q) const noexcept {
        std::size_t cmin = 0, cmax = 0;
        for (std::size_t c = 1; c < N; ++c) {
            if (sig_[c] < sig_[cmin]) cmin = c;
            if (sig_[c] > sig_[cmax]) cmax = c;
        }
        const auto quantile = [&](std::size_t c) {
            return std::min(dmax_, -std::log1p(-q * norm_[c]) / sig_[c]);
        };
        F lo = quantile(cmax), hi = quantile(cmin);
        F t = lo;
        for (int it = 0; it < 32 && hi - lo > F(0); ++it) {
            F cdf = 0, pdf = 0;
            for (std::size_t c = 0; c < N; ++c) {
                const F e = std::exp(-sig_[c] * t);
                cdf += (F(1) - e) / norm_[c];
                pdf += sig_[c] * e / norm_[c];
            }
            const F r = cdf / F(N) - q;
            if (r < F(0)) lo = t; else hi = t;
            F next = pdf > F(0) ? t - r * F(N) / pdf : F(0.5) * (lo + hi);
            if (!(next >= lo && next <= hi)) next = F(0.5) * (lo + hi);
            if (std::abs(next - t) <= F(8) * std::numeric_limits<F>::epsilon() * std::max(t, F(1e-30))) {
                t = next;
                break;
            }
            t = next;
        }
        return std::clamp(t, F(0), dmax_);
    }

    S sig_;
    F dmax_;
    DepthSampling mode_;
    bool uniform_ = false;
    F smin_ = F(0), sbar_ = F(0), norm_bar_ = F(0);
    std::array<F, N> norm_{};  ///< 1 - exp(-sigma_t,c d_max) per channel (channel_mixture only)
};

/// Where the multiple-scattering term comes from beyond the table and near the boundary.
enum class MsFarField {
    /// The paper's Eq. 7 as is: the infinite-medium table, zero beyond its grid.
    none,
    /// Our addition (not in the paper): the table within its grid, plus the light its walks
    /// dropped beyond their escape radius and would have brought back
    /// (`ms_table_escape_radius`); beyond the grid the infinite-medium diffusion Green's function
    /// of the same sources; and everywhere the bounded-medium correction u = phi_bounded -
    /// phi_infinite of diffusion theory, solved once on a grid over the boundary
    /// (diffusion/grid.hpp, Robin condition with the boundary's A). The light that
    /// the infinite-medium table counts although it would have left the medium, and the light
    /// that diffuses farther than the table reaches, are then both accounted for (docs/wang18.md).
    /// The boundary's reflection of the multiply scattered light is in the Robin condition, so
    /// the bounced term (Eq. 8) then reflects only the single- and double-scattered light that
    /// reaches the boundary.
    diffusion
};

/// Options of the point-based renderer (defaults follow the paper where it gives values).
template <std::floating_point F>
struct PointBasedOptions {
    int light_samples = 1;          ///< points on the light per surface sample (>= 1; 1 for delta lights)
    F volume_step = F(0);           ///< Delta between volume samples (scene units); <= 0: 0.1 / sigma_t
    F max_optical_depth = F(10);    ///< stop following a light ray after this sigma_t u
    int light_bounces = 2;          ///< internal reflections followed on light rays
    int camera_bounces = 2;         ///< internal reflections followed on camera rays
    int k_max = 16;                 ///< camera samples per inside segment (Eq. 10)
    /// Where the camera samples go when the channels' sigma_t differ (see DepthSampling). The
    /// default is Eq. 10 with the mean sigma_t; `min_extinction` bounds every weight and cuts the
    /// point-based noise 2.2x on BmpS. (red sigma_t 0.67 of the mean; docs/wang18.md), is neutral
    /// on Wax and Milk (channels within 10 %), and doubles the small double-scattering noise of
    /// Oil (sigma_t ratio 4.2).
    DepthSampling depth_sampling = DepthSampling::average_extinction;
    F r_min = F(0);                 ///< 1/r^2 averaging radius; <= 0: the volume step
    CutCriterion<F> cut{};          ///< Alg. 1 thresholds
    std::uint32_t two_step_depth = 0;  ///< > 0: two-step traversal stopping at this depth (Sec. 4.3)
    bool use_density_factor = false;   ///< apply Eq. 4's k_v to single scattering
    /// Give the part of a volume sample's box that lies outside the boundary to its inside part
    /// (needs a TangentPlaneBoundary): without it the box kernel of Eq. 5 loses the light of
    /// boxes that stick out of the surface (optically thick media: -24 % single scattering at
    /// 20 mean free paths with boxes of ~0.6 mfp).
    bool clip_boxes = true;
    /// Widen the phase lobes of aggregated cut nodes (HG phase only; see `light_phase`): the
    /// node's direction coherence and the cone it subtends from P. Cuts the Alg. 1 aggregation
    /// bias of peaked lobes (g = 0.7, eps1 = 0.5: from -13 % to -3 % on double scattering).
    bool widen_lobes = true;
    /// Multiple-scattering table lookup bilinear between direction-bin centres (false: nearest
    /// bin, as a plain table read).
    bool ms_interpolate = true;
    /// Boundary image of the multiple-scattering term (our addition, not in the paper): the
    /// table is an infinite-medium response, so it counts light that crossed the boundary
    /// between events. Subtract the response of the source mirrored across the local tangent
    /// plane shifted outward by `ms_image_offset` transport mean free paths (method of images;
    /// needs a TangentPlaneBoundary). Off by default (the paper's Eq. 7 as is): it removes the
    /// over-count at 5 mean free paths but over-corrects by ~20 % at 20-50 (docs/wang18.md).
    /// Ignored with `ms_far_field = MsFarField::diffusion`, which corrects for the boundary itself.
    bool ms_boundary_image = false;
    /// Offset of the mirrored source beyond the tangent plane, in transport mean free paths
    /// 1 / (sigma_t (1 - albedo g)) (used only with ms_boundary_image).
    F ms_image_offset = F(0);
    /// Far field and boundary of the multiple-scattering term (see MsFarField; needs a table).
    MsFarField ms_far_field = MsFarField::none;
    /// Cell side of the far field's diffusion grid, in mean free paths of the mean sigma_t (> 0).
    F diffusion_cell = F(1);
    /// Opening ratio of the tree walk that sums the sources' infinite-medium field at the grid's
    /// boundary faces: a node is used whole when its bounds' diagonal is below this times its
    /// distance (in (0, 2]).
    F diffusion_opening = F(0.5);
    /// Scale of the Alg. 1 thresholds (eps1, eps2) for the bounced term's cuts on the camera side
    /// (Eq. 8 over the bounce samples, Eqs. 6 and 7 over the secondary samples; our addition,
    /// >= 1). The bounced light is a small, smooth share of the total, so a coarser cut there
    /// costs little accuracy and half of the render time on BmpS. (docs/wang18.md).
    F bounce_cut_scale = F(1);
    /// Solid-angle threshold of a separate, coarser Alg. 1 cut for the table term (Eq. 7) only
    /// (our addition; sr). 0: the table term rides on the double-scattering cut, as in the
    /// paper. The table's lobes vary slowly in space and direction, while Eq. 6's cut is refined
    /// for peaked phase functions, so a coarser cut for Eq. 7 saves most of its table lookups
    /// (memory-bound on a large table).
    F ms_cut_eps1 = F(0);
    /// The escape radius the table was built with (MsTableOptions::escape_radius, mean free
    /// paths; > 0): its walks drop the particles beyond it, so the table lacks the light that
    /// would have come back. With the far field, that light is added back on the table's grid as
    /// the diffusion field of the dropped particles (a perfectly absorbing sphere at this radius).
    F ms_table_escape_radius = F(24);
    /// @var single
    /// Compute single scattering (Eq. 5).
    /// @var double_
    /// Compute double scattering (Eq. 6).
    bool single = true, double_ = true, multiple = true;  ///< components to compute
    /// Eq. 8 bounced multiple scattering through surface samples (needs `bounce_samples` > 0).
    bool bounced = true;
    /// Surface samples that carry the inside illumination (a stride subset of the light surface
    /// samples, areas scaled to cover the boundary); 0: no bounced term.
    int bounce_samples = 1024;
    int bounce_rays = 4;            ///< inward rays per bounce sample to gather its incoming light
    int bounce_k_max = 4;           ///< camera-sample count on those rays (Eq. 10)
    bool bounce_secondary = true;   ///< secondary volume samples: events 2, 3, ... after a reflection
    /// Eq. 8 next to a bounce sample: spread its light over its disk (ring quadrature) instead
    /// of evaluating the kernel at its centre only.
    bool bounce_disk_quadrature = true;
    /// Generations of Eq. 8 bounced light: 1 = light reflected once at the boundary; 2 = also twice
    /// (with bounce_series, the later generations as a geometric series).
    int bounce_generations = 2;
    bool bounce_series = false;     ///< generation 2: sum the later generations as a geometric series
    /// How the bounce samples store the reflected light: `specular` (default) or the paper's
    /// `diffuse` (see BounceReflection).
    BounceReflection bounce_reflection = BounceReflection::specular;
    /// Connect every light surface sample to the light (Sec. 3.4.1). False: the light surface
    /// samples gather nothing from the light and only the EnteringLight records passed to the
    /// constructor light the medium (e.g. photons that include the direct light, for a medium
    /// behind a glass that a straight connection would ignore).
    bool direct_light = true;
    int leaf_items = 8;             ///< octree leaf size (paper: 8)
    /// Tree cuts skip the nodes farther from the receiver than the reach of every kernel (not in
    /// the paper; a saving, not an approximation of Eqs. 6-8 beyond this transmittance): the
    /// multiple-scattering table's grid (exactly zero beyond it) and, for Eq. 6 and Eq. 8, this
    /// optical distance in the least-extinguished channel (e^-30 = 1e-13). <= 0: no culling.
    F cull_optical_distance = F(30);
};

/// Radiance split by component (W sr^-1 m^-2 per channel).
template <class S>
struct PointBasedComponents {
    /// @var single
    /// Single scattering.
    /// @var double_
    /// Double scattering.
    /// @var multiple
    /// Multiple scattering (table term, Eq. 7).
    /// @var bounced
    /// Bounced multiple scattering (Eq. 8).
    S single{0}, double_{0}, multiple{0}, bounced{0};
    /// Sum of the four components.
    [[nodiscard]] S total() const noexcept { return single + double_ + multiple + bounced; }
};

/// The point-based renderer for one medium object (see the file comment).
/// \tparam Phase  phase function (PhaseFunction concept) with Spectrum S
/// \tparam Boundary  a shape with `intersect(Ray, t&, n&)` (outward normals), convex
template <class Phase, class Boundary, std::size_t N = Phase::Spectrum::size>
class PointBasedRenderer {
public:
    /// Floating-point type (the phase function's).
    using F = typename Phase::Float;
    /// Spectrum type (the phase function's).
    using S = typename Phase::Spectrum;
    /// The homogeneous medium the renderer is built for.
    using Medium = ContinuousMedium<Phase, S>;
    /// Octree item: a volume or surface light sample (position, direction, power).
    using Item = OctreeItem<F, S>;

    /// A volume sample's box: centre, frame (e1, e2, d), half extents, 1 / volume.
    struct Box {
        /// @var c
        /// Centre (the volume sample's position) [scene units].
        /// @var e1
        /// First unit axis across the light ray.
        /// @var e2
        /// Second unit axis across the light ray.
        /// @var d
        /// Unit axis along the light ray.
        Vec3<F> c, e1, e2, d;
        /// @var h1
        /// Half extent along e1 (half the side of the surface sample's footprint) [scene units].
        /// @var h2
        /// Half extent along e2 [scene units].
        /// @var hd
        /// Half extent along d (half the volume step) [scene units].
        /// @var inv_volume
        /// 1 / box volume [1/scene units^3] (divided by the inside fraction when clip_boxes is on).
        /// @var source_area
        /// Area of the surface sample the light ray entered through (S_v of Eq. 4) [scene units^2].
        F h1, h2, hd, inv_volume, source_area;
    };

    /// Build the light samples. \param medium sigma_t > 0 in every channel; \param eta
    /// n_inside / n_outside > 0; \param ms optional multiple-scattering table (nullptr: no
    /// multiple term), must have the medium's albedo and outlive the renderer. Throws
    /// invalid_argument on bad input.
    /// \param boundary convex shape of the medium (outward normals; copied);
    /// \param surface light surface samples on the boundary (>= 1);
    /// \param light the light source, sampled at every surface sample;
    /// \param opt renderer options (validated here, copied);
    /// \param rng random numbers for the light points and the volume-sample offsets (same seed, same samples).
    PointBasedRenderer(const Medium& medium, F eta, const Boundary& boundary,
                       const std::vector<SurfaceSample<F>>& surface, const Light<F, S>& light,
                       const PointBasedOptions<F>& opt, Rng& rng, const MsTable<N>* ms = nullptr)
        : PointBasedRenderer(medium, eta, boundary, surface, light, opt, rng, ms, {}) {}

    /// As above with the bounce surface samples of Eq. 8 given separately (`bounce_surface`, e.g.
    /// their own even lattice of `bounce_samples` points, each with its area): the bounced term
    /// then does not depend on the light surface samples. Empty: a stride subset of `surface`
    /// (the constructor above). A stride subset of a Fibonacci lattice is an uneven cover: on the
    /// 20-mfp sphere the bounced term moved between -18 % and +9 % with the light sample count.
    PointBasedRenderer(const Medium& medium, F eta, const Boundary& boundary,
                       const std::vector<SurfaceSample<F>>& surface, const Light<F, S>& light,
                       const PointBasedOptions<F>& opt, Rng& rng, const MsTable<N>* ms,
                       const std::vector<SurfaceSample<F>>& bounce_surface)
        : PointBasedRenderer(medium, eta, boundary, surface, light, opt, rng, ms, bounce_surface, {}) {}

    /// As above, with light that enters the medium after interactions with the environment
    /// (`entering`, Sec. 3.4.2): each record adds the volume samples of one light ray, beside
    /// those of the light surface samples (none of these when `opt.direct_light` is false). The
    /// bounce samples then gather the light of both. Throws invalid_argument if a record has a
    /// non-positive area, a negative or non-finite power or a direction that does not enter.
    PointBasedRenderer(const Medium& medium, F eta, const Boundary& boundary,
                       const std::vector<SurfaceSample<F>>& surface, const Light<F, S>& light,
                       const PointBasedOptions<F>& opt, Rng& rng, const MsTable<N>* ms,
                       const std::vector<SurfaceSample<F>>& bounce_surface,
                       const std::vector<EnteringLight<F, S>>& entering)
        : medium_(medium), eta_(eta), boundary_(boundary), opt_(opt), ms_(ms) {
        check_argument(std::isfinite(eta) && eta > F(0), "PointBasedRenderer", "eta", eta, "(0, inf)");
        for (std::size_t c = 0; c < S::size; ++c)
            check_argument(medium.sigma_t()[c] > F(0), "PointBasedRenderer", "sigma_t", medium.sigma_t()[c], "(0, inf)");
        check_argument(!surface.empty(), "PointBasedRenderer", "surface samples", surface.size(), ">= 1");
        check_argument(opt.light_samples >= 1, "PointBasedRenderer", "light_samples", opt.light_samples, ">= 1");
        check_argument(opt.k_max >= 1 && opt.k_max <= 4096, "PointBasedRenderer", "k_max", opt.k_max, "[1, 4096]");
        check_argument(opt.light_bounces >= 0 && opt.light_bounces <= 64, "PointBasedRenderer", "light_bounces",
                       opt.light_bounces, "[0, 64]");
        check_argument(opt.camera_bounces >= 0 && opt.camera_bounces <= 64, "PointBasedRenderer", "camera_bounces",
                       opt.camera_bounces, "[0, 64]");
        check_argument(std::isfinite(opt.volume_step) && std::isfinite(opt.r_min), "PointBasedRenderer",
                       "volume_step/r_min", opt.volume_step, "finite");
        check_argument(opt.max_optical_depth > F(0), "PointBasedRenderer", "max_optical_depth", opt.max_optical_depth,
                       "(0, inf)");
        check_argument(std::isfinite(opt.ms_cut_eps1) && opt.ms_cut_eps1 >= F(0), "PointBasedRenderer", "ms_cut_eps1",
                       opt.ms_cut_eps1, "[0, inf) sr");
        check_argument(std::isfinite(opt.bounce_cut_scale) && opt.bounce_cut_scale >= F(1), "PointBasedRenderer",
                       "bounce_cut_scale", opt.bounce_cut_scale, "[1, inf)");
        bounce_cut_ = opt.cut;
        bounce_cut_.eps1 *= opt.bounce_cut_scale;
        bounce_cut_.eps2 *= opt.bounce_cut_scale;
        check_argument(opt.cut.eps1 >= F(0) && opt.cut.eps2 >= F(0), "PointBasedRenderer", "cut.eps1/eps2",
                       opt.cut.eps1, "[0, inf)");
        if (ms) {
            check_argument(!ms->empty(), "PointBasedRenderer", "ms table size", ms->size(), "> 0");
            for (std::size_t c = 0; c < N; ++c)
                check_argument(std::abs(ms->albedo(c) - double(medium.albedo()[c])) < 1e-4, "PointBasedRenderer",
                               "ms table albedo", ms->albedo(c), "the medium's albedo");
        }
        sigma_bar_ = medium.sigma_t().average();
        step_ = opt.volume_step > F(0) ? opt.volume_step : F(0.1) / sigma_bar_;
        r_min_ = opt.r_min > F(0) ? opt.r_min : step_;
        {
            const F g = F(medium.phase().mean_cosine().average());
            for (std::size_t c = 0; c < S::size; ++c) {
                const F a = medium.albedo()[c];
                image_offset_[c] = opt.ms_image_offset / (medium.sigma_t()[c] * std::max(F(1e-3), F(1) - a * g));
            }
        }
        check_argument(opt.bounce_samples >= 0, "PointBasedRenderer", "bounce_samples", opt.bounce_samples, ">= 0");
        check_argument(opt.bounce_rays >= 1 && opt.bounce_rays <= 1024, "PointBasedRenderer", "bounce_rays",
                       opt.bounce_rays, "[1, 1024]");
        check_argument(opt.bounce_k_max >= 1 && opt.bounce_k_max <= 4096, "PointBasedRenderer", "bounce_k_max",
                       opt.bounce_k_max, "[1, 4096]");
        bounce_fdr_ = fresnel_diffuse_reflectance(eta_);
        check_argument(std::isfinite(opt.diffusion_cell) && opt.diffusion_cell > F(0), "PointBasedRenderer",
                       "diffusion_cell", opt.diffusion_cell, "(0, inf) mean free paths");
        check_argument(opt.diffusion_opening > F(0) && opt.diffusion_opening <= F(2), "PointBasedRenderer",
                       "diffusion_opening", opt.diffusion_opening, "(0, 2]");
        check_argument(std::isfinite(opt.ms_table_escape_radius) && opt.ms_table_escape_radius > F(0),
                       "PointBasedRenderer", "ms_table_escape_radius", opt.ms_table_escape_radius, "(0, inf) mean free paths");
        check_argument(opt.ms_far_field == MsFarField::none || ms != nullptr, "PointBasedRenderer",
                       "ms table (for ms_far_field = diffusion)", 0, "a table");
        for (const EnteringLight<F, S>& e : entering) {
            check_argument(std::isfinite(e.area) && e.area > F(0), "PointBasedRenderer", "entering light area", e.area,
                           "(0, inf)");
            for (std::size_t c = 0; c < S::size; ++c)
                check_argument(std::isfinite(e.power[c]) && e.power[c] >= F(0), "PointBasedRenderer",
                               "entering light power", e.power[c], "[0, inf)");
            check_argument(glm::dot(e.d, e.n) < F(0), "PointBasedRenderer", "entering light d . n", glm::dot(e.d, e.n),
                           "(-1, 0) (inward)");
        }
        set_reach();
        build_samples(surface, light, entering, rng);
        if (opt.bounced && opt.bounce_samples > 0) {
            if (bounce_surface.empty())
                build_bounce_samples(surface, rng);
            else
                build_bounce_samples(bounce_surface, rng);
        }
        // After the bounce samples: the far field's sources are the volume samples and the
        // secondary samples of the reflected light.
        if (opt.ms_far_field == MsFarField::diffusion) build_far_field(surface);
    }

    /// Octree over the volume light samples (Sec. 4).
    [[nodiscard]] const Octree<F, S>& volume_tree() const noexcept { return tree_; }
    /// Box of every volume sample, indexed by the sample's item id.
    [[nodiscard]] const std::vector<Box>& boxes() const noexcept { return boxes_; }
    /// Number of volume light samples.
    [[nodiscard]] std::size_t volume_sample_count() const noexcept { return tree_.items().size(); }
    /// Distance Delta between volume samples along a light ray [scene units].
    [[nodiscard]] F volume_step() const noexcept { return step_; }
    /// Memory held by the light samples (Table 3's "mem." without the table): the items and
    /// nodes of the volume, bounce-surface and secondary trees, the volume samples' boxes and
    /// density factors, in bytes.
    [[nodiscard]] std::size_t bytes() const noexcept {
        auto tb = [](const Octree<F, S>& t) {
            return t.items().size() * sizeof(Item) + t.nodes().size() * sizeof(typename Octree<F, S>::Node);
        };
        std::size_t far = dgrid_ ? dgrid_->bytes() : 0;
        for (const auto& set : dfield_)
            for (const auto& f : set) far += f.v.size() * sizeof(F);
        return tb(tree_) + tb(surf_tree_) + tb(sec_tree_) + boxes_.size() * sizeof(Box) + k_.size() * sizeof(F) + far;
    }
    /// Switch the boundary image of the multiple term (PointBasedOptions::ms_boundary_image) after
    /// construction, for studies that compare both on the same light samples (the bounce samples
    /// keep the light they gathered at construction).
    void set_ms_boundary_image(bool on) noexcept { opt_.ms_boundary_image = on; }
    /// Read the multiple-scattering table from its quadtree-compressed copy `q` from now on
    /// (Sec. 5.2; the dense table passed to the constructor is no longer read and may be
    /// released; `q` must outlive the renderer; nullptr: back to the dense table, which must then
    /// still exist). The bounce samples keep the light they gathered at construction. Throws
    /// invalid_argument if q's albedo is not the medium's.
    void use_compressed_table(const MsTableQuadtree<N>* q) {
        if (q) {
            for (std::size_t c = 0; c < N; ++c)
                check_argument(std::abs(q->albedo(c) - double(medium_.albedo()[c])) < 1e-4, "PointBasedRenderer",
                               "compressed ms table albedo", q->albedo(c), "the medium's albedo");
        }
        msq_ = q;
        set_reach();
    }
    /// The far field's diffusion grid (PointBasedOptions::ms_far_field), or nullptr.
    [[nodiscard]] const DiffusionGrid<F>* far_field_grid() const noexcept { return dgrid_ ? &*dgrid_ : nullptr; }
    /// The far field's bounded-medium correction of the multiple-scattering emission density at
    /// P toward `to_cam` (per channel; 0 without the far field), of the light's volume samples
    /// (`set` 0, the multiple term) or of the bounced light's secondary samples (1).
    [[nodiscard]] S far_field_correction(const Vec3<F>& P, const Vec3<F>& to_cam, int set = 0) const noexcept {
        S m(F(0));
        if (!dgrid_ || dfield_[std::size_t(set & 1)][0].v.empty()) return m;
        const S sig_s = medium_.sigma_s();
        for (std::size_t c = 0; c < S::size; ++c) {
            Vec3<F> gr;
            const F u = dgrid_->eval(dfield_[std::size_t(set & 1)][c], P, &gr);
            m[c] = sig_s[c] * inv_four_pi_v<F> * (u - F(3) * far_g_[c] * far_D_[c] * glm::dot(gr, to_cam));
        }
        return m;
    }
    /// True if a multiple-scattering table (dense or compressed) is in use.
    [[nodiscard]] bool has_table() const noexcept { return msq_ != nullptr || ms_ != nullptr; }
    /// Octree of the bounce surface samples (Eq. 8): p = position, d = inward normal, w = I_j =
    /// A_j M_j / pi (M_j: radiant exitance of the light reflected inward at the sample).
    [[nodiscard]] const Octree<F, S>& surface_tree() const noexcept { return surf_tree_; }
    /// Secondary volume samples of the bounced light (second and later events after a reflection).
    [[nodiscard]] const Octree<F, S>& bounce_volume_tree() const noexcept { return sec_tree_; }
    /// Ratio of twice- to once-reflected light per channel (0 with one generation).
    [[nodiscard]] const S& bounce_ratio() const noexcept { return bounce_ratio_; }

    /// Radiance along a camera ray (outside the boundary), by component.
    [[nodiscard]] PointBasedComponents<S> radiance_components(const Ray<F>& ray, Rng& rng) const noexcept {
        PointBasedComponents<S> out;
        F t;
        Vec3<F> n;
        if (!boundary_.intersect(ray, t, n)) return out;
        const Vec3<F> wi = -ray.d;
        const F cos_i = glm::dot(wi, n);
        if (cos_i <= F(0)) return out;  // camera inside the boundary: not supported
        Vec3<F> wt;
        F eta_rel = F(1);
        if (!refract(wi, n, eta_, wt, &eta_rel)) return out;
        S w(F((F(1) - fresnel_dielectric(cos_i, eta_)) / (eta_rel * eta_rel)));
        Vec3<F> o = offset_ray_origin(ray(t), -n, wt);
        Vec3<F> dir = glm::normalize(wt);
        for (int b = 0; b <= opt_.camera_bounces; ++b) {
            F te;
            Vec3<F> ne;
            if (!boundary_.intersect(Ray<F>(o, dir), te, ne)) break;
            gather_segment(o, dir, te, w, rng, out);
            const Vec3<F> pe = o + te * dir;
            const F fr = fresnel_dielectric(glm::dot(-dir, ne), eta_);
            w *= medium_.transmittance(te) * fr;
            if (w.max_value() <= F(0)) break;
            dir = glm::normalize(dir - F(2) * glm::dot(dir, ne) * ne);
            o = offset_ray_origin(pe, -ne, dir);
        }
        return out;
    }

    /// Total radiance along a camera ray (Eq. 9).
    [[nodiscard]] S radiance(const Ray<F>& ray, Rng& rng) const noexcept { return radiance_components(ray, rng).total(); }

    /// The 1/r^2 kernel averaged over a ball of radius R whose centre is at distance r (exact for
    /// r < 10 R, 1/r^2 beyond, where the two differ by < 0.4 %).
    [[nodiscard]] static F inverse_square_ball(F r, F R) noexcept {
        if (r >= F(10) * R) return F(1) / (r * r);
        const double rd = double(r), Rd = double(R);
        const double vol = 4.0 / 3.0 * pi_v<double> * Rd * Rd * Rd;
        double I;
        if (rd < 1e-6 * Rd) {
            I = 4.0 * pi_v<double> * Rd;
        } else {
            const double lg = std::log((Rd + rd) / std::abs(Rd - rd));
            I = 2.0 * pi_v<double> / rd * (0.5 * (Rd * Rd - rd * rd) * (std::isfinite(lg) ? lg : 0.0) + rd * Rd);
        }
        return F(I / vol);
    }

    /// Double- and multiple-scattering emission density at P (per unit length along the camera
    /// ray, toward -omega) from the Alg. 1 tree cut (Eqs. 6 and 7).
    void gather_point(const Vec3<F>& P, const Vec3<F>& omega, S& dbl, S& mul) const noexcept {
        gather_point(P, omega, dbl, mul, opt_.cut, opt_.two_step_depth);
    }
    /// As above with an explicit cut criterion and two-step stopping depth (0 = one step).
    void gather_point(const Vec3<F>& P, const Vec3<F>& omega, S& dbl, S& mul, const CutCriterion<F>& cut,
                      std::uint32_t two_step_depth) const noexcept {
        gather_point_tree(tree_, P, omega, dbl, mul, cut, two_step_depth);
    }
    /// As gather_point over any sample tree (the light's volume samples, or the secondary volume
    /// samples of the bounced light).
    void gather_point_tree(const Octree<F, S>& tree, const Vec3<F>& P, const Vec3<F>& omega, S& dbl, S& mul,
                           const CutCriterion<F>& cut, std::uint32_t two_step_depth, bool multiple = true) const noexcept {
        if (tree.items().empty()) return;
        const Vec3<F> to_cam = -omega;
        const Phase& ph = medium_.phase();
        auto pval = [&](const Vec3<F>& a, const Vec3<F>& b) { return F(ph.eval(a, b).value.average()); };
        const S sig_s = medium_.sigma_s();
        const bool with_table = multiple && opt_.multiple && has_table();
        // With ms_cut_eps1 > 0 the table term has its own, coarser cut (two traversals).
        const bool split = with_table && opt_.double_ && opt_.ms_cut_eps1 > F(0);
        bool do_double = opt_.double_, do_table = with_table;
        auto contrib = [&](const Vec3<F>& xv, const Vec3<F>& dv, const S& wv, F coherence, F c_view) {
            const Vec3<F> rv = P - xv;
            const F r = glm::length(rv);
            if (!(r > F(0))) return;
            const Vec3<F> rh = rv / r;
            if (do_double) {
                const S pp = light_phase(dv, rh, coherence * c_view) * light_phase(rh, to_cam, c_view);
                const F k = inverse_square_ball(r, r_min_);
                dbl += sig_s * sig_s * wv * medium_.transmittance(r) * pp * k;
            }
            if (do_table && r <= reach_table_) {  // beyond reach_table_ the table is 0 in every channel
                S m = dgrid_ ? table_or_far(P, xv, dv, coherence, to_cam) : table_response(rv, dv, to_cam);
                if constexpr (TangentPlaneBoundary<Boundary, F>) {
                    if (opt_.ms_boundary_image && !dgrid_) {
                        Vec3<F> q, n;
                        boundary_tangent_plane(boundary_, xv, q, n);
                        const F h = std::max(F(0), glm::dot(q - xv, n));  // depth of the source
                        const Vec3<F> dm = dv - F(2) * glm::dot(dv, n) * n;
                        for (std::size_t c = 0; c < S::size; ++c) {
                            const Vec3<F> xm = xv + F(2) * (h + image_offset_[c]) * n;
                            const F mc = table_response_channel(c, P - xm, dm, to_cam);
                            m[c] = std::max(F(0), m[c] - mc);
                        }
                    }
                }
                mul += sig_s * wv * m;
            }
        };
        // A node seen from P under solid angle Omega spreads the directions r^ over a cone whose
        // mean cosine is 1 - Omega / (4 pi) (uniform cap): both lobes are widened by it.
        auto node_fn = [&](const typename Octree<F, S>::Node& nd) {
            const F c_view = std::max(F(0), F(1) - node_solid_angle(nd.bounds, P) / (F(4) * pi_v<F>));
            if (opt_.widen_lobes) contrib(nd.p, nd.d, nd.w, nd.coherence, c_view);
            else contrib(nd.p, nd.d, nd.w, F(1), F(1));
        };
        auto item_fn = [&](const Item& it) { contrib(it.p, it.d, it.w, F(1), F(1)); };
        auto run_cut = [&](const CutCriterion<F>& c) {
            CutCriterion<F> cut_r = c;
            if (opt_.cull_optical_distance > F(0))
                cut_r.max_distance = std::min(c.max_distance, std::max(do_double ? reach_kernel_ : F(0),
                                                                       do_table ? reach_table_ : F(0)));
            if (two_step_depth > 0) {
                std::array<std::uint32_t, 1024> buf;
                const std::size_t n = tree.coarse_cut(P, to_cam, cut_r, pval, two_step_depth, std::span(buf));
                if (n <= buf.size()) {
                    tree.tree_cut_from(std::span<const std::uint32_t>(buf.data(), n), P, to_cam, cut_r, pval, node_fn,
                                        item_fn);
                    return;
                }
            }
            tree.tree_cut(P, to_cam, cut_r, pval, node_fn, item_fn);
        };
        if (!split) {
            run_cut(cut);
            return;
        }
        do_table = false;
        run_cut(cut);
        do_double = false;
        do_table = true;
        CutCriterion<F> cm = cut;
        cm.eps1 = std::max(cut.eps1, opt_.ms_cut_eps1);
        cm.eps2 = cm.eps1;  // the table's lobes are smooth: no finer cut for a peaked phase
        run_cut(cm);
    }

    /// Table response (Eq. 7 without the source power) at offset rv = P - x_v from a source
    /// travelling along dv, toward `to_cam`, per channel: sigma_t^3 L_o(rho sigma_t, z sigma_t, .).
    [[nodiscard]] S table_response(const Vec3<F>& rv, const Vec3<F>& dv, const Vec3<F>& to_cam) const noexcept {
        S m(F(0));
        const F z = glm::dot(rv, dv);
        const F rho = glm::length(rv - z * dv);
        // The direction lookup (acos, atan2) only where some channel is on the grid (the same
        // test as the table's corners; 0 elsewhere).
        bool on_grid = false;
        for (std::size_t c = 0; c < S::size && !on_grid; ++c) on_grid = on_table_grid(c, rho, z);
        if (!on_grid) return m;
        const MsDirection dir = table_direction(rv, dv, to_cam);
        for (std::size_t c = 0; c < S::size; ++c) {
            const F st = medium_.sigma_t()[c];
            m[c] = F(table_eval(c, double(rho * st), double(z * st), dir)) * st * st * st;
        }
        return m;
    }
    /// True if (rho, z) (scene units) lies on the table's grid in channel c's mean free paths (the
    /// test of ms_cell_corners: the table is 0 elsewhere).
    [[nodiscard]] bool on_table_grid(std::size_t c, F rho, F z) const noexcept {
        const MsTableGrid& g = msq_ ? msq_->grid() : ms_->grid();
        const F st = medium_.sigma_t()[c];
        const double rr = double(rho * st), zz = double(z * st);
        return rr >= 0 && rr <= g.rho_max && zz >= g.z_min && zz <= g.z_max;
    }
    /// The table value (dense or compressed) of channel c at (rho, z) in mean free paths.
    [[nodiscard]] double table_eval(std::size_t c, double rho, double z, const MsDirection& dir) const noexcept {
        return msq_ ? msq_->eval_dir(c, rho, z, dir) : ms_->eval_dir(c, rho, z, dir);
    }
    /// One channel c of table_response() (c < the spectrum size; not checked).
    [[nodiscard]] F table_response_channel(std::size_t c, const Vec3<F>& rv, const Vec3<F>& dv,
                                           const Vec3<F>& to_cam) const noexcept {
        const MsDirection dir = table_direction(rv, dv, to_cam);
        const F z = glm::dot(rv, dv);
        const F rho = glm::length(rv - z * dv);
        const F st = medium_.sigma_t()[c];
        return F(table_eval(c, double(rho * st), double(z * st), dir)) * st * st * st;
    }
    /// The far field's infinite-medium diffusion response of channel c (per unit scattered power)
    /// at P from a source at xv travelling along dv (direction coherence `coh`): the emission
    /// density sigma_s (phi + 3 g E . to_cam) / (4 pi) of an isotropic point source of power
    /// alpha (the light after its first collision) at xv + delta coh dv, delta = g / sigma_t'.
    [[nodiscard]] F far_kernel(std::size_t c, const Vec3<F>& P, const Vec3<F>& xv, const Vec3<F>& dv, F coh,
                               const Vec3<F>& to_cam) const noexcept {
        Vec3<F> E;
        const F phi = far_green(c, P, xv, dv, coh, E);
        return medium_.sigma_s()[c] * inv_four_pi_v<F> * (phi + F(3) * far_g_[c] * glm::dot(E, to_cam));
    }
    /// The infinite-medium diffusion field of channel c at x per unit scattered power at xv
    /// travelling along dv (coherence `coh`): the fluence phi = alpha e^{-k r} / (4 pi D r) of a
    /// point source of power alpha at xv + delta coh dv (r at least half a grid cell), returned,
    /// and its flux E = -D grad phi.
    [[nodiscard]] F far_green(std::size_t c, const Vec3<F>& x, const Vec3<F>& xv, const Vec3<F>& dv, F coh,
                              Vec3<F>& E) const noexcept {
        const Vec3<F> rr = x - (xv + (far_delta_[c] * coh) * dv);
        const F r = std::max(glm::length(rr), far_soft_);
        const F e = medium_.albedo()[c] * inv_four_pi_v<F> * std::exp(-far_kappa_[c] * r);
        E = (e * (F(1) + far_kappa_[c] * r) / (r * r * r)) * rr;
        return e / (far_D_[c] * r);
    }
    /// The light the table's walks dropped beyond their escape radius and that would have come
    /// back to offset rv (emission density per unit scattered power, isotropic; channel c).
    [[nodiscard]] F table_return(std::size_t c, const Vec3<F>& rv) const noexcept {
        // far_ret_ = sigma_s / (4 pi) alpha / (4 pi D) e^{-k Re} / sinh(k Re) (k Re > 1e-4) or
        // the same with 1 / Re and no sinh (k -> 0): the shape is sinh(k r) / r or 1.
        const F k = far_kappa_[c];
        if (k * far_re_[c] <= F(1e-4)) return far_ret_[c];
        const F x = k * glm::length(rv);
        return far_ret_[c] * (x < F(1e-3) ? k * (F(1) + x * x / F(6)) : k * std::sinh(x) / x);
    }
    /// Multiple-scattering response with the far field on: the table where the channel's (rho, z)
    /// is on its grid, far_kernel() beyond.
    [[nodiscard]] S table_or_far(const Vec3<F>& P, const Vec3<F>& xv, const Vec3<F>& dv, F coh,
                                 const Vec3<F>& to_cam) const noexcept {
        const Vec3<F> rv = P - xv;
        const F z = glm::dot(rv, dv);
        const F rho = glm::length(rv - z * dv);
        std::array<bool, S::size> on{};
        bool any = false;
        for (std::size_t c = 0; c < S::size; ++c) {
            on[c] = on_table_grid(c, rho, z);
            any = any || on[c];
        }
        MsDirection dir;
        if (any) dir = table_direction(rv, dv, to_cam);
        S m(F(0));
        for (std::size_t c = 0; c < S::size; ++c) {
            const F st = medium_.sigma_t()[c];
            m[c] = on[c] ? F(table_eval(c, double(rho * st), double(z * st), dir)) * st * st * st + table_return(c, rv)
                         : far_kernel(c, P, xv, dv, coh, to_cam);
        }
        return m;
    }
    /// Multiple-scattering table direction bin of the exit direction `to_cam`, in the frame of a source
    /// at offset rv travelling along dv (cos theta about dv, phi from the radial direction folded to
    /// [0, pi]); bilinear weights when ms_interpolate is on. Needs a table (ms non-null).
    [[nodiscard]] MsDirection table_direction(const Vec3<F>& rv, const Vec3<F>& dv, const Vec3<F>& to_cam) const noexcept {
        const F z = glm::dot(rv, dv);
        const Vec3<F> radial = rv - z * dv;
        const F rho = glm::length(radial);
        const Vec3<F> ex = rho > F(0) ? radial / rho : Frame<F>(dv).s;
        const Vec3<F> ey = glm::cross(dv, ex);
        const F cz = glm::dot(to_cam, dv);
        const F phi = std::atan2(std::abs(glm::dot(to_cam, ey)), glm::dot(to_cam, ex));
        return msq_ ? msq_->direction(double(cz), double(phi), opt_.ms_interpolate)
                    : ms_->direction(double(cz), double(phi), opt_.ms_interpolate);
    }

    /// Phase value for light arriving along the mean direction d of a node whose unit directions
    /// have mean resultant length `coherence` (1 for a single sample). For a HenyeyGreenstein
    /// phase, the lobe averaged over the node's directions is approximated by
    /// HG with g * coherence (exact first moment: the mean cosine of a lobe convolved with a
    /// direction spread of mean cosine c is g c); other phase functions use the mean direction.
    [[nodiscard]] S light_phase(const Vec3<F>& d, const Vec3<F>& w, F coherence) const noexcept {
        const Phase& ph = medium_.phase();
        if constexpr (WidenableLobePhase<Phase>) {
            if (coherence < F(1)) return S(F(widened_phase_value(ph, F(glm::dot(d, w)), coherence)));
        }
        return ph.eval(d, w).value;
    }

    /// Bounced multiple scattering (Eq. 8) emission density at P toward -omega from the tree cut
    /// over the bounce surface samples: sigma_s sum_j I_j cos_j exp(-sigma_t q_j) / q_j^2
    /// p(q^_j, -omega), with the reflected light of sample j treated as diffuse (I_j = A_j M_j / pi,
    /// cos_j between its inward normal and q^_j = (P - s_j) / q_j), as in the paper.
    [[nodiscard]] S gather_bounced(const Vec3<F>& P, const Vec3<F>& omega) const noexcept {
        return gather_bounced(P, omega, opt_.cut);
    }
    /// As gather_bounced(P, omega) with the cut thresholds `cut` instead of the options'.
    [[nodiscard]] S gather_bounced(const Vec3<F>& P, const Vec3<F>& omega, const CutCriterion<F>& cut) const noexcept {
        S acc(F(0));
        if (surf_tree_.items().empty()) return acc;
        const Vec3<F> to_cam = -omega;
        const Phase& ph = medium_.phase();
        auto pval = [&](const Vec3<F>& a, const Vec3<F>& b) { return F(ph.eval(a, b).value.average()); };
        // The solid angle of a sample of area A at distance q, cosine cj: A cj / q^2 far away,
        // bounded by 2 pi near it (that of a disk of the same area seen on its axis,
        // 2 pi (1 - 1 / sqrt(1 + A cj / (pi q^2)))), so a receiver next to a sample stays finite.
        auto contrib = [&](const Vec3<F>& xs, const Vec3<F>& ns, const S& ws, F area) {
            const Vec3<F> q = P - xs;
            const F r = glm::length(q);
            if (!(r > F(0))) return;
            const Vec3<F> qh = q / r;
            const F cj = glm::dot(qh, ns);
            if (cj <= F(0)) return;
            const F x = area * cj / (pi_v<F> * r * r);
            const F omega_s = x < F(1e-3) ? area * cj / (r * r) * (F(1) - F(0.75) * x)
                                          : F(2) * pi_v<F> * (F(1) - F(1) / std::sqrt(F(1) + x));
            acc += ws * (omega_s / area * bounce_lobe(cj)) * medium_.transmittance(r) * ph.eval(qh, to_cam).value;
        };
        CutCriterion<F> cut_r = cut;
        if (opt_.cull_optical_distance > F(0)) cut_r.max_distance = std::min(cut.max_distance, reach_kernel_);
        surf_tree_.tree_cut(
            P, to_cam, cut_r, pval,
            [&](const typename Octree<F, S>::Node& nd) { contrib(nd.p, nd.d, nd.w, F(nd.end - nd.begin) * bounce_area_); },
            [&](const Item& it) {
                // Near a sample its light is spread over the disk of its area a: an equal-area
                // ring quadrature (centre + 6 k points on ring k) with the exact kernel
                // cos e^{-sigma_t r} / r^2 per point; 4 rings (37 points) within 2 a, 2 rings
                // (7 points) within 4 a. The centre-point kernel alone is 25-60 % low next to a
                // sample (test_ms_bias (e)), which biases the bounced term low when the samples
                // are farther apart than the receivers are from the surface.
                const F a = std::sqrt(bounce_area_ * inv_pi_v<F>);
                const Vec3<F> dq = P - it.p;
                const F d2 = glm::dot(dq, dq);
                if (!opt_.bounce_disk_quadrature || d2 > F(16) * a * a) {
                    contrib(it.p, it.d, it.w, bounce_area_);
                    return;
                }
                const int rings = d2 > F(4) * a * a ? 2 : 4;
                const int npts = 1 + 3 * rings * (rings - 1);
                const Frame<F> fr(it.d);
                const S wn = it.w / F(npts);
                const F an = bounce_area_ / F(npts);
                contrib(it.p, it.d, wn, an);
                for (int k = 1; k < rings; ++k) {
                    const F c0 = F(1 + 3 * k * (k - 1)), c1 = F(1 + 3 * k * (k + 1));
                    const F rr = a * std::sqrt(F(0.5) * (c0 + c1) / F(npts));
                    for (int j = 0; j < 6 * k; ++j) {
                        const F ph = (F(j) + F(0.5) * F(k % 2)) * (F(2) * pi_v<F> / F(6 * k));
                        contrib(it.p + rr * (std::cos(ph) * fr.s + std::sin(ph) * fr.t), it.d, wn, an);
                    }
                }
            });
        return medium_.sigma_s() * acc;
    }
    /// Radiance of a bounce sample's reflected light at cosine `cos_in` to its inward normal,
    /// relative to the diffuse lobe's M_j / pi: 1 for BounceReflection::diffuse, F_in(cos_in) /
    /// F_dr for `specular` (integrates to 1 against cos over the hemisphere).
    [[nodiscard]] F bounce_lobe(F cos_in) const noexcept {
        if (opt_.bounce_reflection == BounceReflection::diffuse || !(bounce_fdr_ > F(0))) return F(1);
        return fresnel_dielectric(-cos_in, eta_) / bounce_fdr_;
    }
    /// Eq. 8 summed over every bounce surface sample individually (tests, reference).
    [[nodiscard]] S gather_bounced_brute_force(const Vec3<F>& P, const Vec3<F>& omega) const noexcept {
        CutCriterion<F> c;
        c.eps1 = F(0);
        c.eps2 = F(0);
        return gather_bounced(P, omega, c);
    }

    /// Brute-force double/multiple sum over every volume sample individually (eps1 = eps2 = 0:
    /// the tree cut reaches every item; tests, reference).
    void gather_point_brute_force(const Vec3<F>& P, const Vec3<F>& omega, S& dbl, S& mul) const noexcept {
        CutCriterion<F> c;
        c.eps1 = F(0);
        c.eps2 = F(0);
        gather_point(P, omega, dbl, mul, c, 0);
    }

private:
    /// A bounce sample's gather ray reflected at the boundary (BounceReflection::specular).
    struct BounceRay {
        Vec3<F> o{F(0)}, d{F(0), F(0), F(1)};  ///< origin (just inside) and inward direction
        S power{F(0)};                         ///< reflected power A_j (pi / nr) L F
    };
    /// Reach of the kernels (PointBasedOptions::cull_optical_distance): Eqs. 6 and 8 to that
    /// optical distance in the least-extinguished channel; the table to its grid's farthest
    /// point (sqrt(rho_max^2 + max(z_min^2, z_max^2)) mean free paths, the longest channel's),
    /// with a 0.1 % margin for rounding.
    void set_reach() noexcept {
        const F smin = medium_.sigma_t().min_value();
        reach_kernel_ = opt_.cull_optical_distance > F(0) ? opt_.cull_optical_distance / smin
                                                          : std::numeric_limits<F>::infinity();
        const MsTableGrid* g = msq_ ? &msq_->grid() : (ms_ ? &ms_->grid() : nullptr);
        if (!g) {
            reach_table_ = F(0);
            return;
        }
        const double zr = std::max(std::abs(g->z_min), std::abs(g->z_max));
        reach_table_ = F(1.001 * std::sqrt(g->rho_max * g->rho_max + zr * zr) / double(smin));
        // With the far field the multiple term reaches every source (the diffusion kernel beyond).
        if (opt_.ms_far_field == MsFarField::diffusion) reach_table_ = std::numeric_limits<F>::infinity();
    }

    /// The far field (MsFarField::diffusion): per-channel diffusion parameters, the grid over the
    /// boundary (the box of the light surface samples), the Robin data g = phi_inf + 2 A D
    /// dphi_inf/dn of the volume samples and the bounced light's secondary samples at every
    /// boundary face, and the correction u per channel.
    void build_far_field(const std::vector<SurfaceSample<F>>& surface) {
        const S sig_t = medium_.sigma_t(), sig_s = medium_.sigma_s(), gg = medium_.phase().mean_cosine();
        const F A = boundary_A(eta_);
        for (std::size_t c = 0; c < S::size; ++c) {
            const F sa = sig_t[c] - sig_s[c];
            const F stp = sa + sig_s[c] * (F(1) - gg[c]);  // sigma_t'
            far_D_[c] = F(1) / (F(3) * stp);
            far_kappa_[c] = std::sqrt(std::max(F(0), sa) / far_D_[c]);
            far_delta_[c] = gg[c] / stp;
            far_g_[c] = gg[c];
            // The dropped particles' return (MsFarField doc): alpha / (4 pi D) e^{-k Re} sinh(k r)
            // / (r sinh(k Re)) with Re the escape radius plus the extrapolation length 2 D.
            far_re_[c] = opt_.ms_table_escape_radius / sig_t[c] + F(2) * far_D_[c];
            const double kr = double(far_kappa_[c]) * double(far_re_[c]);
            const double a = double(sig_s[c]) / (4.0 * pi_v<double>) * double(medium_.albedo()[c]) /
                             (4.0 * pi_v<double> * double(far_D_[c]));
            // e^{-k Re} / sinh(k Re) = 2 / (e^{2 k Re} - 1)
            far_ret_[c] = F(kr <= 1e-4 ? a / double(far_re_[c]) : a * 2.0 / std::expm1(2.0 * kr));
        }
        Aabb<F> box;
        for (const SurfaceSample<F>& sp : surface) box.expand(sp.p);
        const F h = opt_.diffusion_cell / sigma_bar_;
        far_soft_ = F(0.5) * h;
        dgrid_.emplace(boundary_, box, h);
        const auto& faces = dgrid_->faces();
        // Robin data per face, channel and source set (0: the light's volume samples, 1: the
        // secondary samples of the bounced light), solved separately so that each correction goes
        // with its component.
        std::vector<std::array<std::array<F, S::size>, 2>> gdata(faces.size());
        const F theta = opt_.diffusion_opening;
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 64)
#endif
        for (std::ptrdiff_t fi = 0; fi < std::ptrdiff_t(faces.size()); ++fi) {
            const DiffusionGridFace<F>& fc = faces[std::size_t(fi)];
            std::array<double, S::size> phi{}, dn{};
            auto add = [&](const Vec3<F>& xv, const Vec3<F>& dv, F coh, const S& w) {
                for (std::size_t c = 0; c < S::size; ++c) {
                    Vec3<F> E;
                    const F q = sig_s[c] * w[c];  // scattered power
                    phi[c] += double(q * far_green(c, fc.s, xv, dv, coh, E));
                    dn[c] -= double(q * glm::dot(E, fc.n) / far_D_[c]);  // dphi/dn = -E . n / D
                }
            };
            for (int set = 0; set < 2; ++set) {
                const Octree<F, S>* tree = set == 0 ? &tree_ : &sec_tree_;
                phi.fill(0.0);
                dn.fill(0.0);
                const auto& nodes = tree->nodes();
                const auto& items = tree->items();
                std::array<std::uint32_t, 256> stack;
                std::size_t top = 0;
                if (!nodes.empty()) stack[top++] = 0;
                while (top > 0) {
                    const auto& nd = nodes[stack[--top]];
                    const bool whole = glm::length(nd.bounds.hi - nd.bounds.lo) < theta * glm::length(fc.s - nd.p);
                    if (whole) {
                        add(nd.p, nd.d, nd.coherence, nd.w);
                    } else if (nd.leaf()) {
                        for (std::uint32_t k = nd.begin; k < nd.end; ++k) add(items[k].p, items[k].d, F(1), items[k].w);
                    } else {
                        for (std::uint32_t ch = 0; ch < nd.child_count && top < stack.size(); ++ch)
                            stack[top++] = nd.first_child + ch;
                    }
                }
                for (std::size_t c = 0; c < S::size; ++c)
                    gdata[std::size_t(fi)][std::size_t(set)][c] = F(phi[c] + 2.0 * double(A) * double(far_D_[c]) * dn[c]);
            }
        }
        for (int set = 0; set < 2; ++set) {
            if (set == 1 && sec_tree_.items().empty()) break;
            for (std::size_t c = 0; c < S::size; ++c) {
                std::vector<F> g(faces.size());
                for (std::size_t f = 0; f < faces.size(); ++f) g[f] = gdata[f][std::size_t(set)][c];
                const F sa = std::max(F(0), sig_t[c] - sig_s[c]);
                const std::vector<F> u = dgrid_->solve(far_D_[c], sa, A, {}, g);
                dfield_[std::size_t(set)][c] = dgrid_->field(u, far_D_[c], A, g);
            }
        }
    }

    void build_samples(const std::vector<SurfaceSample<F>>& surface, const Light<F, S>& light,
                       const std::vector<EnteringLight<F, S>>& entering, Rng& rng) {
        std::vector<Item> items;
        const int nl = light.is_delta() ? 1 : opt_.light_samples;
        for (const SurfaceSample<F>& s : surface) {
            if (!opt_.direct_light) break;  // the light surface samples stay dark
            for (int j = 0; j < nl; ++j) {
                const Vec2<F> u2 = rng.uniform2<F>();
                const Vec2<F> u((F(j) + u2.x) / F(nl), u2.y);  // stratified in one dimension
                const F xi = rng.uniform<F>();
                const Vec3<F> ref = offset_ray_origin(s.p, s.n, s.n);
                const LightSample<F, S> ls = light.sample(ref, u);
                if (!(ls.pdf > F(0)) || ls.L.is_black()) continue;
                const F cos_i = glm::dot(ls.w, s.n);
                if (cos_i <= F(0)) continue;
                Vec3<F> wt;
                F eta_rel;
                if (!refract(ls.w, s.n, eta_, wt, &eta_rel)) continue;
                wt = glm::normalize(wt);
                const F tr = F(1) - fresnel_dielectric(cos_i, eta_);
                const S phi = ls.L * (cos_i * s.area * tr / (ls.pdf * F(nl)));
                add_light_ray(s.p, s.n, wt, phi, s.area, xi, items);
            }
        }
        for (const EnteringLight<F, S>& e : entering) {
            if (e.power.max_value() <= F(0)) continue;
            add_light_ray(e.p, e.n, glm::normalize(e.d), e.power, e.area, rng.uniform<F>(), items);
        }
        check_argument(items.size() < std::size_t(std::numeric_limits<std::uint32_t>::max()), "PointBasedRenderer",
                       "volume samples", items.size(), "< 2^32");
        tree_ = Octree<F, S>(std::move(items), opt_.leaf_items);
        if (opt_.use_density_factor) {
            // Eq. 4: A_v = bounding-box area of the leaf's samples (largest face), S_v = the area
            // around the surface sample at the origin of the ray.
            k_.assign(boxes_.size(), F(1));
            for (const auto& nd : tree_.nodes()) {
                if (!nd.leaf()) continue;
                const Vec3<F> e = nd.bounds.extent();
                const F A = std::max({e.x * e.y, e.y * e.z, e.x * e.z});
                for (std::uint32_t i = nd.begin; i < nd.end; ++i) {
                    const auto id = tree_.items()[i].id;
                    k_[id] = density_factor(A, boxes_[id].source_area, sigma_bar_);
                }
            }
        }
    }

    /// The volume samples of one light ray that enters at p (outward normal n) along the unit
    /// inside direction wt with power phi through a patch of area `area`: one every Delta from
    /// xi Delta on, each with its box (cross-section area |wt . n|), followed through
    /// `light_bounces` internal reflections (deterministic Fresnel split).
    void add_light_ray(const Vec3<F>& p, const Vec3<F>& n, const Vec3<F>& wt, S phi, F area, F xi,
                       std::vector<Item>& items) {
        const F max_len = opt_.max_optical_depth / medium_.sigma_t().min_value();
        const F side = std::sqrt(area * std::abs(glm::dot(wt, n)));
        Vec3<F> o = offset_ray_origin(p, -n, wt);
        Vec3<F> dir = wt;
        F travelled = F(0);
        for (int b = 0; b <= opt_.light_bounces; ++b) {
            F te;
            Vec3<F> ne;
            if (!boundary_.intersect(Ray<F>(o, dir), te, ne)) break;
            const F len = std::min(te, max_len - travelled);
            const Frame<F> fr(dir);
            for (F u0 = xi * step_; u0 < len; u0 += step_) {
                Item it;
                it.p = o + u0 * dir;
                it.d = dir;
                it.w = phi * medium_.transmittance(u0) * step_;
                Box bx{it.p, fr.s, fr.t, dir, F(0.5) * side, F(0.5) * side, F(0.5) * step_,
                       F(1) / (side * side * step_), area};
                if (opt_.clip_boxes) bx.inv_volume /= inside_fraction(bx);
                const Vec3<F> hext = glm::abs(bx.e1) * bx.h1 + glm::abs(bx.e2) * bx.h2 + glm::abs(bx.d) * bx.hd;
                it.extent = Aabb<F>(it.p - hext, it.p + hext);
                it.id = std::uint32_t(boxes_.size());
                boxes_.push_back(bx);
                items.push_back(it);
            }
            travelled += te;
            if (travelled >= max_len) break;
            const Vec3<F> pe = o + te * dir;
            phi *= medium_.transmittance(te) * fresnel_dielectric(glm::dot(-dir, ne), eta_);
            if (phi.max_value() <= F(0)) break;
            dir = glm::normalize(dir - F(2) * glm::dot(dir, ne) * ne);
            o = offset_ray_origin(pe, -ne, dir);
        }
    }

    /// Bounce surface samples (Sec. 3.5.5). Generation 1: the light arriving from inside at each
    /// sample (single + double + multiple radiance gathered along `bounce_rays` cosine-
    /// distributed inward rays, the same estimator as a camera ray inside) times the Fresnel
    /// reflectance seen from inside, stored as a diffuse exitance M_j. The reflected light then
    /// enters the medium again: the surface samples carry it to the first scattering after the
    /// reflection (Eq. 8, `surface_tree`), and secondary volume samples along `bounce_rays`
    /// inward rays per surface sample carry it to the second and later events (Eqs. 6 and 7 over
    /// `bounce_volume_tree`). Generation 2 (`bounce_generations` = 2): the same gather of the
    /// bounced field gives the light reflected twice, M2_j; the later generations are summed as
    /// a geometric series with the ratio r = sum M2 / sum M1 per channel, M_j = M1_j + M2_j / (1 - r).
    void build_bounce_samples(const std::vector<SurfaceSample<F>>& surface, Rng& rng) {
        const std::size_t n = surface.size();
        const std::size_t stride = std::max<std::size_t>(1, (n + std::size_t(opt_.bounce_samples) - 1) /
                                                                 std::size_t(opt_.bounce_samples));
        std::vector<std::size_t> pick;
        for (std::size_t i = 0; i < n; i += stride) pick.push_back(i);
        const F area_scale = F(double(n) / double(pick.size()));
        std::vector<SurfaceSample<F>> bs(pick.size());
        for (std::size_t i = 0; i < pick.size(); ++i) {
            bs[i] = surface[pick[i]];
            bs[i].area *= area_scale;
        }
        (void)rng;
        const bool specular = opt_.bounce_reflection == BounceReflection::specular;
        std::vector<BounceRay> rays1, rays2;
        std::vector<S> M1 = gather_at_surface(bs, true, false, specular ? &rays1 : nullptr);
        set_bounce_sources(bs, M1, specular ? &rays1 : nullptr);
        if (opt_.bounce_generations >= 2) {
            const std::vector<S> M2 = gather_at_surface(bs, false, true, specular ? &rays2 : nullptr);
            S s1(F(0)), s2(F(0));
            for (std::size_t i = 0; i < bs.size(); ++i) {
                s1 += M1[i] * bs[i].area;
                s2 += M2[i] * bs[i].area;
            }
            S geo;
            for (std::size_t c = 0; c < S::size; ++c) {
                const F r = s1[c] > F(0) ? std::clamp(s2[c] / s1[c], F(0), F(0.9)) : F(0);
                geo[c] = F(1) / (F(1) - r);
                bounce_ratio_[c] = r;
            }
            for (std::size_t i = 0; i < bs.size(); ++i) M1[i] += opt_.bounce_series ? M2[i] * geo : M2[i];
            if (specular) {
                if (opt_.bounce_series)
                    for (BounceRay& b : rays2) b.power *= geo;
                rays1.insert(rays1.end(), rays2.begin(), rays2.end());
            }
            set_bounce_sources(bs, M1, specular ? &rays1 : nullptr);
        }
    }

    /// A uniform point of the disk of area `s.area` around the surface sample in its tangent
    /// plane, moved onto the boundary (a ray back along -n); false if the ray misses. Spreads the
    /// light a sample carries over the patch it stands for.
    bool jitter_on_surface(const SurfaceSample<F>& s, Vec2<F> u, Vec3<F>& p, Vec3<F>& n) const noexcept {
        const Frame<F> fr(s.n);
        const F a = std::sqrt(s.area * inv_pi_v<F>);
        const F rr = a * std::sqrt(u.x), ph = F(2) * pi_v<F> * u.y;
        const Vec3<F> q = s.p + rr * (std::cos(ph) * fr.s + std::sin(ph) * fr.t) + a * s.n;
        F t;
        if (!boundary_.intersect(Ray<F>(q, -s.n), t, n)) return false;
        p = q - t * s.n;
        return glm::dot(n, s.n) > F(0);
    }

    /// Reflected exitance M_j at each surface sample of the light gathered from inside (the
    /// primary field and/or the bounced field).
    /// With `rays`: also each gather ray's reflection (index sample nr + ray): the mirror image of
    /// the ray about the boundary at its origin, carrying A_j (pi / nr) L F, the ray's share of
    /// A_j M_j (zero power where the ray found no boundary).
    std::vector<S> gather_at_surface(const std::vector<SurfaceSample<F>>& bs, bool primary, bool bounced,
                                     std::vector<BounceRay>* rays = nullptr) const {
        std::vector<S> M(bs.size(), S(F(0)));
        const int nr = opt_.bounce_rays;
        if (rays) rays->assign(bs.size() * std::size_t(nr), BounceRay{});
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 16)
#endif
        for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(bs.size()); ++ii) {
            const SurfaceSample<F>& s = bs[std::size_t(ii)];
            Rng r = Rng::from_key(0x424f554e43ull, std::uint64_t(ii), bounced ? 2u : 1u);
            S acc(F(0));
            for (int k = 0; k < nr; ++k) {
                Vec3<F> ps, ns;
                if (!jitter_on_surface(s, r.uniform2<F>(), ps, ns)) continue;
                const Frame<F> fk(-ns);
                const Vec2<F> u2 = r.uniform2<F>();
                const Vec3<F> wl = sample_cosine_hemisphere(Vec2<F>((F(k) + u2.x) / F(nr), u2.y));
                const Vec3<F> w = glm::normalize(fk.to_world(wl));
                const Vec3<F> o = offset_ray_origin(ps, -ns, w);
                F te;
                Vec3<F> ne;
                if (!boundary_.intersect(Ray<F>(o, w), te, ne)) continue;
                PointBasedComponents<S> c;
                // With the far field the multiply scattered light is not reflected here: skip it.
                gather_segment(o, w, te, S(F(1)), r, c, opt_.bounce_k_max, primary, bounced,
                               opt_.ms_far_field == MsFarField::none);
                // Light arriving along -w hits the boundary from inside at cosine wl.z. With the
                // far field, the reflection of the multiply scattered (diffuse) light is in its
                // Robin condition: only the single- and double-scattered light is reflected here.
                const S arriving = opt_.ms_far_field == MsFarField::diffusion ? S(c.single + c.double_ + c.bounced)
                                                                               : c.total();
                const S reflected = arriving * fresnel_dielectric(-wl.z, eta_);
                acc += reflected;
                if (rays) {
                    BounceRay& b = (*rays)[std::size_t(ii) * std::size_t(nr) + std::size_t(k)];
                    // The light arrived along -w; its mirror image about the tangent plane goes
                    // inward along -w + 2 (w . n) n (n outward).
                    b.d = glm::normalize(F(2) * glm::dot(w, ns) * ns - w);
                    b.o = offset_ray_origin(ps, -ns, b.d);
                    b.power = reflected * (s.area * pi_v<F> / F(nr));
                }
            }
            M[std::size_t(ii)] = acc * (pi_v<F> / F(nr));  // int L F cos d omega, cosine-sampled
        }
        return M;
    }

    /// Secondary volume samples along the ray (o, w) inside the boundary, up to max_len: one every
    /// Delta (the first jittered with `rng`), each holding power T(u) Delta (no-op if the ray
    /// finds no boundary).
    void add_secondary_samples(const Vec3<F>& o, const Vec3<F>& w, const S& power, F max_len, Rng& rng,
                               std::vector<Item>& sec) const {
        F te;
        Vec3<F> ne;
        if (!boundary_.intersect(Ray<F>(o, w), te, ne)) return;
        const F len = std::min(te, max_len);
        for (F u0 = rng.uniform<F>() * step_; u0 < len; u0 += step_) {
            Item v;
            v.p = o + u0 * w;
            v.d = w;
            v.w = power * medium_.transmittance(u0) * step_;
            v.extent = Aabb<F>(v.p, v.p);
            v.id = std::uint32_t(sec.size());
            sec.push_back(v);
        }
    }

    /// Surface tree (Eq. 8: I_j = A_j M_j / pi along the inward normal) and secondary volume
    /// samples: without `rays` (diffuse storage) power A_j M_j / bounce_rays along each of
    /// bounce_rays cosine-distributed inward rays; with them (specular storage) along each ray of
    /// `rays` with its own power.
    void set_bounce_sources(const std::vector<SurfaceSample<F>>& bs, const std::vector<S>& M,
                            const std::vector<BounceRay>* rays = nullptr) {
        std::vector<Item> items(bs.size());
        std::vector<Item> sec;
        const int nr = opt_.bounce_rays;
        const F max_len = opt_.max_optical_depth / medium_.sigma_t().min_value();
        for (std::size_t i = 0; i < bs.size(); ++i) {
            const SurfaceSample<F>& s = bs[i];
            Item it;
            it.p = s.p;
            it.d = -s.n;
            it.w = M[i] * (s.area * inv_pi_v<F>);
            it.extent = Aabb<F>(s.p, s.p);
            it.id = std::uint32_t(i);
            items[i] = it;
            if (rays || M[i].max_value() <= F(0) || !opt_.bounce_secondary) continue;
            Rng r = Rng::from_key(0x5345434fu, std::uint64_t(i));
            const S phi = M[i] * (s.area / F(nr));
            for (int k = 0; k < nr; ++k) {
                Vec3<F> ps, ns;
                if (!jitter_on_surface(s, r.uniform2<F>(), ps, ns)) continue;
                const Frame<F> fk(-ns);
                const Vec2<F> u2 = r.uniform2<F>();
                const Vec3<F> w = glm::normalize(fk.to_world(sample_cosine_hemisphere(Vec2<F>((F(k) + u2.x) / F(nr), u2.y))));
                add_secondary_samples(offset_ray_origin(ps, -ns, w), w, phi, max_len, r, sec);
            }
        }
        if (rays && opt_.bounce_secondary) {
            // Specular storage: each gather ray's reflection.
            for (std::size_t k = 0; k < rays->size(); ++k) {
                const BounceRay& b = (*rays)[k];
                if (b.power.max_value() <= F(0)) continue;
                Rng r = Rng::from_key(0x5345434fu, std::uint64_t(k), 3u);
                add_secondary_samples(b.o, b.d, b.power, max_len, r, sec);
            }
        }
        bounce_area_ = F(0);
        for (const auto& b : bs) bounce_area_ += b.area / F(bs.size());
        surf_tree_ = Octree<F, S>(std::move(items), opt_.leaf_items);
        sec_tree_ = sec.empty() ? Octree<F, S>() : Octree<F, S>(std::move(sec), opt_.leaf_items);
    }

    /// Fraction of a box inside the boundary (3 x 3 x 3 sub-cell centres; 1 for a box whose
    /// centre is deeper than its half diagonal, or without a TangentPlaneBoundary). Light that
    /// the box kernel would spread outside the medium is given to its inside part.
    F inside_fraction(const Box& b) const noexcept {
        if constexpr (TangentPlaneBoundary<Boundary, F>) {
            Vec3<F> q, n;
            boundary_tangent_plane(boundary_, b.c, q, n);
            const F depth = glm::dot(q - b.c, n);
            const F hd = std::sqrt(b.h1 * b.h1 + b.h2 * b.h2 + b.hd * b.hd);
            if (depth > hd) return F(1);
            int in = 0;
            for (int i = -1; i <= 1; ++i)
                for (int j = -1; j <= 1; ++j)
                    for (int k = -1; k <= 1; ++k) {
                        const Vec3<F> x = b.c + F(2) / F(3) * (F(i) * b.h1 * b.e1 + F(j) * b.h2 * b.e2 + F(k) * b.hd * b.d);
                        Vec3<F> qx, nx;
                        boundary_tangent_plane(boundary_, x, qx, nx);
                        in += glm::dot(qx - x, nx) > F(0) ? 1 : 0;
                    }
            return std::max(F(in), F(1)) / F(27);
        } else {
            (void)b;
            return F(1);
        }
    }

    /// Exact segment/OBB overlap [t0, t1] within [0, tmax]; false if none (or if the segment
    /// only touches the box: the overlap then carries no light). The segment is moved into the
    /// box's frame (e1, e2, d) and clipped by the library's slab test (geometry/aabb.hpp).
    static bool clip_box(const Box& b, const Vec3<F>& o, const Vec3<F>& w, F tmax, F& t0, F& t1) noexcept {
        t0 = F(0);
        t1 = tmax;
        const Vec3<F> rel = o - b.c;
        const Vec3<F> ol(glm::dot(rel, b.e1), glm::dot(rel, b.e2), glm::dot(rel, b.d));
        const Vec3<F> wl(glm::dot(w, b.e1), glm::dot(w, b.e2), glm::dot(w, b.d));
        const Vec3<F> h(b.h1, b.h2, b.hd);
        return clip_ray_to_box(ol, wl, -h, h, t0, t1) && t0 < t1;
    }

    void gather_segment(const Vec3<F>& o, const Vec3<F>& w, F dmax, const S& weight, Rng& rng,
                        PointBasedComponents<S>& out) const noexcept {
        gather_segment(o, w, dmax, weight, rng, out, opt_.k_max, true, true);
    }
    /// `primary`: single, double and multiple from the light's volume samples; `with_bounced`:
    /// the bounced term (Eq. 8 + the secondary samples' Eqs. 6 and 7); `with_multiple` false: no
    /// table term (Eq. 7) from either sample set.
    void gather_segment(const Vec3<F>& o, const Vec3<F>& w, F dmax, const S& weight, Rng& rng,
                        PointBasedComponents<S>& out, int k_max, bool primary, bool with_bounced,
                        bool with_multiple = true) const noexcept {
        const S sig_s = medium_.sigma_s();
        const S& sig_t = medium_.sigma_t();
        const Phase& ph = medium_.phase();
        if (opt_.single && primary) {
            S acc(F(0));
            tree_.visit_segment(o, w, F(0), dmax, [&](const Item& it) {
                const Box& b = boxes_[it.id];
                F t0, t1;
                if (!clip_box(b, o, w, dmax, t0, t1)) return;
                S integral;
                for (std::size_t c = 0; c < S::size; ++c)
                    integral[c] = (std::exp(-sig_t[c] * t0) - std::exp(-sig_t[c] * t1)) / sig_t[c];
                F k = k_.empty() ? F(1) : k_[it.id];
                acc += ph.eval(it.d, -w).value * it.w * integral * (b.inv_volume / k);
            });
            out.single += weight * sig_s * acc;
        }
        const bool bounced = with_bounced && !surf_tree_.items().empty();
        const bool prim = primary && (opt_.double_ || (with_multiple && opt_.multiple && has_table()));
        if (!(prim || bounced)) return;
        const CameraDepthSampler<S> ds(sig_t, dmax, opt_.depth_sampling);
        if (!ds.valid()) return;
        const F xi = rng.uniform<F>();
        S dsum(F(0)), msum(F(0)), bsum(F(0));
        for (int k = 0; k < k_max; ++k) {
            S wk;
            const F dk = ds.sample((F(k) + xi) / F(k_max), k_max, wk);  // Eq. 10 (jittered)
            S dbl(F(0)), mul(F(0));
            const Vec3<F> Pk = o + dk * w;
            if (prim) gather_point_tree(tree_, Pk, w, dbl, mul, opt_.cut, opt_.two_step_depth, with_multiple);
            if (prim && dgrid_ && opt_.multiple && with_multiple) mul += far_field_correction(Pk, -w);
            dsum += wk * dbl;
            msum += wk * mul;
            if (bounced) {
                S b2(F(0)), b3(F(0));
                gather_point_tree(sec_tree_, Pk, w, b2, b3, bounce_cut_, 0, with_multiple);
                bsum += wk * (gather_bounced(Pk, w, bounce_cut_) + b2 + b3);
                if (dgrid_) bsum += wk * far_field_correction(Pk, -w, 1);
            }
        }
        out.double_ += weight * dsum;
        out.multiple += weight * msum;
        out.bounced += weight * bsum;
    }

    Medium medium_;
    F eta_;
    Boundary boundary_;
    PointBasedOptions<F> opt_;
    const MsTable<N>* ms_;
    const MsTableQuadtree<N>* msq_ = nullptr;
    F sigma_bar_ = F(1), step_ = F(0.1), r_min_ = F(0.1);
    F reach_kernel_ = std::numeric_limits<F>::infinity();  ///< cull distance of Eqs. 6 and 8 (scene units)
    F reach_table_ = F(0);  ///< distance beyond which the table is 0 in every channel (scene units)
    std::array<F, S::size> image_offset_{};  ///< ms_image_offset in scene units per channel
    Octree<F, S> tree_;
    Octree<F, S> surf_tree_;
    Octree<F, S> sec_tree_;
    S bounce_ratio_{0};
    F bounce_fdr_ = F(0);  ///< hemispherical mean of the inside Fresnel reflectance (specular lobe)
    F bounce_area_ = F(1);  ///< mean area of a bounce surface sample
    std::vector<Box> boxes_;
    std::vector<F> k_;
    CutCriterion<F> bounce_cut_{};  ///< the bounced term's camera-side cut (bounce_cut_scale)
    // Far field (MsFarField::diffusion).
    std::optional<DiffusionGrid<F>> dgrid_;
    std::array<std::array<typename DiffusionGrid<F>::Field, S::size>, 2> dfield_{};  ///< [source set][channel]
    std::array<F, S::size> far_D_{}, far_kappa_{}, far_delta_{}, far_g_{};
    F far_soft_ = F(0);
    std::array<F, S::size> far_re_{}, far_ret_{};  ///< the table's escape radius + 2 D (scene units)
};

}  // namespace grainlight
