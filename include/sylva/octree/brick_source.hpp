// sylva/octree/brick_source.hpp -- where the bricks of a bricked octree come from when they are
// not all in memory (Gobbetti et al., section 5 and Fig. 2: the out-of-core octree database
// behind the CPU and GPU caches).
//
// A BrickSource holds an octree's index (every node, its min/max and neighbour pointers; small:
// 64 bytes a node) and hands out one brick at a time. The in-core octree is one (TreeBrickSource
// below, for tests and for volumes that fit); the on-disk brick store (sylva/store/) is another.
// The caches and the loader (sylva/octree/residency.hpp) read only through this concept.
//
// The index follows sylva/shared/octree_layout.h with these conventions:
//   - word 7 (brick count M) is the number of bricks in the source, word 8 their words;
//   - node word +12 is the node's brick key in [0, M) (SYLVA_OCT_NONE: the node has no brick);
//   - node word +1 bits 16-17 (brick state) are SYLVA_OCT_BRICK_HOST for nodes with a brick:
//     the brick lives in the source, not in any buffer bound beside this index. A renderer
//     builds a per-frame copy whose word +12 is a slot in its brick buffer and whose state is
//     SYLVA_OCT_BRICK_RESIDENT for the nodes it has loaded.
#ifndef SYLVA_OCTREE_BRICK_SOURCE_HPP
#define SYLVA_OCTREE_BRICK_SOURCE_HPP

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "sylva/octree/build.hpp"
#include "sylva/octree/encode.hpp"

namespace sylva::octree {

/// What reading one brick gave.
enum class BrickStatus : std::uint32_t {
    ok = 0,       ///< `out` holds the brick, bit for bit as octree::build made it
    missing = 1,  ///< the source has no such brick (an unfinished store, a key out of range)
    corrupt = 2,  ///< the brick is there but failed its checksum or did not decode; `out` is
                  ///< unspecified and must not be drawn (draw the parent's brick instead)
};

/// A source of bricks: `index()` is the octree's index words (conventions above) and stays
/// valid and unchanged for the source's lifetime; `read_brick(key, out)` fills `out` (exactly
/// index word 8 words) with brick `key`. read_brick must be safe to call from several threads
/// at once (the loader reads while the renderer asks for the index).
template <class S>
concept BrickSource = requires(const S& s, std::uint32_t key, std::span<std::uint32_t> out) {
    { s.index() } -> std::convertible_to<std::span<const std::uint32_t>>;
    { s.read_brick(key, out) } -> std::same_as<BrickStatus>;
};

/// The in-core octree as a BrickSource: the index encoded with SYLVA_OCT_BRICK_HOST, bricks
/// copied out of the tree. Tests use it as the reference the store must equal.
class TreeBrickSource {
public:
    explicit TreeBrickSource(Tree t) : tree_(std::move(t)), index_(encode(tree_, SYLVA_OCT_BRICK_HOST)) {}

    [[nodiscard]] std::span<const std::uint32_t> index() const { return index_; }
    [[nodiscard]] const Tree& tree() const { return tree_; }

    BrickStatus read_brick(std::uint32_t key, std::span<std::uint32_t> out) const {
        const std::size_t words = tree_.brick_words();
        if (key >= tree_.brick_count() || out.size() != words) return BrickStatus::missing;
        auto first = tree_.bricks.begin() + static_cast<std::ptrdiff_t>(std::size_t{key} * words);
        std::copy(first, first + static_cast<std::ptrdiff_t>(words), out.begin());
        return BrickStatus::ok;
    }

private:
    Tree tree_;
    std::vector<std::uint32_t> index_;
};

static_assert(BrickSource<TreeBrickSource>);

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_BRICK_SOURCE_HPP
