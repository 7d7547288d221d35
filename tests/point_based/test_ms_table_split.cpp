// The multiple-scattering table build split over block ranges (build_ms_table_blocks +
// MsTableHistograms::append + finish_ms_table, what the MPI ranks of examples/ms_table.cpp do)
// gives exactly the table of one build_ms_table call: particles are keyed by their global index
// and the blocks are summed in block order, so any split must be bit-identical. Bad ranges and
// incomplete histograms are refused with the parameter named.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>

#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"

using namespace grainlight;

namespace {
using RGBf = Spectrum<3, float>;
MsTableOptions split_options() {
    MsTableOptions o;
    o.n_rho = 8;
    o.n_z = 16;
    o.n_theta = 4;
    o.n_phi = 4;
    o.rho_max = 6;
    o.z_min = -6;
    o.z_max = 6;
    o.photons = 3001;  // not a multiple of the block count: the last block is short
    o.blocks = 7;
    o.seed = 5;
    return o;
}
}  // namespace

TEST_CASE("ms_table split: any split of the blocks gives the one-call table bit for bit", "[ms_table][mpi]") {
    const HenyeyGreenstein<float, RGBf> phase(0.4f);
    const RGBf albedo{0.5f, 0.8f, 0.95f};
    const MsTableOptions o = split_options();
    const MsTable<3> one = build_ms_table(phase, albedo, o);
    REQUIRE(ms_table_blocks(o) == 7);
    for (const auto& cuts : {std::vector<std::uint64_t>{0, 7}, std::vector<std::uint64_t>{0, 3, 7},
                             std::vector<std::uint64_t>{0, 1, 2, 5, 7}, std::vector<std::uint64_t>{0, 0, 4, 4, 7}}) {
        MsTableHistograms all = build_ms_table_blocks(phase, albedo, o, cuts[0], cuts[1]);
        for (std::size_t k = 1; k + 1 < cuts.size(); ++k) all.append(build_ms_table_blocks(phase, albedo, o, cuts[k], cuts[k + 1]));
        const MsTable<3> split = finish_ms_table(phase, albedo, o, all);
        REQUIRE(split.size() == one.size());
        CHECK(std::memcmp(split.values().data(), one.values().data(), one.size() * sizeof(float)) == 0);
    }
    // The split is not trivially empty: the table holds light (orders >= 2 in an albedo-0.8 medium).
    CHECK(one.total(1) > 0.5);
}

TEST_CASE("ms_table split: bad ranges and incomplete histograms are refused", "[ms_table][mpi]") {
    const HenyeyGreenstein<float, RGBf> phase(0.4f);
    const RGBf albedo{0.5f, 0.5f, 0.5f};
    const MsTableOptions o = split_options();
    CHECK_THROWS_WITH(build_ms_table_blocks(phase, albedo, o, 0, 8), Catch::Contains("block range end"));
    CHECK_THROWS_WITH(build_ms_table_blocks(phase, albedo, o, 5, 4), Catch::Contains("block range end"));
    MsTableHistograms part = build_ms_table_blocks(phase, albedo, o, 0, 3);
    CHECK_THROWS_WITH(finish_ms_table(phase, albedo, o, part), Catch::Contains("histogram blocks"));
    CHECK_THROWS_WITH(part.append(build_ms_table_blocks(phase, albedo, o, 4, 7)), Catch::Contains("next.first_block"));
    MsTableOptions bad = o;
    bad.blocks = 0;
    CHECK_THROWS_WITH(ms_table_blocks(bad), Catch::Contains("blocks"));
}
