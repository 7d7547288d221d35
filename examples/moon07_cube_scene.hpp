// moon07_cube_scene.hpp: the scene shared by the Moon07 cube examples (moon07_fig9_cube_shadow,
// moon07_fig11_spotlight): explicit glass spheres in a cube on a black floor under a quad light
// (optionally emitting only inside a cone: a spotlight with a finite, hittable emitter, so that
// path tracing through specular spheres can reach it), a blocker, one camera path for path
// tracing / low order / high order (switch rule + ShellTracer), batch renders and image output.
// The scene is generic over its volume (VolumeScene<Vol>): a cube (gl::BoxDistance, CubeScene) or
// the bowl of moon07_fig12_bowl (BowlVolume: the lower half of a ball, flat top), optionally on a
// diffuse table instead of the black floor. Batch renders checkpoint (--checkpoint / --resume)
// through the example harness (checkpoint_for, removed by ex.finish()).
#pragma once
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cctype>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/cli.hpp"
#include "common/harness.hpp"
#include "common/output.hpp"
#include "common/progress.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/statistics.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/distance.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/shell_tracer.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/packing/poisson.hpp"
#include "grainlight/precompute/shell_builder.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/lights.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace gl = grainlight;
using gl::Vec3d;
using S1 = gl::Spectrum<1, double>;

namespace {

double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

enum class Mode { pt, low, high };

/// Entry distance of a ray into a box volume (inf if it misses).
inline double volume_entry(const gl::BoxDistance& v, const gl::Ray<double>& r) noexcept {
    const gl::Aabb<double> b(v.lo, v.hi);
    const Vec3d inv(1 / r.d.x, 1 / r.d.y, 1 / r.d.z);
    double te = 0;
    if (!gl::intersect_aabb(b, r.o, inv, 1e-9, std::numeric_limits<double>::infinity(), &te))
        return std::numeric_limits<double>::infinity();
    return te;
}

/// Outward normal of the box face nearest to p.
inline Vec3d volume_normal(const gl::BoxDistance& v, const Vec3d& p) noexcept {
    int best = 0;
    double dmin = std::numeric_limits<double>::infinity(), sgn = 1;
    for (int a = 0; a < 3; ++a) {
        if (p[a] - v.lo[a] < dmin) { dmin = p[a] - v.lo[a]; best = a; sgn = -1; }
        if (v.hi[a] - p[a] < dmin) { dmin = v.hi[a] - p[a]; best = a; sgn = 1; }
    }
    Vec3d n(0.0);
    n[best] = sgn;
    return n;
}

/// The bowl of moon07_fig12_bowl: the lower half of a ball (centre c, radius rb), i.e. the points
/// with |p - c| <= rb and p.z <= c.z (a hemispherical bowl filled to its rim, flat top face).
/// Meets the ShellTracer `Volume` requirements: signed distance (> 0 inside; exact inside, as the
/// nearest point of the sphere of a point below the rim lies below the rim) and exit distance.
struct BowlVolume {
    Vec3d c{0.0};   ///< centre of the ball (the centre of the flat top face)
    double rb = 1;  ///< radius of the ball

    /// Signed distance to the boundary (> 0 inside, a lower bound of |distance| outside).
    [[nodiscard]] double operator()(const Vec3d& p) const noexcept {
        return std::min(rb - glm::length(p - c), c.z - p.z);
    }
    /// Distance along unit d from p (inside) to the boundary.
    [[nodiscard]] double exit_distance(const Vec3d& p, const Vec3d& d) const noexcept {
        const Vec3d rel = p - c;
        const double b = glm::dot(rel, d), cc = glm::dot(rel, rel) - rb * rb;
        double t = std::max(0.0, -b + std::sqrt(std::max(0.0, b * b - cc)));
        if (d.z > 0) t = std::min(t, std::max(0.0, (c.z - p.z) / d.z));
        return t;
    }
    /// Entry distance of a ray from outside (inf if it misses).
    [[nodiscard]] double entry(const gl::Ray<double>& r) const noexcept {
        constexpr double inf = std::numeric_limits<double>::infinity();
        const Vec3d rel = r.o - c;
        const double b = glm::dot(rel, r.d), cc = glm::dot(rel, rel) - rb * rb, disc = b * b - cc;
        if (disc < 0) return inf;
        const double sq = std::sqrt(disc);
        double t0 = -b - sq, t1 = -b + sq;  // inside the ball
        // Half-space z <= c.z.
        if (r.d.z > 0) t1 = std::min(t1, (c.z - r.o.z) / r.d.z);
        else if (r.d.z < 0) t0 = std::max(t0, (c.z - r.o.z) / r.d.z);
        else if (r.o.z > c.z) return inf;
        if (t0 > t1 || t1 < 1e-9) return inf;
        return std::max(t0, 0.0);
    }
    /// Outward normal of the boundary part nearest to p (inside: the face a shell step from p leaves
    /// through, for ShellFaceOptics): the flat top, or the sphere's radial direction. For the
    /// sphere the tracer treats the face as its tangent plane at the nearest point, at distance
    /// (*this)(p) along this normal.
    [[nodiscard]] Vec3d normal(const Vec3d& p) const noexcept {
        // |.|: on the boundary (the explicit tracer's faces) a point may be a round-off outside.
        if (std::abs(c.z - p.z) <= std::abs(rb - glm::length(p - c))) return Vec3d(0, 0, 1);
        return glm::normalize(p - c);
    }
};
/// Entry distance of a ray into the bowl (inf if it misses).
inline double volume_entry(const BowlVolume& v, const gl::Ray<double>& r) noexcept { return v.entry(r); }
/// Outward normal of the bowl's boundary part nearest to p (on the boundary).
inline Vec3d volume_normal(const BowlVolume& v, const Vec3d& p) noexcept { return v.normal(p); }

/// The Fig. 9 scene (and Fig. 11, Fig. 12): explicit spheres in a volume (a cube or a bowl), light,
/// blocker, a black floor or a diffuse table at z = 0.
template <class Vol>
struct VolumeScene {
    double L = 1, eta = 1.5;
    gl::PeriodicTile tile;  ///< the volume's spheres in a padded tile (images never reach the volume)
    Vol cube;               ///< the volume (named for the cube scenes; the bowl in Fig. 12)
    gl::Light<double, S1> light;
    gl::QuadShape<double> blocker;
    int max_events = 100000;
    bool cut = false;  ///< spheres cut by the volume's faces (glass faces there) instead of whole ones
    /// Cut spheres' flat faces index matched (no refraction, no Fresnel at the volume's faces): the
    /// scene the shells' exit rules describe (they leave along the in-medium direction).
    bool clear_faces = false;
    double spot_cos = -2;  ///< the light emits only within acos(spot_cos) of its normal (spotlight; -2: everywhere)
    double floor_albedo = 0;  ///< Lambertian albedo of the floor z = 0 (0: black, the cube scenes)
    int max_floor_bounces = 8;  ///< paths end after this many floor bounces

    /// Outward normal of the volume's boundary nearest to p.
    [[nodiscard]] Vec3d face_normal(const Vec3d& p) const noexcept { return volume_normal(cube, p); }
    double clock_mean = 2.0;  ///< mean path length between switch candidates (R)
    bool hand_back = false;   ///< high order: shells only where they fit, explicit tracing near the faces
    /// High order: a shell-traced path that leaves the volume continues into the scene (table
    /// bounce, its shadow ray, re-entry, shells again: the tracer's continuation hook) instead of
    /// ending at the boundary.
    bool continuation = false;
    bool table_nee = true;       ///< a shadow ray to the light at every table bounce (when floor_albedo > 0)
    int max_continuations = 16;  ///< a path leaves the volume through the shells at most this often

    /// Where radiance_from starts a path: the state it carries over from before.
    struct PathStart {
        int events = 0;              ///< explicit events so far (switch rule)
        bool handed = false;         ///< high order: the path has been through the shells (its light counts)
        bool skip_emission = false;  ///< the first segment's emission was estimated by a shadow ray
        int floor_bounces = 0;       ///< table bounces so far
        int continuations = 0;       ///< exits from the shells so far
    };

    /// The shell tracer's Env with the continuation hook (ShellContinuationEnv): a path that leaves
    /// the volume goes on through radiance_from (high order, its light counted).
    template <class Tracer>
    struct ContinuationEnv {
        const VolumeScene* scene;
        const Tracer* tracer;
        gl::ShellTraceStats* ts;
        PathStart start;
        [[nodiscard]] gl::LightSample<double, S1> sample_light(const Vec3d& p, const Vec3d& u) const noexcept {
            return scene->sample_light(p, u);
        }
        [[nodiscard]] bool visible(const Vec3d& p, const Vec3d& w, double dist) const noexcept {
            return scene->visible(p, w, dist);
        }
        [[nodiscard]] S1 escape(const gl::Ray<double>& r) const noexcept { return scene->escape(r); }
        [[nodiscard]] S1 continue_outside(const gl::Ray<double>& r, gl::Rng& rng, bool direct_counted) const noexcept {
            if (start.continuations > scene->max_continuations) return S1(0.0);
            PathStart s = start;
            s.skip_emission = direct_counted;
            return S1(scene->radiance_from(r.o + 1e-9 * scene->tile.radius() * r.d, r.d, rng, Mode::high, tracer,
                                           nullptr, ts, s));
        }
    };

    // --- the scene outside the medium (also the Env of the shell tracer) ---
    /// Radiance along a ray outside the cube: the light's front side, else black (blocker,
    /// floor z = 0, background). `t_cube`: the distance to the cube (inf: ignore it).
    /// `floor_t`: set to the distance to the floor when the floor is what the ray hits (else inf).
    [[nodiscard]] double outside(const gl::Ray<double>& r, double t_cube, bool& enters,
                                 double* floor_t = nullptr) const noexcept {
        enters = false;
        if (floor_t) *floor_t = std::numeric_limits<double>::infinity();
        if (r.o.z < 0) return 0.0;  // below the floor: absorbed
        double t_best = t_cube;
        int what = 0;  // 0 none/cube, 1 light, 2 blocker, 3 floor
        double t;
        Vec3d n;
        if (light.quad.intersect(r, t, n) && t < t_best && glm::dot(r.d, n) < 0 && -glm::dot(r.d, n) >= spot_cos) {
            t_best = t;
            what = 1;
        }
        if (blocker.intersect(r, t, n) && t < t_best) {
            t_best = t;
            what = 2;
        }
        if (r.d.z < 0 && r.o.z > 0) {
            const double tf = -r.o.z / r.d.z;
            if (tf < t_best) {
                t_best = tf;
                what = 3;
            }
        }
        if (what == 1) return light.power[0];
        if (what == 3 && floor_t) *floor_t = t_best;
        if (what == 0 && std::isfinite(t_cube)) enters = true;
        return 0.0;
    }
    [[nodiscard]] gl::LightSample<double, S1> sample_light(const Vec3d& p, const Vec3d& u) const noexcept {
        gl::LightSample<double, S1> ls = light.sample(p, gl::Vec2d(u.x, u.y));
        if (ls && -glm::dot(ls.w, light.quad.normal) < spot_cos) ls.pdf = 0;  // outside the spot cone
        return ls;
    }
    [[nodiscard]] bool visible(const Vec3d& p, const Vec3d& w, double dist) const noexcept {
        double t;
        Vec3d n;
        return !blocker.intersect(gl::Ray<double>(p, w, dist * (1 - 1e-9)), t, n);
    }
    [[nodiscard]] S1 escape(const gl::Ray<double>& r) const noexcept {
        bool enters;
        return S1(outside(r, std::numeric_limits<double>::infinity(), enters));
    }

    /// Entry distance of the ray into the volume (inf if it misses).
    [[nodiscard]] double cube_entry(const gl::Ray<double>& r) const noexcept { return volume_entry(cube, r); }

    /// One camera path. PT: explicit to the end. Low: explicit, stopped (0) when the switch rule
    /// fires. High: 0 unless the switch rule fires, then the shell tracer's radiance.
    template <class Tracer>
    [[nodiscard]] double radiance(gl::Ray<double> r, gl::Rng& rng, Mode mode, const Tracer* tracer,
                                  std::uint64_t* events_out = nullptr, gl::ShellTraceStats* ts = nullptr) const noexcept {
        return radiance_from(r.o, r.d, rng, mode, tracer, events_out, ts, PathStart{});
    }

    /// radiance() of a path at p (outside the volume) along unit d with the state `s0` (the
    /// continuation hook starts paths here where they leave the shells).
    template <class Tracer>
    [[nodiscard]] double radiance_from(Vec3d p, Vec3d d, gl::Rng& rng, Mode mode, const Tracer* tracer,
                                       std::uint64_t* events_out, gl::ShellTraceStats* ts,
                                       const PathStart& s0) const noexcept {
        bool in_cube = false, in_glass = false, has_last = false;
        Vec3d c(0.0);
        int events = s0.events;
        double clock = -1;  // path length to the next switch candidate (< 0: draw)
        bool handed = s0.handed;  // high order: the path came back from the shells
        double beta = 1;      // throughput factor from the shells (hand-back mode) and the table
        double acc = 0;       // light gathered by the table's shadow rays
        bool skip = s0.skip_emission;  // the next outside segment's emission is a shadow ray's
        const double R = tile.radius();
        int floor_bounces = s0.floor_bounces;
        for (int guard = 0; guard < max_events; ++guard) {
            if (!in_cube) {
                const bool skip_segment = skip;
                skip = false;
                const bool counting = mode != Mode::high || handed;
                const gl::Ray<double> ray(p, d);
                const double tc = cube_entry(ray);
                bool enters = false;
                double tf = std::numeric_limits<double>::infinity();
                const double Le = outside(ray, tc, enters, &tf);
                if (floor_albedo > 0 && std::isfinite(tf) && floor_bounces < max_floor_bounces) {
                    // Diffuse table: a cosine-weighted bounce (weight = albedo), in every mode.
                    ++floor_bounces;
                    p = ray(tf);
                    p.z = 1e-9 * R;
                    if (table_nee) {
                        // Shadow ray to the light: the direct segment (not through the volume, whose
                        // light is found by the path); the bounce direction's direct hit is then skipped.
                        const gl::LightSample<double, S1> ls =
                            sample_light(p, Vec3d(rng.uniform2<double>(), 0.0));
                        if (counting && ls && ls.w.z > 0 && visible(p, ls.w, ls.dist) &&
                            !(cube_entry(gl::Ray<double>(p, ls.w)) < ls.dist))
                            acc += beta * floor_albedo * ls.w.z / gl::pi_v<double> * ls.L[0] / ls.pdf;
                        skip = true;
                    }
                    d = gl::sample_cosine_hemisphere(rng.uniform2<double>());
                    beta *= floor_albedo;
                    continue;
                }
                if (!enters) {
                    if (events_out) *events_out += std::uint64_t(events);
                    return counting && !skip_segment ? acc + beta * Le : acc;
                }
                p += tc * d;
                in_cube = true;
                has_last = false;
                if (cut) {  // entering through a cut sphere: flat glass face
                    const gl::TileHit h = tile.first_hit(gl::Vec3i64{0, 0, 0}, p, d, 0.0, 1e-9);
                    if (h && h.t_enter < 0) {
                        if (!clear_faces) {
                            const Vec3d n = face_normal(p);
                            bool refracted = false;
                            double eta_rel = 1;
                            d = gl::sample_dielectric(d, n, eta, rng.uniform<double>(), refracted, eta_rel);
                            ++events;
                            if (!refracted) {
                                in_cube = false;
                                p += 1e-9 * n;
                                continue;
                            }
                        }
                        in_glass = true;
                        c = tile.center(h.sphere) + Vec3d(double(h.tile.x), double(h.tile.y), double(h.tile.z)) * tile.side();
                    }
                }
                continue;
            }
            double t;
            bool leaves = false;
            const double t_out = cube.exit_distance(p, d);
            if (in_glass) {
                const Vec3d rel = p - c;
                const double b = glm::dot(rel, d), cc = glm::dot(rel, rel) - R * R;
                t = std::max(0.0, -b + std::sqrt(std::max(0.0, b * b - cc)));
                if (cut && t_out < t) {  // the flat face of a cut sphere comes first
                    p += t_out * d;
                    if (clear_faces) {  // index matched: straight out
                        in_glass = false;
                        in_cube = false;
                        p += 1e-9 * tile.radius() * d;
                        continue;
                    }
                    const Vec3d n = face_normal(p);
                    bool refracted = false;
                    double eta_rel = 1;
                    d = gl::sample_dielectric(d, n, eta, rng.uniform<double>(), refracted, eta_rel);
                    ++events;
                    if (refracted) {
                        in_glass = false;
                        in_cube = false;
                        p += 1e-9 * n;
                    } else {
                        p -= 1e-9 * n;
                    }
                    continue;
                }
            } else {
                t = std::numeric_limits<double>::infinity();
                double t_min = 0;
                for (int k = 0; k < 4; ++k) {
                    const gl::TileHit h = tile.first_hit(gl::Vec3i64{0, 0, 0}, p, d, t_min, t_out);
                    if (!h) break;
                    const Vec3d cen = tile.center(h.sphere) + Vec3d(double(h.tile.x), double(h.tile.y), double(h.tile.z)) * tile.side();
                    if (has_last && glm::length(cen - c) < 1e-9 * R && h.t_enter < 1e-7 * R) {
                        t_min = h.t_exit;
                        continue;
                    }
                    c = cen;
                    t = std::max(0.0, h.t_enter);
                    break;
                }
                if (!std::isfinite(t)) {
                    t = t_out;
                    leaves = true;
                }
            }
            // Switch rule (Moon07 Sec. 4.2): once min_scatter events happened, candidate switch
            // points arrive along the path length as a Poisson clock (mean spacing clock_mean),
            // so a switch point is a typical point of the path, like the table's start frames
            // (SpherePackingShellSource: a random point along each path); the first candidate at
            // least the switch depth inside the volume switches.
            bool restart = false;  // handed back from the shells: continue from the new state
            if (mode != Mode::pt && tracer && events >= tracer->options().min_scatter) {
                double along = 0;
                for (;;) {
                    if (!(clock >= 0)) clock = gl::sample_exponential(rng.uniform<double>(), 1.0 / clock_mean);
                    if (along + clock >= t) {
                        clock -= t - along;
                        break;
                    }
                    along += clock;
                    clock = -1;
                    const Vec3d x = p + along * d;
                    if (tracer->may_switch(x, events)) {
                        if (events_out && !hand_back) *events_out += std::uint64_t(events);
                        if (mode == Mode::low) return acc;
                        if (!hand_back && !continuation) return acc + beta * tracer->trace(x, d, rng, *this, ts)[0];
                        if (!hand_back)  // continuation hook: a path leaving the shells goes on in the scene
                            return acc + beta * tracer->trace(x, d, rng,
                                                              ContinuationEnv<Tracer>{this, tracer, ts,
                                                                                      PathStart{events, true, false, floor_bounces,
                                                                                                s0.continuations + 1}},
                                                              ts)[0];
                        // Hand-back mode: shells where they fit, then explicit tracing again from
                        // the hand-back point in the scene's own spheres (glass if it lies in one).
                        const gl::ShellHandBack<S1> hb = tracer->trace_to_boundary(x, d, rng, ts);
                        if (!hb.handed_back) return acc;
                        handed = true;
                        beta *= hb.beta;
                        p = hb.x;
                        d = hb.omega;
                        clock = -1;
                        has_last = false;
                        in_glass = false;
                        if (const auto sc = tile.sphere_containing(p)) {
                            c = sc->center;
                            const double b = glm::length(glm::cross(p - c, d));
                            if (b * eta <= R) {
                                in_glass = true;  // a chord a ray from outside can follow
                            } else {  // a trapped chord: pass this sphere (leave at its far side)
                                const Vec3d rel = p - c;
                                const double bb = glm::dot(rel, d), cc = glm::dot(rel, rel) - R * R;
                                p += std::max(0.0, -bb + std::sqrt(std::max(0.0, bb * bb - cc))) * d;
                                has_last = true;
                            }
                        }
                        restart = true;
                        break;
                    }
                }
            }
            if (restart) continue;
            if (leaves) {  // leaves the cube (air to air, index matched)
                p += t_out * d;
                in_cube = false;
                continue;
            }
            // Interface event at a sphere: Fresnel reflection or refraction.
            p += t * d;
            const Vec3d n = glm::normalize(p - c);
            bool refracted = false;
            double eta_rel = 1;
            d = gl::sample_dielectric(d, n, eta, rng.uniform<double>(), refracted, eta_rel);
            if (refracted) in_glass = !in_glass;
            has_last = true;
            ++events;
        }
        if (events_out) *events_out += std::uint64_t(events);
        return acc;
    }
};

/// The Moon07 cube scene (moon07_fig9_cube_shadow, moon07_fig11_spotlight).
using CubeScene = VolumeScene<gl::BoxDistance>;
/// The pixels of a W x H camera whose centre ray enters the scene's volume (1) or not (0), and
/// their count; throws when fewer than 16 do (`what` names the volume in the message).
template <class SceneT, class Camera>
[[nodiscard]] std::vector<char> volume_pixel_mask(const SceneT& scene, const Camera& cam, int W, int H,
                                                  std::size_t& n_mask, const std::string& what) {
    std::vector<char> mask(std::size_t(W) * std::size_t(H), 0);
    n_mask = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const gl::Ray<double> r = cam.generate_ray(x + 0.5, y + 0.5);
            bool enters = false;
            (void)scene.outside(r, scene.cube_entry(r), enters);
            mask[std::size_t(y) * std::size_t(W) + std::size_t(x)] = enters;
            n_mask += enters;
        }
    if (n_mask < 16) throw std::runtime_error("the camera sees fewer than 16 " + what + " pixels");
    return mask;
}

/// A shell table cached on disk: loaded from `path` when it exists (unless `rebuild`), else built
/// from the samples `sample()` returns (build_shell_table with `bo`) and saved there (if `save`).
struct CachedShellTable {
    gl::ShellTable table;
    double build_seconds = 0;   ///< CPU seconds to load or build it
    double nmf_error = -1;      ///< NMF relative error of a built table (-1 when loaded)
    bool cached = false;        ///< loaded from `path`
    double raw_bytes = 0;       ///< the unfactored grid's size
    double factored_bytes = 0;  ///< the stored factors' size
};
template <class Sample>
[[nodiscard]] CachedShellTable cached_shell_table(const std::filesystem::path& path, bool rebuild,
                                                  const gl::ShellBuildOptions& bo, Sample&& sample, bool save = true) {
    CachedShellTable c;
    const double b0 = cpu_seconds();
    if (!rebuild && std::filesystem::exists(path)) {
        c.table = gl::ShellTable::load(path);
        c.cached = true;
        // A table cached with another grid or cos-cell layout (e.g. SHEL v1, equal cos cells) is stale.
        if (c.table.n_c != bo.n_c || c.table.n_u != bo.n_u || c.table.n_v != bo.n_v || c.table.rank != bo.rank ||
            c.table.cos_cells != bo.cos_cells)
            c.cached = false;
    }
    if (!c.cached) {
        gl::ShellBuildResult built = gl::build_shell_table(sample(), bo);
        c.nmf_error = built.nmf_relative_error;
        c.table = std::move(built.table);
        if (save) c.table.save(path);  // MPI: every rank builds the same table, rank 0 saves it
    }
    c.build_seconds = cpu_seconds() - b0;
    c.raw_bytes = double(c.table.n_shells()) * bo.n_c * bo.n_u * bo.n_v * sizeof(float);
    c.factored_bytes = double(c.table.W.size() + c.table.H.size() + c.table.fa.size()) * sizeof(float);
    return c;
}

/// The switch-rule, shell-table and high-order options the Moon07 scene examples (Figs. 9, 11, 12)
/// share: declared on the Example in one place (`volume` names the volume in the help texts),
/// checked by check() after ready().
struct ShellSceneOptions {
    int spp_low = 16;                 ///< low-order samples per pixel per batch
    int spp_high = 8;                 ///< high-order (shell) samples per pixel per batch
    int min_scatter = 3;              ///< switch rule: explicit interface events before shells
    double switch_depth = 2.0;        ///< switch rule: depth below the surface to switch (R)
    std::uint64_t shell_paths = 0;    ///< paths of the shell precomputation
    int n_radii = 0;                  ///< number of shell radii
    double shell_r0 = 2.0;            ///< smallest shell radius r_0 (R)
    bool rebuild_table = false;       ///< ignore a cached shell table in --out
    bool no_nee = false;              ///< high order without Fig. 6's shadow rays
    std::string exit_rule = "table";  ///< radial (Moon07) or table
    bool hand_back = false;           ///< explicit tracing within r_0 of the faces
    std::string cos_cells = "angle";  ///< cos theta_1 cells of the shell table: angle (equal theta_1) or cos

    /// `spp_low_default`, `spp_high_default`: the example's defaults of --spp-low / --spp-high.
    static ShellSceneOptions declare(gl_examples::Example& ex, const std::string& volume, int spp_low_default = 16,
                                     int spp_high_default = 8) {
        ShellSceneOptions o;
        o.spp_low = ex.opt<int>("spp-low", spp_low_default, "low-order samples per pixel per batch");
        o.spp_high = ex.opt<int>("spp-high", spp_high_default, "high-order (shell) samples per pixel per batch");
        o.min_scatter = ex.opt<int>("min-scatter", 3, "switch rule: explicit interface events before shells");
        o.switch_depth = ex.opt<double>(
            "switch-depth", 2.0, "switch rule: depth below the " + volume + " surface to switch (R; default r_0 = 2)");
        o.shell_paths = ex.opt<std::uint64_t>("shell-paths", 20000, 500000, "paths of the shell precomputation");
        o.n_radii = ex.opt<int>("shell-radii", 8, 12, "number of shell radii (paper: 12-16)");
        o.shell_r0 = ex.opt<double>("shell-r0", 2.0, "smallest shell radius r_0 (R; the correlation length)");
        o.rebuild_table = ex.opt<bool>("rebuild-table", false, "ignore a cached shell table in --out");
        o.no_nee = ex.opt<bool>("no-nee", false, "high order without Fig. 6's shadow rays (count escapes that hit the light)");
        o.exit_rule = ex.opt<std::string>(
            "exit-rule", "table",
            "exits outside the " + volume + ": radial (Moon07: along y - x) or table (along the sampled T_r direction)");
        o.cos_cells = ex.opt<std::string>(
            "cos-cells", "angle",
            "shell table cells in cos theta_1: angle (equal widths in theta_1, resolves the forward peak) or cos (equal widths in cos theta_1, the tables before)");
        o.hand_back = ex.opt<bool>(
            "hand-back", false,
            "high order: shells only where they fit, explicit tracing within r_0 of the faces (no exit rule, no shadow rays)");
        return o;
    }
    /// The tracer's switch rule, shadow rays and exit rule from these options (R: sphere radius;
    /// with hand_back the explicit zone is r_0 deep and the scene must trace to the boundary).
    [[nodiscard]] gl::ShellTracerOptions tracer_options(double R) const {
        gl::ShellTracerOptions to;
        to.min_scatter = min_scatter;
        to.switch_depth = switch_depth;
        to.nee = !no_nee;
        to.exit_rule = exit_rule == "table" ? gl::ShellExitRule::table : gl::ShellExitRule::radial;
        if (hand_back) to.hand_back_depth = shell_r0 * R;
        return to;
    }
    /// The shell table's cos theta_1 cell layout (--cos-cells).
    [[nodiscard]] gl::ShellCosCells cos_layout() const {
        return cos_cells == "cos" ? gl::ShellCosCells::uniform_cos : gl::ShellCosCells::uniform_angle;
    }
    /// Throws cli_error naming the option, the value and the valid range.
    void check() const {
        using gl_examples::cli_error;
        if (cos_cells != "angle" && cos_cells != "cos")
            throw cli_error("--cos-cells = " + cos_cells + " must be angle or cos");
        if (spp_low < 1 || spp_high < 1)
            throw cli_error("--spp-low = " + std::to_string(spp_low) + ", --spp-high = " + std::to_string(spp_high) +
                            " must be >= 1");
        if (n_radii < 2 || n_radii > 64) throw cli_error("--shell-radii = " + std::to_string(n_radii) + " must be in [2, 64]");
        if (exit_rule != "radial" && exit_rule != "table")
            throw cli_error("--exit-rule = " + exit_rule + " must be radial or table");
        if (shell_paths < 1000) throw cli_error("--shell-paths = " + std::to_string(shell_paths) + " must be >= 1000");
        if (!(shell_r0 > 0 && shell_r0 < 1e6))
            throw cli_error("--shell-r0 = " + std::to_string(shell_r0) + " must be in (0, 1e6)");
        if (!(switch_depth >= 0 && switch_depth < 1e6))
            throw cli_error("--switch-depth = " + std::to_string(switch_depth) + " must be in [0, 1e6)");
    }
};

/// Face optics at the shell exit (Figs. 9, 11, 12; ShellFaceOptics, integrators/shell_tracer.hpp):
/// `--face-optics on|off` (default on). With it, a shell step that leaves the volume crosses the
/// face inside glass with the probability q(|cos theta|) measured on the packing's own paths
/// (plane_crossing_glass_fraction, 8 cells), and is Fresnel-reflected back or refracted out there.
struct FaceOpticsOption {
    bool on = true;
    static FaceOpticsOption declare(gl_examples::Example& ex) {
        FaceOpticsOption f;
        const std::string v = ex.opt<std::string>(
            "face-optics", "on",
            "on: shell exits through a face of the volume meet its glass-air interface with the measured glass fraction q(|cos|) (Fresnel reflection back, refraction out); off: they leave straight (Moon07)");
        if (v != "on" && v != "off") throw gl_examples::cli_error("--face-optics = " + v + " must be on or off");
        f.on = v == "on";
        return f;
    }
    /// The tracer's face optics for a scene whose faces are glass (cut spheres, not index matched);
    /// off otherwise. `q_mean` receives the crossing-weighted mean of q (0 when off).
    [[nodiscard]] gl::ShellFaceOptics optics(const gl::PeriodicTile& rsa, double eta, bool glass_faces, bool full,
                                             std::uint64_t seed, double& q_mean) const {
        q_mean = 0;
        if (!on || !glass_faces) return {};
        const double R = rsa.radius();
        gl::ShellFaceOptics f;
        f.eta = eta;
        f.q = gl::plane_crossing_glass_fraction(rsa, eta, 8, full ? 4000 : 1000, 400 * R, 20 * R, seed ^ 0xFACEu);
        for (const double v : f.q) q_mean += v / double(f.q.size());
        return f;
    }
};

/// The shell table of a scene of random glass spheres (Figs. 9, 11, 12): --shell-radii radii evenly
/// from r_0 to r_max, the scene's grid (full 50 x 50 x 25, quick 24 x 16 x 16 cells, rank 5),
/// sampled from the scene's own RSA packing (the medium's random process: ior 1.5, no absorption,
/// paths cut at 20 R), cached in `out` as <file_prefix><parameters>.shel (saved when `save`, i.e.
/// by MPI rank 0); one log line on stderr under `tag`.
[[nodiscard]] inline CachedShellTable scene_shell_table(const ShellSceneOptions& so, const gl::PeriodicTile& rsa,
                                                        double R, double r_max, bool full, const std::string& file_prefix,
                                                        std::size_t n_spheres, double fraction, std::uint64_t seed,
                                                        const std::filesystem::path& out, bool save,
                                                        const std::string& tag) {
    std::vector<double> radii(static_cast<std::size_t>(so.n_radii), 0.0);
    const double r0 = so.shell_r0 * R;
    for (int i = 0; i < so.n_radii; ++i) radii[std::size_t(i)] = r0 + (r_max - r0) * double(i) / double(so.n_radii - 1);
    gl::ShellBuildOptions bo;
    bo.n_c = full ? 50 : 24;
    bo.n_u = full ? 50 : 16;
    bo.n_v = full ? 25 : 16;
    bo.rank = 5;
    bo.cos_cells = so.cos_layout();
    const std::string key = std::to_string(n_spheres) + "_" + std::to_string(int(fraction * 1000)) + "_" +
                            std::to_string(so.shell_paths) + "_" + std::to_string(so.n_radii) + "_" +
                            std::to_string(bo.n_c) + "x" + std::to_string(bo.n_u) + "x" + std::to_string(bo.n_v) +
                            "_r" + std::to_string(int(so.shell_r0 * 100)) + "_s" + std::to_string(seed);
    const std::filesystem::path table_path = out / (file_prefix + key + ".shel");
    CachedShellTable ct = cached_shell_table(table_path, so.rebuild_table, bo, [&] {
        const gl::SpherePackingShellSource src(rsa, 1.5, 0.0, 20 * R);
        return gl::collect_shell_samples(src, radii, so.shell_paths, seed ^ 0x9u);
    }, save);
    std::cerr << tag << ": shell table " << (ct.cached ? "loaded" : "built") << " (" << ct.build_seconds
              << " CPU s), " << ct.table.n_shells() << " radii " << radii.front() << ".." << radii.back()
              << " R, raw " << ct.raw_bytes / 1024 << " KiB -> factored " << ct.factored_bytes / 1024 << " KiB\n";
    return ct;
}

/// Per-pixel batch statistics of B renders.
struct BatchImages {
    int W = 0, H = 0, B = 0;
    std::vector<std::vector<double>> img;  // [batch][pixel]
    double cpu = 0;
    [[nodiscard]] double mean(std::size_t i) const {
        double s = 0;
        for (const auto& b : img) s += b[i];
        return s / double(B);
    }
    /// Variance of the batch mean at pixel i.
    [[nodiscard]] double var_mean(std::size_t i) const {
        const double m = mean(i);
        double s = 0;
        for (const auto& b : img) s += (b[i] - m) * (b[i] - m);
        return s / double(B - 1) / double(B);
    }
};

/// Path tracing (`pt`) against low-order PT + shells (`lo` + `hi`) over the pixels of `mask`
/// (the volume's pixels), as Figs. 9, 11 and 12 report it: means, per-pixel variances of the batch
/// means, the bias of the shells' mean with its standard error from the batches, the shells'
/// error against the truth (variance plus the squared bias beyond the noise of both means,
/// measuring.md), and the equal-error and time-to-unit-variance speed-ups.
struct ShellVsPt {
    std::size_t NP = 0;                          ///< pixels of the image
    double nm = 0;                               ///< pixels in the mask
    std::vector<double> I_pt, I_lo, I_hi, I_sh;  ///< per-pixel means (I_sh = I_lo + I_hi)
    double sum_pt = 0, sum_sh = 0, sum_lo = 0, sum_hi = 0;  ///< sums over the mask
    double mean_pt = 0, mean_sh = 0;             ///< means over the mask
    double var_pt = 0, var_sh = 0;               ///< mean per-pixel variance of the batch means
    double mse_sh_pixelwise = 0;                 ///< pixel-wise MSE estimate (reference-noise dominated)
    double se_pt = 0, se_sh = 0;                 ///< standard errors of the masked means (batches)
    double bias2 = 0, mse_sh = 0;                ///< squared bias beyond noise; shells' MSE
    double rmse_pt = 0, rmse_sh = 0;             ///< root of var_pt and mse_sh
    double bias_rel = 0, bias_rel_se = 0;        ///< (mean_sh - mean_pt) / mean_pt and its error
    double t_shells = 0, speedup = 0, ttuv_ratio = 0;  ///< CPU s of low + high; the two speed-ups
};

/// The comparison keys every Moon07 scene example's JSON line carries (issue 10: seconds_pt,
/// seconds_low, seconds_high, rmse_pt, rmse_shells, speedup_equal_error, mean_pt, mean_shells;
/// with the low / high split of the mean, the bias and its standard error, the ttuv ratio).
inline void add_comparison_json(gl_examples::Json& j, const ShellVsPt& st, double seconds_pt, double seconds_low,
                                double seconds_high) {
    j.num("seconds_pt", seconds_pt)
        .num("seconds_low", seconds_low)
        .num("seconds_high", seconds_high)
        .num("rmse_pt", st.rmse_pt)
        .num("rmse_shells", st.rmse_sh)
        .num("speedup_equal_error", st.speedup)
        .num("mean_pt", st.mean_pt)
        .num("mean_shells", st.mean_sh)
        .num("mean_low", st.sum_lo / st.nm)
        .num("mean_high", st.sum_hi / st.nm)
        .num("bias_rel", st.bias_rel)
        .num("exit_rule_bias", st.bias_rel)
        .num("bias_rel_se", st.bias_rel_se)
        .num("ttuv_ratio", st.ttuv_ratio);
}
/// The high-order pass's tracer statistics (fraction of samples switched to shells, shell steps
/// per switched path, fraction leaving by the exit rule); `high_samples` = high-order samples
/// over the mask.
inline void add_tracer_json(gl_examples::Json& j, const gl::ShellTraceStats& ts, double high_samples) {
    j.num("switched_fraction", double(ts.paths) / high_samples)
        .num("shell_steps_per_switched_path", ts.paths ? double(ts.steps) / double(ts.paths) : 0.0)
        .num("exit_fraction", ts.paths ? double(ts.exits) / double(ts.paths) : 0.0)
        .num("face_reflections_per_switched_path", ts.paths ? double(ts.face_reflections) / double(ts.paths) : 0.0);
}
/// The shell table's keys (build or load CPU seconds, cached, NMF error, raw and factored bytes).
inline void add_table_json(gl_examples::Json& j, const CachedShellTable& ct) {
    j.num("shell_build_cpu_seconds", ct.build_seconds)
        .boolean("shell_table_cached", ct.cached)
        .num("nmf_error", ct.nmf_error)
        .num("shell_raw_bytes", ct.raw_bytes)
        .num("shell_factored_bytes", ct.factored_bytes);
}

inline ShellVsPt compare_shells_to_pt(const BatchImages& pt, const BatchImages& lo, const BatchImages& hi,
                                      const std::vector<char>& mask) {
    ShellVsPt r;
    const std::size_t NP = std::size_t(pt.W) * std::size_t(pt.H);
    r.NP = NP;
    r.I_pt.resize(NP);
    r.I_lo.resize(NP);
    r.I_hi.resize(NP);
    r.I_sh.resize(NP);
    double sq = 0;
    std::size_t n_mask = 0;
    for (std::size_t i = 0; i < NP; ++i) {
        r.I_pt[i] = pt.mean(i);
        r.I_lo[i] = lo.mean(i);
        r.I_hi[i] = hi.mean(i);
        r.I_sh[i] = r.I_lo[i] + r.I_hi[i];
        if (!mask[i]) continue;
        ++n_mask;
        r.sum_pt += r.I_pt[i];
        r.sum_sh += r.I_sh[i];
        r.sum_lo += r.I_lo[i];
        r.sum_hi += r.I_hi[i];
        r.var_pt += pt.var_mean(i);
        r.var_sh += lo.var_mean(i) + hi.var_mean(i);
        sq += (r.I_sh[i] - r.I_pt[i]) * (r.I_sh[i] - r.I_pt[i]);
    }
    const double nm = double(n_mask);
    r.nm = nm;
    r.mean_pt = r.sum_pt / nm;
    r.mean_sh = r.sum_sh / nm;
    r.var_pt /= nm;
    r.var_sh /= nm;
    // Pixel-wise estimate (noisy: dominated by the reference's own variance at these budgets).
    r.mse_sh_pixelwise = std::max(sq / nm - r.var_pt, r.var_sh);
    // Bias of the mean over the masked pixels (exit rule + table), standard error from batches.
    auto region_se = [&](const BatchImages& bi) {
        std::vector<double> m(std::size_t(bi.B), 0.0);
        for (int b = 0; b < bi.B; ++b)
            for (std::size_t i = 0; i < NP; ++i)
                if (mask[i]) m[std::size_t(b)] += bi.img[std::size_t(b)][i] / nm;
        gl::Welford w;
        for (double v : m) w.add(v);
        return w.standard_error();
    };
    r.se_pt = region_se(pt);
    r.se_sh = std::hypot(region_se(lo), region_se(hi));
    // Error of the shell image against the truth: its variance plus the squared bias of the masked
    // mean, less the part of that difference explained by the noise of both means (a bias inside
    // the noise counts as zero; measuring.md).
    r.bias2 = std::max(0.0, (r.mean_sh - r.mean_pt) * (r.mean_sh - r.mean_pt) - r.se_pt * r.se_pt - r.se_sh * r.se_sh);
    r.mse_sh = r.var_sh + r.bias2;
    r.rmse_pt = std::sqrt(r.var_pt);
    r.rmse_sh = std::sqrt(r.mse_sh);
    r.bias_rel = (r.mean_sh - r.mean_pt) / r.mean_pt;
    r.bias_rel_se = std::hypot(r.se_pt, r.se_sh) / r.mean_pt;
    r.t_shells = lo.cpu + hi.cpu;
    r.speedup = pt.cpu * r.var_pt / r.mse_sh / r.t_shells;
    // Variance-only (time to unit variance) ratio: the speed-up if the bias were zero.
    r.ttuv_ratio = (pt.cpu * r.var_pt) / (r.t_shells * r.var_sh);
    return r;
}

/// Where a batch render gets its checkpoint, progress bar and row share: the harness Example
/// (checkpoint_for, ex.progress, rows y % ranks == rank gathered on rank 0), or none (no
/// checkpoint, a plain progress bar, every row).
struct BatchHooks {
    const gl_examples::Example* ex = nullptr;  ///< harness example (checkpoint_for, progress, MPI)
    [[nodiscard]] gl::CheckpointOptions checkpoint(const std::string& stem) const {
        return ex ? gl_examples::checkpoint_for(*ex, stem) : gl::CheckpointOptions{};
    }
    [[nodiscard]] gl_examples::ProgressBar progress(const std::string& label, std::uint64_t total) const {
        return ex ? ex->progress(label, total) : gl_examples::ProgressBar(label, total);
    }
};

template <class Fn>
BatchImages render_batches(const gl::PinholeCamera<double>& cam, int spp, int B, std::uint64_t seed, int threads,
                           const std::string& label, Fn&& fn, const BatchHooks& hooks) {
    BatchImages out;
    out.W = cam.width();
    out.H = cam.height();
    out.B = B;
    auto bar = hooks.progress(label, std::uint64_t(B) * std::uint64_t(cam.height()));
    double cpu = 0;  // this rank's render time (the gathers' waiting is not counted)
    for (int b = 0; b < B; ++b) {
        gl::RenderOptions ro;
        ro.spp = spp;
        ro.seed = seed * 1000003u + std::uint64_t(b);
        ro.threads = threads;
        if (hooks.ex) {  // MPI: this rank's rows (y % ranks == rank), gathered on rank 0 below
            ro.row_offset = hooks.ex->rank();
            ro.row_stride = hooks.ex->ranks();
        }
        ro.checkpoint = hooks.checkpoint(label + ".b" + std::to_string(b));
        const double c0 = cpu_seconds();
        gl::Film film = gl::render_image(
            cam, [&](const gl::Ray<double>& r, gl::Rng& rng) { return S1(fn(r, rng)); }, ro,
            [&](int n) { bar.advance(std::uint64_t(n)); });
        cpu += cpu_seconds() - c0;
        if (hooks.ex) film = hooks.ex->mpi().gather_film_rows(film);  // rank 0: every row; others: empty
        std::vector<double> v;
        if (film.width() == out.W && film.height() == out.H) {
            v.resize(std::size_t(out.W) * std::size_t(out.H));
            for (int y = 0; y < out.H; ++y)
                for (int x = 0; x < out.W; ++x) v[std::size_t(y) * std::size_t(out.W) + std::size_t(x)] = film.value(x, y, 0);
        }
        out.img.push_back(std::move(v));
    }
    bar.done();
    out.cpu = hooks.ex ? hooks.ex->mpi().sum_to_root({cpu})[0] : cpu;  // CPU s of all ranks
    return out;
}

void write_image(const std::filesystem::path& dir, const std::string& name, const std::vector<double>& v, int W, int H,
                 double scale) {
    gl::Image img(W, H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            for (int ch = 0; ch < 3; ++ch) img.at(x, y, ch) = float(v[std::size_t(y) * std::size_t(W) + std::size_t(x)]);
    gl::write_exr(dir / (name + ".exr"), img);
    gl::write_png(dir / (name + ".png"), img, {std::log2(scale)});
}

/// The three renders of a Moon07 scene example and the summed shell-step tallies of the high order.
struct ShellPasses {
    BatchImages pt, lo, hi;   ///< path tracing, low order, high order (shells)
    gl::ShellTraceStats ts;   ///< tallies of the shell-traced parts (rows rendered by this run)
};

/// Path tracing (seed), low order (seed + 1) and high order (seed + 2) in B batches each, labelled
/// "<tag> path tracing", "<tag> low order", "<tag> high order (shells)" (the checkpoint names).
/// `radiance(ray, rng, mode, stats)` is one camera path (stats: per-thread tallies, high order only).
template <class Radiance>
ShellPasses render_shell_passes(const gl::PinholeCamera<double>& cam, int spp_pt, int spp_low, int spp_high, int B,
                                std::uint64_t seed, int threads, const std::string& tag, Radiance&& radiance,
                                const BatchHooks& hooks) {
    ShellPasses p;
    p.pt = render_batches(cam, spp_pt, B, seed, threads, tag + " path tracing",
                          [&](const gl::Ray<double>& r, gl::Rng& rng) { return radiance(r, rng, Mode::pt, nullptr); },
                          hooks);
    p.lo = render_batches(cam, spp_low, B, seed + 1, threads, tag + " low order",
                          [&](const gl::Ray<double>& r, gl::Rng& rng) { return radiance(r, rng, Mode::low, nullptr); },
                          hooks);
    std::vector<gl::ShellTraceStats> tstats(256);  // per thread, summed after the render
    p.hi = render_batches(cam, spp_high, B, seed + 2, threads, tag + " high order (shells)",
                          [&](const gl::Ray<double>& r, gl::Rng& rng) {
#if defined(_OPENMP)
                              const int tid = std::min(255, omp_get_thread_num());
#else
                              const int tid = 0;
#endif
                              return radiance(r, rng, Mode::high, &tstats[std::size_t(tid)]);
                          },
                          hooks);
    // Every counter of ShellTraceStats, listed once: summed over threads, then over ranks.
    using TS = gl::ShellTraceStats;
    constexpr std::uint64_t TS::* counters[] = {&TS::paths, &TS::steps, &TS::scattered, &TS::exits,
                                                &TS::straight_escapes, &TS::face_reflections};
    for (const auto& t : tstats)
        for (auto c : counters) p.ts.*c += t.*c;
    if (hooks.ex) {  // every rank's tallies, summed on rank 0 (exact as doubles below 2^53)
        std::vector<double> mine;
        for (auto c : counters) mine.push_back(double(p.ts.*c));
        const std::vector<double> all = hooks.ex->mpi().sum_to_root(mine);
        for (std::size_t i = 0; i < std::size(counters); ++i) p.ts.*counters[i] = std::uint64_t(all[i]);
    }
    return p;
}

/// As above for a harness example: its seed and threads, checkpoint_for(ex, ...) per batch
/// render (removed by ex.finish(); one file per rank under MPI), progress bars through
/// ex.progress, and under MPI (`mpirun -np K`) rank r renders the rows y % K == r of every batch,
/// gathered on rank 0 (the images there are byte-identical to one process's; the other ranks'
/// BatchImages hold empty images: they should return ex.finish({}) after this call); CPU
/// seconds and shell-step tallies are summed over the ranks (MpiSession::sum_to_root).
template <class Radiance>
ShellPasses render_shell_passes(const gl_examples::Example& ex, const gl::PinholeCamera<double>& cam, int spp_pt,
                                int spp_low, int spp_high, int B, const std::string& tag, Radiance&& radiance) {
    return render_shell_passes(cam, spp_pt, spp_low, spp_high, B, ex.seed(), ex.threads(), tag,
                               std::forward<Radiance>(radiance), BatchHooks{&ex});
}

/// The four images <prefix>_{pt,shells,low,high}.exr/.png at the exposure 0.35 / mean_pt.
inline void write_shell_images(const std::filesystem::path& dir, const std::string& prefix, const ShellVsPt& st, int W,
                               int H) {
    const double scale = 0.35 / std::max(1e-12, st.mean_pt);
    write_image(dir, prefix + "_pt", st.I_pt, W, H, scale);
    write_image(dir, prefix + "_shells", st.I_sh, W, H, scale);
    write_image(dir, prefix + "_low", st.I_lo, W, H, scale);
    write_image(dir, prefix + "_high", st.I_hi, W, H, scale);
}

}  // namespace
