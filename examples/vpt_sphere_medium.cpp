// vpt_sphere_medium: a sphere of scattering medium inside a smooth dielectric boundary, resting on
// a diffuse ground under a quad area light (plus a dim constant sky), rendered with the library's
// volumetric path tracer (integrators/vpt.hpp on the walk kernel) and written as EXR (float RGB)
// and an sRGB PNG preview. On the example harness (examples/common/harness.hpp).
//
//   vpt_sphere_medium [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                     [--ior N] [--exposure EV] [--checkpoint SECONDS] [--resume]
//   mpirun -np K vpt_sphere_medium ...      (built with MPI: rank r renders rows y % K == r)
//
// Prints one JSON summary line (the last line of stdout): image size, spp, mean RGB, seconds,
// camera paths per second, the number of non-finite samples (counted, replaced by zero), the
// ranks and their rows, and the output files. Progress goes to stderr. With --checkpoint the
// render's state is written to DIR/vpt_sphere_medium.render.checkpoint every SECONDS; --resume
// continues a killed run from it, and the resumed image is byte-identical to an uninterrupted
// run with the same arguments.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/film_checkpoint.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl = grainlight;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "vpt_sphere_medium", "render a dielectric sphere of scattering medium on a diffuse ground (EXR + PNG)",
        "out/vpt_sphere_medium", [&](gl_examples::Example& ex) {
            const auto spp = ex.opt<std::uint64_t>("spp", 64, 1024, "samples per pixel");
            const float ior = float(ex.opt<double>("ior", 1.33, "relative index of the sphere's boundary (1 = index-matched)"));
            const double exposure = ex.opt<double>("exposure", 0.0, "PNG preview exposure in stops");
            ex.checkpointable();
            ex.ready();
            if (spp < 1 || spp > (1u << 20))
                throw gl_examples::cli_error("--spp = " + std::to_string(spp) + " must be in [1, 2^20]");
            const int width = ex.full() ? 640 : 320, height = ex.full() ? 480 : 240;

            using Phase = gl::HenyeyGreenstein<float, gl::RGB>;
            using Medium = gl::ContinuousMedium<Phase, gl::RGB>;
            using Scene = gl::Scene<Medium>;
            Scene scene;
            // A milky, slightly blue medium: optical radius 3-3.8 per channel (near-grey sigma_t keeps
            // the spectral free-flight weights near 1), blue-favouring albedo, g = 0.5.
            const int milk = scene.add_medium(Medium(gl::RGB{3.0f, 3.3f, 3.8f}, gl::RGB{0.95f, 0.97f, 0.99f}, Phase(0.5f)));
            scene.add_shape(gl::QuadShape<float>(gl::Vec3f(-6, 0, -6), gl::Vec3f(0, 0, 12), gl::Vec3f(12, 0, 0)),
                            gl::Material<float, gl::RGB>::diffuse(gl::RGB{0.55f, 0.5f, 0.45f}));
            scene.add_shape(gl::SphereShape<float>(gl::Vec3f(0, 1, 0), 1.0f), gl::Material<float, gl::RGB>::dielectric(ior),
                            milk, -1);
            // Quad light above and to the left, facing down; dim sky. A large soft light: paths
            // inside the dielectric reach it only by refraction (no shadow connection through a
            // dielectric), so a large emitter keeps that noise down.
            scene.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-4.0f, 4.5f, -2.0f), gl::Vec3f(4, 0, 0), gl::Vec3f(0, 0, 4)),
                                 gl::RGB{3.2f, 3.0f, 2.7f});
            scene.add_light(Scene::LightT::environment_light(gl::RGB{0.12f, 0.15f, 0.2f}));
            const gl::PinholeCamera<float> camera(gl::Vec3f(0, 2.2f, 6.0f), gl::Vec3f(0, 0.9f, 0), gl::Vec3f(0, 1, 0), 35.0f,
                                                  width, height);

            // Seed, threads, this rank's rows and the checkpoint come from the harness.
            gl::RenderOptions opt = gl_examples::render_options(ex, int(spp), "render");
            opt.vpt.max_depth = 512;
            const int resumed_rows = opt.checkpoint.resume && std::filesystem::exists(opt.checkpoint.path)
                                         ? gl::FilmCheckpoint::load(opt.checkpoint.path).rows_finished()
                                         : 0;
            auto bar = ex.progress("vpt_sphere_medium", std::uint64_t(height));
            const auto t0 = std::chrono::steady_clock::now();
            const gl::Film local = gl::render_vpt(scene, camera, opt, [&](int n) { bar.advance(std::uint64_t(n)); });
            const gl::Film film = ex.mpi().gather_film_rows(local);  // rank 0: every rank's rows
            bar.done();
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (!ex.root()) return ex.finish({});

            const gl::Image img = film.image();
            const auto exr = ex.out() / "vpt_sphere_medium.exr";
            const auto png = ex.out() / "vpt_sphere_medium.png";
            gl::write_exr(exr, img);
            gl::write_png(png, img, {exposure});
            const double paths = double(width) * double(height) * double(spp);
            auto j = ex.summary();
            j.integer("width", width)
                .integer("height", height)
                .integer("spp", (long long)spp)
                .num("ior", ior)
                .nums("mean_rgb", {img.mean(0), img.mean(1), img.mean(2)})
                .num("seconds", seconds)
                .num("paths_per_second", paths / seconds)
                .str("rank_rows", "rank r renders the rows y with y % ranks == r")
                .nums("rank_row_counts", ex.mpi().row_counts(height))
                .integer("resumed_rows", resumed_rows)
                .str("exr", exr.string())
                .str("png", png.string());
            gl_examples::Example::nonfinite(j, film.nonfinite_samples());
            return ex.finish(j);
        });
}
