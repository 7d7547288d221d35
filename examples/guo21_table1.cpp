// guo21_table1: Guo21 Table 1 / Sec. 6.8, render time and memory per scene, ours vs EPT. The
// paper's scenes are meshes we do not have: every row is the 1 m cube of guo21_fig18_absorption
// (large quad light above, black background) holding that row's particle count and PSD, rendered
// as explicit dielectric spheres (EPT, media/discrete_particles.hpp's ExplicitSphereMedium) and by
// ours -FD (DiscreteParticleMedium, r_c = 20 um) at equal spp. Table 1 excludes absorption, so all
// particles are non-absorbing. PSDs: CORNELL 1000 um (Fig. 12), DRAGON 10 um (our Fig. 14 set-up),
// BENCH / STAIRCASE / LAMP log-normal r_g = 800 um, sigma_g = 4 in [1, 2000] um (Figs. 17-18; LAMP's
// PSD is not in the text), HOUSE log-normal r_g = 100 um, sigma_g = 2 (Fig. 19's first row), ice
// (1.31) except STAIRCASE (1.5, Fig. 18). Counts: the paper's at full; at quick at most 3e5.
//
//   guo21_table1 [--quality quick|full] [--out DIR] [--seed S] [--threads N] [--spp N] [--width W]
//                [--checkpoint SECONDS] [--resume]
//
// Every render is split by rows over MPI ranks and resumable (--checkpoint / --resume); CPU seconds
// are the renders' process CPU time summed over the ranks.
//
// Printed beside the paper's minutes and memory (its spp, its machine): our render CPU seconds of
// both methods (ours' per-bin optics tables, computed once per scene, are reported apart), the ratio EPT / ours (paper: 1.2x for LAMP and CORNELL) and our memory (cloud + grid).
// Equal spp, not equal error (guo21_fig12_cornell measures time to unit variance). Last stdout line:
// JSON with lists scene, N, cpu_seconds_ept, cpu_seconds_ours, time_ratio, memory_mb_ours,
// bytes_per_particle, mean_ept, mean_ours and the paper's columns.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "common/harness.hpp"
#include "guo21_mpi_render.hpp"
#include "grainlight/integrators/discrete_vpt.hpp"
#include "grainlight/integrators/render.hpp"
#include "grainlight/media/discrete_particles.hpp"
#include "grainlight/packing/particle_cloud.hpp"
#include "grainlight/scene/camera.hpp"
#include "grainlight/scene/image_io.hpp"
#include "grainlight/scene/scene.hpp"
#include "grainlight/traversal/particle_grid.hpp"

namespace gl = grainlight;
using S = gl::Spectrum<1, float>;

namespace {

template <class Scene>
void build_scene(Scene& sc, int medium) {
    using Mat = gl::Material<float, S>;
    sc.add_shape(gl::BoxShape<float>(gl::Vec3f(-0.5f, 0.0f, -0.5f), gl::Vec3f(0.5f, 1.0f, 0.5f)), Mat::index_matched(), medium,
                 -1);
    sc.add_quad_light(gl::QuadShape<float>(gl::Vec3f(-1.5f, 2.25f, -1.5f), gl::Vec3f(3.0f, 0, 0), gl::Vec3f(0, 0, 3.0f)),
                      S(1.25f));
}

struct Row {
    std::string scene;
    double paper_n, paper_spp, paper_memory_mb, paper_ept_min, paper_ours_min;  // paper_ept_min < 0: "-"
    gl::CloudSpecies species;
    double eta, r_max_um;
};

}  // namespace

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "guo21_table1", "Guo21 Table 1: render time and memory per scene, ours vs EPT", "out/guo21_table1",
        [&](gl_examples::Example& ex) -> int {
            const int spp = ex.opt<int>("spp", 128, 1024, "samples per pixel (both methods)");
            const int width = ex.opt<int>("width", 128, 256, "image width (height = 3/4 width)");
            ex.checkpointable();
            ex.ready();
            guo21_mpi::quiet_other_ranks(ex);
            if (width < 8 || width > 8192) throw gl_examples::cli_error("--width must be in [8, 8192]");
            if (spp < 1 || spp > 65536) throw gl_examples::cli_error("--spp must be in [1, 65536]");
            const bool full = ex.full();
            const int height = width * 3 / 4;
            const double r_c = 20e-6;
            const gl::LogNormalPsd big(800, 4, 1, 2000), house(100, 2, 1, 2000);
            std::vector<Row> rows = {
                {"LAMP", 5e5, 1024, 49, 44, 36, gl::cloud_species(big), 1.31, 2000},
                {"CORNELL BOX", 1e5, 1024, 60, 16, 13, gl::cloud_species(gl::MonodispersePsd(1000.0)), 1.31, 1000},
                {"DRAGON", 1e5, 2048, 397, -1, 16, gl::cloud_species(gl::MonodispersePsd(10.0)), 1.31, 10},
                {"BENCH", 2e5, 2048, 52, -1, 20, gl::cloud_species(big), 1.31, 2000},
                {"STAIRCASE", 3e6, 4096, 138, -1, 53, gl::cloud_species(big), 1.5, 2000},
                {"HOUSE", 4e6, 1024, 545, -1, 38, gl::cloud_species(house), 1.31, 2000},
            };
            const gl::PinholeCamera<float> camera(gl::Vec3f(0.0f, 1.375f, 2.75f), gl::Vec3f(0.0f, 0.5f, 0.0f),
                                                  gl::Vec3f(0, 1, 0), 32.0f, width, height);
            gl::RenderOptions opt;
            opt.spp = spp;
            opt.threads = ex.threads();
            opt.seed = ex.seed();
            opt.vpt.max_depth = 256;

            std::printf("Guo21 Table 1 (Sec. 6.8): stand-in scenes (1 m cube), %dx%d, %d spp, ours -FD r_c = 20 um\n", width,
                        height, spp);
            std::printf("  %-12s %9s | %6s %8s %8s %8s | %9s %10s %10s %8s %9s %9s %9s\n", "scene", "N", "spp", "mem MB",
                        "EPT min", "ours min", "N (ours)", "EPT cpu s", "ours cpu s", "EPT/ours", "mem MB", "B/part", "optics s");
            gl_examples::Csv csv({"row", "paper_N", "paper_spp", "paper_memory_mb", "paper_ept_min", "paper_ours_min", "N",
                                  "cpu_seconds_ept", "cpu_seconds_ours", "time_ratio", "memory_mb_ours", "bytes_per_particle",
                                  "mean_ept", "mean_ours", "cpu_seconds_ours_optics"});
            std::vector<double> v_setup, v_n, v_te, v_to, v_ratio, v_mem, v_bpp, v_me, v_mo, p_n, p_mem, p_ept, p_ours;
            std::string names = "[";
            for (std::size_t k = 0; k < rows.size(); ++k) {
                const Row& row = rows[k];
                const auto N = std::uint64_t(full ? row.paper_n : std::min(row.paper_n, 3e5));
                auto cloud = std::make_shared<gl::ParticleCloud>(
                    gl::ParticleCloud::generate(gl::BoxBoundary(gl::Vec3d(-0.5, 0.0, -0.5), gl::Vec3d(0.5, 1.0, 0.5)), N,
                                                {row.species}, ex.seed() * 7919 + 100 + k, 1e6));
                gl::ParticleGridSettings gs;
                gs.dilation = r_c;
                const double h = std::max(std::cbrt(1.0 / double(N)), 2 * (r_c + row.r_max_um * 1e-6));
                const int res = int(std::clamp(std::ceil(1.0 / h), 1.0, 4096.0));
                gs.resolution = {res, res, res};
                // EPT: explicit dielectric spheres (default grid).
                double cpu_e = 0, mean_e = 0;
                {
                    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gl::ParticleGridSettings{});
                    using M = gl::ExplicitSphereMedium<float>;
                    gl::Scene<M> sc;
                    build_scene(sc, sc.add_medium(M(grid, float(row.eta))));
                    auto bar = ex.progress("EPT " + row.scene, std::uint64_t(height));
                    // This rank's rows, its checkpoint, gathered on every rank; CPU seconds summed over ranks.
                    guo21_mpi::RankClock clock;
                    const gl::Image img = guo21_mpi::render_image(
                        ex, opt, "ept_" + std::to_string(k),
                        [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_discrete_vpt(sc, camera, o, prog); },
                        [&](int n) { bar.advance(std::uint64_t(n)); }, &clock);
                    cpu_e = guo21_mpi::sum_over_ranks(ex.mpi(), clock.cpu);
                    bar.done();
                    mean_e = img.mean(0);
                }
                double cpu_o = 0, mean_o = 0, mem = 0, setup_o = 0;
                {
                    auto grid = std::make_shared<gl::ParticleGrid>(*cloud, gs);
                    gl::DiscreteMediumSettings ms;
                    ms.query_radius = r_c;
                    ms.diffraction = false;
                    gl::ParticleModel model;
                    model.particle_index = {row.eta, 0.0};
                    using M = gl::DiscreteParticleMedium<float>;
                    const std::clock_t c1 = std::clock();
                    gl::Scene<M> sc;
                    build_scene(sc, sc.add_medium(M(grid, {model}, ms)));
                    setup_o = double(std::clock() - c1) / CLOCKS_PER_SEC;  // per-bin optics tables, reported apart
                    mem = double(sc.medium(0).memory_bytes());
                    auto bar = ex.progress("ours " + row.scene, std::uint64_t(height));
                    guo21_mpi::RankClock clock;
                    const gl::Image img = guo21_mpi::render_image(
                        ex, opt, "ours_" + std::to_string(k),
                        [&](const gl::RenderOptions& o, auto&& prog) { return gl::render_discrete_vpt(sc, camera, o, prog); },
                        [&](int n) { bar.advance(std::uint64_t(n)); }, &clock);
                    cpu_o = guo21_mpi::sum_over_ranks(ex.mpi(), clock.cpu);
                    bar.done();
                    mean_o = img.mean(0);
                }
                const double ratio = cpu_e / cpu_o;
                char pe[16];
                if (row.paper_ept_min < 0) std::snprintf(pe, sizeof pe, "-");
                else std::snprintf(pe, sizeof pe, "%.0f", row.paper_ept_min);
                std::printf("  %-12s %9.0e | %6.0f %8.0f %8s %8.0f | %9.0e %10.2f %10.2f %7.2fx %9.1f %9.1f %9.2f\n",
                            row.scene.c_str(), row.paper_n, row.paper_spp, row.paper_memory_mb, pe, row.paper_ours_min, double(N),
                            cpu_e, cpu_o, ratio, mem / 1e6, mem / double(N), setup_o);
                csv.row({double(k), row.paper_n, row.paper_spp, row.paper_memory_mb, row.paper_ept_min, row.paper_ours_min,
                         double(N), cpu_e, cpu_o, ratio, mem / 1e6, mem / double(N), mean_e, mean_o, setup_o});
                names += (k ? "," : "") + gl_examples::Json::quote(row.scene);
                v_n.push_back(double(N));
                v_te.push_back(cpu_e);
                v_to.push_back(cpu_o);
                v_ratio.push_back(ratio);
                v_mem.push_back(mem / 1e6);
                v_bpp.push_back(mem / double(N));
                v_me.push_back(mean_e);
                v_mo.push_back(mean_o);
                v_setup.push_back(setup_o);
                p_n.push_back(row.paper_n);
                p_mem.push_back(row.paper_memory_mb);
                p_ept.push_back(row.paper_ept_min);
                p_ours.push_back(row.paper_ours_min);
            }
            names += "]";
            if (!ex.root()) return ex.finish({});  // only rank 0 writes
            ex.csv("guo21_table1.csv", csv);
            std::printf("  paper: ours 1.2x faster than EPT for LAMP and CORNELL BOX (minutes at the paper's spp on its "
                        "machine; memory incl. the scene); ours: equal-spp CPU time on stand-in scenes, memory = cloud + grid\n");
            gl_examples::Json j = ex.summary();
            j.integer("width", width)
                .integer("height", height)
                .integer("spp", spp)
                .raw("scene", names)
                .nums("N", v_n)
                .nums("cpu_seconds_ept", v_te)
                .nums("cpu_seconds_ours", v_to)
                .nums("time_ratio", v_ratio)
                .nums("memory_mb_ours", v_mem)
                .nums("bytes_per_particle", v_bpp)
                .nums("mean_ept", v_me)
                .nums("mean_ours", v_mo)
                .nums("cpu_seconds_ours_optics", v_setup)
                .nums("paper_N", p_n)
                .nums("paper_memory_mb", p_mem)
                .nums("paper_ept_minutes", p_ept)
                .nums("paper_ours_minutes", p_ours)
                .num("bytes_per_particle_max", *std::max_element(v_bpp.begin(), v_bpp.end()))
                .str("cpu_seconds_note", "process CPU seconds of the renders, summed over the ranks");
            guo21_mpi::rank_rows(j, ex, height);
            return ex.finish(j);
        });
}
