// wang18_table3_materials: Wang & Holzschuch 2018 (TVCG), Table 3 at the paper's optical scale.
// Table 2's materials Oil, Wax, Milk and BmpS. (sigma_s, sigma_a via albedo and mean free path
// per RGB channel, HG g; the paper's values) each fill a smooth glass sphere (eta 1.33; no mesh
// boundary exists in the library yet, so the paper's bumpy sphere is a smooth sphere here) of
// radius 20 green mean free paths under a quad light. Per material:
//   - point-based (integrators/point_based.hpp, Eqs. 5-9): light samples built once, then
//     `--pb-spp` stratified camera rays per pixel that all reuse them; time, memory (table +
//     samples), and its own per-pixel noise from two independent halves of its rays;
//   - the reference: the library's VPT, one grey walk per colour channel, no path-length cap
//     (Russian roulette only), 8 batches; time per sample and per-pixel variance per sample;
//   - the equal-error speed-up of ../shared/reference/measuring.md: e^2 = MSE(point-based,
//     reference mean) - the reference's variance of the mean (from its batches), with its
//     standard error over pixels; the VPT's time to e^2 = variance per sample / e^2 x CPU seconds
//     per sample; speed-up = that / point-based CPU seconds (samples + render), in one run;
//   - the bias of the image mean with the reference's standard error;
//   - beside it: Table 3's time ratio of UPBP to the paper's offline method, its MSE, and
//     Table 2's table memory.
// The multiple-scattering table of each material is built once and cached in --out under a name
// made of its parameters. By default the multiple term adds the diffusion far field
// (PointBasedOptions::ms_far_field, our addition: the table's own near field, diffusion beyond
// it and the bounded medium's correction; `--ms-far-field none` is the paper's Eq. 7 alone).
//
//   wang18_table3_materials [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                           [--materials oil,wax,milk,bmps] [--pb-spp N] [--vpt-spp N] ...
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <span>
#include <sstream>
#include <string>
#include <optional>
#include <vector>

#include "common/harness.hpp"
#include "wang18_bumpy.hpp"
#include "grainlight/integrators/ms_table_quadtree.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/core/serialization.hpp"
#include "grainlight/precompute/ms_table.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl = grainlight;

namespace {

using Phase = gl::HenyeyGreenstein<float, gl::RGB>;
using Medium = gl::ContinuousMedium<Phase, gl::RGB>;
using Renderer = gl::PointBasedRenderer<Phase, gl::SphereShape<float>>;
using Grey = gl::Spectrum<1, float>;
using PhaseG = gl::HenyeyGreenstein<float, Grey>;
using MediumG = gl::ContinuousMedium<PhaseG, Grey>;
using SceneG = gl::Scene<MediumG>;
constexpr int kBatches = 8;

double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Table 2 (albedo, mean free path in mm, g, compressed table memory, precompute time) and
/// Table 3 (UPBP render time, offline pre-processing + render time, MSE) of Wang18.
struct Material {
    const char* key;
    const char* name;
    gl::RGB albedo;
    float mfp[3];
    float g;
    double paper_table_mb, paper_precompute_s;
    double paper_upbp_s, paper_pre_s, paper_render_s, paper_mse;
    [[nodiscard]] double paper_ratio() const { return paper_upbp_s / (paper_pre_s + paper_render_s); }
};

const Material kMaterials[] = {
    {"oil", "Oil", {0.0042f, 0.4535f, 0.0995f}, {9.7087f, 11.6279f, 2.7397f}, 0.9f, 52.4, 14, 6 * 3600.0, 33, 34 * 60.0, 1.1e-3},
    {"wax", "Wax", {0.9803f, 0.9615f, 0.7500f}, {0.6536f, 0.6250f, 0.5882f}, 0.8f, 63.8, 172, 3 * 3600.0, 6, 1.1 * 60, 2.9e-4},
    {"milk", "Milk", {0.9999f, 0.9997f, 0.9991f}, {0.8422f, 0.7521f, 0.6848f}, 0.7f, 67.9, 212, 6 * 3600.0, 17, 20.7 * 60, 1.3e-3},
    {"bmps", "BmpS.", {0.9545f, 0.6774f, 0.4565f}, {4.5455f, 3.2258f, 2.1739f}, 0.7f, 71.9, 101, 6 * 3600.0, 11, 0.97 * 60, 3.2e-4},
};

// VPT callback: all scattered light (>= 1 event) that reaches the light.
struct ScatteredOnly {
    const SceneG& scene;
    int count = 0;
    float L = 0;
    bool on_scatter(gl::PathState<float, Grey>&, const gl::Interaction<float, Grey>&, const MediumG&) noexcept {
        ++count;
        return true;
    }
    bool on_surface(gl::PathState<float, Grey>& st, const gl::SurfaceHit<float, Grey>& hit) noexcept {
        if (hit.light >= 0 && count > 0) L += (st.throughput * scene.emitted(hit, st.ray.d))[0];
        return true;
    }
};

struct Settings {
    int W = 32, pb_spp = 4, vpt_spp = 64, surface = 12000, bounce = 512, k_max = 1;
    int max_cells = 128;  ///< cap on the table's radial cells (axial: twice)
    float table_range = 10;  ///< table extent in mean free paths (0: automatic)
    bool ms_image = false;   ///< boundary image of the multiple term (PointBasedOptions::ms_boundary_image)
    float ms_image_offset = 0;  ///< its offset in transport mean free paths
    gl::MsFarField far_field = gl::MsFarField::diffusion;  ///< PointBasedOptions::ms_far_field
    float diffusion_cell = 2.0f;  ///< its grid cell in mean free paths
    std::string bounced = "auto";  ///< Eq. 8: on, off, auto (on)
    float ms_eps1 = 0;  ///< PointBasedOptions::ms_cut_eps1
    float bounce_cut = 4;  ///< PointBasedOptions::bounce_cut_scale
    int light_samples = 2;  ///< points on the quad light per light surface sample
    int vpt_max_depth = 0;   ///< VPT path cap in events (0: none; the paper's UPBP: 50)
    gl::DepthSampling depth_sampling = gl::DepthSampling::min_extinction;  ///< camera samples of Eq. 10
    std::string table_read = "dense";  ///< the table the renderer reads: dense, merged (5 %), noise
    float eps1 = 1.0f, R_opt = 20.0f;
    gl::MsTableOptions table;
};

/// Merge tolerance of the reported merged quadtree (relative power-weighted L1 error of the table).
constexpr double kTableMerge = 0.05;

struct Result {
    double seconds_table = 0, seconds_samples = 0, seconds_pb = 0, seconds_vpt = 0;
    double table_mb = 0, samples_mb = 0, table_qt_mb = 0, table_qt_lossy_mb = 0, table_qt_merged_mb = 0;
    double table_qt_noise_mb = 0;
    std::size_t table_qt_noise_lobes = 0;
    double pb_mean = 0, ref_mean = 0, ref_se = 0, rel = 0, rel_se = 0;
    double mse = 0, ref_var_mean = 0, e2 = 0, e2_se = 0, pb_noise = 0, var_ps = 0, half_ratio = 0;
    std::array<double, 4> pb_noise_comp{};  ///< the point-based noise of single, double, multiple, bounced
    double speedup = 0, events_per_path = 0;
    bool table_cached = false;
    std::size_t volume_samples = 0;
};

std::string table_key(const Material& m, const gl::MsTableOptions& to) {
    std::ostringstream os;
    os << "wang18_ms_table_" << m.key << "_g" << m.g << "_" << to.n_rho << "x" << to.n_z << "x" << to.n_theta << "x"
       << to.n_phi  << "_r" << to.rho_max << "_e" << to.escape_radius << "_" << to.photons << "_s" << to.seed << "_v"
       << gl::ms_table_estimator_version << ".bin";
    return os.str();
}

constexpr std::uint32_t kCellNoiseKind = gl::fourcc("MSNZ");

void save_cell_noise(const std::filesystem::path& path, const std::vector<double>& v) {
    gl::ByteWriter w;
    w.put(std::uint64_t(v.size()));
    w.put_array(v.data(), v.size());
    gl::write_container_atomic(path, kCellNoiseKind, 1, w.bytes());
}

std::vector<double> load_cell_noise(const std::filesystem::path& path, std::size_t expect) {
    const auto payload = gl::read_container(path, kCellNoiseKind, 1);
    gl::ByteReader r(payload, "cell noise '" + path.string() + "'");
    const auto n = r.get<std::uint64_t>();
    if (n != expect) r.fail("holds " + std::to_string(n) + " values, expected " + std::to_string(expect));
    std::vector<double> v;
    r.get_array(v, n);
    r.expect_end();
    return v;
}

Result run_material(const gl_examples::Example& ex, const Material& mat, const Settings& st, std::uint64_t seed,
                    const std::filesystem::path& out) {
    Result r;
    const int W = st.W, H = st.W;
    const float sc = st.R_opt * mat.mfp[1];  // sigma_t = R_opt * l_green / l_c on a unit sphere
    const gl::RGB sigma_t{sc / mat.mfp[0], sc / mat.mfp[1], sc / mat.mfp[2]};
    const float eta = 1.33f;
    const Medium medium(sigma_t, mat.albedo, Phase(mat.g));
    const gl::SphereShape<float> sphere(gl::Vec3f(0.0f), 1.0f);
    const gl::QuadShape<float> quad(gl::Vec3f(-2.0f, 2.5f, -2.5f), gl::Vec3f(4, 0, 0), gl::Vec3f(0, 0, 4));
    const float Le = 4.0f;
    const gl::PinholeCamera<float> camera(gl::Vec3f(0.0f, 0.3f, 4.2f), gl::Vec3f(0.0f), gl::Vec3f(0, 1, 0), 32.0f, W,
                                          H);

    // --- Multiple-scattering table: cached on disk keyed by its parameters. ---
    // The table's extent: +-table_range mean free paths (default 10, the cell count scaled with
    // it up to `max_cells`); 0 = follow the material: 5 diffusion lengths
    // L_d = l / sqrt(3 (1 - alpha)(1 - alpha g)) of the channel that spreads most, at most the
    // sphere's diameter + 4 mfp. The infinite-medium response of a high-albedo material does not
    // decay within the object (milk: L_d ~ 100 mfp), so the wider table counts light that would
    // have left the sphere: Wax +43 %, Milk +1058 % with the automatic range against -24 % and
    // -1.3 % at 10 mfp (docs/wang18.md); the range is then a knob, not a model.
    gl::MsTableOptions to = st.table;
    {
        double ld = 0;
        for (int c = 0; c < 3; ++c) {
            const double a = mat.albedo[c];
            ld = std::max(ld, 1.0 / std::sqrt(3.0 * std::max(1e-9, 1.0 - a) * (1.0 - a * mat.g)));
        }
        const double range = st.table_range > 0 ? double(st.table_range)
                                                : std::clamp(5.0 * ld, 10.0, 2.0 * st.R_opt + 4.0);
        const double f = range / st.table.rho_max;
        to.n_rho = std::min(st.max_cells, int(std::ceil(st.table.n_rho * f)));
        to.n_z = std::min(2 * st.max_cells, int(std::ceil(st.table.n_z * f)));
        to.rho_max = range;
        to.z_min = -range;
        to.z_max = range;
        to.escape_radius = std::max(st.table.escape_radius, 1.5 * range);
    }
    double c0 = cpu_seconds();
    const auto table_path = out / table_key(mat, to);
    // The cells' relative noise (MsTableBuildInfo) is cached beside the table.
    auto noise_path = table_path;
    noise_path += ".noise";
    gl::MsTable<3> table;
    std::vector<double> cell_noise;
    if (std::filesystem::exists(table_path) && std::filesystem::exists(noise_path)) {
        try {
            table = gl::MsTable<3>::load(table_path);
            cell_noise = load_cell_noise(noise_path, 3 * table.grid().cells());
            r.table_cached = true;
        } catch (const std::exception&) {
            r.table_cached = false;
        }
    }
    if (!r.table_cached) {
        gl::MsTableBuildInfo info;
        table = gl::build_ms_table(Phase(mat.g), mat.albedo, to, &info);
        cell_noise = gl::ms_table_cell_relative_noise(info);
        if (ex.root()) {
            table.save(table_path);
            save_cell_noise(noise_path, cell_noise);
        }
    }
    r.seconds_table = cpu_seconds() - c0;
    r.table_mb = double(table.bytes()) / 1e6;
    // Quadtree over the empty (rho, z) regions (item 4): lossless, and dropping cells below 1e-4
    // of the table's largest value.
    r.table_qt_mb = double(gl::MsTableQuadtree<3>(table, 0.0).bytes()) / 1e6;
    r.table_qt_lossy_mb = double(gl::MsTableQuadtree<3>(table, 1e-4).bytes()) / 1e6;
    // ... and merging blocks whose power-weighted L1 error is within 5 % (Sec. 5.2's density-driven
    // subdivision, with a bound; integrators/ms_table_quadtree.hpp).
    r.table_qt_merged_mb = double(gl::MsTableQuadtree<3>(table, 0.0, kTableMerge).bytes()) / 1e6;
    // ... and merging blocks with no structure above the table's own noise (chi-square at 2 sigma).
    // The renderer reads the dense table, or (--table-read) one of these compressed copies.
    std::optional<gl::MsTableQuadtree<3>> read_q;
    {
        gl::MsTableQuadtree<3> qn(table, 0.0, kTableMerge, cell_noise);
        r.table_qt_noise_mb = double(qn.bytes()) / 1e6;
        r.table_qt_noise_lobes = qn.stored_lobes();
        if (st.table_read == "noise") read_q.emplace(std::move(qn));
    }
    if (st.table_read == "merged") read_q.emplace(table, 0.0, kTableMerge);

    // --- Point-based: light samples once, then pb_spp camera rays per pixel. ---
    gl::PointBasedOptions<float> po;
    po.light_samples = st.light_samples;
    po.volume_step = 0.2f / sigma_t.average();
    po.k_max = st.k_max;
    po.depth_sampling = st.depth_sampling;
    po.camera_bounces = 0;
    po.light_bounces = 0;
    po.max_optical_depth = 8.0f;
    po.cut.eps1 = st.eps1;
    po.cut.eps2 = 0.2f * st.eps1;
    po.two_step_depth = 3;
    po.bounce_samples = st.bounce;
    po.bounce_rays = 4;
    po.bounce_k_max = 3;
    po.ms_boundary_image = st.ms_image;
    po.ms_image_offset = st.ms_image_offset;
    po.ms_far_field = st.far_field;
    po.diffusion_cell = st.diffusion_cell;
    po.ms_cut_eps1 = st.ms_eps1;
    po.bounce_cut_scale = st.bounce_cut;
    // The far field's Robin condition carries the boundary's reflection of diffuse light: no Eq. 8.
    po.bounced = st.bounced != "off";
    c0 = cpu_seconds();
    gl::Rng lrng = gl::Rng::from_key(seed, 0x5742u);
    Renderer pb(medium, eta, sphere, gl::sphere_surface_samples(sphere, st.surface),
                gl::Light<float, gl::RGB>::quad_light(quad, gl::RGB(Le)), po, lrng, &table,
                gl::sphere_surface_samples(sphere, po.bounce_samples));
    if (read_q) pb.use_compressed_table(&*read_q);  // the bounce samples keep the dense table's light
    r.seconds_samples = cpu_seconds() - c0;
    r.volume_samples = pb.volume_sample_count();
    r.samples_mb = double(pb.bytes()) / 1e6;

    const std::size_t npx = std::size_t(W) * std::size_t(H);
    // Two independent halves of the point-based rays (stratified sub-pixel positions, one half
    // on the even strata, one on the odd): their difference gives the point-based noise.
    std::vector<double> pbh(2 * npx * 3, 0.0);
    const int side = std::max(1, int(std::lround(std::sqrt(double(st.pb_spp)))));
    // Checkerboard over the side x side strata (each half stratified); ray parity with one stratum.
    auto half_of = [side](int s) {
        if (side < 2) return s % 2;
        const int cell = s % (side * side);
        return (cell % side + cell / side) % 2;
    };
    c0 = cpu_seconds();
    // Film 2 c + h holds the sum of half h's rays of component c (single, double, multiple,
    // bounced): the halves' difference per component says which term the point-based noise is in.
    constexpr int kPbComp = 4;
    std::vector<double> comp_sums(std::size_t(2 * kPbComp) * npx * 3, 0.0);
    {
        // Rows through the render driver (wang18_bumpy.hpp: checkpoints, rows split over the MPI
        // ranks, gathered on rank 0).
        const std::vector<gl::Film> f = wang18::render_rows(
            ex, std::string("wang18 ") + mat.key + " point-based", std::string(mat.key) + " point-based", W, H,
            2 * kPbComp, st.pb_spp, [&](int y, std::span<gl::Film> film) {
                for (int x = 0; x < W; ++x) {
                    const std::size_t p = std::size_t(y) * W + x;
                    for (int s = 0; s < st.pb_spp; ++s) {
                        gl::Rng rng = gl::Rng::from_key(seed, p, 0x10000u + std::uint64_t(s));
                        const gl::Vec2f u = rng.uniform2<float>();
                        const int cell = s % (side * side);
                        const float fx = (float(cell % side) + u.x) / float(side), fy = (float(cell / side) + u.y) / float(side);
                        const auto L = pb.radiance_components(camera.generate_ray(float(x) + fx, float(y) + fy), rng);
                        const std::array<gl::RGB, kPbComp> parts{L.single, L.double_, L.multiple, L.bounced};
                        for (int c = 0; c < kPbComp; ++c)
                            film[std::size_t(2 * c + half_of(s))].add_rgb(x, y, parts[c][0], parts[c][1], parts[c][2]);
                    }
                }
            });
        for (int c = 0; c < 2 * kPbComp; ++c) {
            const auto sums = f[std::size_t(c)].sums();
            for (std::size_t i = 0; i < npx * 3; ++i) {
                comp_sums[std::size_t(c) * npx * 3 + i] = sums[i];
                pbh[std::size_t(c % 2) * npx * 3 + i] += sums[i];
            }
        }
    }
    r.seconds_pb = wang18::sum_over_ranks(ex, cpu_seconds() - c0);
    // Rays per half.
    std::array<int, 2> nh{0, 0};
    for (int s = 0; s < st.pb_spp; ++s) ++nh[std::size_t(half_of(s))];
    // var(mean of all) = var per ray / n; E[d^2] = var per ray (1/n0 + 1/n1) for the halves' means' difference d.
    const double noise_norm = double(st.pb_spp) * (1.0 / nh[0] + 1.0 / std::max(1, nh[1]));
    gl::Image pbi(W, H);
    double pb_noise = 0;
    for (std::size_t p = 0; p < npx; ++p)
        for (int ch = 0; ch < 3; ++ch) {
            const double a = pbh[p * 3 + std::size_t(ch)], b = pbh[(npx + p) * 3 + std::size_t(ch)];
            pbi.at(int(p % W), int(p / W), ch) = float((a + b) / double(st.pb_spp));
            if (nh[1] > 0) {
                const double d = a / nh[0] - b / nh[1];
                pb_noise += d * d / noise_norm;
            }
        }
    if (nh[1] > 0)
        for (int c = 0; c < kPbComp; ++c)
            for (std::size_t i = 0; i < npx * 3; ++i) {
                const double d = comp_sums[std::size_t(2 * c) * npx * 3 + i] / nh[0] -
                                 comp_sums[std::size_t(2 * c + 1) * npx * 3 + i] / nh[1];
                r.pb_noise_comp[std::size_t(c)] += d * d / noise_norm;
            }

    // --- VPT reference: one grey walk per channel, kBatches batches (sample s -> batch s % B). ---
    std::vector<SceneG> scenes;
    for (int ch = 0; ch < 3; ++ch) {
        SceneG s;
        const int m = s.add_medium(MediumG(Grey(sigma_t[ch]), Grey(mat.albedo[ch]), PhaseG(mat.g)));
        s.add_shape(sphere, gl::Material<float, Grey>::dielectric(eta), m, -1);
        s.add_quad_light(quad, Grey(Le));
        scenes.push_back(std::move(s));
    }
    std::vector<double> bs(std::size_t(kBatches) * npx * 3, 0.0);
    std::vector<double> events(std::size_t(H), 0.0);
    gl::WalkOptions<float> wo;  // no max_depth cap (unless --vpt-max-depth); Russian roulette after 5 events
    if (st.vpt_max_depth > 0) wo.max_depth = st.vpt_max_depth;
    c0 = cpu_seconds();
    {
        // Films 0..7: batch sums (sample s -> batch s % 8); film 8, channel 0: scattering events.
        const std::vector<gl::Film> f = wang18::render_rows(
            ex, std::string("wang18 ") + mat.key + " VPT reference", std::string(mat.key) + " VPT reference", W, H,
            kBatches + 1, st.vpt_spp, [&](int y, std::span<gl::Film> film) {
                for (int x = 0; x < W; ++x) {
                    const std::size_t p = std::size_t(y) * W + x;
                    for (int s = 0; s < st.vpt_spp; ++s) {
                        double L[3] = {0, 0, 0}, count = 0;
                        for (int ch = 0; ch < 3; ++ch) {
                            wang18::ChannelSample cs = wang18::channel_sample(camera, x, y, seed, p, s, ch);
                            ScatteredOnly cb{scenes[std::size_t(ch)]};
                            auto ps = gl::start_path<float, Grey>(cs.ray, -1);
                            (void)gl::walk(scenes[std::size_t(ch)], ps, cs.rng, cb, wo);
                            L[ch] = cb.L;
                            count += cb.count;
                        }
                        film[std::size_t(s % kBatches)].add_rgb(x, y, L[0], L[1], L[2]);
                        film[kBatches].add_rgb(x, y, count, 0, 0);
                    }
                }
            });
        for (int b = 0; b < kBatches; ++b) {
            const auto sums = f[std::size_t(b)].sums();
            for (std::size_t i = 0; i < npx * 3; ++i) bs[std::size_t(b) * npx * 3 + i] = sums[i];
        }
        const auto ev = f[kBatches].sums();
        for (std::size_t p = 0; p < npx; ++p) events[p / std::size_t(W)] += ev[3 * p];
    }
    r.seconds_vpt = wang18::sum_over_ranks(ex, cpu_seconds() - c0);
    double ev = 0;
    for (double e : events) ev += e;
    r.events_per_path = ev / (double(npx) * 3.0 * st.vpt_spp);
    const double per_batch = double(st.vpt_spp) / kBatches;

    // Image means per batch -> bias of the mean with its standard error (bs holds one film in
    // wang18::batch_index's layout).
    static_assert(kBatches == wang18::kBatches);
    const wang18::BatchMean ref_mean = wang18::batch_mean(bs, 0, npx, st.vpt_spp);
    r.ref_mean = ref_mean.mean;
    r.ref_se = ref_mean.se;
    r.pb_mean = (pbi.mean(0) + pbi.mean(1) + pbi.mean(2)) / 3.0;
    r.rel = r.ref_mean > 0 ? (r.pb_mean - r.ref_mean) / r.ref_mean : 0.0;
    r.rel_se = r.ref_mean > 0 ? r.ref_se / r.ref_mean : 0.0;

    // Per pixel: MSE against the reference mean minus the reference's variance of the mean.
    gl::Image refi(W, H);
    double sum_e = 0, sum_e2 = 0, var_ps[2] = {0, 0};
    for (std::size_t p = 0; p < npx; ++p)
        for (int ch = 0; ch < 3; ++ch) {
            double b8[kBatches], m = 0;
            for (int b = 0; b < kBatches; ++b) {
                b8[b] = bs[(std::size_t(b) * npx + p) * 3 + std::size_t(ch)] / per_batch;
                m += b8[b] / kBatches;
            }
            double vv = 0;
            for (int b = 0; b < kBatches; ++b) vv += (b8[b] - m) * (b8[b] - m) / (kBatches - 1);
            for (int h = 0; h < 2; ++h) {
                double mh = 0, vh = 0;
                for (int b = h * kBatches / 2; b < (h + 1) * kBatches / 2; ++b) mh += b8[b] / (kBatches / 2);
                for (int b = h * kBatches / 2; b < (h + 1) * kBatches / 2; ++b)
                    vh += (b8[b] - mh) * (b8[b] - mh) / (kBatches / 2 - 1);
                var_ps[h] += vh * per_batch;
            }
            refi.at(int(p % W), int(p / W), ch) = float(m);
            const double d = double(pbi.at(int(p % W), int(p / W), ch)) - m;
            const double e = d * d - vv / kBatches;  // unbiased per-pixel error estimate
            r.mse += d * d;
            r.ref_var_mean += vv / kBatches;
            sum_e += e;
            sum_e2 += e * e;
        }
    const double n3 = double(npx * 3);
    r.mse /= n3;
    r.ref_var_mean /= n3;
    r.pb_noise = pb_noise / n3;
    for (double& v : r.pb_noise_comp) v /= n3;
    r.var_ps = (var_ps[0] + var_ps[1]) / (2 * n3);
    r.half_ratio = var_ps[1] > 0 ? var_ps[0] / var_ps[1] : 0.0;
    const double e_mean = sum_e / n3;
    r.e2_se = std::sqrt(std::max(0.0, sum_e2 / n3 - e_mean * e_mean) / n3);
    // Not resolved below its standard error: use the larger of the two (a lower bound on the
    // speed-up then).
    r.e2 = std::max(e_mean, r.e2_se);
    const double t_ref = r.var_ps / r.e2 * (r.seconds_vpt / double(st.vpt_spp));
    r.speedup = t_ref / (r.seconds_samples + r.seconds_pb);

    // Vertical profile (row means over the three channels): where the per-pixel bias sits.
    gl_examples::Csv prof({"row", "point_based", "vpt"});
    for (int y = 0; y < H; ++y) {
        double a = 0, b = 0;
        for (int x = 0; x < W; ++x)
            for (int ch = 0; ch < 3; ++ch) {
                a += pbi.at(x, y, ch) / (3.0 * W);
                b += refi.at(x, y, ch) / (3.0 * W);
            }
        prof.row_text({std::to_string(y), std::to_string(a), std::to_string(b)});
    }
    if (!ex.root()) return r;  // rank 0 writes
    prof.write(out / (std::string("wang18_table3_") + mat.key + "_profile.csv"));
    const double scale = 1.0 / std::max(1e-6, 4.0 * r.ref_mean);
    gl::write_exr(out / (std::string("wang18_table3_") + mat.key + "_point_based.exr"), pbi);
    gl::write_png(out / (std::string("wang18_table3_") + mat.key + "_point_based.png"), pbi, {scale});
    gl::write_exr(out / (std::string("wang18_table3_") + mat.key + "_vpt.exr"), refi);
    gl::write_png(out / (std::string("wang18_table3_") + mat.key + "_vpt.png"), refi, {scale});
    return r;
}

/// Sec. 5.2 / Table 2 at the paper's resolution: one material's table on the paper's grid
/// (1024 x 512 (rho, z) cells, 18 x 36 directions: our azimuth is folded into [0, pi], so 18 x 18
/// bins hold the paper's 36 over [0, 2 pi]) over the same +-10 mfp, built with the shared
/// fixed-point tally, then compressed with the quadtree. Not cached (2 GB).
struct PaperTable {
    std::uint64_t photons = 0;
    double seconds_build = 0, seconds_compress = 0, dense_mb = 0, histogram_mb = 0;
    double qt_mb = 0, qt_lossy_mb = 0, qt_merged_mb = 0, qt_noise_mb = 0;
    std::size_t stored_lobes = 0, merged_lobes = 0, merged_leaves = 0, noise_lobes = 0, noise_leaves = 0;
    std::size_t cells_with_events = 0, cells = 0;
    std::array<double, 3> relative_noise{};
};

PaperTable run_paper_table(const Material& mat, const gl::MsTableOptions& base, std::uint64_t photons) {
    PaperTable r;
    gl::MsTableOptions to = base;
    to.n_rho = 1024;
    to.n_z = 512;
    to.n_theta = 18;
    to.n_phi = 18;
    to.photons = photons;
    to.blocks = 16;
    to.tally = gl::MsTableTally::automatic;  // 16 x 4 GB per block would not fit: the shared tally
    r.photons = photons;
    gl::MsTableBuildInfo info;
    double c0 = cpu_seconds();
    const gl::MsTable<3> table = gl::build_ms_table(Phase(mat.g), mat.albedo, to, &info);
    r.seconds_build = cpu_seconds() - c0;
    r.dense_mb = double(table.bytes()) / 1e6;
    r.histogram_mb = double(info.histogram_bytes) / 1e6;
    for (std::size_t c = 0; c < 3; ++c) r.relative_noise[c] = info.relative_noise[c];
    r.cells = info.cell_events.size();
    for (const auto n : info.cell_events) r.cells_with_events += n > 0;
    c0 = cpu_seconds();
    r.qt_mb = double(gl::MsTableQuadtree<3>(table, 0.0).bytes()) / 1e6;
    r.qt_lossy_mb = double(gl::MsTableQuadtree<3>(table, 1e-4).bytes()) / 1e6;
    {
        const gl::MsTableQuadtree<3> q(table, 0.0, kTableMerge);
        r.qt_merged_mb = double(q.bytes()) / 1e6;
        r.merged_lobes = q.stored_lobes();
        r.merged_leaves = q.merged_leaves();
    }
    {
        const gl::MsTableQuadtree<3> q(table, 0.0, kTableMerge, gl::ms_table_cell_relative_noise(info));
        r.qt_noise_mb = double(q.bytes()) / 1e6;
        r.noise_lobes = q.stored_lobes();
        r.noise_leaves = q.merged_leaves();
    }
    r.seconds_compress = cpu_seconds() - c0;
    return r;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_table3_materials",
        "Wang18 Table 3: point-based vs VPT at equal error for Oil, Wax, Milk, BmpS. in a sphere of 20 green mfp",
        [&](gl_examples::Example& ex) {
            Settings st;
            const std::string mats = ex.opt<std::string>("materials", "oil,wax,milk,bmps", "comma-separated subset of oil,wax,milk,bmps");
            st.W = ex.opt<int>("width", 32, 128, "image width and height in pixels");
            st.pb_spp = ex.opt<int>("pb-spp", 4, 4, "point-based camera rays per pixel (stratified; >= 2)");
            st.vpt_spp = ex.opt<int>("vpt-spp", 64, 2048, "VPT samples per pixel and channel (multiple of 8)");
            st.surface = ex.opt<int>("surface-samples", 12000, 12000, "light surface samples on the sphere");
            st.bounce = ex.opt<int>("bounce-samples", 512, 512, "bounce surface samples (Eq. 8)");
            st.k_max = ex.opt<int>("k-max", 1, 1, "camera samples per inside segment (Eq. 10)");
            st.eps1 = ex.opt<float>("eps1", 1.0f, 1.0f, "Alg. 1 solid-angle threshold eps1 (sr; eps2 = eps1 / 5)");
            const int photons = ex.opt<int>("table-photons", 200000, 2000000, "particles of each MS table");
            const int table_cells = ex.opt<int>("table-cells", 48, 48, "MS table radial cells over +-range (axial: twice)");
            const int table_bins = ex.opt<int>("table-bins", 12, 12, "MS table polar direction bins (azimuth: half)");
            st.ms_image = ex.opt<bool>("ms-image", false, "boundary image of the multiple-scattering term (method of images)");
            st.ms_image_offset = ex.opt<float>("ms-image-offset", 0.0f, "image plane offset in transport mean free paths");
            const std::string far = ex.opt<std::string>(
                "ms-far-field", "diffusion",
                "multiple scattering beyond the table and at the boundary: none (the paper's Eq. 7) or diffusion (the bounded-medium "
                "diffusion correction on a grid; the bounced term is then off)");
            st.diffusion_cell = ex.opt<float>("diffusion-cell", 2.0f, "far field grid cell in mean free paths");
            st.ms_eps1 = ex.opt<float>("ms-eps1", 0.0f, "solid-angle threshold of a separate, coarser cut for the table term (sr; 0: the double-scattering cut)");
            st.light_samples = ex.opt<int>("light-samples", 2, 2, "points on the quad light per light surface sample (stratified)");
            st.bounce_cut = ex.opt<float>("bounce-cut-scale", 4.0f, "scale of eps1 and eps2 for the bounced term's cuts (>= 1)");
            st.bounced = ex.opt<std::string>("bounced", "auto", "the bounced term (Eq. 8): on, off, auto (on; with the far field it reflects single and double scattering)");
            st.vpt_max_depth = ex.opt<int>("vpt-max-depth", 0, "cap the VPT paths at this many events (0: none; the paper's UPBP reference: 50)");
            st.table_range = ex.opt<float>("table-range", 10.0f, "MS table extent +-range in mean free paths (0: 5 diffusion lengths, at most the sphere)");
            st.table_read = ex.opt<std::string>(
                "table-read", "dense",
                "table the renderer reads: dense, merged (quadtree merged within 5 %), noise (also merged within its noise)");
            const std::string depth = ex.opt<std::string>(
                "depth-sampling", "min",
                "camera samples of Eq. 10 when the channels' sigma_t differ: min (exp(-sigma_min t)), average (Eq. 10 with the "
                "mean sigma_t), mixture (balance heuristic over the channels)");
            const std::string paper_table = ex.opt<std::string>(
                "paper-table", "none", "wax",
                "build this material's table on the paper's 1024 x 512 x 18 x 36 grid and compress it (none: skip; ~6 GB)");
            const int paper_photons = ex.opt<int>("paper-table-photons", 200000, 2000000, "particles of the paper-resolution table");
            ex.checkpointable();
            ex.ready();
            if (st.pb_spp < 2 || st.pb_spp > 4096)
                throw gl_examples::cli_error("--pb-spp must be in [2, 4096], got " + std::to_string(st.pb_spp));
            if (st.vpt_spp < 16 || st.vpt_spp % kBatches != 0)
                throw gl_examples::cli_error("--vpt-spp must be >= 16 and a multiple of 8, got " + std::to_string(st.vpt_spp));
            if (st.W < 4 || st.W > 2048) throw gl_examples::cli_error("--width must be in [4, 2048]");
            if (st.surface < 16 || st.bounce < 1 || st.k_max < 1)
                throw gl_examples::cli_error("--surface-samples >= 16, --bounce-samples >= 1, --k-max >= 1");
            if (!(st.eps1 > 0 && st.eps1 <= 10)) throw gl_examples::cli_error("--eps1 must be in (0, 10]");
            if (!(st.table_range >= 0 && st.table_range <= 200))
                throw gl_examples::cli_error("--table-range must be in [0, 200] (0: automatic)");
            if (photons < 1000) throw gl_examples::cli_error("--table-photons must be >= 1000");
            if (st.table_read != "dense" && st.table_read != "merged" && st.table_read != "noise")
                throw gl_examples::cli_error("--table-read must be dense, merged or noise, got '" + st.table_read + "'");
            if (st.bounced != "on" && st.bounced != "off" && st.bounced != "auto")
                throw gl_examples::cli_error("--bounced must be on, off or auto, got '" + st.bounced + "'");
            if (far == "none") st.far_field = gl::MsFarField::none;
            else if (far == "diffusion") st.far_field = gl::MsFarField::diffusion;
            else throw gl_examples::cli_error("--ms-far-field must be none or diffusion, got '" + far + "'");
            if (st.light_samples < 1 || st.light_samples > 64) throw gl_examples::cli_error("--light-samples must be in [1, 64]");
            if (!(st.bounce_cut >= 1 && st.bounce_cut <= 100))
                throw gl_examples::cli_error("--bounce-cut-scale must be in [1, 100]");
            if (!(st.diffusion_cell > 0.05f && st.diffusion_cell <= 10))
                throw gl_examples::cli_error("--diffusion-cell must be in (0.05, 10] mean free paths");
            if (depth == "min") st.depth_sampling = gl::DepthSampling::min_extinction;
            else if (depth == "average") st.depth_sampling = gl::DepthSampling::average_extinction;
            else if (depth == "mixture") st.depth_sampling = gl::DepthSampling::channel_mixture;
            else throw gl_examples::cli_error("--depth-sampling must be min, average or mixture, got '" + depth + "'");
            const bool full = ex.full();
            if (table_cells < 4 || table_cells > 1024) throw gl_examples::cli_error("--table-cells must be in [4, 1024]");
            if (table_bins < 2 || table_bins > 64 || table_bins % 2 != 0)
                throw gl_examples::cli_error("--table-bins must be even and in [2, 64]");
            st.table.n_rho = std::uint32_t(table_cells);
            st.table.n_z = std::uint32_t(2 * table_cells);
            st.table.n_theta = std::uint32_t(table_bins);
            st.table.n_phi = std::uint32_t(table_bins / 2);
            st.table.rho_max = 10;
            st.table.z_min = -10;
            st.table.z_max = 10;
            st.table.photons = std::uint64_t(photons);
            st.table.seed = ex.seed();
            st.table.blocks = 4;  // 4 tally blocks (deterministic for any thread count)
            st.max_cells = full ? 256 : 128;

            std::vector<const Material*> run;
            std::stringstream ss(mats);
            for (std::string k; std::getline(ss, k, ',');) {
                const Material* m = nullptr;
                for (const auto& x : kMaterials)
                    if (k == x.key) m = &x;
                if (!m) throw gl_examples::cli_error("--materials: unknown material '" + k + "' (oil, wax, milk, bmps)");
                run.push_back(m);
            }
            if (run.empty()) throw gl_examples::cli_error("--materials: empty list");

            gl_examples::Csv csv({"material", "seconds_table", "seconds_samples", "seconds_pb", "seconds_vpt",
                                  "memory_mb", "table_mb", "table_quadtree_mb", "table_quadtree_lossy_mb", "table_quadtree_merged_mb", "table_quadtree_noise_mb", "paper_table_mb", "mse", "e2", "e2_se", "pb_noise",
                                  "vpt_variance_per_sample", "speedup_equal_error", "paper_time_ratio", "paper_mse",
                                  "rel_diff_total", "rel_diff_total_stderr", "vpt_events_per_path"});
            gl_examples::Json jm;
            std::vector<std::pair<std::string, double>> flat;  // top-level copies for the ctest checker
            if (ex.root()) std::printf("Wang18 Table 3 materials in a smooth glass sphere (eta 1.33) of radius %.0f green mean free "
                        "paths, %dx%d pixels, point-based %d rays/pixel, VPT %d spp x 3 channels\n",
                        double(st.R_opt), st.W, st.W, st.pb_spp, st.vpt_spp);
            if (ex.root()) std::printf("  %-6s %8s %8s %8s %9s %9s %10s %10s %8s %9s %8s %14s %9s\n", "mat.", "pb [s]", "VPT [s]",
                        "mem MB", "(T2: MB)", "events", "e^2", "pb noise", "speedup", "(T3: x)", "T3 MSE",
                        "bias", "table [s]");
            for (const Material* m : run) {
                const Result r = run_material(ex, *m, st, ex.seed(), ex.out());
                const double mem = r.table_mb + r.samples_mb;
                if (ex.root()) std::printf("  %-6s %8.2f %8.2f %8.1f %9.1f %9.1f %10.2e %10.2e %7.2fx %8.0fx %8.1e %+6.1f+-%4.1f%% "
                            "%7.2f%s\n",
                            m->name, r.seconds_samples + r.seconds_pb, r.seconds_vpt, mem, m->paper_table_mb,
                            r.events_per_path, r.e2, r.pb_noise, r.speedup, m->paper_ratio(), m->paper_mse,
                            100 * r.rel, 100 * r.rel_se, r.seconds_table, r.table_cached ? " (cached)" : "");
                if (ex.root()) std::printf("         e^2 = %.3e +- %.1e (MSE %.3e - reference variance of the mean %.3e; point-based "
                            "noise %.2e, so bias^2 ~ %.2e); VPT variance/sample %.3e (halves %.2f); %zu volume samples "
                            "(%.1f MB) + table %.1f MB\n",
                            r.e2, r.e2_se, r.mse, r.ref_var_mean, r.pb_noise, r.e2 - r.pb_noise, r.var_ps,
                            r.half_ratio, r.volume_samples, r.samples_mb, r.table_mb);
                if (ex.root()) std::printf("         point-based noise by component: single %.2e, double %.2e, multiple %.2e, bounced %.2e "
                            "(the rest: their covariances)\n", r.pb_noise_comp[0], r.pb_noise_comp[1], r.pb_noise_comp[2],
                            r.pb_noise_comp[3]);
                if (ex.root()) std::printf("         table: dense %.1f MB, quadtree over empty regions %.1f MB (lossless), %.1f MB "
                            "(cells < 1e-4 of the peak dropped), %.2f MB (blocks merged within %.0f %% power-weighted L1), "
                            "%.2f MB (%zu lobes; also blocks flat within the table's noise)   "
                            "[Table 2: %.1f MB compressed, 8.4 GB dense]\n",
                            r.table_mb, r.table_qt_mb, r.table_qt_lossy_mb, r.table_qt_merged_mb, 100 * kTableMerge,
                            r.table_qt_noise_mb, r.table_qt_noise_lobes, m->paper_table_mb);
                csv.row_text({m->key, std::to_string(r.seconds_table), std::to_string(r.seconds_samples),
                              std::to_string(r.seconds_pb), std::to_string(r.seconds_vpt), std::to_string(mem),
                              std::to_string(r.table_mb), std::to_string(r.table_qt_mb),
                              std::to_string(r.table_qt_lossy_mb), std::to_string(r.table_qt_merged_mb),
                              std::to_string(r.table_qt_noise_mb),
                              std::to_string(m->paper_table_mb), std::to_string(r.mse),
                              std::to_string(r.e2), std::to_string(r.e2_se), std::to_string(r.pb_noise),
                              std::to_string(r.var_ps), std::to_string(r.speedup), std::to_string(m->paper_ratio()),
                              std::to_string(m->paper_mse), std::to_string(r.rel), std::to_string(r.rel_se),
                              std::to_string(r.events_per_path)});
                gl_examples::Json j;
                j.num("speedup_equal_error", r.speedup)
                    .num("rel_diff_total", r.rel)
                    .num("rel_diff_total_stderr", r.rel_se)
                    .num("seconds_point_based", r.seconds_samples + r.seconds_pb)
                    .num("seconds_samples", r.seconds_samples)
                    .num("seconds_render", r.seconds_pb)
                    .num("seconds_vpt", r.seconds_vpt)
                    .num("seconds_table", r.seconds_table)
                    .num("memory_mb", mem)
                    .num("table_mb", r.table_mb)
                    .num("table_quadtree_mb", r.table_qt_mb)
                    .num("table_quadtree_lossy_mb", r.table_qt_lossy_mb)
                    .num("table_quadtree_merged_mb", r.table_qt_merged_mb)
                    .num("table_quadtree_noise_mb", r.table_qt_noise_mb)
                    .integer("table_quadtree_noise_lobes", std::int64_t(r.table_qt_noise_lobes))
                    .num("mse", r.mse)
                    .num("error2", r.e2)
                    .num("error2_stderr", r.e2_se)
                    .num("pb_noise", r.pb_noise)
                    .num("pb_noise_single", r.pb_noise_comp[0])
                    .num("pb_noise_double", r.pb_noise_comp[1])
                    .num("pb_noise_multiple", r.pb_noise_comp[2])
                    .num("pb_noise_bounced", r.pb_noise_comp[3])
                    .num("vpt_variance_per_sample", r.var_ps)
                    .num("vpt_variance_half_ratio", r.half_ratio)
                    .num("vpt_events_per_path", r.events_per_path)
                    .num("paper_time_ratio", m->paper_ratio())
                    .num("paper_mse", m->paper_mse)
                    .num("paper_table_mb", m->paper_table_mb);
                jm.raw(m->key, j.str());
                flat.push_back({std::string(m->key) + "_speedup_equal_error", r.speedup});
                flat.push_back({std::string(m->key) + "_rel_diff_total", r.rel});
                flat.push_back({std::string(m->key) + "_rel_diff_total_stderr", r.rel_se});
                flat.push_back({std::string(m->key) + "_seconds_point_based", r.seconds_samples + r.seconds_pb});
                flat.push_back({std::string(m->key) + "_seconds_vpt", r.seconds_vpt});
                flat.push_back({std::string(m->key) + "_memory_mb", mem});
            }
            // The paper's grid for one material (Table 2's memory and Sec. 5.2's compression).
            gl_examples::Json jp;
            bool have_paper = false;
            if (paper_table != "none") {
                const Material* pm = nullptr;
                for (const auto& x : kMaterials)
                    if (paper_table == x.key) pm = &x;
                if (!pm) throw gl_examples::cli_error("--paper-table: unknown material '" + paper_table + "' (oil, wax, milk, bmps, none)");
                if (paper_photons < 1000) throw gl_examples::cli_error("--paper-table-photons must be >= 1000");
                const PaperTable pt = run_paper_table(*pm, st.table, std::uint64_t(paper_photons));
                have_paper = true;
                if (ex.root())
                    std::printf("\n  %s on the paper's grid (1024 x 512 cells x 18 x 36 directions, +-10 mfp, %llu particles): "
                                "build %.1f CPU s (histogram %.0f MB, shared fixed-point tally), dense %.0f MB [paper: 8.4 GB]; "
                                "%zu of %zu cells hold events; relative noise %.3f / %.3f / %.3f (R / G / B)\n"
                                "  quadtree: %.0f MB lossless, %.0f MB (cells < 1e-4 of the peak dropped), %.1f MB merged "
                                "within %.0f %% (%zu lobes), %.1f MB merged where flat within the noise (%zu lobes, %zu merged "
                                "blocks); %.1f CPU s   [Table 2: %.1f MB, 8256 lobes, 50 M particles]\n",
                                pm->name, (unsigned long long)pt.photons, pt.seconds_build, pt.histogram_mb, pt.dense_mb,
                                pt.cells_with_events, pt.cells, pt.relative_noise[0], pt.relative_noise[1],
                                pt.relative_noise[2], pt.qt_mb, pt.qt_lossy_mb, pt.qt_merged_mb, 100 * kTableMerge,
                                pt.merged_lobes, pt.qt_noise_mb, pt.noise_lobes, pt.noise_leaves, pt.seconds_compress,
                                pm->paper_table_mb);
                jp.str("material", pm->key)
                    .str("grid", "1024x512x18x36")
                    .integer("photons", std::int64_t(pt.photons))
                    .num("seconds_build", pt.seconds_build)
                    .num("seconds_compress", pt.seconds_compress)
                    .num("histogram_mb", pt.histogram_mb)
                    .num("dense_mb", pt.dense_mb)
                    .num("quadtree_mb", pt.qt_mb)
                    .num("quadtree_lossy_mb", pt.qt_lossy_mb)
                    .num("quadtree_merged_mb", pt.qt_merged_mb)
                    .integer("quadtree_merged_lobes", std::int64_t(pt.merged_lobes))
                    .num("quadtree_noise_mb", pt.qt_noise_mb)
                    .integer("quadtree_noise_lobes", std::int64_t(pt.noise_lobes))
                    .integer("cells_with_events", std::int64_t(pt.cells_with_events))
                    .num("relative_noise_green", pt.relative_noise[1])
                    .num("paper_dense_mb", 8400.0)
                    .num("paper_table_mb", pm->paper_table_mb)
                    .integer("paper_lobes", 8256);
            }
            if (!ex.root()) return ex.finish({});  // rank 0 writes and prints
            const auto csv_path = ex.csv("wang18_table3_materials.csv", csv);
            ex.plot("wang18_table3_materials", csv_path, ex.out() / "wang18_table3_materials.png");
            auto j = ex.summary();
            wang18::put_rank_rows(ex, j, st.W);
            j.integer("pb_spp", st.pb_spp).integer("vpt_spp", st.vpt_spp).integer("width", st.W);
            j.str("ms_far_field", st.far_field == gl::MsFarField::diffusion ? "diffusion" : "none")
                .num("diffusion_cell", st.diffusion_cell)
                .integer("k_max", st.k_max)
                .num("bounce_cut_scale", st.bounce_cut)
                .num("eps1", st.eps1);
            j.raw("materials", jm.str());
            if (have_paper) j.raw("paper_table", jp.str());
            for (const auto& [k, v] : flat) j.num(k, v);
            return ex.finish(j);
        });
}
