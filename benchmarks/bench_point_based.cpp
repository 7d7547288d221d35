// Wang18 point-based rendering: octree build (items/s), Alg. 1 tree cuts (cuts/s, with the cut
// size as a counter), camera rays through the point-based renderer by component (rays/s), and
// the multiple-scattering table precomputation (photons/s), and Sec. 3.4.2's photons: their walk
// through a room to the object (photons/s) and their assignment to the nearest light surface
// sample (the grid against a brute-force scan written here as the baseline).
#include <benchmark/benchmark.h>

#include <vector>

#include "grainlight/integrators/point_based.hpp"
#include "grainlight/integrators/point_based_environment.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/precompute/ms_table.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl = grainlight;

namespace {
using Phase = gl::HenyeyGreenstein<float, gl::RGB>;
using Medium = gl::ContinuousMedium<Phase, gl::RGB>;
using Renderer = gl::PointBasedRenderer<Phase, gl::SphereShape<float>>;

// The example's material (Wang18 Table 2 "BmpS.", mean free path / 10) in a unit glass sphere.
Medium medium() { return Medium(gl::RGB{2.2f, 3.1f, 4.6f}, gl::RGB{0.9545f, 0.6774f, 0.4565f}, Phase(0.7f)); }
const gl::SphereShape<float> kSphere(gl::Vec3f(0.0f), 1.0f);
const gl::QuadShape<float> kQuad(gl::Vec3f(-2.0f, 2.5f, -2.5f), gl::Vec3f(4, 0, 0), gl::Vec3f(0, 0, 4));

const gl::MsTable<3>& table() {
    static const gl::MsTable<3> t = [] {
        gl::MsTableOptions o;
        o.n_rho = 24;
        o.n_z = 48;
        o.n_theta = 12;
        o.n_phi = 6;
        o.rho_max = 10;
        o.z_min = -10;
        o.z_max = 10;
        o.photons = 50000;
        return gl::MsTable<3>::build(Phase(0.7f), gl::RGB{0.9545f, 0.6774f, 0.4565f}, o);
    }();
    return t;
}

Renderer make_renderer(float eps1, std::uint32_t two_step) {
    gl::PointBasedOptions<float> po;
    po.light_samples = 4;
    po.volume_step = 0.05f;
    po.k_max = 8;
    po.cut.eps1 = eps1;
    po.cut.eps2 = eps1 / 5;
    po.two_step_depth = two_step;
    gl::Rng rng = gl::Rng::from_key(1);
    return Renderer(medium(), 1.33f, kSphere, gl::sphere_surface_samples(kSphere, 6000),
                    gl::Light<float, gl::RGB>::quad_light(kQuad, gl::RGB(4.0f)), po, rng, &table());
}
const Renderer& renderer() {
    static const Renderer r = make_renderer(0.5f, 0);
    return r;
}
}  // namespace

// Octree build over state.range(0) clustered items. items = samples inserted.
static void BM_OctreeBuild(benchmark::State& state) {
    const auto n = std::size_t(state.range(0));
    std::vector<gl::OctreeItem<float, gl::RGB>> items(n);
    gl::Rng rng = gl::Rng::from_key(3);
    for (std::size_t i = 0; i < n; ++i) {
        const float s = (i % 2) ? 0.1f : 1.0f;
        items[i].p = rng.uniform3<float>() * s;
        items[i].w = gl::RGB(1.0f);
        items[i].extent = gl::Aabb<float>(items[i].p, items[i].p);
    }
    for (auto _ : state) {
        gl::Octree<float, gl::RGB> t(items);
        benchmark::DoNotOptimize(t.nodes().data());
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(n));
}
BENCHMARK(BM_OctreeBuild)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);

// Alg. 1 tree cut from points inside the sphere (eps1 = range / 100, eps2 = eps1 / 5), one-step
// (range(1) = 0) or two-step with stopping depth range(1). items = cuts.
static void BM_TreeCut(benchmark::State& state) {
    const auto& tree = renderer().volume_tree();
    const gl::CutCriterion<float> c{float(state.range(0)) / 100.0f, float(state.range(0)) / 500.0f,
                                    gl::pi_v<float> / 4};
    const Phase ph(0.7f);
    auto pv = [&](const gl::Vec3f& a, const gl::Vec3f& b) { return ph.eval(a, b).pdf; };
    std::int64_t i = 0, visited = 0;
    std::vector<std::uint32_t> buf(4096);
    for (auto _ : state) {
        const gl::Vec3f P(0.5f * std::sin(float(i)), 0.5f * std::cos(0.7f * float(i)), 0.3f * std::sin(0.3f * float(i)));
        const gl::Vec3f o(0.0f, 0.0f, -1.0f);
        float acc = 0;
        auto nf = [&](const auto& n) { acc += n.w[0], ++visited; };
        auto itf = [&](const auto& it) { acc += it.w[0], ++visited; };
        if (state.range(1) > 0) {
            const auto n = tree.coarse_cut(P, o, c, pv, std::uint32_t(state.range(1)), std::span(buf));
            tree.tree_cut_from(std::span<const std::uint32_t>(buf.data(), n), P, o, c, pv, nf, itf);
        } else {
            tree.tree_cut(P, o, c, pv, nf, itf);
        }
        benchmark::DoNotOptimize(acc);
        ++i;
    }
    state.SetItemsProcessed(i);
    state.counters["cut_size"] = double(visited) / double(std::max<std::int64_t>(1, i));
}
BENCHMARK(BM_TreeCut)->Args({50, 0})->Args({20, 0})->Args({50, 3})->Args({20, 3})->Unit(benchmark::kMicrosecond);

// Camera rays through the renderer: range(0) = 0 single only, 1 all components (Eq. 9). items = rays.
static void BM_CameraRay(benchmark::State& state) {
    const auto& r = renderer();
    std::int64_t i = 0;
    for (auto _ : state) {
        gl::Rng rng = gl::Rng::from_key(5, std::uint64_t(i));
        const gl::Vec2f u = rng.uniform2<float>();
        const gl::Vec3f eye(0.0f, 0.0f, 4.0f);
        const gl::Ray<float> ray(eye, glm::normalize(gl::Vec3f(1.4f * u.x - 0.7f, 1.4f * u.y - 0.7f, 0.0f) - eye));
        if (state.range(0) == 0) {
            // Single scattering only: the tree's segment visit with the exact box clip (Eq. 5).
            std::size_t n = 0;
            r.volume_tree().visit_segment(ray.o, ray.d, 2.5f, 5.0f, [&](const auto&) { ++n; });
            benchmark::DoNotOptimize(n);
        } else {
            benchmark::DoNotOptimize(r.radiance(ray, rng));
        }
        ++i;
    }
    state.SetItemsProcessed(i);
}
BENCHMARK(BM_CameraRay)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// Multiple-scattering table precomputation with the walk kernel (BmpS. albedo, g = 0.7).
// items = photons.
static void BM_MsTableBuild(benchmark::State& state) {
    gl::MsTableOptions o;
    o.n_rho = 16;
    o.n_z = 32;
    o.n_theta = 8;
    o.n_phi = 4;
    o.photons = std::uint64_t(state.range(0));
    o.blocks = 1;
    for (auto _ : state) {
        auto t = gl::MsTable<3>::build(Phase(0.7f), gl::RGB{0.9545f, 0.6774f, 0.4565f}, o);
        benchmark::DoNotOptimize(t.values().data());
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()) * state.range(0));
}
BENCHMARK(BM_MsTableBuild)->Arg(20000)->Unit(benchmark::kMillisecond);

// Sec. 3.4.2: photons from the quad light walked through a glossy floor and a diffuse wall to the
// unit sphere (items = photons shot).
static void BM_EnvironmentPhotons(benchmark::State& state) {
    gl::Scene<Medium> room;
    room.add_shape(gl::QuadShape<float>(gl::Vec3f(-7.0f, -1.1f, -7.0f), gl::Vec3f(0, 0, 14), gl::Vec3f(14, 0, 0)),
                   gl::Material<float, gl::RGB>::glossy(gl::RGB(0.6f), 0.15f));
    room.add_shape(gl::QuadShape<float>(gl::Vec3f(-7.0f, -1.1f, -2.6f), gl::Vec3f(14, 0, 0), gl::Vec3f(0, 8, 0)),
                   gl::Material<float, gl::RGB>::diffuse(gl::RGB(0.5f)));
    const int object = room.add_shape(kSphere, gl::Material<float, gl::RGB>::absorber());
    room.add_quad_light(kQuad, gl::RGB(1.0f));
    gl::EnvironmentPhotonOptions o;
    o.photons = std::uint64_t(state.range(0));
    for (auto _ : state) {
        auto ph = gl::trace_environment_photons(room, object, o);
        benchmark::DoNotOptimize(ph.data());
        ++o.seed;
    }
    state.SetItemsProcessed(std::int64_t(state.iterations()) * state.range(0));
}
BENCHMARK(BM_EnvironmentPhotons)->Arg(100000)->Unit(benchmark::kMillisecond);

// Nearest light surface sample of a point near the sphere: the library's grid (Arg 0) against a
// brute-force scan over all samples (Arg 1, the baseline); 20 000 samples.
static void BM_NearestSurfaceSample(benchmark::State& state) {
    const auto surf = gl::sphere_surface_samples(kSphere, 20000);
    const gl::detail::NearestSample<float> grid(surf);
    std::vector<gl::Vec3f> q(4096);
    gl::Rng rng = gl::Rng::from_key(5);
    for (auto& p : q) p = (1.0f + 0.01f * rng.uniform<float>()) * gl::sample_uniform_sphere(rng.uniform2<float>());
    std::size_t i = 0;
    for (auto _ : state) {
        const gl::Vec3f& p = q[i++ & 4095];
        std::size_t best = 0;
        if (state.range(0) == 0) {
            best = grid.nearest(p);
        } else {
            float bd = 1e30f;
            for (std::size_t j = 0; j < surf.size(); ++j) {
                const gl::Vec3f d = surf[j].p - p;
                const float d2 = glm::dot(d, d);
                if (d2 < bd) {
                    bd = d2;
                    best = j;
                }
            }
        }
        benchmark::DoNotOptimize(best);
    }
}
BENCHMARK(BM_NearestSurfaceSample)->Arg(0)->Arg(1);
