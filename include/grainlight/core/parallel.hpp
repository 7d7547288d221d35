/// @file grainlight/core/parallel.hpp
/// One blocked-parallel loop with an ordered reduction: `parallel_blocks(count, block, threads,
/// work, merge)` splits [0, count) into blocks of `block` items, runs `work(block_index, begin,
/// end) -> Partial` for each block on OpenMP threads (dynamic schedule), keeps every partial, and
/// then merges them in block order on the calling thread. Floating-point sums therefore do not
/// depend on the thread count or schedule: a seed gives bit-identical results on 1 or N threads
/// when `work` draws its random numbers from counter-based generators keyed by item index. The
/// pragmas compile away without OpenMP (the loop then runs serially, same result).
///
/// `work` must not throw (it runs inside an OpenMP region); `merge(accumulator, partial)` may.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace grainlight {

/// Number of blocks of `block` items covering `count` items.
[[nodiscard]] constexpr std::uint64_t block_count(std::uint64_t count, std::uint64_t block) noexcept {
    return block == 0 ? 0 : (count + block - 1) / block;
}

/// See the file comment. `threads` <= 0: the OpenMP default. Returns the merged accumulator
/// (initially `init`). Throws grainlight::invalid_argument for block == 0.
template <class Partial, class Work, class Merge>
[[nodiscard]] Partial parallel_blocks(std::uint64_t count, std::uint64_t block, int threads, Work&& work, Merge&& merge,
                                      Partial init = Partial{}) {
    check_argument(block >= 1, "parallel_blocks", "block", block, ">= 1");
    const std::uint64_t nb = block_count(count, block);
    std::vector<Partial> partials(static_cast<std::size_t>(nb));
#if defined(_OPENMP)
    const int nt = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
#else
    (void)threads;
#endif
    for (std::int64_t b = 0; b < std::int64_t(nb); ++b) {
        const std::uint64_t begin = std::uint64_t(b) * block;
        const std::uint64_t end = std::min(count, begin + block);
        partials[std::size_t(b)] = work(std::uint64_t(b), begin, end);
    }
    for (auto& p : partials) merge(init, std::move(p));
    return init;
}

}  // namespace grainlight
