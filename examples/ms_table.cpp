// ms_table: precompute Wang18's multiple-scattering table (Sec. 3.5.4 / 5.2: the emission of
// scattering orders >= 2 around a point source in an infinite medium, binned over (rho, z) and
// the incoming direction, then folded with the phase function) for one homogeneous material, save
// it (.mstab, the shared container) and print its per-channel total beside the closed form.
//
//   ms_table [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--albedo A | r,g,b]
//            [--g G] [--photons P] [--n-rho N] [--n-z N] [--n-theta N] [--n-phi N]
//            [--extent MFP] [--blocks B]
//
// Check against theory: a unit of scattered power scatters alpha at each further collision, so
// orders >= 2 emit alpha^2 / (1 - alpha) in all of space (the test suite's closed form); the
// table holds the part inside its (rho, z) box, so its total is that minus the light beyond the
// box (printed as the captured fraction; high albedo spreads farther).
// Built with MPI, `mpirun -np K ms_table ...` gives rank r a contiguous range of the build's
// source-particle blocks; rank 0 appends the ranks' histograms in block order, so the .mstab file
// is byte-identical to a single-process run with the same seed. The last stdout line is JSON
// with the totals, the table's bytes, "ranks" and each rank's block range ("rank_blocks").
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {
using RGBf = gl::Spectrum<3, float>;

// Histograms as bytes for the gather on rank 0: first block, block count, block size, values.
std::vector<unsigned char> encode(const gl::MsTableHistograms& h) {
    gl::ByteWriter w;
    w.put(h.first_block).put(std::uint64_t(h.blocks.size()));
    w.put(std::uint64_t(h.blocks.empty() ? 0 : h.blocks.front().size()));
    for (const auto& b : h.blocks) w.put_array(b.data(), b.size());
    return w.bytes();
}
gl::MsTableHistograms decode(const std::vector<unsigned char>& bytes) {
    gl::ByteReader r(bytes, "multiple-scattering histograms from another rank");
    gl::MsTableHistograms h;
    h.first_block = r.get<std::uint64_t>();
    const auto n = r.get<std::uint64_t>(), size = r.get<std::uint64_t>();
    h.blocks.resize(std::size_t(n));
    for (auto& b : h.blocks) r.get_array(b, size);
    r.expect_end();
    return h;
}
}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "ms_table",
               "Wang18 Sec. 3.5.4: precompute the multiple-scattering table of one material (MPI-aware)",
               "out/ms_table", [&](Example& ex) {
        const auto albedo_list = ex.opt<std::vector<double>>("albedo", {0.7, 0.9, 0.99},
                                                             "single-scattering albedo, one value or r,g,b in [0, 1)");
        const double g = ex.opt<double>("g", 0.7, "Henyey-Greenstein mean cosine in (-1, 1) (Wang18 Table 2: 0.7)");
        const auto photons = ex.opt<std::uint64_t>("photons", 100000, 2000000, "source particles");
        const auto n_rho = ex.opt<std::uint64_t>("n-rho", 32, 64, "radial cells (paper: 1024)");
        const auto n_z = ex.opt<std::uint64_t>("n-z", 64, 128, "axial cells (paper: 512)");
        const auto n_theta = ex.opt<std::uint64_t>("n-theta", 16, 18, "polar direction bins (paper: 18)");
        const auto n_phi = ex.opt<std::uint64_t>("n-phi", 8, 18, "azimuth bins over [0, pi] (paper: 36 over [0, 2 pi])");
        const double extent = ex.opt<double>("extent", 10.0, 20.0, "half extent of the (rho, z) box in mean free paths");
        const auto blocks = ex.opt<std::uint64_t>("blocks", 16, "source-particle blocks (the unit of work split over ranks)");
        ex.ready();
        if (albedo_list.size() != 1 && albedo_list.size() != 3)
            throw cli_error("--albedo takes one value or three (r,g,b), got " + std::to_string(albedo_list.size()));
        RGBf albedo;
        for (std::size_t c = 0; c < 3; ++c) {
            const double a = albedo_list[albedo_list.size() == 1 ? 0 : c];
            if (!(a >= 0.0 && a < 1.0)) throw cli_error("--albedo = " + std::to_string(a) + " must be in [0, 1)");
            albedo[c] = float(a);
        }
        if (!(g > -1.0 && g < 1.0)) throw cli_error("--g = " + ex.given_text("g") + " must be in (-1, 1)");
        if (!(extent > 0.0 && extent <= 1000.0)) throw cli_error("--extent = " + ex.given_text("extent") + " must be in (0, 1000]");
        gl::MsTableOptions o;
        o.n_rho = int(std::min<std::uint64_t>(n_rho, 1u << 20));
        o.n_z = int(std::min<std::uint64_t>(n_z, 1u << 20));
        o.n_theta = int(std::min<std::uint64_t>(n_theta, 1u << 20));
        o.n_phi = int(std::min<std::uint64_t>(n_phi, 1u << 20));
        o.rho_max = extent;
        o.z_min = -extent;
        o.z_max = extent;
        o.photons = photons;
        o.escape_radius = 3.0 * extent;
        o.seed = ex.seed();
        o.blocks = int(std::min<std::uint64_t>(blocks, 1u << 20));
        const gl::HenyeyGreenstein<float, RGBf> phase{float(g)};
        const std::uint64_t nb = gl::ms_table_blocks(o);  // validates every option, naming it

        // This rank's contiguous share of the blocks; rank 0 appends the others in rank order.
        const MpiSession& mpi = ex.mpi();
        const auto [b0, b1] = mpi.block_range(nb);
        // Chunks of one block per thread, so the progress bar moves and every thread has a block.
        auto bar = ex.progress("ms table", b1 - b0);
        const std::uint64_t chunk = std::uint64_t(std::max(1, ex.threads()));
        gl::MsTableHistograms mine;
        mine.first_block = b0;
        for (std::uint64_t b = b0; b < b1; b += chunk) {
            mine.append(gl::build_ms_table_blocks(phase, albedo, o, b, std::min(b1, b + chunk)));
            bar.advance(std::min(b1, b + chunk) - b);
        }
        const auto all = mpi.gather_bytes(encode(mine));
        bar.done();
        const double secs = bar.seconds();
        if (!ex.root()) return ex.finish({});
        gl::MsTableHistograms hist = mpi.size() == 1 ? std::move(mine) : decode(all[0]);
        for (int r = 1; r < mpi.size(); ++r) hist.append(decode(all[std::size_t(r)]));
        const gl::MsTable<3> table = gl::finish_ms_table(phase, albedo, o, hist);
        const auto file = ex.out() / "ms_table.mstab";
        gl::save_ms_table(table, file);

        std::printf("Wang18 multiple-scattering table: HG g = %.3f, %llu source particles, grid %d x %d (rho, z) x %d x %d "
                    "directions over +-%.1f mfp, %llu blocks on %d rank(s), %.2f s\n",
                    g, (unsigned long long)photons, o.n_rho, o.n_z, o.n_theta, o.n_phi, extent, (unsigned long long)nb,
                    mpi.size(), secs);
        std::vector<double> totals, closed, captured;
        for (std::size_t c = 0; c < 3; ++c) {
            const double a = double(albedo[c]);
            totals.push_back(table.total(c));
            closed.push_back(a * a / (1.0 - a));
            captured.push_back(closed.back() > 0 ? totals.back() / closed.back() : 0.0);
            std::printf("  channel %zu: albedo %.4f, total emission of orders >= 2 %.5f, infinite-medium closed form "
                        "alpha^2 / (1 - alpha) = %.5f, captured by the box %.1f %%\n",
                        c, a, totals.back(), closed.back(), 100.0 * captured.back());
        }
        const double mb = double(table.size()) * sizeof(float) / 1e6;
        std::printf("  table %.2f MB dense (paper: 8.4 GB dense at 1024 x 512 x 18 x 36, 36-72 MB after compression, "
                    "Wang18 Table 2); wrote %s\n",
                    mb, file.c_str());
        auto j = ex.summary();
        j.nums("total", totals).nums("closed_form", closed).nums("captured_fraction", captured).num("table_mb", mb)
            .num("captured_min", *std::min_element(captured.begin(), captured.end()))
            .num("captured_max", *std::max_element(captured.begin(), captured.end()));
        j.integer("photons", (long long)photons).num("seconds", secs);
        j.nums("rank_blocks", mpi.block_ranges(nb));  // [begin, end) block range of each rank
        return ex.finish(j);
    });
}
