// sylva/octree/build.hpp -- builds Gobbetti, Marton and Iglesias Guitian's bricked volume octree
// ("A single-pass GPU ray casting framework for interactive out-of-core rendering of massive
// volumetric datasets", sections 3 and 4) in core, from a density grid.
//
// What is built (the encoding is sylva/shared/octree_layout.h):
//  * the volume cut into cubical bricks of B^3 voxels (Config::brick_size); the octree's L levels
//    subdivide the cube of B * 2^(L - 1) voxels per axis that holds the volume, so level l's
//    nodes are W_l = B * 2^(L - 1 - l) voxels wide and node (level l, coords c) covers the voxels
//    [c * W_l, min((c + 1) * W_l, dims)) -- boxes are computed from (l, c), never stored. Nodes
//    that would start at or beyond the volume are virtual: not stored, never visited. Every leaf
//    sits at level L - 1 (the volume octree is complete; sparse octrees share the same encoding);
//  * per node a brick of (B + 2 * border)^3 samples: at the leaves the voxels themselves, at
//    inner nodes a level of the LoD pyramid (section 3, "a filtered representation of the
//    children"): the 2x2x2 box filter of the level below, weighted by the voxels each coarse
//    voxel covers, so a coarse voxel is the mean of the full-resolution voxels under it even
//    where the volume is not a power of two. Borders replicate the neighbouring samples of the
//    same level and are clamped at the volume's edge (section 3: one layer for trilinear
//    interpolation, two for central-difference gradients at rendering time);
//  * per node [min, max] of every density trilinear sampling inside the node's box can return,
//    from its own brick or from any brick below it: the node's voxels plus one voxel around them
//    (clamped), at its level and every finer one. Any cut below the node stays inside it, so
//    culling by it is conservative (section 4: empty nodes are terminal);
//  * per node and face the neighbour pointer of section 4 (Fig. 3): the node at the same level
//    just across the face, or the deepest coarser node containing that point when no same-level
//    node exists (only in sparse octrees), or none outside the volume.
// The pyramid, the bricks and the ranges are computed in parallel (executor).
#ifndef SYLVA_OCTREE_BUILD_HPP
#define SYLVA_OCTREE_BUILD_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/shared/octree_brick.h"
#include "sylva/volume/grid.hpp"

namespace sylva::octree {

/// "No node" / "no brick" in pointers and brick indices (also SYLVA_OCT_NONE in the encoding).
inline constexpr std::uint32_t kNone = 0xFFFFFFFFu;
/// Deepest tree: node coordinates are 16 bits in the encoding, so at most 65536 nodes per axis.
inline constexpr std::uint32_t kMaxLevels = 17;
/// Largest volume extent along an axis (voxel-space coordinates stay exact in float32).
inline constexpr std::uint32_t kMaxDim = (1u << 24) - 1u;

/// Faces, in the order of the neighbour pointers: -x, +x, -y, +y, -z, +z (face f is axis f / 2,
/// on the upper side when f is odd).
enum Face : std::uint32_t { NegX = 0, PosX, NegY, PosY, NegZ, PosZ };

/// One node of the built octree.
struct Node {
    std::uint32_t level = 0;            ///< 0 = the root
    glm::u32vec3 coord{0};              ///< position among the level's nodes (box = coord * W_level)
    std::uint32_t first_child = kNone;  ///< index of the first existing child; kNone for leaves
    std::uint32_t child_mask = 0;       ///< bit o set when child octant o (x | y << 1 | z << 2) exists
    std::array<std::uint32_t, 6> neighbour{kNone, kNone, kNone, kNone, kNone, kNone};  ///< per Face
    float min = 0.0f;                   ///< see the top of this header
    float max = 0.0f;
    std::uint32_t brick = kNone;        ///< index into Tree::bricks; kNone: the node has none
    [[nodiscard]] bool leaf() const { return child_mask == 0u; }
};

/// How a brick stores its samples (sylva/shared/octree_layout.h): float32 bits of the
/// normalised density, or the density rounded to 16 or 8 bits (q / 65535, q / 255).
enum class BrickFormat : std::uint32_t {
    Float32 = SYLVA_OCT_FORMAT_FLOAT32,
    Unorm16 = SYLVA_OCT_FORMAT_UNORM16,  ///< the paper's 16-bit texels; half the memory
    Unorm8 = SYLVA_OCT_FORMAT_UNORM8,    ///< a quarter of the memory
};

/// "float32", "unorm16", "unorm8" (statistics, build records, command lines).
inline const char* brick_format_name(BrickFormat f) {
    return f == BrickFormat::Unorm16 ? "unorm16" : (f == BrickFormat::Unorm8 ? "unorm8" : "float32");
}

/// The brick format called `name`; throws sylva::Error listing the known ones.
inline BrickFormat brick_format_from_name(std::string_view name) {
    for (BrickFormat f : {BrickFormat::Float32, BrickFormat::Unorm16, BrickFormat::Unorm8})
        if (name == brick_format_name(f)) return f;
    throw Error("unknown brick format '" + std::string(name) + "' (known: float32, unorm16, unorm8)");
}

/// The built octree. Nodes are stored level by level (node 0 is the root) and the existing
/// children of a node are consecutive, in octant order, from first_child.
struct Tree {
    volume::Dims dims{0};          ///< volume size in voxels
    vec3 spacing{1.0f};            ///< world size of one voxel
    std::uint32_t brick_size = 0;  ///< B
    std::uint32_t border = 0;      ///< replicated samples on each side of a brick
    std::uint32_t levels = 0;      ///< L
    BrickFormat format = BrickFormat::Float32;
    std::vector<Node> nodes;
    /// The bricks, brick_words() words each in `format`; sample (x, y, z) of brick i (x, y, z in
    /// [0, B + 2 * border), x fastest) is sample x + S * (y + S * z) of the brick's words
    /// (sylva/shared/octree_layout.h), S = B + 2 * border, the voxel (or coarse voxel)
    /// coord * B - border + (x, y, z) of the node's level, clamped to the level's extent.
    std::vector<std::uint32_t> bricks;
    double build_ms = 0.0;

    /// Samples per brick side, S = B + 2 * border.
    [[nodiscard]] std::uint32_t brick_side() const { return brick_size + 2u * border; }
    /// Words per brick: S^3 samples in `format`.
    [[nodiscard]] std::uint32_t brick_words() const {
        return shared::sylva_oct_brick_word_count(brick_side(), static_cast<std::uint32_t>(format));
    }
    [[nodiscard]] std::size_t brick_count() const { return brick_words() ? bricks.size() / brick_words() : 0u; }
    /// Width in voxels of a node of level l: B * 2^(L - 1 - l).
    [[nodiscard]] std::uint32_t width(std::uint32_t level) const { return brick_size << (levels - 1u - level); }
    /// Nodes per axis of level l that start inside the volume: ceil(dims / width).
    [[nodiscard]] glm::u32vec3 level_nodes(std::uint32_t level) const {
        std::uint32_t w = width(level);
        return (dims + (w - 1u)) / w;
    }
    /// Voxel-space box of a node: [coord * W, min((coord + 1) * W, dims)].
    [[nodiscard]] glm::u32vec3 box_lo(const Node& n) const { return n.coord * width(n.level); }
    [[nodiscard]] glm::u32vec3 box_hi(const Node& n) const {
        return glm::min((n.coord + 1u) * width(n.level), dims);
    }
    /// Sample (x, y, z) of brick b as a normalised density.
    [[nodiscard]] float sample(std::uint32_t b, std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
        std::uint32_t s = brick_side();
        return shared::sylva_oct_brick_value(shared::Words{bricks.data(), bricks.size()}, b * brick_words(),
                                             static_cast<std::uint32_t>(format), x + s * (y + s * z));
    }
    /// Bytes of the bricks.
    [[nodiscard]] std::size_t brick_bytes() const { return bricks.size() * 4u; }
};

/// Settings of octree::build.
struct Config {
    /// B, voxels per brick side. The paper's results use 32^3 bricks (section 7, "a granularity
    /// of 32^3 octree bricks with 1 layer overlap"); 16 suits volumes of a few hundred voxels.
    /// Powers of two from 4 to 64 are accepted (4 and 8 for tests and tiny volumes).
    std::uint32_t brick_size = 32;
    /// Samples replicated on each side of a brick (section 3): "one layer is replicated for
    /// linear interpolation support, while two layers are replicated for additionally using
    /// central differences to compute gradients at rendering time". The paper's runs use 1 with
    /// precomputed gradients; sylva's DVR computes gradients at rendering time (the reference
    /// marcher reads densities one voxel away from each sample, two voxels beyond a brick), so
    /// the default is 2: every shaded sample then reads one brick.
    /// Costs (36/34)^3 = 1.19x the brick memory of border 1 for B = 32, 1.37x for B = 16.
    std::uint32_t border = 2;
    /// How bricks store samples. Float32 (default) keeps every density; Unorm16 (the paper's
    /// "16-bit texels") and Unorm8 round each density to the nearest of 65536 or 256 steps, for
    /// half or a quarter of the memory. A uint16 / uint8 volume normalised over its type's range
    /// (volume::normalize of a Type-range volume, or any range whose densities are v / 65535 or
    /// v / 255) loses nothing: its octree then renders the marcher's image bit for bit. Node
    /// ranges are those of the rounded samples (culling stays exact).
    BrickFormat format = BrickFormat::Float32;
};

namespace detail {

inline std::string dims_text(volume::Dims d) {
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z);
}

/// Checks the configuration: a power-of-two brick size in [4, 64] and a border of 1 or 2.
inline void check_config(const Config& cfg) {
    if (cfg.brick_size < 4 || cfg.brick_size > 64 || !std::has_single_bit(cfg.brick_size))
        throw Error("octree::build: brick size " + std::to_string(cfg.brick_size) +
                    " is not a power of two from 4 to 64 (the paper uses 32)");
    if (cfg.border < 1 || cfg.border > 2)
        throw Error("octree::build: border " + std::to_string(cfg.border) +
                    " is not 1 (trilinear) or 2 (trilinear and gradients)");
    if (!shared::sylva_oct_brick_format_ok(static_cast<std::uint32_t>(cfg.format)))
        throw Error("octree::build: unknown brick format " + std::to_string(static_cast<std::uint32_t>(cfg.format)) +
                    " (Float32, Unorm16 or Unorm8)");
}

/// Checks the grid: every extent in [1, 2^24 - 1], as many values as voxels, densities finite
/// and in [0, 1] (naming the first bad voxel), spacing finite and positive.
inline void check_grid(const volume::DensityGrid& g) {
    volume::Dims d = g.dims;
    if (d.x == 0 || d.y == 0 || d.z == 0)
        throw Error("octree::build: the volume is " + dims_text(d) + " voxels; every extent must be at least 1");
    if (d.x > kMaxDim || d.y > kMaxDim || d.z > kMaxDim)
        throw Error("octree::build: the volume is " + dims_text(d) + " voxels; extents above 2^24 - 1 are not supported");
    std::size_t n = volume::voxel_count(d);
    if (g.values.size() != n)
        throw Error("octree::build: the grid holds " + std::to_string(g.values.size()) + " values for " +
                    std::to_string(n) + " voxels");
    if (!all_finite(g.spacing) || !(g.spacing.x > 0.0f && g.spacing.y > 0.0f && g.spacing.z > 0.0f))
        throw Error("octree::build: grid spacing must be finite and > 0");
    for (std::size_t i = 0; i < n; ++i)
        if (!(g.values[i] >= 0.0f && g.values[i] <= 1.0f))
            throw Error("octree::build: voxel " + std::to_string(i) + " is " +
                        (std::isnan(g.values[i]) ? std::string("NaN") : std::to_string(g.values[i])) +
                        ", not a normalised density in [0, 1]");
}

/// L = 1 + ceil(log2(max leaf bricks per axis)).
inline std::uint32_t level_count(volume::Dims d, std::uint32_t b) {
    std::uint32_t leaves = std::max({(d.x + b - 1) / b, (d.y + b - 1) / b, (d.z + b - 1) / b});
    return 1u + static_cast<std::uint32_t>(std::bit_width(leaves - 1u));
}

/// One level of the LoD pyramid: level s has ceil(dims / 2^s) coarse voxels per axis, each the
/// mean of the full-resolution voxels it covers.
/// Level 0 reads the grid's own values (no copy).
struct LodLevel {
    volume::Dims dims{0};
    std::vector<float> values;     ///< levels >= 1
    const float* data = nullptr;   ///< values.data(), or the grid's values at level 0
    [[nodiscard]] float at(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
        return data[volume::voxel_index(dims, x, y, z)];
    }
};

/// Full-resolution voxels under coarse voxel i of level s along an axis of n voxels.
inline std::uint32_t covered(std::uint32_t i, std::uint32_t s, std::uint32_t n) {
    return std::min(1u << s, n - (i << s));
}

/// Level s of the pyramid from level s - 1 (`fine`): 2x2x2 box filter weighted by the voxels
/// each fine voxel covers, accumulated in double.
template <Executor X>
LodLevel downsample(const LodLevel& fine, std::uint32_t s, volume::Dims full, X& exec) {
    LodLevel out{(fine.dims + 1u) / 2u, {}, nullptr};
    out.values.resize(volume::voxel_count(out.dims));
    out.data = out.values.data();
    exec.parallel_for(0, out.dims.z, 1, [&](std::size_t z0, std::size_t z1) {
        for (std::uint32_t z = std::uint32_t(z0); z < z1; ++z)
            for (std::uint32_t y = 0; y < out.dims.y; ++y)
                for (std::uint32_t x = 0; x < out.dims.x; ++x) {
                    double sum = 0.0, weight = 0.0;
                    for (std::uint32_t o = 0; o < 8; ++o) {
                        glm::u32vec3 f(2 * x + (o & 1u), 2 * y + ((o >> 1) & 1u), 2 * z + (o >> 2));
                        if (f.x >= fine.dims.x || f.y >= fine.dims.y || f.z >= fine.dims.z) continue;
                        double w = double(covered(f.x, s - 1, full.x)) * covered(f.y, s - 1, full.y) *
                                   covered(f.z, s - 1, full.z);
                        sum += w * fine.at(f.x, f.y, f.z);
                        weight += w;
                    }
                    out.values[volume::voxel_index(out.dims, x, y, z)] = float(sum / weight);
                }
    });
    return out;
}

/// The pyramid's levels 0 (the grid) .. levels - 1.
template <Executor X>
std::vector<LodLevel> lod_pyramid(const volume::DensityGrid& g, std::uint32_t levels, X& exec) {
    std::vector<LodLevel> lod;
    lod.reserve(levels);
    lod.push_back({g.dims, {}, g.values.data()});
    for (std::uint32_t s = 1; s < levels; ++s) lod.push_back(downsample(lod.back(), s, g.dims, exec));
    return lod;
}

/// The complete octree's nodes, level by level, children consecutive in octant order.
inline std::vector<Node> complete_nodes(const Tree& t) {
    std::vector<Node> nodes(1);
    std::size_t level_begin = 0;
    for (std::uint32_t l = 0; l + 1 < t.levels; ++l) {
        std::size_t level_end = nodes.size();
        glm::u32vec3 below = t.level_nodes(l + 1);
        for (std::size_t n = level_begin; n < level_end; ++n) {
            nodes[n].first_child = static_cast<std::uint32_t>(nodes.size());
            for (std::uint32_t o = 0; o < 8; ++o) {
                glm::u32vec3 c = nodes[n].coord * 2u + glm::u32vec3(o & 1u, (o >> 1) & 1u, o >> 2);
                if (c.x >= below.x || c.y >= below.y || c.z >= below.z) continue;
                nodes[n].child_mask |= 1u << o;
                Node child;
                child.level = l + 1;
                child.coord = c;
                nodes.push_back(child);
            }
        }
        level_begin = level_end;
    }
    return nodes;
}

/// The largest integer sample of a unorm format (65535, 255); 0 for float32.
inline std::uint32_t unorm_max(BrickFormat f) {
    return f == BrickFormat::Unorm16 ? 65535u : (f == BrickFormat::Unorm8 ? 255u : 0u);
}

/// Density d in [0, 1] rounded to the nearest step of `max` (v / max gives v back); d is
/// clamped to [0, 1] and NaN reads 0. Rounds half away from zero, as std::lround: d * max is
/// exact in double (24 by 16 bits) and so is + 0.5, so truncating the sum rounds the same.
inline std::uint32_t quantise(float d, std::uint32_t max) {
    const float c = d > 0.0f ? std::min(d, 1.0f) : 0.0f;
    return static_cast<std::uint32_t>(double(c) * double(max) + 0.5);
}

/// The density a sample of d reads back in format f (sylva_oct_brick_value's arithmetic).
inline float stored_density(float d, BrickFormat f) {
    std::uint32_t max = unorm_max(f);
    return max == 0u ? d : float(quantise(d, max)) / float(max);
}

/// Fills node n's brick from the pyramid level of its depth (borders clamped at the edge), in
/// the tree's format.
inline void fill_brick(Tree& t, const std::vector<LodLevel>& lod, std::size_t n) {
    const Node& node = t.nodes[n];
    const LodLevel& src = lod[t.levels - 1u - node.level];
    const std::uint32_t s = t.brick_side();
    const glm::ivec3 lo = glm::ivec3(node.coord * t.brick_size) - int(t.border);
    const glm::ivec3 top = glm::ivec3(src.dims) - 1;
    std::uint32_t* out = t.bricks.data() + std::size_t{node.brick} * t.brick_words();
    const std::uint32_t max = unorm_max(t.format);
    const std::uint32_t bits = t.format == BrickFormat::Unorm16 ? 16u : 8u;
    std::uint32_t j = 0;
    for (std::uint32_t z = 0; z < s; ++z)
        for (std::uint32_t y = 0; y < s; ++y)
            for (std::uint32_t x = 0; x < s; ++x, ++j) {
                glm::ivec3 v = glm::clamp(lo + glm::ivec3(x, y, z), glm::ivec3(0), top);
                float d = src.at(std::uint32_t(v.x), std::uint32_t(v.y), std::uint32_t(v.z));
                if (max == 0u) {
                    out[j] = std::bit_cast<std::uint32_t>(d);
                } else {
                    std::uint32_t per_word = 32u / bits;  // 2 or 4 samples a word, low bits first
                    out[j / per_word] |= quantise(d, max) << ((j % per_word) * bits);
                }
            }
}

/// [min, max] of the densities trilinear sampling in node n's box reaches at its own level: its
/// coarse voxels plus one around them, clamped to the level's extent.
inline std::pair<float, float> own_range(const Tree& t, const std::vector<LodLevel>& lod, const Node& node) {
    const LodLevel& src = lod[t.levels - 1u - node.level];
    glm::u32vec3 lo = glm::max(glm::ivec3(node.coord * t.brick_size) - 1, glm::ivec3(0));
    glm::u32vec3 hi = glm::min((node.coord + 1u) * t.brick_size, src.dims - 1u);
    float a = std::numeric_limits<float>::infinity(), b = -a;
    for (std::uint32_t z = lo.z; z <= hi.z; ++z)
        for (std::uint32_t y = lo.y; y <= hi.y; ++y)
            for (std::uint32_t x = lo.x; x <= hi.x; ++x) {
                float v = src.at(x, y, z);
                a = std::min(a, v);
                b = std::max(b, v);
            }
    return {a, b};
}

/// Index range [begin, end) of each level's nodes (nodes are stored level by level).
inline std::vector<std::size_t> level_starts(const std::vector<Node>& nodes, std::uint32_t levels) {
    std::vector<std::size_t> start(levels + 1, nodes.size());
    for (std::size_t n = nodes.size(); n-- > 0;) start[nodes[n].level] = n;
    for (std::uint32_t l = levels; l-- > 0;) start[l] = std::min(start[l], start[l + 1]);
    return start;
}

/// Bricks and ranges, level by level from the leaves up, in parallel within a level.
template <Executor X>
void fill_bricks_and_ranges(Tree& t, const std::vector<LodLevel>& lod, X& exec) {
    std::vector<std::size_t> start = level_starts(t.nodes, t.levels);
    for (std::uint32_t l = t.levels; l-- > 0;) {
        exec.parallel_for(start[l], start[l + 1], 8, [&](std::size_t n0, std::size_t n1) {
            for (std::size_t n = n0; n < n1; ++n) {
                fill_brick(t, lod, n);
                Node& node = t.nodes[n];
                auto [a, b] = own_range(t, lod, node);
                a = stored_density(a, t.format);  // rounding is monotonic: the stored samples' range
                b = stored_density(b, t.format);
                for (std::uint32_t o = 0, c = node.first_child; o < 8; ++o) {
                    if (((node.child_mask >> o) & 1u) == 0u) continue;
                    a = std::min(a, t.nodes[c].min);
                    b = std::max(b, t.nodes[c].max);
                    ++c;
                }
                node.min = a;
                node.max = b;
            }
        });
    }
}

}  // namespace detail

/// Fills every node's neighbour pointers (section 4, Fig. 3) from the nodes' levels and
/// coordinates: per face, the node at the same level just across it, else the deepest coarser
/// node containing that place, else kNone (across the volume's boundary). Works on any octree
/// in Tree's node order, complete or sparse (the element octree shares it).
inline void link_neighbours(Tree& t) {
    std::vector<std::vector<std::uint32_t>> at(t.levels);  // per level: a dense (coords -> node) table
    for (std::uint32_t l = 0; l < t.levels; ++l) {
        glm::u32vec3 r = t.level_nodes(l);
        at[l].assign(std::size_t{r.x} * r.y * r.z, kNone);
    }
    auto slot = [&](std::uint32_t l, glm::u32vec3 c) {
        glm::u32vec3 r = t.level_nodes(l);
        return c.x + std::size_t{r.x} * (c.y + std::size_t{r.y} * c.z);
    };
    for (std::size_t n = 0; n < t.nodes.size(); ++n) at[t.nodes[n].level][slot(t.nodes[n].level, t.nodes[n].coord)] = std::uint32_t(n);
    for (Node& node : t.nodes) {
        glm::u32vec3 r = t.level_nodes(node.level);
        for (std::uint32_t f = 0; f < 6; ++f) {
            std::uint32_t a = f / 2;
            node.neighbour[f] = kNone;
            if ((f & 1u) == 0u ? node.coord[a] == 0u : node.coord[a] + 1u >= r[a]) continue;  // outside
            glm::u32vec3 c = node.coord;
            c[a] = (f & 1u) ? c[a] + 1u : c[a] - 1u;
            for (std::uint32_t l = node.level + 1; l-- > 0;) {
                std::uint32_t m = at[l][slot(l, c >> (node.level - l))];
                if (m != kNone) {
                    node.neighbour[f] = m;
                    break;
                }
            }
        }
    }
}

/// Builds the bricked octree of `g` (see the top of this header). Throws sylva::Error naming the
/// problem for a bad configuration (brick size, border), a zero or too large extent, a value
/// count that does not match the extents, a density that is NaN or outside [0, 1], a bad
/// spacing, or bricks that would exceed 2^32 - 1 words in all.
template <Executor X>
Tree build(const volume::DensityGrid& g, X& exec, const Config& cfg = {}) {
    auto t0 = std::chrono::steady_clock::now();
    detail::check_config(cfg);
    detail::check_grid(g);
    Tree t;
    t.dims = g.dims;
    t.spacing = g.spacing;
    t.brick_size = cfg.brick_size;
    t.border = cfg.border;
    t.levels = detail::level_count(g.dims, cfg.brick_size);
    t.format = cfg.format;
    if (t.levels > kMaxLevels)
        throw Error("octree::build: a " + detail::dims_text(g.dims) + " volume in bricks of " +
                    std::to_string(cfg.brick_size) + " needs " + std::to_string(t.levels) + " levels, more than " +
                    std::to_string(kMaxLevels));
    t.nodes = detail::complete_nodes(t);
    std::size_t words = t.nodes.size() * std::size_t{t.brick_words()};
    if (words > 0xFFFFFFFFu)
        throw Error("octree::build: " + std::to_string(t.nodes.size()) + " bricks of " +
                    std::to_string(t.brick_words()) + " samples exceed 2^32 - 1 words; use a smaller volume or " +
                    "the out-of-core octree");
    for (std::size_t n = 0; n < t.nodes.size(); ++n) t.nodes[n].brick = static_cast<std::uint32_t>(n);
    t.bricks.resize(words);
    std::vector<detail::LodLevel> lod = detail::lod_pyramid(g, t.levels, exec);
    detail::fill_bricks_and_ranges(t, lod, exec);
    link_neighbours(t);
    t.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return t;
}

/// octree::build on the calling thread.
inline Tree build(const volume::DensityGrid& g, const Config& cfg = {}) {
    SerialExecutor serial;
    return build(g, serial, cfg);
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_BUILD_HPP
