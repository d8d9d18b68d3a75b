// sylva/kdtree/subvolumes.hpp -- the leaf list and Vidal et al.'s subvolume list under a budget
// (section 2.2): boxes for renderers that iterate a short list instead of traversing the tree.
//
// Every list here is a set of node boxes of disjoint subtrees, so the boxes never overlap and
// together hold every occupied voxel. Boxes are integer voxel ranges: where two of them touch,
// the shared face is the same integer plane in both, and in world space the same floats
// (origin + plane * spacing), so adjacent subvolumes meet without a gap or an overlap (the
// consistency of common faces that Vidal et al. section 2.2 asks for).
#ifndef SYLVA_KDTREE_SUBVOLUMES_HPP
#define SYLVA_KDTREE_SUBVOLUMES_HPP

#include <algorithm>
#include <cstdint>
#include <vector>

#include "sylva/core/aabb.hpp"
#include "sylva/core/error.hpp"
#include "sylva/kdtree/tree.hpp"

namespace sylva::kdtree {

/// The voxel boxes of the leaves, in leaf-index order (the order the iterator reports).
inline std::vector<VoxelBox> leaf_boxes(const Tree& t) {
    std::vector<VoxelBox> out;
    out.reserve(t.leaves.size());
    for (std::uint32_t n : t.leaves) out.push_back(t.nodes[n].box);
    return out;
}

/// Voxel boxes in world space (cell convention).
inline std::vector<Aabb> world_boxes(const Tree& t, const std::vector<VoxelBox>& boxes) {
    std::vector<Aabb> out;
    out.reserve(boxes.size());
    for (const VoxelBox& b : boxes) out.push_back(t.world(b));
    return out;
}

/// Number of leaves under every node.
inline std::vector<std::uint32_t> leaves_below(const Tree& t) {
    std::vector<std::uint32_t> n(t.nodes.size(), 1u);
    for (std::size_t i = t.nodes.size(); i-- > 0;)  // children follow their parents
        if (!t.nodes[i].is_leaf()) n[i] = n[t.nodes[i].first_child] + n[t.nodes[i].first_child + 1];
    return n;
}

/// Nodes of at most `budget` subvolumes (Vidal section 2.2): a node with budget 1, or a leaf,
/// is one subvolume; a node with at most `budget` leaves below gives all of them; otherwise
/// the budget is shared in proportion to the children's leaf counts, the lower child getting
/// ceil(M * M_l / (M_l + M_r)) (at most M - 1) and the upper child the rest, so the list never
/// exceeds the budget (the paper's two ceilings can). Lower subtrees come first. Throws
/// sylva::Error for a budget of 0.
inline std::vector<std::uint32_t> subvolume_nodes(const Tree& t, std::uint32_t budget) {
    if (budget == 0) throw Error("kdtree::subvolume_nodes: the budget must be at least 1");
    std::vector<std::uint32_t> out;
    if (t.nodes.empty()) return out;
    std::vector<std::uint32_t> below = leaves_below(t);
    struct Item { std::uint32_t node, budget; };
    std::vector<Item> stack{{0u, budget}};
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        const Node& n = t.nodes[it.node];
        if (n.is_leaf() || it.budget == 1 || below[it.node] <= it.budget) {
            if (n.is_leaf() || it.budget == 1) {
                out.push_back(it.node);
            } else {  // every leaf below, lower subtrees first
                stack.push_back({n.first_child + 1, below[n.first_child + 1]});
                stack.push_back({n.first_child, below[n.first_child]});
            }
            continue;
        }
        std::uint64_t ml = below[n.first_child], mr = below[n.first_child + 1];
        auto lower = static_cast<std::uint32_t>((std::uint64_t{it.budget} * ml + ml + mr - 1) / (ml + mr));
        lower = std::clamp<std::uint32_t>(lower, 1u, it.budget - 1);
        stack.push_back({n.first_child + 1, it.budget - lower});
        stack.push_back({n.first_child, lower});
    }
    return out;
}

/// The voxel boxes of subvolume_nodes(t, budget).
inline std::vector<VoxelBox> subvolumes(const Tree& t, std::uint32_t budget) {
    std::vector<VoxelBox> out;
    for (std::uint32_t n : subvolume_nodes(t, budget)) out.push_back(t.nodes[n].box);
    return out;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_SUBVOLUMES_HPP
