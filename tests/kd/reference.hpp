// Brute-force references and generators for the kd-tree tests, written independently of the
// library's SVTs, builders and iterator: direct counting, scanning, a plain slab test.
#ifndef SYLVA_TESTS_KD_REFERENCE_HPP
#define SYLVA_TESTS_KD_REFERENCE_HPP

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <sylva/kdtree/tree.hpp>
#include <sylva/volume/grid.hpp>
#include <sylva/volume/occupancy.hpp>

#include "../missing_data.hpp"

namespace sylva::kdtest {

using volume::Dims;
using volume::Occupancy;
using volume::VoxelBox;

/// Independent random voxels, each occupied with probability p.
inline Occupancy random_occupancy(Dims d, double p, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::bernoulli_distribution b(p);
    Occupancy o{d, vec3(1.0f), std::vector<std::uint8_t>(std::size_t{d.x} * d.y * d.z)};
    for (auto& v : o.voxels) v = b(rng) ? 1u : 0u;
    return o;
}

/// A few solid balls and thin rods in empty space: sparse, clustered, with holes between.
inline Occupancy blobby_occupancy(Dims d, std::uint32_t seed, int blobs = 5) {
    std::mt19937 rng(seed);
    Occupancy o{d, vec3(1.0f), std::vector<std::uint8_t>(std::size_t{d.x} * d.y * d.z)};
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int k = 0; k < blobs; ++k) {
        vec3 c(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
        float r = 1.0f + u(rng) * 0.15f * float(std::max({d.x, d.y, d.z}));
        bool rod = k % 3 == 2;
        for (std::uint32_t z = 0; z < d.z; ++z)
            for (std::uint32_t y = 0; y < d.y; ++y)
                for (std::uint32_t x = 0; x < d.x; ++x) {
                    vec3 p = vec3(x, y, z) + 0.5f - c;
                    bool in = rod ? (std::abs(p.y) < 1.0f && std::abs(p.z) < 1.5f && std::abs(p.x) < 2 * r)
                                  : glm::dot(p, p) < r * r;
                    if (in) o.voxels[volume::voxel_index(d, x, y, z)] = 1u;
                }
    }
    return o;
}

/// Occupied voxels in `b` by direct counting.
inline std::uint64_t count_direct(const Occupancy& o, const VoxelBox& b) {
    std::uint64_t n = 0;
    VoxelBox c = volume::intersect(b, volume::full_box(o.dims));
    for (std::uint32_t z = c.lo.z; z < c.hi.z; ++z)
        for (std::uint32_t y = c.lo.y; y < c.hi.y; ++y)
            for (std::uint32_t x = c.lo.x; x < c.hi.x; ++x) n += o.at(x, y, z) ? 1u : 0u;
    return n;
}

/// Tight box of the occupied voxels of `b` by scanning.
inline VoxelBox tight_direct(const Occupancy& o, const VoxelBox& b) {
    VoxelBox t;
    VoxelBox c = volume::intersect(b, volume::full_box(o.dims));
    for (std::uint32_t z = c.lo.z; z < c.hi.z; ++z)
        for (std::uint32_t y = c.lo.y; y < c.hi.y; ++y)
            for (std::uint32_t x = c.lo.x; x < c.hi.x; ++x)
                if (o.at(x, y, z)) t.extend(VoxelBox{uvec3(x, y, z), uvec3(x + 1, y + 1, z + 1)});
    return t;
}

/// A random box inside the grid (possibly a single voxel or the whole grid).
inline VoxelBox random_box(Dims d, std::mt19937& rng) {
    VoxelBox b;
    for (int a = 0; a < 3; ++a) {
        std::uniform_int_distribution<std::uint32_t> u(0, d[a]);
        std::uint32_t p = u(rng), q = u(rng);
        if (p == q) q = p + 1 <= d[a] ? p + 1 : p - 1;
        b.lo[a] = std::min(p, q);
        b.hi[a] = std::max(p, q);
    }
    return b;
}

/// Checks the tree invariants against the occupancy: leaves never overlap, every occupied
/// voxel lies in exactly one leaf, every node box is the tight box of its voxels (scanned),
/// children lie inside their parent on either side of its plane, the statistics add up.
inline void check_tree(const kdtree::Tree& t, const Occupancy& o) {
    std::vector<std::uint8_t> cover(o.voxels.size(), 0);
    std::uint64_t leaf_volume = 0;
    for (std::size_t i = 0; i < t.leaves.size(); ++i) {
        const VoxelBox& b = t.nodes[t.leaves[i]].box;
        REQUIRE(t.nodes[t.leaves[i]].leaf == i);
        leaf_volume += b.volume();
        for (std::uint32_t z = b.lo.z; z < b.hi.z; ++z)
            for (std::uint32_t y = b.lo.y; y < b.hi.y; ++y)
                for (std::uint32_t x = b.lo.x; x < b.hi.x; ++x) {
                    auto& c = cover[volume::voxel_index(o.dims, x, y, z)];
                    REQUIRE(c == 0);  // leaves do not overlap
                    c = 1;
                }
    }
    for (std::size_t v = 0; v < o.voxels.size(); ++v)
        if (o.voxels[v]) REQUIRE(cover[v] == 1);  // culls only empty space
    for (std::size_t i = 0; i < t.nodes.size(); ++i) {
        const kdtree::Node& n = t.nodes[i];
        REQUIRE(tight_direct(o, n.box) == n.box);
        if (n.is_leaf()) continue;
        const VoxelBox& lo = t.nodes[n.first_child].box;
        const VoxelBox& hi = t.nodes[n.first_child + 1].box;
        REQUIRE(n.first_child > i);
        REQUIRE((n.box.contains(lo) && n.box.contains(hi)));
        REQUIRE(lo.hi[n.axis] <= n.plane);
        REQUIRE(hi.lo[n.axis] >= n.plane);
        VoxelBox below = n.box, above = n.box;  // the children are the tight boxes of each side
        below.hi[n.axis] = n.plane;
        above.lo[n.axis] = n.plane;
        REQUIRE(tight_direct(o, below) == lo);
        REQUIRE(tight_direct(o, above) == hi);
    }
    std::uint64_t occupied = o.count();
    CHECK(t.stats.occupied == occupied);
    CHECK(t.stats.leaf_volume == leaf_volume);
    CHECK(t.stats.voxels == o.voxels.size());
    if (occupied == 0) CHECK(t.nodes.empty());
    else CHECK(t.nodes[0].box == tight_direct(o, volume::full_box(o.dims)));
}

/// Plain closed slab test in voxel space (spacing 1, origin 0): t = (plane - o) * (1 / d),
/// -0 canonicalised; an axis whose reciprocal is infinite is parallel (inside for all t when
/// lo <= o <= hi). Empty (t0 > t1) on a miss.
inline Interval slab(const Ray& r, const VoxelBox& b, Interval range) {
    for (int a = 0; a < 3; ++a) {
        float o = r.origin[a], inv = 1.0f / r.direction[a];
        float lo = float(b.lo[a]), hi = float(b.hi[a]);
        if (std::isinf(inv)) {
            if (o < lo || o > hi) return Interval{1.0f, 0.0f};
            continue;
        }
        float ta = (lo - o) * inv + 0.0f, tb = (hi - o) * inv + 0.0f;
        range.t0 = std::max(range.t0, std::min(ta, tb));
        range.t1 = std::min(range.t1, std::max(ta, tb));
    }
    return range;
}

inline float signed_zero(std::mt19937& rng) { return (rng() & 1u) ? 0.0f : -0.0f; }

/// Rays of every kind: random directions, one or two +-0 components (axis-parallel), origins
/// inside and outside the grid. `in_plane` puts the origin on integer planes of the parallel
/// axes (rays lying in split planes); otherwise origins are never integers there.
inline std::vector<Ray> make_rays(volume::Dims d, std::size_t n, std::uint32_t seed, bool in_plane) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-0.3f, 1.3f), dir(-1.0f, 1.0f);
    std::vector<Ray> rays(n);
    for (std::size_t i = 0; i < n; ++i) {
        Ray& r = rays[i];
        r.origin = vec3(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
        r.direction = vec3(dir(rng), dir(rng), dir(rng));
        int kind = static_cast<int>(i % 4);
        for (int a = 0; a < 3; ++a) {
            bool zero = (kind == 1 && a == int(i % 3)) || (kind == 2 && a != int(i % 3)) || (kind == 3 && a == 2);
            if (!zero) continue;
            r.direction[a] = signed_zero(rng);
            float o = std::floor(u(rng) * d[a]);
            r.origin[a] = in_plane ? o : o + 0.375f;
        }
        if (glm::all(glm::equal(r.direction, vec3(0.0f)))) r.direction.x = 1.0f;
    }
    return rays;
}

/// Path of a data file; a missing file FAILs the test naming the path, or with
/// SYLVA_ALLOW_MISSING_DATA=1 ends it as skipped (tests/missing_data.hpp).
inline std::string data_file(const std::string& name) { return testdata::require(name).string(); }

/// `g` quantised into a uint8 or uint16 volume whose value range cuts off both ends (raw values
/// below range_lo read as density 0, above range_hi as 1: plateaus of the density in the value).
inline volume::Volume quantised(const volume::DensityGrid& g, volume::ScalarType type) {
    volume::Volume v;
    v.type = type;
    v.dims = g.dims;
    v.spacing = g.spacing;
    bool u8 = type == volume::ScalarType::U8;
    float top = u8 ? 255.0f : 65535.0f;
    v.range_lo = u8 ? 12.0f : 700.0f;
    v.range_hi = u8 ? 230.0f : 61000.0f;
    v.bytes.resize(g.values.size() * (u8 ? 1 : 2));
    for (std::size_t i = 0; i < g.values.size(); ++i) {
        // Spread past the range on both sides, so that the plateaus hold voxels.
        float raw = std::clamp(std::round(g.values[i] * top * 1.1f - 0.05f * top), 0.0f, top);
        if (u8) {
            v.bytes[i] = static_cast<std::byte>(static_cast<std::uint8_t>(raw));
        } else {
            auto r = static_cast<std::uint16_t>(raw);
            std::memcpy(&v.bytes[2 * i], &r, 2);
        }
    }
    return v;
}

}  // namespace sylva::kdtest

#endif  // SYLVA_TESTS_KD_REFERENCE_HPP
