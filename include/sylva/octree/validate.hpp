// sylva/octree/validate.hpp -- checks an untrusted bricked-octree encoding (from disk, from a
// user) before anything traverses it, with a message that names the first problem found. It
// never reads outside the spans it is given, whatever their words.
#ifndef SYLVA_OCTREE_VALIDATE_HPP
#define SYLVA_OCTREE_VALIDATE_HPP

#include <bit>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/shared/octree_layout.h"

namespace sylva::octree {

namespace detail {

[[noreturn]] inline void invalid(const std::string& what) { throw Error("octree::validate: " + what); }

inline std::string node_text(std::size_t n) { return "node " + std::to_string(n); }

/// Header words 0 .. 19 one by one, each failure with its own message.
inline void validate_header(std::span<const std::uint32_t> w, std::size_t brick_buffer_words) {
    if (w.size() < SYLVA_OCT_HEADER_WORDS)
        invalid(std::to_string(w.size()) + " words, shorter than the 20-word header");
    if (w[0] != SYLVA_OCT_MAGIC) invalid("bad magic (not a bricked octree encoding)");
    if (w[1] != SYLVA_OCT_VERSION) invalid("unsupported version " + std::to_string(w[1]));
    if (brick_buffer_words > 0xFFFFFFFFu) invalid("the brick buffer exceeds 2^32 - 1 words");
    if (w[9] != w.size())
        invalid("the header says " + std::to_string(w[9]) + " words, the buffer holds " + std::to_string(w.size()) +
                " (truncated or padded)");
    for (int a = 0; a < 3; ++a)
        if (w[2 + a] < 1u || w[2 + a] > SYLVA_OCT_MAX_DIM)
            invalid("extent " + std::to_string(w[2 + a]) + " along axis " + std::to_string(a) + " outside 1 .. 2^24 - 1");
    std::uint32_t b = w[5] & 255u, border = (w[5] >> 8) & 255u, levels = (w[5] >> 16) & 255u, format = w[5] >> 24;
    if (b < 4 || b > 64 || !std::has_single_bit(b))
        invalid("brick size " + std::to_string(b) + " is not a power of two from 4 to 64");
    if (border < 1 || border > 2) invalid("border " + std::to_string(border) + " is not 1 or 2");
    if (!shared::sylva_oct_brick_format_ok(format))
        invalid("unknown brick format " + std::to_string(format) + " (0 float32, 2 unorm16, 3 unorm8)");
    std::uint32_t want = shared::sylva_oct_level_count(glm::u32vec3(w[2], w[3], w[4]), b);
    if (levels != want || levels > SYLVA_OCT_MAX_LEVELS)
        invalid(std::to_string(levels) + " levels, the extents and brick size need " + std::to_string(want) +
                " (at most 17)");
    std::uint32_t side = b + 2 * border, brick_words = shared::sylva_oct_brick_word_count(side, format);
    if (w[8] != brick_words)
        invalid("brick words " + std::to_string(w[8]) + ", a brick of side " + std::to_string(side) + " in format " +
                std::to_string(format) + " has " + std::to_string(brick_words));
    std::size_t records = (w.size() - SYLVA_OCT_HEADER_WORDS) / SYLVA_OCT_NODE_WORDS;
    if ((w.size() - SYLVA_OCT_HEADER_WORDS) % SYLVA_OCT_NODE_WORDS != 0 || w[6] != records || w[6] == 0)
        invalid(std::to_string(w[6]) + " nodes stated, the buffer holds " + std::to_string(records) +
                " whole 16-word records");
    if (brick_buffer_words != std::size_t{w[7]} * w[8])
        invalid(std::to_string(w[7]) + " bricks of " + std::to_string(w[8]) + " words need " +
                std::to_string(std::size_t{w[7]} * w[8]) + " words, the brick buffer holds " +
                std::to_string(brick_buffer_words));
    for (int a = 0; a < 3; ++a) {
        float s = std::bit_cast<float>(w[10 + a]), inv = std::bit_cast<float>(w[13 + a]), o = std::bit_cast<float>(w[16 + a]);
        if (!(std::isfinite(s) && s > 0.0f && std::isfinite(inv) && inv > 0.0f && std::isfinite(o)))
            invalid("spacing, 1 / spacing or origin along axis " + std::to_string(a) + " not finite (and positive)");
    }
    if (w[19] != 0u) invalid("reserved header word 19 is not 0");
}

/// Key of (level, coordinates) for the node lookup.
inline std::uint64_t node_key(std::uint32_t level, glm::u32vec3 c) {
    return std::uint64_t{level} << 48 | std::uint64_t{c.z} << 32 | std::uint64_t{c.y} << 16 | c.x;
}

/// The fields of one record that need no other record: reserved bits, level, coordinates, the
/// child mask against the level below, the range, the brick index and state.
inline void validate_record(std::span<const std::uint32_t> w, const shared::SylvaOctHeader& h, std::size_t n) {
    using namespace sylva::shared;
    const std::uint32_t* r = &w[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n];
    if ((r[1] & ~0xF1FFFu) != 0u || (r[3] >> 16) != 0u || r[13] != 0u || r[14] != 0u || r[15] != 0u)
        invalid(node_text(n) + " has reserved bits set");
    std::uint32_t level = sylva_oct_level(r[1]), mask = sylva_oct_child_mask(r[1]);
    if (level >= h.levels) invalid(node_text(n) + " is at level " + std::to_string(level) + " of " + std::to_string(h.levels));
    glm::u32vec3 c(r[2] & 0xFFFFu, r[2] >> 16, r[3]);
    std::uint32_t width = sylva_oct_width(h, level);
    for (int a = 0; a < 3; ++a)
        if (std::uint64_t{c[a]} * width >= h.dims[a])
            invalid(node_text(n) + " (level " + std::to_string(level) + ") starts outside the volume along axis " +
                    std::to_string(a));
    if (n == 0 && (level != 0u || c != glm::u32vec3(0u))) invalid("node 0 is not the root (level 0 at the origin)");
    if ((r[1] & SYLVA_OCT_CUT_LEAF) != 0u && (r[1] & SYLVA_OCT_CUT_BELOW) != 0u)
        invalid(node_text(n) + " is marked both a leaf of the cut and below it");
    if (n == 0 && (r[1] & SYLVA_OCT_CUT_BELOW) != 0u) invalid("the root is marked below the cut");
    if ((mask == 0u) != (r[0] == SYLVA_OCT_NONE))
        invalid(node_text(n) + ": its first child and its child mask disagree about it being a leaf");
    if (mask != 0u && level + 1 >= h.levels) invalid(node_text(n) + " has children below the last level");
    if (mask != 0u && std::uint64_t{r[0]} + std::popcount(mask) > h.node_count)
        invalid(node_text(n) + "'s children " + std::to_string(r[0]) + " .. are out of range (" +
                std::to_string(h.node_count) + " nodes)");
    float lo = std::bit_cast<float>(r[10]), hi = std::bit_cast<float>(r[11]);
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo <= hi)) invalid(node_text(n) + " has a bad range (not finite, or min > max)");
    std::uint32_t state = sylva_oct_brick_state(r[1]);
    if (state > SYLVA_OCT_BRICK_RESIDENT) invalid(node_text(n) + " has brick state 3");
    if (r[12] == SYLVA_OCT_NONE ? state != SYLVA_OCT_BRICK_ABSENT : r[12] >= h.brick_count)
        invalid(node_text(n) + "'s brick index " + std::to_string(r[12]) + " is out of range or disagrees with its state");
}

/// Children: each child one level down at 2 c + octant, every node but the root the child of
/// exactly one node (with levels increasing along children, that makes the nodes one tree).
inline void validate_children(std::span<const std::uint32_t> w, const shared::SylvaOctHeader& h) {
    using namespace sylva::shared;
    Words buf{w.data(), w.size()};
    std::vector<std::uint8_t> parents(h.node_count, 0);
    for (std::uint32_t n = 0; n < h.node_count; ++n) {
        std::uint32_t flags = sylva_oct_flags(buf, n), mask = sylva_oct_child_mask(flags);
        glm::u32vec3 c = sylva_oct_coord(buf, n);
        for (std::uint32_t o = 0; o < 8; ++o) {
            if (((mask >> o) & 1u) == 0u) continue;
            std::uint32_t k = sylva_oct_child(sylva_oct_first_child(buf, n), mask, o);
            glm::u32vec3 want = c * 2u + glm::u32vec3(o & 1u, (o >> 1) & 1u, o >> 2);
            if (sylva_oct_level(sylva_oct_flags(buf, k)) != sylva_oct_level(flags) + 1 || sylva_oct_coord(buf, k) != want)
                invalid(node_text(n) + "'s child octant " + std::to_string(o) + " (" + node_text(k) +
                        ") is not one level down at twice the coordinates plus the octant");
            bool below = (flags & (SYLVA_OCT_CUT_LEAF | SYLVA_OCT_CUT_BELOW)) != 0u;
            if (below != ((sylva_oct_flags(buf, k) & SYLVA_OCT_CUT_BELOW) != 0u))
                invalid(node_text(k) + " is " + (below ? "not " : "") + "marked below the cut, but its parent " +
                        node_text(n) + (below ? " is a cut leaf or below the cut" : " is inside the working set"));
            if (k == 0 || parents[k]++ != 0) invalid(node_text(k) + " is the child of more than one node (or the root is a child)");
        }
    }
    for (std::uint32_t n = 1; n < h.node_count; ++n)
        if (parents[n] == 0) invalid(node_text(n) + " is no node's child (unreachable)");
}

/// The neighbour pointer node n should hold across `face`, from the (level, coords) lookup.
inline std::uint32_t expected_neighbour(const std::unordered_map<std::uint64_t, std::uint32_t>& at,
                                        const shared::SylvaOctHeader& h, std::uint32_t level, glm::u32vec3 c,
                                        std::uint32_t face) {
    std::uint32_t a = face / 2, width = shared::sylva_oct_width(h, level);
    if ((face & 1u) == 0u ? c[a] == 0u : std::uint64_t{c[a] + 1u} * width >= h.dims[a]) return SYLVA_OCT_NONE;
    c[a] = (face & 1u) ? c[a] + 1u : c[a] - 1u;
    for (std::uint32_t l = level + 1; l-- > 0;) {
        auto it = at.find(node_key(l, c >> (level - l)));
        if (it != at.end()) return it->second;
    }
    return SYLVA_OCT_NONE;
}

/// Every neighbour pointer against the one the nodes' levels and coordinates imply.
inline void validate_neighbours(std::span<const std::uint32_t> w, const shared::SylvaOctHeader& h) {
    using namespace sylva::shared;
    Words buf{w.data(), w.size()};
    std::unordered_map<std::uint64_t, std::uint32_t> at;
    at.reserve(h.node_count);
    for (std::uint32_t n = 0; n < h.node_count; ++n)
        at.emplace(node_key(sylva_oct_level(sylva_oct_flags(buf, n)), sylva_oct_coord(buf, n)), n);
    for (std::uint32_t n = 0; n < h.node_count; ++n)
        for (std::uint32_t f = 0; f < 6; ++f) {
            std::uint32_t want = expected_neighbour(at, h, sylva_oct_level(sylva_oct_flags(buf, n)), sylva_oct_coord(buf, n), f);
            std::uint32_t got = sylva_oct_neighbour(buf, n, f);
            if (got != want)
                invalid(node_text(n) + "'s neighbour across face " + std::to_string(f) + " is " +
                        (got == SYLVA_OCT_NONE ? std::string("none") : std::to_string(got)) + ", the node whose box touches " +
                        "that face is " + (want == SYLVA_OCT_NONE ? std::string("none") : std::to_string(want)));
        }
}

}  // namespace detail

/// Checks an index (`words`) and its brick buffer (`bricks`) against the layout of
/// sylva/shared/octree_layout.h: every header field; per node the reserved bits, level,
/// coordinates, range, brick index and state, cut bits (never both; the children of a cut leaf
/// or of a node below the cut, and only they, below the cut); children in range, one level down at the right
/// coordinates, every node but the root the child of exactly one node (so no cycles and nothing
/// unreachable); every neighbour pointer equal to the node whose box touches that face (same
/// level, else the deepest coarser one, none outside the volume); every brick sample finite.
/// Throws sylva::Error naming the first problem.
inline void validate(std::span<const std::uint32_t> words, std::span<const std::uint32_t> bricks) {
    detail::validate_header(words, bricks.size());
    shared::Words buf{words.data(), words.size()};
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(buf, static_cast<std::uint32_t>(words.size()),
                                                             static_cast<std::uint32_t>(bricks.size()));
    if (h.valid == 0u) detail::invalid("the shared header reader refuses the encoding");
    for (std::size_t n = 0; n < h.node_count; ++n) detail::validate_record(words, h, n);
    detail::validate_children(words, h);
    detail::validate_neighbours(words, h);
    if (h.format == SYLVA_OCT_FORMAT_FLOAT32) {  // integer samples are always in range
        for (std::size_t i = 0; i < bricks.size(); ++i)
            if ((bricks[i] & 0x7F800000u) == 0x7F800000u)
                detail::invalid("brick sample " + std::to_string(i) + " is not a finite float");
    }
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_VALIDATE_HPP
