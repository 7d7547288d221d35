/// @file grainlight/integrators/point_based_environment.hpp
/// Wang18 Sec. 3.4.2: light surface samples after environment interactions. Light that reaches
/// the medium's boundary only after bounces in a surrounding scene (a glossy or diffuse floor, a
/// wall, the glass around a liquid) is gathered by photons and handed to the point-based
/// renderer as `EnteringLight` records, one per light surface sample.
///
/// Photons leave the scene's lights (`sample_emission`) and are walked through the surroundings
/// with the library's walk kernel in importance mode (BSDF sampling at diffuse and glossy
/// surfaces, Fresnel at smooth dielectrics, Russian roulette). A photon that reaches the
/// object's shape (`object_shape`, e.g. an absorber in the scene) after at least one event in
/// the surroundings is refracted into the medium there (power times 1 - F, direction by Snell's
/// law) and stops; photons that reach it straight from the light are left to the renderer's own
/// light surface samples unless `include_direct` is set (then the records carry all of the
/// light, for `PointBasedOptions::direct_light = false`). Each photon is given to the nearest
/// surface sample (a partition of the boundary into the samples' cells, so the records carry
/// exactly the photons' power). The paper then gives each sample one ray along the photons'
/// mean direction ("we average all the photons that are close to it, by averaging the direction
/// and radiance", Sec. 3.4.2: `EnteringDirections::mean`); by default a few rays along photons
/// resampled by power keep the spread of directions, which light from a floor or a large lamp
/// has (`EnteringDirections::resampled`).
///
/// The paper builds the samples behind transparent layers by tracing the refracted rays from
/// blue-noise points on the outer layer and thinning them; photons through the layers give the
/// same light with one mechanism for both of its cases (docs/wang18.md).
///
/// Deterministic for `seed` on any thread count: photon i draws from Rng::from_key(seed, i), and
/// the photons are summed per sample in photon order.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <cstdint>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/walk.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/scene/concepts.hpp"

namespace grainlight {

/// Options of `trace_environment_photons` (and `environment_entering_light`).
struct EnvironmentPhotonOptions {
    std::uint64_t photons = 1000000;  ///< photons shot from the scene's lights (>= 1)
    std::uint64_t seed = 1;           ///< random stream (photon i: Rng::from_key(seed, i, 0x454e56))
    int max_depth = 64;               ///< events in the surroundings before a photon is dropped
    /// Russian roulette after this many events, on the photon's throughput relative to its
    /// emitted power (an analog walk through albedos <= 1 is never killed by it).
    int rr_depth = 3;
    bool include_direct = false;      ///< also keep photons that reach the object straight from a light
};

/// A photon that reached the object: where, along which direction, with which power.
template <std::floating_point F, class S>
struct ArrivingPhoton {
    Vec3<F> p{F(0)};  ///< hit point on the object's boundary
    Vec3<F> n{F(0), F(0), F(1)};  ///< outward unit normal there
    Vec3<F> w{F(0), F(0), -F(1)};  ///< unit propagation direction on arrival (outside)
    S power{F(0)};  ///< power carried [W] (before the boundary's Fresnel)
    int events = 0;  ///< events in the surroundings before it arrived (0: straight from a light)
};

/// The result of `environment_entering_light`.
template <std::floating_point F, class S>
struct EnvironmentLight {
    std::vector<EnteringLight<F, S>> entering;  ///< records of the surface samples that received photons (1 or rays_per_sample each)
    S power_arriving{F(0)};  ///< power of the kept photons reaching the boundary (before Fresnel) [W]
    S power_entering{F(0)};  ///< of which transmitted into the medium [W]
    std::uint64_t photons = 0;  ///< photons shot
    std::uint64_t kept = 0;     ///< photons kept (reached the object after >= 1 event, or directly with include_direct)
};

namespace detail {

/// Walk callbacks of a photon in the surroundings: stop at the object, remember the arrival.
template <std::floating_point F, class S>
struct ObjectArrival {
    int object_shape = -1;
    bool arrived = false;
    ArrivingPhoton<F, S> photon;
    bool on_surface(PathState<F, S>& st, const SurfaceHit<F, S>& hit) noexcept {
        if (hit.shape != object_shape) return true;
        arrived = true;
        photon.p = hit.p;
        photon.n = hit.n;
        photon.w = st.ray.d;
        photon.power = st.throughput;
        photon.events = st.depth;
        return false;
    }
};

/// Nearest-sample lookup over surface samples: a uniform grid of cells about two sample spacings
/// wide, searched in growing shells of cells until the nearest candidate is certain.
template <std::floating_point F>
class NearestSample {
public:
    explicit NearestSample(const std::vector<SurfaceSample<F>>& s) : s_(s) {
        lo_ = s.front().p;
        Vec3<F> hi = lo_;
        double area = 0;
        for (const auto& x : s) {
            lo_ = glm::min(lo_, x.p);
            hi = glm::max(hi, x.p);
            area += double(x.area);
        }
        const F spacing = F(std::sqrt(area / double(s.size())));
        const Vec3<F> ext = hi - lo_;
        cell_ = std::max(F(2) * spacing, F(1e-6) * std::max({ext.x, ext.y, ext.z, F(1)}));
        for (int a = 0; a < 3; ++a) res_[a] = std::clamp(int(ext[a] / cell_) + 1, 1, 512);
        first_.assign(std::size_t(res_[0]) * std::size_t(res_[1]) * std::size_t(res_[2]) + 1, 0);
        std::vector<std::uint32_t> cell_of(s.size());
        for (std::size_t i = 0; i < s.size(); ++i) {
            cell_of[i] = std::uint32_t(index(cell_coords(s[i].p)));
            ++first_[cell_of[i] + 1];
        }
        for (std::size_t c = 1; c < first_.size(); ++c) first_[c] += first_[c - 1];
        items_.resize(s.size());
        std::vector<std::uint32_t> fill(first_.begin(), first_.end() - 1);  // next free slot per cell
        for (std::size_t i = 0; i < s.size(); ++i) items_[fill[cell_of[i]]++] = std::uint32_t(i);
    }
    /// Index of the sample nearest to p.
    [[nodiscard]] std::size_t nearest(const Vec3<F>& p) const noexcept {
        const std::array<int, 3> c = cell_coords(p);
        F best = std::numeric_limits<F>::infinity();
        std::size_t arg = 0;
        const int rmax = std::max({res_[0], res_[1], res_[2]});
        for (int r = 0; r <= rmax; ++r) {
            // Cells at Chebyshev distance r; any point in them is >= (r - 1) cells away.
            if (r >= 1 && F(r - 1) * cell_ > std::sqrt(best)) break;
            for (int z = c[2] - r; z <= c[2] + r; ++z)
                for (int y = c[1] - r; y <= c[1] + r; ++y)
                    for (int x = c[0] - r; x <= c[0] + r; ++x) {
                        if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != r) continue;
                        if (x < 0 || y < 0 || z < 0 || x >= res_[0] || y >= res_[1] || z >= res_[2]) continue;
                        const std::size_t k = index({x, y, z});
                        for (std::uint32_t j = first_[k]; j < first_[k + 1]; ++j) {
                            const Vec3<F> d = s_[items_[j]].p - p;
                            const F d2 = glm::dot(d, d);
                            if (d2 < best) {
                                best = d2;
                                arg = items_[j];
                            }
                        }
                    }
        }
        return arg;
    }

private:
    [[nodiscard]] std::array<int, 3> cell_coords(const Vec3<F>& p) const noexcept {
        std::array<int, 3> c{};
        for (int a = 0; a < 3; ++a) c[std::size_t(a)] = std::clamp(int(std::floor((p[a] - lo_[a]) / cell_)), 0, res_[a] - 1);
        return c;
    }
    [[nodiscard]] std::size_t index(const std::array<int, 3>& c) const noexcept {
        return (std::size_t(c[2]) * std::size_t(res_[1]) + std::size_t(c[1])) * std::size_t(res_[0]) + std::size_t(c[0]);
    }
    const std::vector<SurfaceSample<F>>& s_;
    Vec3<F> lo_;
    F cell_ = F(1);
    std::array<int, 3> res_{1, 1, 1};
    std::vector<std::uint32_t> first_, items_;
};

}  // namespace detail

/// The photons of `opt` that reach shape `object_shape` of `scene` (see the file comment), in
/// photon order. Throws invalid_argument if opt.photons is 0 or object_shape is negative.
template <LitScene Scene>
    requires Medium<typename Scene::Medium>
[[nodiscard]] std::vector<ArrivingPhoton<typename Scene::Float, typename Scene::Spectrum>> trace_environment_photons(
    const Scene& scene, int object_shape, const EnvironmentPhotonOptions& opt) {
    using F = typename Scene::Float;
    using S = typename Scene::Spectrum;
    check_argument(opt.photons >= 1, "trace_environment_photons", "photons", opt.photons, ">= 1");
    check_argument(object_shape >= 0, "trace_environment_photons", "object_shape", object_shape, ">= 0");
    check_argument(opt.max_depth >= 1, "trace_environment_photons", "max_depth", opt.max_depth, ">= 1");
    constexpr std::uint64_t block = 4096;
    const std::uint64_t nb = (opt.photons + block - 1) / block;
    std::vector<std::vector<ArrivingPhoton<F, S>>> per_block(nb);
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (std::ptrdiff_t b = 0; b < std::ptrdiff_t(nb); ++b) {
        const std::uint64_t i0 = std::uint64_t(b) * block, i1 = std::min(opt.photons, i0 + block);
        for (std::uint64_t i = i0; i < i1; ++i) {
            Rng rng = Rng::from_key(opt.seed, i, 0x454e56u);
            const F u_pick = rng.uniform<F>();
            const Vec2<F> u_pos = rng.uniform2<F>(), u_dir = rng.uniform2<F>();
            const EmissionSample<F, S> e = scene.sample_emission(u_pick, u_pos, u_dir);
            if (!e) continue;
            // Walk with unit throughput (Russian roulette relative to the emitted power); the
            // photon's power is its emission weight times the throughput.
            PathState<F, S> st = start_path<F, S>(e.ray, -1, S(F(1)));
            detail::ObjectArrival<F, S> cb;
            cb.object_shape = object_shape;
            WalkOptions<F> wo;
            wo.max_depth = opt.max_depth;
            wo.rr_depth = opt.rr_depth;
            wo.mode = TransportMode::importance;
            (void)walk(scene, st, rng, cb, wo);
            if (!cb.arrived || (cb.photon.events == 0 && !opt.include_direct)) continue;
            cb.photon.power *= e.weight;
            if (!(cb.photon.power.max_value() > F(0))) continue;
            per_block[std::size_t(b)].push_back(cb.photon);
        }
    }
    std::vector<ArrivingPhoton<F, S>> out;
    for (auto& v : per_block) out.insert(out.end(), v.begin(), v.end());
    return out;
}

/// How the photons given to one surface sample become light rays into the medium.
enum class EnteringDirections : std::uint8_t {
    /// The paper's (Sec. 3.4.2): one ray along the photons' power-weighted mean refracted
    /// direction, carrying their power. Exact when they arrive from one direction (a point light,
    /// a mirror); light from a wide solid angle (an area light near the object, a diffuse floor)
    /// is focused into one tube (measured: single scattering off by up to 50 % beside the direct
    /// connection to a 6 x 6 quad light one radius away).
    mean,
    /// `rays_per_sample` rays along photons drawn with probability proportional to their
    /// (channel-average) power, stratified, each carrying its photon's power divided by
    /// rays_per_sample times that probability: the photons' direction distribution in
    /// expectation, per channel.
    resampled
};

/// Options of `entering_light_from_photons`.
struct EnteringLightOptions {
    EnteringDirections directions = EnteringDirections::resampled;  ///< see EnteringDirections
    int rays_per_sample = 4;          ///< rays per sample with `resampled` (>= 1)
    std::uint64_t seed = 1;           ///< stream of the resampling (sample j: Rng::from_key(seed, j, 0x525352))
};

/// Entering-light records from photons that arrived at the boundary of a medium of relative
/// index `eta` (n_inside / n_outside), for each surface sample that received any (see the file
/// comment and EnteringDirections; with `resampled` each record has area A_j / rays_per_sample).
/// Each photon's power is divided by `photons_shot` (the photons' weights are per-photon
/// estimates of the light's power). Throws invalid_argument if `surface` is empty, eta is not
/// positive, photons_shot is 0 or rays_per_sample < 1.
template <std::floating_point F, class S>
[[nodiscard]] EnvironmentLight<F, S> entering_light_from_photons(const std::vector<ArrivingPhoton<F, S>>& photons,
                                                                std::uint64_t photons_shot,
                                                                const std::vector<SurfaceSample<F>>& surface, F eta,
                                                                const EnteringLightOptions& opt = {}) {
    constexpr std::size_t N = S::size;
    check_argument(!surface.empty(), "entering_light_from_photons", "surface samples", surface.size(), ">= 1");
    check_argument(std::isfinite(eta) && eta > F(0), "entering_light_from_photons", "eta", eta, "(0, inf)");
    check_argument(photons_shot >= 1, "entering_light_from_photons", "photons_shot", photons_shot, ">= 1");
    check_argument(opt.rays_per_sample >= 1 && opt.rays_per_sample <= 1024, "entering_light_from_photons",
                   "rays_per_sample", opt.rays_per_sample, "[1, 1024]");
    EnvironmentLight<F, S> out;
    out.photons = photons_shot;
    const double inv_n = 1.0 / double(photons_shot);
    // Refracted photons: sample index, inside direction, transmitted power (double sums).
    struct Entered {
        std::size_t sample;
        Vec3<F> d;
        std::array<double, N> power;
    };
    std::vector<Entered> in;
    in.reserve(photons.size());
    std::array<double, N> arriving{}, entering{};
    const detail::NearestSample<F> grid(surface);
    for (const ArrivingPhoton<F, S>& ph : photons) {
        const F cos_i = -glm::dot(ph.w, ph.n);
        if (!(cos_i > F(0))) continue;  // arrived from inside (cannot happen for an opaque object)
        ++out.kept;
        const double tr = 1.0 - double(fresnel_dielectric(cos_i, eta));
        Vec3<F> wt;
        F eta_rel;
        const bool refracted = refract(-ph.w, ph.n, eta, wt, &eta_rel);
        Entered e{refracted ? grid.nearest(ph.p) : 0, refracted ? Vec3<F>(glm::normalize(wt)) : Vec3<F>(F(0)), {}};
        for (std::size_t c = 0; c < N; ++c) {
            const double a = double(ph.power[c]) * inv_n;
            arriving[c] += a;
            if (!refracted) continue;
            e.power[c] = a * tr;
            entering[c] += e.power[c];
        }
        if (refracted) in.push_back(e);
    }
    for (std::size_t c = 0; c < N; ++c) {
        out.power_arriving[c] = F(arriving[c]);
        out.power_entering[c] = F(entering[c]);
    }
    // The photons of each sample, in photon order (counting sort).
    std::vector<std::size_t> first(surface.size() + 1, 0);
    for (const Entered& e : in) ++first[e.sample + 1];
    for (std::size_t j = 1; j < first.size(); ++j) first[j] += first[j - 1];
    std::vector<std::size_t> order(in.size());
    {
        std::vector<std::size_t> fill(first.begin(), first.end() - 1);
        for (std::size_t i = 0; i < in.size(); ++i) order[fill[in[i].sample]++] = i;
    }
    auto avg = [](const std::array<double, N>& p) {
        double a = 0;
        for (double x : p) a += x;
        return a / double(N);
    };
    // An inward direction at sample s (a mean of inward directions of a curved cell can graze the
    // sample's tangent plane; its power is unchanged).
    auto inward = [](Vec3<F> d, const SurfaceSample<F>& s) {
        if (!(glm::dot(d, s.n) < F(-1e-3))) d = glm::normalize(d - (glm::dot(d, s.n) + F(1e-3)) * s.n);
        return d;
    };
    for (std::size_t j = 0; j < surface.size(); ++j) {
        const std::size_t b = first[j], e = first[j + 1];
        if (b == e) continue;
        const SurfaceSample<F>& s = surface[j];
        double total = 0;
        std::array<double, N> sum{};
        Vec3<double> mean(0.0);
        for (std::size_t k = b; k < e; ++k) {
            const Entered& x = in[order[k]];
            const double a = avg(x.power);
            total += a;
            mean += Vec3<double>(x.d) * a;
            for (std::size_t c = 0; c < N; ++c) sum[c] += x.power[c];
        }
        if (!(total > 0)) continue;
        if (opt.directions == EnteringDirections::mean) {
            const double len = glm::length(mean);
            S pw;
            for (std::size_t c = 0; c < N; ++c) pw[c] = F(sum[c]);
            out.entering.push_back(EnteringLight<F, S>{s.p, s.n, inward(len > 0.0 ? Vec3<F>(mean / len) : -s.n, s), pw, s.area});
            continue;
        }
        // Stratified draws of photons with probability a_k / total.
        const int m = opt.rays_per_sample;
        Rng rng = Rng::from_key(opt.seed, std::uint64_t(j), 0x525352u);
        const double u0 = double(rng.uniform<F>());
        double cum = 0;
        std::size_t k = b;
        for (int r = 0; r < m; ++r) {
            const double target = (double(r) + u0) / double(m) * total;
            while (k + 1 < e && cum + avg(in[order[k]].power) <= target) cum += avg(in[order[k++]].power);
            const Entered& x = in[order[k]];
            const double p = avg(x.power) / total;
            S pw;
            for (std::size_t c = 0; c < N; ++c) pw[c] = F(x.power[c] / (double(m) * p));
            out.entering.push_back(EnteringLight<F, S>{s.p, s.n, inward(x.d, s), pw, s.area / F(m)});
        }
    }
    return out;
}

/// Sec. 3.4.2 in one call: `trace_environment_photons` then `entering_light_from_photons` on the
/// light surface samples `surface` of the object (shape `object_shape` of `scene`, relative
/// index eta).
template <LitScene Scene>
    requires Medium<typename Scene::Medium>
[[nodiscard]] EnvironmentLight<typename Scene::Float, typename Scene::Spectrum> environment_entering_light(
    const Scene& scene, int object_shape, typename Scene::Float eta,
    const std::vector<SurfaceSample<typename Scene::Float>>& surface, const EnvironmentPhotonOptions& opt = {},
    const EnteringLightOptions& entering = {}) {
    const auto photons = trace_environment_photons(scene, object_shape, opt);
    return entering_light_from_photons(photons, opt.photons, surface, eta, entering);
}

}  // namespace grainlight
