// sylva/kdtree/tree.hpp -- the plain in-memory empty-space kd-tree the builders produce and the
// encoder reads (Vidal et al. Alg. 1, TreeNode).
//
// Every node holds the tight box of the occupied voxels it contains (a VoxelBox, half-open
// voxel indices). An inner node splits its box at `plane` along `axis`; its two children are
// the tight boxes of the occupied voxels on either side, stored next to each other: the lower
// child (voxels < plane) at first_child, the upper child (voxels >= plane) at first_child + 1.
// Children never overlap, so neither do the leaves, and every occupied voxel lies in exactly
// one leaf: the tree culls only empty space. Nodes are numbered breadth first (root = 0), so
// a child's index is always greater than its parent's.
#ifndef SYLVA_KDTREE_TREE_HPP
#define SYLVA_KDTREE_TREE_HPP

#include <cstddef>
#include <cstdint>
#include <vector>

#include "sylva/core/aabb.hpp"
#include "sylva/volume/occupancy.hpp"

namespace sylva::kdtree {

using volume::VoxelBox;

inline constexpr std::uint32_t kNone = 0xFFFFFFFFu;
inline constexpr std::uint8_t kLeaf = 3;

/// One node: a leaf (axis == kLeaf) or an inner node with two children.
struct Node {
    VoxelBox box;                      ///< tight box of the occupied voxels inside
    std::uint32_t first_child = kNone;  ///< inner: lower child; the upper child follows it
    std::uint32_t leaf = kNone;         ///< leaf: index into Tree::leaves
    std::uint32_t plane = 0;            ///< inner: split plane, a voxel coordinate along `axis`
    std::uint8_t axis = kLeaf;          ///< inner: 0, 1, 2; leaf: kLeaf
    std::uint8_t depth = 0;             ///< root = 0
    [[nodiscard]] bool is_leaf() const { return axis == kLeaf; }
    friend bool operator==(const Node&, const Node&) = default;
};

/// What a build produced (Zellmann et al. Table 1's columns) and how long its phases took.
struct BuildStats {
    std::uint64_t voxels = 0;       ///< voxels of the grid
    std::uint64_t occupied = 0;     ///< occupied voxels (Table 1, "occupancy")
    std::uint64_t leaf_volume = 0;  ///< voxels inside leaves (occupied + empty space kept)
    std::size_t nodes = 0;
    std::size_t leaves = 0;
    std::uint32_t max_depth = 0;  ///< root = 0
    double occupancy_ms = 0.0;    ///< SVT / partial SVT / local-box phase (0 when built elsewhere)
    double split_ms = 0.0;        ///< node-splitting phase

    /// Percentage of occupied voxels.
    [[nodiscard]] double percent_occupied() const {
        return voxels ? 100.0 * static_cast<double>(occupied) / static_cast<double>(voxels) : 0.0;
    }
    /// Percentage of the empty voxels that no leaf holds (Zellmann et al. Table 1, "% culled":
    /// culled / empty); 0 when the grid has no empty voxel.
    [[nodiscard]] double percent_culled() const {
        std::uint64_t empty = voxels - occupied;
        return empty ? 100.0 * static_cast<double>(voxels - leaf_volume) / static_cast<double>(empty) : 0.0;
    }
    /// Percentage of the whole grid that no leaf holds (Vidal et al. Table 1, "space removed").
    [[nodiscard]] double percent_removed() const {
        return voxels ? 100.0 * static_cast<double>(voxels - leaf_volume) / static_cast<double>(voxels) : 0.0;
    }
};

/// A built tree. An all-empty grid gives a tree without nodes (and without leaves).
struct Tree {
    volume::Dims dims{0};
    vec3 spacing{1.0f};
    vec3 origin{0.0f};  ///< world position of the grid corner (voxel (0, 0, 0)'s lower corner)
    std::vector<Node> nodes;
    /// Node index of each leaf, in leaf-index order (breadth first).
    std::vector<std::uint32_t> leaves;
    BuildStats stats;

    /// The voxel box of leaf i.
    [[nodiscard]] const VoxelBox& leaf_box(std::size_t i) const { return nodes[leaves[i]].box; }
    /// A voxel box in world space (cell convention, see volume/grid.hpp).
    [[nodiscard]] Aabb world(const VoxelBox& b) const { return b.world(spacing, origin); }
};

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_TREE_HPP
