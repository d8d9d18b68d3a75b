// Independent references for the bricked octree's tests: test volumes, the LoD pyramid computed
// straight from the full-resolution voxels, a random sparse octree, a brute-force neighbour
// search and a stack-based (recursive) front-to-back walk.
#ifndef SYLVA_TESTS_OCTREE_REFERENCE_HPP
#define SYLVA_TESTS_OCTREE_REFERENCE_HPP

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/shared/octree_layout.h>
#include <sylva/shared/ray_box.h>

namespace octree_test {

using namespace sylva;

/// Smooth blobs plus noise in [0, 1] (every voxel differs, so a wrong index shows).
inline volume::DensityGrid blobs(volume::Dims d, std::uint32_t seed, vec3 spacing = vec3(1.0f)) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    vec3 c0(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
    float r = 0.4f * float(std::max({d.x, d.y, d.z}));
    volume::DensityGrid g{d, spacing, std::vector<float>(volume::voxel_count(d))};
    for (std::uint32_t z = 0; z < d.z; ++z)
        for (std::uint32_t y = 0; y < d.y; ++y)
            for (std::uint32_t x = 0; x < d.x; ++x) {
                vec3 p(x, y, z);
                float v = std::exp(-glm::dot(p - c0, p - c0) / (r * r));
                g.values[volume::voxel_index(d, x, y, z)] = std::clamp(0.8f * v + 0.2f * u(rng), 0.0f, 1.0f);
            }
    return g;
}

/// Level s of the LoD pyramid from its definition: coarse voxel v is the mean (in double) of the
/// full-resolution voxels in [v 2^s, (v + 1) 2^s), clipped to the volume.
struct RefLod {
    volume::Dims dims{0};
    std::vector<double> values;
    [[nodiscard]] double at(glm::ivec3 v) const {  // clamped to the extent
        v = glm::clamp(v, glm::ivec3(0), glm::ivec3(dims) - 1);
        return values[volume::voxel_index(dims, std::uint32_t(v.x), std::uint32_t(v.y), std::uint32_t(v.z))];
    }
};

inline RefLod reference_lod(const volume::DensityGrid& g, std::uint32_t s) {
    std::uint32_t w = 1u << s;
    RefLod out{(g.dims + (w - 1u)) / w, {}};
    out.values.assign(volume::voxel_count(out.dims), 0.0);
    std::vector<double> count(out.values.size(), 0.0);
    for (std::uint32_t z = 0; z < g.dims.z; ++z)
        for (std::uint32_t y = 0; y < g.dims.y; ++y)
            for (std::uint32_t x = 0; x < g.dims.x; ++x) {
                std::size_t i = volume::voxel_index(out.dims, x >> s, y >> s, z >> s);
                out.values[i] += g.at(x, y, z);
                count[i] += 1.0;
            }
    for (std::size_t i = 0; i < count.size(); ++i) out.values[i] /= count[i];
    return out;
}

/// An octree over `dims` whose nodes split at random (probability p below the root), with the
/// builder's node order; no bricks; neighbour pointers from octree::link_neighbours.
inline octree::Tree sparse_tree(volume::Dims dims, std::uint32_t b, std::uint32_t seed, float p) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    octree::Tree t;
    t.dims = dims;
    t.brick_size = b;
    t.border = 1;
    t.levels = shared::sylva_oct_level_count(dims, b);
    t.nodes.resize(1);
    for (std::size_t n = 0; n < t.nodes.size(); ++n) {
        octree::Node node = t.nodes[n];
        if (node.level + 1 >= t.levels || (n > 0 && u(rng) >= p)) continue;
        glm::u32vec3 below = t.level_nodes(node.level + 1);
        std::uint32_t first = std::uint32_t(t.nodes.size()), mask = 0;
        for (std::uint32_t o = 0; o < 8; ++o) {
            glm::u32vec3 c = node.coord * 2u + glm::u32vec3(o & 1u, (o >> 1) & 1u, o >> 2);
            if (c.x >= below.x || c.y >= below.y || c.z >= below.z) continue;
            mask |= 1u << o;
            octree::Node child;
            child.level = node.level + 1;
            child.coord = c;
            t.nodes.push_back(child);
        }
        t.nodes[n].first_child = first;
        t.nodes[n].child_mask = mask;
    }
    octree::link_neighbours(t);
    return t;
}

/// Brute force: the deepest node of level <= node's containing the point a quarter voxel
/// across the centre of face f (kNone when that point is outside the volume).
inline std::uint32_t brute_neighbour(const octree::Tree& t, const octree::Node& node, std::uint32_t f) {
    glm::dvec3 lo(t.box_lo(node)), hi(t.box_hi(node));
    glm::dvec3 p = 0.5 * (lo + hi);
    std::uint32_t a = f / 2;
    p[a] = (f & 1u) ? hi[a] + 0.25 : lo[a] - 0.25;
    if (p[a] < 0.0 || p[a] > double(t.dims[a])) return octree::kNone;
    std::uint32_t best = octree::kNone, best_level = 0;
    for (std::size_t m = 0; m < t.nodes.size(); ++m) {
        const octree::Node& c = t.nodes[m];
        if (c.level > node.level) continue;
        glm::dvec3 l(t.box_lo(c)), h(t.box_hi(c));
        bool inside = l.x <= p.x && p.x < h.x && l.y <= p.y && p.y < h.y && l.z <= p.z && p.z < h.z;
        if (inside && (best == octree::kNone || c.level > best_level)) {
            best = std::uint32_t(m);
            best_level = c.level;
        }
    }
    return best;
}

/// A ray in voxel space, as the iterator sees it after sylva_ray_to_grid.
struct VoxelRay {
    vec3 org, rcp;
    glm::u32vec3 par;
};

struct Leaf {
    std::uint32_t node;
    float t0, t1;
    bool operator==(const Leaf& o) const {
        return node == o.node && std::bit_cast<std::uint32_t>(t0) == std::bit_cast<std::uint32_t>(o.t0) &&
               std::bit_cast<std::uint32_t>(t1) == std::bit_cast<std::uint32_t>(o.t1);
    }
};

/// The stack-based reference walk: recursion over the children in front-to-back octant order
/// (octant ^ the direction's sign mask), yielding the cut leaves with a positive-length interval
/// computed with the slab test's arithmetic; on a parallel axis a box is [lo, hi), closed at the
/// volume's upper end (the iterator's documented rules).
/// `cut_leaf`, when given, marks the leaves of a view-dependent cut (one byte per node).
inline void reference_walk(const octree::Tree& t, std::uint32_t n, const VoxelRay& r, float t_min, float t_max,
                           std::uint32_t max_level, std::vector<Leaf>& out,
                           const std::vector<std::uint8_t>* cut_leaf = nullptr) {
    using namespace sylva::shared;
    const octree::Node& node = t.nodes[n];
    vec3 lo(t.box_lo(node)), hi(t.box_hi(node));
    float a = t_min, b = t_max;
    for (int k = 0; k < 3; ++k) {
        if (r.par[k]) {
            float o = r.org[k];
            bool in = lo[k] <= o && (o < hi[k] || (o == hi[k] && hi[k] == float(t.dims[k])));
            if (!in) return;
        } else {
            float ta = sylva_canon((lo[k] - r.org[k]) * r.rcp[k]), tb = sylva_canon((hi[k] - r.org[k]) * r.rcp[k]);
            a = sylva_max(a, sylva_min(ta, tb));
            b = sylva_min(b, sylva_max(ta, tb));
        }
    }
    if (!(a < b)) return;
    if (node.leaf() || node.level >= max_level || (cut_leaf && (*cut_leaf)[n])) {
        out.push_back({n, a, b});
        return;
    }
    std::uint32_t flip = 0;
    for (std::uint32_t k = 0; k < 3; ++k)
        if (std::bit_cast<std::uint32_t>(r.rcp[k]) & 0x80000000u) flip |= 1u << k;
    for (std::uint32_t k = 0; k < 8; ++k) {
        std::uint32_t o = k ^ flip;
        if ((node.child_mask >> o) & 1u)
            reference_walk(t, shared::sylva_oct_child(node.first_child, node.child_mask, o), r, t_min, t_max, max_level, out,
                           cut_leaf);
    }
}

}  // namespace octree_test

#endif  // SYLVA_TESTS_OCTREE_REFERENCE_HPP
