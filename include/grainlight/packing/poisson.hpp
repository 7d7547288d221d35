/// @file grainlight/packing/poisson.hpp
/// Random sequential addition (RSA, "hard-sphere Poisson" packing) of equal spheres in a periodic
/// cube: centres are drawn uniformly one after another and rejected if the new sphere overlaps
/// an earlier one (minimum-image convention). RSA saturates near f = 0.38 (Torquato, Uche &
/// Stillinger 2006) and slows down well before, so it is offered for low packing rates
/// (f <= 0.35) and as the starting configuration of the event-driven MD packer (md_packer.hpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/packing/periodic_tile.hpp"

namespace grainlight {

/// Largest packing rate random_sequential_addition accepts.
inline constexpr double rsa_max_fraction = 0.35;

/// Radius of N equal spheres filling the fraction f of a cube of side L:
/// R = (3 f L^3 / (4 pi N))^(1/3).
[[nodiscard]] inline double radius_for_fraction(std::size_t n, double fraction, double side) noexcept {
    return std::cbrt(3.0 * fraction * side * side * side / (4.0 * pi_v<double> * double(n)));
}

namespace detail {

/// RSA centres of n spheres of the given radius in the periodic cube [0, side)^3.
/// Returns false if `max_attempts` trials in total were not enough.
inline bool rsa_centers(std::size_t n, double radius, double side, Rng& rng, std::uint64_t max_attempts,
                        std::vector<Vec3d>& out) {
    out.clear();
    out.reserve(n);
    const double diam = 2 * radius;
    const std::int64_t m = grid_cells_per_axis(side, diam, n);
    const double w = side / double(m);
    std::vector<std::uint32_t> head(static_cast<std::size_t>(m * m * m), UINT32_MAX), next;
    next.reserve(n);
    const double d2 = diam * diam;
    std::uint64_t attempts = 0;
    while (out.size() < n) {
        if (attempts++ >= max_attempts) return false;
        const Vec3d c = rng.uniform3<double>() * side;
        std::array<std::int64_t, 3> k{};
        for (int a = 0; a < 3; ++a) k[a] = std::clamp<std::int64_t>(static_cast<std::int64_t>(c[a] / w), 0, m - 1);
        bool ok = true;
        for (int dz = -1; dz <= 1 && ok; ++dz)
            for (int dy = -1; dy <= 1 && ok; ++dy)
                for (int dx = -1; dx <= 1 && ok; ++dx) {
                    const std::array<std::int64_t, 3> q{k[0] + dx, k[1] + dy, k[2] + dz};
                    Vec3d shift(0.0);
                    std::array<std::int64_t, 3> qw{};
                    for (int a = 0; a < 3; ++a) {
                        const std::int64_t t = floor_div(q[a], m);
                        qw[a] = q[a] - t * m;
                        shift[a] = double(t) * side;
                    }
                    const auto id = static_cast<std::size_t>((qw[2] * m + qw[1]) * m + qw[0]);
                    for (std::uint32_t j = head[id]; j != UINT32_MAX; j = next[j]) {
                        const Vec3d r = out[j] + shift - c;
                        if (glm::dot(r, r) < d2) {
                            ok = false;
                            break;
                        }
                    }
                }
        if (!ok) continue;
        const auto id = static_cast<std::size_t>((k[2] * m + k[1]) * m + k[0]);
        next.push_back(head[id]);
        head[id] = std::uint32_t(out.size());
        out.push_back(c);
    }
    return true;
}

}  // namespace detail

/// A periodic tile of `n` equal spheres at packing rate `fraction` (0 < f <= 0.35) in a cube of
/// side `side`, by random sequential addition driven by `rng` (deterministic for a seed).
/// The radius follows from f: R = (3 f L^3 / (4 pi n))^(1/3).
/// Throws grainlight::invalid_argument for n == 0, f outside (0, 0.35], side <= 0, 2R >= L, or
/// if 2000 n trials in total do not place all spheres.
[[nodiscard]] inline PeriodicTile random_sequential_addition(std::size_t n, double fraction, Rng& rng,
                                                             double side = 1.0) {
    constexpr const char* where = "random_sequential_addition";
    check_argument(n >= 1, where, "n", n, ">= 1");
    check_argument(fraction > 0 && fraction <= rsa_max_fraction, where, "fraction", fraction,
                   "(0, 0.35] (RSA saturates near 0.38; use md_pack for denser packings)");
    check_argument(std::isfinite(side) && side > 0, where, "side", side, "finite, > 0");
    const double r = radius_for_fraction(n, fraction, side);
    check_argument(2 * r < side, where, "n", n, "large enough that 2R < side at this fraction");
    std::vector<Vec3d> c;
    if (!detail::rsa_centers(n, r, side, rng, 2000 * std::uint64_t(n) + 100000, c))
        raise_invalid_argument(where, "fraction", fraction, "reachable by RSA with this n (no room found)");
    return PeriodicTile(side, r, std::move(c));
}

}  // namespace grainlight
