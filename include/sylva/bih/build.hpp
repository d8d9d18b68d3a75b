// sylva/bih/build.hpp -- Bounding Interval Hierarchy construction (Kinkelin sections 3.1, 5.1;
// Waechter and Keller 2006), generic over any range of bounded elements.
//
// Each node is split in the middle of its box's longest axis; elements go left when the centre
// of their box is on or left of the plane, right otherwise (an in-place partition, here of
// per-element records that carry box and index); the two bounding planes are the maximum of
// the left boxes and the minimum of the right boxes, computed during the partition. Empty
// children follow Config::empty_children.
// Where the midpoint makes no progress (every element on one side and no plane trims the box),
// the builder trims the axis with the most slack instead, and where the box is already tight,
// splits at the middle of the element centres; elements whose centres all coincide stay in one
// leaf. Every path ends at Config::max_depth (at most SYLVA_BIH_DEPTH_CAP), so the build always
// terminates and the iterator's stack can never overflow.
//
// Parallel builds hand subtrees to executor tasks that write their nodes into chunks of their
// own: the serial ones (nearly all nodes) into regions of the tree's node array, the others into
// an arena; one pass then moves the chunks into pre-order in that array (RegionRate, assemble).
// The tree (nodes, planes, order, statistics) is the same whatever the executor, bit for bit.
#ifndef SYLVA_BIH_BUILD_HPP
#define SYLVA_BIH_BUILD_HPP

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/bih/tree.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/shared/bih_layout.h"

namespace sylva::bih {

/// How a node with one empty child is stored (Kinkelin section 3.1).
enum class EmptyChildren {
    Infinite,  ///< the empty child's plane is -inf / +inf; one side of the child is trimmed
    TrimBoth,  ///< "elaborate": both planes bound the single child, trimming two sides per level
};

/// Builder settings. Defaults follow Kinkelin section 5.1 (one element per leaf, leaf boxes
/// trimmed until they equal the element's box).
struct Config {
    /// A node with at most this many elements may become a leaf (section 5.1: 1).
    std::uint32_t max_leaf_elements = 1;
    /// Keep splitting such a node until its box equals the box of its elements, so the leaf box
    /// can stand in for the element (section 3.3: "implicit AABB").
    bool trim_leaves = true;
    /// Representation of nodes with one empty child (section 3.1).
    EmptyChildren empty_children = EmptyChildren::TrimBoth;
    /// Nodes with more than max_leaf_elements and at most this many elements (0: none) split
    /// at an object median rounded up to a multiple of fill_width along their centres' longest
    /// axis, instead of at the middle of their box, so that the leaves below come in full
    /// groups of fill_width. For trees whose leaves are tested fill_width elements at a time
    /// (bih::wide_source_config: a WideTree's packets of four spheres, which the midpoint split
    /// left 2.8 of 4 full at 10^4 uniform spheres). At most 64: larger values act as 64.
    std::uint32_t fill_below = 0;
    /// See fill_below.
    std::uint32_t fill_width = 4;
    /// Nodes at this depth become leaves whatever they hold; clamped to SYLVA_BIH_DEPTH_CAP.
    std::uint32_t max_depth = SYLVA_BIH_DEPTH_CAP;
    /// Subtrees with more elements than this are built as parallel tasks on the executor; does
    /// not change the tree. 1024: clustered inputs split unevenly, and with 4096 a 10^4-element
    /// clustered build often left one of two threads idle (median 1.4-2.2 ms, against 1.26-1.29
    /// with 1024; uniform 1.16-1.18 against 1.21-1.24 ms; 10^5 uniform 16.0 against 13.0 ms).
    std::size_t parallel_threshold = 1024;
    /// Called with the fraction of elements placed in leaves (0..1), possibly from several threads.
    std::function<void(double)> on_progress;

    /// Settings for trees that serve element queries over their encoding (bih::first_hit,
    /// bih::all_hits with LeafRecords) rather than trimmed-leaf rendering: up to 32 elements a
    /// leaf, leaves not trimmed (Kinkelin 5.1's one-element trimmed leaves cost ~5 nodes an
    /// element, and a query visits many of them per leaf). Measured with sylva-bench's spheres
    /// and rays, 16 and 32 were within 5 % of the best of 2..64 elements a leaf up to 10^6
    /// spheres; at 10^7, 32 was ~15 % faster. (A bih::WideTree, the fastest host queries, is
    /// best made by bih::build_wide, from a tree with leaves of its leaf size, untrimmed:
    /// bih/wide_build.hpp.)
    [[nodiscard]] static Config for_queries() {
        Config c;
        c.max_leaf_elements = 32;
        c.trim_leaves = false;
        return c;
    }
};

namespace detail {

/// Config::fill_below's cap: the filling split selects among the centres in arrays this long.
inline constexpr std::size_t kFillMax = 64;

/// What the build partitions: an element's box and its index in the caller's array. The
/// records move with the partition, so every pass reads them in sequence instead of
/// gathering boxes through an index permutation (the build's cost at 10^6+ elements).
/// Trivially constructible on purpose: arrays of them are filled in parallel, never zeroed.
struct Prim {
    float lo[3];
    std::uint32_t index;
    float hi[3];
    std::uint32_t pad;  ///< 32 bytes: records move as two aligned 16-byte halves
    /// Centre along `axis`, as lo * 0.5 + hi * 0.5 (no overflow for huge boxes).
    [[nodiscard]] float center(int axis) const { return lo[axis] * 0.5f + hi[axis] * 0.5f; }
    [[nodiscard]] Aabb box() const { return {vec3(lo[0], lo[1], lo[2]), vec3(hi[0], hi[1], hi[2])}; }
};

/// Extends `u` by a record's box exactly as Aabb::extend does (the first of equal values wins).
inline void extend(Aabb& u, const Prim& p) { u.extend(p.box()); }

/// The box of records [begin, end), folded in order.
inline Aabb union_of(const Prim* prims, std::size_t begin, std::size_t end) {
    Aabb u;
    for (std::size_t i = begin; i < end; ++i) extend(u, prims[i]);
    return u;
}

/// Throws for the smallest index in `bad` (numeric_limits::max() when there is none).
inline void throw_if_bad(std::size_t bad, const Prim* prims) {
    if (bad == std::numeric_limits<std::size_t>::max()) return;
    Aabb b = prims[bad].box();
    throw Error("bih::build: element " + std::to_string(bad) +
                (b.finite() ? " has an inverted box (lo > hi)" : " has non-finite bounds (NaN or inf)"));
}

/// Fills the records of all elements in parallel and returns the box of all of them. The
/// union is taken per block and the blocks are merged in order, which gives the same bits as
/// one fold in element order (min and max keep the first of equal values, +0 and -0 included).
template <Bounded E, Executor X>
Aabb gather_prims(std::span<const E> elements, Prim* prims, X& exec) {
    const std::size_t n = elements.size(), block = 16384, blocks = (n + block - 1) / block;
    std::vector<Aabb> part(blocks);
    std::atomic<std::size_t> bad{std::numeric_limits<std::size_t>::max()};
    exec.parallel_for(0, blocks, 1, [&](std::size_t blo, std::size_t bhi) {
        for (std::size_t b = blo; b < bhi; ++b) {
            Aabb u;
            for (std::size_t i = b * block, end = std::min(n, i + block); i < end; ++i) {
                Aabb e = bounds_of(elements[i]);
                prims[i] = Prim{{e.lo.x, e.lo.y, e.lo.z}, static_cast<std::uint32_t>(i), {e.hi.x, e.hi.y, e.hi.z}, 0u};
                if (!e.finite() || e.empty()) {
                    std::size_t expected = bad.load();
                    while (i < expected && !bad.compare_exchange_weak(expected, i)) {
                    }
                }
                extend(u, prims[i]);
            }
            part[b] = u;
        }
    });
    throw_if_bad(bad.load(), prims);
    Aabb all;
    for (const Aabb& u : part) all.extend(u);
    return all;
}

/// Partitions a[0, n) in place, record k going right where goes_right(k, a[k] as it was) is
/// true, and returns the left count; left_max folds the his of the left records, right_min the
/// los of the right ones. One branch-free Lomuto pass swaps each record with the first one not
/// known to go left: the left records keep their order, the right ones are rotated among
/// themselves. Why Lomuto: each step's addresses depend only on a running count (one add),
/// where the classic two-ended loop (Kinkelin 3.1: swap a right record with the last unexamined
/// one and examine that next) chained every step's loads through the previous step's side:
/// 3.7-10.6 ns a record, 2.5-2.9 here (README, "A partition that does not wait on itself").
/// The sets on each side are the same, so the nodes and planes are; only the order of the
/// elements within a leaf of several differs from the classic loop's.
template <class GoesRight>
SYLVA_FORCEINLINE std::size_t lomuto_partition(Prim* a, std::size_t n, int axis, GoesRight goes_right,
                                               float& left_max, float& right_min) {
    const float inf = std::numeric_limits<float>::infinity();
    float lmax = -inf, rmin = inf;
    std::size_t i = 0;  // [0, i) go left; [i, k) go right
    for (std::size_t k = 0; k < n; ++k) {
        const Prim x = a[k], y = a[i];
        const std::size_t is_right = goes_right(k, x) ? 1u : 0u;
        const float hi[2] = {x.hi[axis], -inf}, lo[2] = {inf, x.lo[axis]};
        lmax = std::max(lmax, hi[is_right]);  // max(x, -inf) and min(x, +inf) keep x
        rmin = std::min(rmin, lo[is_right]);
        a[k] = y;  // i == k: both stores write x back
        a[i] = x;
        i += 1 - is_right;
    }
    left_max = lmax;
    right_min = rmin;
    return i;
}

/// lomuto_partition over sides the caller computed: right[k] != 0 sends a[k] right.
inline std::size_t partition_by_sides(Prim* a, std::size_t n, int axis, const std::uint8_t* right,
                                      float& left_max, float& right_min) {
    return lomuto_partition(a, n, axis, [right](std::size_t k, const Prim&) { return right[k] != 0; }, left_max,
                            right_min);
}

/// lomuto_partition by centre <= cut along `axis` (the side taken in the same pass: a separate
/// pass writing the sides first cost 5-10 % of a build).
/// Not inlined, and starting on a 64-byte boundary, so that its loop sits at the same place in
/// the instruction cache lines in every program: inlined into the builder, its speed depended on
/// where unrelated code put the builder's function (sylva-bench, the same source but for a
/// change in sylva/bih/wide.hpp: the WideTree's source BIH at 10^5 spheres 5.5-6.0 or 4.4-4.7
/// ms a build, at 10^6 77-82 or 60-63 ms; pinned like this 4.5-4.7 and 63-64 in both programs).
[[gnu::noinline, gnu::aligned(64)]] inline std::size_t partition_in_place(Prim* a, std::size_t n, int axis, float cut,
                                                                          float& left_max, float& right_min) {
    return lomuto_partition(a, n, axis, [axis, cut](std::size_t, const Prim& x) { return !(x.center(axis) <= cut); },
                            left_max, right_min);
}

/// Where a parallel build writes the nodes of its serial chunks: a region of the tree's own
/// node array per chunk, at a fixed rate of slots per element, so that those nodes (nearly all
/// of them) are written once and then moved down into pre-order in place, instead of being
/// written into scratch and copied into a second array. Why: on a new VM every page the build
/// touches first costs (README, "Cold and steady state"); the scratch copy was a third of the
/// default tree's 350 MB at 10^6 spheres. A chunk over elements [b, e) gets slots
/// [offset(b), offset(e)), after kHead slots for the nodes that precede the first one in
/// pre-order (those of the chunks whose tasks fork: one chain of them per level). Rates (slots
/// an element, `num / den`), for sylva-bench's spheres, uniform and clustered, 10^5 and 10^6:
/// trimmed leaves, EmptyChildren::TrimBoth 21/4 = 5.25 (measured 4.92 an element, per chunk
/// 4.92-5.27), Infinite 13/2 (measured 6.00-6.01); untrimmed leaves 16/5 a leaf's worth = 3.2 /
/// max_leaf_elements (measured 2.86-2.92 / leaf size over all, up to 5.1 in a clustered chunk).
/// A chunk that needs more slots spills into the arena (ChunkNodes).
struct RegionRate {
    static constexpr std::size_t kHead = 256;
    std::uint64_t num = 0, den = 1;  ///< num == 0: no regions
    [[nodiscard]] static RegionRate for_config(const Config& cfg) {
        if (!cfg.trim_leaves) return RegionRate{16, 5ull * cfg.max_leaf_elements};
        return cfg.empty_children == EmptyChildren::TrimBoth ? RegionRate{21, 4} : RegionRate{13, 2};
    }
    [[nodiscard]] std::size_t offset(std::size_t element) const {
        return kHead + static_cast<std::size_t>(static_cast<std::uint64_t>(element) * num / den);
    }
};

/// The nodes of one chunk. In a build on one thread a LargeVector that becomes the tree's array;
/// in a parallel build a serial chunk's region of the tree's array (RegionRate) until it fills
/// up, else a run of the build's memory::RunArena (core/memory.hpp says why: most chunks are
/// small, and as vectors each was a fresh mapping in 4 KiB pages). Indices stay valid when a
/// region spills into a run; references to nodes last until the next append.
class ChunkNodes {
public:
    /// Starts empty with room for about `expected` nodes, in `arena` unless it is null.
    void start(memory::RunArena<Node>* arena, std::size_t expected) {
        region_ = nullptr;
        nodes_.start(arena, expected);
    }
    /// Starts empty in `room` slots at `region`, which is index `at` of the tree's array; a
    /// region that fills up moves into a run of `arena`.
    void start_region(Node* region, std::size_t room, std::size_t at, memory::RunArena<Node>* arena) {
        region_ = region;
        room_ = room;
        at_ = at;
        size_ = 0;
        arena_ = arena;
    }
    Node& emplace_back() {
        if (region_) {
            if (size_ < room_) return *::new (static_cast<void*>(region_ + size_++)) Node();
            spill();
        }
        return nodes_.emplace_back();
    }
    Node& operator[](std::size_t i) { return region_ ? region_[i] : nodes_[i]; }
    const Node& operator[](std::size_t i) const { return region_ ? region_[i] : nodes_[i]; }
    [[nodiscard]] std::size_t size() const { return region_ ? size_ : nodes_.size(); }
    void close() {
        if (!region_) nodes_.close();
    }
    /// Whether the nodes are in a region of the tree's array, and at which index it starts.
    [[nodiscard]] bool in_region() const { return region_ != nullptr; }
    [[nodiscard]] std::size_t region_at() const { return at_; }
    /// Whether the nodes are a LargeVector that can become the tree's array as it is.
    [[nodiscard]] bool is_vector() const { return !region_ && !nodes_.in_arena(); }
    LargeVector<Node>& vector() { return nodes_.vector(); }

private:
    [[gnu::noinline]] void spill() {
        nodes_.start(arena_, 2 * size_ + 64);
        for (std::size_t i = 0; i < size_; ++i) nodes_.emplace_back() = region_[i];
        region_ = nullptr;
    }
    Node* region_ = nullptr;
    std::size_t room_ = 0, at_ = 0, size_ = 0;
    memory::RunArena<Node>* arena_ = nullptr;
    memory::RunOrVector<Node> nodes_;
};

/// The nodes one build task made, in pre-order. The subtrees that parallel tasks built hang
/// off it as sub-chunks; in the final array each follows the nodes this chunk had when the
/// sub-chunk was attached (`at`), like the append of a serial build.
struct Chunk {
    struct Link {
        std::uint32_t node = 0;  ///< local index of the parent node
        std::uint32_t slot = 0;  ///< which child of it the sub-chunk's root is
        std::size_t at = 0;      ///< nodes of this chunk that precede the sub-chunk
        std::unique_ptr<Chunk> sub;
    };
    ChunkNodes nodes;
    std::vector<Link> links;
    std::size_t leaves = 0, single_child_nodes = 0;
    std::uint32_t max_depth = 0, max_leaf_elements = 0;
    std::size_t total = 0;  ///< nodes here and in all sub-chunks (set by assembly)
    std::size_t base = 0;   ///< final index of nodes[0] (set by assembly)

    /// Final index of local node i.
    [[nodiscard]] std::size_t final_index(std::size_t i) const {
        std::size_t at = base + i;
        for (const Link& l : links)
            if (l.at <= i) at += l.sub->total;
        return at;
    }
};

/// Builds one subtree into a chunk (indices local to it); subtrees over more than
/// Config::parallel_threshold elements go to parallel tasks with chunks of their own.
template <Executor X>
class SubtreeBuilder {
public:
    /// `arena` holds the chunks' nodes of a parallel build (null: each chunk a LargeVector);
    /// `regions`, where not null, is the tree's node array, in which serial chunks get regions
    /// at `rate` (RegionRate).
    SubtreeBuilder(Prim* prims, std::uint32_t* order, const Config& cfg, X& exec,
                   std::atomic<std::size_t>& placed, std::size_t total, memory::RunArena<Node>* arena,
                   Node* regions = nullptr, RegionRate rate = {})
        : p_(prims), order_(order), cfg_(cfg), exec_(exec), placed_(placed), total_(total),
          arena_(arena), regions_(regions), rate_(rate) {}

    /// Builds the subtree over records [begin, end) with box `box` at `depth` into `out`;
    /// writes the element order of its leaves into order[begin, end).
    void build(Chunk& out, std::size_t begin, std::size_t end, const Aabb& box, std::uint32_t depth) {
        if (regions_ && end - begin <= cfg_.parallel_threshold) {  // a serial chunk (children())
            const std::size_t lo = rate_.offset(begin), hi = rate_.offset(end);
            out.nodes.start_region(regions_ + lo, hi - lo, lo, arena_);
        } else {
            out.nodes.start(arena_, reserve_for(end - begin));
        }
        node(out, begin, end, box, depth);
        out.nodes.close();
    }

private:
    struct Split {
        enum Kind { Leaf, Two, One } kind = Leaf;
        int axis = 0;
        std::size_t mid = 0;  ///< elements [begin, mid) go left
        float plane[2] = {0.0f, 0.0f};
        Aabb box[2];
    };

    /// Nodes to reserve for m elements: about 5 per element when leaves are trimmed (Kinkelin
    /// Table 3: 2 leaves - 1 plus ~60 % single-child nodes), fewer with wider leaves.
    std::size_t reserve_for(std::size_t m) const {
        if (m > cfg_.parallel_threshold && exec_.concurrency() > 1) return 64;  // a chain, then tasks
        return cfg_.trim_leaves ? 6 * m + 64 : 3 * m / cfg_.max_leaf_elements + 64;  // unused pages cost nothing
    }

    void node(Chunk& out, std::size_t begin, std::size_t end, const Aabb& box, std::uint32_t depth) {
        if (end - begin == 1) {
            single(out, begin, box, depth);
            return;
        }
        std::uint32_t self = static_cast<std::uint32_t>(out.nodes.size());
        out.nodes.emplace_back();
        out.max_depth = std::max(out.max_depth, depth);
        Split s = choose(begin, end, box, depth);
        if (s.kind == Split::Leaf) {
            make_leaf(out, out.nodes[self], begin, end);
            return;
        }
        Node& n = out.nodes[self];
        n.make_inner(s.axis);
        n.plane[0] = s.plane[0];
        n.plane[1] = s.plane[1];
        if (s.kind == Split::One) {
            bool left = s.mid == end;
            bool single = cfg_.empty_children == EmptyChildren::TrimBoth;
            n.single = single;
            n.child[(single || left) ? 0 : 1] = static_cast<std::uint32_t>(out.nodes.size());
            ++out.single_child_nodes;
            node(out, begin, end, s.box[0], depth + 1);
            return;
        }
        children(out, self, begin, end, s, depth);
    }

    /// The nodes of a one-element range (most nodes of a trimmed tree): the splits choose()
    /// makes for it, a chain of single-child trims ending in a leaf, without partitions.
    void single(Chunk& out, std::size_t at, Aabb box, std::uint32_t depth) {
        const Aabb u = p_[at].box();
        const bool trim_both = cfg_.empty_children == EmptyChildren::TrimBoth;
        for (;; ++depth) {
            out.max_depth = std::max(out.max_depth, depth);
            Node& n = out.nodes.emplace_back();
            if (depth >= cfg_.max_depth || !cfg_.trim_leaves || u == box) {
                make_leaf(out, n, at, at + 1);
                return;
            }
            int a = box.longest_axis();  // midpoint(): the element falls on one side
            bool left = p_[at].center(a) <= box.lo[a] * 0.5f + box.hi[a] * 0.5f;
            float lo = (trim_both || !left) ? u.lo[a] : box.lo[a];  // one_sided()
            float hi = (trim_both || left) ? u.hi[a] : box.hi[a];
            Split s = (lo == box.lo[a] && hi == box.hi[a]) ? trim(at, at + 1, box, u)
                                                           : one_child(box, a, lo, hi, left ? at + 1 : at, left);
            n.make_inner(s.axis);
            n.plane[0] = s.plane[0];
            n.plane[1] = s.plane[1];
            n.single = trim_both;
            n.child[(trim_both || s.mid == at + 1) ? 0 : 1] = static_cast<std::uint32_t>(out.nodes.size());
            ++out.single_child_nodes;
            box = s.box[0];
        }
    }

    void children(Chunk& out, std::uint32_t self, std::size_t begin, std::size_t end, const Split& s,
                  std::uint32_t depth) {
        bool parallel = exec_.concurrency() > 1 && (end - begin) > cfg_.parallel_threshold;
        if (!parallel) {
            out.nodes[self].child[0] = static_cast<std::uint32_t>(out.nodes.size());
            node(out, begin, s.mid, s.box[0], depth + 1);
            out.nodes[self].child[1] = static_cast<std::uint32_t>(out.nodes.size());
            node(out, s.mid, end, s.box[1], depth + 1);
            return;
        }
        auto left = std::make_unique<Chunk>(), right = std::make_unique<Chunk>();
        out.nodes.close();  // a chunk ends where its tasks begin (nothing is appended after them)
        exec_.invoke([&] { build(*left, begin, s.mid, s.box[0], depth + 1); },
                     [&] { build(*right, s.mid, end, s.box[1], depth + 1); });
        out.links.push_back({self, 0, out.nodes.size(), std::move(left)});
        out.links.push_back({self, 1, out.nodes.size(), std::move(right)});
    }

    void make_leaf(Chunk& out, Node& n, std::size_t begin, std::size_t end) {
        n.axis = kLeaf;
        n.first = static_cast<std::uint32_t>(begin);
        n.count = static_cast<std::uint32_t>(end - begin);
        for (std::size_t i = begin; i < end; ++i) order_[i] = p_[i].index;
        ++out.leaves;
        out.max_leaf_elements = std::max(out.max_leaf_elements, n.count);
        if (cfg_.on_progress) {
            std::size_t before = placed_.fetch_add(end - begin);
            std::size_t step = std::max<std::size_t>(total_ / 100, 1);
            if (before / step != (before + end - begin) / step)
                cfg_.on_progress(static_cast<double>(before + end - begin) / static_cast<double>(total_));
        }
    }

    /// The split of a node; may reorder (and move) its records, so it takes the buffers.
    Split choose(std::size_t begin, std::size_t end, const Aabb& box, std::uint32_t depth) {
        if (depth >= cfg_.max_depth) return Split{};
        bool small = (end - begin) <= cfg_.max_leaf_elements;
        Aabb u;
        if (small) {
            if (!cfg_.trim_leaves) return Split{};
            u = union_of(p_, begin, end);
            if (u == box) return Split{};
        }
        if (!small && end - begin <= std::min<std::size_t>(cfg_.fill_below, kFillMax)) {
            Split s = filling_split(begin, end, box);
            if (s.kind != Split::Leaf) return s;
        }
        Split s = midpoint(begin, end, box);
        if (s.kind != Split::Leaf) return s;
        if (!small) u = union_of(p_, begin, end);
        if (!(u == box)) return trim(begin, end, box, u);
        return centroid_split(begin, end, box);
    }

    /// The paper's rule: middle of the longest axis. Returns Leaf when it makes no progress.
    Split midpoint(std::size_t begin, std::size_t end, const Aabb& box) {
        Split s;
        s.axis = box.longest_axis();
        float cut = box.lo[s.axis] * 0.5f + box.hi[s.axis] * 0.5f;
        s.mid = partition(begin, end, s.axis, cut, s.plane[0], s.plane[1]);
        if (s.mid != begin && s.mid != end) return two_children(s, box);
        return one_sided(begin, end, box, s);
    }

    /// All elements fell on one side of the plane: a node with one empty child if that trims.
    Split one_sided(const std::size_t begin, std::size_t end, const Aabb& box, Split s) {
        int a = s.axis;
        bool left = s.mid == end;
        float lo = box.lo[a], hi = box.hi[a];
        if (cfg_.empty_children == EmptyChildren::TrimBoth) {
            Aabb u = union_of(p_, begin, end);
            lo = u.lo[a];
            hi = u.hi[a];
        } else if (left) {
            hi = s.plane[0];
        } else {
            lo = s.plane[1];
        }
        if (lo == box.lo[a] && hi == box.hi[a]) return Split{};
        return one_child(box, a, lo, hi, left ? end : begin, left);
    }

    /// A node with one child trimmed to [lo, hi] along `axis`; `mid` == end marks a left child.
    Split one_child(const Aabb& box, int axis, float lo, float hi, std::size_t mid, bool left) {
        Split s;
        s.kind = Split::One;
        s.mid = mid;
        s.axis = axis;
        s.box[0] = box;
        s.box[0].lo[axis] = lo;
        s.box[0].hi[axis] = hi;
        const float inf = std::numeric_limits<float>::infinity();
        if (cfg_.empty_children == EmptyChildren::TrimBoth) {
            s.plane[0] = lo;
            s.plane[1] = hi;
        } else {
            s.plane[0] = left ? hi : -inf;
            s.plane[1] = left ? inf : lo;
        }
        return s;
    }

    /// Trims the box towards the elements' box `u` on the axis with the most slack.
    Split trim(std::size_t begin, std::size_t end, const Aabb& box, const Aabb& u) {
        int best = 0;
        float slack = -1.0f;
        for (int a = 0; a < 3; ++a) {
            float sl = (u.lo[a] - box.lo[a]) + (box.hi[a] - u.hi[a]);
            if (sl > slack) {
                slack = sl;
                best = a;
            }
        }
        bool infinite = cfg_.empty_children == EmptyChildren::Infinite;
        bool left = !infinite || u.hi[best] < box.hi[best];  // Infinite: cut the side with slack
        float lo = (infinite && left) ? box.lo[best] : u.lo[best];
        float hi = (infinite && !left) ? box.hi[best] : u.hi[best];
        return one_child(box, best, lo, hi, left ? end : begin, left);
    }

    /// fill_below's split: the first multiple of fill_width at or above half of the elements go
    /// left, by centre along the centres' longest axis; Leaf where the centres coincide. The
    /// centres are copied into a small array, the centres below each one are counted there (no
    /// branches: std::nth_element on the records took a fifth of build_wide at 10^5 spheres),
    /// and the records move once, by partition_by_sides.
    Split filling_split(std::size_t begin, std::size_t end, const Aabb& box) {
        const Aabb c = centres_box(begin, end);
        Split s;
        s.axis = c.longest_axis();
        const int a = s.axis;
        if (!(c.hi[a] > c.lo[a])) return s;
        const std::size_t w = std::max<std::size_t>(cfg_.fill_width, 1), n = end - begin;
        const std::size_t left = std::max<std::size_t>(w, (n / 2 + w - 1) / w * w);
        if (left >= n) return Split{};
        float key[kFillMax];
        for (std::size_t k = 0; k < n; ++k) key[k] = p_[begin + k].center(a);
        // Each centre's count of smaller ones, in one pass. A rank is at least that count, so
        // the `left` centres of rank < left are among those with fewer than `left` below them:
        // if exactly `left` have, they are the ones. Otherwise equal centres straddle the split,
        // and the ranks (the count below plus equal_before) break the tie by position.
        std::uint32_t below[kFillMax];
        std::size_t under = 0;
        for (std::size_t k = 0; k < n; ++k) {
            std::uint32_t b = 0;
            for (std::size_t j = 0; j < n; ++j) b += key[j] < key[k] ? 1u : 0u;
            below[k] = b;
            under += b < left ? 1u : 0u;
        }
        std::uint8_t right[kFillMax];
        if (under == left)
            for (std::size_t k = 0; k < n; ++k) right[k] = below[k] >= left;
        else
            for (std::size_t k = 0; k < n; ++k) right[k] = below[k] + equal_before(key, k) >= left;
        s.mid = begin + partition_by_sides(p_ + begin, n, a, right, s.plane[0], s.plane[1]);
        return two_children(s, box);
    }

    /// How many of key[0, k) equal key[k]: with the count of smaller keys, key[k]'s position in
    /// the keys sorted by value, equal values in index order.
    static std::size_t equal_before(const float* key, std::size_t k) {
        std::size_t equal = 0;
        for (std::size_t j = 0; j < k; ++j) equal += key[j] == key[k] ? 1u : 0u;
        return equal;
    }

    /// Box already tight: split at the middle of the centres' extent; Leaf if they coincide.
    Split centroid_split(std::size_t begin, std::size_t end, const Aabb& box) {
        const Aabb c = centres_box(begin, end);
        Split s;
        s.axis = c.longest_axis();
        if (!(c.hi[s.axis] > c.lo[s.axis])) return s;
        float cut = c.lo[s.axis] * 0.5f + c.hi[s.axis] * 0.5f;
        if (!(cut < c.hi[s.axis])) cut = c.lo[s.axis];
        s.mid = partition(begin, end, s.axis, cut, s.plane[0], s.plane[1]);
        return two_children(s, box);
    }

    /// The box of the centres of records [begin, end).
    Aabb centres_box(std::size_t begin, std::size_t end) const {
        Aabb c;
        for (std::size_t i = begin; i < end; ++i) c.extend(vec3(p_[i].center(0), p_[i].center(1), p_[i].center(2)));
        return c;
    }

    /// s as a split into two children: each takes `box` cut at its own plane.
    static Split two_children(Split s, const Aabb& box) {
        s.kind = Split::Two;
        s.box[0] = s.box[1] = box;
        s.box[0].hi[s.axis] = s.plane[0];
        s.box[1].lo[s.axis] = s.plane[1];
        return s;
    }

    std::size_t partition(std::size_t begin, std::size_t end, int axis, float cut, float& left_max,
                          float& right_min) {
        return begin + partition_in_place(p_ + begin, end - begin, axis, cut, left_max, right_min);
    }

    Prim* p_;
    std::uint32_t* order_;
    const Config& cfg_;
    X& exec_;
    std::atomic<std::size_t>& placed_;
    std::size_t total_;
    memory::RunArena<Node>* arena_;
    Node* regions_;
    RegionRate rate_;
};

/// Sets the total size of every chunk and the final index of its first node (pre-order, each
/// sub-chunk after the nodes its parent chunk had when it was attached); lists the chunks.
inline std::size_t place_chunks(Chunk& c, std::size_t base, std::vector<Chunk*>& list) {
    c.base = base;
    list.push_back(&c);
    c.total = c.nodes.size();
    for (Chunk::Link& l : c.links) c.total += place_chunks(*l.sub, base + l.at + (c.total - c.nodes.size()), list);
    return c.total;
}

/// Copies one chunk into the final array, turning local child indices into final ones and
/// pointing the parents of sub-chunks at their roots; `out` holds final indices from `first` on.
/// A chunk in a region of `out` itself moves down or stays (movable_in_place: every chunk ends
/// at or below the next region), node by node from the first, so each is read before it can be
/// overwritten.
inline void copy_chunk(const Chunk& c, Node* out, std::size_t first = 0) {
    const bool plain = c.links.empty() || c.links.front().at == c.nodes.size();  // sub-chunks only after
    const std::size_t size = c.nodes.size();
    if (plain) {  // most chunks: one shift for all (a region is plain)
        const Node* from = size ? &c.nodes[0] : nullptr;
        Node* to = out + (c.base - first);
        const auto base = static_cast<std::uint32_t>(c.base);
        for (std::size_t i = 0; i < size; ++i) {
            Node n = from[i];
            const std::uint32_t shift = n.leaf() ? 0u : base;  // a leaf's words are first, count
            for (std::uint32_t& child : n.child) child += child != kNoChild ? shift : 0u;
            to[i] = n;
        }
    } else {
        for (std::size_t i = 0; i < size; ++i) {
            Node n = c.nodes[i];
            if (!n.leaf())
                for (std::uint32_t& child : n.child)
                    if (child != kNoChild) child = static_cast<std::uint32_t>(c.final_index(child));
            out[c.final_index(i) - first] = n;
        }
    }
    for (const Chunk::Link& l : c.links)
        out[c.final_index(l.node) - first].child[l.slot] = static_cast<std::uint32_t>(l.sub->base);
}

/// The statistics of all chunks together.
inline void collect_stats(const std::vector<Chunk*>& list, BuildStats& s) {
    for (const Chunk* c : list) {
        s.leaves += c->leaves;
        s.single_child_nodes += c->single_child_nodes;
        s.max_depth = std::max(s.max_depth, c->max_depth);
        s.max_leaf_elements = std::max(s.max_leaf_elements, c->max_leaf_elements);
    }
}

/// Whether the chunks (in pre-order) can be copied into place one after another inside the
/// array that holds their regions: every node must land below `room`, and no chunk on a region
/// that a later chunk still has to read. Then no region chunk moves up (its base is the end of
/// the chunks before it, at most its region's start).
inline bool movable_in_place(const std::vector<Chunk*>& list, std::size_t total, std::size_t room) {
    if (total > room) return false;
    std::size_t unread = room;  // the lowest region start of the chunks after the one looked at
    for (auto it = list.rbegin(); it != list.rend(); ++it) {
        const Chunk& c = **it;
        const std::size_t end = c.nodes.size() ? c.final_index(c.nodes.size() - 1) + 1 : c.base;
        if (end > unread) return false;
        if (c.nodes.in_region()) unread = std::min(unread, c.nodes.region_at());
    }
    return true;
}

/// How assemble() made the tree's array (for tests).
enum class Assembly {
    Whole,    ///< a one-thread build: the one chunk's vector became the array
    InPlace,  ///< the chunks moved into pre-order inside the array of their regions
    Copied,   ///< the chunks copied into a new array, in parallel
};

/// Moves the chunks (pre-order, movable_in_place) into place in `out`, the array of their
/// regions, in parallel: the list is cut into one part a thread, of about equal nodes, each
/// moved in order. A part's first chunks, those whose places still hold regions of the parts
/// before it, are copied aside and put in place once all parts are done (at 10^6 spheres
/// ~1/30 of the nodes).
template <Executor X>
void move_chunks(const std::vector<Chunk*>& list, std::size_t total, Node* out, X& exec) {
    const std::size_t parts = std::clamp<std::size_t>(exec.concurrency(), 1, list.size());
    std::vector<std::size_t> cut(parts + 1, list.size());  // part p: list[cut[p], cut[p + 1])
    cut[0] = 0;
    for (std::size_t k = 0, p = 1, nodes = 0; k < list.size() && p < parts; ++k) {
        nodes += list[k]->nodes.size();
        if (nodes >= total / parts * p) cut[p++] = k + 1;
    }
    struct Aside {
        std::size_t first = 0;  ///< final index of nodes[0]
        LargeVector<Node> nodes;
    };
    std::vector<Aside> aside(parts);
    exec.parallel_for(0, parts, 1, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t p = lo; p < hi; ++p) {
            std::size_t guard = 0;  // end of the last region before this part (regions ascend)
            for (std::size_t k = cut[p]; k-- > 0;)
                if (list[k]->nodes.in_region()) {
                    guard = list[k]->nodes.region_at() + list[k]->nodes.size();
                    break;
                }
            std::size_t k = cut[p], end = cut[p];
            while (end < cut[p + 1] && list[end]->base < guard) ++end;  // bases ascend
            if (end > k) {
                aside[p].first = list[k]->base;
                aside[p].nodes.resize((end < list.size() ? list[end]->base : total) - aside[p].first);
                for (; k < end; ++k) copy_chunk(*list[k], aside[p].nodes.data(), aside[p].first);
            }
            for (; k < cut[p + 1]; ++k) copy_chunk(*list[k], out);
        }
    });
    for (const Aside& a : aside) std::copy(a.nodes.begin(), a.nodes.end(), out + a.first);
}

/// Copies the chunks into `out` (total nodes, pre-order) in parallel; frees their vectors.
template <Executor X>
void copy_chunks(const std::vector<Chunk*>& list, Node* out, X& exec) {
    exec.parallel_for(0, list.size(), 1, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t k = lo; k < hi; ++k) {
            copy_chunk(*list[k], out);
            LargeVector<Node>().swap(list[k]->nodes.vector());  // lowers the peak memory (arena runs: at the end)
        }
    });
}

/// Joins the chunks into one pre-order node array and fills the stats. With `regions`, t.nodes
/// is the array the serial chunks' regions are in (RegionRate): the chunks move into place in
/// it (move_chunks), unless that could overwrite a region before it is read; then, as without
/// regions, they are copied into a new array in parallel.
template <Executor X>
Assembly assemble(Chunk& root, Tree& t, X& exec, bool regions) {
    std::vector<Chunk*> list;
    std::size_t total = place_chunks(root, 0, list);
    if (total >= std::numeric_limits<std::uint32_t>::max())
        throw Error("bih::build: " + std::to_string(total) + " nodes exceed 32-bit node indices");
    collect_stats(list, t.stats);
    t.stats.nodes = total;
    if (list.size() == 1 && root.nodes.is_vector()) {
        t.nodes = std::move(root.nodes.vector());
        return Assembly::Whole;
    }
    if (regions && movable_in_place(list, total, t.nodes.size())) {
        move_chunks(list, total, t.nodes.data(), exec);
        t.nodes.resize(total);
        return Assembly::InPlace;
    }
    LargeVector<Node> fresh;  // the regions' array is read while the copy is written
    LargeVector<Node>& out = regions ? fresh : t.nodes;
    if (out.capacity() < total) {  // new pages: faulted on all threads, not in the resize
        out.clear();
        memory::prefault<Node>(total, exec);
    }
    out.resize(total);
    copy_chunks(list, out.data(), exec);
    if (regions) t.nodes.swap(fresh);
    return Assembly::Copied;
}

/// Fills in the statistics of a finished tree (any tree whose children follow their parents).
inline void measure(Tree& t) {
    BuildStats& s = t.stats;
    s.nodes = t.nodes.size();
    std::vector<std::uint32_t> depth(t.nodes.size(), 0);
    for (std::size_t i = 0; i < t.nodes.size(); ++i) {  // children always follow their parent
        const Node& n = t.nodes[i];
        s.max_depth = std::max(s.max_depth, depth[i]);
        if (n.leaf()) {
            ++s.leaves;
            s.max_leaf_elements = std::max(s.max_leaf_elements, n.count);
            continue;
        }
        if (n.children() == 1) ++s.single_child_nodes;
        for (std::uint32_t c : n.child)
            if (c != kNoChild) depth[c] = depth[i] + 1;
    }
}

/// bih::build into `t`, reusing its arrays (bih::rebuild, sylva/bih/refit.hpp). `rate` replaces
/// RegionRate::for_config and `how` learns how the node array was made (both for tests).
template <Bounded E, Executor X>
void build_into(Tree& t, std::span<const E> elements, const Config& config, X& exec,
                std::optional<RegionRate> rate = std::nullopt, Assembly* how = nullptr) {
    auto start = std::chrono::steady_clock::now();
    // The records, nodes and order are written once and read by the encoder or the WideTree
    // collapse, not by queries: 4 KiB pages where those fault cheaply (core/memory.hpp).
    memory::SmallPagesWhereCheap small_pages;
    if (elements.empty()) throw Error("bih::build: no elements (empty input)");
    if (elements.size() >= std::numeric_limits<std::uint32_t>::max())
        throw Error("bih::build: too many elements (" + std::to_string(elements.size()) + ", at most 2^32 - 2)");
    Config cfg = config;
    cfg.max_depth = std::min<std::uint32_t>(cfg.max_depth, SYLVA_BIH_DEPTH_CAP);
    cfg.max_leaf_elements = std::max<std::uint32_t>(cfg.max_leaf_elements, 1);

    // A parallel build (the condition is SubtreeBuilder::children's for the root) writes its
    // serial chunks into regions of t.nodes (RegionRate) and the rest (the chunks whose tasks
    // fork, a few nodes each, and regions that overflow) into an arena until they are
    // assembled: blocks of n / 64 nodes, 16 KiB to 1 MiB (small blocks of the allocator, carved
    // from its 2 MiB chunks: at 10^4 spheres a 2 MiB huge page of its own for ~100 nodes was a
    // tenth of a cold build). Without regions (a zero rate) the arena holds every chunk: blocks
    // of about 1/16 of the nodes expected (reserve_for's estimate), between 1 and 64 MiB, or one
    // block where all of them fit in 1 MiB (memory::kArenaBlock).
    const std::size_t n = elements.size();
    const RegionRate regions = rate ? *rate : RegionRate::for_config(cfg);
    const bool parallel = exec.concurrency() > 1 && n > cfg.parallel_threshold;
    // The workers' wake-up overlaps the records' gathering and the first splits (an executor's
    // optional hook: ThreadPool::wake_workers says why).
    if constexpr (requires { exec.wake_workers(); })
        if (parallel) exec.wake_workers();
    // Regions only where all of them have 32-bit node indices (beyond, the arena alone).
    const bool in_regions = parallel && regions.num && regions.offset(n) < std::numeric_limits<std::uint32_t>::max();
    std::optional<memory::RunArena<Node>> arena;
    if (parallel) {
        const std::size_t expected = (cfg.trim_leaves ? 6 * n : 3 * n / cfg.max_leaf_elements) + 64;
        const std::size_t large = (memory::kArenaBlock + sizeof(Node) - 1) / sizeof(Node);
        const std::size_t small = (memory::kCachedBlock + sizeof(Node) - 1) / sizeof(Node);  // >= a cached block
        arena.emplace(in_regions        ? std::clamp<std::size_t>(n / 64, small, large - small)
                      : expected <= large ? expected
                                          : std::clamp<std::size_t>(expected / 16, large, (std::size_t{64} << 20) / sizeof(Node)));
    }
    detail::Chunk root;
    {
        // Scratch from the large-block allocator: default-initialised (no zeroing pass), and
        // warm memory when an earlier build freed blocks of this size (freed before the
        // assembly, which may reuse it). The records come first: a bad element throws before
        // anything of `t` changes (a rebuild keeps its tree).
        memory::LargeBuffer<detail::Prim> prims(n);
        const Aabb bounds = detail::gather_prims(elements, prims.data(), exec);
        t.stats = {};
        t.bounds = bounds;
        if (t.order.capacity() < n) {  // new pages: faulted on all threads, not in the resize
            t.order.clear();
            memory::prefault<std::uint32_t>(n, exec);
        }
        t.order.resize(n);
        if (in_regions) {
            const std::size_t room = regions.offset(n);
            t.nodes.clear();
            if (t.nodes.capacity() < room) memory::prefault<Node>(room, exec);  // as t.order
            t.nodes.resize(room);
        }
        std::atomic<std::size_t> placed{0};
        detail::SubtreeBuilder<X> builder(prims.data(), t.order.data(), cfg, exec, placed, n,
                                          arena ? &*arena : nullptr, in_regions ? t.nodes.data() : nullptr, regions);
        builder.build(root, 0, n, t.bounds, 0);
    }
    const Assembly made = detail::assemble(root, t, exec, in_regions);
    if (how) *how = made;
    t.stats.elements = elements.size();
    t.stats.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace detail

/// Builds a BIH over `elements`. Throws sylva::Error for an empty input, more than 2^32 - 1
/// elements, or an element whose box is not finite or inverted (lo > hi); the message names
/// the element. The elements are not modified; the tree refers to them through `order`.
template <Bounded E, Executor X>
Tree build(std::span<const E> elements, const Config& config, X& exec) {
    Tree t;
    detail::build_into(t, elements, config, exec);
    return t;
}

/// Builds on the calling thread.
template <Bounded E>
Tree build(std::span<const E> elements, const Config& config = {}) {
    SerialExecutor serial;
    return build(elements, config, serial);
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_BUILD_HPP
