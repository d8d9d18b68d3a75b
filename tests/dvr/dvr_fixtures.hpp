// Volumes, voxel BIHs, node ranges, transfer functions and an independent reference integrator
// for the volume-renderer tests. Everything here is written for the tests, independently of
// the library's volume stages (classification, gradients, LoD) that other headers provide.
#ifndef SYLVA_TESTS_DVR_FIXTURES_HPP
#define SYLVA_TESTS_DVR_FIXTURES_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <span>
#include <utility>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/core/ray.hpp>
#include <sylva/elements/voxel.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/grid.hpp>

namespace sylva::dvrtest {

using Field = std::function<double(glm::dvec3)>;

/// A grid whose voxel values are `f` at the voxel centres (v + 0.5) * spacing.
inline volume::DensityGrid sample_grid(volume::Dims dims, vec3 spacing, const Field& f) {
    volume::DensityGrid g{dims, spacing, std::vector<float>(volume::voxel_count(dims))};
    for (std::uint32_t z = 0; z < dims.z; ++z)
        for (std::uint32_t y = 0; y < dims.y; ++y)
            for (std::uint32_t x = 0; x < dims.x; ++x) {
                glm::dvec3 c = (glm::dvec3(x, y, z) + 0.5) * glm::dvec3(spacing);
                g.values[volume::voxel_index(dims, x, y, z)] = static_cast<float>(f(c));
            }
    return g;
}

/// Smooth procedural volume: three Gaussian blobs inside the grid (values in [0, ~1]).
inline Field blobs(vec3 box_hi) {
    glm::dvec3 hi(box_hi);
    return [hi](glm::dvec3 p) {
        glm::dvec3 q = p / hi;  // [0, 1]^3
        auto blob = [&](glm::dvec3 c, double r, double w) {
            glm::dvec3 e = q - c;
            return w * std::exp(-glm::dot(e, e) / (r * r));
        };
        double d = blob({0.42, 0.45, 0.5}, 0.3, 0.85) + blob({0.7, 0.62, 0.42}, 0.2, 0.6) +
                   blob({0.3, 0.72, 0.62}, 0.17, 0.55);
        return std::min(d, 1.0);
    };
}

/// Voxel cuboids of every voxel with density >= threshold; the gradient is the central
/// difference (d[i+1] - d[i-1]) / 2 of the grid (edge voxels repeat outside).
inline std::vector<VoxelCuboid> grid_cuboids(const volume::DensityGrid& g, float threshold) {
    std::vector<VoxelCuboid> out;
    for (std::uint32_t z = 0; z < g.dims.z; ++z)
        for (std::uint32_t y = 0; y < g.dims.y; ++y)
            for (std::uint32_t x = 0; x < g.dims.x; ++x) {
                float d = g.at(x, y, z);
                if (!(d >= threshold)) continue;
                std::int64_t X = x, Y = y, Z = z;
                vec3 grad(g.clamped(X + 1, Y, Z) - g.clamped(X - 1, Y, Z), g.clamped(X, Y + 1, Z) - g.clamped(X, Y - 1, Z),
                          g.clamped(X, Y, Z + 1) - g.clamped(X, Y, Z - 1));
                out.push_back({g.voxel_box(x, y, z), d, grad * 0.5f});
            }
    return out;
}

/// Voxel cuboids of every voxel of `g` with the gradient of the analytic field `f` by central
/// differences one voxel apart (exact for linear fields, also at the grid's edges).
inline std::vector<VoxelCuboid> field_cuboids(const volume::DensityGrid& g, const Field& f) {
    std::vector<VoxelCuboid> out;
    glm::dvec3 s(g.spacing);
    for (std::uint32_t z = 0; z < g.dims.z; ++z)
        for (std::uint32_t y = 0; y < g.dims.y; ++y)
            for (std::uint32_t x = 0; x < g.dims.x; ++x) {
                glm::dvec3 c = (glm::dvec3(x, y, z) + 0.5) * s;
                glm::dvec3 grad(f(c + glm::dvec3(s.x, 0, 0)) - f(c - glm::dvec3(s.x, 0, 0)),
                                f(c + glm::dvec3(0, s.y, 0)) - f(c - glm::dvec3(0, s.y, 0)),
                                f(c + glm::dvec3(0, 0, s.z)) - f(c - glm::dvec3(0, 0, s.z)));
                out.push_back({g.voxel_box(x, y, z), g.at(x, y, z), vec3(grad * 0.5)});
            }
    return out;
}

/// One voxel per leaf (the builder's defaults), encoded with the voxel payload.
inline std::vector<std::uint32_t> encode_voxels(const std::vector<VoxelCuboid>& cuboids,
                                                bih::NodeFormat format = bih::NodeFormat::Float32) {
    std::span<const VoxelCuboid> es(cuboids);
    bih::Tree t = bih::build(es);
    return bih::encode(t, es, VoxelPayload{}, {format, bih::Layout::TreeChunks, 2});
}

/// Node-range buffer of an encoded voxel BIH, computed by decoding the words: for each node
/// the min and max of the linear reconstruction d_c + g . (x - c) / voxel_size over the boxes
/// of its leaves, as unorm16 rounded outwards (bits 0-15 min, 16-31 max).
class NodeRanges {
public:
    NodeRanges(std::span<const std::uint32_t> words, vec3 voxel_size)
        : w_{words.data(), words.size()}, voxel_(voxel_size) {
        h_ = shared::sylva_bih_read_header(w_, static_cast<std::uint32_t>(words.size()));
        out_.assign(h_.node_count, 0u);
        bool f32 = (h_.flags & SYLVA_BIH_FLAG_FLOAT_NODES) != 0u;
        visit(0, f32 ? h_.root_lo : vec3(0.0f), f32 ? h_.root_hi : vec3(1.0f));
    }
    [[nodiscard]] const std::vector<std::uint32_t>& words() const { return out_; }

private:
    using Range = std::pair<double, double>;
    Range visit(std::uint32_t n, vec3 lo, vec3 hi) {
        std::uint32_t meta = shared::sylva_bih_meta(w_, h_, n), axis = meta & 3u;
        Range r;
        if (axis == SYLVA_BIH_LEAF) {
            r = leaf(n, lo, hi);
        } else {
            vec2 planes = shared::sylva_bih_planes(w_, h_, n);
            vec3 hl = hi, lr = lo;
            hl[axis] = planes.x;
            lr[axis] = planes.y;
            if (meta & 4u) {
                std::uint32_t child = (h_.flags & SYLVA_BIH_FLAG_CHUNKED) ? (meta >> 3u) : n + 1u;
                vec3 l2 = lo, h2 = hi;
                l2[axis] = planes.x;
                h2[axis] = planes.y;
                r = visit(child, l2, h2);
            } else {
                uvec2 kids = shared::sylva_bih_children(h_, n, meta, planes);
                r = {1e30, -1e30};
                if (kids.x != SYLVA_NO_NODE) r = merge(r, visit(kids.x, lo, hl));
                if (kids.y != SYLVA_NO_NODE) r = merge(r, visit(kids.y, lr, hi));
            }
        }
        double lo16 = std::floor(std::clamp(r.first, 0.0, 1.0) * 65535.0);
        double hi16 = std::ceil(std::clamp(r.second, 0.0, 1.0) * 65535.0);
        out_[n] = static_cast<std::uint32_t>(lo16) | (static_cast<std::uint32_t>(hi16) << 16);
        return r;
    }
    Range leaf(std::uint32_t n, vec3 lo, vec3 hi) {
        shared::SylvaVoxel v = shared::sylva_voxel_unpack(shared::sylva_bih_payload(w_, h_, n));
        glm::dvec3 wl(shared::sylva_bih_to_world(h_, lo)), wh(shared::sylva_bih_to_world(h_, hi));
        glm::dvec3 half = (wh - wl) * 0.5 / glm::dvec3(voxel_);
        double reach = std::abs(v.gradient.x) * half.x + std::abs(v.gradient.y) * half.y + std::abs(v.gradient.z) * half.z;
        return {v.density - reach, v.density + reach};
    }
    static Range merge(Range a, Range b) { return {std::min(a.first, b.first), std::max(a.second, b.second)}; }

    shared::Words w_;
    shared::SylvaBihHeader h_{};
    vec3 voxel_;
    std::vector<std::uint32_t> out_;
};

inline std::uint32_t rgba8(std::uint32_t r, std::uint32_t g, std::uint32_t b, std::uint32_t a) {
    return r | (g << 8) | (b << 16) | (a << 24);
}

/// A transfer function of n entries, entry i = f(i / (n - 1)) with each channel in [0, 1].
inline std::vector<std::uint32_t> make_tf(std::size_t n, const std::function<vec4(float)>& f) {
    std::vector<std::uint32_t> tf(n);
    for (std::size_t i = 0; i < n; ++i) {
        vec4 c = glm::clamp(f(float(i) / float(n - 1)), 0.0f, 1.0f) * 255.0f;
        tf[i] = rgba8(std::uint32_t(std::lround(c.r)), std::uint32_t(std::lround(c.g)), std::uint32_t(std::lround(c.b)),
                      std::uint32_t(std::lround(c.a)));
    }
    return tf;
}

/// A smooth TF: transparent below `lo`, alpha rising linearly to `peak` at 1, colour from
/// blue over orange to white.
inline std::vector<std::uint32_t> smooth_tf(float lo, float peak) {
    return make_tf(256, [=](float d) {
        float a = d <= lo ? 0.0f : peak * (d - lo) / (1.0f - lo);
        return vec4(0.2f + 0.8f * d, 0.3f + 0.5f * d * d, 0.9f - 0.6f * d, a);
    });
}

/// Rays from points around `box` (a few inside) towards random points inside it.
inline std::vector<Ray> rays_into(const Aabb& box, std::size_t n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Ray> rays;
    vec3 e = box.extent();
    for (std::size_t i = 0; i < n; ++i) {
        vec3 target = box.lo + vec3(u(rng), u(rng), u(rng)) * e;
        vec3 from = box.lo + (vec3(u(rng), u(rng), u(rng)) * 3.0f - 1.0f) * e;
        if (i % 8 == 0) from = box.lo + vec3(u(rng), u(rng), u(rng)) * e;  // inside
        vec3 d = target - from;
        if (glm::dot(d, d) < 1e-6f) d = vec3(0.3f, 0.2f, 1.0f);
        rays.push_back({from, d});
    }
    return rays;
}

/// The part of the ray (unit direction) inside `box`, in double precision: [t0, t1] or nothing.
inline std::optional<std::pair<double, double>> chord(const Ray& r, const Aabb& box) {
    glm::dvec3 o(r.origin), d = glm::normalize(glm::dvec3(r.direction));
    double t0 = 0.0, t1 = 1e300;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < box.lo[a] || o[a] > box.hi[a]) return std::nullopt;
            continue;
        }
        double ta = (box.lo[a] - o[a]) / d[a], tb = (box.hi[a] - o[a]) / d[a];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
    }
    if (!(t0 < t1)) return std::nullopt;
    return std::make_pair(t0, t1);
}

/// Straight RGBA of the TF at density d, by the TF definition (independent of tf.h).
inline glm::dvec4 tf_at(const std::vector<std::uint32_t>& tf, double d) {
    d = std::clamp(d, 0.0, 1.0) * double(tf.size() - 1);
    std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(d), tf.size() - 1), j = std::min(i + 1, tf.size() - 1);
    auto texel = [](std::uint32_t c) {
        return glm::dvec4(c & 255u, (c >> 8) & 255u, (c >> 16) & 255u, c >> 24) / 255.0;
    };
    return glm::mix(texel(tf[i]), texel(tf[j]), d - double(i));
}

/// Reference emission-absorption integral of a continuous field along the chord of `r` through
/// `box`, in double: `substeps` midpoint pieces, each with opacity 1 - (1 - alpha)^(h / unit).
/// Returns premultiplied RGBA.
inline glm::dvec4 reference_integral(const Ray& r, const Aabb& box, const Field& f, const std::vector<std::uint32_t>& tf,
                                     double unit, int substeps) {
    auto c = chord(r, box);
    if (!c) return glm::dvec4(0.0);
    glm::dvec3 o(r.origin), d = glm::normalize(glm::dvec3(r.direction));
    double h = (c->second - c->first) / substeps;
    glm::dvec4 acc(0.0);
    for (int i = 0; i < substeps; ++i) {
        double t = c->first + (i + 0.5) * h;
        glm::dvec4 s = tf_at(tf, f(o + t * d));
        double a = 1.0 - std::pow(1.0 - std::min(s.a, 1.0), h / unit);
        double k = (1.0 - acc.a) * a;
        acc += glm::dvec4(glm::dvec3(s) * k, k);
    }
    return acc;
}

}  // namespace sylva::dvrtest

#endif  // SYLVA_TESTS_DVR_FIXTURES_HPP
