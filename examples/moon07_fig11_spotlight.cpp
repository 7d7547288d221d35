// moon07_fig11_spotlight: Moon07 Fig. 11, a cube of Poisson-distributed glass spheres under a
// spotlight, rendered (a) by path tracing through the explicit spheres and (b) by low-order PT +
// high-order shells (integrators/shell_tracer.hpp, Fig. 6's shadow rays), with the equal-error
// speed-up and the fraction of the image intensity inside the spot (paper: 57 % rendered, 65 %
// photographed; 28.1 h PT vs 1.05 h, 27x).
//
//   moon07_fig11_spotlight [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//        [--spheres N] [--fraction F] [--width W] [--spp-pt N] [--spp-low N] [--spp-high N]
//        [--batches B] [--min-scatter K] [--switch-depth D] [--light-size S] [--light-height H]
//        [--spot-angle DEG] [--shell-paths N] [--shell-radii N] [--rebuild-table] [--cut-spheres] [--no-nee]
//        [--face-optics on|off] [--clear-faces] [--packing rsa|md] [--camera-height H]
//
// Scene: the cube of moon07_fig9_cube_shadow (moon07_cube_scene.hpp; same spheres, table and
// camera), no blocker; the spotlight is a square emitter of side 0.2 L (--light-size) at
// 0.6 L (--light-height) above the centre of the top face, facing down and emitting only within
// --spot-angle (default 30 deg: a spot of radius 0.35 L on the top face, penumbra +- 0.1 L).
// --quality full uses the paper's premise, a spotlight of small solid angle ("path traced rays
// are very unlikely to exit the medium and hit the light source", Moon07 Sec. 5): the same 0.2 L
// emitter at 1.5 L with a 13 deg cone (0.018 sr, spot radius 0.45 L), and 2048 PT spp (256 per
// batch) so that the reference still resolves the mean to ~1 % (docs/moon07.md, emitter study).
// Every vertex of a path through the explicit spheres is a smooth dielectric interface (a delta
// BSDF), so next-event estimation contributes nothing there: path tracing and the low order
// reach the light only when a ray leaving the cube hits the emitter, and a point spotlight would
// be black in both. Their noise is set by the emitter's solid angle from the top face:
// the old default (0.05 L at 1.5 L, 13 deg; 1.1e-3 sr) gave ~25 emitter hits per quick PT image
// (+- 19 % on the mean); the default (0.2 L at 0.6 L; 0.11 sr, the same spot radius) gives 100x
// the hits. The shell tracer's shadow rays sample the emitter like any area light. The spot
// region is the part of the top face within light_height L tan(spot angle) + the emitter's half
// side of the spot centre; spot_fraction = image intensity of the pixels seeing it / that of all
// cube pixels.
// Measurement as in moon07_fig9_cube_shadow (batches, measuring.md). JSON (last stdout line):
// seconds_pt, seconds_low, seconds_high, rmse_pt, rmse_shells, speedup_equal_error, mean_pt,
// mean_shells, spot_fraction_pt, spot_fraction_shells, bias_rel (+ _se), paper values.
#include "grainlight/packing/md_packer.hpp"
#include "moon07_cube_scene.hpp"

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "moon07_fig11_spotlight",
        "Moon07 Fig. 11: cube of glass spheres under a spotlight, path tracing vs low-order PT + shells",
        "out/moon07_fig11_spotlight", [&](gl_examples::Example& ex) -> int {
        const auto n_spheres = ex.opt<std::size_t>("spheres", 15000, 120000, "number of glass spheres (paper: 120000)");
        const double fraction = ex.opt<double>("fraction", 0.3, "packing fraction of the spheres, (0, 0.35] (rsa) or (0, 0.64) (md)");
        const std::string packing = ex.opt<std::string>(
            "packing", "rsa",
            "rsa: random sequential addition (Moon07's Poisson spheres, f <= 0.35); md: an MD packing (packing/md_packer.hpp, "
            "poured beads pack at ~0.6)");
        const int W = ex.opt<int>("width", 128, 512, "image width (height = 3/4 width)");
        const int H = std::max(1, W * 3 / 4);
        const int spp_pt = ex.opt<int>("spp-pt", 96, 256, "path-tracing samples per pixel per batch");
        const ShellSceneOptions so = ShellSceneOptions::declare(ex, "cube", 32, 48);
        const double light_size = ex.opt<double>("light-size", 0.2, "side of the square spot emitter / L");
        const double spot_angle = ex.opt<double>("spot-angle", 30.0, 13.0, "half-angle of the spot cone (deg, (0, 60])");
        const double light_height =
            ex.opt<double>("light-height", 0.6, 1.5, "height of the spot emitter above the top face / L, (0, 10]");
        const int B = ex.opt<int>("batches", 8, "independent batches per image (>= 4)");
        const double cam_height = ex.opt<double>(
            "camera-height", 1.3, "camera height / L above the floor (1.3: 18 deg above the horizon; the spot fraction depends on it)");
        (void)ex.opt<bool>("cut-spheres", true,
                           "a cube cut out of the periodic packing (flat glass faces; the default)");
        const bool whole_spheres = ex.opt<bool>(
            "whole-spheres", false,
            "whole spheres only, centres >= R inside (a sphere-free skin the shells do not describe: +12 % bias at L = 59 R)");
        const bool clear_faces = ex.opt<bool>(
            "clear-faces", false,
            "cut spheres' flat faces index matched (no refraction or Fresnel at the cube's faces; face optics then off)");
        const FaceOpticsOption fo = FaceOpticsOption::declare(ex);
        ex.checkpointable();
        ex.ready();
        so.check();
        const bool full = ex.full();
        const std::uint64_t seed = ex.seed();
        if (!(spot_angle > 0 && spot_angle <= 60))
            throw gl_examples::cli_error("--spot-angle = " + std::to_string(spot_angle) + " must be in (0, 60]");
        if (!(light_height > 0 && light_height <= 10))
            throw gl_examples::cli_error("--light-height = " + std::to_string(light_height) + " must be in (0, 10]");
        if (!(light_size > 0 && light_size <= 1))
            throw gl_examples::cli_error("--light-size = " + std::to_string(light_size) + " must be in (0, 1]");
        if (n_spheres < 100) throw gl_examples::cli_error("--spheres = " + std::to_string(n_spheres) + " must be >= 100");
        const bool md = packing == "md";
        if (!md && packing != "rsa") throw gl_examples::cli_error("--packing = " + packing + " must be rsa or md");
        if (!md && !(fraction > 0 && fraction <= gl::rsa_max_fraction))
            throw gl_examples::cli_error("--fraction = " + std::to_string(fraction) + " must be in (0, 0.35] with --packing rsa");
        if (md && !(fraction > 0 && fraction < gl::md_max_fraction))
            throw gl_examples::cli_error("--fraction = " + std::to_string(fraction) + " must be in (0, 0.64) with --packing md");
        if (!(cam_height >= 0.5 && cam_height <= 20))
            throw gl_examples::cli_error("--camera-height = " + std::to_string(cam_height) + " must be in [0.5, 20]");
        if (W < 8 || W > 8192) throw gl_examples::cli_error("--width = " + std::to_string(W) + " must be in [8, 8192]");
        if (B < 4) throw gl_examples::cli_error("--batches = " + std::to_string(B) + " must be >= 4");
        if (spp_pt < 1) throw gl_examples::cli_error("--spp-pt = " + std::to_string(spp_pt) + " must be >= 1");
        const std::filesystem::path out = ex.out();
        const auto wall0 = std::chrono::steady_clock::now();

        // --- the medium: RSA (or MD-packed) spheres (radius 1) in a periodic cube of side L ---
        const double L = std::cbrt(double(n_spheres) * 4.0 / 3.0 * gl::pi_v<double> / fraction);
        gl::Rng prng = gl::Rng::from_key(seed, 0xC0BEu);
        const gl::PeriodicTile rsa = [&] {
            if (!md) return gl::random_sequential_addition(n_spheres, fraction, prng, L);
            const gl::MdPackResult r = gl::md_pack(n_spheres, fraction, seed);
            const double sc = 1.0 / r.tile.radius();  // unit sphere radius; side = L up to the achieved fraction
            std::vector<Vec3d> c = r.tile.centers();
            for (auto& v : c) v *= sc;
            std::cerr << "moon07_fig11: MD packing reached f = " << r.fraction << (r.reached_target ? "" : " (jammed)") << "\n";
            return gl::PeriodicTile(r.tile.side() * sc, 1.0, std::move(c));
        }();
        const double R = rsa.radius();
        std::vector<Vec3d> kept;
        for (const Vec3d& c : rsa.centers())
            if (c.x >= R && c.x <= L - R && c.y >= R && c.y <= L - R && c.z >= R && c.z <= L - R) kept.push_back(c);
        CubeScene scene{L, 1.5, gl::PeriodicTile(L + 4 * R, R, kept), gl::BoxDistance(Vec3d(0.0), Vec3d(L)),
                        gl::Light<double, S1>::quad_light(
                            gl::QuadShape<double>(Vec3d((0.5 - light_size / 2) * L, (0.5 - light_size / 2) * L, (1 + light_height) * L),
                                                  Vec3d(0, light_size * L, 0), Vec3d(light_size * L, 0, 0)),
                            S1(0.9 / (light_size * light_size))),
                        gl::QuadShape<double>(Vec3d(0, 0, -100 * L), Vec3d(L, 0, 0), Vec3d(0, L, 0))};  // no blocker (below the floor)
        scene.spot_cos = std::cos(spot_angle * gl::pi_v<double> / 180);
        if (!whole_spheres) {  // default: the medium the shell table describes up to the faces
            scene.tile = rsa;
            scene.cut = true;
            scene.clear_faces = clear_faces;
            kept = rsa.centers();
        }
        std::cerr << "moon07_fig11: " << kept.size() << " spheres in a cube of side " << L << " R (f = " << fraction
                  << ")\n";

        // --- shell table from the same random process (cached; scene_shell_table, moon07_cube_scene.hpp) ---
        const CachedShellTable ct = scene_shell_table(so, rsa, R, 0.45 * L, full, md ? "moon07_fig11_md_" : "moon07_fig9_", n_spheres, fraction, seed,
                                                      out, ex.root(), "moon07_fig11");  // MPI: rank 0 saves the table
        const gl::ShellTable& table = ct.table;
        const double raw_bytes = ct.raw_bytes, factored_bytes = ct.factored_bytes;

        gl::ShellTracerOptions to = so.tracer_options(R);
        double face_q = 0;
        to.face = fo.optics(rsa, scene.eta, scene.cut && !scene.clear_faces, full, seed, face_q);
        if (to.face.enabled()) std::cerr << "moon07_fig11: face optics, glass fraction of face crossings q = " << face_q << "\n";
        scene.hand_back = so.hand_back;
        const gl::ShellTracer<S1, gl::BoxDistance> tracer(table, scene.cube, to);

        // --- camera; pixels that see the cube ---
        const gl::PinholeCamera<double> cam(Vec3d(2.2 * L, -1.6 * L, cam_height * L), Vec3d(0.5 * L, 0.5 * L, 0.42 * L),
                                            Vec3d(0, 0, 1), 36.0, W, H);
        std::size_t n_mask = 0;
        const std::vector<char> mask = volume_pixel_mask(scene, cam, W, H, n_mask, "cube");
        // Pixels whose primary ray enters the top face inside the spot region.
        const double spot_r = L * std::tan(spot_angle * gl::pi_v<double> / 180) * light_height + 0.5 * light_size * L;
        std::vector<char> spot(mask.size(), 0);
        std::size_t n_spot = 0;
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const std::size_t i = std::size_t(y) * std::size_t(W) + std::size_t(x);
                if (!mask[i]) continue;
                const gl::Ray<double> r = cam.generate_ray(x + 0.5, y + 0.5);
                const Vec3d q = r(scene.cube_entry(r));
                spot[i] = q.z > L * (1 - 1e-9) && std::hypot(q.x - 0.5 * L, q.y - 0.5 * L) <= spot_r;
                n_spot += spot[i];
            }
        if (n_spot < 4) throw std::runtime_error("the camera sees fewer than 4 pixels of the spot");

        // --- renders (--checkpoint SECONDS / --resume: one checkpoint per batch render, kept when it
        // finishes so a resumed run skips it, all removed at the end of a completed run; the shell
        // passes' step tallies count only the rows rendered by the resumed run) ---
        const ShellPasses passes = render_shell_passes(
            ex, cam, spp_pt, so.spp_low, so.spp_high, B, "fig11",
            [&](const gl::Ray<double>& r, gl::Rng& rng, Mode m, gl::ShellTraceStats* s) {
                return scene.radiance(r, rng, m, &tracer, nullptr, s);
            });
        if (!ex.root()) return ex.finish({});  // MPI: rank 0 has the gathered images and writes everything
        const BatchImages &pt = passes.pt, &lo = passes.lo, &hi = passes.hi;
        const gl::ShellTraceStats& ts = passes.ts;
        const double high_samples = double(so.spp_high) * B * double(n_mask);

        // --- statistics over the cube pixels (compare_shells_to_pt, moon07_cube_scene.hpp) ---
        const ShellVsPt st = compare_shells_to_pt(pt, lo, hi, mask);
        const std::size_t NP = st.NP;
        const double mean_pt = st.mean_pt, mean_sh = st.mean_sh, sum_pt = st.sum_pt, sum_sh = st.sum_sh,
                     sum_lo = st.sum_lo, sum_hi = st.sum_hi, mse_sh_pixelwise = st.mse_sh_pixelwise,
                     rmse_pt = st.rmse_pt, rmse_sh = st.rmse_sh, bias_rel = st.bias_rel,
                     bias_rel_se = st.bias_rel_se, speedup = st.speedup, nm = st.nm;
        const std::vector<double> &I_pt = st.I_pt, &I_sh = st.I_sh;

        // Fraction of the image intensity (cube pixels) inside the spot.
        double in_pt = 0, in_sh = 0;
        for (std::size_t i = 0; i < NP; ++i)
            if (spot[i]) {
                in_pt += I_pt[i];
                in_sh += I_sh[i];
            }
        const double spot_fraction_pt = in_pt / std::max(1e-300, sum_pt);
        const double spot_fraction_sh = in_sh / std::max(1e-300, sum_sh);
        // Per-region means: the spot (pixels seeing it) and the rest of the cube's pixels.
        const double n_rest = std::max(1.0, double(n_mask) - double(n_spot));
        const double mean_pt_spot = in_pt / double(n_spot), mean_sh_spot = in_sh / double(n_spot);
        const double mean_pt_rest = (sum_pt - in_pt) / n_rest, mean_sh_rest = (sum_sh - in_sh) / n_rest;

        // --- outputs ---
        write_shell_images(out, "moon07_fig11", st, W, H);
        // Ours (CPU s) beside the paper's (minutes on a 128-CPU cluster, as CPU s).
        gl_examples::Csv csv({"seconds_pt", "seconds_low", "seconds_high", "speedup_equal_error", "mean_pt",
                              "mean_shells", "rmse_pt", "rmse_shells", "bias_rel", "spot_fraction"});
        csv.row({pt.cpu, lo.cpu, hi.cpu, speedup, mean_pt, mean_sh, rmse_pt, rmse_sh, bias_rel, spot_fraction_sh});
        // The paper's row: 28.1 h PT vs 0.78 h low + 0.27 h high on its cluster (as s), 27x, 57 % rendered.
        csv.row({28.1 * 3600, 0.78 * 3600, 0.27 * 3600, 27.0, 0, 0, 0, 0, 0, 0.57});
        ex.csv("moon07_fig11_spotlight.csv", csv);
        std::cout << "Moon07 Fig. 11 (cube of glass spheres under a spotlight), " << kept.size() << " spheres, " << W << "x"
                  << H << ", " << B << " batches\n"
                  << "  path tracing: " << pt.cpu << " CPU s (" << spp_pt * B << " spp)   paper: 28.1 h\n"
                  << "  low order:    " << lo.cpu << " CPU s (" << so.spp_low * B << " spp)   paper: 0.78 h\n"
                  << "  high order:   " << hi.cpu << " CPU s (" << so.spp_high * B << " spp)   paper: 0.27 h\n"
                  << "  mean over the cube: PT " << mean_pt << ", shells " << mean_sh << " (low " << sum_lo / nm
                  << " + high " << sum_hi / nm << "), bias " << 100 * bias_rel << " +- " << 100 * bias_rel_se
                  << " %\n"
                  << "  RMSE: PT " << rmse_pt << ", shells " << rmse_sh << "; equal-error speed-up " << speedup
                  << "x   paper: 27x (28.1 / 1.05 h; 'less than 1/40' in its text)\n"
                  << "  intensity inside the spot: PT " << 100 * spot_fraction_pt << " %, shells " << 100 * spot_fraction_sh
                  << " %   paper: 57 % rendered, 65 % photographed\n"
                  << "  shell table: raw " << raw_bytes / 1024 << " KiB -> factored " << factored_bytes / 1024
                  << " KiB   paper: ~30 MB -> 250 KB\n";
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        gl_examples::Json j = ex.summary();
        add_comparison_json(j, st, pt.cpu, lo.cpu, hi.cpu);
        add_tracer_json(j, ts, high_samples);
        add_table_json(j, ct);
        j.num("rmse_shells_pixelwise", std::sqrt(mse_sh_pixelwise))
            .num("spot_fraction_pt", spot_fraction_pt)
            .num("spot_fraction_shells", spot_fraction_sh)
            .num("paper_spot_fraction_rendered", 0.57)
            .num("paper_spot_fraction_photo", 0.65)
            .integer("spot_pixels", (long long)n_spot)
            .num("mean_pt_spot", mean_pt_spot)
            .num("mean_shells_spot", mean_sh_spot)
            .num("rel_diff_spot", mean_sh_spot / std::max(1e-300, mean_pt_spot) - 1)
            .num("mean_pt_rest", mean_pt_rest)
            .num("mean_shells_rest", mean_sh_rest)
            .num("rel_diff_rest", mean_sh_rest / std::max(1e-300, mean_pt_rest) - 1)
            .boolean("clear_faces", scene.clear_faces)
            .num("paper_speedup", 27.0)
            .num("light_size", light_size)
            .num("light_height", light_height)
            .num("spot_angle_deg", spot_angle)
            .str("packing", packing)
            .num("camera_height", cam_height)
            .num("packing_fraction", rsa.packing_fraction())
            .num("emitter_solid_angle_sr", light_size * light_size / (light_height * light_height))
            .boolean("cut_spheres", scene.cut)
            .boolean("exit_rule_table", to.exit_rule == gl::ShellExitRule::table)
            .boolean("hand_back", scene.hand_back)
            .boolean("face_optics", to.face.enabled())
            .num("face_glass_fraction", face_q)
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
