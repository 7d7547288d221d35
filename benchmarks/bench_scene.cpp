// Scene and transport throughput: BVH ray-triangle queries through a scene mesh, camera paths of
// the volumetric path tracer (paths/s), slab photon walks (paths/s). Items/s are rays or paths.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "grainlight/integrators/vpt.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/integrators/slab.hpp"

namespace gl = grainlight;

namespace {

using Phase = gl::HenyeyGreenstein<float, gl::RGB>;
using MediumT = gl::ContinuousMedium<Phase, gl::RGB>;
using SceneT = gl::Scene<MediumT>;

// A UV sphere of radius 1 with `rings` x `segments` quads (2 triangles each), outward winding.
gl::TriangleMesh<float> uv_sphere(int rings, int segments) {
    gl::TriangleMesh<float> m;
    for (int i = 0; i <= rings; ++i) {
        const float th = float(M_PI) * float(i) / float(rings);
        for (int j = 0; j < segments; ++j) {
            const float ph = 2.0f * float(M_PI) * float(j) / float(segments);
            m.vertices.emplace_back(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
        }
    }
    auto id = [segments](int i, int j) { return std::uint32_t(i * segments + (j % segments)); };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            if (i > 0) m.triangles.push_back({id(i, j), id(i + 1, j), id(i, j + 1)});
            if (i + 1 < rings) m.triangles.push_back({id(i, j + 1), id(i + 1, j), id(i + 1, j + 1)});
        }
    m.compute_face_normals();
    return m;
}

void BM_MeshClosestHit(benchmark::State& state) {
    const int rings = int(state.range(0));
    const gl::MeshShape<float> mesh(uv_sphere(rings, 2 * rings));
    std::vector<gl::Ray<float>> rays;
    gl::Rng rng = gl::Rng::from_key(1);
    for (int i = 0; i < 4096; ++i) {
        const gl::Vec3f o = 3.0f * gl::sample_uniform_sphere(rng.uniform2<float>());
        const gl::Vec3f t = 0.8f * gl::sample_uniform_sphere(rng.uniform2<float>());
        rays.emplace_back(o, glm::normalize(t - o));
    }
    std::size_t k = 0;
    int hits = 0;
    for (auto _ : state) {
        float t;
        gl::Vec3f n;
        hits += mesh.intersect(rays[k++ & 4095], t, n) ? 1 : 0;
    }
    benchmark::DoNotOptimize(hits);
    state.SetItemsProcessed(state.iterations());
    state.counters["triangles"] = double(mesh.bvh->triangle_count());
}
BENCHMARK(BM_MeshClosestHit)->Arg(32)->Arg(128)->Arg(512);

SceneT bench_scene() {
    SceneT s;
    const int m = s.add_medium(MediumT(gl::RGB{3.0f, 3.3f, 3.8f}, gl::RGB{0.95f, 0.97f, 0.99f}, Phase(0.5f)));
    s.add_shape(gl::QuadShape<float>(gl::Vec3f(-6, 0, -6), gl::Vec3f(0, 0, 12), gl::Vec3f(12, 0, 0)),
                gl::Material<float, gl::RGB>::diffuse(gl::RGB{0.55f, 0.5f, 0.45f}));
    s.add_shape(gl::SphereShape<float>(gl::Vec3f(0, 1, 0), 1.0f), gl::Material<float, gl::RGB>::dielectric(1.33f), m, -1);
    s.add_shape(gl::SphereShape<float>(gl::Vec3f(2.2f, 0.6f, 0.3f), 0.6f), gl::Material<float, gl::RGB>::index_matched(),
                m, -1);
    s.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-4.0f, 4.5f, -2.0f), gl::Vec3f(4, 0, 0), gl::Vec3f(0, 0, 4)),
                     gl::RGB{3.2f, 3.0f, 2.7f});
    s.add_light(SceneT::LightT::environment_light(gl::RGB{0.12f, 0.15f, 0.2f}));
    return s;
}

// Camera paths of the VPT through the example scene (one path per item, NEE on or off).
void BM_VptCameraPaths(benchmark::State& state) {
    const SceneT scene = bench_scene();
    const gl::PinholeCamera<float> cam(gl::Vec3f(0, 2.2f, 6.0f), gl::Vec3f(0, 0.9f, 0), gl::Vec3f(0, 1, 0), 35.0f, 64, 48);
    gl::VptOptions opt;
    opt.nee = state.range(0) != 0;
    std::uint64_t i = 0;
    float acc = 0;
    for (auto _ : state) {
        gl::Rng rng = gl::Rng::from_key(7, i);
        const int px = int(i % 64), py = int((i / 64) % 48);
        ++i;
        acc += gl::vpt_radiance(scene, cam.generate_ray(float(px) + 0.5f, float(py) + 0.5f), -1, rng, opt)[0];
    }
    benchmark::DoNotOptimize(acc);
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_VptCameraPaths)->Arg(1)->Arg(0);

// Photon walks of the slab estimator (index-matched and n = 1.5, a = 0.9, b = 4, g = 0.7).
void BM_SlabPaths(benchmark::State& state) {
    gl::SlabParams p;
    p.albedo = 0.9;
    p.optical_depth = 4.0;
    p.g = 0.7;
    p.ior = state.range(0) == 0 ? 1.0 : 1.5;
    const gl::SlabProblem problem(p);
    std::uint64_t first = 0;
    double r = 0;
    for (auto _ : state) {
        r += problem.run(first, 64, 3).R.mean();
        first += 64;
    }
    benchmark::DoNotOptimize(r);
    state.SetItemsProcessed(state.iterations() * 64);
}
BENCHMARK(BM_SlabPaths)->Arg(0)->Arg(1);

}  // namespace
