// Hand-written pieces against the Debian libraries that cover the same job (the ecosystem issue's
// "well-kept libraries instead of hand-written code where they serve better"), one binary, same
// data, side by side. The third-party baselines live here, not in the library, and are compiled
// only when their headers are installed (Debian: libtinyobjloader-dev, nlohmann-json3-dev):
//   - OBJ loading: grainlight::load_obj vs tinyobjloader's ObjReader (triangulate on), on an
//     icosphere of 327 680 triangles written as a plain v/f file (items/s = triangles/s);
//   - JSON summary lines: the examples' gl_examples::Json vs nlohmann::json dump, 12 numeric fields.
// docs/architecture.md ("Libraries we did not adopt") quotes the numbers.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/output.hpp"
#include "grainlight/geometry/grains.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

#if __has_include(<tiny_obj_loader.h>)
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>
#define GRAINLIGHT_BENCH_TINYOBJ 1
#endif
#if __has_include(<nlohmann/json.hpp>)
#include <nlohmann/json.hpp>
#define GRAINLIGHT_BENCH_NLOHMANN 1
#endif

namespace gl = grainlight;

namespace {

const std::string& obj_file() {
    static const std::string path = [] {
        const auto p = std::filesystem::temp_directory_path() / "grainlight_bench_icosphere7.obj";
        const auto m = gl::make_icosphere<double>(7);
        std::ofstream f(p);
        char buf[96];
        for (const auto& v : m.vertices) {
            std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", v.x, v.y, v.z);
            f << buf;
        }
        for (const auto& t : m.triangles) f << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
        return p.string();
    }();
    return path;
}

void BM_load_obj_grainlight(benchmark::State& st) {
    const auto& p = obj_file();
    std::size_t tris = 0;
    for (auto _ : st) {
        const auto m = gl::load_obj<float>(p);
        tris = m.triangles.size();
        benchmark::DoNotOptimize(m.vertices.data());
    }
    st.SetItemsProcessed(std::int64_t(st.iterations()) * std::int64_t(tris));
}
BENCHMARK(BM_load_obj_grainlight)->Unit(benchmark::kMillisecond);

#if defined(GRAINLIGHT_BENCH_TINYOBJ)
void BM_load_obj_tinyobjloader(benchmark::State& st) {
    const auto& p = obj_file();
    std::size_t tris = 0;
    for (auto _ : st) {
        tinyobj::ObjReader r;
        tinyobj::ObjReaderConfig cfg;
        cfg.triangulate = true;
        if (!r.ParseFromFile(p, cfg)) st.SkipWithError("tinyobjloader failed");
        tris = r.GetShapes().empty() ? 0 : r.GetShapes()[0].mesh.indices.size() / 3;
        benchmark::DoNotOptimize(r.GetAttrib().vertices.data());
    }
    st.SetItemsProcessed(std::int64_t(st.iterations()) * std::int64_t(tris));
}
BENCHMARK(BM_load_obj_tinyobjloader)->Unit(benchmark::kMillisecond);
#endif

void BM_json_line_examples(benchmark::State& st) {
    for (auto _ : st) {
        gl_examples::Json j;
        for (int k = 0; k < 12; ++k) j.num("field_" + std::to_string(k), 0.1234567 * k + 1e-3);
        auto s = j.str();
        benchmark::DoNotOptimize(s.data());
    }
}
BENCHMARK(BM_json_line_examples);

#if defined(GRAINLIGHT_BENCH_NLOHMANN)
void BM_json_line_nlohmann(benchmark::State& st) {
    for (auto _ : st) {
        nlohmann::json j;
        for (int k = 0; k < 12; ++k) j["field_" + std::to_string(k)] = 0.1234567 * k + 1e-3;
        auto s = j.dump();
        benchmark::DoNotOptimize(s.data());
    }
}
BENCHMARK(BM_json_line_nlohmann);
#endif

}  // namespace
