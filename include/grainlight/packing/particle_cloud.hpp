/// @file grainlight/packing/particle_cloud.hpp
/// A cloud of individually placed spherical particles (Guo21 Sec. 5: "we generate and store
/// N_tot particles with random positions and log-normal distributed radii"): uniform random
/// centres inside a shape (any geometry/voxelized_boundary.hpp BoundaryShape: BoxBoundary,
/// SphereBoundary, a closed MeshBoundary), radii drawn from a size distribution
/// (optics/psd.hpp SizeDistribution, sampled by inversion), and mixtures of several particle
/// species (each with its own PSD and number share; Guo21 Sec. 7 names mixtures as a limitation).
///
/// Storage: 16 bytes per particle (float centre + float radius), particles grouped by species
/// (species s owns indices [species_begin(s), species_begin(s + 1))). Positions are in scene
/// units; PSD radii are in micrometres and converted with `um_per_unit` (1e6: scene in metres).
/// generate() does not prevent overlaps (a Poisson/binomial cloud, as the paper's sparse media
/// assume); generate_non_overlapping() places the same kind of cloud by random sequential
/// addition (each centre redrawn until its sphere overlaps no earlier one): hard spheres, which
/// is what explicit-sphere path tracing (ExplicitSphereMedium) needs to be exact.
///
/// Determinism: the k-th particle drawn for species s uses Pcg32::from_key(seed, s, k): the same
/// cloud for a seed on any machine and thread count. The generators then store each species in
/// spatial (Morton) order (sort_spatially()), so index begin(s) + k is not the k-th draw. The
/// counts per species are round(share * N) (largest remainders), not random.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/aabb.hpp"
#include "grainlight/geometry/voxelized_boundary.hpp"
#include "grainlight/optics/psd.hpp"

namespace grainlight {

/// One particle: centre and radius in scene units (16 bytes).
struct CloudParticle {
    /// @var x
    /// Centre x [scene units].
    /// @var y
    /// Centre y [scene units].
    /// @var z
    /// Centre z [scene units].
    /// @var r
    /// Radius [scene units] (> 0).
    float x = 0, y = 0, z = 0, r = 0;
    /// The centre as a vector [scene units].
    [[nodiscard]] Vec3<float> center() const noexcept { return {x, y, z}; }
};
static_assert(sizeof(CloudParticle) == 16, "a cloud particle is 16 bytes");

/// One species of a mixture: a radius sampler u -> r [um] (inversion of its PSD) and its number
/// share (> 0; shares are normalized over the species).
struct CloudSpecies {
    /// Radius sampler: maps u in [0, 1) to a radius [um] (> 0, finite; checked at generation).
    std::function<double(double)> sample_radius_um;
    /// Number share of the species (> 0, finite; normalised over the species of a cloud).
    double share = 1.0;
    /// Optional name (reports and logs only).
    std::string name;
};

/// A species from any SizeDistribution (the PSD is copied into the sampler).
template <SizeDistribution Psd>
[[nodiscard]] CloudSpecies cloud_species(const Psd& psd, double share = 1.0, std::string name = "") {
    return {[psd](double u) { return double(psd.sample(u)); }, share, std::move(name)};
}
/// A monodisperse species (MonodispersePsd is not a density, so it has its own overload).
[[nodiscard]] inline CloudSpecies cloud_species(const MonodispersePsd& psd, double share = 1.0, std::string name = "") {
    const double r = psd.radius();
    return {[r](double) { return r; }, share, std::move(name)};
}

/// A cloud of spherical particles grouped by species (see the file comment): 16 bytes per
/// particle, positions and radii in scene units. Built by generate() or from_particles(), then
/// read-only (const members are safe to call from any number of threads).
class ParticleCloud {
public:
    ParticleCloud() = default;

    /// N particles uniformly inside `shape` (rejection sampling in shape.bounds()), species drawn
    /// by number share, radii from each species' sampler [um] divided by um_per_unit. Stored in
    /// spatial (Morton) order within each species: see sort_spatially().
    template <BoundaryShape Shape>
    static ParticleCloud generate(const Shape& shape, std::uint64_t count, const std::vector<CloudSpecies>& species,
                                  std::uint64_t seed, double um_per_unit = 1e6) {
        ParticleCloud c = generate_in_key_order(shape, count, species, seed, um_per_unit);
        c.sort_spatially();
        return c;
    }

    /// Reorder the particles of each species along a Morton (Z-order) curve over the domain
    /// (21 bits per axis), ties by the previous index: deterministic, and particles near in space
    /// are near in memory, so the grid's voxel lists (ParticleGrid) read the particle array almost
    /// sequentially instead of at random (cache misses on the particle loads were most of the
    /// cylinder queries' time at 1e6 particles). The set of particles, the species ranges and
    /// every physical result are unchanged; only indices (and so summation and member order) change.
    void sort_spatially() {
        if (particles_.size() < 2) return;
        const Vec3d lo = bounds_.lo, ext = bounds_.hi - bounds_.lo;
        auto spread = [](std::uint64_t v) {  // 21 bits -> every third bit of 63
            v &= 0x1fffffull;
            v = (v | v << 32) & 0x1f00000000ffffull;
            v = (v | v << 16) & 0x1f0000ff0000ffull;
            v = (v | v << 8) & 0x100f00f00f00f00full;
            v = (v | v << 4) & 0x10c30c30c30c30c3ull;
            v = (v | v << 2) & 0x1249249249249249ull;
            return v;
        };
        auto quant = [&](float x, int a) {
            const double t = ext[a] > 0 ? (double(x) - lo[a]) / ext[a] : 0.0;
            return std::uint64_t(std::clamp(t, 0.0, 1.0) * double((1u << 21) - 1));
        };
        std::vector<std::pair<std::uint64_t, std::uint32_t>> key(particles_.size());
        for (std::uint32_t i = 0; i < particles_.size(); ++i) {
            const CloudParticle& q = particles_[i];
            key[i] = {spread(quant(q.x, 0)) | spread(quant(q.y, 1)) << 1 | spread(quant(q.z, 2)) << 2, i};
        }
        for (std::size_t s = 0; s + 1 < begin_.size(); ++s) std::sort(key.begin() + begin_[s], key.begin() + begin_[s + 1]);
        std::vector<CloudParticle> sorted(particles_.size());
        for (std::size_t i = 0; i < key.size(); ++i) sorted[i] = particles_[key[i].second];
        particles_ = std::move(sorted);
    }

private:
    template <BoundaryShape Shape>
    static ParticleCloud generate_in_key_order(const Shape& shape, std::uint64_t count, const std::vector<CloudSpecies>& species,
                                               std::uint64_t seed, double um_per_unit) {
        const char* who = "ParticleCloud::generate";
        check_argument(count >= 1, who, "count", count, ">= 1 (an empty cloud has no medium)");
        check_argument(count < (std::uint64_t(1) << 32) - 1, who, "count", count, "< 2^32 - 1");
        check_argument(!species.empty(), who, "species.size()", species.size(), ">= 1");
        check_argument(std::isfinite(um_per_unit) && um_per_unit > 0, who, "um_per_unit", um_per_unit, "> 0 (finite)");
        double total_share = 0;
        for (std::size_t s = 0; s < species.size(); ++s) {
            check_argument(std::isfinite(species[s].share) && species[s].share > 0, who,
                           "species[" + std::to_string(s) + "].share", species[s].share, "> 0 (finite)");
            check_argument(bool(species[s].sample_radius_um), who, "species[" + std::to_string(s) + "].sample_radius_um",
                           "empty", "a radius sampler");
            total_share += species[s].share;
        }
        const Aabb<double> b = shape.bounds();
        const Vec3d lo = b.lo, ext = b.hi - b.lo;
        for (int a = 0; a < 3; ++a)
            check_argument(std::isfinite(ext[a]) && ext[a] > 0, who, "shape.bounds() extent", ext[a], "(0, inf)");

        // Counts per species by largest remainders.
        std::vector<std::uint64_t> n(species.size());
        std::vector<std::pair<double, std::size_t>> rem;
        std::uint64_t assigned = 0;
        for (std::size_t s = 0; s < species.size(); ++s) {
            const double want = double(count) * species[s].share / total_share;
            n[s] = std::uint64_t(std::floor(want));
            assigned += n[s];
            rem.push_back({want - double(n[s]), s});
        }
        std::sort(rem.begin(), rem.end(), [](auto& a, auto& c) { return a.first > c.first || (a.first == c.first && a.second < c.second); });
        for (std::size_t k = 0; assigned < count; ++k, ++assigned) ++n[rem[k % rem.size()].second];

        ParticleCloud c;
        c.particles_.reserve(count);
        c.begin_.push_back(0);
        c.um_per_unit_ = um_per_unit;
        std::uint64_t tries = 0;
        for (std::size_t s = 0; s < species.size(); ++s) {
            for (std::uint64_t i = 0; i < n[s]; ++i) {
                Rng rng = Rng::from_key(seed, std::uint64_t(s), i);
                Vec3d p;
                for (int k = 0;; ++k) {
                    ++tries;
                    p = lo + rng.uniform3<double>() * ext;
                    if (shape.inside(p)) break;
                    check_argument(k < 100000, who, "shape", "no point inside after 1e5 tries", "a shape with volume");
                }
                const double r_um = species[s].sample_radius_um(rng.uniform<double>());
                check_argument(std::isfinite(r_um) && r_um > 0, who, "species[" + std::to_string(s) + "] radius_um", r_um,
                               "> 0 (finite)");
                c.particles_.push_back({float(p.x), float(p.y), float(p.z), float(r_um / um_per_unit)});
                c.r_max_ = std::max(c.r_max_, double(float(r_um / um_per_unit)));
            }
            c.begin_.push_back(std::uint32_t(c.particles_.size()));
        }
        c.volume_ = ext.x * ext.y * ext.z * double(count) / double(tries);
        if constexpr (std::is_same_v<Shape, BoxBoundary>) c.volume_ = ext.x * ext.y * ext.z;
        if constexpr (std::is_same_v<Shape, SphereBoundary>) c.volume_ = 4.0 / 3.0 * pi_v<double> * std::pow(shape.radius, 3);
        c.bounds_ = b;
        return c;
    }

public:
    /// Like generate(), but no two spheres overlap: random sequential addition in index order
    /// (species by species); particle i of species s draws its radius and then centres from
    /// Pcg32::from_key(seed, s, i) until its sphere is disjoint from every earlier one (a hash
    /// grid of cells >= 2 r_max). Deterministic for a seed. Throws grainlight::invalid_argument
    /// naming `count` when a particle finds no free place in `max_tries` draws (the packing is
    /// near RSA's jamming limit, ~38 % by volume for equal spheres). The placed cloud is then
    /// stored in spatial order, as generate()'s (sort_spatially()).
    template <BoundaryShape Shape>
    static ParticleCloud generate_non_overlapping(const Shape& shape, std::uint64_t count,
                                                  const std::vector<CloudSpecies>& species, std::uint64_t seed,
                                                  double um_per_unit = 1e6, int max_tries = 100000) {
        const char* who = "ParticleCloud::generate_non_overlapping";
        check_argument(max_tries >= 1, who, "max_tries", max_tries, ">= 1");
        // The Poisson cloud gives the validated counts, radii (same keys) and domain.
        ParticleCloud c = generate_in_key_order(shape, count, species, seed, um_per_unit);
        const Aabb<double> b = shape.bounds();
        const Vec3d lo = b.lo, ext = b.hi - b.lo;
        const double h = std::max(2 * c.r_max_, std::cbrt(ext.x * ext.y * ext.z / double(count)));
        std::array<std::int64_t, 3> res{};
        for (int a = 0; a < 3; ++a) res[std::size_t(a)] = std::max<std::int64_t>(1, std::int64_t(std::ceil(ext[a] / h)));
        check_argument(double(res[0]) * double(res[1]) * double(res[2]) < 4e9, who, "count", count,
                       "a cloud whose hash grid fits in memory");
        std::vector<std::int32_t> head(std::size_t(res[0] * res[1] * res[2]), -1), next(std::size_t(count), -1);
        auto cell = [&](const Vec3d& p, int a) {
            return std::clamp<std::int64_t>(std::int64_t(std::floor((p[a] - lo[a]) / h)), 0, res[std::size_t(a)] - 1);
        };
        for (std::size_t s = 0; s < species.size(); ++s) {
            for (std::uint32_t i = c.begin_[s], k = 0; i < c.begin_[s + 1]; ++i, ++k) {
                Rng rng = Rng::from_key(seed ^ 0x9e3779b97f4a7c15ull, std::uint64_t(s), k);
                const double r = double(c.particles_[i].r);
                Vec3d p;
                for (int t = 0;; ++t) {
                    check_argument(t < max_tries, who, "count", count,
                                   "fewer particles: no free place for particle " + std::to_string(i) + " after " +
                                       std::to_string(max_tries) + " draws (random sequential addition is jammed)");
                    // Rounded to the stored float centre first, so the test holds for what is stored.
                    p = Vec3d(Vec3<float>(lo + rng.uniform3<double>() * ext));
                    if (!shape.inside(p)) continue;
                    const std::int64_t cx = cell(p, 0), cy = cell(p, 1), cz = cell(p, 2);
                    bool free = true;
                    for (std::int64_t z = std::max<std::int64_t>(cz - 1, 0); free && z <= std::min(cz + 1, res[2] - 1); ++z)
                        for (std::int64_t y = std::max<std::int64_t>(cy - 1, 0); free && y <= std::min(cy + 1, res[1] - 1); ++y)
                            for (std::int64_t x = std::max<std::int64_t>(cx - 1, 0); free && x <= std::min(cx + 1, res[0] - 1); ++x)
                                for (std::int32_t j = head[std::size_t((z * res[1] + y) * res[0] + x)]; j >= 0; j = next[std::size_t(j)]) {
                                    const CloudParticle& q = c.particles_[std::size_t(j)];
                                    const Vec3d v = Vec3d(q.x, q.y, q.z) - p;
                                    const double R = r + double(q.r);
                                    if (glm::dot(v, v) < R * R) {
                                        free = false;
                                        break;
                                    }
                                }
                    if (free) break;
                }
                c.particles_[i].x = float(p.x);
                c.particles_[i].y = float(p.y);
                c.particles_[i].z = float(p.z);
                const std::size_t ci = std::size_t((cell(p, 2) * res[1] + cell(p, 1)) * res[0] + cell(p, 0));
                next[i] = head[ci];
                head[ci] = std::int32_t(i);
            }
        }
        c.sort_spatially();
        return c;
    }

    /// Build from explicit particles (one species). Radii must be > 0 and finite.
    static ParticleCloud from_particles(std::vector<CloudParticle> ps, const Aabb<double>& domain, double volume,
                                        double um_per_unit = 1e6) {
        const char* who = "ParticleCloud::from_particles";
        check_argument(!ps.empty(), who, "particles.size()", ps.size(), ">= 1 (an empty cloud has no medium)");
        check_argument(std::isfinite(volume) && volume > 0, who, "volume", volume, "> 0 (finite)");
        ParticleCloud c;
        for (std::size_t i = 0; i < ps.size(); ++i) {
            check_argument(std::isfinite(ps[i].r) && ps[i].r > 0, who, "particles[" + std::to_string(i) + "].r", ps[i].r,
                           "> 0 (finite)");
            check_argument(std::isfinite(ps[i].x + ps[i].y + ps[i].z), who, "particles[" + std::to_string(i) + "] centre",
                           ps[i].x + ps[i].y + ps[i].z, "finite");
            c.r_max_ = std::max(c.r_max_, double(ps[i].r));
        }
        c.begin_ = {0, std::uint32_t(ps.size())};
        c.particles_ = std::move(ps);
        c.bounds_ = domain;
        c.volume_ = volume;
        c.um_per_unit_ = um_per_unit;
        return c;
    }

    /// Number of particles.
    [[nodiscard]] std::size_t size() const noexcept { return particles_.size(); }
    /// Particle i (< size(); not checked).
    [[nodiscard]] const CloudParticle& operator[](std::size_t i) const noexcept { return particles_[i]; }
    /// All particles, grouped by species.
    [[nodiscard]] const std::vector<CloudParticle>& particles() const noexcept { return particles_; }
    /// Number of species (0 for a default-constructed cloud).
    [[nodiscard]] std::size_t species_count() const noexcept { return begin_.empty() ? 0 : begin_.size() - 1; }
    /// First particle index of species s, for s in [0, species_count()] (s = species_count() gives size()).
    [[nodiscard]] std::uint32_t species_begin(std::size_t s) const noexcept { return begin_[s]; }
    /// Species of particle i (binary search over the few species ranges).
    [[nodiscard]] std::size_t species_of(std::uint32_t i) const noexcept {
        return std::size_t(std::upper_bound(begin_.begin() + 1, begin_.end(), i) - (begin_.begin() + 1));
    }
    /// Largest radius [scene units].
    [[nodiscard]] double max_radius() const noexcept { return r_max_; }
    /// Volume of the domain the centres fill [scene units^3] (exact for a box or sphere, else by
    /// the rejection rate).
    [[nodiscard]] double volume() const noexcept { return volume_; }
    /// Bounding box of the domain the centres fill [scene units] (the shape's bounds, or as given).
    [[nodiscard]] const Aabb<double>& domain() const noexcept { return bounds_; }
    /// Micrometres per scene unit (1e6: scene in metres), used to convert PSD radii.
    [[nodiscard]] double um_per_unit() const noexcept { return um_per_unit_; }
    /// Bytes held by the particle array.
    [[nodiscard]] std::size_t memory_bytes() const noexcept { return particles_.capacity() * sizeof(CloudParticle); }

private:
    std::vector<CloudParticle> particles_;
    std::vector<std::uint32_t> begin_;
    double r_max_ = 0, volume_ = 0, um_per_unit_ = 1e6;
    Aabb<double> bounds_;
};

}  // namespace grainlight
