// embree_aggregate: an Embree scene -- a ground mesh, an area-light mesh and a procedural
// aggregate of ~10^5 grains registered as an Embree user geometry (adapters/embree.hpp) -- rendered
// by explicit path tracing in which every closest-hit and shadow query goes to Embree
// (rtcIntersect1 / rtcOccluded1). Grain interactions use the library's EPT piece
// (integrators/ept.hpp grain_sojourn), light sampling and MIS the library's scene lights
// (scene/scene.hpp). The same scene rendered by the library's own render_ept (Algorithm 1 + its
// scene layer) is the reference: both are unbiased estimators of the same image, so their means
// must agree within the statistical error (printed, and checked by a ctest entry).
//
//   embree_aggregate [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N]
//                    [--checkpoint SECONDS] [--resume]
//   mpirun -np K embree_aggregate ...       (built with MPI: rank r renders rows y % K == r)
//
// Writes embree_aggregate.{exr,png} (Embree render) and library_ept.{exr,png}; last line JSON.
#include <embree3/rtcore.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/checkpoint.hpp"
#include "common/harness.hpp"
#include "grainlight/adapters/embree.hpp"
#include "grainlight/integrators/ept.hpp"
#include "grainlight/media/continuous.hpp"
#include "grainlight/packing/md_packer.hpp"
#include "grainlight/phase/henyey_greenstein.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"

namespace gl = grainlight;
using namespace gl_examples;

namespace {

using Medium = gl::ContinuousMedium<gl::HenyeyGreenstein<float, gl::RGB>, gl::RGB>;
using LibScene = gl::Scene<Medium>;
using Shape = gl::SphereBoundary;
using Agg = gl::GranularAggregate<Shape>;
using Hit = gl::SurfaceHit<float, gl::RGB>;

// The scene, once as Embree geometry and once in the library's scene layer.
const gl::QuadShape<float> ground_quad(gl::Vec3f(-4, 0, -4), gl::Vec3f(0, 0, 8), gl::Vec3f(8, 0, 0));  // normal +y
const gl::QuadShape<float> light_quad(gl::Vec3f(-1.5f, 3.0f, 0.5f), gl::Vec3f(1.5f, 0, 0), gl::Vec3f(0, 0, 1.5f));  // -y
const gl::RGB ground_albedo{0.45f, 0.42f, 0.4f};
const gl::RGB light_radiance{9.0f, 8.6f, 8.0f};
const gl::RGB sky{0.10f, 0.12f, 0.16f};

unsigned add_quad_mesh(RTCDevice dev, RTCScene scene, const gl::QuadShape<float>& q) {
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4));
    const gl::Vec3f p[4] = {q.corner, q.corner + q.edge_u, q.corner + q.edge_u + q.edge_v, q.corner + q.edge_v};
    for (int i = 0; i < 4; ++i) v[3 * i] = p[i].x, v[3 * i + 1] = p[i].y, v[3 * i + 2] = p[i].z;
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2));
    const unsigned is[6] = {0, 1, 2, 0, 2, 3};
    for (int i = 0; i < 6; ++i) idx[i] = is[i];
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    return id;
}

struct EmbreeWorld {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    unsigned ground = 0, light = 0, grains = 0;
    ~EmbreeWorld() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

RTCRayHit make_ray(const gl::Vec3d& o, const gl::Vec3d& d, float tfar) {
    RTCRayHit rh{};
    rh.ray.org_x = float(o.x), rh.ray.org_y = float(o.y), rh.ray.org_z = float(o.z);
    rh.ray.dir_x = float(d.x), rh.ray.dir_y = float(d.y), rh.ray.dir_z = float(d.z);
    rh.ray.tnear = 0.0f, rh.ray.tfar = tfar, rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID, rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

// Radiance along a camera ray with every visibility query answered by Embree. Mirrors the
// library's ept_radiance (NEE + power-heuristic MIS at Lambertian points, Russian roulette).
gl::RGB embree_radiance(const EmbreeWorld& w, const LibScene& lights, const Agg& agg, const gl::Ray<float>& ray,
                        gl::Rng& rng, const gl::EptOptions& opt, std::uint64_t& rays) {
    gl::RGB L(0.0f), beta(1.0f);
    gl::Vec3d p(ray.o), d(glm::normalize(gl::Vec3d(ray.d)));
    bool specular = true;
    double last_pdf = 0;
    gl::Vec3d last_p = p;
    int events = 0;
    const double R = agg.grain_radius();
    gl::EmbreeGrainRecord rec;
    gl::EmbreeGrainContext ctx;
    gl::init_grain_context(ctx, &rec);

    auto nee = [&](const gl::Vec3d& x, const gl::Vec3d& nf, const gl::RGB& rho, const gl::RGB& thr) {
        const gl::Vec3f u = rng.uniform3<float>();
        const gl::Vec3d origin = x + gl::detail::grain_surface_epsilon(R) * nf;
        const auto ls = lights.sample_light(gl::Vec3f(origin), u);
        if (!ls || ls.L.is_black()) return;
        const gl::Vec3d wl(ls.w);
        const double c = glm::dot(wl, nf);
        if (c <= 0) return;
        RTCRay shadow = make_ray(origin, wl, std::isinf(ls.dist) ? 1e30f : float(double(ls.dist) * (1 - 1e-4))).ray;
        ++rays;
        rtcOccluded1(w.scene, &ctx.context, &shadow);
        if (shadow.tfar < 0) return;
        const double pdf_b = c * gl::inv_pi_v<double>;
        const double wmis = ls.delta ? 1.0 : gl::power_heuristic(double(ls.pdf), pdf_b);
        L += thr * rho * ls.L * float(c * gl::inv_pi_v<double> * wmis / double(ls.pdf));
    };
    auto emission = [&](const gl::RGB& Le, const Hit& h) {
        if (Le.is_black()) return;
        double wmis = 1;
        if (opt.nee && !specular) wmis = gl::power_heuristic(last_pdf, double(lights.light_pdf(gl::Vec3f(last_p), gl::Vec3f(d), h)));
        L += beta * Le * float(wmis);
    };

    while (events < opt.max_events) {
        rec.hit = false;
        RTCRayHit rh = make_ray(p, d, 1e30f);
        ++rays;
        rtcIntersect1(w.scene, &ctx.context, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
            emission(lights.environment(gl::Vec3f(d)), Hit{});
            break;
        }
        // Embree's origin is the float-rounded p: hit points are rebuilt from that origin.
        const gl::Vec3d o(rh.ray.org_x, rh.ray.org_y, rh.ray.org_z);
        if (rh.hit.geomID == w.grains) {
            const gl::GrainSojourn s = gl::grain_sojourn(
                agg, rec.grain, o + rec.t * d, d, rec.n_world, beta, rng, opt.mode, opt.max_events - events,
                [&](const gl::Vec3d& x, const gl::Vec3d& n, gl::RGB& thr) {
                    const gl::GrainMaterial& m = agg.exemplars()[rec.grain.exemplar].material();
                    nee(x, n, gl::RGB{float(m.albedo[0]), float(m.albedo[1]), float(m.albedo[2])}, thr);
                },
                [](const gl::Vec3d&, const gl::Vec3d&) {});
            events += s.events;
            if (s.kind == gl::GrainSojourn::absorbed || beta.is_black()) break;
            p = s.p, d = s.d, last_p = s.p;
            specular = s.specular;
            last_pdf = s.pdf;
        } else {
            const double t = rh.ray.tfar;
            const gl::Vec3d x = o + t * d;
            if (rh.hit.geomID == w.light) {
                Hit h;
                h.t = float(t), h.p = gl::Vec3f(x), h.n = light_quad.normal, h.light = 0;
                emission(lights.emitted(h, gl::Vec3f(d)), h);
                break;  // the light is black (an absorber)
            }
            // Ground: Lambertian.
            ++events;
            const gl::Vec3d n(ground_quad.normal);
            const gl::Vec3d nf = glm::dot(d, n) < 0 ? n : -n;
            if (opt.nee) nee(x, nf, ground_albedo, beta);
            const gl::Vec3d local = gl::sample_cosine_hemisphere(rng.uniform2<double>());
            d = glm::normalize(gl::Frame<double>(nf).to_world(local));
            beta *= ground_albedo;
            p = x + 1e-5 * (1.0 + gl::max_abs_component(x)) * nf;
            specular = false;
            last_pdf = gl::cosine_hemisphere_pdf(local.z);
            last_p = x;
        }
        if (events >= opt.rr_depth) {
            const float q = std::min(1.0f, beta.max_value());
            if (q < 1.0f) {
                if (!(q > 0.0f) || rng.uniform<float>() >= q) break;
                beta /= q;
            }
        }
    }
    return L;
}

}  // namespace

int main(int argc, char** argv) {
    return run(argc, argv, "embree_aggregate",
               "A procedural aggregate as an Embree user geometry next to Embree meshes, rendered by EPT over Embree",
               "out/embree_aggregate", [&](Example& ex) {
        const auto spp = ex.opt<std::uint64_t>("spp", 16, 64, "samples per pixel");
        ex.checkpointable();  // --checkpoint SECONDS / --resume (one checkpoint per render and rank)
        ex.ready();
        if (spp < 1 || spp > 65536) throw cli_error("--spp = " + std::to_string(spp) + " must be in [1, 65536]");
        const bool full = ex.full();
        const auto& out = ex.out();
        const int threads = ex.threads();
        const std::uint64_t seed = ex.seed();
        const int width = full ? 480 : 200, height = full ? 300 : 125;

        // The aggregate: a ball of radius 0.5 on the ground, grains of bounding radius 0.012 from an
        // MD tile at f = 0.6, half clear crystals, half snow-like grains.
        const double r_grain = 0.012;
        const auto packed = gl::md_pack(300, 0.6, seed);
        const double scale = r_grain / packed.tile.radius();
        std::vector<gl::Vec3d> centers = packed.tile.centers();
        for (auto& c : centers) c *= scale;
        const gl::PeriodicTile tile(packed.tile.side() * scale, r_grain, std::move(centers));
        std::vector<gl::GrainExemplar> exemplars;
        exemplars.push_back(gl::GrainExemplar::procedural(gl::GrainShape::crystal, 0.95,
                                                   gl::GrainMaterial::make_absorbing_dielectric(1.5, gl::RGBd{0.3, 0.5, 0.9}), 3, 3));
        exemplars.push_back(gl::GrainExemplar::procedural(gl::GrainShape::snow, 1.0,
                                                   gl::GrainMaterial::make_dielectric(1.31), 7, 3));
        const Agg agg(tile, gl::VoxelizedBoundary<Shape>(Shape(gl::Vec3d(0.2, 0.5, 0.0), 0.5), tile.side()), exemplars, {0.5, 0.5},
                      seed);

        EmbreeWorld w;
        w.device = rtcNewDevice(nullptr);
        if (!w.device) throw std::runtime_error("rtcNewDevice failed");
        w.scene = rtcNewScene(w.device);
        w.ground = add_quad_mesh(w.device, w.scene, ground_quad);
        w.light = add_quad_mesh(w.device, w.scene, light_quad);
        w.grains = gl::attach_aggregate(w.device, w.scene, agg);
        rtcCommitScene(w.scene);

        LibScene lib;
        lib.add_shape(ground_quad, gl::Material<float, gl::RGB>::diffuse(ground_albedo));
        lib.add_quad_light(light_quad, light_radiance);
        lib.add_light(LibScene::LightT::environment_light(sky));
        const gl::PinholeCamera<float> camera(gl::Vec3f(0.2f, 1.25f, 3.0f), gl::Vec3f(0.2f, 0.4f, 0.0f), gl::Vec3f(0, 1, 0),
                                              30.0f, width, height);
        gl::EptOptions opt;
        opt.max_events = full ? 4096 : 512;

        // Embree render through the library's row driver (render_rows): this rank's rows
        // (y % ranks == rank) over threads, one keyed generator per pixel sample, checkpoints and
        // resume; film 1 holds each row's tallies at pixel (0, y): sum of green, sum of its
        // square, Embree traversals. Any split over threads and MPI ranks gives the same image.
        const int rank = ex.rank(), ranks = ex.ranks();
        ProgressBar bar = ex.progress("embree", std::uint64_t(2 * height));
        const auto t0 = std::chrono::steady_clock::now();
        gl::RenderOptions eopt = render_options(ex, int(spp), "embree");
        std::vector<gl::Film> films = gl::render_rows(
            width, height, 2, eopt,
            [&](int y, std::span<gl::Film> f) {
                double sum_g = 0, sum_g2 = 0;
                std::uint64_t rays = 0;
                for (int x = 0; x < width; ++x) {
                    const std::uint64_t pixel = std::uint64_t(y) * std::uint64_t(width) + std::uint64_t(x);
                    for (std::uint64_t s = 0; s < spp; ++s) {
                        gl::Rng rng = gl::Rng::from_key(seed, pixel, s);
                        const gl::Vec2f u = rng.uniform2<float>();
                        const auto ray = camera.generate_ray(float(x) + u.x, float(y) + u.y);
                        gl::RGB L = embree_radiance(w, lib, agg, ray, rng, opt, rays);
                        if (!L.is_finite()) {  // counted and reported, never poisoning the pixel
                            f[0].add_nonfinite(x, y);
                            L = gl::RGB(0.0f);
                        }
                        f[0].add_sample(x, y, L);
                        sum_g += L[1];
                        sum_g2 += double(L[1]) * L[1];
                    }
                }
                f[1].add_rgb(0, y, sum_g, sum_g2, double(rays));
            },
            [&](int n) { bar.advance(std::uint64_t(n)); });
        const double t_embree = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        // Library reference: render_ept on the same scene (its own scene layer + Algorithm 1), the
        // same row share, its own checkpoint.
        const auto t1 = std::chrono::steady_clock::now();
        gl::RenderOptions ropt = render_options(ex, int(spp), "library");
        ropt.seed = seed + 1000003;
        gl::EptImages ref = gl::render_ept(lib, agg, camera, ropt, opt, [&](int n) { bar.advance(std::uint64_t(n)); });
        const double t_lib = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        bar.done();
        double local_rays = 0;  // this rank's traversals (its rays per second)
        for (int y = rank; y < height; y += ranks) local_rays += films[1].sums()[3 * std::size_t(y) * std::size_t(width) + 2];
        // Rank 0 assembles the rows (placements, in rank order).
        const gl::Film film = ex.mpi().gather_film_rows(films[0]);
        const gl::Film tallies = ex.mpi().gather_film_rows(films[1]);
        ref.low = ex.mpi().gather_film_rows(ref.low);
        ref.high = ex.mpi().gather_film_rows(ref.high);
        if (!ex.root()) return ex.finish({});

        double sum = 0, sq = 0;
        std::uint64_t rays = 0;
        for (int y = 0; y < height; ++y) {
            const double* t = tallies.sums().data() + 3 * std::size_t(y) * std::size_t(width);
            sum += t[0], sq += t[1], rays += std::uint64_t(t[2]);
        }
        const double n = double(width) * double(height) * double(spp);
        const double mean = sum / n, se = std::sqrt(std::max(0.0, sq / n - mean * mean) / n);
        const gl::Image img = film.image(), lib_img = ref.combined();
        const double lib_mean = lib_img.mean(1);
        gl::write_exr(out / "embree_aggregate.exr", img);
        gl::write_png(out / "embree_aggregate.png", img, {1.0});
        gl::write_exr(out / "library_ept.exr", lib_img);
        gl::write_png(out / "library_ept.png", lib_img, {1.0});

        std::printf("Embree scene: ground mesh + light mesh + procedural aggregate (user geometry) of %llu grains\n",
                    (unsigned long long)agg.grain_count());
        std::printf("  aggregate memory %.3f MB (O(1) in the grain count); Embree sees 1 user primitive\n",
                    double(agg.memory_bytes()) / 1e6);
        std::printf("  %dx%d, %llu spp: Embree EPT %.1f s (%.3g rays/s), library EPT %.1f s on %d threads\n", width, height,
                    (unsigned long long)spp, t_embree, double(local_rays) / t_embree, t_lib, threads);
        std::printf("  image mean (green): Embree %.5f +- %.5f vs library EPT %.5f (reference: equal within the error)\n",
                    mean, se, lib_mean);
        std::printf("wrote %s/{embree_aggregate,library_ept}.{exr,png}\n", out.c_str());
        Json j = ex.summary();
        j.integer("width", width)
            .integer("height", height)
            .integer("spp", (long long)spp)
            .integer("grains", (long long)agg.grain_count())
            .num("memory_mb", double(agg.memory_bytes()) / 1e6)
            .num("mean_embree", mean)
            .num("mean_embree_se", se)
            .num("mean_library", lib_mean)
            .str("rank_rows", "rank r renders the rows y with y % ranks == r (timings: rank 0's)")
            .nums("rank_row_counts", ex.mpi().row_counts(height));
        Example::nonfinite(j, film.nonfinite_samples() + ref.low.nonfinite_samples() + ref.high.nonfinite_samples())
            .num("seconds_embree", t_embree)
            .num("seconds_library", t_lib)
            .num("rays_per_second", double(local_rays) / t_embree);
        return ex.finish(j);
    });
}
