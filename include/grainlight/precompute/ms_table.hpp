/// @file grainlight/precompute/ms_table.hpp
/// Precomputed multiple-scattering response of a homogeneous medium (Wang & Holzschuch 2018,
/// Sec. 3.5.4 and 5.2, used by Eq. 7).
///
/// Set-up (units of the mean free path l = 1/sigma_t, so one table serves every sigma_t): a unit
/// of power is scattered at the origin by light travelling along +z (the phase function picks the
/// first direction); particles then propagate in an infinite medium of albedo alpha with the
/// library's walk kernel (integrators/walk.hpp) and ContinuousMedium. At every scattering event
/// after the first collision (order >= 2 after the source, i.e. >= 3 scatterings in all when the
/// source is itself a scattering event: Wang18's "multiple" term; the first collision is the
/// double-scattering term of Eq. 6), the event is tallied with its incoming direction. The
/// table stores the in-scattering emission density
///
///     L_o(rho, z, omega) = sigma_s int p(omega', omega) L_ms(x, omega') d omega'
///
/// in 1 / (l^3 sr) per unit source power, on a cylindrical grid (rho in [0, rho_max], z in
/// [z_min, z_max], cell centres, bilinear lookup) times a direction grid (theta of omega to +z,
/// phi of omega to the radial direction folded into [0, pi] by mirror symmetry; nearest bin).
/// The incoming directions are histogrammed on the same direction grid and convolved with the
/// phase function after the walk (a precomputed bin-to-bin phase matrix).
///
/// Physical use (Eq. 7): a source of scattered power P_s = sigma_s Phi Delta at x_v with incoming
/// direction d_v gives emission density P_s sigma_t^3 L_o(rho sigma_t, z sigma_t, omega) at P,
/// with z = (P - x_v).d_v, rho = |P - x_v - z d_v|. Outside the grid: 0. Particles farther than
/// `escape_radius` mean free paths from the origin are dropped (they rarely return).
///
/// Closed-form check (tests): integrating L_o over the grid and all directions gives the scattered
/// power of orders >= 2, alpha^2 / (1 - alpha) per unit source power, minus what leaves the grid.
///
/// File: the shared container (core/serialization.hpp), kind "MSTB", version 1. Payload:
/// u32 channels, n_rho, n_z, n_theta, n_phi; f64 rho_max, z_min, z_max, mean_cosine; f64
/// albedo[channels]; u64 photons; u64 count; f32 values[count] (count = channels n_z n_rho
/// n_theta n_phi, index ((c n_z + iz) n_rho + ir) n_theta n_phi + it n_phi + ip).
#pragma once

#include <algorithm>
#include <array>
#include <type_traits>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/core/serialization.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Options of the table precomputation.
struct MsTableOptions {
    int n_rho = 32;             ///< radial cells (paper: 1024)
    int n_z = 64;               ///< axial cells (paper: 512)
    int n_theta = 16;           ///< polar direction bins (paper: 18)
    int n_phi = 8;              ///< azimuth bins over [0, pi] (paper: 36 over [0, 2 pi])
    double rho_max = 8.0;       ///< radial extent (mean free paths)
    double z_min = -8.0;        ///< axial extent (mean free paths)
    double z_max = 8.0;
    std::uint64_t photons = 200000;  ///< source particles
    double escape_radius = 24.0;     ///< particles beyond this distance (mfp) are dropped
    std::uint64_t seed = 1;
    int blocks = 16;            ///< fixed number of tally blocks (deterministic for any thread count)
};

/// The table (see the file comment). N = number of channels.
template <std::size_t N>
class MsTable {
public:
    static constexpr std::uint32_t file_kind = fourcc("MSTB");
    static constexpr std::uint32_t file_version = 1;

    MsTable() = default;

    /// Precompute with the walk kernel. `phase` is any PhaseFunction over Spectrum<N, double>-
    /// compatible float type F; `albedo` per channel in [0, 1). Throws invalid_argument on bad
    /// options.
    template <class Phase>
    [[nodiscard]] static MsTable build(const Phase& phase, const Spectrum<N, typename Phase::Float>& albedo,
                                       const MsTableOptions& opt) {
        using F = typename Phase::Float;
        using S = Spectrum<N, F>;
        static_assert(std::is_same_v<typename Phase::Spectrum, S>,
                      "MsTable::build: the phase function's spectrum must be Spectrum<N, F>");
        check_argument(opt.n_rho >= 1 && opt.n_rho <= 4096, "MsTable::build", "n_rho", opt.n_rho, "[1, 4096]");
        check_argument(opt.n_z >= 1 && opt.n_z <= 4096, "MsTable::build", "n_z", opt.n_z, "[1, 4096]");
        check_argument(opt.n_theta >= 1 && opt.n_theta <= 256, "MsTable::build", "n_theta", opt.n_theta, "[1, 256]");
        check_argument(opt.n_phi >= 1 && opt.n_phi <= 256, "MsTable::build", "n_phi", opt.n_phi, "[1, 256]");
        check_argument(std::isfinite(opt.rho_max) && opt.rho_max > 0, "MsTable::build", "rho_max", opt.rho_max,
                       "(0, inf)");
        check_argument(std::isfinite(opt.z_min) && std::isfinite(opt.z_max) && opt.z_max > opt.z_min,
                       "MsTable::build", "z_max", opt.z_max, "(z_min, inf)");
        check_argument(opt.photons >= 1, "MsTable::build", "photons", double(opt.photons), ">= 1");
        check_argument(opt.blocks >= 1 && opt.blocks <= 1024, "MsTable::build", "blocks", opt.blocks, "[1, 1024]");
        check_argument(opt.escape_radius > 0, "MsTable::build", "escape_radius", opt.escape_radius, "(0, inf)");
        for (std::size_t c = 0; c < N; ++c)
            check_argument(albedo[c] >= F(0) && albedo[c] < F(1), "MsTable::build", "albedo", double(albedo[c]),
                           "[0, 1)");

        MsTable t;
        t.n_rho_ = std::uint32_t(opt.n_rho);
        t.n_z_ = std::uint32_t(opt.n_z);
        t.n_theta_ = std::uint32_t(opt.n_theta);
        t.n_phi_ = std::uint32_t(opt.n_phi);
        t.rho_max_ = opt.rho_max;
        t.z_min_ = opt.z_min;
        t.z_max_ = opt.z_max;
        t.g_ = double(phase.mean_cosine()[0]);
        for (std::size_t c = 0; c < N; ++c) t.albedo_[c] = double(albedo[c]);
        t.photons_ = opt.photons;
        t.set_derived();
        const std::size_t n_dir = std::size_t(opt.n_theta) * std::size_t(opt.n_phi);
        const std::size_t n_cell = std::size_t(opt.n_rho) * std::size_t(opt.n_z);

        // Incoming-direction histograms, one per block, summed in block order.
        using Medium = ContinuousMedium<Phase, S>;
        const Medium medium(S(F(1)), albedo, phase);
        const InfiniteMediumScene<Medium> scene{medium};
        std::vector<std::vector<double>> hist(std::size_t(opt.blocks));
        const std::uint64_t per_block = (opt.photons + std::uint64_t(opt.blocks) - 1) / std::uint64_t(opt.blocks);
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (int b = 0; b < opt.blocks; ++b) {
            std::vector<double>& h = hist[std::size_t(b)];
            h.assign(N * n_cell * n_dir, 0.0);
            const std::uint64_t p0 = std::uint64_t(b) * per_block;
            const std::uint64_t p1 = std::min(opt.photons, p0 + per_block);
            Tally<F, S> tally{t, h, opt.escape_radius * opt.escape_radius};
            WalkOptions<F> wopt;
            wopt.mode = TransportMode::importance;
            wopt.rr_depth = 1 << 20;
            for (std::uint64_t i = p0; i < p1; ++i) {
                Rng rng = Rng::from_key(opt.seed, 0x4d5354ull, i);
                const auto ps = phase.sample(Vec3<F>(F(0), F(0), F(1)), rng.template uniform2<F>());
                if (!(ps.pdf > F(0))) continue;
                PathState<F, S> st = start_path<F, S>(Ray<F>(Vec3<F>(F(0)), ps.w), 0, S(F(1)) * ps.weight);
                (void)walk(scene, st, rng, tally, wopt);
            }
        }
        std::vector<double> sum(N * n_cell * n_dir, 0.0);
        for (const auto& h : hist)
            for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += h[i];

        // Phase matrix between direction bins, averaged over the mirror images (+phi, -phi).
        std::vector<double> pm(n_dir * n_dir);
        for (std::size_t i = 0; i < n_dir; ++i) {
            const Vec3<double> wi = t.bin_direction(i, false), wi2 = t.bin_direction(i, true);
            for (std::size_t j = 0; j < n_dir; ++j) {
                const Vec3<double> wj = t.bin_direction(j, false);
                const auto a = phase.eval(Vec3<F>(wi), Vec3<F>(wj)).value[0];
                const auto b = phase.eval(Vec3<F>(wi2), Vec3<F>(wj)).value[0];
                pm[i * n_dir + j] = 0.5 * (double(a) + double(b));
            }
        }
        t.values_.assign(N * n_cell * n_dir, 0.0f);
        const double dr = opt.rho_max / opt.n_rho, dz = (opt.z_max - opt.z_min) / opt.n_z;
        for (std::size_t c = 0; c < N; ++c)
            for (std::size_t iz = 0; iz < std::size_t(opt.n_z); ++iz)
                for (std::size_t ir = 0; ir < std::size_t(opt.n_rho); ++ir) {
                    const double r0 = double(ir) * dr, r1 = r0 + dr;
                    const double vol = pi_v<double> * (r1 * r1 - r0 * r0) * dz;
                    const std::size_t base = ((c * opt.n_z + iz) * opt.n_rho + ir) * n_dir;
                    for (std::size_t j = 0; j < n_dir; ++j) {
                        double acc = 0;
                        for (std::size_t i = 0; i < n_dir; ++i) acc += sum[base + i] * pm[i * n_dir + j];
                        t.values_[base + j] = float(acc / (double(opt.photons) * vol));
                    }
                }
        return t;
    }

    /// Emission density L_o (1 / (l^3 sr) per unit source power) of channel c at cylindrical
    /// coordinates (rho, z) in mean free paths, for outgoing direction with cosine `cos_theta` to
    /// the axis and azimuth `phi` in [0, pi] to the radial direction. 0 outside the grid.
    [[nodiscard]] double eval(std::size_t c, double rho, double z, double cos_theta, double phi) const noexcept {
        if (values_.empty()) return 0.0;
        return eval_bin(c, rho, z, direction_bin(cos_theta, phi));
    }

    /// Index of the direction bin of (cos_theta, phi) (nearest bin), for eval_bin: compute it once
    /// for all channels.
    [[nodiscard]] std::size_t direction_bin(double cos_theta, double phi) const noexcept {
        const double theta = std::acos(std::clamp(cos_theta, -1.0, 1.0));
        const std::size_t it = std::min<std::size_t>(n_theta_ - 1, std::size_t(theta / pi_v<double> * n_theta_));
        const std::size_t ip =
            std::min<std::size_t>(n_phi_ - 1, std::size_t(std::clamp(phi, 0.0, pi_v<double>) / pi_v<double> * n_phi_));
        return it * n_phi_ + ip;
    }

    /// As eval, with the direction bin j = direction_bin(cos_theta, phi) (bilinear in rho, z).
    [[nodiscard]] double eval_bin(std::size_t c, double rho, double z, std::size_t j) const noexcept {
        if (values_.empty() || !(rho >= 0) || rho > rho_max_ || z < z_min_ || z > z_max_) return 0.0;
        const double fr = rho * inv_dr_ - 0.5, fz = (z - z_min_) * inv_dz_ - 0.5;
        const int r0 = int(std::floor(fr)), z0 = int(std::floor(fz));
        const double ar = fr - r0, az = fz - z0;
        const int ra = std::max(r0, 0), rb = std::min(r0 + 1, int(n_rho_) - 1);
        const int za = std::max(z0, 0), zb = std::min(z0 + 1, int(n_z_) - 1);
        const std::size_t nd = std::size_t(n_theta_) * n_phi_;
        const float* base = values_.data() + c * n_z_ * n_rho_ * nd + j;
        auto at = [&](int iz, int ir) { return double(base[(std::size_t(iz) * n_rho_ + std::size_t(ir)) * nd]); };
        return (1 - az) * ((1 - ar) * at(za, ra) + ar * at(za, rb)) + az * ((1 - ar) * at(zb, ra) + ar * at(zb, rb));
    }

    /// Integral of L_o over the grid volume and all directions for channel c (per unit source
    /// power): the scattered power of orders >= 2 that stays on the grid.
    [[nodiscard]] double total(std::size_t c) const noexcept {
        const double dr = rho_max_ / n_rho_, dz = (z_max_ - z_min_) / n_z_;
        double s = 0;
        for (std::size_t iz = 0; iz < n_z_; ++iz)
            for (std::size_t ir = 0; ir < n_rho_; ++ir) {
                const double r0 = double(ir) * dr, r1 = r0 + dr;
                const double vol = pi_v<double> * (r1 * r1 - r0 * r0) * dz;
                for (std::size_t it = 0; it < n_theta_; ++it) {
                    const double th0 = pi_v<double> * double(it) / n_theta_, th1 = pi_v<double> * double(it + 1) / n_theta_;
                    const double dom = 2.0 * pi_v<double> / n_phi_ * (std::cos(th0) - std::cos(th1));  // both mirror halves
                    for (std::size_t ip = 0; ip < n_phi_; ++ip)
                        s += vol * dom *
                             values_[((c * n_z_ + iz) * n_rho_ + ir) * n_theta_ * n_phi_ + it * n_phi_ + ip];
                }
            }
        return s;
    }

    [[nodiscard]] double albedo(std::size_t c) const noexcept { return albedo_[c]; }
    [[nodiscard]] double mean_cosine() const noexcept { return g_; }
    [[nodiscard]] std::uint64_t photons() const noexcept { return photons_; }
    [[nodiscard]] std::size_t size() const noexcept { return values_.size(); }
    [[nodiscard]] bool empty() const noexcept { return values_.empty(); }
    [[nodiscard]] const std::vector<float>& values() const noexcept { return values_; }

    /// Save atomically in the shared container (kind "MSTB"). Throws io_error.
    void save(const std::filesystem::path& path) const {
        ByteWriter w;
        w.put(std::uint32_t(N));
        w.put(n_rho_);
        w.put(n_z_);
        w.put(n_theta_);
        w.put(n_phi_);
        w.put(rho_max_);
        w.put(z_min_);
        w.put(z_max_);
        w.put(g_);
        for (std::size_t c = 0; c < N; ++c) w.put(albedo_[c]);
        w.put(photons_);
        w.put(std::uint64_t(values_.size()));
        w.put_array(values_.data(), values_.size());
        write_container_atomic(path, file_kind, file_version, w.bytes());
    }

    /// Load; throws io_error if unreadable, format_error on a corrupt/truncated/mismatched file.
    [[nodiscard]] static MsTable load(const std::filesystem::path& path) {
        const auto payload = read_container(path, file_kind, file_version);
        ByteReader r(payload, "MsTable '" + path.string() + "'");
        MsTable t;
        const auto ch = r.get<std::uint32_t>();
        if (ch != N) r.fail("has " + std::to_string(ch) + " channels, expected " + std::to_string(N));
        t.n_rho_ = r.get<std::uint32_t>();
        t.n_z_ = r.get<std::uint32_t>();
        t.n_theta_ = r.get<std::uint32_t>();
        t.n_phi_ = r.get<std::uint32_t>();
        auto dim_ok = [](std::uint32_t n, std::uint32_t hi) { return n >= 1 && n <= hi; };
        if (!dim_ok(t.n_rho_, 4096) || !dim_ok(t.n_z_, 4096) || !dim_ok(t.n_theta_, 256) || !dim_ok(t.n_phi_, 256))
            r.fail("grid dimensions out of range");
        t.rho_max_ = r.get<double>();
        t.z_min_ = r.get<double>();
        t.z_max_ = r.get<double>();
        t.g_ = r.get<double>();
        if (!(std::isfinite(t.rho_max_) && t.rho_max_ > 0 && std::isfinite(t.z_min_) && std::isfinite(t.z_max_) &&
              t.z_max_ > t.z_min_ && std::isfinite(t.g_)))
            r.fail("grid extent out of range");
        for (std::size_t c = 0; c < N; ++c) {
            t.albedo_[c] = r.get<double>();
            if (!(t.albedo_[c] >= 0 && t.albedo_[c] <= 1)) r.fail("albedo out of [0, 1]");
        }
        t.photons_ = r.get<std::uint64_t>();
        const auto count = r.get<std::uint64_t>();
        const std::uint64_t expect =
            std::uint64_t(N) * t.n_rho_ * t.n_z_ * std::uint64_t(t.n_theta_) * t.n_phi_;
        if (count != expect) r.fail("value count " + std::to_string(count) + " != " + std::to_string(expect));
        r.get_array(t.values_, count);
        t.set_derived();
        r.expect_end();
        for (float v : t.values_)
            if (!(std::isfinite(v) && v >= 0.0f)) r.fail("negative or non-finite value");
        return t;
    }

    /// An infinite homogeneous medium as a WalkScene (no surfaces, everything in medium 0).
    template <class M>
    struct InfiniteMediumScene {
        using Medium = M;
        using Float = typename M::Float;
        using Spectrum = typename M::Spectrum;
        const M& m;
        [[nodiscard]] SurfaceHit<Float, Spectrum> intersect(const Ray<Float>&) const noexcept { return {}; }
        [[nodiscard]] const M& medium(int) const noexcept { return m; }
    };

private:
    /// Walk callbacks: histogram scattering events of order >= 2 by cell and incoming direction.
    template <class F, class S>
    struct Tally {
        const MsTable& t;
        std::vector<double>& h;
        double escape2;
        template <class M>
        bool on_scatter(PathState<F, S>& st, const Interaction<F, S>& it, const M&) noexcept {
            const Vec3<double> p(it.p);
            if (glm::dot(p, p) > escape2) return false;
            if (st.depth < 2) return true;
            const double rho = std::sqrt(p.x * p.x + p.y * p.y);
            if (rho >= t.rho_max_ || p.z < t.z_min_ || p.z >= t.z_max_) return true;
            const std::size_t ir = std::min<std::size_t>(t.n_rho_ - 1, std::size_t(rho / t.rho_max_ * t.n_rho_));
            const std::size_t iz =
                std::min<std::size_t>(t.n_z_ - 1, std::size_t((p.z - t.z_min_) / (t.z_max_ - t.z_min_) * t.n_z_));
            const Vec3<double> d(st.ray.d);
            double ex = 1, ey = 0;
            if (rho > 0) {
                ex = p.x / rho;
                ey = p.y / rho;
            }
            const double lx = d.x * ex + d.y * ey, ly = -d.x * ey + d.y * ex;
            const std::size_t j = t.direction_bin(d.z, std::atan2(std::abs(ly), lx));
            const std::size_t n_dir = std::size_t(t.n_theta_) * t.n_phi_;
            for (std::size_t c = 0; c < N; ++c)
                h[((c * t.n_z_ + iz) * t.n_rho_ + ir) * n_dir + j] += double(st.throughput[c]);
            return true;
        }
    };

    /// Centre direction of bin j in the local frame (x = radial, z = axis); `mirror` flips phi.
    [[nodiscard]] Vec3<double> bin_direction(std::size_t j, bool mirror) const noexcept {
        const double th = pi_v<double> * (double(j / n_phi_) + 0.5) / n_theta_;
        const double ph = pi_v<double> * (double(j % n_phi_) + 0.5) / n_phi_ * (mirror ? -1.0 : 1.0);
        return {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
    }

    std::uint32_t n_rho_ = 0, n_z_ = 0, n_theta_ = 0, n_phi_ = 0;
    double rho_max_ = 1, z_min_ = -1, z_max_ = 1, g_ = 0;
    double inv_dr_ = 1, inv_dz_ = 1;  ///< cells per mean free path (derived)
    void set_derived() noexcept {
        inv_dr_ = n_rho_ / rho_max_;
        inv_dz_ = n_z_ / (z_max_ - z_min_);
    }
    std::array<double, N> albedo_{};
    std::uint64_t photons_ = 0;
    std::vector<float> values_;
};

}  // namespace grainlight
