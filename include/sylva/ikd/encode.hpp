// sylva/ikd/encode.hpp -- writes an implicit kd-tree (sylva/ikd/build.hpp) as the flat words of
// sylva/shared/ikd_layout.h: the header, the level table, the node words. The grid the
// iterator reads beside it is sylva::GridWords (sylva/render/volume.hpp) of the same grid.
#ifndef SYLVA_IKD_ENCODE_HPP
#define SYLVA_IKD_ENCODE_HPP

#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/ikd/build.hpp"
#include "sylva/shared/ikd_layout.h"

namespace sylva::ikd {

/// The encoding of `t` (layout: sylva/shared/ikd_layout.h; node format 1, two nodes a word,
/// when t.node_bits is 8). Throws sylva::Error when the tree is inconsistent (its level table
/// and node words disagree, ranges that are not 8-bit in an 8-bit tree) or the words exceed
/// 2^32 - 1.
inline std::vector<std::uint32_t> encode(const Tree& t) {
    const std::size_t levels = t.levels.size();
    const std::size_t nodes_at = SYLVA_IKD_HEADER_WORDS + 2 * levels;
    if (t.node_bits != 8 && t.node_bits != 16) throw Error("ikd::encode: node_bits " + std::to_string(t.node_bits) + "; 8 or 16");
    const bool half = t.node_bits == 8;
    const std::size_t node_words = half ? (t.ranges.size() + 1) / 2 : t.ranges.size();
    const std::size_t total = nodes_at + node_words;
    if (total > 0xFFFFFFFFu) throw Error("ikd::encode: " + std::to_string(total) + " words exceed 2^32 - 1");
    std::size_t expected = 0;
    for (std::size_t l = 0; l < std::min<std::size_t>(t.stored_levels, levels); ++l) expected += t.levels[l].count();
    if (expected != t.ranges.size() || levels != std::size_t{t.lg.x} + t.lg.y + t.lg.z || t.stored_levels > levels)
        throw Error("ikd::encode: the tree's levels and node words disagree");
    std::vector<std::uint32_t> w(total, 0u);
    w[0] = SYLVA_IKD_MAGIC;
    w[1] = SYLVA_IKD_VERSION;
    for (int a = 0; a < 3; ++a) {
        w[2 + a] = t.cells[a];
        w[10 + a] = std::bit_cast<std::uint32_t>(t.spacing[a]);
        w[13 + a] = std::bit_cast<std::uint32_t>(t.origin[a]);
        w[17 + a] = std::bit_cast<std::uint32_t>(1.0f / t.spacing[a]);
    }
    w[5] = static_cast<std::uint32_t>(levels) | (t.lg.x << 8) | (t.lg.y << 16) | (t.lg.z << 24);
    w[6] = static_cast<std::uint32_t>(t.ranges.size());
    w[7] = (half ? SYLVA_IKD_FORMAT_UNORM8 : SYLVA_IKD_FORMAT_UNORM16) | (t.stored_levels << 8);
    w[8] = std::bit_cast<std::uint32_t>(t.range_lo);
    w[9] = std::bit_cast<std::uint32_t>(t.range_hi);
    w[16] = static_cast<std::uint32_t>(total);
    for (std::size_t l = 0; l < levels; ++l) {
        const Level& lv = t.levels[l];
        w[SYLVA_IKD_HEADER_WORDS + 2 * l] =
            lv.axis | (lv.log2_width.x << 8) | (lv.log2_width.y << 16) | (lv.log2_width.z << 24);
        w[SYLVA_IKD_HEADER_WORDS + 2 * l + 1] = lv.first;
    }
    if (!half) {
        std::copy(t.ranges.begin(), t.ranges.end(), w.begin() + static_cast<std::ptrdiff_t>(nodes_at));
        return w;
    }
    for (std::size_t k = 0; k < t.ranges.size(); ++k) {  // q * 257 back to q: min | max << 8, two a word
        std::uint32_t r = t.ranges[k], lo = (r & 0xFFFFu) / 257u, hi = (r >> 16) / 257u;
        if (lo * 257u != (r & 0xFFFFu) || hi * 257u != (r >> 16))
            throw Error("ikd::encode: node " + std::to_string(k) + "'s range is not 8-bit (node_bits 8)");
        w[nodes_at + k / 2] |= (lo | hi << 8) << (16 * (k & 1));
    }
    return w;
}

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_ENCODE_HPP
