// examples/common/mpi.hpp: optional MPI scale-out of the example programs. Built with MPI
// (GRAINLIGHT_EXAMPLES_MPI, CMake option GRAINLIGHT_WITH_MPI, on when OpenMPI is found) the same
// binaries split their work over the ranks of `mpirun -np K` and reduce it on rank 0 in a fixed
// order, so the output is bit-identical to a single-process run with the same seed (the keyed
// generators make every sample independent of who computes it). Without MPI, or run without
// mpirun, everything is one rank. Only rank 0 writes files and prints the JSON summary.
//
// Work splits: renders give rank r the rows y with y % K == r (RenderOptions::row_offset /
// row_stride: interleaved rows balance a centred object), precomputations a contiguous block range
// (block_range). Reductions: gather_bytes collects each rank's serialized partial on rank 0 in rank
// order; gather_film_rows assembles a film from the ranks' rows (a placement, not a sum), and
// share_film_rows gives that film to every rank; sum_to_root adds per-rank vectors in rank order;
// broadcast sends rank 0's decisions (a timed preview's choice) to all ranks.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "grainlight/scene/film.hpp"

#if defined(GRAINLIGHT_EXAMPLES_MPI)
#include <mpi.h>
#endif

namespace gl_examples {

/// MPI for the lifetime of the object (MPI_Init / MPI_Finalize when built with MPI).
class MpiSession {
public:
    MpiSession(int& argc, char**& argv) {
#if defined(GRAINLIGHT_EXAMPLES_MPI)
        int inited = 0;
        MPI_Initialized(&inited);
        if (!inited) {
            MPI_Init(&argc, &argv);
            owns_ = true;
        }
        MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
        MPI_Comm_size(MPI_COMM_WORLD, &size_);
#else
        (void)argc;
        (void)argv;
#endif
    }
    ~MpiSession() {
#if defined(GRAINLIGHT_EXAMPLES_MPI)
        // A rank leaving by an exception would leave the others waiting in a collective: abort all.
        if (size_ > 1 && std::uncaught_exceptions() > 0) MPI_Abort(MPI_COMM_WORLD, 1);
        if (owns_) MPI_Finalize();
#endif
    }
    MpiSession(const MpiSession&) = delete;
    MpiSession& operator=(const MpiSession&) = delete;

    /// This process's rank (0 without MPI).
    [[nodiscard]] int rank() const noexcept { return rank_; }
    /// Number of ranks (1 without MPI).
    [[nodiscard]] int size() const noexcept { return size_; }
    /// Rank 0 writes outputs and prints.
    [[nodiscard]] bool root() const noexcept { return rank_ == 0; }
    /// The contiguous share [begin, end) of `count` items for this rank (balanced to one item).
    [[nodiscard]] std::pair<std::uint64_t, std::uint64_t> block_range(std::uint64_t count) const noexcept {
        const auto k = std::uint64_t(size_), r = std::uint64_t(rank_);
        return {count * r / k, count * (r + 1) / k};
    }
    /// The share of rank r (for reporting).
    [[nodiscard]] std::pair<std::uint64_t, std::uint64_t> block_range_of(int r, std::uint64_t count) const noexcept {
        const auto k = std::uint64_t(size_), rr = std::uint64_t(r);
        return {count * rr / k, count * (rr + 1) / k};
    }

    /// Every rank's share of `count` items as [begin_0, end_0, begin_1, end_1, ...] (for the JSON
    /// summaries' "rank_blocks").
    [[nodiscard]] std::vector<double> block_ranges(std::uint64_t count) const {
        std::vector<double> ranges;
        for (int r = 0; r < size_; ++r) {
            const auto [b, e] = block_range_of(r, count);
            ranges.push_back(double(b));
            ranges.push_back(double(e));
        }
        return ranges;
    }

    /// Rows per rank of a `height`-row render split as y % size() == rank (for the JSON
    /// summaries' "rank_row_counts").
    [[nodiscard]] std::vector<double> row_counts(int height) const {
        std::vector<double> counts;
        for (int r = 0; r < size_; ++r) counts.push_back(double((height - r + size_ - 1) / size_));
        return counts;
    }

    /// Collect every rank's bytes on rank 0, in rank order (other ranks get an empty list).
    [[nodiscard]] std::vector<std::vector<unsigned char>> gather_bytes(const std::vector<unsigned char>& mine) const {
        std::vector<std::vector<unsigned char>> all;
#if defined(GRAINLIGHT_EXAMPLES_MPI)
        if (size_ > 1) {
            const auto n = static_cast<unsigned long long>(mine.size());
            std::vector<unsigned long long> sizes(std::size_t(size_), 0);
            MPI_Gather(&n, 1, MPI_UNSIGNED_LONG_LONG, sizes.data(), 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
            // Chunks below 2^30 bytes keep MPI's int counts valid for any partial size.
            constexpr unsigned long long chunk = 1ull << 30;
            if (root()) {
                all.resize(std::size_t(size_));
                all[0] = mine;
                for (int r = 1; r < size_; ++r) {
                    auto& buf = all[std::size_t(r)];
                    buf.resize(std::size_t(sizes[std::size_t(r)]));
                    for (unsigned long long off = 0; off < buf.size(); off += chunk)
                        MPI_Recv(buf.data() + off, int(std::min<unsigned long long>(chunk, buf.size() - off)), MPI_BYTE, r,
                                 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
                }
            } else {
                for (unsigned long long off = 0; off < mine.size(); off += chunk)
                    MPI_Send(mine.data() + off, int(std::min<unsigned long long>(chunk, mine.size() - off)), MPI_BYTE, 0, 0,
                             MPI_COMM_WORLD);
            }
            return all;
        }
#endif
        all.push_back(mine);
        return all;
    }

    /// The film of a render whose rows were split with row_offset = rank, row_stride = size():
    /// on rank 0 the complete film (row y from rank y % size()), elsewhere an empty film.
    [[nodiscard]] grainlight::Film gather_film_rows(const grainlight::Film& local) const {
        if (size_ == 1) return local;
        const int w = local.width(), h = local.height();
        // Only this rank's rows travel: per row 3w sums, w weights, w non-finite counts.
        std::vector<unsigned char> mine;
        for (int y = rank_; y < h; y += size_) append_row(local, y, mine);
        const auto all = gather_bytes(mine);
        if (!root()) return {};
        RowsIn in(w, h);
        for (int r = 0; r < size_; ++r) {
            const unsigned char* p = all[std::size_t(r)].data();
            for (int y = r; y < h; y += size_) in.read_row(y, p);
        }
        return in.film();
    }

    /// Element-wise sum of every rank's `values` on rank 0, added in rank order (elsewhere the
    /// input is returned unchanged). For per-row quantities of a row-split render (zero in the
    /// rows a rank did not render) this is a placement and bit-identical to one process; for
    /// integer-valued counts below 2^53 it is exact.
    [[nodiscard]] std::vector<double> sum_to_root(std::vector<double> values) const {
#if defined(GRAINLIGHT_EXAMPLES_MPI)
        if (size_ > 1) {
            std::vector<unsigned char> mine(values.size() * sizeof(double));
            std::memcpy(mine.data(), values.data(), mine.size());
            const auto all = gather_bytes(mine);
            if (!root()) return values;
            std::fill(values.begin(), values.end(), 0.0);
            for (const auto& buf : all) {
                if (buf.size() != values.size() * sizeof(double)) throw std::runtime_error("sum_to_root: ranks sent different sizes");
                for (std::size_t i = 0; i < values.size(); ++i) {
                    double v;
                    std::memcpy(&v, buf.data() + i * sizeof(double), sizeof(double));
                    values[i] += v;
                }
            }
        }
#endif
        return values;
    }

    /// Rank 0's bytes on every rank (`bytes` is replaced elsewhere).
    void broadcast_bytes(std::vector<unsigned char>& bytes) const {
#if defined(GRAINLIGHT_EXAMPLES_MPI)
        if (size_ > 1) {
            unsigned long long n = bytes.size();
            MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
            bytes.resize(std::size_t(n));
            constexpr unsigned long long chunk = 1ull << 30;
            for (unsigned long long off = 0; off < n; off += chunk)
                MPI_Bcast(bytes.data() + off, int(std::min<unsigned long long>(chunk, n - off)), MPI_BYTE, 0, MPI_COMM_WORLD);
        }
#else
        (void)bytes;
#endif
    }

    /// Rank 0's values on every rank (decisions rank 0 takes from its own timings: every rank
    /// then renders the same image).
    void broadcast(std::vector<double>& values) const {
        if (size_ == 1) return;
        std::vector<unsigned char> b(values.size() * sizeof(double));
        if (!b.empty()) std::memcpy(b.data(), values.data(), b.size());
        broadcast_bytes(b);
        values.resize(b.size() / sizeof(double));
        if (!b.empty()) std::memcpy(values.data(), b.data(), b.size());
    }

    /// gather_film_rows, then the complete film on every rank (not only rank 0): every rank can
    /// summarize the same film and take the same decisions from it.
    [[nodiscard]] grainlight::Film share_film_rows(const grainlight::Film& local) const {
        if (size_ == 1) return local;
        const int w = local.width(), h = local.height();
        grainlight::Film full = gather_film_rows(local);
        std::vector<unsigned char> bytes;
        if (root())
            for (int y = 0; y < h; ++y) append_row(full, y, bytes);
        broadcast_bytes(bytes);
        if (root()) return full;
        RowsIn in(w, h);
        const unsigned char* p = bytes.data();
        for (int y = 0; y < h; ++y) in.read_row(y, p);
        return in.film();
    }

private:
    // A film's accumulators filled row by row from append_row's byte layout.
    struct RowsIn {
        int w, h;
        std::vector<double> sums, weights;
        std::vector<std::uint32_t> nonfinite;
        RowsIn(int width, int height)
            : w(width), h(height), sums(3 * std::size_t(width) * std::size_t(height)),
              weights(std::size_t(width) * std::size_t(height)), nonfinite(std::size_t(width) * std::size_t(height)) {}
        // Row y from p (3w sums, w weights, w non-finite counts); p moves past it.
        void read_row(int y, const unsigned char*& p) {
            const std::size_t i0 = std::size_t(y) * std::size_t(w), n = std::size_t(w);
            std::memcpy(sums.data() + 3 * i0, p, 3 * n * sizeof(double));
            p += 3 * n * sizeof(double);
            std::memcpy(weights.data() + i0, p, n * sizeof(double));
            p += n * sizeof(double);
            std::memcpy(nonfinite.data() + i0, p, n * sizeof(std::uint32_t));
            p += n * sizeof(std::uint32_t);
        }
        grainlight::Film film() {
            return grainlight::Film::from_accumulators(w, h, std::move(sums), std::move(weights), std::move(nonfinite));
        }
    };
    static void append_row(const grainlight::Film& f, int y, std::vector<unsigned char>& out) {
        const std::size_t w = std::size_t(f.width()), i0 = std::size_t(y) * w;
        auto put = [&](const void* src, std::size_t bytes) {
            const auto* b = static_cast<const unsigned char*>(src);
            out.insert(out.end(), b, b + bytes);
        };
        put(f.sums().data() + 3 * i0, 3 * w * sizeof(double));
        put(f.weights().data() + i0, w * sizeof(double));
        put(f.nonfinite_counts().data() + i0, w * sizeof(std::uint32_t));
    }
    int rank_ = 0, size_ = 1;
    bool owns_ = false;
};

}  // namespace gl_examples
