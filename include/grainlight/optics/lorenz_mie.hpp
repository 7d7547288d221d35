/// @file grainlight/optics/lorenz_mie.hpp
/// Exact Lorenz-Mie scattering by a homogeneous sphere: amplitude functions S1(theta), S2(theta)
/// and the efficiencies Qext, Qsca, Qabs, Qback and the asymmetry parameter g (Guo21 Sec. 3 and
/// its Appendix A; series as in Bohren & Huffman 1983 Ch. 4, numerics after Wiscombe 1979/1980).
///
/// **Sign convention (stated once for all of optics/).** The relative refractive index is passed
/// as m = n + i k with k >= 0 for an absorbing particle (the way material tables list it). The
/// amplitudes S1, S2 are returned in the convention of van de Hulst and Wiscombe's MIEV0
/// (time dependence exp(+i omega t), in which the same absorbing index reads n - i k): Re S(0) =
/// x^2 Qext / 4 > 0 and, e.g., S(0) = 55.80662 - 9.758097 i for m = 0.75, x = 10. Guo21's GOA
/// phases (Eqs. 9-10) use the same convention, so Mie and GOA amplitudes can be compared and
/// summed directly. For Bohren & Huffman's convention (exp(-i omega t)) take complex conjugates.
///
/// Numerics: N = x + 4.05 x^(1/3) + 2 terms (Wiscombe); the logarithmic derivative D_n(m x) by
/// downward recurrence started at max(N, |m x|) + 16 from a Lentz continued fraction (never from
/// D = 0); psi_n(x) by upward recurrence while n <= x and by ratios from a downward recurrence
/// beyond (stable), chi_n(x) upward. Valid from x = 1e-3 (Rayleigh) to x = 1e5.
///
/// The series is computed once per (m, x); `amplitudes` then evaluates any number of angles.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <span>
#include <vector>

#include "grainlight/core/error.hpp"

namespace grainlight {

/// Efficiencies of one sphere (dimensionless: cross section / (pi r^2)); g is the mean cosine.
struct MieEfficiencies {
    double qext = 0;   ///< extinction efficiency
    double qsca = 0;   ///< scattering efficiency
    double qabs = 0;   ///< absorption efficiency, qext - qsca (>= 0 up to round-off)
    double qback = 0;  ///< backscattering efficiency 4 |S1(180 deg)|^2 / x^2
    double g = 0;      ///< asymmetry parameter <cos theta> (0 when qsca = 0)
};

/// The two complex scattering amplitudes at one angle (van de Hulst convention, see file doc).
struct ScatteringAmplitudes {
    std::complex<double> S1;  ///< perpendicular polarization
    std::complex<double> S2;  ///< parallel polarization
};

namespace detail {

/// Lentz evaluation of r_n(z) = psi_{n-1}(z) / psi_n(z) = (2n+1)/z - 1/((2n+3)/z - 1/(...)),
/// the continued fraction of the Riccati-Bessel ratio (so D_n(z) = r_n(z) - n/z).
inline std::complex<double> riccati_ratio_cf(std::size_t n, std::complex<double> z) noexcept {
    using C = std::complex<double>;
    const double tiny = 1e-300;
    const C inv_z = 1.0 / z;
    C f = double(2 * n + 1) * inv_z;
    if (std::abs(f) < tiny) f = tiny;
    C c = f, d = 0.0;
    for (std::size_t j = 1; j < 10000000; ++j) {
        const C b = double(2 * (n + j) + 1) * inv_z;
        d = b - d;
        if (std::abs(d) < tiny) d = tiny;
        c = b - 1.0 / c;
        if (std::abs(c) < tiny) c = tiny;
        d = 1.0 / d;
        const C delta = c * d;
        f *= delta;
        if (std::abs(delta - 1.0) < 1e-16) break;
    }
    return f;
}

}  // namespace detail

/// Wiscombe's number of series terms for far-field quantities: x + 4.05 x^(1/3) + 2.
[[nodiscard]] inline std::size_t mie_num_terms(double x) noexcept {
    return std::size_t(x + 4.05 * std::cbrt(x) + 2.0);
}

/// Lorenz-Mie solution for one sphere: the coefficients a_n, b_n of the series, computed once,
/// then efficiencies and amplitudes at any angle.
class LorenzMie {
public:
    /// m: particle index relative to the host, n + i k (n > 0, k >= 0 absorbing; m < 1 allowed,
    /// e.g. bubbles). x = 2 pi n_host r / lambda_vacuum: size parameter, 0 < x <= 1e6.
    /// Throws grainlight::invalid_argument otherwise.
    LorenzMie(std::complex<double> m, double x) : m_(m), x_(x) {
        check_argument(std::isfinite(x) && x > 0 && x <= 1e6, "LorenzMie", "x", x, "0 < x <= 1e6 (finite)");
        check_argument(std::isfinite(m.real()) && m.real() > 0, "LorenzMie", "Re(m)", m.real(), "> 0 (finite)");
        check_argument(std::isfinite(m.imag()) && m.imag() >= 0, "LorenzMie", "Im(m)", m.imag(),
                       ">= 0 (finite; k >= 0 absorbs)");
        compute_coefficients();
    }

    [[nodiscard]] std::complex<double> m() const noexcept { return m_; }
    [[nodiscard]] double x() const noexcept { return x_; }
    /// Number of series terms N.
    [[nodiscard]] std::size_t num_terms() const noexcept { return an_.size(); }
    /// a_n, b_n for n = 1..N (index n-1), van de Hulst convention.
    [[nodiscard]] std::span<const std::complex<double>> a() const noexcept { return an_; }
    [[nodiscard]] std::span<const std::complex<double>> b() const noexcept { return bn_; }

    /// Qext, Qsca, Qabs, Qback and g from the series (B&H Eqs. 4.61, 4.62, 4.74, 4.82).
    [[nodiscard]] MieEfficiencies efficiencies() const noexcept {
        const std::size_t N = an_.size();
        double ext = 0, sca = 0, asy1 = 0, asy2 = 0;
        std::complex<double> back = 0;
        for (std::size_t i = 0; i < N; ++i) {
            const double n = double(i + 1), w = 2 * n + 1;
            const auto a = an_[i], b = bn_[i];
            ext += w * (a.real() + b.real());
            sca += w * (std::norm(a) + std::norm(b));
            back += ((i + 1) % 2 ? -w : w) * (a - b);
            asy2 += w / (n * (n + 1)) * (a * std::conj(b)).real();
            if (i + 1 < N)
                asy1 += n * (n + 2) / (n + 1) *
                        (a * std::conj(an_[i + 1]) + b * std::conj(bn_[i + 1])).real();
        }
        const double s = 2 / (x_ * x_);
        MieEfficiencies q;
        q.qext = s * ext;
        q.qsca = s * sca;
        q.qabs = m_.imag() > 0 ? q.qext - q.qsca : 0.0;  // exactly 0 without absorption (no round-off sign)
        q.qback = std::norm(back) / (x_ * x_);
        q.g = sca > 0 ? 2 * (asy1 + asy2) / sca : 0.0;
        return q;
    }

    /// S1, S2 at scattering angle theta given by mu = cos(theta) in [-1, 1].
    [[nodiscard]] ScatteringAmplitudes amplitudes(double mu) const noexcept {
        std::complex<double> s1 = 0, s2 = 0;
        double pi0 = 0, pi1 = 1;  // pi_{n-1}, pi_n
        const std::size_t N = an_.size();
        for (std::size_t i = 0; i < N; ++i) {
            const double n = double(i + 1);
            const double tau = n * mu * pi1 - (n + 1) * pi0;
            s1 += an_w_[i] * pi1 + bn_w_[i] * tau;
            s2 += an_w_[i] * tau + bn_w_[i] * pi1;
            const double pi2 = ((2 * n + 1) * mu * pi1 - (n + 1) * pi0) / n;
            pi0 = pi1;
            pi1 = pi2;
        }
        return {s1, s2};
    }

    /// S at mu and at -mu (theta and pi - theta) in one pass over the series (pi_n(-mu) =
    /// (-1)^(n-1) pi_n(mu), tau_n(-mu) = (-1)^n tau_n(mu)).
    void amplitudes_pair(double mu, ScatteringAmplitudes& at_mu, ScatteringAmplitudes& at_minus_mu) const noexcept {
        std::complex<double> e1 = 0, e2 = 0, o1 = 0, o2 = 0;  // even / odd n parts
        double pi0 = 0, pi1 = 1;
        const std::size_t N = an_.size();
        for (std::size_t i = 0; i < N; ++i) {
            const double n = double(i + 1);
            const double tau = n * mu * pi1 - (n + 1) * pi0;
            const auto p1 = an_w_[i] * pi1, t1 = bn_w_[i] * tau;
            const auto p2 = bn_w_[i] * pi1, t2 = an_w_[i] * tau;
            if ((i + 1) % 2) {  // n odd: pi even-signed, tau odd-signed under mu -> -mu
                e1 += p1; o1 += t1; e2 += p2; o2 += t2;
            } else {
                o1 += p1; e1 += t1; o2 += p2; e2 += t2;
            }
            const double pi2 = ((2 * n + 1) * mu * pi1 - (n + 1) * pi0) / n;
            pi0 = pi1;
            pi1 = pi2;
        }
        at_mu = {e1 + o1, e2 + o2};
        at_minus_mu = {e1 - o1, e2 - o2};
    }

    /// S1, S2 at every mu in `cos_theta` (out.size() == cos_theta.size()); the series is reused.
    void amplitudes(std::span<const double> cos_theta, std::span<ScatteringAmplitudes> out) const noexcept {
        for (std::size_t k = 0; k < cos_theta.size() && k < out.size(); ++k) out[k] = amplitudes(cos_theta[k]);
    }

private:
    void compute_coefficients() {
        using C = std::complex<double>;
        const std::size_t N = std::max<std::size_t>(mie_num_terms(x_), 1);
        const double x = x_;
        // Internally Bohren-Huffman (exp(-i omega t)): m_bh = n + i k; conjugate at the end.
        const C m = m_;
        const C mx = m * x;
        // D_n(mx) by downward recurrence from a continued-fraction start.
        const std::size_t nstart = std::max<std::size_t>(N, std::size_t(std::abs(mx))) + 16;
        std::vector<C> D(N + 1);
        {
            C d = detail::riccati_ratio_cf(nstart, mx) - double(nstart) / mx;
            for (std::size_t n = nstart; n > N; --n) d = double(n) / mx - 1.0 / (d + double(n) / mx);
            D[N] = d;
            for (std::size_t n = N; n >= 1; --n) {
                const C dn = D[n];
                D[n - 1] = double(n) / mx - 1.0 / (dn + double(n) / mx);
            }
        }
        // Ratios r_n(x) = psi_{n-1}(x)/psi_n(x) for n > x, by downward recurrence (stable).
        const std::size_t nup = std::min<std::size_t>(N, std::size_t(x));  // psi upward for n <= nup
        std::vector<double> r(N + 2, 0.0);
        if (nup < N) {
            double rr = detail::riccati_ratio_cf(N + 1, C(x, 0)).real();
            r[N + 1] = rr;
            for (std::size_t n = N; n > nup; --n) {
                rr = double(2 * n + 1) / x - 1.0 / rr;
                r[n] = rr;
            }
        }
        an_.resize(N);
        bn_.resize(N);
        an_w_.resize(N);
        bn_w_.resize(N);
        // psi_{-1} = cos x, psi_0 = sin x; chi_{-1} = -sin x, chi_0 = cos x; xi_n = psi_n - i chi_n.
        double psi_prev = std::sin(x), chi_prev = std::cos(x);  // n - 1 = 0
        double psi_pp = std::cos(x), chi_pp = -std::sin(x);     // n - 2 = -1
        for (std::size_t n = 1; n <= N; ++n) {
            const double dn = double(n);
            double psi;
            if (n <= nup) {
                psi = double(2 * n - 1) / x * psi_prev - psi_pp;
            } else {
                psi = psi_prev / r[n];
            }
            const double chi = double(2 * n - 1) / x * chi_prev - chi_pp;
            const C xi(psi, -chi), xi_prev(psi_prev, -chi_prev);
            const C da = D[n] / m + dn / x;
            const C db = D[n] * m + dn / x;
            C a = (da * psi - psi_prev) / (da * xi - xi_prev);
            C b = (db * psi - psi_prev) / (db * xi - xi_prev);
            a = std::conj(a);  // to van de Hulst / Wiscombe convention
            b = std::conj(b);
            an_[n - 1] = a;
            bn_[n - 1] = b;
            const double w = (2 * dn + 1) / (dn * (dn + 1));
            an_w_[n - 1] = w * a;
            bn_w_[n - 1] = w * b;
            psi_pp = psi_prev;
            psi_prev = psi;
            chi_pp = chi_prev;
            chi_prev = chi;
        }
    }

    std::complex<double> m_;
    double x_;
    std::vector<std::complex<double>> an_, bn_, an_w_, bn_w_;
};

/// Efficiencies of a sphere (m = n + i k, k >= 0; x > 0); see LorenzMie.
[[nodiscard]] inline MieEfficiencies mie_efficiencies(std::complex<double> m, double x) {
    return LorenzMie(m, x).efficiencies();
}

}  // namespace grainlight
