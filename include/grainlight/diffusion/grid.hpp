/// @file grainlight/diffusion/grid.hpp
/// The steady diffusion equation in a bounded medium of any closed shape, on a cell-centred
/// grid (finite volumes, 7-point stencil), with the Robin (partial-current) boundary condition
///
///     -div(D grad phi) + sigma_a phi = q            inside V,
///     phi + 2 A D dphi/dn = -g                      on dV (n outward; g = 0: the physical field).
///
/// The shape enters only through ray casts from cell centres: a cell is inside when a ray from
/// its centre leaves the shape first; a face between an inside cell and an outside one is cut
/// by the true surface at distance delta along the axis, with the surface normal n there. The
/// face's outward flux per unit face area is D (phi_i + g) / (delta + 2 A D / |n_a|): the linear
/// profile along the axis that meets the Robin condition where the axis crosses the surface.
/// Summed over the faces of a staircase this leaks through the true area of the surface (the
/// faces of axis a project the surface with weight |n_a|, the profile's slope carries another
/// |n_a| in the thin-boundary limit and 1 / |n_a| of the extrapolation length in the thick one),
/// so the staircase does not inflate the leakage (a sphere of radius 20 cells: tests/diffusion).
///
/// Used by the point-based renderer's far field (integrators/point_based.hpp): the correction
/// u = phi_bounded - phi_infinite has no sources inside and boundary data g = phi_inf + 2 A D
/// dphi_inf / dn, so it is smooth where the point sources are singular.
///
/// The system is symmetric positive definite; it is solved by conjugate gradients with a Jacobi
/// preconditioner (double accumulation).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/ray.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/aabb.hpp"

namespace grainlight {

/// A boundary face of a DiffusionGrid: an inside cell whose neighbour along one axis is outside.
template <std::floating_point F>
struct DiffusionGridFace {
    std::uint32_t cell = 0;  ///< inside-cell index (DiffusionGrid::inside_cells order)
    std::uint8_t axis = 0;   ///< 0, 1, 2 for x, y, z
    std::int8_t sign = 1;    ///< +1 or -1: the direction of the outside neighbour
    F delta = F(0);          ///< distance from the cell centre to the surface along the axis (0, h]
    F n_axis = F(1);         ///< |n . e_axis| of the surface normal there (>= 1e-3)
    Vec3<F> s{F(0)};         ///< the surface point
    Vec3<F> n{F(0)};         ///< the outward surface normal at s
};

/// Result of DiffusionGrid::solve.
struct DiffusionSolveInfo {
    int iterations = 0;               ///< conjugate-gradient iterations
    double relative_residual = 0.0;   ///< |r| / |b| at exit
};

/// Cell-centred grid over a closed shape (see the file comment).
template <std::floating_point F>
class DiffusionGrid {
public:
    /// Build over `box` (enlarged by one cell on every side) with cells of side h, classifying the
    /// cell centres against `boundary` (`intersect(Ray<F>, t&, n&)` with outward normals).
    /// Throws invalid_argument for h <= 0, an empty box or more than 2^27 cells.
    template <class Boundary>
    DiffusionGrid(const Boundary& boundary, const Aabb<F>& box, F h) : h_(h) {
        check_argument(std::isfinite(h) && h > F(0), "DiffusionGrid", "h", h, "(0, inf)");
        const Vec3<F> ext = box.hi - box.lo;
        check_argument(std::isfinite(ext.x) && ext.x >= F(0) && ext.y >= F(0) && ext.z >= F(0), "DiffusionGrid",
                       "box extent", ext.x, "finite, >= 0");
        double total = 1;
        for (int a = 0; a < 3; ++a) {
            n_[a] = int(std::ceil(double(ext[a]) / double(h))) + 2;
            total *= double(n_[a]);
        }
        check_argument(total <= double(1u << 27), "DiffusionGrid", "cells", total, "<= 2^27 (larger h)");
        lo_ = box.lo - Vec3<F>(h);
        const std::size_t nc = std::size_t(total);
        index_.assign(nc, -1);
        for (int k = 0; k < n_[2]; ++k)
            for (int j = 0; j < n_[1]; ++j)
                for (int i = 0; i < n_[0]; ++i) {
                    const Vec3<F> c = centre(i, j, k);
                    F t;
                    Vec3<F> nn;
                    if (boundary.intersect(Ray<F>(c, Vec3<F>(F(1), F(0), F(0))), t, nn) && nn.x > F(0)) {
                        index_[flat(i, j, k)] = std::int32_t(cells_.size());
                        cells_.push_back(std::uint32_t(flat(i, j, k)));
                    }
                }
        for (std::size_t ci = 0; ci < cells_.size(); ++ci) {
            int ijk[3];
            unflat(cells_[ci], ijk);
            for (int a = 0; a < 3; ++a)
                for (int s = -1; s <= 1; s += 2) {
                    int q[3] = {ijk[0], ijk[1], ijk[2]};
                    q[a] += s;
                    if (q[a] >= 0 && q[a] < n_[a] && index_[flat(q[0], q[1], q[2])] >= 0) continue;
                    DiffusionGridFace<F> f;
                    f.cell = std::uint32_t(ci);
                    f.axis = std::uint8_t(a);
                    f.sign = std::int8_t(s);
                    Vec3<F> dir(F(0));
                    dir[a] = F(s);
                    const Vec3<F> c = centre(ijk[0], ijk[1], ijk[2]);
                    F t;
                    Vec3<F> nn;
                    if (boundary.intersect(Ray<F>(c, dir), t, nn) && t <= F(1.5) * h && t > F(0)) {
                        f.delta = std::max(t, F(1e-3) * h);
                        f.n = glm::normalize(nn);
                    } else {  // no crossing found near the centre (grazing): the face's middle
                        f.delta = F(0.5) * h;
                        f.n = dir;
                    }
                    f.s = c + f.delta * dir;
                    f.n_axis = std::max(F(1e-3), std::abs(f.n[a]));
                    faces_.push_back(f);
                }
        }
    }

    /// Cell side [scene units].
    [[nodiscard]] F h() const noexcept { return h_; }
    /// Cells along x, y, z (the box plus one cell on every side).
    [[nodiscard]] std::array<int, 3> dims() const noexcept { return {n_[0], n_[1], n_[2]}; }
    /// Number of inside cells (the unknowns).
    [[nodiscard]] std::size_t inside_count() const noexcept { return cells_.size(); }
    /// Boundary faces (inside cell next to an outside one).
    [[nodiscard]] const std::vector<DiffusionGridFace<F>>& faces() const noexcept { return faces_; }
    /// Centre of the i-th inside cell.
    [[nodiscard]] Vec3<F> inside_centre(std::size_t i) const noexcept {
        int ijk[3];
        unflat(cells_[i], ijk);
        return centre(ijk[0], ijk[1], ijk[2]);
    }
    /// Inside-cell index of the cell containing p, or -1 (outside or off the grid).
    [[nodiscard]] std::int64_t cell_of(const Vec3<F>& p) const noexcept {
        int q[3];
        for (int a = 0; a < 3; ++a) {
            q[a] = int(std::floor((p[a] - lo_[a]) / h_));
            if (q[a] < 0 || q[a] >= n_[a]) return -1;
        }
        return index_[flat(q[0], q[1], q[2])];
    }

    /// Solve for phi on the inside cells: `q` per inside cell (source per unit volume, or empty
    /// for none), `g` per face (or empty for g = 0); D > 0, sigma_a >= 0, A >= 1 the boundary
    /// coefficient. Relative residual `tol`, at most `max_iter` iterations.
    std::vector<F> solve(F D, F sigma_a, F A, const std::vector<F>& q, const std::vector<F>& g,
                         DiffusionSolveInfo* info = nullptr, double tol = 1e-7, int max_iter = 20000) const {
        check_argument(std::isfinite(D) && D > F(0), "DiffusionGrid::solve", "D", D, "(0, inf)");
        check_argument(std::isfinite(sigma_a) && sigma_a >= F(0), "DiffusionGrid::solve", "sigma_a", sigma_a,
                       "[0, inf)");
        check_argument(std::isfinite(A) && A >= F(1), "DiffusionGrid::solve", "A", A, "[1, inf)");
        check_argument(q.empty() || q.size() == cells_.size(), "DiffusionGrid::solve", "q size", q.size(),
                       "0 or the inside-cell count");
        check_argument(g.empty() || g.size() == faces_.size(), "DiffusionGrid::solve", "g size", g.size(),
                       "0 or the face count");
        const std::size_t n = cells_.size();
        // Equation of cell i divided by h^3: sum_j D/h^2 (u_i - u_j) + sum_f c_f (u_i + g_f) / h
        // + sigma_a u_i = q_i, with c_f = D / (delta + 2 A D / |n_a|).
        const double dh2 = double(D) / (double(h_) * double(h_));
        std::vector<double> diag(n, double(sigma_a)), b(n, 0.0);
        for (std::size_t i = 0; i < n; ++i) {
            if (!q.empty()) b[i] = double(q[i]);
            diag[i] += dh2 * double(inside_neighbours(i));
        }
        for (std::size_t f = 0; f < faces_.size(); ++f) {
            const DiffusionGridFace<F>& fc = faces_[f];
            const double cf = double(D) / (double(fc.delta) + 2.0 * double(A) * double(D) / double(fc.n_axis)) / double(h_);
            diag[fc.cell] += cf;
            if (!g.empty()) b[fc.cell] -= cf * double(g[f]);
        }
        auto apply = [&](const std::vector<double>& x, std::vector<double>& y) {
#if defined(_OPENMP)
#pragma omp parallel for schedule(static)
#endif
            for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(n); ++ii) {
                const std::size_t i = std::size_t(ii);
                int ijk[3];
                unflat(cells_[i], ijk);
                double s = diag[i] * x[i];
                for (int a = 0; a < 3; ++a)
                    for (int d = -1; d <= 1; d += 2) {
                        int qq[3] = {ijk[0], ijk[1], ijk[2]};
                        qq[a] += d;
                        if (qq[a] < 0 || qq[a] >= n_[a]) continue;
                        const std::int32_t j = index_[flat(qq[0], qq[1], qq[2])];
                        if (j >= 0) s -= dh2 * x[std::size_t(j)];
                    }
                y[i] = s;
            }
        };
        std::vector<double> x(n, 0.0), r = b, z(n), p(n), ap(n);
        double bnorm = 0;
        for (double v : b) bnorm += v * v;
        bnorm = std::sqrt(bnorm);
        int it = 0;
        double rel = 0;
        if (bnorm > 0) {
            for (std::size_t i = 0; i < n; ++i) z[i] = r[i] / diag[i];
            p = z;
            double rz = 0;
            for (std::size_t i = 0; i < n; ++i) rz += r[i] * z[i];
            for (it = 1; it <= max_iter; ++it) {
                apply(p, ap);
                double pap = 0;
                for (std::size_t i = 0; i < n; ++i) pap += p[i] * ap[i];
                if (!(pap > 0)) break;
                const double alpha = rz / pap;
                double rr = 0;
                for (std::size_t i = 0; i < n; ++i) {
                    x[i] += alpha * p[i];
                    r[i] -= alpha * ap[i];
                    rr += r[i] * r[i];
                }
                rel = std::sqrt(rr) / bnorm;
                if (rel <= tol) break;
                double rz2 = 0;
                for (std::size_t i = 0; i < n; ++i) {
                    z[i] = r[i] / diag[i];
                    rz2 += r[i] * z[i];
                }
                const double beta = rz2 / rz;
                rz = rz2;
                for (std::size_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
            }
        }
        if (info) {
            info->iterations = std::min(it, max_iter);
            info->relative_residual = rel;
        }
        return std::vector<F>(x.begin(), x.end());
    }

    /// A solved field ready for lookups: the inside values plus ghost values in the outside cells
    /// next to them (the Robin profile of each face carried to the ghost centre; cells further out
    /// that a lookup may touch take the mean of their filled neighbours), so that trilinear
    /// interpolation and its gradient are defined everywhere inside the shape.
    struct Field {
        std::vector<F> v;  ///< value per grid cell (flat index), 0 where never filled
    };

    /// Fill a Field from `phi` (solve()'s result) with the same D, A and g as the solve.
    [[nodiscard]] Field field(const std::vector<F>& phi, F D, F A, const std::vector<F>& g = {}) const {
        check_argument(phi.size() == cells_.size(), "DiffusionGrid::field", "phi size", phi.size(),
                       "the inside-cell count");
        Field fd;
        fd.v.assign(index_.size(), F(0));
        std::vector<std::uint8_t> filled(index_.size(), 0);
        std::vector<F> acc(index_.size(), F(0));
        std::vector<std::uint16_t> cnt(index_.size(), 0);
        for (std::size_t i = 0; i < cells_.size(); ++i) {
            fd.v[cells_[i]] = phi[i];
            filled[cells_[i]] = 1;
        }
        for (std::size_t f = 0; f < faces_.size(); ++f) {
            const DiffusionGridFace<F>& fc = faces_[f];
            int ijk[3];
            unflat(cells_[fc.cell], ijk);
            ijk[fc.axis] += fc.sign;
            if (ijk[fc.axis] < 0 || ijk[fc.axis] >= n_[fc.axis]) continue;
            const F ui = phi[fc.cell], gf = g.empty() ? F(0) : g[f];
            // The profile's slope along the axis is -(u_i + g) / (delta + 2 A D / |n_a|).
            const F ghost = ui - h_ * (ui + gf) / (fc.delta + F(2) * A * D / fc.n_axis);
            const std::size_t o = flat(ijk[0], ijk[1], ijk[2]);
            acc[o] += ghost;
            cnt[o] += 1;
        }
        for (std::size_t o = 0; o < acc.size(); ++o)
            if (cnt[o] > 0) {
                fd.v[o] = acc[o] / F(cnt[o]);
                filled[o] = 2;
            }
        // Second ring: the mean of the filled 26-neighbours.
        std::vector<F> v2 = fd.v;
        for (int k = 0; k < n_[2]; ++k)
            for (int j = 0; j < n_[1]; ++j)
                for (int i = 0; i < n_[0]; ++i) {
                    const std::size_t o = flat(i, j, k);
                    if (filled[o]) continue;
                    F s = F(0);
                    int c = 0;
                    for (int dk = -1; dk <= 1; ++dk)
                        for (int dj = -1; dj <= 1; ++dj)
                            for (int di = -1; di <= 1; ++di) {
                                const int a = i + di, bq = j + dj, cq = k + dk;
                                if (a < 0 || bq < 0 || cq < 0 || a >= n_[0] || bq >= n_[1] || cq >= n_[2]) continue;
                                const std::size_t m = flat(a, bq, cq);
                                if (filled[m]) {
                                    s += fd.v[m];
                                    ++c;
                                }
                            }
                    if (c > 0) v2[o] = s / F(c);
                }
        fd.v = std::move(v2);
        return fd;
    }

    /// Trilinear value of `fd` at p and its gradient (the interpolant's derivative); 0 off the grid.
    [[nodiscard]] F eval(const Field& fd, const Vec3<F>& p, Vec3<F>* grad = nullptr) const noexcept {
        F u[3];
        int q[3];
        for (int a = 0; a < 3; ++a) {
            const F x = (p[a] - lo_[a]) / h_ - F(0.5);
            q[a] = int(std::floor(x));
            if (q[a] < 0 || q[a] + 1 >= n_[a]) {
                if (grad) *grad = Vec3<F>(F(0));
                return F(0);
            }
            u[a] = x - F(q[a]);
        }
        F c[2][2][2];
        for (int dk = 0; dk < 2; ++dk)
            for (int dj = 0; dj < 2; ++dj)
                for (int di = 0; di < 2; ++di) c[dk][dj][di] = fd.v[flat(q[0] + di, q[1] + dj, q[2] + dk)];
        const F x = u[0], y = u[1], z = u[2];
        auto lerp = [](F a, F b, F t) { return a + t * (b - a); };
        const F c00 = lerp(c[0][0][0], c[0][0][1], x), c10 = lerp(c[0][1][0], c[0][1][1], x);
        const F c01 = lerp(c[1][0][0], c[1][0][1], x), c11 = lerp(c[1][1][0], c[1][1][1], x);
        const F c0 = lerp(c00, c10, y), c1 = lerp(c01, c11, y);
        if (grad) {
            const F dx0 = lerp(lerp(c[0][0][1] - c[0][0][0], c[0][1][1] - c[0][1][0], y),
                               lerp(c[1][0][1] - c[1][0][0], c[1][1][1] - c[1][1][0], y), z);
            const F dy0 = lerp(lerp(c[0][1][0] - c[0][0][0], c[0][1][1] - c[0][0][1], x),
                               lerp(c[1][1][0] - c[1][0][0], c[1][1][1] - c[1][0][1], x), z);
            const F dz0 = c1 - c0;
            *grad = Vec3<F>(dx0, dy0, dz0) / h_;
        }
        return lerp(c0, c1, z);
    }

    /// Bytes held by the grid (index, cells and faces).
    [[nodiscard]] std::size_t bytes() const noexcept {
        return index_.size() * sizeof(std::int32_t) + cells_.size() * sizeof(std::uint32_t) +
               faces_.size() * sizeof(DiffusionGridFace<F>);
    }

private:
    [[nodiscard]] std::size_t flat(int i, int j, int k) const noexcept {
        return (std::size_t(k) * std::size_t(n_[1]) + std::size_t(j)) * std::size_t(n_[0]) + std::size_t(i);
    }
    void unflat(std::size_t o, int ijk[3]) const noexcept {
        ijk[0] = int(o % std::size_t(n_[0]));
        o /= std::size_t(n_[0]);
        ijk[1] = int(o % std::size_t(n_[1]));
        ijk[2] = int(o / std::size_t(n_[1]));
    }
    [[nodiscard]] Vec3<F> centre(int i, int j, int k) const noexcept {
        return lo_ + h_ * Vec3<F>(F(i) + F(0.5), F(j) + F(0.5), F(k) + F(0.5));
    }
    [[nodiscard]] int inside_neighbours(std::size_t i) const noexcept {
        int ijk[3];
        unflat(cells_[i], ijk);
        int c = 0;
        for (int a = 0; a < 3; ++a)
            for (int d = -1; d <= 1; d += 2) {
                int qq[3] = {ijk[0], ijk[1], ijk[2]};
                qq[a] += d;
                if (qq[a] >= 0 && qq[a] < n_[a] && index_[flat(qq[0], qq[1], qq[2])] >= 0) ++c;
            }
        return c;
    }

    F h_;
    int n_[3] = {0, 0, 0};
    Vec3<F> lo_{F(0)};
    std::vector<std::int32_t> index_;     ///< flat cell -> inside index or -1
    std::vector<std::uint32_t> cells_;    ///< inside index -> flat cell
    std::vector<DiffusionGridFace<F>> faces_;
};

}  // namespace grainlight
