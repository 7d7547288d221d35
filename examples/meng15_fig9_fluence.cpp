// meng15_fig9_fluence: the detector-sphere experiment of Meng15 Sec. 4.2.3 / Fig. 9 / Fig. 10.
//
// A photon starts at a random point between the grains of an infinite procedural aggregate
// (tiled MD packing of unit bounding spheres at f = 0.63, randomly rotated grains) in a random
// direction and is traced explicitly (EPT, integrators/ept.hpp) through 10 grain interactions;
// its exit point p_i and direction w_i after the 10th interaction are the beam source. Detector
// spheres of radius 7.5 and 15 mean free paths (1/sigma_t of Eq. 4) are centred on p_i and the
// photon is traced until it leaves each of them (first exit). At the exit point p_e we record
// the inclination theta (angle between p_e - p_i and w_i) and the exit direction w_o projected
// onto the tangent plane at p_e (Fig. 10's coordinate system: x along increasing theta, y =
// w_i x w_e direction, normal w_e). The same is done with volumetric path tracing (VPT) in the
// homogeneous medium with the derived RTE parameters (media/teleportation.hpp
// make_effective_medium: sigma_t of Eq. 4, alpha_s and the tabulated Phi of the scatterometer
// for the same grain mesh), photons starting at p_i along w_i.
//
//   meng15_fig9_fluence [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--photons N]
//
// "Fluence" here is the exit density: photons leaving the detector per unit area of the
// detector sphere per source photon, as a function of theta (both methods use the same
// estimator). Printed per grain and radius: the per-bin relative difference (VPT - EPT) / EPT
// and the L1 distance between the two normalized distributions over theta. Paper observation:
// the agreement at 15 mean free paths is better than at 7.5 (VPT over-estimates forward
// scattering at short distances). Writes CSV (fluence, radiance field) + PNG; last line JSON.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/media/teleportation.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/precompute/scatterometer.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {

constexpr int n_theta = 18;     // 10-degree inclination bins
constexpr int n_field = 16;     // projected-direction histogram, n_field^2 cells over [-1, 1]^2
constexpr int n_bands = 3;      // inclination bands for the radiance field: [0,45), [45,135), [135,180]
constexpr double interactions_before_source = 10;  // Meng15 Sec. 4.2.3

struct Tally {
    std::array<std::array<double, n_theta>, 2> fluence{};                       // [radius][theta bin]
    std::array<std::array<std::array<double, n_field * n_field>, n_bands>, 2> field{};  // [radius][band][cell]
    std::uint64_t photons = 0, lost = 0, interactions = 0;
    void add(const Tally& o) {
        for (int r = 0; r < 2; ++r) {
            for (int i = 0; i < n_theta; ++i) fluence[r][i] += o.fluence[r][i];
            for (int b = 0; b < n_bands; ++b)
                for (int i = 0; i < n_field * n_field; ++i) field[r][b][i] += o.field[r][b][i];
        }
        photons += o.photons;
        lost += o.lost;
        interactions += o.interactions;
    }
};

/// Record an exit of detector `r` at point pe (relative to the source) with direction w.
void record(Tally& t, int r, const gl::Vec3d& rel, const gl::Vec3d& wi, const gl::Vec3d& w) {
    const double len = glm::length(rel);
    const gl::Vec3d we = rel / len;
    const double ct = std::clamp(glm::dot(we, wi), -1.0, 1.0);
    const double theta = std::acos(ct) * 180.0 / gl::pi_v<double>;
    t.fluence[std::size_t(r)][std::size_t(std::min(n_theta - 1, int(theta / (180.0 / n_theta))))] += 1.0;
    // Tangent frame at pe: x along increasing theta, y = we x x.
    gl::Vec3d x = ct * we - wi;  // d(we)/d(theta) direction (perpendicular to we, away from wi)
    const double xl = glm::length(x);
    if (xl < 1e-12) {
        x = gl::Frame<double>(we).s;
    } else {
        x /= xl;
    }
    const gl::Vec3d y = glm::cross(we, x);
    const double px = glm::dot(w, x), py = glm::dot(w, y);
    const int band = theta < 45 ? 0 : (theta < 135 ? 1 : 2);
    const int ix = std::clamp(int((px + 1) * 0.5 * n_field), 0, n_field - 1);
    const int iy = std::clamp(int((py + 1) * 0.5 * n_field), 0, n_field - 1);
    t.field[std::size_t(r)][std::size_t(band)][std::size_t(iy * n_field + ix)] += 1.0;
}

/// Detector crossing on the segment a -> b (relative to the source): the exit parameter s in
/// (0, 1] where |a + s (b - a)| = radius, if |a| < radius <= |b|.
bool crossing(const gl::Vec3d& a, const gl::Vec3d& b, double radius, gl::Vec3d& pe) {
    if (glm::dot(b, b) < radius * radius) return false;
    const gl::Vec3d d = b - a;
    const auto roots = gl::intersect_sphere(a, d, gl::Vec3d(0.0), radius);
    const double s = roots.hit ? std::clamp(roots.t_far, 0.0, 1.0) : 1.0;
    pe = a + s * d;
    return true;
}

struct DetectorState {
    std::array<double, 2> radius{};
    gl::Vec3d src{0.0}, wi{0.0, 0.0, 1.0};
    int next = 0;  // next detector to record (0, 1; 2 = done)
    Tally* tally = nullptr;
    /// Process the straight segment a -> b (world); false once both detectors are recorded.
    bool segment(const gl::Vec3d& a, const gl::Vec3d& b) {
        while (next < 2) {
            gl::Vec3d pe;
            if (!crossing(a - src, b - src, radius[std::size_t(next)], pe)) return true;
            record(*tally, next, pe, wi, glm::normalize(b - a));
            ++next;
        }
        return false;
    }
};

template <class Agg>
void ept_block(const Agg& agg, std::uint64_t first, std::uint64_t count, std::uint64_t seed,
               const std::array<double, 2>& radius, Tally& t) {
    for (std::uint64_t i = first; i < first + count; ++i) {
        gl::Rng rng = gl::Rng::from_key(seed, i, 0xf19e);
        gl::Vec3d p(0.0);
        for (int k = 0; k < 1000; ++k) {
            p = agg.tile().side() * rng.uniform3<double>();
            if (!agg.tile().sphere_containing(p)) break;
        }
        const gl::Vec3d d = gl::sample_uniform_sphere(rng.uniform2<double>());
        struct Cb {
            DetectorState det;
            bool active = false;
            std::uint64_t* interactions;
            bool on_segment(const gl::Vec3d& a, const gl::Vec3d& b) { return !active || det.segment(a, b); }
            bool on_interaction(const gl::GrainInteraction& gi) {
                ++*interactions;
                if (!active && gi.index == int(interactions_before_source)) {
                    if (gi.absorbed) return false;
                    active = true;
                    det.src = gi.x_o;
                    det.wi = gi.w_o;
                }
                return true;
            }
        } cb;
        cb.det.radius = radius;
        cb.det.tally = &t;
        cb.interactions = &t.interactions;
        gl::RGB w(1.0f);
        (void)gl::ept_photon_walk(agg, p, d, w, rng, cb, 1 << 22);
        ++t.photons;
        if (cb.det.next < 2) ++t.lost;
    }
}

template <class Medium>
void vpt_block(const Medium& m, std::uint64_t first, std::uint64_t count, std::uint64_t seed,
               const std::array<double, 2>& radius, Tally& t) {
    const double sigma_t = double(m.sigma_t()[1]);
    const double albedo = double(m.albedo()[1]);
    for (std::uint64_t i = first; i < first + count; ++i) {
        gl::Rng rng = gl::Rng::from_key(seed, i, 0x7b7);
        DetectorState det;
        det.radius = radius;
        det.tally = &t;
        det.src = gl::Vec3d(0.0);
        det.wi = gl::Vec3d(0.0, 0.0, 1.0);
        gl::Vec3d p(0.0), w = det.wi;
        for (int k = 0; k < (1 << 22); ++k) {
            const double s = gl::sample_exponential(rng.uniform<double>(), sigma_t);
            const gl::Vec3d q = p + s * w;
            if (!det.segment(p, q)) break;
            p = q;
            ++t.interactions;
            if (rng.uniform<double>() >= albedo) break;
            const auto ps = m.phase().sample(gl::Vec3f(w), rng.uniform2<float>());
            w = glm::normalize(gl::Vec3d(ps.w));
        }
        ++t.photons;
        if (det.next < 2) ++t.lost;
    }
}

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig9_fluence",
               "Meng15 Fig. 9: detector-sphere fluence and exit radiance, EPT vs VPT with derived parameters",
               "out/meng15_fig9_fluence", [&](Example& ex) -> int {
        const std::uint64_t photons =
            ex.opt<std::uint64_t>("photons", 16000, 400000, "photons per grain and method");
        ex.ready();
        const bool full = ex.full();
        const auto& out = ex.out();
        const int threads = ex.threads();
        const std::uint64_t seed = ex.seed();
        if (photons < 100) throw cli_error("--photons must be >= 100");
        const double f = 0.63;

        const auto packed = gl::md_pack(full ? 2000 : 400, f, seed);
        const double scale = 1.0 / packed.tile.radius();
        std::vector<gl::Vec3d> centers = packed.tile.centers();
        for (auto& c : centers) c *= scale;
        const gl::PeriodicTile tile(packed.tile.side() * scale, 1.0, std::move(centers));
        const double f_real = tile.packing_fraction();

        struct G {
            const char* preset;
            const char* label;
        };
        const G grains[] = {{"glass-bead", "dielectric spheres"}, {"snow", "snow"}};
        const int level = 4;
        Csv fcsv({"grain", "radius_mfp", "theta_deg", "fluence_ept", "fluence_vpt", "rel_diff", "frac_ept", "frac_vpt"});
        Csv rcsv({"grain", "radius_mfp", "band", "method", "ix", "iy", "value"});
        Json j = ex.summary();
        j.num("packing_rate", f_real).integer("photons", (long long)photons);
        std::printf("Meng15 Fig. 9 detector sphere, f = %.4f, unit grains, %llu photons per grain and method\n", f_real,
                    (unsigned long long)photons);
        bool order_ok = true;
        for (const auto& g : grains) {
            const gl::GrainPreset p = gl::grain_preset(g.preset);
            gl::ScatterometerConfig cfg;
            cfg.rays = full ? 1000000 : 200000;
            cfg.seed = seed;
            const auto stats =
                gl::run_scatterometer(gl::ScatterometerGrain::procedural(p.shape, p.radius, p.material, p.seed, level), cfg);
            const auto medium = gl::make_effective_medium<float, gl::RGB>(stats, f_real, 1.0);
            const double mfp = 1.0 / double(medium.sigma_t()[1]);
            const std::array<double, 2> radius{7.5 * mfp, 15.0 * mfp};
            using B = gl::EverywhereBoundary;
            const gl::GranularAggregate<B> agg(tile, gl::VoxelizedBoundary<B>({}, tile.side()),
                                               {gl::GrainExemplar::from_preset(p, level)}, {1.0}, seed);
            const std::uint64_t block = 100;
            // Blocks of photons on the example's threads, merged in block order (thread-count independent).
            const auto merge = [](Tally& acc, const Tally& t) { acc.add(t); };
            const Tally E = ex.parallel<Tally>(
                std::string("fig9 ") + g.preset + " EPT", photons, block,
                [&](std::uint64_t, std::uint64_t first, std::uint64_t end) {
                    Tally t;
                    ept_block(agg, first, end - first, seed, radius, t);
                    return t;
                },
                merge);
            const Tally V = ex.parallel<Tally>(
                std::string("fig9 ") + g.preset + " VPT", photons, block,
                [&](std::uint64_t, std::uint64_t first, std::uint64_t end) {
                    Tally t;
                    vpt_block(medium, first, end - first, seed, radius, t);
                    return t;
                },
                merge);
            std::printf("\n%s: sigma_t = %.4f / R (mfp %.3f R), alpha_s = %.3f, g = %.3f; detectors at %.2f R and %.2f R; "
                        "EPT %.1f interactions/photon, VPT %.1f events/photon\n",
                        g.label, 1.0 / mfp, mfp, stats.alpha_s_avg(), stats.g_avg(), radius[0], radius[1],
                        double(E.interactions) / double(E.photons), double(V.interactions) / double(V.photons));
            std::array<double, 2> l1{};
            for (int r = 0; r < 2; ++r) {
                const double R = radius[std::size_t(r)];
                double se = 0, sv = 0;
                for (int i = 0; i < n_theta; ++i) {
                    se += E.fluence[std::size_t(r)][std::size_t(i)];
                    sv += V.fluence[std::size_t(r)][std::size_t(i)];
                }
                std::printf("  r = %4.1f mfp: theta  fluence EPT   fluence VPT   (VPT-EPT)/EPT\n", r == 0 ? 7.5 : 15.0);
                for (int i = 0; i < n_theta; ++i) {
                    const double th0 = i * 180.0 / n_theta, th1 = (i + 1) * 180.0 / n_theta;
                    const double area = 2 * gl::pi_v<double> * R * R *
                                        (std::cos(th0 * gl::pi_v<double> / 180) - std::cos(th1 * gl::pi_v<double> / 180));
                    const double fe = E.fluence[std::size_t(r)][std::size_t(i)] / (double(E.photons) * area);
                    const double fv = V.fluence[std::size_t(r)][std::size_t(i)] / (double(V.photons) * area);
                    const double pe = E.fluence[std::size_t(r)][std::size_t(i)] / se;
                    const double pv = V.fluence[std::size_t(r)][std::size_t(i)] / sv;
                    const double rel = fe > 0 ? (fv - fe) / fe : 0.0;
                    l1[std::size_t(r)] += std::abs(pe - pv);
                    std::printf("              %5.0f  %.4e    %.4e    %+7.1f %%\n", 0.5 * (th0 + th1), fe, fv, 100 * rel);
                    fcsv.row_text({g.preset, r == 0 ? "7.5" : "15", std::to_string(0.5 * (th0 + th1)), std::to_string(fe),
                                   std::to_string(fv), std::to_string(rel), std::to_string(pe), std::to_string(pv)});
                }
                std::printf("  r = %4.1f mfp: L1 distance between the normalized theta distributions = %.4f "
                            "(lost photons: EPT %llu, VPT %llu)\n",
                            r == 0 ? 7.5 : 15.0, l1[std::size_t(r)], (unsigned long long)E.lost, (unsigned long long)V.lost);
                for (int b = 0; b < n_bands; ++b)
                    for (int k = 0; k < 2; ++k) {
                        const Tally& T = k == 0 ? E : V;
                        for (int c = 0; c < n_field * n_field; ++c)
                            rcsv.row_text({g.preset, r == 0 ? "7.5" : "15", std::to_string(b), k == 0 ? "ept" : "vpt",
                                           std::to_string(c % n_field), std::to_string(c / n_field),
                                           std::to_string(T.field[std::size_t(r)][std::size_t(b)][std::size_t(c)] /
                                                          double(T.photons))});
                    }
            }
            const bool better = l1[1] < l1[0];
            order_ok = order_ok && better;
            std::printf("  %s: L1 at 15 mfp %s L1 at 7.5 mfp (paper: agreement better at 15 mfp)\n", g.label,
                        better ? "<" : ">=");
            j.num(std::string(g.preset) + "_L1_7_5", l1[0]).num(std::string(g.preset) + "_L1_15", l1[1]);
        }
        const auto fpath = ex.csv("meng15_fig9_fluence.csv", fcsv);
        const auto rpath = ex.csv("meng15_fig9_radiance_field.csv", rcsv);
        ex.plot("meng15_fig9_fluence", fpath, out / "meng15_fig9_fluence.png", {rpath.string(), std::to_string(n_field)});
        j.boolean("agreement_better_at_15_mfp", order_ok);
        std::printf("\nwrote %s, %s, meng15_fig9_fluence.png, meng15_fig9_fluence_radiance.png (%d threads)\n", fpath.c_str(),
                    rpath.c_str(), threads);
        return ex.finish(j);
    });
}
