// wang18_fig20_vs_shells: Wang & Holzschuch 2018 (TVCG), Fig. 20 and Sec. 6.2.2 ("Comparison with
// Moon et al. on Bumpy Sphere Scene with g = 0.95 (unbounced multiple scattering only)"): the
// multiple-scattering term of the bumpy sphere (examples/wang18_bumpy.hpp: displaced icosphere,
// radius 20 green mean free paths, BmpS. albedo, HG g = 0.95, eta 1.33) rendered
//   (a) by the point-based renderer from our MS table (Eq. 7, integrators/point_based.hpp),
//   (b) by Moon07 shells (precompute/shell_builder.hpp ContinuousShellSource + build_shell_table,
//       integrators/shell_tracer.hpp ShellSwitchMedium) of the same bytes as that MS table,
//   (c) by shells of `--large-factor` times those bytes,
// each beside the same component of the VPT reference (the library's walk kernel through the same
// mesh, uncapped): paths with >= 3 scattering events and no boundary reflection between events.
// The shell render traces the first two scattering events exactly (so single and double are not
// in it), then advances by the largest shell that fits inside the mesh (MeshDistance), exact
// steps within r_0 of the surface; a shell exit with a scattered exit counts as an event, so its
// path space is the VPT's multiple term exactly. Shell memory: radii, W and H (NMF factors), f_a
// and the per-shell probabilities as stored (doubles), three channels; the angular resolution
// n_u = n_v is the largest that fits the byte budget at the given rank, shell count and n_c.
// Paper: "using the same amount of memory, Moon et al.'s method blurs the variations in multiple
// scattering; increasing the memory allocated, they get results that are visually similar to
// ours"; Fig. 20(e): the shell table "contains numerous artefacts, caused by the low resolution
// in the angular domain".
//
//   wang18_fig20_vs_shells [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                          [--vpt-spp N] [--shell-spp N] [--width N] [--large-factor F] ...
//
// Outputs: wang18_fig20_{table,shells_equal,shells_large,vpt}_multiple.{exr,png}, the
// representations wang18_fig20_repr_{table_slice,table_lobe,shells_equal_exit,shells_large_exit}
// .{exr,png}, wang18_fig20_vs_shells.csv (+ .png panel); JSON summary (last stdout line) with
// memory_*_mb, rel_diff_multiple_*, e2_*, highpass_* per method.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "grainlight/geometry/distance.hpp"
#include "grainlight/integrators/shell_tracer.hpp"
#include "grainlight/precompute/shell_builder.hpp"
#include "wang18_bumpy.hpp"

namespace gl = grainlight;

namespace {

using Switch = gl::ShellSwitchMedium<wang18::MediumG, gl::MeshDistance>;

/// The medium of the shell render: exact free flights (mode 0, the mesh's interior medium) or the
/// shell switch medium (mode 1, set by the callback after the second exact event). Both point to
/// objects owned by the caller.
struct ModeMedium {
    using Float = float;
    using Spectrum = wang18::Grey;
    const wang18::MediumG* exact = nullptr;
    const Switch* shells = nullptr;  ///< null: exact mode
    [[nodiscard]] gl::Interaction<float, Spectrum> sample_interaction(const gl::Ray<float>& r, float t, gl::Rng& rng) const noexcept {
        return shells ? shells->sample_interaction(r, t, rng) : exact->sample_interaction(r, t, rng);
    }
    [[nodiscard]] Spectrum transmittance(const gl::Ray<float>& r, float t, gl::Rng& rng) const noexcept {
        return exact->transmittance(r, t, rng);
    }
    [[nodiscard]] decltype(auto) phase() const noexcept { return exact->phase(); }
};
using ShellScene = gl::Scene<ModeMedium>;

/// Walk callbacks of the shell render: two exact events, then shells; light reaching the quad
/// light after >= 3 events (shell scattered exits count) with no boundary reflection between
/// events is the multiple term.
struct ShellCb {
    const ShellScene& scene;
    int count = 0;
    bool bounced_between = false;
    float L = 0;
    bool on_scatter(gl::PathState<float, wang18::Grey>& st, const gl::Interaction<float, wang18::Grey>&, const ModeMedium&) noexcept {
        ++count;
        if (count >= 2 && st.specular) bounced_between = true;
        if (bounced_between) return false;  // not in the multiple term: stop
        if (count == 2) st.medium = 1;      // from here on, shells
        return true;
    }
    bool on_surface(gl::PathState<float, wang18::Grey>& st, const gl::SurfaceHit<float, wang18::Grey>& hit) noexcept {
        if (hit.light < 0 || count < 3 || bounced_between) return true;
        L += (st.throughput * scene.emitted(hit, st.ray.d))[0];
        return true;
    }
};

/// Bytes of a shell table as stored (doubles).
std::size_t shell_bytes(const gl::ShellTable& t) {
    return sizeof(double) * (t.radii.size() * 4 + t.W.size() + t.H.size() + t.fa.size());
}
/// Bytes of a table of `ns` shells, n_c cos cells, n_uv^2 direction cells, rank K, fa_bins + 1 f_a entries.
std::size_t shell_bytes(int ns, int n_c, int n_uv, int K, int fa_bins) {
    return sizeof(double) * (std::size_t(ns) * 4 + std::size_t(ns) * std::size_t(n_c) * std::size_t(K) +
                             std::size_t(K) * std::size_t(n_uv) * std::size_t(n_uv) + std::size_t(fa_bins) + 1);
}

/// A shell image and its per-pixel variance of the mean (kBatches batches).
struct ShellRun {
    gl::Image img;
    std::vector<double> var_mean;  ///< per pixel and channel
    double cpu = 0, shell_steps_share = 0;
};

/// Render the shell-based multiple term (channels through their own tables), `spp` per pixel and channel.
ShellRun render_shells(const gl_examples::Example& ex, const wang18::BumpyScene& sc, const std::vector<gl::ShellTable>& tables,
                       int spp, std::uint64_t seed, const std::string& label) {
    const gl::MeshDistance dist(sc.mesh);
    std::vector<wang18::MediumG> exact;
    for (int ch = 0; ch < 3; ++ch)
        exact.emplace_back(wang18::Grey(sc.sigma_t[ch]), wang18::Grey(sc.albedo[ch]), wang18::PhaseG(sc.g));
    std::vector<std::unique_ptr<Switch>> sw;
    for (int ch = 0; ch < 3; ++ch) sw.push_back(std::make_unique<Switch>(exact[std::size_t(ch)], tables[std::size_t(ch)], dist, true));
    std::vector<ShellScene> scenes;
    const gl::MeshShape<float> mshape(sc.mesh);
    for (int ch = 0; ch < 3; ++ch) {
        ShellScene s;
        const int m = s.add_medium(ModeMedium{&exact[std::size_t(ch)], nullptr});
        (void)s.add_medium(ModeMedium{&exact[std::size_t(ch)], sw[std::size_t(ch)].get()});
        s.add_shape(mshape, gl::Material<float, wang18::Grey>::dielectric(sc.eta), m, -1);
        s.add_quad_light(sc.quad, wang18::Grey(sc.Le));
        scenes.push_back(std::move(s));
    }
    const int W = sc.W, H = sc.H, B = wang18::kBatches;
    const std::size_t npx = std::size_t(W) * std::size_t(H);
    std::vector<double> bs(std::size_t(B) * npx * 3, 0.0);
    const double c0 = wang18::cpu_seconds();
    for (int b = 0; b < B; ++b) {
        const std::vector<gl::Film> f = wang18::render_rows(
            ex, label + " batch " + std::to_string(b + 1) + "/" + std::to_string(B), label + " batch " + std::to_string(b), W, H, 1,
            spp, [&](int y, std::span<gl::Film> film) {
                for (int x = 0; x < W; ++x) {
                    const std::size_t p = std::size_t(y) * std::size_t(W) + std::size_t(x);
                    for (int s = b; s < spp; s += B) {
                        float L[3] = {0, 0, 0};
                        for (int ch = 0; ch < 3; ++ch) {
                            wang18::ChannelSample cs = wang18::channel_sample(sc.camera, x, y, seed ^ 0x5E11u, p, s, ch);
                            ShellCb cb{scenes[std::size_t(ch)]};
                            auto st = gl::start_path<float, wang18::Grey>(cs.ray, -1);
                            (void)gl::walk(scenes[std::size_t(ch)], st, cs.rng, cb, gl::WalkOptions<float>{});
                            L[ch] = cb.L;
                        }
                        film[0].add_rgb(x, y, L[0], L[1], L[2]);
                    }
                }
            });
        const auto sums = f[0].sums();
        for (std::size_t i = 0; i < npx * 3; ++i) bs[std::size_t(b) * npx * 3 + i] = sums[i];
    }
    ShellRun r;
    r.cpu = wang18::sum_over_ranks(ex, wang18::cpu_seconds() - c0);
    r.img = gl::Image(W, H);
    r.var_mean.assign(npx * 3, 0.0);
    const double per_batch = double(spp) / B;
    for (std::size_t p = 0; p < npx; ++p)
        for (int ch = 0; ch < 3; ++ch) {
            double m = 0, v = 0, xb[wang18::kBatches];
            for (int b = 0; b < B; ++b) m += (xb[b] = bs[std::size_t(b) * npx * 3 + 3 * p + std::size_t(ch)] / per_batch) / B;
            for (int b = 0; b < B; ++b) v += (xb[b] - m) * (xb[b] - m) / (B - 1);
            r.img.at(int(p % std::size_t(W)), int(p / std::size_t(W)), ch) = float(m);
            r.var_mean[3 * p + std::size_t(ch)] = v / B;
        }
    return r;
}

/// Per-pixel variance of the mean of the VPT's component k.
std::vector<double> vpt_var_mean(const wang18::VptRun& v, int k) {
    const std::size_t npx = std::size_t(v.W) * std::size_t(v.H);
    const double per_batch = double(v.spp) / wang18::kBatches;
    std::vector<double> out(npx * 3, 0.0);
    for (std::size_t p = 0; p < npx; ++p)
        for (int ch = 0; ch < 3; ++ch) {
            double m = 0, vv = 0, xb[wang18::kBatches];
            for (int b = 0; b < wang18::kBatches; ++b) m += (xb[b] = v.bs[v.idx(k, b, p, ch)] / per_batch) / wang18::kBatches;
            for (int b = 0; b < wang18::kBatches; ++b) vv += (xb[b] - m) * (xb[b] - m) / (wang18::kBatches - 1);
            out[3 * p + std::size_t(ch)] = vv / wang18::kBatches;
        }
    return out;
}

/// High-pass part of an image: the pixel minus the mean of its 3 x 3 neighbourhood (clamped at the border).
std::vector<double> high_pass(const gl::Image& a) {
    std::vector<double> h(std::size_t(a.width) * std::size_t(a.height) * 3, 0.0);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int ch = 0; ch < 3; ++ch) {
                double s = 0;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx)
                        s += a.at(std::clamp(x + dx, 0, a.width - 1), std::clamp(y + dy, 0, a.height - 1), ch);
                h[(std::size_t(y) * std::size_t(a.width) + std::size_t(x)) * 3 + std::size_t(ch)] = a.at(x, y, ch) - s / 9.0;
            }
    return h;
}

/// Errors of one method's multiple term against the VPT's (measuring.md: e^2 = MSE minus both
/// images' variances of the mean; the high-pass part's noise is 8/9 of the pixel variance for
/// independent pixels).
struct Errors {
    double mean = 0, rel = 0, rel_se = 0, mse = 0, e2 = 0, e2_hp = 0, hp_ratio = 0;
};
Errors errors(const gl::Image& t, const std::vector<double>* t_var, const gl::Image& ref, const std::vector<double>& ref_var,
              double ref_mean, double ref_se) {
    Errors e;
    e.mean = wang18::image_mean(t);
    e.rel = ref_mean > 0 ? (e.mean - ref_mean) / ref_mean : 0.0;
    double tv_mean = 0;
    if (t_var) {
        for (double v : *t_var) tv_mean += v;
        tv_mean /= double(t_var->size());
    }
    e.rel_se = ref_mean > 0 ? std::sqrt(ref_se * ref_se + tv_mean / double(ref_var.size())) / ref_mean : 0.0;
    const auto ht = high_pass(t), hr = high_pass(ref);
    double mse = 0, var = 0, hmse = 0, et = 0, er = 0, rv = 0;
    for (std::size_t i = 0; i < ht.size(); ++i) {
        const int p = int(i / 3), ch = int(i % 3);
        const double d = double(t.at(p % t.width, p / t.width, ch)) - double(ref.at(p % t.width, p / t.width, ch));
        mse += d * d;
        var += ref_var[i] + (t_var ? (*t_var)[i] : 0.0);
        hmse += (ht[i] - hr[i]) * (ht[i] - hr[i]);
        et += ht[i] * ht[i] - (t_var ? 8.0 / 9.0 * (*t_var)[i] : 0.0);
        er += hr[i] * hr[i];
        rv += 8.0 / 9.0 * ref_var[i];
    }
    const double n = double(ht.size());
    e.mse = mse / n;
    e.e2 = std::max(e.mse - var / n, 1e-3 * e.mse);
    e.e2_hp = std::max(hmse / n - 8.0 / 9.0 * var / n, 1e-3 * hmse / n);
    e.hp_ratio = er - rv > 0 ? et / (er - rv) : 0.0;
    return e;
}

/// Write a representation image (one channel repeated), normalised to its maximum.
void save_repr(const gl_examples::Example& ex, const std::string& name, int w, int h, const std::vector<double>& v) {
    gl::Image img(w, h);
    double mx = 0;
    for (double x : v) mx = std::max(mx, x);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int ch = 0; ch < 3; ++ch)
                img.at(x, y, ch) = float(mx > 0 ? v[std::size_t(y) * std::size_t(w) + std::size_t(x)] / mx : 0.0);
    wang18::save_image(ex, name, img, 1.0);
}

/// The exit-direction density of shell i at the cos theta_1 cell j (the NMF reconstruction W H),
/// n_u x n_v, of channel table t.
std::vector<double> shell_exit_slice(const gl::ShellTable& t, std::size_t i, std::size_t j) {
    const std::size_t K = std::size_t(t.rank), nd = t.n_dir(), row = i * std::size_t(t.n_c) + j;
    std::vector<double> v(nd, 0.0);
    for (std::size_t q = 0; q < nd; ++q)
        for (std::size_t k = 0; k < K; ++k) v[q] += t.W[row * K + k] * t.H[k * nd + q];
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_fig20_vs_shells",
        "Wang18 Fig. 20: multiple scattering from the MS table vs Moon07 shells of the same and of more memory",
        "out/wang18_fig20_vs_shells", [&](gl_examples::Example& ex) -> int {
            const int vpt_spp = ex.opt<int>("vpt-spp", 256, 1024, "VPT samples per pixel and channel (multiple of 8)");
            const int shell_spp = ex.opt<int>("shell-spp", 128, 512, "shell-render samples per pixel and channel (multiple of 8)");
            const int n_surface = ex.opt<int>("surface-samples", 12000, 40000, "Poisson-disk light surface samples on the mesh");
            const int rays = ex.opt<int>("rays", 4, 4, "camera rays per pixel of the point-based render");
            const int W = ex.opt<int>("width", 32, 96, "image width = height in pixels");
            const double g = ex.opt<double>("g", 0.95, "HG mean cosine (paper Fig. 20: 0.95)");
            const double R_opt = ex.opt<double>("radius-mfp", 20.0, "sphere radius in green mean free paths");
            const int n_rho = ex.opt<int>("table-rho", 16, 24, "MS table radial cells");
            const int n_z = ex.opt<int>("table-z", 32, 48, "MS table axial cells");
            const int n_theta = ex.opt<int>("table-theta", 8, 12, "MS table polar direction bins");
            const int n_phi = ex.opt<int>("table-phi", 4, 6, "MS table azimuth bins");
            const int photons = ex.opt<int>("table-photons", 200000, 2000000, "MS table photons");
            const double rho_max = ex.opt<double>("table-rho-max", 10.0, "MS table radial extent [mean free paths]");
            const double z_min = ex.opt<double>("table-z-min", -10.0, "MS table axial lower bound [mean free paths]");
            const double z_max = ex.opt<double>("table-z-max", 10.0, "MS table axial upper bound [mean free paths]");
            const int shells = ex.opt<int>("shells", 6, 8, "shell radii (geometric from 1 to --shell-rmax mean free paths)");
            const double shell_rmax = ex.opt<double>("shell-rmax", 8.0, "largest shell radius [mean free paths of its channel]");
            const int n_c = ex.opt<int>("shell-nc", 24, 32, "shell cells in cos theta_1");
            const int rank = ex.opt<int>("shell-rank", 6, 8, "NMF terms of the shell tables (paper 4-6)");
            const int shell_paths = ex.opt<int>("shell-paths", 60000, 400000, "paths per shell table");
            const int nmf_iter = ex.opt<int>("nmf-iterations", 150, 400, "NMF multiplicative-update iterations");
            const std::string cos_cells = ex.opt<std::string>(
                "shell-cos-cells", "angle", "layout of the shells' cos theta_1 cells: angle (equal theta_1 widths) or cos");
            const double eps1 = ex.opt<double>("eps1", 1.0, 0.2, "Alg. 1 solid-angle threshold eps1 (sr); eps2 = eps1 / 5");
            const double large = ex.opt<double>("large-factor", 4.0, 6.0, "memory of the large shell table / MS table memory (paper: 'increasing the memory')");
            ex.checkpointable();
            ex.ready();
            wang18::check_vpt_spp(vpt_spp);
            wang18::check_vpt_spp(shell_spp);
            wang18::check_surface_samples(n_surface);
            wang18::check_render_args(rays, W, R_opt);
            using gl_examples::cli_error;
            if (!(g > -0.99 && g < 0.99)) throw cli_error("--g = " + std::to_string(g) + " must be in (-0.99, 0.99)");
            if (n_rho < 2 || n_rho > 1024 || n_z < 2 || n_z > 1024) throw cli_error("--table-rho and --table-z must be in [2, 1024]");
            if (n_theta < 1 || n_theta > 64 || n_phi < 1 || n_phi > 64) throw cli_error("--table-theta and --table-phi must be in [1, 64]");
            if (photons < 1000 || photons > 100000000) throw cli_error("--table-photons = " + std::to_string(photons) + " must be in [1e3, 1e8]");
            if (shells < 1 || shells > 32) throw cli_error("--shells = " + std::to_string(shells) + " must be in [1, 32]");
            if (!(shell_rmax >= 1 && shell_rmax <= 0.5 * R_opt)) throw cli_error("--shell-rmax must be in [1, radius-mfp / 2]");
            if (n_c < 2 || n_c > 256) throw cli_error("--shell-nc = " + std::to_string(n_c) + " must be in [2, 256]");
            if (rank < 1 || rank > 64) throw cli_error("--shell-rank = " + std::to_string(rank) + " must be in [1, 64]");
            if (shell_paths < 1000 || shell_paths > 100000000) throw cli_error("--shell-paths must be in [1e3, 1e8]");
            if (nmf_iter < 10 || nmf_iter > 10000) throw cli_error("--nmf-iterations must be in [10, 1e4]");
            if (cos_cells != "angle" && cos_cells != "cos")
                throw cli_error("--shell-cos-cells = '" + cos_cells + "' must be angle or cos");
            if (!(eps1 > 0 && eps1 <= 10)) throw cli_error("--eps1 = " + std::to_string(eps1) + " must be in (0, 10]");
            if (!(large >= 1 && large <= 100)) throw cli_error("--large-factor = " + std::to_string(large) + " must be in [1, 100]");
            const bool full = ex.full();
            const auto& out = ex.out();
            const std::uint64_t seed = ex.seed();
            const wang18::BumpyScene sc = wang18::make_bumpy_scene(W, float(R_opt), float(g));

            // (a) The MS table (cached on disk by its parameters) and the point-based multiple term.
            gl::MsTableOptions to;
            to.n_rho = std::uint32_t(n_rho);
            to.n_z = std::uint32_t(n_z);
            to.n_theta = std::uint32_t(n_theta);
            to.n_phi = std::uint32_t(n_phi);
            if (!(rho_max > 0 && rho_max <= 1000 && z_min < z_max && z_max - z_min <= 2000))
                throw cli_error("--table-rho-max must be in (0, 1000] and --table-z-min < --table-z-max");
            to.rho_max = rho_max;
            to.z_min = z_min;
            to.z_max = z_max;
            to.photons = std::uint64_t(photons);
            to.seed = seed;
            char key[160];
            std::snprintf(key, sizeof key, "wang18_fig20_ms_table_g%.3f_%dx%dx%dx%d_r%g_z%g_%g_%d_s%llu_v%d.bin", g, n_rho, n_z,
                          n_theta, n_phi, rho_max, z_min, z_max, photons, (unsigned long long)seed,
                          gl::ms_table_estimator_version);
            double c0 = wang18::cpu_seconds();
            gl::MsTable<3> table;
            bool cached = false;
            if (std::filesystem::exists(out / key)) try {
                    table = gl::MsTable<3>::load(out / key);
                    cached = true;
                } catch (const std::exception&) {
                    cached = false;
                }
            if (!cached) {
                table = gl::MsTable<3>::build(wang18::Phase(float(g)), sc.albedo, to);
                if (ex.root()) table.save(out / key);
            }
            const double cpu_table = wang18::cpu_seconds() - c0;
            const std::size_t table_bytes = table.bytes();
            gl::PointBasedOptions<float> po = wang18::default_options(sc, full);
            po.cut.eps1 = float(eps1);
            po.cut.eps2 = 0.2f * float(eps1);
            po.bounce_samples = 0;  // the multiple term only (Eq. 8's bounced term is not compared)
            const wang18::PbRun pb = wang18::render_pb(ex, sc, &table, po, n_surface, seed, "fig20 point-based", rays);

            // (b), (c) Shell tables of the MS table's bytes and of `large` times them, per channel.
            std::vector<double> radii_mfp;
            for (int i = 0; i < shells; ++i)
                radii_mfp.push_back(shells == 1 ? shell_rmax : std::pow(shell_rmax, double(i) / double(shells - 1)));
            const int fa_bins = 256;
            auto pick_nuv = [&](double budget) {
                int nuv = 1;
                while (nuv < 512 && 3 * shell_bytes(shells, n_c, nuv + 1, rank, fa_bins) <= budget) ++nuv;
                return nuv;
            };
            const int nuv_eq = pick_nuv(double(table_bytes)), nuv_lg = pick_nuv(large * double(table_bytes));
            struct Shells {
                std::vector<gl::ShellTable> t;
                std::size_t bytes = 0;
                double cpu = 0, nmf_err = 0;
                int nuv = 0;
            };
            auto build_shells = [&](int nuv) {
                Shells s;
                s.nuv = nuv;
                const double t0 = wang18::cpu_seconds();
                for (int ch = 0; ch < 3; ++ch) {
                    const wang18::MediumG m(wang18::Grey(sc.sigma_t[ch]), wang18::Grey(sc.albedo[ch]), wang18::PhaseG(sc.g));
                    std::vector<double> radii;
                    for (double r : radii_mfp) radii.push_back(r / double(sc.sigma_t[ch]));
                    const gl::ContinuousShellSource<wang18::MediumG> src(m);
                    const gl::ShellSamples smp = gl::collect_shell_samples(src, radii, std::uint64_t(shell_paths),
                                                                           seed + 31 * std::uint64_t(ch + 1), fa_bins);
                    gl::ShellBuildOptions bo;
                    bo.n_c = n_c;
                    bo.n_u = bo.n_v = nuv;
                    bo.rank = rank;
                    bo.nmf_iterations = nmf_iter;
                    bo.cos_cells = cos_cells == "cos" ? gl::ShellCosCells::uniform_cos : gl::ShellCosCells::uniform_angle;
                    bo.seed = seed;
                    gl::ShellBuildResult res = gl::build_shell_table(smp, bo);
                    s.nmf_err = std::max(s.nmf_err, res.nmf_relative_error);
                    s.bytes += shell_bytes(res.table);
                    s.t.push_back(std::move(res.table));
                }
                s.cpu = wang18::cpu_seconds() - t0;
                return s;
            };
            const Shells sh_eq = build_shells(nuv_eq);
            const ShellRun run_eq = render_shells(ex, sc, sh_eq.t, shell_spp, seed, "fig20 shells (equal memory)");
            const Shells sh_lg = build_shells(nuv_lg);
            const ShellRun run_lg = render_shells(ex, sc, sh_lg.t, shell_spp, seed + 7, "fig20 shells (large memory)");

            // The reference's multiple term.
            const wang18::VptRun vpt = wang18::render_vpt(ex, sc, vpt_spp, seed, "fig20 VPT reference");
            const wang18::Comparison c = wang18::compare(pb, vpt);
            const std::vector<double> ref_var = vpt_var_mean(vpt, 2);
            const gl::Image& ref = vpt.img[2];
            const Errors e_tab = errors(pb.img[2], nullptr, ref, ref_var, c.ref[2], c.ref_se[2]);
            const Errors e_eq = errors(run_eq.img, &run_eq.var_mean, ref, ref_var, c.ref[2], c.ref_se[2]);
            const Errors e_lg = errors(run_lg.img, &run_lg.var_mean, ref, ref_var, c.ref[2], c.ref_se[2]);

            if (!ex.root()) return ex.finish({});  // rank 0 writes and prints
            // Exposure (stops): the VPT's brightest channel mean over the object's pixels at 0.3.
            double ch_max = 0;
            for (int ch = 0; ch < 3; ++ch) ch_max = std::max(ch_max, ref.mean(ch));
            const double exposure = std::log2(0.3 * 0.5 / std::max(ch_max, 1e-12));  // the sphere covers ~half the pixels
            wang18::save_image(ex, "wang18_fig20_table_multiple", pb.img[2], exposure);
            wang18::save_image(ex, "wang18_fig20_shells_equal_multiple", run_eq.img, exposure);
            wang18::save_image(ex, "wang18_fig20_shells_large_multiple", run_lg.img, exposure);
            wang18::save_image(ex, "wang18_fig20_vpt_multiple", ref, exposure);
            // (e) The representations (green channel): the MS table's emission summed over
            // directions on its (rho, z) grid (rows z, columns rho), the lobe (theta x phi) at rho = 0,
            // z = 2 mfp; the shells' exit-direction density (u x v) of the middle shell at the most
            // forward cos theta_1 cell.
            {
                const auto& gr = table.grid();
                std::vector<double> slice(std::size_t(gr.n_rho) * gr.n_z, 0.0), lobe(gr.directions(), 0.0);
                for (std::uint32_t iz = 0; iz < gr.n_z; ++iz)
                    for (std::uint32_t ir = 0; ir < gr.n_rho; ++ir)
                        for (std::size_t j = 0; j < gr.directions(); ++j)
                            slice[std::size_t(gr.n_z - 1 - iz) * gr.n_rho + ir] += table.values()[table.value_index(1, iz, ir, j)];
                for (std::size_t j = 0; j < gr.directions(); ++j) lobe[j] = table.eval_bin(1, 0.0, 2.0, j);
                save_repr(ex, "wang18_fig20_repr_table_slice", int(gr.n_rho), int(gr.n_z), slice);
                save_repr(ex, "wang18_fig20_repr_table_lobe", int(gr.n_phi), int(gr.n_theta), lobe);
                const std::size_t mid = std::size_t(shells) / 2;
                save_repr(ex, "wang18_fig20_repr_shells_equal_exit", nuv_eq, nuv_eq, shell_exit_slice(sh_eq.t[1], mid, std::size_t(n_c - 1)));
                save_repr(ex, "wang18_fig20_repr_shells_large_exit", nuv_lg, nuv_lg, shell_exit_slice(sh_lg.t[1], mid, std::size_t(n_c - 1)));
            }

            const double mb = 1e6;
            std::printf("Wang18 Fig. 20: multiple scattering (>= 3 events, no boundary bounce) of the bumpy sphere (%zu triangles), "
                        "radius %.0f green mfp, BmpS. albedo, g %.2f, eta 1.33; %d x %d pixels\n",
                        sc.shape.triangle_count(), R_opt, g, W, W);
            std::printf("  MS table %dx%d (rho, z) x %dx%d (theta, phi), %d photons: %.3f MB (%.2f s%s)\n", n_rho, n_z, n_theta, n_phi,
                        photons, double(table_bytes) / mb, cpu_table, cached ? ", cached" : "");
            std::printf("  shells: %d radii 1..%.1f mfp, n_c %d (equal %s cells), rank %d, %d paths per channel; equal memory n_u = n_v = %d: %.3f MB "
                        "(%.2f s, NMF error %.3f); large n_u = n_v = %d: %.3f MB = %.1fx (%.2f s, NMF error %.3f)\n",
                        shells, shell_rmax, n_c, cos_cells == "cos" ? "cos theta_1" : "theta_1", rank, shell_paths, nuv_eq, double(sh_eq.bytes) / mb, sh_eq.cpu, sh_eq.nmf_err, nuv_lg,
                        double(sh_lg.bytes) / mb, double(sh_lg.bytes) / double(table_bytes), sh_lg.cpu, sh_lg.nmf_err);
            std::printf("  %-14s %9s %10s %18s %10s %10s %9s\n", "method", "memory MB", "mean", "rel.diff (s.e.)", "e^2", "e^2 hp",
                        "hp ratio");
            gl_examples::Csv csv({"method", "memory_mb", "mean", "rel_diff", "rel_se", "mse", "e2", "e2_highpass", "highpass_ratio", "seconds"});
            struct Row {
                const char* name;
                double mbytes;
                const Errors& e;
                double sec;
            };
            const Row rows[] = {{"table", double(table_bytes) / mb, e_tab, pb.cpu_total()},
                                {"shells_equal", double(sh_eq.bytes) / mb, e_eq, run_eq.cpu},
                                {"shells_large", double(sh_lg.bytes) / mb, e_lg, run_lg.cpu}};
            for (const Row& r : rows) {
                std::printf("  %-14s %9.3f %10.5f %+9.1f%% (%4.1f%%) %10.3e %10.3e %9.2f\n", r.name, r.mbytes, r.e.mean, 100 * r.e.rel,
                            100 * r.e.rel_se, r.e.e2, r.e.e2_hp, r.e.hp_ratio);
                csv.row_text({r.name, std::to_string(r.mbytes), std::to_string(r.e.mean), std::to_string(r.e.rel), std::to_string(r.e.rel_se),
                              std::to_string(r.e.mse), std::to_string(r.e.e2), std::to_string(r.e.e2_hp), std::to_string(r.e.hp_ratio),
                              std::to_string(r.sec)});
            }
            std::printf("  %-14s %9s %10.5f (s.e. %.1e)\n", "VPT", "-", c.ref[2], c.ref_se[2]);
            std::printf("  hp ratio: high-pass energy of the image over the VPT's (noise removed; < 1 = blurred); e^2 hp: error of "
                        "the high-pass part\n");
            std::printf("  [paper Fig. 20 / Sec. 6.2.2: same memory -> shells blur multiple scattering; more memory -> visually "
                        "similar to the table; the shell table shows artefacts of its low angular resolution]\n");
            std::printf("  CPU: point-based %.2f s, shells equal %.2f s + %.2f s build, large %.2f s + %.2f s build, VPT %.2f s\n",
                        pb.cpu_total(), run_eq.cpu, sh_eq.cpu, run_lg.cpu, sh_lg.cpu, vpt.cpu);
            const auto csv_path = ex.csv("wang18_fig20_vs_shells.csv", csv);
            ex.plot("wang18_fig20_vs_shells", csv_path, out / "wang18_fig20_vs_shells.png", {out.string()});

            gl_examples::Json j = ex.summary();
            wang18::put_rank_rows(ex, j, W);
            j.integer("width", W).num("eps1", eps1).integer("table_theta", n_theta).integer("table_phi", n_phi).integer("vpt_spp", vpt_spp).integer("shell_spp", shell_spp).num("g", g);
            j.num("memory_ms_table_mb", double(table_bytes) / mb)
                .num("memory_shells_equal_mb", double(sh_eq.bytes) / mb)
                .num("memory_shells_large_mb", double(sh_lg.bytes) / mb)
                .integer("shells_equal_nuv", nuv_eq)
                .integer("shells_large_nuv", nuv_lg)
                .str("shell_cos_cells", cos_cells)
                .num("vpt_multiple", c.ref[2])
                .num("vpt_multiple_se", c.ref_se[2]);
            const char* keys[3] = {"table", "shells_equal", "shells_large"};
            for (int k = 0; k < 3; ++k) {
                const Errors& e = rows[k].e;
                const std::string s = keys[k];
                j.num("rel_diff_multiple_" + s, e.rel)
                    .num("rel_se_multiple_" + s, e.rel_se)
                    .num("e2_" + s, e.e2)
                    .num("e2_highpass_" + s, e.e2_hp)
                    .num("highpass_ratio_" + s, e.hp_ratio)
                    .num("seconds_" + s, rows[k].sec);
            }
            j.num("seconds_table_build", cpu_table)
                .num("seconds_shells_equal_build", sh_eq.cpu)
                .num("seconds_shells_large_build", sh_lg.cpu)
                .num("seconds_vpt", vpt.cpu)
                .num("nmf_error_shells_equal", sh_eq.nmf_err)
                .num("nmf_error_shells_large", sh_lg.nmf_err)
                .str("png", (out / "wang18_fig20_vs_shells.png").string());
            return ex.finish(j);
        });
}
