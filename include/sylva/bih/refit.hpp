// sylva/bih/refit.hpp -- moving elements (issue 14, item 5): refit a BIH to new element boxes
// (same nodes, same leaf order, new planes) and rebuild it into the same tree.
//
// Refit: a node's planes bound its children's subtrees (Kinkelin 3.1), so after the elements
// moved, the planes are recomputed bottom up from the leaves' new element boxes: a two-child
// node gets plane[0] = the lower child's box hi and plane[1] = the upper child's box lo along
// its axis (the children may now overlap, which the BIH allows); a single-child node
// (EmptyChildren::TrimBoth) gets its child's [lo, hi]; the +-inf variant keeps its infinite
// plane and bounds the child it has. Queries stay exact whatever the motion; only the tree's
// quality ages (children overlap more, leaves are no longer trimmed to their element), so a
// renderer refits for a few frames and rebuilds when the traversal slows down. The nodes are in
// pre-order (children after their parent), so one backward pass sees every child before its
// parent; the leaves' boxes are computed in parallel first.
//
// Rebuild: bih::rebuild builds anew into an existing tree, reusing its order array; the
// builder's scratch and node chunks come from memory::LargeAllocator, which keeps freed blocks
// for the next build of the same size (sylva/core/memory.hpp), so a per-frame rebuild does not
// go back to the system for memory.
#ifndef SYLVA_BIH_REFIT_HPP
#define SYLVA_BIH_REFIT_HPP

#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/bih/build.hpp"
#include "sylva/bih/tree.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"

namespace sylva::bih {

/// Recomputes the planes of `t` (built over elements of the same count, whose boxes have moved)
/// from the current boxes of `elements`; t.bounds becomes their box. Returns the time taken in
/// ms. Throws sylva::Error when the count differs from the tree's or an element's box is not
/// finite or inverted (the message names it); the tree is then unchanged.
template <Bounded E, Executor X>
double refit(Tree& t, std::span<const E> elements, X& exec) {
    auto start = std::chrono::steady_clock::now();
    if (elements.size() != t.order.size() || t.nodes.empty())
        throw Error("bih::refit: the tree was built over " + std::to_string(t.order.size()) + " elements, not " +
                    std::to_string(elements.size()));
    const std::size_t n = t.nodes.size();
    std::vector<Aabb> box(n);
    std::vector<std::size_t> bad_in(exec.concurrency() * 4 + 1, elements.size());
    exec.parallel_for(0, n, 4096, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i) {
            const Node& node = t.nodes[i];
            if (!node.leaf()) continue;
            Aabb u;
            for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
                std::uint32_t e = t.order[k];
                if (e >= elements.size()) throw Error("bih::refit: the tree's order names element " + std::to_string(e));
                Aabb b = bounds_of(elements[e]);
                if (!b.finite() || b.empty()) throw Error("bih::refit: element " + std::to_string(e) + "'s box is not finite or inverted");
                u.extend(b);
            }
            box[i] = u;
        }
    });
    for (std::size_t i = n; i-- > 0;) {
        const Node& node = t.nodes[i];
        if (node.leaf()) continue;
        Aabb u;
        for (std::uint32_t c : node.child) {
            if (c == kNoChild) continue;
            if (c <= i || c >= n) throw Error("bih::refit: node " + std::to_string(i) + "'s child does not follow it");
            u.extend(box[c]);
        }
        box[i] = u;
    }
    for (std::size_t i = 0; i < n; ++i) {  // planes written only once every box is known
        Node& node = t.nodes[i];
        if (node.leaf()) continue;
        int a = node.axis;
        if (node.single) {
            node.plane[0] = box[node.child[0]].lo[a];
            node.plane[1] = box[node.child[0]].hi[a];
            continue;
        }
        if (node.child[0] != kNoChild) node.plane[0] = box[node.child[0]].hi[a];
        if (node.child[1] != kNoChild) node.plane[1] = box[node.child[1]].lo[a];
    }
    t.bounds = box[0];
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

/// Refit on the calling thread.
template <Bounded E>
double refit(Tree& t, std::span<const E> elements) {
    SerialExecutor serial;
    return refit(t, elements, serial);
}

/// Builds `t` anew over `elements` (the same result as bih::build, node for node), reusing its
/// order array. Throws as bih::build.
template <Bounded E, Executor X>
void rebuild(Tree& t, std::span<const E> elements, const Config& config, X& exec) {
    detail::build_into(t, elements, config, exec);
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_REFIT_HPP
