/// @file grainlight/geometry/grains.hpp
/// Procedural grain meshes and grain materials for the virtual scatterometer (Meng15 Sec. 4.2)
/// and for explicit path tracing of grains (Meng15 Sec. 3.2).
///
/// Every procedural grain is star-shaped around the origin: it is a subdivided icosahedron whose
/// vertices are pushed to the radius r(w) of a shape function, so the mesh is watertight and
/// consistently oriented by construction. It is then scaled so that its bounding sphere centred at
/// the origin (the largest vertex distance) has exactly the requested radius R. In a packing the
/// bounding sphere has radius 1 and R <= 1 (a grain larger than its bounding sphere is an error).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "grainlight/core/error.hpp"
#include "grainlight/core/math.hpp"
#include "grainlight/core/rng.hpp"
#include "grainlight/core/spectrum.hpp"
#include "grainlight/core/vector.hpp"
#include "grainlight/geometry/triangle_mesh.hpp"

namespace grainlight {

/// Validate the radius of a grain that must fit in its unit bounding sphere: (0, 1].
inline void check_grain_radius(std::string_view where, std::string_view param, double radius) {
    check_argument(radius > 0.0 && radius <= 1.0, where, param, radius,
                   "(0, 1] (the grain must fit in its unit bounding sphere)");
}

/// Validate a grain mesh for its unit bounding sphere: a valid mesh, every vertex within the unit
/// sphere, watertight, outward normals (positive signed volume). Returns its bounding radius.
inline double check_grain_mesh(std::string_view where, const TriangleMesh<float>& mesh) {
    mesh.validate(std::string(where));
    const double r = double(mesh.max_vertex_radius());
    check_argument(r > 0.0 && r <= 1.0 + 1e-6, where, "bounding radius of the mesh", r,
                   "(0, 1] (the grain must fit in its unit bounding sphere)");
    check_argument(mesh.is_watertight(), where, "watertight", "no", "a closed, consistently oriented mesh");
    check_argument(mesh.signed_volume() > 0.0, where, "signed volume", mesh.signed_volume(), "> 0 (outward normals)");
    return r;
}

/// Procedural grain shapes.
enum class GrainShape {
    sphere,   ///< a sphere (the scatterometer intersects it analytically; the mesh is for renderers)
    snow,     ///< bumpy, irregular rounded grain: sum of random Gaussian lobes on a sphere
    crystal,  ///< rounded cube (superquadric |x|^p + |y|^p + |z|^p = 1, p = 6) with slightly jittered faces: salt/sugar
    rice,     ///< prolate ellipsoid, axes 1 : 0.38 : 0.34, slightly bent
    flake     ///< flat oblate, irregular-outline flake, axes 1 : 0.9 : 0.18
};

/// Name <-> enum ("sphere", "snow", "crystal", "rice", "flake").
[[nodiscard]] inline std::string_view to_string(GrainShape s) noexcept {
    switch (s) {
        case GrainShape::sphere: return "sphere";
        case GrainShape::snow: return "snow";
        case GrainShape::crystal: return "crystal";
        case GrainShape::rice: return "rice";
        case GrainShape::flake: return "flake";
    }
    return "?";
}
/// Throws grainlight::invalid_argument for an unknown name.
[[nodiscard]] inline GrainShape grain_shape_from_string(std::string_view name) {
    for (GrainShape s : {GrainShape::sphere, GrainShape::snow, GrainShape::crystal, GrainShape::rice, GrainShape::flake})
        if (to_string(s) == name) return s;
    raise_invalid_argument("grain_shape_from_string", "shape", std::string(name), "sphere|snow|crystal|rice|flake");
}

/// Unit icosphere: the icosahedron subdivided `level` times (20 * 4^level triangles), vertices
/// on the unit sphere, outward-facing counter-clockwise triangles, shared vertices (watertight).
template <std::floating_point F = float>
[[nodiscard]] inline TriangleMesh<F> make_icosphere(int level) {
    check_argument(level >= 0 && level <= 8, "make_icosphere", "level", level, "[0, 8]");
    TriangleMesh<double> m;
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    const double vs[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                              {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    for (auto& v : vs) m.vertices.push_back(glm::normalize(Vec3d(v[0], v[1], v[2])));
    m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                   {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                   {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int l = 0; l < level; ++l) {
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
        auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
            const auto key = std::minmax(a, b);
            auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            const auto id = std::uint32_t(m.vertices.size());
            m.vertices.push_back(glm::normalize(m.vertices[a] + m.vertices[b]));
            mid.emplace(key, id);
            return id;
        };
        std::vector<std::array<std::uint32_t, 3>> next;
        next.reserve(m.triangles.size() * 4);
        for (const auto& tri : m.triangles) {
            const std::uint32_t a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
            next.push_back({tri[0], a, c});
            next.push_back({tri[1], b, a});
            next.push_back({tri[2], c, b});
            next.push_back({a, b, c});
        }
        m.triangles = std::move(next);
    }
    TriangleMesh<F> out;
    out.vertices.reserve(m.vertices.size());
    for (const auto& v : m.vertices) out.vertices.emplace_back(Vec3<F>(v));
    out.triangles = std::move(m.triangles);
    out.compute_face_normals();
    return out;
}

namespace detail {

/// Radius of the (unscaled) grain surface in unit direction w; shapes are star-shaped.
struct GrainRadiusFunction {
    GrainShape shape = GrainShape::sphere;
    // snow: Gaussian lobes (direction, amplitude, angular width)
    std::vector<std::array<double, 5>> lobes;
    // crystal: jitter of the six face distances; rice/flake: axes and outline wobble
    std::array<double, 6> face{1, 1, 1, 1, 1, 1};
    std::array<double, 4> wobble{0, 0, 0, 0};

    [[nodiscard]] double operator()(const Vec3d& w) const noexcept {
        switch (shape) {
            case GrainShape::sphere: return 1.0;
            case GrainShape::snow: {
                double r = 1.0;
                for (const auto& l : lobes) {
                    const double c = w.x * l[0] + w.y * l[1] + w.z * l[2];
                    r += l[3] * std::exp((c - 1.0) / l[4]);
                }
                return r;
            }
            case GrainShape::crystal: {
                // Superquadric with per-face half-widths: r = (sum |w_i / a_i|^p)^(-1/p).
                const double p = 6.0;
                const double ax = w.x >= 0 ? face[0] : face[1], ay = w.y >= 0 ? face[2] : face[3],
                             az = w.z >= 0 ? face[4] : face[5];
                const double s = std::pow(std::abs(w.x / ax), p) + std::pow(std::abs(w.y / ay), p) +
                                 std::pow(std::abs(w.z / az), p);
                return std::pow(s, -1.0 / p);
            }
            case GrainShape::rice: {
                const double a = 1.0, b = 0.38, c = 0.34;
                // bend: the long axis curves slightly toward +y
                const double wy = w.y - wobble[0] * (w.x * w.x);
                return 1.0 / std::sqrt(sqr(w.x / a) + sqr(wy / b) + sqr(w.z / c));
            }
            case GrainShape::flake: {
                const double phi = std::atan2(w.y, w.x);
                const double outline =
                    1.0 + wobble[0] * std::cos(3.0 * phi + wobble[1]) + wobble[2] * std::cos(5.0 * phi + wobble[3]);
                const double a = outline, b = 0.9 * outline, c = 0.18;
                return 1.0 / std::sqrt(sqr(w.x / a) + sqr(w.y / b) + sqr(w.z / c));
            }
        }
        return 1.0;
    }
};

inline GrainRadiusFunction make_radius_function(GrainShape shape, std::uint64_t seed) {
    GrainRadiusFunction f;
    f.shape = shape;
    Pcg32 rng = Pcg32::from_key(seed, 0x67726169ull /* "grai" */, std::uint64_t(shape));
    switch (shape) {
        case GrainShape::sphere: break;
        case GrainShape::snow: {
            // 14 lobes of random height (+-) and width: a rounded, irregular, bumpy grain.
            for (int i = 0; i < 14; ++i) {
                const double z = 1.0 - 2.0 * rng.next_double(), ph = 2.0 * pi_v<double> * rng.next_double();
                const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
                const double amp = (i < 9 ? 0.28 : -0.15) * (0.4 + 0.6 * rng.next_double());
                const double width = 0.05 + 0.12 * rng.next_double();
                f.lobes.push_back({s * std::cos(ph), s * std::sin(ph), z, amp, width});
            }
            break;
        }
        case GrainShape::crystal:
            for (auto& a : f.face) a = 0.9 + 0.2 * rng.next_double();
            break;
        case GrainShape::rice: f.wobble[0] = 0.1 + 0.1 * rng.next_double(); break;
        case GrainShape::flake:
            f.wobble = {0.06 + 0.06 * rng.next_double(), 2 * pi_v<double> * rng.next_double(),
                        0.03 + 0.04 * rng.next_double(), 2 * pi_v<double> * rng.next_double()};
            break;
    }
    return f;
}

}  // namespace detail

/// Procedural grain mesh of the given shape, seed and icosphere subdivision level (20 * 4^level
/// triangles; 5 gives 20480), scaled so its origin-centred bounding sphere has radius
/// `bounding_radius` (> 0; <= 1 for use inside a packing's unit bounding sphere, which the
/// scatterometer checks). Watertight with outward normals. The same (shape, seed, level) always
/// gives the same mesh.
template <std::floating_point F = float>
[[nodiscard]] inline TriangleMesh<F> make_grain_mesh(GrainShape shape, F bounding_radius, std::uint64_t seed = 1,
                                                     int level = 5) {
    check_argument(bounding_radius > F(0) && std::isfinite(bounding_radius), "make_grain_mesh", "bounding_radius",
                   bounding_radius, "(0, inf)");
    const TriangleMesh<double> base = make_icosphere<double>(level);
    const detail::GrainRadiusFunction radius = detail::make_radius_function(shape, seed);
    std::vector<Vec3d> pts(base.vertices.size());
    double rmax = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
        pts[i] = base.vertices[i] * radius(base.vertices[i]);
        rmax = std::max(rmax, glm::length(pts[i]));
    }
    TriangleMesh<F> mesh;
    mesh.vertices.reserve(pts.size());
    const double scale = double(bounding_radius) / rmax;
    for (const auto& p : pts) mesh.vertices.emplace_back(Vec3<F>(p * scale));
    mesh.triangles = base.triangles;
    mesh.compute_face_normals();
    mesh.validate("make_grain_mesh");
    return mesh;
}

/// How light interacts with a grain (Meng15 Table 1's materials).
enum class GrainMaterialKind {
    dielectric,             ///< smooth lossless dielectric (glass beads, salt, sugar, snow/ice)
    absorbing_dielectric,   ///< smooth dielectric enclosing a homogeneous absorbing/scattering medium (sand)
    diffuse                 ///< opaque Lambertian surface (flour)
};

/// Name of a material kind ("dielectric", "absorbing-dielectric", "diffuse").
[[nodiscard]] inline std::string_view to_string(GrainMaterialKind k) noexcept {
    switch (k) {
        case GrainMaterialKind::dielectric: return "dielectric";
        case GrainMaterialKind::absorbing_dielectric: return "absorbing-dielectric";
        case GrainMaterialKind::diffuse: return "diffuse";
    }
    return "?";
}

/// Grain material, per channel where it varies (ChannelValues: grey, RGB or any number of spectral
/// samples; a render with Spectrum<N> accepts grey values or exactly N channels, see
/// `compatible_with`). Lengths (interior coefficients) are in units
/// of the *bounding-sphere* radius (the scatterometer's unit), so sigma_a = 1 means one mean free
/// path per bounding-sphere radius.
struct GrainMaterial {
    /// Which model applies.
    GrainMaterialKind kind = GrainMaterialKind::dielectric;
    double ior = 1.5;                          ///< relative index of refraction (> 0, != 1 allowed)
    ChannelValues interior_sigma_a{0.0};       ///< absorption coefficient inside (absorbing_dielectric)
    ChannelValues interior_sigma_s{0.0};       ///< scattering coefficient inside (absorbing_dielectric)
    double interior_g = 0.0;                   ///< HG asymmetry of the interior phase function (0 = isotropic)
    ChannelValues albedo{0.8};                 ///< Lambertian albedo (diffuse)

    /// Smooth lossless dielectric of relative index `ior` (validated).
    [[nodiscard]] static GrainMaterial make_dielectric(double ior) {
        GrainMaterial m;
        m.kind = GrainMaterialKind::dielectric;
        m.ior = ior;
        m.validate();
        return m;
    }
    /// Dielectric enclosing a medium (sigma per bounding radius, HG g), validated.
    [[nodiscard]] static GrainMaterial make_absorbing_dielectric(double ior, ChannelValues sigma_a, ChannelValues sigma_s = 0.0,
                                                                 double g = 0.0) {
        GrainMaterial m;
        m.kind = GrainMaterialKind::absorbing_dielectric;
        m.ior = ior;
        m.interior_sigma_a = sigma_a;
        m.interior_sigma_s = sigma_s;
        m.interior_g = g;
        m.validate();
        return m;
    }
    /// Lambertian grain with per-channel albedo in [0, 1] (validated).
    [[nodiscard]] static GrainMaterial make_diffuse(ChannelValues albedo) {
        GrainMaterial m;
        m.kind = GrainMaterialKind::diffuse;
        m.albedo = albedo;
        m.validate();
        return m;
    }
    /// True if every channel behaves identically (one traced path serves all channels).
    [[nodiscard]] bool is_grey() const noexcept {
        switch (kind) {
            case GrainMaterialKind::dielectric: return true;
            case GrainMaterialKind::absorbing_dielectric: return interior_sigma_a.is_grey() && interior_sigma_s.is_grey();
            case GrainMaterialKind::diffuse: return albedo.is_grey();
        }
        return true;
    }
    /// Number of channels the material varies over (1 when grey; else the channel count of its
    /// non-grey values).
    [[nodiscard]] std::size_t channels() const noexcept {
        std::size_t n = 1;
        for (const ChannelValues* v : {&interior_sigma_a, &interior_sigma_s, &albedo})
            if (!v->is_grey()) n = std::max(n, v->size());
        return n;
    }
    /// Usable by a render with `n` spectrum channels (every non-grey value has exactly n channels).
    [[nodiscard]] bool compatible_with(std::size_t n) const noexcept {
        return interior_sigma_a.compatible_with(n) && interior_sigma_s.compatible_with(n) && albedo.compatible_with(n);
    }
    /// Throws grainlight::invalid_argument unless the material can be rendered with `n` channels.
    void check_channels(std::size_t n, const char* where) const {
        check_argument(compatible_with(n), where, "material channels", channels(),
                       "1 (grey) or " + std::to_string(n) + " (the spectrum's channel count)");
    }
    /// Throws grainlight::invalid_argument naming the bad parameter.
    void validate() const {
        const char* where = "GrainMaterial";
        check_argument(ior > 0.0 && std::isfinite(ior), where, "ior", ior, "(0, inf)");
        for (std::size_t c = 0; c < interior_sigma_a.size(); ++c)
            check_argument(interior_sigma_a[c] >= 0.0 && std::isfinite(interior_sigma_a[c]), where, "interior_sigma_a",
                           interior_sigma_a[c], "[0, inf)");
        for (std::size_t c = 0; c < interior_sigma_s.size(); ++c)
            check_argument(interior_sigma_s[c] >= 0.0 && std::isfinite(interior_sigma_s[c]), where, "interior_sigma_s",
                           interior_sigma_s[c], "[0, inf)");
        for (std::size_t c = 0; c < albedo.size(); ++c)
            check_argument(albedo[c] >= 0.0 && albedo[c] <= 1.0, where, "albedo", albedo[c], "[0, 1]");
        const std::size_t n = channels();
        check_argument(compatible_with(n), where, "channel counts", n,
                       "every non-grey value (interior_sigma_a, interior_sigma_s, albedo) with the same count");
        check_argument(interior_g > -1.0 && interior_g < 1.0, where, "interior_g", interior_g, "(-1, 1)");
    }
};

}  // namespace grainlight

namespace grainlight {

/// A named grain of Meng15 Table 1 as this library models it: a procedural shape with its
/// bounding radius (in units of the packing's bounding sphere), a shape seed and a material.
/// Interior coefficients are per bounding-sphere radius. These are *our* procedural stand-ins
/// for the paper's scanned/modelled grains (docs/meng15.md explains where the statistics differ).
struct GrainPreset {
    std::string name;          ///< e.g. "glass-bead"
    std::string paper_column;  ///< Table 1 column ("" if the grain is not in Table 1)
    /// Procedural shape family.
    GrainShape shape = GrainShape::sphere;
    /// Bounding radius in units of the packing's bounding sphere, in (0, 1].
    double radius = 1.0;
    /// Seed of the procedural shape (same seed, same mesh).
    std::uint64_t seed = 1;
    /// Interior and surface optics of the grain.
    GrainMaterial material{};
};

/// One column of Meng15 Table 1 ("extracted statistics, averaged over wavelength and rounded to
/// two digits"), lengths in units of the bounding-sphere radius.
struct Meng15Table1Column {
    /// Column heading, e.g. "Glass bead".
    const char* name;
    /// @var lambda_delta
    /// Mean pass-through offset of the rays that miss the grain.
    /// @var lambda_s
    /// Length of the mean teleport vector of the rays that hit and leave.
    /// @var alpha_s
    /// Effective grain albedo: fraction of hitting rays that leave.
    /// @var beta
    /// Hit probability of a ray crossing the bounding sphere.
    double lambda_delta, lambda_s, alpha_s, beta;
};

/// Meng15 Table 1 (ACM TOG 34(4), 2015), all seven columns.
inline constexpr Meng15Table1Column meng15_table1[] = {
    {"glass beads", 0.00, 1.44, 1.00, 1.00}, {"flour", 0.87, 0.18, 1.00, 0.66},
    {"pink salt", 0.97, 1.00, 0.99, 0.53},   {"sand", 0.85, 0.50, 0.68, 0.63},
    {"snow", 0.86, 1.40, 1.00, 0.65},        {"cane sugar", 0.77, 1.17, 1.00, 0.71},
    {"brown sugar", 0.77, 0.88, 0.76, 0.71},
};

/// The Table 1 column called `name`, or nullptr.
[[nodiscard]] inline const Meng15Table1Column* find_meng15_table1(std::string_view name) noexcept {
    for (const auto& c : meng15_table1)
        if (name == c.name) return &c;
    return nullptr;
}

/// The presets: glass-bead, snow, salt (pink salt), sugar (cane sugar), brown-sugar, sand, flour,
/// rice. Pink salt gets a faint absorption, brown sugar and sand an interior absorbing (sand:
/// also scattering) medium, flour is a white Lambertian grain.
[[nodiscard]] inline std::vector<GrainPreset> grain_presets() {
    std::vector<GrainPreset> p;
    p.push_back({"glass-bead", "glass beads", GrainShape::sphere, 1.0, 1, GrainMaterial::make_dielectric(1.5)});
    p.push_back({"flour", "flour", GrainShape::crystal, 0.96, 11, GrainMaterial::make_diffuse(RGBd{0.998, 0.996, 0.99})});
    p.push_back({"salt", "pink salt", GrainShape::crystal, 0.9, 3,
                 GrainMaterial::make_absorbing_dielectric(1.54, RGBd{0.001, 0.006, 0.004})});
    p.push_back({"sand", "sand", GrainShape::snow, 1.0, 5,
                 GrainMaterial::make_absorbing_dielectric(1.54, RGBd{0.12, 0.2, 0.32}, RGBd{4.0, 4.0, 4.0}, 0.0)});
    p.push_back({"snow", "snow", GrainShape::snow, 1.0, 7, GrainMaterial::make_dielectric(1.31)});
    p.push_back({"sugar", "cane sugar", GrainShape::crystal, 1.0, 9, GrainMaterial::make_dielectric(1.56)});
    p.push_back({"brown-sugar", "brown sugar", GrainShape::crystal, 1.0, 13,
                 GrainMaterial::make_absorbing_dielectric(1.56, RGBd{0.06, 0.13, 0.26}, RGBd(1.0), 0.0)});
    p.push_back({"rice", "", GrainShape::rice, 1.0, 17,
                 GrainMaterial::make_absorbing_dielectric(1.53, RGBd{0.01, 0.01, 0.02}, RGBd{3.0, 3.0, 3.0}, 0.0)});
    return p;
}

/// The preset called `name`; throws grainlight::invalid_argument listing the valid names.
[[nodiscard]] inline GrainPreset grain_preset(std::string_view name) {
    std::string names;
    for (const auto& p : grain_presets()) {
        if (p.name == name) return p;
        names += (names.empty() ? "" : "|") + p.name;
    }
    raise_invalid_argument("grain_preset", "preset", std::string(name), names);
}

}  // namespace grainlight
