// Compiles against the names and paths of grainlight 0.1 that CHANGELOG.md lists as moved or
// renamed (kept for one release): forwarding headers, type aliases, deprecated overloads.
#include <grainlight/precompute/serialization.hpp>  // forwards to core/serialization.hpp
#include <grainlight/optics/lorenz_mie.hpp>
#include <grainlight/phase/mie.hpp>
#include <grainlight/precompute/scatterometer.hpp>
#include <grainlight/integrators/ept.hpp>
#include <grainlight/integrators/slab.hpp>
#include <grainlight/media/teleportation.hpp>

namespace old_names {

// Never called: the point is that it compiles.
[[maybe_unused]] double use_old_names() {
    using namespace grainlight;
    const GrainMaterial glass = GrainMaterial::make_dielectric(1.5);
    const ScatterometerGrain g = ScatterometerGrain::sphere(0.9, glass);
    const GrainExemplar e = GrainExemplar::sphere(0.9, glass);
    const auto phase = MiePhase<float>::from_mie({1.33, 0.0}, 5.0);
    bool refracted = false;
    double eta_rel = 1;
    const Vec3d w = sample_dielectric(Vec3d(0, 0, -1), Vec3d(0, 0, 1), 1.5, 0.5, refracted, eta_rel);
    const SlabProblem slab(SlabParams{});
    ByteWriter bw;
    bw.put(std::uint32_t(1));
    return g.radius() + e.radius() + double(phase.mean_cosine()[0]) + w.z + slab.params().albedo;
}

}  // namespace old_names
