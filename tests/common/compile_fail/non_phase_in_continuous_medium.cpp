// Must NOT compile: a type that is not a phase function used as ContinuousMedium's phase. The
// ctest entry passes only when the compiler's message names the unsatisfied concept
// (PhaseFunction), not on any error.
#include "grainlight/media/continuous.hpp"

struct NotAPhase {
    using Float = float;
    using Spectrum = grainlight::RGB;
    float eval(int) const { return 0.0f; }  // wrong signature; no sample, no mean_cosine
};

int main() {
    grainlight::ContinuousMedium<NotAPhase, grainlight::RGB> m(1.0f, 0.5f, NotAPhase{});
    (void)m;
}
