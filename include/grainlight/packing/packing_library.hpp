/// @file grainlight/packing/packing_library.hpp
/// A dictionary of periodic tiles indexed by packing rate (Meng15 Sec. 3.1: "a dictionary of
/// periodic tiles for various packing ratios f"), generated with md_pack, saved as one
/// grainlight container file, and queried for the tile nearest to a requested rate.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/core/serialization.hpp"

namespace grainlight {

/// Tiles sorted by packing rate. Lookups are by nearest rate.
class PackingLibrary {
public:
    /// Payload type code of the library file format (see core/serialization.hpp).
    static constexpr std::uint32_t file_kind = fourcc("TLIB");
    /// Version of the library payload layout.
    static constexpr std::uint32_t file_kind_version = 1;

    PackingLibrary() = default;

    /// Generate one tile of `n` spheres (unit cube) per requested rate with md_pack; tile i uses
    /// the seed hash_words(seed, i). Rates above what the packer reaches give the jammed rate.
    [[nodiscard]] static PackingLibrary generate(const std::vector<double>& fractions, std::size_t n,
                                                 std::uint64_t seed, const MdPackerOptions& options = {}) {
        PackingLibrary lib;
        for (std::size_t i = 0; i < fractions.size(); ++i)
            lib.add(md_pack(n, fractions[i], hash_words(seed, i), options).tile);
        return lib;
    }

    /// Add a tile (kept sorted by packing rate).
    void add(PeriodicTile tile) {
        const double f = tile.packing_fraction();
        auto it = std::upper_bound(tiles_.begin(), tiles_.end(), f,
                                   [](double v, const PeriodicTile& t) { return v < t.packing_fraction(); });
        tiles_.insert(it, std::move(tile));
    }
    /// Number of tiles.
    [[nodiscard]] std::size_t size() const noexcept { return tiles_.size(); }
    /// True if the library holds no tile.
    [[nodiscard]] bool empty() const noexcept { return tiles_.empty(); }
    /// Tile i in ascending order of packing rate (std::out_of_range if i >= size()).
    [[nodiscard]] const PeriodicTile& tile(std::size_t i) const { return tiles_.at(i); }
    /// Packing rates of the tiles, ascending.
    [[nodiscard]] std::vector<double> fractions() const {
        std::vector<double> f;
        for (const auto& t : tiles_) f.push_back(t.packing_fraction());
        return f;
    }
    /// The tile whose packing rate is nearest to `fraction` (ties: the lower rate). Throws
    /// grainlight::invalid_argument if the library is empty or fraction is outside (0, 0.64).
    [[nodiscard]] const PeriodicTile& nearest(double fraction) const {
        check_argument(fraction > 0 && fraction < md_max_fraction, "PackingLibrary::nearest", "fraction", fraction,
                       "(0, 0.64)");
        check_argument(!tiles_.empty(), "PackingLibrary::nearest", "library size", tiles_.size(), ">= 1");
        std::size_t best = 0;
        for (std::size_t i = 1; i < tiles_.size(); ++i)
            if (std::abs(tiles_[i].packing_fraction() - fraction) < std::abs(tiles_[best].packing_fraction() - fraction))
                best = i;
        return tiles_[best];
    }

    /// Save all tiles in one container (kind TLIB v1: u64 count, then per tile u64 size + TILE
    /// payload), written atomically.
    void save(const std::filesystem::path& path) const {
        ByteWriter w;
        w.put(std::uint64_t(tiles_.size()));
        for (const auto& t : tiles_) {
            const auto p = t.to_payload();
            w.put(std::uint64_t(p.size()));
            w.put_array(p.data(), p.size());
        }
        write_container_atomic(path, file_kind, file_kind_version, w.bytes());
    }
    /// Load a library; grainlight::format_error on any malformed content.
    [[nodiscard]] static PackingLibrary load(const std::filesystem::path& path) {
        const std::string ctx = "'" + path.string() + "'";
        const auto payload = read_container(path, file_kind, file_kind_version);
        ByteReader r(payload, ctx);
        const auto count = r.get<std::uint64_t>();
        if (count > r.remaining() / sizeof(std::uint64_t)) r.fail("tile count " + std::to_string(count) + " exceeds the data");
        PackingLibrary lib;
        for (std::uint64_t i = 0; i < count; ++i) {
            const auto size = r.get<std::uint64_t>();
            std::vector<unsigned char> bytes;
            r.get_array(bytes, size);
            lib.add(PeriodicTile::from_payload(bytes, ctx + " tile " + std::to_string(i)));
        }
        r.expect_end();
        return lib;
    }

private:
    std::vector<PeriodicTile> tiles_;
};

}  // namespace grainlight
