// sylva/bih/wide_build.hpp -- a WideTree (sylva/bih/wide.hpp) straight from the elements: the
// BIH it is collapsed from, built with leaves of the wide tree's leaf size, then the collapse.
//
// Why: the collapse makes every BIH subtree of at most WideConfig::leaf_size elements one wide
// leaf, so a BIH split below that size is work the collapse undoes. Built with leaves of that
// size (and untrimmed, since the collapse refits the boxes), the BIH has the same nodes above
// them (the builder's choice for a node does not depend on the leaf size while it holds more
// elements than that), hence the same wide nodes, leaves and depth; only the order of the
// elements inside a leaf may differ, which changes no answer (first_hit breaks ties by element
// index, all_hits sorts). From 2^15 elements, where the leaves hold 8, that is about half the
// BIH nodes to build and to collapse: measured with a throw-away probe over sylva-bench's
// uniform spheres on two threads (README, "Shared machinery"), the whole build 9.1-9.5 ->
// 7.3-7.7 ms at 10^5 and 100-105 -> 84-86 ms at 10^6; up to 2^15 elements the leaves hold 4
// and nothing changes.
//
//   auto wide = bih::build_wide(std::span<const Sphere>(spheres), bih::WideConfig{}, pool);
//   auto hit = bih::first_hit(wide, ray);
//
// Callers that keep the BIH too (its encoding for the GPU) build it with wide_source_config and
// collapse it themselves; a BIH of other settings collapses into the same queries (wide.hpp).
#ifndef SYLVA_BIH_WIDE_BUILD_HPP
#define SYLVA_BIH_WIDE_BUILD_HPP

#include <cstddef>
#include <span>

#include "sylva/bih/build.hpp"
#include "sylva/bih/wide.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/executor.hpp"

namespace sylva::bih {

/// The BIH settings a WideTree over `elements` elements is collapsed from: leaves of up to
/// wide.leaf_size(elements) elements, not trimmed; everything else Config's defaults.
[[nodiscard]] inline Config wide_source_config(std::size_t elements, const WideConfig& wide = {}) {
    Config c;
    c.max_leaf_elements = wide.leaf_size(elements);
    c.trim_leaves = false;
    c.fill_below = 32;  // 16 and 32 measured (README, "Leaves that fill the packets")
    c.fill_width = 4;   // a packet of four spheres
    return c;
}

/// Builds the BIH of wide_source_config over `elements` on `exec` and collapses it into a
/// WideTree (which keeps its own copy of the elements; the BIH is dropped). Throws
/// sylva::Error as bih::build does (an empty input, too many elements, a box that is not
/// finite or inverted).
template <Intersectable E, Executor X>
WideTree<E> build_wide(std::span<const E> elements, const WideConfig& wide, X& exec) {
    const Tree tree = build(elements, wide_source_config(elements.size(), wide), exec);
    return WideTree<E>(tree, elements, wide, exec);
}

/// The same on the calling thread.
template <Intersectable E>
WideTree<E> build_wide(std::span<const E> elements, const WideConfig& wide = {}) {
    SerialExecutor serial;
    return build_wide(elements, wide, serial);
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_WIDE_BUILD_HPP
