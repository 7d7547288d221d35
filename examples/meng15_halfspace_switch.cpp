// meng15_halfspace_switch: where the hybrid's VPT bias near a boundary comes from (issue 12).
//
// A half-space of grains (the `sand` preset by default: Meng15's SANDCASTLE grains; MD packing
// f = 0.6, unit grain radius, a box of side 2H and depth D standing in for the half-space y < 0)
// under a white sky of radiance 1: a path entering at incidence theta returns the directional-
// hemispherical reflectance of the half-space (reciprocity: the albedo for light from -d). Every
// path is traced by explicit path tracing of the grains (EPT, integrators/ept.hpp), the
// reference, and at the same time forked into continuations that replace EPT from some point on,
// each with its own random stream (the EPT prefix is shared, so differences are paired and their
// noise is that of the continuations only):
//
//   after k = 1, 2, 3 explicit grain interactions,
//   * vpt_entry_lib: the library's switch (integrators/hybrid.hpp hybrid_vpt_continuation): at the
//     next grain hit inside the boundary the grain interaction becomes a scattering event of the
//     effective medium (Meng15 Eq. 4 sigma_t, alpha_s, tabulated Phi), then VPT with NEE;
//   * vpt_entry: the same in a plain walk written here (no NEE; checks the library's walk);
//   * tt_entry: at the same grain hit, the teleportation-transport model (Meng15 Sec. 4.1,
//     media/teleportation.hpp TeleportationMedium): the grain interaction drawn from the
//     scatterometer's joint (direction, exit offset) table, then TT flights (Eq. 1 exponential
//     bounding-sphere encounters, pass-throughs from the recorded chords);
//   * vpt_exit / tt_exit: the two models from the exit point of interaction k (the point where
//     Eq. 4's flights between exit points start), with EPT's flight to the next grain replaced too.
//
// VPT and TT share alpha_s and the directions; they differ in the positions of events: TT keeps
// the teleport (mean lambda_s along the incident direction, Table 1) and the bounding-sphere
// encounters with their misses, VPT lumps both into one exponential flight per event (Eq. 4). So
// TT against EPT measures what the TT model itself misses (non-exponential flights between
// grains in a dense packing, correlations between a grain's teleport and the next flight), and
// VPT against TT what the reduction to the RTE loses. Reflectance of a half-space does not depend
// on the length scale of exponential flights, so Eq. 4's sigma_t cannot matter here; only the
// shape of the transport near the surface can.
//
//   meng15_halfspace_switch [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                           [--preset NAME] [--paths N] [--angles DEG,DEG] [--half-width H] [--depth D]
//
// Prints, per incidence angle, the EPT reflectance and each continuation's relative difference
// to it (paired standard error); writes a CSV; last line JSON.
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "meng15_scenes.hpp"

namespace gl = grainlight;
using namespace gl_examples;
namespace m15 = gl_examples::meng15;

namespace {

constexpr int kOrders = 3;  // switch after k = 1..kOrders explicit interactions
enum Variant : int { vpt_entry_lib = 0, vpt_entry_nomem, vpt_entry, vpt_mem_entry, tt_entry, vpt_exit, tt_exit, variants_per_k };
const char* const kVariantNames[variants_per_k] = {"vpt_entry_lib", "vpt_entry_nomem", "vpt_entry", "vpt_mem_entry", "tt_entry", "vpt_exit", "tt_exit"};
constexpr int kVariants = 1 + kOrders * variants_per_k;  // 0: EPT
int variant_index(int k, int v) { return 1 + (k - 1) * variants_per_k + v; }

/// Move a point above the plane y = 0 travelling down onto the plane (just below it). False if it
/// leaves upward (escape).
bool enter_half_space(gl::Vec3d& p, const gl::Vec3d& w) {
    if (p.y < 0.0) return true;
    if (w.y >= 0.0) return false;
    p += (p.y / -w.y) * w;
    p.y = -1e-9;
    return true;
}

/// Russian roulette on a throughput of at most a few units; false: the path ends.
template <class T>
bool roulette(T& beta_max_scaled, double b_max, gl::Rng& rng, int depth) {
    if (depth < 8) return true;
    const double q = std::min(1.0, b_max);
    if (!(rng.uniform<double>() < q)) return false;
    beta_max_scaled /= q;
    return true;
}

/// A scattering event of the effective medium in channel c: albedo, a direction from its phase
/// function (throughput b, direction w updated).
void scatter_effective(const m15::Grains& g, std::size_t c, gl::Vec3d& w, double& b, gl::Rng& rng) {
    b *= g.rte.alpha_s[c];
    const auto ps = g.medium.phase().sample(gl::Vec3f(w), rng.uniform2<float>());
    b *= double(ps.weight[c]);
    w = glm::normalize(gl::Vec3d(ps.w));
}

/// VPT of the effective medium in the half-space y < 0, one colour channel c, no NEE (the sky is
/// reached by escaping): returns the escaping throughput. `scatter_first`: the walk starts with a
/// scattering event at p (the hybrid's switch at a grain hit), else with a flight.
double vpt_walk(const m15::Grains& g, std::size_t c, gl::Vec3d p, gl::Vec3d w, double b, bool scatter_first, gl::Rng& rng,
                gl::Vec3d& w_escape) {
    const double sig = g.rte.sigma_t[c];
    auto scatter = [&]() { scatter_effective(g, c, w, b, rng); };
    if (scatter_first) scatter();
    w_escape = w;
    for (int depth = 0; depth < 100000; ++depth) {
        w_escape = w;
        if (!enter_half_space(p, w)) return b;
        const double t = -std::log1p(-rng.uniform<double>()) / sig;
        if (w.y > 0.0 && p.y + t * w.y >= 0.0) return b;
        p += t * w;
        scatter();
        if (!roulette(b, b, rng, depth)) return 0.0;
    }
    return 0.0;
}

/// A flight segment remembered by vpt_walk_memk.
struct Seg {
    gl::Vec3d a{0.0}, b{0.0};
};
struct SegHistory {
    std::array<Seg, 8> s{};
    int n = 0;  // segments stored (newest at (n - 1) % 8)
    void push(const gl::Vec3d& a, const gl::Vec3d& b) { s[std::size_t(n++ % 8)] = Seg{a, b}; }
};

/// vpt_walk with K flights of memory: a candidate collision at distance t is real with the
/// probability that a grain centre in the collision disc (radius R, perpendicular to the flight)
/// is not in one of the remembered flights' empty tubes (nor, with `boundary`, above the surface,
/// where no grain has its centre); 32 points of the disc (Vogel spiral).
double vpt_walk_memk(const m15::Grains& g, int K, int E, bool boundary, std::size_t c, gl::Vec3d p, gl::Vec3d w, double b,
                     SegHistory h, gl::Rng& rng) {
    const double sig = g.rte.sigma_t[c];
    const double R = 1.0;
    auto scatter = [&]() { scatter_effective(g, c, w, b, rng); };
    constexpr int N = 32;
    std::array<gl::Vec2d, N> disc;
    for (int i = 0; i < N; ++i) {
        const double r = std::sqrt((i + 0.5) / N), ph = i * 2.399963229728653;
        disc[std::size_t(i)] = gl::Vec2d(r * std::cos(ph), r * std::sin(ph));
    }
    auto in_tubes = [&](const gl::Vec3d& P) {
        const int m = std::min(K, std::min(h.n, 8));
        for (int j = 0; j < m; ++j) {
            const Seg& sg = h.s[std::size_t((h.n - 1 - j) % 8)];
            const gl::Vec3d ab = sg.b - sg.a;
            const double L2 = glm::dot(ab, ab);
            if (!(L2 > 0)) continue;
            const gl::Vec3d ap = P - sg.a;
            const double tau = glm::dot(ap, ab);
            if (tau < 0 || tau > L2) continue;
            if (glm::dot(ap, ap) - tau * tau / L2 < R * R) return true;
        }
        return false;
    };
    scatter();
    for (int depth = 0; depth < 100000; ++depth) {
        if (!enter_half_space(p, w)) return b;
        const gl::Frame<double> fr(w);
        double t = 0;
        bool escaped = false;
        for (;;) {
            t += -std::log1p(-rng.uniform<double>()) / sig;
            if (w.y > 0.0 && p.y + t * w.y >= 0.0) { escaped = true; break; }
            if (depth >= E) break;
            const gl::Vec3d q = p + t * w;
            int in = 0;
            for (int i = 0; i < N; ++i) {
                const gl::Vec3d x = q + R * fr.to_world(gl::Vec3d(disc[std::size_t(i)].x, disc[std::size_t(i)].y, 0.0));
                in += (in_tubes(x) || (boundary && x.y > 0.0)) ? 1 : 0;  // no grain centre above the surface
            }
            if (rng.uniform<double>() * N >= in) break;
        }
        if (escaped) return b;
        h.push(p, p + t * w);
        p += t * w;
        scatter();
        if (!roulette(b, b, rng, depth)) return 0.0;
    }
    return 0.0;
}

/// The teleportation-transport process in the half-space (RGB weights, grey distances).
/// `grain_first`: the walk starts with a grain interaction at p (entry point), else with a flight.
gl::RGBd tt_walk(const gl::TeleportationMedium<float>& tt, gl::Vec3d p, gl::Vec3d w, gl::RGBd b, bool grain_first,
                 gl::Rng& rng, gl::Vec3d& w_escape) {
    auto apply = [&](const auto& it) {
        if (it.kind != gl::EventKind::scatter) return false;
        for (std::size_t c = 0; c < 3; ++c) b[c] *= double(it.weight[c]);
        p = gl::Vec3d(it.p);
        w = glm::normalize(gl::Vec3d(it.w));
        return true;
    };
    if (grain_first && !apply(tt.grain_interaction(gl::Vec3f(p), gl::Vec3f(w), rng))) return gl::RGBd{0.0};
    for (int depth = 0; depth < 100000; ++depth) {
        w_escape = w;
        if (!enter_half_space(p, w)) return b;
        const float t_max = w.y > 0.0 ? float(-p.y / w.y) : std::numeric_limits<float>::infinity();
        const auto it = tt.sample_interaction(gl::Ray<float>(gl::Vec3f(p), gl::Vec3f(w)), t_max, rng);
        if (it.kind == gl::EventKind::escape) return b;
        if (!apply(it)) return gl::RGBd{0.0};
        const double bm = std::max({b[0], b[1], b[2]});
        if (depth >= 8) {
            const double q = std::min(1.0, bm);
            if (!(rng.uniform<double>() < q)) return gl::RGBd{0.0};
            for (std::size_t c = 0; c < 3; ++c) b[c] /= q;
        }
    }
    return gl::RGBd{0.0};
}

gl::RGBd to_rgbd(const gl::RGB& s) { return gl::RGBd{double(s[0]), double(s[1]), double(s[2])}; }
double mean3(const gl::RGBd& s) { return (s[0] + s[1] + s[2]) / 3.0; }

struct Sums {
    double n = 0;
    std::array<std::array<double, 3>, kVariants> est{};  // sum of the estimate per channel
    std::array<double, kVariants> diff{}, diff2{};      // sum of (channel mean - EPT's) and its square
    std::array<double, kVariants> n_switch{};           // paths that reached the fork
    double ept2 = 0;                                    // sum of EPT's channel mean squared
    // Reflected light by the angle psi between the escape direction and the reversed incident
    // direction (kDirBins bins of 180 / kDirBins degrees): EPT, and the k = 1 continuations.
    std::array<std::array<double, 12>, 4> dir{};
};
constexpr int kDirBins = 12;
enum DirSeries : int { dir_ept = 0, dir_vpt_entry, dir_vpt_exit, dir_tt_exit };
const char* const kDirNames[4] = {"ept", "vpt_entry", "vpt_exit", "tt_exit"};

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_halfspace_switch",
               "Meng15 hybrid near a boundary: EPT vs VPT and TT continuations in a half-space of grains",
               "out/meng15_halfspace_switch", [&](Example& ex) -> int {
        const std::string preset = ex.opt<std::string>("preset", "sand", "grain preset (geometry/grains.hpp)");
        const long long paths = ex.opt<long long>("paths", 100000, 2000000, "paths per incidence angle");
        const std::string angles_text = ex.opt<std::string>("angles", "0,60", "incidence angles in degrees, comma separated");
        const double H = ex.opt<double>("half-width", 300.0, 1000.0, "half-width of the half-space box, grain radii");
        const double D = ex.opt<double>("depth", 300.0, 1000.0, "depth of the half-space box, grain radii");
        const int level = ex.opt<int>("grain-level", 3, 4, "icosphere level of the grain mesh");
        const int mem_k = ex.opt<int>("flight-memory", gl::HybridOptions{}.flight_memory, gl::HybridOptions{}.flight_memory,
                                      "flights remembered by the continuations with flight memory (HybridOptions::flight_memory)");
        const int mem_e = ex.opt<int>("flight-memory-flights", gl::HybridOptions{}.flight_memory_flights,
                                      gl::HybridOptions{}.flight_memory_flights,
                                      "flights of those continuations that use the memory (HybridOptions::flight_memory_flights)");
        const bool mem_boundary = ex.opt<bool>(
            "flight-memory-boundary", gl::HybridOptions{}.flight_memory_boundary,
            "while the memory is active, no grain centre above the surface (HybridOptions::flight_memory_boundary)");
        ex.ready();
        if (paths < 100 || paths > 1000000000LL) throw cli_error("--paths = " + std::to_string(paths) + " must be in [100, 1e9]");
        if (!(H >= 20 && H <= 1e5)) throw cli_error("--half-width = " + ex.given_text("half-width") + " must be in [20, 1e5]");
        if (!(D >= 20 && D <= 1e5)) throw cli_error("--depth = " + ex.given_text("depth") + " must be in [20, 1e5]");
        if (level < 1 || level > 5) throw cli_error("--grain-level must be in [1, 5]");
        if (mem_k < 0 || mem_k > gl::FlightMemory::capacity)
            throw cli_error("--flight-memory = " + std::to_string(mem_k) + " must be in [0, " + std::to_string(gl::FlightMemory::capacity) + "]");
        if (mem_e < 0) throw cli_error("--flight-memory-flights = " + std::to_string(mem_e) + " must be >= 0");
        std::vector<double> angles;
        {
            std::stringstream ss(angles_text);
            std::string item;
            while (std::getline(ss, item, ',')) {
                const double a = std::stod(item);
                if (!(a >= 0 && a < 89)) throw cli_error("--angles: " + item + " must be in [0, 89)");
                angles.push_back(a);
            }
            if (angles.empty()) throw cli_error("--angles: at least one angle");
        }
        const std::uint64_t seed = ex.seed();

        const m15::Grains g = m15::make_grains(gl::grain_preset(preset), seed, ex.full(), level);
        const gl::BoxBoundary shape(gl::Vec3d(-H, -D, -H), gl::Vec3d(H, 0.0, H));
        const gl::GranularAggregate<gl::BoxBoundary> agg = g.aggregate(shape, seed);
        const gl::TeleportationMedium<float> tt(g.stats, g.tile.packing_fraction(), 1.0);
        m15::SceneT ept;
        ept.add_light(m15::SceneT::LightT::environment_light(gl::RGB{1.0f, 1.0f, 1.0f}));
        m15::SceneT vpt = ept;
        const int m = vpt.add_medium(g.medium);
        const int b = vpt.add_shape(gl::BoxShape<float>(gl::Vec3f(shape.lo), gl::Vec3f(shape.hi)),
                                    gl::Material<float, gl::RGB>::index_matched(), m, -1);
        const gl::HybridContext<gl::BoundaryDistance<gl::BoxBoundary>> ctx{m, b, {shape}, nullptr};
        gl::HybridOptions hopt;
        hopt.mode = gl::HybridMode::ept_vpt;
        hopt.vpt.max_depth = 1 << 20;  // no truncation (the library's default of 256 events cuts high-albedo paths)
        hopt.flight_memory = mem_k;
        hopt.flight_memory_flights = mem_e;
        hopt.flight_memory_boundary = mem_boundary;
        const gl::CentresInside<gl::BoxBoundary, gl::BoundaryDistance<gl::BoxBoundary>> centres{&shape, &ctx.distance};
        gl::HybridOptions hopt_nomem = hopt;
        hopt_nomem.flight_memory = 0;  // Meng15's memoryless VPT
        gl::EptOptions eopt;
        eopt.max_events = 1 << 20;

        std::printf("Half-space of %s grains (f = %.3f, %zu per tile), box %.0f x %.0f x %.0f grain radii, white sky\n",
                    preset.c_str(), g.tile.packing_fraction(), g.tile.size(), 2 * H, D, 2 * H);
        std::printf("effective medium (Eq. 4): alpha_s = %.3f %.3f %.3f, 1/sigma_t = %.3f R (green), g = %.3f; "
                    "TT: beta = %.3f, lambda_s = %.3f R, lambda_beta = %.3f R\n",
                    g.rte.alpha_s[0], g.rte.alpha_s[1], g.rte.alpha_s[2], 1.0 / g.rte.sigma_t[1], g.rte.g[1], g.stats.beta(),
                    g.rte.lambda_s[1], g.rte.lambda_beta);

        Json j = ex.summary();
        j.str("preset", preset).integer("paths", paths).num("packing_rate", g.tile.packing_fraction());
        Csv csv({"theta_deg", "k", "variant", "reflectance", "rel_diff", "rel_diff_stderr", "switched_fraction"});
        Csv dir_csv({"theta_deg", "psi_deg_low", "ept", "vpt_entry_k1", "vpt_exit_k1", "tt_exit_k1"});
        std::string per_angle = "{";
        double worst_tt_exit = 0;
        for (std::size_t ai = 0; ai < angles.size(); ++ai) {
            const double th = angles[ai] * gl::pi_v<double> / 180.0;
            const gl::Vec3d d0(std::sin(th), -std::cos(th), 0.0);
            const double W = 0.25 * H;  // entry points spread over the packing
            const Sums s = ex.parallel<Sums>(
                "half-space " + std::to_string(int(angles[ai])) + " deg", std::uint64_t(paths), 500,
                [&](std::uint64_t, std::uint64_t begin, std::uint64_t end) {
                    Sums part;
                    for (std::uint64_t i = begin; i < end; ++i) {
                        gl::Rng rng = gl::Rng::from_key(seed, i, 0x68616c66ull + ai);
                        const gl::Vec3d o((2 * rng.uniform<double>() - 1) * W, 2.0, (2 * rng.uniform<double>() - 1) * W);
                        auto ps = gl::EptPathState<gl::RGB>::start(gl::Ray<float>(gl::Vec3f(o), gl::Vec3f(d0)),
                                                                   std::numeric_limits<int>::max());
                        gl::RGB low(0.0f), high(0.0f);
                        std::uint64_t grain_rays = 0;
                        std::array<gl::RGBd, kVariants> est{};
                        std::array<bool, kVariants> forked{};
                        std::array<std::array<double, kDirBins>, 4> dir{};  // this path's reflected light by psi
                        auto psi_bin = [&](const gl::Vec3d& w) {
                            const double c = std::clamp(-glm::dot(glm::normalize(w), d0), -1.0, 1.0);
                            return std::min(kDirBins - 1, int(std::acos(c) / gl::pi_v<double> * kDirBins));
                        };
                        auto fork_rng = [&](int vi) { return gl::Rng::from_key(seed ^ 0x5eedf0cull, i, std::uint64_t(vi) * 64 + ai); };
                        SegHistory hist;
                        gl::FlightMemory lib_hist;
                        lib_hist.radius = 1.0;
                        auto policy = [&](const gl::EptPathState<gl::RGB>& st, const gl::Vec3d& x, bool same) {
                            if (!same) {
                                hist.push(st.p, x);
                                lib_hist.push(st.p, x);
                            }
                            if (same || !shape.inside(x)) return gl::EptSwitch::stay;
                            for (int k = 1; k <= kOrders; ++k) {
                                const int v0 = variant_index(k, vpt_entry_lib);
                                if (forked[std::size_t(v0)] || st.order < k) continue;
                                const gl::RGBd base = to_rgbd(low + high);
                                const gl::RGBd beta = to_rgbd(st.beta);
                                {
                                    gl::Rng r = fork_rng(v0);
                                    est[std::size_t(v0)] =
                                        base + to_rgbd(gl::hybrid_vpt_continuation(vpt, ctx, x, st.d, st.beta, r, hopt, nullptr, nullptr,
                                                                                   &lib_hist, centres));
                                }
                                {
                                    const int vi = variant_index(k, vpt_entry_nomem);
                                    gl::Rng r = fork_rng(vi);
                                    est[std::size_t(vi)] =
                                        base + to_rgbd(gl::hybrid_vpt_continuation(vpt, ctx, x, st.d, st.beta, r, hopt_nomem));
                                }
                                {
                                    const int vi = variant_index(k, vpt_entry);
                                    gl::Rng r = fork_rng(vi);
                                    gl::RGBd e = base;
                                    for (std::size_t c = 0; c < 3; ++c) {
                                        gl::Vec3d we(0.0);
                                        const double y = vpt_walk(g, c, x, st.d, beta[c], true, r, we);
                                        e[c] += y;
                                        if (k == 1) dir[dir_vpt_entry][std::size_t(psi_bin(we))] += y / 3.0;
                                    }
                                    est[std::size_t(vi)] = e;
                                }
                                {
                                    const int vi = variant_index(k, tt_entry);
                                    gl::Rng r = fork_rng(vi);
                                    gl::Vec3d we(0.0);
                                    est[std::size_t(vi)] = base + tt_walk(tt, x, st.d, beta, true, r, we);
                                }
                                {
                                    const int vi = variant_index(k, vpt_mem_entry);
                                    gl::Rng r = fork_rng(vi);
                                    gl::RGBd e = base;
                                    for (std::size_t c = 0; c < 3; ++c) e[c] += vpt_walk_memk(g, mem_k, mem_e, hopt.flight_memory_boundary, c, x, st.d, beta[c], hist, r);
                                    est[std::size_t(vi)] = e;
                                    forked[std::size_t(vi)] = true;
                                }
                                for (int v : {int(vpt_entry_lib), int(vpt_entry_nomem), int(vpt_entry), int(tt_entry)}) forked[std::size_t(variant_index(k, v))] = true;
                            }
                            return gl::EptSwitch::stay;
                        };
                        gl::Vec3d x_unused(0.0);
                        for (;;) {
                            const int order_before = ps.order;
                            const gl::EptStep r = gl::ept_step(ept, agg, ps, low, high, grain_rays, rng, eopt, policy, x_unused);
                            if (r != gl::EptStep::next) break;
                            if (ps.order == order_before || !ps.have_last_grain) continue;
                            // ps.p: the exit point of interaction ps.order (its bounding sphere), ps.d its direction.
                            for (int k = 1; k <= kOrders; ++k) {
                                const int v0 = variant_index(k, vpt_exit);
                                if (forked[std::size_t(v0)] || ps.order < k) continue;
                                const gl::RGBd base = to_rgbd(low + high);
                                const gl::RGBd beta = to_rgbd(ps.beta);
                                {
                                    gl::Rng r = fork_rng(v0);
                                    gl::RGBd e = base;
                                    for (std::size_t c = 0; c < 3; ++c) {
                                        gl::Vec3d we(0.0);
                                        const double y = vpt_walk(g, c, ps.p, ps.d, beta[c], false, r, we);
                                        e[c] += y;
                                        if (k == 1) dir[dir_vpt_exit][std::size_t(psi_bin(we))] += y / 3.0;
                                    }
                                    est[std::size_t(v0)] = e;
                                }
                                {
                                    const int vi = variant_index(k, tt_exit);
                                    gl::Rng rr = fork_rng(vi);
                                    gl::Vec3d we(0.0);
                                    const gl::RGBd y = tt_walk(tt, ps.p, ps.d, beta, false, rr, we);
                                    est[std::size_t(vi)] = base + y;
                                    if (k == 1) dir[dir_tt_exit][std::size_t(psi_bin(we))] += mean3(y);
                                }
                                forked[std::size_t(v0)] = forked[std::size_t(variant_index(k, tt_exit))] = true;
                            }
                        }
                        est[0] = to_rgbd(low + high);
                        const double y0 = mean3(est[0]);
                        // EPT gathers light only where it escapes to the sky (no diffuse grain surface: no NEE),
                        // in its last direction.
                        dir[dir_ept][std::size_t(psi_bin(ps.d))] += y0;
                        for (int sidx = 1; sidx < 4; ++sidx) {
                            const int vi = variant_index(1, sidx == dir_vpt_entry ? vpt_entry : sidx == dir_vpt_exit ? vpt_exit : tt_exit);
                            if (!forked[std::size_t(vi)]) dir[std::size_t(sidx)][std::size_t(psi_bin(ps.d))] += y0;
                        }
                        for (int sidx = 0; sidx < 4; ++sidx)
                            for (int bI = 0; bI < kDirBins; ++bI) part.dir[std::size_t(sidx)][std::size_t(bI)] += dir[std::size_t(sidx)][std::size_t(bI)];
                        part.n += 1;
                        part.ept2 += y0 * y0;
                        for (int v = 0; v < kVariants; ++v) {
                            if (v > 0 && !forked[std::size_t(v)]) est[std::size_t(v)] = est[0];  // never switched: EPT's path
                            if (forked[std::size_t(v)]) part.n_switch[std::size_t(v)] += 1;
                            const double dv = mean3(est[std::size_t(v)]) - y0;
                            for (std::size_t c = 0; c < 3; ++c) part.est[std::size_t(v)][c] += est[std::size_t(v)][c];
                            part.diff[std::size_t(v)] += dv;
                            part.diff2[std::size_t(v)] += dv * dv;
                        }
                    }
                    return part;
                },
                [](Sums& acc, const Sums& p) {
                    acc.n += p.n;
                    acc.ept2 += p.ept2;
                    for (int sidx = 0; sidx < 4; ++sidx)
                        for (int bI = 0; bI < kDirBins; ++bI) acc.dir[std::size_t(sidx)][std::size_t(bI)] += p.dir[std::size_t(sidx)][std::size_t(bI)];
                    for (int v = 0; v < kVariants; ++v) {
                        for (std::size_t c = 0; c < 3; ++c) acc.est[std::size_t(v)][c] += p.est[std::size_t(v)][c];
                        acc.diff[std::size_t(v)] += p.diff[std::size_t(v)];
                        acc.diff2[std::size_t(v)] += p.diff2[std::size_t(v)];
                        acc.n_switch[std::size_t(v)] += p.n_switch[std::size_t(v)];
                    }
                });
            const double n = s.n;
            auto refl = [&](int v) { return (s.est[std::size_t(v)][0] + s.est[std::size_t(v)][1] + s.est[std::size_t(v)][2]) / (3 * n); };
            const double r0 = refl(0);
            const double r0_se = std::sqrt(std::max(0.0, s.ept2 / n - r0 * r0) / n);
            std::printf("\ntheta = %.0f deg: EPT reflectance %.5f +- %.5f (R G B %.4f %.4f %.4f), %.0f paths\n", angles[ai], r0,
                        r0_se, s.est[0][0] / n, s.est[0][1] / n, s.est[0][2] / n, n);
            std::printf("  relative difference to EPT (paired standard error), by explicit interactions k before the switch:\n");
            std::printf("  %-3s", "k");
            for (int v = 0; v < variants_per_k; ++v) std::printf(" %22s", kVariantNames[v]);
            std::printf(" %10s\n", "switched");
            std::string ak = "{\"reflectance_ept\":" + std::to_string(r0) + ",\"reflectance_ept_stderr\":" + std::to_string(r0_se);
            for (int k = 1; k <= kOrders; ++k) {
                std::printf("  %-3d", k);
                for (int v = 0; v < variants_per_k; ++v) {
                    const int vi = variant_index(k, v);
                    const double md = s.diff[std::size_t(vi)] / n;
                    const double se = std::sqrt(std::max(0.0, s.diff2[std::size_t(vi)] / n - md * md) / n);
                    const double rel = md / r0, rel_se = se / r0;
                    char cell[64];
                    std::snprintf(cell, sizeof cell, "%+.2f +- %.2f %%", 100 * rel, 100 * rel_se);
                    std::printf(" %22s", cell);
                    const std::string key = std::string(kVariantNames[v]) + "_k" + std::to_string(k);
                    ak += ",\"rel_diff_" + key + "\":" + std::to_string(rel) + ",\"rel_diff_" + key + "_stderr\":" + std::to_string(rel_se);
                    csv.row({angles[ai], double(k), double(v), refl(vi), rel, rel_se, s.n_switch[std::size_t(vi)] / n});
                    if (v == tt_exit) worst_tt_exit = std::max(worst_tt_exit, std::abs(rel));
                }
                std::printf(" %9.3f\n", s.n_switch[std::size_t(variant_index(k, vpt_entry_lib))] / n);
            }
            std::printf("  reflected light by the angle psi between the escape direction and the reversed incident direction "
                        "(k = 1; share of EPT's total, and each continuation / EPT in that bin):\n  %-10s %8s", "psi [deg]", "EPT");
            for (int sidx = 1; sidx < 4; ++sidx) std::printf(" %10s", kDirNames[sidx]);
            std::printf("\n");
            for (int bI = 0; bI < kDirBins; ++bI) {
                const double e = s.dir[dir_ept][std::size_t(bI)] / n;
                if (!(e > 0)) continue;
                std::printf("  %3d-%-6d %8.4f", bI * 180 / kDirBins, (bI + 1) * 180 / kDirBins, e / r0);
                for (int sidx = 1; sidx < 4; ++sidx) std::printf(" %10.3f", s.dir[std::size_t(sidx)][std::size_t(bI)] / n / e);
                std::printf("\n");
                dir_csv.row({angles[ai], double(bI) * 180.0 / kDirBins, e, s.dir[1][std::size_t(bI)] / n, s.dir[2][std::size_t(bI)] / n,
                             s.dir[3][std::size_t(bI)] / n});
            }
            if (ai == 0) {  // flat keys of the first angle (ctest checks)
                auto rel = [&](int k, int v) { return s.diff[std::size_t(variant_index(k, v))] / n / r0; };
                auto rel_se = [&](int k, int v) {
                    const int vi = variant_index(k, v);
                    const double md = s.diff[std::size_t(vi)] / n;
                    return std::sqrt(std::max(0.0, s.diff2[std::size_t(vi)] / n - md * md) / n) / r0;
                };
                j.num("theta_deg", angles[0])
                    .num("reflectance_ept", r0)
                    .num("rel_diff_vpt_k1", rel(1, vpt_entry_lib))
                    .num("rel_diff_vpt_k1_stderr", rel_se(1, vpt_entry_lib))
                    .num("rel_diff_vpt_plain_k1", rel(1, vpt_entry))
                    .num("rel_diff_vpt_nomem_k1", rel(1, vpt_entry_nomem))
                    .num("rel_diff_vpt_nomem_k1_stderr", rel_se(1, vpt_entry_nomem))
                    .num("rel_diff_vpt_mem_plain_k1", rel(1, vpt_mem_entry))
                    .num("rel_diff_vpt_nomem_k3", rel(3, vpt_entry_nomem))
                    .num("rel_diff_vpt_k2", rel(2, vpt_entry_lib))
                    .num("rel_diff_vpt_k3", rel(3, vpt_entry_lib))
                    .num("rel_diff_vpt_k3_stderr", rel_se(3, vpt_entry_lib))
                    .num("rel_diff_tt_entry_k1", rel(1, tt_entry))
                    .num("rel_diff_tt_exit_k1", rel(1, tt_exit))
                    .num("rel_diff_vpt_exit_k1", rel(1, vpt_exit));
            }
            ak += "}";
            per_angle += std::string(ai ? "," : "") + "\"theta_" + std::to_string(int(angles[ai])) + "\":" + ak;
        }
        per_angle += "}";
        std::printf("\nvariant codes in the CSV: 0 vpt_entry_lib, 1 vpt_entry_nomem, 2 vpt_entry, 3 vpt_mem_entry, 4 tt_entry, 5 vpt_exit, 6 tt_exit\n");
        const auto csv_path = ex.csv("meng15_halfspace_switch.csv", csv);
        const auto dir_path = ex.csv("meng15_halfspace_switch_directions.csv", dir_csv);
        std::printf("wrote %s and %s\n", csv_path.c_str(), dir_path.c_str());
        j.raw("angles", per_angle);
        j.num("max_abs_rel_diff_tt_exit", worst_tt_exit);
        return ex.finish(j);
    });
}
