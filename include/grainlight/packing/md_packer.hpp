/// @file grainlight/packing/md_packer.hpp
/// Dense periodic packings of equal spheres by event-driven molecular dynamics with
/// Lubachevsky-Stillinger growth (Lubachevsky & Stillinger 1990; Skoge, Donev, Stillinger &
/// Torquato 2006, "Packing hyperspheres in high-dimensional Euclidean spaces", PRE 74, 041127),
/// the packer Meng15 Sec. 3.1 uses for its dictionary of tiles.
///
/// Method (our implementation of the published algorithm):
/// - start from a random sequential addition configuration at a moderate rate (<= 0.3) with
///   Maxwell-Boltzmann velocities (kT = m = 1, zero total momentum);
/// - all diameters grow linearly in time, D(t) = D_0 + a t; a is the dimensionless growth rate
///   in units where the number density is 1 (box side N^(1/3)) and kT = m = 1;
/// - pair collision times solve |r + v tau| = D(t) + a tau (smallest positive root); at a
///   collision the normal relative velocity is reflected in the frame of the growing surfaces,
///   u_n' = 2 a - u_n, so the pair separates at least at the growth rate;
/// - each sphere holds one predicted event (collision or cell-boundary crossing) in an indexed
///   binary heap; a collision is valid only if the partner has not collided since the
///   prediction (collision counters); a cell list (cell width >= the final diameter) limits
///   predictions to the 27 neighbouring cells, with periodic images;
/// - every few collisions per sphere all positions are synchronized, the kinetic energy is
///   rescaled to kT = 1 (growth heats the system) and the reduced pressure
///   Z = PV/(NkT) = 1 + sum_collisions D |dp| / (3 N kT dt) is estimated;
/// - the run stops when D reaches the diameter of the target rate, or at jamming (Z above a
///   threshold: the collision rate diverges), or after an event budget;
/// - a final cell-list check over all pairs finds the smallest centre distance; radii are shrunk
///   by a reported factor (1 - ~1e-12) so that round-off overlaps are removed.
/// Fast growth jams near f = 0.634-0.64; very slow growth can crystallize above ~0.6 (Skoge et
/// al.), so the default rate is fast and the run stops at the target rate.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/packing/periodic_tile.hpp"
#include "grainlight/packing/poisson.hpp"

namespace grainlight {

/// Largest packing rate md_pack accepts as a target (random close packing is ~0.64).
inline constexpr double md_max_fraction = 0.64;

/// Settings of the event-driven MD packer.
struct MdPackerOptions {
    /// Dimensionless growth rate a = dD/dt (number density 1, kT = m = 1). Larger is faster and
    /// jams at a lower rate; 0.01-0.1 jam near 0.63-0.64 for N ~ 1e3.
    double growth_rate = 0.03;
    /// Packing rate of the RSA start (used as min(initial_fraction, 0.8 * target)).
    double initial_fraction = 0.3;
    /// Jamming: stop when the reduced pressure Z = PV/(NkT) exceeds this.
    double jamming_pressure = 1e4;
    /// Event budget per sphere; the run stops (as jammed) when it is used up.
    double max_events_per_sphere = 1e5;
    /// Collisions per sphere between velocity rescaling / pressure checkpoints.
    double collisions_per_checkpoint = 5.0;
};

/// Outcome of md_pack.
struct MdPackResult {
    PeriodicTile tile;             ///< the packing (radius already shrunk)
    double fraction = 0;           ///< achieved packing rate (tile.packing_fraction())
    double target_fraction = 0;    ///< requested rate
    bool reached_target = false;   ///< false: stopped at jamming or at the event budget
    double reduced_pressure = 0;   ///< last estimate of Z = PV/(NkT)
    double shrink_factor = 1;      ///< final radius / radius at the end of the MD run
    std::uint64_t events = 0;      ///< processed events (collisions, cell crossings, stale)
    std::uint64_t collisions = 0;  ///< processed collisions
};

namespace detail {

/// Smallest tau >= 0 with |r + v tau| = D + a tau, or +inf (see the file comment).
[[nodiscard]] inline double ls_collision_time(const Vec3d& r, const Vec3d& v, double diam, double a) noexcept {
    const double A = glm::dot(v, v) - a * a;
    const double B = glm::dot(r, v) - diam * a;
    const double C = glm::dot(r, r) - diam * diam;
    constexpr double inf = std::numeric_limits<double>::infinity();
    if (B < 0 && C <= 0) return 0.0;  // touching/overlapping by round-off and approaching
    if (A >= 0 && B >= 0) return inf;  // separating faster than growing (the common case)
    const double disc = B * B - A * C;
    if (disc < 0) return inf;
    const double sq = std::sqrt(disc);
    if (A < 0) return B >= 0 ? (-B - sq) / A : C / (-B + sq);
    return C / (-B + sq);
}

/// Indexed binary min-heap of event times, one slot per sphere.
class EventHeap {
public:
    void reset(const std::vector<double>& keys) {
        key_ = keys;
        const std::size_t n = keys.size();
        heap_.resize(n);
        pos_.resize(n);
        for (std::size_t i = 0; i < n; ++i) heap_[i] = std::uint32_t(i), pos_[i] = std::uint32_t(i);
        for (std::size_t i = n / 2; i-- > 0;) down(i);
    }
    [[nodiscard]] std::uint32_t top() const noexcept { return heap_[0]; }
    [[nodiscard]] double top_key() const noexcept { return key_[heap_[0]]; }
    void update(std::uint32_t id, double k) noexcept {
        const double old = key_[id];
        key_[id] = k;
        if (k < old)
            up(pos_[id]);
        else
            down(pos_[id]);
    }

private:
    void swap_at(std::size_t a, std::size_t b) noexcept {
        std::swap(heap_[a], heap_[b]);
        pos_[heap_[a]] = std::uint32_t(a);
        pos_[heap_[b]] = std::uint32_t(b);
    }
    void up(std::size_t i) noexcept {
        while (i > 0) {
            const std::size_t p = (i - 1) / 2;
            if (!(key_[heap_[i]] < key_[heap_[p]])) break;
            swap_at(i, p);
            i = p;
        }
    }
    void down(std::size_t i) noexcept {
        const std::size_t n = heap_.size();
        for (;;) {
            std::size_t l = 2 * i + 1, s = i;
            if (l < n && key_[heap_[l]] < key_[heap_[s]]) s = l;
            if (l + 1 < n && key_[heap_[l + 1]] < key_[heap_[s]]) s = l + 1;
            if (s == i) break;
            swap_at(i, s);
            i = s;
        }
    }
    std::vector<double> key_;
    std::vector<std::uint32_t> heap_, pos_;
};

/// The event-driven Lubachevsky-Stillinger simulation (box side N^(1/3)).
class LsSimulation {
public:
    static constexpr std::uint32_t no_partner = UINT32_MAX;

    LsSimulation(std::vector<Vec3d> x, double diam0, double box, double max_diam, double growth, Rng& rng)
        : n_(x.size()), box_(box), d0_(diam0), a_(growth) {
        m_ = static_cast<int>(grid_cells_per_axis(box, max_diam, n_));
        w_ = box / m_;
        p_.resize(n_);
        for (std::size_t i = 0; i < n_; ++i) p_[i].x = x[i];
        ncoll_.assign(n_, 0);
        ev_.resize(n_);
        cell_.resize(n_);
        head_.assign(std::size_t(m_) * m_ * m_, no_partner);
        // Maxwell-Boltzmann velocities (Box-Muller), zero momentum, kT = 1.
        Vec3d mean(0.0);
        for (auto& pi : p_) {
            for (int a = 0; a < 3; ++a) {
                const double u1 = 1.0 - rng.uniform<double>(), u2 = rng.uniform<double>();
                pi.v[a] = std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * pi_v<double> * u2);
            }
            mean += pi.v;
        }
        mean /= double(n_);
        for (auto& pi : p_) pi.v -= mean;
        rescale_velocities();
        for (std::size_t i = 0; i < n_; ++i) {
            std::array<int, 3> c{};
            for (int a = 0; a < 3; ++a) {
                p_[i].x[a] -= box_ * std::floor(p_[i].x[a] / box_);
                c[a] = std::clamp(static_cast<int>(p_[i].x[a] / w_), 0, m_ - 1);
            }
            cell_[i] = c;
            link(std::uint32_t(i));
        }
    }

    [[nodiscard]] double diameter(double t) const noexcept { return d0_ + a_ * t; }
    [[nodiscard]] double diameter() const noexcept { return diameter(t_); }
    [[nodiscard]] double fraction() const noexcept {
        const double d = diameter();
        return double(n_) * pi_v<double> / 6.0 * d * d * d / (box_ * box_ * box_);
    }
    [[nodiscard]] double pressure() const noexcept { return z_; }
    [[nodiscard]] std::uint64_t events() const noexcept { return events_; }
    [[nodiscard]] std::uint64_t collisions() const noexcept { return collisions_; }

    /// Run until the diameter reaches d_stop, Z > z_jam, or the event budget is used.
    /// `on_checkpoint(fraction)` is called at every checkpoint. Returns true if d_stop was reached.
    template <class OnCheckpoint>
    bool run(double d_stop, double z_jam, std::uint64_t max_events, std::uint64_t collisions_per_checkpoint,
             OnCheckpoint&& on_checkpoint) {
        predict_all();
        std::uint64_t coll_at_checkpoint = collisions_;
        virial_ = 0;
        double t_checkpoint_start = 0;
        for (;;) {
            const double t_stop = (d_stop - d0_) / a_;
            const std::uint32_t i = heap_.top();
            const double te = heap_.top_key();
            if (te >= t_stop) {
                sync_all(t_stop);
                t_ = t_stop;
                return true;
            }
            t_ = te;
            ++events_;
            Event& e = ev_[i];
            if (e.partner == no_partner) {
                cross_cell(i, e.axis);
                predict(i);
            } else if (ncoll_[e.partner] != e.partner_count) {
                predict(i);  // stale: the partner changed course since the prediction
            } else {
                collide(i, e.partner, e.shift);
            }
            if (collisions_ - coll_at_checkpoint >= collisions_per_checkpoint) {
                // Reduced pressure over the interval (virial of the collision impulses).
                const double dt = t_ - t_checkpoint_start;
                double v2 = 0;
                sync_all(t_);
                for (const auto& pi : p_) v2 += glm::dot(pi.v, pi.v);
                const double kT = v2 / (3.0 * double(n_));
                z_ = dt > 0 ? 1.0 + virial_ / (3.0 * double(n_) * kT * dt) : std::numeric_limits<double>::infinity();
                rebase();
                rescale_velocities();
                predict_all();
                coll_at_checkpoint = collisions_;
                virial_ = 0;
                t_checkpoint_start = 0;
                on_checkpoint(fraction());
                if (z_ > z_jam) return false;
            }
            if (events_ >= max_events) {
                sync_all(t_);
                return false;
            }
        }
    }

    /// Centres wrapped into [0, box).
    [[nodiscard]] std::vector<Vec3d> positions() {
        sync_all(t_);
        std::vector<Vec3d> out(n_);
        for (std::size_t i = 0; i < n_; ++i) out[i] = p_[i].x;
        for (auto& p : out)
            for (int a = 0; a < 3; ++a) {
                p[a] -= box_ * std::floor(p[a] / box_);
                if (p[a] >= box_) p[a] = 0;
            }
        return out;
    }

private:
    /// Per-sphere state in one cache line: position at time tl, velocity, cell-list links.
    struct alignas(64) Particle {
        Vec3d x{0.0};
        double tl = 0;
        Vec3d v{0.0};
        std::uint32_t next = no_partner, prev = no_partner;
    };
    struct Event {
        double time = std::numeric_limits<double>::infinity();
        std::uint32_t partner = no_partner;
        int axis = 0;
        std::uint64_t partner_count = 0;
        std::array<std::int8_t, 3> shift{0, 0, 0};  // partner image (box units) at prediction
    };

    [[nodiscard]] std::size_t cell_id(const std::array<int, 3>& c) const noexcept {
        return (std::size_t(c[2]) * m_ + c[1]) * m_ + c[0];
    }
    void link(std::uint32_t i) noexcept {
        const auto id = cell_id(cell_[i]);
        p_[i].prev = no_partner;
        p_[i].next = head_[id];
        if (head_[id] != no_partner) p_[head_[id]].prev = i;
        head_[id] = i;
    }
    void unlink(std::uint32_t i) noexcept {
        const auto id = cell_id(cell_[i]);
        if (p_[i].prev != no_partner)
            p_[p_[i].prev].next = p_[i].next;
        else
            head_[id] = p_[i].next;
        if (p_[i].next != no_partner) p_[p_[i].next].prev = p_[i].prev;
    }
    void sync(std::uint32_t i, double t) noexcept {
        p_[i].x += p_[i].v * (t - p_[i].tl);
        p_[i].tl = t;
    }
    void sync_all(double t) noexcept {
        for (std::uint32_t i = 0; i < n_; ++i) sync(i, t);
    }
    /// Make t = 0 the current time (keeps event times small and precise).
    void rebase() noexcept {
        d0_ = diameter(t_);
        t_ = 0;
        for (auto& pi : p_) pi.tl = 0.0;
    }
    void rescale_velocities() noexcept {
        double v2 = 0;
        for (const auto& pi : p_) v2 += glm::dot(pi.v, pi.v);
        const double s = v2 > 0 ? std::sqrt(3.0 * double(n_) / v2) : 1.0;
        for (auto& pi : p_) pi.v *= s;
    }
    void cross_cell(std::uint32_t i, int axis) noexcept {
        sync(i, t_);
        unlink(i);
        auto& c = cell_[i][axis];
        if (p_[i].v[axis] > 0) {
            if (++c == m_) {
                c = 0;
                p_[i].x[axis] -= box_;
                ++ncoll_[i];  // position representation changed: partners' image shifts are stale
            }
        } else {
            if (--c < 0) {
                c = m_ - 1;
                p_[i].x[axis] += box_;
                ++ncoll_[i];
            }
        }
        link(i);
    }
    void collide(std::uint32_t i, std::uint32_t j, const std::array<std::int8_t, 3>& shift) noexcept {
        sync(i, t_);
        sync(j, t_);
        const Vec3d r = p_[j].x + Vec3d(shift[0], shift[1], shift[2]) * box_ - p_[i].x;
        const double len = std::sqrt(glm::dot(r, r));
        const Vec3d nrm = r / len;
        const double un = glm::dot(p_[j].v - p_[i].v, nrm);
        const double dp = std::max(a_ - un, 0.0);  // impulse per sphere (m = 1)
        p_[i].v -= dp * nrm;
        p_[j].v += dp * nrm;
        virial_ += diameter(t_) * dp;
        ++ncoll_[i];
        ++ncoll_[j];
        ++collisions_;
        predict(i);
        predict(j);
    }
    void predict(std::uint32_t i) noexcept {
        sync(i, t_);
        Event e;
        // Cell-boundary crossing.
        for (int a = 0; a < 3; ++a) {
            const double va = p_[i].v[a];
            if (va == 0) continue;
            const double b = (cell_[i][a] + (va > 0 ? 1 : 0)) * w_;
            const double tau = std::max((b - p_[i].x[a]) / va, 0.0);
            if (t_ + tau < e.time) {
                e.time = t_ + tau;
                e.axis = a;
            }
        }
        const double diam = diameter(t_);
        const Vec3d xi = p_[i].x, vi = p_[i].v;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    std::array<int, 3> q{cell_[i][0] + dx, cell_[i][1] + dy, cell_[i][2] + dz};
                    std::array<std::int8_t, 3> sh{0, 0, 0};
                    for (int a = 0; a < 3; ++a) {
                        if (q[a] < 0) {
                            q[a] += m_;
                            sh[a] = -1;
                        } else if (q[a] >= m_) {
                            q[a] -= m_;
                            sh[a] = 1;
                        }
                    }
                    const Vec3d shift = Vec3d(sh[0], sh[1], sh[2]) * box_;
                    for (std::uint32_t j = head_[cell_id(q)]; j != no_partner; j = p_[j].next) {
                        if (j == i) continue;
                        const Particle& pj = p_[j];
                        const Vec3d xj = pj.x + pj.v * (t_ - pj.tl) + shift;
                        const double tau = ls_collision_time(xj - xi, pj.v - vi, diam, a_);
                        if (t_ + tau < e.time) {
                            e.time = t_ + tau;
                            e.partner = j;
                            e.partner_count = ncoll_[j];
                            e.shift = sh;
                        }
                    }
                }
        ev_[i] = e;
        if (heap_ready_) heap_.update(i, e.time);
    }
    void predict_all() {
        heap_ready_ = false;
        std::vector<double> keys(n_);
        for (std::uint32_t i = 0; i < n_; ++i) {
            predict(i);
            keys[i] = ev_[i].time;
        }
        heap_.reset(keys);
        heap_ready_ = true;
    }

    std::size_t n_;
    double box_, d0_, a_;
    int m_ = 1;
    double w_ = 1;
    double t_ = 0;
    double virial_ = 0, z_ = 1;
    std::uint64_t events_ = 0, collisions_ = 0;
    std::vector<Particle> p_;
    std::vector<std::uint64_t> ncoll_;  // per-sphere version: collisions + periodic wraps
    std::vector<Event> ev_;
    std::vector<std::array<int, 3>> cell_;
    std::vector<std::uint32_t> head_;
    EventHeap heap_;
    bool heap_ready_ = false;
};

/// No-op progress callback.
struct NoProgress {
    void operator()(double) const noexcept {}
};

}  // namespace detail

/// Pack `n` equal spheres in a periodic cube of side `side` up to packing rate `fraction` by
/// event-driven MD with Lubachevsky-Stillinger growth (see the file comment), deterministic for
/// `seed`. If the packing jams (or the event budget runs out) before `fraction`, the result holds
/// the rate reached and reached_target = false. `progress(current_fraction)` is called at every
/// checkpoint (for progress bars). Throws grainlight::invalid_argument for n < 2, fraction
/// outside (0, 0.64), side <= 0, or invalid options.
template <class Progress = detail::NoProgress>
[[nodiscard]] MdPackResult md_pack(std::size_t n, double fraction, std::uint64_t seed, const MdPackerOptions& opt = {},
                                   double side = 1.0, Progress&& progress = {}) {
    constexpr const char* where = "md_pack";
    check_argument(n >= 2, where, "n", n, ">= 2");
    check_argument(fraction > 0 && fraction < md_max_fraction, where, "fraction", fraction, "(0, 0.64)");
    check_argument(std::isfinite(side) && side > 0, where, "side", side, "finite, > 0");
    check_argument(std::isfinite(opt.growth_rate) && opt.growth_rate > 0, where, "growth_rate", opt.growth_rate, "> 0");
    check_argument(opt.initial_fraction > 0 && opt.initial_fraction <= 0.35, where, "initial_fraction",
                   opt.initial_fraction, "(0, 0.35]");
    check_argument(opt.jamming_pressure > 1, where, "jamming_pressure", opt.jamming_pressure, "> 1");
    check_argument(opt.max_events_per_sphere > 0, where, "max_events_per_sphere", opt.max_events_per_sphere, "> 0");
    check_argument(opt.collisions_per_checkpoint > 0, where, "collisions_per_checkpoint", opt.collisions_per_checkpoint,
                   "> 0");
    const double box = std::cbrt(double(n));  // number density 1
    const double d_target = 2 * radius_for_fraction(n, fraction, box);
    check_argument(d_target < 0.5 * box, where, "n", n, "large enough that 2R < side / 2 at this fraction");

    Rng rng = Rng::from_key(seed, 0x6d645f7061636bull /* "md_pack" */, n);
    const double f0 = std::min(opt.initial_fraction, 0.8 * fraction);
    const double d0 = 2 * radius_for_fraction(n, f0, box);
    std::vector<Vec3d> x;
    if (!detail::rsa_centers(n, d0 / 2, box, rng, 2000 * std::uint64_t(n) + 100000, x))
        raise_invalid_argument(where, "initial_fraction", f0, "reachable by RSA");

    detail::LsSimulation sim(std::move(x), d0, box, d_target, opt.growth_rate, rng);
    const auto max_events = static_cast<std::uint64_t>(opt.max_events_per_sphere * double(n));
    const auto per_checkpoint =
        std::max<std::uint64_t>(1, static_cast<std::uint64_t>(opt.collisions_per_checkpoint * double(n)));
    const bool reached = sim.run(d_target, opt.jamming_pressure, max_events, per_checkpoint, progress);
    double diam = sim.diameter();
    std::vector<Vec3d> pos = sim.positions();

    // Final all-pairs (cell list) overlap check; shrink to remove round-off overlaps.
    double dmin = std::numeric_limits<double>::infinity();
    detail::for_each_close_pair(pos, box, std::min(diam * 1.001, box / 2),
                                [&](std::uint32_t, std::uint32_t, const Vec3d& r) {
                                    dmin = std::min(dmin, std::sqrt(glm::dot(r, r)));
                                });
    const double d_final = std::min(diam, dmin) * (1.0 - 1e-12);
    const double scale = side / box;
    for (auto& p : pos) {
        p *= scale;
        for (int a = 0; a < 3; ++a)
            if (p[a] >= side) p[a] = 0;
    }
    MdPackResult res{PeriodicTile(side, 0.5 * d_final * scale, std::move(pos))};
    res.fraction = res.tile.packing_fraction();
    res.target_fraction = fraction;
    res.reached_target = reached;
    res.reduced_pressure = sim.pressure();
    res.shrink_factor = d_final / diam;
    res.events = sim.events();
    res.collisions = sim.collisions();
    return res;
}

}  // namespace grainlight
