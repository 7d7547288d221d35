/// @file grainlight/integrators/hybrid.hpp
/// Meng15 Sec. 5: the hybrid integrator that starts camera paths with explicit path tracing of
/// the grains (EPT, integrators/ept.hpp), switches them to volumetric path tracing (VPT) in the
/// effective continuous medium of the scatterometer statistics (media/teleportation.hpp,
/// make_effective_medium) once the rays of a pixel's bundle have become incoherent, and from VPT
/// to diffusion (DA: improved diffusion, diffusion/improved.hpp) deep inside the medium.
///
/// Pieces (equation -> function):
///   - Bundles traced in lock-step, Eq. 5: `hybrid_bundle` spawns N paths of one pixel (N = 16
///     in the paper, HybridOptions::bundle_size) and advances them one EPT event at a time. After
///     every round k it computes sigma_k = sqrt(1/N_k sum_i |x_i^k - mean|^2) over the N_k paths
///     still alive in EPT mode (their current vertices) and arms the bundle when
///     sigma_k > tau N_k / N (tau = HybridOptions::tau grain radii; 4 in the paper) or when one
///     path remains. An armed path switches at its next grain hit ("all paths in a bundle switch
///     upon hitting the next grain"), after at least `min_ept_interactions` grain interactions in
///     EPT (Meng15 Sec. 6: "at least one grain interaction in EPT mode before switching"), and
///     only where the grain hit lies inside the aggregate's boundary shape (where the effective
///     medium is).
///   - The switch replaces that grain interaction by a scattering event of the effective medium
///     (albedo alpha_s, phase Phi), with next-event estimation, and continues with the VPT of
///     integrators/vpt.hpp in `scene_vpt`: the same lights and surfaces as the EPT scene plus the
///     aggregate's boundary shape as an index-matched surface enclosing the effective medium.
///   - Acceptance P_a (Sec. 5): at the switch the path survives with probability P_a (weight
///     1 / P_a). `optimal_acceptance` is Eq. 8, the minimiser of Eq. 6 x Eq. 7;
///     `estimate_optimal_acceptance` measures V_L, V_H, t_L, t_H on a preview (every stride-th
///     pixel of the camera, same samples per pixel and pixel footprint, P_a = 1: Meng15's "down-
///     scaled image 1% of the original size ... footprint of the original pixels").
///   - VPT -> DA (Sec. 5, App. A): at a VPT scattering vertex x with distance to the boundary
///     >= d_DA = min(1 / sigma_t', 0.5 / sigma_tr) (the largest over the colour channels), the
///     path samples a uniform direction from x, finds the boundary point x_s (normal N_s), and
///     moves there with the weight of the improved-diffusion point-source profile R_p(r; z)
///     (z, r: depth of x below and offset along the tangent plane of x_s; multipole of a slab of
///     thickness z_r + z_a from an auxiliary ray along -omega_i as in App. A, or the
///     semi-infinite dipole) divided by the area pdf of x_s, i.e. 4 pi |x_s - x|^2 / |cos theta_s|. At x_s it gathers the incident
///     radiance like a white Lambertian vertex (NEE with MIS, then a cosine-sampled direction out
///     of the medium): Meng15 "sample the direct illumination at x_i ... we resume VPT from x_i".
///     Why R_p: by reciprocity the mean radiance phi / 4 pi at x due to irradiance E on the
///     boundary is (1 / pi) int E(x_s) R_p(x_s; x) dA (checked by the furnace: E = pi L gives L
///     when int R_p dA = 1).
///   - Time to unit variance (Sec. 6): `render_hybrid` records per pixel the sample variance of
///     the bundle estimates (total, low-order = EPT part, high-order = VPT/DA part) and the CPU
///     time of the two parts (the thread CPU time of each image row, split in the ratio of the
///     parts' steady-clock times inside the bundles); ttuv = (mean pixel variance of one bundle
///     sample) x (CPU seconds of a one-bundle-per-pixel image). `render_hybrid` is
///     `summarize_hybrid(render_hybrid_films(...))`: a process may render only its rows
///     (HybridOptions::row_offset / row_stride), the films' rows are placed together and the
///     summary is computed once, equal to a single process's (the examples' MPI split).
///
/// Mode `HybridMode::ept` evaluates the same criterion but never switches: contributions after
/// the would-be switch go to the high-order image, and every path is bit-identical to
/// ept_radiance with the same generator (each path of a bundle has its own counter-based
/// generator Pcg32::from_key(seed, pixel, bundle * N + i), as render_ept's sample index).
///
/// Techniques (Meng15 Fig. 11): HybridMode ept, ept_vpt, ept_vpt_da, and the grain-free vpt and
/// vpt_da (camera paths enter the effective medium directly: hybrid_vpt_camera_path). Films
/// (Fig. 12): HybridImages::ept_image / vpt_image / da_image (what each technique gathered) and
/// switch_depth.
///
/// Distance to the boundary: any callable double(const Vec3d&) returning the distance (or a
/// lower bound) from an interior point to the boundary surface; the DA switch asks
/// `ball_inside(distance, x, d_DA)` (geometry/distance.hpp), which uses a member
/// `ball_inside(x, r)` when the callable has one. `BoundaryDistance<Shape>` covers
/// SphereBoundary, BoxBoundary and the half-space used in tests; `add_mesh_boundary` makes any
/// closed triangle mesh (an OBJ) the boundary: the mesh goes into scene_vpt and its MeshDistance
/// (exact nearest point through a box tree, early-exit ball query) drives the switch.
///
/// Kernel rules: no allocation, no exceptions, no virtual calls; randomness only from the paths'
/// generators. The clock is read only when HybridOptions::measure_time is set.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/integrators/flight_memory.hpp"
#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/diffusion/improved.hpp"
#include "grainlight/diffusion/multipole.hpp"
#include "grainlight/geometry/distance.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/vpt.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/scene/concepts.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/scene/shapes.hpp"
#include "grainlight/traversal/aggregate.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif
#if defined(__unix__) || defined(__APPLE__)
#include <time.h>
#endif

namespace grainlight {

namespace detail {
/// CPU seconds consumed by the calling thread (POSIX CLOCK_THREAD_CPUTIME_ID; elsewhere the
/// steady clock). Unlike wall time it does not grow when other processes share the cores.
[[nodiscard]] inline double thread_cpu_seconds() noexcept {
#if defined(CLOCK_THREAD_CPUTIME_ID)
    timespec ts{};
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) == 0) return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
#endif
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace detail

// ---------------------------------------------------------------------------------------------
// Distance to the boundary (VPT -> DA criterion)
// ---------------------------------------------------------------------------------------------

/// Distance from p to the surface of a solid sphere (meaningful for interior points; negative
/// outside).
[[nodiscard]] inline double distance_to_boundary(const SphereBoundary& s, const Vec3d& p) noexcept {
    return s.radius - glm::length(p - s.center);
}
/// Distance from p to the surface of a solid axis-aligned box (interior points; <= 0 outside).
[[nodiscard]] inline double distance_to_boundary(const BoxBoundary& b, const Vec3d& p) noexcept {
    double d = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) d = std::min({d, p[a] - b.lo[a], b.hi[a] - p[a]});
    return d;
}

/// The half-space z < z0 (tests: Meng15 App. A's planar assumption holds exactly).
struct HalfSpaceBoundary {
    double z0 = 0;  ///< height of the boundary plane
};
/// Distance from p to the plane z = z0 of a half-space z < z0.
[[nodiscard]] inline double distance_to_boundary(const HalfSpaceBoundary& h, const Vec3d& p) noexcept {
    return h.z0 - p.z;
}

/// Callable distance-to-boundary for a shape with a `distance_to_boundary` overload.
template <class Shape>
struct BoundaryDistance {
    Shape shape;  ///< the boundary shape
    /// distance_to_boundary(shape, p).
    [[nodiscard]] double operator()(const Vec3d& p) const noexcept { return distance_to_boundary(shape, p); }
};

/// A distance that is never large enough (disables the DA switch).
struct NoBoundaryDistance {
    /// Always 0.
    [[nodiscard]] double operator()(const Vec3d&) const noexcept { return 0.0; }
};

// ---------------------------------------------------------------------------------------------
// Options, diffusion parameters, Eq. 8
// ---------------------------------------------------------------------------------------------

/// Which techniques a hybrid render uses: the five combinations of Meng15 Fig. 11.
enum class HybridMode : std::uint8_t {
    ept,         ///< EPT only (the criterion only splits low/high order)
    ept_vpt,     ///< EPT -> VPT
    ept_vpt_da,  ///< EPT -> VPT -> DA
    vpt,         ///< VPT only: camera paths enter the effective medium directly (no grains)
    vpt_da       ///< VPT -> DA (no grains)
};

/// The mode switches to diffusion deep inside.
[[nodiscard]] constexpr bool hybrid_uses_da(HybridMode m) noexcept {
    return m == HybridMode::ept_vpt_da || m == HybridMode::vpt_da;
}
/// The mode traces camera paths through the explicit grains first.
[[nodiscard]] constexpr bool hybrid_uses_ept(HybridMode m) noexcept {
    return m == HybridMode::ept || m == HybridMode::ept_vpt || m == HybridMode::ept_vpt_da;
}
/// Fig. 11's label of a mode: "EPT", "EPT+VPT", "EPT+VPT+DA", "VPT", "VPT+DA".
[[nodiscard]] inline const char* hybrid_mode_name(HybridMode m) noexcept {
    switch (m) {
        case HybridMode::ept: return "EPT";
        case HybridMode::ept_vpt: return "EPT+VPT";
        case HybridMode::ept_vpt_da: return "EPT+VPT+DA";
        case HybridMode::vpt: return "VPT";
        case HybridMode::vpt_da: return "VPT+DA";
    }
    return "?";
}

/// Options of the hybrid integrator (defaults: Meng15 Sec. 5).
struct HybridOptions {
    HybridMode mode = HybridMode::ept_vpt;  ///< techniques (Fig. 11)
    int bundle_size = 16;           ///< N: paths per bundle (1..64)
    double tau = 4.0;               ///< Eq. 5 threshold in grain (bounding-sphere) radii
    int min_ept_interactions = 1;   ///< grain interactions in EPT before a path may switch
    /// Smallest distance from the boundary (world units) at which a path may switch: the grain hit
    /// must satisfy ball_inside(ctx.distance, x, min_switch_depth). 0 (default): Meng15's rule,
    /// any grain hit inside the boundary. Near the boundary the effective medium misstates the
    /// light that comes back from the first few grain layers, which biases VPT low on low-albedo
    /// aggregates (measured on the sandcastle: docs/meng15_hybrid.md, Fig. 1).
    double min_switch_depth = 0.0;
    bool switch_single = true;      ///< arm the bundle when only one path remains
    /// Flight memory of the VPT part (media/flight_memory.hpp): its flights know the K most recent
    /// flights of the path (the EPT flights before the switch, then its own) and collide less in
    /// their grain-free tubes, the shadowing correlation of a packing that a memoryless effective
    /// medium misses near a boundary. K = 0: Meng15's memoryless VPT. Measured in a half-space of
    /// sand switched after one interaction: -7.8 / -5.8 % at 0 / 60 degrees without, -1.7 / -0.6 %
    /// with K = 4 (docs/meng15_hybrid.md).
    int flight_memory = 4;
    /// Flights of the VPT part that use the memory (the first ones after the switch; see
    /// FlightMemory::flights_left).
    int flight_memory_flights = 8;
    /// While the memory is active, no grain centre lies outside the aggregate's boundary: a flight
    /// near the boundary collides less (the part of its collision disc outside holds no centre).
    /// Needs the boundary: hybrid_bundle and the switch calibration pass it (CentresInside). Off
    /// by default: with a mesh boundary every candidate collision and shadow-ray step asks the
    /// mesh distance, which made the 400-R snowman's EPT+VPT 5x slower (docs/meng15_hybrid.md).
    bool flight_memory_boundary = false;
    double acceptance = 1.0;        ///< P_a in (0, 1]
    EptOptions ept{};               ///< EPT part (events budget, roulette, NEE)
    VptOptions vpt{};               ///< VPT part (depth, roulette, NEE)
    int max_da_restarts = 64;       ///< DA connections per path at most
    /// DA with the finite-slab multipole of Meng15 App. A (thickness z_r + z_a from an auxiliary
    /// ray along -omega_i); false: the semi-infinite improved-diffusion dipole.
    bool multipole = true;
    bool measure_time = false;      ///< time the EPT and VPT/DA parts (for P_a and ttuv)
    /// Periodic checkpoints and resume of render_hybrid (integrators/render.hpp; off by default).
    /// A checkpoint holds the finished rows' films, per-pixel statistics, CPU times and counters,
    /// so a resumed render gives the same images and the same ttuv inputs as one uninterrupted run.
    CheckpointOptions checkpoint{};
    /// Render only the rows y with y % row_stride == row_offset of the (strided) image: one of
    /// row_stride processes' share (MPI ranks); the other rows stay empty.
    int row_offset = 0;
    int row_stride = 1;  ///< see row_offset

    /// Throws grainlight::invalid_argument for out-of-range fields.
    void validate(const char* where) const {
        check_argument(bundle_size >= 1 && bundle_size <= 64, where, "bundle_size", bundle_size, "[1, 64]");
        check_argument(tau > 0.0, where, "tau", tau, "(0, inf] (grain radii)");
        check_argument(min_ept_interactions >= 0, where, "min_ept_interactions", min_ept_interactions, ">= 0");
        check_argument(min_switch_depth >= 0.0 && std::isfinite(min_switch_depth), where, "min_switch_depth", min_switch_depth,
                       "[0, inf) (world units)");
        check_argument(acceptance > 0.0 && acceptance <= 1.0, where, "acceptance", acceptance, "(0, 1]");
        check_argument(max_da_restarts >= 0, where, "max_da_restarts", max_da_restarts, ">= 0");
        check_argument(flight_memory >= 0 && flight_memory <= FlightMemory::capacity, where, "flight_memory", flight_memory,
                       "[0, " + std::to_string(FlightMemory::capacity) + "] (flights)");
        check_argument(flight_memory_flights >= 0, where, "flight_memory_flights", flight_memory_flights, ">= 0");
    }
    /// Whether the VPT part uses flight memory.
    [[nodiscard]] bool uses_flight_memory() const noexcept { return flight_memory > 0 && flight_memory_flights > 0; }
};

/// Per-channel improved diffusion of the effective medium (index-matched boundary, Meng15 App.
/// A: eta = 1) and the switch distance d_DA. One entry per spectrum channel of the render, or one
/// entry (or identical entries) for a grey medium; render_hybrid rejects any other count.
struct HybridDiffusion {
    std::vector<ImprovedDiffusion<double>> channel;  ///< improved diffusion per spectrum channel
    double d_DA = 0;  ///< max over channels of min(1 / sigma_t', 0.5 / sigma_tr)

    /// Every channel has the same parameters.
    [[nodiscard]] bool is_grey() const noexcept {
        for (const auto& d : channel)
            if (d.sigma_s_prime() != channel.front().sigma_s_prime() || d.sigma_a() != channel.front().sigma_a()) return false;
        return true;
    }
    /// Usable by a render with `n` spectrum channels.
    [[nodiscard]] bool compatible_with(std::size_t n) const noexcept {
        return !channel.empty() && (channel.size() == 1 || channel.size() == n || is_grey());
    }
    /// The diffusion of spectrum channel c (requires compatible_with(number of channels)).
    [[nodiscard]] const ImprovedDiffusion<double>& at(std::size_t c) const noexcept {
        return channel[c < channel.size() ? c : 0];
    }
};

/// Diffusion parameters from the effective RTE parameters (Sec. 4.2.3: sigma_s' = (1 - g)
/// alpha_s sigma_t, sigma_a = (1 - alpha_s) sigma_t), eta = 1, one entry per channel of `p`.
[[nodiscard]] inline HybridDiffusion make_hybrid_diffusion(const EffectiveRteParams& p) {
    HybridDiffusion h;
    for (std::size_t c = 0; c < RGBd::size; ++c)
        h.channel.emplace_back(p.sigma_s_reduced[c], p.sigma_a[c], 1.0);
    for (const auto& d : h.channel) h.d_DA = std::max(h.d_DA, d.switch_distance());
    return h;
}

/// Meng15 Eq. 8: the acceptance probability minimising the time to unit variance
/// (V_L + V_H / P_a)(t_L + P_a t_H) of Eqs. 6-7: P_a = sqrt(V_H t_L / (V_L t_H)), clamped to
/// [p_min, 1]. V_L, V_H: variances of one sample's low- and high-order parts (at P_a = 1);
/// t_L, t_H: their costs (any common unit). Degenerate inputs (V_L = 0 or t_H = 0) give 1.
[[nodiscard]] inline double optimal_acceptance(double V_L, double V_H, double t_L, double t_H,
                                               double p_min = 1.0 / 64.0) noexcept {
    if (!(V_L > 0.0) || !(t_H > 0.0)) return 1.0;
    const double p = std::sqrt(std::max(0.0, V_H) * std::max(0.0, t_L) / (V_L * t_H));
    if (!std::isfinite(p)) return 1.0;
    return std::clamp(p, p_min, 1.0);
}

/// Eqs. 6-7: predicted time to unit variance (V_L + V_H / P_a)(t_L + P_a t_H).
[[nodiscard]] inline double predicted_ttuv(double V_L, double V_H, double t_L, double t_H, double P_a) noexcept {
    return (V_L + V_H / P_a) * (t_L + P_a * t_H);
}

/// What the hybrid needs to know about the VPT scene: the index of the effective medium, the
/// index of the aggregate's boundary shape (an index-matched surface enclosing that medium), the
/// distance-to-boundary callable and the diffusion model (ept_vpt_da only).
template <class Distance>
struct HybridContext {
    int medium = 0;                         ///< effective medium index in scene_vpt
    int boundary_shape = 0;                 ///< shape index of the aggregate boundary in scene_vpt
    Distance distance{};                    ///< distance to the boundary (VPT -> DA)
    const HybridDiffusion* diffusion = nullptr;  ///< required for HybridMode::ept_vpt_da
};

/// A closed triangle mesh (e.g. load_obj) as the aggregate boundary of the hybrid: adds the mesh
/// to `scene_vpt` as the index-matched surface enclosing the effective medium `medium` and
/// returns the context whose distance is the mesh's own distance tree (MeshDistance: the VPT ->
/// DA switch asks `ball_inside(x, d_DA)`, i.e. "no triangle within d_DA and x inside", Meng15
/// Sec. 5's kD-tree search). The aggregate is `GranularAggregate<MeshBoundary>` over the same
/// mesh in the same frame (anchor tile 0). Throws grainlight::invalid_argument for a mesh that
/// is not closed and outward-oriented (MeshDistance / MeshBoundary checks) or a bad medium.
template <class SceneT, std::floating_point F>
[[nodiscard]] HybridContext<MeshDistance> add_mesh_boundary(SceneT& scene_vpt, const TriangleMesh<F>& mesh, int medium,
                                                            const HybridDiffusion* diffusion = nullptr) {
    using SF = typename SceneT::Float;
    MeshDistance dist(mesh);
    TriangleMesh<SF> m;
    m.vertices.reserve(mesh.vertices.size());
    for (const auto& v : mesh.vertices) m.vertices.emplace_back(Vec3<SF>(v));
    m.triangles = mesh.triangles;
    m.compute_face_normals();
    const int shape = scene_vpt.add_shape(MeshShape<SF>(m), SceneT::MaterialT::index_matched(), medium, -1);
    return HybridContext<MeshDistance>{medium, shape, std::move(dist), diffusion};
}

/// Counters of a path / bundle.
struct HybridCounters {
    std::uint64_t paths = 0;         ///< camera paths
    std::uint64_t switched = 0;      ///< paths that switched EPT -> VPT (accepted)
    std::uint64_t rejected = 0;      ///< paths pruned by the P_a roulette at the switch
    std::uint64_t switch_depth = 0;  ///< sum of grain interactions in EPT before the switch
    std::uint64_t da = 0;            ///< DA connections
    std::uint64_t grain_rays = 0;    ///< Algorithm 1 traversals
    /// Add another set of counters.
    void merge(const HybridCounters& o) noexcept {
        paths += o.paths;
        switched += o.switched;
        rejected += o.rejected;
        switch_depth += o.switch_depth;
        da += o.da;
        grain_rays += o.grain_rays;
    }
};

// ---------------------------------------------------------------------------------------------
// VPT (+ DA) continuation after the switch
// ---------------------------------------------------------------------------------------------

namespace detail {

/// VPT callbacks plus the DA switch at scattering vertices.
template <LitScene Scene, class Distance>
struct HybridVptCallbacks {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    VptCallbacks<Scene> vpt;
    const HybridContext<Distance>& ctx;
    bool da_enabled = false;
    bool da_pending = false;
    Vec3d da_x{0.0};

    bool on_surface(PathState<F, S>& st, const SurfaceHit<F, S>& hit) noexcept { return vpt.on_surface(st, hit); }
    void on_escape(const PathState<F, S>& st) noexcept { vpt.on_escape(st); }
    template <class M>
    bool on_scatter(PathState<F, S>& st, const Interaction<F, S>& it, const M& m) noexcept {
        if (da_enabled && st.medium == ctx.medium) {
            const Vec3d x(it.p);
            if (ball_inside(ctx.distance, x, ctx.diffusion->d_DA)) {
                da_pending = true;
                da_x = x;
                return false;
            }
        }
        return vpt.on_scatter(st, it, m);
    }
};

}  // namespace detail

/// One DA connection from the interior point x (Meng15 App. A): a uniform direction omega_i from
/// x to the boundary point x_s (which must be the boundary shape `ctx.boundary_shape` of
/// `scene`), weight R_p(r; z_r) 4 pi |x_s - x|^2 / |cos theta_s| per channel, with z_r, r the
/// depth of x below and its offset along the tangent plane of x_s. R_p: with `multipole`, the
/// improved-diffusion multipole of a slab of thickness d = z_r + z_a (z_a: depth of x below the
/// tangent plane at x_a, the boundary hit of an auxiliary ray along -omega_i), else the
/// semi-infinite improved dipole (also when the auxiliary ray misses the boundary). On success
/// returns true and fills `hit` (x_s, outward normal) and `weight`.
template <LitScene Scene, class Distance>
[[nodiscard]] bool sample_diffusion_connection(const Scene& scene, const HybridContext<Distance>& ctx, const Vec3d& x,
                                               Rng& rng, SurfaceHit<typename Scene::Float, typename Scene::Spectrum>& hit,
                                               typename Scene::Spectrum& weight, bool multipole = true) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    const Vec3d w = sample_uniform_sphere(rng.uniform2<double>());
    hit = scene.intersect(Ray<F>(Vec3<F>(x), Vec3<F>(w)));
    if (!hit.hit() || hit.shape != ctx.boundary_shape) return false;
    const Vec3d n = glm::normalize(Vec3d(hit.n));
    const double c = glm::dot(w, n);
    if (!(c > 1e-6)) return false;  // must leave through the boundary from inside
    const double dist = double(hit.t);
    const double z = dist * c;  // depth of x below the tangent plane of x_s
    const double r = std::sqrt(std::max(0.0, dist * dist - z * z));
    const double inv_pdf_area = 4.0 * pi_v<double> * dist * dist / c;
    double thickness = std::numeric_limits<double>::infinity();
    if (multipole) {
        const SurfaceHit<F, S> ha = scene.intersect(Ray<F>(Vec3<F>(x), Vec3<F>(-w)));
        if (ha.hit() && ha.shape == ctx.boundary_shape) {
            const double z_a = glm::dot(Vec3d(ha.p) - x, glm::normalize(Vec3d(ha.n)));
            if (z_a > 0.0) thickness = z + z_a;
        }
    }
    weight = S(F(0));
    for (std::size_t ch = 0; ch < S::size; ++ch) {
        const auto& d = ctx.diffusion->at(ch);
        double Rp;
        if (std::isfinite(thickness)) {
            const MultipoleSlab<double> slab(d.sigma_s_prime(), d.sigma_a(), 1.0, thickness, DiffusionModel::improved);
            Rp = slab.point_R(r, z);
        } else {
            Rp = d.point_R(r, z);
        }
        weight[ch] = F(Rp * inv_pdf_area);
    }
    return true;
}

namespace detail {

/// The VPT walk of `st` with DA restarts (HybridVptCallbacks): walks while `walk_on`, and at
/// every pending DA vertex makes a diffusion connection (sample_diffusion_connection), gathers
/// at the boundary point like a white Lambertian vertex and walks on out of the medium.
/// Returns the radiance; `*da_part` (if given) receives the part gathered after the first DA
/// connection (Meng15 Fig. 12's DA contribution).
template <LitScene Scene, class Distance>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] typename Scene::Spectrum hybrid_walk_with_da(const Scene& scene_vpt, const HybridContext<Distance>& ctx,
                                                           HybridVptCallbacks<Scene, Distance>& cb,
                                                           PathState<typename Scene::Float, typename Scene::Spectrum>& st,
                                                           bool walk_on, Rng& rng, const HybridOptions& opt,
                                                           const WalkOptions<typename Scene::Float>& wopt,
                                                           HybridCounters* counters,
                                                           typename Scene::Spectrum* da_part) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    constexpr F inf = std::numeric_limits<F>::infinity();
    bool any_da = false;
    S before_da(F(0));
    for (int restarts = 0;; ++restarts) {
        if (walk_on) {
            const WalkEnd e = walk(scene_vpt, st, rng, cb, wopt);
            if (e != WalkEnd::stopped || !cb.da_pending) break;
        }
        walk_on = true;
        if (!cb.da_pending || restarts >= opt.max_da_restarts) break;
        cb.da_pending = false;
        if (counters) ++counters->da;
        if (!any_da) {
            any_da = true;
            before_da = cb.vpt.L;
        }
        // DA: move to a boundary point with the diffusion weight, gather there as a white
        // Lambertian vertex (NEE + MIS), leave the medium along a cosine-sampled direction.
        SurfaceHit<F, S> h;
        S w;
        if (!sample_diffusion_connection(scene_vpt, ctx, cb.da_x, rng, h, w, opt.multipole)) break;
        st.throughput *= w;
        if (st.throughput.is_black()) break;
        const Vec3<F> n = glm::normalize(h.n);
        SurfaceHit<F, S> lam = h;
        lam.type = SurfaceType::diffuse;
        lam.reflectance = S(F(1));
        lam.light = -1;
        st.ray = Ray<F>(Vec3<F>(cb.da_x), -n, inf, st.ray.cone);  // arriving from inside: faces n
        st.medium = h.medium_outside;                               // NEE leaves the medium
        (void)cb.vpt.on_surface(st, lam);
        const Vec3<F> local = sample_cosine_hemisphere(rng.uniform2<F>());
        const Vec3<F> wo = glm::normalize(Frame<F>(n).to_world(local));
        st.ray = Ray<F>(offset_ray_origin(h.p, n, wo), wo, inf, st.ray.cone);
        st.medium = h.medium_outside;
        st.specular = false;
        st.last_pdf = cosine_hemisphere_pdf(local.z);
        st.last_p = h.p;
        if (++st.depth > wopt.max_depth) break;
    }
    if (da_part) *da_part = any_da ? S(cb.vpt.L - before_da) : S(F(0));
    return cb.vpt.L;
}

}  // namespace detail

namespace detail {

/// hybrid_vpt_continuation on `scene_vpt` as given (a scene or a FlightMemoryScene view).
template <LitScene Scene, class Distance>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] typename Scene::Spectrum hybrid_vpt_continuation_impl(const Scene& scene_vpt, const HybridContext<Distance>& ctx,
                                                                    const Vec3d& x, const Vec3d& d,
                                                                    const typename Scene::Spectrum& beta, Rng& rng,
                                                                    const HybridOptions& opt, HybridCounters* counters,
                                                                    typename Scene::Spectrum* da_part) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    using M = typename Scene::Medium;
    constexpr F inf = std::numeric_limits<F>::infinity();
    const M& m = scene_vpt.medium(ctx.medium);
    detail::HybridVptCallbacks<Scene, Distance> cb{VptCallbacks<Scene>{scene_vpt, rng, opt.vpt}, ctx};
    cb.da_enabled = hybrid_uses_da(opt.mode) && ctx.diffusion != nullptr;
    WalkOptions<F> wopt;
    wopt.max_depth = opt.vpt.max_depth;
    wopt.rr_depth = opt.vpt.rr_depth;
    wopt.mode = TransportMode::radiance;
    if (da_part) *da_part = S(F(0));

    PathState<F, S> st = start_path<F, S>(Ray<F>(Vec3<F>(x), Vec3<F>(d)), ctx.medium, beta);
    if constexpr (requires { m.albedo(); }) st.throughput *= m.albedo();
    Interaction<F, S> it;
    it.kind = EventKind::scatter;
    it.p = Vec3<F>(x);
    it.nee = NeeKind::phase;
    st.depth = 1;
    bool walk_on = true;
    if (cb.da_enabled && ball_inside(ctx.distance, x, ctx.diffusion->d_DA)) {  // test in double precision
        cb.da_pending = true;
        cb.da_x = x;
        walk_on = false;
    } else {
        walk_on = cb.on_scatter(st, it, m);
    }
    if (walk_on) {
        const auto ps = m.phase().sample(Vec3<F>(d), rng.uniform2<F>());
        if (!ps) return cb.vpt.L;
        st.throughput *= ps.weight;
        st.ray = Ray<F>(Vec3<F>(x), ps.w, inf, st.ray.cone);
        st.specular = false;
        st.last_pdf = ps.pdf;
        st.last_p = Vec3<F>(x);
    }
    return detail::hybrid_walk_with_da(scene_vpt, ctx, cb, st, walk_on, rng, opt, wopt, counters, da_part);
}

}  // namespace detail

/// The high-order part of a path after the switch: from the grain hit x (direction of arrival d,
/// throughput beta) in the effective medium `ctx.medium` of `scene_vpt`: the grain interaction
/// becomes a scattering event of the effective medium (albedo, NEE, phase sampling), then VPT,
/// and (modes with DA) DA connections deep inside. Returns the radiance; counts DA connections
/// in `counters`; `*da_part` (if given) receives the part gathered after the first DA
/// connection (the DA contribution; the rest is VPT's). `history`: the path's flights before
/// the switch and the grain radius (FlightMemory; the last flight ends at x); with it and
/// `opt.uses_flight_memory()`, the VPT's first `opt.flight_memory_flights` flights remember the
/// `opt.flight_memory` most recent flights (FlightMemoryScene); without it, memoryless VPT.
template <LitScene Scene, class Distance, class Region = AnyCentre>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] typename Scene::Spectrum hybrid_vpt_continuation(const Scene& scene_vpt, const HybridContext<Distance>& ctx,
                                                               const Vec3d& x, const Vec3d& d,
                                                               const typename Scene::Spectrum& beta, Rng& rng,
                                                               const HybridOptions& opt,
                                                               HybridCounters* counters = nullptr,
                                                               typename Scene::Spectrum* da_part = nullptr,
                                                               const FlightMemory* history = nullptr,
                                                               const Region& region = {}) noexcept {
    if constexpr (requires(const typename Scene::Medium& m) {
                      m.sigma_t();
                      m.albedo();
                  }) {
        if (history && opt.uses_flight_memory()) {
            FlightMemory mem = *history;
            mem.forget_region();
            mem.remembered = opt.flight_memory;
            mem.flights_left = opt.flight_memory_flights;
            if constexpr (Region::constrains) {
                if (opt.flight_memory_boundary) {
                    const FlightMemoryScene<Scene, Region> view(scene_vpt, ctx.medium, &mem, region);
                    return detail::hybrid_vpt_continuation_impl(view, ctx, x, d, beta, rng, opt, counters, da_part);
                }
            }
            const FlightMemoryScene<Scene> view(scene_vpt, ctx.medium, &mem);
            return detail::hybrid_vpt_continuation_impl(view, ctx, x, d, beta, rng, opt, counters, da_part);
        }
    }
    return detail::hybrid_vpt_continuation_impl(scene_vpt, ctx, x, d, beta, rng, opt, counters, da_part);
}

/// A camera path of the VPT-only modes (HybridMode::vpt, vpt_da; Meng15 Fig. 11's "VPT" and
/// "VPT+DA"): `ray` starts in vacuum (medium -1) in `scene_vpt` and enters the effective medium
/// through the index-matched boundary; VPT with DA connections deep inside when the mode has
/// DA. Returns the radiance; `*da_part` as in hybrid_vpt_continuation.
template <LitScene Scene, class Distance>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] typename Scene::Spectrum hybrid_vpt_camera_path(const Scene& scene_vpt, const HybridContext<Distance>& ctx,
                                                              const Ray<typename Scene::Float>& ray, Rng& rng,
                                                              const HybridOptions& opt, HybridCounters* counters = nullptr,
                                                              typename Scene::Spectrum* da_part = nullptr) noexcept {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    detail::HybridVptCallbacks<Scene, Distance> cb{VptCallbacks<Scene>{scene_vpt, rng, opt.vpt}, ctx};
    cb.da_enabled = hybrid_uses_da(opt.mode) && ctx.diffusion != nullptr;
    WalkOptions<F> wopt;
    wopt.max_depth = opt.vpt.max_depth;
    wopt.rr_depth = opt.vpt.rr_depth;
    wopt.mode = TransportMode::radiance;
    PathState<F, S> st = start_path<F, S>(ray, -1);
    return detail::hybrid_walk_with_da(scene_vpt, ctx, cb, st, true, rng, opt, wopt, counters, da_part);
}

/// Radiance (mean over directions, as seen by a scattering vertex) at an interior point x
/// estimated by one DA connection: the quantity the VPT -> DA switch adds at a vertex of
/// throughput 1 (tests: deep inside a half-space under a constant sky it is
/// L_sky int R_p dA = L_sky ImprovedDiffusion::point_total(z)).
template <LitScene Scene, class Distance>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] typename Scene::Spectrum diffusion_radiance(const Scene& scene_vpt, const HybridContext<Distance>& ctx,
                                                          const Vec3d& x, Rng& rng, bool multipole = true,
                                                          const VptOptions& vopt = {}) noexcept {
    using S = typename Scene::Spectrum;
    using F = typename Scene::Float;
    HybridOptions opt;
    opt.mode = HybridMode::ept_vpt_da;
    opt.multipole = multipole;
    opt.vpt = vopt;
    // A continuation whose first vertex is x with unit weight: undo the albedo of the first event.
    S beta(F(1));
    const auto& m = scene_vpt.medium(ctx.medium);
    if constexpr (requires { m.albedo(); })
        for (std::size_t c = 0; c < S::size; ++c) beta[c] = m.albedo()[c] > F(0) ? F(1) / m.albedo()[c] : F(0);
    if (!(ctx.diffusion && ball_inside(ctx.distance, x, ctx.diffusion->d_DA))) return S(F(0));
    return hybrid_vpt_continuation(scene_vpt, ctx, x, Vec3d(0, 0, 1), beta, rng, opt);
}

// ---------------------------------------------------------------------------------------------
// EPT in lock-step bundles (Eq. 5)
// ---------------------------------------------------------------------------------------------

/// Radiance of one camera path of a hybrid bundle: the EPT part (low order) and the part after
/// the (possibly virtual) switch (high order).
template <class S>
struct HybridPathRadiance {
    S low{0.0f};            ///< radiance gathered in EPT before the switch
    S high{0.0f};           ///< radiance gathered after the (possibly virtual) switch
    S da{0.0f};             ///< the part of `high` gathered after a DA connection
    bool switched = false;  ///< switched (or, in mode ept, reached the would-be switch)
    int switch_order = 0;   ///< grain interactions in EPT before the switch
    Vec3d switch_point{0.0};  ///< the grain hit where the path switched (valid when `switched`)
};

/// A bundle's result: per-path radiances and the CPU seconds of the two parts.
template <class S, int NMax = 64>
struct HybridBundleResult {
    std::array<HybridPathRadiance<S>, NMax> path{};  ///< per-path radiances (first n used)
    int n = 0;                                       ///< paths in the bundle
    double seconds_low = 0;                          ///< steady-clock seconds of the EPT part
    double seconds_high = 0;                         ///< steady-clock seconds of the part after the switch
    HybridCounters counters{};                       ///< switch / DA counters
    /// Mean over the bundle's paths of the low / high / total radiance.
    [[nodiscard]] S mean_low() const noexcept {
        S s(typename S::value_type(0));
        for (int i = 0; i < n; ++i) s += path[std::size_t(i)].low;
        return s / typename S::value_type(n);
    }
    /// Mean over the bundle's paths of the high-order radiance.
    [[nodiscard]] S mean_high() const noexcept {
        S s(typename S::value_type(0));
        for (int i = 0; i < n; ++i) s += path[std::size_t(i)].high;
        return s / typename S::value_type(n);
    }
    /// Mean over the bundle's paths of the DA part of the high-order radiance.
    [[nodiscard]] S mean_da() const noexcept {
        S s(typename S::value_type(0));
        for (int i = 0; i < n; ++i) s += path[std::size_t(i)].da;
        return s / typename S::value_type(n);
    }
};

/// Eq. 5's coherence measure: sigma_k = sqrt(1/N_k sum |x_i - mean|^2) of the given points.
[[nodiscard]] inline double bundle_spread(const Vec3d* x, int n) noexcept {
    if (n <= 0) return 0.0;
    Vec3d m(0.0);
    for (int i = 0; i < n; ++i) m += x[i];
    m /= double(n);
    double s = 0;
    for (int i = 0; i < n; ++i) s += glm::dot(x[i] - m, x[i] - m);
    return std::sqrt(s / double(n));
}

/// Trace one bundle of `n` camera paths (rays[i] with generators rngs[i], all of one pixel) in
/// lock-step through the EPT scene `scene_ept` (lights and surfaces; the aggregate is not one of
/// its shapes) containing `agg`, switching to VPT/DA in `scene_vpt` (see the file comment).
/// n in [1, 64].
template <LitScene Scene, BoundaryShape Shape, class Distance>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] HybridBundleResult<typename Scene::Spectrum> hybrid_bundle(
    const Scene& scene_ept, const Scene& scene_vpt, const GranularAggregate<Shape>& agg,
    const HybridContext<Distance>& ctx, const Ray<typename Scene::Float>* rays, Rng* rngs, int n,
    const HybridOptions& opt) noexcept {
    using S = typename Scene::Spectrum;
    using Clock = std::chrono::steady_clock;
    HybridBundleResult<S> res;
    n = std::clamp(n, 1, 64);
    res.n = n;
    res.counters.paths = std::uint64_t(n);
    // The EPT prefix of every path is ept_step itself (NeverSwitch until the bundle is armed).
    std::array<EptPathState<S>, 64> ps;
    std::array<bool, 64> path_alive{};
    for (int i = 0; i < n; ++i) {
        ps[std::size_t(i)] = EptPathState<S>::start(rays[i], std::numeric_limits<int>::max());
        path_alive[std::size_t(i)] = true;
    }
    const double tau = opt.tau * agg.grain_radius();
    bool armed = false;
    double t_high = 0;
    const auto t0 = opt.measure_time ? Clock::now() : Clock::time_point{};
    if (!hybrid_uses_ept(opt.mode)) {
        // Fig. 11's VPT and VPT+DA: no grains; the whole path is the "high-order" part.
        for (int i = 0; i < n; ++i) {
            auto& path = res.path[std::size_t(i)];
            path.high = hybrid_vpt_camera_path(scene_vpt, ctx, rays[i], rngs[i], opt, &res.counters, &path.da);
        }
        if (opt.measure_time) res.seconds_high = std::chrono::duration<double>(Clock::now() - t0).count();
        return res;
    }
    int alive = n;
    std::array<Vec3d, 64> xs;
    // Each path's recent flights (ending at grain hits), for the VPT's flight memory.
    const bool memory = opt.uses_flight_memory() && opt.mode != HybridMode::ept;
    std::array<FlightMemory, 64> history;
    if (memory)
        for (int i = 0; i < n; ++i) history[std::size_t(i)].radius = agg.grain_radius();
    while (alive > 0) {
        for (int i = 0; i < n; ++i) {
            auto& q = ps[std::size_t(i)];
            if (!path_alive[std::size_t(i)]) continue;
            auto& path = res.path[std::size_t(i)];
            Vec3d x_switch(0.0);
            // Eq. 5 switch at the next grain hit of an armed bundle, inside the boundary.
            auto policy = [&](const EptPathState<S>& st, const Vec3d& x, bool same) {
                if (memory && !same) history[std::size_t(i)].push(st.p, x);
                if (!armed || st.high || same || st.order < opt.min_ept_interactions || !agg.boundary().shape().inside(x))
                    return EptSwitch::stay;
                if (opt.min_switch_depth > 0.0 && !ball_inside(ctx.distance, x, opt.min_switch_depth)) return EptSwitch::stay;
                path.switched = true;
                path.switch_order = st.order;
                path.switch_point = x;
                // Mode ept: only the split changes.
                return opt.mode != HybridMode::ept ? EptSwitch::switch_here : EptSwitch::high_from_here;
            };
            // Mode ept: the steps after the would-be switch are the high-order part's cost.
            const bool time_step = opt.measure_time && opt.mode == HybridMode::ept && q.high;
            const auto ts0 = time_step ? Clock::now() : Clock::time_point{};
            const EptStep r = ept_step(scene_ept, agg, q, path.low, path.high, res.counters.grain_rays, rngs[i], opt.ept,
                                       policy, x_switch);
            if (time_step) t_high += std::chrono::duration<double>(Clock::now() - ts0).count();
            if (r == EptStep::next) continue;
            path_alive[std::size_t(i)] = false;
            if (r == EptStep::switch_here) {
                // P_a roulette, then the VPT (+ DA) continuation.
                Rng& rng = rngs[i];
                if (opt.acceptance < 1.0 && rng.uniform<double>() >= opt.acceptance) {
                    ++res.counters.rejected;
                    continue;
                }
                ++res.counters.switched;
                res.counters.switch_depth += std::uint64_t(res.path[std::size_t(i)].switch_order);
                const S beta = q.beta / typename S::value_type(opt.acceptance);
                const auto th0 = opt.measure_time ? Clock::now() : Clock::time_point{};
                S da_part(0.0f);
                res.path[std::size_t(i)].high +=
                    hybrid_vpt_continuation(scene_vpt, ctx, x_switch, q.d, beta, rng, opt, &res.counters, &da_part,
                                            memory ? &history[std::size_t(i)] : nullptr,
                                            CentresInside<Shape, Distance>{&agg.boundary().shape(), &ctx.distance});
                res.path[std::size_t(i)].da += da_part;
                if (opt.measure_time) t_high += std::chrono::duration<double>(Clock::now() - th0).count();
            }
        }
        // Eq. 5 on the vertices of the paths still in EPT.
        int nk = 0;
        for (int i = 0; i < n; ++i)
            if (path_alive[std::size_t(i)]) xs[std::size_t(nk++)] = ps[std::size_t(i)].p;
        alive = nk;
        if (!armed && nk > 0) {
            if (nk == 1 && opt.switch_single && n > 1)
                armed = true;
            else if (bundle_spread(xs.data(), nk) > tau * double(nk) / double(n))
                armed = true;
            else if (n == 1 && opt.switch_single)
                armed = true;
        }
    }
    if (opt.measure_time) {
        const double total = std::chrono::duration<double>(Clock::now() - t0).count();
        res.seconds_high = t_high;
        res.seconds_low = std::max(0.0, total - t_high);
    }
    if (opt.mode == HybridMode::ept)
        for (int i = 0; i < n; ++i)
            if (res.path[std::size_t(i)].switched) {
                ++res.counters.switched;
                res.counters.switch_depth += std::uint64_t(res.path[std::size_t(i)].switch_order);
            }
    return res;
}

// ---------------------------------------------------------------------------------------------
// Render driver with time to unit variance
// ---------------------------------------------------------------------------------------------

/// Result of a hybrid render: low-order (EPT) and high-order (after the switch) images, the
/// per-pixel variance statistics of the bundle samples and the CPU time of the two parts.
struct HybridImages {
    /// low: the EPT part (Fig. 12's EPT contribution); high: everything after the switch (VPT +
    /// DA; in the VPT-only modes the whole image).
    Film low;
    Film high;  ///< see `low`
    /// The part of `high` gathered after a DA connection (Fig. 12's DA contribution).
    Film da;
    /// Per pixel: mean number of EPT grain interactions before the switch over the paths that
    /// switched (0 where none did), in all three channels (Meng15 Fig. 12's switch-depth view).
    Image switch_depth;
    int spp = 0;                    ///< bundles per pixel
    double var_total = 0;           ///< mean over pixels of the sample variance of one bundle estimate (channel mean)
    double var_low = 0;   ///< the same for the low-order (EPT) part
    double var_high = 0;  ///< the same for the high-order part
    double m2_high = 0;             ///< mean over pixels of the second moment E[H^2] of the high-order part
    /// Standard error of var_total (spread of the per-pixel variances over the pixels / sqrt(pixels)).
    double var_total_se = 0;
    /// Per pixel: sample variance of one bundle estimate, total / low / high order (channels 0-2).
    Image pixel_variance;
    /// Per pixel: E[H^2] of the high-order part of one bundle estimate (channel 0).
    Image pixel_m2_high;
    double cpu_seconds_low = 0;   ///< thread CPU seconds of the low-order part, summed over threads
    double cpu_seconds_high = 0;  ///< the same for the high-order part
    HybridCounters counters{};    ///< switch / DA counters of the render
    HybridMode mode = HybridMode::ept_vpt;  ///< the techniques of the render
    /// The image: low + high.
    [[nodiscard]] Image combined() const {
        Image a = low.image();
        const Image b = high.image();
        for (std::size_t i = 0; i < a.rgb.size(); ++i) a.rgb[i] += b.rgb[i];
        return a;
    }
    /// Fig. 12's per-technique contributions: EPT (low; in mode ept the whole image).
    [[nodiscard]] Image ept_image() const { return mode == HybridMode::ept ? combined() : low.image(); }
    /// VPT's contribution: high order minus the DA part (0 in mode ept).
    [[nodiscard]] Image vpt_image() const {
        if (mode == HybridMode::ept) return Image(high.width(), high.height());
        Image a = high.image();
        const Image b = da.image();
        for (std::size_t i = 0; i < a.rgb.size(); ++i) a.rgb[i] -= b.rgb[i];
        return a;
    }
    /// DA's contribution.
    [[nodiscard]] Image da_image() const { return da.image(); }
    /// CPU seconds per bundle sample per pixel (the time of a 1-spp image).
    [[nodiscard]] double seconds_per_spp() const noexcept {
        return spp > 0 ? (cpu_seconds_low + cpu_seconds_high) / double(spp) : 0.0;
    }
    /// Meng15 Sec. 6: time to unit variance = mean pixel variance of a 1-spp image x its time.
    [[nodiscard]] double ttuv() const noexcept { return var_total * seconds_per_spp(); }
    /// The same for the high-order part alone (Table 2, right half).
    [[nodiscard]] double ttuv_high() const noexcept { return spp > 0 ? var_high * cpu_seconds_high / double(spp) : 0.0; }
    /// The same for the low-order part alone.
    [[nodiscard]] double ttuv_low() const noexcept { return spp > 0 ? var_low * cpu_seconds_low / double(spp) : 0.0; }
};

/// What render_hybrid_films renders: the 8 films of the row driver (HybridFilms::Slot: the low /
/// high / DA images, then per-pixel statistics and per-row CPU times and counters as exact
/// doubles), everything summarize_hybrid needs. The seam for splitting a render over processes:
/// each renders its rows (HybridOptions::row_offset / row_stride), the films' rows are assembled
/// (a placement, no sum: the rows are disjoint), then summarized once, so the summary is the
/// same as a single process's.
struct HybridFilms {
    /// Film slots.
    enum Slot : int { low, high, da, var, m2_depth, seconds, count_a, count_b, slots };
    std::vector<Film> films;                ///< `slots` films of equal size
    int spp = 0;                            ///< bundles per pixel
    HybridMode mode = HybridMode::ept_vpt;  ///< the techniques of the render
};

namespace detail {
/// The film slots of HybridFilms under the names render_hybrid_films and summarize_hybrid use.
enum HybridFilmIndex : int {
    f_low = HybridFilms::low,
    f_high = HybridFilms::high,
    f_da = HybridFilms::da,
    f_var = HybridFilms::var,
    f_m2_depth = HybridFilms::m2_depth,
    f_seconds = HybridFilms::seconds,
    f_count_a = HybridFilms::count_a,
    f_count_b = HybridFilms::count_b,
    n_films = HybridFilms::slots
};
}  // namespace detail

/// Render with the hybrid integrator: every `stride`-th pixel in x and y (stride 1: the full
/// image; the result then has ceil(w / stride) x ceil(h / stride) pixels, each the centre pixel
/// of its block with the original footprint), `spp` bundles of opt.bundle_size paths per pixel.
/// Path i of bundle b of pixel p uses Pcg32::from_key(seed, p, b * N + i) (p = full-image pixel
/// index): images are bit-identical for any thread count. Rows over OpenMP threads. Returns the
/// raw films (render_hybrid = summarize_hybrid of these).
template <LitScene Scene, BoundaryShape Shape, class Distance, class Camera, class Progress = NoProgress>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] HybridFilms render_hybrid_films(const Scene& scene_ept, const Scene& scene_vpt, const GranularAggregate<Shape>& agg,
                                         const HybridContext<Distance>& ctx, const Camera& camera, int spp,
                                         std::uint64_t seed, int threads, HybridOptions opt, int stride = 1,
                                         Progress&& progress = {}) {
    check_argument(spp >= 1, "render_hybrid", "spp", spp, ">= 1");
    check_argument(threads >= 0, "render_hybrid", "threads", threads, ">= 0");
    check_argument(stride >= 1, "render_hybrid", "stride", stride, ">= 1");
    opt.validate("render_hybrid");
    check_argument(!hybrid_uses_da(opt.mode) || ctx.diffusion != nullptr, "render_hybrid", "ctx.diffusion",
                   "null", "a HybridDiffusion for the modes with DA (ept_vpt_da, vpt_da)");
    check_argument(ctx.medium >= 0, "render_hybrid", "ctx.medium", ctx.medium, ">= 0");
    using F = typename Camera::Float;
    using S = typename Scene::Spectrum;
    check_material_channels(agg, S::size, "render_hybrid");
    if (hybrid_uses_da(opt.mode))
        check_argument(ctx.diffusion->compatible_with(S::size), "render_hybrid", "ctx.diffusion channels",
                       ctx.diffusion->channel.size(), "1 (grey) or " + std::to_string(S::size) + " (the spectrum's channels)");
    opt.measure_time = true;
    const int W = camera.width(), H = camera.height();
    const int w = (W + stride - 1) / stride, h = (H + stride - 1) / stride;
    const int N = opt.bundle_size;
    // The row driver (render_rows: threads, row shares, checkpoints) renders into 8 films: the
    // low / high / DA images, then per-pixel statistics as exact doubles (add_rgb once per pixel):
    // (var_total, var_low, var_high), (E[H^2], mean switch depth, 0); per row at pixel (0, y): (CPU
    // seconds low, high, 0) and the counters. Everything the summary below needs is in the films,
    // so a resumed render (checkpointed films) gives the same result as an uninterrupted one.
    using enum detail::HybridFilmIndex;
    RenderOptions ro;
    ro.spp = spp;
    ro.seed = seed;
    ro.threads = threads;
    ro.checkpoint = opt.checkpoint;
    ro.row_offset = opt.row_offset;
    ro.row_stride = opt.row_stride;
    std::vector<Film> films = render_rows(
        w, h, n_films, ro,
        [&](int y, std::span<Film> f) {
            const double cpu0 = detail::thread_cpu_seconds();
            double wall_l = 0, wall_h = 0;
            HybridCounters rc{};
            std::array<Ray<F>, 64> rays;
            std::array<Rng, 64> rngs;
            for (int x = 0; x < w; ++x) {
                const int X = std::min(W - 1, x * stride + stride / 2), Y = std::min(H - 1, y * stride + stride / 2);
                const std::uint64_t pixel = std::uint64_t(Y) * std::uint64_t(W) + std::uint64_t(X);
                Welford wt, wl, wh;
                double depth_sum = 0, depth_n = 0;
                for (int s = 0; s < spp; ++s) {
                    for (int i = 0; i < N; ++i) {
                        rngs[std::size_t(i)] =
                            Rng::from_key(seed, pixel, std::uint64_t(s) * std::uint64_t(N) + std::uint64_t(i));
                        const Vec2<F> u = rngs[std::size_t(i)].template uniform2<F>();
                        rays[std::size_t(i)] = camera.generate_ray(F(X) + u.x, F(Y) + u.y);
                    }
                    const auto b = hybrid_bundle(scene_ept, scene_vpt, agg, ctx, rays.data(), rngs.data(), N, opt);
                    for (int i = 0; i < N; ++i)
                        if (b.path[std::size_t(i)].switched) {
                            depth_sum += double(b.path[std::size_t(i)].switch_order);
                            depth_n += 1;
                        }
                    S lo = b.mean_low(), hi = b.mean_high(), da = b.mean_da();
                    // Non-finite bundle means are counted per pixel (Film::nonfinite_samples), then zeroed.
                    if (!lo.is_finite()) {
                        f[f_low].add_nonfinite(x, y);
                        lo = S(0.0f);
                    }
                    if (!hi.is_finite()) {
                        f[f_high].add_nonfinite(x, y);
                        hi = S(0.0f);
                        da = S(0.0f);
                    }
                    if (!da.is_finite()) {
                        f[f_da].add_nonfinite(x, y);
                        da = S(0.0f);
                    }
                    f[f_low].add_sample(x, y, lo);
                    f[f_high].add_sample(x, y, hi);
                    f[f_da].add_sample(x, y, da);
                    wl.add(double(lo.average()));
                    wh.add(double(hi.average()));
                    wt.add(double(lo.average()) + double(hi.average()));
                    wall_l += b.seconds_low;
                    wall_h += b.seconds_high;
                    rc.merge(b.counters);
                }
                f[f_var].add_rgb(x, y, wt.variance(), wl.variance(), wh.variance());
                f[f_m2_depth].add_rgb(x, y, wh.variance() + wh.mean() * wh.mean(), depth_n > 0 ? depth_sum / depth_n : 0.0,
                                      0.0);
            }
            // The row's thread CPU time, split between the two parts in the ratio of their
            // steady-clock times measured inside the bundles.
            const double cpu = std::max(0.0, detail::thread_cpu_seconds() - cpu0);
            const double wall = wall_l + wall_h;
            f[f_seconds].add_rgb(0, y, wall > 0 ? cpu * wall_l / wall : cpu, wall > 0 ? cpu * wall_h / wall : 0.0, 0.0);
            f[f_count_a].add_rgb(0, y, double(rc.paths), double(rc.switched), double(rc.rejected));
            f[f_count_b].add_rgb(0, y, double(rc.switch_depth), double(rc.da), double(rc.grain_rays));
        },
        std::forward<Progress>(progress));
    return HybridFilms{std::move(films), spp, opt.mode};
}

/// The images and summary (variances, CPU times, counters) of a hybrid render from its films.
/// Per-row sums in x order, then rows in order: the same for any thread count, resume or row split.
[[nodiscard]] inline HybridImages summarize_hybrid(HybridFilms hf) {
    check_argument(hf.films.size() == std::size_t(HybridFilms::slots), "summarize_hybrid", "films", hf.films.size(),
                   std::to_string(int(HybridFilms::slots)));
    std::vector<Film>& films = hf.films;
    const int w = films[0].width(), h = films[0].height();
    using enum detail::HybridFilmIndex;
    HybridImages img;
    img.switch_depth = Image(w, h);
    img.spp = hf.spp;
    img.mode = hf.mode;
    img.pixel_variance = Image(w, h);
    img.pixel_m2_high = Image(w, h);
    auto raw = [&](int k, int x, int y, int c) {
        return films[std::size_t(k)].sums()[3 * (std::size_t(y) * std::size_t(w) + std::size_t(x)) + std::size_t(c)];
    };
    double var_t2 = 0;
    for (int y = 0; y < h; ++y) {
        double var_t = 0, var_t2_row = 0, var_l = 0, var_h = 0, m2_h = 0;
        for (int x = 0; x < w; ++x) {
            const double vt = raw(f_var, x, y, 0), vl = raw(f_var, x, y, 1), vh = raw(f_var, x, y, 2);
            const double m2 = raw(f_m2_depth, x, y, 0), depth = raw(f_m2_depth, x, y, 1);
            var_t += vt;
            var_t2_row += vt * vt;
            var_l += vl;
            var_h += vh;
            m2_h += m2;
            img.pixel_variance.at(x, y, 0) = float(vt);
            img.pixel_variance.at(x, y, 1) = float(vl);
            img.pixel_variance.at(x, y, 2) = float(vh);
            img.pixel_m2_high.at(x, y, 0) = float(m2);
            for (int c = 0; c < 3; ++c) img.switch_depth.at(x, y, c) = float(depth);
        }
        var_t2 += var_t2_row;
        img.var_total += var_t;
        img.var_low += var_l;
        img.var_high += var_h;
        img.m2_high += m2_h;
        img.cpu_seconds_low += raw(f_seconds, 0, y, 0);
        img.cpu_seconds_high += raw(f_seconds, 0, y, 1);
        HybridCounters rc;
        rc.paths = std::uint64_t(raw(f_count_a, 0, y, 0));
        rc.switched = std::uint64_t(raw(f_count_a, 0, y, 1));
        rc.rejected = std::uint64_t(raw(f_count_a, 0, y, 2));
        rc.switch_depth = std::uint64_t(raw(f_count_b, 0, y, 0));
        rc.da = std::uint64_t(raw(f_count_b, 0, y, 1));
        rc.grain_rays = std::uint64_t(raw(f_count_b, 0, y, 2));
        img.counters.merge(rc);
    }
    img.low = std::move(films[f_low]);
    img.high = std::move(films[f_high]);
    img.da = std::move(films[f_da]);
    const double np = double(w) * double(h);
    img.var_total /= np;
    img.var_total_se = np > 1 ? std::sqrt(std::max(0.0, var_t2 / np - img.var_total * img.var_total) / (np - 1)) : 0.0;
    img.var_low /= np;
    img.var_high /= np;
    img.m2_high /= np;
    return img;
}

/// Render with the hybrid integrator (render_hybrid_films, then summarize_hybrid).
template <LitScene Scene, BoundaryShape Shape, class Distance, class Camera, class Progress = NoProgress>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] HybridImages render_hybrid(const Scene& scene_ept, const Scene& scene_vpt, const GranularAggregate<Shape>& agg,
                                         const HybridContext<Distance>& ctx, const Camera& camera, int spp,
                                         std::uint64_t seed, int threads, HybridOptions opt, int stride = 1,
                                         Progress&& progress = {}) {
    return summarize_hybrid(render_hybrid_films(scene_ept, scene_vpt, agg, ctx, camera, spp, seed, threads, std::move(opt), stride,
                                                std::forward<Progress>(progress)));
}

/// The preview of Meng15 Sec. 5 for P_a: V_L, V_H (mean pixel variances of the low- and
/// high-order parts of one bundle sample), t_L, t_H (CPU seconds of the two parts per bundle
/// sample per pixel) and P_a of Eq. 8.
struct AcceptanceEstimate {
    double V_L = 0;  ///< variance of the low-order part of one sample
    double V_H = 0;  ///< variance of the high-order part of one sample
    double t_L = 0;  ///< CPU seconds of the low-order part per sample
    double t_H = 0;  ///< CPU seconds of the high-order part per sample
    double P_a = 1;  ///< Eq. 8 (Meng15)
    /// Eq. 8 with the exact variance of the roulette estimator L + H 1{u < P_a} / P_a:
    /// Var = (V - E[H^2]) + E[H^2] / P_a (V = total variance at P_a = 1), i.e. Eq. 8 with
    /// V_L -> V - E[H^2], V_H -> E[H^2]. Eq. 6 neglects (1 / P_a - 1) E[H]^2 and the low/high
    /// covariance; this one does not.
    double P_a_moments = 1;
    /// The acceptance that never loses (what render drivers should use; docs/meng15_hybrid.md):
    /// P_a_robust below when its predicted gain is resolved and worth a render of its own, i.e.
    /// gain - 2 gain_se > min_gain (robust_acceptance; default 1.1), else 1.
    double P_a_safe = 1;
    /// Eq. 8, moments form, on robust preview moments: the preview pixels are split into 8
    /// interleaved groups and V, E[H^2] are the means of the group means without the largest
    /// and the smallest (one glint in one pixel cannot dominate).
    double P_a_robust = 1;
    double gain = 1;     ///< predicted ttuv(P_a = 1) / ttuv(P_a_robust) (exact roulette variance x Eq. 7)
    double gain_se = 0;  ///< its jackknife standard error over the 8 groups
    double V_robust = 0;   ///< robust total variance V of one sample at P_a = 1
    double M_robust = 0;   ///< robust E[H^2] of one sample (P_a_robust = Eq. 8 with V_L = V - M, V_H = M)
};

/// Smallest predicted ttuv gain (after subtracting two of its standard errors) for which
/// P_a_safe leaves P_a = 1. The jackknife error covers the preview's pixel noise, not the model:
/// the two parts' CPU times come from the preview, and two renders of the same image differ in
/// CPU time by up to ~10 % on a shared machine (meng15_table2_ttuv on the sandcastle at full:
/// predicted gains 1.02-1.03 measured as 0.90-1.20). A gain below that is not worth a render.
inline constexpr double kAcceptanceMinGain = 1.1;

/// The robust and the safe acceptance (AcceptanceEstimate::P_a_robust, P_a_safe, gain,
/// gain_se) from a preview rendered at P_a = 1 (its per-pixel variances) and the per-sample
/// costs t_L, t_H of its two parts. Fills those four fields of `a`. `min_gain`: P_a_safe is
/// P_a_robust only if gain - 2 gain_se > min_gain (>= 1).
inline void robust_acceptance(const HybridImages& pv, double t_L, double t_H, AcceptanceEstimate& a,
                              double p_min = 1.0 / 64.0, double min_gain = kAcceptanceMinGain) {
    constexpr int G = 8;
    const int w = pv.pixel_variance.width, h = pv.pixel_variance.height;
    std::array<double, G> V{}, M{}, n{};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int g = (x + 3 * y) % G;
            V[std::size_t(g)] += double(pv.pixel_variance.at(x, y, 0));
            M[std::size_t(g)] += double(pv.pixel_m2_high.at(x, y, 0));
            n[std::size_t(g)] += 1;
        }
    int groups = 0;
    for (int g = 0; g < G; ++g)
        if (n[std::size_t(g)] > 0) {
            V[std::size_t(groups)] = V[std::size_t(g)] / n[std::size_t(g)];
            M[std::size_t(groups)] = M[std::size_t(g)] / n[std::size_t(g)];
            ++groups;
        }
    a.P_a_robust = a.P_a_safe = 1;
    a.gain = 1;
    a.gain_se = 0;
    if (groups < 4 || !(t_L > 0) || !(t_H > 0)) return;
    // Mean of the group values without the largest and the smallest (of V; M follows its group).
    auto trimmed = [&](int skip, double& v, double& m) {
        int lo = -1, hi = -1;
        for (int g = 0; g < groups; ++g) {
            if (g == skip) continue;
            if (lo < 0 || V[std::size_t(g)] < V[std::size_t(lo)]) lo = g;
            if (hi < 0 || V[std::size_t(g)] > V[std::size_t(hi)]) hi = g;
        }
        v = m = 0;
        int k = 0;
        for (int g = 0; g < groups; ++g) {
            if (g == skip || g == lo || g == hi) continue;
            v += V[std::size_t(g)];
            m += M[std::size_t(g)];
            ++k;
        }
        v /= std::max(1, k);
        m /= std::max(1, k);
    };
    auto gain_at = [&](double v, double m, double P) {
        const double p1 = predicted_ttuv(v - m, m, t_L, t_H, 1.0), pp = predicted_ttuv(v - m, m, t_L, t_H, P);
        return pp > 0 ? p1 / pp : 1.0;
    };
    double v, m;
    trimmed(-1, v, m);
    a.V_robust = v;
    a.M_robust = m;
    a.P_a_robust = optimal_acceptance(v - m, m, t_L, t_H, p_min);
    a.gain = gain_at(v, m, a.P_a_robust);
    // Jackknife over the groups.
    std::array<double, G> gj{};
    double gm = 0;
    for (int g = 0; g < groups; ++g) {
        double vj, mj;
        trimmed(g, vj, mj);
        gj[std::size_t(g)] = gain_at(vj, mj, a.P_a_robust);
        gm += gj[std::size_t(g)];
    }
    gm /= double(groups);
    double ss = 0;
    for (int g = 0; g < groups; ++g) ss += (gj[std::size_t(g)] - gm) * (gj[std::size_t(g)] - gm);
    a.gain_se = std::sqrt(double(groups - 1) / double(groups) * ss);
    a.P_a_safe = a.gain - 2.0 * a.gain_se > std::max(1.0, min_gain) ? a.P_a_robust : 1.0;
}

/// Estimate the optimal acceptance probability (Eq. 8) from a preview render of every
/// `stride`-th pixel (10: Meng15's 1%-size image) with P_a = 1 and the same spp.
template <LitScene Scene, BoundaryShape Shape, class Distance, class Camera>
    requires PhaseMedium<typename Scene::Medium>
[[nodiscard]] AcceptanceEstimate estimate_optimal_acceptance(const Scene& scene_ept, const Scene& scene_vpt,
                                                             const GranularAggregate<Shape>& agg,
                                                             const HybridContext<Distance>& ctx, const Camera& camera,
                                                             int spp, std::uint64_t seed, int threads, HybridOptions opt,
                                                             int stride = 10) {
    opt.acceptance = 1.0;
    opt.checkpoint = {};  // the preview is short and whole: no checkpoint, no row share
    opt.row_offset = 0;
    opt.row_stride = 1;
    const HybridImages pv = render_hybrid(scene_ept, scene_vpt, agg, ctx, camera, spp, seed, threads, opt, stride);
    AcceptanceEstimate a;
    const double np = double(pv.low.width()) * double(pv.low.height()) * double(spp);
    a.V_L = pv.var_low;
    a.V_H = pv.var_high;
    a.t_L = pv.cpu_seconds_low / np;
    a.t_H = pv.cpu_seconds_high / np;
    a.P_a = optimal_acceptance(a.V_L, a.V_H, a.t_L, a.t_H);
    a.P_a_moments = optimal_acceptance(pv.var_total - pv.m2_high, pv.m2_high, a.t_L, a.t_H);
    robust_acceptance(pv, a.t_L, a.t_H, a);
    return a;
}

}  // namespace grainlight
