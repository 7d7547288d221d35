/// @file grainlight/optics/goa.hpp
/// Geometrical optics approximation (GOA) of scattering by a large sphere (Guo21 Sec. 3.1,
/// Eqs. 4-14; after Glantschnig & Chen 1981, Ungut et al. 1981, van de Hulst 1957 Ch. 12, and
/// for absorbing spheres Yu, Shen & Wei 2009).
///
/// S_j(theta) = sum_{p=0}^{p_max} sum_{rays} S_j^(p) + S_D,j (diffraction only for theta < 90 deg),
///   S_D       = alpha^2 J1(alpha sin theta) / (alpha sin theta)                              (Eq. 4)
///   S_j^(p)   = alpha eps_j sqrt(sin 2 theta_i / (2 sin theta |d theta_p / d theta_i|)) e^{i phi} (Eq. 7)
///   theta_p   = 2 p theta_t - 2 theta_i - (p - 1) pi,  theta = q (theta_p - 2 pi l)             (Eqs. 5-6)
///   eps_j     = r_j (p = 0),  (1 - r_j^2)(-r_j)^(p-1) (p > 0), r_j Fresnel AMPLITUDE coeffs     (Eq. 8)
///   phi       = 2 alpha (cos theta_i - p eta cos theta_t) + pi/2 (1 + p - 2 l - s/2 - q/2)     (Eqs. 9-10)
/// with s = sgn(d theta_p / d theta_i). Conventions are those of optics/lorenz_mie.hpp (index
/// n + i k, k >= 0 absorbs; amplitudes in van de Hulst's exp(+i omega t) convention, which Eqs.
/// 9-10 are written in), so GOA and Mie amplitudes compare directly. r_1 (perpendicular) =
/// (cos i - m cos t)/(cos i + m cos t), r_2 (parallel) = (m cos i - cos t)/(m cos i + cos t), so
/// S2(180) = -S1(180) and S1(0) = S2(0) as in Mie theory.
///
/// Every ray of each order is found: [0, theta_i,max] is split at the rainbow incidence
/// cos^2 theta_i = (eta^2 - 1)/(p^2 - 1) into monotonic pieces, and every branch (q, l) whose
/// target q theta + 2 pi l lies in a piece's range gets one root (safeguarded Newton; p = 0 and
/// p = 1 in closed form). Two rays near each rainbow are thus both kept. At theta = 0 and pi only
/// the axial rays contribute, by their limit sin 2 theta_i / (2 sin theta |theta_p'|) ->
/// 1 / theta_p'(0)^2 with phi_f = pi/2 (2p - s); non-axial rays that exit exactly at 0 or pi
/// (glories) make GOA diverge there and are skipped.
///
/// Absorbing spheres (eta = n + i k, Guo21 Appendix C after Yu, Shen & Wei 2009, to first order
/// in k/n): ray directions follow the real part n; Fresnel coefficients use the complex index;
/// each of the p chords (length 2 r cos theta_t) attenuates the amplitude by exp(-2 alpha k
/// cos theta_t), i.e. the complex index enters the path phase of Eq. 9. Absorption cross
/// section: the ray-optics integral over impact parameters (`Goa::qabs`), whose weak-absorption
/// limit is Guo21 Eq. 13 (`goa_absorption_cross_section_eq13`).
///
/// Bubbles (n < 1): total internal reflection makes r_j complex (|r_j| = 1) beyond the critical
/// angle; transmitted orders exist only below it.
///
/// GOA lacks the edge (surface-wave) term of extinction (Qext ~ 2 + c x^(-2/3)): its forward
/// amplitude is ~1 % low at x ~ 1000 and a few % low at x ~ 20.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <span>
#include <sstream>
#include <vector>
#include <string>

#include <boost/math/special_functions/bessel.hpp>

#include "grainlight/core/error.hpp"
#include "grainlight/core/quadrature.hpp"
#include "grainlight/optics/lorenz_mie.hpp"

namespace grainlight {

namespace detail {

/// sin x and cos x for the ray phases (|x| up to ~1e6 rad at alpha ~ 1e5): Cody-Waite reduction
/// by pi/2 split in 33-bit parts (k P1 and k P2 exact for |k| < 2^20), Taylor polynomials to
/// degree 17 / 18 on [-pi/4, pi/4] (truncation < 1e-19); absolute error a few 1e-16, inline and
/// branch-light (glibc's sincos call was 60 % of the cached-ray evaluation). Larger |x|: std.
inline void goa_sincos(double x, double& s, double& c) noexcept {
    if (!(std::abs(x) < 8e5)) {
        s = std::sin(x);
        c = std::cos(x);
        return;
    }
    constexpr double two_over_pi = 0.63661977236758134308;
    constexpr double P1 = 1.57079632673412561417e+00;  // pi/2, first 33 bits
    constexpr double P2 = 6.07710050630396597660e-11;  // next 33 bits
    constexpr double P3 = 2.02226624879595063154e-21;  // remainder
    constexpr double round_magic = 6755399441055744.0;  // 1.5 * 2^52: round to nearest
    const double k = (x * two_over_pi + round_magic) - round_magic;
    const double r = ((x - k * P1) - k * P2) - k * P3;
    const double z = r * r;
    const double sp = -1.0 / 6 + z * (1.0 / 120 + z * (-1.0 / 5040 + z * (1.0 / 362880 + z * (-1.0 / 39916800 +
                      z * (1.0 / 6227020800 + z * (-1.0 / 1307674368000 + z * (1.0 / 355687428096000)))))));
    const double cp = 1.0 / 24 + z * (-1.0 / 720 + z * (1.0 / 40320 + z * (-1.0 / 3628800 + z * (1.0 / 479001600 +
                      z * (-1.0 / 87178291200 + z * (1.0 / 20922789888000 + z * (-1.0 / 6402373705728000)))))));
    const double sr = r + r * z * sp;
    const double cr = 1.0 - 0.5 * z + z * z * cp;
    const long long q = static_cast<long long>(k) & 3;
    const double ss = (q & 1) ? cr : sr, cc = (q & 1) ? sr : cr;
    s = (q & 2) ? -ss : ss;
    c = ((q + 1) & 2) ? -cc : cc;
}

}  // namespace detail

/// One geometric ray of order p leaving the sphere at the requested scattering angle. Its
/// amplitude at size parameter alpha is
///   S_j = alpha * eps_j * geom * exp(-2 alpha atten) * exp(i (2 alpha path + phase_f)).
struct GoaRay {
    int p = 0;                  ///< number of chords (0: external reflection)
    double theta_i = 0;         ///< incidence angle [rad]
    double theta_t = 0;         ///< refraction angle [rad] (from the real index)
    std::complex<double> eps1;  ///< Eq. 8, perpendicular
    std::complex<double> eps2;  ///< Eq. 8, parallel
    double geom = 0;            ///< sqrt(sin 2 theta_i / (2 sin theta |d theta_p/d theta_i|)) (or its axial limit)
    double phase_f = 0;         ///< focal-line phase, Eq. 10 [rad]
    double path = 0;            ///< cos theta_i - p n cos theta_t (phi_p = 2 alpha path, Eq. 9)
    double atten = 0;           ///< p k cos theta_t (amplitude factor exp(-2 alpha atten))

    /// Amplitudes of this ray at size parameter alpha.
    [[nodiscard]] ScatteringAmplitudes amplitudes(double alpha) const noexcept {
        const double mag = alpha * geom * (atten > 0 ? std::exp(-2 * alpha * atten) : 1.0);
        double sn, cs;
        detail::goa_sincos(2 * alpha * path + phase_f, sn, cs);
        const double er = mag * cs, ei = mag * sn;  // complex products written out (no NaN-recovery call)
        return {{eps1.real() * er - eps1.imag() * ei, eps1.real() * ei + eps1.imag() * er},
                {eps2.real() * er - eps2.imag() * ei, eps2.real() * ei + eps2.imag() * er}};
    }
};

namespace detail {

inline constexpr double goa_pi = 3.14159265358979323846;

/// Fresnel amplitude coefficients (r_perp, r_par) for incidence cosine cos_i from outside onto
/// relative index m (m = n + i k, k >= 0), returned in van de Hulst's convention.
inline void fresnel_amplitudes(std::complex<double> m, double cos_i, std::complex<double>& r1,
                               std::complex<double>& r2) noexcept {
    using C = std::complex<double>;
    const double sin2 = std::max(0.0, 1 - cos_i * cos_i);
    C w = 1.0 - sin2 / (m * m);
    if (w.imag() == 0) w = C(w.real(), 0.0);  // principal branch: +i for total internal reflection
    const C cos_t = std::sqrt(w);             // Bohren-Huffman (exp(-i omega t)) side
    r1 = std::conj((cos_i - m * cos_t) / (cos_i + m * cos_t));
    r2 = std::conj((m * cos_i - cos_t) / (m * cos_i + cos_t));
}

/// Deflection theta_p(theta_i) (Eq. 5) and its derivative, real index n.
struct GoaDeflection {
    int p;
    double n;
    [[nodiscard]] double theta_t(double ti) const noexcept { return std::asin(std::min(1.0, std::sin(ti) / n)); }
    [[nodiscard]] double value(double ti) const noexcept {
        return 2 * p * theta_t(ti) - 2 * ti - (p - 1) * goa_pi;
    }
    /// value(ti), and its derivative in `deriv` (one sin/cos/asin/sqrt each).
    [[nodiscard]] double value_and_derivative(double ti, double& deriv) const noexcept {
        const double si = std::sin(ti), ci = std::cos(ti);
        const double st = std::min(1.0, si / n);
        const double ct = std::sqrt(std::max(0.0, 1 - st * st));
        deriv = ct <= 0 ? (p > 0 ? 1e300 : -2.0) : 2.0 * p * ci / (n * ct) - 2;
        return 2 * p * std::asin(st) - 2 * ti - (p - 1) * goa_pi;
    }
    [[nodiscard]] double derivative(double ti) const noexcept {
        const double ct = std::sqrt(std::max(0.0, 1 - std::sin(ti) * std::sin(ti) / (n * n)));
        if (ct <= 0) return p > 0 ? 1e300 : -2.0;
        return 2.0 * p * std::cos(ti) / (n * ct) - 2;
    }
};

}  // namespace detail

/// Finds the rays of orders p = 0..p_max leaving a sphere of relative index m (n + i k, k >= 0)
/// at a given scattering angle. Rays do not depend on the size parameter (only their amplitudes
/// do, see GoaRay::amplitudes). Construction tabulates each order's deflection function on its
/// monotonic pieces once (allocation), so that `rays` needs only a table look-up and one or two
/// Newton steps per root (no allocation).
class GoaRaySolver {
public:
    /// Solver for relative index m (Re m > 0, != 1; Im m >= 0) and orders p = 0..p_max (0..1000);
    /// throws grainlight::invalid_argument otherwise. Tabulation allocates; rays() then does not.
    GoaRaySolver(std::complex<double> m, int p_max) : m_(m), p_max_(p_max) {
        check_argument(std::isfinite(m.real()) && m.real() > 0 && m.real() != 1.0, "GoaRaySolver", "Re(m)",
                       m.real(), "> 0, != 1 (finite)");
        check_argument(std::isfinite(m.imag()) && m.imag() >= 0, "GoaRaySolver", "Im(m)", m.imag(), ">= 0 (finite)");
        check_argument(p_max >= 0 && p_max <= 1000, "GoaRaySolver", "p_max", p_max, "0..1000");
        using detail::goa_pi;
        const double n = m.real();
        theta_max_ = n >= 1 ? 0.5 * goa_pi : std::asin(n);
        for (int p = 2; p <= p_max; ++p) {
            const detail::GoaDeflection d{p, n};
            double cuts[3] = {0.0, theta_max_, theta_max_};
            int npieces = 1;
            if (n > 1) {
                const double c2 = (n * n - 1) / double(p * p - 1);
                if (c2 < 1) {
                    cuts[1] = std::acos(std::sqrt(c2));
                    npieces = 2;
                }
            }
            for (int k = 0; k < npieces; ++k) {
                Piece pc;
                pc.p = p;
                pc.first = nodes_.size();
                const double a = cuts[k], b = cuts[k + 1];
                for (int j = 0; j < kNodes; ++j) {
                    // Nodes cluster (quadratically) at the rainbow end where theta_p is flat.
                    double t = double(j) / (kNodes - 1);
                    const bool rainbow_at_b = (npieces == 2 && k == 0);
                    const bool rainbow_at_a = (npieces == 2 && k == 1);
                    if (rainbow_at_b) t = 1 - (1 - t) * (1 - t);
                    if (rainbow_at_a) t = t * t;
                    const double ti = j == kNodes - 1 ? b : a + (b - a) * t;
                    nodes_.push_back({ti, d.value(ti)});
                }
                pc.lo = std::min(nodes_[pc.first].v, nodes_.back().v);
                pc.hi = std::max(nodes_[pc.first].v, nodes_.back().v);
                pc.increasing = nodes_.back().v > nodes_[pc.first].v;
                pieces_.push_back(pc);
            }
        }
    }

    /// Relative refractive index m = n + i k of the sphere.
    [[nodiscard]] std::complex<double> m() const noexcept { return m_; }
    /// Highest ray order p traced (p = 0 reflection, 1 transmission, p >= 2 with p - 1 internal reflections).
    [[nodiscard]] int p_max() const noexcept { return p_max_; }

    /// Calls `f(const GoaRay&)` for every ray leaving at scattering angle theta in [0, pi] [rad].
    template <class Fn>
    void rays(double theta, Fn&& f) const {
        using detail::goa_pi;
        const double n = m_.real();
        const double sin_theta = std::sin(theta);
        const bool axial = theta <= 0 || theta >= goa_pi || sin_theta < 1e-12;
        if (axial) {
            // Axial ray theta_i = 0: theta_p(0) = -(p-1) pi, forward for odd p, backward for even p.
            for (int p = 0; p <= p_max_; ++p) {
                const bool forward = (p % 2) == 1;
                if (forward != (theta < 0.5 * goa_pi)) continue;
                const double dp = 2.0 * p / n - 2;
                if (std::abs(dp) < 1e-12) continue;  // n = p: axial focus at infinity
                const double s = dp > 0 ? 1.0 : -1.0;
                emit(p, 0.0, 1.0 / std::abs(dp), 0.5 * goa_pi * (2 * p - s), f);
            }
            return;
        }
        // p = 0, closed form: theta_i = (pi - theta)/2, q = 1, l = 0, s = -1, geometric factor 1/2.
        emit(0, 0.5 * (goa_pi - theta), 0.5, 0.5 * goa_pi, f);
        if (p_max_ >= 1) {
            // p = 1: theta_1 = 2 (theta_t - theta_i) is monotonic; closed form tan theta_i =
            // n sin h / (n cos h - 1) with h = -theta_1 / 2.
            const detail::GoaDeflection d{1, n};
            const double v_end = d.value(theta_max_);
            const double lo = std::min(0.0, v_end), hi = std::max(0.0, v_end);
            for (int q = 1; q >= -1; q -= 2) {
                const double target = q * theta;  // |theta_1| < pi: l = 0
                if (!(target > lo && target < hi)) continue;
                const double h = -0.5 * target;
                double ti = std::atan2(n * std::sin(h), n * std::cos(h) - 1);
                if (ti < 0) ti += goa_pi;
                ti = std::clamp(ti, 0.0, theta_max_);
                root(d, ti, theta, sin_theta, q, 0, f);
            }
        }
        for (const Piece& pc : pieces_) {
            const detail::GoaDeflection d{pc.p, n};
            for (int q = 1; q >= -1; q -= 2) {
                const double base = q * theta;
                const long l0 = long(std::ceil((pc.lo - base) / (2 * goa_pi)));
                const long l1 = long(std::floor((pc.hi - base) / (2 * goa_pi)));
                for (long l = l0; l <= l1; ++l) {
                    const double target = base + 2 * goa_pi * double(l);
                    // Bracket from the table, start at the linear interpolant, then safeguarded Newton.
                    std::size_t lo_i = pc.first, hi_i = pc.first + kNodes - 1;
                    while (hi_i - lo_i > 1) {
                        const std::size_t mid = (lo_i + hi_i) / 2;
                        if ((nodes_[mid].v < target) == pc.increasing) lo_i = mid; else hi_i = mid;
                    }
                    const Node& A = nodes_[lo_i];
                    const Node& B = nodes_[hi_i];
                    double ti = A.t;
                    if (B.v != A.v) ti = A.t + (B.t - A.t) * std::clamp((target - A.v) / (B.v - A.v), 0.0, 1.0);
                    ti = newton(d, target, ti, A.t, B.t, pc.increasing);
                    root(d, ti, theta, sin_theta, q, l, f);
                }
            }
        }
    }

private:
    static constexpr int kNodes = 128;
    struct Node {
        double t, v;
    };
    struct Piece {
        int p = 0;
        std::size_t first = 0;
        double lo = 0, hi = 0;
        bool increasing = true;
    };

    static double newton(const detail::GoaDeflection& d, double target, double t, double lo, double hi,
                         bool increasing) noexcept {
        for (int it = 0; it < 60; ++it) {
            double df;
            const double f = d.value_and_derivative(t, df) - target;
            if (f == 0) return t;
            if ((f > 0) == increasing) hi = t; else lo = t;
            double tn = t - f / df;
            if (!(tn >= lo && tn <= hi) || !std::isfinite(tn)) tn = 0.5 * (lo + hi);
            if (std::abs(tn - t) < 1e-13 || hi - lo < 1e-13) return tn;
            t = tn;
        }
        return t;
    }

    template <class Fn>
    void root(const detail::GoaDeflection& d, double ti, double theta, double sin_theta, int q, long l, Fn& f) const {
        if (ti <= 0 || ti >= theta_max_) return;  // axial rays exit only at 0 or pi; grazing rays carry nothing
        (void)theta;
        const double si = std::sin(ti), ci = std::cos(ti), n = m_.real();
        const double st = std::min(1.0, si / n), ct = std::sqrt(std::max(0.0, 1 - st * st));
        if (ct <= 0) return;
        const double dth = 2.0 * d.p * ci / (n * ct) - 2;
        if (!std::isfinite(dth) || dth == 0) return;
        const double s = dth > 0 ? 1.0 : -1.0;
        const double geom = std::sqrt(2 * si * ci / (2 * sin_theta * std::abs(dth)));
        const double phase_f = 0.5 * detail::goa_pi * (1 + d.p - 2 * double(l) - 0.5 * s - 0.5 * q);
        emit(d.p, ti, ci, st, ct, geom, phase_f, f);
    }

    template <class Fn>
    void emit(int p, double ti, double geom, double phase_f, Fn& f) const {
        const double ci = std::cos(ti), st = std::min(1.0, std::sin(ti) / m_.real());
        emit(p, ti, ci, st, std::sqrt(std::max(0.0, 1 - st * st)), geom, phase_f, f);
    }

    /// ci = cos theta_i, st = sin theta_t, ct = cos theta_t (real index).
    template <class Fn>
    void emit(int p, double ti, double ci, double st, double ct, double geom, double phase_f, Fn& f) const {
        GoaRay ray;
        ray.p = p;
        ray.theta_i = ti;
        const double n = m_.real();
        std::complex<double> r1, r2;
        if (m_.imag() == 0 && st < 1) {
            // Real index without total internal reflection: real Fresnel coefficients (m cos t = n ct).
            const double a = n * ct;
            r1 = (ci - a) / (ci + a);
            r2 = (n * ci - ct) / (n * ci + ct);
        } else {
            detail::fresnel_amplitudes(m_, ci, r1, r2);
        }
        if (p == 0) {
            ray.eps1 = r1;
            ray.eps2 = r2;
            ray.path = ci;
        } else {
            ray.theta_t = std::asin(st);
            std::complex<double> e1 = 1.0 - r1 * r1, e2 = 1.0 - r2 * r2;
            for (int j = 1; j < p; ++j) {
                e1 *= -r1;
                e2 *= -r2;
            }
            ray.eps1 = e1;
            ray.eps2 = e2;
            ray.path = ci - p * n * ct;
            ray.atten = p * m_.imag() * ct;
        }
        ray.geom = geom;
        ray.phase_f = phase_f;
        f(static_cast<const GoaRay&>(ray));
    }

    std::complex<double> m_;
    int p_max_;
    double theta_max_ = 0;
    std::vector<Node> nodes_;
    std::vector<Piece> pieces_;
};

/// Calls `f(const GoaRay&)` for every ray of orders p = 0..p_max that leaves a sphere of
/// relative index m at scattering angle theta in [0, pi] [rad] (builds a GoaRaySolver; reuse one
/// for many angles).
template <class Fn>
void goa_rays(std::complex<double> m, int p_max, double theta, Fn&& f) {
    GoaRaySolver(m, p_max).rays(theta, f);
}

namespace detail {
/// J1(z) for z >= 0: Hankel's asymptotic expansion (Abramowitz & Stegun 9.2.5, 9.2.9-9.2.10,
/// mu = 4) for z >= 40, where six terms of P and Q give < 1e-14 relative error; Boost.Math
/// (double-precision policy; its default promotes to long double, ~10x slower) below.
inline double bessel_j1(double z) {
    if (z >= 40) {
        const double y = 1 / (8 * z), y2 = y * y;
        // P = 1 - (3)(-5)/2! y^2 + (3)(-5)(-21)(-45)/4! y^4 - ..., Q = 3 y - (3)(-5)(-21)/3! y^3 + ...
        const double p = 1 + y2 * (-(-15.0) / 2 + y2 * ((3.0 * -5 * -21 * -45) / 24 +
                                                        y2 * (-(3.0 * -5 * -21 * -45 * -77 * -117) / 720)));
        const double q = y * (3 + y2 * (-(3.0 * -5 * -21) / 6 + y2 * ((3.0 * -5 * -21 * -45 * -77) / 120 +
                                                                       y2 * (-(3.0 * -5 * -21 * -45 * -77 * -117 * -165) / 5040))));
        const double chi = z - 0.75 * goa_pi;
        return std::sqrt(2 / (goa_pi * z)) * (p * std::cos(chi) - q * std::sin(chi));
    }
    using policy = boost::math::policies::policy<boost::math::policies::promote_double<false>>;
    return boost::math::cyl_bessel_j(1, z, policy());
}
}  // namespace detail

/// Fraunhofer diffraction amplitude S_D(theta) = alpha^2 J1(alpha sin theta)/(alpha sin theta)
/// (Guo21 Eq. 4), equal for both polarizations and real; alpha^2/2 at theta = 0.
[[nodiscard]] inline double fraunhofer_amplitude(double alpha, double theta) {
    const double z = alpha * std::sin(theta);
    if (std::abs(z) < 1e-6) return alpha * alpha * (0.5 - z * z / 16);
    return alpha * alpha * detail::bessel_j1(z) / z;
}

/// GOA scattering by one sphere of relative index m (n + i k, k >= 0, n != 1) and size parameter
/// alpha = 2 pi n_host r / lambda: amplitudes (Eq. 11), extinction (Eq. 12), absorption and
/// scattering efficiencies.
class Goa {
public:
    /// p_max: highest order kept (Guo21 uses 3, the default). diffraction: add S_D for theta < 90 deg.
    Goa(std::complex<double> m, double alpha, int p_max = 3, bool diffraction = true)
        : m_(m), alpha_(alpha), p_max_(p_max), diffraction_(diffraction), solver_(m, p_max) {
        check_argument(std::isfinite(alpha) && alpha > 0, "Goa", "alpha", alpha, "> 0 (finite)");
        check_argument(std::isfinite(m.real()) && m.real() > 0 && m.real() != 1.0, "Goa", "Re(m)", m.real(),
                       "> 0, != 1 (finite)");
        check_argument(std::isfinite(m.imag()) && m.imag() >= 0, "Goa", "Im(m)", m.imag(), ">= 0 (finite)");
        check_argument(p_max >= 0 && p_max <= 1000, "Goa", "p_max", p_max, "0..1000");
    }

    /// Relative refractive index m = n + i k of the sphere.
    [[nodiscard]] std::complex<double> m() const noexcept { return m_; }
    /// Size parameter alpha = 2 pi r / lambda (in the host).
    [[nodiscard]] double alpha() const noexcept { return alpha_; }
    /// Highest ray order p included.
    [[nodiscard]] int p_max() const noexcept { return p_max_; }
    /// One-line description: m, alpha, orders and diffraction.
    [[nodiscard]] std::string to_string() const {
        return "Goa[m = " + grainlight::detail::to_display(m_.real()) + " + " + grainlight::detail::to_display(m_.imag()) + "i, alpha = " + grainlight::detail::to_display(alpha_) + ", orders 0.." +
               std::to_string(p_max_) + (diffraction_ ? ", with diffraction]" : ", no diffraction]");
    }

    /// S1, S2 at scattering angle theta [rad] in [0, pi] (Eq. 11).
    [[nodiscard]] ScatteringAmplitudes amplitudes_at_angle(double theta) const {
        ScatteringAmplitudes s{0.0, 0.0};
        solver_.rays(theta, [&](const GoaRay& ray) {
            const auto a = ray.amplitudes(alpha_);
            s.S1 += a.S1;
            s.S2 += a.S2;
        });
        if (diffraction_ && theta < 0.5 * detail::goa_pi) {
            const double sd = fraunhofer_amplitude(alpha_, theta);
            s.S1 += sd;
            s.S2 += sd;
        }
        return s;
    }
    /// S1, S2 at mu = cos(theta) (same as amplitudes_at_angle(acos(mu))).
    [[nodiscard]] ScatteringAmplitudes amplitudes(double mu) const {
        return amplitudes_at_angle(std::acos(std::clamp(mu, -1.0, 1.0)));
    }
    /// Only the order-p rays at theta (no diffraction).
    [[nodiscard]] ScatteringAmplitudes order_amplitudes(int p, double theta) const {
        ScatteringAmplitudes s{0.0, 0.0};
        solver_.rays(theta, [&](const GoaRay& ray) {
            if (ray.p != p) return;
            const auto a = ray.amplitudes(alpha_);
            s.S1 += a.S1;
            s.S2 += a.S2;
        });
        return s;
    }

    /// Extinction efficiency from the forward amplitude, Qext = 4 Re S(0) / alpha^2 (Eq. 3):
    /// Eq. 12, 2 + (4/alpha) sum_{p odd} Re{eps(0) e^{i phi}} / (2 |p/eta - 1|), attenuated for k > 0.
    [[nodiscard]] double qext() const { return 4 * amplitudes_at_angle(0.0).S1.real() / (alpha_ * alpha_); }

    /// Absorption efficiency by ray optics: Qabs = 2 int_0^{pi/2} A(theta_i) sin theta_i cos theta_i
    /// d theta_i, A = (1 - R) (1 - e^-tau) / (1 - R e^-tau) polarization-averaged, tau = 4 alpha k
    /// cos theta_t. Its weak-absorption limit is Guo21 Eq. 13.
    [[nodiscard]] double qabs() const {
        const double n = m_.real(), k = m_.imag();
        if (k <= 0) return 0.0;
        // Gauss-Legendre in u = sin^2 theta_i (d(sin^2)/2 = sin cos dtheta), split at the critical angle.
        const double umax = n >= 1 ? 1.0 : n * n;
        double sum = 0;
        constexpr auto& xg = gauss_legendre_nodes<8>.x;
        constexpr auto& wg = gauss_legendre_nodes<8>.w;
        const int panels = 64;
        for (int pi = 0; pi < panels; ++pi) {
            const double u0 = umax * pi / panels, u1 = umax * (pi + 1) / panels;
            for (int g = 0; g < 8; ++g) {
                const double u = 0.5 * (u0 + u1) + 0.5 * (u1 - u0) * xg[g];
                const double ci = std::sqrt(1 - u);
                std::complex<double> r1, r2;
                detail::fresnel_amplitudes(m_, ci, r1, r2);
                const double ct = std::sqrt(std::max(0.0, 1 - u / (n * n)));
                const double att = std::exp(-4 * alpha_ * k * ct);
                double a = 0;
                for (double R : {std::norm(r1), std::norm(r2)}) a += 0.5 * (1 - R) * (1 - att) / (1 - R * att);
                sum += 0.5 * (u1 - u0) * wg[g] * a;
            }
        }
        return sum;
    }
    /// Scattering efficiency Qext - Qabs.
    [[nodiscard]] double qsca() const { return qext() - qabs(); }

private:
    std::complex<double> m_;
    double alpha_;
    int p_max_;
    bool diffraction_;
    GoaRaySolver solver_;
};

/// GOA rays cached for a fixed set of scattering angles. The rays (incidence angles, Fresnel
/// factors, focal phases) depend on the index and the angle only, so a table built once serves
/// every radius: evaluating a new size parameter costs one complex exponential per ray plus the
/// diffraction term per angle (the bulk integration over a PSD, optics/bulk.hpp, relies on it).
class GoaTable {
public:
    /// theta: angles in [0, pi] [rad] (any order).
    GoaTable(std::complex<double> m, int p_max, std::span<const double> theta)
        : theta_(theta.begin(), theta.end()) {
        const GoaRaySolver solver(m, p_max);
        offsets_.reserve(theta_.size() + 1);
        offsets_.push_back(0);
        for (double t : theta_) {
            check_argument(t >= 0 && t <= detail::goa_pi, "GoaTable", "theta", t, "[0, pi]");
            solver.rays(t, [&](const GoaRay& r) { rays_.push_back(r); });
            offsets_.push_back(rays_.size());
        }
    }
    /// Number of tabulated angles.
    [[nodiscard]] std::size_t size() const noexcept { return theta_.size(); }
    /// Tabulated scattering angles [rad], in [0, pi].
    [[nodiscard]] std::span<const double> theta() const noexcept { return theta_; }
    /// Rays at angle index i.
    [[nodiscard]] std::span<const GoaRay> rays(std::size_t i) const noexcept {
        return std::span<const GoaRay>(rays_).subspan(offsets_[i], offsets_[i + 1] - offsets_[i]);
    }
    /// S1, S2 at angle index i for size parameter alpha (Eq. 11).
    [[nodiscard]] ScatteringAmplitudes amplitudes(double alpha, std::size_t i, bool diffraction = true) const {
        ScatteringAmplitudes s{0.0, 0.0};
        for (const GoaRay& r : rays(i)) {
            const auto a = r.amplitudes(alpha);
            s.S1 += a.S1;
            s.S2 += a.S2;
        }
        if (diffraction && theta_[i] < 0.5 * detail::goa_pi) {
            const double sd = fraunhofer_amplitude(alpha, theta_[i]);
            s.S1 += sd;
            s.S2 += sd;
        }
        return s;
    }
    /// |S1|^2 + |S2|^2 at every angle, into out (out.size() >= size()).
    void intensities(double alpha, std::span<double> out, bool diffraction = true) const {
        for (std::size_t i = 0; i < theta_.size(); ++i) {
            const auto s = amplitudes(alpha, i, diffraction);
            out[i] = std::norm(s.S1) + std::norm(s.S2);
        }
    }

private:
    std::vector<double> theta_;
    std::vector<GoaRay> rays_;
    std::vector<std::size_t> offsets_;
};

/// Angular moments of the GOA intensity, I_k = int_{-1}^{1} (|S1|^2 + |S2|^2) mu^k dmu for k = 0, 1
/// (so the numerically integrated Qsca = I_0 / alpha^2 and g = I_1 / I_0). Quadrature in theta:
/// 4-point Gauss panels of width 0.25/alpha over the diffraction peak (theta < 20/alpha), then
/// panels of width max(1/alpha, pi/40000) (4 nodes per fringe period pi/alpha up to alpha ~ 1e4),
/// split at 90 deg and at the rainbow angles, next to which theta = s +- u^2 removes the
/// integrable 1/sqrt singularity.
struct GoaMoments {
    /// @var i0
    /// I_0 = int (|S1|^2 + |S2|^2) dmu over [-1, 1] (Qsca = I_0 / alpha^2).
    /// @var i1
    /// I_1 = int (|S1|^2 + |S2|^2) mu dmu over [-1, 1] (g = I_1 / I_0).
    double i0 = 0, i1 = 0;
};
/// Compute I_0 and I_1 of `goa` (diffraction included) by the quadrature described at GoaMoments.
[[nodiscard]] inline GoaMoments goa_intensity_moments(const Goa& goa) {
    const double a = goa.alpha(), pi = detail::goa_pi;
    constexpr auto& xg = gauss_legendre_nodes<4>.x;
    constexpr auto& wg = gauss_legendre_nodes<4>.w;
    GoaMoments m;
    auto panel = [&](double t0, double t1) {
        for (int g = 0; g < 4; ++g) {
            const double t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * xg[g];
            const auto s = goa.amplitudes_at_angle(t);
            const double w = 0.5 * (t1 - t0) * wg[g] * std::sin(t) * (std::norm(s.S1) + std::norm(s.S2));
            m.i0 += w;
            m.i1 += w * std::cos(t);
        }
    };
    const double peak = std::min(20.0 / a, 0.5 * pi);
    const int n_peak = std::max(1, int(std::ceil(peak / (0.25 / a))));
    for (int i = 0; i < n_peak; ++i) panel(peak * i / n_peak, peak * (i + 1) / n_peak);
    // Breakpoints: 90 deg (diffraction is cut there, Eq. 11) and the rainbow angles, where the
    // intensity has an integrable 1/sqrt singularity: next to them integrate in u with
    // theta = s +- u^2, which makes the integrand smooth.
    std::vector<double> cuts = {peak, 0.5 * pi, pi};
    std::vector<double> bows;
    const double n = goa.m().real();
    for (int p = 2; p <= goa.p_max() && n > 1; ++p) {
        const double c2 = (n * n - 1) / double(p * p - 1);
        if (c2 >= 1) continue;
        const double ti = std::acos(std::sqrt(c2));
        const double tp = 2 * p * std::asin(std::sin(ti) / n) - 2 * ti - (p - 1) * pi;
        const double th = std::abs(std::remainder(tp, 2 * pi));
        if (th > peak && th < pi) {
            cuts.push_back(th);
            bows.push_back(th);
        }
    }
    std::sort(cuts.begin(), cuts.end());
    auto is_bow = [&](double t) { return std::find(bows.begin(), bows.end(), t) != bows.end(); };
    const double h = std::max(1.0 / a, pi / 40000);
    auto uniform = [&](double lo, double hi) {
        const int k = std::max(1, int(std::ceil((hi - lo) / h)));
        for (int i = 0; i < k; ++i) panel(lo + (hi - lo) * i / k, lo + (hi - lo) * (i + 1) / k);
    };
    // Half-segment [s, s + sign L] next to a singular point s, in u = sqrt(|theta - s|).
    auto graded = [&](double s, double sign, double len) {
        const double umax = std::sqrt(len);
        const int k = std::max(4, int(std::ceil(2 * umax * umax / h)));
        for (int i = 0; i < k; ++i) {
            const double u0 = umax * i / k, u1 = umax * (i + 1) / k;
            for (int g = 0; g < 4; ++g) {
                const double u = 0.5 * (u0 + u1) + 0.5 * (u1 - u0) * xg[g];
                const double t = s + sign * u * u;
                const auto amp = goa.amplitudes_at_angle(t);
                const double w = 0.5 * (u1 - u0) * wg[g] * 2 * u * std::sin(t) * (std::norm(amp.S1) + std::norm(amp.S2));
                m.i0 += w;
                m.i1 += w * std::cos(t);
            }
        }
    };
    for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
        const double lo = cuts[c], hi = cuts[c + 1];
        if (hi <= lo) continue;
        const bool blo = is_bow(lo), bhi = is_bow(hi);
        if (!blo && !bhi) {
            uniform(lo, hi);
            continue;
        }
        const double mid = 0.5 * (lo + hi);
        if (blo) graded(lo, 1.0, mid - lo); else uniform(lo, mid);
        if (bhi) graded(hi, -1.0, hi - mid); else uniform(mid, hi);
    }
    return m;
}

/// GOA asymmetry parameter g = \<cos theta\> by quadrature of |S1|^2 + |S2|^2 (goa_intensity_moments).
[[nodiscard]] inline double goa_asymmetry_parameter(const Goa& goa) {
    const auto m = goa_intensity_moments(goa);
    return m.i0 > 0 ? m.i1 / m.i0 : 0.0;
}

/// Guo21 Eq. 14: GOA extinction cross section with p = 1 only, for radius r, real relative
/// index eta > 0, eta != 1, and host wavenumber k = 2 pi n_host / lambda_vacuum (units: r and
/// 1/k in the same length unit; result in that unit squared):
/// C_t = 2 pi r^2 + 4 r lambda eta^2 / ((eta+1)^2 |eta-1|) sin(2 k r (1 - eta)), lambda = 2 pi / k.
[[nodiscard]] inline double goa_extinction_cross_section_eq14(double r, double eta, double k) {
    const double lambda = 2 * detail::goa_pi / k;
    return 2 * detail::goa_pi * r * r +
           4 * r * lambda * eta * eta / ((eta + 1) * (eta + 1) * std::abs(eta - 1)) * std::sin(2 * k * r * (1 - eta));
}

/// Guo21 Eq. 13: weak-absorption GOA absorption cross section of a sphere of radius r, index
/// m = eta_r + i eta_i (eta_r >= 1), wavelength lambda in the host (same length unit as r):
/// C_a = 16 pi^2 r^3 eta_i / (3 lambda eta_r) [eta_r^3 - (eta_r^2 - 1)^(3/2)].
[[nodiscard]] inline double goa_absorption_cross_section_eq13(double r, std::complex<double> m, double lambda) {
    const double nr = m.real(), ni = m.imag();
    const double pi = detail::goa_pi;
    const double bracket = nr >= 1 ? nr * nr * nr - std::pow(nr * nr - 1, 1.5) : nr * nr * nr;
    return 16 * pi * pi * r * r * r * ni / (3 * lambda * nr) * bracket;
}

// ---- validity range ---------------------------------------------------------------------------
// GOA's extinction (Eq. 12) misses two things exact Mie theory has, which fixes where it can be
// trusted (docs/guo21.md, "GOA validity range"; measured in tests/optics/test_goa_validity.cpp):
//  1. For m -> 1 van de Hulst's anomalous-diffraction formula (1957, Sec. 11.22),
//       Q = 2 - 4 e^{-rho tan b} (cos b / rho) sin(rho - b) - 4 e^{-rho tan b} (cos b / rho)^2 cos(rho - 2b)
//           + 4 (cos b / rho)^2 cos 2b,   rho = 2 x (n - 1), tan b = k / (n - 1),
//     is exact, and GOA's p = 1 term reproduces only its first-order (1/rho) part; the missing
//     (cos b / rho)^2 = 1 / rho_c^2 terms with rho_c = 2 x |m - 1| (complex m) are up to 8 / rho_c^2, a
//     relative error up to 4 / rho_c^2 of Q ~ 2, and for rho_c < ~4 GOA even turns negative (Qext =
//     -2 at m = 1.0001). Hence rho_c = 2 x |m - 1| >= goa_valid_phase_shift (6: <= 11 %).
//  2. The edge (surface-wave) term of extinction, ~ x^(-2/3) relative, plus resonance ripple:
//     measured against Mie on n = 0.5-10, k = 0-10, x up to 6000 it stays below 15 % from
//     x >= 45 when k <= 2, and from x >= 100 for strongly absorbing, metal-like spheres (k > 2,
//     whose surface waves raise Mie's Qext by 15 % at x = 50).

/// Minimum phase shift rho_c = 2 x |m - 1| (complex m) for GOA to be valid.
inline constexpr double goa_valid_phase_shift = 6.0;

/// The size-parameter floor of GOA's validity for relative index m, from the edge term alone
/// (45 for Im m <= 2, 100 above).
[[nodiscard]] inline double goa_valid_edge_size_parameter(std::complex<double> m) noexcept {
    return m.imag() > 2 ? 100.0 : 45.0;
}

/// Smallest size parameter from which GOA is valid for relative index m: both criteria above
/// (infinite for m = 1).
[[nodiscard]] inline double goa_valid_min_size_parameter(std::complex<double> m) noexcept {
    const double dm = std::abs(m - 1.0);
    const double from_phase = dm > 0 ? goa_valid_phase_shift / (2 * dm) : INFINITY;
    return std::max(goa_valid_edge_size_parameter(m), from_phase);
}

/// Where a GOA result stands with respect to the validity criterion.
struct GoaValidity {
    bool valid = false;       ///< x >= min_size_parameter (both criteria hold)
    double size_parameter = 0;  ///< x
    double phase_shift = 0;     ///< rho_c = 2 x |m - 1|, complex m
    double min_size_parameter = 0;  ///< goa_valid_min_size_parameter(m)
};

/// Validity of GOA for relative index m and size parameter x (no GOA evaluation).
[[nodiscard]] inline GoaValidity goa_validity(std::complex<double> m, double x) noexcept {
    GoaValidity v;
    v.size_parameter = x;
    v.phase_shift = 2 * x * std::abs(m - 1.0);
    v.min_size_parameter = goa_valid_min_size_parameter(m);
    v.valid = x >= v.min_size_parameter && v.phase_shift >= goa_valid_phase_shift;
    return v;
}

/// GOA efficiencies with their validity flag.
struct GoaEfficiencies {
    double qext = 0;  ///< Eq. 12
    double qabs = 0;  ///< ray-optics absorption (Goa::qabs)
    double qsca = 0;  ///< qext - qabs
    /// Whether GOA is trustworthy at this (m, x) (see goa_validity).
    GoaValidity validity;
};

/// Qext, Qabs, Qsca of `goa` and whether GOA is valid there. Outside the validity range the
/// numbers are still returned (flagged valid = false: Guo21's Figs. 2-6 evaluate GOA there on
/// purpose); where they are not physical (Qext or Qsca negative, or not finite: nearly
/// index-matched spheres with rho_c < ~4) it throws grainlight::invalid_argument naming x and
/// rho_c. Goa::qext() itself stays the bare Eq. 12.
[[nodiscard]] inline GoaEfficiencies goa_efficiencies(const Goa& goa) {
    GoaEfficiencies e;
    e.validity = goa_validity(goa.m(), goa.alpha());
    e.qext = goa.qext();
    e.qabs = goa.qabs();
    e.qsca = e.qext - e.qabs;
    const double tiny = 1e-12 * std::max(1.0, std::abs(e.qext));
    if (!(std::isfinite(e.qext) && std::isfinite(e.qabs) && e.qext >= 0 && e.qsca >= -tiny)) {
        std::ostringstream range;
        range.precision(6);
        range << ">= 0 with Qsca >= 0 (Qsca = " << e.qsca << "): GOA is not valid at m = " << goa.m().real() << " + "
              << goa.m().imag() << " i, x = " << e.validity.size_parameter << ", rho = 2 x |m - 1| = "
              << e.validity.phase_shift << " (valid from x >= " << e.validity.min_size_parameter
              << " with rho >= " << goa_valid_phase_shift << "); use Lorenz-Mie";
        raise_invalid_argument("goa_efficiencies", "Qext", e.qext, range.str());
    }
    e.qsca = std::max(0.0, e.qsca);
    return e;
}

}  // namespace grainlight
