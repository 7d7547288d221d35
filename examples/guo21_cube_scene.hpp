// guo21_cube_scene.hpp: the 1 m cube scene shared by the Guo21 discrete-media examples (Figs. 18, 19,
// and the Figs. 5, 13, 16, 20 and mixture examples): a cube [-0.5, 0.5] x [0, 1] x [-0.5, 0.5] of
// particles under a large dim quad light above it (outside the view), black background, seen by one
// pinhole camera; the particle grid's resolution rule; and the continuous pair of a discrete medium
// (the same particles' global sigma_t = sum C_t / V, albedo sum C_s / sum C_t and ensemble phase
// function, Eq. 17 over the realized particles), with and without the membership rule's factor.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/optics/bulk.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/phase/mie.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/film.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace guo21_cube {

namespace gl = grainlight;
/// One grey channel (the cube examples render at one wavelength).
using S = gl::Spectrum<1, float>;

/// Cube side [m].
constexpr double kSide = 1.0;
/// Cube volume [m^3].
constexpr double kVolume = kSide * kSide * kSide;
/// The per-pixel mean of two equally weighted renders (the two seeded halves of a render).
inline gl::Image average(const gl::Image& a, const gl::Image& b) {
    gl::Image m = a;
    for (std::size_t i = 0; i < m.rgb.size(); ++i) m.rgb[i] = 0.5f * (a.rgb[i] + b.rgb[i]);
    return m;
}


/// The cube's domain for ParticleCloud::generate.
inline gl::BoxBoundary cube_boundary() { return gl::BoxBoundary(gl::Vec3d(-0.5, 0.0, -0.5), gl::Vec3d(0.5, 1.0, 0.5)); }

/// Adds the cube (index-matched boundary holding medium `medium`) and the 3 m x 3 m light at y = 2.25
/// facing down (radiance 1.25) to `sc`.
template <class Scene>
void build_scene(Scene& sc, int medium) {
    using Mat = gl::Material<float, S>;
    sc.add_shape(gl::BoxShape<float>(gl::Vec3f(-0.5f, 0.0f, -0.5f), gl::Vec3f(0.5f, 1.0f, 0.5f)), Mat::index_matched(), medium,
                 -1);
    sc.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-1.5f, 2.25f, -1.5f), gl::Vec3f(3.0f, 0, 0), gl::Vec3f(0, 0, 3.0f)),
                      S(1.25f));
}

/// The camera looking at the cube from (0, 1.375, 2.75), 32 deg vertical field of view.
inline gl::PinholeCamera<float> camera(int width, int height) {
    return gl::PinholeCamera<float>(gl::Vec3f(0.0f, 1.375f, 2.75f), gl::Vec3f(0.0f, 0.5f, 0.0f), gl::Vec3f(0, 1, 0), 32.0f, width,
                                    height);
}

/// Distance from the camera to the cube's front (z_med of Eq. 23) [m].
constexpr double kZMed = 2.4;

/// Grid settings for `count` particles in the cube: about one particle per voxel, voxels no smaller
/// than the largest dilated sphere's diameter 2 (r_c + r_max) (both in m).
inline gl::ParticleGridSettings grid_settings(std::uint64_t count, double r_c, double r_max_m) {
    gl::ParticleGridSettings gs;
    gs.dilation = r_c;
    const double h = std::max(std::cbrt(kVolume / double(count)), 2 * (r_c + r_max_m));
    const int res = int(std::clamp(std::ceil(kSide / h), 1.0, 4096.0));
    gs.resolution = {res, res, res};
    return gs;
}

/// Largest particle radius of a cloud [um].
inline double max_radius_um(const gl::ParticleCloud& cloud) {
    double r = 0;
    for (std::uint32_t i = 0; i < cloud.size(); ++i) r = std::max(r, double(cloud[i].r) * 1e6);
    return r;
}

/// The continuous pair of a discrete medium: its particles' sum C_t / V, albedo and ensemble phase
/// function (Eq. 17 as a sum over the realized particles, with the medium's per-bin optics: sum over
/// bins of (the bin's sum of C_s) f_bin), and the membership rule's Poisson average of the discrete
/// medium (each particle's C_t and C_s scaled by membership_extinction_factor, albedo unchanged).
struct ContinuousPair {
    double sigma_t = 0;  ///< global sigma_t = sum C_t / V [1/m]
    double albedo = 0;   ///< sum C_s / sum C_t
    double factor = 1;   ///< extinction-weighted mean membership factor
    gl::MiePhase<float, S> phase;         ///< ensemble phase of the particles
    gl::MiePhase<float, S> phase_factor;  ///< ensemble phase with each particle weighted by its factor
};

/// Builds the continuous pair of `dm` (one species, `model`) whose particles are `cloud`; r_c [m],
/// lambda [um], r_max_um the cloud's largest radius.
template <class DMed>
ContinuousPair continuous_pair(const DMed& dm, const gl::ParticleCloud& cloud, const gl::ParticleModel& model, double r_c,
                               double lambda, bool diffraction, double r_max_um, int theta_nodes_tail) {
    ContinuousPair cp;
    double sum_ct = 0, sum_ctf = 0;
    const auto& bins = dm.bins(0);
    std::vector<double> w_bin(bins.size(), 0.0), wf_bin(bins.size(), 0.0);
    for (std::uint32_t i = 0; i < cloud.size(); ++i) {
        const double ct = double(dm.extinction_cross_section(i));
        const double f_i = gl::membership_extinction_factor(double(cloud[i].r), r_c, ct);
        sum_ct += ct;
        sum_ctf += ct * f_i;
        const auto* ph = &dm.phase_of(i);
        for (std::size_t b = 0; b < bins.size(); ++b)
            if (ph == &bins[b].phase) {
                w_bin[b] += double(dm.albedo(i)) * ct;
                wf_bin[b] += double(dm.albedo(i)) * ct * f_i;
                break;
            }
    }
    cp.factor = sum_ctf / sum_ct;
    const double x_max = 2 * gl::pi_v<double> * model.host_index * r_max_um / lambda;
    const std::vector<double> theta = gl::forward_peaked_theta_grid(x_max, 400, theta_nodes_tail);
    std::vector<double> ens(theta.size(), 0.0), ensf(theta.size(), 0.0), inten;
    for (std::size_t b = 0; b < bins.size(); ++b) {
        if (!(w_bin[b] > 0) || !(bins[b].C_s_um2 > 0)) continue;
        double ct = 0, cs = 0;
        gl::particle_optics(model, bins[b].r_rep_um, lambda, diffraction, theta, ct, cs, inten);
        for (std::size_t t = 0; t < theta.size(); ++t) {
            ens[t] += w_bin[b] / cs * inten[t];
            ensf[t] += wf_bin[b] / cs * inten[t];
        }
    }
    std::vector<S> ens_s(theta.size()), ensf_s(theta.size());
    for (std::size_t t = 0; t < theta.size(); ++t) {
        ens_s[t] = S(float(ens[t]));
        ensf_s[t] = S(float(ensf[t]));
    }
    cp.phase = gl::MiePhase<float, S>::from_intensities(theta, ens_s);
    cp.phase_factor = gl::MiePhase<float, S>::from_intensities(theta, ensf_s);
    cp.sigma_t = dm.global_sigma_t();
    cp.albedo = dm.global_sigma_s() / dm.global_sigma_t();
    return cp;
}

/// RMS over pixels of (a - b) in channel 0, divided by `mean_b`.
inline double rel_rmse(const gl::Image& a, const gl::Image& b, double mean_b) {
    double s = 0;
    const std::size_t n = std::size_t(a.width) * std::size_t(a.height);
    for (std::size_t i = 0; i < n; ++i) {
        const double d = double(a.rgb[3 * i]) - double(b.rgb[3 * i]);
        s += d * d;
    }
    return std::sqrt(s / double(n)) / mean_b;
}

}  // namespace guo21_cube
