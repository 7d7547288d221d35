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
//   wang18_point_based [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                      [--vpt-spp N] [--surface-samples N] [--bias-study]
#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "common/cli.hpp"
#include "common/output.hpp"
#include "common/progress.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace gl = grainlight;

namespace {

using Phase = gl::HenyeyGreenstein<float, gl::RGB>;
using Medium = gl::ContinuousMedium<Phase, gl::RGB>;
using Renderer = gl::PointBasedRenderer<Phase, gl::SphereShape<float>>;
using Grey = gl::Spectrum<1, float>;
using PhaseG = gl::HenyeyGreenstein<float, Grey>;
using MediumG = gl::ContinuousMedium<PhaseG, Grey>;
using SceneG = gl::Scene<MediumG>;

constexpr int kComp = 5;  // single, double, multiple, bounced, total
const char* const kCompName[kComp] = {"single", "double", "multiple", "bounced", "total"};
constexpr int kBatches = 8;

double g_eps1 = 0;  // Alg. 1 solid-angle threshold (--eps1; 0: the quality default)
int g_bounce_samples = 0;  // bounce surface samples (--bounce-samples; 0: the quality default)

double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// VPT callbacks: scattered light by number of scattering events; paths with a boundary
// reflection between two scattering events go to `bounced`.
struct SplitVpt {
    const SceneG& scene;
    int count = 0;
    bool bounced_between = false;
    std::array<float, 4> L{0, 0, 0, 0};
    bool on_scatter(gl::PathState<float, Grey>& st, const gl::Interaction<float, Grey>&, const MediumG&) noexcept {
        ++count;
        if (count >= 2 && st.specular) bounced_between = true;
        return true;
    }
    bool on_surface(gl::PathState<float, Grey>& st, const gl::SurfaceHit<float, Grey>& hit) noexcept {
        if (hit.light < 0 || count == 0) return true;
        const float c = (st.throughput * scene.emitted(hit, st.ray.d))[0];
        L[bounced_between ? 3 : std::min(count, 3) - 1] += c;
        return true;
    }
};

struct Case {
    std::string name;
    float R_opt;  // radius in green mean free paths
};

struct CaseResult {
    double pb[kComp]{}, ref[kComp]{}, ref_se[kComp]{}, rel[kComp]{}, rel_se[kComp]{};
    double pb_multiple_image = 0, rel_multiple_image = 0;
    double cpu_pb = 0, cpu_samples = 0, cpu_vpt = 0, e2 = 0, ref_var_mean = 0, ref_var_per_sample = 0;
    double var_half_ratio = 0, speedup = 0, bounced_share = 0, bounce_ratio = 0;
    std::size_t volume_samples = 0;
    int spp = 0;
};

double image_mean(const gl::Image& a) { return (a.mean(0) + a.mean(1) + a.mean(2)) / 3.0; }

CaseResult run_case(const Case& cs, const gl::MsTable<3>& table, bool full, int vpt_spp, int n_surface, int threads,
                    std::uint64_t seed, const std::filesystem::path& out, bool study, int bounce_generations) {
    (void)threads;
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
    res.spp = vpt_spp;

    // --- Point-based: light samples (volume + bounce surface samples), render. ---
    gl::PointBasedOptions<float> po;
    po.light_samples = thick ? 2 : 4;
    po.volume_step = thick ? 0.2f / sigma_t.average() : 0.05f;
    po.k_max = full ? 16 : 6;
    po.camera_bounces = thick ? 0 : (full ? 2 : 1);
    po.light_bounces = thick ? 0 : 2;
    po.max_optical_depth = thick ? 8.0f : 10.0f;
    po.cut.eps1 = g_eps1 > 0 ? float(g_eps1) : (full ? 0.2f : 1.0f);
    po.cut.eps2 = 0.2f * po.cut.eps1;
    po.two_step_depth = 3;
    po.bounce_samples = g_bounce_samples > 0 ? g_bounce_samples : (full ? 4096 : 512);
    po.bounce_rays = full ? 8 : 4;
    po.bounce_k_max = full ? 6 : 3;
    po.bounce_generations = bounce_generations;
    double c0 = cpu_seconds();
    gl::Rng lrng = gl::Rng::from_key(seed, 0x5742u);
    const int n_surf = thick && !full ? 2 * n_surface : n_surface;
    Renderer pb(medium, eta, sphere, gl::sphere_surface_samples(sphere, n_surf),
                gl::Light<float, gl::RGB>::quad_light(quad, gl::RGB(Le)), po, lrng, &table,
                gl::sphere_surface_samples(sphere, po.bounce_samples));
    res.cpu_samples = cpu_seconds() - c0;
    res.volume_samples = pb.volume_sample_count();
    res.bounce_ratio = pb.bounce_ratio()[1];

    std::vector<gl::Image> pbi(kComp, gl::Image(W, H));
    gl::Image pb_eq7(W, H);
    auto render_pb = [&](bool eq7_only) {
        gl_examples::ProgressBar bar("wang18 " + cs.name + (eq7_only ? " point-based (boundary image)" : " point-based"),
                                     std::uint64_t(H));
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (int y = 0; y < H; ++y) {
            for (int x = 0; x < W; ++x) {
                gl::Rng rng = gl::Rng::from_key(seed, std::uint64_t(y) * W + x, 0x10000u);
                const gl::Vec2f u = rng.uniform2<float>();
                const auto c = pb.radiance_components(camera.generate_ray(float(x) + u.x, float(y) + u.y), rng);
                for (int ch = 0; ch < 3; ++ch) {
                    if (eq7_only) {
                        pb_eq7.at(x, y, ch) = c.multiple[ch];
                        continue;
                    }
                    pbi[0].at(x, y, ch) = c.single[ch];
                    pbi[1].at(x, y, ch) = c.double_[ch];
                    pbi[2].at(x, y, ch) = c.multiple[ch];
                    pbi[3].at(x, y, ch) = c.bounced[ch];
                    pbi[4].at(x, y, ch) = c.total()[ch];
                }
            }
            bar.advance(1);
        }
        bar.done();
    };
    c0 = cpu_seconds();
    render_pb(false);
    res.cpu_pb = cpu_seconds() - c0;
    if (study) {
        pb.set_ms_boundary_image(true);
        render_pb(true);
        pb.set_ms_boundary_image(false);
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
    // batch sums [comp][batch][pixel * 3 + ch]
    std::vector<double> bs(std::size_t(kComp) * kBatches * npx * 3, 0.0);
    auto bidx = [&](int k, int b, std::size_t p, int ch) {
        return ((std::size_t(k) * kBatches + std::size_t(b)) * npx + p) * 3 + std::size_t(ch);
    };
    gl::WalkOptions<float> wo;  // no max_depth cap; Russian roulette after 5 events
    gl_examples::ProgressBar bar2("wang18 " + cs.name + " VPT reference", std::uint64_t(H));
    c0 = cpu_seconds();
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (int y = 0; y < H; ++y) {
        for (int x = 0; x < W; ++x) {
            const std::size_t p = std::size_t(y) * W + x;
            for (int ch = 0; ch < 3; ++ch) {
                for (int s = 0; s < vpt_spp; ++s) {
                    gl::Rng rng = gl::Rng::from_key(seed, p, std::uint64_t(s) * 3 + std::uint64_t(ch));
                    const gl::Vec2f u = rng.uniform2<float>();
                    SplitVpt cb{scenes[std::size_t(ch)]};
                    auto st = gl::start_path<float, Grey>(camera.generate_ray(float(x) + u.x, float(y) + u.y), -1);
                    (void)gl::walk(scenes[std::size_t(ch)], st, rng, cb, wo);
                    const int b = s % kBatches;
                    double tot = 0;
                    for (int k = 0; k < 4; ++k) {
                        bs[bidx(k, b, p, ch)] += cb.L[std::size_t(k)];
                        tot += cb.L[std::size_t(k)];
                    }
                    bs[bidx(4, b, p, ch)] += tot;
                }
            }
        }
        bar2.advance(1);
    }
    bar2.done();
    res.cpu_vpt = cpu_seconds() - c0;
    const double per_batch = double(vpt_spp) / kBatches;

    // Component means with standard errors from the batch image means.
    std::vector<gl::Image> refi(kComp, gl::Image(W, H));
    for (int k = 0; k < kComp; ++k) {
        double bm[kBatches]{};
        for (int b = 0; b < kBatches; ++b) {
            double s = 0;
            for (std::size_t i = 0; i < npx * 3; ++i) s += bs[bidx(k, b, 0, 0) + i];
            bm[b] = s / (per_batch * double(npx * 3));
        }
        double m = 0, v = 0;
        for (double x : bm) m += x / kBatches;
        for (double x : bm) v += (x - m) * (x - m) / (kBatches - 1);
        for (std::size_t p = 0; p < npx; ++p)
            for (int ch = 0; ch < 3; ++ch) {
                double s = 0;
                for (int b = 0; b < kBatches; ++b) s += bs[bidx(k, b, p, ch)];
                refi[std::size_t(k)].at(int(p % W), int(p / W), ch) = float(s / double(vpt_spp));
            }
        res.ref[k] = m;
        res.ref_se[k] = std::sqrt(v / kBatches);
        res.pb[k] = image_mean(pbi[std::size_t(k)]);
        res.rel[k] = m > 0 ? (res.pb[k] - m) / m : 0.0;
        res.rel_se[k] = m > 0 ? res.ref_se[k] / m : 0.0;
    }
    res.bounced_share = res.ref[4] > 0 ? res.ref[3] / res.ref[4] : 0.0;
    if (study) {
        res.pb_multiple_image = image_mean(pb_eq7);
        res.rel_multiple_image = res.ref[2] > 0 ? (res.pb_multiple_image - res.ref[2]) / res.ref[2] : 0.0;
    }

    // Per-pixel variance of the total (per sample, from the batches), two halves for the check.
    double mse = 0, var_mean = 0, var_ps[2] = {0, 0};
    for (std::size_t p = 0; p < npx; ++p)
        for (int ch = 0; ch < 3; ++ch) {
            double bm[kBatches], m = 0;
            for (int b = 0; b < kBatches; ++b) {
                bm[b] = bs[bidx(4, b, p, ch)] / per_batch;
                m += bm[b] / kBatches;
            }
            double v = 0, vh[2] = {0, 0}, mh[2] = {0, 0};
            for (int b = 0; b < kBatches; ++b) v += (bm[b] - m) * (bm[b] - m) / (kBatches - 1);
            for (int h = 0; h < 2; ++h) {
                for (int b = h * kBatches / 2; b < (h + 1) * kBatches / 2; ++b) mh[h] += bm[b] / (kBatches / 2);
                for (int b = h * kBatches / 2; b < (h + 1) * kBatches / 2; ++b)
                    vh[h] += (bm[b] - mh[h]) * (bm[b] - mh[h]) / (kBatches / 2 - 1);
                var_ps[h] += vh[h] * per_batch;
            }
            const double d = double(pbi[4].at(int(p % W), int(p / W), ch)) - m;
            mse += d * d;
            var_mean += v / kBatches;
        }
    const double n3 = double(npx * 3);
    mse /= n3;
    var_mean /= n3;
    res.ref_var_mean = var_mean;
    res.ref_var_per_sample = var_mean * double(vpt_spp);
    res.var_half_ratio = var_ps[1] > 0 ? var_ps[0] / var_ps[1] : 0.0;
    res.e2 = std::max(mse - var_mean, 1e-3 * mse);
    // Reference time to error e^2: (per-sample variance / e^2) samples per pixel, at the measured
    // CPU seconds per pixel sample (all three channel walks).
    const double t_ref = res.ref_var_per_sample / res.e2 * (res.cpu_vpt / double(vpt_spp));
    res.speedup = t_ref / (res.cpu_samples + res.cpu_pb);

    auto save = [&](const gl::Image& img, const std::string& nm) {
        gl::write_exr(out / (nm + ".exr"), img);
        gl::write_png(out / (nm + ".png"), img, {thick ? 4.0 : 1.0});
    };
    if (!study) {
        save(pbi[4], "wang18_" + cs.name + "_point_based");
        save(refi[4], "wang18_" + cs.name + "_vpt");
        for (int k = 0; k < 4; ++k) {
            save(pbi[std::size_t(k)], "wang18_" + cs.name + "_pb_" + kCompName[k]);
            save(refi[std::size_t(k)], "wang18_" + cs.name + "_vpt_" + kCompName[k]);
        }
    }
    return res;
}

void print_case(const Case& cs, const CaseResult& r) {
    std::printf("Wang18 point-based vs VPT, %s sphere (radius %.1f green mean free paths), BmpS. material, eta 1.33\n",
                cs.name.c_str(), double(cs.R_opt));
    std::printf("  %-9s %12s %12s %10s %9s\n", "component", "point-based", "VPT", "VPT s.e.", "rel.diff");
    for (int k = 0; k < kComp; ++k)
        std::printf("  %-9s %12.5f %12.5f %10.2e %+8.1f%% (+- %.1f%%)\n", kCompName[k], r.pb[k], r.ref[k], r.ref_se[k],
                    100 * r.rel[k], 100 * r.rel_se[k]);
    std::printf("  bounced light (reflection between events): %.1f%% of all scattered light; twice/once reflected "
                "(point-based, green): %.3f\n",
                100 * r.bounced_share, r.bounce_ratio);
    std::printf("  CPU: light samples %.2f s (%zu volume samples), point-based render %.2f s, VPT %.2f s (%d spp x 3 "
                "channels)\n",
                r.cpu_samples, r.volume_samples, r.cpu_pb, r.cpu_vpt, r.spp);
    std::printf("  equal error: point-based e^2 = %.3e (MSE minus the reference's variance %.3e), VPT variance per "
                "sample %.3e (halves agree to %.2f) -> speed-up %.2fx   [paper Table 3: 11x-360x vs UPBP; BmpS. 360x]\n",
                r.e2, r.ref_var_mean, r.ref_var_per_sample, r.var_half_ratio, r.speedup);
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run_main("wang18_point_based", [&]() -> int {
        gl_examples::Cli cli(argc, argv, "wang18_point_based",
                             "Wang18 point-based single + double + multiple + bounced scattering vs the VPT reference");
        cli.common_options("out/wang18_point_based")
            .option("vpt-spp", "VPT samples per pixel and channel, multiple of 8 (default: 512 quick, 4096 full)")
            .option("surface-samples", "light surface samples on the sphere (default: 6000 quick, 20000 full; the thick case uses twice as many at quick)")
            .option("eps1", "Alg. 1 solid-angle threshold eps1 in sr (default 1.0 quick, 0.2 full; eps2 = eps1 / 5)")
            .option("bounce-samples", "bounce surface samples of Eq. 8, their own Fibonacci lattice (default 512 quick, 4096 full)")
            .option("bounce-generations", "reflections carried by the bounced term: 1 (Eq. 8 as in the paper) or 2 (default)")
            .option("bias-study", "flag: the multiple-scattering bias study (optical radius 2, 5, 20, 50), docs/wang18.md");
        cli.finish();
        const bool full = cli.full_quality();
        const auto out = cli.out_dir("out/wang18_point_based");
        const int threads = cli.threads();
        const int vpt_spp = int(cli.integer("vpt-spp", full ? 4096 : 512));
        const int n_surface = int(cli.integer("surface-samples", full ? 20000 : 6000));
        if (vpt_spp < 16 || vpt_spp % kBatches != 0 || n_surface < 16)
            throw gl_examples::cli_error("--vpt-spp >= 16 and a multiple of 8, --surface-samples >= 16");
        const std::uint64_t seed = cli.seed();
#if defined(_OPENMP)
        if (threads > 0) omp_set_num_threads(threads);
#endif
        const bool study = cli.has("bias-study");
        g_eps1 = cli.num("eps1", 0.0);
        if (g_eps1 < 0 || g_eps1 > 10) throw gl_examples::cli_error("--eps1 must be in (0, 10]");
        const int bounce_generations = int(cli.integer("bounce-generations", 2));
        g_bounce_samples = int(cli.integer("bounce-samples", 0));
        if (g_bounce_samples > 1000000) throw gl_examples::cli_error("--bounce-samples must be <= 1000000");
        if (bounce_generations < 1 || bounce_generations > 2) throw gl_examples::cli_error("--bounce-generations must be 1 or 2");

        // One table for both cases (it is in units of the mean free path): built once, cached on
        // disk keyed by its parameters.
        const float g = 0.7f;
        const gl::RGB albedo{0.9545f, 0.6774f, 0.4565f};
        gl::MsTableOptions to;
        to.n_rho = full ? 96 : 48;
        to.n_z = full ? 192 : 96;
        to.n_theta = full ? 18 : 12;
        to.n_phi = full ? 9 : 6;
        to.rho_max = 10;
        to.z_min = -10;
        to.z_max = 10;
        to.photons = full ? 2000000 : 200000;
        to.seed = seed;
        const auto table_path = out / ("wang18_ms_table_g0.7_bmps_" + std::to_string(to.n_rho) + "x" +
                                       std::to_string(to.n_z) + "x" + std::to_string(to.n_theta) + "x" +
                                       std::to_string(to.n_phi) + "_" + std::to_string(to.photons) + "_s" +
                                       std::to_string(seed) + ".bin");
        double c0 = cpu_seconds();
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
            table.save(table_path);
        }
        const double cpu_table = cpu_seconds() - c0;

        if (study) {
            const float radii[4] = {2, 5, 20, 50};
            std::printf("Multiple-scattering bias study (BmpS., g = 0.7, eta 1.33; multiple = >= 3 events, no boundary "
                        "reflection between events)\n");
            std::printf("  %8s %12s %12s %14s %16s %12s %10s\n", "R/l_g", "VPT mult.", "s.e.", "Eq. 7 (paper)",
                        "Eq. 7 + image", "total", "bounced");
            gl_examples::Json j;
            j.str("example", "wang18_point_based_bias_study");
            for (float R : radii) {
                const Case cs{"R" + std::to_string(int(R)), R};
                const CaseResult r = run_case(cs, table, full, vpt_spp, n_surface, threads, seed, out, true, bounce_generations);
                std::printf("  %8.0f %12.5f %11.1f%% %+13.1f%% %+15.1f%% %+11.1f%% %9.1f%%\n", double(R), r.ref[2],
                            100 * r.rel_se[2], 100 * r.rel[2], 100 * r.rel_multiple_image, 100 * r.rel[4],
                            100 * r.bounced_share);
                const std::string p = "R" + std::to_string(int(R)) + "_";
                j.num(p + "rel_diff_multiple_eq7", r.rel[2])
                    .num(p + "rel_diff_multiple_image", r.rel_multiple_image)
                    .num(p + "rel_se_multiple", r.rel_se[2])
                    .num(p + "rel_diff_total", r.rel[4])
                    .num(p + "bounced_share", r.bounced_share);
            }
            std::cout << j.str() << std::endl;
            return 0;
        }

        const Case thick{"thick", 20.0f}, small{"small", 10.0f / 3.2258f};
        const CaseResult rt = run_case(thick, table, full, vpt_spp, n_surface, threads, seed, out, false, bounce_generations);
        const CaseResult rs = run_case(small, table, full, vpt_spp, n_surface, threads, seed, out, false, bounce_generations);
        std::printf("MS table %ux%ux%ux%u from %llu particles: %.2f s CPU%s, %.1f MB\n", table.grid().n_rho,
                    table.grid().n_z, table.grid().n_theta, table.grid().n_phi, (unsigned long long)table.photons(),
                    cpu_table, cached ? " (loaded from the cache)" : "", double(table.bytes()) / 1e6);
        print_case(thick, rt);
        print_case(small, rs);

        gl_examples::Csv csv({"case", "component", "pb_mean", "vpt_mean", "vpt_se", "rel_diff"});
        for (const auto& [cs, r] : {std::pair<const Case&, const CaseResult&>{thick, rt}, {small, rs}})
            for (int k = 0; k < kComp; ++k)
                csv.row_text({cs.name, kCompName[k], std::to_string(r.pb[k]), std::to_string(r.ref[k]),
                              std::to_string(r.ref_se[k]), std::to_string(r.rel[k])});
        csv.write(out / "wang18_point_based.csv");

        gl_examples::Json j;
        j.str("example", "wang18_point_based").integer("vpt_spp", vpt_spp).integer("surface_samples", n_surface);
        j.num("seconds_table", cpu_table);
        auto put = [&](const std::string& p, const CaseResult& r) {
            j.integer(p + "volume_samples", (long long)r.volume_samples)
                .num(p + "seconds_samples", r.cpu_samples)
                .num(p + "seconds_pb", r.cpu_pb)
                .num(p + "seconds_vpt", r.cpu_vpt);
            for (int k = 0; k < kComp; ++k) {
                j.num(p + "rel_diff_" + kCompName[k], r.rel[k]);
                j.num(p + "rel_se_" + kCompName[k], r.rel_se[k]);
            }
            j.num(p + "bounced_share", r.bounced_share)
                .num(p + "pb_error2", r.e2)
                .num(p + "vpt_variance_per_sample", r.ref_var_per_sample)
                .num(p + "vpt_variance_half_ratio", r.var_half_ratio)
                .num(p + "speedup_equal_error", r.speedup);
        };
        put("", rt);
        put("small_", rs);
        j.num("paper_speedup_bmps", 360.0).str("png", (out / "wang18_thick_point_based.png").string());
        std::cout << j.str() << std::endl;
        return 0;
    });
}
