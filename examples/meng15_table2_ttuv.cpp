// meng15_table2_ttuv: Meng15 Table 2 -- time to unit variance (ttuv, Sec. 6) of EPT, EPT+VPT and
// EPT+VPT+DA (integrators/hybrid.hpp), for the whole image and its high-order part, with P_a = 1
// and with the optimal acceptance P_a of Eqs. 6-8, and the bias of each against EPT, on
// procedural stand-ins for the paper's scenes (we have no scanned meshes):
//   snow_sphere   a sphere of snow grains (Fig. 11's object), analytic sphere boundary;
//   snowman_1m    a snowman of snow grains, its boundary a closed triangle mesh (three balls of a
//                 surface of revolution, flat bottom) through add_mesh_boundary: the DA switch
//                 asks the mesh's distance tree (MeshDistance::ball_inside);
//   snowman_10cm  the same snowman with the grain radius x 10 (Fig. 13 bottom; full quality, or
//                 --scenes);
//   spices        Fig. 12's four heaps (flour as diffuse grains, pink salt, brown sugar, cane sugar), radius
//                 --size / 2, one aggregate per panel, measured as one image of four panels (half width each);
//   sandcastle    Fig. 1's castle (towers, walls, keep: a heightfield CSG union, make_sandcastle_mesh) of sand
//                 grains, --castle-size grain radii wide (full: 5200, ~2e9 grains);
//   glass_bead_cube  Fig. 7's cube of glass beads (Moon07 Fig. 9; meng15_fig7_glass_bead_cube), --beads beads;
//   obj           any closed OBJ mesh (--obj FILE), centred, standing on the ground, --size tall.
// Each scene is printed beside Table 2's row (SPICES, SANDCASTLE, SNOWMAN LG. / SM.; the sphere has no row: Table 2's
// range over its four scenes). P_a opt uses AcceptanceEstimate::P_a_safe (docs/meng15_hybrid.md:
// robust preview moments, kept at 1 unless the predicted gain is resolved); when it is 1 the
// P_a = 1 render is reused (the same paths: no timing noise between the two rows).
//
//   meng15_table2_ttuv [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--scenes a,b]
//                      [--spp N] [--width W] [--size R] [--castle-size C] [--absorption A] [--preview-stride K]
//                      [--obj FILE] [--pa P] [--max-events N] [--vpt-depth N] [--min-ept N|auto] [--tau T]
//                      [--switch-depth D] [--checkpoint SECONDS] [--resume]
//
// --checkpoint / --resume: one checkpoint per scene, technique and panel in --out, and the P_a the
// timed previews chose beside them (a resumed run renders with the killed run's P_a); --pa pins
// P_a (no preview) when two runs must give the same images. mpirun -np K: rank r renders the rows
// y % K == r of every render (meng15_scenes.hpp render_hybrid_run), rank 0 runs the previews and
// sends their P_a to all ranks.
//
// ttuv per measuring.md: per pixel the sample variance over spp >= 8 independent bundle samples
// (B = spp batches), averaged over the pixels, times the thread CPU seconds of a 1-spp image;
// speed-up = ttuv(EPT) / ttuv(technique) from renders in one run. Last stdout line:
// {"scenes": {"<scene>": {ten numbers}, ...}, then the run's metadata}.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "meng15_scenes.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/procedural_boundaries.hpp"
#include "grainlight/integrators/hybrid.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/phase/tabulated.hpp"
#include "grainlight/precompute/scatterometer.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {

using meng15::Composite;
using meng15::Panel;
using meng15::SceneT;

// Meng15 Table 2 (ttuv in seconds; speedups over EPT in parentheses there).
struct PaperRow {
    const char* name;
    double total[5];  // EPT, EPT+VPT Pa=1, Pa=opt, EPT+VPT+DA Pa=1, Pa=opt
    double high[5];
};
constexpr PaperRow table2[] = {
    {"SPICES", {1617.3, 400.3, 249.7, 219.8, 201.9}, {688.8, 5.3, 5.0, 0.3, 0.4}},
    {"SANDCASTLE", {30.7, 14.4, 13.7, 13.9, 13.7}, {11.8, 0.1, 0.1, 0.4, 0.1}},
    {"SNOWMAN LG.", {4000.8, 132.0, 39.6, 16.3, 15.4}, {3548.6, 8.8, 9.2, 0.4, 0.5}},
    {"SNOWMAN SM.", {2868.4, 171.1, 52.7, 28.1, 25.2}, {2338.0, 6.1, 8.6, 0.4, 0.5}},
};
// Table 2's printed speedups (the ttuv columns are rounded to 0.1 s).
constexpr double table2_speedup[4][4] = {{4.00, 6.50, 7.40, 8.00}, {2.10, 2.20, 2.20, 2.20}, {30.3, 101.0, 246.0, 260.0},
                                         {16.8, 54.4, 102.0, 114.0}};
constexpr double table2_speedup_high[4][4] = {{130.8, 137.8, 2554.0, 1968.0}, {206.8, 230.0, 26.5, 242.0},
                                              {404.6, 385.3, 8473.0, 7394.0}, {381.5, 271.4, 6431.0, 4997.0}};

struct Measured {
    std::string technique;
    double Pa = 1, ttuv = 0, ttuv_se = 0, ttuv_high = 0, mean = 0, mean_se = 0, speed = 1, speed_high = 1, speed_se = 0;
    double ttuv_low = 0, speed_bound = 0;  ///< ttuv of the EPT part alone; ttuv(EPT) / it: the best any continuation could do
    double bias = 0, bias_se = 0, switched = 0, switch_depth = 0, da_per_path = 0, cpu = 0;
    bool reused = false;
};

struct SceneResult {
    std::string key;
    std::vector<Measured> rows;
    std::string json;
};

struct RunConfig {
    int spp = 8;
    int preview_stride = 4;
    std::uint64_t seed = 1;
    int threads = 1;
    int max_events = 4096;
    int vpt_depth = 4096;
    double exposure = 0;
    double pa_pinned = 0;  ///< --pa: P_a of the "P_a opt" rows without a preview (0: preview)
    int min_ept = 1;       ///< --min-ept: grain interactions in EPT before a path may switch
    double tau = 4.0;      ///< --tau: Eq. 5's bundle-spread threshold [grain radii]
    double switch_depth = 0;  ///< --switch-depth: smallest boundary distance of a switch [grain radii]
    int flight_memory = gl::HybridOptions{}.flight_memory;  ///< --flight-memory: flights the VPT remembers (0: memoryless)
    bool flight_memory_boundary = gl::HybridOptions{}.flight_memory_boundary;  ///< --flight-memory-boundary
};

// One scene: one or more panels (equal sizes) measured as one image (meng15_scenes.hpp).
template <class Shape, class Distance, class Camera>
SceneResult run_scene(const Example& ex, const std::string& key, const std::vector<Panel<Shape, Distance, Camera>>& panels,
                      const RunConfig& rc, int paper_row) {
    struct Tech {
        const char* name;
        gl::HybridMode mode;
        bool opt;
    };
    const Tech techs[5] = {{"EPT", gl::HybridMode::ept, false},
                           {"EPT+VPT Pa=1", gl::HybridMode::ept_vpt, false},
                           {"EPT+VPT Pa=opt", gl::HybridMode::ept_vpt, true},
                           {"EPT+VPT+DA Pa=1", gl::HybridMode::ept_vpt_da, false},
                           {"EPT+VPT+DA Pa=opt", gl::HybridMode::ept_vpt_da, true}};
    SceneResult res;
    res.key = key;
    Composite last_p1;
    Measured ept_row, last_p1_row;
    std::printf("\n  %-18s %6s %11s %11s %13s %10s %9s %17s %7s %6s %8s\n", "technique", "P_a", "ttuv", "ttuv_high",
                "speedup", "sp_high", "mean", "bias vs EPT", "switch", "DA/pth", "bound");
    for (int ti = 0; ti < 5; ++ti) {
        const Tech& t = techs[ti];
        gl::HybridOptions opt;
        opt.mode = t.mode;
        opt.ept.max_events = rc.max_events;
        opt.vpt.max_depth = rc.vpt_depth;
        opt.min_ept_interactions = rc.min_ept;
        opt.tau = rc.tau;
        opt.min_switch_depth = rc.switch_depth;  // grain radius 1 in every scene
        opt.flight_memory = rc.flight_memory;
        opt.flight_memory_boundary = rc.flight_memory_boundary;
        double Pa = 1.0;
        std::vector<double> Pa_panel;
        if (t.opt && rc.pa_pinned > 0) {
            Pa = rc.pa_pinned;
            Pa_panel.assign(panels.size(), Pa);
            std::printf("  %-18s P_a pinned by --pa: %.3f\n", t.name, Pa);
        } else if (t.opt) {
            // Per panel (per aggregate) P_a; the row's P_a is their largest. Rank 0 runs the timed
            // previews, every rank gets their P_a, and --checkpoint keeps them for --resume
            // (checkpoint.hpp decided): a resumed run renders with the killed run's P_a.
            std::string stem = key + "_" + t.name + ".pa";
            Pa_panel = decided(ex, stem, [&] {
                std::vector<double> v;
                for (const auto& p : panels) {
                    gl::HybridOptions po = opt;
                    if (p.min_ept > 0) po.min_ept_interactions = p.min_ept;
                    const gl::AcceptanceEstimate a = gl::estimate_optimal_acceptance(
                        *p.ept, *p.vpt, *p.agg, *p.ctx, *p.camera, rc.spp, rc.seed + 1, rc.threads, po, rc.preview_stride);
                    v.push_back(a.P_a_safe);
                    std::printf("  %-18s %s preview (every %dth pixel): V_L %.3g V_H %.3g t_L %.3g t_H %.3g -> Eq. 8 %.3f; moments "
                                "%.3f; robust V %.3g E[H^2] %.3g -> %.3f (predicted gain %.2f +- %.2f) -> P_a %.3f\n",
                                t.name, p.name.c_str(), rc.preview_stride, a.V_L, a.V_H, a.t_L, a.t_H, a.P_a, a.P_a_moments,
                                a.V_robust, a.M_robust, a.P_a_robust, a.gain, a.gain_se, a.P_a_safe);
                }
                return v;
            });
            Pa = *std::max_element(Pa_panel.begin(), Pa_panel.end());
        }
        const bool all_one = std::all_of(Pa_panel.begin(), Pa_panel.end(), [](double v) { return v == 1.0; });
        opt.acceptance = 1.0;
        Composite img;
        Measured m;
        m.technique = t.name;
        m.Pa = Pa;
        if (t.opt && all_one) {
            img = last_p1;
            m = last_p1_row;
            m.technique = t.name;
            m.reused = true;
        } else {
            img = meng15::render_panels(ex, panels, rc.spp, rc.seed, opt, key + " " + t.name, Pa_panel);
            const gl::Image all = img.image(Composite::Part::combined);
            m.mean = img.mean;
            m.mean_se = img.mean_se;
            m.ttuv = img.ttuv();
            m.ttuv_se = img.ttuv_se();
            m.ttuv_high = img.ttuv_high();
            m.ttuv_low = img.ttuv_low();
            m.switched = img.switched / img.paths;
            m.switch_depth = img.switched > 0 ? img.switch_depth / img.switched : 0.0;
            m.da_per_path = img.da / img.paths;
            m.cpu = img.cpu();
            std::string file = key + "_" + t.name;
            for (char& ch : file) ch = (ch == ' ' || ch == '+' || ch == '=') ? '_' : char(std::tolower(ch));
            if (ex.root()) gl::write_exr(ex.out() / (file + ".exr"), all);
            if (ex.root()) gl::write_png(ex.out() / (file + ".png"), all, {rc.exposure});
            if (t.mode == gl::HybridMode::ept_vpt_da) {
                // Fig. 12: per-technique contributions and the switch depth.
                if (ex.root()) gl::write_exr(ex.out() / (file + "_ept.exr"), img.image(Composite::Part::ept));
                if (ex.root()) gl::write_exr(ex.out() / (file + "_vpt.exr"), img.image(Composite::Part::vpt));
                if (ex.root()) gl::write_exr(ex.out() / (file + "_da.exr"), img.image(Composite::Part::da));
                if (ex.root()) gl::write_exr(ex.out() / (file + "_switch_depth.exr"), img.image(Composite::Part::switch_depth));
            }
        }
        if (t.mode == gl::HybridMode::ept) ept_row = m;
        m.speed = ept_row.ttuv / m.ttuv;
        m.speed_high = m.ttuv_high > 0 ? ept_row.ttuv_high / m.ttuv_high : 0.0;
        m.speed_bound = t.mode != gl::HybridMode::ept && m.ttuv_low > 0 ? ept_row.ttuv / m.ttuv_low : 0.0;
        m.speed_se = m.speed * std::hypot(ept_row.ttuv_se / ept_row.ttuv, t.mode == gl::HybridMode::ept ? 0.0 : m.ttuv_se / m.ttuv);
        m.bias = (m.mean - ept_row.mean) / ept_row.mean;
        m.bias_se = std::hypot(m.mean_se, t.mode == gl::HybridMode::ept ? 0.0 : ept_row.mean_se) / ept_row.mean;
        if (!t.opt) {
            last_p1 = img;
            last_p1_row = m;
        }
        std::printf("  %-18s %6.3f %11.4g %11.4g %7.2fx+-%4.2f %9.1fx %9.4f %+7.2f%%+-%5.2f%% %7.2f %6.2f %7.2fx%s\n", t.name, Pa,
                    m.ttuv, m.ttuv_high, m.speed, m.speed_se, m.speed_high, m.mean, 100 * m.bias, 100 * m.bias_se,
                    m.switched, m.da_per_path, m.speed_bound, m.reused ? "  (= P_a = 1 render)" : "");
        res.rows.push_back(m);
    }
    // Table 2 beside ours.
    if (paper_row >= 0) {
        const PaperRow& p = table2[paper_row];
        std::printf("  Meng15 Table 2 %-12s ttuv EPT %.1f s | EPT+VPT %.1f (%.1fx), opt %.1f (%.1fx) | EPT+VPT+DA %.1f (%.1fx), "
                    "opt %.1f (%.1fx)\n",
                    p.name, p.total[0], p.total[1], table2_speedup[paper_row][0], p.total[2], table2_speedup[paper_row][1],
                    p.total[3], table2_speedup[paper_row][2], p.total[4], table2_speedup[paper_row][3]);
        std::printf("  %27s high order: EPT %.1f s | EPT+VPT %.1f (%.1fx), opt %.1f (%.1fx) | EPT+VPT+DA %.1f (%.1fx), opt %.1f "
                    "(%.1fx)\n",
                    "", p.high[0], p.high[1], table2_speedup_high[paper_row][0], p.high[2], table2_speedup_high[paper_row][1],
                    p.high[3], table2_speedup_high[paper_row][2], p.high[4], table2_speedup_high[paper_row][3]);
    } else {
        std::printf("  (Table 2 has no row for this scene; its speedups over its four scenes: EPT+VPT 2.1-30.3x, opt 2.2-101x, "
                    "EPT+VPT+DA 2.2-246x, opt 2.2-260x; high order 131-405x, 138-385x, 26.5-8473x, 242-7394x)\n");
    }
    const auto& r = res.rows;
    Json j;
    j.num("ept_vpt_speedup", r[1].speed)
        .num("ept_vpt_speedup_high_order", r[1].speed_high)
        .num("ept_vpt_pa_opt_speedup", r[2].speed)
        .num("ept_vpt_da_speedup", r[3].speed)
        .num("ept_vpt_da_speedup_high_order", r[3].speed_high)
        .num("ept_vpt_da_pa_opt_speedup", r[4].speed)
        .num("bias_ept_vpt", r[1].bias)
        .num("bias_ept_vpt_stderr", r[1].bias_se)
        .num("bias_ept_vpt_da", r[3].bias)
        .num("bias_ept_vpt_da_stderr", r[3].bias_se);
    res.json = j.str();
    return res;
}

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_table2_ttuv",
               "Meng15 Table 2: ttuv and speedups of EPT+VPT and EPT+VPT+DA over EPT on snow_sphere / snowman stand-ins",
               [&](Example& ex) {
        const std::string scenes_arg =
            ex.opt<std::string>("scenes", "snow_sphere,snowman_1m,spices", "snow_sphere,snowman_1m,snowman_10cm,spices,sandcastle,glass_bead_cube",
                                "scenes to render (snow_sphere, snowman_1m, snowman_10cm, spices, sandcastle, glass_bead_cube, obj)");
        const int spp = ex.opt<int>("spp", 8, 8, "bundles of 16 paths per pixel (>= 8: the variance batches)");
        const int width = ex.opt<int>("width", 64, 96, "image width (height = 3/4 width)");
        const double size = ex.opt<double>("size", 60.0, 400.0, "snowman height / 2.5 x sphere radius, in grain radii");
        const double castle = ex.opt<double>("castle-size", 60.0, 5200.0,
                                             "sandcastle width in grain radii (5200: ~2e9 sand grains, Fig. 1's scale)");
        const double beads = ex.opt<double>("beads", 15000.0, 120000.0, "glass beads in glass_bead_cube (Moon07 Fig. 9)");
        const double absorption = ex.opt<double>("absorption", 1e-3, 3e-4, "grain interior absorption per grain radius (green)");
        const int stride = ex.opt<int>("preview-stride", 4, 4, "P_a preview: every k-th pixel in x and y");
        const int level = ex.opt<int>("grain-level", 3, 4, "icosphere level of the snow grain mesh");
        const double exposure = ex.opt<double>("exposure", 0.0, "PNG exposure in stops");
        const std::string obj = ex.opt<std::string>("obj", "", "closed OBJ mesh for the scene 'obj' (scaled to --size grain radii tall)");
        const int max_events = ex.opt<int>("max-events", 4096, "EPT events per path at most (grain-walk events count)");
        const int vpt_depth = ex.opt<int>("vpt-depth", 4096, "VPT scattering + surface events per path at most");
        const std::string min_ept_arg = ex.opt<std::string>(
            "min-ept", "auto",
            "grain interactions in EPT before a path may switch: 'auto' (per grain kind, the smallest count whose bias in a "
            "half-space of the grains is within 3 %: integrators/hybrid_calibration.hpp) or a count (Meng15 Sec. 6: 1)");
        const double tau = ex.opt<double>("tau", 4.0, "Eq. 5's bundle-spread threshold tau [grain radii] (Meng15: 4)");
        const double switch_depth = ex.opt<double>(
            "switch-depth", 0.0, "switch to VPT only at least this far inside the boundary [grain radii] (Meng15: 0)");
        const int flight_memory = ex.opt<int>(
            "flight-memory", gl::HybridOptions{}.flight_memory,
            "flights of the path the VPT remembers (media/flight_memory.hpp; 0: Meng15's memoryless effective medium)");
        const bool memory_boundary = ex.opt<bool>(
            "flight-memory-boundary", gl::HybridOptions{}.flight_memory_boundary,
            "while the memory is active, no grain centre outside the aggregate's boundary (HybridOptions::flight_memory_boundary)");
        const auto pa_given = ex.opt_optional<double>(
            "pa", "pin P_a of the 'P_a opt' techniques to this value in (0, 1] (no preview; reproducible images)");
        ex.checkpointable();  // --checkpoint SECONDS / --resume: one checkpoint per scene, technique and panel
        ex.ready();
        meng15::quiet_other_ranks(ex);
        if (max_events < 16 || max_events > (1 << 24))
            throw cli_error("--max-events = " + ex.given_text("max-events") + " must be in [16, 16777216]");
        if (vpt_depth < 16 || vpt_depth > (1 << 24)) throw cli_error("--vpt-depth = " + ex.given_text("vpt-depth") + " must be in [16, 16777216]");
        if (pa_given && !(*pa_given > 0.0 && *pa_given <= 1.0)) throw cli_error("--pa = " + ex.given_text("pa") + " must be in (0, 1]");
        const bool min_ept_auto = min_ept_arg == "auto";
        int min_ept = 1;
        if (!min_ept_auto) {
            std::size_t used = 0;
            try {
                min_ept = std::stoi(min_ept_arg, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used != min_ept_arg.size() || min_ept < 1 || min_ept > 1000)
                throw cli_error("--min-ept = " + min_ept_arg + " must be 'auto' or an integer in [1, 1000]");
        }
        if (!(tau > 0 && tau <= 1e6)) throw cli_error("--tau = " + ex.given_text("tau") + " must be in (0, 1e6]");
        if (flight_memory < 0 || flight_memory > gl::FlightMemory::capacity)
            throw cli_error("--flight-memory = " + ex.given_text("flight-memory") + " must be in [0, " +
                            std::to_string(gl::FlightMemory::capacity) + "]");
        if (!(switch_depth >= 0 && switch_depth <= 1e6))
            throw cli_error("--switch-depth = " + ex.given_text("switch-depth") + " must be in [0, 1e6]");
        if (spp < 8 || spp > 4096) throw cli_error("--spp must be in [8, 4096] (measuring.md: >= 8 batches)");
        if (width < 8 || width > 2048) throw cli_error("--width must be in [8, 2048]");
        if (!(size >= 10 && size <= 5000)) throw cli_error("--size must be in [10, 5000] grain radii");
        if (!(castle >= 10 && castle <= 1e5)) throw cli_error("--castle-size must be in [10, 1e5] grain radii");
        if (!(beads >= 100 && beads <= 1e9)) throw cli_error("--beads must be in [100, 1e9]");
        if (!(absorption >= 0 && absorption <= 0.1)) throw cli_error("--absorption must be in [0, 0.1]");
        if (stride < 1 || stride > 50) throw cli_error("--preview-stride must be in [1, 50]");
        if (level < 1 || level > 5) throw cli_error("--grain-level must be in [1, 5]");
        std::vector<std::string> scenes;
        {
            std::stringstream ss(scenes_arg);
            std::string s;
            while (std::getline(ss, s, ','))
                if (!s.empty()) {
                    if (s != "snow_sphere" && s != "snowman_1m" && s != "snowman_10cm" && s != "spices" && s != "sandcastle" &&
                        s != "glass_bead_cube" && s != "obj")
                        throw cli_error("--scenes: '" + s +
                                        "' is not one of snow_sphere, snowman_1m, snowman_10cm, spices, sandcastle, glass_bead_cube, obj");
                    if (s == "obj" && obj.empty()) throw cli_error("--scenes obj needs --obj FILE");
                    scenes.push_back(s);
                }
        }
        if (scenes.empty()) throw cli_error("--scenes is empty");
        RunConfig rc;
        rc.spp = spp;
        rc.preview_stride = stride;
        rc.seed = ex.seed();
        rc.threads = ex.threads();
        rc.exposure = exposure;
        rc.pa_pinned = pa_given ? *pa_given : 0.0;
        rc.max_events = max_events;
        rc.vpt_depth = vpt_depth;
        rc.min_ept = min_ept;
        rc.tau = tau;
        rc.switch_depth = switch_depth;
        rc.flight_memory = flight_memory;
        rc.flight_memory_boundary = memory_boundary;
        const int height = std::max(6, width * 3 / 4);

        const meng15::Grains g = meng15::make_snow_grains(ex.seed(), ex.full(), absorption, level);
        std::printf("Meng15 Table 2 stand-ins: snow grains (ior 1.31, absorption %.2g /R green), f = %.3f, albedo %.4f, "
                    "sigma_t %.3f /R, g %.3f, d_DA = %.2f R; %dx%d px, %d bundles x 16 paths per pixel\n",
                    absorption, g.tile.packing_fraction(), g.stats.alpha_s(1), g.rte.sigma_t[1], g.rte.g[1], g.diffusion.d_DA,
                    width, height, spp);

        Csv csv({"scene", "technique", "P_a", "ttuv", "ttuv_stderr", "ttuv_high", "speedup", "speedup_stderr", "speedup_high",
                 "mean", "bias", "bias_stderr", "switched_fraction", "switch_depth", "da_per_path", "cpu_seconds",
                 "paper_speedup", "paper_speedup_high", "speedup_bound"});
        std::string scenes_json, min_ept_json;
        int snow_k = 0;  // --min-ept auto: the snow grains' calibrated count (computed once)
        auto snow_min_ept = [&]() {
            if (!min_ept_auto) return 0;
            if (snow_k == 0) snow_k = meng15::calibrate_min_ept(g, ex.seed(), ex.threads(), "snow grains", flight_memory, memory_boundary);
            return snow_k;
        };
        auto note_min_ept = [&](const std::string& name, int k) {
            min_ept_json += std::string(min_ept_json.empty() ? "" : ",") + Json::quote(name) + ":" + std::to_string(k > 0 ? k : min_ept);
        };
        for (const std::string& key : scenes) {
            SceneResult r;
            if (key == "spices") {
                // Fig. 12's four heaps (flour, pink salt, brown sugar, cane sugar), one aggregate per
                // panel, measured as one image of four panels (meng15_scenes.hpp).
                const double Rh = 0.5 * size;
                const auto heaps = meng15::make_spice_panels(Rh, absorption, std::max(8, width / 2), std::max(6, height / 2),
                                                             ex.seed(), ex.full(), level);
                std::printf("\nscene spices: four heaps of radius %.0f grain radii (flour, pink salt, brown sugar, cane sugar), "
                            "%dx%d px each; albedo (green) / d_DA:",
                            Rh, std::max(8, width / 2), std::max(6, height / 2));
                for (const auto& h : heaps) std::printf(" %s %.4f / %.2f R", h->name.c_str(), h->grains.stats.alpha_s(1), h->grains.diffusion.d_DA);
                std::printf("\n");
                for (const auto& h : heaps) {
                    if (min_ept_auto) h->min_ept = meng15::calibrate_min_ept(h->grains, ex.seed(), ex.threads(), h->name, flight_memory, memory_boundary);
                    note_min_ept("spices " + h->name, h->min_ept);
                }
                r = run_scene(ex, key, meng15::panels_of(heaps), rc, 0);
            } else if (key == "sandcastle") {
                const auto sc = meng15::make_sandcastle_panel(0.5 * castle, width, height, ex.seed(), ex.full(), level);
                std::printf("\nscene sandcastle: castle of sand grains %.0f grain radii wide (%zu triangles, ~%.3g grains; "
                            "albedo %.4f, d_DA = %.2f R)\n",
                            castle, sc[0]->mesh.triangle_count(), sc[0]->grain_count, sc[0]->grains.stats.alpha_s(1),
                            sc[0]->grains.diffusion.d_DA);
                if (min_ept_auto) sc[0]->min_ept = meng15::calibrate_min_ept(sc[0]->grains, ex.seed(), ex.threads(), "sand grains", flight_memory, memory_boundary);
                note_min_ept(key, sc[0]->min_ept);
                r = run_scene(ex, key, meng15::panels_of(sc), rc, 1);
            } else if (key == "glass_bead_cube") {
                const auto cube = meng15::make_glass_bead_cube(beads, width, height, ex.seed(), ex.full());
                std::printf("\nscene glass_bead_cube: Moon07 Fig. 9's cube of %.0f glass beads (RSA f = 0.3), side %.1f bead radii "
                            "(albedo %.4f, d_DA = %.2f R)\n",
                            beads, cube->L, cube->grains.stats.alpha_s(1), cube->grains.diffusion.d_DA);
                auto pans = cube->panels();
                if (min_ept_auto)
                    for (auto& pn : pans) pn.min_ept = meng15::calibrate_min_ept(cube->grains, ex.seed(), ex.threads(), "glass beads", flight_memory, memory_boundary);
                note_min_ept(key, pans.empty() ? 0 : pans[0].min_ept);
                r = run_scene(ex, key, pans, rc, -1);
            } else if (key == "snow_sphere") {
                const double Rb = size / 2.5;
                const gl::SphereBoundary shape(gl::Vec3d(0.0, Rb, 0.0), Rb);
                const gl::GranularAggregate<gl::SphereBoundary> agg = g.aggregate(shape, ex.seed());
                const float R = float(Rb);
                SceneT ept = meng15::make_lit_scene(R);
                SceneT vpt = ept;
                const int m = vpt.add_medium(g.medium);
                const int b = vpt.add_shape(gl::SphereShape<float>(gl::Vec3f(0.0f, R, 0.0f), R),
                                            gl::Material<float, gl::RGB>::index_matched(), m, -1);
                const gl::HybridContext<gl::BoundaryDistance<gl::SphereBoundary>> ctx{m, b, {shape}, &g.diffusion};
                const gl::PinholeCamera<float> cam(gl::Vec3f(0.0f, 1.6f * R, 4.2f * R), gl::Vec3f(0.0f, 0.9f * R, 0.0f),
                                                   gl::Vec3f(0, 1, 0), 36.0f, width, height);
                std::printf("\nscene snow_sphere: sphere of radius %.0f grain radii (Fig. 11's object)\n", Rb);
                note_min_ept(key, snow_min_ept());
                r = run_scene(ex, key,
                              std::vector<Panel<gl::SphereBoundary, gl::BoundaryDistance<gl::SphereBoundary>, gl::PinholeCamera<float>>>{
                                  {key, &agg, &ept, &vpt, &ctx, &cam, snow_min_ept()}},
                              rc, -1);
            } else {
                const bool small = key == "snowman_10cm";
                const double Hs = small ? size / 10.0 : size;
                gl::TriangleMesh<double> mesh;
                if (key == "obj") {
                    // Any closed OBJ: centred in x and z, standing on y = 0, scaled to Hs tall.
                    mesh = gl::load_obj<double>(obj);
                    const gl::Aabb<double> bb = mesh.bounds();
                    const double hgt = bb.hi.y - bb.lo.y;
                    if (!(hgt > 0)) throw cli_error("--obj: '" + obj + "' has no height");
                    const gl::Vec3d c(0.5 * (bb.lo.x + bb.hi.x), bb.lo.y, 0.5 * (bb.lo.z + bb.hi.z));
                    for (auto& v : mesh.vertices) v = (v - c) * (Hs / hgt);
                    mesh.compute_face_normals();
                } else {
                    mesh = gl::make_snowman_mesh(Hs, ex.full() ? 192 : 96, ex.full() ? 128 : 64);
                }
                const gl::MeshBoundary shape(mesh);
                const gl::GranularAggregate<gl::MeshBoundary> agg = g.aggregate(shape, ex.seed());
                const float R = float(0.4 * Hs);
                SceneT ept = meng15::make_lit_scene(R);
                SceneT vpt = ept;
                const int m = vpt.add_medium(g.medium);
                const gl::HybridContext<gl::MeshDistance> ctx = gl::add_mesh_boundary(vpt, mesh, m, &g.diffusion);
                const float Hf = float(Hs);
                const gl::PinholeCamera<float> cam(gl::Vec3f(0.0f, 0.55f * Hf, 1.45f * Hf), gl::Vec3f(0.0f, 0.46f * Hf, 0.0f),
                                                   gl::Vec3f(0, 1, 0), 36.0f, width, height);
                std::printf("\nscene %s: %s %.0f grain radii tall (%s; mesh boundary of %zu triangles, DA switch via "
                            "MeshDistance::ball_inside)\n",
                            key.c_str(), key == "obj" ? obj.c_str() : "snowman", Hs,
                            key == "obj" ? "user mesh" : small ? "Fig. 13 bottom: grain radius x10" : "Fig. 13 top",
                            mesh.triangle_count());
                note_min_ept(key, snow_min_ept());
                r = run_scene(ex, key,
                              std::vector<Panel<gl::MeshBoundary, gl::MeshDistance, gl::PinholeCamera<float>>>{
                                  {key, &agg, &ept, &vpt, &ctx, &cam, snow_min_ept()}},
                              rc, key == "obj" ? -1 : small ? 3 : 2);
            }
            const int prow = key == "snowman_1m" ? 2 : key == "snowman_10cm" ? 3 : key == "spices" ? 0 : key == "sandcastle" ? 1 : -1;
            for (std::size_t i = 0; i < r.rows.size(); ++i) {
                const Measured& m = r.rows[i];
                const double ps = i == 0 ? 1.0 : prow >= 0 ? table2_speedup[prow][i - 1] : 0.0;
                const double ph = i == 0 ? 1.0 : prow >= 0 ? table2_speedup_high[prow][i - 1] : 0.0;
                csv.row_text({key, m.technique, std::to_string(m.Pa), std::to_string(m.ttuv), std::to_string(m.ttuv_se),
                              std::to_string(m.ttuv_high), std::to_string(m.speed), std::to_string(m.speed_se),
                              std::to_string(m.speed_high), std::to_string(m.mean), std::to_string(m.bias),
                              std::to_string(m.bias_se), std::to_string(m.switched), std::to_string(m.switch_depth),
                              std::to_string(m.da_per_path), std::to_string(m.cpu), std::to_string(ps), std::to_string(ph),
                              std::to_string(m.speed_bound)});
            }
            if (!scenes_json.empty()) scenes_json += ',';
            scenes_json += Json::quote(key);
            scenes_json += ':';
            scenes_json += r.json;
        }
        if (ex.root()) {
            const auto csv_path = ex.csv("meng15_table2_ttuv.csv", csv);
            ex.plot("meng15_table2_ttuv", csv_path, ex.out() / "meng15_table2_ttuv.png");
        }
        std::printf("wrote %s/*.{exr,png} (per scene and technique; *_ept/_vpt/_da/_switch_depth.exr: Fig. 12's "
                    "contributions), meng15_table2_ttuv.{csv,png}\n",
                    ex.out().c_str());
        // Last line: {"scenes": {...}} first (the issue's shape), then the run's metadata.
        Json meta = ex.summary();
        meta.num("d_DA", g.diffusion.d_DA).integer("spp", spp).str("min_ept_rule", min_ept_auto ? "auto" : min_ept_arg);
        meta.raw("min_ept", "{" + min_ept_json + "}").integer("flight_memory", flight_memory).boolean("flight_memory_boundary", memory_boundary);
        meng15::rank_rows(meta, ex, height);
        return ex.finish_line("{\"scenes\":{" + scenes_json + "}," + meta.str().substr(1));
    });
}
