// sylva/ikd/validate.hpp -- checks an untrusted implicit kd-tree encoding (from disk, from a
// user) before anything traverses it, with a message that names the first problem found.
#ifndef SYLVA_IKD_VALIDATE_HPP
#define SYLVA_IKD_VALIDATE_HPP

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>

#include "sylva/core/error.hpp"
#include "sylva/shared/ikd_layout.h"

namespace sylva::ikd {

namespace detail {

inline void validate_fixed_words(std::span<const std::uint32_t> w) {
    if (w.size() < SYLVA_IKD_HEADER_WORDS)
        throw Error("ikd::validate: " + std::to_string(w.size()) + " words, shorter than the 20-word header");
    if (w[0] != SYLVA_IKD_MAGIC) throw Error("ikd::validate: bad magic (not an implicit kd-tree encoding)");
    if (w[1] != SYLVA_IKD_VERSION) throw Error("ikd::validate: unsupported version " + std::to_string(w[1]));
    if (((w[7] & 255u) != SYLVA_IKD_FORMAT_UNORM16 && (w[7] & 255u) != SYLVA_IKD_FORMAT_UNORM8) || (w[7] >> 16) != 0u)
        throw Error("ikd::validate: unknown node format " + std::to_string(w[7] & 255u) + " (word 7 = " +
                    std::to_string(w[7]) + ")");
    if (w[16] != w.size())
        throw Error("ikd::validate: the header says " + std::to_string(w[16]) + " words, the buffer holds " +
                    std::to_string(w.size()) + " (truncated or padded)");
    for (int a = 0; a < 3; ++a) {
        if (w[2 + a] < 1 || w[2 + a] > SYLVA_IKD_MAX_CELLS)
            throw Error("ikd::validate: " + std::to_string(w[2 + a]) + " cells along axis " + std::to_string(a) +
                        ", outside 1 .. 65535");
        float s = std::bit_cast<float>(w[10 + a]), inv = std::bit_cast<float>(w[17 + a]),
              o = std::bit_cast<float>(w[13 + a]);
        if (!(std::isfinite(s) && s > 0.0f && std::isfinite(inv) && inv > 0.0f && std::isfinite(o)))
            throw Error("ikd::validate: spacing, 1/spacing or origin along axis " + std::to_string(a) +
                        " not finite (and positive)");
    }
}

}  // namespace detail

/// Checks `words` against the layout of sylva/shared/ikd_layout.h for a grid buffer of
/// `grid_words` words: header fields, padding and level count, each level-table entry, the node
/// count and total size, and every node word (min <= max). Throws sylva::Error naming the first
/// problem; returns normally when sylva_ikd_read_header accepts the encoding.
inline void validate(std::span<const std::uint32_t> words, std::size_t grid_words) {
    using namespace sylva::shared;
    detail::validate_fixed_words(words);
    glm::u32vec3 cells(words[2], words[3], words[4]);
    std::uint32_t levels = words[5] & 255u;
    glm::u32vec3 lg(sylva_ikd_bits5(words[5], 8), sylva_ikd_bits5(words[5], 16), sylva_ikd_bits5(words[5], 24));
    for (int a = 0; a < 3; ++a)
        if (lg[a] != sylva_ikd_log2_ceil(cells[a]))
            throw Error("ikd::validate: padding 2^" + std::to_string(lg[a]) + " along axis " + std::to_string(a) +
                        " is not the least power of two >= " + std::to_string(cells[a]) + " cells");
    if (levels != lg.x + lg.y + lg.z)
        throw Error("ikd::validate: " + std::to_string(levels) + " levels, the padding needs " +
                    std::to_string(lg.x + lg.y + lg.z));
    std::uint32_t stored = (words[7] >> 8) & 255u;
    if (stored > levels)
        throw Error("ikd::validate: " + std::to_string(stored) + " stored levels of " + std::to_string(levels));
    std::size_t samples = std::size_t{cells.x + 1} * (cells.y + 1) * (cells.z + 1);
    if (samples > 0xFFFFFFFFu)
        throw Error("ikd::validate: a grid of " + std::to_string(samples) + " samples exceeds 2^32 - 1");
    if (samples != grid_words)
        throw Error("ikd::validate: the tree's " + std::to_string(cells.x) + "x" + std::to_string(cells.y) + "x" +
                    std::to_string(cells.z) + " cells need a grid of " + std::to_string(samples) +
                    " samples, the grid buffer holds " + std::to_string(grid_words));
    if (words.size() < SYLVA_IKD_HEADER_WORDS + 2 * std::size_t{levels})
        throw Error("ikd::validate: the level table does not fit in the buffer");
    Words buf{words.data(), words.size()};
    std::uint32_t implied = sylva_ikd_check_levels(buf, cells, lg, levels, stored);
    if (implied == 0xFFFFFFFFu)
        throw Error("ikd::validate: the level table is inconsistent (axes, widths or first nodes)");
    std::uint32_t format = words[7] & 255u;
    const std::size_t nodes_at = SYLVA_IKD_HEADER_WORDS + 2 * std::size_t{levels};
    if (implied != words[6] || words.size() != nodes_at + sylva_ikd_node_words(implied, format))
        throw Error("ikd::validate: " + std::to_string(words[6]) + " nodes stored in " +
                    std::to_string(words.size() - nodes_at) + " words, the level table implies " +
                    std::to_string(implied) + " nodes");
    SylvaIkdHeader h{};
    h.format = format;
    h.nodes_at = static_cast<std::uint32_t>(nodes_at);
    for (std::uint32_t k = 0; k < implied; ++k) {
        std::uint32_t r = sylva_ikd_node_word(buf, h, k);
        if ((r & 0xFFFFu) > (r >> 16)) throw Error("ikd::validate: node " + std::to_string(k) + " has min above max");
    }
    if (format == SYLVA_IKD_FORMAT_UNORM8 && (implied & 1u) != 0u && (words.back() >> 16) != 0u)
        throw Error("ikd::validate: the unused half of the last 8-bit node word is not 0");
    if (sylva_ikd_read_header(buf, static_cast<std::uint32_t>(words.size()), static_cast<std::uint32_t>(grid_words))
            .valid == 0u)
        throw Error("ikd::validate: the shared header reader refuses the encoding");
}

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_VALIDATE_HPP
