// Discrete participating media (Guo21 Secs. 5-6): particle cloud, particle grid, the discrete
// medium's T_A / free flights / Q(theta) / direction sampler, and the discrete VPT.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <set>
#include <span>
#include <tuple>
#include <vector>

#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/geometry/sphere.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace gl = grainlight;
using gl::Vec3d;
using gl::Vec3f;

namespace {

using Medium = gl::DiscreteParticleMedium<float>;

struct Setup {
    std::shared_ptr<gl::ParticleCloud> cloud;
    std::shared_ptr<gl::ParticleGrid> grid;
    std::shared_ptr<Medium> medium;
};

// Monodisperse ice-like spheres (m = 1.31, non-absorbing) in the box [0, side]^3; scene units = um.
Setup make_setup(std::uint64_t n, double r_um, double side, double r_c, std::uint64_t seed, double forced = 0.5,
                 int radius_bins = 24, int resolution = 0) {
    Setup s;
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(side));
    s.cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, n, {gl::cloud_species(gl::MonodispersePsd(r_um))}, seed, 1.0));
    gl::ParticleGridSettings gs;
    gs.dilation = r_c;
    if (resolution) gs.resolution = {resolution, resolution, resolution};
    s.grid = std::make_shared<gl::ParticleGrid>(*s.cloud, gs);
    gl::ParticleModel model;
    model.particle_index = {1.31, 0.0};
    gl::DiscreteMediumSettings ms;
    ms.query_radius = r_c;
    ms.forced_collision = forced;
    ms.radius_bins = radius_bins;
    ms.theta_nodes_tail = 300;
    s.medium = std::make_shared<Medium>(s.grid, std::vector<gl::ParticleModel>{model}, ms);
    return s;
}

Vec3f random_unit(gl::Rng& rng) { return gl::sample_uniform_sphere(rng.uniform2<float>()); }

}  // namespace

TEST_CASE("particle cloud: 16 bytes per particle, deterministic, species shares, domain", "[discrete][cloud]") {
    const gl::BoxBoundary box(Vec3d(-1.0), Vec3d(2.0));
    const std::vector<gl::CloudSpecies> mix = {gl::cloud_species(gl::LogNormalPsd(10, 2, 1, 100), 3.0),
                                               gl::cloud_species(gl::MonodispersePsd(50), 1.0)};
    const auto a = gl::ParticleCloud::generate(box, 10001, mix, 7, 1e6);
    const auto b = gl::ParticleCloud::generate(box, 10001, mix, 7, 1e6);
    REQUIRE(a.size() == 10001);
    CHECK(sizeof(gl::CloudParticle) == 16);
    CHECK(a.memory_bytes() == 16 * 10001);
    REQUIRE(a.species_count() == 2);
    CHECK(a.species_begin(1) == 7501);  // 3:1 of 10001 by largest remainders
    CHECK(a.species_of(0) == 0);
    CHECK(a.species_of(7500) == 0);
    CHECK(a.species_of(7501) == 1);
    CHECK(a.volume() == Approx(27.0));
    bool same = true;
    for (std::size_t i = 0; i < a.size(); ++i)
        same = same && a[i].x == b[i].x && a[i].y == b[i].y && a[i].z == b[i].z && a[i].r == b[i].r;
    CHECK(same);
    double mean_x = 0, rmin = 1e9, rmax = 0;
    for (std::size_t i = 0; i < a.species_begin(1); ++i) {
        CHECK((a[i].x >= -1 && a[i].x <= 2 && a[i].y >= -1 && a[i].z <= 2));
        mean_x += a[i].x;
        rmin = std::min(rmin, double(a[i].r));
        rmax = std::max(rmax, double(a[i].r));
    }
    mean_x /= a.species_begin(1);
    CHECK(mean_x == Approx(0.5).margin(4 * 3 / std::sqrt(12.0 * 7501)));  // uniform in [-1, 2]
    CHECK(rmin >= 1e-6 * 0.9999);
    CHECK(rmax <= 100e-6 * 1.0001);
    for (std::size_t i = a.species_begin(1); i < a.size(); ++i) CHECK(a[i].r == Approx(50e-6));
    // Sphere domain: every centre inside, exact volume.
    const gl::SphereBoundary ball(Vec3d(0.0), 1.0);
    const auto c = gl::ParticleCloud::generate(ball, 2000, {gl::cloud_species(gl::MonodispersePsd(1))}, 3, 1e6);
    bool inside = true;
    for (const auto& p : c.particles()) inside = inside && (p.x * p.x + p.y * p.y + p.z * p.z < 1.0001f);
    CHECK(inside);
    CHECK(c.volume() == Approx(4.0 / 3.0 * gl::pi_v<double>));
}

TEST_CASE("sort_spatially: same particles, neighbours in memory are neighbours in space", "[discrete][cloud]") {
    // A shuffled copy (from_particles keeps the given order) sorted along the Morton curve: the
    // same multiset of particles, and the mean distance between consecutive particles drops from
    // the random-pair value (~0.66 of the box side) to a few inter-particle spacings.
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    const auto gen = gl::ParticleCloud::generate(box, 20000, {gl::cloud_species(gl::LogNormalPsd(10, 2, 1, 100))}, 5, 1e6);
    std::vector<gl::CloudParticle> ps = gen.particles();
    gl::Rng rng = gl::Rng::from_key(9, 1);
    for (std::size_t i = ps.size() - 1; i > 0; --i) std::swap(ps[i], ps[std::size_t(rng.uniform<double>() * double(i + 1)) % (i + 1)]);
    auto mean_step = [](const gl::ParticleCloud& c) {
        double sum = 0;
        for (std::size_t i = 1; i < c.size(); ++i) sum += glm::length(Vec3d(c[i].center() - c[i - 1].center()));
        return sum / double(c.size() - 1);
    };
    auto key = [](const gl::CloudParticle& p) { return std::array<float, 4>{p.x, p.y, p.z, p.r}; };
    gl::ParticleCloud c = gl::ParticleCloud::from_particles(ps, gen.domain(), gen.volume());
    const double before = mean_step(c);
    c.sort_spatially();
    const double after = mean_step(c);
    INFO("mean consecutive distance " << before << " -> " << after << " (spacing " << std::cbrt(1.0 / 20000) << ")");
    CHECK(before > 0.5);
    CHECK(after < 4 * std::cbrt(1.0 / 20000));
    std::vector<std::array<float, 4>> k0, k1;
    for (const auto& p : ps) k0.push_back(key(p));
    for (const auto& p : c.particles()) k1.push_back(key(p));
    std::sort(k0.begin(), k0.end());
    std::sort(k1.begin(), k1.end());
    CHECK(k0 == k1);
    // The generators store this order already: sorting again changes nothing.
    gl::ParticleCloud again = gen;
    again.sort_spatially();
    bool same = true;
    for (std::size_t i = 0; i < gen.size(); ++i) same = same && key(again[i]) == key(gen[i]);
    CHECK(same);
}

TEST_CASE("non-overlapping cloud: no two spheres intersect (all pairs), deterministic, same radii", "[discrete][cloud]") {
    // Random sequential addition at 25 % volume fraction (RSA jams near 38 %): checked against
    // every pair, for a monodisperse cloud and a log-normal + monodisperse mixture.
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    const std::uint64_t n = 3000;
    const double r_um = 1e6 * std::cbrt(0.25 * 3 / (4 * gl::pi_v<double> * double(n)));
    const std::vector<std::vector<gl::CloudSpecies>> cases = {
        {gl::cloud_species(gl::MonodispersePsd(r_um))},
        {gl::cloud_species(gl::LogNormalPsd(0.7 * r_um, 1.3, 0.3 * r_um, 1.5 * r_um), 2.0),
         gl::cloud_species(gl::MonodispersePsd(r_um), 1.0)}};
    for (const auto& species : cases) {
        const auto a = gl::ParticleCloud::generate_non_overlapping(box, n, species, 11, 1e6);
        const auto b = gl::ParticleCloud::generate_non_overlapping(box, n, species, 11, 1e6);
        const auto poisson = gl::ParticleCloud::generate(box, n, species, 11, 1e6);
        REQUIRE(a.size() == n);
        REQUIRE(a.species_count() == poisson.species_count());
        std::size_t overlaps = 0, outside = 0, differ = 0, radius_differs = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const auto& p = a[i];
            outside += !(p.x >= 0 && p.x <= 1 && p.y >= 0 && p.y <= 1 && p.z >= 0 && p.z <= 1);
            differ += !(p.x == b[i].x && p.y == b[i].y && p.z == b[i].z && p.r == b[i].r);
            for (std::size_t j = i + 1; j < n; ++j) {
                const double dx = double(p.x) - a[j].x, dy = double(p.y) - a[j].y, dz = double(p.z) - a[j].z;
                const double R = double(p.r) + a[j].r;
                overlaps += dx * dx + dy * dy + dz * dz < R * R;
            }
        }
        // Same radii per species as the Poisson cloud (both are stored in their own spatial order,
        // so compare the sorted radii of each species range).
        for (std::size_t s = 0; s < a.species_count(); ++s) {
            std::vector<float> ra, rp;
            for (std::size_t i = a.species_begin(s); i < a.species_begin(s + 1); ++i) {
                ra.push_back(a[i].r);
                rp.push_back(poisson[i].r);
            }
            std::sort(ra.begin(), ra.end());
            std::sort(rp.begin(), rp.end());
            radius_differs += ra != rp;
        }
        CHECK(overlaps == 0);
        CHECK(outside == 0);
        CHECK(differ == 0);
        CHECK(radius_differs == 0);
        // The Poisson cloud at the same density overlaps (the test can fail): 8 phi n / 2 pairs expected.
        std::size_t poisson_overlaps = 0;
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t j = i + 1; j < n; ++j) {
                const double dx = double(poisson[i].x) - poisson[j].x, dy = double(poisson[i].y) - poisson[j].y,
                             dz = double(poisson[i].z) - poisson[j].z, R = double(poisson[i].r) + poisson[j].r;
                poisson_overlaps += dx * dx + dy * dy + dz * dz < R * R;
            }
        CHECK(poisson_overlaps > 100);
    }
    // Beyond RSA's jamming limit: a clear error naming the count.
    const double r_jam = 1e6 * std::cbrt(0.6 * 3 / (4 * gl::pi_v<double> * 500.0));
    try {
        (void)gl::ParticleCloud::generate_non_overlapping(box, 500, {gl::cloud_species(gl::MonodispersePsd(r_jam))}, 1, 1e6, 2000);
        FAIL("a 60 % volume fraction should not be placeable by random sequential addition");
    } catch (const std::invalid_argument& e) {
        CHECK(std::string(e.what()).find("count") != std::string::npos);
    }
}

TEST_CASE("bad input names the parameter", "[discrete][errors]") {
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    auto throws_with = [](auto&& f, const std::string& word) {
        try {
            f();
        } catch (const std::exception& e) {
            return std::string(e.what()).find(word) != std::string::npos;
        }
        return false;
    };
    CHECK(throws_with([&] { (void)gl::ParticleCloud::generate(box, 0, {gl::cloud_species(gl::MonodispersePsd(1))}, 1); },
                      "count"));
    CHECK(throws_with([&] { (void)gl::MonodispersePsd(-1.0); }, "radius"));
    CHECK(throws_with([&] { (void)gl::MonodispersePsd(std::nan("")); }, "radius"));
    gl::CloudSpecies bad{[](double) { return -2.0; }, 1.0, "bad"};
    CHECK(throws_with([&] { (void)gl::ParticleCloud::generate(box, 10, {bad}, 1); }, "radius_um"));
    CHECK(throws_with([&] { (void)gl::ParticleCloud::from_particles({{0, 0, 0, std::nanf("")}}, {}, 1.0); }, ".r"));
    CHECK(throws_with([&] { (void)gl::ParticleCloud::from_particles({}, {}, 1.0); }, "particles.size()"));
    // A PSD that puts no mass in [r_min, r_max].
    CHECK(throws_with([&] { (void)gl::LogNormalPsd(1.0, 1.1, 1e6, 1e7); }, "r_min, r_max"));
    CHECK(throws_with([&] { (void)gl::query_radius_eq23(0.0, 1e-3, 1.0, 2.0); }, "k"));
    CHECK(throws_with([&] { (void)gl::query_radius_eq23(-1.0, 1e-3, 1.0, 2.0); }, "k"));
    const auto cloud = gl::ParticleCloud::generate(box, 10, {gl::cloud_species(gl::MonodispersePsd(1))}, 1);
    gl::ParticleGridSettings gs;
    gs.resolution = {0, 4, 4};
    CHECK(throws_with([&] { (void)gl::ParticleGrid(cloud, gs); }, "resolution[0]"));
    gs.resolution = {4, 4, 4};
    gs.prefetch = 2;
    CHECK(throws_with([&] { (void)gl::ParticleGrid(cloud, gs); }, "prefetch"));
    gs.prefetch = -1;
    gs.dilation = 1e-3;
    auto grid = std::make_shared<gl::ParticleGrid>(cloud, gs);
    gl::DiscreteMediumSettings ms;
    ms.query_radius = 0;
    CHECK(throws_with([&] { (void)Medium(grid, {gl::ParticleModel{}}, ms); }, "query_radius"));
    ms.query_radius = 1.0;  // larger than the dilation
    CHECK(throws_with([&] { (void)Medium(grid, {gl::ParticleModel{}}, ms); }, "query_radius"));
}

TEST_CASE("grid: cylinder and sphere queries equal brute force over every particle", "[discrete][grid]") {
    // Polydisperse, dense enough that dilated spheres span several voxels.
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    const auto cloud = gl::ParticleCloud::generate(box, 4000, {gl::cloud_species(gl::LogNormalPsd(10000, 2, 1000, 60000))},
                                                   11, 1e6);
    for (const double dil : {0.0, 0.02, 0.08}) {
        for (const int res : {0, 3, 17}) {
          for (const int prefetch : {0, 1}) {  // the plain and the software-pipelined walk
            gl::ParticleGridSettings gs;
            gs.dilation = dil;
            gs.prefetch = prefetch;
            if (res) gs.resolution = {res, res + 1, res + 2};
            const gl::ParticleGrid grid(cloud, gs);
            REQUIRE(grid.prefetching() == (prefetch == 1));
            gl::Rng rng = gl::Rng::from_key(5, res, std::uint64_t(dil * 1000));
            int mismatches = 0, members_total = 0;
            for (int q = 0; q < 300; ++q) {
                const Vec3f o = Vec3f(-0.2f) + 1.4f * rng.uniform3<float>();
                const Vec3f d = random_unit(rng);
                const float t_max = 0.2f + 1.5f * rng.uniform<float>();
                const float rc = float(dil) * rng.uniform<float>();
                std::vector<std::uint32_t> got;
                grid.for_each_in_cylinder(o, d, 0.0f, t_max, rc, [&](std::uint32_t i, float, float) {
                    got.push_back(i);
                    return true;
                });
                std::vector<std::uint32_t> want;
                for (std::uint32_t i = 0; i < cloud.size(); ++i) {
                    float s, b2;
                    if (gl::ParticleGrid::cylinder_member(cloud[i], o, d, rc, s, b2) && s > 0 && s <= t_max) want.push_back(i);
                }
                std::sort(got.begin(), got.end());
                members_total += int(want.size());
                if (got != want) ++mismatches;
                // Sphere query.
                const float rq = float(dil) * rng.uniform<float>();
                std::vector<std::uint32_t> gs2, ws2;
                grid.for_each_in_sphere(o, rq, [&](std::uint32_t i, float) {
                    gs2.push_back(i);
                    return true;
                });
                for (std::uint32_t i = 0; i < cloud.size(); ++i) {
                    const Vec3f v = cloud[i].center() - o;
                    const float R = cloud[i].r + rq;
                    if (glm::dot(v, v) < R * R) ws2.push_back(i);
                }
                std::sort(gs2.begin(), gs2.end());
                if (gs2 != ws2) ++mismatches;
            }
            INFO("dilation " << dil << " resolution " << res << " prefetch " << prefetch << " members " << members_total);
            CHECK(mismatches == 0);
            CHECK(members_total > 100);
          }
        }
    }
}

TEST_CASE("grid: the software-pipelined walk visits what the plain walk visits, in order, and stops alike",
          "[discrete][grid]") {
    // The two walks share the DDA; the pipelined one runs it ahead and prefetches. Every visit
    // (cell references, t_enter, t_exit) must be identical, also when the visitor stops early
    // (a stop after the k-th visit must not visit the voxels the pipeline had already generated).
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    const auto cloud = gl::ParticleCloud::generate(box, 3000, {gl::cloud_species(gl::LogNormalPsd(8000, 2, 1000, 40000))},
                                                   17, 1e6);
    for (const int res : {0, 1, 2, 9}) {
        gl::ParticleGridSettings plain, piped;
        plain.dilation = piped.dilation = 0.01;
        if (res) plain.resolution = piped.resolution = {res, res + 3, res};
        plain.prefetch = 0;
        piped.prefetch = 1;
        const gl::ParticleGrid g0(cloud, plain), g1(cloud, piped);
        REQUIRE(!g0.prefetching());
        REQUIRE(g1.prefetching());
        gl::Rng rng = gl::Rng::from_key(9, res);
        int differ = 0, visits = 0;
        for (int q = 0; q < 400; ++q) {
            const Vec3f o = Vec3f(-0.3f) + 1.6f * rng.uniform3<float>();
            const Vec3f d = random_unit(rng);
            const float t_max = 2.0f * rng.uniform<float>();
            const int stop_after = q % 3 == 0 ? 1 + int(rng.uniform<float>() * 6) : 1 << 30;
            auto record = [&](const gl::ParticleGrid& g, std::vector<std::tuple<const std::uint32_t*, std::size_t, float, float>>& out) {
                const bool finished = g.walk_voxels(o, d, 0.0f, t_max, [&](std::span<const std::uint32_t> refs, float te, float tx) {
                    out.emplace_back(refs.data(), refs.size(), te, tx);
                    return int(out.size()) < stop_after;
                });
                out.emplace_back(nullptr, finished ? 1 : 0, 0.0f, 0.0f);
            };
            std::vector<std::tuple<const std::uint32_t*, std::size_t, float, float>> a, b;
            record(g0, a);
            record(g1, b);
            // Same cells: the reference lists are equal element by element (different grids).
            bool same = a.size() == b.size();
            for (std::size_t k = 0; same && k < a.size(); ++k) {
                const auto& [pa, na, tea, txa] = a[k];
                const auto& [pb, nb, teb, txb] = b[k];
                same = na == nb && tea == teb && txa == txb && (pa == nullptr) == (pb == nullptr) &&
                       (pa == nullptr || std::equal(pa, pa + na, pb));
            }
            visits += int(a.size()) - 1;  // without the end marker
            if (!same) ++differ;
        }
        INFO("resolution " << res << " visits " << visits);
        CHECK(differ == 0);
        CHECK(visits > 250);
    }
}

TEST_CASE("T_A of a Poisson cloud matches the closed form of the membership rule", "[discrete][transmittance]") {
    // E[T_A] = exp(-n pi (r_p + r_c)^2 L (1 - e^{-c})), c = C_t / (pi r_c^2), over placements.
    const double side = 1000, r_um = 5, r_c = 5, L = 400;
    const std::uint64_t n_part = 8000;
    double sum = 0, sum2 = 0, expected = 0, beer = 0;
    int count = 0;
    for (int real = 0; real < 12; ++real) {
        const Setup s = make_setup(n_part, r_um, side, r_c, 100 + real, 0.5, 1);
        const double Ct = s.medium->extinction_cross_section(0);
        const double c = Ct / (gl::pi_v<double> * r_c * r_c);
        const double n = double(n_part) / (side * side * side);
        expected = std::exp(-n * gl::pi_v<double> * (r_um + r_c) * (r_um + r_c) * L * -std::expm1(-c));
        beer = std::exp(-n * Ct * L);
        gl::Rng rng = gl::Rng::from_key(9, real);
        gl::Rng dummy;
        for (int q = 0; q < 300; ++q) {
            // A segment of length L well inside the box.
            const Vec3f d = random_unit(rng);
            const Vec3f mid = Vec3f(float(side / 2)) + 150.0f * (rng.uniform3<float>() - Vec3f(0.5f));
            const Vec3f o = mid - float(L / 2) * d;
            const float T = s.medium->transmittance(gl::Ray<float>(o, d), float(L), dummy)[0];
            sum += T;
            sum2 += double(T) * T;
            ++count;
        }
        if (real == 0) {
            INFO("c = " << c);
            CHECK(c > 0.5);  // not the Beer-Lambert limit: the rule's saturation matters
        }
    }
    const double mean = sum / count, var = sum2 / count - mean * mean;
    // Rays of one realization overlap a little: inflate the naive standard error 2x.
    const double se = 2 * std::sqrt(var / count);
    INFO("mean T_A " << mean << " closed form " << expected << " se " << se << " Beer-Lambert " << beer);
    CHECK(std::abs(beer - expected) > 8 * se);  // the test tells the rule from Beer-Lambert
    CHECK(std::abs(mean - expected) < 4 * se);
    CHECK(std::abs(mean - expected) < 0.02);
}

TEST_CASE("mean free flight vs 1 / sigma_t for r_c >> r_p", "[discrete][freeflight]") {
    // r_p = 5 um, r_c = 250 um: the membership factor is (1.02)^2 (1 - e^-c)/c ~ 1.04.
    const double side = 4000, r_um = 5, r_c = 250;
    const Setup s = make_setup(200000, r_um, side, r_c, 3, 0.0, 1, 16);  // analog collisions
    const double sigma = s.medium->global_sigma_t();
    const double factor = gl::membership_extinction_factor(r_um, r_c, s.medium->extinction_cross_section(0));
    CHECK(factor == Approx(1.0404).epsilon(0.002));
    const double sigma_eff = sigma * factor;
    const float L = 1500;
    gl::Rng rng = gl::Rng::from_key(77);
    double sum = 0, sum2 = 0;
    const int n = 5000;
    for (int k = 0; k < n; ++k) {
        const Vec3f d = random_unit(rng);
        const Vec3f o = Vec3f(float(side / 2)) + 500.0f * (rng.uniform3<float>() - Vec3f(0.5f)) - 0.5f * L * d;
        const auto it = s.medium->sample_interaction(gl::Ray<float>(o, d), L, rng);
        const double t = it.kind == gl::EventKind::scatter ? it.t : L;
        CHECK(it.weight[0] == Approx(1.0f));  // analog and non-absorbing
        sum += t;
        sum2 += t * t;
    }
    const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
    const double want = -std::expm1(-sigma_eff * L) / sigma_eff;  // E[min(t, L)]
    const double want_bulk = -std::expm1(-sigma * L) / sigma;
    INFO("mean " << mean << " +- " << se << " closed form " << want << " bulk 1/sigma_t form " << want_bulk << " sigma L "
                 << sigma * L);
    CHECK(std::abs(mean - want) < 4 * se);
    CHECK(std::abs(mean - want_bulk) / want_bulk < 0.05);
    CHECK(sigma * L > 0.5);
}

TEST_CASE("Q(theta) of Eq. 24 tends to sigma_s f(theta) of Eq. 17 as the query sphere grows", "[discrete][q]") {
    const double side = 2000, r_um = 5;
    const Setup s = make_setup(100000, r_um, side, 150, 21, 0.5, 1);
    const double sigma_s = s.medium->global_sigma_s();
    const Vec3f w_in(0, 0, 1);
    const auto& phase = s.medium->phase_of(0);
    gl::Rng rng = gl::Rng::from_key(4);
    std::vector<double> spread;
    for (const float rq : {20.0f, 60.0f, 150.0f}) {
        for (const double theta : {0.05, 0.5, 2.4}) {
            const Vec3f w_out(float(std::sin(theta)), 0.0f, float(std::cos(theta)));
            const double want = sigma_s * phase.eval(w_in, w_out).value[0];
            double sum = 0, sum2 = 0;
            const int n = 300;
            for (int k = 0; k < n; ++k) {
                const Vec3f y = Vec3f(float(side / 2)) + 1000.0f * (rng.uniform3<float>() - Vec3f(0.5f));
                const double q = s.medium->query_sphere_q(y, w_in, w_out, rq) / want;
                sum += q;
                sum2 += q * q;
            }
            const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
            INFO("r_q " << rq << " theta " << theta << " <Q>/(sigma_s f) " << mean << " sd " << sd);
            CHECK(std::abs(mean - 1) < 4 * sd / std::sqrt(double(n)) + 1e-3);
            if (theta == 0.5) spread.push_back(sd);
        }
    }
    // One query's relative scatter falls like 1 / sqrt(particles in the sphere).
    CHECK(spread[1] < 0.7 * spread[0]);
    CHECK(spread[2] < 0.7 * spread[1]);
    CHECK(spread[2] < 0.3);
}

TEST_CASE("direction sampler: chi-square against its pdf", "[discrete][phase]") {
    const Setup s = make_setup(100, 5, 1000, 5, 2, 0.5, 1);
    const auto& phase = s.medium->phase_of(0);
    const Vec3f w_in(0, 0, 1);
    // Bins in theta: fine near forward (the diffraction peak), then uniform.
    std::vector<double> edges = {0.0};
    for (double t = 0.01; t < 0.3; t *= 1.35) edges.push_back(t);
    for (double t = 0.3; t < gl::pi_v<double>; t += 0.15) edges.push_back(t);
    edges.push_back(gl::pi_v<double>);
    const std::size_t nb = edges.size() - 1;
    std::vector<double> expected(nb, 0.0);
    for (std::size_t b = 0; b < nb; ++b) {
        const int m = 400;
        for (int k = 0; k < m; ++k) {  // midpoint rule in mu
            const double mu0 = std::cos(edges[b]), mu1 = std::cos(edges[b + 1]);
            const double mu = mu0 + (mu1 - mu0) * (k + 0.5) / m;
            const double st = std::sqrt(std::max(0.0, 1 - mu * mu));
            const Vec3f w(float(st), 0.0f, float(mu));
            expected[b] += 2 * gl::pi_v<double> * phase.eval(w_in, w).value[0] * (mu0 - mu1) / m;
        }
    }
    const int n = 200000;
    std::vector<double> observed(nb, 0.0);
    gl::Rng rng = gl::Rng::from_key(31);
    for (int k = 0; k < n; ++k) {
        const auto ps = phase.sample(w_in, rng.uniform2<float>());
        REQUIRE(ps);
        const double th = std::acos(std::clamp(double(ps.w.z), -1.0, 1.0));
        const std::size_t b = std::min(nb - 1, std::size_t(std::upper_bound(edges.begin(), edges.end(), th) - edges.begin()) - 1);
        observed[b] += 1;
        // pdf consistent with eval
        if (k < 200) CHECK(ps.pdf == Approx(phase.eval(w_in, ps.w).pdf).epsilon(1e-3));
    }
    double chi2 = 0, esum = 0;
    int dof = -1;
    double pooled_e = 0, pooled_o = 0;
    for (std::size_t b = 0; b < nb; ++b) {
        esum += expected[b];
        pooled_e += expected[b] * n;
        pooled_o += observed[b];
        if (pooled_e >= 20) {
            chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
            ++dof;
            pooled_e = pooled_o = 0;
        }
    }
    INFO("chi2 " << chi2 << " dof " << dof << " total prob " << esum);
    CHECK(esum == Approx(1.0).epsilon(2e-3));
    CHECK(dof > 20);
    CHECK(chi2 < dof + 5 * std::sqrt(2.0 * dof));  // ~p = 1e-4
}

namespace {
// A closed enclosure of 6 inward-facing quad lights, each diffuse (albedo 0.5) and emitting 0.5,
// around a box of discrete medium: radiance 1 everywhere if transport conserves energy.
template <class M>
gl::Scene<M> furnace_scene(const M& medium, float lo, float hi) {
    using S = typename M::Spectrum;
    using Mat = gl::Material<float, S>;
    gl::Scene<M> sc;
    const int m = sc.add_medium(medium);
    const float a = -1.0f, b = 2.0f, e = b - a;
    auto quad = [&](Vec3f o, Vec3f v, Vec3f u) { sc.add_quad_light(gl::QuadShape<float>(o, u, v), S(0.5f), Mat::diffuse(S(0.5f))); };
    quad(Vec3f(a, a, a), Vec3f(0, e, 0), Vec3f(e, 0, 0));   // z = a, normal +z
    quad(Vec3f(a, a, b), Vec3f(e, 0, 0), Vec3f(0, e, 0));   // z = b, normal -z
    quad(Vec3f(a, a, a), Vec3f(0, 0, e), Vec3f(0, e, 0));   // x = a, normal +x
    quad(Vec3f(b, a, a), Vec3f(0, e, 0), Vec3f(0, 0, e));   // x = b, normal -x
    quad(Vec3f(a, a, a), Vec3f(e, 0, 0), Vec3f(0, 0, e));   // y = a, normal +y
    quad(Vec3f(a, b, a), Vec3f(0, 0, e), Vec3f(e, 0, 0));   // y = b, normal -y
    sc.add_shape(gl::BoxShape<float>(Vec3f(lo), Vec3f(hi)), Mat::index_matched(), m, -1);
    return sc;
}
}  // namespace

TEST_CASE("white furnace: non-absorbing particles in a closed diffuse-white enclosure give 1", "[discrete][furnace]") {
    // Scene units: metres; 2e4 spheres of 2 mm (GOA, m = 1.31) in the unit cube: optical depth ~ 1.
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, 20000, {gl::cloud_species(gl::MonodispersePsd(2000))}, 5, 1e6));
    for (const double rc : {0.0005, 0.02}) {  // opaque members (r_c < r_p) and r_c >> r_p
        gl::ParticleGridSettings gs;
        gs.dilation = rc;
        auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
        gl::ParticleModel model;
        model.particle_index = {1.31, 0.0};
        gl::DiscreteMediumSettings ms;
        ms.query_radius = rc;
        ms.theta_nodes_tail = 300;
        const Medium medium(grid, {model}, ms);
        const auto sc = furnace_scene(medium, 0.0f, 1.0f);
        const gl::PinholeCamera<float> cam(Vec3f(0.5f, 0.5f, 1.8f), Vec3f(0.5f, 0.5f, 0.5f), Vec3f(0, 1, 0), 50.0f, 16, 16);
        gl::RenderOptions opt;
        opt.spp = 40;
        opt.seed = 3;
        opt.vpt.max_depth = 1000;
        const gl::Film film = gl::render_discrete_vpt(sc, cam, opt);
        const gl::Image img = film.image();
        double sum = 0, sum2 = 0;
        for (int y = 0; y < 16; ++y)
            for (int x = 0; x < 16; ++x) {
                sum += img.at(x, y, 0);
                sum2 += double(img.at(x, y, 0)) * img.at(x, y, 0);
            }
        const double mean = sum / 256, se = std::sqrt((sum2 / 256 - mean * mean) / 256);
        INFO("r_c " << rc << " furnace mean " << mean << " +- " << se << " sigma_t " << medium.global_sigma_t());
        CHECK(medium.global_sigma_t() > 0.5);
        CHECK(std::abs(mean - 1) < 4 * se + 1e-3);
        CHECK(se < 0.02);
    }
}

TEST_CASE("discrete VPT is deterministic across thread counts", "[discrete][determinism]") {
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, 5000, {gl::cloud_species(gl::MonodispersePsd(3000))}, 8, 1e6));
    gl::ParticleGridSettings gs;
    gs.dilation = 0.004;
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
    gl::DiscreteMediumSettings ms;
    ms.query_radius = 0.004;
    ms.theta_nodes_tail = 200;
    const Medium medium(grid, {gl::ParticleModel{}}, ms);
    const auto sc = furnace_scene(medium, 0.0f, 1.0f);
    const gl::PinholeCamera<float> cam(Vec3f(0.5f, 0.5f, 1.8f), Vec3f(0.5f, 0.5f, 0.5f), Vec3f(0, 1, 0), 50.0f, 12, 10);
    gl::RenderOptions opt;
    opt.spp = 4;
    opt.threads = 1;
    const gl::Image a = gl::render_discrete_vpt(sc, cam, opt).image();
    opt.threads = 2;
    const gl::Image b = gl::render_discrete_vpt(sc, cam, opt).image();
    opt.threads = 3;
    const gl::Image c = gl::render_discrete_vpt(sc, cam, opt).image();
    CHECK(a.rgb == b.rgb);
    CHECK(a.rgb == c.rgb);
}

namespace {
// Ray optics of one sphere of relative index m for unpolarized light, by quadrature over the
// impact parameter (uniform in b^2) and a sum over every order p (van de Hulst 1957, Sec. 12.2:
// deviation pi - 2i for p = 0, 2(i - t) + (p - 1)(pi - 2t) for p >= 1; weights R for p = 0 and
// (1 - R)^2 R^(p - 1) per polarization, R = |r_perp|^2 or |r_parl|^2 of the Fresnel formulas).
// polarized: the two polarizations summed (exact); otherwise the unpolarized R at every bounce.
// Returns the mean cosine g; back = the share scattered into the backward hemisphere.
double sphere_ray_optics_g(double m, bool polarized, double& back) {
    const int nb = 20000;
    double g = 0, wsum = 0;
    back = 0;
    for (int k = 0; k < nb; ++k) {
        const double b = std::sqrt((k + 0.5) / nb), i = std::asin(b), t = std::asin(b / m);
        const double ci = std::cos(i), ct = std::cos(t);
        const double rs = std::pow((ci - m * ct) / (ci + m * ct), 2), rp = std::pow((m * ci - ct) / (m * ci + ct), 2);
        const double Rs[2] = {rs, rp}, Ru = 0.5 * (rs + rp);
        for (int p = 0; p < 400; ++p) {
            const double dev = p == 0 ? gl::pi_v<double> - 2 * i : 2 * (i - t) + (p - 1) * (gl::pi_v<double> - 2 * t);
            double w = 0;
            for (int a = 0; a < 2; ++a) {
                const double R = polarized ? Rs[a] : Ru;
                w += 0.5 * (p == 0 ? R : (1 - R) * (1 - R) * std::pow(R, p - 1));
            }
            g += w * std::cos(dev);
            back += std::cos(dev) < 0 ? w : 0.0;
            wsum += w;
        }
    }
    back /= wsum;
    return g / wsum;
}
}  // namespace

TEST_CASE("explicit spheres: one crossing is ray optics with both polarizations (every order)", "[discrete][ept]") {
    // Parallel light on one sphere: the exit directions of the whole-sphere crossing against the
    // closed-form sum over orders. The unpolarized-per-bounce model (what a renderer's Fresnel
    // gives) differs by more than the test's resolution, so the test can tell them apart.
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::from_particles({{0, 0, 0, 1}}, gl::Aabb<double>{Vec3d(-2.0), Vec3d(2.0)}, 64.0));
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gl::ParticleGridSettings{});
    const double m = 1.31;
    const gl::ExplicitSphereMedium<float> ept(grid, float(m));
    const int n = 2000000;
    double sum = 0, sum2 = 0, back = 0;
    int scattered = 0, off_surface = 0;
    for (int k = 0; k < n; ++k) {
        gl::Rng rng = gl::Rng::from_key(77, std::uint64_t(k));
        const double b = std::sqrt(rng.uniform<double>()), phi = 2 * gl::pi_v<double> * rng.uniform<double>();
        const gl::Ray<float> ray(Vec3f(float(b * std::cos(phi)), float(b * std::sin(phi)), -3.0f), Vec3f(0, 0, 1));
        const auto it = ept.sample_interaction(ray, 10.0f, rng);
        if (it.kind != gl::EventKind::scatter) continue;
        ++scattered;
        // The event is outside the sphere, on its surface, leaving it.
        off_surface += !(std::abs(glm::length(Vec3d(it.p)) - 1) < 1e-3);
        const double c = it.w.z;
        sum += c;
        sum2 += c * c;
        back += c < 0;
    }
    CHECK(scattered >= n - n / 1000);  // b < 1 hits except the rim's round-off
    CHECK(off_surface == 0);
    const double g = sum / scattered, se = std::sqrt((sum2 / scattered - g * g) / scattered);
    double back_pol = 0, back_unpol = 0;
    const double g_pol = sphere_ray_optics_g(m, true, back_pol), g_unpol = sphere_ray_optics_g(m, false, back_unpol);
    INFO("EPT g " << g << " +- " << se << ", ray optics (s + p) " << g_pol << ", unpolarized per bounce " << g_unpol
                  << "; backward share " << back / scattered << " vs " << back_pol << " / " << back_unpol);
    CHECK(std::abs(g - g_pol) < 4 * se);
    CHECK(std::abs(g_unpol - g_pol) > 8 * se);  // the test resolves the polarization model
    const double bs = back / scattered, bse = std::sqrt(bs * (1 - bs) / scattered);
    CHECK(std::abs(bs - back_pol) < 4 * bse);
}

TEST_CASE("explicit spheres: exact hits through the grid agree with brute force", "[discrete][ept]") {
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, 3000, {gl::cloud_species(gl::MonodispersePsd(20000))}, 12, 1e6));
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gl::ParticleGridSettings{});
    const gl::ExplicitSphereMedium<float> ept(grid, 1.31f);
    gl::Rng rng = gl::Rng::from_key(2);
    int agree = 0, hits = 0;
    const int n = 2000;
    for (int k = 0; k < n; ++k) {
        const Vec3f o(rng.uniform<float>(), rng.uniform<float>(), -0.1f);
        const Vec3f d = glm::normalize(Vec3f(rng.uniform<float>() - 0.5f, rng.uniform<float>() - 0.5f, 1.0f));
        float t;
        const auto i = ept.first_hit(o, d, 2.0f, t);
        float best = 2.0f;
        std::int64_t bi = -1;
        for (std::uint32_t j = 0; j < cloud->size(); ++j) {
            const auto r = gl::intersect_sphere(o, d, (*cloud)[j].center(), (*cloud)[j].r);
            if (r.hit && r.t_near > 0 && r.t_near <= best) best = r.t_near, bi = j;
        }
        if (bi >= 0) ++hits;
        if (bi == i && (bi < 0 || std::abs(best - t) < 1e-5f)) ++agree;
    }
    CHECK(agree == n);
    CHECK(hits > n / 10);
}

TEST_CASE("mixtures and absorbing particles: per-species optics, bulk sigma_t = number-weighted sum", "[discrete][mixture]") {
    // Two species: ice r = 5 um (m = 1.31) and absorbing dust r = 20 um (m = 1.5 + 0.01 i), 1:3.
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1000.0));
    auto cloud = std::make_shared<gl::ParticleCloud>(gl::ParticleCloud::generate(
        box, 4000, {gl::cloud_species(gl::MonodispersePsd(5), 1.0), gl::cloud_species(gl::MonodispersePsd(20), 3.0)}, 4, 1.0));
    gl::ParticleGridSettings gs;
    gs.dilation = 10;
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
    gl::ParticleModel ice, dust;
    ice.particle_index = {1.31, 0.0};
    dust.particle_index = {1.5, 0.01};
    gl::DiscreteMediumSettings ms;
    ms.query_radius = 10;
    ms.theta_nodes_tail = 200;
    const Medium m(grid, {ice, dust}, ms);
    const auto ci = gl::SingleParticle(5, 0.55, ice).cross_sections();
    const auto cd = gl::SingleParticle(20, 0.55, dust).cross_sections();
    const double V = 1e9;
    CHECK(m.global_sigma_t() == Approx((1000 * ci.C_t + 3000 * cd.C_t) / V).epsilon(1e-6));
    CHECK(m.global_sigma_s() == Approx((1000 * ci.C_s + 3000 * cd.C_s) / V).epsilon(1e-6));
    CHECK(m.albedo(0) == Approx(1.0f));
    CHECK(m.albedo(3999) == Approx(cd.C_s / cd.C_t).epsilon(1e-5));
    CHECK(m.albedo(3999) < 0.9f);  // Eq. 13 / App. C absorption
    // An absorbing member's collision weight carries its albedo (analog collisions here).
    gl::Rng rng = gl::Rng::from_key(1);
    const auto& p = (*cloud)[3999];
    const gl::Ray<float> r(p.center() - Vec3f(0, 0, 1), Vec3f(0, 0, 1));
    bool seen = false;
    for (int k = 0; k < 200 && !seen; ++k) {
        const auto it = m.sample_interaction(r, 2.0f, rng);
        if (it.is_scatter() && it.p == p.center()) {
            seen = true;
            const float P = 1.0f - m.transmittance(r, 2.0f, rng)[0];
            CHECK(it.weight[0] == Approx(P / std::max(P, 0.5f) * m.albedo(3999)).epsilon(1e-4));
        }
    }
    CHECK(seen);
    // The scattering particle is found at its vertex and excluded from the next segment.
    CHECK(m.particle_at(p.center()) == 3999);
}

TEST_CASE("-FD is ray optics: C_t = pi r^2 and no Fraunhofer peak", "[discrete][fd]") {
    // r = 200 um ice at 0.55 um (x = 2285): with diffraction C_t ~ 2 pi r^2 (extinction paradox)
    // and a forward peak of width ~1/x; without, C_t = pi r^2 exactly and f(0) is ray optics only.
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(1.0));
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, 10, {gl::cloud_species(gl::MonodispersePsd(200))}, 1, 1e6));
    gl::ParticleGridSettings gs;
    gs.dilation = 1e-3;
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
    gl::ParticleModel ice;
    ice.particle_index = {1.31, 0.0};
    gl::DiscreteMediumSettings ms;
    ms.query_radius = 1e-3;
    ms.theta_nodes_tail = 300;
    const Medium with(grid, {ice}, ms);
    ms.diffraction = false;
    const Medium without(grid, {ice}, ms);
    const double geo = gl::pi_v<double> * 200e-6 * 200e-6;
    CHECK(double(without.extinction_cross_section(0)) / geo == Approx(1.0).epsilon(1e-5));
    CHECK(with.extinction_cross_section(0) / geo == Approx(2.0).epsilon(0.02));
    CHECK(without.albedo(0) == Approx(1.0f));
    const Vec3f z(0, 0, 1);
    const double f0_with = with.phase_eval(0, z, z).value[0], f0_without = without.phase_eval(0, z, z).value[0];
    INFO("f(0) with " << f0_with << " without " << f0_without);
    CHECK(f0_with > 1000 * f0_without);
    // Away from the peak (30 deg) the ray-optics part carries twice the share without diffraction.
    const Vec3f w30(0.5f, 0.0f, float(std::sqrt(0.75)));
    const double r30 = without.phase_eval(0, z, w30).value[0] / with.phase_eval(0, z, w30).value[0];
    CHECK(r30 == Approx(2.0).epsilon(0.15));
}

TEST_CASE("NEE roulette at particle events is unbiased: the same mean as tracing every shadow ray", "[discrete][nee]") {
    // Two estimators of one scene that must agree: a slab of 1 mm spheres (GOA, m = 1.31; r_c = r_p / 20,
    // opaque members as in Guo21 Fig. 12; mean free path 0.16 m, so most light is scattered more than
    // once and the roulette, which starts at a path's second event, acts) in the dark under one small
    // quad light, seen from the side (light scattered by ~90 deg, where the phase is below isotropic), rendered with
    // every NEE shadow ray traced (nee_roulette = 0) and with the phase-value roulette (1), independent
    // seeds. Their image means agree within 3 standard errors (from the pixel scatter of the difference
    // image, in which the scene's structure cancels).
    const gl::BoxBoundary box(Vec3d(-0.3, 0.0, -0.3), Vec3d(0.3, 0.3, 0.3));
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, 200000, {gl::cloud_species(gl::MonodispersePsd(1000))}, 11, 1e6));
    const double rc = 5e-5;
    gl::ParticleGridSettings gs;
    gs.dilation = rc;
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
    gl::ParticleModel model;
    model.particle_index = {1.31, 0.0};
    gl::DiscreteMediumSettings ms;
    ms.query_radius = rc;
    ms.theta_nodes_tail = 300;
    using S = Medium::Spectrum;
    using Mat = gl::Material<float, S>;
    gl::Scene<Medium> sc;
    const int m = sc.add_medium(Medium(grid, {model}, ms));
    sc.add_quad_light(gl::QuadShape<float>(Vec3f(-0.15f, 1.0f, -0.15f), Vec3f(0.3f, 0, 0), Vec3f(0, 0, 0.3f)), S(20.0f));
    sc.add_shape(gl::BoxShape<float>(Vec3f(-0.302f, -0.002f, -0.302f), Vec3f(0.302f, 0.302f, 0.302f)), Mat::index_matched(), m,
                 -1);
    const gl::PinholeCamera<float> cam(Vec3f(0.0f, 0.5f, 1.4f), Vec3f(0.0f, 0.15f, 0.0f), Vec3f(0, 1, 0), 30.0f, 16, 16);
    auto render = [&](float roulette, std::uint64_t seed) {
        gl::RenderOptions opt;
        opt.spp = 2048;
        opt.seed = seed;
        opt.vpt.max_depth = 256;
        return gl::render_image(
                   cam, [&](const auto& r, gl::Rng& rng) { return gl::discrete_vpt_radiance(sc, r, -1, rng, opt.vpt, roulette); }, opt)
            .image();
    };
    const gl::Image a = render(0.0f, 21), b = render(1.0f, 22);
    double sa = 0, sd = 0, sd2 = 0;
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            const double d = double(b.at(x, y, 0)) - a.at(x, y, 0);
            sa += a.at(x, y, 0), sd += d, sd2 += d * d;
        }
    const double mean = sa / 256, md = sd / 256, se = std::sqrt((sd2 / 256 - md * md) / 255);
    INFO("all shadow rays: mean " << mean << "; roulette - all " << md << " +- " << se);
    CHECK(mean > 0);
    CHECK(std::abs(md) < 3 * se);  // fixed seeds: measured 0.5 se; without the 1 / p weight: 4.0 se
    CHECK(se < 0.1 * mean);
}

TEST_CASE("Guo21 Sec. 5.5 global sampler is unbiased for Eq. 21: first event vs exact quadrature", "[discrete][global]") {
    // One realization, one ray. Eq. 21's first-event terms are deterministic given the cloud:
    //   escape:   E[w 1{escape}] = T_A(x, z)
    //   scatter:  E[w 1{scatter}] = int_0^z T_A(x, y) int Q(y, w') dw' dy = int_0^z T_A sum_{i in S(y)} C_s,i / mu_i dy
    //             E[w cos(theta) 1{scatter}] = int_0^z T_A sum_{i in S(y)} C_s,i g_i / mu_i dy
    // with S(y) the query sphere's members (|p_i - y| < r_i + r_c), mu_i = 4/3 pi (r_i + r_c)^3, and
    // T_A from the cylinder's members with 0 < s_i <= t (Eqs. 18-19). The quadrature is exact (the
    // integrand is piecewise constant between the members' s_i and s_i +- h_i) and finds the members by
    // brute force over every particle, independent of the grid. Scene units: um.
    // Two query radii: r_c = 40 um (the spheres along the ray overlap: no empty sphere) and 12 um
    // (about three quarters of the ray's points have an empty query sphere, Eq. 22's delta).
    const double side = 1000, r_um = 5;
    const gl::BoxBoundary box(Vec3d(0.0), Vec3d(side));
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, 12000, {gl::cloud_species(gl::MonodispersePsd(r_um))}, 31, 1.0));
    for (const double r_c : {40.0, 12.0}) {
    gl::ParticleGridSettings gs;
    gs.dilation = r_c;
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
    gl::ParticleModel model;
    model.particle_index = {1.31, 0.0};
    gl::DiscreteMediumSettings ms;
    ms.query_radius = r_c;
    ms.radius_bins = 1;
    ms.theta_nodes_tail = 300;
    ms.sampling = gl::DiscreteSampling::global;
    const Medium medium(grid, {model}, ms);
    REQUIRE(medium.global_sampling());
    const double sigma = medium.global_sigma_t();

    const Vec3f o(100.0f, 503.0f, 497.0f), d(1.0f, 0.0f, 0.0f);
    const float z = 800.0f;
    INFO("r_c " << r_c << ", sigma_t z = " << sigma * z);
    CHECK(sigma * z > 1.0);
    CHECK(sigma * z < 3.0);

    // Exact quadrature over the members of the tube around the ray (brute force).
    const double A = gl::pi_v<double> * r_c * r_c;
    struct Mem {
        double s, h, tau, cs_mu, g_cs_mu;
    };
    std::vector<Mem> mem;
    std::vector<double> cuts = {0.0, double(z)};
    for (std::uint32_t i = 0; i < cloud->size(); ++i) {
        const auto& p = (*cloud)[i];
        const Vec3d v = Vec3d(p.x, p.y, p.z) - Vec3d(o);
        const double s = v.x, b2 = v.y * v.y + v.z * v.z, R = p.r + r_c;
        if (b2 >= R * R) continue;
        Mem m;
        m.s = s;
        m.h = std::sqrt(R * R - b2);
        m.tau = medium.extinction_cross_section(i) / A;
        const double cs = double(medium.extinction_cross_section(i)) * medium.albedo(i);
        m.cs_mu = cs / (4.0 / 3.0 * gl::pi_v<double> * R * R * R);
        m.g_cs_mu = m.cs_mu * medium.phase_of(i).mean_cosine()[0];
        mem.push_back(m);
        for (const double c : {s, s - m.h, s + m.h})
            if (c > 0 && c < z) cuts.push_back(c);
    }
    std::sort(cuts.begin(), cuts.end());
    double I_scatter = 0, I_cos = 0, tau_z = 0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
        const double a = cuts[k], b = cuts[k + 1], mid = 0.5 * (a + b);
        if (!(b > a)) continue;
        double tau = 0, q = 0, qg = 0;
        for (const Mem& m : mem) {
            if (m.s > 0 && m.s <= mid) tau += m.tau;
            if (std::abs(mid - m.s) < m.h) q += m.cs_mu, qg += m.g_cs_mu;
        }
        I_scatter += (b - a) * std::exp(-tau) * q;
        I_cos += (b - a) * std::exp(-tau) * qg;
    }
    for (const Mem& m : mem)
        if (m.s > 0 && m.s <= z) tau_z += m.tau;
    INFO("tube members " << mem.size() << ", T_A(z) " << std::exp(-tau_z) << ", scatter integral " << I_scatter);
    CHECK(mem.size() > 5);
    // The grid's gather gives the same T_A (float round-off only).
    gl::Rng r0 = gl::Rng::from_key(1);
    CHECK(medium.transmittance(gl::Ray<float>(o, d), z, r0)[0] == Approx(std::exp(-tau_z)).epsilon(1e-4));

    gl::Rng rng = gl::Rng::from_key(2024);
    const int n = 200000;
    double se_sum = 0, se_sum2 = 0, sc_sum = 0, sc_sum2 = 0, cs_sum = 0, cs_sum2 = 0;
    int empty = 0;
    for (int k = 0; k < n; ++k) {
        const auto it = medium.sample_interaction(gl::Ray<float>(o, d), z, rng);
        const double w = it.weight[0];
        REQUIRE(std::isfinite(w));
        REQUIRE(w >= 0);
        double e = 0, s = 0, c = 0;
        if (it.is_escape()) e = w;
        else if (it.is_scatter()) s = w, c = w * double(glm::dot(it.w, d));
        else ++empty;
        se_sum += e, se_sum2 += e * e, sc_sum += s, sc_sum2 += s * s, cs_sum += c, cs_sum2 += c * c;
    }
    auto stat = [&](double sum, double sum2) {
        const double m = sum / n;
        return std::pair<double, double>(m, std::sqrt(std::max(0.0, sum2 / n - m * m) / n));
    };
    const auto [esc, esc_se] = stat(se_sum, se_sum2);
    const auto [sca, sca_se] = stat(sc_sum, sc_sum2);
    const auto [cosm, cos_se] = stat(cs_sum, cs_sum2);
    INFO("escape " << esc << " +- " << esc_se << " (exact " << std::exp(-tau_z) << "); scatter " << sca << " +- " << sca_se
                   << " (exact " << I_scatter << "); cos-weighted " << cosm << " +- " << cos_se << " (exact " << I_cos
                   << "); empty spheres " << empty);
    CHECK(std::abs(esc - std::exp(-tau_z)) < 4 * esc_se);
    CHECK(std::abs(sca - I_scatter) < 4 * sca_se);
    CHECK(std::abs(cosm - I_cos) < 4 * cos_se);
    CHECK(sca_se < 0.02 * I_scatter);
    if (r_c < 20) CHECK(empty > n / 4);  // the sampler meets Eq. 22's empty spheres on this ray
    else CHECK(empty == 0);

    // The global phase is the C_s-weighted mix of the particles' phases: one species, one bin here.
    CHECK(medium.global_phase().mean_cosine()[0] == Approx(medium.phase_of(0).mean_cosine()[0]).epsilon(1e-3));
    }
}

TEST_CASE("Guo21 Sec. 5.5 global sampler: NEE with Eq. 24's Q equals phase sampling alone", "[discrete][global]") {
    // Two estimators of one image that must agree: the global sampler with NEE + MIS at its events
    // (global_nee_factor) and without NEE (the light found only by sampled directions). A slab of
    // 1.3 mm spheres (-FD, sigma_t ~ 5 / m) with r_c ~ 8 r_p (~6 particles per query sphere) under a quad light, seen from the side; independent seeds; the
    // image means agree within 3 standard errors of their difference.
    const gl::BoxBoundary box(Vec3d(-0.3, 0.0, -0.3), Vec3d(0.3, 0.3, 0.3));
    auto cloud = std::make_shared<gl::ParticleCloud>(
        gl::ParticleCloud::generate(box, 100000, {gl::cloud_species(gl::MonodispersePsd(1300))}, 12, 1e6));
    const double rc = 0.01;
    gl::ParticleGridSettings gs;
    gs.dilation = rc;
    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
    gl::ParticleModel model;
    model.particle_index = {1.31, 0.0};
    gl::DiscreteMediumSettings ms;
    ms.query_radius = rc;
    ms.theta_nodes_tail = 300;
    ms.diffraction = false;
    ms.sampling = gl::DiscreteSampling::global;
    using S = Medium::Spectrum;
    using Mat = gl::Material<float, S>;
    gl::Scene<Medium> sc;
    const Medium med(grid, {model}, ms);
    INFO("sigma_t " << med.global_sigma_t() << " / m");
    const int m = sc.add_medium(med);
    sc.add_quad_light(gl::QuadShape<float>(Vec3f(-0.4f, 0.8f, -0.4f), Vec3f(0.8f, 0, 0), Vec3f(0, 0, 0.8f)), S(2.0f));
    sc.add_shape(gl::BoxShape<float>(Vec3f(-0.302f, -0.002f, -0.302f), Vec3f(0.302f, 0.302f, 0.302f)), Mat::index_matched(), m,
                 -1);
    const gl::PinholeCamera<float> cam(Vec3f(0.0f, 0.15f, 1.4f), Vec3f(0.0f, 0.15f, 0.0f), Vec3f(0, 1, 0), 25.0f, 12, 12);
    auto render = [&](bool nee, int spp, std::uint64_t seed) {
        gl::RenderOptions opt;
        opt.spp = spp;
        opt.seed = seed;
        opt.vpt.max_depth = 64;
        opt.vpt.nee = nee;
        return gl::render_discrete_vpt(sc, cam, opt).image();
    };
    const gl::Image a = render(true, 256, 41), b = render(false, 1024, 42);
    double sa = 0, sd = 0, sd2 = 0;
    const int np = 144;
    for (int y = 0; y < 12; ++y)
        for (int x = 0; x < 12; ++x) {
            const double dd = double(b.at(x, y, 0)) - a.at(x, y, 0);
            sa += a.at(x, y, 0), sd += dd, sd2 += dd * dd;
        }
    const double mean = sa / np, md = sd / np, se = std::sqrt((sd2 / np - md * md) / (np - 1));
    INFO("NEE: mean " << mean << "; no NEE - NEE " << md << " +- " << se);
    CHECK(mean > 0);
    CHECK(std::abs(md) < 3 * se);
    CHECK(se < 0.1 * mean);
}
