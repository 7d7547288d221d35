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
// The reference's object light in these two is the light that entered the medium straight from
// the light source, which is what the point-based light samples gather; the light that entered it
// after a bounce in the room is reported apart, as its share of the reference's object light
// (Sec. 3.4.2's environment light on surface samples would gather it; not implemented).
//
//   wang18_surroundings [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                       [--width N] [--rays N] [--vpt-spp N] [--surface-samples N] [--eps1 E]
//                       [--table-range R] [--floor glossy|diffuse] [--room-spp N]
//
// Outputs: wang18_surroundings_{pb,vpt}.{exr,png} (all light), *_object.{exr,png}, the CSV, and
// the JSON summary (last stdout line): rel_diff_object_direct, rel_diff_object_via_surroundings
// with their standard errors, vpt_object_lit_by_surroundings_share, the times.
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "grainlight/integrators/point_based_surroundings.hpp"
#include "wang18_bumpy.hpp"

namespace gl = grainlight;

namespace {

// Films of both renders: all light, object light seen directly, object light through the room;
// the reference adds its object light that entered the medium after a bounce in the room.
enum Film : int { kAll = 0, kObjDirect = 1, kObjVia = 2, kObjLitByRoom = 3, kFilms = 4 };

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
// are object light; `room_before_medium` marks paths whose light entered the medium after a
// diffuse bounce in the room (walked backwards from the camera: a room bounce after the first
// scattering).
struct RoomVpt {
    const wang18::SceneG& scene;
    int object_shape = -1;
    int count = 0;
    bool room_after_scatter = false;
    float all = 0, object = 0;
    bool on_scatter(gl::PathState<float, wang18::Grey>&, const gl::Interaction<float, wang18::Grey>&,
                    const wang18::MediumG&) noexcept {
        ++count;
        return true;
    }
    bool on_surface(gl::PathState<float, wang18::Grey>& st, const gl::SurfaceHit<float, wang18::Grey>& hit) noexcept {
        if (count > 0 && (hit.type == gl::SurfaceType::diffuse || hit.type == gl::SurfaceType::glossy)) room_after_scatter = true;
        if (hit.light < 0) return true;
        const float c = (st.throughput * scene.emitted(hit, st.ray.d))[0];
        all += c;
        if (count > 0) object += c;
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
            double c0 = wang18::cpu_seconds();
            gl::Rng lrng = gl::Rng::from_key(seed, 0x5742u);
            const auto surf = gl::mesh_surface_samples(sc.shape, n_surface, seed);
            const auto bounce = gl::mesh_surface_samples(sc.shape, po.bounce_samples, seed + 17);
            const wang18::MeshRenderer pb(sc.medium(), sc.eta, sc.shape, surf,
                                          gl::Light<float, gl::RGB>::quad_light(sc.quad, gl::RGB(sc.Le)), po, lrng, &table,
                                          bounce);
            const double cpu_samples = wang18::cpu_seconds() - c0;

            // The surroundings: floor, wall, the light, and the object as an opaque shape.
            gl::Scene<wang18::Medium> room_scene;
            const gl::MeshShape<float> mshape(sc.mesh);
            room_scene.add_shape(room.floor, room.floor_material(room.floor_rho));
            room_scene.add_shape(room.wall, gl::Material<float, gl::RGB>::diffuse(room.wall_rho));
            const int object = room_scene.add_shape(mshape, gl::Material<float, gl::RGB>::absorber());
            room_scene.add_quad_light(sc.quad, gl::RGB(sc.Le));

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
                            const auto r = gl::point_based_in_scene(room_scene, object, pb, ray, rng);
                            room_light += r.surroundings;
                            acc[direct ? kObjDirect : kObjVia] += r.object;
                        }
                        acc[kObjDirect] *= 1.0f / float(rays);
                        acc[kObjVia] *= 1.0f / float(rays);
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
                        if (cb.room_after_scatter)
                            v[kObjLitByRoom][ch] = cb.object;
                        else
                            v[direct ? kObjDirect : kObjVia][ch] = cb.object;
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
            const double obj_all = ref[kObjDirect] + ref[kObjVia] + ref[kObjLitByRoom];
            const double lit_by_room = obj_all > 0 ? ref[kObjLitByRoom] / obj_all : 0.0;

            const double exposure = 0.0;
            wang18::save_image(ex, "wang18_surroundings_pb", pimg[kAll], exposure);
            wang18::save_image(ex, "wang18_surroundings_vpt", vimg[kAll], exposure);
            gl::Image pobj(W, H), vobj(W, H);
            for (int y = 0; y < H; ++y)
                for (int x = 0; x < W; ++x)
                    for (int ch = 0; ch < 3; ++ch) {
                        pobj.at(x, y, ch) = pimg[kObjDirect].at(x, y, ch) + pimg[kObjVia].at(x, y, ch);
                        vobj.at(x, y, ch) = vimg[kObjDirect].at(x, y, ch) + vimg[kObjVia].at(x, y, ch) +
                                            vimg[kObjLitByRoom].at(x, y, ch);
                    }
            wang18::save_image(ex, "wang18_surroundings_pb_object", pobj, exposure + 2.0);
            wang18::save_image(ex, "wang18_surroundings_vpt_object", vobj, exposure + 2.0);

            std::printf("Wang18 Sec. 3.5.1: bumpy sphere (%zu triangles, radius 20 green mean free paths, BmpS., g 0.7, eta 1.33) "
                        "on a %s floor before a diffuse wall, under the quad light; %d x %d pixels, %d point-based rays per "
                        "pixel (%d paths for the room's own light), VPT %d spp x 3 channels (8 batches)\n",
                        sc.shape.triangle_count(), room.glossy_floor ? "glossy (GGX alpha 0.15)" : "diffuse", W, H, rays, room_spp,
                        vpt_spp);
            std::printf("  %-30s %12s %12s %10s %18s\n", "light (image mean)", "point-based", "VPT", "VPT s.e.", "rel.diff");
            const char* names[kFilms] = {"all (room + object)", "object, seen directly", "object, through the room",
                                         "object lit by the room (VPT)"};
            gl_examples::Csv csv({"light", "pb_mean", "vpt_mean", "vpt_se", "rel_diff", "rel_se"});
            for (int k = 0; k < kFilms; ++k) {
                if (k == kObjLitByRoom)
                    std::printf("  %-30s %12s %12.5f %10.2e   (%.1f %% of the VPT's object light)\n", names[k], "-",
                                ref[std::size_t(k)], ref_se[std::size_t(k)], 100 * lit_by_room);
                else
                    std::printf("  %-30s %12.5f %12.5f %10.2e %+8.1f%% (+- %.1f%%)\n", names[k], pbm[std::size_t(k)],
                                ref[std::size_t(k)], ref_se[std::size_t(k)], 100 * rel(k), 100 * rel_se(k));
                csv.row_text({names[k], std::to_string(pbm[std::size_t(k)]), std::to_string(ref[std::size_t(k)]),
                              std::to_string(ref_se[std::size_t(k)]), std::to_string(rel(k)), std::to_string(rel_se(k))});
            }
            (void)ex.csv("wang18_surroundings.csv", csv);
            std::printf("  (object rows: the VPT's light that entered the medium straight from the light source, which the "
                        "point-based light samples gather; 'all' differs by design: no outside Fresnel reflection, no caustics "
                        "on the room, no light entering the object after a bounce in the room)\n");
            std::printf("  CPU: point-based %.2f s (light samples %.2f + render %.2f; MS table %.2f s%s), VPT %.2f s\n",
                        cpu_samples + cpu_pb, cpu_samples, cpu_pb, cpu_table, cached ? ", cached" : "", cpu_vpt);
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
                .num("seconds_table", cpu_table)
                .num("seconds_samples", cpu_samples)
                .num("seconds_pb", cpu_pb)
                .num("seconds_vpt", cpu_vpt)
                .str("png", (ex.out() / "wang18_surroundings_pb.png").string());
            return ex.finish(j);
        });
}
