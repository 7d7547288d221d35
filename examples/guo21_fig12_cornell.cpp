// guo21_fig12_cornell: Guo21 Fig. 12 / Sec. 6.1. 1e5 ice spheres (r = 1000 um, m = 1.31,
// lambda = 0.55 um) in a Cornell box (1 m cube of diffuse walls, grey: one spectral channel; a
// square area light in the ceiling), rendered four ways:
//   - EPT: the particles as explicit smooth dielectric spheres (exact ray-sphere hits through the
//     particle grid, Fresnel reflection/refraction; media/discrete_particles.hpp ExplicitSphereMedium),
//   - ours: the discrete-particle medium with Fraunhofer diffraction (GOA amplitudes + C_t of Eq. 12),
//   - ours -FD: without diffraction (ray optics exactly: C_t = pi r^2, amplitudes without S_D),
//   - FD only: ours - ours -FD,
// all with the query radius r_c = r_p / 20 (k given below), plus ours -FD at the paper's k = 0.5 and
// 1 (Eq. 23), where the membership rule's bias for opaque particles, (1 + r_c / r_p)^2 in
// extinction, is large. The walls are lit through the cloud; the mean radiance of the image is
// the compared number.
//
//   guo21_fig12_cornell [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                       [--width W] [--count N] [--rc-over-rp F]
//
// Last stdout line: JSON with mean_ept, mean_discrete, mean_discrete_no_diffraction,
// rel_diff_no_diffraction (vs EPT), rel_diff_discrete, mean_no_diffraction_k05 / _k1 and their
// predicted extinction factors, seconds_ept, seconds_discrete, time ratio, memory_mb_discrete,
// bytes_per_particle.
#include <chrono>
#include <ctime>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>
#include <iostream>
#include <memory>

#include "common/checkpoint.hpp"
#include "guo21_cornell_scene.hpp"
#include "common/harness.hpp"
#include "grainlight/core/color.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/optics/ice_index.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

namespace {

using guo21_cornell::build_cornell;
using guo21_cornell::CornellColours;
using guo21_cornell::kHi;
using guo21_cornell::kLo;
using guo21_cornell::kRadiusUm;
using guo21_cornell::masked_mean;
using guo21_cornell::render_scene_batches;
using guo21_cornell::Run;

/// Spectral Cornell box (Guo21 Sec. 6: 8 wavelength samples): RGB colours of the walls (linear
/// sRGB) and the light, upsampled by Jakob & Hanika 2019 (core/color.hpp).
struct SpectralCornell {
    gl::SigmoidSpectrum white = gl::fit_sigmoid_spectrum(gl::Vec3d(0.7, 0.7, 0.7));
    gl::SigmoidSpectrum red = gl::fit_sigmoid_spectrum(gl::Vec3d(0.63, 0.065, 0.05));
    gl::SigmoidSpectrum green = gl::fit_sigmoid_spectrum(gl::Vec3d(0.14, 0.45, 0.091));
    gl::EmissionSpectrum light = gl::fit_emission_spectrum(gl::Vec3d(12.0, 12.0, 12.0));
    [[nodiscard]] CornellColours at(double lambda_nm) const {
        return {float(white(lambda_nm)), float(red(lambda_nm)), float(green(lambda_nm)), float(light(lambda_nm))};
    }
};
using Bins8 = gl::WavelengthBins<8>;

/// Combine 8 one-channel renders (one per wavelength bin) into linear sRGB balanced to the
/// equal-energy white (an equal-energy radiance L renders as (L, L, L)); also returns Y / int y_bar
/// per pixel in `lum`.
gl::Image combine_spectral(const std::vector<gl::Image>& per_lambda, std::vector<float>& lum) {
    gl::Image out = per_lambda[0];
    const gl::Vec3d I = gl::cie1931_cmf_integral(Bins8::lo_nm, Bins8::hi_nm);
    const gl::Vec3d white = gl::xyz_to_linear_srgb(I);
    const std::size_t npx = out.rgb.size() / 3;
    lum.assign(npx, 0.0f);
    for (std::size_t px = 0; px < npx; ++px) {
        gl::Vec3d xyz(0.0);
        for (std::size_t i = 0; i < 8; ++i) xyz += double(per_lambda[i].rgb[3 * px]) * Bins8::xyz_weight(i);
        const gl::Vec3d rgb = gl::xyz_to_linear_srgb(xyz);
        for (int c = 0; c < 3; ++c) out.rgb[3 * px + std::size_t(c)] = float(rgb[c] / white[c]);
        lum[px] = float(xyz.y / I.y);
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(argc, argv, "guo21_fig12_cornell",
                            "Guo21 Fig. 12: 1e5 spheres of 1000 um in a Cornell box, EPT vs ours vs ours -FD",
                            "out/guo21_fig12_cornell", [&](gl_examples::Example& ex) -> int {
        using gl_examples::cli_error;
        const int width = ex.opt<int>("width", 64, 512, "image width = height");
        const int spp = ex.opt<int>("spp", 32, 512, "samples per pixel");
        const auto count = ex.opt<std::uint64_t>("count", 100000, "number of particles");
        const double rc_over_rp = ex.opt<double>("rc-over-rp", 0.05, "query radius r_c / r_p of the EPT comparison");
        const int batches = ex.opt<int>("batches", 8, "independent batches per render (variance, time to unit variance)");
        const bool paper_k = ex.opt<int>("paper-k", 1, "1: also render ours -FD at the paper's k = 0.5 and 1; 0: skip") != 0;
        const bool spectral =
            ex.opt<int>("spectral", 0, 1,
                        "1: also render EPT, ours and ours -FD at 8 wavelengths (ice index of Warren & Brandt 2008, coloured "
                        "walls, CIE 1931 -> sRGB; spp / 8 per wavelength)") != 0;
        ex.checkpointable();
        ex.ready();
        guo21_mpi::quiet_other_ranks(ex);
        const auto& out = ex.out();
        const int threads = ex.threads();
        if (width < 8 || width > 8192) throw cli_error("--width = " + std::to_string(width) + " must be in [8, 8192]");
        if (spp < 1 || spp > 65536) throw cli_error("--spp = " + std::to_string(spp) + " must be in [1, 65536]");
        if (count < 1 || count > 100000000) throw cli_error("--count = " + std::to_string(count) + " must be in [1, 1e8]");
        if (!(rc_over_rp > 0 && rc_over_rp <= 10))
            throw cli_error("--rc-over-rp = " + ex.given_text("rc-over-rp") + " must be in (0, 10]");
        const double r_p = kRadiusUm * 1e-6;
        if (batches < 2 || batches > 64 || batches > spp)
            throw cli_error("--batches = " + std::to_string(batches) + " must be in [2, min(64, spp)]");

        const gl::PinholeCamera<float> camera = guo21_cornell::camera(width);
        const double z_med = 2.3 - kHi.z;  // nearest depth of the medium
        const double footprint = double(camera.spread_angle()) * z_med;  // S_pix z_med / z_near
        auto k_of = [&](double r_c) { return 2 * r_c / footprint; };
        auto rc_of = [&](double k) { return gl::query_radius_eq23(k, double(camera.spread_angle()), 1.0, z_med); };

        const std::vector<char> mask = guo21_cornell::cloud_mask(camera, width);
        auto cloud = std::make_shared<gl::ParticleCloud>(gl::ParticleCloud::generate(
            gl::BoxBoundary(kLo, kHi), count, {gl::cloud_species(gl::MonodispersePsd(kRadiusUm))}, ex.seed() * 31 + 7, 1e6));
        gl::ParticleModel model;
        model.particle_index = {1.31, 0.0};

        gl::RenderOptions opt;
        opt.spp = spp;
        opt.threads = threads;
        opt.seed = ex.seed();
        opt.vpt.max_depth = 256;
        // --checkpoint SECONDS / --resume: one checkpoint per render (kept when it finishes, so a
        // resumed run skips the renders already done; ex.finish removes them). A resumed run's
        // timings count only the rows it rendered itself. Under mpirun every render is split by
        // rows over the ranks and gathered on each (guo21_mpi_render.hpp); only rank 0 writes.

        std::printf("Guo21 Fig. 12 (Sec. 6.1): %llu ice spheres r = %.0f um in a 1 m Cornell box, %dx%d, %d spp\n",
                    (unsigned long long)count, kRadiusUm, width, width, spp);

        // EPT of explicit dielectric spheres.
        Run ept;
        {
            auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gl::ParticleGridSettings{});
            using M = gl::ExplicitSphereMedium<float>;
            gl::Scene<M> sc;
            build_cornell(sc, sc.add_medium(M(grid, 1.31f)), 1.5 * r_p);
            ept = render_scene_batches(ex, batches, opt, mask, "EPT", width, sc, camera);
        }
        // Ours with and without diffraction at r_c.
        double memory_mb = 0, bytes_pp = 0;
        auto render_ours = [&](double r_c, bool diffraction, const std::string& label, bool record_memory) {
            gl::ParticleGridSettings gs;
            gs.dilation = r_c;
            auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
            gl::DiscreteMediumSettings ms;
            ms.query_radius = r_c;
            ms.diffraction = diffraction;
            using M = gl::DiscreteParticleMedium<float>;
            gl::Scene<M> sc;
            build_cornell(sc, sc.add_medium(M(grid, {model}, ms)), 1.5 * r_p + r_c);
            if (record_memory) {
                memory_mb = double(sc.medium(0).memory_bytes()) / (1024.0 * 1024.0);
                bytes_pp = double(sc.medium(0).memory_bytes()) / double(count);
            }
            return render_scene_batches(ex, batches, opt, mask, label, width, sc, camera);
        };
        const double r_c = rc_over_rp * r_p;
        const Run ours = render_ours(r_c, true, "ours", true);
        const Run ours_fd = render_ours(r_c, false, "ours -FD", false);
        const double rc05 = rc_of(0.5), rc1 = rc_of(1.0);
        const Run fd_k05 = paper_k ? render_ours(rc05, false, "ours -FD k=0.5", false) : Run{ours_fd};
        const Run fd_k1 = paper_k ? render_ours(rc1, false, "ours -FD k=1", false) : Run{ours_fd};

        // Spectral renders: 8 wavelength bins, each a one-channel render at spp / 8 with the
        // particles' optics (and EPT's sphere index) at that wavelength.
        struct SpectralRun {
            gl::Image img;
            std::vector<float> lum;
            double seconds = 0, mean_luminance = 0;
        };
        const SpectralCornell colours;
        const int spp_lambda = std::max(1, spp / 8);
        auto render_spectral = [&](int kind, const std::string& label) {  // 0 EPT, 1 ours, 2 ours -FD
            SpectralRun sr;
            std::vector<gl::Image> per;
            gl_examples::ProgressBar bar(label, std::uint64_t(width) * 8, !ex.root());
            const auto t0 = std::chrono::steady_clock::now();
            gl::ParticleGridSettings gs;
            gs.dilation = kind == 0 ? 0.0 : r_c;
            auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
            for (std::size_t i = 0; i < 8; ++i) {
                const double lnm = Bins8::lambda_nm(i);
                const auto m_ice = gl::ice_refractive_index(lnm * 1e-3);
                gl::RenderOptions o = opt;
                o.spp = spp_lambda;
                o.seed = opt.seed * 1000003ull + 104729ull * (i + 1);
                const std::string stem = label + ".lambda" + std::to_string(i);
                auto prog = [&](int n) { bar.advance(std::uint64_t(n)); };
                if (kind == 0) {
                    using M = gl::ExplicitSphereMedium<float>;
                    gl::Scene<M> sc;
                    build_cornell(sc, sc.add_medium(M(grid, float(m_ice.real()))), 1.5 * r_p, colours.at(lnm));
                    per.push_back(guo21_mpi::render_image(
                        ex, o, stem, [&](const gl::RenderOptions& oo, auto&& p) { return gl::render_discrete_vpt(sc, camera, oo, p); },
                        prog));
                } else {
                    gl::ParticleModel mi = model;
                    mi.particle_index = m_ice;
                    gl::DiscreteMediumSettings ms;
                    ms.query_radius = r_c;
                    ms.diffraction = kind == 1;
                    ms.wavelength_um = lnm * 1e-3;
                    using M = gl::DiscreteParticleMedium<float>;
                    gl::Scene<M> sc;
                    build_cornell(sc, sc.add_medium(M(grid, {mi}, ms)), 1.5 * r_p + r_c, colours.at(lnm));
                    per.push_back(guo21_mpi::render_image(
                        ex, o, stem, [&](const gl::RenderOptions& oo, auto&& p) { return gl::render_discrete_vpt(sc, camera, oo, p); },
                        prog));
                }
            }
            sr.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            bar.done();
            sr.img = combine_spectral(per, sr.lum);
            double s = 0;
            std::size_t n = 0;
            for (std::size_t px = 0; px < mask.size(); ++px)
                if (mask[px]) s += sr.lum[px], ++n;
            sr.mean_luminance = n ? s / double(n) : 0.0;
            return sr;
        };
        SpectralRun sp_ept, sp_ours, sp_fd;
        if (spectral) {
            sp_ept = render_spectral(0, "EPT spectral");
            sp_ours = render_spectral(1, "ours spectral");
            sp_fd = render_spectral(2, "ours -FD spectral");
        }

        gl::Image fd_only = ours.img;
        for (std::size_t i = 0; i < fd_only.rgb.size(); ++i) fd_only.rgb[i] = std::abs(ours.img.rgb[i] - ours_fd.img.rgb[i]);
        const double m_ept = masked_mean(ept.img, mask), m_ours = masked_mean(ours.img, mask), m_fd = masked_mean(ours_fd.img, mask);
        const double m_k05 = masked_mean(fd_k05.img, mask), m_k1 = masked_mean(fd_k1.img, mask);
        const double ev = std::log2(0.18 / std::max(m_ept, 1e-12));
        if (ex.root()) {  // only rank 0 writes
            gl::write_exr(out / "ept.exr", ept.img);
            gl::write_png(out / "ept.png", ept.img, {ev});
            gl::write_exr(out / "ours.exr", ours.img);
            gl::write_png(out / "ours.png", ours.img, {ev});
            gl::write_exr(out / "ours_no_diffraction.exr", ours_fd.img);
            gl::write_png(out / "ours_no_diffraction.png", ours_fd.img, {ev});
            gl::write_exr(out / "fd_only.exr", fd_only);
            gl::write_png(out / "fd_only.png", fd_only, {ev + 3});
            gl::write_png(out / "ours_no_diffraction_k05.png", fd_k05.img, {ev});
            gl::write_png(out / "ours_no_diffraction_k1.png", fd_k1.img, {ev});
            if (spectral) {
                const double evs = std::log2(0.18 / std::max(sp_ept.mean_luminance, 1e-12));
                gl::write_exr(out / "ept_spectral.exr", sp_ept.img);
                gl::write_png(out / "ept_spectral.png", sp_ept.img, {evs});
                gl::write_exr(out / "ours_spectral.exr", sp_ours.img);
                gl::write_png(out / "ours_spectral.png", sp_ours.img, {evs});
                gl::write_exr(out / "ours_no_diffraction_spectral.exr", sp_fd.img);
                gl::write_png(out / "ours_no_diffraction_spectral.png", sp_fd.img, {evs});
            }
        }

        // Predicted mean-extinction factor of the membership rule for -FD (C_t = pi r_p^2):
        // (1 + r_p/r_c)^2 (1 - e^-c)/c, c = (r_p/r_c)^2; -> (1 + r_c/r_p)^2 for r_c << r_p (opaque members).
        auto factor = [&](double rc) { return gl::membership_extinction_factor(r_p, rc, gl::pi_v<double> * r_p * r_p); };
        const double f_rc = factor(r_c), f05 = factor(rc05), f1 = factor(rc1);
        std::printf("  query radius r_c = %.0f um = r_p / %.0f (k = %.3f at this width, Eq. 23 as a length); grid: ~1 "
                    "particle per voxel\n  means over the pixels that look through the cloud (light excluded)\n",
                    r_c * 1e6, 1 / rc_over_rp, k_of(r_c));
        std::printf("  %-34s %12s %10s %10s %24s\n", "render", "mean", "vs EPT", "seconds", "predicted ext. factor");
        std::printf("  %-34s %12.6g %10s %10.1f %24s\n", "EPT (explicit dielectric spheres)", m_ept, "", ept.seconds, "1");
        std::printf("  %-34s %12.6g %+10.4f %10.1f %24.4f\n", "ours -FD (ray optics)", m_fd, m_fd / m_ept - 1, ours_fd.seconds,
                    f_rc);
        std::printf("  %-34s %12.6g %+10.4f %10.1f %24s\n", "ours (with diffraction)", m_ours, m_ours / m_ept - 1, ours.seconds,
                    "-");
        std::printf("  %-34s %12.6g %+10.4f %10.1f %24.4f\n", "ours -FD, k = 0.5", m_k05,
                    m_k05 / m_ept - 1, fd_k05.seconds, f05);
        std::printf("  %-34s %12.6g %+10.4f %10.1f %24.4f\n", "ours -FD, k = 1", m_k1, m_k1 / m_ept - 1,
                    fd_k1.seconds, f1);
        std::size_t npix = 0;
        for (const char c : mask) npix += c ? 1 : 0;
        const double tt_ept = ept.ttuv(npix), tt_ours = ours.ttuv(npix), tt_fd = ours_fd.ttuv(npix);
        std::printf("  time EPT / ours at equal spp (CPU seconds): %.2fx with diffraction, %.2fx -FD (paper: 1.2x at 1e5,\n"
                    "  Fig. 20: >= 2x from 1e6 on)\n",
                    ept.cpu_seconds / ours.cpu_seconds, ept.cpu_seconds / ours_fd.cpu_seconds);
        std::printf("  time to unit variance (per-sample variance x CPU s per sample, %d batches, masked pixels):\n"
                    "    EPT %.3g, ours %.3g, ours -FD %.3g -> speed-up EPT / ours %.2fx, EPT / ours -FD %.2fx\n"
                    "    (variance halves agree: EPT %.2f, ours %.2f, ours -FD %.2f; bias of ours -FD vs EPT %+.4f +- %.4f)\n",
                    batches, tt_ept, tt_ours, tt_fd, tt_ept / tt_ours, tt_ept / tt_fd, ept.var_half_ratio, ours.var_half_ratio,
                    ours_fd.var_half_ratio, m_fd - m_ept, std::hypot(ours_fd.mean_se, ept.mean_se));
        std::printf("  memory of ours: %.1f MB (%.1f bytes per particle: 16 cloud + grid); paper Table 1: 60 MB\n", memory_mb,
                    bytes_pp);
        if (spectral)
            std::printf("  spectral (8 bins 380-780 nm, %d spp each, ice n = %.4f..%.4f, Jakob-Hanika walls; mean Y over the\n"
                        "  same pixels): EPT %.5g, ours %.5g (%+.4f), ours -FD %.5g (%+.4f); %.1f / %.1f / %.1f s\n",
                        spp_lambda, gl::ice_refractive_index(Bins8::lambda_nm(0) * 1e-3).real(),
                        gl::ice_refractive_index(Bins8::lambda_nm(7) * 1e-3).real(), sp_ept.mean_luminance,
                        sp_ours.mean_luminance, sp_ours.mean_luminance / sp_ept.mean_luminance - 1, sp_fd.mean_luminance,
                        sp_fd.mean_luminance / sp_ept.mean_luminance - 1, sp_ept.seconds, sp_ours.seconds, sp_fd.seconds);
        std::printf("  paper: -FD is close to the full model; the FD-only image shows subtle differences (Fraunhofer's\n"
                    "  lobe at 1000 um is ~0.03 deg wide: r^2/lambda = 1.8 m, the box is in the particles' near field)\n");

        gl_examples::Json j = ex.summary();
        j.integer("width", width)
            .integer("spp", spp)
            .integer("count", (long long)count)
            .num("radius_um", kRadiusUm)
            .num("query_radius_m", r_c)
            .num("rc_over_rp", rc_over_rp)
            .num("k", k_of(r_c))
            .num("mean_ept", m_ept)
            .num("mean_discrete", m_ours)
            .num("mean_discrete_no_diffraction", m_fd)
            .num("rel_diff_no_diffraction", m_fd / m_ept - 1)
            .num("rel_diff_discrete", m_ours / m_ept - 1)
            .num("predicted_extinction_factor", f_rc)
            .num("mean_no_diffraction_k05", m_k05)
            .num("mean_no_diffraction_k1", m_k1)
            .num("query_radius_k05_m", rc05)
            .num("query_radius_k1_m", rc1)
            .num("predicted_extinction_factor_k05", f05)
            .num("predicted_extinction_factor_k1", f1)
            .num("seconds_ept", ept.seconds)
            .num("seconds_discrete", ours.seconds)
            .num("seconds_discrete_no_diffraction", ours_fd.seconds)
            .num("time_ratio_ept_over_discrete", ept.cpu_seconds / ours.cpu_seconds)
            .num("time_ratio_ept_over_discrete_no_diffraction", ept.cpu_seconds / ours_fd.cpu_seconds)
            .num("cpu_seconds_ept", ept.cpu_seconds)
            .num("cpu_seconds_discrete", ours.cpu_seconds)
            .num("cpu_seconds_discrete_no_diffraction", ours_fd.cpu_seconds)
            .num("ttuv_ept", tt_ept)
            .num("ttuv_discrete", tt_ours)
            .num("ttuv_discrete_no_diffraction", tt_fd)
            .num("ttuv_speedup_discrete", tt_ept / tt_ours)
            .num("ttuv_speedup_discrete_no_diffraction", tt_ept / tt_fd)
            .num("variance_half_ratio_ept", ept.var_half_ratio)
            .num("bias_no_diffraction", m_fd - m_ept)
            .num("bias_no_diffraction_se", std::hypot(ours_fd.mean_se, ept.mean_se))
            .integer("batches", batches)
            .integer("spectral", spectral ? 1 : 0)
            .num("paper_time_ratio", 1.2)
            .num("memory_mb_discrete", memory_mb)
            .num("bytes_per_particle", bytes_pp);
        guo21_mpi::rank_rows(j, ex, width);
        j.str("cpu_seconds_note", "process CPU seconds of the renders, summed over the ranks");
        gl_examples::Example::nonfinite(j, ept.nonfinite + ours.nonfinite + ours_fd.nonfinite);
        if (spectral)
            j.num("mean_luminance_ept_spectral", sp_ept.mean_luminance)
                .num("mean_luminance_discrete_spectral", sp_ours.mean_luminance)
                .num("mean_luminance_discrete_no_diffraction_spectral", sp_fd.mean_luminance)
                .num("rel_diff_no_diffraction_spectral", sp_fd.mean_luminance / sp_ept.mean_luminance - 1)
                .num("rel_diff_discrete_spectral", sp_ours.mean_luminance / sp_ept.mean_luminance - 1)
                .num("seconds_ept_spectral", sp_ept.seconds)
                .num("seconds_discrete_spectral", sp_ours.seconds);
        return ex.finish(j);  // the run is complete: its checkpoints are removed
    });
}
