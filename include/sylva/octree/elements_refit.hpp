// sylva/octree/elements_refit.hpp -- moving elements in the element octree (issue 14, item 5):
// refit keeps the lattice and every node (levels, coordinates, children, neighbour pointers) and
// lists each leaf's elements anew from their current boxes, with the builder's overlap test
// (sylva/octree/elements.hpp: an element goes to the octants whose closed halves its padded
// box overlaps). The node cells do not move, so the leaves still tile the lattice and queries
// stay exact; what ages is the split decisions (leaves that now hold many elements are not
// split). Elements that left the lattice cannot be listed: refit then returns false and leaves
// the tree as it was, and the caller rebuilds (rebuild_elements).
#ifndef SYLVA_OCTREE_ELEMENTS_REFIT_HPP
#define SYLVA_OCTREE_ELEMENTS_REFIT_HPP

#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/octree/elements.hpp"

namespace sylva::octree {

/// Lists the leaves of `et` anew from the current boxes of `elements` (the same count it was
/// built over; `cfg` the configuration it was built with). Returns false, with `et` unchanged,
/// when an element's padded box reaches outside the lattice; throws sylva::Error for another
/// element count or a non-finite box.
template <Bounded E, Executor X>
bool refit_elements(ElementTree& et, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    auto start = std::chrono::steady_clock::now();
    if (elements.size() != et.element_count || et.tree.nodes.empty())
        throw Error("octree::refit_elements: the tree was built over " + std::to_string(et.element_count) +
                    " elements, not " + std::to_string(elements.size()));
    detail::scene_box(elements);  // throws naming a non-finite box
    Tree& t = et.tree;
    std::vector<detail::CellBox> boxes = detail::cell_boxes(elements, et, cfg.overlap_pad, exec);
    vec3 dims(t.dims);
    std::vector<std::uint32_t> all;
    all.reserve(elements.size());
    for (std::uint32_t i = 0; i < elements.size(); ++i) {
        const detail::CellBox& b = boxes[i];
        if (b.lo.x > b.hi.x) continue;
        if (glm::any(glm::lessThan(b.lo, vec3(0.0f))) || glm::any(glm::greaterThan(b.hi, dims))) return false;
        all.push_back(i);
    }
    // Top down, level by level (a level's nodes are contiguous and its children follow it).
    std::vector<std::vector<std::uint32_t>> lists(t.nodes.size());
    lists[0] = std::move(all);
    std::size_t begin = 0;
    while (begin < t.nodes.size()) {
        std::size_t end = begin;
        while (end < t.nodes.size() && t.nodes[end].level == t.nodes[begin].level) ++end;
        exec.parallel_for(begin, end, 1, [&](std::size_t n0, std::size_t n1) {
            for (std::size_t n = n0; n < n1; ++n) {
                const Node& node = t.nodes[n];
                if (node.leaf()) continue;
                std::uint32_t w = t.width(node.level + 1);
                glm::u32vec3 mid = (2u * node.coord + 1u) * w;
                glm::bvec3 upper = glm::lessThan(mid, t.dims);
                vec3 fmid(mid);
                std::uint32_t slot[8], k = node.first_child;
                for (std::uint32_t o = 0; o < 8; ++o) slot[o] = ((node.child_mask >> o) & 1u) ? k++ : kNone;
                for (std::uint32_t e : lists[n]) {
                    const detail::CellBox& b = boxes[e];
                    std::uint32_t sides[3];
                    for (int a = 0; a < 3; ++a)
                        sides[a] = (b.lo[a] <= fmid[a] ? 1u : 0u) | (upper[a] && b.hi[a] >= fmid[a] ? 2u : 0u);
                    for (std::uint32_t o = 0; o < 8; ++o)
                        if (slot[o] != kNone && ((sides[0] >> (o & 1u)) & 1u) && ((sides[1] >> ((o >> 1) & 1u)) & 1u) &&
                            ((sides[2] >> ((o >> 2) & 1u)) & 1u))
                            lists[slot[o]].push_back(e);
                }
                std::vector<std::uint32_t>().swap(lists[n]);
            }
        });
        begin = end;
    }
    et.refs.clear();
    et.leaf_first.assign(1, 0u);
    for (std::size_t n = 0; n < t.nodes.size(); ++n) {
        Node& node = t.nodes[n];
        if (!node.leaf()) continue;
        node.brick = kNone;
        if (lists[n].empty()) continue;
        node.brick = std::uint32_t(et.leaf_first.size() - 1);
        et.refs.insert(et.refs.end(), lists[n].begin(), lists[n].end());
        et.leaf_first.push_back(std::uint32_t(et.refs.size()));
    }
    et.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return true;
}

/// Builds `et` anew over `elements` (the same tree as build_elements). The element octree's
/// builder keeps a list per pending node and its levels; it reuses no memory of `et` (the
/// kd-tree's and the BIH's rebuilds do), which sylva-bench's refit/rebuild rows show.
template <Bounded E, Executor X>
void rebuild_elements(ElementTree& et, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    et = build_elements(elements, cfg, exec);
}

/// Refit when every element is still inside the lattice, else rebuild; true when it refitted.
template <Bounded E, Executor X>
bool update_elements(ElementTree& et, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    if (refit_elements(et, elements, cfg, exec)) return true;
    rebuild_elements(et, elements, cfg, exec);
    return false;
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_ELEMENTS_REFIT_HPP
