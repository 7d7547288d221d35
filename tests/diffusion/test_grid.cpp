// The finite-volume diffusion grid (diffusion/grid.hpp) against closed forms in a sphere of
// radius R with the Robin condition phi + 2 A D dphi/dr = 0 at r = R (Duderstadt & Hamilton 1976,
// ch. 5: the one-speed diffusion equation in spherical geometry; solutions e^{-kr}/r and
// sinh(kr)/r of the homogeneous equation, k = sqrt(sigma_a / D)):
//  - a uniform source q: phi(r) = q / sigma_a (1 - C sinh(k r) / r), C from the Robin condition;
//    the thin-boundary case (A = 1, D small against the cell) makes the staircase's leakage show
//    if it counted the faces' area instead of the surface's;
//  - a point source Q at the centre through the correction u = phi - phi_inf (no sources, Robin
//    data g = phi_inf + 2 A D dphi_inf/dn), the way the point-based far field uses it:
//    phi(r) = Q / (4 pi D) (e^{-kr}/r - C sinh(kr)/r).
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "grainlight/diffusion/grid.hpp"
#include "grainlight/scene/shapes.hpp"

using namespace grainlight;

namespace {
struct SphereCase {
    double R, D, sa, A;
    [[nodiscard]] double k() const { return std::sqrt(sa / D); }
    // Homogeneous solutions and their r-derivatives.
    [[nodiscard]] double s(double r) const { return r < 1e-9 ? k() : std::sinh(k() * r) / r; }
    [[nodiscard]] double ds(double r) const { return (k() * r * std::cosh(k() * r) - std::sinh(k() * r)) / (r * r); }
    [[nodiscard]] double f(double r) const { return std::exp(-k() * r) / r; }
    [[nodiscard]] double df(double r) const { return -std::exp(-k() * r) * (1 + k() * r) / (r * r); }
};

const std::vector<Vec3<double>> kDirs = {{1, 0, 0}, {0, 0.6, 0.8}, {-0.48, 0.6, -0.64}, {0.577, -0.577, 0.577}};
}  // namespace

TEST_CASE("diffusion grid: uniform source in a sphere against the closed form", "[diffusion][grid]") {
    for (const SphereCase sc : {SphereCase{10.0, 1.0 / 3.0, 0.02, 2.5}, SphereCase{10.0, 0.05, 0.05, 1.0}}) {
        const SphereShape<double> sph(Vec3<double>(0.1, -0.2, 0.05), sc.R);
        const Aabb<double> box(sph.center - Vec3<double>(sc.R), sph.center + Vec3<double>(sc.R));
        const DiffusionGrid<double> grid(sph, box, 0.5);
        const double q = 1.0;
        const double C = 1.0 / (sc.s(sc.R) + 2 * sc.A * sc.D * sc.ds(sc.R));  // phi(R) + 2AD phi'(R) = 0
        std::vector<double> src(grid.inside_count(), q);
        DiffusionSolveInfo info;
        const std::vector<double> phi = grid.solve(sc.D, sc.sa, sc.A, src, {}, &info);
        CAPTURE(sc.D, sc.A, info.iterations, info.relative_residual);
        REQUIRE(info.relative_residual < 1e-6);
        const auto fd = grid.field(phi, sc.D, sc.A);
        for (double r : {0.0, 4.0, 8.0, 9.5}) {
            for (const auto& d : kDirs) {
                const double exact = q / sc.sa * (1 - C * sc.s(r));
                const double got = grid.eval(fd, sph.center + r * glm::normalize(d));
                CAPTURE(r, exact, got);
                // Half a cell from the surface, a profile of scale L_d = 2 cells (second case) is
                // interpolated to 3-4 %.
                CHECK(got == Approx(exact).epsilon(r > 9 ? 0.05 : 0.02));
            }
        }
        // Conservation: absorbed + leaked = emitted, and the leakage matches the closed form's
        // outward current 4 pi R^2 (-D phi'(R)).
        double absorbed = 0, leaked = 0;
        const double h3 = std::pow(grid.h(), 3);
        for (double v : phi) absorbed += sc.sa * v * h3;
        for (const auto& fc : grid.faces())
            leaked += grid.h() * grid.h() * sc.D * phi[fc.cell] / (fc.delta + 2 * sc.A * sc.D / fc.n_axis);
        const double emitted = q * h3 * double(grid.inside_count());
        CHECK(absorbed + leaked == Approx(emitted).epsilon(1e-5));
        const double leak_exact = 4 * M_PI * sc.R * sc.R * (-sc.D) * (q / sc.sa) * (-C * sc.ds(sc.R));
        const double emitted_exact = q * 4.0 / 3.0 * M_PI * std::pow(sc.R, 3);
        CAPTURE(leaked, leak_exact, emitted, emitted_exact);
        CHECK(leaked / emitted == Approx(leak_exact / emitted_exact).epsilon(0.03));
    }
}

TEST_CASE("diffusion grid: point source through the boundary correction u = phi - phi_inf", "[diffusion][grid]") {
    const SphereCase sc{10.0, 1.0 / 3.0, 0.01, 2.5};
    const double Q = 1.0;
    const SphereShape<double> sph(Vec3<double>(0.0), sc.R);
    const Aabb<double> box(Vec3<double>(-sc.R), Vec3<double>(sc.R));
    const DiffusionGrid<double> grid(sph, box, 0.5);
    const double a = Q / (4 * M_PI * sc.D);
    std::vector<double> g(grid.faces().size());
    for (std::size_t i = 0; i < g.size(); ++i) {
        const auto& fc = grid.faces()[i];
        const double r = glm::length(fc.s);
        const double dn = glm::dot(fc.n, fc.s / r);  // dphi_inf/dn = dphi/dr (r^ . n)
        g[i] = a * sc.f(r) + 2 * sc.A * sc.D * a * sc.df(r) * dn;
    }
    DiffusionSolveInfo info;
    const std::vector<double> u = grid.solve(sc.D, sc.sa, sc.A, {}, g, &info);
    REQUIRE(info.relative_residual < 1e-6);
    const auto fd = grid.field(u, sc.D, sc.A, g);
    const double C = (sc.f(sc.R) + 2 * sc.A * sc.D * sc.df(sc.R)) / (sc.s(sc.R) + 2 * sc.A * sc.D * sc.ds(sc.R));
    for (double r : {1.0, 5.0, 9.0, 9.8}) {
        for (const auto& d : kDirs) {
            const Vec3<double> p = r * glm::normalize(d);
            Vec3<double> grad;
            const double got = a * sc.f(r) + grid.eval(fd, p, &grad);
            const double exact = a * (sc.f(r) - C * sc.s(r));
            CAPTURE(r, exact, got);
            CHECK(got == Approx(exact).epsilon(0.02));
            // The correction's gradient is radial: -a C s'(r) r^.
            const double gr = glm::dot(grad, glm::normalize(d));
            CHECK(gr == Approx(-a * C * sc.ds(r)).epsilon(0.05).margin(1e-4));
        }
    }
}

TEST_CASE("diffusion grid: bad input", "[diffusion][grid]") {
    const SphereShape<double> sph(Vec3<double>(0.0), 1.0);
    const Aabb<double> box(Vec3<double>(-1.0), Vec3<double>(1.0));
    CHECK_THROWS_WITH(DiffusionGrid<double>(sph, box, 0.0), Catch::Contains("h"));
    CHECK_THROWS_WITH(DiffusionGrid<double>(sph, box, 1e-4), Catch::Contains("cells"));
    const DiffusionGrid<double> grid(sph, box, 0.25);
    CHECK_THROWS_WITH(grid.solve(-1.0, 0.1, 2.0, {}, {}), Catch::Contains("D"));
    CHECK_THROWS_WITH(grid.solve(1.0, 0.1, 0.5, {}, {}), Catch::Contains("A"));
    CHECK_THROWS_WITH(grid.solve(1.0, 0.1, 2.0, std::vector<double>(3, 1.0), {}), Catch::Contains("q size"));
}
