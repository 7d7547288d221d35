// moon07_fig12_bowl: Moon07 Fig. 12, 100 000 glass spheres filling a bowl-shaped volume that
// rests on a diffuse table under a larger area light, rendered (a) by path tracing through the
// explicit spheres and (b) by low-order PT + high-order shells (integrators/shell_tracer.hpp,
// Fig. 6's two shadow rays), with the equal-error speed-up (paper: 175 vs 15.7 min, 11x) and the
// shell table's compression (paper: ~30 MB -> 250 KB).
//
//   moon07_fig12_bowl [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//        [--spheres N] [--fraction F] [--width W] [--spp-pt N] [--spp-low N] [--spp-high N]
//        [--batches B] [--min-scatter K] [--switch-depth D] [--light-size S] [--table-albedo A]
//        [--shell-paths N] [--shell-radii N] [--rebuild-table] [--no-continuation] [--no-table-nee]
//        [--face-optics on|off] [--checkpoint SECONDS] [--resume]
//
// Scene (units: the sphere radius R = 1): the bowl is the lower half of a ball of radius
// R_b = (2 N / f)^(1/3) (so that it holds N spheres at packing fraction f), filled to its rim
// (a flat top face), its lowest point touching a Lambertian table z = 0 (albedo 0.5,
// --table-albedo). The spheres (eta = 1.5, no absorption) are cut out of a periodic RSA packing
// of side D = 2 R_b (packing/poisson.hpp), as the cube of moon07_fig9_cube_shadow is: glass
// faces where spheres meet the bowl's boundary (moon07_cube_scene.hpp: VolumeScene<BowlVolume>).
// A square light of side 0.3 D (--light-size; Fig. 9's is 0.12 L) at height 1.5 D faces down. The
// shell table comes from the same random process (cached in DIR); radii r_0 = 2 R .. 0.45 R_b.
// The table is explicit in every image: paths that hit it bounce (cosine-weighted, weight =
// albedo, a shadow ray to the light at each bounce: --no-table-nee), also before the switch; a
// path that leaves the bowl through the shells continues into the scene (the shell tracer's
// continuation hook: table bounce, re-entry, explicit tracing and shells again), so bowl -> table
// -> bowl light is in the high-order image too (--no-continuation: lost, about -11 %).
// Measurement as in moon07_fig9_cube_shadow (batches, ../shared/reference/measuring.md), over
// the pixels that see the bowl. JSON (last stdout line): seconds_pt, seconds_low, seconds_high,
// rmse_pt, rmse_shells, speedup_equal_error, mean_pt, mean_shells, exit_rule_bias (= bias_rel,
// + bias_rel_se), shell_raw_bytes, shell_factored_bytes, paper values.
#include "moon07_cube_scene.hpp"

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "moon07_fig12_bowl",
        "Moon07 Fig. 12: a bowl of glass spheres on a table, path tracing vs low-order PT + shells",
        "out/moon07_fig12_bowl", [&](gl_examples::Example& ex) -> int {
        const auto n_spheres =
            ex.opt<std::size_t>("spheres", 8000, 100000, "number of glass spheres in the bowl (paper: 100000)");
        const double fraction = ex.opt<double>("fraction", 0.3, "packing fraction of the RSA spheres, (0, 0.35]");
        const int W = ex.opt<int>("width", 128, 512, "image width (height = 3/4 width)");
        const int H = std::max(1, W * 3 / 4);
        const int spp_pt = ex.opt<int>("spp-pt", 48, "path-tracing samples per pixel per batch");
        const ShellSceneOptions so = ShellSceneOptions::declare(ex, "bowl");
        const FaceOpticsOption fo = FaceOpticsOption::declare(ex);
        const double light_size = ex.opt<double>(
            "light-size", 0.3, "side of the square light / bowl diameter D (a larger light than Fig. 9's)");
        const int B = ex.opt<int>("batches", 8, "independent batches per image (>= 4)");
        const double table_albedo = ex.opt<double>("table-albedo", 0.5, "Lambertian albedo of the table, [0, 1)");
        const bool no_continuation = ex.opt<bool>(
            "no-continuation", false,
            "high order: end shell-traced paths at the bowl's boundary (no table bounce after the shells)");
        const bool no_table_nee =
            ex.opt<bool>("no-table-nee", false, "no shadow ray at table bounces (paths find the light by hitting it)");
        ex.checkpointable();
        ex.ready();
        so.check();
        const bool full = ex.full();
        const std::uint64_t seed = ex.seed();
        if (!(light_size > 0 && light_size <= 1))
            throw gl_examples::cli_error("--light-size = " + std::to_string(light_size) + " must be in (0, 1]");
        if (!(table_albedo >= 0 && table_albedo < 1))
            throw gl_examples::cli_error("--table-albedo = " + std::to_string(table_albedo) + " must be in [0, 1)");
        if (n_spheres < 100) throw gl_examples::cli_error("--spheres = " + std::to_string(n_spheres) + " must be >= 100");
        if (!(fraction > 0 && fraction <= gl::rsa_max_fraction))
            throw gl_examples::cli_error("--fraction = " + std::to_string(fraction) + " must be in (0, 0.35]");
        if (W < 8 || W > 8192) throw gl_examples::cli_error("--width = " + std::to_string(W) + " must be in [8, 8192]");
        if (B < 4) throw gl_examples::cli_error("--batches = " + std::to_string(B) + " must be >= 4");
        if (spp_pt < 1) throw gl_examples::cli_error("--spp-pt = " + std::to_string(spp_pt) + " must be >= 1");
        const std::filesystem::path out = ex.out();
        const auto wall0 = std::chrono::steady_clock::now();

        // --- the medium: RSA spheres (radius 1) in a periodic cube of side D, the bowl cut out of it ---
        const double Rb = std::cbrt(2.0 * double(n_spheres) / fraction);  // N 4/3 pi = f 2/3 pi R_b^3
        const double L = 2 * Rb;                                            // D: the tile and the bowl's diameter
        const auto n_tile = std::size_t(std::llround(fraction * L * L * L / (4.0 / 3.0 * gl::pi_v<double>)));
        gl::Rng prng = gl::Rng::from_key(seed, 0xB0A1u);
        const gl::PeriodicTile rsa = gl::random_sequential_addition(n_tile, fraction, prng, L);
        const double R = rsa.radius();
        const BowlVolume bowl{Vec3d(Rb, Rb, Rb), Rb};
        std::size_t n_in = 0;  // spheres with their centre in the bowl
        for (const Vec3d& c : rsa.centers()) n_in += bowl(c) > 0;
        // Light: irradiance at the bowl's rim about 4x that of Fig. 9's light at its cube.
        VolumeScene<BowlVolume> scene{L, 1.5, rsa, bowl,
                                      gl::Light<double, S1>::quad_light(
                                          gl::QuadShape<double>(Vec3d((0.55 - light_size / 2) * L, (0.5 - light_size / 2) * L, 1.5 * L),
                                                                Vec3d(0, light_size * L, 0), Vec3d(light_size * L, 0, 0)),
                                          S1(0.9 * 0.12 * 0.12 / (light_size * light_size) * 4.0)),
                                      gl::QuadShape<double>(Vec3d(0, 0, -100 * L), Vec3d(L, 0, 0), Vec3d(0, L, 0))};  // no blocker
        scene.cut = true;
        scene.floor_albedo = table_albedo;
        scene.continuation = !no_continuation;
        scene.table_nee = !no_table_nee;
        std::cerr << "moon07_fig12: " << n_in << " sphere centres in a bowl of radius " << Rb << " R (tile of " << n_tile
                  << " spheres, side " << L << " R, f = " << fraction << ")\n";

        // --- shell table from the same random process (cached; scene_shell_table, moon07_cube_scene.hpp) ---
        const CachedShellTable ct = scene_shell_table(so, rsa, R, 0.45 * Rb, full, "moon07_fig12_bowl_", n_spheres, fraction, seed,
                                                      out, ex.root(), "moon07_fig12");  // MPI: rank 0 saves the table
        const gl::ShellTable& table = ct.table;
        const double raw_bytes = ct.raw_bytes, factored_bytes = ct.factored_bytes;

        gl::ShellTracerOptions to = so.tracer_options(R);
        // Face optics: the bowl's faces are glass where its boundary cuts spheres (the rim plane and
        // the sphere, the latter as its tangent plane at the point nearest to a step's start).
        double face_q = 0;
        to.face = fo.optics(rsa, scene.eta, scene.cut && !scene.clear_faces, full, seed, face_q);
        scene.hand_back = so.hand_back;
        const gl::ShellTracer<S1, BowlVolume> tracer(table, scene.cube, to);

        // --- camera; pixels that see the bowl ---
        const gl::PinholeCamera<double> cam(Vec3d(1.9 * L, -1.4 * L, 1.5 * L), Vec3d(0.5 * L, 0.5 * L, 0.2 * L),
                                            Vec3d(0, 0, 1), 36.0, W, H);
        std::size_t n_mask = 0;
        const std::vector<char> mask = volume_pixel_mask(scene, cam, W, H, n_mask, "bowl");

        // --- renders (--checkpoint SECONDS / --resume: one checkpoint per batch render, kept when it
        // finishes so a resumed run skips it, all removed at the end of a completed run; the shell
        // passes' step tallies count only the rows rendered by the resumed run) ---
        const ShellPasses passes = render_shell_passes(
            ex, cam, spp_pt, so.spp_low, so.spp_high, B, "fig12",
            [&](const gl::Ray<double>& r, gl::Rng& rng, Mode m, gl::ShellTraceStats* s) {
                return scene.radiance(r, rng, m, &tracer, nullptr, s);
            });
        if (!ex.root()) return ex.finish({});  // MPI: rank 0 has the gathered images and writes everything
        const BatchImages &pt = passes.pt, &lo = passes.lo, &hi = passes.hi;
        const gl::ShellTraceStats& ts = passes.ts;
        const double high_samples = double(so.spp_high) * B * double(n_mask);

        // --- statistics over the bowl pixels (compare_shells_to_pt, moon07_cube_scene.hpp) ---
        const ShellVsPt st = compare_shells_to_pt(pt, lo, hi, mask);
        const double mean_pt = st.mean_pt, mean_sh = st.mean_sh, sum_lo = st.sum_lo, sum_hi = st.sum_hi,
                     mse_sh_pixelwise = st.mse_sh_pixelwise, rmse_pt = st.rmse_pt, rmse_sh = st.rmse_sh,
                     bias_rel = st.bias_rel, bias_rel_se = st.bias_rel_se, speedup = st.speedup, nm = st.nm;

        // --- outputs ---
        write_shell_images(out, "moon07_fig12", st, W, H);
        // Ours (CPU s) beside the paper's (minutes on a 128-CPU cluster, as CPU s).
        gl_examples::Csv csv({"seconds_pt", "seconds_low", "seconds_high", "speedup_equal_error", "mean_pt",
                              "mean_shells", "rmse_pt", "rmse_shells", "bias_rel"});
        csv.row({pt.cpu, lo.cpu, hi.cpu, speedup, mean_pt, mean_sh, rmse_pt, rmse_sh, bias_rel});
        // The paper's row: 175 min PT vs 15.7 min low + high (as s; its split is not given), 11x.
        csv.row({175 * 60.0, 15.7 * 60.0, 0, 11.0, 0, 0, 0, 0, 0});
        ex.csv("moon07_fig12_bowl.csv", csv);
        std::cout << "Moon07 Fig. 12 (bowl of glass spheres on a table), " << n_in << " spheres, " << W << "x"
                  << H << ", " << B << " batches\n"
                  << "  path tracing: " << pt.cpu << " CPU s (" << spp_pt * B << " spp)   paper: 175 min\n"
                  << "  low order:    " << lo.cpu << " CPU s (" << so.spp_low * B << " spp)   paper: low + high 15.7 min\n"
                  << "  high order:   " << hi.cpu << " CPU s (" << so.spp_high * B << " spp)\n"
                  << "  mean over the bowl: PT " << mean_pt << ", shells " << mean_sh << " (low " << sum_lo / nm
                  << " + high " << sum_hi / nm << "), bias " << 100 * bias_rel << " +- " << 100 * bias_rel_se
                  << " %\n"
                  << "  RMSE: PT " << rmse_pt << ", shells " << rmse_sh << "; equal-error speed-up " << speedup
                  << "x   paper: 11x (175 / 15.7 min)\n"
                  << "  shell table: raw " << raw_bytes / 1024 << " KiB -> factored " << factored_bytes / 1024
                  << " KiB   paper: ~30 MB -> 250 KB\n";
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        gl_examples::Json j = ex.summary();
        add_comparison_json(j, st, pt.cpu, lo.cpu, hi.cpu);
        add_tracer_json(j, ts, high_samples);
        add_table_json(j, ct);
        j.num("rmse_shells_pixelwise", std::sqrt(mse_sh_pixelwise))
            .num("paper_speedup", 11.0)
            .num("paper_seconds_pt", 175 * 60.0)
            .num("paper_seconds_shells", 15.7 * 60.0)
            .num("paper_raw_bytes", 30e6)
            .num("paper_factored_bytes", 250e3)
            .num("table_albedo", table_albedo)
            .boolean("cut_spheres", scene.cut)
            .boolean("face_optics", to.face.enabled())
            .num("face_glass_fraction", face_q)
            .boolean("exit_rule_table", to.exit_rule == gl::ShellExitRule::table)
            .boolean("hand_back", scene.hand_back)
            .str("cos_cells", so.cos_cells)
            .boolean("continuation", scene.continuation)
            .boolean("table_nee", scene.table_nee)
            .integer("min_scatter", so.min_scatter)
            .num("switch_depth", to.switch_depth)
            .integer("spheres", (long long)n_in)
            .num("bowl_radius_R", Rb)
            .integer("bowl_pixels", (long long)n_mask)
            .str("rank_rows", "rank r renders the rows y with y % ranks == r")
            .nums("rank_row_counts", ex.mpi().row_counts(H))
            .num("wall_seconds", wall);
        return ex.finish(j);  // removes the checkpoints of the completed run
        });
}
