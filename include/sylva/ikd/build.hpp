// sylva/ikd/build.hpp -- builds Wald et al.'s implicit min/max kd-tree over the cells of a
// density grid ("Faster Isosurface Ray Tracing using Implicit KD-Trees", sections 3.3 and 5).
//
// What is built (the layout is sylva/shared/ikd_layout.h):
//  * a balanced kd-tree over the grid's cells (R - 1 per axis for R samples), virtually padded
//    to powers of two per axis (section 5.3); one split axis per level, chosen as the axis with
//    the most halvings left (x before y before z), so the planes are implicit (section 5.1);
//  * per stored node, the [min, max] of the normalised densities at the corners of every real
//    cell below it, computed bottom-up level by level and in parallel over each level's z rows;
//    the cells themselves (the last level) are not stored (section 5.2);
//  * min/max as unorm16 or unorm8 (Config::node_bits) rounded outward (min down, max up), so
//    culling stays conservative.
// Virtual nodes (those starting at or beyond the real cells) are never stored: each level holds
// ceil(C / width) nodes per axis, addressed from the node's first cell (no pointers).
#ifndef SYLVA_IKD_BUILD_HPP
#define SYLVA_IKD_BUILD_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::ikd {

/// One stored level: its split axis, node width (log2, in cells), real node counts per axis
/// and the index of its first node.
struct Level {
    std::uint32_t axis = 0;
    glm::u32vec3 log2_width{0};
    glm::u32vec3 nodes{0};
    std::uint32_t first = 0;
    [[nodiscard]] std::size_t count() const { return std::size_t{nodes.x} * nodes.y * nodes.z; }
};

/// The built tree: geometry, levels and the packed node ranges (unorm16 min | max << 16).
struct Tree {
    glm::u32vec3 cells{0};  ///< cells per axis (samples - 1)
    glm::u32vec3 lg{0};     ///< log2 of the padded cell counts
    std::vector<Level> levels;          ///< all L levels (axes and widths), stored or not
    std::uint32_t stored_levels = 0;    ///< levels with node words; the rest are bricks
    /// One word per stored node, level by level: unorm16 min | max << 16. With node_bits 8 the
    /// ranges were rounded outward to unorm8 q and are held here as q * 257 (the same density),
    /// as sylva_ikd_node_word reads them back from the encoding's half words.
    std::vector<std::uint32_t> ranges;
    std::uint32_t node_bits = 16;       ///< 16 or 8: the encoding's node format
    vec3 spacing{1.0f};                 ///< world size of one cell (the grid's voxel size)
    vec3 origin{0.5f};                  ///< world position of sample (0, 0, 0)
    float range_lo = 0.0f, range_hi = 1.0f;  ///< raw values of densities 0 and 1 (information)
    double build_ms = 0.0;

    /// Total cells, and the bytes of the encoding (header, level table, node words).
    [[nodiscard]] std::size_t cell_count() const { return std::size_t{cells.x} * cells.y * cells.z; }
    [[nodiscard]] std::size_t bytes() const {
        return (20 + 2 * levels.size() + (node_bits == 8 ? (ranges.size() + 1) / 2 : ranges.size())) * 4;
    }
};

/// Settings of ikd::build.
struct Config {
    /// Bottom levels not stored (bricks). 0 is the paper's slim tree without leaves (section
    /// 5.2: one node per cell pair, about one node per cell). Each level more halves the nodes;
    /// below the stored levels nothing is culled and a brick's cells are tested one by one
    /// (section 5.2 proposes such bricks and smaller ranges without measuring them). 3 (the
    /// default) leaves bricks of 2x2x2 cells, 4 of 4x2x2, 6 of 4x4x4. On the 8-bit aneurism
    /// and bonsai at 512^2 (iso 0.3), with 8-bit nodes: 4.2 MB with 3 levels, 2.1 MB with 4,
    /// 0.5 MB with 6 and the slim 16-bit tree's 66.8 MB (the data: 16.8 MB); packets through 3
    /// levels take 7.5 steps a ray against 8.3 with 4 and 10.5 with 6, and are 1.02-1.05x
    /// faster than with 4 and 1.14-1.2x than with 6 (README, Wald section: sylva-iso-bench
    /// --alt-bricks N --alt-bits B; sylva-render --ikd-bricks N --ikd-node-bits B).
    std::uint32_t brick_levels = 3;
    /// Bits of a node's min and max: 8 (the default: unorm8, half a word a node, Wald's 8-bit
    /// ranges of section 5.2) or 16 (unorm16, one word). Both are rounded outward from the exact
    /// densities, so culling stays conservative and the candidate cells are the same; 8 bits
    /// halve the index and cull a little less on data with more than 8 bits (a node is kept
    /// when an isovalue is within 1/255 of its range). On the aneurism and bonsai the packets
    /// through 3 brick levels were 1.01-1.03x faster with 16 bits (whose index, 268 bytes over
    /// half of 8-bit data, misses issue 11's 0.5x), through 4 levels 0.98-1.04x.
    std::uint32_t node_bits = 8;
    /// Raw value range the grid was normalised with (recorded in the header; sylva-render passes
    /// the volume's). Default: densities as they are.
    float range_lo = 0.0f;
    float range_hi = 1.0f;
};

namespace detail {

inline std::uint32_t log2_ceil(std::uint32_t c) {
    std::uint32_t lg = 0;
    while ((std::uint32_t{1} << lg) < c) ++lg;
    return lg;
}

/// Checks the grid: >= 2 samples per axis, at most 65536, fewer than 2^32 samples, densities
/// finite and in [0, 1], spacing finite and positive.
inline void check_grid(const volume::DensityGrid& g) {
    auto d = g.dims;
    if (d.x < 2 || d.y < 2 || d.z < 2)
        throw Error("ikd::build: the grid is " + std::to_string(d.x) + "x" + std::to_string(d.y) + "x" +
                    std::to_string(d.z) + " samples; every axis needs at least 2 (one cell)");
    if (d.x > 65536 || d.y > 65536 || d.z > 65536)
        throw Error("ikd::build: more than 65536 samples along an axis");
    std::size_t n = volume::voxel_count(d);
    if (n > 0xFFFFFFFFu) throw Error("ikd::build: " + std::to_string(n) + " samples exceed 2^32 - 1");
    if (g.values.size() != n)
        throw Error("ikd::build: the grid holds " + std::to_string(g.values.size()) + " values for " +
                    std::to_string(n) + " samples");
    if (!all_finite(g.spacing) || !(g.spacing.x > 0.0f && g.spacing.y > 0.0f && g.spacing.z > 0.0f))
        throw Error("ikd::build: grid spacing must be finite and > 0");
    for (std::size_t i = 0; i < n; ++i)
        if (!(g.values[i] >= 0.0f && g.values[i] <= 1.0f))
            throw Error("ikd::build: sample " + std::to_string(i) + " is " +
                        (std::isnan(g.values[i]) ? std::string("NaN") : std::to_string(g.values[i])) +
                        ", not a normalised density in [0, 1]");
}

/// The level table: one axis per level, the axis with the most halvings left.
inline std::vector<Level> make_levels(glm::u32vec3 cells, glm::u32vec3 lg) {
    std::vector<Level> levels;
    glm::u32vec3 w = lg;
    std::uint32_t first = 0;
    while (w.x + w.y + w.z > 0) {
        Level l;
        l.axis = (w.x >= w.y && w.x >= w.z) ? 0u : (w.y >= w.z ? 1u : 2u);
        l.log2_width = w;
        for (int a = 0; a < 3; ++a) l.nodes[a] = (cells[a] + (1u << w[a]) - 1u) >> w[a];
        l.first = first;
        first += static_cast<std::uint32_t>(l.count());
        levels.push_back(l);
        w[l.axis] -= 1;
    }
    return levels;
}

/// [min, max] over the eight corners of cell (x, y, z).
inline std::pair<float, float> cell_range(const volume::DensityGrid& g, std::uint32_t x, std::uint32_t y,
                                          std::uint32_t z) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (std::uint32_t k = 0; k < 8; ++k) {
        float v = g.at(x + (k & 1u), y + ((k >> 1) & 1u), z + ((k >> 2) & 1u));
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    return {lo, hi};
}

/// Float ranges of one level, computed from the level below (`below`, nullptr: the cells).
struct LevelRanges {
    std::vector<float> lo, hi;
};

/// Level l's node ranges from the level below: `below` holds its ranges and `rb` its real nodes
/// per axis; below == nullptr means the cells (rb = the cell counts), read from the grid.
template <Executor X>
LevelRanges level_ranges(const volume::DensityGrid& g, const Level& l, glm::u32vec3 rb, const LevelRanges* below,
                         X& exec) {
    LevelRanges out{std::vector<float>(l.count()), std::vector<float>(l.count())};
    glm::u32vec3 r = l.nodes;
    exec.parallel_for(0, r.z, 1, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k)
            for (std::uint32_t j = 0; j < r.y; ++j)
                for (std::uint32_t i = 0; i < r.x; ++i) {
                    glm::u32vec3 c0(i, j, static_cast<std::uint32_t>(k));
                    c0[l.axis] *= 2;  // children: c0 and c0 + 1 along the axis, in the level below
                    glm::u32vec3 c1 = c0;
                    c1[l.axis] += 1;
                    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
                    for (glm::u32vec3 c : {c0, c1}) {
                        if (c[l.axis] >= rb[l.axis]) continue;  // a virtual child: no cells
                        std::pair<float, float> cr =
                            below ? std::pair{below->lo[c.x + rb.x * (c.y + std::size_t{rb.y} * c.z)],
                                              below->hi[c.x + rb.x * (c.y + std::size_t{rb.y} * c.z)]}
                                  : cell_range(g, c.x, c.y, c.z);
                        lo = std::min(lo, cr.first);
                        hi = std::max(hi, cr.second);
                    }
                    std::size_t at = i + r.x * (j + std::size_t{r.y} * k);
                    out.lo[at] = lo;
                    out.hi[at] = hi;
                }
    });
    return out;
}

/// unorm16 min (rounded down) | max (rounded up) << 16; with 8 bits the unorm8 codes rounded
/// the same way, widened to q * 257 (their unorm16 code).
inline std::uint32_t pack_range(float lo, float hi, std::uint32_t bits = 16) {
    double top = bits == 8 ? 255.0 : 65535.0, widen = bits == 8 ? 257.0 : 1.0;
    double a = std::floor(static_cast<double>(lo) * top), b = std::ceil(static_cast<double>(hi) * top);
    auto q = [&](double v) { return static_cast<std::uint32_t>(std::clamp(v, 0.0, top) * widen); };
    return q(a) | (q(b) << 16);
}

}  // namespace detail

/// Builds the implicit kd-tree over `g`'s cells (see the top of this header). Throws
/// sylva::Error for grids with fewer than 2 samples along an axis, more than 65536 along one or
/// 2^32 in all, densities that are NaN or outside [0, 1] (naming the sample), a bad spacing.
template <Executor X>
Tree build(const volume::DensityGrid& g, X& exec, const Config& cfg = {}) {
    auto t0 = std::chrono::steady_clock::now();
    detail::check_grid(g);
    if (cfg.node_bits != 8 && cfg.node_bits != 16)
        throw Error("ikd::build: node_bits " + std::to_string(cfg.node_bits) + "; 8 or 16");
    Tree t;
    t.node_bits = cfg.node_bits;
    t.cells = g.dims - 1u;
    t.lg = glm::u32vec3(detail::log2_ceil(t.cells.x), detail::log2_ceil(t.cells.y), detail::log2_ceil(t.cells.z));
    t.levels = detail::make_levels(t.cells, t.lg);
    t.spacing = g.spacing;
    t.origin = 0.5f * g.spacing;  // voxel centres: sylva/volume/grid.hpp
    t.range_lo = cfg.range_lo;
    t.range_hi = cfg.range_hi;
    const std::size_t levels = t.levels.size();
    t.stored_levels = static_cast<std::uint32_t>(levels > cfg.brick_levels ? levels - cfg.brick_levels : 0);
    std::size_t total = 0;
    for (std::size_t l = 0; l < levels; ++l) {
        t.levels[l].first = static_cast<std::uint32_t>(total);  // brick levels: first = N, no nodes
        if (l < t.stored_levels) total += t.levels[l].count();
    }
    t.ranges.resize(total);
    detail::LevelRanges below;
    for (std::size_t l = levels; l-- > 0;) {  // every level's ranges: a stored level reads the one below
        bool cells_below = l + 1 == levels;
        detail::LevelRanges here = detail::level_ranges(g, t.levels[l], cells_below ? t.cells : t.levels[l + 1].nodes,
                                                        cells_below ? nullptr : &below, exec);
        if (l < t.stored_levels)
            for (std::size_t i = 0; i < here.lo.size(); ++i)
                t.ranges[t.levels[l].first + i] = detail::pack_range(here.lo[i], here.hi[i], cfg.node_bits);
        below = std::move(here);
    }
    t.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return t;
}

/// ikd::build on the calling thread.
inline Tree build(const volume::DensityGrid& g, const Config& cfg = {}) {
    SerialExecutor serial;
    return build(g, serial, cfg);
}

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_BUILD_HPP
