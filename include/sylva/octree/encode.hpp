// sylva/octree/encode.hpp -- writes a bricked octree (sylva/octree/build.hpp) as the flat index
// words of sylva/shared/octree_layout.h. The bricks are already words (Tree::bricks, float32
// bits): they cross to the device as they are, beside the index.
#ifndef SYLVA_OCTREE_ENCODE_HPP
#define SYLVA_OCTREE_ENCODE_HPP

#include <bit>
#include <cstdint>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/octree/build.hpp"
#include "sylva/shared/octree_layout.h"

namespace sylva::octree {

namespace detail {

/// Throws unless `t`'s geometry fits the header fields.
inline void check_encodable(const Tree& t) {
    if (t.levels < 1 || t.levels > kMaxLevels || t.brick_size < 4 || t.brick_size > 64 || t.border < 1 || t.border > 2 ||
        t.dims.x < 1 || t.dims.y < 1 || t.dims.z < 1 || t.dims.x > kMaxDim || t.dims.y > kMaxDim || t.dims.z > kMaxDim)
        throw Error("octree::encode: the tree's extents, brick size, border or levels are out of range");
    if (t.nodes.empty()) throw Error("octree::encode: the tree has no nodes");
    std::size_t total = SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * t.nodes.size();
    if (total > 0xFFFFFFFFu) throw Error("octree::encode: " + std::to_string(total) + " words exceed 2^32 - 1");
    if (t.bricks.size() % t.brick_words() != 0u || t.bricks.size() > 0xFFFFFFFFu)
        throw Error("octree::encode: the brick buffer is not a whole number of bricks below 2^32 words");
}

/// Node record words +0 .. +15 (layout: sylva/shared/octree_layout.h).
inline void write_node(const Tree& t, const Node& n, std::uint32_t state, std::uint32_t* w) {
    if (n.level >= t.levels || n.coord.x > 0xFFFFu || n.coord.y > 0xFFFFu || n.coord.z > 0xFFFFu || n.child_mask > 255u)
        throw Error("octree::encode: a node's level, coordinates or child mask are out of range");
    std::uint32_t brick_state = n.brick == kNone ? SYLVA_OCT_BRICK_ABSENT : state;
    w[0] = n.first_child;
    w[1] = n.child_mask | (n.level << 8) | (brick_state << 16);
    w[2] = n.coord.x | (n.coord.y << 16);
    w[3] = n.coord.z;
    for (std::uint32_t f = 0; f < 6; ++f) w[4 + f] = n.neighbour[f];
    w[10] = std::bit_cast<std::uint32_t>(n.min);
    w[11] = std::bit_cast<std::uint32_t>(n.max);
    w[12] = n.brick;
}

}  // namespace detail

/// The index words of `t` (layout: sylva/shared/octree_layout.h); the brick buffer is
/// t.bricks. Nodes with a brick get brick state `state` (default: resident in the brick buffer
/// bound beside the index, the in-core case), nodes without one SYLVA_OCT_BRICK_ABSENT. Throws
/// sylva::Error when the tree does not fit the layout.
inline std::vector<std::uint32_t> encode(const Tree& t, std::uint32_t state = SYLVA_OCT_BRICK_RESIDENT) {
    detail::check_encodable(t);
    if (state > SYLVA_OCT_BRICK_RESIDENT) throw Error("octree::encode: brick state " + std::to_string(state) + " is not 0, 1 or 2");
    std::vector<std::uint32_t> w(SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * t.nodes.size(), 0u);
    w[0] = SYLVA_OCT_MAGIC;
    w[1] = SYLVA_OCT_VERSION;
    for (int a = 0; a < 3; ++a) {
        w[2 + a] = t.dims[a];
        w[10 + a] = std::bit_cast<std::uint32_t>(t.spacing[a]);
        w[13 + a] = std::bit_cast<std::uint32_t>(1.0f / t.spacing[a]);
        w[16 + a] = std::bit_cast<std::uint32_t>(0.0f);
    }
    w[5] = t.brick_size | (t.border << 8) | (t.levels << 16) | (static_cast<std::uint32_t>(t.format) << 24);
    w[6] = static_cast<std::uint32_t>(t.nodes.size());
    w[7] = static_cast<std::uint32_t>(t.brick_count());
    w[8] = t.brick_words();
    w[9] = static_cast<std::uint32_t>(w.size());
    for (std::size_t n = 0; n < t.nodes.size(); ++n)
        detail::write_node(t, t.nodes[n], state, &w[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n]);
    return w;
}

/// Bytes of the index words of `t`.
inline std::size_t index_bytes(const Tree& t) { return (SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * t.nodes.size()) * 4u; }

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_ENCODE_HPP
