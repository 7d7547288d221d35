// Wang18 multiple-scattering table (Sec. 3.5.4, 5.2): the emission density integrated over space
// and directions equals the scattered power of orders >= 2 (closed form alpha^2 / (1 - alpha) in
// an infinite medium, per unit source power); save/load round trip; corrupt and truncated files.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>
#include <type_traits>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"

using namespace grainlight;

namespace {
using Grey = Spectrum<1, float>;
using RGBf = Spectrum<3, float>;
std::filesystem::path tmp(const char* name) { return std::filesystem::temp_directory_path() / name; }

const MsTable<3>& small_table() {
    static const MsTable<3> t = [] {
        MsTableOptions o;
        o.n_rho = 16;
        o.n_z = 32;
        o.n_theta = 8;
        o.n_phi = 4;
        o.rho_max = 12;
        o.z_min = -12;
        o.z_max = 12;
        o.photons = 40000;
        return MsTable<3>::build(HenyeyGreenstein<float, RGBf>(0.5f), RGBf{0.3f, 0.5f, 0.7f}, o);
    }();
    return t;
}
}  // namespace

TEST_CASE("ms_table: total emission of orders >= 2 is alpha^2 / (1 - alpha)", "[ms_table]") {
    const auto& t = small_table();
    // Closed form: a unit of scattered power; each further collision scatters a fraction alpha,
    // so collisions 2, 3, ... scatter alpha^2 + alpha^3 + ... = alpha^2 / (1 - alpha). With
    // 40000 photons the MC error is < 1 %; the grid (12 mfp) loses < 1 % for alpha <= 0.7.
    const double alphas[3] = {0.3, 0.5, 0.7};
    for (std::size_t c = 0; c < 3; ++c) {
        const double expect = alphas[c] * alphas[c] / (1 - alphas[c]);
        CHECK(t.total(c) == Approx(expect).epsilon(0.03));
    }
    // Anisotropy: forward of the source (z > 0) there is more emission than behind it (g = 0.5).
    CHECK(t.eval(1, 0.5, 2.0, 1.0, 0.0) > t.eval(1, 0.5, -2.0, 1.0, 0.0));
    // Outside the grid: 0.
    CHECK(t.eval(0, 13.0, 0.0, 0.0, 0.0) == 0.0);
}

TEST_CASE("ms_table: the phase matrix is the bin average of the phase function and conserves power", "[ms_table]") {
    // Row i of the bin-to-bin phase matrix is the phase function per steradian, averaged over the
    // incoming bin i (both mirror images) and over each outgoing bin: its integral over the
    // outgoing bins is the phase function's norm, 1, however narrow the lobe. (The matrix read at
    // the bin centres, p(c_i, c_j), which the builder used until 2026-12-06, has rows integrating
    // to 4.2-18.8 at g = 0.95 and 1.25-2.5 at g = 0.9 on these grids, 1.00-1.03 at g = 0.7.)
    for (const float g : {0.0f, 0.7f, 0.95f}) {
        for (const auto& nt_np : {std::pair<int, int>{8, 4}, std::pair<int, int>{12, 6}}) {
            MsTableGrid grid;
            grid.n_rho = 2;
            grid.n_z = 2;
            grid.n_theta = std::uint32_t(nt_np.first);
            grid.n_phi = std::uint32_t(nt_np.second);
            const auto shape = MsTable<1>::layout(grid, {0.5}, g, 1);
            const HenyeyGreenstein<float, Grey> ph(g);
            const std::vector<double> pm = detail::ms_table_phase_matrix(ph, shape);
            const std::size_t nd = grid.directions();
            double worst = 0;
            for (std::size_t i = 0; i < nd; ++i) {
                double row = 0;
                for (std::size_t j = 0; j < nd; ++j) row += pm[i * nd + j] * ms_bin_solid_angle(grid, j);
                worst = std::max(worst, std::abs(row - 1));
            }
            INFO("g = " << g << ", grid " << nt_np.first << " x " << nt_np.second);
            CHECK(worst < 1e-5);
        }
    }
    // Against an independent fine quadrature of the same average with the phase function's eval
    // (incoming 12 x 12 x 2 mirrors, outgoing 96 x 48 x 2 mirrors per bin, midpoints equal in cos
    // theta and phi), g = 0.7 on the 8 x 4 grid: every entry holding > 5 % of its row's power
    // within 2 %, > 0.5 % within 5 % (the matrix draws 131 072 directions of the lobe per row, a
    // shifted grid per incoming direction: an entry of 1 % gets ~1300 of them).
    MsTableGrid grid;
    grid.n_rho = 2;
    grid.n_z = 2;
    grid.n_theta = 8;
    grid.n_phi = 4;
    const auto shape = MsTable<1>::layout(grid, {0.5}, 0.7, 1);
    const HenyeyGreenstein<float, Grey> ph(0.7f);
    const std::vector<double> pm = detail::ms_table_phase_matrix(ph, shape);
    const std::size_t nd = grid.directions();
    auto dir = [&](std::size_t b, double fa, double fb, bool mirror) { return Vec3f(ms_bin_point(grid, b, fa, fb, mirror)); };
    int compared = 0;
    for (const std::size_t i : {std::size_t(0), std::size_t(9), std::size_t(14), std::size_t(30)}) {
        for (std::size_t j = 0; j < nd; ++j) {
            if (!(pm[i * nd + j] * ms_bin_solid_angle(grid, j) > 0.005)) continue;
            double acc = 0;
            int n = 0;
            for (int a = 0; a < 12; ++a)
                for (int b = 0; b < 12; ++b)
                    for (int m = 0; m < 2; ++m) {
                        const Vec3f wi = dir(i, (a + 0.5) / 12, (b + 0.5) / 12, m == 1);
                        for (int u = 0; u < 96; ++u)
                            for (int v = 0; v < 48; ++v)
                                for (int m2 = 0; m2 < 2; ++m2) {
                                    acc += double(ph.eval(wi, dir(j, (u + 0.5) / 96, (v + 0.5) / 48, m2 == 1)).value[0]);
                                    ++n;
                                }
                    }
            INFO("incoming bin " << i << ", outgoing bin " << j);
            const double share = pm[i * nd + j] * ms_bin_solid_angle(grid, j);
            CHECK(pm[i * nd + j] == Approx(acc / n).epsilon(share > 0.05 ? 0.02 : 0.05));
            ++compared;
        }
    }
    CHECK(compared >= 12);
}

TEST_CASE("ms_table: a narrow lobe (g = 0.95) emits the power its cells tallied", "[ms_table]") {
    // Per cell and channel, the emitted power sum_j L_j Omega_j V equals the tallied power of the
    // events there (MsTableBuildInfo::cell_weight, per source particle): the convolution with the
    // phase function moves light between directions only. Also the closed form of the total,
    // alpha^2 / (1 - alpha) for alpha = 0.5 (short walks: the grid keeps them).
    MsTableOptions o;
    o.n_rho = 8;
    o.n_z = 16;
    o.n_theta = 8;
    o.n_phi = 4;
    o.rho_max = 12;
    o.z_min = -12;
    o.z_max = 12;
    o.photons = 20000;
    MsTableBuildInfo info;
    const auto t = build_ms_table(HenyeyGreenstein<float, Grey>(0.95f), Grey(0.5f), o, &info);
    const MsTableGrid& g = t.grid();
    double worst = 0, tallied = 0;
    for (std::size_t iz = 0; iz < g.n_z; ++iz)
        for (std::size_t ir = 0; ir < g.n_rho; ++ir) {
            double emitted = 0;
            for (std::size_t j = 0; j < g.directions(); ++j)
                emitted += double(t.values()[t.value_index(0, iz, ir, j)]) * ms_bin_solid_angle(g, j);
            emitted *= ms_cell_volume(g, ir);
            const double w = info.cell_weight[iz * g.n_rho + ir] / double(o.photons);
            tallied += w;
            if (w > 1e-4) worst = std::max(worst, std::abs(emitted / w - 1));
        }
    CHECK(worst < 1e-4);
    CHECK(t.total(0) == Approx(tallied).epsilon(1e-4));
    CHECK(t.total(0) == Approx(0.5).epsilon(0.05));
}

TEST_CASE("ms_table: isotropic phase gives an isotropic emission lobe", "[ms_table]") {
    // Independent fact: with an isotropic phase function the in-scattered emission
    // sigma_s int p L d omega' does not depend on the outgoing direction.
    MsTableOptions o;
    o.n_rho = 4;
    o.n_z = 8;
    o.n_theta = 6;
    o.n_phi = 3;
    o.rho_max = 4;
    o.z_min = -4;
    o.z_max = 4;
    o.photons = 4000;
    const auto t = MsTable<1>::build(HenyeyGreenstein<float, Grey>(0.0f), Grey(0.6f), o);
    // The phase matrix is a quadrature of the bin averages that draws directions from the phase
    // function (ms_table_phase_matrix): for an isotropic phase its bins agree to ~1e-3, not to
    // the float rounding of a matrix of equal entries.
    const double a = t.eval(0, 1.0, 1.0, 1.0, 0.0), b = t.eval(0, 1.0, 1.0, -0.7, 2.0);
    CHECK(a > 0);
    CHECK(a == Approx(b).epsilon(5e-3));
}

TEST_CASE("ms_table: save / load round trip and corrupt files", "[ms_table]") {
    const auto& t = small_table();
    const auto path = tmp("grainlight_test_ms_table.bin");
    t.save(path);
    const auto u = MsTable<3>::load(path);
    REQUIRE(u.size() == t.size());
    CHECK(u.values() == t.values());
    CHECK(u.albedo(2) == t.albedo(2));
    CHECK(u.eval(1, 1.3, 0.7, 0.2, 1.0) == t.eval(1, 1.3, 0.7, 0.2, 1.0));
    // Wrong channel count.
    CHECK_THROWS_AS(MsTable<1>::load(path), grainlight::format_error);
    // Flip one payload byte: checksum mismatch.
    std::vector<char> bytes;
    {
        std::ifstream f(path, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(f), {});
    }
    const auto bad = tmp("grainlight_test_ms_table_bad.bin");
    auto write = [&](const std::vector<char>& b) {
        std::ofstream f(bad, std::ios::binary | std::ios::trunc);
        f.write(b.data(), std::streamsize(b.size()));
    };
    auto flipped = bytes;
    flipped[bytes.size() / 2] ^= 0x5a;
    write(flipped);
    CHECK_THROWS_AS(MsTable<3>::load(bad), grainlight::format_error);
    auto truncated = bytes;
    truncated.resize(bytes.size() - 7);
    write(truncated);
    CHECK_THROWS_AS(MsTable<3>::load(bad), grainlight::format_error);
    write(std::vector<char>(10, 'x'));
    CHECK_THROWS_AS(MsTable<3>::load(bad), grainlight::format_error);
    CHECK_THROWS_AS(MsTable<3>::load(tmp("grainlight_no_such_ms_table.bin")), grainlight::io_error);
    std::filesystem::remove(path);
    std::filesystem::remove(bad);
}

namespace {
MsTableOptions tally_options(MsTableTally tally, std::uint64_t photons, std::uint64_t seed = 1) {
    MsTableOptions o;
    o.n_rho = 12;
    o.n_z = 24;
    o.n_theta = 6;
    o.n_phi = 4;
    o.rho_max = 10;
    o.z_min = -10;
    o.z_max = 10;
    o.photons = photons;
    o.seed = seed;
    o.tally = tally;
    return o;
}
const HenyeyGreenstein<float, RGBf> kTallyPhase(0.6f);
const RGBf kTallyAlbedo{0.5f, 0.9f, 0.99f};
}  // namespace

TEST_CASE("ms_table: the shared fixed-point tally gives the per-block table", "[ms_table]") {
    // Two independent summations of the same events (doubles per block in block order; 32.32
    // fixed point in one histogram): the values agree to the fixed point's rounding, far below
    // the Monte Carlo noise, and the totals to 1e-7.
    MsTableBuildInfo ib, is;
    const auto a = build_ms_table(kTallyPhase, kTallyAlbedo, tally_options(MsTableTally::per_block, 6000), &ib);
    const auto b = build_ms_table(kTallyPhase, kTallyAlbedo, tally_options(MsTableTally::shared, 6000), &is);
    CHECK(ib.tally == MsTableTally::per_block);
    CHECK(is.tally == MsTableTally::shared);
    CHECK(is.histogram_bytes * 16 == ib.histogram_bytes);
    REQUIRE(a.size() == b.size());
    float vmax = 0;
    for (float v : a.values()) vmax = std::max(vmax, v);
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (a.values()[i] > 1e-6f * vmax)
            worst = std::max(worst, std::abs(double(a.values()[i]) - double(b.values()[i])) / double(a.values()[i]));
    CHECK(worst < 1e-5);
    for (std::size_t c = 0; c < 3; ++c) CHECK(b.total(c) == Approx(a.total(c)).epsilon(1e-7));
    // The statistics do not depend on the tally, and a build with them equals one without.
    CHECK(ib.cell_events == is.cell_events);
    const auto a2 = build_ms_table(kTallyPhase, kTallyAlbedo, tally_options(MsTableTally::per_block, 6000));
    CHECK(a2.values() == a.values());
    // automatic: a small table keeps the per-block tally (its histograms fit the budget).
    MsTableBuildInfo ia;
    (void)build_ms_table(kTallyPhase, kTallyAlbedo, tally_options(MsTableTally::automatic, 500), &ia);
    CHECK(ia.tally == MsTableTally::per_block);
}

#ifdef _OPENMP
TEST_CASE("ms_table: the shared tally gives the same bits on 1 and 2 threads", "[ms_table]") {
    const int before = omp_get_max_threads();
    omp_set_num_threads(1);
    const auto one = build_ms_table(kTallyPhase, kTallyAlbedo, tally_options(MsTableTally::shared, 4000));
    omp_set_num_threads(2);
    const auto two = build_ms_table(kTallyPhase, kTallyAlbedo, tally_options(MsTableTally::shared, 4000));
    omp_set_num_threads(before);
    CHECK(one.values() == two.values());
}
#endif

TEST_CASE("ms_table: the table's noise estimate matches the scatter of independent builds", "[ms_table]") {
    // Independent check: 32 builds with different seeds. The spread of a cell's power over the
    // builds is its variance, and sum_p X_p^2 estimates it without bias in every build, so
    // summed over the cells the sample variance over builds and the mean estimate agree (to the
    // precision of a 32-sample variance, ~25 %, better over the cells).
    constexpr int builds = 32;
    std::vector<MsTableBuildInfo> info(builds);
    for (int s = 0; s < builds; ++s)
        (void)build_ms_table(kTallyPhase, kTallyAlbedo, tally_options(MsTableTally::per_block, 4000, 101 + s), &info[s]);
    const std::size_t cells = info[0].cell_events.size();
    for (std::size_t c = 0; c < 3; ++c) {
        double spread = 0, estimate = 0;
        for (std::size_t i = 0; i < cells; ++i) {
            double m = 0, m2 = 0;
            for (const auto& in : info) {
                const double x = in.cell_weight[c * cells + i];
                m += x;
                m2 += x * x;
                estimate += in.cell_weight2[c * cells + i] / builds;
            }
            m /= builds;
            spread += (m2 / builds - m * m) * builds / (builds - 1.0);
        }
        INFO("channel " << c << ": variance over builds " << spread << ", estimated " << estimate);
        CHECK(spread / estimate > 0.8);
        CHECK(spread / estimate < 1.25);
        CHECK(info[0].relative_noise[c] > 0.0);
    }
}

TEST_CASE("ms_table: every channel is as precise as a grey build of its own albedo", "[ms_table]") {
    // Independent references: three grey (one-channel) builds, each the analog walk of one
    // albedo, with other seeds. The RGB build shares one walk between its channels; its
    // channels' totals must agree with the grey ones within their noise and their noise must not
    // exceed the grey builds'. (Before the RGB build walked with the mean albedo: the channel of
    // albedo 0.95 then carried a factor 0.95 / 0.62 per event and its relative noise was ~6x the
    // grey build's; the totals of BmpS. tables moved by 25 % between seeds.)
    const HenyeyGreenstein<float, RGBf> ph3(0.7f);
    const float alb[3] = {0.95f, 0.6f, 0.3f};
    const std::uint64_t photons = 6000;
    MsTableBuildInfo irgb;
    const auto rgb = build_ms_table(ph3, RGBf{alb[0], alb[1], alb[2]},
                                    tally_options(MsTableTally::per_block, photons, 7), &irgb);
    for (std::size_t c = 0; c < 3; ++c) {
        MsTableBuildInfo ig;
        const auto grey = build_ms_table(HenyeyGreenstein<float, Grey>(0.7f), Grey(alb[c]),
                                         tally_options(MsTableTally::per_block, photons, 1000 + c), &ig);
        // Standard error of a total: the per-particle deposits summed per cell are independent
        // between particles; their squares summed over cells bound the total's variance from
        // below (cross-cell covariance is positive), so use 4 of them plus a 1 % floor.
        double v_rgb = 0, v_grey = 0;
        const std::size_t cells = ig.cell_weight.size();
        for (std::size_t i = 0; i < cells; ++i) {
            v_rgb += irgb.cell_weight2[c * cells + i];
            v_grey += ig.cell_weight2[i];
        }
        const double n2 = double(photons) * double(photons);
        const double se = std::sqrt(v_rgb / n2 + v_grey / n2);
        INFO("channel " << c << " albedo " << alb[c] << ": RGB total " << rgb.total(c) << ", grey total "
                        << grey.total(0) << ", s.e. " << se << ", relative noise RGB " << irgb.relative_noise[c]
                        << " grey " << ig.relative_noise[0]);
        CHECK(std::abs(rgb.total(c) - grey.total(0)) < 4 * se + 0.01 * grey.total(0));
        CHECK(irgb.relative_noise[c] < 1.15 * ig.relative_noise[0]);
    }
}

TEST_CASE("ms_table: bad options", "[ms_table]") {
    MsTableOptions o;
    o.photons = 10;
    o.n_rho = 0;
    CHECK_THROWS_AS(MsTable<1>::build(HenyeyGreenstein<float, Grey>(0.0f), Grey(0.5f), o), grainlight::invalid_argument);
    o.n_rho = 4;
    o.z_max = o.z_min;
    CHECK_THROWS_AS(MsTable<1>::build(HenyeyGreenstein<float, Grey>(0.0f), Grey(0.5f), o), grainlight::invalid_argument);
    o.z_max = 4;
    CHECK_THROWS_AS(MsTable<1>::build(HenyeyGreenstein<float, Grey>(0.0f), Grey(1.0f), o), grainlight::invalid_argument);
}

// Names kept for one release after the record moved to integrators/ms_table.hpp.
static_assert(MsTable<3>::file_kind == ms_table_file_kind);
static_assert(std::is_same_v<MsTable<1>::InfiniteMediumScene<ContinuousMedium<HenyeyGreenstein<float, Spectrum<1, float>>, Spectrum<1, float>>>,
                             InfiniteMediumScene<ContinuousMedium<HenyeyGreenstein<float, Spectrum<1, float>>, Spectrum<1, float>>>>);
