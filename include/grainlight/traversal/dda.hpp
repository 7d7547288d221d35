/// @file grainlight/traversal/dda.hpp
/// Amanatides-Woo 3D DDA ("A Fast Voxel Traversal Algorithm for Ray Tracing", Eurographics
/// 1987) over an unbounded uniform grid with 64-bit cell indices: visits, in order of distance,
/// every cell the segment o + t d, t in [t_min, t_max], passes through, with the entry and exit
/// parameters of each.
///
/// Precision. The ray origin is given as a 64-bit base cell plus a local offset from that cell's
/// corner, and the crossing parameters are recomputed from the integer cell offset at every step
/// (no accumulated t += t_delta drift), so rays in grids of billions of cells keep their accuracy.
/// Ties (a ray through an edge or corner) step one axis at a time (lowest axis first); the
/// zero-length cells visited in between have t_enter == t_exit.
#pragma once

#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <utility>

#include "grainlight/core/config.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/aabb.hpp"

namespace grainlight {

/// Iterator over the cells of a uniform grid pierced by a ray segment (Amanatides & Woo 1987).
///
/// Usage:
/// ```
/// for (GridDda<double> dda(base, offset, d, cell_size, t0, t1); !dda.done(); dda.step())
///     visit(dda.cell(), dda.t_enter(), dda.t_exit());
/// ```
/// Cell c (64-bit integer per axis) covers [c h, (c + 1) h) per axis in the grid's frame; the ray
/// origin is base_cell h + local_offset. d need not be unit length (t is in units of d).
template <std::floating_point F>
class GridDda {
public:
    /// Set up the traversal of o + t d, t in [t_min, t_max] (t_max may be +inf: then the caller
    /// stops). An empty interval, a zero direction or a non-positive cell size gives done().
    GRAINLIGHT_HOST_DEVICE GridDda(const Vec3i64& base_cell, const Vec3<F>& local_offset, const Vec3<F>& d,
                                   const Vec3<F>& cell_size, F t_min, F t_max) noexcept
        : base_(base_cell), o_(local_offset), d_(d), h_(cell_size), t_(t_min), t_max_(t_max) {
        if (!(t_min <= t_max) || !(cell_size.x > 0 && cell_size.y > 0 && cell_size.z > 0) ||
            !(d.x != 0 || d.y != 0 || d.z != 0)) {
            done_ = true;
            return;
        }
        for (int a = 0; a < 3; ++a) {
            const F p = o_[a] + t_min * d_[a];
            r_[a] = static_cast<std::int64_t>(std::floor(p / h_[a]));
            step_[a] = d_[a] > 0 ? 1 : (d_[a] < 0 ? -1 : 0);
            next_[a] = crossing(a);
        }
        // Guard against round-off putting the start point on the far side of a boundary.
        for (int a = 0; a < 3; ++a)
            if (next_[a] < t_min) {
                r_[a] += step_[a];
                next_[a] = crossing(a);
            }
        update_axis();
    }

    /// No cell left (the segment is exhausted).
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE bool done() const noexcept { return done_; }
    /// Current cell (absolute 64-bit index: base_cell + offset).
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE Vec3i64 cell() const noexcept {
        return Vec3i64(base_.x + r_[0], base_.y + r_[1], base_.z + r_[2]);
    }
    /// Current cell relative to base_cell.
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE const std::array<std::int64_t, 3>& relative_cell() const noexcept { return r_; }
    /// Ray parameter where the segment enters the current cell (>= t_min).
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE F t_enter() const noexcept { return t_; }
    /// Ray parameter where the segment leaves the current cell (<= t_max).
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE F t_exit() const noexcept { return next_[axis_] < t_max_ ? next_[axis_] : t_max_; }
    /// Axis (0, 1, 2) through whose face the segment leaves the current cell.
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE int exit_axis() const noexcept { return axis_; }

    /// Advance to the next cell along the ray.
    GRAINLIGHT_HOST_DEVICE void step() noexcept {
        if (done_) return;
        const F t_next = next_[axis_];
        if (!(t_next < t_max_)) {
            done_ = true;
            return;
        }
        t_ = t_next;
        r_[axis_] += step_[axis_];
        next_[axis_] = crossing(axis_);
        update_axis();
    }

private:
    [[nodiscard]] GRAINLIGHT_HOST_DEVICE F crossing(int a) const noexcept {
        if (step_[a] == 0) return std::numeric_limits<F>::infinity();
        const F boundary = F(r_[a] + (step_[a] > 0 ? 1 : 0)) * h_[a];
        return (boundary - o_[a]) / d_[a];
    }
    GRAINLIGHT_HOST_DEVICE void update_axis() noexcept {
        axis_ = (next_[0] <= next_[1]) ? (next_[0] <= next_[2] ? 0 : 2) : (next_[1] <= next_[2] ? 1 : 2);
    }

    Vec3i64 base_;
    Vec3<F> o_, d_, h_;
    F t_, t_max_;
    std::array<std::int64_t, 3> r_{}, step_{};
    std::array<F, 3> next_{};
    int axis_ = 0;
    bool done_ = false;
};

/// Clip the parameter interval [t0, t1] of o + t d to the box [lo, hi]: geometry/aabb.hpp's
/// clip_ray_to_box under its traversal-layer name (kept for callers).
template <std::floating_point F>
[[nodiscard]] GRAINLIGHT_HOST_DEVICE inline bool clip_to_box(const Vec3<F>& o, const Vec3<F>& d, const Vec3<F>& lo,
                                                             const Vec3<F>& hi, F& t0, F& t1) noexcept {
    return clip_ray_to_box(o, d, lo, hi, t0, t1);
}

}  // namespace grainlight
