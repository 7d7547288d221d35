// moon07_fig13_grains: Moon07 Fig. 13 with procedural grains instead of the paper's glass Buddha
// meshes: a bowl of ~10 000 lossless dielectric grain meshes (a Meng15 procedural aggregate,
// traversal/aggregate.hpp GranularAggregate, with a mix of geometry/grains.hpp presets) resting on
// a diffuse table under an area light, rendered (a) by explicit path tracing through the grain
// meshes (EPT: Algorithm 1 traversal and grain sojourns, integrators/ept.hpp) and (b) by
// low-order EPT + high-order shells (integrators/shell_tracer.hpp) with shells built from the
// same aggregate (precompute/shell_builder.hpp GrainAggregateShellSource), with the equal-error
// speed-up and the same JSON keys as moon07_fig9_cube_shadow / moon07_fig12_bowl.
//
//   moon07_fig13_grains [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//        [--grains N] [--presets A,B] [--width W] [--spp-pt N] [--spp-low N] [--spp-high N]
//        [--batches B] [--min-scatter K] [--switch-depth D] [--table-albedo A] [--shell-paths N]
//        [--shell-radii N] [--mesh-level L] [--rebuild-table] [--no-continuation]
//        [--checkpoint SECONDS] [--resume]
//
// Scene (units: the grains' bounding radius R = 1): bounding spheres of a periodic RSA packing
// (f = 0.3, 128 per tile) carry one randomly rotated grain each (exemplars: --presets, equal
// weights; default sugar crystals and snow grains, eta 1.56 / 1.31, no absorption); grains whose
// centre lies in the bowl (the lower half of a ball of radius R_b, N = 0.15 R_b^3 grains, the flat
// top at its rim) are kept. The bowl's lowest point is R above the Lambertian table z = 0 (albedo
// 0.5) so no grain reaches below it; a square light of side 0.3 D at 1.5 D faces down
// (D = 2 R_b). The shell table comes from the same aggregate process over all space (host-point
// frames, as the switch points are), radii 2 R .. 0.45 R_b. Switch rule: after --min-scatter
// grain interactions, candidates along the path length in the host as a Poisson clock (mean 2 R),
// the first one at least --switch-depth inside the bowl switches. A path leaving the bowl through
// the shells continues into the scene (the tracer's continuation hook: table bounce, re-entry).
// Measurement as in moon07_fig12_bowl (batches, ../shared/reference/measuring.md) over the pixels
// that see the bowl. JSON (last stdout line): seconds_pt, seconds_low, seconds_high, rmse_pt,
// rmse_shells, speedup_equal_error, mean_pt, mean_shells, exit_rule_bias, bias_rel_se,
// shell_raw_bytes, shell_factored_bytes, grains, paper values (Fig. 13 gives no timing).
#include <sstream>

#include "grainlight/geometry/voxelized_boundary.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/traversal/aggregate.hpp"
#include "moon07_cube_scene.hpp"

namespace {

/// The bowl as an aggregate boundary (BoundaryShape): centres with BowlVolume >= 0.
struct BowlShape {
    BowlVolume v;
    [[nodiscard]] bool inside(const Vec3d& p) const noexcept { return v(p) >= 0; }
    [[nodiscard]] gl::Aabb<double> bounds() const noexcept {
        return {v.c - Vec3d(v.rb, v.rb, v.rb), v.c + Vec3d(v.rb, v.rb, 0.0)};
    }
    /// Conservative class of a box: the ball's exact class combined with the half-space z <= c.z.
    [[nodiscard]] gl::VoxelClass classify_box(const Vec3d& lo, const Vec3d& hi) const noexcept {
        const gl::VoxelClass ball = gl::SphereBoundary(v.c, v.rb).classify_box(lo, hi);
        const gl::VoxelClass half = hi.z <= v.c.z ? gl::VoxelClass::inside
                                    : lo.z >= v.c.z ? gl::VoxelClass::outside
                                                    : gl::VoxelClass::partial;
        if (ball == gl::VoxelClass::outside || half == gl::VoxelClass::outside) return gl::VoxelClass::outside;
        if (ball == gl::VoxelClass::inside && half == gl::VoxelClass::inside) return gl::VoxelClass::inside;
        return gl::VoxelClass::partial;
    }
};

using Agg = gl::GranularAggregate<BowlShape>;

/// The Fig. 13 scene: the grain bowl, the table z = 0, the light; one camera path for PT / low /
/// high order (switch rule + ShellTracer with the continuation hook).
struct GrainBowlScene {
    const Agg* agg = nullptr;
    BowlVolume bowl;
    gl::Light<double, S1> light;
    double floor_albedo = 0.5;
    int max_floor_bounces = 8;
    int max_events = 100000;
    double clock_mean = 2.0;
    bool continuation = true;
    int max_continuations = 16;

    struct PathStart {
        int events = 0;
        bool handed = false;
        bool skip_emission = false;
        int floor_bounces = 0;
        int continuations = 0;
    };

    [[nodiscard]] gl::LightSample<double, S1> sample_light(const Vec3d& p, const Vec3d& u) const noexcept {
        return light.sample(p, gl::Vec2d(u.x, u.y));
    }
    /// Shadow rays of the shell tracer: the medium is the shells' business, nothing else blocks.
    [[nodiscard]] bool visible(const Vec3d&, const Vec3d&, double) const noexcept { return true; }
    [[nodiscard]] S1 escape(const gl::Ray<double>& r) const noexcept {
        double t;
        Vec3d n;
        return light.quad.intersect(r, t, n) && glm::dot(r.d, n) < 0 ? light.power : S1(0.0);
    }

    template <class Tracer>
    struct ContinuationEnv {
        const GrainBowlScene* scene;
        const Tracer* tracer;
        gl::ShellTraceStats* ts;
        PathStart start;
        [[nodiscard]] gl::LightSample<double, S1> sample_light(const Vec3d& p, const Vec3d& u) const noexcept {
            return scene->sample_light(p, u);
        }
        [[nodiscard]] bool visible(const Vec3d& p, const Vec3d& w, double d) const noexcept { return scene->visible(p, w, d); }
        [[nodiscard]] S1 escape(const gl::Ray<double>& r) const noexcept { return scene->escape(r); }
        [[nodiscard]] S1 continue_outside(const gl::Ray<double>& r, gl::Rng& rng, bool direct_counted) const noexcept {
            if (start.continuations > scene->max_continuations) return S1(0.0);
            PathStart s = start;
            s.skip_emission = direct_counted;
            return S1(scene->radiance_from(r.o, r.d, rng, Mode::high, tracer, ts, s));
        }
    };

    template <class Tracer>
    [[nodiscard]] double radiance(const gl::Ray<double>& r, gl::Rng& rng, Mode mode, const Tracer* tracer,
                                  gl::ShellTraceStats* ts = nullptr) const noexcept {
        return radiance_from(r.o, r.d, rng, mode, tracer, ts, PathStart{});
    }

    /// One path from p along unit d (outside every grain).
    template <class Tracer>
    [[nodiscard]] double radiance_from(Vec3d p, Vec3d d, gl::Rng& rng, Mode mode, const Tracer* tracer,
                                       gl::ShellTraceStats* ts, const PathStart& s0) const noexcept {
        constexpr double inf = std::numeric_limits<double>::infinity();
        const double R = agg->grain_radius();
        int events = s0.events, floor_bounces = s0.floor_bounces;
        bool handed = s0.handed, skip = s0.skip_emission;
        double acc = 0, beta = 1, clock = -1;
        // Switch rule along a host piece [a, a + len d]: returns the switch point's distance or -1.
        const auto switch_on = [&](const Vec3d& a, const Vec3d& w, double len) -> double {
            if (mode == Mode::pt || !tracer || events < tracer->options().min_scatter) return -1;
            double along = 0;
            for (;;) {
                if (!(clock >= 0)) clock = gl::sample_exponential(rng.uniform<double>(), 1.0 / clock_mean);
                if (along + clock >= len) {
                    clock -= len - along;
                    return -1;
                }
                along += clock;
                clock = -1;
                if (tracer->may_switch(a + along * w, events)) return along;
            }
        };
        const auto do_switch = [&](const Vec3d& x, const Vec3d& w) -> double {
            if (mode == Mode::low) return acc;
            if (!continuation) return acc + beta * tracer->trace(x, w, rng, *this, ts)[0];
            return acc + beta * tracer->trace(x, w, rng,
                                              ContinuationEnv<Tracer>{this, tracer, ts,
                                                                      PathStart{events, true, false, floor_bounces,
                                                                                s0.continuations + 1}},
                                              ts)[0];
        };
        for (int guard = 0; guard < max_events; ++guard) {
            const bool counting = mode != Mode::high || handed;
            const bool skip_segment = skip;
            skip = false;
            const double t_floor = d.z < 0 && p.z > 0 ? -p.z / d.z : inf;
            double t_light = inf, tq;
            Vec3d nq;
            if (light.quad.intersect(gl::Ray<double>(p, d), tq, nq) && glm::dot(d, nq) < 0) t_light = tq;
            const double t_max = std::min(t_floor, t_light);
            const gl::AggregateHit h = agg->intersect(p, d, 0.0, std::isfinite(t_max) ? t_max : 1e6 * R);
            const double t_next = h ? h.t : t_max;
            if (std::isfinite(t_next)) {
                const double ts_ = switch_on(p, d, t_next);
                if (ts_ >= 0) return do_switch(p + ts_ * d, d);
            }
            if (!h) {
                if (t_light < t_floor) return counting && !skip_segment ? acc + beta * light.power[0] : acc;
                if (!std::isfinite(t_floor) || floor_bounces >= max_floor_bounces || !(floor_albedo > 0)) return acc;
                // Table: shadow ray (the direct segment; blocked by any grain), cosine bounce.
                ++floor_bounces;
                p += t_floor * d;
                p.z = 1e-9 * R;
                const gl::LightSample<double, S1> ls = sample_light(p, Vec3d(rng.uniform2<double>(), 0.0));
                if (counting && ls && ls.w.z > 0 && !agg->occluded(p, ls.w, 0.0, ls.dist))
                    acc += beta * floor_albedo * ls.w.z / gl::pi_v<double> * ls.L[0] / ls.pdf;
                skip = true;
                d = gl::sample_cosine_hemisphere(rng.uniform2<double>());
                beta *= floor_albedo;
                continue;
            }
            // A grain interaction (lossless grains: the throughput stays 1).
            ++events;
            const Vec3d c = agg->sphere_center(h.grain.tile, h.grain.sphere);
            Vec3d q = p + h.t * d, n = h.n;
            S1 thr(1.0);
            bool ended = false;
            for (;;) {
                const gl::GrainSojourn s = gl::grain_sojourn(
                    *agg, h.grain, q, d, n, thr, rng, gl::TransportMode::importance, 10000,
                    [](const Vec3d&, const Vec3d&, S1&) {}, [](const Vec3d&, const Vec3d&) {});
                if (!s.is_exited()) {
                    ended = true;
                    break;
                }
                const auto r2 = gl::intersect_sphere(s.p, s.d, c, R);
                const double t_out = r2.hit ? std::max(0.0, r2.t_far) : 0.0;
                const gl::AggregateHit again = agg->intersect_grain(h.grain, s.p, s.d, 0.0, t_out);
                if (again) {
                    const double ts_ = switch_on(s.p, s.d, again.t);
                    if (ts_ >= 0) return do_switch(s.p + ts_ * s.d, s.d);
                    q = s.p + again.t * s.d;
                    d = s.d;
                    n = again.n;
                    continue;
                }
                const double ts_ = switch_on(s.p, s.d, t_out);
                if (ts_ >= 0) return do_switch(s.p + ts_ * s.d, s.d);
                p = s.p + t_out * s.d;
                d = s.d;
                break;
            }
            if (ended) return acc;
            beta *= double(thr[0]);
            if (!(beta > 0)) return acc;
        }
        return acc;
    }
};

std::vector<std::string> split_list(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        if (!item.empty()) out.push_back(item);
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "moon07_fig13_grains",
        "Moon07 Fig. 13 with procedural grains: a bowl of grain meshes, explicit path tracing vs low-order EPT + shells",
        "out/moon07_fig13_grains", [&](gl_examples::Example& ex) -> int {
        const auto n_grains =
            ex.opt<std::size_t>("grains", 3000, 10000, "grains in the bowl (Fig. 13: ~10 000 glass Buddhas)");
        const std::string presets_text = ex.opt<std::string>(
            "presets", "sugar,snow", "exemplar presets (geometry/grains.hpp), comma separated, lossless dielectrics");
        const std::vector<std::string> presets = split_list(presets_text);
        const int level = ex.opt<int>("mesh-level", 2, 3, "subdivision level of the grain meshes");
        const int W = ex.opt<int>("width", 64, 512, "image width (height = 3/4 width)");
        const int H = std::max(1, W * 3 / 4);
        const int spp_pt = ex.opt<int>("spp-pt", 32, "path-tracing samples per pixel per batch");
        const int spp_low = ex.opt<int>("spp-low", 8, "low-order samples per pixel per batch");
        const int spp_high = ex.opt<int>("spp-high", 8, "high-order (shell) samples per pixel per batch");
        const int B = ex.opt<int>("batches", 8, "independent batches per image (>= 4)");
        const int min_scatter = ex.opt<int>("min-scatter", 3, "switch rule: grain interactions before shells");
        const double switch_depth = ex.opt<double>(
            "switch-depth", 2.0, "switch rule: depth below the bowl surface to switch (R; default r_0 = 2)");
        const double table_albedo = ex.opt<double>("table-albedo", 0.5, "Lambertian albedo of the table, [0, 1)");
        const std::uint64_t shell_paths =
            ex.opt<std::uint64_t>("shell-paths", 10000, 200000, "paths of the shell precomputation");
        const int n_radii = ex.opt<int>("shell-radii", 6, 12, "number of shell radii (paper: 12-16)");
        const bool rebuild_table = ex.opt<bool>("rebuild-table", false, "ignore a cached shell table in --out");
        const bool no_continuation =
            ex.opt<bool>("no-continuation", false, "high order: end shell-traced paths at the bowl's boundary");
        ex.checkpointable();
        ex.ready();
        const bool full = ex.full();
        const std::uint64_t seed = ex.seed();
        if (n_grains < 100 || n_grains > 2000000)
            throw gl_examples::cli_error("--grains = " + std::to_string(n_grains) + " must be in [100, 2000000]");
        if (presets.empty()) throw gl_examples::cli_error("--presets must name at least one preset");
        if (level < 0 || level > 5) throw gl_examples::cli_error("--mesh-level = " + std::to_string(level) + " must be in [0, 5]");
        if (W < 8 || W > 8192) throw gl_examples::cli_error("--width = " + std::to_string(W) + " must be in [8, 8192]");
        if (B < 4) throw gl_examples::cli_error("--batches = " + std::to_string(B) + " must be >= 4");
        if (spp_pt < 1 || spp_low < 1 || spp_high < 1) throw gl_examples::cli_error("--spp-* must be >= 1");
        if (n_radii < 2 || n_radii > 64) throw gl_examples::cli_error("--shell-radii must be in [2, 64]");
        if (shell_paths < 1000) throw gl_examples::cli_error("--shell-paths must be >= 1000");
        if (!(table_albedo >= 0 && table_albedo < 1))
            throw gl_examples::cli_error("--table-albedo = " + std::to_string(table_albedo) + " must be in [0, 1)");
        if (!(switch_depth >= 0 && switch_depth < 1e6))
            throw gl_examples::cli_error("--switch-depth = " + std::to_string(switch_depth) + " must be in [0, 1e6)");
        const std::filesystem::path out = ex.out();
        const auto wall0 = std::chrono::steady_clock::now();

        // --- the aggregate: RSA bounding spheres (R = 1), grains from the presets, the bowl ---
        std::vector<gl::GrainExemplar> exemplars;
        std::vector<double> weights;
        for (const std::string& name : presets) {
            const gl::GrainPreset p = gl::grain_preset(name);  // throws naming the valid presets
            if (p.material.kind != gl::GrainMaterialKind::dielectric)
                throw gl_examples::cli_error("--presets: " + name + " is not a lossless dielectric preset");
            exemplars.push_back(gl::GrainExemplar::from_preset(p, level));
            weights.push_back(1.0);
        }
        gl::Rng prng = gl::Rng::from_key(seed, 0xF13u);
        const gl::PeriodicTile unit = gl::random_sequential_addition(128, 0.3, prng, 1.0);
        const double sc = 1.0 / unit.radius();
        std::vector<Vec3d> centers = unit.centers();
        for (auto& c : centers) c *= sc;
        const gl::PeriodicTile tile(unit.side() * sc, 1.0, std::move(centers));
        const double R = 1.0;
        const double Rb = std::cbrt(double(n_grains) / (0.3 * 0.5));  // N = f (2/3 pi Rb^3) / (4/3 pi)
        const double L = 2 * Rb;
        const BowlVolume bowl{Vec3d(Rb, Rb, Rb + R), Rb};
        const Agg agg(tile, gl::VoxelizedBoundary<BowlShape>(BowlShape{bowl}, tile.side()), exemplars, weights, seed);
        const std::uint64_t n_in = agg.grain_count();
        const double light_size = 0.3;
        GrainBowlScene scene;
        scene.agg = &agg;
        scene.bowl = bowl;
        scene.light = gl::Light<double, S1>::quad_light(
            gl::QuadShape<double>(Vec3d((0.55 - light_size / 2) * L, (0.5 - light_size / 2) * L, 1.5 * L + R),
                                  Vec3d(0, light_size * L, 0), Vec3d(light_size * L, 0, 0)),
            S1(0.9 * 0.12 * 0.12 / (light_size * light_size) * 4.0));
        scene.floor_albedo = table_albedo;
        scene.continuation = !no_continuation;
        std::cerr << "moon07_fig13: " << n_in << " grains (" << presets_text << ", level " << level
                  << ") in a bowl of radius " << Rb << " R\n";

        // --- shell table from the same aggregate process over all space (cached) ---
        std::vector<double> radii(static_cast<std::size_t>(n_radii), 0.0);
        const double r0 = 2 * R, r_max = 0.45 * Rb;
        for (int i = 0; i < n_radii; ++i) radii[std::size_t(i)] = r0 + (r_max - r0) * double(i) / double(n_radii - 1);
        gl::ShellBuildOptions bo;
        bo.n_c = full ? 50 : 24;
        bo.n_u = full ? 50 : 16;
        bo.n_v = full ? 25 : 16;
        bo.rank = 5;
        std::string key = "grains_" + std::to_string(n_grains) + "_" + std::to_string(shell_paths) + "_" +
                          std::to_string(n_radii) + "_" + std::to_string(bo.n_c) + "x" + std::to_string(bo.n_u) + "x" +
                          std::to_string(bo.n_v) + "_l" + std::to_string(level) + "_s" + std::to_string(seed);
        for (const auto& p : presets) key += "_" + p;
        const std::filesystem::path table_path = out / ("moon07_fig13_" + key + ".shel");
        const CachedShellTable ct = cached_shell_table(table_path, rebuild_table, bo, [&] {
            using EB = gl::EverywhereBoundary;
            const gl::GranularAggregate<EB> bulk(tile, gl::VoxelizedBoundary<EB>({}, tile.side()), exemplars, weights, seed);
            const gl::GrainAggregateShellSource<EB> src(bulk, 20 * R);
            return gl::collect_shell_samples(src, radii, shell_paths, seed ^ 0x13u);
        }, ex.root());  // MPI: rank 0 saves the table
        const gl::ShellTable& table = ct.table;
        const double raw_bytes = ct.raw_bytes, factored_bytes = ct.factored_bytes;
        std::cerr << "moon07_fig13: shell table " << (ct.cached ? "loaded" : "built") << " (" << ct.build_seconds << " CPU s), "
                  << table.n_shells() << " radii " << radii.front() << ".." << radii.back() << " R\n";

        gl::ShellTracerOptions to;
        to.min_scatter = min_scatter;
        to.switch_depth = switch_depth;
        to.exit_rule = gl::ShellExitRule::table;
        const gl::ShellTracer<S1, BowlVolume> tracer(table, bowl, to);

        // --- camera; pixels that see the bowl ---
        const gl::PinholeCamera<double> cam(Vec3d(1.9 * L, -1.4 * L, 1.5 * L), Vec3d(0.5 * L, 0.5 * L, 0.2 * L),
                                            Vec3d(0, 0, 1), 36.0, W, H);
        std::vector<char> mask(std::size_t(W) * std::size_t(H), 0);
        std::size_t n_mask = 0;
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const bool in = std::isfinite(bowl.entry(cam.generate_ray(x + 0.5, y + 0.5)));
                mask[std::size_t(y) * std::size_t(W) + std::size_t(x)] = in;
                n_mask += in;
            }
        if (n_mask < 16) throw std::runtime_error("the camera sees fewer than 16 bowl pixels");

        const ShellPasses passes = render_shell_passes(
            ex, cam, spp_pt, spp_low, spp_high, B, "fig13",
            [&](const gl::Ray<double>& r, gl::Rng& rng, Mode m, gl::ShellTraceStats* s) {
                return scene.radiance(r, rng, m, &tracer, s);
            });
        if (!ex.root()) return ex.finish({});  // MPI: rank 0 has the gathered images and writes everything
        const BatchImages &pt = passes.pt, &lo = passes.lo, &hi = passes.hi;
        const gl::ShellTraceStats& ts = passes.ts;
        const double high_samples = double(spp_high) * B * double(n_mask);
        const ShellVsPt st = compare_shells_to_pt(pt, lo, hi, mask);

        write_shell_images(out, "moon07_fig13", st, W, H);
        gl_examples::Csv csv({"seconds_pt", "seconds_low", "seconds_high", "speedup_equal_error", "mean_pt", "mean_shells",
                              "rmse_pt", "rmse_shells", "bias_rel"});
        csv.row({pt.cpu, lo.cpu, hi.cpu, st.speedup, st.mean_pt, st.mean_sh, st.rmse_pt, st.rmse_sh, st.bias_rel});
        ex.csv("moon07_fig13_grains.csv", csv);
        std::cout << "Moon07 Fig. 13 (bowl of procedural grains instead of glass Buddhas), " << n_in << " grains, " << W
                  << "x" << H << ", " << B << " batches\n"
                  << "  path tracing (EPT): " << pt.cpu << " CPU s (" << spp_pt * B << " spp)   paper: no timing for Fig. 13\n"
                  << "  low order:          " << lo.cpu << " CPU s (" << spp_low * B << " spp)\n"
                  << "  high order:         " << hi.cpu << " CPU s (" << spp_high * B << " spp)\n"
                  << "  mean over the bowl: PT " << st.mean_pt << ", shells " << st.mean_sh << " (low " << st.sum_lo / st.nm
                  << " + high " << st.sum_hi / st.nm << "), bias " << 100 * st.bias_rel << " +- " << 100 * st.bias_rel_se << " %\n"
                  << "  RMSE: PT " << st.rmse_pt << ", shells " << st.rmse_sh << "; equal-error speed-up " << st.speedup
                  << "x   (paper: Figs. 9, 11, 12: 16x, 27x, 11x)\n"
                  << "  shell table: raw " << raw_bytes / 1024 << " KiB -> factored " << factored_bytes / 1024
                  << " KiB   paper: ~30 MB -> 250 KB\n";
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        gl_examples::Json j = ex.summary();
        add_comparison_json(j, st, pt.cpu, lo.cpu, hi.cpu);
        add_tracer_json(j, ts, high_samples);
        add_table_json(j, ct);
        j.num("paper_raw_bytes", 30e6)
            .num("paper_factored_bytes", 250e3)
            .num("table_albedo", table_albedo)
            .boolean("continuation", scene.continuation)
            .integer("min_scatter", min_scatter)
            .num("switch_depth", switch_depth)
            .integer("grains", (long long)n_in)
            .integer("exemplars", (long long)exemplars.size())
            .num("bowl_radius_R", Rb)
            .integer("bowl_pixels", (long long)n_mask)
            .str("rank_rows", "rank r renders the rows y with y % ranks == r")
            .nums("rank_row_counts", ex.mpi().row_counts(H))
            .num("wall_seconds", wall);
        return ex.finish(j);  // removes the checkpoints of the completed run
        });
}
