// meng15_fig5_shape_of_grains: Meng15 Fig. 5 -- a procedural aggregate shape filled with
// millions of grains, none of them stored: a sphere and a box, or a lumpy triangle-mesh blob
// (voxelized on the tile grid, 2 bits per voxel) filled from a tiled MD packing with randomly rotated cube-like (crystal) or snow
// grains, rendered with explicit path tracing (integrators/ept.hpp) on a diffuse ground under a
// quad light and a dim sky. Low-order (<= k grain interactions) and high-order contributions go
// to separate images.
//
//   meng15_fig5_shape_of_grains [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                               [--grain cube|snow] [--shape sphere-box|blob] [--grain-radius R]
//                               [--spp N] [--exposure EV]
//
// Prints the grain count, the aggregate's memory (vs. what explicit per-grain transforms and a
// BVH over instances would need) and the Algorithm 1 ray rate. Writes EXR (combined, low, high)
// and a PNG preview; last line JSON.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <type_traits>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl = grainlight;
using namespace gl_examples;

int main(int argc, char** argv) {
    return run(argc, argv, "meng15_fig5_shape_of_grains",
               "Meng15 Fig. 5: a sphere and a box filled with millions of procedurally instanced grains (EPT)",
               "out/meng15_fig5_shape_of_grains", [&](Example& app) -> int {
        const std::string grain = app.opt<std::string>("grain", "cube", "cube | snow");
        const std::string shape_name = app.opt<std::string>(
            "shape", "sphere-box", "sphere-box (a sphere and a box) | blob (a lumpy triangle-mesh blob)");
        const double r_grain = app.opt<double>(
            "grain-radius", 0.004, "bounding-sphere radius of the grains (scene units; the sphere has radius 0.5)");
        const std::uint64_t spp = app.opt<std::uint64_t>("spp", 8, 64, "samples per pixel");
        const double exposure = app.opt<double>("exposure", 1.0, "PNG exposure in stops");
        app.checkpointable();  // --checkpoint SECONDS / --resume
        app.ready();
        const bool full = app.full();
        const auto& out = app.out();
        const int threads = app.threads();
        const std::uint64_t seed = app.seed();
        if (grain != "cube" && grain != "snow") throw cli_error("--grain = '" + grain + "' must be cube or snow");
        if (!(r_grain >= 2e-4 && r_grain <= 0.05)) throw cli_error("--grain-radius must be in [2e-4, 0.05]");
        if (spp < 1 || spp > 65536) throw cli_error("--spp must be in [1, 65536]");
        const int width = full ? 640 : 320, height = full ? 400 : 200;

        // Tile: MD packing at f = 0.6, scaled to the grain radius.
        const auto packed = gl::md_pack(full ? 1000 : 300, 0.6, seed);
        const double s = r_grain / packed.tile.radius();
        std::vector<gl::Vec3d> centers = packed.tile.centers();
        for (auto& c : centers) c *= s;
        gl::PeriodicTile tile(packed.tile.side() * s, r_grain, std::move(centers));

        // Grains: cube-like crystals (brown sugar: absorbing) or snow (lossless ice), Meng15 presets.
        std::vector<gl::GrainExemplar> ex;
        std::vector<double> w;
        if (grain == "cube") {
            gl::GrainPreset a = gl::grain_preset("brown-sugar"), b = gl::grain_preset("sugar");
            ex.push_back(gl::GrainExemplar::from_preset(a, 3));
            b.material = gl::GrainMaterial::make_absorbing_dielectric(1.56, gl::RGBd{0.05, 0.08, 0.15});
            ex.push_back(gl::GrainExemplar::from_preset(b, 3));
            w = {0.5, 0.5};
        } else {
            for (std::uint64_t k = 0; k < 3; ++k) {
                gl::GrainPreset p = gl::grain_preset("snow");
                p.seed = 7 + 2 * k;  // three different snow grains
                p.material = gl::GrainMaterial::make_absorbing_dielectric(1.31, gl::RGBd{0.02, 0.01, 0.005});
                ex.push_back(gl::GrainExemplar::from_preset(p, 3));
            }
            w = {1, 1, 1};
        }
        if (shape_name != "sphere-box" && shape_name != "blob")
            throw cli_error("--shape = '" + shape_name + "' must be sphere-box or blob");
        auto render = [&](const auto& shape) {
            const auto t_build0 = std::chrono::steady_clock::now();
            using Shape = std::decay_t<decltype(shape)>;
            gl::GranularAggregate<Shape> agg(tile, gl::VoxelizedBoundary<Shape>(shape, tile.side()), ex, w, seed);
            const std::uint64_t n_grains = agg.grain_count();
            const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_build0).count();
            const double mem_mb = double(agg.memory_bytes()) / 1e6;
            // Explicit instancing: a 3x4 float transform + exemplar id per grain, plus a BVH over them (~2 nodes
            // of 32 bytes per instance).
            const double explicit_mb = double(n_grains) * (48.0 + 4.0 + 64.0) / 1e6;

            using Medium = gl::ContinuousMedium<gl::HenyeyGreenstein<float, gl::RGB>, gl::RGB>;
            using Scene = gl::Scene<Medium>;
            Scene scene;
            scene.add_shape(gl::QuadShape<float>(gl::Vec3f(-4, 0, -4), gl::Vec3f(0, 0, 8), gl::Vec3f(8, 0, 0)),
                            gl::Material<float, gl::RGB>::diffuse(gl::RGB{0.45f, 0.42f, 0.4f}));
            scene.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-1.5f, 3.0f, 0.5f), gl::Vec3f(1.5f, 0, 0), gl::Vec3f(0, 0, 1.5f)),
                                 gl::RGB{9.0f, 8.6f, 8.0f});
            scene.add_light(Scene::LightT::environment_light(gl::RGB{0.10f, 0.12f, 0.16f}));
            const gl::PinholeCamera<float> camera(gl::Vec3f(0.2f, 1.25f, 3.0f), gl::Vec3f(0.2f, 0.35f, 0.0f), gl::Vec3f(0, 1, 0),
                                                  32.0f, width, height);
            gl::EptOptions opt;
            opt.max_events = full ? 4096 : 512;
            auto bar = app.progress("fig5", std::uint64_t(height));
            const auto t0 = std::chrono::steady_clock::now();
            // This rank's rows (y % ranks == rank) and checkpoint; rank 0 assembles the rows.
            gl::EptImages img = gl::render_ept(scene, agg, camera, render_options(app, int(spp), "render"), opt,
                                               [&](int n) { bar.advance(std::uint64_t(n)); });
            bar.done();
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const double local_rays = double(img.grain_rays);  // rays per second: rank 0's
            img.low = app.mpi().gather_film_rows(img.low);
            img.high = app.mpi().gather_film_rows(img.high);
            if (!app.root()) {
                app.finish({});
                return;
            }
            const gl::Image all = img.combined();
            gl::write_exr(out / "meng15_fig5_shape_of_grains.exr", all);
            gl::write_exr(out / "meng15_fig5_low_order.exr", img.low.image());
            gl::write_exr(out / "meng15_fig5_high_order.exr", img.high.image());
            gl::write_png(out / "meng15_fig5_shape_of_grains.png", all, {exposure});
            gl::write_png(out / "meng15_fig5_low_order.png", img.low.image(), {exposure});
            gl::write_png(out / "meng15_fig5_high_order.png", img.high.image(), {exposure});
            const double rays_per_s = local_rays / seconds;
            std::printf("Meng15 Fig. 5: %s of %s grains\n", shape_name.c_str(), grain.c_str());
            std::printf("  grains: %llu (bounding radius %.4g, tile of %zu spheres, f = %.3f, %zu voxels of which %zu inside, "
                        "%zu partial)\n",
                        (unsigned long long)n_grains, r_grain, tile.size(), tile.packing_fraction(),
                        agg.boundary().voxel_count(), agg.boundary().inside_count(), agg.boundary().partial_count());
            std::printf("  memory: %.3f MB for the aggregate (voxels %.1f kB at 2 bits each) vs ~%.0f MB for explicit instances "
                        "+ BVH (paper: 'storing the transformation matrices ... impractical')\n",
                        mem_mb, double(agg.boundary().memory_bytes()) / 1e3, explicit_mb);
            std::printf("  render: %dx%d, %llu spp, %.1f s on %d threads, %.3g Algorithm-1 rays/s (camera + shadow rays), setup %.2f s\n",
                        width, height, (unsigned long long)spp, seconds, threads, rays_per_s, build_s);
            std::printf("  low-order (<= %d grain interactions) mean %.4f, high-order mean %.4f (green channel)\n",
                        opt.low_order_max, img.low.image().mean(1), img.high.image().mean(1));
            std::printf("wrote %s/meng15_fig5_{shape_of_grains,low_order,high_order}.{exr,png}\n", out.c_str());
            Json j = app.summary();
            j.integer("grains", (long long)n_grains)
                .num("memory_mb", mem_mb)
                .num("explicit_memory_mb", explicit_mb)
                .num("rays_per_second", rays_per_s)
                .num("seconds", seconds)
                .integer("spp", (long long)spp)
                .str("rank_rows", "rank r renders the rows y with y % ranks == r (timings: rank 0's)")
                .nums("rank_row_counts", app.mpi().row_counts(height));
            Example::nonfinite(j, img.low.nonfinite_samples() + img.high.nonfinite_samples());
            app.finish(j);
        };
        if (shape_name == "blob") {
            // A lumpy, bunny-sized blob: the procedural snow shape scaled to radius 0.6, as a
            // watertight triangle mesh boundary (voxelized by triangle rasterization + parity).
            gl::TriangleMesh<float> blob = gl::make_grain_mesh<float>(gl::GrainShape::snow, 0.6f, 5, 3);
            for (auto& v : blob.vertices) v += gl::Vec3f(0.2f, 0.55f, 0.0f);
            blob.compute_face_normals();
            render(gl::MeshBoundary(blob));
        } else {
            using U = gl::UnionBoundary<gl::SphereBoundary, gl::BoxBoundary>;
            render(U{gl::SphereBoundary(gl::Vec3d(-0.6, 0.5, 0.0), 0.5),
                     gl::BoxBoundary(gl::Vec3d(0.05, 0.0, -0.35), gl::Vec3d(1.0, 0.7, 0.35))});
        }
        return 0;
    });
}
