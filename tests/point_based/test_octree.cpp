// Octree over light samples (Wang18 Sec. 3.4.3, Alg. 1, Sec. 4.3): the tree cut with zero error
// threshold equals the brute-force sum over all samples; every cut partitions the samples (each
// counted exactly once); the two-step traversal gives the same cut as the one-step one; Eq. 4.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/traversal/octree.hpp"

using namespace grainlight;

namespace {
using Grey = Spectrum<1, double>;
using Tree = Octree<double, Grey>;

std::vector<Tree::Item> random_items(int n, std::uint64_t seed) {
    std::vector<Tree::Item> v(static_cast<std::size_t>(n));
    Rng rng = Rng::from_key(seed);
    for (int i = 0; i < n; ++i) {
        auto& it = v[std::size_t(i)];
        // Clustered: half in a small ball (a "caustic"), half spread out.
        const double s = (i % 2) ? 0.05 : 1.0;
        it.p = rng.uniform3<double>() * s;
        it.d = glm::normalize(Vec3d(0.2 * rng.uniform<double>(), 0.1, 1.0));
        it.w = Grey(0.5 + rng.uniform<double>());
        it.extent = Aabb<double>(it.p - 0.01, it.p + 0.01);
        it.id = std::uint32_t(i);
    }
    return v;
}
double isotropic(const Vec3d&, const Vec3d&) { return 1.0 / (4.0 * pi_v<double>); }
double peaked(const Vec3d& a, const Vec3d& b) { return std::exp(5.0 * (glm::dot(a, b) - 1.0)) * 2.0; }
double f_of(const Vec3d& P, const Vec3d& x, const Grey& w) { return w[0] / (glm::dot(P - x, P - x) + 1e-3); }
}  // namespace

TEST_CASE("octree: zero-threshold cut equals the brute-force sum over all samples", "[octree]") {
    const auto items = random_items(5000, 7);
    const Tree tree(items);
    REQUIRE(tree.items().size() == items.size());
    CutCriterion<double> zero;
    zero.eps1 = 0;
    zero.eps2 = 0;
    for (const Vec3d P : {Vec3d(0.5, 0.5, 2.0), Vec3d(0.02, 0.02, 0.02), Vec3d(0.3, 0.7, 0.5)}) {
        double brute = 0;
        for (const auto& it : items) brute += f_of(P, it.p, it.w);
        double cut = 0;
        std::size_t n_nodes = 0, n_items = 0;
        tree.tree_cut(P, Vec3d(0, 0, 1), zero, isotropic,
                      [&](const Tree::Node& n) { cut += f_of(P, n.p, n.w), ++n_nodes; },
                      [&](const Tree::Item& it) { cut += f_of(P, it.p, it.w), ++n_items; });
        CHECK(cut == Approx(brute).epsilon(1e-12));
        CHECK(n_nodes + n_items >= items.size() - 1);  // at most a degenerate (single-point) node aggregates
    }
}

TEST_CASE("octree: every cut partitions the samples; coarser thresholds give smaller cuts", "[octree]") {
    const auto items = random_items(4000, 11);
    const Tree tree(items);
    double total = 0;
    for (const auto& it : items) total += it.w[0];
    REQUIRE(tree.nodes()[0].w[0] == Approx(total).epsilon(1e-12));
    std::size_t last = 0;
    for (const double eps : {1.0, 0.1, 0.01, 0.001}) {
        CutCriterion<double> c;
        c.eps1 = eps;
        c.eps2 = eps / 10;
        std::vector<int> seen(items.size(), 0);
        double w = 0;
        std::size_t size = 0;
        tree.tree_cut(Vec3d(0.5, 0.5, 1.5), Vec3d(0, 0, 1), c, peaked,
                      [&](const Tree::Node& n) {
                          w += n.w[0];
                          ++size;
                          for (std::uint32_t i = n.begin; i < n.end; ++i) ++seen[tree.items()[i].id];
                      },
                      [&](const Tree::Item& it) {
                          w += it.w[0];
                          ++size;
                          ++seen[it.id];
                      });
        CHECK(w == Approx(total).epsilon(1e-10));
        bool once = true;
        for (int s : seen) once = once && s == 1;
        CHECK(once);
        CHECK(size >= last);
        last = size;
    }
    CHECK(last > 100);
}

TEST_CASE("octree: two-step traversal visits the same cut as the one-step traversal", "[octree]") {
    const auto items = random_items(3000, 3);
    const Tree tree(items);
    CutCriterion<double> c;
    c.eps1 = 0.02;
    c.eps2 = 0.002;
    const Vec3d P(0.2, 0.9, 1.2), o = glm::normalize(Vec3d(0.3, -0.2, 1.0));
    double one = 0, two = 0;
    std::size_t n1 = 0, n2 = 0;
    tree.tree_cut(P, o, c, peaked, [&](const Tree::Node& n) { one += f_of(P, n.p, n.w), ++n1; },
                  [&](const Tree::Item& it) { one += f_of(P, it.p, it.w), ++n1; });
    for (std::uint32_t depth : {1u, 2u, 3u}) {
        std::vector<std::uint32_t> buf(4096);
        const std::size_t n = tree.coarse_cut(P, o, c, peaked, depth, std::span(buf));
        REQUIRE(n <= buf.size());
        two = 0;
        n2 = 0;
        tree.tree_cut_from(std::span<const std::uint32_t>(buf.data(), n), P, o, c, peaked,
                           [&](const Tree::Node& nd) { two += f_of(P, nd.p, nd.w), ++n2; },
                           [&](const Tree::Item& it) { two += f_of(P, it.p, it.w), ++n2; });
        CHECK(n2 == n1);
        CHECK(two == Approx(one).epsilon(1e-12));
    }
    // A buffer that is too small is reported.
    std::vector<std::uint32_t> tiny(1);
    CHECK(tree.coarse_cut(P, o, c, peaked, 3, std::span(tiny)) == tiny.size() + 1);
}

TEST_CASE("octree: segment visit finds exactly the samples whose box the segment crosses", "[octree]") {
    const auto items = random_items(2000, 5);
    const Tree tree(items);
    const Vec3d o(-1, 0.51, 0.49), d = glm::normalize(Vec3d(1, 0.02, 0.01));
    std::size_t found = 0;
    tree.visit_segment(o, d, 0.0, 10.0, [&](const Tree::Item&) { ++found; });
    std::size_t brute = 0;
    for (const auto& it : items) {
        double t0 = 0, t1 = 10;
        bool hit = true;
        for (int a = 0; a < 3; ++a) {
            double tn = (it.extent.lo[a] - o[a]) / d[a], tf = (it.extent.hi[a] - o[a]) / d[a];
            if (tn > tf) std::swap(tn, tf);
            t0 = std::max(t0, tn);
            t1 = std::min(t1, tf);
        }
        hit = t0 <= t1;
        brute += hit;
    }
    CHECK(found == brute);
    CHECK(brute > 0);
}

TEST_CASE("octree: leaves hold at most 8 samples; aggregates are weight averages", "[octree]") {
    const auto items = random_items(1000, 9);
    const Tree tree(items);
    for (const auto& n : tree.nodes()) {
        if (n.leaf()) CHECK(n.end - n.begin <= 8u);
        CHECK(Aabb<double>(n.bounds.lo - 1e-12, n.bounds.hi + 1e-12).contains(n.p));  // round-off of the average
        CHECK(n.coherence <= 1.0 + 1e-12);
    }
}

TEST_CASE("octree: Eq. 4 density factor", "[octree]") {
    // (clamp(A/S, 1, 8) * clamp(sigma_t, 0.3, 0.8))^2, values by hand.
    CHECK(density_factor(0.5, 1.0, 1.0) == Approx(0.64));
    CHECK(density_factor(4.0, 1.0, 0.5) == Approx(4.0));
    CHECK(density_factor(100.0, 1.0, 0.1) == Approx(8.0 * 8.0 * 0.09));
}

TEST_CASE("octree: bad input", "[octree]") {
    auto items = random_items(10, 1);
    CHECK_THROWS_AS(Tree(items, 0), grainlight::invalid_argument);
    CHECK_THROWS_AS(Tree(items, 8, 31), grainlight::invalid_argument);
    items[3].p.x = std::nan("");
    CHECK_THROWS_AS(Tree(items), grainlight::invalid_argument);
    items = random_items(10, 1);
    items[2].w = Grey(-1.0);
    CHECK_THROWS_AS(Tree(items), grainlight::invalid_argument);
    const Tree empty(std::vector<Tree::Item>{});
    CHECK(empty.empty());
    int calls = 0;
    empty.tree_cut(Vec3d(0), Vec3d(0, 0, 1), CutCriterion<double>{}, isotropic, [&](const Tree::Node&) { ++calls; },
                   [&](const Tree::Item&) { ++calls; });
    CHECK(calls == 0);
}

TEST_CASE("octree: node directions stay unit vectors for tiny float weights", "[octree]") {
    // Regression: the mean direction of a node was normalised from the weighted sum, whose
    // squared length underflows in float for weights ~1e-20 (secondary samples deep in an
    // optically thick medium) and gave NaN directions.
    using FT = Octree<float, Spectrum<1, float>>;
    std::vector<FT::Item> v(64);
    Rng rng = Rng::from_key(3);
    for (std::size_t i = 0; i < v.size(); ++i) {
        v[i].p = Vec3<float>(rng.uniform<float>(), rng.uniform<float>(), rng.uniform<float>());
        v[i].d = glm::normalize(Vec3<float>(0.3f, 0.2f, 1.0f) + 0.2f * Vec3<float>(rng.uniform<float>(), 0.0f, 0.0f));
        v[i].w = Spectrum<1, float>(1e-21f);
        v[i].extent = Aabb<float>(v[i].p, v[i].p);
        v[i].id = std::uint32_t(i);
    }
    const FT tree(std::move(v));
    for (const auto& n : tree.nodes()) {
        CHECK(std::isfinite(n.d.x + n.d.y + n.d.z));
        CHECK(glm::length(n.d) == Approx(1.0).epsilon(1e-5));
    }
}
