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
///
/// Speed (issue 13; numbers and commands in docs/performance.md): the series is built with the
/// complex arithmetic written out (no library division) and a_n, b_n computed inside the serial
/// D_n chain, where they fill its latency; the angle kernel runs blocks of detail::kMieLanes
/// angles as structure of arrays with the accumulators in registers, no division in the
/// recurrence, and the span overload evaluates theta and pi - theta once (mu and -mu equal to
/// 4 eps). Portable: plain C++20, vectorized by the compiler (`#pragma omp simd` / GCC ivdep;
/// no include path, no link flag, no -march needed). All work is in double.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <span>
#include <vector>
#include <string>

#include "grainlight/core/error.hpp"

namespace grainlight {

/// Efficiencies of one sphere (dimensionless: cross section / (pi r^2)); g is the mean cosine.
struct MieEfficiencies {
    double qext = 0;   ///< extinction efficiency
    double qsca = 0;   ///< scattering efficiency
    double qabs = 0;   ///< absorption efficiency, qext - qsca (>= 0 up to round-off)
    double qback = 0;  ///< backscattering efficiency 4 |S1(180 deg)|^2 / x^2
    double g = 0;      ///< asymmetry parameter \<cos theta\> (0 when qsca = 0)
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

// The kernel's lane loop is vectorized as an outer loop (GCC; with OpenMP's simd directive when
// -fopenmp or -fopenmp-simd is on, else by the GCC ivdep hint and -O3). Clang does not vectorize
// outer loops (a forced request only warns): there it runs as two interleaved scalar lanes.
#if defined(__clang__)
#define GRAINLIGHT_MIE_SIMD
#elif defined(_OPENMP)
#define GRAINLIGHT_MIE_SIMD _Pragma("omp simd")
#elif defined(__GNUC__)
#define GRAINLIGHT_MIE_SIMD _Pragma("GCC ivdep")
#else
#define GRAINLIGHT_MIE_SIMD
#endif
#if defined(__GNUC__)
#define GRAINLIGHT_MIE_NOINLINE __attribute__((noinline))
#else
#define GRAINLIGHT_MIE_NOINLINE
#endif

/// Angles per block of the amplitude kernel: two native vectors of doubles, so that two
/// independent pi_n recurrences hide the latency of one.
#if defined(__AVX512F__)
inline constexpr std::size_t kMieLanes = 16;
#elif defined(__AVX__)
inline constexpr std::size_t kMieLanes = 8;
#else
inline constexpr std::size_t kMieLanes = 4;
#endif

/// The series as the amplitude kernel reads it: for each pair of orders (n, n + 1), n odd, the
/// ten numbers Re, Im of w_n a_n, Re, Im of w_n b_n, (n+1)/n, then the same for n + 1 (one
/// sequential stream), w_n = (2n+1)/(n(n+1)); N even (the series is zero-padded).
struct MieSeriesView {
    const double* coef;
    std::size_t N;
};

/// Amplitudes at W angles (mu[0..W)) in one pass over n: the pi_n / tau_n recurrence per lane
/// without division (pi_{n+1} = t + (n+1)/n (t - pi_{n-1}), tau_n = n (t - pi_{n-1}) - pi_{n-1},
/// t = mu pi_n), two n per step, accumulators in registers. The sums are split by the parity of
/// their terms under mu -> -mu: out = [E1r E1i O1r O1i E2r E2i O2r O2i] x W, S_j(mu) = E_j + O_j,
/// S_j(-mu) = E_j - O_j. The lane loop is the vectorized one (outer-loop SIMD) and carries two
/// independent lanes per iteration (k and k + W/2), so that two recurrences hide each other's
/// latency. Requires s.N even (>= 2; the series is zero-padded). Never inlined: every caller runs
/// the same code, hence the same rounding.
template <std::size_t W>
GRAINLIGHT_MIE_NOINLINE inline void mie_amplitude_block(const MieSeriesView& s, const double* __restrict mu_in,
                                                        double* __restrict out) noexcept {
    static_assert(W % 2 == 0);
    constexpr std::size_t H = W / 2;
    const double* __restrict cf = s.coef;
    const std::size_t N = s.N;
    GRAINLIGHT_MIE_SIMD
    for (std::size_t k = 0; k < H; ++k) {
        const double mua = mu_in[k], mub = mu_in[k + H];
        double pa0 = 0, pa1 = 1, pb0 = 0, pb1 = 1;
        double e1ra = 0, e1ia = 0, o1ra = 0, o1ia = 0, e2ra = 0, e2ia = 0, o2ra = 0, o2ia = 0;
        double e1rb = 0, e1ib = 0, o1rb = 0, o1ib = 0, e2rb = 0, e2ib = 0, o2rb = 0, o2ib = 0;
        double nn = 1;
        std::size_t i = 0;
        do {  // (no loop guard: keeps the inner loop simple enough for outer-loop vectorization)
            // n = i + 1 odd: pi_n even under mu -> -mu, tau_n odd; n + 1 even: the reverse.
            const double* __restrict q = cf + 5 * i;
            const double ar = q[0], ai = q[1], br = q[2], bi = q[3], c = q[4];
            const double ar2 = q[5], ai2 = q[6], br2 = q[7], bi2 = q[8], cc = q[9];
            const double nn2 = nn + 1;
            {
                const double ta = mua * pa1, da = ta - pa0, tb = mub * pb1, db = tb - pb0;
                const double taua = nn * da - pa0, qa2 = ta + c * da;
                const double taub = nn * db - pb0, qb2 = tb + c * db;
                e1ra += ar * pa1; e1ia += ai * pa1; o1ra += br * taua; o1ia += bi * taua;
                e2ra += br * pa1; e2ia += bi * pa1; o2ra += ar * taua; o2ia += ai * taua;
                e1rb += ar * pb1; e1ib += ai * pb1; o1rb += br * taub; o1ib += bi * taub;
                e2rb += br * pb1; e2ib += bi * pb1; o2rb += ar * taub; o2ib += ai * taub;
                pa0 = pa1; pa1 = qa2;
                pb0 = pb1; pb1 = qb2;
            }
            {
                const double ta = mua * pa1, da = ta - pa0, tb = mub * pb1, db = tb - pb0;
                const double taua = nn2 * da - pa0, qa2 = ta + cc * da;
                const double taub = nn2 * db - pb0, qb2 = tb + cc * db;
                o1ra += ar2 * pa1; o1ia += ai2 * pa1; e1ra += br2 * taua; e1ia += bi2 * taua;
                o2ra += br2 * pa1; o2ia += bi2 * pa1; e2ra += ar2 * taua; e2ia += ai2 * taua;
                o1rb += ar2 * pb1; o1ib += ai2 * pb1; e1rb += br2 * taub; e1ib += bi2 * taub;
                o2rb += br2 * pb1; o2ib += bi2 * pb1; e2rb += ar2 * taub; e2ib += ai2 * taub;
                pa0 = pa1; pa1 = qa2;
                pb0 = pb1; pb1 = qb2;
            }
            nn += 2;
            i += 2;
        } while (i < N);
        out[0 * W + k] = e1ra; out[1 * W + k] = e1ia; out[2 * W + k] = o1ra; out[3 * W + k] = o1ia;
        out[4 * W + k] = e2ra; out[5 * W + k] = e2ia; out[6 * W + k] = o2ra; out[7 * W + k] = o2ia;
        out[0 * W + k + H] = e1rb; out[1 * W + k + H] = e1ib; out[2 * W + k + H] = o1rb; out[3 * W + k + H] = o1ib;
        out[4 * W + k + H] = e2rb; out[5 * W + k + H] = e2ib; out[6 * W + k + H] = o2rb; out[7 * W + k + H] = o2ib;
    }
}

/// S1, S2 of lane l from the parity parts (sign +1: at mu, -1: at -mu).
inline void mie_combine(const double* part, std::size_t W, std::size_t l, int sign, ScatteringAmplitudes& s) noexcept {
    const double sg = sign;
    s.S1 = {part[0 * W + l] + sg * part[2 * W + l], part[1 * W + l] + sg * part[3 * W + l]};
    s.S2 = {part[4 * W + l] + sg * part[6 * W + l], part[5 * W + l] + sg * part[7 * W + l]};
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

    /// Relative refractive index m = n + i k given at construction.
    [[nodiscard]] std::complex<double> m() const noexcept { return m_; }
    /// Size parameter x = 2 pi n_host r / lambda_vacuum.
    [[nodiscard]] double x() const noexcept { return x_; }
    /// Number of series terms N.
    [[nodiscard]] std::size_t num_terms() const noexcept { return ab_.size() / 2; }
    /// One-line description: m, x and the number of series terms.
    [[nodiscard]] std::string to_string() const {
        return "LorenzMie[m = " + grainlight::detail::to_display(m_.real()) + " + " + grainlight::detail::to_display(m_.imag()) + "i, x = " + grainlight::detail::to_display(x_) + ", " +
               std::to_string(num_terms()) + " terms]";
    }
    /// a_n, b_n for n = 1..N (index n-1), van de Hulst convention.
    [[nodiscard]] std::span<const std::complex<double>> a() const noexcept { return {ab_.data(), num_terms()}; }
    /// b_n for n = 1..N (index n-1), van de Hulst convention.
    [[nodiscard]] std::span<const std::complex<double>> b() const noexcept {
        return {ab_.data() + num_terms(), num_terms()};
    }

    /// Qext, Qsca, Qabs, Qback and g from the series (B&H Eqs. 4.61, 4.62, 4.74, 4.82).
    [[nodiscard]] MieEfficiencies efficiencies() const noexcept {
        const std::size_t N = num_terms();
        const auto av = a(), bv = b();
        double ext = 0, sca = 0, asy1 = 0, asy2 = 0;
        std::complex<double> back = 0;
        for (std::size_t i = 0; i < N; ++i) {
            const double n = double(i + 1), w = 2 * n + 1;
            const auto a = av[i], b = bv[i];
            ext += w * (a.real() + b.real());
            sca += w * (std::norm(a) + std::norm(b));
            back += ((i + 1) % 2 ? -w : w) * (a - b);
            asy2 += w / (n * (n + 1)) * (a * std::conj(b)).real();
            if (i + 1 < N)
                asy1 += n * (n + 2) / (n + 1) *
                        (a * std::conj(av[i + 1]) + b * std::conj(bv[i + 1])).real();
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

    /// S1, S2 at scattering angle theta given by mu = cos(theta) in [-1, 1]. Evaluated by the same
    /// kernel as the span overload (bit-identical to it for the same mu).
    [[nodiscard]] ScatteringAmplitudes amplitudes(double mu) const noexcept {
        alignas(64) double lanes[detail::kMieLanes];
        alignas(64) double part[8 * detail::kMieLanes];
        for (double& l : lanes) l = mu;
        detail::mie_amplitude_block<detail::kMieLanes>(view(), lanes, part);
        ScatteringAmplitudes s;
        detail::mie_combine(part, detail::kMieLanes, 0, +1, s);
        return s;
    }

    /// S at mu and at -mu (theta and pi - theta) in one pass over the series (pi_n(-mu) =
    /// (-1)^(n-1) pi_n(mu), tau_n(-mu) = (-1)^n tau_n(mu)); bit-identical to amplitudes(mu),
    /// amplitudes(-mu) (the recurrences commute exactly with the sign of mu).
    void amplitudes_pair(double mu, ScatteringAmplitudes& at_mu, ScatteringAmplitudes& at_minus_mu) const noexcept {
        alignas(64) double lanes[detail::kMieLanes];
        alignas(64) double part[8 * detail::kMieLanes];
        for (double& l : lanes) l = mu;
        detail::mie_amplitude_block<detail::kMieLanes>(view(), lanes, part);
        detail::mie_combine(part, detail::kMieLanes, 0, +1, at_mu);
        detail::mie_combine(part, detail::kMieLanes, 0, -1, at_minus_mu);
    }

    /// S1, S2 at every mu in `cos_theta` (out.size() == cos_theta.size()); the series is reused.
    /// Angles are evaluated in blocks of detail::kMieLanes (structure of arrays, accumulators in
    /// registers), and a pair mu, mu' with |mu + mu'| <= 4 eps (theta and pi - theta of a
    /// symmetric grid, symmetric only to round-off: cos(pi i / 179)) is evaluated once, at the
    /// larger of the two, mu' then reads as -mu (a change of at most 4 eps in mu).
    void amplitudes(std::span<const double> cos_theta, std::span<ScatteringAmplitudes> out) const noexcept {
        const std::size_t K = std::min(cos_theta.size(), out.size());
        if (K == 0) return;
        constexpr std::size_t W = detail::kMieLanes;
        // Pairing: sort by mu, match the smallest with the largest while they mirror each other.
        std::vector<std::size_t> order(K);
        for (std::size_t k = 0; k < K; ++k) order[k] = k;
        std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cos_theta[a] < cos_theta[b]; });
        std::vector<std::size_t> primary, mirror;  // mirror = K when unpaired
        primary.reserve(K);
        mirror.reserve(K);
        constexpr double tol = 4 * 2.220446049250313e-16;
        std::size_t lo = 0, hi = K;
        while (lo < hi) {
            const double a = cos_theta[order[lo]], b = cos_theta[order[hi - 1]];
            if (hi - lo >= 2 && std::abs(a + b) <= tol) {
                primary.push_back(order[hi - 1]);
                mirror.push_back(order[lo]);
                ++lo;
                --hi;
            } else if (a + b < 0) {  // the smallest has no partner
                primary.push_back(order[lo]);
                mirror.push_back(K);
                ++lo;
            } else {
                primary.push_back(order[hi - 1]);
                mirror.push_back(K);
                --hi;
            }
        }
        alignas(64) double lanes[W];
        alignas(64) double part[8 * W];
        const auto v = view();
        for (std::size_t b0 = 0; b0 < primary.size(); b0 += W) {
            const std::size_t nb = std::min(W, primary.size() - b0);
            for (std::size_t l = 0; l < W; ++l) lanes[l] = cos_theta[primary[b0 + std::min(l, nb - 1)]];
            detail::mie_amplitude_block<W>(v, lanes, part);
            for (std::size_t l = 0; l < nb; ++l) {
                detail::mie_combine(part, W, l, +1, out[primary[b0 + l]]);
                if (mirror[b0 + l] < K) detail::mie_combine(part, W, l, -1, out[mirror[b0 + l]]);
            }
        }
    }

private:
    [[nodiscard]] detail::MieSeriesView view() const noexcept {
        return {coef_.data(), num_terms() + num_terms() % 2};
    }

    void compute_coefficients() {
        using C = std::complex<double>;
        const std::size_t N = std::max<std::size_t>(mie_num_terms(x_), 1);
        const double x = x_;
        // Internally Bohren-Huffman (exp(-i omega t)): m_bh = n + i k; conjugate at the end.
        // Complex arithmetic is written out (std::complex division is a library call under GCC).
        const double mr = m_.real(), mi = m_.imag();
        const double mxr = mr * x, mxi = mi * x;
        const double mx2 = mxr * mxr + mxi * mxi;
        const double imxr = mxr / mx2, imxi = -mxi / mx2;  // 1 / (m x)
        const double m2 = mr * mr + mi * mi;
        const double imr = mr / m2, imi = -mi / m2;  // 1 / m
        const double ix = 1.0 / x;
        // psi_n(x): upward while n <= x, beyond by ratios r_n = psi_{n-1}/psi_n from a downward
        // recurrence started by a continued fraction (stable); chi_n(x) upward. psi_{-1} = cos x,
        // psi_0 = sin x; chi_{-1} = -sin x, chi_0 = cos x.
        const std::size_t nup = std::min<std::size_t>(N, std::size_t(x));
        // One allocation for the kernel stream (5 per order, N even) and, behind it, the scratch
        // psi_n, chi_n (few large allocations: no page faults when the series is rebuilt).
        const std::size_t ncoef = 5 * (N + N % 2);
        coef_.assign(ncoef + 2 * (N + 1), 0.0);
        double* const psi = coef_.data() + ncoef;
        double* const chi = psi + (N + 1);
        {
            const double s = std::sin(x), c = std::cos(x);
            psi[0] = s;
            chi[0] = c;
            double psi_pp = c, chi_pp = -s, psi_p = s, chi_p = c;  // (n-2), (n-1) in registers
            std::size_t n = 1;
            for (; n <= nup; ++n) {  // two independent chains in one loop: each hides the other's latency
                const double f = double(2 * n - 1) * ix;
                const double ch = f * chi_p - chi_pp, ps = f * psi_p - psi_pp;
                chi[n] = ch;
                psi[n] = ps;
                chi_pp = chi_p;
                chi_p = ch;
                psi_pp = psi_p;
                psi_p = ps;
            }
            for (; n <= N; ++n) {
                const double f = double(2 * n - 1) * ix;
                const double ch = f * chi_p - chi_pp;
                chi[n] = ch;
                chi_pp = chi_p;
                chi_p = ch;
            }
            if (nup < N) {
                std::vector<double> r(N - nup + 1);  // r[n - nup - 1] = r_n, n = nup+1 .. N+1
                double rr = detail::riccati_ratio_cf(N + 1, C(x, 0)).real();
                r[N - nup] = rr;
                for (std::size_t n = N; n > nup; --n) r[n - nup - 1] = rr = double(2 * n + 1) * ix - 1.0 / rr;
                for (std::size_t n = nup + 1; n <= N; ++n) psi[n] = psi[n - 1] / r[n - nup - 1];
            }
        }
        ab_.resize(2 * N);
        double* const ab_a = reinterpret_cast<double*>(ab_.data());
        double* const ab_b = ab_a + 2 * N;
        // D_n(mx) by downward recurrence from a continued-fraction start at nstart, carried as
        // z_n = D_n + n/(mx): z_{n-1} = (2n-1)/(mx) - 1/z_n (one complex reciprocal on the serial
        // chain). a_n, b_n are computed as soon as D_n is known: independent work that fills the
        // latency of the chain.
        const std::size_t nstart = std::max<std::size_t>(N, std::size_t(std::sqrt(mx2))) + 16;
        const C d0 = detail::riccati_ratio_cf(nstart, C(mxr, mxi)) - double(nstart) / C(mxr, mxi);
        double zr = d0.real() + double(nstart) * imxr, zi = d0.imag() + double(nstart) * imxi;
        // a_n, b_n from D_n (the part off the serial chain; n runs downward, so 1/(n+1) is the
        // previous call's 1/n: one division for w_n = 1/n + 1/(n+1) and (n+1)/n = 1 + 1/n).
        double inv_up = 1.0 / double(N + 1);
        auto emit = [&](std::size_t n, double Dnr, double Dni) {
            const double dn = double(n);
            const double ps = psi[n], ps1 = psi[n - 1];
            const double xr = ps, xi = -chi[n], x1r = ps1, x1i = -chi[n - 1];  // xi_n = psi_n - i chi_n
            const double nx = dn * ix;
            // da = D/m + n/x, db = D m + n/x
            const double dar = Dnr * imr - Dni * imi + nx, dai = Dnr * imi + Dni * imr;
            const double dbr = Dnr * mr - Dni * mi + nx, dbi = Dnr * mi + Dni * mr;
            // a = (da psi_n - psi_{n-1}) / (da xi_n - xi_{n-1}), b likewise with db.
            const double nar = dar * ps - ps1, nai = dai * ps;
            const double Dar = dar * xr - dai * xi - x1r, Dai = dar * xi + dai * xr - x1i;
            const double nbr = dbr * ps - ps1, nbi = dbi * ps;
            const double Dbr = dbr * xr - dbi * xi - x1r, Dbi = dbr * xi + dbi * xr - x1i;
            const double ia = 1.0 / (Dar * Dar + Dai * Dai), ib = 1.0 / (Dbr * Dbr + Dbi * Dbi);
            // conj(num / den) = conj(num) den / |den|^2 (van de Hulst / Wiscombe convention)
            const double are = (nar * Dar + nai * Dai) * ia, aim = (nar * Dai - nai * Dar) * ia;
            const double bre = (nbr * Dbr + nbi * Dbi) * ib, bim = (nbr * Dbi - nbi * Dbr) * ib;
            ab_a[2 * (n - 1)] = are;
            ab_a[2 * (n - 1) + 1] = aim;
            ab_b[2 * (n - 1)] = bre;
            ab_b[2 * (n - 1) + 1] = bim;
            const double inv_n = 1.0 / dn;
            const double w = inv_n + inv_up;  // (2n+1)/(n(n+1))
            inv_up = inv_n;
            double* q = coef_.data() + 5 * (n - 1);
            q[0] = w * are;
            q[1] = w * aim;
            q[2] = w * bre;
            q[3] = w * bim;
            q[4] = 1.0 + inv_n;  // (n+1)/n
        };
        if (mi == 0 && zi == 0) {
            // Real m x (no absorption): D_n is real and the chain is one real division per order.
            for (std::size_t n = nstart; n >= 1; --n) {
                if (n <= N) emit(n, zr - double(n) * imxr, 0.0);
                zr = double(2 * n - 1) * imxr - 1.0 / zr;
            }
        } else {
            for (std::size_t n = nstart; n >= 1; --n) {
                if (n <= N) emit(n, zr - double(n) * imxr, zi - double(n) * imxi);
                // 1/z = conj(z)/|z|^2: two divisions in parallel keep the chain short.
                const double z2 = zr * zr + zi * zi;
                const double s = double(2 * n - 1);
                const double wr = zr / z2, wi = zi / z2;
                zr = s * imxr - wr;
                zi = s * imxi + wi;
            }
        }
    }

    std::complex<double> m_;
    double x_;
    std::vector<std::complex<double>> ab_;  // a_1..a_N, then b_1..b_N
    std::vector<double> coef_;  // the kernel's stream (detail::MieSeriesView)
};

/// Efficiencies of a sphere (m = n + i k, k >= 0; x > 0); see LorenzMie.
[[nodiscard]] inline MieEfficiencies mie_efficiencies(std::complex<double> m, double x) {
    return LorenzMie(m, x).efficiencies();
}

}  // namespace grainlight
