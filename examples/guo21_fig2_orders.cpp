// guo21_fig2_orders: Guo21 Fig. 2, the impact of the highest GOA order p on F = (|S1| + |S2|)/2
// (eta = 1.33, lambda = 0.6 um): F for p <= 1, 2, 3 and 100 at r = 2, 10 and 100 um.
//
//   guo21_fig2_orders [--quality quick|full] [--out DIR]
//
// Paper (Sec. 3.2): "with p = 3 ... an almost identical curve with that of p = 100, irrespective
// of the particle size". Printed: the energy-weighted difference sum (F_p - F_100)^2 / sum F_100^2
// and the largest per-angle ratio, for p = 1, 2, 3.
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/optics/goa.hpp"

int main(int argc, char** argv) {
    return gl_examples::run(argc, argv, "guo21_fig2_orders",
                            "Guo21 Fig. 2: GOA (|S1|+|S2|)/2 for p = 1, 2, 3, 100",
                            [&](gl_examples::Example& ex) -> int {
        ex.ready();
        const bool full = ex.full();
        const auto& out = ex.out();
        const double pi = 3.14159265358979323846, lambda = 0.6;
        const std::complex<double> m(1.33, 0);
        const std::vector<double> radii = {2, 10, 100};
        const std::vector<int> orders = {1, 2, 3, 100};
        const int n = full ? 1801 : 721;  // 0.1 or 0.25 degree steps
        std::vector<std::string> header = {"theta_deg"};
        for (double r : radii)
            for (int p : orders) header.push_back("F_r" + std::to_string(int(r)) + "_p" + std::to_string(p));
        gl_examples::Csv csv(header);
        // F[r][p][angle]
        std::vector<std::vector<std::vector<double>>> F(radii.size(), std::vector<std::vector<double>>(orders.size()));
        for (std::size_t i = 0; i < radii.size(); ++i)
            for (std::size_t j = 0; j < orders.size(); ++j) {
                const grainlight::Goa goa(m, 2 * pi * radii[i] / lambda, orders[j]);
                F[i][j].resize(std::size_t(n));
                for (int a = 0; a < n; ++a) {
                    const auto s = goa.amplitudes_at_angle(pi * a / (n - 1));
                    F[i][j][std::size_t(a)] = 0.5 * (std::abs(s.S1) + std::abs(s.S2));
                }
            }
        for (int a = 0; a < n; ++a) {
            std::vector<double> row = {180.0 * a / (n - 1)};
            for (std::size_t i = 0; i < radii.size(); ++i)
                for (std::size_t j = 0; j < orders.size(); ++j) row.push_back(F[i][j][std::size_t(a)]);
            csv.row(row);
        }
        const auto csv_path = ex.csv("guo21_fig2_orders.csv", csv);
        ex.plot("guo21_fig2_orders", csv_path, out / "guo21_fig2_orders.png");
        std::printf("Guo21 Fig. 2: GOA (|S1|+|S2|)/2 for p <= 1, 2, 3 vs p <= 100 (eta 1.33, lambda 0.6 um)\n");
        std::printf("  %8s %4s %22s %24s\n", "r [um]", "p", "energy diff vs p=100", "max |F_p/F_100 - 1|");
        gl_examples::Json j = ex.summary();
        for (std::size_t i = 0; i < radii.size(); ++i)
            for (std::size_t jj = 0; jj + 1 < orders.size(); ++jj) {
                double num = 0, den = 0, worst = 0;
                for (int a = 0; a < n; ++a) {
                    const double f = F[i][jj][std::size_t(a)], g = F[i].back()[std::size_t(a)];
                    num += (f - g) * (f - g);
                    den += g * g;
                    if (g > 0) worst = std::max(worst, std::abs(f / g - 1));
                }
                std::printf("  %8.0f %4d %22.3e %24.3f\n", radii[i], orders[jj], num / den, worst);
                if (orders[jj] == 3)
                    j.num("energy_diff_p3_vs_p100_r" + std::to_string(int(radii[i])), num / den)
                        .num("max_rel_diff_p3_vs_p100_r" + std::to_string(int(radii[i])), worst);
            }
        std::printf("  paper: p = 3 gives an almost identical curve to p = 100 at every size.\n");
        return ex.finish(j);
    });
}
