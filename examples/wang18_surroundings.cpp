// wang18_surroundings: Wang & Holzschuch 2018 (TVCG), Sec. 3.5.1 ("camera rays ... after
// diffuse or glossy bounces in the scene") and the scenes of Figs. 15-17, where the translucent
// object stands in a room: the bumpy sphere of wang18_fig12_components (radius 20 green mean free
// paths, BmpS., g 0.7, eta 1.33) on a glossy floor (GGX; `--floor diffuse`: Lambertian) before a
// diffuse wall, under the quad light.
// The point-based medium is one opaque shape of the surrounding scene
// (integrators/point_based_surroundings.hpp): the surroundings' VPT (NEE with MIS) adds, where a
// path reaches the object, the point-based radiance (Eqs. 5-9) along the arriving ray.
//
// Reference: the library's VPT of the whole scene (the object a dielectric holding the medium),
// uncapped, pure path tracing, one grey walk per channel, 8 batches. Both are split per sample:
//   - object, seen directly: light scattered in the medium on samples whose camera ray hits the
//     object first;
//   - object, through the surroundings: the same light on samples whose camera ray hits the floor
//     or the wall first (the object's light reflected by the room: Sec. 3.5.1's camera rays).
// Sec. 3.4.2: the light that reaches the object after bounces in the room (the glossy floor's
// reflection of the lamp, the wall) enters the point-based medium through entering-light records
// gathered by `--env-photons` photons (integrators/point_based_environment.hpp). The reference
// reports that light apart ("object lit by the room": its paths have a room bounce between the
// light and a scattering event), and a second point-based renderer built from the records alone
// gives the same component. With `--env-photons 0` (the renderer of Sec. 3.4.1 only) the object
// rows compare against the reference's light that entered straight from the light source.
//
//   wang18_surroundings [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                       [--width N] [--rays N] [--vpt-spp N] [--surface-samples N] [--eps1 E]
//                       [--table-range R] [--floor glossy|diffuse] [--room-spp N]
//                       [--env-photons N] [--env-directions mean|resampled]
//
// Outputs: wang18_surroundings_{pb,vpt}.{exr,png} (all light), *_object.{exr,png}, the CSV, and
// the JSON summary (last stdout line): rel_diff_object_direct, rel_diff_object_via_surroundings,
// rel_diff_object_lit_by_surroundings with their standard errors,
// vpt_object_lit_by_surroundings_share, the times.
#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include "grainlight/integrators/point_based_environment.hpp"
#include "grainlight/integrators/point_based_surroundings.hpp"
#include "wang18_bumpy.hpp"

namespace gl = grainlight;

namespace {

// Films of both renders: all light, object light seen directly, object light through the room,
// and the part of the object light that entered the medium after a bounce in the room (the
// point-based renderer of the entering-light records alone; the reference's paths with a room
// bounce between the light and a scattering event).
// The reference also keeps its interreflected object light (see RoomVpt) apart.
// Lit by the room is split again by the camera ray: seen directly (kObjLitByRoom) or through
// the room (kObjLitByRoomVia).
enum Film : int { kAll = 0, kObjDirect = 1, kObjVia = 2, kObjLitByRoom = 3, kObjInter = 4, kObjLitByRoomVia = 5, kFilms = 6 };

constexpr float kFloorY = -1.12f;  // below the bumps (at most 6 % of the unit radius)

// The object as black (paths that only estimate the room's light).
struct DarkObject {
    [[nodiscard]] gl::RGB radiance(const gl::Ray<float>&, gl::Rng&) const noexcept { return gl::RGB(0.0f); }
};

struct Room {
    gl::QuadShape<float> floor{gl::Vec3f(-7.0f, kFloorY, -7.0f), gl::Vec3f(0, 0, 14), gl::Vec3f(14, 0, 0)};  // normal +y
    gl::QuadShape<float> wall{gl::Vec3f(-7.0f, kFloorY, -2.6f), gl::Vec3f(14, 0, 0), gl::Vec3f(0, 8, 0)};    // normal +z
    gl::RGB floor_rho{0.60f, 0.58f, 0.55f};  ///< diffuse albedo, or F0 of the glossy floor
    float floor_alpha = 0.15f;               ///< GGX width of the glossy floor
    bool glossy_floor = true;
    gl::RGB wall_rho{0.45f, 0.50f, 0.60f};
    template <class S>
    [[nodiscard]] gl::Material<float, S> floor_material(const S& rho) const {
        return glossy_floor ? gl::Material<float, S>::glossy(rho, floor_alpha) : gl::Material<float, S>::diffuse(rho);
    }
};

// VPT reference callbacks (pure path tracing): emission hits after >= 1 scattering in the medium
// are object light, split by where the light went between the lamp and the medium (walked
// backwards from the camera):
//   - straight: no room bounce after the first scattering;
//   - lit by the room: a room bounce after the last scattering (the lamp's light reached the
//     medium only after the room: what the entering-light photons carry), none between two
//     scatterings;
//   - interreflected: a room bounce between two scatterings (light that left the medium, was
//     reflected by the room and entered it again; no point-based component models it).
struct RoomVpt {
    const wang18::SceneG& scene;
    int object_shape = -1;
    int count = 0;
    bool room_since_scatter = false;  ///< a room bounce since the last scattering event
    bool room_between = false;        ///< a room bounce between two scattering events
    float all = 0, straight = 0, lit_by_room = 0, interreflected = 0;
    bool on_scatter(gl::PathState<float, wang18::Grey>&, const gl::Interaction<float, wang18::Grey>&,
                    const wang18::MediumG&) noexcept {
        if (room_since_scatter) room_between = true;
        room_since_scatter = false;
        ++count;
        return true;
    }
    bool on_surface(gl::PathState<float, wang18::Grey>& st, const gl::SurfaceHit<float, wang18::Grey>& hit) noexcept {
        if (count > 0 && (hit.type == gl::SurfaceType::diffuse || hit.type == gl::SurfaceType::glossy)) room_since_scatter = true;
        if (hit.light < 0) return true;
        const float c = (st.throughput * scene.emitted(hit, st.ray.d))[0];
        all += c;
        if (count == 0) return true;
        (room_between ? interreflected : room_since_scatter ? lit_by_room : straight) += c;
        return true;
    }
};

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_surroundings",
        "Wang18 Sec. 3.5.1: the point-based bumpy sphere in a room, seen directly and through the room's bounces, beside the VPT",
        "out/wang18_surroundings", [&](gl_examples::Example& ex) -> int {
            const int W = ex.opt<int>("width", 40, 512, "image width in pixels (height 3/4 of it)");
            const int rays = ex.opt<int>("rays", 4, 4, "camera rays per pixel of the point-based render");
            const int room_spp = ex.opt<int>("room-spp", 16, 64,
                                             "paths per pixel for the room's own light (>= --rays; the object's light "
                                             "comes from the first --rays of them)");
            const int vpt_spp = ex.opt<int>("vpt-spp", 1024, 256, "VPT samples per pixel and channel (multiple of 8)");
            const int n_surface = ex.opt<int>("surface-samples", 12000, 40000, "Poisson-disk light surface samples on the mesh");
            const double eps1 = ex.opt<double>("eps1", 1.0, 0.5, "Alg. 1 solid-angle threshold eps1 (sr); eps2 = eps1 / 5");
            const double range = ex.opt<double>("table-range", 10.0,
                                                "extent of the MS table in mean free paths (+- range; same cell size)");
            const std::string floor_kind = ex.opt<std::string>("floor", "glossy", "glossy (GGX, F0 0.6, alpha 0.15) | diffuse (albedo 0.6)");
            const long long env_photons = ex.opt<long long>(
                "env-photons", 2000000, 20000000,
                "photons for the light that reaches the object after the room (Sec. 3.4.2); 0: none");
            const int env_split_rays = ex.opt<int>(
                "env-split-rays", 4, 1,
                "camera rays per pixel (the first of --rays) that also render the lit-by-the-room component alone");
            const int env_rays = ex.opt<int>("env-rays", 1, 2, "light rays per surface sample from the photons (resampled directions)");
            const std::string env_dirs = ex.opt<std::string>(
                "env-directions", "resampled", "mean (the paper's: one averaged direction per surface sample) | resampled");
            ex.checkpointable();
            ex.ready();
            wang18::check_render_args(rays, W, 20.0);
            wang18::check_vpt_spp(vpt_spp);
            if (room_spp < rays || room_spp > 65536)
                throw gl_examples::cli_error("--room-spp = " + ex.given_text("room-spp") + " must be in [--rays, 65536]");
            wang18::check_surface_samples(n_surface);
            if (!(eps1 > 0 && eps1 <= 10))
                throw gl_examples::cli_error("--eps1 = " + ex.given_text("eps1") + " must be in (0, 10]");
            if (!(range >= 2 && range <= 60))
                throw gl_examples::cli_error("--table-range = " + ex.given_text("table-range") + " must be in [2, 60]");
            if (env_photons < 0 || env_photons > 4000000000LL)
                throw gl_examples::cli_error("--env-photons = " + ex.given_text("env-photons") + " must be in [0, 4e9]");
            if (env_split_rays < 1 || env_split_rays > rays)
                throw gl_examples::cli_error("--env-split-rays = " + ex.given_text("env-split-rays") + " must be in [1, --rays]");
            if (env_rays < 1 || env_rays > 64)
                throw gl_examples::cli_error("--env-rays = " + ex.given_text("env-rays") + " must be in [1, 64]");
            if (env_dirs != "mean" && env_dirs != "resampled")
                throw gl_examples::cli_error("--env-directions = " + env_dirs + " must be mean or resampled");
            const bool env_on = env_photons > 0;
            const bool full = ex.full();
            const std::uint64_t seed = ex.seed();
            const int H = std::max(3, W * 3 / 4);

            wang18::BumpyScene sc = wang18::make_bumpy_scene(W, 20.0f, 0.7f);
            sc.H = H;
            sc.camera = gl::PinholeCamera<float>(gl::Vec3f(0.0f, 1.1f, 5.6f), gl::Vec3f(0.0f, -0.35f, 0.0f),
                                                 gl::Vec3f(0, 1, 0), 40.0f, W, H);
            if (floor_kind != "glossy" && floor_kind != "diffuse")
                throw gl_examples::cli_error("--floor = " + floor_kind + " must be glossy or diffuse");
            Room room;
            room.glossy_floor = floor_kind == "glossy";

            // The point-based object: light samples on the mesh, the MS table (cached), the renderer.
            double cpu_table = 0;
            bool cached = false;
            const gl::MsTable<3> table = wang18::cached_table(ex.out(), sc, full, seed, cpu_table, cached, ex.root(), range);
            gl::PointBasedOptions<float> po = wang18::default_options(sc, full);
            po.cut.eps1 = float(eps1);
            po.cut.eps2 = 0.2f * float(eps1);
            // The surroundings: floor, wall, the light, and the object as an opaque shape.
            gl::Scene<wang18::Medium> room_scene;
            const gl::MeshShape<float> mshape(sc.mesh);
            room_scene.add_shape(room.floor, room.floor_material(room.floor_rho));
            room_scene.add_shape(room.wall, gl::Material<float, gl::RGB>::diffuse(room.wall_rho));
            const int object = room_scene.add_shape(mshape, gl::Material<float, gl::RGB>::absorber());
            room_scene.add_quad_light(sc.quad, gl::RGB(sc.Le));

            double c0 = wang18::cpu_seconds();
            const auto surf = gl::mesh_surface_samples(sc.shape, n_surface, seed);
            const auto bounce = gl::mesh_surface_samples(sc.shape, po.bounce_samples, seed + 17);
            // Sec. 3.4.2: photons through the room give the light that enters after it.
            gl::EnvironmentLight<float, gl::RGB> env;
            if (env_on) {
                gl::EnvironmentPhotonOptions eo;
                eo.photons = std::uint64_t(env_photons);
                eo.seed = seed * 7919 + 0x454e56ull;
                gl::EnteringLightOptions el;
                el.directions = env_dirs == "mean" ? gl::EnteringDirections::mean : gl::EnteringDirections::resampled;
                el.seed = seed;
                el.rays_per_sample = env_rays;
                env = gl::environment_entering_light(room_scene, object, sc.eta, surf, eo, el);
            }
            const double cpu_env = wang18::cpu_seconds() - c0;
            const auto lamp = gl::Light<float, gl::RGB>::quad_light(sc.quad, gl::RGB(sc.Le));
            gl::Rng lrng = gl::Rng::from_key(seed, 0x5742u);
            const wang18::MeshRenderer pb(sc.medium(), sc.eta, sc.shape, surf, lamp, po, lrng, &table, bounce, env.entering);
            // The entering light alone (the component the reference reports as "lit by the room").
            std::optional<wang18::MeshRenderer> pb_env;
            if (env_on) {
                gl::PointBasedOptions<float> pe = po;
                pe.direct_light = false;
                gl::Rng erng = gl::Rng::from_key(seed, 0x5743u);
                pb_env.emplace(sc.medium(), sc.eta, sc.shape, surf, lamp, pe, erng, &table, bounce, env.entering);
            }
            const double cpu_samples = wang18::cpu_seconds() - c0;

            c0 = wang18::cpu_seconds();
            const std::vector<gl::Film> pf = wang18::render_rows(
                ex, "point-based in the room", "point-based", W, H, kFilms, rays, [&](int y, std::span<gl::Film> film) {
                    for (int x = 0; x < W; ++x) {
                        gl::RGB acc[kFilms];
                        for (auto& a : acc) a = gl::RGB(0.0f);
                        // The object's light from `rays` paths; the room's from `room_spp` (>= rays: the
                        // first `rays` paths serve both; the others end at the object without asking it).
                        gl::RGB room_light(0.0f);
                        for (int k = 0; k < room_spp; ++k) {
                            gl::Rng rng = gl::Rng::from_key(seed, std::uint64_t(y) * std::uint64_t(W) + std::uint64_t(x),
                                                            0x10000u + std::uint64_t(k));
                            const gl::Vec2f u = rng.uniform2<float>();
                            const gl::Ray<float> ray = sc.camera.generate_ray(float(x) + u.x, float(y) + u.y);
                            if (k >= rays) {
                                room_light += gl::point_based_in_scene(room_scene, object, DarkObject{}, ray, rng).surroundings;
                                continue;
                            }
                            const bool direct = room_scene.intersect(ray).shape == object;
                            gl::Rng rng_env = rng;  // the same path through the room for both renderers
                            const auto r = gl::point_based_in_scene(room_scene, object, pb, ray, rng);
                            room_light += r.surroundings;
                            acc[direct ? kObjDirect : kObjVia] += r.object;
                            if (pb_env && k < env_split_rays)
                                acc[direct ? kObjLitByRoom : kObjLitByRoomVia] +=
                                    gl::point_based_in_scene(room_scene, object, *pb_env, ray, rng_env).object;
                        }
                        acc[kObjDirect] *= 1.0f / float(rays);
                        acc[kObjVia] *= 1.0f / float(rays);
                        acc[kObjLitByRoom] *= 1.0f / float(env_split_rays);
                        acc[kObjLitByRoomVia] *= 1.0f / float(env_split_rays);
                        acc[kAll] = room_light * (1.0f / float(room_spp)) + acc[kObjDirect] + acc[kObjVia];
                        for (int f = 0; f < kFilms; ++f) film[std::size_t(f)].add_rgb(x, y, acc[f][0], acc[f][1], acc[f][2]);
                    }
                });
            const double cpu_pb = wang18::sum_over_ranks(ex, wang18::cpu_seconds() - c0);

            // The reference: per channel a grey scene with the object as a dielectric holding the medium.
            std::vector<wang18::SceneG> scenes;
            std::array<int, 3> vpt_object{};
            for (int ch = 0; ch < 3; ++ch) {
                wang18::SceneG s;
                const int m = s.add_medium(wang18::MediumG(wang18::Grey(sc.sigma_t[ch]), wang18::Grey(sc.albedo[ch]),
                                                           wang18::PhaseG(sc.g)));
                s.add_shape(room.floor, room.floor_material(wang18::Grey(room.floor_rho[ch])));
                s.add_shape(room.wall, gl::Material<float, wang18::Grey>::diffuse(wang18::Grey(room.wall_rho[ch])));
                vpt_object[std::size_t(ch)] = s.add_shape(mshape, gl::Material<float, wang18::Grey>::dielectric(sc.eta), m, -1);
                s.add_quad_light(sc.quad, wang18::Grey(sc.Le));
                scenes.push_back(std::move(s));
            }
            const std::size_t npx = std::size_t(W) * std::size_t(H);
            // Batch sums (layout of wang18::batch_index).
            std::vector<double> bs(std::size_t(kFilms) * wang18::kBatches * npx * 3, 0.0);
            c0 = wang18::cpu_seconds();
            wang18::batched_films<kFilms>(
                ex, "VPT reference", "vpt", W, H, vpt_spp, bs, [&](int x, int y, std::size_t p, int s, double (&v)[kFilms][3]) {
                    for (int ch = 0; ch < 3; ++ch) {
                        wang18::ChannelSample cs = wang18::channel_sample(sc.camera, x, y, seed, p, s, ch);
                        const auto& scene = scenes[std::size_t(ch)];
                        const bool direct = scene.intersect(cs.ray).shape == vpt_object[std::size_t(ch)];
                        RoomVpt cb{scene, vpt_object[std::size_t(ch)]};
                        auto st = gl::start_path<float, wang18::Grey>(cs.ray, -1);
                        (void)gl::walk(scene, st, cs.rng, cb, gl::WalkOptions<float>{});
                        v[kAll][ch] = cb.all;
                        // With the entering light on, the object rows hold all of the object's
                        // light; without it, only the light that entered straight from the lamp.
                        v[direct ? kObjLitByRoom : kObjLitByRoomVia][ch] = cb.lit_by_room;
                        v[kObjInter][ch] = cb.interreflected;
                        v[direct ? kObjDirect : kObjVia][ch] = cb.straight + (env_on ? cb.lit_by_room : 0.0f);
                    }
                });
            const double cpu_vpt = wang18::sum_over_ranks(ex, wang18::cpu_seconds() - c0);
            if (!ex.root()) return ex.finish({});

            // Image means (over pixels and channels) per film; the reference's standard error from its batches.
            std::array<double, kFilms> pbm{}, ref{}, ref_se{};
            std::array<gl::Image, kFilms> pimg, vimg;
            for (int k = 0; k < kFilms; ++k) {
                pimg[std::size_t(k)] = pf[std::size_t(k)].image();
                pbm[std::size_t(k)] = wang18::image_mean(pimg[std::size_t(k)]);
                vimg[std::size_t(k)] = gl::Image(W, H);
                for (std::size_t p = 0; p < npx; ++p)
                    for (int ch = 0; ch < 3; ++ch) {
                        double s = 0;
                        for (int b = 0; b < wang18::kBatches; ++b) s += bs[wang18::batch_index(k, b, npx, p, ch)];
                        vimg[std::size_t(k)].at(int(p % std::size_t(W)), int(p / std::size_t(W)), ch) = float(s / double(vpt_spp));
                    }
                const wang18::BatchMean bm = wang18::batch_mean(bs, k, npx, vpt_spp);
                ref[std::size_t(k)] = bm.mean;
                ref_se[std::size_t(k)] = bm.se;
            }
            auto rel = [&](int k) { return ref[std::size_t(k)] > 0 ? pbm[std::size_t(k)] / ref[std::size_t(k)] - 1.0 : 0.0; };
            auto rel_se = [&](int k) { return ref[std::size_t(k)] > 0 ? ref_se[std::size_t(k)] / ref[std::size_t(k)] : 0.0; };
            const double obj_all =
                ref[kObjDirect] + ref[kObjVia] + (env_on ? 0.0 : ref[kObjLitByRoom] + ref[kObjLitByRoomVia]) + ref[kObjInter];
            const double lit_by_room = obj_all > 0 ? (ref[kObjLitByRoom] + ref[kObjLitByRoomVia]) / obj_all : 0.0;
            const double interreflected = obj_all > 0 ? ref[kObjInter] / obj_all : 0.0;
            // The whole lit-by-the-room component (seen directly and through the room).
            const wang18::BatchMean lit_ref = wang18::batch_mean(bs, {kObjLitByRoom, kObjLitByRoomVia}, npx, vpt_spp);
            const double lit_pb = pbm[kObjLitByRoom] + pbm[kObjLitByRoomVia];
            const double lit_rel = lit_ref.mean > 0 ? lit_pb / lit_ref.mean - 1.0 : 0.0;
            const double lit_rel_se = lit_ref.mean > 0 ? lit_ref.se / lit_ref.mean : 0.0;

            const double exposure = 0.0;
            wang18::save_image(ex, "wang18_surroundings_pb", pimg[kAll], exposure);
            wang18::save_image(ex, "wang18_surroundings_vpt", vimg[kAll], exposure);
            gl::Image pobj(W, H), vobj(W, H);
            for (int y = 0; y < H; ++y)
                for (int x = 0; x < W; ++x)
                    for (int ch = 0; ch < 3; ++ch) {
                        pobj.at(x, y, ch) = pimg[kObjDirect].at(x, y, ch) + pimg[kObjVia].at(x, y, ch);
                        vobj.at(x, y, ch) = vimg[kObjDirect].at(x, y, ch) + vimg[kObjVia].at(x, y, ch) +
                                            (env_on ? 0.0f : vimg[kObjLitByRoom].at(x, y, ch) + vimg[kObjLitByRoomVia].at(x, y, ch)) +
                                            vimg[kObjInter].at(x, y, ch);
                    }
            wang18::save_image(ex, "wang18_surroundings_pb_object", pobj, exposure + 2.0);
            wang18::save_image(ex, "wang18_surroundings_vpt_object", vobj, exposure + 2.0);

            std::printf("Wang18 Sec. 3.5.1: bumpy sphere (%zu triangles, radius 20 green mean free paths, BmpS., g 0.7, eta 1.33) "
                        "on a %s floor before a diffuse wall, under the quad light; %d x %d pixels, %d point-based rays per "
                        "pixel (%d paths for the room's own light), VPT %d spp x 3 channels (8 batches)\n",
                        sc.shape.triangle_count(), room.glossy_floor ? "glossy (GGX alpha 0.15)" : "diffuse", W, H, rays, room_spp,
                        vpt_spp);
            if (env_on)
                std::printf("  Sec. 3.4.2: %lld photons through the room, %llu reached the object after >= 1 bounce: %.4g W "
                            "arriving (green), %zu entering-light records (%s directions)\n",
                            env_photons, (unsigned long long)env.kept, double(env.power_arriving[1]), env.entering.size(),
                            env_dirs.c_str());
            std::printf("  %-30s %12s %12s %10s %18s\n", "light (image mean)", "point-based", "VPT", "VPT s.e.", "rel.diff");
            const char* names[kFilms] = {"all (room + object)", "object, seen directly", "object, through the room",
                                         "lit by the room, seen directly", "object interreflected (VPT)",
                                         "lit by the room, through it"};
            gl_examples::Csv csv({"light", "pb_mean", "vpt_mean", "vpt_se", "rel_diff", "rel_se"});
            for (const int k : {int(kAll), int(kObjDirect), int(kObjVia), int(kObjLitByRoom), int(kObjLitByRoomVia), int(kObjInter)}) {
                if (k == kObjInter)
                    std::printf("  %-30s %12s %12.5f %10.2e   (%.1f %% of the VPT's object light: left the medium, "
                                "reflected by the room, entered again; not modelled)\n",
                                names[k], "-", ref[std::size_t(k)], ref_se[std::size_t(k)], 100 * interreflected);
                else if ((k == kObjLitByRoom || k == kObjLitByRoomVia) && !env_on)
                    std::printf("  %-30s %12s %12.5f %10.2e   (%.1f %% of the VPT's object light)\n", names[k], "-",
                                ref[std::size_t(k)], ref_se[std::size_t(k)], obj_all > 0 ? 100 * ref[std::size_t(k)] / obj_all : 0.0);
                else
                    std::printf("  %-30s %12.5f %12.5f %10.2e %+8.1f%% (+- %.1f%%)\n", names[k], pbm[std::size_t(k)],
                                ref[std::size_t(k)], ref_se[std::size_t(k)], 100 * rel(k), 100 * rel_se(k));
                csv.row_text({names[k], std::to_string(pbm[std::size_t(k)]), std::to_string(ref[std::size_t(k)]),
                              std::to_string(ref_se[std::size_t(k)]), std::to_string(rel(k)), std::to_string(rel_se(k))});
            }
            if (env_on) {
                std::printf("  %-30s %12.5f %12.5f %10.2e %+8.1f%% (+- %.1f%%)\n", "lit by the room, all", lit_pb, lit_ref.mean,
                            lit_ref.se, 100 * lit_rel, 100 * lit_rel_se);
                csv.row_text({"lit by the room, all", std::to_string(lit_pb), std::to_string(lit_ref.mean),
                              std::to_string(lit_ref.se), std::to_string(lit_rel), std::to_string(lit_rel_se)});
            }
            (void)ex.csv("wang18_surroundings.csv", csv);
            if (env_on)
                std::printf("  (object rows: all of the light scattered in the medium, the part that entered after a bounce in "
                            "the room (%.1f %% of the VPT's object light) included; 'lit by the room' is that part alone, "
                            "point-based from the entering-light records; 'all' differs by design: no outside Fresnel "
                            "reflection, no caustics on the room, no interreflection)\n",
                            100 * lit_by_room);
            else
                std::printf("  (object rows: the VPT's light that entered the medium straight from the light source, which the "
                            "point-based light samples gather; 'all' differs by design: no outside Fresnel reflection, no "
                            "caustics on the room, no light entering the object after a bounce in the room)\n");
            std::printf("  CPU: point-based %.2f s (light samples %.2f, of which photons %.2f, + render %.2f; MS table %.2f s%s), "
                        "VPT %.2f s\n",
                        cpu_samples + cpu_pb, cpu_samples, cpu_env, cpu_pb, cpu_table, cached ? ", cached" : "", cpu_vpt);
            std::printf("  [paper: Figs. 15-17 render the media in furnished scenes; Fig. 17: 18 min for the media, 16 min for the "
                        "rest of the scene; no per-component numbers are given]\n");

            gl_examples::Json j = ex.summary();
            j.integer("width", W).integer("height", H).integer("rays", rays).integer("room_spp", room_spp).integer("vpt_spp", vpt_spp).num("table_range", range);
            j.str("floor", floor_kind);
            wang18::put_rank_rows(ex, j, H);
            j.num("pb_object_direct", pbm[kObjDirect])
                .num("vpt_object_direct", ref[kObjDirect])
                .num("rel_diff_object_direct", rel(kObjDirect))
                .num("rel_se_object_direct", rel_se(kObjDirect))
                .num("pb_object_via_surroundings", pbm[kObjVia])
                .num("vpt_object_via_surroundings", ref[kObjVia])
                .num("rel_diff_object_via_surroundings", rel(kObjVia))
                .num("rel_se_object_via_surroundings", rel_se(kObjVia))
                .num("pb_all", pbm[kAll])
                .num("vpt_all", ref[kAll])
                .num("vpt_object_lit_by_surroundings_share", lit_by_room)
                .num("vpt_object_interreflected_share", interreflected)
                .num("env_photons", double(env_photons))
                .str("env_directions", env_dirs)
                .num("env_records", double(env.entering.size()))
                .integer("env_rays", env_rays)
                .num("pb_object_lit_by_surroundings", lit_pb)
                .num("vpt_object_lit_by_surroundings", lit_ref.mean)
                .num("rel_diff_object_lit_by_surroundings", lit_rel)
                .num("rel_se_object_lit_by_surroundings", lit_rel_se)
                .num("rel_diff_object_lit_by_surroundings_direct", rel(kObjLitByRoom))
                .num("rel_se_object_lit_by_surroundings_direct", rel_se(kObjLitByRoom))
                .num("rel_diff_object_lit_by_surroundings_via", rel(kObjLitByRoomVia))
                .num("rel_se_object_lit_by_surroundings_via", rel_se(kObjLitByRoomVia))
                .num("seconds_env_photons", cpu_env)
                .num("seconds_table", cpu_table)
                .num("seconds_samples", cpu_samples)
                .num("seconds_pb", cpu_pb)
                .num("seconds_vpt", cpu_vpt)
                .str("png", (ex.out() / "wang18_surroundings_pb.png").string());
            return ex.finish(j);
        });
}
