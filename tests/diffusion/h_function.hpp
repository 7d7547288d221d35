// Exact total reflectance of an index-matched, isotropically scattering half-space under normal
// incidence, R(mu0 = 1) = 1 - H(1) sqrt(1 - a), with Chandrasekhar's H-function (Chandrasekhar,
// *Radiative Transfer*, 1960, ch. V) solved here from
//   1/H(mu) = sqrt(1 - a) + (a/2) int_0^1 mu' H(mu') / (mu + mu') dmu'
// by fixed-point iteration on Gauss-Legendre nodes (tabulated values in
// shared/reference/halfspace_albedo.md check the solver: a = 0.5 -> 0.115226, a = 0.8 -> 0.285255).
#pragma once

#include <cmath>
#include <vector>

namespace diffusion_test {

struct GaussLegendre01 {
    std::vector<double> x, w;  // nodes and weights on [0, 1]
    explicit GaussLegendre01(int n) {
        for (int i = 1; i <= n; ++i) {
            double z = std::cos(M_PI * (i - 0.25) / (n + 0.5)), dp = 1;
            for (int it = 0; it < 100; ++it) {
                double p0 = 1, p1 = z;
                for (int k = 2; k <= n; ++k) {
                    const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n * (z * p1 - p0) / (z * z - 1);
                const double dz = p1 / dp;
                z -= dz;
                if (std::abs(dz) < 1e-15) break;
            }
            x.push_back(0.5 * (1 - z));
            w.push_back(1.0 / ((1 - z * z) * dp * dp));
        }
    }
};

// R(mu0 = 1) of the half-space with single-scattering albedo a in (0, 1).
inline double halfspace_reflectance(double a, int nodes = 200) {
    const GaussLegendre01 q(nodes);
    const double s = std::sqrt(1 - a);
    std::vector<double> h(q.x.size(), 1.0), nh(h.size());
    auto eval = [&](double mu) {
        double acc = 0;
        for (std::size_t j = 0; j < h.size(); ++j) acc += q.w[j] * q.x[j] * h[j] / (mu + q.x[j]);
        return 1.0 / (s + 0.5 * a * acc);
    };
    for (int it = 0; it < 200000; ++it) {
        double change = 0;
        for (std::size_t i = 0; i < h.size(); ++i) {
            nh[i] = eval(q.x[i]);
            change = std::max(change, std::abs(nh[i] - h[i]));
        }
        h.swap(nh);
        if (change < 1e-13) break;
    }
    return 1 - eval(1.0) * s;
}

}  // namespace diffusion_test
