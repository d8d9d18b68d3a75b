// sylva/kdtree/encode.hpp -- turns a built kd-tree into the flat word array of
// sylva/shared/kd_layout.h: a 20-word header and four words a node, in the tree's own
// breadth-first order (the children of a node are adjacent, lower first).
#ifndef SYLVA_KDTREE_ENCODE_HPP
#define SYLVA_KDTREE_ENCODE_HPP

#include <algorithm>
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
}

/// Checks that the nodes form one tree rooted at node 0 (children in range and after their
/// parent, every node reached exactly once, axes 0..2 or kLeaf, every leaf's index used once and
/// matching Tree::leaves, depth within SYLVA_KD_DEPTH_CAP) and returns its depth (root = 0),
/// measured from the nodes, never read from Tree::stats. Throws sylva::Error naming the node.
inline std::uint32_t check_structure(const Tree& t) {
    const std::size_t n = t.nodes.size();
    if (n == 0) {
        if (!t.leaves.empty()) throw Error("kdtree::encode: a tree without nodes lists leaves");
        return 0;
    }
    std::vector<std::uint8_t> seen(n, 0), leaf_seen(t.leaves.size(), 0);
    struct Item { std::uint32_t node, depth; };
    std::vector<Item> stack{{0u, 0u}};
    seen[0] = 1;
    std::uint32_t depth = 0;
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        const Node& node = t.nodes[it.node];
        std::string where = "node " + std::to_string(it.node);
        if (it.depth > SYLVA_KD_DEPTH_CAP)
            throw Error("kdtree::encode: " + where + " lies at depth " + std::to_string(it.depth) + ", over the cap of " +
                        std::to_string(SYLVA_KD_DEPTH_CAP));
        depth = std::max(depth, it.depth);
        if (node.is_leaf()) {
            if (node.leaf >= t.leaves.size() || leaf_seen[node.leaf] || t.leaves[node.leaf] != it.node)
                throw Error("kdtree::encode: leaf " + where + " has leaf index " + std::to_string(node.leaf) +
                            ", which is out of range, repeated or not this node's entry in Tree::leaves");
            leaf_seen[node.leaf] = 1;
            continue;
        }
        if (node.axis > 2) throw Error("kdtree::encode: " + where + " has axis " + std::to_string(node.axis));
        if (node.first_child <= it.node || std::size_t{node.first_child} + 1 >= n)
            throw Error("kdtree::encode: inner " + where + " has children " + std::to_string(node.first_child) +
                        " (out of range or not after their parent)");
        for (std::uint32_t c = node.first_child; c <= node.first_child + 1; ++c) {
            if (seen[c])
                throw Error("kdtree::encode: node " + std::to_string(c) + " is reached twice (from " + where +
                            "): a shared subtree");
            seen[c] = 1;
            stack.push_back({c, it.depth + 1});
        }
    }
    for (std::size_t i = 0; i < n; ++i)
        if (!seen[i]) throw Error("kdtree::encode: node " + std::to_string(i) + " is not reached from the root");
    for (std::size_t i = 0; i < leaf_seen.size(); ++i)
        if (!leaf_seen[i]) throw Error("kdtree::encode: leaf index " + std::to_string(i) + " belongs to no leaf");
    return depth;
}

inline void write_header(std::vector<std::uint32_t>& w, const Tree& t, std::uint32_t depth) {
    w[0] = SYLVA_KD_MAGIC;
    w[1] = SYLVA_KD_VERSION;
    w[2] = 0;
    w[3] = static_cast<std::uint32_t>(t.nodes.size());
    w[4] = depth;
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
        at[3] = shared::sylva_kd_meta_make(SYLVA_KD_LEAF, n.leaf);
        return;
    }
    if (n.axis > 2 || n.first_child <= i || std::size_t{n.first_child} + 1 >= t.nodes.size())
        throw Error("kdtree::encode: inner node " + std::to_string(i) + " has bad children");
    at[3] = shared::sylva_kd_meta_make(n.axis, n.first_child);
}

}  // namespace detail

/// Encodes `tree` (see sylva/shared/kd_layout.h). Throws sylva::Error when a grid dimension is
/// over 65535 (16-bit box coordinates), the spacing is not finite and positive, or the tree
/// breaks the layout (children before their parent, empty boxes, too many nodes). The tree is
/// not trusted: its links must form one tree rooted at node 0 (detail::check_structure), and
/// the header's depth is measured from the nodes, not read from Tree::stats.
inline std::vector<std::uint32_t> encode(const Tree& tree) {
    detail::check_encodable(tree);
    const std::uint32_t depth = detail::check_structure(tree);
    std::vector<std::uint32_t> w(SYLVA_KD_HEADER_WORDS + tree.nodes.size() * SYLVA_KD_NODE_WORDS, 0u);
    detail::write_header(w, tree, depth);
    for (std::size_t i = 0; i < tree.nodes.size(); ++i)
        detail::write_node(&w[SYLVA_KD_HEADER_WORDS + i * SYLVA_KD_NODE_WORDS], tree, i);
    return w;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_ENCODE_HPP
