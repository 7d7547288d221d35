// wang18_fig12_components: Wang & Holzschuch 2018 (TVCG), Fig. 12 ("Individual component
// validation on the Bumpy Sphere scene"): every component of the point-based renderer
// (single Eq. 5, double Eq. 6, multiple Eq. 7, bounced Eq. 8, total Eq. 9) beside the
// reference's, on a bumpy sphere mesh (a displaced icosphere standing in for the paper's mesh;
// Poisson-disk surface samples on it) of radius 20 green mean free paths, BmpS. material, g 0.7.
// The reference is the library's VPT through the same mesh, uncapped (see examples/wang18_bumpy.hpp).
// Paper: 1 min for all components vs 6 h for UPBP (360x), memory 4x smaller.
//
//   wang18_fig12_components [--quality quick|full] [--out DIR] [--seed S] [--threads N]
//                           [--vpt-spp N] [--surface-samples N] [--width N] [--eps1 E] [--obj MESH.obj]
//
// Outputs: wang18_fig12_{pb,vpt}_<component>.{exr,png}, wang18_fig12_components.csv; the JSON
// summary (last stdout line) has rel_diff_<component> with rel_se_<component>, e2_<component>,
// speedup_equal_error, the times and memory.
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "grainlight/integrators/ms_table_symmetric.hpp"
#include "wang18_bumpy.hpp"

namespace gl = grainlight;

int main(int argc, char** argv) {
    return gl_examples::run(
        argc, argv, "wang18_fig12_components",
        "Wang18 Fig. 12: each point-based component on a bumpy sphere mesh beside the VPT's", "out/wang18_fig12_components",
        [&](gl_examples::Example& ex) -> int {
            const int vpt_spp = ex.opt<int>("vpt-spp", 256, 2048, "VPT samples per pixel and channel (multiple of 8)");
            const int n_surface = ex.opt<int>("surface-samples", 12000, 40000, "Poisson-disk light surface samples on the mesh");
            const int builds = ex.opt<int>("builds", 3, 2, "independent light-sample builds averaged (their spread is the point-based noise)");
            const int rays = ex.opt<int>("rays", 4, 1, "camera rays per pixel of the point-based render");
            const int W = ex.opt<int>("width", 32, 96, "image width = height in pixels");
            const double eps1 = ex.opt<double>("eps1", 1.0, 0.2, "Alg. 1 solid-angle threshold eps1 (sr); eps2 = eps1 / 5");
            const double R_opt = ex.opt<double>("radius-mfp", 20.0, "sphere radius in green mean free paths");
            const double tol = ex.opt<double>("table-tolerance", 0.0,
                                              "quadtree compression tolerance of the MS table (relative to its peak; 0 lossless)");
            const double merge = ex.opt<double>("table-merge", 0.0,
                                                "quadtree merge tolerance of the MS table (relative power-weighted L1 error of "
                                                "merged blocks; 0: no merging)");
            const int sym = ex.opt<int>("symmetric-lobes", 0,
                                        "render with the MS table's lobes made symmetric about the source-to-point axis "
                                        "with this many axis bins (Wang18 Sec. 4.1's GPU table; 0: the full lobes)");
            const int level = ex.opt<int>("mesh-level", 4, "icosphere subdivision level of the bumpy sphere (20 4^level triangles)");
            const double bumps = ex.opt<double>("bumps", 0.06, "relative height of the bumps");
            const std::string obj = ex.opt<std::string>(
                "obj", "", "a closed Wavefront OBJ mesh as the boundary instead of the bumpy sphere (scaled to radius 1)");
            ex.checkpointable();
            ex.ready();
            if (vpt_spp < 16 || vpt_spp % wang18::kBatches != 0)
                throw gl_examples::cli_error("--vpt-spp must be >= 16 and a multiple of 8");
            if (n_surface < 16 || n_surface > 10000000) throw gl_examples::cli_error("--surface-samples must be in [16, 1e7]");
            if (builds < 1 || builds > 64) throw gl_examples::cli_error("--builds must be in [1, 64]");
            if (rays < 1 || rays > 1024) throw gl_examples::cli_error("--rays must be in [1, 1024]");
            if (W < 4 || W > 2048) throw gl_examples::cli_error("--width must be in [4, 2048]");
            if (!(eps1 > 0 && eps1 <= 10)) throw gl_examples::cli_error("--eps1 must be in (0, 10]");
            if (!(R_opt > 0.5 && R_opt <= 200)) throw gl_examples::cli_error("--radius-mfp must be in (0.5, 200]");
            if (!(tol >= 0 && tol < 0.1)) throw gl_examples::cli_error("--table-tolerance must be in [0, 0.1)");
            if (!(merge >= 0 && merge < 1)) throw gl_examples::cli_error("--table-merge must be in [0, 1)");
            if (sym < 0 || sym > 1024) throw gl_examples::cli_error("--symmetric-lobes must be in [0, 1024]");
            if (level < 1 || level > 7) throw gl_examples::cli_error("--mesh-level must be in [1, 7]");
            if (!(bumps >= 0 && bumps < 0.3)) throw gl_examples::cli_error("--bumps must be in [0, 0.3)");
            const bool full = ex.full();
            const auto& out = ex.out();
            const std::uint64_t seed = ex.seed();

            const wang18::BumpyScene sc = wang18::make_bumpy_scene(W, float(R_opt), 0.7f, level, bumps, obj);
            double cpu_table = 0;
            bool cached = false;
            const gl::MsTable<3> table_full = wang18::cached_table(out, sc, full, seed, cpu_table, cached, ex.root());
            // Sec. 4.1's symmetric lobes, written back onto the full direction grid so the renderer reads them unchanged.
            std::size_t sym_bytes = 0;
            const gl::MsTable<3> table = [&] {
                if (sym == 0) return table_full;
                const gl::MsSymmetricTable<3> s(table_full, std::uint32_t(sym));
                sym_bytes = s.bytes();
                return s.expand();
            }();
            const gl::MsTableQuadtree<3> qtree(table, tol, merge);
            // Table 2's table: 1024 x 512 (rho, z) cells x 36 x 18 directions x 3 channels of floats.
            const double paper_dense_bytes = 1024.0 * 512.0 * 36.0 * 18.0 * 3.0 * 4.0;
            gl::PointBasedOptions<float> po = wang18::default_options(sc, full);
            po.cut.eps1 = float(eps1);
            po.cut.eps2 = 0.2f * float(eps1);
            std::vector<wang18::PbRun> runs;
            for (int b = 0; b < builds; ++b)
                runs.push_back(wang18::render_pb(ex, sc, &table, po, n_surface, seed + 1000 * std::uint64_t(b),
                                                 "fig12 point-based build " + std::to_string(b + 1), rays, &qtree));
            std::array<double, wang18::kComp> pb_se{};
            const wang18::PbRun pb = wang18::average_runs(runs, pb_se);
            const wang18::VptRun vpt = wang18::render_vpt(ex, sc, vpt_spp, seed, "fig12 VPT reference");
            wang18::Comparison c = wang18::compare(pb, vpt);
            // The relative difference's standard error: the reference's batches and the builds.
            for (int k = 0; k < wang18::kComp; ++k)
                c.rel_se[k] = c.ref[k] > 0 ? std::hypot(c.ref_se[k], pb_se[std::size_t(k)]) / c.ref[k] : 0.0;

            if (!ex.root()) return ex.finish({});  // rank 0 writes and prints
            const double exposure = 4.0;
            for (int k = 0; k < wang18::kComp; ++k) {
                const std::string nm = wang18::kCompName[k];
                wang18::save_image(ex, "wang18_fig12_pb_" + nm, pb.img[std::size_t(k)], exposure);
                wang18::save_image(ex, "wang18_fig12_vpt_" + nm, vpt.img[std::size_t(k)], exposure);
            }
            if (!obj.empty()) std::printf("Boundary mesh: %s\n", obj.c_str());
            std::printf("Wang18 Fig. 12: bumpy sphere mesh (%zu triangles, bumps %.2f), radius %.0f green mean free paths, "
                        "BmpS. material, g 0.7, eta 1.33; %d x %d pixels\n",
                        sc.shape.triangle_count(), bumps, R_opt, W, W);
            std::printf("  %d independent light-sample builds averaged, %d camera rays per pixel; rel.diff s.e. = reference "
                        "batches and the builds' spread\n",
                        builds, rays);
            std::printf("  %d Poisson-disk surface samples (radius %.4f), %zu volume samples, %d bounce samples; MS table "
                        "%ux%ux%ux%u (%.2f s%s)\n",
                        pb.surface_samples, pb.poisson_radius, pb.volume_samples, po.bounce_samples, table.grid().n_rho,
                        table.grid().n_z, table.grid().n_theta, table.grid().n_phi, cpu_table, cached ? ", cached" : "");
            std::printf("  MS table read from its quadtree (tolerance %g, merge %g): %.2f MB dense -> %.2f MB compressed (%zu of "
                        "%zu cells read %zu stored lobes, %zu merged blocks)   [paper Table 2: %.1f GB dense at 1024 x 512 x 36 x 18 (our count: %.2f GB of floats) -> "
                        "36-72 MB per material; that grid needs > 4 GB here and is not built]\n",
                        tol, merge, double(qtree.dense_bytes()) / 1e6, double(qtree.bytes()) / 1e6, qtree.stored_cells(),
                        table.grid().cells(), qtree.stored_lobes(), qtree.merged_leaves(), 8.4, paper_dense_bytes / 1e9);
            if (sym > 0)
                std::printf("  MS lobes made symmetric about the source-to-point axis (%d axis bins, Sec. 4.1): %.2f MB instead of "
                            "%.2f MB dense\n",
                            sym, double(sym_bytes) / 1e6, double(table_full.bytes()) / 1e6);
            std::printf("  %-9s %12s %12s %10s %9s %11s\n", "component", "point-based", "VPT", "VPT s.e.", "rel.diff", "e^2");
            gl_examples::Csv csv({"component", "pb_mean", "vpt_mean", "vpt_se", "rel_diff", "rel_se", "mse", "e2"});
            for (int k = 0; k < wang18::kComp; ++k) {
                std::printf("  %-9s %12.5f %12.5f %10.2e %+8.1f%% (+- %.1f%%) %10.3e\n", wang18::kCompName[k], c.pb[k],
                            c.ref[k], c.ref_se[k], 100 * c.rel[k], 100 * c.rel_se[k], c.e2[k]);
                csv.row_text({wang18::kCompName[k], std::to_string(c.pb[k]), std::to_string(c.ref[k]),
                              std::to_string(c.ref_se[k]), std::to_string(c.rel[k]), std::to_string(c.rel_se[k]),
                              std::to_string(c.mse[k]), std::to_string(c.e2[k])});
            }
            (void)ex.csv("wang18_fig12_components.csv", csv);
            std::printf("  bounced light (boundary reflection between events): %.1f%% of the reference's scattered light\n",
                        100 * c.bounced_share);
            std::printf("  CPU: point-based %.2f s (samples %.2f + render %.2f), %.1f MB samples + %.1f MB compressed table; VPT %.2f s "
                        "(%d spp x 3 channels)\n",
                        pb.cpu_total(), pb.cpu_samples, pb.cpu_render, double(pb.bytes) / 1e6, double(qtree.bytes()) / 1e6,
                        vpt.cpu, vpt_spp);
            std::printf("  equal error (total): e^2 = %.3e, VPT variance per sample %.3e (batch halves agree to %.2f) -> "
                        "speed-up %.2fx   [paper Fig. 12: 1 min vs 6 h for UPBP, 360x]\n",
                        c.e2[4], c.ref_var_per_sample, c.var_half_ratio, c.speedup);

            gl_examples::Json j = ex.summary();
            j.integer("width", W).integer("rays", rays).integer("builds", builds).integer("vpt_spp", vpt_spp).integer("surface_samples", pb.surface_samples);
            wang18::put_rank_rows(ex, j, W);
            j.integer("triangles", (long long)sc.shape.triangle_count()).integer("volume_samples", (long long)pb.volume_samples);
            for (int k = 0; k < wang18::kComp; ++k) {
                const std::string nm = wang18::kCompName[k];
                j.num("pb_" + nm, c.pb[k]).num("vpt_" + nm, c.ref[k]);
                j.num("rel_diff_" + nm, c.rel[k]).num("rel_se_" + nm, c.rel_se[k]).num("e2_" + nm, c.e2[k]);
                j.num("pb_build_rel_se_" + nm, c.ref[k] > 0 ? pb_se[std::size_t(k)] / c.ref[k] : 0.0);
            }
            j.num("bounced_share", c.bounced_share)
                .num("seconds_table", cpu_table)
                .num("seconds_samples", pb.cpu_samples)
                .num("seconds_pb", pb.cpu_render)
                .num("seconds_vpt", vpt.cpu)
                .num("memory_mb_samples", double(pb.bytes) / 1e6)
                .num("memory_mb_table", double(table.bytes()) / 1e6)
                .num("memory_mb_table_compressed", double(qtree.bytes()) / 1e6)
                .num("table_tolerance", tol)
                .num("table_merge_tolerance", merge)
                .integer("symmetric_lobes", sym)
                .num("memory_mb_table_symmetric", double(sym_bytes) / 1e6)
                .num("paper_table_dense_gb", 8.4)
                .num("vpt_variance_per_sample", c.ref_var_per_sample)
                .num("vpt_variance_half_ratio", c.var_half_ratio)
                .num("speedup_equal_error", c.speedup)
                .num("paper_speedup", 360.0)
                .str("png", (out / "wang18_fig12_pb_total.png").string());
            return ex.finish(j);
        });
}
