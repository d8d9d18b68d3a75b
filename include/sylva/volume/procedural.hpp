// sylva/volume/procedural.hpp -- analytic and synthetic density grids: test references with
// known values, and the default volumes when no data file is at hand.
//
// All follow the cell conventions of sylva/volume/grid.hpp: voxel v's value is the function at
// its centre, (v + 0.5) * spacing in world space. Densities are normalised to [0, 1].
//  * marschner_lobb: the Marschner-Lobb test signal (1994), a reconstruction-filter benchmark.
//  * sparse_nbody: Gaussian blobs in halos joined by filaments, mostly empty space (a stand-in
//    for an N-body density field; deterministic for a seed).
//  * constant_box, linear_ramp, radial_falloff: simple fields whose renderings and
//    reconstructions have closed forms (exact checks of renderers and resampling).
#ifndef SYLVA_VOLUME_PROCEDURAL_HPP
#define SYLVA_VOLUME_PROCEDURAL_HPP

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <new>
#include <numbers>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::volume {

namespace detail::procedural {

/// A zero grid of `dims` voxels with `spacing`; throws sylva::Error (naming `what`) for zero or
/// overflowing dims, a bad spacing, or when it cannot be allocated.
inline DensityGrid empty_grid(Dims dims, vec3 spacing, const char* what) {
    std::size_t n;
    try {
        n = voxel_count(dims, sizeof(float));
    } catch (const Error& e) {
        throw Error(std::string(what) + ": " + e.what());
    }
    if (!all_finite(spacing) || !(spacing.x > 0.0f) || !(spacing.y > 0.0f) || !(spacing.z > 0.0f))
        throw Error(std::string(what) + ": spacing must be finite and positive");
    DensityGrid g{dims, spacing, {}};
    try {
        g.values.assign(n, 0.0f);
    } catch (const std::bad_alloc&) {
        throw Error(std::string(what) + ": cannot allocate " + std::to_string(n) + " voxels");
    }
    return g;
}

/// World centre of voxel (x, y, z).
inline vec3 centre(const DensityGrid& g, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return (vec3(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)) + 0.5f) * g.spacing;
}

/// Fills every voxel with f(world centre), clamped to [0, 1].
template <class F>
void fill(DensityGrid& g, F&& f) {
    for (std::uint32_t z = 0; z < g.dims.z; ++z)
        for (std::uint32_t y = 0; y < g.dims.y; ++y)
            for (std::uint32_t x = 0; x < g.dims.x; ++x)
                g.values[voxel_index(g.dims, x, y, z)] = std::clamp(f(centre(g, x, y, z)), 0.0f, 1.0f);
}

inline void check_density(float d, const char* what) {
    if (!(d >= 0.0f && d <= 1.0f))
        throw Error(std::string(what) + ": density " + std::to_string(d) + " is not in [0, 1]");
}

/// A small deterministic generator (splitmix64): the same numbers on every platform and
/// standard library, unlike std::*_distribution.
class Rng {
public:
    explicit Rng(std::uint64_t seed) : state_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    /// Uniform in [0, 1).
    float uniform() { return static_cast<float>(next() >> 40) * (1.0f / 16777216.0f); }
    /// Standard normal (Box-Muller).
    float normal() {
        float u1 = std::max(uniform(), 1e-7f), u2 = uniform();
        return std::sqrt(-2.0f * std::log(u1)) * std::cos(2.0f * std::numbers::pi_v<float> * u2);
    }
    vec3 normal3() { return vec3(normal(), normal(), normal()); }
    vec3 uniform3() { return vec3(uniform(), uniform(), uniform()); }

private:
    std::uint64_t state_;
};

}  // namespace detail::procedural

// ---- Marschner-Lobb ------------------------------------------------------------------------

/// Parameters of the Marschner-Lobb signal. Marschner and Lobb, "An evaluation of
/// reconstruction filters for volume rendering" (1994): f_M = 6 and alpha = 0.25 on [-1, 1]^3.
struct MarschnerLobbConfig {
    float f_m = 6.0f;     ///< frequency of the radial ripples (f_M)
    float alpha = 0.25f;  ///< weight of the ripples against the vertical sine (alpha)
    vec3 spacing{1.0f};   ///< world size of one voxel
};

/// The Marschner-Lobb function at p in [-1, 1]^3:
///   rho(p) = (1 - sin(pi z / 2) + alpha (1 + rho_r(sqrt(x^2 + y^2)))) / (2 (1 + alpha)),
///   rho_r(r) = cos(2 pi f_M cos(pi r / 2)); its range is [0, 1].
inline float marschner_lobb_at(vec3 p, float f_m = 6.0f, float alpha = 0.25f) {
    constexpr float pi = std::numbers::pi_v<float>;
    float r = std::sqrt(p.x * p.x + p.y * p.y);
    float rho_r = std::cos(2.0f * pi * f_m * std::cos(pi * r / 2.0f));
    return (1.0f - std::sin(pi * p.z / 2.0f) + alpha * (1.0f + rho_r)) / (2.0f * (1.0f + alpha));
}

/// The Marschner-Lobb signal sampled on `dims` voxels: the grid's world box maps linearly onto
/// [-1, 1]^3, so voxel v holds marschner_lobb_at(-1 + 2 (v + 0.5) / dims). Clamped to [0, 1].
inline DensityGrid marschner_lobb(Dims dims, const MarschnerLobbConfig& config = {}) {
    DensityGrid g = detail::procedural::empty_grid(dims, config.spacing, "marschner_lobb");
    if (!std::isfinite(config.f_m) || !std::isfinite(config.alpha) || !(config.alpha >= 0.0f))
        throw Error("marschner_lobb: f_m and alpha must be finite, alpha >= 0");
    vec3 extent = vec3(dims) * g.spacing;
    detail::procedural::fill(
        g, [&](vec3 c) { return marschner_lobb_at(2.0f * c / extent - 1.0f, config.f_m, config.alpha); });
    return g;
}

// ---- sparse N-body-like density --------------------------------------------------------------

/// Parameters of sparse_nbody. Positions are in the unit cube, mapped onto the grid's box.
struct SparseNbodyConfig {
    std::uint32_t blobs = 4000;     ///< Gaussian blobs in all
    std::uint32_t halos = 24;       ///< halo centres; filaments join each to its two nearest
    float halo_share = 0.35f;       ///< share of blobs inside halos
    float field_share = 0.10f;      ///< share scattered uniformly; the rest lie along filaments
    float blob_sigma = 0.006f;      ///< blob width (standard deviation), fraction of the largest dimension
    float filament_width = 0.012f;  ///< standard deviation across a filament (unit cube)
    vec3 spacing{1.0f};             ///< world size of one voxel
};

namespace detail::procedural {

/// One Gaussian blob: centre (unit cube), width (unit cube) and peak.
struct Blob {
    vec3 centre;
    float sigma;
    float amplitude;
};

/// Halo centres, radii and filaments (pairs of halos), then the blobs placed among them.
inline std::vector<Blob> nbody_blobs(const SparseNbodyConfig& c, Rng& rng) {
    std::vector<vec3> halo(c.halos);
    std::vector<float> radius(c.halos);
    for (std::uint32_t h = 0; h < c.halos; ++h) {
        halo[h] = 0.12f + 0.76f * rng.uniform3();
        radius[h] = 0.015f + 0.045f * rng.uniform() * rng.uniform();  // many small halos, few large
    }
    std::vector<std::pair<std::uint32_t, std::uint32_t>> filaments;
    for (std::uint32_t h = 0; h < c.halos; ++h) {
        std::vector<std::uint32_t> order;
        for (std::uint32_t o = 0; o < c.halos; ++o)
            if (o != h) order.push_back(o);
        std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
            return glm::length(halo[a] - halo[h]) < glm::length(halo[b] - halo[h]);
        });
        for (std::size_t k = 0; k < std::min<std::size_t>(2, order.size()); ++k)
            filaments.emplace_back(std::min(h, order[k]), std::max(h, order[k]));
    }
    std::sort(filaments.begin(), filaments.end());
    filaments.erase(std::unique(filaments.begin(), filaments.end()), filaments.end());
    std::vector<Blob> blobs;
    for (std::uint32_t b = 0; b < c.blobs; ++b) {
        float kind = rng.uniform(), width = c.blob_sigma * (0.7f + 0.6f * rng.uniform());
        if (kind < c.halo_share && !halo.empty()) {
            std::uint32_t h = std::min(static_cast<std::uint32_t>(rng.uniform() * float(c.halos)), c.halos - 1);
            float concentration = rng.uniform();  // denser towards the core
            blobs.push_back({halo[h] + rng.normal3() * radius[h] * concentration, width, 1.0f});
        } else if (kind < c.halo_share + c.field_share || filaments.empty()) {
            blobs.push_back({rng.uniform3(), width, 0.35f});
        } else {
            auto [a, e] = filaments[std::min<std::size_t>(
                static_cast<std::size_t>(rng.uniform() * float(filaments.size())), filaments.size() - 1)];
            float t = rng.uniform();
            blobs.push_back({glm::mix(halo[a], halo[e], t) + rng.normal3() * c.filament_width, width, 0.6f});
        }
    }
    return blobs;
}

/// Adds one truncated (3 sigma) Gaussian to `acc`, in voxel units.
inline void splat(std::vector<float>& acc, Dims dims, const Blob& b) {
    vec3 centre = b.centre * vec3(dims);
    float sigma = b.sigma * static_cast<float>(std::max({dims.x, dims.y, dims.z}));
    sigma = std::max(sigma, 0.5f);
    float reach = 3.0f * sigma, inv = 1.0f / (2.0f * sigma * sigma);
    glm::ivec3 lo = glm::max(glm::ivec3(glm::floor(centre - reach)), glm::ivec3(0));
    glm::ivec3 hi = glm::min(glm::ivec3(glm::ceil(centre + reach)), glm::ivec3(dims) - 1);
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) {
                vec3 d = vec3(float(x), float(y), float(z)) + 0.5f - centre;
                float d2 = glm::dot(d, d);
                if (d2 <= reach * reach)
                    acc[voxel_index(dims, std::uint32_t(x), std::uint32_t(y), std::uint32_t(z))] +=
                        b.amplitude * std::exp(-d2 * inv);
            }
}

}  // namespace detail::procedural

/// A sparse, N-body-like density field: `config.blobs` truncated Gaussian blobs, clustered in
/// halos, strung along filaments between neighbouring halos, and a few scattered in the field;
/// everything else is exactly 0 (mostly empty space). The summed density s is mapped to
/// log(1 + s / 0.25) / log(1 + max s / 0.25), so the densest voxel is 1 and faint filaments stay
/// visible. Deterministic for a seed (its own generator, not std::*_distribution). Throws
/// sylva::Error for zero or overflowing dims, a bad spacing, or shares outside [0, 1].
inline DensityGrid sparse_nbody(Dims dims, std::uint32_t seed, const SparseNbodyConfig& config = {}) {
    using namespace detail::procedural;
    DensityGrid g = empty_grid(dims, config.spacing, "sparse_nbody");
    if (!(config.halo_share >= 0.0f && config.field_share >= 0.0f && config.halo_share + config.field_share <= 1.0f) ||
        !(config.blob_sigma > 0.0f && config.blob_sigma < 1.0f) ||
        !(config.filament_width >= 0.0f && config.filament_width < 1.0f))
        throw Error("sparse_nbody: shares must be in [0, 1] with a sum <= 1, widths in (0, 1)");
    Rng rng(0x5EED0000ull ^ (std::uint64_t{seed} << 17) ^ seed);
    for (const Blob& b : nbody_blobs(config, rng)) splat(g.values, dims, b);
    float top = *std::max_element(g.values.begin(), g.values.end());
    if (top > 0.0f) {
        float norm = 1.0f / std::log1p(top / 0.25f);
        for (float& v : g.values) v = v >= top ? 1.0f : std::min(std::log1p(v / 0.25f) * norm, 1.0f);
    }
    return g;
}

// ---- exact fields ----------------------------------------------------------------------------

/// `density` in the voxels [lo, hi) (per axis, voxel indices), 0 elsewhere: a box whose world
/// extent is [lo * spacing, hi * spacing]. Throws unless density is in [0, 1] and lo <= hi <= dims.
inline DensityGrid constant_box(Dims dims, float density, glm::u32vec3 lo, glm::u32vec3 hi, vec3 spacing = vec3(1.0f)) {
    DensityGrid g = detail::procedural::empty_grid(dims, spacing, "constant_box");
    detail::procedural::check_density(density, "constant_box");
    if (glm::any(glm::greaterThan(lo, hi)) || glm::any(glm::greaterThan(hi, dims)))
        throw Error("constant_box: box [lo, hi) must satisfy lo <= hi <= dims");
    for (std::uint32_t z = lo.z; z < hi.z; ++z)
        for (std::uint32_t y = lo.y; y < hi.y; ++y)
            std::fill_n(g.values.begin() + static_cast<std::ptrdiff_t>(voxel_index(dims, lo.x, y, z)), hi.x - lo.x,
                        density);
    return g;
}

/// `density` in every voxel.
inline DensityGrid constant_box(Dims dims, float density, vec3 spacing = vec3(1.0f)) {
    DensityGrid g = detail::procedural::empty_grid(dims, spacing, "constant_box");
    detail::procedural::check_density(density, "constant_box");
    std::fill(g.values.begin(), g.values.end(), density);
    return g;
}

/// Voxel centre c (world) holds clamp(offset + dot(slope, c), 0, 1). Inside the centres, the
/// trilinear reconstruction of such a grid is the same linear function wherever it is not
/// clamped. Throws for a non-finite slope or offset.
inline DensityGrid linear_ramp(Dims dims, vec3 slope, float offset, vec3 spacing = vec3(1.0f)) {
    DensityGrid g = detail::procedural::empty_grid(dims, spacing, "linear_ramp");
    if (!all_finite(slope) || !std::isfinite(offset)) throw Error("linear_ramp: slope and offset must be finite");
    detail::procedural::fill(g, [&](vec3 c) { return offset + glm::dot(slope, c); });
    return g;
}

/// Voxel centre c (world) holds clamp(1 - |c - centre| / radius, 0, 1): the isosurface of
/// level L is the sphere of radius (1 - L) * radius around `centre`. Throws unless radius > 0
/// and centre is finite.
inline DensityGrid radial_falloff(Dims dims, vec3 centre, float radius, vec3 spacing = vec3(1.0f)) {
    DensityGrid g = detail::procedural::empty_grid(dims, spacing, "radial_falloff");
    if (!all_finite(centre) || !std::isfinite(radius) || !(radius > 0.0f))
        throw Error("radial_falloff: centre must be finite and radius finite and positive");
    detail::procedural::fill(g, [&](vec3 c) { return 1.0f - glm::length(c - centre) / radius; });
    return g;
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_PROCEDURAL_HPP
