// sylva/io/particles.hpp -- particle files: N consecutive little-endian float32 (x, y, z)
// triples (the layout of ../shared/data, NAME_Nx3_float32.raw), and a procedural galaxy.
#ifndef SYLVA_IO_PARTICLES_HPP
#define SYLVA_IO_PARTICLES_HPP

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/elements/sphere.hpp"

namespace sylva::io {

// read_points reads the files' little-endian float32 triples straight into vec3s.
static_assert(std::endian::native == std::endian::little,
              "sylva::io: particle files hold little-endian float32 and are read in host byte order; big-endian "
              "hosts are not supported");

/// What a particle file's name states: NAME_NxC_TYPE.raw (the convention of ../shared/data).
struct NamedLayout {
    std::string count;       ///< N as written (digits), empty when the name states no layout
    std::string components;  ///< C as written
    std::string type;        ///< TYPE as written
};

/// Splits a file name of the form NAME_NxC_TYPE.raw (N and C decimal digits); an empty layout
/// when the name does not have that form.
inline NamedLayout named_layout(const std::string& path) {
    std::string name = std::filesystem::path(path).filename().string();
    const std::string ext = ".raw";
    if (name.size() <= ext.size() || name.compare(name.size() - ext.size(), ext.size(), ext) != 0) return {};
    name.resize(name.size() - ext.size());
    std::size_t type_at = name.rfind('_');
    if (type_at == std::string::npos || type_at == 0) return {};
    std::size_t dims_at = name.rfind('_', type_at - 1);
    if (dims_at == std::string::npos) return {};
    std::string dims = name.substr(dims_at + 1, type_at - dims_at - 1);
    std::size_t x = dims.find('x');
    auto digits = [](const std::string& s) {
        return !s.empty() && s.find_first_not_of("0123456789") == std::string::npos;
    };
    if (x == std::string::npos || !digits(dims.substr(0, x)) || !digits(dims.substr(x + 1))) return {};
    return {dims.substr(0, x), dims.substr(x + 1), name.substr(type_at + 1)};
}

/// The N of a file name following NAME_Nx3_float32.raw, or 0 when the name states no layout.
/// Throws sylva::Error when the name states another layout (NAME_10x4_float32.raw,
/// NAME_10x3_uint8.raw: not float32 xyz triples), 0 points, or a count over 10^18.
inline std::uint64_t points_in_name(const std::string& path) {
    NamedLayout l = named_layout(path);
    if (l.count.empty()) return 0;
    const std::string what = "particle file " + path + ": its name says " + l.count + "x" + l.components + "_" + l.type;
    if (l.components != "3" || l.type != "float32")
        throw Error(what + ", but particle files hold float32 xyz triples (NAME_Nx3_float32.raw)");
    std::size_t lead = l.count.find_first_not_of('0');
    std::string digits = lead == std::string::npos ? "0" : l.count.substr(lead);
    if (digits == "0") throw Error("particle file " + path + ": its name says 0 points");
    if (digits.size() > 18)
        throw Error("particle file " + path + ": its name says " + l.count + " points, more than any file holds");
    return std::stoull(digits);
}

/// Reads float32 xyz triples. Throws sylva::Error naming the file when it cannot be opened, is
/// empty, is not a whole number of triples, has a name stating another layout or a count it
/// does not hold (points_in_name), or holds a NaN or infinite coordinate (with the point's index).
inline std::vector<vec3> read_points(const std::string& path) {
    std::error_code ec;
    auto bytes = std::filesystem::file_size(path, ec);
    if (ec) throw Error("cannot read particle file " + path + ": " + ec.message());
    const std::uint64_t named = points_in_name(path);  // first: a name stating another layout is refused as such
    if (bytes == 0) throw Error("particle file " + path + " is empty");
    if (bytes % 12 != 0)
        throw Error("particle file " + path + " has " + std::to_string(bytes) +
                    " bytes, not a whole number of float32 xyz triples (12 bytes each)");
    std::uint64_t n = bytes / 12;
    if (named && named != n)
        throw Error("particle file " + path + " holds " + std::to_string(n) + " points but its name says " +
                    std::to_string(named) + " (truncated or wrong file?)");
    std::vector<vec3> pts(n);
    std::ifstream in(path, std::ios::binary);
    if (!in.read(reinterpret_cast<char*>(pts.data()), static_cast<std::streamsize>(bytes)))  // bytes of the floats
        throw Error("cannot read particle file " + path + ": read failed");
    for (std::size_t i = 0; i < pts.size(); ++i)
        if (!std::isfinite(pts[i].x) || !std::isfinite(pts[i].y) || !std::isfinite(pts[i].z))
            throw Error("particle file " + path + ": point " + std::to_string(i) + " is NaN or infinite");
    return pts;
}

/// Settings for turning points into particles.
struct ParticleStyle {
    /// Radius as a multiple of the mean spacing (cube root of box volume / N); 0 keeps `radius`.
    float spacing_factor = 0.25f;
    float radius = 0.01f;
    float opacity = 0.12f;
    float kappa = 2.0f;
};

/// Spheres at `points`, coloured by distance from their centroid (warm core, cool halo). The
/// box volume, mean spacing and distances are computed in double, so finite coordinates of any
/// size give finite radii (float32 products overflowed from about 7e12 on). Throws sylva::Error
/// when a sphere would reach past the float32 range (points near +-3.4e38), naming the point.
inline std::vector<Sphere> spheres_from_points(const std::vector<vec3>& points, const ParticleStyle& style = {}) {
    using dvec = glm::dvec3;
    Aabb box;
    dvec mean{0.0};
    for (const vec3& p : points) {
        box.extend(p);
        mean += dvec(p) / static_cast<double>(points.size());
    }
    dvec ext = dvec(box.hi) - dvec(box.lo);
    dvec e = glm::max(ext, dvec(1e-6 * (1.0 + glm::length(ext))));
    double spacing = std::cbrt(e.x * e.y * e.z / static_cast<double>(points.size()));
    double r = style.spacing_factor > 0.0f ? double(style.spacing_factor) * spacing : double(style.radius);
    double reach = 0.5 * glm::length(e);
    auto radius = static_cast<float>(r);
    std::vector<Sphere> out;
    out.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        const vec3& p = points[i];
        if (!std::isfinite(radius) || !Sphere{p, radius}.bounds().finite())
            throw Error("particles: point " + std::to_string(i) + " (" + std::to_string(p.x) + ", " + std::to_string(p.y) +
                        ", " + std::to_string(p.z) + ") with radius " + std::to_string(r) +
                        " reaches past the float32 range (coordinates too large)");
        auto t = static_cast<float>(std::clamp(glm::length(dvec(p) - mean) / reach, 0.0, 1.0));
        vec3 c = glm::mix(vec3(1.0f, 0.75f, 0.4f), vec3(0.3f, 0.5f, 1.0f), std::sqrt(t));
        out.push_back({p, radius, vec4(c, style.opacity), style.kappa});
    }
    return out;
}

/// A synthetic spiral galaxy of `n` particles: a bulge, two logarithmic arms and a thin disc,
/// in [-1, 1]^2 x [-0.15, 0.15]. Deterministic for a seed.
inline std::vector<Sphere> synthetic_galaxy(std::size_t n, std::uint32_t seed = 7) {
    std::mt19937 rng(seed);
    std::normal_distribution<float> g(0.0f, 1.0f);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Sphere> out;
    out.reserve(n);
    float r0 = 0.9f / std::sqrt(static_cast<float>(n) / 1e6f + 1e-3f) * 0.004f;
    for (std::size_t i = 0; i < n; ++i) {
        float pick = u(rng);
        vec3 p;
        vec3 col;
        if (pick < 0.2f) {  // bulge
            p = vec3(g(rng), g(rng) * 0.6f, g(rng)) * 0.12f;
            col = vec3(1.0f, 0.8f, 0.55f);
        } else {            // arms and disc
            float r = 0.05f + 0.95f * std::pow(u(rng), 0.7f);
            float arm = (pick < 0.85f) ? ((i % 2) ? 0.0f : 3.14159265f) : u(rng) * 6.2831853f;
            float theta = arm + 2.2f * std::log(r / 0.05f) + g(rng) * 0.18f;
            p = vec3(r * std::cos(theta), g(rng) * 0.02f * (1.2f - r), r * std::sin(theta));
            col = glm::mix(vec3(0.95f, 0.85f, 0.75f), vec3(0.45f, 0.6f, 1.0f), r);
        }
        out.push_back({p, r0 * (0.6f + 0.8f * u(rng)), vec4(col, 0.35f), 2.0f});
    }
    return out;
}

}  // namespace sylva::io

#endif  // SYLVA_IO_PARTICLES_HPP
