// meng15_scenes.hpp: the procedural stand-ins of Meng15's hybrid scenes shared by the Meng15
// scene examples (table2, fig1, fig7, fig11, fig12, fig13, hybrid_convergence): grains from the
// procedural presets with their effective medium and diffusion (make_snow_grains: the snow of
// fig11, fig13 and table2), the lit ground scene (make_lit_scene), the one render call every
// example goes through (render_hybrid_run: this MPI rank's rows, one checkpoint per render, the
// films shared by all ranks, then the summary), and
// "panels" (one aggregate, its EPT and VPT scenes, context and camera each) rendered with the
// hybrid and measured as one image. A scene of several aggregates of different grains (the
// four spice heaps) is rendered as side-by-side panels, one aggregate per panel: render_hybrid
// takes one aggregate and one effective medium. The image of K equal panels has the mean
// pixel variance of the panels' mean and the time of their sum, so its ttuv is
// (mean_k V_k) x (sum_k t_k) (Sec. 6).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/procedural_boundaries.hpp"
#include "grainlight/integrators/hybrid.hpp"
#include "grainlight/integrators/hybrid_calibration.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/precompute/scatterometer.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl_examples::meng15 {

namespace gl = grainlight;

using Medium = gl::ContinuousMedium<gl::TabulatedPhase<float, gl::RGB>, gl::RGB>;
using SceneT = gl::Scene<Medium>;

/// Grains of one aggregate: the MD-packed tile (f = 0.6, unit grain radius), the preset (shape,
/// material), its scatterometer statistics, effective RTE parameters, diffusion and medium.
struct Grains {
    gl::PeriodicTile tile;
    gl::GrainPreset preset;
    gl::GrainStats stats;
    gl::EffectiveRteParams rte;
    gl::HybridDiffusion diffusion;
    Medium medium;
    int level = 3;  ///< icosphere level of the grain mesh
    /// The aggregate of these grains inside `shape`.
    template <class Shape>
    [[nodiscard]] gl::GranularAggregate<Shape> aggregate(const Shape& shape, std::uint64_t seed) const {
        return gl::GranularAggregate<Shape>(
            tile, gl::VoxelizedBoundary<Shape>(shape, tile.side()),
            {gl::GrainExemplar::procedural(preset.shape, preset.radius, preset.material, preset.seed, level)}, {1.0}, seed);
    }
};

/// Grains of preset `p` (its material as given) in the unit-grain-radius tile `tile` and their
/// scatterometer statistics (400k / 100k rays at full / quick).
inline Grains make_grains(gl::PeriodicTile tile, const gl::GrainPreset& p, std::uint64_t seed, bool full, int level) {
    gl::ScatterometerConfig cfg;
    cfg.rays = full ? 400000 : 100000;
    cfg.seed = seed;
    gl::GrainStats stats = gl::run_scatterometer(gl::ScatterometerGrain::procedural(p.shape, p.radius, p.material, p.seed, level), cfg);
    const gl::EffectiveRteParams rte = gl::effective_rte_params(stats, tile.packing_fraction(), 1.0);
    Medium medium = gl::make_effective_medium<float, gl::RGB>(stats, tile.packing_fraction(), 1.0);
    return Grains{std::move(tile), p, stats, rte, gl::make_hybrid_diffusion(rte), std::move(medium), level};
}

/// The tile `t` scaled to unit grain radius.
inline gl::PeriodicTile unit_radius_tile(const gl::PeriodicTile& t) {
    const double s = 1.0 / t.radius();
    std::vector<gl::Vec3d> centers = t.centers();
    for (auto& c : centers) c *= s;
    return gl::PeriodicTile(t.side() * s, 1.0, std::move(centers));
}

/// Grains of preset `p` in an MD packing at f = 0.6 (400 grains per tile at full, 200 at quick).
inline Grains make_grains(const gl::GrainPreset& p, std::uint64_t seed, bool full, int level) {
    return make_grains(unit_radius_tile(gl::md_pack(full ? 400 : 200, 0.6, seed).tile), p, seed, full, level);
}

/// Snow grains (the snow preset's shape, ior 1.31) with a faint ice-like absorption per grain
/// radius (green = `absorption`; red x2, blue x0.5) so that paths stay finite.
inline Grains make_snow_grains(std::uint64_t seed, bool full, double absorption, int level) {
    gl::GrainPreset p = gl::grain_preset("snow");
    p.material = gl::GrainMaterial::make_absorbing_dielectric(1.31, gl::RGBd{2.0 * absorption, absorption, 0.5 * absorption});
    return make_grains(p, seed, full, level);
}

/// Ground + a small warm quad light high on one side + a dim blue sky, sized to the object
/// (R: its scale; the ground one grain radius below y = 0, not coplanar with flat bottoms).
inline SceneT make_lit_scene(float R) {
    SceneT sc;
    sc.add_shape(gl::QuadShape<float>(gl::Vec3f(-8 * R, -1.0f, -8 * R), gl::Vec3f(0, 0, 16 * R), gl::Vec3f(16 * R, 0, 0)),
                 gl::Material<float, gl::RGB>::diffuse(gl::RGB{0.45f, 0.45f, 0.45f}));
    sc.add_quad_light(gl::QuadShape<float>(gl::Vec3f(1.2f * R, 4.0f * R, 1.2f * R), gl::Vec3f(0.8f * R, 0, 0),
                                           gl::Vec3f(0, 0, 0.8f * R)),
                      gl::RGB{60.0f, 57.0f, 52.0f});
    sc.add_light(SceneT::LightT::environment_light(gl::RGB{0.04f, 0.05f, 0.08f}));
    return sc;
}

/// The explicit grain interactions the hybrid must keep before a switch for grains `g`
/// (integrators/hybrid_calibration.hpp: a half-space of these grains, EPT against the hybrid's
/// VPT continuation after k = 1..6 interactions, the smallest k within `tolerance`). Prints one
/// line labelled `name`.
inline int calibrate_min_ept(const Grains& g, std::uint64_t seed, int threads, const std::string& name,
                             int flight_memory = gl::HybridOptions{}.flight_memory,
                             bool flight_memory_boundary = gl::HybridOptions{}.flight_memory_boundary, double tolerance = 0.03) {
    const double absorbed = 1.0 - std::min({g.rte.alpha_s[0], g.rte.alpha_s[1], g.rte.alpha_s[2]});
    if (absorbed < 2e-3) {
        // A half-space of (nearly) lossless grains returns (nearly) all light in both EPT and the
        // effective medium: no bias to measure, and its paths are very long.
        std::printf("  %s: albedo >= %.4f, switch calibration skipped (a lossless half-space returns all light) -> min_ept 1\n",
                    name.c_str(), 1.0 - absorbed);
        return 1;
    }
    gl::SwitchCalibrationOptions o;
    o.seed = seed;
    o.threads = threads;
    o.tolerance = tolerance;
    o.flight_memory = flight_memory;
    o.flight_memory_boundary = flight_memory_boundary;
    const gl::SwitchCalibration c = gl::calibrate_min_ept_interactions(
        g.tile, {gl::GrainExemplar::procedural(g.preset.shape, g.preset.radius, g.preset.material, g.preset.seed, g.level)}, {1.0},
        seed, g.medium, o);
    std::printf("  %s: switch calibration in a half-space of its grains (EPT reflectance %.3f, %llu paths per angle at 0 and 60 deg): "
                "bias of switching after k interactions",
                name.c_str(), c.reflectance_ept, (unsigned long long)c.paths);
    for (const auto& b : c.by_k) std::printf(" k=%d %+.1f+-%.1f%%", b.k, 100 * b.rel_diff, 100 * b.stderr_rel);
    std::printf(" -> min_ept %d%s\n", c.min_ept_interactions, c.resolved ? "" : " (not resolved at 2 standard errors)");
    return c.min_ept_interactions;
}

/// One panel of an image: an aggregate, its EPT / VPT scenes, the hybrid context and a camera
/// (all owned by the caller).
template <class Shape, class Distance, class Camera>
struct Panel {
    std::string name;
    const gl::GranularAggregate<Shape>* agg = nullptr;
    const SceneT* ept = nullptr;
    const SceneT* vpt = nullptr;
    const gl::HybridContext<Distance>* ctx = nullptr;
    const Camera* camera = nullptr;
    int min_ept = 0;  ///< explicit grain interactions before a switch for this panel's grains (0: the options')
};

/// Rank 0 prints the tables and the summary line; the other ranks' stdout goes to /dev/null (their
/// results are the same: render_hybrid_run gives every rank the whole render).
inline void quiet_other_ranks(const Example& ex) {
    if (!ex.root()) std::fflush(stdout), (void)std::freopen("/dev/null", "w", stdout);
}

/// One hybrid render of an example, resumable and split over the MPI ranks: this rank renders its
/// rows (row_offset = rank, row_stride = ranks) with the checkpoint `stem` (checkpoint_for; its
/// key mixed with opt.acceptance, so a checkpoint of another P_a is refused), then every film's
/// rows are assembled on every rank (MpiSession::share_film_rows: a placement in row order, no
/// sum) and summarized once (summarize_hybrid). Every rank thus holds the single-process result:
/// the same images, variances, counters and CPU seconds (the sum of all ranks' row times, as
/// one process's threads would sum them), so the decisions taken from it are the same too.
template <class Scene, class Shape, class Distance, class Camera>
gl::HybridImages render_hybrid_run(const Example& ex, const std::string& stem, const Scene& ept, const Scene& vpt,
                                   const gl::GranularAggregate<Shape>& agg, const gl::HybridContext<Distance>& ctx,
                                   const Camera& cam, int spp, std::uint64_t seed, gl::HybridOptions opt,
                                   const std::string& label) {
    opt.row_offset = ex.rank();
    opt.row_stride = ex.ranks();
    opt.checkpoint = checkpoint_for(ex, stem);
    if (!opt.checkpoint.path.empty()) opt.checkpoint.key ^= std::hash<double>{}(opt.acceptance);
    ProgressBar bar = ex.progress(label, std::uint64_t(cam.height()));
    gl::HybridFilms f = gl::render_hybrid_films(ept, vpt, agg, ctx, cam, spp, seed, ex.threads(), opt, 1,
                                                [&](int n) { bar.advance(std::uint64_t(n)); });
    bar.done();
    if (ex.ranks() > 1)
        for (auto& film : f.films) film = ex.mpi().share_film_rows(film);
    return gl::summarize_hybrid(std::move(f));
}

/// The rows each rank rendered, for the JSON summaries ("rank_rows": rank r renders the rows
/// y with y % ranks == r; "rank_row_counts": how many of `height`).
inline Json& rank_rows(Json& j, const Example& ex, int height) {
    return j.str("rank_rows", "rank r renders the rows y with y % ranks == r").nums("rank_row_counts", ex.mpi().row_counts(height));
}

/// K panels of equal size rendered with one technique, measured as one image side by side.
struct Composite {
    std::vector<gl::HybridImages> panels;
    double mean = 0, mean_se = 0;  ///< channel-mean radiance of the whole image and its standard error
    double var_total = 0, var_total_se = 0, var_high = 0, var_low = 0;  ///< mean pixel variance of one bundle sample
    double seconds_per_spp = 0, high_seconds_per_spp = 0, low_seconds_per_spp = 0;  ///< thread CPU seconds of a 1-spp image (all panels)
    double paths = 0, switched = 0, switch_depth = 0, da = 0;  ///< counters summed over panels
    int spp = 0;
    [[nodiscard]] double ttuv() const { return var_total * seconds_per_spp; }
    [[nodiscard]] double ttuv_se() const { return var_total_se * seconds_per_spp; }
    [[nodiscard]] double ttuv_high() const { return var_high * high_seconds_per_spp; }
    /// ttuv of the low-order (EPT) part alone: the technique's ttuv if what follows the switch
    /// cost no time and added no variance (its best possible speed-up is ttuv(EPT) / this).
    [[nodiscard]] double ttuv_low() const { return var_low * low_seconds_per_spp; }
    [[nodiscard]] double cpu() const { return seconds_per_spp * spp; }
    /// The panels' images side by side (`which`: combined, ept, vpt, da, switch depth).
    enum class Part { combined, ept, vpt, da, switch_depth };
    [[nodiscard]] gl::Image image(Part which) const {
        const int w = panels.front().low.width(), h = panels.front().low.height();
        gl::Image out(w * int(panels.size()), h);
        for (std::size_t k = 0; k < panels.size(); ++k) {
            const gl::HybridImages& p = panels[k];
            const gl::Image im = which == Part::combined ? p.combined()
                                 : which == Part::ept    ? p.ept_image()
                                 : which == Part::vpt    ? p.vpt_image()
                                 : which == Part::da     ? p.da_image()
                                                         : p.switch_depth;
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    for (int c = 0; c < 3; ++c) out.at(int(k) * w + x, y, c) = im.at(x, y, c);
        }
        return out;
    }
};

inline double mean3(const gl::Image& im) { return (im.mean(0) + im.mean(1) + im.mean(2)) / 3.0; }

/// The statistics of the side-by-side image of `panels` (equal sizes): mean over the panels of
/// the means and pixel variances, sum of the times (Sec. 6's ttuv of the whole image).
inline Composite compose(std::vector<gl::HybridImages> panels) {
    Composite c;
    const double K = double(panels.size());
    double se2 = 0, mse2 = 0;
    for (const auto& p : panels) {
        const double npx = double(p.low.width()) * double(p.low.height());
        c.mean += mean3(p.combined()) / K;
        mse2 += p.var_total / (double(p.spp) * npx);
        c.var_total += p.var_total / K;
        se2 += p.var_total_se * p.var_total_se;
        c.var_high += p.var_high / K;
        c.var_low += p.var_low / K;
        c.seconds_per_spp += p.seconds_per_spp();
        c.high_seconds_per_spp += p.spp > 0 ? p.cpu_seconds_high / double(p.spp) : 0.0;
        c.low_seconds_per_spp += p.spp > 0 ? p.cpu_seconds_low / double(p.spp) : 0.0;
        c.paths += double(p.counters.paths);
        c.switched += double(p.counters.switched) + double(p.counters.rejected);
        c.switch_depth += double(p.counters.switch_depth);
        c.da += double(p.counters.da);
        c.spp = p.spp;
    }
    c.var_total_se = std::sqrt(se2) / K;
    c.mean_se = std::sqrt(mse2) / K;
    c.panels = std::move(panels);
    return c;
}

/// Render every panel with `opt` (per-panel acceptance P_a[k] if given) and compose; each panel is
/// one render_hybrid_run (its checkpoint stem: `label` and, with several panels, the panel's name).
template <class Shape, class Distance, class Camera>
Composite render_panels(const Example& ex, const std::vector<Panel<Shape, Distance, Camera>>& panels, int spp,
                        std::uint64_t seed, gl::HybridOptions opt, const std::string& label,
                        const std::vector<double>& P_a = {}) {
    std::vector<gl::HybridImages> imgs;
    for (std::size_t k = 0; k < panels.size(); ++k) {
        const auto& p = panels[k];
        if (k < P_a.size()) opt.acceptance = P_a[k];
        gl::HybridOptions po = opt;
        if (p.min_ept > 0) po.min_ept_interactions = p.min_ept;
        const std::string name = label + (panels.size() > 1 ? " " + p.name : std::string());
        // Each panel its own generator stream (seed + k): panels are independent images.
        imgs.push_back(render_hybrid_run(ex, name, *p.ept, *p.vpt, *p.agg, *p.ctx, *p.camera, spp, seed + 7919 * k, po, name));
    }
    return compose(std::move(imgs));
}

/// Meng15 Fig. 12's spice heaps: (panel name, preset, material). Flour: the preset's diffuse
/// grains; pink salt and brown sugar: the presets; cane sugar: the preset's ior 1.56 with a faint
/// absorption (`absorption` per grain radius, as the snow) so that EPT paths in the lossless
/// sugar end.
struct SpiceHeap {
    const char* name;
    gl::GrainPreset preset;
};
inline std::vector<SpiceHeap> spice_heaps(double absorption) {
    std::vector<SpiceHeap> h;
    h.push_back({"flour", gl::grain_preset("flour")});
    h.push_back({"pink_salt", gl::grain_preset("salt")});
    h.push_back({"brown_sugar", gl::grain_preset("brown-sugar")});
    gl::GrainPreset sugar = gl::grain_preset("sugar");
    sugar.material = gl::GrainMaterial::make_absorbing_dielectric(1.56, gl::RGBd{absorption, absorption, absorption});
    h.push_back({"cane_sugar", sugar});
    return h;
}

/// Everything one mesh-bounded panel owns (a Panel points into it; kept behind a unique_ptr so
/// its address is stable): grains, the boundary mesh, the aggregate, the EPT / VPT scenes, the
/// context (add_mesh_boundary: the DA switch asks MeshDistance::ball_inside) and the camera.
struct MeshPanel {
    std::string name;
    Grains grains;
    gl::TriangleMesh<double> mesh;
    gl::GranularAggregate<gl::MeshBoundary> agg;
    SceneT ept, vpt;
    gl::HybridContext<gl::MeshDistance> ctx;
    gl::PinholeCamera<float> camera;
    double grain_count = 0;  ///< grains in the aggregate: f x volume / (4/3 pi) (unit grain radius)
    int min_ept = 0;         ///< Panel::min_ept
};

/// A mesh panel under make_lit_scene(light_scale).
inline std::unique_ptr<MeshPanel> make_mesh_panel(const std::string& name, Grains g, gl::TriangleMesh<double> mesh,
                                                  const gl::PinholeCamera<float>& cam, float light_scale, std::uint64_t seed) {
    const gl::MeshBoundary shape(mesh);
    gl::GranularAggregate<gl::MeshBoundary> agg = g.aggregate(shape, seed);
    SceneT ept = make_lit_scene(light_scale);
    SceneT vpt = ept;
    const int m = vpt.add_medium(g.medium);
    gl::HybridContext<gl::MeshDistance> ctx = gl::add_mesh_boundary(vpt, mesh, m);
    const double count = g.tile.packing_fraction() * mesh.signed_volume() / (4.0 / 3.0 * gl::pi_v<double>);
    auto p = std::unique_ptr<MeshPanel>(new MeshPanel{name, std::move(g), std::move(mesh), std::move(agg), std::move(ept),
                                                      std::move(vpt), std::move(ctx), cam, count});
    p->ctx.diffusion = &p->grains.diffusion;  // the diffusion at its final address
    return p;
}

/// The four spice heaps (radius `Rh` grain radii, height 0.55 Rh: about 36 degrees at the foot),
/// each in its own panel of w x h pixels under the lit scene.
inline std::vector<std::unique_ptr<MeshPanel>> make_spice_panels(double Rh, double absorption, int w, int h, std::uint64_t seed,
                                                                 bool full, int level) {
    std::vector<std::unique_ptr<MeshPanel>> out;
    const float Rf = float(Rh);
    const gl::PinholeCamera<float> cam(gl::Vec3f(0.0f, 0.95f * Rf, 2.4f * Rf), gl::Vec3f(0.0f, 0.2f * Rf, 0.0f), gl::Vec3f(0, 1, 0),
                                       36.0f, w, h);
    for (const SpiceHeap& s : spice_heaps(absorption))
        out.push_back(make_mesh_panel(s.name, make_grains(s.preset, seed, full, level),
                                      gl::make_heap_mesh(Rh, 0.55 * Rh, full ? 96 : 48, full ? 128 : 64), cam, float(0.5 * Rh), seed));
    return out;
}

/// Fig. 1's sandcastle stand-in: make_sandcastle_mesh of half-width S grain radii (1.14 S tall)
/// of the `sand` preset's grains, one w x h panel seen from the front and above.
inline std::vector<std::unique_ptr<MeshPanel>> make_sandcastle_panel(double S, int w, int h, std::uint64_t seed, bool full,
                                                                     int level) {
    const float Sf = float(S);
    const gl::PinholeCamera<float> cam(gl::Vec3f(0.0f, 1.25f * Sf, 2.7f * Sf), gl::Vec3f(0.0f, 0.38f * Sf, 0.0f), gl::Vec3f(0, 1, 0),
                                       36.0f, w, h);
    std::vector<std::unique_ptr<MeshPanel>> out;
    out.push_back(make_mesh_panel("sandcastle", make_grains(gl::grain_preset("sand"), seed, full, level),
                                  gl::make_sandcastle_mesh(S, full ? 256 : 96), cam, float(0.6 * S), seed));
    return out;
}

/// Panels over mesh panels.
inline std::vector<Panel<gl::MeshBoundary, gl::MeshDistance, gl::PinholeCamera<float>>> panels_of(
    const std::vector<std::unique_ptr<MeshPanel>>& mp) {
    std::vector<Panel<gl::MeshBoundary, gl::MeshDistance, gl::PinholeCamera<float>>> p;
    for (const auto& h : mp) p.push_back({h->name, &h->agg, &h->ept, &h->vpt, &h->ctx, &h->camera, h->min_ept});
    return p;
}

/// Meng15 Fig. 7's glass-bead cube (Moon07 Fig. 9): lossless glass spheres (the glass-bead
/// preset, ior 1.5) by random sequential addition at f = 0.3 (a periodic tile of 200 / 400 beads at
/// quick / full), the cube's side from the bead count as in moon07_fig9_cube_shadow (L = cbrt(n
/// 4/3 pi / f) bead radii), standing on y = 0; Moon07's light at 2.2 L (0.05 L off axis, radiance
/// 0.9 / side^2) but of side 0.5 L instead of 0.12 L, and a dim grey sky (0.1) instead of black:
/// EPT through specular beads reaches a light only by hitting it (no NEE through the glass), and
/// with Moon07's small light EPT's image is a few fireflies at any affordable sample count. The
/// black blocker at 1.5 L over x < -0.08 L as in Moon07. Owned objects (kept behind a unique_ptr).
struct GlassBeadCube {
    double L = 0;  ///< cube side in bead radii
    Grains grains;
    gl::BoxBoundary shape;
    gl::GranularAggregate<gl::BoxBoundary> agg;
    SceneT ept, vpt;
    gl::HybridContext<gl::BoundaryDistance<gl::BoxBoundary>> ctx;
    gl::PinholeCamera<float> camera;
    /// The one panel.
    [[nodiscard]] std::vector<Panel<gl::BoxBoundary, gl::BoundaryDistance<gl::BoxBoundary>, gl::PinholeCamera<float>>> panels() const {
        return {{"glass_bead_cube", &agg, &ept, &vpt, &ctx, &camera}};
    }
};

/// The cube of `beads` glass beads seen by a w x h camera from the front left and above.
inline std::unique_ptr<GlassBeadCube> make_glass_bead_cube(double beads, int w, int h, std::uint64_t seed, bool full) {
    const double f = 0.3;
    const double L = std::cbrt(beads * 4.0 / 3.0 * gl::pi_v<double> / f);
    gl::Rng prng = gl::Rng::from_key(seed, 0xC0BEu);
    const gl::PeriodicTile rsa = gl::random_sequential_addition(full ? 400 : 200, f, prng, 1.0);
    Grains g = make_grains(unit_radius_tile(rsa), gl::grain_preset("glass-bead"), seed, full, 1);
    const gl::BoxBoundary shape(gl::Vec3d(-0.5 * L, 0.0, -0.5 * L), gl::Vec3d(0.5 * L, L, 0.5 * L));
    gl::GranularAggregate<gl::BoxBoundary> agg = g.aggregate(shape, seed);
    const float Lf = float(L), ls = 0.5f;
    SceneT ept;
    ept.add_quad_light(gl::QuadShape<float>(gl::Vec3f((0.05f - ls / 2) * Lf, 2.2f * Lf, -ls / 2 * Lf), gl::Vec3f(ls * Lf, 0, 0),
                                            gl::Vec3f(0, 0, ls * Lf)),
                       gl::RGB(0.9f / (ls * ls)));
    ept.add_shape(gl::QuadShape<float>(gl::Vec3f(-2.5f * Lf, 1.5f * Lf, -3.0f * Lf), gl::Vec3f(0, 0, 6.0f * Lf), gl::Vec3f(2.42f * Lf, 0, 0)),
                  gl::Material<float, gl::RGB>::diffuse(gl::RGB(0.0f)));
    ept.add_light(SceneT::LightT::environment_light(gl::RGB(0.1f)));
    SceneT vpt = ept;
    const int m = vpt.add_medium(g.medium);
    const int b = vpt.add_shape(gl::BoxShape<float>(gl::Vec3f(-0.5f * Lf, 0.0f, -0.5f * Lf), gl::Vec3f(0.5f * Lf, Lf, 0.5f * Lf)),
                                gl::Material<float, gl::RGB>::index_matched(), m, -1);
    const gl::PinholeCamera<float> cam(gl::Vec3f(-1.1f * Lf, 1.25f * Lf, 2.2f * Lf), gl::Vec3f(0.0f, 0.45f * Lf, 0.0f), gl::Vec3f(0, 1, 0),
                                       36.0f, w, h);
    auto c = std::unique_ptr<GlassBeadCube>(new GlassBeadCube{L, std::move(g), shape, std::move(agg), std::move(ept), std::move(vpt),
                                                              gl::HybridContext<gl::BoundaryDistance<gl::BoxBoundary>>{m, b, {shape}, nullptr},
                                                              cam});
    c->ctx.diffusion = &c->grains.diffusion;
    return c;
}

}  // namespace gl_examples::meng15
