// Wang18 multiple-scattering term: the tests that separate the causes of its bias (issue 11,
// item 1) and the bounced term (Eq. 8).
//  (a) the table itself against a direct infinite-medium tally at the same points (no grid, no
//      direction bins: every event of order >= 2 inside a small ball around the point adds its
//      own phase value toward the outgoing direction), nearest and interpolated direction lookup;
//  (b) the infinite-medium assumption: the same source at the centre of a sphere whose boundary
//      lets light leave (a table whose walks stop at radius R), against the infinite medium;
//      the light the boundary removes (the "boundary share") shrinks with R;
//  (c) the tree-cut aggregation of Eq. 7 against the brute-force sum over every volume sample;
//  (d) Eq. 8 through the surface samples' tree cut against the brute-force sum over every
//      surface sample written out here;
//  (e) Eq. 8 next to a bounce sample (ring quadrature) against a fine integral over the disks;
//  (f) the cuts' culling beyond the kernels' reach against the same cuts without it.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

#include "scene_fixture.hpp"

using namespace pb_test;

namespace {

// Direct tally of the emission density L_o (table units: 1 / (l^3 sr) per unit source power) at
// point X, one sum per set of directions (each averaged over its directions): events of order >= 2
// in a ball of radius delta around X.
struct BallTally {
    Vec3<double> X;
    std::vector<std::vector<Vec3<double>>> sets;
    double delta2;
    const Phase* phase;
    std::vector<double> sums{};
    bool on_scatter(PathState<float, Grey>& st, const Interaction<float, Grey>& it, const MediumT&) noexcept {
        if (st.depth < 2) return true;
        const Vec3<double> p(it.p);
        const Vec3<double> d = p - X;
        if (glm::dot(d, d) < delta2)
            for (std::size_t k = 0; k < sets.size(); ++k) {
                double e = 0;
                for (const auto& w : sets[k]) e += double(phase->eval(st.ray.d, Vec3f(w)).value[0]);
                sums[k] += double(st.throughput[0]) * e / double(sets[k].size());
            }
        return glm::dot(p, p) < 24.0 * 24.0;
    }
};

// F_dr = 2 int_0^1 F_in(mu) mu dmu for light inside (relative index kEta), by 20000 midpoints in mu:
// the normalization of the specular bounce lobe, integrated independently of the library's
// fresnel_diffuse_reflectance (256 midpoints in mu^2).
double inside_fresnel_mean() {
    double fdr = 0;
    for (int i = 0; i < 20000; ++i) {
        const double mu = (i + 0.5) / 20000;
        fdr += 2 * mu * double(fresnel_dielectric(float(-mu), kEta)) / 20000;
    }
    return fdr;
}

std::vector<double> direct_emission(float albedo, float g, Vec3<double> X, std::vector<std::vector<Vec3<double>>> sets,
                                    double delta, int photons) {
    const Phase ph(g);
    const MediumT m(1.0f, albedo, ph);
    const InfiniteMediumScene<MediumT> scene{m};
    BallTally t{X, std::move(sets), delta * delta, &ph};
    t.sums.assign(t.sets.size(), 0.0);
    WalkOptions<float> wo;
    wo.mode = TransportMode::importance;
    wo.rr_depth = 1 << 20;
    for (int i = 0; i < photons; ++i) {
        Rng rng = Rng::from_key(99, std::uint64_t(i));
        const auto ps = ph.sample(Vec3f(0, 0, 1), rng.uniform2<float>());
        PathState<float, Grey> st = start_path<float, Grey>(Ray<float>(Vec3f(0.0f), ps.w), 0, ps.weight);
        (void)walk(scene, st, rng, t, wo);
    }
    const double vol = 4.0 / 3.0 * pi_v<double> * delta * delta * delta;
    for (double& v : t.sums) v /= double(photons) * vol;
    return t.sums;
}

}  // namespace

TEST_CASE("ms_bias (a): the table equals a direct infinite-medium tally at the same points", "[ms_bias]") {
    // alpha 0.7, g 0.5; table cells of 0.25 mfp, 15 deg x 22.5 deg bins. Reference: the direct
    // ball tally (delta = 0.25 mfp, 300 000 photons: ~3 % MC error at these points).
    const float alpha = 0.7f, g = 0.5f;
    MsTableOptions o;
    o.n_rho = 24;
    o.n_z = 48;
    o.n_theta = 12;
    o.n_phi = 8;
    o.rho_max = 6;
    o.z_min = -6;
    o.z_max = 6;
    o.photons = 300000;
    const auto t = MsTable<1>::build(Phase(g), Grey(alpha), o);
    struct Pt {
        double rho, z, cos_t, phi;
    };
    const Pt pts[] = {{1.0, 1.5, 0.8, 0.5}, {1.5, -0.5, 0.0, 1.5}, {0.7, 2.5, 0.95, 0.0}};
    std::vector<double> err_nearest, err_interp;
    for (const Pt& p : pts) {
        const Vec3<double> X(p.rho, 0.0, p.z);
        const double s = std::sqrt(1 - p.cos_t * p.cos_t);
        const Vec3<double> w(s * std::cos(p.phi), s * std::sin(p.phi), p.cos_t);
        // The direct emission toward w, and averaged over w's table bin (8 x 8 directions equal
        // in cos theta and phi, both mirror images): a table of bins holds bin averages.
        const std::size_t j = t.direction_bin(p.cos_t, p.phi);
        std::vector<Vec3<double>> ws;
        for (int a = 0; a < 8; ++a)
            for (int b = 0; b < 8; ++b)
                for (int m = 0; m < 2; ++m) ws.push_back(ms_bin_point(t.grid(), j, (a + 0.5) / 8, (b + 0.5) / 8, m == 1));
        const std::vector<double> d = direct_emission(alpha, g, X, {{w}, ws}, 0.25, 300000);  // one walk, both tallies
        const double direct = d[0], direct_bin = d[1];
        const double nearest = t.eval(0, p.rho, p.z, p.cos_t, p.phi);
        const double interp = t.eval_interpolated(0, p.rho, p.z, p.cos_t, p.phi);
        std::printf("ms_bias (a) rho %.1f z %.1f: direct %.4g  table nearest %.4g (%+.1f%%)  interpolated %.4g (%+.1f%%)"
                    "  direct bin average %.4g, nearest vs it %+.1f%%\n",
                    p.rho, p.z, direct, nearest, 100 * (nearest / direct - 1), interp, 100 * (interp / direct - 1),
                    direct_bin, 100 * (nearest / direct_bin - 1));
        // The nearest bin is the direct emission averaged over that bin, within the bilinear
        // (rho, z) lookup's resolution and the MC error (~3 % on each side): measured +4 %, +10 %,
        // -9 %. It fails with a wrong normalisation, a missing or non-conserving phase
        // convolution, or a swapped (rho, z).
        CHECK(nearest == Approx(direct_bin).epsilon(0.12));
        // Against the emission toward w itself the interpolated lookup keeps within 15 % (the
        // last point: a forward-peaked lobe 18 deg off the axis, where 15 deg bins average the
        // peak away: -13 %).
        CHECK(interp == Approx(direct).epsilon(0.15));
        err_nearest.push_back(std::abs(nearest / direct - 1));
        err_interp.push_back(std::abs(interp / direct - 1));
    }
    // Nearest-bin lookup at a direction between bin centres (theta 90 deg, phi 86 deg): +20 %;
    // bilinear between bin centres: +4 %.
    CHECK(err_interp[1] < 0.5 * err_nearest[1]);
}

TEST_CASE("ms_bias (b): the light a boundary removes from a central source shrinks with the optical radius",
          "[ms_bias]") {
    // The same source in a sphere of radius R whose boundary lets light leave (walks stop at R,
    // as an index-matched boundary): table total over the ball vs the infinite medium.
    // alpha 0.9 (many events), g 0.7.
    MsTableOptions o;
    o.n_rho = 8;
    o.n_z = 16;
    o.n_theta = 2;
    o.n_phi = 1;
    o.rho_max = 2;
    o.z_min = -2;
    o.z_max = 2;
    o.photons = 60000;
    const float alpha = 0.9f, g = 0.7f;
    o.escape_radius = 40;
    const auto inf = MsTable<1>::build(Phase(g), Grey(alpha), o);
    double prev_share = 1;
    for (double R : {2.0, 5.0, 20.0}) {
        o.escape_radius = R;
        const auto bounded = MsTable<1>::build(Phase(g), Grey(alpha), o);
        const double share = 1 - bounded.total(0) / inf.total(0);  // within 2 mfp of the source
        std::printf("ms_bias (b) R = %4.0f mfp: boundary share of the emission within 2 mfp = %.1f%%\n", R, 100 * share);
        CHECK(share < prev_share);
        prev_share = share;
        if (R >= 20) CHECK(std::abs(share) < 0.02);  // interior: the infinite medium is exact
        if (R <= 2) CHECK(share > 0.2);               // small sphere: the table over-counts
    }
}

TEST_CASE("ms_bias (c, d): tree cuts of Eq. 7 and Eq. 8 against brute-force sums", "[ms_bias]") {
    MsTableOptions t;
    t.n_rho = 16;
    t.n_z = 32;
    t.n_theta = 8;
    t.n_phi = 4;
    t.rho_max = 6;
    t.z_min = -6;
    t.z_max = 6;
    t.photons = 20000;
    const auto table = MsTable<1>::build(Phase(kG), Grey(kAlbedo), t);
    PointBasedOptions<float> o;
    o.volume_step = 0.15f;
    o.light_samples = 1;
    o.light_bounces = 0;
    o.k_max = 4;
    o.bounce_samples = 300;
    o.bounce_rays = 2;
    o.bounce_k_max = 2;
    o.bounce_generations = 1;
    o.bounce_disk_quadrature = false;  // (d) checks Eq. 8 at the sample centres; (e) the disk quadrature
    o.cut = CutCriterion<float>{0.2f, 0.02f, pi_v<float> / 4};
    Rng rng = Rng::from_key(11);
    const Renderer r(medium(), kEta, sphere(), sphere_surface_samples(sphere(), 1200),
                     Light<float, Grey>::quad_light(quad(), Grey(1.0f)), o, rng, &table);
    REQUIRE(r.surface_tree().items().size() == 300);
    const MediumT m = medium();
    const float area = 4 * pi_v<float> / 300;
    const Vec3f omega = glm::normalize(Vec3f(0.1f, -0.3f, -1.0f));
    const double fdr = inside_fresnel_mean();
    for (const Vec3f P : {Vec3f(0.0f, 0.6f, 0.3f), Vec3f(-0.4f, -0.2f, 0.5f), Vec3f(0.1f, 0.1f, 0.0f)}) {
        // (c) Eq. 7: cut vs every volume sample.
        Grey d0(0.0f), m0(0.0f), d1(0.0f), m1(0.0f);
        r.gather_point_brute_force(P, omega, d0, m0);
        r.gather_point(P, omega, d1, m1);
        std::printf("ms_bias (c) multiple: cut %.4g  brute force %.4g (%+.1f%%)\n", m1[0], m0[0], 100 * (m1[0] / m0[0] - 1));
        CHECK(m0[0] > 0.0f);
        CHECK(m1[0] == Approx(m0[0]).epsilon(0.05));
        // (d) Eq. 8 written out over every surface sample: sigma_s I_j f(c) Omega_j / A_j T(q) p,
        // with the default specular storage's lobe f = F_in(c) / F_dr (inside_fresnel_mean).
        double brute = 0;
        for (const auto& it : r.surface_tree().items()) {
            const Vec3f q = P - it.p;
            const float d = glm::length(q);
            const Vec3f qh = q / d;
            const float c = glm::dot(qh, it.d);
            if (c <= 0) continue;
            const double x = double(area) * c / (pi_v<double> * d * d);
            const double om = 2 * pi_v<double> * (1 - 1 / std::sqrt(1 + x));
            const double lobe = double(fresnel_dielectric(-c, kEta)) / fdr;
            brute += double(m.sigma_s()[0]) * it.w[0] * lobe * om / area * std::exp(-kSigmaT * d) *
                     m.phase().eval(qh, -omega).value[0];
        }
        const Grey bb = r.gather_bounced_brute_force(P, omega), bc = r.gather_bounced(P, omega);
        std::printf("ms_bias (d) bounced: brute force %.4g, by hand %.4g, cut %.4g\n", bb[0], brute, bc[0]);
        CHECK(brute > 0);
        CHECK(bb[0] == Approx(brute).epsilon(2e-3));
        CHECK(bc[0] == Approx(brute).epsilon(0.05));
    }
}

TEST_CASE("ms_bias (e): Eq. 8 next to a bounce sample, ring quadrature over the disk vs a fine integral over the disks", "[ms_bias]") {
    // The light of bounce sample j is spread over the disk of its area in its tangent plane; the
    // exact Eq. 8 next to it is sigma_s (I_j / A_j) int_disk f(cos) cos e^{-sigma_t r} / r^2 p dA,
    // f = 1 for the diffuse storage and, for the specular one, the Fresnel lobe F_in(cos) / F_dr
    // of an isotropic inside radiance (F_dr: inside_fresnel_mean). A 60 x 48 polar-grid integral
    // per disk is the reference; the ring quadrature must be within 10 % of it and closer to it
    // than the centre-point kernel.
    const double fdr = inside_fresnel_mean();
    MsTableOptions t;
    t.n_rho = 8;
    t.n_z = 16;
    t.n_theta = 4;
    t.n_phi = 2;
    t.photons = 2000;
    const auto table = MsTable<1>::build(Phase(kG), Grey(kAlbedo), t);
    for (const BounceReflection mode : {BounceReflection::diffuse, BounceReflection::specular}) {
        const bool spec = mode == BounceReflection::specular;
        PointBasedOptions<float> o;
        o.bounce_samples = 300;
        o.bounce_rays = 2;
        o.bounce_k_max = 2;
        o.bounce_generations = 1;
        o.bounce_reflection = mode;
        Rng rng = Rng::from_key(11);
        const Renderer r(medium(), kEta, sphere(), sphere_surface_samples(sphere(), 1200),
                         Light<float, Grey>::quad_light(quad(), Grey(1.0f)), o, rng, &table);
        o.bounce_disk_quadrature = false;
        Rng rng2 = Rng::from_key(11);
        const Renderer rc(medium(), kEta, sphere(), sphere_surface_samples(sphere(), 1200),
                          Light<float, Grey>::quad_light(quad(), Grey(1.0f)), o, rng2, &table);
        const MediumT m = medium();
        const float area = 4 * pi_v<float> / 300;
        const double a = std::sqrt(double(area) / pi_v<double>);
        const Vec3f omega = glm::normalize(Vec3f(0.1f, -0.3f, -1.0f));
        int checked = 0;
        double err_rings = 0, err_centre = 0;
        for (std::size_t pick : {std::size_t(5), std::size_t(77), std::size_t(150)}) {
            const auto& s0 = r.surface_tree().items()[pick];
            if (!(s0.w[0] > 0)) continue;
            // A receiver 0.3 disk radii inside, 0.5 radii off the sample's centre.
            const Frame<float> f0(s0.d);
            const Vec3f P = s0.p + float(0.3 * a) * s0.d + float(0.5 * a) * f0.s;
            double fine = 0;
            for (const auto& it : r.surface_tree().items()) {
                const Frame<float> fr(it.d);
                const int nr = 60, nph = 48;
                for (int i = 0; i < nr; ++i)
                    for (int k = 0; k < nph; ++k) {
                        const double rr = a * std::sqrt((i + 0.5) / nr), ph = 2 * pi_v<double> * (k + 0.5) / nph;
                        const Vec3f x = it.p + float(rr * std::cos(ph)) * fr.s + float(rr * std::sin(ph)) * fr.t;
                        const Vec3f q = P - x;
                        const double d = glm::length(q);
                        const Vec3f qh = q / float(d);
                        const double c = glm::dot(qh, it.d);
                        if (c <= 0) continue;
                        const double lobe = spec ? double(fresnel_dielectric(float(-c), kEta)) / fdr : 1.0;
                        fine += double(m.sigma_s()[0]) * it.w[0] / area * (double(area) / (nr * nph)) * lobe * c /
                                (d * d) * std::exp(-kSigmaT * d) * m.phase().eval(qh, -omega).value[0];
                    }
            }
            const double quad7 = r.gather_bounced_brute_force(P, omega)[0];
            const double centre = rc.gather_bounced_brute_force(P, omega)[0];
            std::printf("ms_bias (e) bounced next to a sample (%s): fine %.4g, rings %.4g (%+.1f%%), centre %.4g (%+.1f%%)\n",
                        spec ? "specular" : "diffuse", fine, quad7, 100 * (quad7 / fine - 1), centre,
                        100 * (centre / fine - 1));
            CHECK(quad7 == Approx(fine).epsilon(0.10));
            err_rings += std::abs(quad7 / fine - 1);
            err_centre += std::abs(centre / fine - 1);
            ++checked;
        }
        CHECK(checked >= 2);
        // Over the receivers the rings are closer than the centre point (one receiver of the
        // specular lobe can be near the centre value by chance: -5.4 % vs the rings' -6.4 %).
        CHECK(err_rings < err_centre);
    }
}

TEST_CASE("ms_bias (g): both storages of the bounced light send A_j M_j into the secondary samples", "[ms_bias]") {
    // Conservation: the secondary samples along a ray of power P hold P e^{-sigma_t u} Delta every
    // Delta (jittered), i.e. P / sigma_t in all, in an optically thick sphere (sigma_t R = 40,
    // where only rays within ~3 degrees of the tangent plane are cut short). Summed over the
    // samples this is sum_j A_j M_j / sigma_t, and sum_j A_j M_j = pi sum_j I_j from the surface
    // tree, for the paper's diffuse storage (cosine rays of equal power) and for the specular one
    // (each gather ray's mirror image with its own power). Both storages gather the same M_j.
    const float st = 40.0f;
    const MediumT m(st, kAlbedo, Phase(kG));
    double surf[2] = {0, 0}, sec[2] = {0, 0};
    int idx = 0;
    for (const BounceReflection mode : {BounceReflection::diffuse, BounceReflection::specular}) {
        PointBasedOptions<float> o;
        o.bounce_samples = 256;
        o.bounce_rays = 8;
        o.bounce_k_max = 2;
        o.bounce_generations = 1;
        o.light_bounces = 0;
        o.camera_bounces = 0;
        o.max_optical_depth = 12.0f;
        o.bounce_reflection = mode;
        Rng rng = Rng::from_key(5);
        const Renderer r(m, kEta, sphere(), sphere_surface_samples(sphere(), 800),
                         Light<float, Grey>::quad_light(quad(), Grey(1.0f)), o, rng, nullptr,
                         sphere_surface_samples(sphere(), 256));
        for (const auto& it : r.surface_tree().items()) surf[idx] += pi_v<double> * it.w[0];
        for (const auto& it : r.bounce_volume_tree().items()) sec[idx] += double(it.w[0]) * st;
        std::printf("ms_bias (g) %s storage: sum A_j M_j %.5g, secondary samples x sigma_t %.5g (%+.2f%%)\n",
                    idx ? "specular" : "diffuse", surf[idx], sec[idx], 100 * (sec[idx] / surf[idx] - 1));
        REQUIRE(surf[idx] > 0);
        CHECK(sec[idx] == Approx(surf[idx]).epsilon(0.02));
        ++idx;
    }
    CHECK(surf[1] == Approx(surf[0]).epsilon(1e-6));
}

TEST_CASE("ms_bias (f): culling the tree cuts beyond the kernels' reach changes nothing that is not below e^-30",
          "[ms_bias]") {
    // A unit sphere of optical radius 40 (sigma_t = 40): the table's grid (+-6 mean free paths,
    // reach sqrt(72) = 8.5 mfp) and the e^-30 reach of Eqs. 6 and 8 (0.75 scene units) are both
    // well inside it, so the cut from a receiver on the far side skips most of the tree.
    MsTableOptions t;
    t.n_rho = 16;
    t.n_z = 32;
    t.n_theta = 8;
    t.n_phi = 4;
    t.rho_max = 6;
    t.z_min = -6;
    t.z_max = 6;
    t.photons = 20000;
    const auto table = MsTable<1>::build(Phase(kG), Grey(kAlbedo), t);
    const MediumT m(40.0f, kAlbedo, Phase(kG));
    PointBasedOptions<float> o;
    o.volume_step = 0.01f;
    o.light_samples = 1;
    o.light_bounces = 0;
    o.max_optical_depth = 12;
    o.bounce_samples = 200;
    o.bounce_rays = 2;
    o.bounce_k_max = 2;
    o.bounce_generations = 1;
    o.cut = CutCriterion<float>{0.2f, 0.04f, pi_v<float> / 4};
    o.two_step_depth = 3;
    auto make = [&](float cull) {
        PointBasedOptions<float> oc = o;
        oc.cull_optical_distance = cull;
        Rng rng = Rng::from_key(12);
        return Renderer(m, kEta, sphere(), sphere_surface_samples(sphere(), 800),
                        Light<float, Grey>::quad_light(quad(), Grey(1.0f)), oc, rng, &table);
    };
    const Renderer culled = make(30.0f), full = make(0.0f);
    REQUIRE(culled.volume_sample_count() == full.volume_sample_count());
    const Vec3f omega = glm::normalize(Vec3f(0.1f, -0.3f, -1.0f));
    int nonzero = 0;
    // Receivers: under the lit top (in reach of the samples) and on the far side (out of reach).
    for (const Vec3f P : {Vec3f(0.0f, 0.95f, 0.05f), Vec3f(0.2f, 0.9f, -0.1f), Vec3f(0.0f, 0.5f, 0.0f),
                          Vec3f(0.0f, -0.9f, 0.2f)}) {
        Grey d0(0.0f), m0(0.0f), d1(0.0f), m1(0.0f);
        full.gather_point(P, omega, d0, m0);
        culled.gather_point(P, omega, d1, m1);
        const Grey b0 = full.gather_bounced(P, omega), b1 = culled.gather_bounced(P, omega);
        std::printf("ms_bias (f) at y = %.2f: multiple %.6g vs %.6g, double %.6g vs %.6g, bounced %.6g vs %.6g\n",
                    double(P.y), m1[0], m0[0], d1[0], d0[0], b1[0], b0[0]);
        nonzero += m0[0] > 0 ? 1 : 0;
        // The table is 0 beyond its grid: the same multiple term. Eqs. 6 and 8 lose only terms below
        // e^-30 of a sample's weight: the same to 1e-5, or below 1e-12 where the receiver is out of
        // reach (the near receivers' terms are ~0.1-1).
        CHECK(m1[0] == Approx(m0[0]).epsilon(1e-5));
        CHECK(std::abs(d1[0] - d0[0]) <= 1e-5 * std::abs(d0[0]) + 1e-12);
        CHECK(std::abs(b1[0] - b0[0]) <= 1e-5 * std::abs(b0[0]) + 1e-12);
    }
    CHECK(nonzero >= 2);  // the comparison is not between zeros only
}
