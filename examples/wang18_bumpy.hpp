// Shared scene and measurement of the Wang18 bumpy-sphere examples (wang18_fig12_components and
// the sweeps wang18_fig14_mse_vs_g, wang18_fig22_cost_vs_g, wang18_fig23_surface_samples,
// wang18_fig24_epsilon):
//  - the scene: a bumpy sphere (geometry/surface_sampling.hpp make_bumpy_sphere: a radially
//    displaced icosphere, the stand-in for the paper's "Bumpy sphere" mesh) as the refractive
//    boundary (eta 1.33, geometry/closed_mesh.hpp ClosedMeshShape) filled with the paper's
//    "Bumpy sphere" material (Table 2: albedo {0.9545, 0.6774, 0.4565}, mean free path ratios
//    {4.5455, 3.2258, 2.1739}), scaled so the radius is `R_opt` green mean free paths, under a
//    quad light;
//  - the point-based render (integrators/point_based.hpp over the mesh, Poisson-disk surface
//    samples), per component;
//  - the reference: the library's VPT (walk kernel) through the same mesh, one grey walk per
//    colour channel, no path-length cap (Russian roulette only), kBatches batches, split by the
//    number of scattering events and by boundary reflections between events (the bounced
//    term's path space), as in wang18_point_based;
//  - the comparison as in ../shared/reference/measuring.md: bias with its standard error from
//    the batches, per-component error e^2 = MSE - the reference's variance of the mean, and the
//    equal-error speed-up (reference time to reach e^2 over the point-based time, CPU seconds).
#pragma once

#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "grainlight/geometry/closed_mesh.hpp"
#include "grainlight/geometry/surface_sampling.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace wang18 {

namespace gl = grainlight;

using Phase = gl::HenyeyGreenstein<float, gl::RGB>;
using Medium = gl::ContinuousMedium<Phase, gl::RGB>;
using MeshRenderer = gl::PointBasedRenderer<Phase, gl::ClosedMeshShape<float>>;
using Grey = gl::Spectrum<1, float>;
using PhaseG = gl::HenyeyGreenstein<float, Grey>;
using MediumG = gl::ContinuousMedium<PhaseG, Grey>;
using SceneG = gl::Scene<MediumG>;

constexpr int kComp = 5;  // single, double, multiple, bounced, total
inline const char* const kCompName[kComp] = {"single", "double", "multiple", "bounced", "total"};
constexpr int kBatches = 8;

/// The sweeps' shared argument checks (cli_error naming the option, the value and the range).
inline void check_render_args(int rays, int width, double radius_mfp) {
    using gl_examples::cli_error;
    if (rays < 1 || rays > 1024) throw cli_error("--rays = " + std::to_string(rays) + " must be in [1, 1024]");
    if (width < 4 || width > 2048) throw cli_error("--width = " + std::to_string(width) + " must be in [4, 2048]");
    if (!(radius_mfp > 0.5 && radius_mfp <= 200))
        throw cli_error("--radius-mfp = " + std::to_string(radius_mfp) + " must be in (0.5, 200]");
}
/// --vpt-spp: >= 16 and a multiple of the batch count.
inline void check_vpt_spp(int vpt_spp) {
    if (vpt_spp < 16 || vpt_spp % kBatches != 0)
        throw gl_examples::cli_error("--vpt-spp = " + std::to_string(vpt_spp) + " must be >= 16 and a multiple of " +
                                     std::to_string(kBatches));
}
/// --surface-samples in [16, 1e7].
inline void check_surface_samples(int n) {
    if (n < 16 || n > 10000000)
        throw gl_examples::cli_error("--surface-samples = " + std::to_string(n) + " must be in [16, 1e7]");
}

/// Process CPU seconds (all threads).
inline double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// The render driver for the Wang18 examples' camera-ray and reference renders (the generic gather
/// of the point-based renders): rows of a W x H image into `films` films (at most 16) through
/// grainlight::render_rows, so a render takes the harness's --checkpoint SECONDS / --resume
/// (checkpoint file `stem` in --out; a killed and resumed render is byte-identical, since every
/// pixel's samples are keyed by (seed, pixel, sample)) and splits its rows over the MPI ranks
/// (rank r renders the rows y with y % ranks == r); every film is then gathered on rank 0 in a
/// fixed order (a placement of rows, not a sum). `row(y, films)` renders row y into every film
/// and must touch only row y. Rank 0 gets the complete films; the other ranks get black films of
/// the same size (their results are not used). `spp` only fingerprints the checkpoint.
template <class RowFn>
[[nodiscard]] std::vector<gl::Film> render_rows(const gl_examples::Example& ex, const std::string& label,
                                                const std::string& stem, int W, int H, int films, int spp, RowFn&& row) {
    const gl::RenderOptions o = gl_examples::render_options(ex, spp, stem);
    auto bar = ex.progress(label, std::uint64_t(H));
    std::vector<gl::Film> local = gl::render_rows(
        W, H, films, o, [&](int y, std::span<gl::Film> f) { row(y, f); },
        [&](int n) { bar.advance(std::uint64_t(n)); });
    bar.done();
    std::vector<gl::Film> out;
    for (const gl::Film& f : local) {
        gl::Film g = ex.mpi().gather_film_rows(f);
        out.push_back(ex.root() ? std::move(g) : gl::Film(W, H));
    }
    return out;
}

/// Sum of `x` over the MPI ranks, on rank 0 (CPU seconds of a split render); `x` elsewhere.
[[nodiscard]] inline double sum_over_ranks(const gl_examples::Example& ex, double x) {
    return ex.mpi().sum_to_root({x})[0];
}

/// Rows of each rank for the JSON summaries ("rank_rows", "rank_row_counts").
inline void put_rank_rows(const gl_examples::Example& ex, gl_examples::Json& j, int H) {
    const std::vector<double> rows = ex.mpi().row_counts(H);
    j.str("rank_rows", "rank r renders the rows y with y % ranks == r of every camera-ray and reference render; "
                       "the light samples are built on every rank (deterministic)")
        .nums("rank_row_counts", rows);
}

/// The bumpy-sphere scene.
struct BumpyScene {
    float R_opt = 20, g = 0.7f, eta = 1.33f, Le = 4.0f;
    gl::RGB albedo{0.9545f, 0.6774f, 0.4565f};
    gl::RGB sigma_t{1.0f};
    gl::TriangleMesh<float> mesh;
    gl::ClosedMeshShape<float> shape;
    gl::QuadShape<float> quad{gl::Vec3f(-2.0f, 2.5f, -2.5f), gl::Vec3f(4, 0, 0), gl::Vec3f(0, 0, 4)};
    gl::PinholeCamera<float> camera{gl::Vec3f(0.0f, 0.3f, 4.2f), gl::Vec3f(0.0f), gl::Vec3f(0, 1, 0), 32.0f, 16, 16};
    int W = 16, H = 16;
    [[nodiscard]] Medium medium() const { return Medium(sigma_t, albedo, Phase(g)); }
};

/// Bumpy sphere of unit radius (icosphere `level`, bumps of relative height `bumps` and
/// frequency 5), R_opt green mean free paths, HG g, a W x W image. With a non-empty `obj`, that
/// Wavefront OBJ mesh instead (must be closed; centred on its bounding-box centre and scaled to a
/// bounding radius of 1, so R_opt is its bounding radius in green mean free paths).
inline BumpyScene make_bumpy_scene(int W, float R_opt, float g, int level = 4, double bumps = 0.06,
                                   const std::string& obj = "") {
    BumpyScene s;
    s.R_opt = R_opt;
    s.g = g;
    const float lr[3] = {4.5455f, 3.2258f, 2.1739f};
    const float sc = R_opt * lr[1];
    s.sigma_t = gl::RGB{sc / lr[0], sc / lr[1], sc / lr[2]};
    if (obj.empty()) {
        s.mesh = gl::make_bumpy_sphere<float>(level, 1.0, bumps, 5.0);
    } else {
        s.mesh = gl::load_obj<float>(obj);
        const gl::Vec3f c = s.mesh.bounds().center();
        float r = 0;
        for (const auto& v : s.mesh.vertices) r = std::max(r, glm::length(v - c));
        gl::check_argument(r > 0, "make_bumpy_scene", "obj bounding radius", r, "> 0");
        for (auto& v : s.mesh.vertices) v = (v - c) / r;
        s.mesh.compute_face_normals();
    }
    s.shape = gl::ClosedMeshShape<float>(s.mesh);
    s.W = s.H = W;
    s.camera = gl::PinholeCamera<float>(gl::Vec3f(0.0f, 0.3f, 4.2f), gl::Vec3f(0.0f), gl::Vec3f(0, 1, 0), 32.0f, W, W);
    return s;
}

/// Point-based options of the bumpy-sphere examples (thick medium: no internal-reflection
/// following on light and camera rays, as wang18_point_based's thick case).
inline gl::PointBasedOptions<float> default_options(const BumpyScene& sc, bool full) {
    gl::PointBasedOptions<float> po;
    po.light_samples = 2;
    po.volume_step = 0.2f / sc.sigma_t.average();
    po.k_max = full ? 16 : 6;
    po.camera_bounces = 0;
    po.light_bounces = 0;
    po.max_optical_depth = 8.0f;
    po.cut.eps1 = full ? 0.2f : 1.0f;
    po.cut.eps2 = 0.2f * po.cut.eps1;
    po.two_step_depth = 3;
    po.bounce_samples = full ? 4096 : 512;
    po.bounce_rays = full ? 8 : 4;
    po.bounce_k_max = full ? 6 : 3;
    return po;
}

/// The multiple-scattering table of the material with HG g (Eq. 7), built once and cached in
/// `dir` keyed by its parameters (written only with `write`: rank 0). `cpu` receives the build
/// (or load) CPU seconds.
inline gl::MsTable<3> cached_table(const std::filesystem::path& dir, const BumpyScene& sc, bool full, std::uint64_t seed,
                                   double& cpu, bool& cached, bool write = true, double range = 10.0) {
    gl::MsTableOptions to;
    to.n_rho = full ? 96 : 48;
    to.n_z = full ? 192 : 96;
    to.n_theta = full ? 18 : 12;
    to.n_phi = full ? 9 : 6;
    // The extent in mean free paths (default 10) at the same cell size.
    const double scale = range / 10.0;
    to.n_rho = int(std::lround(double(to.n_rho) * scale));
    to.n_z = int(std::lround(double(to.n_z) * scale));
    to.rho_max = range;
    to.z_min = -range;
    to.z_max = range;
    to.photons = full ? 2000000 : 200000;
    to.seed = seed;
    char gbuf[32];
    std::snprintf(gbuf, sizeof gbuf, "%.3f", double(sc.g));
    const auto path = dir / ("wang18_ms_table_g" + std::string(gbuf) + "_bmps_" + std::to_string(to.n_rho) + "x" +
                             std::to_string(to.n_z) + "x" + std::to_string(to.n_theta) + "x" + std::to_string(to.n_phi) +
                             "_" + std::to_string(to.photons) + "_s" + std::to_string(seed) + "_v" +
                             std::to_string(gl::ms_table_estimator_version) +
                             (range == 10.0 ? std::string() : "_r" + std::to_string(range)) + ".bin");
    const double c0 = cpu_seconds();
    gl::MsTable<3> table;
    cached = false;
    if (std::filesystem::exists(path)) {
        try {
            table = gl::MsTable<3>::load(path);
            cached = true;
        } catch (const std::exception&) {
            cached = false;
        }
    }
    if (!cached) {
        table = gl::MsTable<3>::build(Phase(sc.g), sc.albedo, to);
        if (write) table.save(path);
    }
    cpu = cpu_seconds() - c0;
    return table;
}

/// Mean of an RGB image over pixels and channels.
inline double image_mean(const gl::Image& a) { return (a.mean(0) + a.mean(1) + a.mean(2)) / 3.0; }

/// A point-based render: one image per component, CPU times, sample counts.
struct PbRun {
    std::vector<gl::Image> img;
    double cpu_samples = 0, cpu_render = 0;
    std::size_t volume_samples = 0, bytes = 0;
    double poisson_radius = 0;
    int surface_samples = 0;
    [[nodiscard]] double cpu_total() const { return cpu_samples + cpu_render; }
};

/// Build the light samples (Poisson-disk surface samples on the mesh, `n_surface` of them, and
/// `po.bounce_samples` bounce samples) and render every pixel with `rays` camera rays; with
/// `compressed`, the camera rays read the table from its quadtree (the bounce samples are built
/// from the dense one).
inline PbRun render_pb(const gl_examples::Example& ex, const BumpyScene& sc, const gl::MsTable<3>* table,
                       const gl::PointBasedOptions<float>& po, int n_surface, std::uint64_t seed,
                       const std::string& label, int rays = 1, const gl::MsTableQuadtree<3>* compressed = nullptr) {
    PbRun r;
    r.img.assign(kComp, gl::Image(sc.W, sc.H));
    double c0 = cpu_seconds();
    gl::Rng lrng = gl::Rng::from_key(seed, 0x5742u);
    const auto surf = gl::mesh_surface_samples(sc.shape, n_surface, seed, &r.poisson_radius);
    r.surface_samples = int(surf.size());
    const auto bounce = po.bounce_samples > 0 ? gl::mesh_surface_samples(sc.shape, po.bounce_samples, seed + 17)
                                              : std::vector<gl::SurfaceSample<float>>{};
    MeshRenderer pb(sc.medium(), sc.eta, sc.shape, surf, gl::Light<float, gl::RGB>::quad_light(sc.quad, gl::RGB(sc.Le)), po,
                    lrng, table, bounce);
    if (compressed) pb.use_compressed_table(compressed);
    r.cpu_samples = cpu_seconds() - c0;
    r.volume_samples = pb.volume_sample_count();
    r.bytes = pb.bytes();
    c0 = cpu_seconds();
    const std::vector<gl::Film> f = render_rows(
        ex, label, label, sc.W, sc.H, kComp, rays, [&](int y, std::span<gl::Film> film) {
            for (int x = 0; x < sc.W; ++x) {
                gl::PointBasedComponents<gl::RGB> acc;
                for (int k = 0; k < rays; ++k) {
                    gl::Rng rng = gl::Rng::from_key(seed, std::uint64_t(y) * std::uint64_t(sc.W) + std::uint64_t(x),
                                                    0x10000u + std::uint64_t(k));
                    const gl::Vec2f u = rng.uniform2<float>();
                    const auto c = pb.radiance_components(sc.camera.generate_ray(float(x) + u.x, float(y) + u.y), rng);
                    acc.single += c.single;
                    acc.double_ += c.double_;
                    acc.multiple += c.multiple;
                    acc.bounced += c.bounced;
                }
                const float inv = 1.0f / float(rays);
                float v[kComp][3];
                for (int ch = 0; ch < 3; ++ch) {
                    const float a[4] = {acc.single[ch], acc.double_[ch], acc.multiple[ch], acc.bounced[ch]};
                    for (int k = 0; k < 4; ++k) v[k][ch] = a[k] * inv;
                    v[4][ch] = (a[0] + a[1] + a[2] + a[3]) * inv;
                }
                for (int k = 0; k < kComp; ++k) film[std::size_t(k)].add_rgb(x, y, v[k][0], v[k][1], v[k][2]);
            }
        });
    for (int k = 0; k < kComp; ++k) r.img[std::size_t(k)] = f[std::size_t(k)].image();
    r.cpu_render = sum_over_ranks(ex, cpu_seconds() - c0);
    return r;
}

/// Average of independent point-based runs (different light-sample seeds): images averaged, CPU
/// times and memory summed; `build_se[k]` receives the standard error of component k's image mean
/// over the runs (the point-based estimate's own noise; 0 for one run).
inline PbRun average_runs(const std::vector<PbRun>& runs, std::array<double, kComp>& build_se) {
    PbRun a = runs.front();
    build_se.fill(0.0);
    const double n = double(runs.size());
    for (int k = 0; k < kComp; ++k) {
        std::vector<double> m;
        for (const auto& r : runs) m.push_back(image_mean(r.img[std::size_t(k)]));
        double mu = 0, v = 0;
        for (double x : m) mu += x / n;
        for (double x : m) v += runs.size() > 1 ? (x - mu) * (x - mu) / (n - 1) : 0.0;
        build_se[std::size_t(k)] = std::sqrt(v / n);
        for (int y = 0; y < a.img[0].height; ++y)
            for (int x = 0; x < a.img[0].width; ++x)
                for (int ch = 0; ch < 3; ++ch) {
                    double s = 0;
                    for (const auto& r : runs) s += r.img[std::size_t(k)].at(x, y, ch);
                    a.img[std::size_t(k)].at(x, y, ch) = float(s / n);
                }
    }
    a.cpu_samples = a.cpu_render = 0;
    a.bytes = 0;
    for (const auto& r : runs) {
        a.cpu_samples += r.cpu_samples;
        a.cpu_render += r.cpu_render;
        a.bytes = std::max(a.bytes, r.bytes);
    }
    return a;
}

/// VPT callbacks: scattered light by number of scattering events; paths with a boundary
/// reflection between two scattering events go to `bounced`.
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
        L[std::size_t(bounced_between ? 3 : std::min(count, 3) - 1)] += c;
        return true;
    }
};

/// Index of film f, batch b, pixel p, channel ch in batch sums laid out as
/// bs[((f * kBatches + b) * npx + p) * 3 + ch].
[[nodiscard]] inline std::size_t batch_index(int f, int b, std::size_t npx, std::size_t p, int ch) {
    return ((std::size_t(f) * kBatches + std::size_t(b)) * npx + p) * 3 + std::size_t(ch);
}

/// The VPT reference: batch sums of component k (layout of batch_index).
struct VptRun {
    std::vector<double> bs;
    std::vector<gl::Image> img;  ///< mean image per component
    double cpu = 0;
    int spp = 0, W = 0, H = 0;
    [[nodiscard]] std::size_t idx(int k, int b, std::size_t p, int ch) const {
        return batch_index(k, b, std::size_t(W) * std::size_t(H), p, ch);
    }
};

/// A reference in kBatches batches: batch b = samples s with s % kBatches == b, each batch one
/// render_rows pass (progress label "<label> batch b+1/kBatches", checkpoint stem "<stem> batch
/// b") of `Films` films. `sample(x, y, p, s, L)` writes sample s of pixel p (p = y W + x) into
/// L[Films][3] (zeroed). The batch sums go to `bs` (sized by the caller, layout of
/// batch_index); per pixel, batch and channel they add the samples in increasing s.
template <int Films, class SampleFn>
inline void batched_films(const gl_examples::Example& ex, const std::string& label, const std::string& stem, int W,
                          int H, int spp, std::vector<double>& bs, SampleFn&& sample) {
    const std::size_t npx = std::size_t(W) * std::size_t(H);
    for (int b = 0; b < kBatches; ++b) {
        const std::vector<gl::Film> f = render_rows(
            ex, label + " batch " + std::to_string(b + 1) + "/" + std::to_string(kBatches),
            stem + " batch " + std::to_string(b), W, H, Films, spp, [&](int y, std::span<gl::Film> film) {
                for (int x = 0; x < W; ++x) {
                    const std::size_t p = std::size_t(y) * std::size_t(W) + std::size_t(x);
                    for (int s = b; s < spp; s += kBatches) {
                        double L[Films][3] = {};
                        sample(x, y, p, s, L);
                        for (int k = 0; k < Films; ++k) film[std::size_t(k)].add_rgb(x, y, L[k][0], L[k][1], L[k][2]);
                    }
                }
            });
        for (int k = 0; k < Films; ++k) {
            const auto sums = f[std::size_t(k)].sums();
            for (std::size_t p = 0; p < npx; ++p)
                for (int ch = 0; ch < 3; ++ch) bs[batch_index(k, b, npx, p, ch)] = sums[3 * p + std::size_t(ch)];
        }
    }
}

/// Image mean (over pixels and channels) of the films `films` (summed) of a batched reference with `spp` samples per
/// pixel, and its standard error from the spread of the kBatches batch means.
struct BatchMean {
    double mean = 0, se = 0;
};
[[nodiscard]] inline BatchMean batch_mean(const std::vector<double>& bs, std::initializer_list<int> films, std::size_t npx,
                                          int spp) {
    const double per_batch = double(spp) / kBatches;
    double bm[kBatches]{};
    for (int b = 0; b < kBatches; ++b) {
        double s = 0;
        for (const int f : films)
            for (std::size_t i = 0; i < npx * 3; ++i) s += bs[batch_index(f, b, npx, 0, 0) + i];
        bm[b] = s / (per_batch * double(npx * 3));
    }
    BatchMean r;
    double var = 0;
    for (double x : bm) r.mean += x / kBatches;
    for (double x : bm) var += (x - r.mean) * (x - r.mean) / (kBatches - 1);
    r.se = std::sqrt(var / kBatches);
    return r;
}
/// The same for one film.
[[nodiscard]] inline BatchMean batch_mean(const std::vector<double>& bs, int f, std::size_t npx, int spp) {
    return batch_mean(bs, {f}, npx, spp);
}

/// Sample s of pixel p = (x, y) in channel ch of a per-channel grey reference: the random stream
/// keyed (seed, p, 3 s + ch) and the camera ray through the pixel jittered from it. Every VPT
/// reference of the Wang18 examples walks from here, so one key gives the same paths in all.
struct ChannelSample {
    gl::Rng rng;
    gl::Ray<float> ray;
};
template <class Camera>
[[nodiscard]] inline ChannelSample channel_sample(const Camera& camera, int x, int y, std::uint64_t seed, std::size_t p,
                                                  int s, int ch) {
    ChannelSample c{gl::Rng::from_key(seed, p, std::uint64_t(s) * 3 + std::uint64_t(ch)), {}};
    const gl::Vec2f u = c.rng.uniform2<float>();
    c.ray = camera.generate_ray(float(x) + u.x, float(y) + u.y);
    return c;
}

/// The reference's walks (one grey walk per channel, `scenes[ch]`, components split by SplitVpt)
/// through batched_films (stem = label); v.W, v.H, v.spp and v.bs sized by the caller.
template <class Camera>
inline void vpt_batches(const gl_examples::Example& ex, const std::string& label, int W, int H, int spp,
                        std::uint64_t seed, const std::vector<SceneG>& scenes, const Camera& camera,
                        const gl::WalkOptions<float>& wo, VptRun& v) {
    batched_films<kComp>(ex, label, label, W, H, spp, v.bs, [&](int x, int y, std::size_t p, int s, double (&L)[kComp][3]) {
        for (int ch = 0; ch < 3; ++ch) {
            ChannelSample cs = channel_sample(camera, x, y, seed, p, s, ch);
            SplitVpt cb{scenes[std::size_t(ch)]};
            auto st = gl::start_path<float, Grey>(cs.ray, -1);
            (void)gl::walk(scenes[std::size_t(ch)], st, cs.rng, cb, wo);
            double tot = 0;
            for (int k = 0; k < 4; ++k) {
                L[k][ch] = cb.L[std::size_t(k)];
                tot += cb.L[std::size_t(k)];
            }
            L[4][ch] = tot;
        }
    });
}

/// Render the reference with `spp` samples per pixel and channel (a multiple of kBatches).
inline VptRun render_vpt(const gl_examples::Example& ex, const BumpyScene& sc, int spp, std::uint64_t seed,
                         const std::string& label) {
    VptRun v;
    v.spp = spp;
    v.W = sc.W;
    v.H = sc.H;
    std::vector<SceneG> scenes;
    const gl::MeshShape<float> mshape(sc.mesh);
    for (int ch = 0; ch < 3; ++ch) {
        SceneG s;
        const int m = s.add_medium(MediumG(Grey(sc.sigma_t[ch]), Grey(sc.albedo[ch]), PhaseG(sc.g)));
        s.add_shape(mshape, gl::Material<float, Grey>::dielectric(sc.eta), m, -1);
        s.add_quad_light(sc.quad, Grey(sc.Le));
        scenes.push_back(std::move(s));
    }
    const std::size_t npx = std::size_t(sc.W) * std::size_t(sc.H);
    v.bs.assign(std::size_t(kComp) * kBatches * npx * 3, 0.0);
    const double c0 = cpu_seconds();
    vpt_batches(ex, label, sc.W, sc.H, spp, seed, scenes, sc.camera, gl::WalkOptions<float>{}, v);
    v.cpu = sum_over_ranks(ex, cpu_seconds() - c0);
    v.img.assign(kComp, gl::Image(sc.W, sc.H));
    for (int k = 0; k < kComp; ++k)
        for (std::size_t p = 0; p < npx; ++p)
            for (int ch = 0; ch < 3; ++ch) {
                double s = 0;
                for (int b = 0; b < kBatches; ++b) s += v.bs[v.idx(k, b, p, ch)];
                v.img[std::size_t(k)].at(int(p % std::size_t(sc.W)), int(p / std::size_t(sc.W)), ch) = float(s / double(spp));
            }
    return v;
}

/// Point-based vs reference, per component (measuring.md).
struct Comparison {
    double pb[kComp]{}, ref[kComp]{}, ref_se[kComp]{}, rel[kComp]{}, rel_se[kComp]{};
    double mse[kComp]{};   ///< per-pixel MSE against the reference mean image
    double e2[kComp]{};    ///< MSE minus the reference's variance of the mean (>= 1e-3 MSE)
    double ref_var_mean[kComp]{};  ///< reference variance of the mean, averaged over pixels
    double ref_var_per_sample = 0, var_half_ratio = 0, speedup = 0, bounced_share = 0;
};

/// Compare a point-based run with the reference; the equal-error speed-up is on the total.
inline Comparison compare(const PbRun& pb, const VptRun& v) {
    Comparison c;
    const std::size_t npx = std::size_t(v.W) * std::size_t(v.H);
    const double per_batch = double(v.spp) / kBatches;
    for (int k = 0; k < kComp; ++k) {
        const BatchMean bmean = batch_mean(v.bs, k, npx, v.spp);
        const double m = bmean.mean;
        c.ref[k] = m;
        c.ref_se[k] = bmean.se;
        c.pb[k] = image_mean(pb.img[std::size_t(k)]);
        c.rel[k] = m > 0 ? (c.pb[k] - m) / m : 0.0;
        c.rel_se[k] = m > 0 ? c.ref_se[k] / m : 0.0;
        double mse = 0, vm = 0, vps[2] = {0, 0};
        for (std::size_t p = 0; p < npx; ++p)
            for (int ch = 0; ch < 3; ++ch) {
                double b8[kBatches], mean = 0;
                for (int b = 0; b < kBatches; ++b) {
                    b8[b] = v.bs[v.idx(k, b, p, ch)] / per_batch;
                    mean += b8[b] / kBatches;
                }
                double vv = 0;
                for (int b = 0; b < kBatches; ++b) vv += (b8[b] - mean) * (b8[b] - mean) / (kBatches - 1);
                for (int h = 0; h < 2; ++h) {
                    double mh = 0, vh = 0;
                    for (int b = h * kBatches / 2; b < (h + 1) * kBatches / 2; ++b) mh += b8[b] / (kBatches / 2);
                    for (int b = h * kBatches / 2; b < (h + 1) * kBatches / 2; ++b)
                        vh += (b8[b] - mh) * (b8[b] - mh) / (kBatches / 2 - 1);
                    vps[h] += vh * per_batch;
                }
                const double d = double(pb.img[std::size_t(k)].at(int(p % std::size_t(v.W)), int(p / std::size_t(v.W)), ch)) - mean;
                mse += d * d;
                vm += vv / kBatches;
            }
        const double n3 = double(npx * 3);
        c.mse[k] = mse / n3;
        c.ref_var_mean[k] = vm / n3;
        c.e2[k] = std::max(c.mse[k] - c.ref_var_mean[k], 1e-3 * c.mse[k]);
        if (k == 4) {
            c.ref_var_per_sample = c.ref_var_mean[k] * double(v.spp);
            c.var_half_ratio = vps[1] > 0 ? vps[0] / vps[1] : 0.0;
        }
    }
    c.bounced_share = c.ref[4] > 0 ? c.ref[3] / c.ref[4] : 0.0;
    // Reference time to the point-based error e^2 of the total: (per-sample variance / e^2)
    // samples per pixel at the measured CPU seconds per pixel sample (three channel walks).
    const double t_ref = c.ref_var_per_sample / c.e2[4] * (v.cpu / double(v.spp));
    c.speedup = pb.cpu_total() > 0 ? t_ref / pb.cpu_total() : 0.0;
    return c;
}

/// Write `img` as EXR and PNG (exposure `exposure`) into --out, on rank 0 only.
inline void save_image(const gl_examples::Example& ex, const std::string& name, const gl::Image& img, double exposure) {
    if (!ex.root()) return;
    gl::write_exr(ex.out() / (name + ".exr"), img);
    gl::write_png(ex.out() / (name + ".png"), img, {exposure});
}

/// Write `img` as EXR and PNG (exposure `exposure`) into `dir`.
inline void save_image(const std::filesystem::path& dir, const std::string& name, const gl::Image& img, double exposure) {
    gl::write_exr(dir / (name + ".exr"), img);
    gl::write_png(dir / (name + ".png"), img, {exposure});
}

}  // namespace wang18
