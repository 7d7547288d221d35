// Guide-table sampling of core/distribution.hpp (issue 13): the guide finds exactly the interval
// the binary search over the whole CDF finds (so the samplers' u -> x mapping is unchanged), and
// the samplers pass chi-square against their own exact CDF on large, very non-uniform tables.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "common/chi2.hpp"
#include "grainlight/core/distribution.hpp"
#include "grainlight/core/rng.hpp"

using namespace grainlight;

namespace {

// HG-like forward peak on a grid dense toward mu = 1 (as bench_phase's tables), with a run of
// exact zeros (zero-probability intervals) in the backward half.
template <class F>
void peaked_table(std::size_t n, std::vector<F>& x, std::vector<F>& f) {
    x.resize(n);
    f.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double t = double(i) / double(n - 1);
        const double mu = 1.0 - 2.0 * (1.0 - t) * (1.0 - t);
        x[i] = F(mu);
        const double g = 0.9;
        f[i] = F((1 - g * g) / (2 * std::pow(1 + g * g - 2 * g * mu, 1.5)));
        if (mu > -0.6 && mu < -0.3) f[i] = 0;
    }
    x.front() = F(-1);
    x.back() = F(1);
}

template <class F>
std::vector<F> edge_values(std::span<const F> cdf) {
    std::vector<F> u = {F(0), F(1), std::nextafter(F(1), F(0)), F(2), F(-1), std::numeric_limits<F>::quiet_NaN(),
                        std::numeric_limits<F>::denorm_min()};
    for (F c : cdf) {
        u.push_back(c);
        u.push_back(std::nextafter(c, F(0)));
        u.push_back(std::nextafter(c, F(2)));
    }
    auto rng = Pcg32::from_key(11);
    for (int k = 0; k < 200000; ++k) u.push_back(F(rng.uniform<double>()));
    return u;
}

template <class F>
void check_guide_equals_binary_search(std::span<const F> cdf) {
    const detail::CdfGuide guide(cdf);
    std::size_t mismatches = 0;
    for (F u : edge_values(cdf)) {
        const std::size_t ref = find_interval(cdf.size(), [&](std::size_t k) { return cdf[k] <= u; });
        const std::size_t got = guide.find(cdf.data(), cdf.size(), u);
        if (got != ref) {
            ++mismatches;
            UNSCOPED_INFO("n = " << cdf.size() << " u = " << double(u) << " guide " << got << " binary " << ref);
        }
    }
    CHECK(mismatches == 0);
}

}  // namespace

TEST_CASE("Guide table finds the same interval as the binary search", "[core][distribution][guide]") {
    for (std::size_t n : {std::size_t(2), std::size_t(3), std::size_t(64), std::size_t(1000), std::size_t(16384)}) {
        INFO("nodes = " << n);
        {
            std::vector<double> x, f;
            peaked_table(n, x, f);
            DiscreteDistribution<double> d(f);  // its CDF has flat runs where f = 0
            check_guide_equals_binary_search<double>(d.cdf());
        }
        {
            std::vector<float> x, f;
            peaked_table(n, x, f);
            DiscreteDistribution<float> d(f);
            check_guide_equals_binary_search<float>(d.cdf());
        }
    }
    // A CDF with most mass in one interval and many empty ones at both ends.
    std::vector<double> w(5000, 0.0);
    w[2500] = 1;
    w[17] = 1e-300;
    DiscreteDistribution<double> spike(w);
    check_guide_equals_binary_search<double>(spike.cdf());
    CHECK(spike.sample(0.5) == 2500);
}

template <class F>
void check_node_guide_equals_binary_search(std::span<const F> x) {
    const detail::NodeGuide guide(x);
    std::vector<F> v = {x.front(), x.back(), F(x.front() - 1), F(x.back() + 1), std::numeric_limits<F>::quiet_NaN(),
                        std::numeric_limits<F>::infinity(), -std::numeric_limits<F>::infinity()};
    for (F c : x) {
        v.push_back(c);
        v.push_back(std::nextafter(c, F(-10)));
        v.push_back(std::nextafter(c, F(10)));
    }
    auto rng = Pcg32::from_key(12);
    for (int k = 0; k < 200000; ++k)
        v.push_back(F(double(x.front()) + (double(x.back()) - double(x.front())) * rng.uniform<double>()));
    std::size_t mismatches = 0;
    for (F u : v) {
        const std::size_t ref = find_interval(x.size(), [&](std::size_t k) { return x[k] <= u; });
        if (guide.find(x.data(), x.size(), u) != ref) ++mismatches;
    }
    CHECK(mismatches == 0);
}

TEST_CASE("Node guide (pdf / eval / invert) finds the same interval as the binary search", "[core][distribution][guide]") {
    for (std::size_t n : {std::size_t(2), std::size_t(3), std::size_t(64), std::size_t(16384)}) {
        INFO("nodes = " << n);
        std::vector<double> x, f;
        peaked_table(n, x, f);
        check_node_guide_equals_binary_search<double>(x);
        std::vector<float> xf, ff;
        peaked_table(n, xf, ff);
        check_node_guide_equals_binary_search<float>(xf);
        // shifted, scaled, far from 0 (the widening is relative to |x_0| + |x_n|)
        std::vector<double> y(x.size());
        for (std::size_t i = 0; i < x.size(); ++i) y[i] = 1e6 + 3.0 * x[i];
        check_node_guide_equals_binary_search<double>(y);
    }
}

TEST_CASE("Guide-table samplers stay the monotone inverse CDF", "[core][distribution][guide]") {
    std::vector<double> x, f;
    peaked_table(16384, x, f);
    PiecewiseLinear1D<double> lin(x, f);
    std::vector<double> xc(x.begin(), x.end()), fc(f.begin(), f.end() - 1);
    PiecewiseConstant1D<double> pc(xc, fc);
    double prev_l = -2, prev_c = -2;
    std::size_t non_monotone = 0, bad_inverse = 0;
    for (int k = 0; k <= 100000; ++k) {
        const double u = double(k) / 100000.0 * (1 - 1e-16);
        const double sl = lin.sample(u), sc = pc.sample(u);
        if (sl < prev_l || sc < prev_c) ++non_monotone;
        prev_l = sl;
        prev_c = sc;
        if (std::abs(lin.invert(sl) - u) > 1e-9 || std::abs(pc.invert(sc) - u) > 1e-9) ++bad_inverse;
    }
    CHECK(non_monotone == 0);
    CHECK(bad_inverse == 0);
    CHECK(lin.sample(0.0) == -1.0);
}

TEST_CASE("Guide-table samplers pass chi-square on 16384-node tables", "[core][distribution][guide][chi2]") {
    std::vector<double> x, f;
    peaked_table(16384, x, f);
    PiecewiseLinear1D<double> lin(x, f);
    std::vector<double> fc(f.begin(), f.end() - 1);
    PiecewiseConstant1D<double> pc(x, fc);
    DiscreteDistribution<double> disc(fc);
    // Bins equally spaced in the grid parameter t (fine toward mu = 1, where the mass is).
    const int B = 200;
    std::vector<double> edges(B + 1);
    for (int b = 0; b <= B; ++b) {
        const double t = double(b) / B;
        edges[std::size_t(b)] = 1.0 - 2.0 * (1.0 - t) * (1.0 - t);
    }
    auto bin_of = [&](double v) {
        const auto it = std::upper_bound(edges.begin(), edges.end(), v);
        return std::clamp<std::ptrdiff_t>(it - edges.begin() - 1, 0, B - 1);
    };
    const std::size_t n = 400000;
    auto run = [&](auto&& sample, auto&& cdf_at, std::uint64_t seed) {
        std::vector<double> obs(B, 0.0), expd(B, 0.0);
        auto rng = Pcg32::from_key(seed);
        for (std::size_t k = 0; k < n; ++k) obs[std::size_t(bin_of(sample(rng.uniform<double>())))] += 1;
        for (int b = 0; b < B; ++b) expd[std::size_t(b)] = double(n) * (cdf_at(edges[std::size_t(b) + 1]) - cdf_at(edges[std::size_t(b)]));
        return gl_test::chi2_from_counts(obs, expd);
    };
    const double alpha = gl_test::sidak(0.01, 3);
    // Expected counts from the exact integral of the interpolant (closed-form trapezoid per node
    // interval, summed independently of the sampler's CDF table).
    auto lin_cdf = [&](double v) {
        double acc = 0, tot = 0;
        for (std::size_t i = 0; i + 1 < x.size(); ++i) {
            const double h = x[i + 1] - x[i];
            tot += 0.5 * (f[i] + f[i + 1]) * h;
            if (x[i + 1] <= v) acc += 0.5 * (f[i] + f[i + 1]) * h;
            else if (x[i] < v) {
                const double t = (v - x[i]) / h;
                acc += h * (f[i] * t + 0.5 * (f[i + 1] - f[i]) * t * t);
            }
        }
        return acc / tot;
    };
    auto pc_cdf = [&](double v) {
        double acc = 0, tot = 0;
        for (std::size_t i = 0; i + 1 < x.size(); ++i) {
            const double h = x[i + 1] - x[i];
            tot += fc[i] * h;
            acc += fc[i] * std::clamp(v - x[i], 0.0, h);
        }
        return acc / tot;
    };
    const auto rl = run([&](double u) { return lin.sample(u); }, lin_cdf, 21);
    INFO("linear: " << rl.describe());
    CHECK(rl.p_value > alpha);
    const auto rc = run([&](double u) { return pc.sample(u); }, pc_cdf, 22);
    INFO("constant: " << rc.describe());
    CHECK(rc.p_value > alpha);
    // Discrete: index counts against the normalized weights (pooled below 5 expected).
    std::vector<double> obs(fc.size(), 0.0), expd(fc.size());
    double tot = 0;
    for (double v : fc) tot += v;
    for (std::size_t i = 0; i < fc.size(); ++i) expd[i] = double(n) * fc[i] / tot;
    auto rng = Pcg32::from_key(23);
    for (std::size_t k = 0; k < n; ++k) obs[disc.sample(rng.uniform<double>())] += 1;
    const auto rd = gl_test::chi2_from_counts(obs, expd);
    INFO("discrete: " << rd.describe());
    CHECK(rd.p_value > alpha);
}
