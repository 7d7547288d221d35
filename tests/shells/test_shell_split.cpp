// Shell-table sampling split over path-block ranges (collect_shell_sample_blocks, what the MPI
// ranks of `slab --method shells` do), merged in order, equals the one-call collect_shell_samples
// exactly (integer counts and exit lists appended in block order), so the table built from it is
// the same bytes; bad block ranges are refused with the parameter named.
#include <catch2/catch.hpp>

#include <vector>

#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/shell_builder.hpp"

using namespace grainlight;

namespace {
using HG = HenyeyGreenstein<double>;
using CM = ContinuousMedium<HG>;
}  // namespace

TEST_CASE("shell samples split: merged block ranges equal the one-call tallies and table", "[shells][mpi]") {
    const CM m(1.0, 0.95, HG(0.3));
    const ContinuousShellSource<CM> src(m);
    const std::vector<double> radii = {0.5, 1.0, 2.0};
    const std::uint64_t paths = 3 * shell_sample_block + 100;  // 4 blocks, the last one short
    REQUIRE(shell_sample_blocks(paths) == 4);
    const ShellSamples one = collect_shell_samples(src, radii, paths, 9, 32, 4.0);
    ShellSamples split = collect_shell_sample_blocks(src, radii, paths, 9, 0, 1, 32, 4.0);
    split.merge(collect_shell_sample_blocks(src, radii, paths, 9, 1, 1, 32, 4.0));  // empty range
    split.merge(collect_shell_sample_blocks(src, radii, paths, 9, 1, 3, 32, 4.0));
    split.merge(collect_shell_sample_blocks(src, radii, paths, 9, 3, 4, 32, 4.0));
    CHECK(split.n_paths == paths);
    CHECK(split.fa_counts == one.fa_counts);
    for (std::size_t i = 0; i < radii.size(); ++i) {
        CHECK(split.coords[i] == one.coords[i]);
        CHECK(split.n_unscattered[i] == one.n_unscattered[i]);
        CHECK(split.n_absorbed[i] == one.n_absorbed[i]);
        CHECK(one.n_scattered(i) > 1000);  // the comparison is over real exits
    }
    ShellBuildOptions o;
    o.n_c = 8, o.n_u = 4, o.n_v = 4, o.rank = 3;
    CHECK(build_shell_table(split, o).table.to_payload() == build_shell_table(one, o).table.to_payload());
}

TEST_CASE("shell samples split: bad block ranges are refused", "[shells][mpi]") {
    const CM m(1.0, 0.9, HG(0.0));
    const ContinuousShellSource<CM> src(m);
    const std::vector<double> radii = {1.0};
    CHECK_THROWS_WITH(collect_shell_sample_blocks(src, radii, 5000, 1, 0, 3), Catch::Contains("block range end"));
    CHECK_THROWS_WITH(collect_shell_sample_blocks(src, radii, 5000, 1, 2, 1), Catch::Contains("block range end"));
}
