/// @file grainlight/media/discrete_particles.hpp
/// Discrete participating media (Guo21 Secs. 4.2 and 5): a cloud of individually placed spheres
/// (packing/particle_cloud.hpp) gathered along "fat rays" through a particle grid
/// (traversal/particle_grid.hpp), with cross sections and phase functions of every particle
/// from the optics layer (optics/particle.hpp's Mie/GOA choice, cached per radius bin and
/// species at one wavelength). Also the explicit-sphere medium used as Guo21's EPT reference.
///
/// DiscreteParticleMedium (models Medium). Membership and measures (docs/guo21.md derives them):
///  - query cylinder around a ray, radius r_c, cross section A = pi r_c^2 (Eq. 23 read as a
///    length: S_A = k S_pix z_med / z_near is the cylinder's diameter, r_c = S_A / 2);
///    particle i is a member iff its centre lies within r_i + r_c of the axis (Sec. 5.3), and it
///    sits on the axis at s_i = (p_i - o) . d, the axis point nearest to its centre;
///  - T_A(x, x + t d) = exp(-sum_{members, 0 < s_i <= t} C_t,i / A) (Eqs. 18-19);
///  - a member removes the fraction 1 - exp(-C_t,i / A) of the fat ray's radiance; of that,
///    C_s,i / C_t,i is scattered with the particle's own phase function f_i (Eq. 24 with the
///    query region shrunk to the cylinder slice holding particle i, so that the scattering density
///    equals the extinction density times the albedo: energy is conserved per realization);
///    the scattering vertex is the particle's centre, and the particle that scattered is not a
///    member of the next segment (s = 0 there; members need s > 0);
///  - Eq. 24 over a query sphere, Q(y, theta) = sum_{|p_i - y| < r_i + r_c} C_s,i f_i(theta) / mu_i
///    with mu_i = 4/3 pi (r_i + r_c)^3, is `query_sphere_q`: its placement average is exactly
///    N_0 \<C_s f\> (Eq. 17 times sigma_s).
/// Averaged over Poisson placements, E[T_A] = exp(-n pi (r_p + r_c)^2 L (1 - e^{-c})), c = C_t / A,
/// i.e. the mean extinction is n C_t times (1 + r_p / r_c)^2 (1 - e^{-c}) / c
/// (`membership_extinction_factor`): -> 1 for r_c >> r_p (Beer-Lambert), and
/// (1 + r_c / r_p)^2 times the geometric cross section for opaque particles (r_c << r_p).
///
/// Free flights (sample_interaction): the segment's members are gathered once for their total
/// optical depth tau; with P = 1 - e^{-tau} a collision is forced with probability
/// q = max(P, q_min) (q_min = `forced_collision`, default 0.5), the member is chosen in order
/// along the ray by inverting the cumulative 1 - e^{-sum tau_i} (a second gather), and the event
/// weight is (P / q) C_s,i / C_t,i; otherwise the path reaches t_max with weight (1 - P) / (1 - q).
/// q_min = 0 is the analog sampler, done in one pass that stops at the collision (sample_analog).
/// Unbiased for the discrete transport above (docs/guo21.md); the direction is sampled from the
/// member's phase table (has_direction: the medium chooses it; integrators/discrete_vpt.hpp does
/// NEE with `phase_eval(particle_at(p), ...)`). -FD (`diffraction = false`): amplitudes without
/// the Fraunhofer term and C_t = pi r^2 (ray optics exactly; GOA particles only: Mie particles,
/// r below the switch radius, keep their exact optics).
///
/// ExplicitSphereMedium (models Medium): the same cloud as explicit smooth dielectric spheres
/// (exact ray-sphere hits through the grid; a sphere is crossed as one event, with one
/// polarization drawn per crossing and its Fresnel R from optics/fresnel.hpp at every internal
/// bounce: ray optics of a sphere, every order): Guo21's EPT reference. Overlapping spheres are not resolved (a path
/// inside sphere i sees only sphere i), so the reference is exact only for a cloud of disjoint
/// spheres (ParticleCloud::generate_non_overlapping); in a Poisson cloud the overlaps darken it
/// (-5.5 % at 3.7 % volume fraction in the Fig. 20 Cornell box, docs/guo21.md).
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/media/concepts.hpp"
#include "grainlight/optics/bulk.hpp"
#include "grainlight/optics/fresnel.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/particle.hpp"
#include "grainlight/phase/mie.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace grainlight {

/// Query-cylinder radius from Guo21 Eq. 23 read as a length: S_A = k S_pix z_med / z_near is the
/// diameter of the cross section, r_c = S_A / 2. S_pix is the pixel's side on the near plane at
/// z_near (for a pinhole camera S_pix / z_near = its pixel spread angle).
[[nodiscard]] inline double query_radius_eq23(double k, double pixel_size, double z_near, double z_med) {
    const char* who = "query_radius_eq23";
    check_argument(std::isfinite(k) && k > 0, who, "k", k, "> 0 (finite)");
    check_argument(std::isfinite(pixel_size) && pixel_size > 0, who, "pixel_size", pixel_size, "> 0 (finite)");
    check_argument(std::isfinite(z_near) && z_near > 0, who, "z_near", z_near, "> 0 (finite)");
    check_argument(std::isfinite(z_med) && z_med > 0, who, "z_med", z_med, "> 0 (finite)");
    return 0.5 * k * pixel_size * z_med / z_near;
}

/// Mean-extinction factor of the membership rule (centres within r_p + r_c, A = pi r_c^2) for a
/// Poisson cloud of particles of radius r_p and extinction cross section C_t (same units):
/// (1 + r_p / r_c)^2 (1 - e^{-c}) / c with c = C_t / (pi r_c^2).
[[nodiscard]] inline double membership_extinction_factor(double r_p, double r_c, double C_t) {
    const double c = C_t / (pi_v<double> * r_c * r_c);
    const double g = c > 1e-8 ? -std::expm1(-c) / c : 1.0 - 0.5 * c;
    return (1 + r_p / r_c) * (1 + r_p / r_c) * g;
}

/// How a DiscreteParticleMedium samples free flights and directions (docs/guo21.md derives both).
enum class DiscreteSampling {
    /// At the members of the query cylinder (forced or analog collisions, the member's own phase
    /// function): energy is conserved for every realization. The default.
    member,
    /// Guo21 Sec. 5.5: distances from the global sigma_t, directions from the global (ensemble)
    /// phase function, weighted by T_A(x, y) Q(y, theta) / (sigma e^{-sigma t} p(theta)) with Q
    /// from Eq. 24 over the query sphere at y; an escape weighted T_A(x, z) / e^{-sigma z}.
    /// Unbiased for Eq. 21 per realization; energy is conserved only on average over placements.
    global,
};

/// Settings of a DiscreteParticleMedium: wavelength, query-cylinder radius r_c (Guo21 Eq. 23),
/// diffraction on/off (-FD), radius binning of the per-particle optics, forced-collision floor
/// q_min and the phase-table resolution. Validated by the DiscreteParticleMedium constructor.
struct DiscreteMediumSettings {
    double wavelength_um = 0.55;  ///< vacuum wavelength of the (grey) channel
    double query_radius = 0;      ///< r_c [scene units], > 0 and <= the grid's dilation
    bool diffraction = true;      ///< false: Guo21's "-FD" (ray optics exactly)
    int radius_bins = 24;         ///< log-spaced bins per polydisperse species
    double forced_collision = 0.5;  ///< q_min in [0, 1): 0 = analog collisions
    std::size_t theta_nodes_tail = 600;  ///< phase-table angles beyond the forward peak
    DiscreteSampling sampling = DiscreteSampling::member;  ///< free-flight / direction sampler
};

/// Optics of one radius bin.
template <std::floating_point F>
struct ParticleBinOptics {
    double r_rep_um = 0;          ///< radius the optics were computed at
    /// @var C_t_um2
    /// Extinction cross section C_t at r_rep_um [um^2].
    /// @var C_s_um2
    /// Scattering cross section C_s at r_rep_um [um^2].
    /// @var C_a_um2
    /// Absorption cross section C_a = C_t - C_s at r_rep_um [um^2].
    double C_t_um2 = 0, C_s_um2 = 0, C_a_um2 = 0;
    /// Normalised phase function of the bin (tabulated from |S1|^2 + |S2|^2 at r_rep_um).
    MiePhase<F, Spectrum<1, F>> phase;
};

/// Optics of one particle of radius r_um at one wavelength: C_t, C_s, C_a [um^2] and the
/// intensities |S1|^2 + |S2|^2 on theta. diffraction = false: "-FD" (GOA without the Fraunhofer
/// term, C_t = pi r^2); Mie particles are unchanged.
inline void particle_optics(const ParticleModel& model, double r_um, double lambda_um, bool diffraction,
                            std::span<const double> theta, double& C_t, double& C_s, std::vector<double>& intensity) {
    const double k = 2 * pi_v<double> * model.host_index / lambda_um, x = k * r_um, geo = pi_v<double> * r_um * r_um;
    const auto m = model.relative_index();
    intensity.assign(theta.size(), 0.0);
    if (model.method_at(r_um) == ScatteringMethod::mie) {
        const LorenzMie mie(m, x);
        const auto q = mie.efficiencies();
        C_t = q.qext * geo;
        C_s = q.qsca * geo;
        for (std::size_t i = 0; i < theta.size(); ++i) {
            const double mu = i == 0 ? 1.0 : (theta[i] >= pi_v<double> ? -1.0 : std::cos(theta[i]));
            const auto s = mie.amplitudes(mu);
            intensity[i] = std::norm(s.S1) + std::norm(s.S2);
        }
        return;
    }
    const Goa goa(m, x, model.p_max);
    const GoaTable table(m, model.p_max, theta);
    table.intensities(x, intensity, diffraction);
    const double C_a = goa.qabs() * geo;
    C_t = diffraction ? goa.qext() * geo : geo;
    C_s = std::max(0.0, C_t - C_a);
}

/// Discrete participating medium of Guo21 (models Medium; see the file comment for membership,
/// T_A and the forced-collision free flights). Owns its per-species, per-radius-bin optics,
/// computed once in the constructor; shares the particle grid. Immutable after construction:
/// every const member may be called from any number of threads at once.
/// @tparam F floating-point type of rays and weights (particle positions are float).
template <std::floating_point F = float>
class DiscreteParticleMedium {
public:
    /// Floating-point type (Medium concept).
    using Float = F;
    /// Spectrum type: one grey channel of F (Medium concept).
    using Spectrum = grainlight::Spectrum<1, F>;
    /// Short name of Spectrum.
    using S = Spectrum;
    /// Optics of one radius bin (ParticleBinOptics).
    using Bin = ParticleBinOptics<F>;

    /// `models`: one ParticleModel per species of the grid's cloud (or one for all).
    DiscreteParticleMedium(std::shared_ptr<const ParticleGrid> grid, std::vector<ParticleModel> models,
                           const DiscreteMediumSettings& st)
        : grid_(std::move(grid)), st_(st) {
        const char* who = "DiscreteParticleMedium";
        check_argument(bool(grid_), who, "grid", "null", "a particle grid");
        const ParticleCloud& cloud = grid_->cloud();
        check_argument(cloud.size() >= 1, who, "cloud.size()", cloud.size(), ">= 1");
        check_argument(std::isfinite(st.query_radius) && st.query_radius > 0, who, "query_radius", st.query_radius,
                       "> 0 (finite; from k > 0 in Eq. 23)");
        check_argument(st.query_radius <= double(grid_->dilation()) * (1 + 1e-6), who, "query_radius", st.query_radius,
                       "<= the grid's dilation " + std::to_string(grid_->dilation()));
        check_argument(std::isfinite(st.wavelength_um) && st.wavelength_um > 0, who, "wavelength_um", st.wavelength_um,
                       "> 0 (finite)");
        check_argument(st.radius_bins >= 1 && st.radius_bins <= 4096, who, "radius_bins", st.radius_bins, "[1, 4096]");
        check_argument(st.forced_collision >= 0 && st.forced_collision < 1, who, "forced_collision", st.forced_collision,
                       "[0, 1)");
        check_argument(st.sampling == DiscreteSampling::member || st.sampling == DiscreteSampling::global, who, "sampling",
                       int(st.sampling), "DiscreteSampling::member (0) or DiscreteSampling::global (1)");
        const std::size_t ns = cloud.species_count();
        check_argument(models.size() == ns || models.size() == 1, who, "models.size()", models.size(),
                       "1 or the number of species " + std::to_string(ns));
        for (auto& m : models) m.validate();
        if (models.size() == 1 && ns > 1) models.assign(ns, models[0]);
        models_ = models;
        r_c_ = F(st.query_radius);
        inv_area_ = F(1.0 / (pi_v<double> * st.query_radius * st.query_radius));
        const double u2 = cloud.um_per_unit() * cloud.um_per_unit();

        species_.resize(ns);
        double sum_ct = 0, sum_cs = 0;
        for (std::size_t s = 0; s < ns; ++s) {
            SpeciesBins& sb = species_[s];
            double rmin = std::numeric_limits<double>::infinity(), rmax = 0;
            for (std::uint32_t i = cloud.species_begin(s); i < cloud.species_begin(s + 1); ++i) {
                rmin = std::min(rmin, double(cloud[i].r));
                rmax = std::max(rmax, double(cloud[i].r));
            }
            if (!(rmax > 0)) continue;
            const int nb = rmax > rmin * (1 + 1e-6) ? st.radius_bins : 1;
            sb.log_rmin = std::log(rmin);
            sb.inv_dlog = nb > 1 ? double(nb) / (std::log(rmax) - std::log(rmin)) : 0.0;
            const double x_max = 2 * pi_v<double> * models_[s].host_index * rmax * cloud.um_per_unit() / st.wavelength_um;
            const std::vector<double> theta = forward_peaked_theta_grid(x_max, 400, st.theta_nodes_tail);
            std::vector<double> inten;
            for (int b = 0; b < nb; ++b) {
                const double r_rep = nb == 1 ? rmin : std::exp(sb.log_rmin + (b + 0.5) / sb.inv_dlog);
                Bin bin;
                bin.r_rep_um = r_rep * cloud.um_per_unit();
                particle_optics(models_[s], bin.r_rep_um, st.wavelength_um, st.diffraction, theta, bin.C_t_um2, bin.C_s_um2,
                                inten);
                bin.C_a_um2 = bin.C_t_um2 - bin.C_s_um2;
                std::vector<S> v(theta.size());
                for (std::size_t i = 0; i < theta.size(); ++i) v[i] = S(F(inten[i]));
                bin.phase = MiePhase<F, S>::from_intensities(theta, v);
                sb.bins.push_back(std::move(bin));
                // Per-bin constants in scene units: C(r) = C(r_rep) (r / r_rep)^2.
                const double rr = r_rep;
                sb.ct_over_r2.push_back(F(sb.bins.back().C_t_um2 / u2 / (rr * rr)));
                sb.albedo.push_back(F(sb.bins.back().C_t_um2 > 0 ? sb.bins.back().C_s_um2 / sb.bins.back().C_t_um2 : 0.0));
            }
            sb.cs_sum.assign(sb.bins.size(), 0.0);
            for (std::uint32_t i = cloud.species_begin(s); i < cloud.species_begin(s + 1); ++i) {
                const int b = sb.bin_of(cloud[i].r);
                const double ct = double(sb.ct_over_r2[std::size_t(b)]) * double(cloud[i].r) * double(cloud[i].r);
                sum_ct += ct;
                sum_cs += ct * double(sb.albedo[std::size_t(b)]);
                sb.cs_sum[std::size_t(b)] += ct * double(sb.albedo[std::size_t(b)]);
            }
        }
        sigma_t_ = sum_ct / cloud.volume();
        sigma_s_ = sum_cs / cloud.volume();
        build_global_phase();
    }

    /// The particle grid the medium gathers through (shared, not copied).
    [[nodiscard]] const ParticleGrid& grid() const noexcept { return *grid_; }
    /// The particle cloud of the grid (positions and radii in scene units).
    [[nodiscard]] const ParticleCloud& cloud() const noexcept { return grid_->cloud(); }
    /// The settings the medium was built with.
    [[nodiscard]] const DiscreteMediumSettings& settings() const noexcept { return st_; }
    /// Query-cylinder radius r_c [scene units].
    [[nodiscard]] F query_radius() const noexcept { return r_c_; }
    /// Bulk (global) sigma_t = sum_i C_t,i / V and sigma_s [1/scene unit] (Eq. 16 over the domain;
    /// Guo21 Sec. 5.5's global properties).
    [[nodiscard]] double global_sigma_t() const noexcept { return sigma_t_; }
    /// Bulk (global) sigma_s = sum_i C_s,i / V [1/scene unit] (see global_sigma_t()).
    [[nodiscard]] double global_sigma_s() const noexcept { return sigma_s_; }
    /// Global (ensemble) phase function of the cloud: sum_i C_s,i f_i / sum_i C_s,i over every
    /// particle (Eq. 17 over the whole domain, Guo21 Sec. 5.5), tabulated on the union of the
    /// species' angle grids. DiscreteSampling::global samples directions from it.
    [[nodiscard]] const MiePhase<F, S>& global_phase() const noexcept { return global_phase_; }
    /// Number of species (one optics set per species).
    [[nodiscard]] std::size_t species_count() const noexcept { return species_.size(); }
    /// Radius bins of species `species` (< species_count(); not checked), in order of radius.
    [[nodiscard]] const std::vector<Bin>& bins(std::size_t species) const noexcept { return species_[species].bins; }

    /// C_t of particle i [scene units^2] and its albedo.
    [[nodiscard]] F extinction_cross_section(std::uint32_t i) const noexcept {
        const CloudParticle& p = cloud()[i];
        const SpeciesBins& sb = species_[cloud().species_of(i)];
        return sb.ct_over_r2[std::size_t(sb.bin_of(p.r))] * p.r * p.r;
    }
    /// Single-scattering albedo C_s,i / C_t,i of particle i (that of its radius bin).
    [[nodiscard]] F albedo(std::uint32_t i) const noexcept {
        const SpeciesBins& sb = species_[cloud().species_of(i)];
        return sb.albedo[std::size_t(sb.bin_of(cloud()[i].r))];
    }
    /// Phase function of particle i (that of its radius bin).
    [[nodiscard]] const MiePhase<F, S>& phase_of(std::uint32_t i) const noexcept {
        const SpeciesBins& sb = species_[cloud().species_of(i)];
        return sb.bins[std::size_t(sb.bin_of(cloud()[i].r))].phase;
    }
    /// Phase function of particle i (NEE at its scattering vertex).
    [[nodiscard]] PhaseEval<F, S> phase_eval(std::uint32_t i, const Vec3<F>& w_in, const Vec3<F>& w_out) const noexcept {
        return phase_of(i).eval(w_in, w_out);
    }
    /// The particle whose centre is exactly p (a scattering vertex), or -1.
    [[nodiscard]] std::int64_t particle_at(const Vec3<F>& p) const noexcept {
        const Vec3<float> q(p);
        for (const std::uint32_t i : grid_->cell(grid_->cell_of(q))) {
            const CloudParticle& c = cloud()[i];
            if (c.x == q.x && c.y == q.y && c.z == q.z) return std::int64_t(i);
        }
        return -1;
    }

    /// Optical depth sum_{members, 0 < s <= t} C_t,i / A of the query cylinder along ray; the
    /// gather stops once the sum exceeds tau_cap (then any value > tau_cap is returned).
    [[nodiscard]] F optical_depth(const Ray<F>& ray, F t, F tau_cap = std::numeric_limits<F>::infinity()) const noexcept {
        F tau = 0;
        grid_->for_each_in_cylinder(Vec3<float>(ray.o), Vec3<float>(ray.d), 0.0f, float(t), float(r_c_),
                                    [&](std::uint32_t i, float, float) {
                                        tau += extinction_cross_section(i) * inv_area_;
                                        return !(tau > tau_cap);
                                    });
        return tau;
    }
    /// T_A (Eqs. 18-19); deterministic (rng unused).
    [[nodiscard]] S transmittance(const Ray<F>& ray, F t, Rng&) const noexcept {
        const F tau = optical_depth(ray, t, F(40));
        return S(tau > F(40) ? F(0) : std::exp(-tau));
    }

    /// Eq. 24 over the query sphere of radius r_c (membership: centre within r_i + r_c of y;
    /// measure mu_i = 4/3 pi (r_i + r_c)^3): Q(y; w_in -> w_out) [1/scene unit/sr]; 0 for an empty
    /// sphere (Eq. 22's delta: the ray goes on unscattered).
    [[nodiscard]] F query_sphere_q(const Vec3<F>& y, const Vec3<F>& w_in, const Vec3<F>& w_out, F r_query = F(-1)) const noexcept {
        const F rq = r_query >= F(0) ? r_query : r_c_;
        F q = 0;
        grid_->for_each_in_sphere(Vec3<float>(y), float(rq), [&](std::uint32_t i, float) {
            const F R = cloud()[i].r + rq;
            const F mu = F(4.0 / 3.0) * pi_v<F> * R * R * R;
            q += extinction_cross_section(i) * albedo(i) * phase_eval(i, w_in, w_out).value[0] / mu;
            return true;
        });
        return q;
    }

    /// A free flight (see the file comment).
    [[nodiscard]] Interaction<F, S> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        Interaction<F, S> it;
        if (st_.sampling == DiscreteSampling::global) return sample_global(ray, t_max, rng);
        if (st_.forced_collision == 0) return sample_analog(ray, t_max, rng);
        // Pass 1: tau of the segment (P = 1 - e^{-tau}; beyond tau = 40 it is 1 in float and the
        // gather stops after the current voxel), keeping up to kBuffer members so that pass 2 is
        // not needed when they are all (sparse or opaque members).
        constexpr int kBuffer = 16;
        std::uint32_t buf_i[kBuffer];
        float buf_s[kBuffer];
        int nbuf = 0;
        bool overflow = false;
        F tau = 0;
        {
            const Vec3<float> o(ray.o), d(ray.d);
            const float rc = float(r_c_), tm = float(t_max);
            const CloudParticle* ps = cloud().particles().data();
            grid_->walk_voxels(o, d, 0.0f, tm, [&](std::span<const std::uint32_t> refs, float te, float tx) {
                for (const std::uint32_t i : refs) {
                    float s, b2;
                    if (!ParticleGrid::cylinder_member(ps[i], o, d, rc, s, b2)) continue;
                    if (!(s > 0.0f && s <= tm && s >= te && s < tx)) continue;
                    tau += extinction_cross_section(i) * inv_area_;
                    if (nbuf < kBuffer) {
                        buf_i[nbuf] = i;
                        buf_s[nbuf] = s;
                        ++nbuf;
                    } else {
                        overflow = true;
                    }
                }
                return !(tau > F(40));
            });
        }
        const F P = tau > F(40) ? F(1) : -std::expm1(-tau);
        const F q = P > F(0) ? std::max(P, F(st_.forced_collision)) : F(0);
        const F u = rng.uniform<F>();
        if (!(u < q)) {
            it.kind = EventKind::escape;
            it.t = t_max;
            it.p = ray(t_max);
            it.weight = S(q > F(0) ? (F(1) - P) / (F(1) - q) : F(1));
            return it;
        }
        const F tau_star = -std::log1p(-std::min(rng.uniform<F>() * P, F(1) - F(1e-7)));
        std::int64_t chosen = -1;
        float s_chosen = 0;
        if (!overflow) {
            // Order the buffered members by (s, index) (insertion sort) and invert the cumulative tau.
            for (int a = 1; a < nbuf; ++a)
                for (int b = a; b > 0 && (buf_s[b] < buf_s[b - 1] || (buf_s[b] == buf_s[b - 1] && buf_i[b] < buf_i[b - 1])); --b) {
                    std::swap(buf_s[b], buf_s[b - 1]);
                    std::swap(buf_i[b], buf_i[b - 1]);
                }
            F acc = 0;
            for (int a = 0; a < nbuf; ++a) {
                acc += extinction_cross_section(buf_i[a]) * inv_area_;
                chosen = buf_i[a];
                s_chosen = buf_s[a];
                if (acc >= tau_star) break;
            }
        } else {
            choose_member(ray, t_max, tau_star, chosen, s_chosen);
        }
        // round-off (no member reached tau*): an escape of weight 0 for this sample
        return collision_event(ray, t_max, chosen, s_chosen, P / q, F(0), rng);
    }

    /// True if the medium samples as Guo21 Sec. 5.5 (DiscreteSampling::global).
    [[nodiscard]] bool global_sampling() const noexcept { return st_.sampling == DiscreteSampling::global; }
    /// NEE at an event of DiscreteSampling::global (integrators/discrete_vpt.hpp): the factor f that
    /// turns the path throughput after the event (which carries Q(theta_s) / p(theta_s) of the
    /// sampled direction it.w) into that of the light direction w, f = Q(y, w_in -> w) p(theta_s) /
    /// Q(y, w_in -> it.w), and the global phase's pdf of w (the MIS partner). False if the event
    /// carries no Q (never for an event sample_global returned as a scatter).
    [[nodiscard]] bool global_nee_factor(const Interaction<F, S>& it, const Vec3<F>& w_in, const Vec3<F>& w, S& f,
                                         F& pdf) const noexcept {
        const F q_s = query_sphere_q(it.p, w_in, it.w);
        if (!(q_s > F(0)) || !(it.direction_pdf > F(0))) return false;
        f = S(query_sphere_q(it.p, w_in, w) * it.direction_pdf / q_s);
        pdf = global_phase_.eval(w_in, w).pdf;
        return pdf > F(0);
    }

    /// Memory of the cloud + grid [bytes].
    [[nodiscard]] std::size_t memory_bytes() const noexcept { return cloud().memory_bytes() + grid_->memory_bytes(); }

private:
    struct SpeciesBins {
        double log_rmin = 0, inv_dlog = 0;
        std::vector<Bin> bins;
        std::vector<F> ct_over_r2, albedo;
        std::vector<double> cs_sum;  // sum of C_s over the bin's particles [scene units^2]
        [[nodiscard]] int bin_of(float r) const noexcept {
            if (bins.size() <= 1) return 0;
            const int b = int((std::log(double(r)) - log_rmin) * inv_dlog);
            return std::clamp(b, 0, int(bins.size()) - 1);
        }
    };

    /// The global phase: each bin's normalised phase weighted by the bin's sum of C_s, on the
    /// sorted union of the species' angle grids.
    void build_global_phase() {
        std::vector<double> theta;
        for (const SpeciesBins& sb : species_)
            if (!sb.bins.empty()) {
                const auto g = sb.bins.front().phase.theta_grid();
                theta.insert(theta.end(), g.begin(), g.end());
            }
        std::sort(theta.begin(), theta.end());
        theta.erase(std::unique(theta.begin(), theta.end(), [](double a, double b) { return b - a < 1e-12; }), theta.end());
        std::vector<S> v(theta.size(), S(F(0)));
        for (std::size_t k = 0; k < theta.size(); ++k) {
            const double mu = std::cos(theta[k]);
            double acc = 0;
            for (const SpeciesBins& sb : species_)
                for (std::size_t b = 0; b < sb.bins.size(); ++b)
                    if (sb.cs_sum[b] > 0) acc += sb.cs_sum[b] * sb.bins[b].phase.pdf_cos_theta(mu);
            v[k] = S(F(acc));
        }
        global_phase_ = MiePhase<F, S>::from_intensities(theta, v);
    }

    /// Guo21 Sec. 5.5 (DiscreteSampling::global): t ~ sigma e^{-sigma t} with the global sigma_t;
    /// beyond t_max an escape of weight T_A(x, z) e^{sigma z}; otherwise the direction from the
    /// global phase p and the weight T_A(x, y) Q(y, theta) / (sigma e^{-sigma t} p(theta)), Q from
    /// Eq. 24 over the query sphere at y. An empty sphere has Q = 0 (Eq. 22: nothing scatters at
    /// y; the light that goes on unscattered is T_A's): the sample ends with weight 0. Unbiased for
    /// Eq. 21 (docs/guo21.md: continuing the ray at an empty sphere with these denominators would
    /// count the unscattered light twice). T_A is gathered up to an optical depth of sigma t + 110,
    /// beyond which the weight is below float's range anyway; the exponent is capped at 80 (an
    /// escape that far beyond the mean has probability < e^{-80}).
    [[nodiscard]] Interaction<F, S> sample_global(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        Interaction<F, S> it;
        const double sg = sigma_t_;
        const double u = double(rng.uniform<F>());
        const double t = sg > 0 ? -std::log1p(-std::min(u, 1.0 - 1e-12)) / sg : std::numeric_limits<double>::infinity();
        if (!(t < double(t_max))) {
            const double tau = double(optical_depth(ray, t_max, F(sg * double(t_max) + 110)));
            it.kind = EventKind::escape;
            it.t = t_max;
            it.p = ray(t_max);
            it.weight = S(F(std::exp(std::min(sg * double(t_max) - tau, 80.0))));
            return it;
        }
        const F tf = F(t);
        it.t = tf;
        it.p = ray(tf);
        it.kind = EventKind::absorb;
        it.weight = S(F(0));
        const auto ps = global_phase_.sample(ray.d, rng.template uniform2<F>());
        if (!ps || !(ps.pdf > F(0))) return it;
        const F q = query_sphere_q(it.p, ray.d, ps.w);
        if (!(q > F(0))) return it;  // Eq. 22's empty sphere (see above)
        const double tau = double(optical_depth(ray, tf, F(sg * t + 110)));
        it.kind = EventKind::scatter;
        it.has_direction = true;
        it.w = ps.w;
        it.direction_pdf = ps.pdf;
        it.nee = NeeKind::none;
        it.weight = S(F(std::exp(std::min(sg * t - tau, 80.0)) / sg * double(q) / double(ps.pdf)));
        return it;
    }

    /// Analog free flight (forced_collision = 0) in one pass: tau* ~ Exp(1) is drawn first and the
    /// members are walked in order of s until their cumulative optical depth reaches it, so the
    /// walk stops at the collision instead of gathering the whole segment (member i collides with
    /// probability 1 - e^{-C_t,i / A} given the path reached it: the same law as the forced
    /// sampler's with q = P). Event weight = the member's albedo; escape weight 1.
    [[nodiscard]] Interaction<F, S> sample_analog(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        const F tau_star = -std::log1p(-std::min(rng.uniform<F>(), F(1) - F(1e-7)));
        std::int64_t chosen = -1;
        float s_chosen = 0;
        choose_member(ray, t_max, tau_star, chosen, s_chosen, false);
        return collision_event(ray, t_max, chosen, s_chosen, F(1), F(1), rng);
    }

    /// The event of a free flight that chose member `chosen` at axis parameter s (weight scale
    /// times its albedo and the phase sample's weight; the direction is sampled from its phase
    /// table), or, for chosen < 0, the escape at t_max with escape_weight.
    [[nodiscard]] Interaction<F, S> collision_event(const Ray<F>& ray, F t_max, std::int64_t chosen, float s, F scale,
                                                    F escape_weight, Rng& rng) const noexcept {
        Interaction<F, S> it;
        if (chosen < 0) {
            it.kind = EventKind::escape;
            it.t = t_max;
            it.p = ray(t_max);
            it.weight = S(escape_weight);
            return it;
        }
        const std::uint32_t i = std::uint32_t(chosen);
        const CloudParticle& cp = cloud()[i];
        it.kind = EventKind::scatter;
        it.t = F(s);
        it.p = Vec3<F>(cp.x, cp.y, cp.z);
        const auto ps = phase_of(i).sample(ray.d, rng.template uniform2<F>());
        if (!ps) {
            it.kind = EventKind::absorb;
            it.weight = S(F(0));
            return it;
        }
        it.has_direction = true;
        it.w = ps.w;
        it.direction_pdf = ps.pdf;
        it.nee = NeeKind::none;  // generic integrators: no phase() to connect with
        it.weight = S(scale * albedo(i)) * ps.weight;
        return it;
    }

    /// The member where the cumulative optical depth (in order of s) first reaches tau_star;
    /// with `fallback`, the last member when round-off leaves tau_star (< the segment's tau)
    /// unreached; without, chosen stays -1 then (the analog sampler's escape).
    void choose_member(const Ray<F>& ray, F t_max, F tau_star, std::int64_t& chosen, float& s_chosen,
                       bool fallback = true) const noexcept {
        const Vec3<float> o(ray.o), d(ray.d);
        const float rc = float(r_c_);
        const CloudParticle* ps = cloud().particles().data();
        F acc = 0;
        std::int64_t last_member = -1;
        float last_s = 0;
        grid_->walk_voxels(o, d, 0.0f, float(t_max), [&](std::span<const std::uint32_t> refs, float te, float tx) {
            auto member = [&](std::uint32_t i, float& s) {
                float b2;
                if (!ParticleGrid::cylinder_member(ps[i], o, d, rc, s, b2)) return false;
                return s > 0.0f && s <= float(t_max) && s >= te && s < tx;
            };
            F tv = 0;
            for (const std::uint32_t i : refs) {
                float s;
                if (member(i, s)) tv += extinction_cross_section(i) * inv_area_;
            }
            if (tv <= F(0)) return true;
            if (acc + tv < tau_star) {
                acc += tv;
                // remember the farthest member in case round-off leaves tau* unreached
                for (const std::uint32_t i : refs) {
                    float s;
                    if (member(i, s) && (last_member < 0 || s >= last_s)) last_member = i, last_s = s;
                }
                return true;
            }
            // Members of this voxel in order of (s, index).
            float prev_s = -std::numeric_limits<float>::infinity();
            std::uint32_t prev_i = 0;
            bool first = true;
            for (;;) {
                std::int64_t best = -1;
                float best_s = 0;
                for (const std::uint32_t i : refs) {
                    float s;
                    if (!member(i, s)) continue;
                    const bool after = first || s > prev_s || (s == prev_s && i > prev_i);
                    if (!after) continue;
                    if (best < 0 || s < best_s || (s == best_s && i < std::uint32_t(best))) best = i, best_s = s;
                }
                if (best < 0) break;
                first = false;
                prev_s = best_s;
                prev_i = std::uint32_t(best);
                last_member = best;
                last_s = best_s;
                acc += extinction_cross_section(std::uint32_t(best)) * inv_area_;
                if (acc >= tau_star) {
                    chosen = best;
                    s_chosen = best_s;
                    return false;
                }
            }
            return true;
        });
        if (fallback && chosen < 0 && last_member >= 0) {
            chosen = last_member;
            s_chosen = last_s;
        }
    }

    std::shared_ptr<const ParticleGrid> grid_;
    DiscreteMediumSettings st_;
    std::vector<ParticleModel> models_;
    std::vector<SpeciesBins> species_;
    F r_c_ = 0, inv_area_ = 0;
    double sigma_t_ = 0, sigma_s_ = 0;
    MiePhase<F, S> global_phase_;
};

/// Homogeneous grey medium with forced collisions (the paired continuous medium of Guo21
/// Sec. 6.3, sampled like DiscreteParticleMedium so that thin media are not left to analog
/// free flights): over a segment of length t_max, P = 1 - e^{-sigma_t t_max}; a collision is
/// forced with probability q = max(P, q_min) at a distance from the exponential truncated to
/// [0, t_max], weight (P / q) albedo; otherwise escape with weight (1 - P) / (1 - q). Unbiased for
/// the RTE; NEE through phase() (a PhaseMedium).
template <class Phase>
class ForcedCollisionMedium {
public:
    /// Floating-point type (the phase function's).
    using Float = typename Phase::Float;
    /// Short name of Float.
    using F = Float;
    /// Spectrum type: one grey channel of F (Medium concept).
    using Spectrum = grainlight::Spectrum<1, F>;
    /// Short name of Spectrum.
    using S = Spectrum;

    /// Medium of extinction coefficient sigma_t >= 0 [1/scene unit], single-scattering albedo in
    /// [0, 1], phase function `phase` and forced-collision floor q_min in [0, 1) (0: analog free
    /// flights); throws grainlight::invalid_argument naming the parameter otherwise.
    ForcedCollisionMedium(F sigma_t, F albedo, Phase phase, F q_min = F(0.5))
        : sigma_t_(sigma_t), albedo_(albedo), q_min_(q_min), phase_(std::move(phase)) {
        check_argument(std::isfinite(sigma_t) && sigma_t >= F(0), "ForcedCollisionMedium", "sigma_t", sigma_t, "[0, inf)");
        check_argument(albedo >= F(0) && albedo <= F(1), "ForcedCollisionMedium", "albedo", albedo, "[0, 1]");
        check_argument(q_min >= F(0) && q_min < F(1), "ForcedCollisionMedium", "q_min", q_min, "[0, 1)");
    }
    /// Phase function (NEE at scattering vertices).
    [[nodiscard]] const Phase& phase() const noexcept { return phase_; }
    /// Extinction coefficient sigma_t [1/scene unit].
    [[nodiscard]] F sigma_t() const noexcept { return sigma_t_; }
    /// Transmittance exp(-sigma_t t) over [0, t] (deterministic; rng unused).
    [[nodiscard]] S transmittance(const Ray<F>&, F t, Rng&) const noexcept { return S(std::exp(-sigma_t_ * t)); }
    /// Forced-collision free flight over [0, t_max] (see the class comment): a scatter event with
    /// weight (P / q) albedo or an escape at t_max with weight (1 - P) / (1 - q).
    [[nodiscard]] Interaction<F, S> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        Interaction<F, S> it;
        const F P = std::isinf(t_max) ? (sigma_t_ > F(0) ? F(1) : F(0)) : -std::expm1(-sigma_t_ * t_max);
        const F q = P > F(0) ? std::max(P, q_min_) : F(0);
        if (!(rng.uniform<F>() < q)) {
            it.kind = EventKind::escape;
            it.t = t_max;
            it.p = ray(t_max);
            it.weight = S(q > F(0) ? (F(1) - P) / (F(1) - q) : F(1));
            return it;
        }
        const F t = std::min(-std::log1p(-rng.uniform<F>() * P) / sigma_t_, t_max);
        it.kind = EventKind::scatter;
        it.t = t;
        it.p = ray(t);
        it.nee = NeeKind::phase;
        it.weight = S(P / q * albedo_);
        return it;
    }

private:
    F sigma_t_, albedo_, q_min_;
    Phase phase_;
};

/// Sphere lookups of ExplicitSphereMedium through a ParticleGrid (the default lookup). A lookup
/// type provides `particles()` (the spheres, indexed as the cloud), `containing(p)` (a sphere
/// whose interior holds p, or -1) and `first_hit(o, d, t_max, t_hit)` (the first sphere entered
/// along o + t d for t in (1e-5 r, t_max], or -1; t_hit its entry distance), all const, noexcept
/// and allocation-free, so another structure over the same spheres (a BVH, an Embree scene) can be
/// ExplicitSphereMedium's second template argument.
class GridSphereLookup {
public:
    /// Lookups in `grid` (not null); throws grainlight::invalid_argument otherwise.
    explicit GridSphereLookup(std::shared_ptr<const ParticleGrid> grid) : grid_(std::move(grid)) {
        check_argument(bool(grid_), "ExplicitSphereMedium", "grid", "null", "a particle grid");
    }
    /// The particle grid (shared, not copied).
    [[nodiscard]] const ParticleGrid& grid() const noexcept { return *grid_; }
    /// The spheres.
    [[nodiscard]] const CloudParticle* particles() const noexcept { return grid_->cloud().particles().data(); }
    /// Sphere containing p, or -1.
    [[nodiscard]] std::int64_t containing(const Vec3<float>& p) const noexcept {
        std::int64_t found = -1;
        grid_->for_each_in_sphere(p, 0.0f, [&](std::uint32_t i, float) {
            found = i;
            return false;
        });
        return found;
    }
    /// First sphere entered along o + t d, t in (1e-5 r, t_max]: index (or -1) and t_hit.
    [[nodiscard]] std::int64_t first_hit(const Vec3<float>& o, const Vec3<float>& d, float t_max, float& t_hit) const noexcept {
        const CloudParticle* ps = particles();
        std::int64_t best = -1;
        float best_t = t_max;
        grid_->walk_voxels(o, d, 0.0f, t_max, [&](std::span<const std::uint32_t> refs, float, float tx) {
            for (const std::uint32_t i : refs) {
                float s, b2;
                if (!ParticleGrid::cylinder_member(ps[i], o, d, 0.0f, s, b2)) continue;
                const float h = std::sqrt(std::max(0.0f, ps[i].r * ps[i].r - b2));
                const float t = s - h;
                if (t > 1e-5f * ps[i].r && t <= best_t) best = i, best_t = t;
            }
            return !(best >= 0 && best_t < tx);
        });
        t_hit = best_t;
        return best;
    }

private:
    std::shared_ptr<const ParticleGrid> grid_;
};

/// The cloud as explicit smooth dielectric spheres of relative index eta (Guo21's EPT), found
/// through `Lookup` (GridSphereLookup by default; see there for what another lookup provides).
template <std::floating_point F = float, class Lookup = GridSphereLookup>
class ExplicitSphereMedium {
public:
    /// Floating-point type (Medium concept).
    using Float = F;
    /// Spectrum type: one grey channel of F (Medium concept).
    using Spectrum = grainlight::Spectrum<1, F>;
    /// Short name of Spectrum.
    using S = Spectrum;

    /// Spheres of `grid`'s cloud (not null) with relative refractive index eta (> 0, != 1, finite);
    /// throws grainlight::invalid_argument otherwise. Immutable: const members are thread-safe.
    ExplicitSphereMedium(std::shared_ptr<const ParticleGrid> grid, F eta)
        requires std::same_as<Lookup, GridSphereLookup>
        : ExplicitSphereMedium(GridSphereLookup(std::move(grid)), eta) {}
    /// Spheres found through `lookup`, relative refractive index eta (> 0, != 1, finite).
    ExplicitSphereMedium(Lookup lookup, F eta) : lookup_(std::move(lookup)), eta_(eta) {
        check_argument(std::isfinite(eta) && eta > F(0) && eta != F(1), "ExplicitSphereMedium", "eta", eta,
                       "> 0, != 1 (finite)");
    }
    /// The particle grid (shared, not copied).
    [[nodiscard]] const ParticleGrid& grid() const noexcept
        requires std::same_as<Lookup, GridSphereLookup>
    {
        return lookup_.grid();
    }
    /// The sphere lookup.
    [[nodiscard]] const Lookup& lookup() const noexcept { return lookup_; }

    /// Sphere containing p, or -1.
    [[nodiscard]] std::int64_t sphere_containing(const Vec3<float>& p) const noexcept { return lookup_.containing(p); }
    /// First sphere hit along o + t d, t in (eps, t_max]: index (or -1) and t.
    [[nodiscard]] std::int64_t first_hit(const Vec3<float>& o, const Vec3<float>& d, float t_max, float& t_hit) const noexcept {
        return lookup_.first_hit(o, d, t_max, t_hit);
    }

    /// Transmittance along `ray` over [0, t]: 0 if the origin is inside a sphere or a sphere surface
    /// is hit before t, else 1 (deterministic; rng unused).
    [[nodiscard]] S transmittance(const Ray<F>& ray, F t, Rng&) const noexcept {
        const Vec3<float> o(ray.o), d(ray.d);
        if (sphere_containing(o) >= 0) return S(F(0));
        float th;
        return S(first_hit(o, d, float(t), th) >= 0 ? F(0) : F(1));
    }

    /// Next event along `ray` before t_max. From outside: the first sphere hit is crossed whole, as
    /// one event (ray optics of a sphere exactly, Guo21's -FD): a polarization (s or p, each with
    /// probability 1/2) is drawn for the crossing, the path reflects there with that
    /// polarization's Fresnel R(theta_i) or refracts in, and inside it meets the surface at the
    /// same angle every time (chord 2 r cos theta_t), reflecting with the same R (Stokes
    /// reciprocity) until it refracts out: the event is at the exit point, with the exit direction
    /// (has_direction, no NEE). Averaged over the two polarizations this is (|S1|^2 + |S2|^2) / 2
    /// of GOA without diffraction, every order p included; an unpolarized R at each bounce is not
    /// (tested). A path whose origin is inside a sphere (it started there) leaves it with the
    /// unpolarized Fresnel of the exit surface. Escape at t_max if no sphere is hit.
    [[nodiscard]] Interaction<F, S> sample_interaction(const Ray<F>& ray, F t_max, Rng& rng) const noexcept {
        Interaction<F, S> it;
        const Vec3<float> o(ray.o), d(ray.d);
        const CloudParticle* ps = lookup_.particles();
        std::int64_t idx = sphere_containing(o);
        const bool from_inside = idx >= 0;
        float t = 0;
        if (from_inside) {  // inside sphere idx: leave it
            const CloudParticle& c = ps[idx];
            const Vec3<float> v = c.center() - o;
            const float s = glm::dot(v, d), b2 = glm::dot(v, v) - s * s;
            t = s + std::sqrt(std::max(0.0f, c.r * c.r - b2));
            if (!(t < float(t_max))) idx = -1, t = float(t_max);
        } else {
            idx = first_hit(o, d, float(t_max), t);
        }
        if (idx < 0) {
            it.kind = EventKind::escape;
            it.t = t_max;
            it.p = ray(t_max);
            return it;
        }
        const CloudParticle& c = ps[idx];
        const Vec3<F> centre(c.center());
        Vec3<F> p = ray(F(t));
        Vec3<F> n = glm::normalize(p - centre);
        Vec3<F> w;
        if (from_inside) {
            bool refracted = false;
            w = sample_dielectric_dir(ray.d, n, rng.uniform<F>(), refracted);
        } else {
            w = cross_sphere(ray.d, centre, F(c.r), p, n, rng);
        }
        // Offset to the side the new direction leaves into.
        const F eps = F(2e-4) * F(c.r) + F(1e-6) * max_abs_component(p);
        it.kind = EventKind::scatter;
        it.t = F(t);
        it.p = p + (glm::dot(w, n) > F(0) ? eps : -eps) * n;
        it.w = w;
        it.has_direction = true;
        it.direction_pdf = F(0);
        it.nee = NeeKind::none;
        return it;
    }

private:
    /// Whole crossing of the sphere (centre, radius r) hit at p (outward normal n) by a path
    /// along d, with one polarization drawn for it (see sample_interaction). Returns the new
    /// direction; p and n become the exit point and its outward normal (unchanged on reflection
    /// at p).
    [[nodiscard]] Vec3<F> cross_sphere(const Vec3<F>& d, const Vec3<F>& centre, F r, Vec3<F>& p, Vec3<F>& n,
                                       Rng& rng) const noexcept {
        const F cos_i = std::clamp(-glm::dot(d, n), F(0), F(1));
        F r_perp, r_parl;
        const bool transmits = fresnel_amplitudes(cos_i, eta_, r_perp, r_parl);
        const F amp = rng.uniform<F>() < F(0.5) ? r_perp : r_parl;
        const F R = transmits ? amp * amp : F(1);
        const Vec3<F> reflected = glm::normalize(d - F(2) * glm::dot(d, n) * n);
        if (!transmits || rng.uniform<F>() < R) return reflected;
        Vec3<F> w;
        if (!refract(-d, n, eta_, w)) return reflected;
        w = glm::normalize(w);
        // Inside: every chord is 2 r cos theta_t long and meets the surface at theta_t, where the
        // same polarization reflects with the same R; the number of internal reflections is
        // geometric. (R < 1 strictly here; the cap only guards against round-off.)
        const F chord = F(2) * r * std::max(F(0), -glm::dot(w, n));
        for (int k = 0; k < 100000; ++k) {
            p = p + chord * w;
            n = glm::normalize(p - centre);
            p = centre + r * n;  // back onto the surface (no drift over many reflections)
            if (!(rng.uniform<F>() < R)) break;
            w = glm::normalize(w - F(2) * glm::dot(w, n) * n);
        }
        Vec3<F> out;
        if (!refract(-w, n, eta_, out)) return glm::normalize(w - F(2) * glm::dot(w, n) * n);  // round-off only
        return glm::normalize(out);
    }

    /// Fresnel reflection (probability F) or refraction at the sphere surface with outward n.
    [[nodiscard]] Vec3<F> sample_dielectric_dir(const Vec3<F>& d, const Vec3<F>& n, F u, bool& refracted) const noexcept {
        const Vec3<F> wi = -d;
        const F cos_i = glm::dot(wi, n);
        const F fr = fresnel_dielectric(cos_i, eta_);
        Vec3<F> wt(F(0));
        F er = F(1);
        if (u >= fr && refract(wi, n, eta_, wt, &er)) {
            refracted = true;
            return glm::normalize(wt);
        }
        refracted = false;
        return glm::normalize(d - F(2) * glm::dot(d, n) * n);
    }

    Lookup lookup_;
    F eta_;
};

}  // namespace grainlight
