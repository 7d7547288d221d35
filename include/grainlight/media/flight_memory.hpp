/// @file grainlight/media/flight_memory.hpp
/// Flight memory: the shadowing correlation of a packed granular medium, for effective-medium
/// walks that continue a path traced through explicit grains (Meng15's VPT after EPT).
///
/// An effective medium (Meng15 Eq. 4) draws every free flight afresh from an exponential. In a
/// packing, a flight that turns back near the way it came finds that channel free of grains: the
/// path has already crossed it. A memoryless medium puts grains there again, so near a boundary,
/// where much of the reflected light turns back through the channel it entered by, it returns
/// too little light (the shadow-hiding correlation of particulate media: Irvine 1966, "The
/// shadowing effect in diffuse reflection", JGR 71; Hapke 1986, Icarus 67). Measured in a
/// half-space of sand grains (docs/meng15_hybrid.md): switching to VPT after one explicit grain
/// interaction returns 7.8 % / 5.8 % too little light at 0 / 60 degrees incidence.
///
/// The model. Grain centres are treated as a Poisson process, so a flight of a path from a to b
/// is known to have no centre within the grain radius R of the segment: its tube. A later flight
/// from p along w collides at distance t with a grain whose centre lies in the disc of radius R
/// around p + t w perpendicular to w; the part of that disc inside a remembered tube holds no
/// centre. The collision rate is therefore sigma_t (1 - f(t)), with f the shadowed fraction of
/// the disc (the union over the K most recent flights, evaluated on 32 points of a Vogel spiral),
/// and the albedo and phase function are unchanged. Sampling is delta tracking against sigma_t
/// with f as the null fraction (spectral weights when the channels' sigma_t differ; Kutz et al.
/// 2017, "Spectral and decomposition tracking"); shadow rays use the same rate (the exponential
/// transmittance times an unbiased estimate of exp(sigma_t * integral of f), candidate points only
/// near remembered flights). Both see the same medium, so NEE and phase sampling stay consistent.
///
/// Where it applies: `FlightMemory::flights_left` limits the memory to the first flights after
/// the switch (a remembered tube only matters near where it was made; in the half-space, 8 flights
/// give the same reflectance as unlimited memory within 0.1 %, and deep high-albedo walks keep
/// their cost).
///
/// `FlightMemoryMedium<M>` wraps a homogeneous medium `M` (sigma_t(), albedo(), phase(): e.g.
/// ContinuousMedium) and a caller-owned FlightMemory; with no memory (null, empty or spent) it is
/// `M` itself, bit for bit. Kernel rules: no allocation, no exceptions, no virtual calls.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "grainlight/core/frame.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/core/warp.hpp"
#include "grainlight/media/concepts.hpp"

namespace grainlight {

/// Where grain centres may lie, for FlightMemoryMedium: everywhere (no boundary constraint).
/// A region type has `inside(x)` (a grain centre may lie at x), `dist(x)` (a lower bound of the
/// distance from an inside point x to the boundary: the memory asks it, through
/// its safe ball FlightMemory::boundary_distance, where the collision disc or a shadow ray may
/// reach the boundary) and `constrains`; optionally `classify(q, r, x, n, out)` (out[i] =
/// inside(x[i]) for n points within r of the medium point q, all at once; false if it
/// declines), else the disc points near the boundary ask `inside` one by one.
struct AnyCentre {
    /// Always true.
    [[nodiscard]] constexpr bool inside(const Vec3d&) const noexcept { return true; }
    /// Distance from x to the region's boundary (inside: >= 0): infinite.
    [[nodiscard]] double dist(const Vec3d&) const noexcept { return std::numeric_limits<double>::infinity(); }
    /// Whether the region constrains anything (false: the medium skips the tests).
    static constexpr bool constrains = false;
};

/// The most recent flights of a path through a packing of grains of radius `radius`, as
/// segments whose tubes of that radius are known to hold no grain centre (see the file comment).
struct FlightMemory {
    /// Flights stored at most.
    static constexpr int capacity = 8;
    double radius = 1.0;   ///< grain (bounding-sphere) radius R, world units
    int remembered = 4;    ///< K: flights whose tubes count (1..capacity; 0: no memory)
    int flights_left = 8;  ///< flights of the walk that still use the memory (each scattering flight uses one)
    std::array<Vec3d, capacity> from{};  ///< segment starts (ring buffer)
    std::array<Vec3d, capacity> to{};    ///< segment ends
    int count = 0;                       ///< flights pushed so far (the newest at (count - 1) % capacity)
    /// A ball known to lie inside the constraining region (`safe_radius` < 0: none yet), from the
    /// region's last distance query: a point x with |x - safe_centre| + r <= safe_radius has no
    /// boundary within r without a new query (the distance is 1-Lipschitz). It belongs to one
    /// region: call forget_region() before using the memory with another. Mutable: a cache of
    /// const queries.
    mutable Vec3d safe_centre{0.0};
    mutable double safe_radius = -1.0;  ///< see safe_centre

    /// Remember the flight from a to b.
    void push(const Vec3d& a, const Vec3d& b) noexcept {
        const auto i = std::size_t(count % capacity);
        from[i] = a;
        to[i] = b;
        ++count;
    }
    /// Forget every flight.
    void clear() noexcept { count = 0; }
    /// Forget the region's safe ball (see safe_centre).
    void forget_region() const noexcept { safe_radius = -1.0; }
    /// A lower bound of the distance from the medium point x (inside `region`) to the region's
    /// boundary that is >= `need` whenever the safe ball proves it; otherwise the region's
    /// distance at x, which becomes the new safe ball.
    template <class Region>
    [[nodiscard]] double boundary_distance(const Vec3d& x, double need, const Region& region) const noexcept {
        if (safe_radius >= 0.0) {
            const double bound = safe_radius - glm::length(x - safe_centre);
            if (bound >= need) return bound;
        }
        const double d = region.dist(x);
        safe_centre = x;
        safe_radius = std::isfinite(d) ? std::max(d, 0.0) : -1.0;
        return d;
    }
    /// Whether the memory changes the medium now.
    [[nodiscard]] bool active() const noexcept { return count > 0 && remembered > 0 && flights_left > 0; }
    /// Number of flights whose tubes count.
    [[nodiscard]] int size() const noexcept { return std::min({count, remembered, capacity}); }

    /// Whether point q is within 2R of a remembered flight (else the shadowed fraction there is 0).
    [[nodiscard]] bool near(const Vec3d& q) const noexcept {
        const double r2 = 4.0 * radius * radius;
        for (int j = 0; j < size(); ++j)
            if (distance2_to_segment(q, j) < r2) return true;
        return false;
    }

    /// Clips [t0, t1] to the stretch of the ray o + tau w (unit w) that lies within 2R of
    /// remembered flight j (0: the newest): inside the cylinder of radius 2R about its axis and
    /// the slab 2R beyond its ends (a superset of the capsule). False if that is empty.
    [[nodiscard]] bool near_interval(const Vec3d& o, const Vec3d& w, int j, double& t0, double& t1) const noexcept {
        const Vec3d a = from[slot(j)], ab = to[slot(j)] - a;
        const double L = glm::length(ab);
        if (!(L > 0)) return false;
        const Vec3d e = ab / L, oa = o - a;
        const double r = 2.0 * radius;
        // Slab: -r < (oa + tau w).e < L + r.
        const double h = glm::dot(oa, e), we = glm::dot(w, e);
        if (std::abs(we) > 1e-12) {
            double s0 = (-r - h) / we, s1 = (L + r - h) / we;
            if (s0 > s1) std::swap(s0, s1);
            t0 = std::max(t0, s0);
            t1 = std::min(t1, s1);
        } else if (h <= -r || h >= L + r) {
            return false;
        }
        // Cylinder: |oa_perp + tau w_perp|^2 < r^2.
        const Vec3d wp = w - we * e, op = oa - h * e;
        const double A = glm::dot(wp, wp), B = glm::dot(op, wp), C = glm::dot(op, op) - r * r;
        if (A > 1e-12) {
            const double disc = B * B - A * C;
            if (disc <= 0) return false;
            const double sq = std::sqrt(disc);
            t0 = std::max(t0, (-B - sq) / A);
            t1 = std::min(t1, (-B + sq) / A);
        } else if (C >= 0) {
            return false;
        }
        return t1 > t0;
    }

    /// Shadowed fraction f of the collision disc of radius R centred at q, perpendicular to the
    /// flight direction whose frame tangents are s and t: the share of its area within R of a
    /// remembered flight (axially within the flight) or, with a constraining `region`, outside the
    /// region where grain centres lie; on 32 points of a Vogel spiral.
    template <class Region = AnyCentre>
    [[nodiscard]] double shadowed_fraction(const Vec3d& q, const Vec3d& s, const Vec3d& t, const Region& region = {}) const noexcept {
        const int m = size();
        bool edge = false;  // the disc may reach where no centre lies (outside the region)
        if constexpr (Region::constrains) edge = !(boundary_distance(q, radius, region) >= radius);
        if (m == 0 && !edge) return 0.0;
        // Per flight a -> b (ab = b - a, L2 = |ab|^2), a disc point x = q + R (u s + v t) has
        //   (x - a).ab = c0 + u c1 + v c2   and   |x - a|^2 = e0 + u e1 + v e2 + R^2 (u^2 + v^2),
        // so the test "within R of the axis, axially inside" is a few multiply-adds per point.
        const double r2 = radius * radius;
        std::array<bool, kPoints> in{};
        bool any = false;
        for (int j = 0; j < m; ++j) {
            if (distance2_to_segment(q, j) >= 4.0 * r2) continue;  // no disc point within R of it
            const Vec3d a = from[slot(j)], ab = to[slot(j)] - a, qa = q - a;
            const double L2 = glm::dot(ab, ab);
            if (!(L2 > 0)) continue;
            const double inv_L2 = 1.0 / L2;
            const double c0 = glm::dot(qa, ab), c1 = radius * glm::dot(s, ab), c2 = radius * glm::dot(t, ab);
            const double e0 = glm::dot(qa, qa), e1 = 2.0 * radius * glm::dot(qa, s), e2 = 2.0 * radius * glm::dot(qa, t);
            for (std::size_t i = 0; i < kPoints; ++i) {
                const double u = kDiscU[i], v = kDiscV[i];
                const double ax = c0 + u * c1 + v * c2;
                const double d2 = e0 + u * e1 + v * e2 + r2 * kDiscR2[i] - ax * ax * inv_L2;
                in[i] = in[i] || (ax >= 0.0 && ax <= L2 && d2 < r2);
            }
            any = true;
        }
        if constexpr (Region::constrains) {
            if (edge) {
                std::array<Vec3d, kPoints> xs;
                for (std::size_t i = 0; i < kPoints; ++i) xs[i] = q + radius * (kDiscU[i] * s + kDiscV[i] * t);
                std::array<bool, kPoints> ins{};
                bool classified = false;
                if constexpr (requires { region.classify(q, radius, xs.data(), int(kPoints), ins.data()); })
                    classified = region.classify(q, radius, xs.data(), int(kPoints), ins.data());
                for (std::size_t i = 0; i < kPoints; ++i)
                    if (!in[i]) in[i] = classified ? !ins[i] : !region.inside(xs[i]);
                any = true;
            }
        }
        if (!any) return 0.0;
        int n = 0;
        for (bool b : in) n += b ? 1 : 0;
        return double(n) / double(kPoints);
    }

   private:
    // Segment j counted back from the newest.
    [[nodiscard]] std::size_t slot(int j) const noexcept { return std::size_t((count - 1 - j) % capacity); }
    [[nodiscard]] double distance2_to_segment(const Vec3d& x, int j) const noexcept {
        const Vec3d a = from[slot(j)], ab = to[slot(j)] - a, ax = x - a;
        const double L2 = glm::dot(ab, ab);
        const double u = L2 > 0 ? std::clamp(glm::dot(ax, ab) / L2, 0.0, 1.0) : 0.0;
        const Vec3d d = ax - u * ab;
        return glm::dot(d, d);
    }
    // Unit disc: 32 points of a Vogel (golden-angle) spiral, r = sqrt((i + 1/2) / 32), and r^2.
    static constexpr std::size_t kPoints = 32;
    static constexpr std::array<double, kPoints> kDiscU{
        0.125000000, -0.159645045, 0.024436233, 0.201222239, -0.369267557, 0.349802466, -0.117002079, -0.223135654,
        0.484115115, -0.503641109, 0.242788294, 0.179414374, -0.540757006, 0.634369523, -0.387145845, -0.089439655,
        0.549071757, -0.738878471, 0.538955125, -0.036058186, -0.512817532, 0.812359593, -0.688310641, 0.188086057,
        0.435033266, -0.850448410, 0.826102401, -0.357888202, -0.319407334, 0.849908635, -0.944034646, 0.536595808,
    };
    static constexpr std::array<double, kPoints> kDiscV{
        0.000000000, 0.146247939, -0.278438271, 0.262458779, -0.065318231, -0.222515696, 0.435241902, -0.429634123,
        0.176798064, 0.207895728, -0.518824483, 0.572001296, -0.313379738, -0.139464360, 0.550675126, -0.690199644,
        0.462758258, 0.030554945, -0.536332334, 0.779791515, -0.614526793, 0.109301834, 0.478908616, -0.836061382,
        0.759191055, -0.271316239, -0.381680263, 0.855155562, -0.888033758, 0.446688159, 0.248844503, -0.834529771,
    };
    static constexpr std::array<double, kPoints> kDiscR2{
        0.015625000, 0.046875000, 0.078125000, 0.109375000, 0.140625000, 0.171875000, 0.203125000, 0.234375000,
        0.265625000, 0.296875000, 0.328125000, 0.359375000, 0.390625000, 0.421875000, 0.453125000, 0.484375000,
        0.515625000, 0.546875000, 0.578125000, 0.609375000, 0.640625000, 0.671875000, 0.703125000, 0.734375000,
        0.765625000, 0.796875000, 0.828125000, 0.859375000, 0.890625000, 0.921875000, 0.953125000, 0.984375000,
    };
};

/// A homogeneous medium M whose flights remember the path's recent flights (see the file
/// comment). Holds pointers: the medium and the memory must outlive it. With a null, empty or
/// spent memory every call is M's own.
template <class M, class Region = AnyCentre>
    requires requires(const M& m) {
        m.sigma_t();
        m.albedo();
        m.phase();
    }
class FlightMemoryMedium {
   public:
    using Float = typename M::Float;        ///< floating-point type of the medium
    using Spectrum = typename M::Spectrum;  ///< spectrum type of the medium

    /// `base`: the effective medium; `memory`: the path's memory (null: none); `region`: where
    /// grain centres lie (the aggregate's boundary: no centre outside it, so a flight near the
    /// boundary collides less; only while the memory is active).
    FlightMemoryMedium(const M& base, FlightMemory* memory, Region region = {}) noexcept
        : base_(&base), mem_(memory), region_(region) {}

    /// The base medium's phase function.
    [[nodiscard]] decltype(auto) phase() const noexcept { return base_->phase(); }
    /// The base medium's albedo per channel.
    [[nodiscard]] decltype(auto) albedo() const noexcept { return base_->albedo(); }
    /// The base medium's extinction per channel (the rate away from remembered flights).
    [[nodiscard]] decltype(auto) sigma_t() const noexcept { return base_->sigma_t(); }
    /// The base medium.
    [[nodiscard]] const M& base() const noexcept { return *base_; }

    /// Free flight along `ray` (unit direction) up to t_max; a scattering flight is remembered and
    /// uses up one of the memory's flights.
    [[nodiscard]] Interaction<Float, Spectrum> sample_interaction(const Ray<Float>& ray, Float t_max, Rng& rng) const noexcept {
        using F = Float;
        using S = Spectrum;
        if (!mem_ || !mem_->active()) return base_->sample_interaction(ray, t_max, rng);
        const S& sig = base_->sigma_t();
        const S& alb = base_->albedo();
        const double s_max = double(sig.max_value()), s_avg = double(sig.average());
        Interaction<F, S> it;
        if (!(s_max > 0)) {
            it.kind = EventKind::escape;
            it.t = t_max;
            it.p = ray(t_max);
            return it;
        }
        const Vec3d o(ray.o), w(ray.d);
        const Frame<double> fr(w);
        S weight(F(1));
        double t = 0;
        for (int nulls = 0;; ++nulls) {
            if (nulls > kMaxNulls) {  // safety net (no realistic flight comes near it): end the path
                it.kind = EventKind::absorb;
                it.t = F(t);
                it.p = ray(F(t));
                it.weight = S(F(0));
                return it;
            }
            t += sample_exponential(rng.uniform<double>(), s_max);
            if (!(t < double(t_max))) {
                it.kind = EventKind::escape;
                it.t = t_max;
                it.p = ray(t_max);
                it.weight = weight;
                return it;
            }
            const Vec3d q = o + t * w;
            if constexpr (Region::constrains) {
                if (!std::isfinite(double(t_max)) && !region_.inside(q)) {
                    // Left the region along a ray that meets no boundary (a point the scene puts
                    // inside the medium but the region does not, at rounding level): no grain
                    // lies ahead, so the flight escapes.
                    it.kind = EventKind::escape;
                    it.t = t_max;
                    it.p = ray(F(t));
                    it.weight = weight;
                    return it;
                }
            }
            // 0 unless q is within 2R of a remembered flight or (with a region) R of the boundary.
            const double rho = 1.0 - mem_->shadowed_fraction(q, fr.s, fr.t, region_);
            const double p_collide = rho * s_avg / s_max;
            if (rng.uniform<double>() < p_collide) {
                // Collision: weight sigma_s^k / (rho sigma_avg) * rho = albedo^k sigma_t^k / sigma_avg.
                S ws = weight;
                for (std::size_t c = 0; c < S::size; ++c) ws[c] *= F(double(alb[c]) * double(sig[c]) / s_avg);
                it.t = F(t);
                it.p = Vec3<F>(q);
                mem_->push(o, q);
                --mem_->flights_left;
                resolve_collision(it, ws, rng);
                return it;
            }
            // Null collision: weight (s_max - rho sigma^k) / (s_max - rho sigma_avg) per channel.
            const double den = s_max - rho * s_avg;
            for (std::size_t c = 0; c < S::size; ++c) weight[c] *= F((s_max - rho * double(sig[c])) / den);
        }
    }

    /// Transmittance along `ray` over distance t: exp(-sigma_t (t - integral of f)), with the
    /// factor exp(sigma_t * integral of f) estimated without bias from candidate points at rate
    /// max sigma_t on the stretches that pass within 2R of a remembered flight.
    [[nodiscard]] Spectrum transmittance(const Ray<Float>& ray, Float t, Rng& rng) const noexcept {
        using F = Float;
        using S = Spectrum;
        S tr = base_->transmittance(ray, t, rng);
        if (!mem_ || !mem_->active() || tr.is_black()) return tr;
        const S& sig = base_->sigma_t();
        const double lambda = double(sig.max_value());
        if (!(lambda > 0)) return tr;
        const Vec3d o(ray.o), w(ray.d);
        const double tmax = std::isfinite(double(t)) ? double(t) : 1e30;
        // Stretches of the ray within 2R of a remembered flight (elsewhere f = 0).
        std::array<std::array<double, 2>, FlightMemory::capacity> iv{};
        int n = 0;
        for (int j = 0; j < mem_->size(); ++j) {
            double t0 = 0, t1 = tmax;
            if (mem_->near_interval(o, w, j, t0, t1)) iv[std::size_t(n++)] = {t0, t1};
        }
        if (n == 0 && !Region::constrains) return tr;
        for (int i = 1; i < n; ++i)  // insertion sort by start (n <= capacity)
            for (int j = i; j > 0 && iv[std::size_t(j)][0] < iv[std::size_t(j - 1)][0]; --j) std::swap(iv[std::size_t(j)], iv[std::size_t(j - 1)]);
        int m = 0;  // merge overlapping stretches
        for (int i = 0; i < n; ++i) {
            if (m > 0 && iv[std::size_t(i)][0] <= iv[std::size_t(m - 1)][1])
                iv[std::size_t(m - 1)][1] = std::max(iv[std::size_t(m - 1)][1], iv[std::size_t(i)][1]);
            else
                iv[std::size_t(m++)] = iv[std::size_t(i)];
        }
        n = m;
        const Frame<double> fr(w);
        S factor(F(1));
        // One Poisson process of candidates at rate lambda along the segment; stretches where f
        // is 0 (away from every remembered flight and, with a region, more than R inside its
        // boundary) are skipped, which the process's lack of memory allows.
        double u = 0;
        int k = 0;  // the next tube stretch
        for (int steps = 0; steps < kMaxNulls; ++steps) {
            while (k < n && iv[std::size_t(k)][1] <= u) ++k;
            const bool in_tube = k < n && iv[std::size_t(k)][0] <= u;
            if (!in_tube) {
                const double next_tube = k < n ? iv[std::size_t(k)][0] : tmax;
                if constexpr (Region::constrains) {
                    const double skip = mem_->boundary_distance(o + u * w, 1.5 * mem_->radius, region_) - mem_->radius;
                    if (skip > 0.5 * mem_->radius) {
                        u = std::min(u + skip, next_tube);
                        if (u >= tmax) break;
                        continue;
                    }
                } else {
                    if (k >= n) break;
                    u = next_tube;
                    continue;
                }
            }
            u += sample_exponential(rng.uniform<double>(), lambda);
            if (!(u < tmax)) break;
            const Vec3d q = o + u * w;
            const double f = mem_->shadowed_fraction(q, fr.s, fr.t, region_);
            if (f <= 0) continue;
            for (std::size_t c = 0; c < S::size; ++c) factor[c] *= F(1.0 + double(sig[c]) * f / lambda);
        }
        return tr * factor;
    }

   private:
    static constexpr int kMaxNulls = 1 << 20;  ///< null collisions per flight at most
    const M* base_;
    FlightMemory* mem_;
    Region region_;
};

}  // namespace grainlight
