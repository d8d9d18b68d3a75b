// sylva/bih/wide.hpp -- a host query structure made from a built BIH: its levels collapsed into
// 8-wide nodes whose child boxes are refitted to the elements and tested with SIMD slab tests.
//
// Why: the BIH's 8-byte nodes suit the GPU and the front-to-back integrators, but a host query
// that only wants element hits pays ~15 ns for each of many binary node steps. Collapsing
// binary levels into 8-wide nodes (as Embree turns its binary BVH into a BVH8) cuts the steps
// to about a quarter, refitted boxes prune what the BIH's planes cannot (a BIH child is its
// parent's box clipped on one axis), and two SSE slab tests (one AVX2 test where the CPU has
// it, chosen at run time) decide eight children. The tree's topology, leaf ranges and element
// order are the BIH's; only the encoding differs. Which BIH subtrees fill a wide node's slots is
// chosen by dynamic programming over the BIH (Ylitie, Karras, Laine 2017, "Efficient
// incoherent ray traversal on GPUs through compressed wide BVHs"): the grouping with the least
// total half-area of wide nodes, the surface-area heuristic with the BIH's leaves fixed. Made
// once per tree, like LeafRecords; the BIH encoding is still what the GPU and the iterators read.
//
// Layout (all host memory, built here from a checked Tree, so nothing to validate on read):
//   WideNode (256 bytes, 64-aligned): box[6][8] = lo.x, hi.x, lo.y, hi.y, lo.z, hi.z of the
//   eight child slots; child[8], count[8]: an inner child is (wide node index, 0), a leaf is
//   (first packet or record, number of them >= 1); slots are filled from 0, and an unused slot
//   is (kNoChild, 0) with an empty box (lo = +inf, hi = -inf) that no ray enters.
//   Spheres are stored in leaf order as packets of four (SoA centres and radii, 64 bytes);
//   each leaf starts a new packet, unused lanes have radius 0 (never hit) and id kNoChild.
//   Other element types are copied in leaf order and tested one by one.
//
// all_hits walks the nodes in any order (breadth first through a small queue, so that in a large
// tree a node's prefetch has time to arrive before it is tested) and only gathers the leaves it
// enters, a node's entered children and leaves appended with one permutation and store each
// (both stores run for every node, without a branch on whether it entered any); each batch of
// leaves is then tested in two passes (a branch-free float prefilter over every packet, then the
// exact test, bit-identical to Sphere::intersect, for the candidates), and the hits are sorted at
// the end. first_hit walks inner nodes nearest entry first, tests a node's entered leaves
// as soon as the node is tested, and prunes what lies beyond its best.
//
// Any checked BIH collapses; the fastest to build from is one with leaves of the wide tree's leaf
// size (bih::build_wide in sylva/bih/wide_build.hpp makes it and collapses it in one call).
#ifndef SYLVA_BIH_WIDE_HPP
#define SYLVA_BIH_WIDE_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <climits>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "sylva/bih/query.hpp"
#include "sylva/bih/tree.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/elements/sphere.hpp"

// The node test picks AVX2 (one 8-lane slab test instead of two SSE ones) at run time where the
// CPU has it, as Embree picks its kernels by ISA; the walk is compiled twice, once for each.
// GCC only (target attributes and __builtin_cpu_supports); SYLVA_BIH_WIDE_NO_AVX2 keeps SSE.
#if defined(SYLVA_BIH_QUERY_SSE) && defined(__GNUC__) && !defined(__clang__) && \
    (defined(__x86_64__) || defined(__i386__)) && !defined(SYLVA_BIH_WIDE_NO_AVX2)
#include <immintrin.h>
#define SYLVA_BIH_WIDE_AVX2 1
#endif

namespace sylva::bih {

/// How a BIH is collapsed into a WideTree.
struct WideConfig {
    /// A BIH subtree with at most this many elements becomes one leaf (a BIH leaf with more stays
    /// one leaf). 0 (the default) chooses by size: 4 (one packet of spheres) up to kSmallTree
    /// elements, where the tree stays in cache and a node test costs more than the sphere tests
    /// it saves; 8 above, where traversal waits on memory and fewer, fuller nodes win (measured
    /// with sylva-bench: at 10^4 spheres 4 is 5-15 % faster for all hits and as fast for the
    /// first; at 10^5 the two are within the bench's run-to-run spread for all hits, and 8 gives
    /// the first hit 1.05-1.1x on one thread; at 10^6 / 10^7 8 is 15-35 % faster).
    std::uint32_t max_leaf_elements = 0;
    static constexpr std::size_t kSmallTree = std::size_t{1} << 15;
    /// The leaf size used for `elements` elements.
    [[nodiscard]] std::uint32_t leaf_size(std::size_t elements) const {
        if (max_leaf_elements != 0) return max_leaf_elements;
        return elements <= kSmallTree ? 4u : 8u;
    }
};

/// Children per wide node: 8, tested as two groups of four (Embree's BVH8 width). A ray's
/// descent is a chain of dependent node tests, so halving the levels matters more than the
/// extra box tests of a wider node.
inline constexpr int kWideWidth = 8;

/// kWideWidth child boxes (SoA) and their links; see the layout at the top of this file.
struct alignas(64) WideNode {
    float box[6][kWideWidth];
    std::uint32_t child[kWideWidth];
    std::uint32_t count[kWideWidth];
};
static_assert(sizeof(WideNode) == 32 * kWideWidth);

/// Four spheres, transposed: centres and radii lane by lane.
struct alignas(16) SpherePacket {
    float c[3][4];
    float r[4];
};

/// What a WideTree reports about itself.
struct WideStats {
    std::size_t nodes = 0;
    std::size_t leaves = 0;
    std::uint32_t depth = 0;  ///< wide levels, root = 1 (0 when empty)
    std::size_t bytes = 0;    ///< nodes + element storage + ids
};

namespace detail {

/// The least cost of one BIH subtree as at most 1, 2, ..., kWideWidth slots of a wide node:
/// least[i - 1] for i slots (non-increasing in i). The cost is the surface-area heuristic's
/// with the leaves fixed (they are the BIH's): the sum of the half-areas of the wide nodes the
/// subtree becomes, as a ray tests a wide node with a chance proportional to its area. One slot
/// is the subtree as a leaf (cost 0) or as a wide node of its own. Only a node's parent reads
/// its least costs and leaf count (the refit hands them up); what the collapse keeps of it is
/// the choice, packed into the node's SubtreeFacts::plan.
struct SlotCosts {
    float least[kWideWidth];
    /// For i >= 2 slots: how many of them the first child's subtree takes in the least-cost
    /// spread (the second takes the rest), or 0 where one slot costs no more (split[0] = 0).
    std::uint8_t split[kWideWidth];
    /// The first child's share of the least-cost spread over all kWideWidth slots: what a wide
    /// node made here holds (the one-slot choice is not open to it).
    std::uint8_t spread;
    std::uint8_t kind;  ///< kLeaf, kChain (one non-empty child, whose costs these are) or kSpread
    /// Leaves in the subtree, up to kWideWidth (kWideWidth: that many or more): with at least
    /// that many slots it costs 0, every leaf in a slot of its own.
    std::uint8_t leaves;
    static constexpr std::uint8_t kLeaf = 0, kChain = 1, kSpread = 2;
};

/// One BIH subtree after the refit: the tight box of its elements, how many, where they start
/// in the tree's order (a subtree of the in-place builder is one contiguous run), and the
/// collapse's choice for it (SlotCosts without the costs: 36 bytes a BIH node instead of the
/// 80 that the facts and a stored SlotCosts took, so a collapse writes 44 bytes a node less of
/// fresh memory). `plan`, 27 of its 32 bits used:
///   bits 0-1    kind: SlotCosts::kLeaf, kChain or kSpread
///   bit  2      contiguous: its elements are order[first, first + count)
///   bits 3-5    spread: the first child's share of the least-cost spread over kWideWidth slots
///   bits 6-26   split[j - 1] for j = 2 ... kWideWidth slots, 3 bits each at bit 6 + 3 (j - 2)
///               (split[0] is 0: one slot is the subtree itself)
/// Shares are 1 ... kWideWidth - 1 (the second child takes at least one slot), so 3 bits hold them.
struct SubtreeFacts {
    static_assert(kWideWidth == 8, "plan packs slot shares of 3 bits");
    static constexpr std::uint32_t kContiguous = 1u << 2;
    Aabb box;
    std::uint32_t first = 0, count = 0;
    std::uint32_t plan = kContiguous;

    [[nodiscard]] std::uint8_t kind() const { return static_cast<std::uint8_t>(plan & 3u); }
    [[nodiscard]] bool contiguous() const { return (plan & kContiguous) != 0; }
    [[nodiscard]] int spread() const { return static_cast<int>((plan >> 3) & 7u); }
    /// The first child's share over j >= 2 slots, 0 where one slot costs no more.
    [[nodiscard]] int split(int j) const { return static_cast<int>((plan >> (6 + 3 * (j - 2))) & 7u); }
    void set_contiguous(bool c) { plan = c ? plan | kContiguous : plan & ~kContiguous; }
    /// Keeps the contiguous bit, replaces the choice by c's.
    void set_choice(const SlotCosts& c) {
        std::uint32_t p = (plan & kContiguous) | c.kind | (std::uint32_t{c.spread} << 3);
        for (int j = 2; j <= kWideWidth; ++j) p |= std::uint32_t{c.split[j - 1]} << (6 + 3 * (j - 2));
        plan = p;
    }
};

/// b grown outward by a few ulps of its magnitude, so that rounding in the SIMD slab test
/// never drops a ray the exact element test would hit (grazing rays, axis-parallel rays).
inline Aabb padded(const Aabb& b) {
    Aabb p = b;
    for (int a = 0; a < 3; ++a) {
        float m = std::max(std::fabs(b.lo[a]), std::fabs(b.hi[a]));
        float pad = m * 0x1p-20f + std::numeric_limits<float>::denorm_min();
        p.lo[a] = b.lo[a] - pad;
        p.hi[a] = b.hi[a] + pad;
    }
    return p;
}

/// The ray as the child-box test reads it.
struct WideRay {
    float org[3], rcp[3];
    int near_row[3], far_row[3];  ///< rows of WideNode::box holding each axis's entry / exit plane
    WideRay(const Ray& r) {
        for (int a = 0; a < 3; ++a) {
            org[a] = r.origin[a];
            rcp[a] = shared::sylva_safe_rcp(r.direction[a]);
            bool negative = std::signbit(rcp[a]);
            near_row[a] = 2 * a + (negative ? 1 : 0);
            far_row[a] = 2 * a + (negative ? 0 : 1);
        }
    }
};

/// Entry t of the kWideWidth child boxes (into tn_out, unless it is null) and the mask of those
/// the ray enters in [t0, t1]. A NaN slab (a ray lying in a box plane: 0 * inf) constrains
/// nothing: max/min keep the other operand, so the test errs towards entering.
SYLVA_FORCEINLINE int enter_children(const WideNode& n, const WideRay& r, float t0, float t1,
                                     float tn_out[kWideWidth]) {
#ifdef SYLVA_BIH_QUERY_SSE
    int mask = 0;
    for (int g = 0; g < kWideWidth; g += 4) {
        __m128 tn = _mm_set1_ps(t0), tf = _mm_set1_ps(t1);
        for (int a = 0; a < 3; ++a) {
            __m128 o = _mm_set1_ps(r.org[a]), k = _mm_set1_ps(r.rcp[a]);
            __m128 lo = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.box[r.near_row[a]] + g), o), k);
            __m128 hi = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.box[r.far_row[a]] + g), o), k);
            tn = _mm_max_ps(lo, tn);  // maxps returns the second operand when either is NaN
            tf = _mm_min_ps(hi, tf);
        }
        if (tn_out) _mm_storeu_ps(tn_out + g, tn);
        mask |= _mm_movemask_ps(_mm_cmple_ps(tn, tf)) << g;
    }
    return mask;
#else
    int mask = 0;
    for (int c = 0; c < kWideWidth; ++c) {
        float tn = t0, tf = t1;
        for (int a = 0; a < 3; ++a) {
            float lo = (n.box[r.near_row[a]][c] - r.org[a]) * r.rcp[a];
            float hi = (n.box[r.far_row[a]][c] - r.org[a]) * r.rcp[a];
            tn = lo > tn ? lo : tn;  // NaN compares false: tn kept
            tf = hi < tf ? hi : tf;
        }
        if (tn_out) tn_out[c] = tn;
        mask |= tn <= tf ? (1 << c) : 0;
    }
    return mask;
#endif
}

/// The order key of an entry t: its bits made to compare as signed integers in the order of
/// the floats (negative ones flipped), the low 3 bits replaced by the slot, so that keys are
/// distinct and ties (within 8 ulps) go by slot.
SYLVA_FORCEINLINE std::int32_t entry_key(float t, int slot) {
    const auto bits = std::bit_cast<std::int32_t>(t);
    const std::int32_t sortable = bits ^ static_cast<std::int32_t>(static_cast<std::uint32_t>(bits >> 31) >> 1);
    return (sortable & ~7) | slot;
}

/// A leaf the walk entered: its first packet or record and how many (WideNode's child, count).
struct LeafRef {
    std::uint32_t first, count;
};
static_assert(sizeof(LeafRef) == 8);

/// The portable node test (SSE, or scalar without it).
struct BaseNodeTest {
    /// Writes v[c] for each slot c set in `mask`, in slot order, to out[0, popcount(mask)) and
    /// returns how many (out has room for kWideWidth); compress_pairs writes (a[c], b[c]).
    SYLVA_FORCEINLINE static int compress(const std::uint32_t v[kWideWidth], int mask, std::uint32_t* out) {
        int k = 0;
        for (int m = mask; m != 0; m &= m - 1) out[k++] = v[std::countr_zero(static_cast<unsigned>(m))];
        return k;
    }
    SYLVA_FORCEINLINE static int compress_pairs(const std::uint32_t a[kWideWidth], const std::uint32_t b[kWideWidth],
                                                int mask, LeafRef* out) {
        int k = 0;
        for (int m = mask; m != 0; m &= m - 1) {
            const int c = std::countr_zero(static_cast<unsigned>(m));
            out[k++] = {a[c], b[c]};
        }
        return k;
    }
    SYLVA_FORCEINLINE static int enter(const WideNode& n, const WideRay& r, float t0, float t1,
                                       float tn_out[kWideWidth]) {
        return enter_children(n, r, t0, t1, tn_out);
    }
    /// rank[c] for each slot c of `slots`: how many slots of `slots` are entered later than c
    /// (by entry_key), so 0 is the farthest; each other slot gets the number of `slots`.
    SYLVA_FORCEINLINE static void rank_far_first(const float tn[kWideWidth], int slots, int rank[kWideWidth]) {
        std::int32_t key[kWideWidth];
        for (int c = 0; c < kWideWidth; ++c) key[c] = (slots >> c) & 1 ? entry_key(tn[c], c) : INT_MIN;
        for (int c = 0; c < kWideWidth; ++c) {
            int later = 0;
            for (int j = 0; j < kWideWidth; ++j) later += key[j] > key[c] ? 1 : 0;
            rank[c] = later;
        }
    }
};

#ifdef SYLVA_BIH_WIDE_AVX2
/// enter_children's arithmetic on all eight slots at once: the same operations lane by lane
/// (subtract, multiply, maxps / minps keeping the second operand on NaN, ordered <=), so the
/// same mask and entry t bit for bit. Only called from walks compiled for AVX2.
struct Avx2NodeTest {
    /// For each 8-bit mask, the slots whose bit is set in ascending order, one per byte from the
    /// lowest (the rest 0): the lane permutation that moves the chosen lanes to the front.
    static constexpr auto kCompress = [] {
        std::array<std::uint64_t, 256> lut{};
        for (unsigned m = 0; m < 256; ++m) {
            std::uint64_t lanes = 0;
            int k = 0;
            for (unsigned c = 0; c < 8; ++c)
                if (m & (1u << c)) lanes |= std::uint64_t{c} << (8 * k++);
            lut[m] = lanes;
        }
        return lut;
    }();
    [[gnu::target("avx2")]] static inline __m256i compress_order(int mask) {
        return _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(kCompress[static_cast<unsigned>(mask)])));
    }
    /// BaseNodeTest::compress with one permutation and one store (out has room for 8 lanes).
    [[gnu::target("avx2")]] static inline int compress(const std::uint32_t v[kWideWidth], int mask,
                                                       std::uint32_t* out) {
        const __m256i x = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), _mm256_permutevar8x32_epi32(x, compress_order(mask)));
        return std::popcount(static_cast<unsigned>(mask));
    }
    /// BaseNodeTest::compress_pairs: both permuted alike, then interleaved (out has room for 16).
    [[gnu::target("avx2")]] static inline int compress_pairs(const std::uint32_t a[kWideWidth],
                                                             const std::uint32_t b[kWideWidth], int mask,
                                                             LeafRef* out) {
        // The permutation also spreads the lanes as unpacklo / unpackhi want them: 0 1 4 5 | 2 3 6 7.
        const __m256i spread = _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7);
        const __m256i order = _mm256_permutevar8x32_epi32(compress_order(mask), spread);
        const __m256i x = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(a)), order);
        const __m256i y = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(b)), order);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), _mm256_unpacklo_epi32(x, y));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + 4), _mm256_unpackhi_epi32(x, y));
        return std::popcount(static_cast<unsigned>(mask));
    }
    [[gnu::target("avx2")]] static inline int enter(const WideNode& n, const WideRay& r, float t0, float t1,
                                                    float tn_out[kWideWidth]) {
        __m256 tn = _mm256_set1_ps(t0), tf = _mm256_set1_ps(t1);
        for (int a = 0; a < 3; ++a) {
            __m256 o = _mm256_set1_ps(r.org[a]), k = _mm256_set1_ps(r.rcp[a]);
            __m256 lo = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.box[r.near_row[a]]), o), k);
            __m256 hi = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.box[r.far_row[a]]), o), k);
            tn = _mm256_max_ps(lo, tn);
            tf = _mm256_min_ps(hi, tf);
        }
        if (tn_out) _mm256_storeu_ps(tn_out, tn);
        return _mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ));
    }
    /// BaseNodeTest::rank_far_first's ranks (the same entry_key, so the same order), without a
    /// branch: each slot's key against the eight broadcast keys.
    [[gnu::target("avx2")]] static inline void rank_far_first(const float tn[kWideWidth], int slots,
                                                             int rank[kWideWidth]) {
        const __m256i bits = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(tn));
        __m256i key = _mm256_xor_si256(bits, _mm256_srli_epi32(_mm256_srai_epi32(bits, 31), 1));
        key = _mm256_or_si256(_mm256_and_si256(key, _mm256_set1_epi32(~7)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        const __m256i in = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(slots), bit), bit);
        key = _mm256_blendv_epi8(_mm256_set1_epi32(INT_MIN), key, in);
        __m256i later = _mm256_setzero_si256();
        for (int j = 0; j < kWideWidth; ++j)
            later = _mm256_sub_epi32(later, _mm256_cmpgt_epi32(_mm256_permutevar8x32_epi32(key, _mm256_set1_epi32(j)), key));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(rank), later);
    }
};

/// Whether this CPU (and its OS) runs AVX2 code; asked once.
inline bool cpu_has_avx2() {
    static const bool yes = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") != 0;
    }();
    return yes;
}
#endif

}  // namespace detail

/// A BIH collapsed into 8-wide nodes for host queries (see the top of this file). Holds its
/// own copy of the elements in leaf order, so the caller's array may go; element indices in
/// the hits are the caller's.
template <Intersectable E>
class WideTree {
public:
    static constexpr bool kSpheres = std::is_same_v<E, Sphere>;

    WideTree() = default;
    /// Collapses `tree` (built over `elements`): the copy of the elements runs in parallel on
    /// `exec`, and from 2^15 BIH nodes on so do the refit and the wide nodes below the top two
    /// levels (the tree is the same on any executor but for the order of its nodes and records). Throws sylva::Error when the
    /// tree does not fit the elements (a link out of range, a node reached twice, a leaf past
    /// the order, an element index out of range, a BIH deeper than SYLVA_BIH_DEPTH_CAP + 1
    /// levels, the builder's cap).
    template <Executor X>
    WideTree(const Tree& tree, std::span<const E> elements, const WideConfig& cfg, X& exec) {
        for (std::uint32_t e : tree.order)
            if (e >= elements.size())
                throw Error("bih::WideTree: the tree's order refers to element " + std::to_string(e) + " of the " +
                            std::to_string(elements.size()) + " given");
        if (tree.nodes.empty() || tree.order.empty()) return;
        Builder b{*this, tree, elements, cfg.leaf_size(tree.order.size()), {}, {}, 0, {}};
        b.refit(exec);
        b.make(exec);
        b.fill(exec);
        stats_.nodes = nodes_.size();
        stats_.bytes = nodes_.size() * sizeof(WideNode) + ids_.size() * sizeof(std::uint32_t) +
                       records_.size() * sizeof(Record);
    }

    /// The same on the calling thread.
    WideTree(const Tree& tree, std::span<const E> elements, const WideConfig& cfg = {})
        : WideTree(tree, elements, cfg, serial()) {}

    /// A leaf a walk entered: (first packet or record, how many), as for_each_leaf_any_order gives them.
    using LeafRef = detail::LeafRef;

    [[nodiscard]] const WideStats& stats() const { return stats_; }
    [[nodiscard]] std::span<const WideNode> nodes() const { return nodes_; }

    /// Calls on_leaf(first, count) for each leaf the ray's [range] enters, skipping those entered
    /// after `limit()` (re-read before each leaf: first-hit pruning). Inner nodes are walked
    /// nearest entry first; a node's entered leaves come in slot order as soon as the node is
    /// tested, so leaves are not sorted by entry (a caller keeps the best hit it has seen).
    template <class Limit, class OnLeaf>
    void for_each_leaf(const Ray& ray, Interval range, Limit&& limit, OnLeaf&& on_leaf) const {
        if (nodes_.empty() || range.empty()) return;
#ifdef SYLVA_BIH_WIDE_AVX2
        if (detail::cpu_has_avx2()) return nearest_first_avx2(ray, range, limit, on_leaf);
#endif
        nearest_first<detail::BaseNodeTest>(ray, range, limit, on_leaf);
    }

    /// Calls on_leaves(const LeafRef* leaves, n) with batches of the leaves (first, count) the ray's [range]
    /// enters, in no particular order (for queries that sort their hits anyway). The walk only
    /// gathers leaves; testing them in batches keeps the walk's branches independent of what
    /// the leaves hold, and lets the batch's loads and tests overlap.
    template <class OnLeaves>
    void for_each_leaf_any_order(const Ray& ray, Interval range, OnLeaves&& on_leaves) const {
        if (nodes_.empty() || range.empty()) return;
#ifdef SYLVA_BIH_WIDE_AVX2
        if (detail::cpu_has_avx2()) return any_order_avx2(ray, range, on_leaves);
#endif
        any_order<detail::BaseNodeTest>(ray, range, on_leaves);
    }

private:
#ifdef SYLVA_BIH_WIDE_AVX2
    template <class Limit, class OnLeaf>
    [[gnu::target("avx2")]] void nearest_first_avx2(const Ray& ray, Interval range, Limit& limit,
                                                    OnLeaf& on_leaf) const {
        nearest_first<detail::Avx2NodeTest>(ray, range, limit, on_leaf);
    }
    template <class OnLeaves>
    [[gnu::target("avx2")]] void any_order_avx2(const Ray& ray, Interval range, OnLeaves& on_leaves) const {
        any_order<detail::Avx2NodeTest>(ray, range, on_leaves);
    }
#endif

    /// for_each_leaf's walk with node test Test (inlined into each caller, so that the
    /// AVX2 caller compiles all of it for AVX2).
    template <class Test, class Limit, class OnLeaf>
    SYLVA_FORCEINLINE void nearest_first(const Ray& ray, Interval range, Limit& limit, OnLeaf& on_leaf) const {
        detail::WideRay r(ray);
        struct Entry {
            std::uint32_t node;
            float tn;
        };
        Entry stack[kStack];
        std::uint32_t sp = 0;
        std::uint32_t node = 0;  // the node to test next; the stack holds the ones after it
        for (;;) {
            const WideNode& n = nodes_[node];
            float tn[kWideWidth];
            const int mask = Test::enter(n, r, range.t0, std::min(range.t1, limit()), tn);
            // The entered leaves first, in slot order, their loads issued together: testing
            // them here instead of pushing them nearest first costs a packet test where a
            // nearer hit would have pruned one, and saves their sorts, pushes and pops and
            // the wait on each leaf's load right after its push. Measured on one thread (best
            // of 7 passes of 2e5 rays, three alternating rounds): as fast at 1e4 and 1e6, and
            // with leaves of 8 (WideConfig) 1.05-1.1x at 1e5. Handing a node's leaves to
            // batch_hits' branch-free prefilter instead was no faster.
            const int leaves = mask & leaf_mask(n);
            for (int m = leaves; m != 0; m &= m - 1) detail::prefetch(&records_[n.child[lowest_bit(m)]]);
            for (int m = leaves; m != 0; m &= m - 1) {
                const int c = lowest_bit(m);
                if (tn[c] <= limit()) on_leaf(n.child[c], n.count[c]);
            }
            // The next node is the nearest entered inner child, taken without a push and a pop
            // (as Embree's walk does); the others go on the stack farthest first. One or two
            // entered children, the common cases, need no sort.
            int inner = mask & ~leaves;
            if (inner != 0) {
                const int c0 = lowest_bit(inner);
                inner &= inner - 1;
                if (inner == 0) {  // one child
                    if (tn[c0] <= limit()) {
                        node = n.child[c0];
                        continue;
                    }
                } else if ((inner & (inner - 1)) == 0) {  // two children
                    const int c1 = lowest_bit(inner);
                    const bool swap = tn[c1] < tn[c0];  // a select, not a branch
                    const int near = swap ? c1 : c0, far = swap ? c0 : c1;
                    prefetch_node(n.child[far]);
                    stack[sp++] = {n.child[far], tn[far]};
                    node = n.child[near];
                    continue;
                } else {  // three or more: pushed farthest first, the nearest not pushed
                    int rank[kWideWidth];
                    Test::rank_far_first(tn, mask & ~leaves, rank);
                    int k = 0;
                    for (int m = mask & ~leaves; m != 0; m &= m - 1, ++k) {
                        const int c = lowest_bit(m);
                        prefetch_node(n.child[c]);
                        stack[sp + static_cast<std::uint32_t>(rank[c])] = {n.child[c], tn[c]};
                    }
                    sp += static_cast<std::uint32_t>(k - 1);
                    node = stack[sp].node;
                    continue;
                }
            }
            // Nothing to descend into: the nearest pending node not beyond the best hit.
            for (;;) {
                if (sp == 0) return;
                const Entry e = stack[--sp];
                if (e.tn <= limit()) {
                    node = e.node;
                    break;
                }
            }
        }
    }

    /// for_each_leaf_any_order's walk with node test Test (see nearest_first).
    template <class Test, class OnLeaves>
    SYLVA_FORCEINLINE void any_order(const Ray& ray, Interval range, OnLeaves& on_leaves) const {
        detail::WideRay r(ray);
        // Inner nodes to test go into a FIFO queue, so that each is tested several nodes after
        // its prefetch went out; a LIFO stack would test next the child it has just prefetched
        // and wait on memory (measured: the walk alone 20-40 % faster at 1e5-1e6 spheres). A
        // node's entered children and leaves are appended with one permutation and store each
        // (Test::compress), not one branch a child: the queue is linear, with room for a whole
        // store past its end, and moves its pending nodes to the front when a node's children
        // would not fit. When they still do not fit, they go on a stack that is popped first: the
        // queue cannot drain while the stack holds nodes, so from then on the stack is a
        // depth-first stack under at most kWideWidth roots, and kStack bounds it as before.
        // Prefetching pays only for trees that do not stay in a core's cache: below kFarNodes
        // (1 MiB of nodes) the loop over the new children cost more than it saved (one thread,
        // 2e5 rays, alternating processes: at 10^4 spheres 0.43-0.55 -> 0.37-0.38 us a ray,
        // 10^5 1.24-1.54 -> 1.04-1.12 us; at 10^6 it saves 5-30 %).
        // In such trees the queue holds up to 256 nodes, else 64: with 64, a ray through 10^7
        // spheres overflowed it into the stack, whose nodes are not prefetched (sylva-bench
        // --cases all, two rounds alternating the binaries: all hits at 10^7 1.48-1.50x Embree
        // with 64, 1.64-1.66x with 256 for every tree; at 10^4-10^6 the same within the rounds'
        // spread, so the trees that do not prefetch keep 64).
        const bool far = nodes_.size() > kFarNodes;
        constexpr std::uint32_t kQueue = 256;
        const std::uint32_t queue_cap = far ? kQueue : 64u;
        std::uint32_t queue[kQueue + kWideWidth];  // pending: queue[head, tail), tail <= queue_cap
        std::uint32_t head = 0, tail = 0;
        std::uint32_t stack[kStack];
        std::uint32_t sp = 0, node = 0;
        // The leaves found are tested in batches of up to 64, 128 in prefetched trees (their
        // prefetches have longer to arrive: at 10^7 spheres, one thread, three alternating runs
        // of a throw-away probe, 20.2-21.0 -> 19.9-20.2 us a ray).
        constexpr std::uint32_t kFound = 128;
        const std::uint32_t found_cap = far ? kFound : 64u;
        LeafRef found[kFound];  // not zeroed: only [0, nf) is read
        std::uint32_t nf = 0;
        for (;;) {
            const WideNode& n = nodes_[node];
            const int mask = Test::enter(n, r, range.t0, range.t1, nullptr);  // entry t not needed
            const int leaves = mask & leaf_mask(n);
            const int inner = mask & ~leaves;
            // Both stores run for every node, also when it entered no inner child or no leaf
            // (they then store lanes past the end and count nothing): a branch on whether a
            // node has either is taken about half the time, unpredictably, and cost more than
            // the stores (one thread, 2e5 rays, alternating processes: clustered 10^4 spheres
            // 256 -> 199 ns a ray, clustered 10^5 622 -> 527, uniform 10^4 433 -> 401).
            const auto k = static_cast<std::uint32_t>(std::popcount(static_cast<unsigned>(inner)));
            if (tail + k > queue_cap && head != 0) {
                std::copy(queue + head, queue + tail, queue);
                tail -= head;
                head = 0;
            }
            if (tail + k <= queue_cap) {
                const std::uint32_t from = tail;
                tail += static_cast<std::uint32_t>(Test::compress(n.child, inner, queue + tail));
                if (far)
                    for (std::uint32_t j = from; j < tail; ++j) prefetch_node(queue[j]);
            } else {
                for (int m = inner; m != 0; m &= m - 1) stack[sp++] = n.child[lowest_bit(m)];
            }
            const std::uint32_t first_new = nf;
            nf += static_cast<std::uint32_t>(Test::compress_pairs(n.child, n.count, leaves, found + nf));
            if (far)
                for (std::uint32_t j = first_new; j < nf; ++j) detail::prefetch(&records_[found[j].first]);
            if (nf > found_cap - kWideWidth) {
                on_leaves(static_cast<const LeafRef*>(found), nf);
                nf = 0;
            }
            if (sp != 0)
                node = stack[--sp];
            else if (head != tail)
                node = queue[head++];
            else
                break;
        }
        on_leaves(static_cast<const LeafRef*>(found), nf);
    }

public:
    /// How much of the tree all_hits visits for one ray: wide nodes tested and leaves entered
    /// (for benchmarks and tests; the same walk as for_each_leaf_any_order).
    struct Visits {
        std::size_t nodes = 0, leaves = 0;
    };
    [[nodiscard]] Visits visits(const Ray& ray, Interval range = {}) const {
        Visits v;
        if (nodes_.empty() || range.empty()) return v;
        detail::WideRay r(ray);
        std::uint32_t stack[kStack];
        std::uint32_t sp = 0;
        stack[sp++] = 0;
        while (sp > 0) {
            const WideNode& n = nodes_[stack[--sp]];
            ++v.nodes;
            float tn[kWideWidth];
            int mask = detail::enter_children(n, r, range.t0, range.t1, tn);
            for (int c = 0; c < kWideWidth; ++c)
                if (mask & (1 << c)) {
                    if (n.count[c])
                        ++v.leaves;
                    else
                        stack[sp++] = n.child[c];
                }
        }
        return v;
    }

    /// Calls f(element index) for each element of a leaf (first, count), in leaf order.
    template <class F>
    void for_each_leaf_element(std::uint32_t first, std::uint32_t count, F&& f) const {
        constexpr std::uint32_t per_record = kSpheres ? 4u : 1u;
        for (std::size_t k = std::size_t{first} * per_record; k < (std::size_t{first} + count) * per_record; ++k)
            if (ids_[k] != kNoChild) f(ids_[k]);
    }

    /// What leaf_hits needs of the ray, made once per ray.
    using Probe = std::conditional_t<kSpheres, detail::SphereProbe, std::pair<Ray, Interval>>;
    [[nodiscard]] static Probe probe(const Ray& ray, Interval range) { return Probe(ray, range); }

    /// Calls sink(ElementHit) for each element of a leaf (first, count) the ray hits in range.
    template <class Sink>
    SYLVA_FORCEINLINE void leaf_hits(std::uint32_t first, std::uint32_t count, const Probe& p, Sink&& sink) const {
        if constexpr (kSpheres) {
#ifdef SYLVA_BIH_QUERY_SSE
            if (!p.valid) return;
            for (std::uint32_t k = first; k < first + count; ++k) {
                const SpherePacket& s = records_[k];
                __m128 t0, t1;
                int mask = detail::sphere4(p, _mm_load_ps(s.c[0]), _mm_load_ps(s.c[1]), _mm_load_ps(s.c[2]),
                                           _mm_load_ps(s.r), t0, t1);
                if (!mask) continue;
                alignas(16) float lo[4], hi[4];
                _mm_store_ps(lo, t0);
                _mm_store_ps(hi, t1);
                for (; mask != 0; mask &= mask - 1) {
                    int lane = lowest_bit(mask);
                    std::size_t id_at = std::size_t{k} * 4u + static_cast<std::size_t>(lane);
                    sink(ElementHit{ids_[id_at], Interval{lo[lane], hi[lane]}});
                }
            }
#else
            for (std::uint32_t k = first; k < first + count; ++k)
                for (int lane = 0; lane < 4; ++lane) {
                    const SpherePacket& s = records_[k];
                    Sphere sp;
                    sp.center = vec3(s.c[0][lane], s.c[1][lane], s.c[2][lane]);
                    sp.radius = s.r[lane];
                    std::size_t id_at = std::size_t{k} * 4u + static_cast<std::size_t>(lane);
                    if (sp.radius > 0.0f)
                        if (auto t = sp.intersect(p.ray, p.range)) sink(ElementHit{ids_[id_at], *t});
                }
#endif
        } else {
            for (std::uint32_t k = first; k < first + count; ++k)
                if (auto t = intersect_element(records_[k], p.first, p.second)) sink(ElementHit{ids_[k], *t});
        }
    }

    /// Calls sink(ElementHit) for each element hit in a batch of leaves (from
    /// for_each_leaf_any_order). Spheres in two passes: a branch-free prefilter over every
    /// packet (the division and the distance, overlapping from packet to packet), then the
    /// exact test of the few packets some sphere of which may be hit.
    template <class Sink>
    void batch_hits(const LeafRef* leaves, std::uint32_t n, const Probe& p, Sink&& sink) const {
#ifdef SYLVA_BIH_QUERY_SSE
        if constexpr (kSpheres) {
            if (!p.valid) return;
            constexpr std::uint32_t kCap = 128;
            std::uint32_t cand[kCap], nc = 0;
            auto test_candidates = [&] {
                for (std::uint32_t j = 0; j < nc; ++j) leaf_hits(cand[j], 1u, p, sink);
                nc = 0;
            };
            for (std::uint32_t i = 0; i < n; ++i)
                for (std::uint32_t k = leaves[i].first; k < leaves[i].first + leaves[i].count; ++k) {
                    const SpherePacket& s = records_[k];
                    cand[nc] = k;
                    nc += detail::sphere4_maybe(p, _mm_load_ps(s.c[0]), _mm_load_ps(s.c[1]), _mm_load_ps(s.c[2]),
                                                _mm_load_ps(s.r)) != 0
                              ? 1u
                              : 0u;
                    if (nc == kCap) test_candidates();
                }
            test_candidates();
            return;
        }
#endif
        for (std::uint32_t i = 0; i < n; ++i) leaf_hits(leaves[i].first, leaves[i].count, p, sink);
    }

private:
    static SerialExecutor& serial() {
        static SerialExecutor s;  // stateless
        return s;
    }

    /// Bit c set when slot c of n is a leaf (count != 0).
    static int leaf_mask(const WideNode& n) {
#ifdef SYLVA_BIH_QUERY_SSE
        int m = 0;
        for (int g = 0; g < kWideWidth; g += 4) {
            __m128i counts = _mm_load_si128(reinterpret_cast<const __m128i*>(n.count + g));
            __m128i zero = _mm_cmpeq_epi32(counts, _mm_setzero_si128());
            m |= (~_mm_movemask_ps(_mm_castsi128_ps(zero)) & 15) << g;
        }
        return m;
#else
        int m = 0;
        for (int c = 0; c < kWideWidth; ++c) m |= n.count[c] ? (1 << c) : 0;
        return m;
#endif
    }
    static int lowest_bit(int m) {
#if defined(__GNUC__) || defined(__clang__)
        return __builtin_ctz(static_cast<unsigned>(m));
#else
        int c = 0;
        while (!(m & (1 << c))) ++c;
        return c;
#endif
    }
    void prefetch_node(std::uint32_t i) const {
        for (std::size_t line = 0; line < sizeof(WideNode); line += 64)
            detail::prefetch(reinterpret_cast<const char*>(&nodes_[i]) + line);
    }

    using Record = std::conditional_t<kSpheres, SpherePacket, E>;
    /// Stack bound: the wide depth is at most the BIH's (kMaxDepth levels, checked when the tree
    /// is made), and each level leaves at most kWideWidth - 1 siblings behind.
    static constexpr std::uint32_t kMaxDepth = SYLVA_BIH_DEPTH_CAP + 1u;
    static constexpr std::uint32_t kStack = (kWideWidth - 1u) * kMaxDepth + kWideWidth;
    /// From this many nodes (1 MiB) any_order prefetches the nodes and leaves it finds.
    static constexpr std::size_t kFarNodes = (std::size_t{1} << 20) / sizeof(WideNode);

    struct Builder {
        WideTree& out;
        const Tree& tree;
        std::span<const E> elements;
        std::uint32_t leaf_size;  ///< WideConfig::leaf_size for this tree
        LargeVector<detail::SubtreeFacts> facts;
        /// A leaf's records to fill: from record `record`, the elements order[first, first + count).
        struct LeafJob {
            std::uint32_t record, first, count;
        };
        LargeVector<LeafJob> jobs;  ///< from 16 KiB (~1,400 leaves) a warm block of LargeAllocator's cache
        std::uint32_t records = 0;  ///< records (sphere packets or elements) handed out so far

        /// Centres and radii of the spheres in the tree's order (sorted[k] = elements[order[k]]'s):
        /// gathered once, in parallel, so that the leaves' boxes and the packets read them in
        /// sequence instead of each making a random read per sphere (measured at 10^6 spheres:
        /// the two random passes were 26 of the collapse's 69 ms). 16 bytes a sphere, not the
        /// Sphere's 36 (its colour and falloff are not needed here), and not zeroed first: the
        /// collapse of 10^6 spheres on two threads 27.8-29.2 -> 22.9-23.3 ms (10^5: 2.66-2.92 ->
        /// 2.41-2.48). Absent for other element types and small trees (parallel()), whose
        /// elements stay in cache: there the copy only cost a first build.
        std::optional<memory::LargeBuffer<SphereRecord>> sorted;
        /// Centre and radius of sphere k of the tree's order.
        [[nodiscard]] SphereRecord sphere_at(std::size_t k) const
            requires kSpheres
        {
            return sorted ? sorted->data()[k] : SphereRecord::of(elements[tree.order[k]]);
        }
        /// Box of element k of the tree's order (for spheres Sphere::bounds, so the same bits).
        [[nodiscard]] Aabb bounds_at(std::size_t k) const {
            if constexpr (kSpheres) {
                return sphere_at(k).bounds();
            } else {
                return bounds_of(elements[tree.order[k]]);
            }
        }

        /// Tight boxes, counts, order ranges and the collapse's choice of every BIH subtree the
        /// root reaches, children before parents (subtree_facts), after the links are checked
        /// (check_links).
        template <class X>
        void refit(X& exec) {
            // Scratch of the collapse (sorted, facts, has_parent: written once, read once) keeps
            // 4 KiB pages where their faults are cheap, as the builder's arrays do; the query
            // arrays (nodes_, records_, ids_) stay advised huge pages (TLB reach).
            memory::SmallPagesWhereCheap small_pages;
            if constexpr (kSpheres) {
                if (parallel()) {
                    memory::prefault<SphereRecord>(tree.order.size(), exec);  // its pages faulted on all threads
                    sorted.emplace(tree.order.size());
                    SphereRecord* out = sorted->data();
                    exec.parallel_for(0, tree.order.size(), 16384, [&](std::size_t lo, std::size_t hi) {
                        for (std::size_t k = lo; k < hi; ++k) out[k] = SphereRecord::of(elements[tree.order[k]]);
                    });
                }
            }
            memory::prefault<detail::SubtreeFacts>(tree.nodes.size(), exec);
            facts.assign(tree.nodes.size(), {});
            check_links();
            (void)subtree_facts(0, 0, parallel() ? kParallelDepth : 0u, exec);
        }

        /// Throws when a link leaves the tree or a node is reached twice (a cycle, a shared
        /// child): then every node has at most one parent and the root none, so what the root
        /// reaches is a tree, and subtree_facts ends.
        void check_links() const {
            const auto size = static_cast<std::uint32_t>(tree.nodes.size());
            LargeVector<std::uint8_t> has_parent(size, 0);
            for (std::uint32_t n = 0; n < size; ++n)
                for (std::uint32_t c : children(n)) {
                    check_node(c);
                    if (has_parent[c] != 0 || c == 0)
                        throw Error("bih::WideTree: node " + std::to_string(c) + " is reached twice (not a tree)");
                    has_parent[c] = 1;
                }
        }

        /// Trees of fewer BIH nodes are refitted, collapsed and filled on the calling thread,
        /// without the sorted copy: at 10^4 spheres (7,000 nodes) handing out the work cost more
        /// than it saved. 2^13: the collapse of a WideTree's source BIH over 10^5 clustered
        /// spheres (about 27,000 nodes, which 2^15 kept on one thread) took 3.6 ms, 2.3 ms from
        /// 2^13 (two threads; the refit 2.3 -> 1.3 ms, most of it the sorted copy's sequential
        /// reads: 2.7 ms on one thread), and 2^12 brought 10^4 spheres the parallel make and
        /// made it slower (0.08 -> 0.15 ms; throw-away probe timing the three steps, 40 collapses
        /// each, 2 ms apart).
        static constexpr std::size_t kParallelNodes = std::size_t{1} << 13;
        [[nodiscard]] bool parallel() const { return tree.nodes.size() >= kParallelNodes; }
        /// Levels of the BIH whose two subtrees subtree_facts refits in parallel.
        static constexpr std::uint32_t kParallelDepth = 6;

        /// Fills facts for BIH subtree n (at BIH depth `depth`), children first, and returns its
        /// costs (for its parent's); below a depth of `fork` (0: none) the two subtrees run in
        /// parallel on `exec`.
        template <class X>
        detail::SlotCosts subtree_facts(std::uint32_t n, std::uint32_t depth, std::uint32_t fork, X& exec) {
            if (depth > kMaxDepth)
                throw Error("bih::WideTree: the tree is deeper than " + std::to_string(SYLVA_BIH_DEPTH_CAP) +
                            " levels (the builder's cap)");
            const Node& node = tree.nodes[n];
            detail::SlotCosts kid[2];  // the costs of children(n), in its order
            if (node.leaf()) {
                if (std::uint64_t{node.first} + node.count > tree.order.size())
                    throw Error("bih::WideTree: leaf " + std::to_string(n) + " refers past the tree's order");
            } else {
                const Kids k = children(n);
                if (k.n == 2 && depth < fork)
                    exec.invoke([&] { kid[0] = subtree_facts(k.id[0], depth + 1, fork, exec); },
                                [&] { kid[1] = subtree_facts(k.id[1], depth + 1, fork, exec); });
                else
                    for (std::uint32_t i = 0; i < k.n; ++i) kid[i] = subtree_facts(k.id[i], depth + 1, fork, exec);
            }
            facts[n] = fact_of(n);
            const detail::SlotCosts c = costs_of(n, kid);
            facts[n].set_choice(c);
            return c;
        }

        void check_node(std::uint32_t n) const {
            if (n >= tree.nodes.size())
                throw Error("bih::WideTree: a node links to node " + std::to_string(n) + " of " +
                            std::to_string(tree.nodes.size()));
        }

        /// The non-empty children of an inner BIH node (at most two; none for a leaf).
        struct Kids {
            std::uint32_t id[2];
            std::uint32_t n = 0;
            [[nodiscard]] const std::uint32_t* begin() const { return id; }
            [[nodiscard]] const std::uint32_t* end() const { return id + n; }
        };
        [[nodiscard]] SYLVA_FORCEINLINE Kids children(std::uint32_t n) const {
            const Node& node = tree.nodes[n];
            Kids k{};
            if (node.leaf()) return k;
            for (int s = 0; s < (node.single ? 1 : 2); ++s)
                if (node.child[s] != kNoChild) k.id[k.n++] = node.child[s];
            return k;
        }

        [[nodiscard]] detail::SubtreeFacts fact_of(std::uint32_t n) const {
            const Node& node = tree.nodes[n];
            detail::SubtreeFacts f;
            if (node.leaf()) {  // its range was checked by refit
                f.first = node.first;
                f.count = node.count;
                for (std::uint32_t k = node.first; k < node.first + node.count; ++k)
                    f.box.extend(bounds_at(k));
                return f;
            }
            std::uint32_t lo = std::numeric_limits<std::uint32_t>::max(), hi = 0;
            bool contiguous = true;
            for (std::uint32_t c : children(n)) {
                const detail::SubtreeFacts& k = facts[c];
                f.box.extend(k.box);
                f.count += k.count;
                contiguous = contiguous && k.contiguous();
                if (k.count) {
                    lo = std::min(lo, k.first);
                    hi = std::max(hi, k.first + k.count);
                }
            }
            f.first = f.count ? lo : 0u;
            f.set_contiguous(contiguous && (f.count == 0 || hi - lo == f.count));
            return f;
        }

        /// A subtree that becomes one leaf: a BIH leaf, or a small contiguous subtree.
        [[nodiscard]] SYLVA_FORCEINLINE bool leaf_like(std::uint32_t n) const {
            const detail::SubtreeFacts& f = facts[n];
            return tree.nodes[n].leaf() || (f.contiguous() && f.count <= leaf_size);
        }

        /// The non-empty children of BIH node n (none for a leaf).
        [[nodiscard]] SYLVA_FORCEINLINE Kids spread_kids(std::uint32_t n) const {
            Kids k{};
            for (std::uint32_t c : children(n))
                if (facts[c].count != 0) k.id[k.n++] = c;
            return k;
        }

        /// Subtree n's costs from those of children(n), `kid` in its order (facts[n] and the
        /// children's written): least[j - 1] = min(least[0], the least sum over a of the first
        /// non-empty child's least[a - 1] and the second's least[j - a - 1]).
        [[nodiscard]] detail::SlotCosts costs_of(std::uint32_t n, const detail::SlotCosts* kid) const {
            using detail::SlotCosts;
            SlotCosts out{};
            if (leaf_like(n) || facts[n].count == 0) {  // kLeaf, cost 0
                out.leaves = 1;
                return out;
            }
            const SlotCosts* spread_kid[2];  // spread_kids(n)'s costs
            std::uint32_t spread_n = 0;
            const Kids all = children(n);
            for (std::uint32_t i = 0; i < all.n; ++i)
                if (facts[all.id[i]].count != 0) spread_kid[spread_n++] = &kid[i];
            if (spread_n == 1) {
                out = *spread_kid[0];
                out.kind = SlotCosts::kChain;
                return out;
            }
            const SlotCosts& l = *spread_kid[0];
            const SlotCosts& r = *spread_kid[1];
            float spread[kWideWidth + 1];  // spread[j]: the least cost over j slots, j >= 2
            std::uint8_t share[kWideWidth + 1];
            const int flat = l.leaves + r.leaves;  // from this many slots on: every leaf in one
            out.leaves = static_cast<std::uint8_t>(std::min(flat, kWideWidth));
            for (int j = 2; j <= kWideWidth; ++j) {
                if (j >= flat) {  // most nodes, those near the leaves: no search
                    spread[j] = 0.0f;
                    share[j] = l.leaves;
                    continue;
                }
                spread[j] = std::numeric_limits<float>::infinity();
                share[j] = 1;  // where every sum is inf (areas overflowing float)
                for (int a = 1; a < j; ++a) {  // no branch: the compares do not predict
                    const float c = l.least[a - 1] + r.least[j - a - 1];
                    const bool less = c < spread[j];
                    spread[j] = less ? c : spread[j];
                    share[j] = less ? static_cast<std::uint8_t>(a) : share[j];
                }
            }
            out.kind = SlotCosts::kSpread;
            out.spread = share[kWideWidth];
            out.least[0] = facts[n].box.half_area() + spread[kWideWidth];  // a wide node here
            for (int j = 2; j <= kWideWidth; ++j) {
                const bool one = out.least[0] <= spread[j];
                out.least[j - 1] = one ? out.least[0] : spread[j];
                out.split[j - 1] = one ? 0 : share[j];
            }
            return out;
        }

        /// Appends the slots (BIH subtrees) of the least-cost spread of subtree c over at most
        /// j slots to slots[used...]: c itself where one slot is cheapest, else its children's.
        void take(std::uint32_t c, int j, std::uint32_t* slots, std::size_t& used) const {
            const detail::SubtreeFacts& f = facts[c];
            if (f.kind() == detail::SlotCosts::kChain) {
                take(spread_kids(c).id[0], j, slots, used);
            } else if (f.kind() == detail::SlotCosts::kLeaf || j < 2 || f.split(j) == 0) {
                slots[used++] = c;
            } else {
                spread_over(c, f.split(j), j, slots, used);
            }
        }

        /// Subtree n's two children over `first` and j - first slots.
        void spread_over(std::uint32_t n, int first, int j, std::uint32_t* slots, std::size_t& used) const {
            const Kids k = spread_kids(n);
            take(k.id[0], first, slots, used);
            take(k.id[1], j - first, slots, used);
        }

        /// The slots of a wide node made at (non-leaf-like) BIH node n: the least-cost spread of its
        /// subtree over kWideWidth slots (one slot is not a choice here).
        void node_slots(std::uint32_t n, std::uint32_t* slots, std::size_t& used) const {
            while (facts[n].kind() == detail::SlotCosts::kChain) n = spread_kids(n).id[0];
            if (facts[n].kind() == detail::SlotCosts::kLeaf) {  // a chain to one leaf (a big BIH leaf)
                slots[used++] = n;
                return;
            }
            spread_over(n, facts[n].spread(), kWideWidth, slots, used);
        }

        /// Wide nodes, leaf jobs and record count of one piece of the collapse: the top of the
        /// tree, or one subtree below it. With a parallel executor the subtrees whose wide
        /// nodes would start at depth kDeferDepth (up to 64) are made in parallel, each into a
        /// part of its own, and appended to the top with their links shifted (make_node waits
        /// on memory, facts being tens of MB: at 10^6 spheres 12 ms on two threads against 21 on one).
        /// On one thread, and for small trees, the top is all of it, in the order the serial
        /// walk has always given.
        struct Part {
            struct Deferred {
                std::uint32_t at;  ///< wide node of the top whose slot links to the subtree
                int slot;
                std::uint32_t n, depth;  ///< BIH node and wide depth of the subtree's root
            };
            /// A LargeVector when the top is all of it (it becomes the tree's array); in a
            /// parallel collapse a run of make()'s arena, as the BIH builder's chunks are
            /// (faults: below).
            memory::RunOrVector<WideNode> nodes;
            LargeVector<LeafJob> jobs;
            std::vector<Deferred> deferred;
            std::uint32_t records = 0;
            std::uint32_t depth = 0;  ///< deepest wide level, the tree's root at 1
            std::size_t leaves = 0;
            std::uint32_t defer_depth = 0;  ///< 0: make everything here
        };
        static constexpr std::uint32_t kDeferDepth = 3;

        /// About how many wide nodes a subtree of `count` elements becomes (measured on uniform
        /// spheres: 730 for 10^4 at leaves of 4, 8,657 for 10^5, 37,752 for 10^6 at leaves of
        /// 8), a little more than that: the room its node array starts with.
        [[nodiscard]] std::size_t expected_nodes(std::size_t count) const {
            return count / (3u * leaf_size) + 16u;
        }

        template <class X>
        void make(X& exec) {
            if (facts[0].count == 0) return;  // no elements under the root: nothing to hit
            Part top;
            top.defer_depth = exec.concurrency() > 1 && parallel() ? kDeferDepth : 0u;
            // The parts of a parallel collapse grow at once on several threads: as vectors
            // doubling from nothing they were fresh 4 KiB pages every time (at 10^5 spheres
            // about 1,000 faults, most of the collapse's time on a VM where a fault costs
            // ~10 us). In an arena their blocks come from LargeAllocator's cache, warm from the
            // last collapse; blocks of about 1/8 of the nodes expected, 1-64 MiB, in 4 KiB pages where
            // those fault cheaply (scratch, as the builder's chunks).
            std::optional<memory::RunArena<WideNode>> arena;
            if (top.defer_depth != 0) {
                memory::SmallPagesWhereCheap scratch;  // written once, read once by append()
                const std::size_t large = memory::kArenaBlock / sizeof(WideNode);
                arena.emplace(std::clamp<std::size_t>(expected_nodes(facts[0].count) / 8, large,
                                                      (std::size_t{64} << 20) / sizeof(WideNode)));
            }
            memory::RunArena<WideNode>* runs = arena ? &*arena : nullptr;
            top.nodes.start(runs, top.defer_depth != 0 ? 64u : expected_nodes(facts[0].count));
            top.nodes.push_back(blank());
            if (leaf_like(0)) {
                set_slot(top, 0, 0, 0);
                top.depth = 1;
            } else {
                make_node(top, 0, 0, 1);
            }
            top.nodes.close();
            if (top.deferred.empty() && !top.nodes.in_arena()) {  // all of it: taken as it is, not copied
                out.nodes_ = std::move(top.nodes.vector());
                jobs = std::move(top.jobs);
                records = top.records;
                out.stats_.depth = top.depth;
                out.stats_.leaves = top.leaves;
                return;
            }
            std::vector<Part> parts(top.deferred.size());
            exec.parallel_for(0, parts.size(), 1, [&](std::size_t lo, std::size_t hi) {
                for (std::size_t k = lo; k < hi; ++k) {
                    const typename Part::Deferred& d = top.deferred[k];
                    parts[k].nodes.start(runs, expected_nodes(facts[d.n].count));
                    parts[k].nodes.push_back(blank());
                    make_node(parts[k], 0, d.n, d.depth);
                    parts[k].nodes.close();
                }
            });
            std::size_t nodes = top.nodes.size(), leaves = top.jobs.size();
            for (const Part& p : parts) {
                nodes += p.nodes.size();
                leaves += p.jobs.size();
            }
            memory::prefault<WideNode>(nodes, exec);  // append writes them on one thread
            out.nodes_.reserve(nodes);
            {
                memory::SmallPagesWhereCheap scratch;  // written once, read once by fill()
                jobs.reserve(leaves);
            }
            append(top);
            for (std::size_t k = 0; k < parts.size(); ++k) {
                const typename Part::Deferred& d = top.deferred[k];
                out.nodes_[d.at].child[d.slot] = append(parts[k]);
            }
        }

        /// Appends part p to the tree: its nodes with their links shifted past the nodes and
        /// records already there, its leaves' jobs, its counts. Returns the index of its node 0.
        std::uint32_t append(const Part& p) {
            const auto base = static_cast<std::uint32_t>(out.nodes_.size());
            if (std::uint64_t{records} + p.records > std::numeric_limits<std::uint32_t>::max() - 1u)
                throw Error("bih::WideTree: more than 2^32 - 2 leaf records");
            for (std::size_t i = 0; i < p.nodes.size(); ++i) {
                WideNode w = p.nodes[i];
                for (int c = 0; c < kWideWidth; ++c) {
                    if (w.count[c] != 0)
                        w.child[c] += records;
                    else if (w.child[c] != kNoChild)
                        w.child[c] += base;
                }
                out.nodes_.push_back(w);
            }
            for (LeafJob job : p.jobs) {
                job.record += records;
                jobs.push_back(job);
            }
            records += p.records;
            out.stats_.depth = std::max(out.stats_.depth, p.depth);
            out.stats_.leaves += p.leaves;
            return base;
        }

        static WideNode blank() {
            WideNode w;
            const float inf = std::numeric_limits<float>::infinity();
            for (int r = 0; r < 6; ++r)
                for (int c = 0; c < kWideWidth; ++c) w.box[r][c] = (r % 2 == 0) ? inf : -inf;
            for (int c = 0; c < kWideWidth; ++c) {
                w.child[c] = kNoChild;
                w.count[c] = 0;
            }
            return w;
        }

        /// Fills wide node `at` with up to kWideWidth subtrees found below BIH node n, those of the
        /// least-cost spread (detail::SlotCosts: the least total area of wide nodes, found by
        /// dynamic programming over the BIH as Ylitie et al. 2017 collapse binary BVHs into
        /// 8-wide ones, where Embree opens the largest box until the node is full); small
        /// contiguous subtrees and BIH leaves become leaves, the other subtrees wide nodes.
        void make_node(Part& p, std::uint32_t at, std::uint32_t n, std::uint32_t depth) {
            if (depth > kMaxDepth)
                throw Error("bih::WideTree: the tree is deeper than " + std::to_string(SYLVA_BIH_DEPTH_CAP) +
                            " levels (the builder's cap)");
            p.depth = std::max(p.depth, depth);
            // The least-cost choice of up to kWideWidth subtrees below n (costs).
            std::uint32_t slots[kWideWidth];
            std::size_t used = 0;
            node_slots(n, slots, used);
            for (std::size_t s = 0; s < used; ++s) {
                std::uint32_t c = slots[s];
                if (leaf_like(c)) {
                    set_slot(p, at, static_cast<int>(s), c);
                    continue;
                }
                set_box(p, at, static_cast<int>(s), facts[c].box);
                p.nodes[at].count[s] = 0;
                if (depth + 1 == p.defer_depth) {  // made in a part of its own, linked by make()
                    p.nodes[at].child[s] = 0;
                    p.deferred.push_back({at, static_cast<int>(s), c, depth + 1});
                    continue;
                }
                auto child_at = static_cast<std::uint32_t>(p.nodes.size());
                p.nodes.push_back(blank());
                p.nodes[at].child[s] = child_at;
                make_node(p, child_at, c, depth + 1);
            }
        }

        void set_box(Part& p, std::uint32_t at, int slot, const Aabb& box) {
            Aabb padded = detail::padded(box);
            WideNode& w = p.nodes[at];
            for (int a = 0; a < 3; ++a) {
                w.box[2 * a][slot] = padded.lo[a];
                w.box[2 * a + 1][slot] = padded.hi[a];
            }
        }

        /// Slot `slot` of wide node `at` becomes a leaf holding BIH subtree n's elements (one
        /// run of the order: a BIH leaf, or a small subtree that leaf_like found contiguous).
        /// Spheres take ceil(count / 4) packets; the records are filled later by fill().
        void set_slot(Part& p, std::uint32_t at, int slot, std::uint32_t n) {
            const detail::SubtreeFacts& f = facts[n];
            set_box(p, at, slot, f.box);
            std::uint32_t count = kSpheres ? (f.count + 3u) / 4u : f.count;
            if (std::uint64_t{p.records} + count > std::numeric_limits<std::uint32_t>::max() - 1u)
                throw Error("bih::WideTree: more than 2^32 - 2 leaf records");
            p.jobs.push_back({p.records, f.first, f.count});
            WideNode& w = p.nodes[at];
            w.child[slot] = p.records;
            w.count[slot] = count;
            p.records += count;
            ++p.leaves;
        }

        /// Copies the elements into their leaves' records: spheres transposed into packets (in
        /// parallel; unused lanes keep radius 0 and id kNoChild), other types in leaf order.
        template <class X>
        void fill(X& exec) {
            if constexpr (kSpheres) {
                memory::prefault<SpherePacket>(records, exec);  // assign writes them on one thread
                out.records_.assign(records, SpherePacket{});
                memory::prefault<std::uint32_t>(std::size_t{records} * 4u, exec);
                out.ids_.assign(std::size_t{records} * 4u, kNoChild);
                auto fill_jobs = [&](std::size_t lo, std::size_t hi) {
                    for (std::size_t j = lo; j < hi; ++j) {
                        const LeafJob& job = jobs[j];
                        for (std::uint32_t k = 0; k < job.count; ++k) {
                            std::uint32_t id = tree.order[job.first + k];
                            SpherePacket& p = out.records_[job.record + k / 4u];
                            const SphereRecord sp = sphere_at(job.first + k);
                            for (int a = 0; a < 3; ++a) p.c[a][k % 4u] = sp.c[a];
                            p.r[k % 4u] = sp.r;
                            out.ids_[std::size_t{job.record} * 4u + k] = id;
                        }
                    }
                };
                // Small trees on the calling thread: at 10^4 spheres (2,500 leaves) handing a
                // chunk to a worker that slept cost more than the fill (0.055 -> 0.03 ms).
                if (parallel())
                    exec.parallel_for(0, jobs.size(), 1024, fill_jobs);
                else
                    fill_jobs(0, jobs.size());
            } else {  // any element type, default-constructible or not: in job (= record) order
                (void)exec;
                out.records_.reserve(records);
                out.ids_.reserve(records);
                for (const LeafJob& job : jobs)
                    for (std::uint32_t k = 0; k < job.count; ++k) {
                        std::uint32_t id = tree.order[job.first + k];
                        out.ids_.push_back(id);
                        out.records_.push_back(elements[id]);
                    }
            }
        }
    };

    // Large arrays from memory::LargeAllocator (huge pages, warm blocks reused across builds).
    LargeVector<WideNode> nodes_;
    LargeVector<Record> records_;
    LargeVector<std::uint32_t> ids_;
    WideStats stats_;
};

/// The nearest element hit in `range` (smallest entry t; ties: smallest element index), as
/// first_hit over the BIH gives it.
template <Intersectable E>
std::optional<ElementHit> first_hit(const WideTree<E>& wide, const Ray& ray, Interval range = {}) {
    std::optional<ElementHit> best;
    float limit = range.t1;
    const auto probe = WideTree<E>::probe(ray, range);
    wide.for_each_leaf(
        ray, range, [&] { return limit; },
        [&](std::uint32_t first, std::uint32_t count) {
            wide.leaf_hits(first, count, probe, [&](const ElementHit& h) {
                if (!best || hit_before(h, *best)) {
                    best = h;
                    limit = h.t.t0;
                }
            });
        });
    return best;
}

/// Every element hit in `range`, sorted by hit_before, as all_hits over the BIH gives them.
/// The leaves come in any order (see for_each_leaf_any_order); the hits are sorted at the end.
template <Intersectable E>
void all_hits(const WideTree<E>& wide, const Ray& ray, std::vector<ElementHit>& out, Interval range = {}) {
    out.clear();
    const auto probe = WideTree<E>::probe(ray, range);
    using LeafRef = typename WideTree<E>::LeafRef;
    wide.for_each_leaf_any_order(ray, range, [&](const LeafRef* leaves, std::uint32_t n) {
        wide.batch_hits(leaves, n, probe, [&](const ElementHit& h) { out.push_back(h); });
    });
    std::sort(out.begin(), out.end(), hit_before);
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_WIDE_HPP
