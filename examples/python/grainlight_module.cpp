// examples/python/grainlight_module.cpp: the `grainlight` Python module (pybind11 + numpy), a thin
// layer over the header-only optics and packing code, in the shape miepython users know.
//
// Index convention everywhere: m = n + i k with k >= 0 for an absorbing particle, as in the C++
// API (optics/lorenz_mie.hpp). miepython writes the same index as n - i k; a negative imaginary
// part is rejected with a ValueError that says so (pass m.conjugate() to convert).
#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "grainlight/optics/bulk.hpp"
#include "grainlight/optics/goa.hpp"
#include "grainlight/optics/lorenz_mie.hpp"
#include "grainlight/optics/psd.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/precompute/scatterometer.hpp"

namespace py = pybind11;
using cplx = std::complex<double>;
using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using CArray = py::array_t<cplx, py::array::c_style>;

namespace {

constexpr const char* convention_note =
    "The refractive index is m = n + i k with k >= 0 for an absorbing particle (the C++ API's and "
    "the material tables' convention; miepython writes the same index as n - i k, so pass "
    "m.conjugate() of a miepython index).";

// Rejects an index in the n - i k convention with a message naming the convention.
void check_index(const char* fn, cplx m) {
    if (std::isfinite(m.imag()) && m.imag() < 0) {
        std::ostringstream os;
        os << "grainlight." << fn << ": m = " << m.real() << (m.imag() < 0 ? " - " : " + ") << std::abs(m.imag())
           << "i has a negative imaginary part; grainlight uses m = n + i k with k >= 0 for absorbing particles "
              "(miepython writes n - i k: pass m.conjugate())";
        throw py::value_error(os.str());
    }
}

// True for numpy arrays, lists and tuples (array-valued arguments); false for scalars.
bool is_array_like(const py::handle& h) {
    return py::isinstance<py::array>(h) || py::isinstance<py::list>(h) || py::isinstance<py::tuple>(h);
}

std::vector<py::ssize_t> shape_of(const py::array& a) { return {a.shape(), a.shape() + a.ndim()}; }

py::tuple mie_efficiencies(cplx m, py::object x) {
    check_index("mie", m);
    if (!is_array_like(x)) {
        const auto q = grainlight::LorenzMie(m, x.cast<double>()).efficiencies();
        return py::make_tuple(q.qext, q.qsca, q.qback, q.g);
    }
    Array xs = x.cast<Array>();
    const auto shape = shape_of(xs);
    Array qext(shape), qsca(shape), qback(shape), g(shape);
    const double* in = xs.data();
    double *e = qext.mutable_data(), *s = qsca.mutable_data(), *b = qback.mutable_data(), *gg = g.mutable_data();
    for (py::ssize_t i = 0; i < xs.size(); ++i) {
        const auto q = grainlight::LorenzMie(m, in[i]).efficiencies();
        e[i] = q.qext, s[i] = q.qsca, b[i] = q.qback, gg[i] = q.g;
    }
    return py::make_tuple(qext, qsca, qback, g);
}

// S1, S2 over mu for any solver with amplitudes(mu).
template <class Solver>
py::tuple amplitudes_over_mu(const Solver& solver, py::object mu) {
    if (!is_array_like(mu)) {
        const auto s = solver.amplitudes(mu.cast<double>());
        return py::make_tuple(s.S1, s.S2);
    }
    Array mus = mu.cast<Array>();
    const auto shape = shape_of(mus);
    CArray s1(shape), s2(shape);
    const double* in = mus.data();
    cplx *o1 = s1.mutable_data(), *o2 = s2.mutable_data();
    for (py::ssize_t i = 0; i < mus.size(); ++i) {
        if (!(in[i] >= -1 && in[i] <= 1))
            throw py::value_error("grainlight: mu = " + std::to_string(in[i]) + " outside [-1, 1] (mu = cos theta)");
        const auto s = solver.amplitudes(in[i]);
        o1[i] = s.S1, o2[i] = s.S2;
    }
    return py::make_tuple(s1, s2);
}

py::tuple mie_s1_s2(cplx m, double x, py::object mu) {
    check_index("mie_S1_S2", m);
    if (!is_array_like(mu)) {
        const double v = mu.cast<double>();
        if (!(v >= -1 && v <= 1)) throw py::value_error("grainlight.mie_S1_S2: mu = " + std::to_string(v) + " outside [-1, 1]");
    }
    const grainlight::LorenzMie mie(m, x);
    return amplitudes_over_mu(mie, mu);
}

py::tuple goa_efficiencies(cplx m, py::object x, int p_max) {
    check_index("goa", m);
    auto one = [&](double xi) {
        const grainlight::Goa goa(m, xi, p_max);
        const double qext = goa.qext(), qabs = goa.qabs();
        return std::array<double, 3>{qext, qext - qabs, qabs};
    };
    if (!is_array_like(x)) {
        const auto q = one(x.cast<double>());
        return py::make_tuple(q[0], q[1], q[2]);
    }
    Array xs = x.cast<Array>();
    const auto shape = shape_of(xs);
    Array qext(shape), qsca(shape), qabs(shape);
    for (py::ssize_t i = 0; i < xs.size(); ++i) {
        const auto q = one(xs.data()[i]);
        qext.mutable_data()[i] = q[0], qsca.mutable_data()[i] = q[1], qabs.mutable_data()[i] = q[2];
    }
    return py::make_tuple(qext, qsca, qabs);
}

py::tuple goa_s1_s2(cplx m, double x, py::object mu, int p_max, bool diffraction) {
    check_index("goa_S1_S2", m);
    const grainlight::Goa goa(m, x, p_max, diffraction);
    return amplitudes_over_mu(goa, mu);
}

grainlight::ScatteringMethod parse_method(const std::string& s) {
    if (s == "automatic") return grainlight::ScatteringMethod::automatic;
    if (s == "mie") return grainlight::ScatteringMethod::mie;
    if (s == "goa") return grainlight::ScatteringMethod::goa;
    throw py::value_error("grainlight.bulk_optics: method = '" + s + "' (valid: 'automatic', 'mie', 'goa')");
}

py::dict bulk_to_dict(const grainlight::BulkOptics& b) {
    const std::size_t nw = b.channels.size(), nt = b.theta.size();
    Array theta(std::vector<py::ssize_t>{py::ssize_t(nt)});
    std::copy(b.theta.begin(), b.theta.end(), theta.mutable_data());
    Array phase(std::vector<py::ssize_t>{py::ssize_t(nw), py::ssize_t(nt)});
    const auto n_wl = py::ssize_t(nw);
    Array wl(n_wl), st(n_wl), ss(n_wl), sa(n_wl), g(n_wl), ct(n_wl), cs(n_wl);
    for (std::size_t c = 0; c < nw; ++c) {
        const auto& ch = b.channels[c];
        wl.mutable_data()[c] = ch.wavelength_um;
        st.mutable_data()[c] = ch.sigma_t, ss.mutable_data()[c] = ch.sigma_s, sa.mutable_data()[c] = ch.sigma_a;
        g.mutable_data()[c] = ch.g, ct.mutable_data()[c] = ch.mean_C_t, cs.mutable_data()[c] = ch.mean_C_s;
        std::copy(ch.phase.begin(), ch.phase.end(), phase.mutable_data() + c * nt);
    }
    py::dict d;
    d["wavelength_um"] = wl, d["theta"] = theta, d["phase"] = phase;
    d["sigma_t"] = st, d["sigma_s"] = ss, d["sigma_a"] = sa, d["g"] = g;
    d["mean_C_t"] = ct, d["mean_C_s"] = cs;
    return d;
}

py::dict bulk_optics(cplx particle_index, std::vector<double> wavelengths_um, double r_g, double sigma_g,
                     double r_min, double r_max, double number_density, double host_index,
                     const std::string& method, double rel_tol) {
    check_index("bulk_optics", particle_index);
    grainlight::ParticleModel model;
    model.particle_index = particle_index;
    model.host_index = host_index;
    model.method = parse_method(method);
    const grainlight::LogNormalPsd psd(r_g, sigma_g, r_min, r_max, number_density);
    grainlight::BulkSettings settings;
    settings.rel_tol = rel_tol;
    return bulk_to_dict(grainlight::compute_bulk_optics(psd, model, wavelengths_um, settings));
}

py::tuple lognormal_pdf(py::object r, double r_g, double sigma_g, double r_min, double r_max) {
    const grainlight::LogNormalPsd psd(r_g, sigma_g, r_min, r_max);
    Array rs = r.cast<Array>();
    Array pdf(shape_of(rs)), cdf(shape_of(rs));
    for (py::ssize_t i = 0; i < rs.size(); ++i) {
        pdf.mutable_data()[i] = psd.pdf(rs.data()[i]);
        cdf.mutable_data()[i] = psd.cdf(rs.data()[i]);
    }
    return py::make_tuple(pdf, cdf);
}

py::dict md_pack(std::size_t n, double fraction, std::uint64_t seed, double side) {
    std::optional<grainlight::MdPackResult> packed;
    {
        py::gil_scoped_release release;
        packed.emplace(grainlight::md_pack(n, fraction, seed, {}, side));
    }
    const auto& res = *packed;
    const auto& c = res.tile.centers();
    Array centres(std::vector<py::ssize_t>{py::ssize_t(c.size()), 3});
    for (std::size_t i = 0; i < c.size(); ++i)
        for (int a = 0; a < 3; ++a) centres.mutable_data()[3 * i + a] = c[i][a];
    py::dict d;
    d["centres"] = centres;
    d["radius"] = res.tile.radius();
    d["side"] = res.tile.side();
    d["fraction"] = res.fraction;
    d["target_fraction"] = res.target_fraction;
    d["reached_target"] = res.reached_target;
    d["reduced_pressure"] = res.reduced_pressure;
    d["collisions"] = res.collisions;
    return d;
}

py::dict grain_stats(const std::string& preset, std::uint64_t rays, std::uint64_t seed, int level) {
    const grainlight::GrainPreset p = grainlight::grain_preset(preset);
    grainlight::ScatterometerConfig cfg;
    cfg.rays = rays;
    cfg.seed = seed;
    std::optional<grainlight::GrainStats> st;
    {
        py::gil_scoped_release release;
        const auto grain = grainlight::ScatterometerGrain::procedural(p.shape, p.radius, p.material, p.seed, level);
        st.emplace(grainlight::run_scatterometer(grain, cfg));
    }
    const auto& s = *st;
    auto per_channel = [&](auto f) {
        Array a(std::vector<py::ssize_t>{3});
        for (std::size_t c = 0; c < 3; ++c) a.mutable_data()[c] = f(c);
        return a;
    };
    py::dict d;
    d["preset"] = p.name;
    d["rays"] = s.rays;
    d["beta"] = s.beta();
    d["beta_stderr"] = s.beta_stderr();
    d["lambda_delta"] = s.lambda_delta();
    d["alpha_s"] = per_channel([&](std::size_t c) { return s.alpha_s(c); });
    d["lambda_s"] = per_channel([&](std::size_t c) { return s.lambda_s(c); });
    d["teleport_along"] = per_channel([&](std::size_t c) { return s.teleport_along(c); });
    d["g"] = per_channel([&](std::size_t c) { return s.g(c); });
    d["exit_probability"] = per_channel([&](std::size_t c) { return s.exit[c]; });
    const auto edges = grainlight::ScatterometerGrid::mu_edges(s.grid.phase_bins);
    Array mu_edges(std::vector<py::ssize_t>{py::ssize_t(edges.size())});
    std::copy(edges.begin(), edges.end(), mu_edges.mutable_data());
    Array hist(std::vector<py::ssize_t>{3, py::ssize_t(s.grid.phase_bins)});
    for (std::size_t c = 0; c < 3; ++c)
        std::copy(s.phase_hist[c].begin(), s.phase_hist[c].end(), hist.mutable_data() + c * s.grid.phase_bins);
    d["mu_edges"] = mu_edges;
    d["phase_hist"] = hist;
    if (const auto* col = grainlight::find_meng15_table1(p.paper_column)) {
        py::dict t;
        t["column"] = col->name;
        t["beta"] = col->beta, t["lambda_delta"] = col->lambda_delta, t["lambda_s"] = col->lambda_s, t["alpha_s"] = col->alpha_s;
        d["meng15_table1"] = t;
    }
    return d;
}

std::vector<std::string> grain_preset_names() {
    std::vector<std::string> names;
    for (const auto& p : grainlight::grain_presets()) names.push_back(p.name);
    return names;
}

std::string doc(const std::string& body) { return body + "\n\n" + convention_note; }

}  // namespace

PYBIND11_MODULE(grainlight, mod) {
    mod.doc() = doc("grainlight: Lorenz-Mie and geometrical-optics scattering by spheres, size distributions, "
                    "bulk optical properties and periodic sphere packings (the header-only C++ library's "
                    "optics and packing layers).");
#ifdef GRAINLIGHT_VERSION
    mod.attr("__version__") = GRAINLIGHT_VERSION;
#endif
    mod.attr("index_convention") = "n + ik (k >= 0 absorbs)";

    mod.def("mie", &mie_efficiencies, py::arg("m"), py::arg("x"),
            doc("mie(m, x) -> (qext, qsca, qback, g)\n\n"
                "Lorenz-Mie efficiencies of a homogeneous sphere: extinction, scattering and backscattering "
                "efficiencies (cross section / pi r^2; qback = 4 |S1(180 deg)|^2 / x^2) and the asymmetry "
                "parameter g. m: complex index relative to the host; x = 2 pi n_host r / lambda, "
                "0 < x <= 1e6. Floats for a scalar x, numpy arrays of x's shape for an array x.")
                .c_str());
    mod.def("mie_S1_S2", &mie_s1_s2, py::arg("m"), py::arg("x"), py::arg("mu"),
            doc("mie_S1_S2(m, x, mu) -> (S1, S2)\n\n"
                "Lorenz-Mie scattering amplitudes at mu = cos(theta) in [-1, 1]: complex numpy arrays of "
                "mu's shape (complex numbers for a scalar mu). Normalization and phase convention of van "
                "de Hulst and Wiscombe's MIEV0: Re S(0) = x^2 qext / 4, e.g. S(0) = 55.80662 - 9.758097j "
                "for m = 0.75, x = 10 (miepython's norm='wiscombe'). The phase function per steradian is "
                "(|S1|^2 + |S2|^2) / (2 pi x^2 qsca).")
                .c_str());
    mod.def("goa", &goa_efficiencies, py::arg("m"), py::arg("x"), py::arg("p_max") = 3,
            doc("goa(m, x, p_max=3) -> (qext, qsca, qabs)\n\n"
                "Geometrical-optics approximation (Guo et al. 2021, Eqs. 11-13) of a sphere: extinction from "
                "the forward amplitude, absorption by ray optics, qsca = qext - qabs. Re(m) != 1. Floats for a "
                "scalar x, numpy arrays for an array x.")
                .c_str());
    mod.def("goa_S1_S2", &goa_s1_s2, py::arg("m"), py::arg("x"), py::arg("mu"), py::arg("p_max") = 3,
            py::arg("diffraction") = true,
            doc("goa_S1_S2(m, x, mu, p_max=3, diffraction=True) -> (S1, S2)\n\n"
                "GOA amplitudes (reflection/refraction orders 0..p_max, plus Fraunhofer diffraction for "
                "theta < 90 deg) at mu = cos(theta), in the same convention as mie_S1_S2.")
                .c_str());
    mod.def("lognormal_pdf", &lognormal_pdf, py::arg("r"), py::arg("r_g"), py::arg("sigma_g"),
            py::arg("r_min") = 0.0, py::arg("r_max") = std::numeric_limits<double>::infinity(),
            "lognormal_pdf(r, r_g, sigma_g, r_min=0, r_max=inf) -> (pdf, cdf)\n\n"
            "Truncated log-normal size distribution (Guo et al. 2021, Eq. 15): density and CDF at radii r "
            "[um] (numpy arrays of r's shape). r_g: geometric mean radius [um], sigma_g > 1.");
    mod.def("bulk_optics", &bulk_optics, py::arg("m"), py::arg("wavelengths_um"), py::arg("r_g"),
            py::arg("sigma_g"), py::arg("r_min") = 0.0, py::arg("r_max") = std::numeric_limits<double>::infinity(),
            py::arg("number_density") = 1.0, py::arg("host_index") = 1.0, py::arg("method") = "automatic",
            py::arg("rel_tol") = 1e-3,
            doc("bulk_optics(m, wavelengths_um, r_g, sigma_g, r_min=0, r_max=inf, number_density=1, host_index=1, "
                "method='automatic', rel_tol=1e-3) -> dict\n\n"
                "Bulk properties of a cloud of spheres with a truncated log-normal size distribution (Guo et "
                "al. 2021, Eqs. 16-17). m: particle index (n + i k, k >= 0) in a host of real index host_index; "
                "number_density in particles per cubic metre. method: 'automatic' (Mie below r = 2 um, GOA "
                "above), 'mie' or 'goa'. Returns numpy arrays: wavelength_um, sigma_t, sigma_s, sigma_a [1/m], "
                "mean_C_t, mean_C_s [um^2], g (one per wavelength), theta [rad] and phase [1/sr] "
                "(wavelengths x angles).")
                .c_str());
    mod.def("grain_presets", &grain_preset_names, "grain_presets() -> list of the grain preset names (Meng15 Table 1 stand-ins).");
    mod.def("grain_stats", &grain_stats, py::arg("preset"), py::arg("rays") = 200000, py::arg("seed") = 1,
            py::arg("level") = 5,
            "grain_stats(preset, rays=200000, seed=1, level=5) -> dict\n\n"
            "The virtual scatterometer (Meng et al. 2015 Secs. 4.1-4.2) on one preset grain: beta (hit "
            "probability) and its standard error, lambda_delta, and per RGB channel alpha_s, lambda_s, "
            "teleport_along, g, exit_probability (numpy arrays of 3); the phase histogram phase_hist "
            "(3 x bins, P(exit and cos theta in bin)) on mu_edges; and meng15_table1 (the paper's column) "
            "when the preset has one. Lengths in bounding-sphere radii. Deterministic for a seed.");
    mod.def("md_pack", &md_pack, py::arg("n"), py::arg("fraction"), py::arg("seed") = 1, py::arg("side") = 1.0,
            "md_pack(n, fraction, seed=1, side=1.0) -> dict\n\n"
            "Periodic packing of n equal spheres in the cube [0, side)^3 by event-driven molecular dynamics "
            "(Lubachevsky-Stillinger growth; the tiles of Meng et al. 2015 Sec. 3.1), deterministic for seed. "
            "fraction in (0, 0.64). Returns centres (n x 3 numpy array), radius, side, fraction (reached), "
            "target_fraction, reached_target, reduced_pressure, collisions.");
}
