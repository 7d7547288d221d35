/// @file grainlight/traversal/particle_grid.hpp
/// Uniform grid over a particle cloud for gathering the particles of a query cylinder (Guo21
/// Sec. 5.3) or a query sphere (Sec. 5.4).
///
/// Every particle is referenced by every voxel its *dilated* sphere (radius r_p + dilation, the
/// dilation being the largest query radius r_c that will be used) touches (exact sphere-box
/// test), so a cylinder query only walks the voxels the cylinder's axis crosses (3D-DDA,
/// traversal/dda.hpp) and still finds every particle whose centre lies within r_p + r_c of the
/// axis: the axis point nearest to such a centre lies inside the dilated sphere, hence in a
/// voxel that references it. Duplicates are removed without a mark array: a particle is
/// reported only from the voxel containing the axis point nearest to its centre (parameter
/// s = (p - o) . d lies in that voxel's [t_enter, t_exit)); a sphere query reports it only from
/// the voxel containing its centre.
///
/// Resolution: by default about one particle per voxel (Guo21 Sec. 5.3 / 6.5: "high performance
/// is achieved when roughly one particle resides in each voxel"); settable per axis. Memory:
/// (cells + 1) + references 32-bit words. Queries allocate nothing and throw nothing.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/traversal/dda.hpp"

namespace grainlight {

/// Settings of a ParticleGrid: resolution (explicit or automatic), dilation (the largest query
/// radius) and a cell cap. Validated by the ParticleGrid constructor.
struct ParticleGridSettings {
    /// Voxels per axis; all zero: automatic, `particles_per_voxel` on average.
    std::array<int, 3> resolution{0, 0, 0};
    /// Target mean number of particles per voxel of an automatic resolution (> 0; Guo21: about 1).
    double particles_per_voxel = 1.0;
    /// Largest query radius r_c that will be used [scene units]; particles are registered with
    /// their spheres dilated by it.
    double dilation = 0.0;
    /// Cap on the number of cells of an automatic resolution.
    std::uint64_t max_cells = std::uint64_t(1) << 28;
    /// Software-pipelined walks (ParticleGrid::walk_voxels): -1 automatic (on when the cell
    /// offsets, references and particle records together exceed `kPrefetchAutoBytes`, i.e. do
    /// not fit the caches near a core), 0 off, 1 on. Results do not depend on it, only the speed.
    int prefetch = -1;
    /// Size above which `prefetch = -1` turns the pipelined walk on [bytes] (8 MiB).
    static constexpr std::size_t kPrefetchAutoBytes = std::size_t(8) << 20;
};

/// Uniform voxel grid over a ParticleCloud with CSR lists of particle references (see the file
/// comment). Keeps a pointer to the cloud, which must outlive the grid. Read-only after
/// construction: queries are const, allocate nothing and may run on any number of threads.
class ParticleGrid {
public:
    ParticleGrid() = default;

    /// Grid over `cloud` (>= 1 particle; referenced, not copied) with settings `st`; throws
    /// grainlight::invalid_argument naming the setting for a negative or non-finite dilation,
    /// particles_per_voxel <= 0, an explicit resolution outside [1, 65536] or >= 2^32 cells.
    ParticleGrid(const ParticleCloud& cloud, const ParticleGridSettings& st) : cloud_(&cloud) {
        const char* who = "ParticleGrid";
        check_argument(cloud.size() >= 1, who, "cloud.size()", cloud.size(), ">= 1");
        check_argument(std::isfinite(st.dilation) && st.dilation >= 0, who, "dilation", st.dilation, ">= 0 (finite)");
        check_argument(std::isfinite(st.particles_per_voxel) && st.particles_per_voxel > 0, who, "particles_per_voxel",
                       st.particles_per_voxel, "> 0 (finite)");
        check_argument(st.prefetch >= -1 && st.prefetch <= 1, who, "prefetch", st.prefetch, "-1 (automatic), 0 or 1");
        const bool automatic = st.resolution[0] == 0 && st.resolution[1] == 0 && st.resolution[2] == 0;
        if (!automatic)
            for (int a = 0; a < 3; ++a)
                check_argument(st.resolution[a] >= 1 && st.resolution[a] <= 65536, who,
                               "resolution[" + std::to_string(a) + "]", st.resolution[a], "[1, 65536] (or all 0: automatic)");
        dilation_ = float(st.dilation);
        // Bounds: every dilated sphere.
        Vec3d lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (const auto& p : cloud.particles()) {
            const Vec3d c(p.x, p.y, p.z);
            const double R = double(p.r) + st.dilation;
            lo = glm::min(lo, c - Vec3d(R));
            hi = glm::max(hi, c + Vec3d(R));
        }
        const Vec3d ext0 = hi - lo;
        const double pad = 1e-5 * std::max({ext0.x, ext0.y, ext0.z, 1e-30});
        lo -= Vec3d(pad);
        hi += Vec3d(pad);
        const Vec3d ext = hi - lo;
        if (automatic) {
            const double vol = ext.x * ext.y * ext.z;
            double h = std::cbrt(vol * st.particles_per_voxel / double(cloud.size()));
            for (;;) {
                std::uint64_t cells = 1;
                for (int a = 0; a < 3; ++a) cells *= std::uint64_t(std::max(1.0, std::ceil(ext[a] / h)));
                if (cells <= st.max_cells) break;
                h *= 1.1;
            }
            for (int a = 0; a < 3; ++a) res_[a] = int(std::clamp(std::ceil(ext[a] / h), 1.0, 65536.0));
        } else {
            res_ = st.resolution;
        }
        const std::uint64_t ncells = std::uint64_t(res_[0]) * std::uint64_t(res_[1]) * std::uint64_t(res_[2]);
        check_argument(ncells < (std::uint64_t(1) << 32), who, "cells", ncells, "< 2^32");
        lo_ = Vec3<float>(lo);
        for (int a = 0; a < 3; ++a) h_[a] = float(ext[a] / double(res_[a]));
        hi_ = lo_ + Vec3<float>(float(res_[0]) * h_[0], float(res_[1]) * h_[1], float(res_[2]) * h_[2]);

        // Two passes: count, then fill (CSR).
        start_.assign(std::size_t(ncells) + 1, 0);
        auto for_cells = [&](const CloudParticle& p, auto&& fn) {
            const Vec3<float> c = p.center();
            const float R = (p.r + dilation_) * (1.0f + 1e-4f) + 1e-6f * std::max({h_[0], h_[1], h_[2]});
            int a0[3], a1[3];
            for (int a = 0; a < 3; ++a) {
                a0[a] = std::clamp(int(std::floor((c[a] - R - lo_[a]) / h_[a])), 0, res_[a] - 1);
                a1[a] = std::clamp(int(std::floor((c[a] + R - lo_[a]) / h_[a])), 0, res_[a] - 1);
            }
            for (int z = a0[2]; z <= a1[2]; ++z)
                for (int y = a0[1]; y <= a1[1]; ++y)
                    for (int x = a0[0]; x <= a1[0]; ++x) {
                        // Squared distance from the centre to the voxel box.
                        float d2 = 0;
                        const int ix[3] = {x, y, z};
                        for (int a = 0; a < 3; ++a) {
                            const float blo = lo_[a] + float(ix[a]) * h_[a], bhi = blo + h_[a];
                            const float e = c[a] < blo ? blo - c[a] : (c[a] > bhi ? c[a] - bhi : 0.0f);
                            d2 += e * e;
                        }
                        if (d2 <= R * R) fn(cell_index(x, y, z));
                    }
        };
        for (const auto& p : cloud.particles()) for_cells(p, [&](std::uint32_t c) { ++start_[c + 1]; });
        for (std::size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
        refs_.resize(start_.back());
        std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
        for (std::uint32_t i = 0; i < cloud.size(); ++i)
            for_cells(cloud[i], [&](std::uint32_t c) { refs_[fill[c]++] = i; });
        const std::size_t bytes = memory_bytes() + cloud.size() * sizeof(CloudParticle);
        prefetch_ = st.prefetch == 1 || (st.prefetch == -1 && bytes > ParticleGridSettings::kPrefetchAutoBytes);
    }

    /// The cloud the grid references.
    [[nodiscard]] const ParticleCloud& cloud() const noexcept { return *cloud_; }
    /// Voxels per axis (x, y, z).
    [[nodiscard]] const std::array<int, 3>& resolution() const noexcept { return res_; }
    /// Dilation of the registered spheres (the largest usable query radius) [scene units].
    [[nodiscard]] float dilation() const noexcept { return dilation_; }
    /// Number of voxels.
    [[nodiscard]] std::size_t cell_count() const noexcept { return start_.empty() ? 0 : start_.size() - 1; }
    /// Number of particle references over all voxels (>= the particle count).
    [[nodiscard]] std::size_t reference_count() const noexcept { return refs_.size(); }
    /// Memory held by the cell offsets and references, in bytes (the cloud not included).
    [[nodiscard]] std::size_t memory_bytes() const noexcept {
        return (start_.capacity() + refs_.capacity()) * sizeof(std::uint32_t);
    }
    /// References of one cell.
    [[nodiscard]] std::span<const std::uint32_t> cell(std::uint32_t c) const noexcept {
        return {refs_.data() + start_[c], refs_.data() + start_[c + 1]};
    }
    /// Flat index of voxel (x, y, z) (each in [0, resolution()[a]); not checked), x fastest.
    [[nodiscard]] std::uint32_t cell_index(int x, int y, int z) const noexcept {
        return std::uint32_t((std::uint64_t(z) * std::uint64_t(res_[1]) + std::uint64_t(y)) * std::uint64_t(res_[0]) +
                             std::uint64_t(x));
    }
    /// Cell containing point p (clamped to the grid).
    [[nodiscard]] std::uint32_t cell_of(const Vec3<float>& p) const noexcept {
        int ix[3];
        for (int a = 0; a < 3; ++a) ix[a] = std::clamp(int(std::floor((p[a] - lo_[a]) / h_[a])), 0, res_[a] - 1);
        return cell_index(ix[0], ix[1], ix[2]);
    }

    /// Walk the voxels crossed by o + t d (unit d), t in [t_min, t_max], in order:
    /// visit(refs, t_enter, t_exit) -> bool (false stops); empty voxels are skipped. Returns false
    /// if stopped. Amanatides-Woo 3D-DDA (as traversal/dda.hpp) specialized to this bounded grid:
    /// 32-bit cells, a linear cell index stepped by the axis stride, reciprocal directions, and
    /// each crossing recomputed from the integer cell (no accumulated drift). Consecutive voxels
    /// share their boundary parameter exactly (t_exit of one is t_enter of the next).
    ///
    /// With prefetching (ParticleGridSettings::prefetch; automatic for grids beyond the caches near
    /// a core) the walk is software-pipelined: the DDA runs kWalkAhead voxels ahead of the
    /// visit, and the chain of dependent loads a voxel needs (cell offsets -> references ->
    /// particle records) is prefetched one link per step, so that the visit finds them in
    /// cache. For large clouds a plain walk is bound by that chain's latency (docs/performance.md).
    /// The voxels visited, their order and the results are the same either way.
    template <class Visit>
    bool walk_voxels(const Vec3<float>& o, const Vec3<float>& d, float t_min, float t_max, Visit&& visit) const noexcept {
        return prefetch_ ? walk_pipelined(o, d, t_min, t_max, visit) : walk_plain(o, d, t_min, t_max, visit);
    }
    /// True if walk_voxels prefetches (ParticleGridSettings::prefetch).
    [[nodiscard]] bool prefetching() const noexcept { return prefetch_; }

    /// Every particle of the query cylinder around o + t d (unit d), t in (t_min, t_max]: centre
    /// within r_p + r_c of the axis and its nearest axis point s inside (t_min, t_max]
    /// (r_c <= dilation). visit(index, s, b2) -> bool, b2 = squared distance centre-axis; in
    /// voxel order (s ascending across voxels, not within a voxel). Returns false if stopped.
    template <class Visit>
    bool for_each_in_cylinder(const Vec3<float>& o, const Vec3<float>& d, float t_min, float t_max, float r_c,
                              Visit&& visit) const noexcept {
        const CloudParticle* ps = cloud_->particles().data();
        return walk_voxels(o, d, t_min, t_max, [&](std::span<const std::uint32_t> refs, float te, float tx) {
            for (const std::uint32_t i : refs) {
                float s, b2;
                if (!cylinder_member(ps[i], o, d, r_c, s, b2)) continue;
                if (!(s > t_min && s <= t_max && s >= te && s < tx)) continue;
                if (!visit(i, s, b2)) return false;
            }
            return true;
        });
    }

    /// Sphere-cylinder test of Guo21 Sec. 5.3: distance from the centre to the axis < r_p + r_c;
    /// s = axis parameter of the nearest point, b2 = squared distance.
    [[nodiscard]] static bool cylinder_member(const CloudParticle& p, const Vec3<float>& o, const Vec3<float>& d, float r_c,
                                              float& s, float& b2) noexcept {
        const Vec3<float> v = p.center() - o;
        s = glm::dot(v, d);
        const Vec3<float> perp = v - s * d;
        b2 = glm::dot(perp, perp);
        const float R = p.r + r_c;
        return b2 < R * R;
    }

    /// Every particle whose centre lies within r_p + r_q of point y (r_q <= any value; cells
    /// overlapping the ball of radius r_q + r_max are scanned): visit(index, dist2) -> bool.
    template <class Visit>
    bool for_each_in_sphere(const Vec3<float>& y, float r_q, Visit&& visit) const noexcept {
        const float reach = r_q + float(cloud_->max_radius());
        int a0[3], a1[3];
        for (int a = 0; a < 3; ++a) {
            a0[a] = std::clamp(int(std::floor((y[a] - reach - lo_[a]) / h_[a])), 0, res_[a] - 1);
            a1[a] = std::clamp(int(std::floor((y[a] + reach - lo_[a]) / h_[a])), 0, res_[a] - 1);
        }
        const CloudParticle* ps = cloud_->particles().data();
        for (int z = a0[2]; z <= a1[2]; ++z)
            for (int yy = a0[1]; yy <= a1[1]; ++yy)
                for (int x = a0[0]; x <= a1[0]; ++x) {
                    const std::uint32_t c = cell_index(x, yy, z);
                    for (const std::uint32_t i : cell(c)) {
                        const Vec3<float> v = ps[i].center() - y;
                        const float d2 = glm::dot(v, v), R = ps[i].r + r_q;
                        if (!(d2 < R * R)) continue;
                        if (cell_of(ps[i].center()) != c) continue;  // report once: from the centre's cell
                        if (!visit(i, d2)) return false;
                    }
                }
        return true;
    }

private:
    /// The 3D-DDA of walk_voxels over [t0, t1] (already clipped to the grid): next() returns the
    /// crossed voxels in order (cell, t_enter, t_exit), empty ones included.
    class VoxelStepper {
    public:
        VoxelStepper(const ParticleGrid& g, const Vec3<float>& o, const Vec3<float>& d, float t0, float t1) noexcept
            : g_(g), local_(o - g.lo_), t_(t0), t1_(t1) {
            stride_[0] = 1;
            stride_[1] = std::int64_t(g.res_[0]);
            stride_[2] = std::int64_t(g.res_[0]) * std::int64_t(g.res_[1]);
            for (int a = 0; a < 3; ++a) {
                const float p = local_[a] + t0 * d[a];
                ix_[a] = std::clamp(int(std::floor(p / g.h_[a])), 0, g.res_[a] - 1);
                step_[a] = d[a] > 0 ? 1 : (d[a] < 0 ? -1 : 0);
                inv_[a] = step_[a] != 0 ? 1.0f / d[a] : 0.0f;
            }
            for (int a = 0; a < 3; ++a) next_[a] = crossing(a);
            idx_ = std::int64_t(g.cell_index(ix_[0], ix_[1], ix_[2]));
        }
        /// The current voxel, then advance; false once the walk has left [t0, t1] or the grid.
        bool next(std::uint32_t& cell, float& te, float& tx) noexcept {
            if (done_) return false;
            const int axis = (next_[0] <= next_[1]) ? (next_[0] <= next_[2] ? 0 : 2) : (next_[1] <= next_[2] ? 1 : 2);
            cell = std::uint32_t(idx_);
            te = t_;
            tx = next_[axis] < t1_ ? next_[axis] : t1_;
            if (!(next_[axis] < t1_)) {
                done_ = true;
                return true;
            }
            ix_[axis] += step_[axis];
            if (ix_[axis] < 0 || ix_[axis] >= g_.res_[axis]) {
                done_ = true;
                return true;
            }
            idx_ += step_[axis] * stride_[axis];
            t_ = std::max(t_, next_[axis]);
            next_[axis] = crossing(axis);
            return true;
        }

    private:
        [[nodiscard]] float crossing(int a) const noexcept {
            return step_[a] == 0 ? std::numeric_limits<float>::infinity()
                                 : (float(ix_[a] + (step_[a] > 0 ? 1 : 0)) * g_.h_[a] - local_[a]) * inv_[a];
        }
        const ParticleGrid& g_;
        Vec3<float> local_;
        int ix_[3], step_[3];
        float inv_[3], next_[3];
        std::int64_t stride_[3], idx_ = 0;
        float t_, t1_;
        bool done_ = false;
    };

    /// walk_voxels without prefetching.
    template <class Visit>
    bool walk_plain(const Vec3<float>& o, const Vec3<float>& d, float t_min, float t_max, Visit&& visit) const noexcept {
        float t0 = t_min, t1 = t_max;
        if (!clip_to_box(o, d, lo_, hi_, t0, t1)) return true;
        VoxelStepper dda(*this, o, d, t0, t1);
        std::uint32_t cell;
        float te, tx;
        while (dda.next(cell, te, tx)) {
            const std::uint32_t b0 = start_[cell], b1 = start_[std::size_t(cell) + 1];
            if (b0 != b1 && tx >= te) {
                if (!visit(std::span<const std::uint32_t>(refs_.data() + b0, refs_.data() + b1), te, tx)) return false;
            }
        }
        return true;
    }

    /// walk_voxels with the software pipeline.
    template <class Visit>
    bool walk_pipelined(const Vec3<float>& o, const Vec3<float>& d, float t_min, float t_max, Visit&& visit) const noexcept {
        float t0 = t_min, t1 = t_max;
        if (!clip_to_box(o, d, lo_, hi_, t0, t1)) return true;
        VoxelStepper dda(*this, o, d, t0, t1);
        struct Voxel {
            std::uint32_t cell, b0, b1;
            float te, tx;
        };
        const std::uint32_t* start = start_.data();
        const std::uint32_t* refs = refs_.data();
        const CloudParticle* ps = cloud_->particles().data();
        constexpr int kRing = 8;  // >= kWalkAhead, power of two
        Voxel ring[kRing];
        int head = 0, count = 0;
        // Stage 1 (when the DDA generates a voxel, kWalkAhead - 1 visits before its own): the
        // cell offsets.
        auto push = [&]() {
            Voxel& v = ring[(head + count) & (kRing - 1)];
            if (!dda.next(v.cell, v.te, v.tx)) return;
            v.b0 = v.b1 = 0;
            prefetch(start + v.cell);
            ++count;
        };
        for (int k = 0; k < kWalkAhead; ++k) push();
        for (int k = 0; k < std::min(count, kRefsAhead); ++k) ring[k].b0 = start[ring[k].cell], ring[k].b1 = start[ring[k].cell + 1];
        while (count > 0) {
            // Stage 2 (kRefsAhead voxels ahead): the references; stage 3 (kRecordsAhead ahead): the records.
            if (count > kRefsAhead) {
                Voxel& v = ring[(head + kRefsAhead) & (kRing - 1)];
                v.b0 = start[v.cell];
                v.b1 = start[v.cell + 1];
                prefetch(refs + v.b0);
            }
            if (count > kRecordsAhead) {
                const Voxel& v = ring[(head + kRecordsAhead) & (kRing - 1)];
                const std::uint32_t e = std::min(v.b1, v.b0 + 8u);
                for (std::uint32_t j = v.b0; j < e; ++j) prefetch(ps + refs[j]);
            }
            const Voxel v = ring[head];
            head = (head + 1) & (kRing - 1);
            --count;
            push();
            if (v.b0 != v.b1 && v.tx >= v.te) {
                if (!visit(std::span<const std::uint32_t>(refs + v.b0, refs + v.b1), v.te, v.tx)) return false;
            }
        }
        return true;
    }

    /// Voxels the walk's DDA runs ahead of the visit, and the distances (in voxels) at which a
    /// voxel's references and particle records are prefetched (see walk_voxels): each link of
    /// the load chain gets two voxel visits of time.
    static constexpr int kWalkAhead = 7, kRefsAhead = 4, kRecordsAhead = 2;
    /// A read prefetch hint (no effect where the compiler has none).
    static void prefetch([[maybe_unused]] const void* p) noexcept {
#if defined(__GNUC__) || defined(__clang__)
        __builtin_prefetch(p, 0, 3);
#endif
    }

    const ParticleCloud* cloud_ = nullptr;
    std::array<int, 3> res_{1, 1, 1};
    Vec3<float> lo_{0.0f}, hi_{0.0f};
    std::array<float, 3> h_{1, 1, 1};
    float dilation_ = 0;
    bool prefetch_ = false;
    std::vector<std::uint32_t> start_, refs_;
};

}  // namespace grainlight
