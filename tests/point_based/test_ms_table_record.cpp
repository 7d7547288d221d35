// The MsTable record and its lookup on their own (integrators/ms_table.hpp, which must compile
// without precompute/): a table built by hand from a linear field, where bilinear lookups are
// exact, and its input checks.
#include <catch2/catch.hpp>

#include <vector>

#include "grainlight/integrators/ms_table.hpp"

using namespace grainlight;

TEST_CASE("ms_table record: bilinear lookups reproduce a linear field; bad records are refused", "[ms_table]") {
    MsTableGrid g;
    g.n_rho = 4;
    g.n_z = 6;
    g.n_theta = 4;
    g.n_phi = 2;
    g.rho_max = 4;
    g.z_min = -3;
    g.z_max = 3;
    // value = 1 + 0.5 rho_c + 0.25 (z_c + 3) + 0.1 theta_bin + 0.05 phi_bin at cell and bin centres.
    std::vector<float> v(g.cells() * g.directions());
    for (std::uint32_t iz = 0; iz < g.n_z; ++iz)
        for (std::uint32_t ir = 0; ir < g.n_rho; ++ir)
            for (std::uint32_t it = 0; it < g.n_theta; ++it)
                for (std::uint32_t ip = 0; ip < g.n_phi; ++ip)
                    v[((iz * g.n_rho + ir) * g.n_theta + it) * g.n_phi + ip] =
                        float(1 + 0.5 * (ir + 0.5) + 0.25 * (iz + 0.5) + 0.1 * it + 0.05 * ip);
    const MsTable<1> t(g, {0.5}, 0.3, 1000, v);
    // Inside the cell-centre hull the bilinear (rho, z) lookup is exact for a linear field.
    const double rho = 1.8, z = 0.7;
    const double expect_cells = 1 + 0.5 * rho + 0.25 * (z + 3);
    CHECK(t.eval_bin(0, rho, z, 0) == Approx(expect_cells).epsilon(1e-6));
    // Direction: theta between the centres of bins 1 and 2 (67.5 and 112.5 deg) at 90 deg,
    // phi between the two bin centres (45 and 135 deg) at 90 deg: the interpolated lookup gives
    // the mean of the four bins, the nearest lookup one of them.
    const double interp = t.eval_interpolated(0, rho, z, 0.0, pi_v<double> / 2);
    CHECK(interp == Approx(expect_cells + 0.1 * 1.5 + 0.05 * 0.5).epsilon(1e-6));
    const double nearest = t.eval(0, rho, z, 0.0, pi_v<double> / 2);
    CHECK(nearest == Approx(expect_cells + 0.1 * 2 + 0.05 * 1).epsilon(1e-6));
    CHECK(t.eval(0, 4.5, 0.0, 0.0, 0.0) == 0.0);  // outside the grid
    CHECK(t.bytes() == v.size() * sizeof(float));
    // Bad records.
    CHECK_THROWS_AS(MsTable<1>(g, {0.5}, 0.3, 1000, std::vector<float>(3, 1.0f)), grainlight::invalid_argument);
    CHECK_THROWS_AS(MsTable<1>(g, {1.5}, 0.3, 1000, v), grainlight::invalid_argument);
    std::vector<float> neg = v;
    neg[5] = -1.0f;
    CHECK_THROWS_AS(MsTable<1>(g, {0.5}, 0.3, 1000, neg), grainlight::invalid_argument);
    MsTableGrid bad = g;
    bad.z_max = bad.z_min;
    CHECK_THROWS_AS(MsTable<1>(bad, {0.5}, 0.3, 1000, v), grainlight::invalid_argument);
}
