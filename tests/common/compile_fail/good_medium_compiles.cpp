// Must compile: the control for the compile-fail entries (the same includes and a valid use), so
// that a broken include path cannot make the compile-fail entries pass.
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/scene.hpp"

int main() {
    using CM = grainlight::ContinuousMedium<grainlight::HenyeyGreenstein<float, grainlight::RGB>, grainlight::RGB>;
    grainlight::Scene<CM> s;
    s.add_medium(CM(1.0f, 0.5f, grainlight::HenyeyGreenstein<float, grainlight::RGB>(0.3f)));
    return int(s.medium_count()) - 1;
}
