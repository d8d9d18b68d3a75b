// sylva/bih/tree.hpp -- the plain in-memory BIH the builder produces and the encoder reads.
#ifndef SYLVA_BIH_TREE_HPP
#define SYLVA_BIH_TREE_HPP

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "sylva/core/aabb.hpp"
#include "sylva/core/memory.hpp"

namespace sylva::bih {

inline constexpr std::uint32_t kNoChild = std::numeric_limits<std::uint32_t>::max();
inline constexpr std::uint8_t kLeaf = 3;

/// One node. Inner nodes split along `axis` (0..2); leaves have axis == kLeaf.
/// Two children: plane[0] bounds the left child from above, plane[1] the right child from
/// below. An empty child (the +-inf variant) has child index kNoChild and plane -inf / +inf.
/// Single child (`single`, the elaborate variant): child[0] lies within [plane[0], plane[1]].
/// Leaves hold elements order[first .. first + count) of the tree.
/// 20 bytes: a leaf's `first` and `count` share the words of an inner node's `child` (a node
/// is one or the other; a default Node is an empty leaf). The builder's array of these is
/// most of the memory a build touches (about five nodes an element in the default tree).
struct Node {
    float plane[2] = {0.0f, 0.0f};
    union {
        /// Inner nodes (whoever makes a node inner sets both: make_inner). Zero by default: the
        /// words of an empty leaf's range (first 0, count 0). The initializer sits here, not on
        /// the struct's members, which would delete the union's default constructor (clang).
        std::uint32_t child[2] = {0u, 0u};
        struct {
            std::uint32_t first;  ///< leaves: order[first .. first + count)
            std::uint32_t count;
        };
    };
    std::uint8_t axis = kLeaf;
    bool single = false;
    [[nodiscard]] bool leaf() const { return axis == kLeaf; }
    /// Makes the node an inner node split along `a` (0..2), with no children yet.
    void make_inner(int a) {
        axis = static_cast<std::uint8_t>(a);
        child[0] = child[1] = kNoChild;
    }
    /// Number of non-empty children (0 for leaves).
    [[nodiscard]] int children() const {
        if (leaf()) return 0;
        if (single) return 1;
        return (child[0] != kNoChild ? 1 : 0) + (child[1] != kNoChild ? 1 : 0);
    }
};
static_assert(sizeof(Node) == 20, "bih::Node: 2 planes, 2 child-or-range words, axis, single");

/// What the build produced and how long it took (Kinkelin Table 3's rows).
struct BuildStats {
    double build_ms = 0.0;
    std::size_t elements = 0;
    std::size_t nodes = 0;
    std::size_t leaves = 0;
    std::size_t single_child_nodes = 0;  ///< inner nodes with exactly one non-empty child
    std::uint32_t max_depth = 0;         ///< root = 0
    std::uint32_t max_leaf_elements = 0;
    /// Percentage of all nodes that have a single child (Table 3, "% nodes with single child").
    [[nodiscard]] double percent_single_child() const {
        return nodes ? 100.0 * static_cast<double>(single_child_nodes) / static_cast<double>(nodes) : 0.0;
    }
};

/// A built BIH: nodes[0] is the root; `order` is the permutation of element indices the
/// leaves refer to; `bounds` is the box of all elements.
/// Both arrays come from memory::LargeAllocator (huge pages, blocks reused across builds).
struct Tree {
    LargeVector<Node> nodes;
    LargeVector<std::uint32_t> order;
    Aabb bounds;
    BuildStats stats;
};

}  // namespace sylva::bih

#endif  // SYLVA_BIH_TREE_HPP
