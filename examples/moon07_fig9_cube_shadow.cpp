// moon07_fig9_cube_shadow: Moon07 Fig. 9, a cube of Poisson-distributed glass spheres under a
// small rectangular area light, with a blocker casting a shadow edge across the top face,
// rendered (a) by path tracing through the explicit spheres and (b) by Moon07's method: a
// low-order image (explicit path tracing until the switch rule fires) plus a high-order image
// (explicit tracing to the switch point, then shells with Fig. 6's two shadow rays:
// integrators/shell_tracer.hpp), and the equal-error speed-up of (b) over (a).
//
//   moon07_fig9_cube_shadow [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//        [--spheres N] [--fraction F] [--width W] [--spp-pt N] [--spp-low N] [--spp-high N]
//        [--batches B] [--min-scatter K] [--switch-depth D] [--light-size S] [--shell-paths N]
//        [--shell-radii N] [--rebuild-table] [--cos-cells angle|cos] [--exit-rule table|radial]
//        [--hand-back] [--no-nee] [--clear-faces] [--whole-spheres] [--sky-cone DEG] [--face-optics on|off]
//   mpirun -np K moon07_fig9_cube_shadow ...   (built with MPI: rank r renders the rows y % K == r
//        of every batch, gathered on rank 0: the same EXRs as one process)
//
// Scene (units: the sphere radius R = 1): N equal glass spheres (eta = 1.5, no absorption) at
// packing fraction f by random sequential addition (packing/poisson.hpp; paper: 120 000
// "Poisson distributed" spheres; cut by the cube's faces, --whole-spheres: only those with
// centres >= R inside) in a cube of side L = (N 4/3 pi / f)^(1/3) standing on a black
// floor; a square light of side 0.12 L (--light-size) at height 2.2 L facing down; a black blocker at 1.5 L
// covering x < 0.42 L. The shell table is precomputed from the same random process (the
// periodic RSA tile of the cube, SpherePackingShellSource) and cached in DIR.
//
// Measurement (../shared/reference/measuring.md): every image is rendered in B batches with
// different seeds; per pixel the variance of the mean comes from the batches. Over the pixels
// that see the cube: mean_pt, mean_shells (low + high); rmse_pt = the PT reference's own noise;
// rmse_shells^2 = its per-pixel variance + the squared bias of the cube mean against PT beyond
// the noise of both means (the pixel-wise mean (shells - PT)^2 - var(PT) is printed as
// rmse_shells_pixelwise; at these budgets it is dominated by the reference's noise); speedup_equal_error =
// seconds_pt rmse_pt^2 / rmse_shells^2 / (seconds_low + seconds_high) (CPU seconds).
// Bias study (--sky-cone DEG): the light becomes a sky that emits only within DEG of straight
// down, so path tracing resolves the high-order light leaving near vertically to ~1 % (the
// shells count escapes: no shadow rays); docs/moon07.md has the numbers that separate the
// causes of the shells' bias (table cells, exit rule, switch rule).
// JSON (last stdout line): seconds_pt, seconds_low, seconds_high, rmse_pt, rmse_shells,
// speedup_equal_error, mean_pt, mean_shells, bias_rel (+ _se: the exit-rule/shell bias of the
// mean against PT), table figures; paper: 236 min PT vs 12 + 2.25 min, 16x.
#include "moon07_cube_scene.hpp"

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "moon07_fig9_cube_shadow",
        "Moon07 Fig. 9: cube of glass spheres with a shadow edge, path tracing vs low-order PT + shells",
        "out/moon07_fig9_cube_shadow", [&](gl_examples::Example& ex) -> int {
        const auto n_spheres = ex.opt<std::size_t>("spheres", 15000, 120000, "number of glass spheres (paper: 120000)");
        const double fraction = ex.opt<double>("fraction", 0.3, "packing fraction of the RSA spheres, (0, 0.35]");
        const int W = ex.opt<int>("width", 128, 512, "image width (height = 3/4 width)");
        const int H = std::max(1, W * 3 / 4);
        const int spp_pt = ex.opt<int>("spp-pt", 48, "path-tracing samples per pixel per batch");
        const ShellSceneOptions so = ShellSceneOptions::declare(ex, "cube");
        const double light_size = ex.opt<double>("light-size", 0.12, "side of the square light / L (paper: 'small')");
        const int B = ex.opt<int>("batches", 8, "independent batches per image (>= 4)");
        const double sky_cone = ex.opt<double>(
            "sky-cone", 0.0,
            "bias study: replace the light by a sky above the cube that emits only within this angle of straight down (deg, (0, 90); 0: the paper's small light); forces --no-nee");
        (void)ex.opt<bool>("cut-spheres", true,
                           "a cube cut out of the periodic packing (flat glass faces; the default)");
        const bool whole_spheres = ex.opt<bool>(
            "whole-spheres", false,
            "whole spheres only, centres >= R inside (a sphere-free skin the shells do not describe: +12 % bias at L = 59 R)");
        const bool clear_faces = ex.opt<bool>(
            "clear-faces", false,
            "cut spheres' flat faces index matched (no refraction or Fresnel at the cube's faces; isolates the faces' share of the bias)");
        const FaceOpticsOption fo = FaceOpticsOption::declare(ex);
        ex.checkpointable();
        ex.ready();
        so.check();
        const bool full = ex.full();
        const std::uint64_t seed = ex.seed();
        if (!(sky_cone >= 0 && sky_cone < 90))
            throw gl_examples::cli_error("--sky-cone = " + std::to_string(sky_cone) + " must be in [0, 90) degrees");
        if (!(light_size > 0 && light_size <= 1))
            throw gl_examples::cli_error("--light-size = " + std::to_string(light_size) + " must be in (0, 1]");
        if (n_spheres < 100) throw gl_examples::cli_error("--spheres = " + std::to_string(n_spheres) + " must be >= 100");
        if (!(fraction > 0 && fraction <= gl::rsa_max_fraction))
            throw gl_examples::cli_error("--fraction = " + std::to_string(fraction) + " must be in (0, 0.35]");
        if (W < 8 || W > 8192) throw gl_examples::cli_error("--width = " + std::to_string(W) + " must be in [8, 8192]");
        if (B < 4) throw gl_examples::cli_error("--batches = " + std::to_string(B) + " must be >= 4");
        if (spp_pt < 1) throw gl_examples::cli_error("--spp-pt = " + std::to_string(spp_pt) + " must be >= 1");
        const std::filesystem::path out = ex.out();
        const auto wall0 = std::chrono::steady_clock::now();

        // --- the medium: RSA spheres (radius 1) in a periodic cube of side L ---
        const double L = std::cbrt(double(n_spheres) * 4.0 / 3.0 * gl::pi_v<double> / fraction);
        gl::Rng prng = gl::Rng::from_key(seed, 0xC0BEu);
        const gl::PeriodicTile rsa = gl::random_sequential_addition(n_spheres, fraction, prng, L);
        const double R = rsa.radius();
        std::vector<Vec3d> kept;
        for (const Vec3d& c : rsa.centers())
            if (c.x >= R && c.x <= L - R && c.y >= R && c.y <= L - R && c.z >= R && c.z <= L - R) kept.push_back(c);
        CubeScene scene{L, 1.5, gl::PeriodicTile(L + 4 * R, R, kept), gl::BoxDistance(Vec3d(0.0), Vec3d(L)),
                        gl::Light<double, S1>::quad_light(
                            gl::QuadShape<double>(Vec3d((0.55 - light_size / 2) * L, (0.5 - light_size / 2) * L, 2.2 * L),
                                                  Vec3d(0, light_size * L, 0), Vec3d(light_size * L, 0, 0)),
                            S1(0.9 / (light_size * light_size))),
                        gl::QuadShape<double>(Vec3d(-2 * L, -2 * L, 1.5 * L), Vec3d(2.42 * L, 0, 0), Vec3d(0, 5 * L, 0))};
        if (sky_cone > 0) {
            // Bias study: a sky 200 L wide at 2.2 L, radiance 1, seen only along directions within
            // sky_cone of straight down: the cube's light leaving within sky_cone of straight up.
            // Path tracing finds it on most such exits (no small-light noise); the shells count
            // their escapes too (no shadow rays: the sky is too wide to sample by area).
            const double big = 200 * L;
            scene.light = gl::Light<double, S1>::quad_light(
                gl::QuadShape<double>(Vec3d(0.5 * L - big / 2, 0.5 * L - big / 2, 2.2 * L), Vec3d(0, big, 0),
                                      Vec3d(big, 0, 0)),
                S1(1.0));
            scene.spot_cos = std::cos(sky_cone * gl::pi_v<double> / 180);
        }
        if (!whole_spheres) {  // default: the medium the shell table describes up to the faces
            scene.tile = rsa;
            scene.cut = true;
            scene.clear_faces = clear_faces;
            kept = rsa.centers();
        }
        std::cerr << "moon07_fig9: " << kept.size() << " spheres in a cube of side " << L << " R (f = " << fraction
                  << ")\n";

        // --- shell table from the same random process (cached; scene_shell_table, moon07_cube_scene.hpp) ---
        const CachedShellTable ct = scene_shell_table(so, rsa, R, 0.45 * L, full, "moon07_fig9_", n_spheres, fraction, seed,
                                                      out, ex.root(), "moon07_fig9");  // MPI: rank 0 saves the table
        const gl::ShellTable& table = ct.table;
        const double raw_bytes = ct.raw_bytes, factored_bytes = ct.factored_bytes;

        gl::ShellTracerOptions to = so.tracer_options(R);
        if (sky_cone > 0) to.nee = false;
        double face_q = 0;
        to.face = fo.optics(rsa, scene.eta, scene.cut && !scene.clear_faces, full, seed, face_q);
        scene.hand_back = so.hand_back;
        const gl::ShellTracer<S1, gl::BoxDistance> tracer(table, scene.cube, to);

        // --- camera; pixels that see the cube ---
        const gl::PinholeCamera<double> cam(Vec3d(2.2 * L, -1.6 * L, 1.3 * L), Vec3d(0.5 * L, 0.5 * L, 0.42 * L),
                                            Vec3d(0, 0, 1), 36.0, W, H);
        std::size_t n_mask = 0;
        const std::vector<char> mask = volume_pixel_mask(scene, cam, W, H, n_mask, "cube");

        // --- renders (--checkpoint SECONDS / --resume: one checkpoint per batch render, kept when it
        // finishes so a resumed run skips it, all removed at the end of a completed run; the shell
        // passes' step tallies count only the rows rendered by the resumed run) ---
        const ShellPasses passes = render_shell_passes(
            ex, cam, spp_pt, so.spp_low, so.spp_high, B, "fig9",
            [&](const gl::Ray<double>& r, gl::Rng& rng, Mode m, gl::ShellTraceStats* s) {
                return scene.radiance(r, rng, m, &tracer, nullptr, s);
            });
        if (!ex.root()) return ex.finish({});  // MPI: rank 0 has the gathered images and writes everything
        const BatchImages &pt = passes.pt, &lo = passes.lo, &hi = passes.hi;
        const gl::ShellTraceStats& ts = passes.ts;
        const double high_samples = double(so.spp_high) * B * double(n_mask);

        // --- statistics over the cube pixels (compare_shells_to_pt, moon07_cube_scene.hpp) ---
        const ShellVsPt st = compare_shells_to_pt(pt, lo, hi, mask);
        const double mean_pt = st.mean_pt, mean_sh = st.mean_sh, sum_lo = st.sum_lo, sum_hi = st.sum_hi,
                     mse_sh_pixelwise = st.mse_sh_pixelwise, rmse_pt = st.rmse_pt, rmse_sh = st.rmse_sh,
                     bias_rel = st.bias_rel, bias_rel_se = st.bias_rel_se, speedup = st.speedup, nm = st.nm;

        // --- outputs ---
        write_shell_images(out, "moon07_fig9", st, W, H);
        // Ours (CPU s) beside the paper's (minutes on a 128-CPU cluster, as CPU s).
        gl_examples::Csv csv({"seconds_pt", "seconds_low", "seconds_high", "speedup_equal_error", "mean_pt",
                              "mean_shells", "rmse_pt", "rmse_shells", "bias_rel"});
        csv.row({pt.cpu, lo.cpu, hi.cpu, speedup, mean_pt, mean_sh, rmse_pt, rmse_sh, bias_rel});
        csv.row({236 * 60 * 128.0, 12 * 60 * 128.0, 2.25 * 60 * 128.0, 16.0, 0, 0, 0, 0, 0});
        ex.csv("moon07_fig9_cube_shadow.csv", csv);
        std::cout << "Moon07 Fig. 9 (cube of glass spheres, shadow edge), " << kept.size() << " spheres, " << W << "x"
                  << H << ", " << B << " batches\n"
                  << "  path tracing: " << pt.cpu << " CPU s (" << spp_pt * B << " spp)   paper: 236 min x 128 CPUs\n"
                  << "  low order:    " << lo.cpu << " CPU s (" << so.spp_low * B << " spp)   paper: 12 min\n"
                  << "  high order:   " << hi.cpu << " CPU s (" << so.spp_high * B << " spp)   paper: 2.25 min\n"
                  << "  mean over the cube: PT " << mean_pt << ", shells " << mean_sh << " (low " << sum_lo / nm
                  << " + high " << sum_hi / nm << "), bias " << 100 * bias_rel << " +- " << 100 * bias_rel_se
                  << " %\n"
                  << "  RMSE: PT " << rmse_pt << ", shells " << rmse_sh << "; equal-error speed-up " << speedup
                  << "x   paper: 16x (236 / 14.25 min)\n"
                  << "  shell table: raw " << raw_bytes / 1024 << " KiB -> factored " << factored_bytes / 1024
                  << " KiB   paper: ~30 MB -> 250 KB\n";
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        gl_examples::Json j = ex.summary();
        add_comparison_json(j, st, pt.cpu, lo.cpu, hi.cpu);
        add_tracer_json(j, ts, high_samples);
        add_table_json(j, ct);
        j.num("rmse_shells_pixelwise", std::sqrt(mse_sh_pixelwise))
            .num("paper_speedup", 16.0)
            .boolean("cut_spheres", scene.cut)
            .boolean("clear_faces", scene.clear_faces)
            .boolean("exit_rule_table", to.exit_rule == gl::ShellExitRule::table)
            .boolean("hand_back", scene.hand_back)
            .boolean("face_optics", to.face.enabled())
            .num("face_glass_fraction", face_q)
            .num("sky_cone_deg", sky_cone)
            .boolean("nee", to.nee)
            .str("cos_cells", so.cos_cells)
            .integer("min_scatter", so.min_scatter)
            .num("switch_depth", to.switch_depth)
            .integer("spheres", (long long)kept.size())
            .num("cube_side_R", L)
            .integer("cube_pixels", (long long)n_mask)
            .str("rank_rows", "rank r renders the rows y with y % ranks == r")
            .nums("rank_row_counts", ex.mpi().row_counts(H))
            .num("wall_seconds", wall);
        return ex.finish(j);  // removes the checkpoints of the completed run
        });
}
