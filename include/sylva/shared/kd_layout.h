// sylva/shared/kd_layout.h -- the flat empty-space kd-tree encoding (sylva/kdtree/encode.hpp),
// read identically by host and shaders.
//
// An encoded kd-tree is an array of 32-bit words: a 20-word header followed by the nodes, four
// words (one uvec4) each. Boxes are half-open voxel ranges [lo, hi): under the cell convention
// (sylva/volume/grid.hpp) the world box is [origin + lo * spacing, origin + hi * spacing], and
// the iterator works in voxel space, so faces shared by two leaves are the same integers.
//
// Header (word offset: meaning)
//   0      magic 0x444B5953 ("SYKD", little endian)
//   1      format version (SYLVA_KD_VERSION)
//   2      flags (0; reserved)
//   3      node count; 0 for a grid without occupied voxels (the iterator then yields nothing)
//   4      max depth (root = 0); the iterator's stack needs this many entries
//   5      leaf count
//   6-8    grid dimensions in voxels (x, y, z), each 1 .. 65535
//   9      reserved (0)
//   10-12  world position of the grid's corner, voxel (0, 0, 0)'s lower corner (float bits)
//   13-15  world size of one voxel, the spacing (float bits)
//   16-18  1 / spacing (float bits): a world point p is traversed at (p - origin) * (1 / spacing)
//   19     reserved (0)
//
// Node i (words 20 + 4 i .. 20 + 4 i + 3):
//   word 0  bits 0-15 box lo.x, bits 16-31 box hi.x
//   word 1  bits 0-15 box lo.y, bits 16-31 box hi.y
//   word 2  bits 0-15 box lo.z, bits 16-31 box hi.z
//   word 3  bits 0-1  type: 0/1/2 = inner node split along x/y/z, 3 = leaf
//           bits 2-31 inner: index of the lower child (voxels below the split plane); the upper
//                     child is stored right after it, and both indices exceed the parent's
//                     leaf: the leaf index (0 .. leaf count - 1), the position in the leaf list
// The box of a node is the tight box of the occupied voxels under it. The two children of an
// inner node lie on either side of its split plane: lower.hi <= upper.lo along the split axis.
#ifndef SYLVA_SHARED_KD_LAYOUT_H
#define SYLVA_SHARED_KD_LAYOUT_H

#include "sylva/shared/lang.h"

#define SYLVA_KD_MAGIC 0x444B5953u
#define SYLVA_KD_VERSION 1u
#define SYLVA_KD_HEADER_WORDS 20u
#define SYLVA_KD_NODE_WORDS 4u
#define SYLVA_KD_LEAF 3u
/// Node word 3 (the meta word): bits 0-1 type, bits 2-31 index; read and written only through
/// sylva_kd_meta_type / sylva_kd_meta_index / sylva_kd_meta_make.
#define SYLVA_KD_META_TYPE_MASK 3u
#define SYLVA_KD_META_INDEX_SHIFT 2u
/// Largest child or leaf index the 30-bit field holds.
#define SYLVA_KD_MAX_INDEX 0x3FFFFFFFu
/// Largest grid dimension a 16-bit box coordinate holds.
#define SYLVA_KD_MAX_DIM 65535u
/// Hard cap on tree depth: builders never exceed it, the iterator's stack never overflows.
#define SYLVA_KD_DEPTH_CAP 64u

SYLVA_BEGIN_NAMESPACE

/// Header fields the iterator needs, read once per ray.
struct SylvaKdHeader {
    uint node_count;
    uint max_depth;
    uint leaf_count;
    uvec3 dims;
    vec3 origin;
    vec3 spacing;
    vec3 inv_spacing;
    uint valid;
};

/// Three floats of the `words` buffer starting at `at` (in GLSL this reads `words` only).
SYLVA_FN vec3 sylva_kd_load_vec3(SYLVA_BUF(words), uint at) {
    return vec3(uintBitsToFloat(SYLVA_LOAD(words, at)), uintBitsToFloat(SYLVA_LOAD(words, at + 1u)),
                uintBitsToFloat(SYLVA_LOAD(words, at + 2u)));
}

/// Reads and checks the header. `word_count` is the buffer's length in words. A header that is
/// not a kd-tree, a node count the buffer cannot hold or a depth over the cap gives valid == 0.
SYLVA_FN SylvaKdHeader sylva_kd_read_header(SYLVA_BUF(words), uint word_count) {
    SylvaKdHeader h;
    h.node_count = SYLVA_LOAD(words, 3u);
    h.max_depth = SYLVA_LOAD(words, 4u);
    h.leaf_count = SYLVA_LOAD(words, 5u);
    h.dims = uvec3(SYLVA_LOAD(words, 6u), SYLVA_LOAD(words, 7u), SYLVA_LOAD(words, 8u));
    h.origin = sylva_kd_load_vec3(SYLVA_PASS_BUF(words), 10u);
    h.spacing = sylva_kd_load_vec3(SYLVA_PASS_BUF(words), 13u);
    h.inv_spacing = sylva_kd_load_vec3(SYLVA_PASS_BUF(words), 16u);
    bool ok = word_count >= SYLVA_KD_HEADER_WORDS;
    ok = ok && SYLVA_LOAD(words, 0u) == SYLVA_KD_MAGIC && SYLVA_LOAD(words, 1u) == SYLVA_KD_VERSION;
    ok = ok && h.node_count <= (word_count - SYLVA_KD_HEADER_WORDS) / SYLVA_KD_NODE_WORDS;
    ok = ok && h.node_count <= SYLVA_KD_MAX_INDEX && h.leaf_count <= h.node_count;
    ok = ok && h.max_depth <= SYLVA_KD_DEPTH_CAP;
    h.valid = ok ? 1u : 0u;
    return h;
}

/// Word offset of node `i`.
SYLVA_FN uint sylva_kd_node_at(uint i) { return SYLVA_KD_HEADER_WORDS + i * SYLVA_KD_NODE_WORDS; }

/// The meta word (type and index) of node `i`.
SYLVA_FN uint sylva_kd_meta(SYLVA_BUF(words), uint i) { return SYLVA_LOAD(words, sylva_kd_node_at(i) + 3u); }

/// Type of a node from its meta word: split axis 0/1/2 or SYLVA_KD_LEAF.
SYLVA_FN uint sylva_kd_meta_type(uint meta) { return meta & SYLVA_KD_META_TYPE_MASK; }
/// Index field: the lower child (inner) or the leaf index (leaf).
SYLVA_FN uint sylva_kd_meta_index(uint meta) { return meta >> SYLVA_KD_META_INDEX_SHIFT; }
/// The meta word of a node of type `type` with index `index` (<= SYLVA_KD_MAX_INDEX).
SYLVA_FN uint sylva_kd_meta_make(uint type, uint index) { return type | (index << SYLVA_KD_META_INDEX_SHIFT); }

/// Lower corner of node `i`'s box, in voxels.
SYLVA_FN uvec3 sylva_kd_box_lo(SYLVA_BUF(words), uint i) {
    uint at = sylva_kd_node_at(i);
    return uvec3(SYLVA_LOAD(words, at) & 0xFFFFu, SYLVA_LOAD(words, at + 1u) & 0xFFFFu,
                 SYLVA_LOAD(words, at + 2u) & 0xFFFFu);
}

/// Upper corner (exclusive) of node `i`'s box, in voxels.
SYLVA_FN uvec3 sylva_kd_box_hi(SYLVA_BUF(words), uint i) {
    uint at = sylva_kd_node_at(i);
    return uvec3(SYLVA_LOAD(words, at) >> 16u, SYLVA_LOAD(words, at + 1u) >> 16u, SYLVA_LOAD(words, at + 2u) >> 16u);
}

/// A voxel coordinate in world space: origin + v * spacing.
SYLVA_FN vec3 sylva_kd_to_world(SylvaKdHeader h, vec3 v) {
    return vec3(h.origin.x + v.x * h.spacing.x, h.origin.y + v.y * h.spacing.y, h.origin.z + v.z * h.spacing.z);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_LAYOUT_H
