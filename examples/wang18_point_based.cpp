// wang18_point_based: Wang & Holzschuch 2018 (TVCG), the Fig. 12 / Table 3 set-up in small: a
// smooth glass sphere (eta 1.33) filled with the paper's "Bumpy sphere" material (Table 2:
// albedo {0.9545, 0.6774, 0.4565}, mean free path ratios {4.5455, 3.2258, 2.1739}, HG g = 0.7)
// under a quad light, in two optical sizes:
//   thick: radius 20 green mean free paths (the infinite-medium table is in its domain; the
//          "paper's optical scale" of Table 3), the case the JSON's main keys report;
//   small: radius 3.1 green mfp (the paper's mean free paths / 10 on a unit sphere), keys small_*.
// Each case is rendered
//   (a) point-based (integrators/point_based.hpp): single (Eq. 5) + double (Eq. 6, Alg. 1 cut) +
//       multiple (Eq. 7, table precompute/ms_table.hpp) + bounced
//       (Eq. 8, surface samples with their own octree and tree cut), Eq. 9;
//   (b) the reference: the library's VPT (walk kernel), one grey walk per colour channel (each
//       channel's free flights sampled with its own sigma_t: no spectral weights, which made the
//       RGB walk heavy-tailed in the thick sphere), no path-length cap (Russian roulette only),
//       8 batches; split by the number of scattering events and by boundary reflections between
//       events (the bounced term's path space).
// Speed-up at equal error as in ../shared/reference/measuring.md: CPU time, the reference's
// per-sample variance from its batches, the point-based error e^2 = MSE - reference variance.
//
// Runs on the example harness (common/harness.hpp) with the measurement shared with the
// bumpy-sphere examples (wang18_bumpy.hpp). Outputs in --out: EXR + PNG of every component,
// wang18_point_based.csv (component means) with its plot wang18_point_based_components.png
// (examples/plots/wang18_point_based.py), and the JSON summary as the last stdout line; with
// --bias-study, wang18_point_based_bias_study.csv.
//
//   wang18_point_based [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                      [--vpt-spp N] [--surface-samples N] [--eps1 E] [--small-eps1 E] [--bounce-samples N]
//                      [--bounce-generations 1|2] [--bias-study]
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"
#include "wang18_bumpy.hpp"

namespace gl = grainlight;

namespace {

// The measurement (VPT split callbacks, batch layout, comparison, CPU clock) is the one shared
// with the bumpy-sphere examples (wang18_bumpy.hpp); only the shape differs (an analytic sphere).
using wang18::cpu_seconds;
using wang18::Grey;
using wang18::image_mean;
using wang18::kBatches;
using wang18::kComp;
using wang18::kCompName;
using wang18::MediumG;
using wang18::Phase;
using wang18::PhaseG;
using wang18::SceneG;
using wang18::SplitVpt;
using Medium = wang18::Medium;
using Renderer = gl::PointBasedRenderer<Phase, gl::SphereShape<float>>;

/// Run parameters (from the command line).
struct Params {
    bool full = false;
    int vpt_spp = 512, n_surface = 6000, bounce_generations = 2, bounce_samples = 512;
    int k_max = 6, bounce_rays = 4, bounce_k_max = 3;  ///< camera samples per ray (Eq. 10), the bounce gather's rays and samples
    gl::BounceReflection bounce_reflection = gl::BounceReflection::specular;  ///< how bounce samples store reflected light
    double eps1 = 0.2;        ///< Alg. 1 solid-angle threshold (sr), thick case (Table 3's 0.2 for BmpS.)
    double small_eps1 = 1.0;  ///< the same for the small sphere (reported, not bounded)
    std::uint64_t seed = 1;
};

struct Case {
    std::string name;
    float R_opt;  // radius in green mean free paths
};

struct CaseResult {
    wang18::Comparison cmp;  // point-based vs reference (pb, ref, ref_se, rel, rel_se, e2, speed-up)
    double pb_multiple_image = 0, rel_multiple_image = 0;
    double rel_far_mb = 0, rel_far_total = 0;  ///< the diffusion far field: multiple + bounced, total
    double cpu_pb = 0, cpu_samples = 0, cpu_vpt = 0, bounce_ratio = 0;
    std::size_t volume_samples = 0;
    int spp = 0;
};

CaseResult run_case(const gl_examples::Example& ex, const Case& cs, const gl::MsTable<3>& table, const Params& prm,
                    bool study) {
    const bool full = prm.full;
    const std::uint64_t seed = prm.seed;
    const int W = full ? 96 : 40, H = W;
    const gl::RGB albedo{0.9545f, 0.6774f, 0.4565f};
    const float lr[3] = {4.5455f, 3.2258f, 2.1739f};
    const float sc = cs.R_opt * lr[1];
    const gl::RGB sigma_t{sc / lr[0], sc / lr[1], sc / lr[2]};
    const float g = 0.7f, eta = 1.33f;
    const bool thick = cs.R_opt > 5;
    const Medium medium(sigma_t, albedo, Phase(g));
    const gl::SphereShape<float> sphere(gl::Vec3f(0.0f), 1.0f);
    const gl::QuadShape<float> quad(gl::Vec3f(-2.0f, 2.5f, -2.5f), gl::Vec3f(4, 0, 0), gl::Vec3f(0, 0, 4));
    const float Le = 4.0f;
    const gl::PinholeCamera<float> camera(gl::Vec3f(0.0f, 0.3f, 4.2f), gl::Vec3f(0.0f), gl::Vec3f(0, 1, 0), 32.0f, W, H);
    CaseResult res;
    res.spp = prm.vpt_spp;

    // --- Point-based: light samples (volume + bounce surface samples), render. ---
    gl::PointBasedOptions<float> po;
    po.light_samples = thick ? 2 : 4;
    po.volume_step = thick ? 0.2f / sigma_t.average() : 0.05f;
    po.k_max = prm.k_max;
    po.camera_bounces = thick ? 0 : (full ? 2 : 1);
    po.light_bounces = thick ? 0 : 2;
    po.max_optical_depth = thick ? 8.0f : 10.0f;
    po.cut.eps1 = float(thick ? prm.eps1 : prm.small_eps1);
    po.cut.eps2 = 0.2f * po.cut.eps1;
    po.two_step_depth = 3;
    po.bounce_samples = prm.bounce_samples;
    po.bounce_rays = prm.bounce_rays;
    po.bounce_k_max = prm.bounce_k_max;
    po.bounce_generations = prm.bounce_generations;
    po.bounce_reflection = prm.bounce_reflection;
    double c0 = cpu_seconds();
    gl::Rng lrng = gl::Rng::from_key(seed, 0x5742u);
    const int n_surf = thick && !full ? 2 * prm.n_surface : prm.n_surface;
    Renderer pb(medium, eta, sphere, gl::sphere_surface_samples(sphere, n_surf),
                gl::Light<float, gl::RGB>::quad_light(quad, gl::RGB(Le)), po, lrng, &table,
                gl::sphere_surface_samples(sphere, po.bounce_samples));
    res.cpu_samples = cpu_seconds() - c0;
    res.volume_samples = pb.volume_sample_count();
    res.bounce_ratio = pb.bounce_ratio()[1];

    wang18::PbRun pr;
    pr.img.assign(kComp, gl::Image(W, H));
    gl::Image pb_eq7(W, H);
    // Rows through the render driver (wang18_bumpy.hpp render_rows: checkpoints, rows split over
    // MPI ranks and gathered on rank 0); every pixel has its own key, so any thread or rank count
    // gives the same image. `fill` adds one pixel's components to the `nfilm` films.
    auto render_with = [&](const Renderer& r, const std::string& what, int nfilm, auto&& fill) {
        return wang18::render_rows(ex, "wang18 " + cs.name + what, cs.name + what, W, H, nfilm, 1,
                                   [&](int y, std::span<gl::Film> film) {
                                       for (int x = 0; x < W; ++x) {
                                           gl::Rng rng = gl::Rng::from_key(seed, std::uint64_t(y) * W + x, 0x10000u);
                                           const gl::Vec2f u = rng.uniform2<float>();
                                           fill(r.radiance_components(
                                                    camera.generate_ray(float(x) + u.x, float(y) + u.y), rng),
                                                film, x, y);
                                       }
                                   });
    };
    auto add = [](gl::Film& f, int x, int y, const gl::RGB& v) { f.add_rgb(x, y, v[0], v[1], v[2]); };
    using Components = gl::PointBasedComponents<gl::RGB>;
    c0 = cpu_seconds();
    {
        const std::vector<gl::Film> f =
            render_with(pb, " point-based", kComp, [&](const Components& c, std::span<gl::Film> film, int x, int y) {
                add(film[0], x, y, c.single);
                add(film[1], x, y, c.double_);
                add(film[2], x, y, c.multiple);
                add(film[3], x, y, c.bounced);
                add(film[4], x, y, c.total());
            });
        for (int k = 0; k < kComp; ++k) pr.img[std::size_t(k)] = f[std::size_t(k)].image();
    }
    res.cpu_pb = wang18::sum_over_ranks(ex, cpu_seconds() - c0);
    pr.cpu_samples = res.cpu_samples;
    pr.cpu_render = res.cpu_pb;
    // The study's other variants on the same camera rays: Eq. 7 with the boundary image, and the
    // diffusion far field (our addition; multiple + bounced and the total).
    gl::Image far_mb(W, H), far_total(W, H);
    if (study) {
        pb.set_ms_boundary_image(true);
        pb_eq7 = render_with(pb, " point-based (boundary image)", 1,
                             [&](const Components& c, std::span<gl::Film> film, int x, int y) {
                                 add(film[0], x, y, c.multiple);
                             })[0]
                     .image();
        pb.set_ms_boundary_image(false);
        gl::PointBasedOptions<float> pf = po;
        pf.ms_far_field = gl::MsFarField::diffusion;
        gl::Rng frng = gl::Rng::from_key(seed, 0x5742u);
        const Renderer pbf(medium, eta, sphere, gl::sphere_surface_samples(sphere, n_surf),
                           gl::Light<float, gl::RGB>::quad_light(quad, gl::RGB(Le)), pf, frng, &table,
                           gl::sphere_surface_samples(sphere, po.bounce_samples));
        const std::vector<gl::Film> f =
            render_with(pbf, " point-based (far field)", 2, [&](const Components& c, std::span<gl::Film> film, int x, int y) {
                add(film[0], x, y, c.multiple + c.bounced);
                add(film[1], x, y, c.total());
            });
        far_mb = f[0].image();
        far_total = f[1].image();
    }

    // --- VPT reference: one grey walk per channel, kBatches batches (sample s -> batch s % B). ---
    std::vector<SceneG> scenes;
    for (int ch = 0; ch < 3; ++ch) {
        SceneG s;
        const int m = s.add_medium(MediumG(Grey(sigma_t[ch]), Grey(albedo[ch]), PhaseG(g)));
        s.add_shape(sphere, gl::Material<float, Grey>::dielectric(eta), m, -1);
        s.add_quad_light(quad, Grey(Le));
        scenes.push_back(std::move(s));
    }
    const std::size_t npx = std::size_t(W) * std::size_t(H);
    wang18::VptRun v;  // batch sums v.bs[v.idx(comp, batch, pixel, ch)]
    v.spp = prm.vpt_spp;
    v.W = W;
    v.H = H;
    v.bs.assign(std::size_t(kComp) * kBatches * npx * 3, 0.0);
    c0 = cpu_seconds();
    wang18::vpt_batches(ex, "wang18 " + cs.name + " VPT reference", W, H, prm.vpt_spp, seed, scenes, camera,
                        gl::WalkOptions<float>{}, v);  // no max_depth cap; Russian roulette after 5 events
    res.cpu_vpt = wang18::sum_over_ranks(ex, cpu_seconds() - c0);
    v.cpu = res.cpu_vpt;

    // Reference mean images per component.
    std::vector<gl::Image> refi(kComp, gl::Image(W, H));
    for (int k = 0; k < kComp; ++k)
        for (std::size_t p = 0; p < npx; ++p)
            for (int ch = 0; ch < 3; ++ch) {
                double s = 0;
                for (int b = 0; b < kBatches; ++b) s += v.bs[v.idx(k, b, p, ch)];
                refi[std::size_t(k)].at(int(p % W), int(p / W), ch) = float(s / double(v.spp));
            }
    // Means with standard errors from the batches, e^2 = MSE - reference variance of the mean,
    // variance stability between batch halves, equal-error speed-up of the total (measuring.md).
    res.cmp = wang18::compare(pr, v);
    if (study) {
        res.pb_multiple_image = image_mean(pb_eq7);
        res.rel_multiple_image =
            res.cmp.ref[2] > 0 ? (res.pb_multiple_image - res.cmp.ref[2]) / res.cmp.ref[2] : 0.0;
        const double ref_mb = res.cmp.ref[2] + res.cmp.ref[3];
        res.rel_far_mb = ref_mb > 0 ? image_mean(far_mb) / ref_mb - 1 : 0.0;
        res.rel_far_total = res.cmp.ref[4] > 0 ? image_mean(far_total) / res.cmp.ref[4] - 1 : 0.0;
    }

    if (!study) {  // rank 0 only
        const double exposure = thick ? 4.0 : 1.0;
        wang18::save_image(ex, "wang18_" + cs.name + "_point_based", pr.img[4], exposure);
        wang18::save_image(ex, "wang18_" + cs.name + "_vpt", refi[4], exposure);
        for (int k = 0; k < 4; ++k) {
            wang18::save_image(ex, "wang18_" + cs.name + "_pb_" + kCompName[k], pr.img[std::size_t(k)], exposure);
            wang18::save_image(ex, "wang18_" + cs.name + "_vpt_" + kCompName[k], refi[std::size_t(k)], exposure);
        }
    }
    return res;
}

void print_case(const Case& cs, const CaseResult& r) {
    const auto& c = r.cmp;
    std::printf("Wang18 point-based vs VPT, %s sphere (radius %.1f green mean free paths), BmpS. material, eta 1.33\n",
                cs.name.c_str(), double(cs.R_opt));
    std::printf("  %-9s %12s %12s %10s %9s\n", "component", "point-based", "VPT", "VPT s.e.", "rel.diff");
    for (int k = 0; k < kComp; ++k)
        std::printf("  %-9s %12.5f %12.5f %10.2e %+8.1f%% (+- %.1f%%)\n", kCompName[k], c.pb[k], c.ref[k], c.ref_se[k],
                    100 * c.rel[k], 100 * c.rel_se[k]);
    std::printf("  bounced light (reflection between events): %.1f%% of all scattered light; twice/once reflected "
                "(point-based, green): %.3f\n",
                100 * c.bounced_share, r.bounce_ratio);
    std::printf("  CPU: light samples %.2f s (%zu volume samples), point-based render %.2f s, VPT %.2f s (%d spp x 3 "
                "channels)\n",
                r.cpu_samples, r.volume_samples, r.cpu_pb, r.cpu_vpt, r.spp);
    std::printf("  equal error: point-based e^2 = %.3e (MSE minus the reference's variance %.3e), VPT variance per "
                "sample %.3e (halves agree to %.2f) -> speed-up %.2fx   [paper Table 3: 11x-360x vs UPBP; BmpS. 360x]\n",
                c.e2[4], c.ref_var_mean[4], c.ref_var_per_sample, c.var_half_ratio, c.speedup);
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_point_based",
        "Wang18 point-based single + double + multiple + bounced scattering vs the VPT reference",
        "out/wang18_point_based", [&](gl_examples::Example& ex) -> int {
            Params prm;
            prm.vpt_spp = ex.opt<int>("vpt-spp", 2048, 4096, "VPT samples per pixel and channel, multiple of 8");
            prm.n_surface = ex.opt<int>("surface-samples", 12000, 20000,
                                        "light surface samples on the sphere (the thick case uses twice as many at quick)");
            prm.eps1 = ex.opt<double>("eps1", 0.2, 0.2,
                                      "Alg. 1 solid-angle threshold eps1 in sr of the thick case (Table 3: 0.2 for BmpS.), "
                                      "in (0, 10]; eps2 = eps1 / 5");
            prm.small_eps1 = ex.opt<double>("small-eps1", 1.0, 0.2, "eps1 of the small sphere, in (0, 10]");
            prm.bounce_samples = ex.opt<int>("bounce-samples", 512, 4096,
                                             "bounce surface samples of Eq. 8, their own Fibonacci lattice (<= 1000000)");
            prm.k_max = ex.opt<int>("k-max", 6, 16, "camera samples per point-based ray (Eq. 10), in [1, 4096]");
            prm.bounce_rays = ex.opt<int>("bounce-rays", 4, 8, "inward rays per bounce sample gathering its light, in [1, 1024]");
            prm.bounce_k_max = ex.opt<int>("bounce-k-max", 3, 6, "camera samples on each of those rays, in [1, 4096]");
            const std::string table_quality = ex.opt<std::string>(
                "table", "quick", "full",
                "the MS table's resolution and particle count: quick (48 x 96 x 12 x 6, 2e5) or full (96 x 192 x 18 x 9, 2e6)");
            const double table_range = ex.opt<double>("table-range", 10.0, 10.0,
                                                      "the MS table's extent, +- this many mean free paths (cells of the same size)");
            const long long table_photons_opt = ex.opt<long long>(
                "table-photons", 0, 0, "the MS table's particle count; 0 = the --table value's (2e5 or 2e6), else in [1000, 1e9]");
            prm.bounce_generations =
                ex.opt<int>("bounce-generations", 2, "reflections carried by the bounced term: 1 (Eq. 8 as in the paper) or 2");
            const std::string reflection = ex.opt<std::string>(
                "bounce-reflection", "specular",
                "how the bounce samples store the light they reflect: specular (the Fresnel lobe and the gather rays' "
                "mirror images) or diffuse (the paper's)");
            const bool study = ex.opt<bool>(
                "bias-study", false, "flag: the multiple-scattering bias study (optical radius 2, 5, 20, 50), docs/wang18.md");
            ex.checkpointable();
            ex.ready();
            prm.full = ex.full();
            prm.seed = ex.seed();
            const bool full = prm.full;
            const auto& out = ex.out();
            if (prm.vpt_spp < 16 || prm.vpt_spp % kBatches != 0)
                throw gl_examples::cli_error("--vpt-spp = " + std::to_string(prm.vpt_spp) +
                                             " must be >= 16 and a multiple of 8");
            if (prm.n_surface < 16)
                throw gl_examples::cli_error("--surface-samples = " + std::to_string(prm.n_surface) + " must be >= 16");
            if (!(prm.eps1 > 0) || prm.eps1 > 10)
                throw gl_examples::cli_error("--eps1 = " + std::to_string(prm.eps1) + " must be in (0, 10]");
            if (!(prm.small_eps1 > 0) || prm.small_eps1 > 10)
                throw gl_examples::cli_error("--small-eps1 = " + std::to_string(prm.small_eps1) + " must be in (0, 10]");
            if (prm.bounce_samples < 1 || prm.bounce_samples > 1000000)
                throw gl_examples::cli_error("--bounce-samples = " + std::to_string(prm.bounce_samples) +
                                             " must be in [1, 1000000]");
            if (prm.k_max < 1 || prm.k_max > 4096)
                throw gl_examples::cli_error("--k-max = " + std::to_string(prm.k_max) + " must be in [1, 4096]");
            if (prm.bounce_rays < 1 || prm.bounce_rays > 1024)
                throw gl_examples::cli_error("--bounce-rays = " + std::to_string(prm.bounce_rays) + " must be in [1, 1024]");
            if (prm.bounce_k_max < 1 || prm.bounce_k_max > 4096)
                throw gl_examples::cli_error("--bounce-k-max = " + std::to_string(prm.bounce_k_max) +
                                             " must be in [1, 4096]");
            if (reflection != "specular" && reflection != "diffuse")
                throw gl_examples::cli_error("--bounce-reflection = " + reflection + " must be specular or diffuse");
            prm.bounce_reflection =
                reflection == "diffuse" ? gl::BounceReflection::diffuse : gl::BounceReflection::specular;
            if (table_quality != "quick" && table_quality != "full")
                throw gl_examples::cli_error("--table = " + table_quality + " must be quick or full");
            if (!(table_range >= 2.0 && table_range <= 40.0))
                throw gl_examples::cli_error("--table-range = " + std::to_string(table_range) + " must be in [2, 40] mean free paths");
            if (table_photons_opt != 0 && (table_photons_opt < 1000 || table_photons_opt > 1000000000))
                throw gl_examples::cli_error("--table-photons = " + std::to_string(table_photons_opt) +
                                             " must be 0 or in [1000, 1e9]");
            if (prm.bounce_generations < 1 || prm.bounce_generations > 2)
                throw gl_examples::cli_error("--bounce-generations = " + std::to_string(prm.bounce_generations) +
                                             " must be 1 or 2");

            // One table for both cases (it is in units of the mean free path): built once, cached
            // on disk keyed by its parameters.
            const float g = 0.7f;
            const gl::RGB albedo{0.9545f, 0.6774f, 0.4565f};
            gl::MsTableOptions to;
            const bool full_table = table_quality == "full";
            to.n_rho = full_table ? 96 : 48;
            to.n_z = full_table ? 192 : 96;
            to.n_theta = full_table ? 18 : 12;
            to.n_phi = full_table ? 9 : 6;
            to.rho_max = table_range;
            to.z_min = -table_range;
            to.z_max = table_range;
            if (table_range != 10.0) {  // same cell size as the +-10 mfp grid
                to.n_rho = int(std::lround(to.n_rho * table_range / 10.0));
                to.n_z = int(std::lround(to.n_z * table_range / 10.0));
            }
            to.photons = table_photons_opt != 0 ? std::uint64_t(table_photons_opt) : (full_table ? 2000000u : 200000u);
            to.seed = prm.seed;
            const auto table_path = out / ("wang18_ms_table_g0.7_bmps_" + (table_range != 10.0 ? "r" + std::to_string(int(std::lround(table_range * 10))) + "_" : std::string()) + std::to_string(to.n_rho) + "x" +
                                           std::to_string(to.n_z) + "x" + std::to_string(to.n_theta) + "x" +
                                           std::to_string(to.n_phi) + "_" + std::to_string(to.photons) + "_s" +
                                           std::to_string(prm.seed) + "_v" +
                                           std::to_string(gl::ms_table_estimator_version) + ".bin");
            const double c0 = cpu_seconds();
            gl::MsTable<3> table;
            bool cached = false;
            if (std::filesystem::exists(table_path)) {
                try {
                    table = gl::MsTable<3>::load(table_path);
                    cached = true;
                } catch (const std::exception&) {
                    cached = false;
                }
            }
            if (!cached) {
                table = gl::MsTable<3>::build(Phase(g), albedo, to);
                if (ex.root()) table.save(table_path);
            }
            const double cpu_table = cpu_seconds() - c0;

            if (study) {
                const float radii[4] = {2, 5, 20, 50};
                if (ex.root()) std::printf("Multiple-scattering bias study (BmpS., g = 0.7, eta 1.33; multiple = >= 3 events, no "
                            "boundary reflection between events)\n");
                if (ex.root()) std::printf("  %8s %12s %12s %14s %16s %12s %10s %18s %14s\n", "R/l_g", "VPT mult.", "s.e.", "Eq. 7 (paper)",
                            "Eq. 7 + image", "total", "bounced", "far field: m + b", "far: total");
                gl_examples::Json j = ex.summary();
                j.str("study", "bias");
                wang18::put_rank_rows(ex, j, full ? 96 : 40);
                gl_examples::Csv csv({"radius_mfp", "vpt_multiple", "rel_se_multiple", "rel_diff_multiple_eq7",
                                      "rel_diff_multiple_image", "rel_diff_total", "bounced_share",
                                      "rel_diff_far_multiple_bounced", "rel_diff_far_total"});
                for (float R : radii) {
                    const Case cs{"R" + std::to_string(int(R)), R};
                    const CaseResult r = run_case(ex, cs, table, prm, true);
                    const auto& c = r.cmp;
                    if (ex.root()) std::printf("  %8.0f %12.5f %11.1f%% %+13.1f%% %+15.1f%% %+11.1f%% %9.1f%% %+17.1f%% %+13.1f%%\n", double(R), c.ref[2],
                                100 * c.rel_se[2], 100 * c.rel[2], 100 * r.rel_multiple_image, 100 * c.rel[4],
                                100 * c.bounced_share, 100 * r.rel_far_mb, 100 * r.rel_far_total);
                    const std::string p = "R" + std::to_string(int(R)) + "_";
                    j.num(p + "rel_diff_multiple_eq7", c.rel[2])
                        .num(p + "rel_diff_multiple_image", r.rel_multiple_image)
                        .num(p + "rel_se_multiple", c.rel_se[2])
                        .num(p + "rel_diff_total", c.rel[4])
                        .num(p + "bounced_share", c.bounced_share)
                        .num(p + "rel_diff_far_multiple_bounced", r.rel_far_mb)
                        .num(p + "rel_diff_far_total", r.rel_far_total);
                    csv.row({double(R), c.ref[2], c.rel_se[2], c.rel[2], r.rel_multiple_image, c.rel[4], c.bounced_share,
                             r.rel_far_mb, r.rel_far_total});
                }
                if (!ex.root()) return ex.finish({});
                (void)ex.csv("wang18_point_based_bias_study.csv", csv);
                return ex.finish(j);
            }

            const Case thick{"thick", 20.0f}, small{"small", 10.0f / 3.2258f};
            const CaseResult rt = run_case(ex, thick, table, prm, false);
            const CaseResult rs = run_case(ex, small, table, prm, false);
            if (!ex.root()) return ex.finish({});
            std::printf("MS table %ux%ux%ux%u from %llu particles: %.2f s CPU%s, %.1f MB\n", table.grid().n_rho,
                        table.grid().n_z, table.grid().n_theta, table.grid().n_phi, (unsigned long long)table.photons(),
                        cpu_table, cached ? " (loaded from the cache)" : "", double(table.bytes()) / 1e6);
            print_case(thick, rt);
            print_case(small, rs);

            gl_examples::Csv csv({"case", "component", "pb_mean", "vpt_mean", "vpt_se", "rel_diff"});
            for (const auto& [cs, r] : {std::pair<const Case&, const CaseResult&>{thick, rt}, {small, rs}})
                for (int k = 0; k < kComp; ++k)
                    csv.row_text({cs.name, kCompName[k], std::to_string(r.cmp.pb[k]), std::to_string(r.cmp.ref[k]),
                                  std::to_string(r.cmp.ref_se[k]), std::to_string(r.cmp.rel[k])});
            const auto csv_path = ex.csv("wang18_point_based.csv", csv);
            (void)ex.plot("wang18_point_based", csv_path, out / "wang18_point_based_components.png");

            gl_examples::Json j = ex.summary();
            j.integer("vpt_spp", prm.vpt_spp).integer("surface_samples", prm.n_surface);
            j.str("bounce_reflection", reflection);
            wang18::put_rank_rows(ex, j, full ? 96 : 40);
            j.num("seconds_table", cpu_table);
            auto put = [&](const std::string& p, const CaseResult& r) {
                const auto& c = r.cmp;
                j.integer(p + "volume_samples", (long long)r.volume_samples)
                    .num(p + "seconds_samples", r.cpu_samples)
                    .num(p + "seconds_pb", r.cpu_pb)
                    .num(p + "seconds_vpt", r.cpu_vpt);
                for (int k = 0; k < kComp; ++k) {
                    j.num(p + "rel_diff_" + kCompName[k], c.rel[k]);
                    j.num(p + "rel_se_" + kCompName[k], c.rel_se[k]);
                }
                j.num(p + "bounced_share", c.bounced_share)
                    .num(p + "pb_error2", c.e2[4])
                    .num(p + "vpt_variance_per_sample", c.ref_var_per_sample)
                    .num(p + "vpt_variance_half_ratio", c.var_half_ratio)
                    .num(p + "speedup_equal_error", c.speedup);
            };
            put("", rt);
            put("small_", rs);
            j.num("paper_speedup_bmps", 360.0).str("png", (out / "wang18_thick_point_based.png").string());
            return ex.finish(j);
        });
}
