// Must NOT compile: a scene over a medium that has sample_interaction but no transmittance. The
// ctest entry passes only when the compiler's message names the unsatisfied concept (Medium).
#include "grainlight/scene/scene.hpp"

struct NoTransmittance {
    using Float = float;
    using Spectrum = grainlight::RGB;
    grainlight::Interaction<float, grainlight::RGB> sample_interaction(const grainlight::Ray<float>&, float,
                                                                       grainlight::Rng&) const noexcept {
        return {};
    }
};

int main() {
    grainlight::Scene<NoTransmittance> s;
    (void)s;
}
