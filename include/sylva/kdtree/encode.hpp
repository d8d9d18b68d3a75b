// sylva/kdtree/encode.hpp -- turns a built kd-tree into the flat word array of
// sylva/shared/kd_layout.h: a 20-word header and four words a node, in the tree's own
// breadth-first order (the children of a node are adjacent, lower first).
#ifndef SYLVA_KDTREE_ENCODE_HPP
#define SYLVA_KDTREE_ENCODE_HPP

#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/kdtree/tree.hpp"
#include "sylva/shared/kd_layout.h"

namespace sylva::kdtree {

namespace detail {

inline std::uint32_t float_bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

/// Throws unless the grid fits 16-bit coordinates and its transform is finite and positive.
inline void check_encodable(const Tree& t) {
    for (int a = 0; a < 3; ++a) {
        if (t.dims[a] == 0 || t.dims[a] > SYLVA_KD_MAX_DIM)
            throw Error("kdtree::encode: grid dimension " + std::to_string(t.dims[a]) + " is outside 1 .. 65535");
        if (!(std::isfinite(t.spacing[a]) && t.spacing[a] > 0.0f) || !std::isfinite(1.0f / t.spacing[a]))
            throw Error("kdtree::encode: spacing must be finite and positive");
        if (!std::isfinite(t.origin[a])) throw Error("kdtree::encode: origin must be finite");
    }
    if (t.nodes.size() > SYLVA_KD_MAX_INDEX || t.leaves.size() > SYLVA_KD_MAX_INDEX)
        throw Error("kdtree::encode: " + std::to_string(t.nodes.size()) + " nodes exceed the 30-bit index");
    if (t.stats.max_depth > SYLVA_KD_DEPTH_CAP) throw Error("kdtree::encode: tree deeper than the depth cap");
}

inline void write_header(std::vector<std::uint32_t>& w, const Tree& t) {
    w[0] = SYLVA_KD_MAGIC;
    w[1] = SYLVA_KD_VERSION;
    w[2] = 0;
    w[3] = static_cast<std::uint32_t>(t.nodes.size());
    w[4] = t.stats.max_depth;
    w[5] = static_cast<std::uint32_t>(t.leaves.size());
    for (int a = 0; a < 3; ++a) {
        w[6 + a] = t.dims[a];
        w[10 + a] = float_bits(t.origin[a]);
        w[13 + a] = float_bits(t.spacing[a]);
        w[16 + a] = float_bits(1.0f / t.spacing[a]);
    }
}

/// Words 0-3 of node i (see kd_layout.h); throws when the tree breaks the layout's rules.
inline void write_node(std::uint32_t* at, const Tree& t, std::size_t i) {
    const Node& n = t.nodes[i];
    for (int a = 0; a < 3; ++a) {
        if (n.box.empty() || n.box.hi[a] > t.dims[a])
            throw Error("kdtree::encode: node " + std::to_string(i) + " has an empty box or one outside the grid");
        at[a] = n.box.lo[a] | (n.box.hi[a] << 16);
    }
    if (n.is_leaf()) {
        if (n.leaf >= t.leaves.size()) throw Error("kdtree::encode: leaf " + std::to_string(i) + " has no leaf index");
        at[3] = SYLVA_KD_LEAF | (n.leaf << 2);
        return;
    }
    if (n.axis > 2 || n.first_child <= i || std::size_t{n.first_child} + 1 >= t.nodes.size())
        throw Error("kdtree::encode: inner node " + std::to_string(i) + " has bad children");
    at[3] = n.axis | (n.first_child << 2);
}

}  // namespace detail

/// Encodes `tree` (see sylva/shared/kd_layout.h). Throws sylva::Error when a grid dimension is
/// over 65535 (16-bit box coordinates), the spacing is not finite and positive, or the tree
/// breaks the layout (children before their parent, empty boxes, too many nodes).
inline std::vector<std::uint32_t> encode(const Tree& tree) {
    detail::check_encodable(tree);
    std::vector<std::uint32_t> w(SYLVA_KD_HEADER_WORDS + tree.nodes.size() * SYLVA_KD_NODE_WORDS, 0u);
    detail::write_header(w, tree);
    for (std::size_t i = 0; i < tree.nodes.size(); ++i)
        detail::write_node(&w[SYLVA_KD_HEADER_WORDS + i * SYLVA_KD_NODE_WORDS], tree, i);
    return w;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_ENCODE_HPP
