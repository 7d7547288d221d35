// guo21_fig10_lamp: Guo21 Fig. 10 / Sec. 6.1, EPT vs ours for clouds of different PSDs under a
// lamp. The paper's LAMP scene (a mesh) is not available: a procedural stand-in, the 1 m cube of
// particles of guo21_cube_scene.hpp under a "lamp" (a 1.2 m x 1.2 m quad light 0.4 m above the
// cube, facing down; large enough for EPT, which finds the light by path tracing only, to converge) in a dark room (black background), seen by the cube camera.
// Ice spheres (m = 1.31, lambda = 0.55 um), log-normal PSDs r_g = 50, 200, 800 um at sigma_g = 2
// (truncated to [20, 2000] um; the paper's PSDs are not in the text), N = 1e5 (quick) or the paper's
// 5e5 (full), uniformly in the cube. Each PSD is rendered three ways with 8 seeded batches:
//   - EPT: the particles as explicit smooth dielectric spheres (ExplicitSphereMedium: exact
//     ray-sphere hits through the grid, Fresnel reflection/refraction; no diffraction),
//   - ours -FD (ray optics: C_t = pi r^2, GOA amplitudes without S_D): the same physics as EPT,
//   - ours (with Fraunhofer diffraction), which EPT lacks,
// with r_c = 2 um (<= r_p / 10 for every particle: the membership rule's extinction factor for
// opaque members, (1 + r_c / r_p)^2, stays <= 1.21 and is ~1.01 area-weighted; printed).
//
//   guo21_fig10_lamp [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                    [--width W] [--count N] [--query-radius-um R] [--checkpoint SECONDS] [--resume]
//
// Every render is split by rows over MPI ranks (mpirun -np K: byte-identical EXRs) and resumable
// (--checkpoint / --resume: one checkpoint per batch in --out); CPU seconds are summed over ranks.
// Paper: EPT misses the energy of Fraunhofer diffraction, "overly sparse and specular volumetric
// glints"; ours is smoother (pictures; Table 1: 44 vs 36 min, 1.2x). Printed and in the JSON per PSD:
// the means over the pixels that look through the cloud (lamp excluded) of EPT, ours -FD, ours and
// their ratios to EPT with standard errors, the contrast of each image (RMS over those pixels of
// pixel - mean, over the mean, Monte Carlo noise removed in quadrature: the glints), CPU seconds and
// bytes per particle.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/traversal/particle_grid.hpp"
#include "guo21_cornell_scene.hpp"
#include "guo21_cube_scene.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

namespace {

const gl::QuadShape<float> kLamp(gl::Vec3f(-0.6f, 1.4f, -0.6f), gl::Vec3f(1.2f, 0, 0), gl::Vec3f(0, 0, 1.2f));

/// The lamp scene: the cube of medium `medium` (grown by `margin` [m]) and the lamp (radiance 10,
/// facing down) in a dark room (black background): the image is the particles' scattered light.
template <class Scene>
void build_lamp(Scene& sc, int medium, double margin) {
    using Mat = gl::Material<float, S>;
    const float m = float(margin);
    sc.add_quad_light(kLamp, S(10.0f));
    sc.add_shape(gl::BoxShape<float>(gl::Vec3f(-0.5f - m, 0.0f - m, -0.5f - m), gl::Vec3f(0.5f + m, 1.0f + m, 0.5f + m)),
                 Mat::index_matched(), medium, -1);
}

/// Contrast of an image over the masked pixels: RMS of (pixel - mean) / mean, with the Monte Carlo
/// noise of the batch mean (Run::var_per_sample / spp) removed in quadrature.
double contrast(const guo21_cornell::Run& r, const std::vector<char>& mask) {
    const double m = guo21_cornell::masked_mean(r.img, mask);
    double s = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < mask.size(); ++i)
        if (mask[i]) {
            const double d = double(r.img.rgb[3 * i]) - m;
            s += d * d;
            ++n;
        }
    const double raw2 = n ? s / double(n) / (m * m) : 0.0;
    return std::sqrt(std::max(0.0, raw2 - r.var_per_sample / double(r.spp) / (m * m)));
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_fig10_lamp", "Guo21 Fig. 10: EPT of explicit spheres vs ours for several PSDs under a lamp",
        "out/guo21_fig10_lamp", [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 256, 1024, "samples per pixel (8 seeded batches)");
            const int width = ex.opt<int>("width", 80, 512, "image width (height = 3/4 width)");
            const auto count = ex.opt<std::uint64_t>("count", 100000, 500000, "particle count (paper: 5e5)");
            const double r_c_um = ex.opt<double>("query-radius-um", 2.0, "query-cylinder radius r_c [um]");
            ex.checkpointable();
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 8 || spp > 65536) throw gl_examples::cli_error("--spp must be in [8, 65536]");
            if (!(count >= 100 && count <= 100000000)) throw gl_examples::cli_error("--count must be in [100, 1e8]");
            if (!(r_c_um > 0 && r_c_um <= 1e4)) throw gl_examples::cli_error("--query-radius-um must be in (0, 1e4]");
            const auto& out = ex.out();
            const int height = width * 3 / 4;
            const double r_min = 20, r_max = 2000, sigma_g = 2, lambda = 0.55, r_c = r_c_um * 1e-6;
            const std::vector<double> r_gs = {50, 200, 800};
            gl::ParticleModel model;
            model.particle_index = {1.31, 0.0};
            const auto camera = guo21_cube::camera(width, height);
            // Pixels whose centre ray crosses the cube and does not see the lamp.
            std::vector<char> mask(std::size_t(width) * std::size_t(height), 0);
            {
                const gl::BoxShape<float> box{gl::Vec3f(-0.5f, 0.0f, -0.5f), gl::Vec3f(0.5f, 1.0f, 0.5f)};
                for (int y = 0; y < height; ++y)
                    for (int x = 0; x < width; ++x) {
                        const auto r = camera.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
                        float t;
                        gl::Vec3f n;
                        mask[std::size_t(y) * std::size_t(width) + std::size_t(x)] = box.intersect(r, t, n) && !kLamp.intersect(r, t, n);
                    }
            }
            gl::RenderOptions opt;
            opt.spp = spp;
            opt.threads = ex.threads();
            opt.seed = ex.seed();
            opt.vpt.max_depth = 256;
            const int batches = 8;
            std::printf("Guo21 Fig. 10 (Sec. 6.1): N = %llu ice spheres, log-normal sigma_g = %.0f in [%.0f, %.0f] um, 1 m cube under a "
                        "lamp, %dx%d, %d spp, r_c = %.1f um\n",
                        (unsigned long long)count, sigma_g, r_min, r_max, width, height, spp, r_c_um);
            std::printf("  %6s %8s %12s %9s %9s %9s %9s %8s %8s %8s %7s %7s %7s %6s\n", "r_g", "m.factor", "mean_EPT", "-FD/EPT", "+-se",
                        "ours/EPT", "+-se", "c_EPT", "c_-FD", "c_ours", "EPT s", "-FD s", "ours s", "B/p");
            std::vector<double> v_pred, v_of, v_rg, v_fac, v_me, v_mf, v_mo, v_rf, v_rf_se, v_ro, v_ro_se, v_ce, v_cf, v_co, v_te, v_tf, v_to, v_bpp;
            gl_examples::Csv csv({"r_g_um", "membership_factor", "mean_ept", "mean_no_diffraction", "mean_discrete",
                                  "rel_diff_no_diffraction", "rel_diff_no_diffraction_se", "rel_diff_discrete", "rel_diff_discrete_se",
                                  "contrast_ept", "contrast_no_diffraction", "contrast_discrete", "cpu_seconds_ept",
                                  "cpu_seconds_no_diffraction", "cpu_seconds_discrete", "bytes_per_particle"});
            for (std::size_t pi = 0; pi < r_gs.size(); ++pi) {
                const double r_g = r_gs[pi];
                const gl::LogNormalPsd psd(r_g, sigma_g, r_min, r_max);
                auto cloud = std::make_shared<gl::ParticleCloud>(gl::ParticleCloud::generate(
                    guo21_cube::cube_boundary(), count, {gl::cloud_species(psd)}, ex.seed() * 7919 + 10 + pi, 1e6));
                const double r_max_m = guo21_cube::max_radius_um(*cloud) * 1e-6;
                const std::string tag = "rg" + std::to_string(int(r_g));
                guo21_cornell::Run ept;
                {
                    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, guo21_cube::grid_settings(count, 0.0, r_max_m));
                    using M = gl::ExplicitSphereMedium<float>;
                    gl::Scene<M> sc;
                    build_lamp(sc, sc.add_medium(M(grid, 1.31f)), 1.5 * r_max_m);
                    ept = guo21_cornell::render_scene_batches(ex, batches, opt, mask, "EPT " + tag, height, sc, camera);
                }
                double bytes_pp = 0, factor = 1, factor_d = 1;
                auto ours = [&](bool diffraction, const std::string& label) {
                    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, guo21_cube::grid_settings(count, r_c, r_max_m));
                    gl::DiscreteMediumSettings ms;
                    ms.query_radius = r_c;
                    ms.wavelength_um = lambda;
                    ms.diffraction = diffraction;
                    using M = gl::DiscreteParticleMedium<float>;
                    gl::Scene<M> sc;
                    build_lamp(sc, sc.add_medium(M(grid, {model}, ms)), 1.5 * r_max_m + r_c);
                    const M& dm = sc.medium(0);
                    bytes_pp = double(dm.memory_bytes()) / double(count);
                    {
                        // Extinction-weighted membership factor of these particles (per particle's C_t).
                        double sct = 0, sctf = 0;
                        for (std::uint32_t i = 0; i < cloud->size(); ++i) {
                            const double ct = double(dm.extinction_cross_section(i));
                            sct += ct;
                            sctf += ct * gl::membership_extinction_factor(double((*cloud)[i].r), r_c, ct);
                        }
                        (diffraction ? factor_d : factor) = sctf / sct;
                    }
                    return guo21_cornell::render_scene_batches(ex, batches, opt, mask, label + " " + tag, height, sc, camera);
                };
                const auto f = ours(false, "ours -FD");
                const auto o = ours(true, "ours");
                const double me = guo21_cornell::masked_mean(ept.img, mask), mf = guo21_cornell::masked_mean(f.img, mask),
                             mo = guo21_cornell::masked_mean(o.img, mask);
                const double se_f = std::hypot(f.mean_se / me, ept.mean_se * mf / (me * me));
                const double se_o = std::hypot(o.mean_se / me, ept.mean_se * mo / (me * me));
                const double ce = contrast(ept, mask), cf = contrast(f, mask), co = contrast(o, mask);
                // Optically thin, side-scattering view: the image ~ sum of factor x C_t x f(theta). With
                // diffraction C_t doubles and f at wide angles halves (the lobe takes half), so ours / -FD
                // ~ factor_d / factor: thin cylinders (r_c << r_p) see only the geometric shadow of a
                // member (factor_d ~ 0.5), so the diffraction half of the extinction scatters nothing.
                v_pred.push_back(factor_d / factor);
                v_of.push_back(mo / mf);
                v_rg.push_back(r_g);
                v_fac.push_back(factor);
                v_me.push_back(me);
                v_mf.push_back(mf);
                v_mo.push_back(mo);
                v_rf.push_back(mf / me - 1);
                v_rf_se.push_back(se_f);
                v_ro.push_back(mo / me - 1);
                v_ro_se.push_back(se_o);
                v_ce.push_back(ce);
                v_cf.push_back(cf);
                v_co.push_back(co);
                v_te.push_back(ept.cpu_seconds);
                v_tf.push_back(f.cpu_seconds);
                v_to.push_back(o.cpu_seconds);
                v_bpp.push_back(bytes_pp);
                std::printf("  %6.0f %8.4f %12.6g %+9.4f %9.4f %+9.4f %9.4f %8.3f %8.3f %8.3f %7.2f %7.2f %7.2f %6.1f\n", r_g, factor, me,
                            mf / me - 1, se_f, mo / me - 1, se_o, ce, cf, co, ept.cpu_seconds, f.cpu_seconds, o.cpu_seconds, bytes_pp);
                csv.row({r_g, factor, me, mf, mo, mf / me - 1, se_f, mo / me - 1, se_o, ce, cf, co, ept.cpu_seconds, f.cpu_seconds,
                         o.cpu_seconds, bytes_pp});
                const double ev = std::log2(0.18 / std::max(me, 1e-12));
                if (!ex.root()) continue;  // only rank 0 writes
                gl::write_exr(out / ("ept_" + tag + ".exr"), ept.img);
                gl::write_png(out / ("ept_" + tag + ".png"), ept.img, {ev});
                gl::write_exr(out / ("ours_no_diffraction_" + tag + ".exr"), f.img);
                gl::write_png(out / ("ours_no_diffraction_" + tag + ".png"), f.img, {ev});
                gl::write_exr(out / ("ours_" + tag + ".exr"), o.img);
                gl::write_png(out / ("ours_" + tag + ".png"), o.img, {ev});
            }
            if (!ex.root()) return ex.finish({});
            const auto csv_path = ex.csv("guo21_fig10_lamp.csv", csv);
            double max_abs_rf = 0, max_z = 0;
            for (std::size_t i = 0; i < v_rf.size(); ++i) {
                max_abs_rf = std::max(max_abs_rf, std::abs(v_rf[i]));
                max_z = std::max(max_z, std::abs(v_rf[i]) / std::max(v_rf_se[i], 1e-12));
            }
            for (std::size_t i = 0; i < v_rg.size(); ++i)
                std::printf("  r_g = %.0f um: ours / ours -FD = %.3f, predicted by the membership factors (with / without diffraction) "
                            "%.3f\n",
                            v_rg[i], v_of[i], v_pred[i]);
            std::printf("  paper: EPT lacks diffraction (sparse, specular glints), ours is smoother; Table 1 (LAMP, 5e5, 1024 spp): "
                        "EPT 44 min, ours 36 min (1.2x).\n  ours: -FD (ray optics) vs EPT max |rel diff| %.3f (%.1f se); CPU EPT / ours "
                        "%.2fx .. %.2fx at equal spp\n",
                        max_abs_rf, max_z, v_te.front() / v_to.front(), v_te.back() / v_to.back());
            auto j = ex.summary();
            j.integer("width", width)
                .integer("height", height)
                .integer("spp", spp)
                .integer("count", (long long)count)
                .num("query_radius_um", r_c_um)
                .num("sigma_g", sigma_g)
                .nums("r_g_um", v_rg)
                .nums("membership_factor", v_fac)
                .nums("mean_ept", v_me)
                .nums("mean_no_diffraction", v_mf)
                .nums("mean_discrete", v_mo)
                .nums("rel_diff_no_diffraction", v_rf)
                .nums("rel_diff_no_diffraction_se", v_rf_se)
                .nums("rel_diff_discrete", v_ro)
                .nums("rel_diff_discrete_se", v_ro_se)
                .nums("contrast_ept", v_ce)
                .nums("contrast_no_diffraction", v_cf)
                .nums("contrast_discrete", v_co)
                .nums("cpu_seconds_ept", v_te)
                .nums("cpu_seconds_no_diffraction", v_tf)
                .nums("cpu_seconds_discrete", v_to)
                .nums("bytes_per_particle", v_bpp)
                .nums("ours_over_no_diffraction", v_of)
                .nums("predicted_ours_over_no_diffraction", v_pred)
                .num("rel_diff_no_diffraction_last", v_rf.back())
                .num("rel_diff_no_diffraction_se_last", v_rf_se.back())
                .num("ours_over_no_diffraction_last", v_of.back())
                .num("predicted_ours_over_no_diffraction_last", v_pred.back())
                .num("max_abs_rel_diff_no_diffraction", max_abs_rf)
                .num("max_z_no_diffraction", max_z)
                .num("membership_factor_max", *std::max_element(v_fac.begin(), v_fac.end()))
                .num("bytes_per_particle_max", *std::max_element(v_bpp.begin(), v_bpp.end()))
                .num("paper_time_ratio", 44.0 / 36.0)
                .str("csv", csv_path.string())
                .str("cpu_seconds_note", "process CPU seconds of the renders, summed over the ranks");
            guo21_mpi::rank_rows(j, ex, height);
            return ex.finish(j);
        });
}
