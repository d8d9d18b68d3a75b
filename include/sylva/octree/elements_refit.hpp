// sylva/octree/elements_refit.hpp -- moving elements in the element octree (issue 14, item 5):
// refit keeps the lattice and every node (levels, coordinates, children, neighbour pointers) and
// lists each leaf's elements anew from their current boxes, with the builder's overlap test
// (sylva/octree/elements.hpp: an element goes to the octants whose closed halves its padded
// box overlaps). The node cells do not move, so the leaves still tile the lattice and queries
// stay exact; what ages is the split decisions (leaves that now hold many elements are not
// split). Elements that left the lattice cannot be listed: refit then returns false and leaves
// the tree as it was, and the caller rebuilds (rebuild_elements); ElementConfig::refit_margin
// builds a lattice with room for the motion. Refit and rebuild run the builder's level pass
// (sylva/octree/elements.hpp: detail::split_level) over the lists kept in ElementTree::scratch,
// so after the first frame neither allocates.
#ifndef SYLVA_OCTREE_ELEMENTS_REFIT_HPP
#define SYLVA_OCTREE_ELEMENTS_REFIT_HPP

#include <bit>
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
/// built over; `cfg` the configuration it was built with), in the builder's lists kept in
/// et.scratch (no allocation once their capacities suffice). Returns false, with the tree
/// unchanged, when an element's padded box reaches outside the lattice (build with
/// ElementConfig::refit_margin to leave room); throws sylva::Error for another element count, a
/// non-finite box, or nodes not stored as the builder stores them.
template <Bounded E, Executor X>
bool refit_elements(ElementTree& et, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    auto start = std::chrono::steady_clock::now();
    if (elements.size() != et.element_count || et.tree.nodes.empty())
        throw Error("octree::refit_elements: the tree was built over " + std::to_string(et.element_count) +
                    " elements, not " + std::to_string(elements.size()));
    detail::check_config(cfg);
    detail::scene_box(elements, "octree::refit_elements");  // throws naming a non-finite box
    detail::ElementScratch& sc = et.scratch;
    detail::cell_boxes(elements, et, cfg.overlap_pad, sc.boxes, exec);
    vec3 dims(et.tree.dims);
    for (const detail::CellBox& b : sc.boxes)
        if (!(b.lo.x > b.hi.x) && (glm::any(glm::lessThan(b.lo, vec3(0.0f))) || glm::any(glm::greaterThan(b.hi, dims))))
            return false;
    // The nodes must be stored as the builder stores them (level by level, each node's children
    // consecutive where the level order puts them): checked before anything is rewritten.
    std::size_t children = 1;
    for (std::size_t n = 0; n < et.tree.nodes.size(); ++n) {
        const Node& node = et.tree.nodes[n];
        if (node.leaf()) continue;
        if (node.first_child != children || (n > 0 && et.tree.nodes[n - 1].level > node.level))
            throw Error("octree::refit_elements: node " + std::to_string(n) + " is not stored as the builder stores it");
        children += std::size_t(std::popcount(node.child_mask & 0xFFu));
    }
    if (children != et.tree.nodes.size())
        throw Error("octree::refit_elements: the tree's child pointers do not cover its nodes");
    detail::root_list(sc);
    try {
        detail::distribute(et, cfg, true, exec);
    } catch (...) {
        et = ElementTree{};  // the lists were being rewritten: empty, never half listed
        throw;
    }
    et.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return true;
}

/// Builds `et` anew over `elements`: the same tree as build_elements(elements, cfg), into et's
/// own node, reference and scratch arrays (no allocation once their capacities suffice; the
/// scratch is kept for the next frame). Throws as build_elements does: a bad configuration or
/// element leaves `et` as it was; a failure while building (memory, more than 2^32 - 1
/// references) leaves it empty.
template <Bounded E, Executor X>
void rebuild_elements(ElementTree& et, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    detail::build_into(et, elements, cfg, exec);
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
