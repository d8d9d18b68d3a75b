// sylva/kdtree/validate.hpp -- checks an untrusted encoded kd-tree (from disk, from a user) with
// the shared decoder before anything traverses it.
#ifndef SYLVA_KDTREE_VALIDATE_HPP
#define SYLVA_KDTREE_VALIDATE_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/shared/kd_layout.h"

namespace sylva::kdtree {

namespace detail {

/// Header checks beyond the shared reader's: grid size and a finite, positive transform.
inline shared::SylvaKdHeader validate_header(std::span<const std::uint32_t> words) {
    using namespace sylva::shared;
    if (words.size() < SYLVA_KD_HEADER_WORDS) throw Error("kdtree::validate: buffer shorter than the 20-word header");
    if (words[0] != SYLVA_KD_MAGIC) throw Error("kdtree::validate: bad magic (not an encoded kd-tree)");
    if (words[1] != SYLVA_KD_VERSION) throw Error("kdtree::validate: unsupported version " + std::to_string(words[1]));
    Words buf{words.data(), words.size()};
    SylvaKdHeader h = sylva_kd_read_header(buf, static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)));
    if (h.valid == 0u)
        throw Error("kdtree::validate: header inconsistent (node count " + std::to_string(h.node_count) + ", leaf count " +
                    std::to_string(h.leaf_count) + ", depth " + std::to_string(h.max_depth) + ", " +
                    std::to_string(words.size()) + " words)");
    for (int a = 0; a < 3; ++a) {
        if (h.dims[a] == 0 || h.dims[a] > SYLVA_KD_MAX_DIM)
            throw Error("kdtree::validate: grid dimension " + std::to_string(h.dims[a]) + " outside 1 .. 65535");
        bool ok = std::isfinite(h.origin[a]) && std::isfinite(h.spacing[a]) && h.spacing[a] > 0.0f &&
                  std::isfinite(h.inv_spacing[a]) && h.inv_spacing[a] > 0.0f;
        if (!ok) throw Error("kdtree::validate: origin, spacing or 1/spacing not finite and positive");
    }
    if (h.node_count == 0 && (h.leaf_count != 0 || h.max_depth != 0))
        throw Error("kdtree::validate: a tree without nodes must have no leaves and depth 0");
    return h;
}

/// Checks node i's box against the grid and, for a child, against its parent.
inline void check_box(std::span<const std::uint32_t> words, const shared::SylvaKdHeader& h, std::uint32_t i) {
    using namespace sylva::shared;
    Words buf{words.data(), words.size()};
    uvec3 lo = sylva_kd_box_lo(buf, i), hi = sylva_kd_box_hi(buf, i);
    if (!glm::all(glm::lessThan(lo, hi)) || !glm::all(glm::lessThanEqual(hi, h.dims)))
        throw Error("kdtree::validate: node " + std::to_string(i) + " has an empty box or one outside the grid");
}

/// Checks that the children of inner node n lie inside it, on either side of the split.
inline void check_children(std::span<const std::uint32_t> words, std::uint32_t n, std::uint32_t axis,
                           std::uint32_t first) {
    using namespace sylva::shared;
    Words buf{words.data(), words.size()};
    uvec3 plo = sylva_kd_box_lo(buf, n), phi = sylva_kd_box_hi(buf, n);
    for (std::uint32_t c = first; c <= first + 1; ++c) {
        uvec3 lo = sylva_kd_box_lo(buf, c), hi = sylva_kd_box_hi(buf, c);
        if (!glm::all(glm::lessThanEqual(plo, lo)) || !glm::all(glm::lessThanEqual(hi, phi)))
            throw Error("kdtree::validate: child " + std::to_string(c) + " sticks out of its parent " + std::to_string(n));
    }
    if (sylva_kd_box_hi(buf, first)[axis] > sylva_kd_box_lo(buf, first + 1)[axis])
        throw Error("kdtree::validate: the children of node " + std::to_string(n) + " overlap across the split plane");
}

}  // namespace detail

/// Throws sylva::Error naming the first problem: not a kd-tree, a header the buffer cannot
/// hold, a grid or transform out of range, an empty box or one outside the grid or its parent,
/// overlapping children, a child index not after its parent or out of range, a node or leaf
/// index reached twice or never, or a tree deeper than its header says.
inline void validate(std::span<const std::uint32_t> words) {
    using namespace sylva::shared;
    SylvaKdHeader h = detail::validate_header(words);
    Words buf{words.data(), words.size()};
    std::vector<std::uint8_t> seen(h.node_count, 0), leaf_seen(h.leaf_count, 0);
    std::size_t nodes = 0, leaves = 0;
    struct Item { std::uint32_t node, depth; };
    std::vector<Item> stack;
    if (h.node_count) stack.push_back({0u, 0u});
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        std::string where = "node " + std::to_string(it.node);
        if (seen[it.node]) throw Error("kdtree::validate: " + where + " is reached twice (corrupted links)");
        seen[it.node] = 1;
        ++nodes;
        if (it.depth > h.max_depth) throw Error("kdtree::validate: " + where + " is deeper than the header's max depth");
        detail::check_box(words, h, it.node);
        uint meta = sylva_kd_meta(buf, it.node), index = sylva_kd_meta_index(meta);
        if (sylva_kd_meta_type(meta) == SYLVA_KD_LEAF) {
            if (index >= h.leaf_count || leaf_seen[index])
                throw Error("kdtree::validate: leaf " + where + " has a bad or repeated leaf index");
            leaf_seen[index] = 1;
            ++leaves;
            continue;
        }
        if (index <= it.node || std::uint64_t{index} + 1 >= h.node_count)
            throw Error("kdtree::validate: child index out of range at " + where);
        detail::check_children(words, it.node, sylva_kd_meta_type(meta), index);
        stack.push_back({index + 1, it.depth + 1});
        stack.push_back({index, it.depth + 1});
    }
    if (nodes != h.node_count) throw Error("kdtree::validate: some nodes are not reachable from the root");
    if (leaves != h.leaf_count) throw Error("kdtree::validate: some leaf indices belong to no leaf");
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_VALIDATE_HPP
