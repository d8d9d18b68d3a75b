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

/// The encoding of `t` (layout: sylva/shared/ikd_layout.h). Throws sylva::Error when the tree
/// is inconsistent (its level table and node words disagree) or the words exceed 2^32 - 1.
inline std::vector<std::uint32_t> encode(const Tree& t) {
    const std::size_t levels = t.levels.size();
    const std::size_t nodes_at = SYLVA_IKD_HEADER_WORDS + 2 * levels;
    const std::size_t total = nodes_at + t.ranges.size();
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
    w[7] = SYLVA_IKD_FORMAT_UNORM16 | (t.stored_levels << 8);
    w[8] = std::bit_cast<std::uint32_t>(t.range_lo);
    w[9] = std::bit_cast<std::uint32_t>(t.range_hi);
    w[16] = static_cast<std::uint32_t>(total);
    for (std::size_t l = 0; l < levels; ++l) {
        const Level& lv = t.levels[l];
        w[SYLVA_IKD_HEADER_WORDS + 2 * l] =
            lv.axis | (lv.log2_width.x << 8) | (lv.log2_width.y << 16) | (lv.log2_width.z << 24);
        w[SYLVA_IKD_HEADER_WORDS + 2 * l + 1] = lv.first;
    }
    std::copy(t.ranges.begin(), t.ranges.end(), w.begin() + static_cast<std::ptrdiff_t>(nodes_at));
    return w;
}

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_ENCODE_HPP
