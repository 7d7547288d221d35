// guo21_cornell_scene.hpp: the Cornell box of Guo21 Fig. 12 shared by guo21_fig12_cornell,
// guo21_fig13_hg_fit, guo21_fig20_time_vs_n and guo21_ept_embree: a 1 m box of diffuse walls
// (grey: one spectral channel) with a square area light in the ceiling, the box of particle centres
// inside it, the camera, the mask of the pixels that look through the cloud, renders split into
// seeded batches (the mean image, per-sample variance for the time to unit variance, CPU seconds),
// and Fig. 20's set-up of EPT and ours over clouds of N ice spheres (Fig20Setup).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/harness.hpp"
#include "common/progress.hpp"
#include "guo21_mpi_render.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/scene/film_checkpoint.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace guo21_cornell {

namespace gl = grainlight;
/// One grey channel per render.
using S = gl::Spectrum<1, float>;

/// Particle radius of Fig. 12 [um].
constexpr double kRadiusUm = 1000.0;
/// The box of particle centres [m].
inline const gl::Vec3d kLo(0.15, 0.05, 0.15), kHi(0.85, 0.75, 0.85);

/// Reflectances of the walls (white floor/ceiling/back, "red" left, "green" right) and the
/// light's radiance at one wavelength (or the grey values of the one-channel render).
struct CornellColours {
    float white = 0.7f, left = 0.45f, right = 0.35f, light = 12.0f;
};

/// Adds the five walls, the ceiling light and the index-matched box of the medium `medium` (the
/// centres' box grown by `margin` [m]) to `sc`.
template <class Scene>
void build_cornell(Scene& sc, int medium, double margin, const CornellColours& c = {}) {
    using Mat = gl::Material<float, S>;
    using Q = gl::QuadShape<float>;
    using V = gl::Vec3f;
    sc.add_shape(Q(V(0, 0, 0), V(1, 0, 0), V(0, 0, 1)), Mat::diffuse(S(c.white)));  // floor
    sc.add_shape(Q(V(0, 1, 0), V(1, 0, 0), V(0, 0, 1)), Mat::diffuse(S(c.white)));  // ceiling
    sc.add_shape(Q(V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)), Mat::diffuse(S(c.white)));  // back
    sc.add_shape(Q(V(0, 0, 0), V(0, 1, 0), V(0, 0, 1)), Mat::diffuse(S(c.left)));   // left
    sc.add_shape(Q(V(1, 0, 0), V(0, 1, 0), V(0, 0, 1)), Mat::diffuse(S(c.right)));  // right
    // Light 0.3 x 0.3 just below the ceiling, facing down (cross(x, z) = -y).
    sc.add_quad_light(Q(V(0.35f, 0.998f, 0.35f), V(0.3f, 0, 0), V(0, 0, 0.3f)), S(c.light));
    const float m = float(margin);
    sc.add_shape(gl::BoxShape<float>(gl::Vec3f(kLo) - gl::Vec3f(m), gl::Vec3f(kHi) + gl::Vec3f(m)), Mat::index_matched(),
                 medium, -1);
}

/// The camera of Fig. 12: at (0.5, 0.5, 2.3) looking at the back wall, 38 deg, width x width pixels.
inline gl::PinholeCamera<float> camera(int width) {
    return gl::PinholeCamera<float>(gl::Vec3f(0.5f, 0.5f, 2.3f), gl::Vec3f(0.5f, 0.5f, 0.0f), gl::Vec3f(0, 1, 0), 38.0f, width,
                                    width);
}

/// Pixels whose centre ray passes through the cloud's box and does not see the light directly.
inline std::vector<char> cloud_mask(const gl::PinholeCamera<float>& camera, int width) {
    std::vector<char> mask(std::size_t(width) * std::size_t(width), 0);
    const gl::BoxShape<float> box{gl::Vec3f(kLo), gl::Vec3f(kHi)};
    const gl::QuadShape<float> light(gl::Vec3f(0.35f, 0.998f, 0.35f), gl::Vec3f(0.3f, 0, 0), gl::Vec3f(0, 0, 0.3f));
    for (int y = 0; y < width; ++y)
        for (int x = 0; x < width; ++x) {
            const auto r = camera.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
            float t;
            gl::Vec3f n;
            mask[std::size_t(y) * std::size_t(width) + std::size_t(x)] = box.intersect(r, t, n) && !light.intersect(r, t, n);
        }
    return mask;
}

/// One render split into B batches of spp / B samples with different seeds (the same total cost
/// as one render): the mean image, the per-sample variance over the masked pixels from the batch
/// scatter (measuring.md: time to unit variance), wall and CPU seconds. Each batch is split over
/// the MPI ranks by rows and gathered on every rank (guo21_mpi_render.hpp), with its checkpoint
/// "<label>.b<batch>" when the example was run with --checkpoint / --resume; `render(opt,
/// progress)` returns this rank's film. cpu_seconds is the process CPU time of the renders alone
/// (not the gathers), summed over the ranks; seconds is rank 0's wall time (gathers included).
struct Run {
    gl::Image img;
    double seconds = 0, cpu_seconds = 0;
    double var_per_sample = 0;          ///< mean over masked pixels of the per-sample variance
    double var_half_ratio = 0;          ///< variance estimate of batches 0..B/2-1 over B/2..B-1
    double mean_se = 0;                 ///< standard error of the masked mean (from the batches)
    int spp = 0;
    std::uint64_t nonfinite = 0;        ///< non-finite samples the batches' films dropped
    /// Time to unit variance: per-sample variance x CPU seconds per sample (per pixel).
    [[nodiscard]] double ttuv(std::size_t pixels) const { return var_per_sample * cpu_seconds / (double(spp) * double(pixels)); }
};

template <class Render>
Run render_batches(const gl_examples::Example& ex, int batches, const gl::RenderOptions& base, const std::vector<char>& mask,
                   const std::string& label, int rows, Render&& render, bool checkpoint = true) {
    Run r;
    gl_examples::ProgressBar bar(label, std::uint64_t(rows) * std::uint64_t(batches), !ex.root());
    std::vector<gl::Image> imgs;
    const auto t0 = std::chrono::steady_clock::now();
    guo21_mpi::RankClock clock;
    const int spp_b = std::max(1, base.spp / batches);
    for (int b = 0; b < batches; ++b) {
        gl::RenderOptions o = base;
        o.spp = spp_b;
        o.seed = base.seed * 1000003ull + std::uint64_t(b) * 7919ull + 1;
        const gl::Film film = guo21_mpi::render_film(
            ex, o, checkpoint ? label + ".b" + std::to_string(b) : std::string(), render,
            [&](int n) { bar.advance(std::uint64_t(n)); }, &clock);
        r.nonfinite += film.nonfinite_samples();
        imgs.push_back(film.image());
    }
    r.cpu_seconds = guo21_mpi::sum_over_ranks(ex.mpi(), clock.cpu);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    bar.done();
    r.spp = spp_b * batches;
    r.img = imgs[0];
    for (std::size_t i = 0; i < r.img.rgb.size(); ++i) {
        double s = 0;
        for (const auto& im : imgs) s += im.rgb[i];
        r.img.rgb[i] = float(s / batches);
    }
    // Batch variance per masked pixel (channel 0; grey renders), and of the masked mean.
    auto var_of = [&](int b0, int b1) {
        double v = 0;
        std::size_t n = 0;
        for (std::size_t px = 0; px < mask.size(); ++px) {
            if (!mask[px]) continue;
            double m = 0;
            for (int b = b0; b < b1; ++b) m += imgs[std::size_t(b)].rgb[3 * px];
            m /= (b1 - b0);
            double q = 0;
            for (int b = b0; b < b1; ++b) q += (imgs[std::size_t(b)].rgb[3 * px] - m) * (imgs[std::size_t(b)].rgb[3 * px] - m);
            v += q / (b1 - b0 - 1);
            ++n;
        }
        return n ? v / double(n) * spp_b : 0.0;
    };
    r.var_per_sample = var_of(0, batches);
    r.var_half_ratio = batches >= 4 ? var_of(0, batches / 2) / std::max(var_of(batches / 2, batches), 1e-300) : 1.0;
    std::vector<double> means;
    for (const auto& im : imgs) {
        double s = 0;
        std::size_t n = 0;
        for (std::size_t px = 0; px < mask.size(); ++px)
            if (mask[px]) s += im.rgb[3 * px], ++n;
        means.push_back(n ? s / double(n) : 0.0);
    }
    double mm = 0, vv = 0;
    for (double m : means) mm += m;
    mm /= double(batches);
    for (double m : means) vv += (m - mm) * (m - mm);
    r.mean_se = std::sqrt(vv / (batches - 1) / batches);
    return r;
}

/// render_batches of the discrete-medium VPT (integrators/discrete_vpt.hpp) of `sc` through `camera`.
template <class SceneT, class Camera>
Run render_scene_batches(const gl_examples::Example& ex, int batches, const gl::RenderOptions& base,
                         const std::vector<char>& mask, const std::string& label, int rows, const SceneT& sc,
                         const Camera& camera, bool checkpoint = true) {
    return render_batches(
        ex, batches, base, mask, label, rows,
        [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_discrete_vpt(sc, camera, o, prog); }, checkpoint);
}

/// Mean over the pixels whose centre ray passes through the cloud's box and does not see the
/// light directly (the light's own radiance would otherwise dominate the image mean).
double masked_mean(const gl::Image& img, const std::vector<char>& mask) {
    double s = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < mask.size(); ++i)
        if (mask[i]) s += img.rgb[3 * i], ++n;
    return n ? s / double(n) : 0.0;
}

/// Guo21 Fig. 20's renders in this box, shared by guo21_fig20_time_vs_n and guo21_ept_embree: clouds
/// of N ice spheres of kRadiusUm (m = 1.31) rendered by EPT of the explicit spheres (through the
/// particle grid or another sphere lookup) and by ours (the discrete medium, query radius r_c =
/// rc_over_rp r_p), each width x width in `batches` seeded batches (render_scene_batches). The
/// camera, mask, particle model and render options are the same for every N and every render.
struct Fig20Setup {
    static constexpr int batches = 8;
    const gl_examples::Example& ex;
    int width;
    double r_p, r_c;                  ///< particle and query radius [m]
    gl::PinholeCamera<float> camera;  ///< camera(width)
    std::vector<char> mask;           ///< cloud_mask
    std::size_t npix = 0;             ///< pixels in the mask
    gl::ParticleModel model;          ///< ours: the spheres' index 1.31
    gl::RenderOptions opt;            ///< spp, the example's threads and seed, VPT depth 256

    Fig20Setup(const gl_examples::Example& example, int width_px, int spp, double rc_over_rp)
        : ex(example), width(width_px), r_p(kRadiusUm * 1e-6), r_c(rc_over_rp * r_p), camera(guo21_cornell::camera(width_px)),
          mask(cloud_mask(camera, width_px)) {
        for (const char c : mask) npix += c ? 1 : 0;
        model.particle_index = {1.31, 0.0};
        opt.spp = spp;
        opt.threads = ex.threads();
        opt.seed = ex.seed();
        opt.vpt.max_depth = 256;
    }

    /// N centres in the box [kLo, kHi], seeded by the example's seed and N: hard spheres (random
    /// sequential addition) if `non_overlapping`, else Poisson centres.
    [[nodiscard]] std::shared_ptr<gl::ParticleCloud> cloud(std::uint64_t N, bool non_overlapping = true) const {
        const gl::BoxBoundary box(kLo, kHi);
        const std::vector<gl::CloudSpecies> species{gl::cloud_species(gl::MonodispersePsd(kRadiusUm))};
        const std::uint64_t cloud_seed = ex.seed() * 31 + 20 + N;
        return std::make_shared<gl::ParticleCloud>(
            non_overlapping ? gl::ParticleCloud::generate_non_overlapping(box, N, species, cloud_seed, 1e6)
                            : gl::ParticleCloud::generate(box, N, species, cloud_seed, 1e6));
    }

    /// EPT of the explicit spheres found through `lookup` (ExplicitSphereMedium<float, Lookup>).
    template <class Lookup>
    [[nodiscard]] Run ept(Lookup lookup, const std::string& label) const {
        using M = gl::ExplicitSphereMedium<float, Lookup>;
        gl::Scene<M> sc;
        build_cornell(sc, sc.add_medium(M(std::move(lookup), 1.31f)), 1.5 * r_p);
        return render_scene_batches(ex, batches, opt, mask, label, width, sc, camera);
    }

    /// EPT of the explicit spheres through the particle grid of `cloud` (undilated).
    [[nodiscard]] Run ept_grid(const gl::ParticleCloud& cloud, const std::string& label) const {
        return ept(gl::GridSphereLookup(std::make_shared<gl::ParticleGrid>(cloud, gl::ParticleGridSettings{})), label);
    }

    /// Ours: the discrete medium of `cloud` (the grid dilated by r_c), with or without diffraction,
    /// forced-collision floor `forced`; `medium_bytes` (if not null) receives the medium's memory.
    [[nodiscard]] Run ours(const gl::ParticleCloud& cloud, bool diffraction, double forced, const std::string& label,
                           std::size_t* medium_bytes = nullptr) const {
        gl::ParticleGridSettings gs;
        gs.dilation = r_c;
        gl::DiscreteMediumSettings ms;
        ms.query_radius = r_c;
        ms.diffraction = diffraction;
        ms.forced_collision = forced;
        using M = gl::DiscreteParticleMedium<float>;
        gl::Scene<M> sc;
        build_cornell(sc, sc.add_medium(M(std::make_shared<gl::ParticleGrid>(cloud, gs), {model}, ms)), 1.5 * r_p + r_c);
        if (medium_bytes) *medium_bytes = sc.medium(0).memory_bytes();
        return render_scene_batches(ex, batches, opt, mask, label, width, sc, camera);
    }
};

}  // namespace guo21_cornell
