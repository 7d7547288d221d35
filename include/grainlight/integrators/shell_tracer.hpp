/// @file grainlight/integrators/shell_tracer.hpp
/// Rendering and transport with Moon07 shell transport functions (Moon, Walter & Marschner,
/// EGSR 2007, Secs. 4.2-4.3, Figs. 5-7): paths are traced exactly near the surface of a medium
/// and advance by the largest precomputed shell that fits around them in its interior.
///
/// Three pieces:
///   - `ShellSwitchMedium<Exact, Boundary>`: a Medium (media/concepts.hpp) that takes a Fig. 5
///     shell step from every point whose distance to the medium surface (the `Boundary` query,
///     e.g. geometry/distance.hpp) is at least the smallest shell radius r_0, and an exact step of
///     the underlying medium otherwise. For a *continuous* medium this is exact up to the table's
///     discretization (free flights are memoryless, so handing a path back to exact steps near
///     the surface needs no approximate exit rule); the slab solver below uses it through the
///     walk kernel (integrators/walk.hpp) to check the shell machinery against transport theory.
///   - `ShellSlab`: the plane-parallel slab of scene/slab.hpp (same parameters and estimator)
///     solved by shell stepping: `slab --method shells`.
///   - `ShellTracer`: the Fig. 6 integrator for the high-order part of paths in a discrete
///     medium (switch rule, both shadow rays, the exit rule; see its comment).
///
/// Kernel rules: no allocation, exceptions or virtual calls per sample; randomness from `rng`.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/geometry/distance.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/shell.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/concepts.hpp"
#include "grainlight/integrators/slab.hpp"
#include "grainlight/scene/slab.hpp"

namespace grainlight {

/// Step counts of a walk through a ShellSwitchMedium.
struct ShellSwitchStats {
    std::uint64_t shell_steps = 0;  ///< steps taken with a shell
    std::uint64_t exact_steps = 0;  ///< steps of the exact medium
};

/// A medium that advances by Moon07 shells where one fits (distance to the surface >= r_0,
/// the largest r_i <= distance is used: Fig. 5) and by exact steps of `Exact` elsewhere.
/// Scattered shell exits are `scatter` events with `has_direction`; straight shell steps are
/// `null` events. Absorption inside shells is analog by default (grey 0/1 path scores).
/// \tparam Exact a Medium with a phase function (the medium the table was built from)
/// \tparam Boundary distance-to-surface query double(const Vec3d&) (>= 0 inside)
template <class Exact, class Boundary>
    requires PhaseMedium<Exact>
class ShellSwitchMedium {
public:
    /// Floating-point type (the exact medium's).
    using Float = typename Exact::Float;
    /// Spectrum type (the exact medium's).
    using Spectrum = typename Exact::Spectrum;
    /// Short name of Float.
    using F = Float;
    /// Short name of Spectrum.
    using S = Spectrum;
    /// The shell medium that takes the Fig. 5 steps.
    using Shells = ShellMedium<F, S, Boundary>;

    /// \param exact the underlying medium; \param table its shell table (validated);
    /// \param boundary distance-to-surface query; \param analog_absorption see ShellMedium.
    ShellSwitchMedium(Exact exact, ShellTable table, Boundary boundary, bool analog_absorption = true)
        : exact_(std::move(exact)), shells_(std::move(table), boundary, analog_absorption), boundary_(boundary),
          r0_(F(shells_.table().radii.front())) {}

    /// The underlying exact medium.
    [[nodiscard]] const Exact& exact() const noexcept { return exact_; }
    /// The shell medium (table, boundary query, absorption mode).
    [[nodiscard]] const Shells& shells() const noexcept { return shells_; }
    /// Phase function of the exact medium (NEE and exact steps; shell exits sample their own direction).
    [[nodiscard]] decltype(auto) phase() const noexcept { return exact_.phase(); }
    /// Smallest shell radius r_0 (the table's first radius) [scene units].
    [[nodiscard]] F r0() const noexcept { return r0_; }

    /// True if a step from p is a shell step (distance to the surface >= r_0).
    [[nodiscard]] bool uses_shell(const Vec3<F>& p) const noexcept { return F(boundary_(Vec3d(p))) >= r0_; }

    /// Next event along `ray` before t_max: a shell step (ShellMedium::sample_interaction) if
    /// uses_shell(ray.o), else an exact free flight of the underlying medium.
    [[nodiscard]] Interaction<F, S> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        if (uses_shell(ray.o)) return shells_.sample_interaction(ray, t_max, rng);
        return exact_.sample_interaction(ray, t_max, rng);
    }
    /// Exact transmittance of the underlying medium.
    [[nodiscard]] S transmittance(const Ray<F>& r, F t, Rng& rng) const noexcept {
        return exact_.transmittance(r, t, rng);
    }

private:
    Exact exact_;
    Shells shells_;
    Boundary boundary_;
    F r0_;
};

/// Shell radii for a slab solved by shells: `n` radii linearly spaced from r0 to
/// min(r_cap, thickness / 2) (optical depths; sigma_t = 1). Throws invalid_argument naming the
/// parameter when no shell fits (r0 > thickness / 2) or n < 1.
[[nodiscard]] inline std::vector<double> slab_shell_radii(double optical_depth, int n, double r0 = 0.75,
                                                          double r_cap = 8.0) {
    constexpr const char* where = "slab_shell_radii";
    check_argument(n >= 1 && n <= 1024, where, "n", n, "[1, 1024]");
    check_argument(std::isfinite(r0) && r0 > 0, where, "r0", r0, "(0, inf)");
    check_argument(std::isfinite(r_cap) && r_cap >= r0, where, "r_cap", r_cap, "[r0, inf)");
    const double r_max = std::min(r_cap, 0.5 * optical_depth);
    check_argument(r_max >= r0, where, "optical_depth", optical_depth,
                   "at least 2 r0 = " + std::to_string(2 * r0) + " (no shell fits between the faces)");
    std::vector<double> r(static_cast<std::size_t>(n), r0);
    for (int i = 0; i < n; ++i) r[std::size_t(i)] = n == 1 ? r0 : r0 + (r_max - r0) * double(i) / double(n - 1);
    if (n > 1 && !(r_max > r0)) r.resize(1);
    return r;
}

/// The slab of scene/slab.hpp (same parameters, geometry and R/T estimator) solved by shell
/// stepping: inside, paths advance by the largest shell of `table` that fits between the faces;
/// within r_0 of a face they take exact continuous-medium steps (walk kernel, Fresnel faces).
/// `table` must have been built from the slab's own medium (sigma_t = 1, its albedo and g).
class ShellSlab {
public:
    /// Floating-point type (double).
    using F = double;
    /// Spectrum type: one grey double channel.
    using S = Spectrum<1, double>;
    /// Henyey-Greenstein phase of the slab medium.
    using Phase = HenyeyGreenstein<double, S>;
    /// The slab's exact continuous medium (sigma_t = 1).
    using Exact = ContinuousMedium<Phase, S>;
    /// The medium the walks use: shells inside, exact steps within r_0 of a face.
    using MediumType = ShellSwitchMedium<Exact, SlabDistance>;
    /// The slab scene over MediumType (Fresnel faces, R/T estimator of scene/slab.hpp).
    using SceneType = SlabScene<MediumType>;

    /// Throws invalid_argument for bad slab parameters (as SlabProblem) or an invalid table.
    ShellSlab(const SlabParams& p, ShellTable table)
        : problem_(p), scene_(MediumType(problem_.scene().medium(0), std::move(table), SlabDistance{p.optical_depth}),
                              p.optical_depth, p.ior) {}

    /// The slab parameters (as given, validated).
    [[nodiscard]] const SlabParams& params() const noexcept { return problem_.params(); }
    /// The slab scene the walks run in.
    [[nodiscard]] const SceneType& scene() const noexcept { return scene_; }

    /// Paths [first, first + count) with Pcg32::from_key(seed, path, 0) (thread-count
    /// independent). `stats` (optional) receives the step counts.
    [[nodiscard]] SlabTally run(std::uint64_t first, std::uint64_t count, std::uint64_t seed,
                                ShellSwitchStats* stats = nullptr) const noexcept {
        const MediumType& m = scene_.medium(0);
        return run_slab_paths(scene_, params().mu0, first, count, seed, [&] {
            Scorer sc;
            sc.m = &m;
            sc.stats = stats;
            return sc;
        });
    }

private:
    /// SlabProblem's R/T scorer plus the shell / exact step counts.
    struct Scorer : SlabScorer<F, S> {
        const MediumType* m = nullptr;
        ShellSwitchStats* stats = nullptr;
        void on_segment(const PathState<F, S>& st, F) noexcept {
            if (!stats || st.medium < 0) return;
            if (m->uses_shell(st.ray.o))
                ++stats->shell_steps;
            else
                ++stats->exact_steps;
        }
    };
    SlabProblem problem_;
    SceneType scene_;
};

/// An `Env` of ShellTracer::trace that continues paths leaving the volume into the surrounding
/// scene (the continuation hook): `S continue_outside(const Ray<double>& r, Rng& rng, bool
/// direct_counted)` returns the radiance arriving at r.o along -r.d from everything the path meets
/// from there on (surfaces it bounces off, with their own next-event estimation, and the volume
/// again when it re-enters: explicit tracing there, shells again by the switch rule). With
/// `direct_counted` the emission seen directly along the first segment of r is left out: a shadow
/// ray of the tracer has estimated it already. Without the hook a path ends at the volume's
/// boundary (`escape`: the light it sees, or nothing), losing light such as bowl -> table -> bowl.
template <class Env, class S>
concept ShellContinuationEnv = requires(const Env& env, const Ray<double>& r, Rng& rng) {
    { env.continue_outside(r, rng, true) } -> std::convertible_to<S>;
};

/// Direction of a path that leaves the volume through a sampled shell exit point outside it.
enum class ShellExitRule : std::uint8_t {
    radial,  ///< Moon07 (Fig. 5): along y - x, the ray from the shell centre to the exit point
    table    ///< along the exit direction omega' sampled from T_r at y (leaving from y)
};

/// Optics of the volume's faces where a shell step leaves the volume (ShellTracer::trace). In the
/// explicit medium a face plane cuts through the spheres: a path crossing it is inside glass with
/// probability q(|cos theta|) (cos theta = direction . outward face normal; for a packing measure
/// it with plane_crossing_glass_fraction, precompute/shell_builder.hpp), and there it meets the
/// glass-air interface: Fresnel reflection back into the volume (mirrored about the face) or
/// refraction out (Snell, relative index `eta`). Otherwise (probability 1 - q) it leaves straight.
/// Empty `q`: off (Moon07's rule: every exit leaves straight). Needs a Volume with
/// `Vec3d normal(const Vec3d&)` (the outward normal of the face nearest to a point, e.g. BoxDistance);
/// the face of a step is the face nearest to the step's start point (so exits, straight escapes
/// and both shadow rays use the same face and stay one consistent estimator).
struct ShellFaceOptics {
    double eta = 1.5;       ///< index of the grains over that outside the volume (> 0, finite)
    std::vector<double> q;  ///< glass fraction in equal cells of |cos theta| over [0, 1] (each in [0, 1]; empty: off)
    /// True if face optics is on (q not empty).
    [[nodiscard]] bool enabled() const noexcept { return !q.empty(); }
    /// q(|c|): the probability that a crossing at direction cosine c is inside glass.
    [[nodiscard]] double glass_fraction(double c) const noexcept {
        const std::size_t n = q.size();
        const double a = std::min(1.0, std::abs(c));
        return q[std::min(n - 1, std::size_t(a * double(n)))];
    }
    /// Glass faces everywhere (q = 1): a continuous medium in a glass-walled container.
    [[nodiscard]] static ShellFaceOptics glass(double eta) { return ShellFaceOptics{eta, {1.0}}; }
};

/// True if `Volume` gives the outward face normal that ShellFaceOptics needs.
template <class Volume>
concept VolumeWithNormal = requires(const Volume& v, const Vec3d& p) {
    { v.normal(p) } -> std::convertible_to<Vec3d>;
};

/// Options of the Fig. 6 shell tracer.
struct ShellTracerOptions {
    int min_scatter = 2;        ///< explicit events before a path may switch to shells (switch rule)
    double switch_depth = -1;   ///< distance to the surface required to switch (< 0: r_0 of the table)
    bool nee = true;            ///< Fig. 6's two shadow rays (false: count escapes that hit lights)
    int max_steps = 100000;     ///< shell steps per path at most
    /// < 0: Moon07's approximate exit rule at the surface (trace()). >= r_0: hand-back mode
    /// (trace_to_boundary()): a shell step that lands closer than this to the surface returns the
    /// path to the caller, which continues it exactly (explicit geometry or exact medium steps).
    double hand_back_depth = -1;
    /// Exit rule of trace() for sampled exit points outside the volume (Moon07's: radial).
    ShellExitRule exit_rule = ShellExitRule::radial;
    /// Glass-air optics of the faces where trace() leaves the volume (default off).
    ShellFaceOptics face{};
};

/// Where the shell-traced part of a path ended (ShellTracer::trace_to_boundary).
template <class S>
struct ShellHandBack {
    S L{0.0};                  ///< radiance gathered by shadow rays before the hand-back (per unit throughput)
    bool handed_back = false;  ///< true: continue the path exactly from (x, omega) with throughput beta
    Vec3d x{0.0};              ///< position of the hand-back (inside, closer than hand_back_depth to the surface)
    Vec3d omega{0.0, 0.0, 1.0};  ///< direction there (unit)
    double beta = 1.0;         ///< throughput factor accumulated in the shells
};

/// What a shell-traced path did (for statistics).
struct ShellTraceStats {
    /// @var paths
    /// Paths traced (calls of trace() or trace_to_boundary()).
    /// @var steps
    /// Shell steps taken.
    /// @var scattered
    /// Shell steps that ended in a scattering (scattered exits).
    /// @var exits
    /// Shell steps whose exit point fell outside the volume (ShellStepKind::exited).
    /// @var straight_escapes
    /// Shell steps that left the volume unscattered (ShellStepKind::escaped).
    /// @var face_reflections
    /// Exits and straight escapes Fresnel-reflected back inside by a glass face (ShellFaceOptics).
    std::uint64_t paths = 0, steps = 0, scattered = 0, exits = 0, straight_escapes = 0, face_reflections = 0;
};

/// Moon07 Fig. 6 (advanceRayUsingShellsWithDirect) as an integrator for the high-order part of a
/// path inside a homogeneous discrete random medium:
///   - `Volume`: the medium's volume; signed distance `double operator()(Vec3d)` (>= 0 inside,
///     geometry/distance.hpp) picks the largest shell that fits (else r_0), and
///     `exit_distance(p, w)` is the "distance to surface along omega";
///   - `Env` (the scene outside the medium): `LightSample<double, S> sample_light(p, Vec3d u)`
///     (pick a light and a point on it, solid-angle pdf), `bool visible(p, w, dist)` (no blocker
///     between p and the light point; the medium itself is accounted for by the shells) and
///     `S escape(const Ray<double>&)` (radiance arriving along a ray leaving the volume: a light
///     it hits, or the environment).
/// From the switch point (x, omega) the path takes Fig. 5 steps. With `nee`, at every step the
/// first shadow ray adds L p_r(y = x_l) (ShellMedium::exit_escape_density) and after every
/// scattered step the second adds L p_r(w_l | x_{i+1}) T (straight_escape_density); then exits
/// outside the volume and straight escapes along a direction set by a scattered step are not
/// counted again (they are what the shadow rays estimate); a straight escape along the switch
/// direction is counted through `escape`. Without `nee` every escape is followed by `escape`
/// (exits leave along y - x, the paper's exit rule): the analog estimator the shadow rays
/// replace. Both estimate the same expectation (tests/shells/test_shell_tracer.cpp).
/// If `Env` also meets ShellContinuationEnv, a path that leaves the volume (exit outside or
/// straight escape) is handed to `env.continue_outside` instead of ending at the boundary: the
/// emission its shadow ray already estimated is left out of the first segment (direct_counted),
/// all light after a bounce outside (and after re-entry) is kept.
/// `exit_rule = ShellExitRule::table` makes exits outside leave from y along the sampled T_r
/// direction instead of y - x (the first shadow ray then samples one exit point y and adds
/// L p_r(w_l | y) cos if y is outside); `trace_to_boundary` (hand-back mode) needs no exit rule.
template <class S, class Volume>
class ShellTracer {
public:
    /// Shell medium over the volume's distance query (absorption weighted, not analog).
    using Shells = ShellMedium<double, S, Volume>;

    /// Tracer over shell table `table` (validated) and volume `volume` (copied); throws
    /// grainlight::invalid_argument naming the option for min_scatter < 0, max_steps < 1, a NaN
    /// switch_depth, or 0 <= hand_back_depth < r_0. Immutable afterwards: const members are
    /// thread-safe (each thread passes its own Rng and stats).
    ShellTracer(ShellTable table, Volume volume, ShellTracerOptions opt = {})
        : shells_(std::move(table), volume, /*analog_absorption*/ false), volume_(std::move(volume)), opt_(opt) {
        check_argument(opt.min_scatter >= 0, "ShellTracer", "min_scatter", opt.min_scatter, ">= 0");
        check_argument(opt.max_steps >= 1, "ShellTracer", "max_steps", opt.max_steps, ">= 1");
        check_argument(!std::isnan(opt.switch_depth), "ShellTracer", "switch_depth", opt.switch_depth,
                       "a number (< 0: r_0 of the table)");
        switch_depth_ = opt.switch_depth < 0 ? shells_.table().radii.front() : opt.switch_depth;
        eps_ = 1e-9 * shells_.table().radii.front();
        const double r0 = shells_.table().radii.front();
        check_argument(std::isnan(opt.hand_back_depth) ? false : (opt.hand_back_depth < 0 || opt.hand_back_depth >= r0),
                       "ShellTracer", "hand_back_depth", opt.hand_back_depth,
                       "< 0 (Moon07 exit rule) or >= r_0 = " + std::to_string(r0));
        if (opt.face.enabled()) {
            check_argument(VolumeWithNormal<Volume>, "ShellTracer", "face.q.size()", opt.face.q.size(),
                           "0 (face optics off) for a volume without normal()");
            check_argument(std::isfinite(opt.face.eta) && opt.face.eta > 0, "ShellTracer", "face.eta", opt.face.eta,
                           "finite, > 0");
            for (const double v : opt.face.q)
                check_argument(v >= 0 && v <= 1, "ShellTracer", "face.q", v, "[0, 1] in every cell");
        }
    }

    /// Hand-back mode (hand_back_depth h = max(options().hand_back_depth, r_0)): Fig. 5 shell steps from x (inside, at
    /// least h from the surface) along unit omega until a step lands closer than h to the surface; then the state is returned for exact continuation. Every
    /// shell used fits inside the volume (r_i <= distance), so no exit rule and no shadow ray is
    /// needed: the caller's exact tracing does the boundary layer (and its next-event estimation).
    /// For a continuous medium this is exact up to the table's discretization (memoryless free
    /// flights); Moon07's exit rule (trace()) is not (tests/shells/test_shell_tracer.cpp).
    /// Returns handed_back = false if the path was absorbed (analog) or ran out of steps.
    [[nodiscard]] ShellHandBack<S> trace_to_boundary(Vec3d x, Vec3d omega, Rng& rng,
                                                     ShellTraceStats* stats = nullptr) const noexcept {
        ShellHandBack<S> hb;
        if (stats) ++stats->paths;
        const double h = std::max(opt_.hand_back_depth, shells_.table().radii.front());
        const auto inside = [this](const Vec3d& p) { return !(volume_(p) < 0.0); };
        for (int k = 0; k < opt_.max_steps; ++k) {
            if (volume_(x) < h) {
                hb.handed_back = true;
                hb.x = x;
                hb.omega = omega;
                return hb;
            }
            const double t_b = volume_.exit_distance(x, omega);
            const ShellStep<double> st = shells_.step(x, omega, t_b, rng, inside);
            if (stats) ++stats->steps;
            if (st.kind == ShellStepKind::straight) {
                x = st.p;
                continue;
            }
            if (st.kind != ShellStepKind::scattered) break;  // absorbed (a fitting shell never leaves)
            if (stats) ++stats->scattered;
            hb.beta *= st.weight;
            if (!(hb.beta > 0)) break;
            x = st.p;
            omega = st.w;
        }
        hb.beta = 0;
        return hb;
    }

    /// The shell medium (table and volume query).
    [[nodiscard]] const Shells& shells() const noexcept { return shells_; }
    /// The volume (distance and exit-distance queries).
    [[nodiscard]] const Volume& volume() const noexcept { return volume_; }
    /// The options the tracer was built with.
    [[nodiscard]] const ShellTracerOptions& options() const noexcept { return opt_; }
    /// Depth below the surface from which paths may switch to shells (options().switch_depth, or r_0 if that is < 0).
    [[nodiscard]] double switch_depth() const noexcept { return switch_depth_; }

    /// The switch rule (Sec. 4.2): at least min_scatter explicit events and at least the switch
    /// depth (default r_0) inside the volume.
    [[nodiscard]] bool may_switch(const Vec3d& p, int events) const noexcept {
        return events >= opt_.min_scatter && volume_(p) >= switch_depth_;
    }

    /// Radiance gathered by the shell-traced remainder of a path at x (inside) travelling along
    /// unit omega (Fig. 6), per unit path throughput.
    template <class Env>
    [[nodiscard]] S trace(Vec3d x, Vec3d omega, Rng& rng, const Env& env, ShellTraceStats* stats = nullptr) const noexcept {
        S L(0.0);
        double beta = 1.0;
        bool dir_from_scatter = false;
        if (stats) ++stats->paths;
        const auto inside = [this](const Vec3d& p) { return !(volume_(p) < 0.0); };
        for (int k = 0; k < opt_.max_steps; ++k) {
            const double t_b = volume_.exit_distance(x, omega);
            if (opt_.nee && opt_.exit_rule == ShellExitRule::radial) {
                // first shadow ray: leave through a sampled exit point outside, along y - x
                const LightSample<double, S> ls = env.sample_light(x, rng.uniform3<double>());
                if (ls) {
                    const double dens = face_density(x, ls.w, [&](const Vec3d& w) {
                        return shells_.exit_escape_density(x, omega, t_b, w);
                    });
                    if (dens > 0 && env.visible(x, ls.w, ls.dist)) L += ls.L * (beta * dens / ls.pdf);
                }
            } else if (opt_.nee) {
                // first shadow ray, table rule: one exit point y from p_r(y); if it lies outside,
                // the density of leaving from y toward the light is p_r(w_l | y) cos (times the
                // probability of a scattered exit and its expected throughput)
                const int i = shells_.select_shell(volume_(x));
                const double r = shells_.table().radii[std::size_t(i)];
                if (volume_(x) < r) {
                    Vec3d y, w_s;
                    double pdf_s = 0;
                    shells_.sample_exit(i, x, omega, rng, y, w_s, pdf_s);
                    const LightSample<double, S> ls = env.sample_light(y, rng.uniform3<double>());
                    if (ls && volume_(y) < 0.0) {
                        const Vec3d n = glm::normalize(y - x);
                        const double pu = t_b < r ? shells_.attenuation(t_b) : shells_.table().p_unscattered[std::size_t(i)];
                        const double ps = shells_.table().p_scattered[std::size_t(i)], pa = shells_.table().p_absorbed[std::size_t(i)];
                        if (ps > 0) {
                            const double k_s = (1 - pu) * ps / (ps + pa);
                            const double dens = face_density(x, ls.w, [&](const Vec3d& w) {
                                const double c = glm::dot(w, n);
                                return c > 0 ? k_s * shells_.exit_direction_density(i, shell_coords(x, omega, y, w)) * c : 0.0;
                            });
                            if (dens > 0 && env.visible(y, ls.w, ls.dist)) L += ls.L * (beta * dens / ls.pdf);
                        }
                    }
                }
            }
            const ShellStep<double> st = shells_.step(x, omega, t_b, rng, inside);
            if (stats) ++stats->steps;
            switch (st.kind) {
                case ShellStepKind::straight:
                    x = st.p;
                    continue;
                case ShellStepKind::absorbed:
                    return L;
                case ShellStepKind::escaped: {
                    if (stats) ++stats->straight_escapes;
                    Vec3d w_out = omega;
                    if (face_event(x, w_out, rng) == FaceEvent::reflected) {
                        // Fresnel reflection at a glass face: back inside from the face point
                        if (stats) ++stats->face_reflections;
                        x = st.p - eps_ * omega;
                        omega = w_out;
                        dir_from_scatter = false;  // no shadow ray estimated this direction's escape
                        continue;
                    }
                    const bool counted = opt_.nee && dir_from_scatter;  // the second shadow ray estimated it
                    if constexpr (ShellContinuationEnv<Env, S>) {
                        L += env.continue_outside(Ray<double>(st.p, w_out), rng, counted) * beta;
                    } else {
                        if (!counted) L += env.escape(Ray<double>(st.p, w_out)) * beta;
                    }
                    return L;
                }
                case ShellStepKind::exited: {
                    if (stats) ++stats->exits;
                    Vec3d w_out = opt_.exit_rule == ShellExitRule::table ? st.w_table : st.w;
                    beta *= st.weight;  // expected survival of the shell's events (1 - P_a share)
                    if (face_event(x, w_out, rng) == FaceEvent::reflected) {
                        // Fresnel reflection at a glass face: the exit point mirrored back inside
                        if (stats) ++stats->face_reflections;
                        x = mirrored_inside(x, st.p);
                        omega = w_out;
                        dir_from_scatter = false;
                        if (!(beta > 0)) return L;
                        continue;
                    }
                    const Ray<double> out(st.p, w_out);
                    if constexpr (ShellContinuationEnv<Env, S>) {
                        // the first shadow ray estimated the emission seen along `out` (with nee)
                        if (beta > 0) L += env.continue_outside(out, rng, opt_.nee) * beta;
                    } else {
                        if (!opt_.nee) L += env.escape(out) * beta;
                    }
                    return L;
                }
                case ShellStepKind::scattered: {
                    if (stats) ++stats->scattered;
                    beta *= st.weight;
                    if (opt_.nee) {  // second shadow ray: continue along w_l and leave unscattered
                        const LightSample<double, S> ls = env.sample_light(st.p, rng.uniform3<double>());
                        if (ls) {
                            const double dens = face_density(st.p, ls.w, [&](const Vec3d& w) {
                                return shells_.straight_escape_density(st.shell, x, omega, st.p, w,
                                                                       volume_.exit_distance(st.p, w));
                            });
                            if (dens > 0 && env.visible(st.p, ls.w, ls.dist)) L += ls.L * (beta * dens / ls.pdf);
                        }
                    }
                    x = st.p;
                    omega = st.w;
                    dir_from_scatter = true;
                    if (!(beta > 0)) return L;
                    continue;
                }
            }
        }
        return L;
    }

private:
    enum class FaceEvent : std::uint8_t { straight, refracted, reflected };

    /// Face optics on, and the outward normal of the face of a step from x.
    [[nodiscard]] bool face_normal(const Vec3d& x, Vec3d& n) const noexcept {
        if constexpr (VolumeWithNormal<Volume>) {
            if (!opt_.face.enabled()) return false;
            n = volume_.normal(x);
            return true;
        } else {
            (void)x;
            (void)n;
            return false;
        }
    }

    /// The face a step from x leaves through acting on the leaving direction w (unit, in the
    /// medium): with probability q(w . n) the crossing is inside glass and w is Fresnel-reflected
    /// or refracted (sample_dielectric); else (or with face optics off, or w . n <= 0) unchanged.
    [[nodiscard]] FaceEvent face_event(const Vec3d& x, Vec3d& w, Rng& rng) const noexcept {
        Vec3d n;
        if (!face_normal(x, n)) return FaceEvent::straight;
        const double c = glm::dot(w, n);
        if (!(c > 0)) return FaceEvent::straight;
        const double u_glass = rng.uniform<double>(), u_fresnel = rng.uniform<double>();
        if (!(u_glass < opt_.face.glass_fraction(c))) return FaceEvent::straight;
        const DielectricSample<double> ds = sample_dielectric(w, n, opt_.face.eta, u_fresnel);
        w = ds.w;
        return ds.refracted ? FaceEvent::refracted : FaceEvent::reflected;
    }

    /// Density over the direction w_o a path leaves the volume in (outside the face), given the
    /// density `dens(w)` over the in-medium direction w it reaches the face of a step from x with:
    /// (1 - q(c_o)) dens(w_o) + q(c_i) (1 - F(c_i)) dens(w_i) |d omega_i / d omega_o|, w_i the
    /// in-glass direction Snell refracts to w_o and |d omega_i / d omega_o| = c_o / (eta^2 c_i).
    /// The estimate face_event() samples, for the shadow rays.
    template <class Dens>
    [[nodiscard]] double face_density(const Vec3d& x, const Vec3d& w_o, const Dens& dens) const noexcept {
        Vec3d n;
        if (!face_normal(x, n)) return dens(w_o);
        const double c_o = glm::dot(w_o, n);
        if (!(c_o > 0)) return dens(w_o);
        double d = (1 - opt_.face.glass_fraction(c_o)) * dens(w_o);
        Vec3d wt;
        if (refract(w_o, n, opt_.face.eta, wt)) {  // from outside into glass: always refracts
            const Vec3d w_i = -glm::normalize(wt);
            const double c_i = glm::dot(w_i, n);
            if (c_i > 0) {
                const double eta = opt_.face.eta;
                const double t = 1 - fresnel_dielectric(c_i, 1 / eta);
                const double q = opt_.face.glass_fraction(c_i);
                if (q > 0 && t > 0) d += q * t * c_o / (eta * eta * c_i) * dens(w_i);
            }
        }
        return d;
    }

    /// A sampled exit point y of a step from x, outside the volume, reflected about the plane of
    /// the step's face (the face at distance volume_(x) along its normal); if that lands outside
    /// (near an edge), the point where the chord x -> y leaves the volume, just inside.
    [[nodiscard]] Vec3d mirrored_inside(const Vec3d& x, const Vec3d& y) const noexcept {
        Vec3d n(0.0);
        (void)face_normal(x, n);
        const double beyond = glm::dot(y - x, n) - volume_(x);
        const Vec3d m = y - 2 * std::max(0.0, beyond) * n;
        if (!(volume_(m) < 0.0)) return m;
        const Vec3d u = glm::normalize(y - x);
        return x + std::max(0.0, volume_.exit_distance(x, u) - eps_) * u;
    }

    Shells shells_;
    Volume volume_;
    ShellTracerOptions opt_;
    double switch_depth_ = 0;
    double eps_ = 1e-9;  ///< nudge off the surface (1e-9 r_0)
};


}  // namespace grainlight
