// sylva/shared/bih_layout.h -- the flat BIH encoding, read identically by host and shaders.
//
// An encoded BIH is an array of 32-bit words: a 20-word header followed by the nodes.
//
// Header (word offset: meaning)
//   0      magic 0x49425953 ("SYBI", little endian)
//   1      format version (SYLVA_BIH_VERSION)
//   2      flags
//            bit  0     node format: 0 = 16-bit fixed-point planes (2 words a node, Kinkelin
//                       Table 1), 1 = float32 planes (3 words a node)
//            bit  1     layout: 0 = pre-order, 1 = tree chunks (Kinkelin section 5.4)
//            bits 2-5   chunk depth (tree-chunk layout only)
//            bit  6     single-child nodes may occur (the "elaborate" empty-child variant)
//            bits 8-15  payload kind (SYLVA_PAYLOAD_*; kinds >= 128 belong to users)
//   3      node count
//   4      max depth (root = 0); the iterator's stack needs this many entries
//   5      leaf count
//   6      element count (of the source the tree was built over)
//   7      reserved (0)
//   8-10   root box lower corner, world space (float bits)
//   11-13  root box upper corner, world space (float bits)
//   14-16  traversal-space origin o_s (float bits)
//   17-19  traversal-space scale s (float bits): a point p is traversed at (p - o_s) * s.
//          16-bit nodes use the normalised root box [0,1]^3; float nodes use world space
//          (o_s = 0, s = 1).
//
// Node, 16-bit format (2 words, Kinkelin Table 1):
//   word 0  inner: bits 0-15 plane A, bits 16-31 plane B       leaf: payload bits 0-31
//   word 1  bits 0-1  type: 0/1/2 = split axis x/y/z, 3 = leaf
//           inner: bit 2 single-child flag, bits 3-31 child index (29 bits)
//           leaf:  bits 2-31 payload bits 32-61
//   Planes are fixed point over the normalised root box: 0x4000 = 0, 0xC000 = 1, one step
//   = 1/32768. 0x0000 and 0xFFFF mark the planes of empty children (-inf / +inf).
// Node, float32 format (3 words): word 0 plane A (float bits) or payload bits 0-31,
//   word 1 plane B (float bits) or 0, word 2 as word 1 of the 16-bit format.
//   Empty children have plane A = -inf or plane B = +inf.
//
// Inner nodes. Two children: plane A is the upper bound of the left child, plane B the lower
// bound of the right child along the split axis (they may overlap); an empty child is not
// stored and its plane holds the sentinel. Single child (flag set): the child lies within
// [plane A, plane B] along the axis (both planes trim it).
// Child addressing. Pre-order: the first stored child follows its parent (index + 1) and the
// index field points at the second. Tree chunks: the index field points at the first stored
// child and the second follows it. The left child is stored first unless it is empty.
#ifndef SYLVA_SHARED_BIH_LAYOUT_H
#define SYLVA_SHARED_BIH_LAYOUT_H

#include "sylva/shared/lang.h"

#define SYLVA_BIH_MAGIC 0x49425953u
#define SYLVA_BIH_VERSION 1u
#define SYLVA_BIH_HEADER_WORDS 20u
#define SYLVA_BIH_FLAG_FLOAT_NODES 1u
#define SYLVA_BIH_FLAG_CHUNKED 2u
#define SYLVA_BIH_FLAG_SINGLE_CHILD 64u
#define SYLVA_BIH_LEAF 3u
/// Node meta word (the last word of a node): bits 0-1 type, bit 2 single-child flag (inner),
/// bits 3-31 child index (inner) or bits 2-31 payload bits 32-61 (leaf). Read and written only
/// through the sylva_bih_meta_* functions below.
#define SYLVA_BIH_META_TYPE_MASK 3u
#define SYLVA_BIH_META_SINGLE 4u
#define SYLVA_BIH_META_INDEX_SHIFT 3u
#define SYLVA_BIH_META_PAYLOAD_SHIFT 2u
#define SYLVA_BIH_MAX_INDEX 0x1FFFFFFFu
#define SYLVA_BIH_Q_ZERO 0x4000u
#define SYLVA_BIH_Q_ONE 0xC000u
#define SYLVA_BIH_Q_NEG_INF 0x0000u
#define SYLVA_BIH_Q_POS_INF 0xFFFFu
/// Hard cap on tree depth: builders never exceed it, the iterator's stack never overflows.
#define SYLVA_BIH_DEPTH_CAP 64u

#define SYLVA_PAYLOAD_RANGE 0u
#define SYLVA_PAYLOAD_PARTICLE_RGBA 1u
#define SYLVA_PAYLOAD_VOXEL 2u

SYLVA_BEGIN_NAMESPACE

/// Header fields the iterator needs, read once per ray.
struct SylvaBihHeader {
    uint flags;
    uint node_count;
    uint max_depth;
    uint stride;
    vec3 root_lo;
    vec3 root_hi;
    vec3 space_origin;
    vec3 space_scale;
    uint valid;
};

/// Three floats of the `words` buffer (in GLSL this reads `words` only; see lang.h).
SYLVA_FN vec3 sylva_load_vec3(SYLVA_BUF(words), uint at) {
    return vec3(uintBitsToFloat(SYLVA_LOAD(words, at)), uintBitsToFloat(SYLVA_LOAD(words, at + 1u)),
                uintBitsToFloat(SYLVA_LOAD(words, at + 2u)));
}

/// Reads and checks the header. `word_count` is the buffer's length in words; a header that
/// is not a BIH, a node count that does not fit the buffer, or a depth over the cap gives
/// valid == 0, and the iterator then yields no leaves.
SYLVA_FN SylvaBihHeader sylva_bih_read_header(SYLVA_BUF(words), uint word_count) {
    SylvaBihHeader h;
    h.flags = SYLVA_LOAD(words, 2u);
    h.node_count = SYLVA_LOAD(words, 3u);
    h.max_depth = SYLVA_LOAD(words, 4u);
    h.stride = ((h.flags & SYLVA_BIH_FLAG_FLOAT_NODES) != 0u) ? 3u : 2u;
    h.root_lo = sylva_load_vec3(SYLVA_PASS_BUF(words), 8u);
    h.root_hi = sylva_load_vec3(SYLVA_PASS_BUF(words), 11u);
    h.space_origin = sylva_load_vec3(SYLVA_PASS_BUF(words), 14u);
    h.space_scale = sylva_load_vec3(SYLVA_PASS_BUF(words), 17u);
    bool ok = word_count >= SYLVA_BIH_HEADER_WORDS;
    ok = ok && SYLVA_LOAD(words, 0u) == SYLVA_BIH_MAGIC && SYLVA_LOAD(words, 1u) == SYLVA_BIH_VERSION;
    ok = ok && h.node_count >= 1u && h.node_count <= SYLVA_BIH_MAX_INDEX;
    ok = ok && h.node_count <= (word_count - SYLVA_BIH_HEADER_WORDS) / h.stride;
    ok = ok && h.max_depth <= SYLVA_BIH_DEPTH_CAP;
    h.valid = ok ? 1u : 0u;
    return h;
}

/// Word offset of node `i`.
SYLVA_FN uint sylva_bih_node_at(SylvaBihHeader h, uint i) { return SYLVA_BIH_HEADER_WORDS + i * h.stride; }

/// The meta word (type, flags, index or payload high bits) of node `i`.
SYLVA_FN uint sylva_bih_meta(SYLVA_BUF(words), SylvaBihHeader h, uint i) {
    return SYLVA_LOAD(words, sylva_bih_node_at(h, i) + h.stride - 1u);
}

/// Type of a node from its meta word: split axis 0/1/2 or SYLVA_BIH_LEAF.
SYLVA_FN uint sylva_bih_meta_type(uint meta) { return meta & SYLVA_BIH_META_TYPE_MASK; }
/// Whether an inner node has a single child lying within [plane A, plane B].
SYLVA_FN bool sylva_bih_meta_single(uint meta) { return (meta & SYLVA_BIH_META_SINGLE) != 0u; }
/// The child index field of an inner node (see "Child addressing" above).
SYLVA_FN uint sylva_bih_meta_index(uint meta) { return meta >> SYLVA_BIH_META_INDEX_SHIFT; }
/// Payload bits 32-61 of a leaf.
SYLVA_FN uint sylva_bih_meta_payload_hi(uint meta) { return meta >> SYLVA_BIH_META_PAYLOAD_SHIFT; }
/// The meta word of an inner node (axis 0-2, index <= SYLVA_BIH_MAX_INDEX).
SYLVA_FN uint sylva_bih_meta_inner(uint axis, bool single, uint index) {
    return axis | (single ? SYLVA_BIH_META_SINGLE : 0u) | (index << SYLVA_BIH_META_INDEX_SHIFT);
}
/// The meta word of a leaf holding payload bits 32-61 `payload_hi` (< 2^30).
SYLVA_FN uint sylva_bih_meta_leaf(uint payload_hi) {
    return SYLVA_BIH_LEAF | (payload_hi << SYLVA_BIH_META_PAYLOAD_SHIFT);
}
/// Where the first stored child of inner node `n` is: after its parent (pre-order) or at the
/// index field (tree chunks). A single child is the first stored child.
SYLVA_FN uint sylva_bih_first_child(bool chunked, uint n, uint meta) {
    return chunked ? sylva_bih_meta_index(meta) : n + 1u;
}

/// Decodes one 16-bit fixed-point plane into normalised space; sentinels become -inf/+inf
/// (selects, not branches: the host walker's hot loop uses it too).
SYLVA_FN float sylva_bih_decode_q(uint q) {
    float v = float(int(q) - int(SYLVA_BIH_Q_ZERO)) * (1.0f / 32768.0f);
    v = (q == SYLVA_BIH_Q_NEG_INF) ? -sylva_inf() : v;
    return (q == SYLVA_BIH_Q_POS_INF) ? sylva_inf() : v;
}

/// Planes A and B of inner node `i`, in traversal space.
SYLVA_FN vec2 sylva_bih_planes(SYLVA_BUF(words), SylvaBihHeader h, uint i) {
    uint at = sylva_bih_node_at(h, i);
    uint w0 = SYLVA_LOAD(words, at);
    if (h.stride == 3u) {
        return vec2(uintBitsToFloat(w0), uintBitsToFloat(SYLVA_LOAD(words, at + 1u)));
    }
    return vec2(sylva_bih_decode_q(w0 & 0xFFFFu), sylva_bih_decode_q(w0 >> 16u));
}

/// The 62-bit leaf payload of node `i` as (bits 0-31, bits 32-61).
SYLVA_FN uvec2 sylva_bih_payload(SYLVA_BUF(words), SylvaBihHeader h, uint i) {
    uint at = sylva_bih_node_at(h, i);
    return uvec2(SYLVA_LOAD(words, at), sylva_bih_meta_payload_hi(SYLVA_LOAD(words, at + h.stride - 1u)));
}

/// Traversal-space point back to world space: identity for float nodes, lo + p * (hi - lo) over
/// the root box for 16-bit nodes (multiplications only: it runs once per leaf).
SYLVA_FN vec3 sylva_bih_to_world(SylvaBihHeader h, vec3 p) {
    if ((h.flags & SYLVA_BIH_FLAG_FLOAT_NODES) != 0u) return p;
    vec3 lo = h.root_lo;
    vec3 hi = h.root_hi;
    return vec3(lo.x + p.x * (hi.x - lo.x), lo.y + p.y * (hi.y - lo.y), lo.z + p.z * (hi.z - lo.z));
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_BIH_LAYOUT_H
