// sylva/bih/encode.hpp -- turns a built BIH into the flat word array of
// sylva/shared/bih_layout.h (Kinkelin sections 3.3, 5.1, 5.4), and checks untrusted encodings.
#ifndef SYLVA_BIH_ENCODE_HPP
#define SYLVA_BIH_ENCODE_HPP

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "sylva/bih/payload.hpp"
#include "sylva/bih/tree.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/shared/bih_layout.h"

namespace sylva::bih {

enum class NodeFormat {
    Fixed16,  ///< 8-byte nodes, 16-bit fixed-point planes over the normalised root box (Table 1)
    Float32,  ///< 12-byte nodes, float planes in world space (exact)
};
enum class Layout {
    PreOrder,    ///< root, left subtree, right subtree (section 3.3)
    TreeChunks,  ///< children stored as pairs, chunk_depth + 1 levels breadth first (section 5.4)
};

/// Encoder settings.
struct EncodeConfig {
    NodeFormat format = NodeFormat::Fixed16;
    Layout layout = Layout::TreeChunks;
    /// Tree-chunk depth: a chunk holds chunk_depth + 1 levels of both subtrees (section 5.4: 2).
    std::uint32_t chunk_depth = 2;
};

namespace detail {

inline std::uint32_t bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

/// Conservative 16-bit fixed-point plane: `upper` bounds round up, lower bounds round down.
inline std::uint32_t quantize(float p, float lo, float ext, bool upper) {
    if (std::isinf(p)) return p < 0 ? SYLVA_BIH_Q_NEG_INF : SYLVA_BIH_Q_POS_INF;
    double n = ext > 0.0f ? (double(p) - double(lo)) / double(ext) : 0.0;
    double steps = upper ? std::ceil(n * 32768.0) : std::floor(n * 32768.0);
    steps = std::fmin(std::fmax(steps, 0.0), 32768.0);
    return SYLVA_BIH_Q_ZERO + static_cast<std::uint32_t>(steps);
}

/// Node positions in the flat array for the chosen layout; `link` is the index field of each
/// inner node (see bih_layout.h, "Child addressing").
struct Placement {
    std::vector<std::uint32_t> pos;
    std::vector<std::uint32_t> link;
};

/// The stored children of node n, in storage order (left first unless it is empty).
inline int stored_children(const Node& n, std::uint32_t out[2]) {
    if (n.leaf()) return 0;
    if (n.single) {
        out[0] = n.child[0];
        return 1;
    }
    int k = 0;
    for (std::uint32_t c : n.child)
        if (c != kNoChild) out[k++] = c;
    return k;
}

/// What encode measures from the nodes themselves (never from Tree::stats, which a hand-built
/// tree may leave at zero).
struct Shape {
    std::uint32_t max_depth = 0;  ///< root = 0
    std::uint64_t leaves = 0;
    std::uint64_t elements = 0;  ///< sum of the leaves' counts
};

/// Checks that the nodes form one tree rooted at node 0 (every child index in range, every node
/// reached exactly once, so no cycle and no shared subtree, no inner node without a child, axes
/// 0..2 or kLeaf, depth within the layout's cap) and measures it. Throws sylva::Error naming the
/// node. The placement and the parallel node writes rely on this: a cycle would loop forever,
/// an unreached node would be written over node 0.
inline Shape check_structure(const Tree& t) {
    const std::size_t n = t.nodes.size();
    std::vector<std::uint8_t> seen(n, 0);
    struct Item { std::uint32_t node, depth; };
    std::vector<Item> stack{{0u, 0u}};
    seen[0] = 1;
    Shape s;
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        const Node& node = t.nodes[it.node];
        std::string where = "node " + std::to_string(it.node);
        if (it.depth > SYLVA_BIH_DEPTH_CAP)
            throw Error("bih::encode: " + where + " lies at depth " + std::to_string(it.depth) + ", over the cap of " +
                        std::to_string(SYLVA_BIH_DEPTH_CAP));
        s.max_depth = std::max(s.max_depth, it.depth);
        if (node.leaf()) {
            ++s.leaves;
            s.elements += node.count;
            continue;
        }
        if (node.axis > 2) throw Error("bih::encode: " + where + " has axis " + std::to_string(node.axis) + " (0..2 or leaf)");
        if (node.children() == 0) throw Error("bih::encode: inner " + where + " has no child");
        std::uint32_t kids[2];
        int k = stored_children(node, kids);
        for (int c = 0; c < k; ++c) {
            if (kids[c] >= n)
                throw Error("bih::encode: " + where + " has child index " + std::to_string(kids[c]) + " out of range (" +
                            std::to_string(n) + " nodes)");
            if (seen[kids[c]])
                throw Error("bih::encode: node " + std::to_string(kids[c]) + " is reached twice (from " + where +
                            "): a cycle or a shared subtree");
            seen[kids[c]] = 1;
            stack.push_back({kids[c], it.depth + 1});
        }
    }
    for (std::size_t i = 0; i < n; ++i)
        if (!seen[i]) throw Error("bih::encode: node " + std::to_string(i) + " is not reached from the root");
    if (s.elements > 0xFFFFFFFFu)
        throw Error("bih::encode: the leaves hold " + std::to_string(s.elements) + " elements, over 2^32 - 1");
    return s;
}

inline void place_preorder(const Tree& t, Placement& pl) {
    std::uint32_t next = 0;
    std::vector<std::uint32_t> stack{0};
    while (!stack.empty()) {
        std::uint32_t i = stack.back();
        stack.pop_back();
        pl.pos[i] = next++;
        std::uint32_t kids[2];
        int k = stored_children(t.nodes[i], kids);
        if (k == 2) stack.push_back(kids[1]);
        if (k >= 1) stack.push_back(kids[0]);
    }
    for (std::size_t i = 0; i < t.nodes.size(); ++i) {  // index field: second stored child
        std::uint32_t kids[2];
        pl.link[i] = stored_children(t.nodes[i], kids) == 2 ? pl.pos[kids[1]] : 0u;
    }
}

/// Places the chunk below `parent` (its depth + 1 levels, breadth first, from `next` on), then
/// the chunks below that chunk's last level, depth first in order. Iterative (an explicit stack
/// of chunk parents, buffers reused): a 10^7-element tree has millions of chunks.
inline void place_chunk(const Tree& t, Placement& pl, std::uint32_t parent, std::uint32_t depth,
                        std::uint32_t& next) {
    std::vector<std::uint32_t> pending{parent}, level, below;
    while (!pending.empty()) {
        level.assign(1, pending.back());
        pending.pop_back();
        for (std::uint32_t lvl = 0; lvl <= depth && !level.empty(); ++lvl) {
            below.clear();
            for (std::uint32_t p : level) {
                std::uint32_t kids[2];
                int k = stored_children(t.nodes[p], kids);
                if (k == 0) continue;
                pl.link[p] = next;
                for (int c = 0; c < k; ++c) {
                    pl.pos[kids[c]] = next++;
                    below.push_back(kids[c]);
                }
            }
            level.swap(below);
        }
        pending.insert(pending.end(), level.rbegin(), level.rend());  // first of them on top
    }
}

inline Placement place(const Tree& t, const EncodeConfig& cfg) {
    Placement pl{std::vector<std::uint32_t>(t.nodes.size(), 0), std::vector<std::uint32_t>(t.nodes.size(), 0)};
    if (cfg.layout == Layout::PreOrder) {
        place_preorder(t, pl);
    } else {
        std::uint32_t next = 1;
        place_chunk(t, pl, 0, cfg.chunk_depth, next);
    }
    return pl;
}

inline void write_header(std::vector<std::uint32_t>& w, const Tree& t, const Shape& shape, const EncodeConfig& cfg,
                         std::uint32_t kind, bool single) {
    bool f32 = cfg.format == NodeFormat::Float32;
    w[0] = SYLVA_BIH_MAGIC;
    w[1] = SYLVA_BIH_VERSION;
    w[2] = (f32 ? SYLVA_BIH_FLAG_FLOAT_NODES : 0u) | (cfg.layout == Layout::TreeChunks ? SYLVA_BIH_FLAG_CHUNKED : 0u) |
           ((cfg.chunk_depth & 15u) << 2) | (single ? SYLVA_BIH_FLAG_SINGLE_CHILD : 0u) | (kind << 8);  // kind <= 255: checked by encode
    w[3] = static_cast<std::uint32_t>(t.nodes.size());
    w[4] = shape.max_depth;
    w[5] = static_cast<std::uint32_t>(shape.leaves);
    w[6] = static_cast<std::uint32_t>(shape.elements);
    w[7] = 0;
    vec3 ext = t.bounds.extent();
    for (int a = 0; a < 3; ++a) {
        w[8 + a] = bits(t.bounds.lo[a]);
        w[11 + a] = bits(t.bounds.hi[a]);
        w[14 + a] = bits(f32 ? 0.0f : t.bounds.lo[a]);
        w[17 + a] = bits((f32 || !(ext[a] > 0.0f)) ? 1.0f : 1.0f / ext[a]);
    }
}

/// Plane word(s) of an inner node: A is an upper bound unless the node has a single child.
inline void write_planes(std::uint32_t* at, const Node& n, const Tree& t, bool f32) {
    if (f32) {
        at[0] = bits(n.plane[0]);
        at[1] = bits(n.plane[1]);
        return;
    }
    float lo = t.bounds.lo[n.axis], ext = t.bounds.extent()[n.axis];
    std::uint32_t a = quantize(n.plane[0], lo, ext, !n.single);
    std::uint32_t b = quantize(n.plane[1], lo, ext, n.single);
    at[0] = a | (b << 16);
}

}  // namespace detail

namespace detail {

/// Writes nodes [lo, hi) of `tree` at their placed positions; true if one of them is a
/// single-child node. Leaves get `payload`'s bits for their elements (RangePayload needs only
/// the range, so its leaves skip gathering the elements).
template <Bounded E, class P>
bool write_nodes(std::vector<std::uint32_t>& w, const Tree& tree, std::span<const E> elements, const P& payload,
                 const Placement& pl, bool f32, std::size_t lo, std::size_t hi) {
    const std::uint32_t stride = f32 ? 3u : 2u;
    std::vector<E> leaf_elems;
    bool single = false;
    for (std::size_t i = lo; i < hi; ++i) {
        const Node& n = tree.nodes[i];
        std::uint32_t* at = &w[SYLVA_BIH_HEADER_WORDS + std::size_t{pl.pos[i]} * stride];
        std::uint32_t& meta = at[stride - 1];
        if (n.leaf()) {
            std::uint64_t bitsv;
            if constexpr (std::is_same_v<P, RangePayload>) {
                bitsv = std::uint64_t{n.first} | (std::uint64_t{n.count} << 32);  // RangePayload::encode
            } else {
                leaf_elems.clear();
                for (std::uint32_t k = 0; k < n.count; ++k) {
                    std::size_t at_order = std::size_t{n.first} + k;
                    std::uint32_t e = at_order < tree.order.size() ? tree.order[at_order] : ~0u;
                    if (e >= elements.size())
                        throw Error("bih::encode: leaf " + std::to_string(i) + " refers to an element beyond the " +
                                    std::to_string(elements.size()) + " given");
                    leaf_elems.push_back(elements[e]);
                }
                bitsv = payload.encode(std::span<const E>(leaf_elems), n.first);
            }
            if (bitsv >> 62) throw Error("bih::encode: leaf payload does not fit in 62 bits");
            at[0] = static_cast<std::uint32_t>(bitsv);
            meta = shared::sylva_bih_meta_leaf(static_cast<std::uint32_t>(bitsv >> 32));
            continue;
        }
        single = single || n.single;
        write_planes(at, n, tree, f32);
        meta = shared::sylva_bih_meta_inner(n.axis, n.single, pl.link[i]);
    }
    return single;
}

}  // namespace detail

/// Encodes `tree` (built over `elements`) with leaf payloads from `payload`, writing the nodes
/// in parallel on `exec` (the placement of the nodes is one serial pass). The result does not
/// depend on the executor. The tree is not trusted: its links must form one tree rooted at
/// node 0 (see detail::check_structure), and the header's depth, leaf and element counts are
/// measured from the nodes, not read from Tree::stats. Throws sylva::Error when the links do
/// not form such a tree, it is deeper than SYLVA_BIH_DEPTH_CAP, it has more nodes than the
/// 29-bit index field can address, P::kind does not fit 8 bits, a payload encoder would be
/// handed elements `elements` does not have, or a payload does not fit in 62 bits.
template <Bounded E, class P, Executor X>
    requires PayloadEncoder<P, E>
std::vector<std::uint32_t> encode(const Tree& tree, std::span<const E> elements, const P& payload,
                                  const EncodeConfig& cfg, X& exec) {
    if (tree.nodes.empty()) throw Error("bih::encode: empty tree");
    if (tree.nodes.size() > SYLVA_BIH_MAX_INDEX)
        throw Error("bih::encode: " + std::to_string(tree.nodes.size()) + " nodes exceed the 29-bit node index");
    if (cfg.layout == Layout::TreeChunks && cfg.chunk_depth > 15)
        throw Error("bih::encode: chunk depth " + std::to_string(cfg.chunk_depth) + " is over 15");
    if (P::kind > 255u)
        throw Error("bih::encode: payload kind " + std::to_string(P::kind) + " does not fit the header's 8 bits (0..255)");
    const detail::Shape shape = detail::check_structure(tree);
    bool f32 = cfg.format == NodeFormat::Float32;
    std::vector<std::uint32_t> w(SYLVA_BIH_HEADER_WORDS + tree.nodes.size() * (f32 ? 3u : 2u), 0u);
    detail::Placement pl = detail::place(tree, cfg);
    std::atomic<bool> single{false};
    exec.parallel_for(0, tree.nodes.size(), 1u << 16, [&](std::size_t lo, std::size_t hi) {
        if (detail::write_nodes(w, tree, elements, payload, pl, f32, lo, hi)) single = true;
    });
    detail::write_header(w, tree, shape, cfg, P::kind, single.load());
    return w;
}

/// Encodes on the calling thread.
template <Bounded E, class P>
    requires PayloadEncoder<P, E>
std::vector<std::uint32_t> encode(const Tree& tree, std::span<const E> elements, const P& payload,
                                  const EncodeConfig& cfg = {}) {
    SerialExecutor serial;
    return encode(tree, elements, payload, cfg, serial);
}

/// Size in bytes of an encoding.
inline std::size_t encoded_bytes(std::span<const std::uint32_t> words) { return words.size() * 4; }

}  // namespace sylva::bih

#endif  // SYLVA_BIH_ENCODE_HPP
