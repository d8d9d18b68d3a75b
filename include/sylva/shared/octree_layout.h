// sylva/shared/octree_layout.h -- the encoding of the bricked octree with neighbour pointers
// (Gobbetti, Marton, Iglesias Guitian, sections 4 and 5.1, Figs. 3 and 4), and its shared
// decoder.
//
// Voxel space. World point p maps to u = (p - origin) * inv_spacing; voxel v covers [v, v + 1]
// (sylva/volume/grid.hpp), so the volume is the box [0, dims]. The octree has L levels; a node
// of level l is W_l = B * 2^(L - 1 - l) voxels wide and the node with coordinates c covers
// [c * W_l, min((c + 1) * W_l, dims)] (boxes are computed, never stored; section 5.2). Child
// octant o = x | y << 1 | z << 2 of node c is node 2 c + (x, y, z) one level down.
//
// Index words (32-bit), offset: meaning
//   0       magic SYLVA_OCT_MAGIC ("SOCT")
//   1       version SYLVA_OCT_VERSION
//   2-4     dims: volume extent in voxels per axis (each 1 .. 2^24 - 1)
//   5       bits 0-7: brick size B (a power of two, 4 .. 64); bits 8-15: border b (1 or 2);
//           bits 16-23: levels L (1 .. 17, = 1 + ceil(log2(max ceil(dims / B)))); bits 24-31:
//           brick format: SYLVA_OCT_FORMAT_FLOAT32 (0), _UNORM16 (2), _UNORM8 (3) (1 is the
//           element octree's, sylva/shared/octree_elem_iter.h)
//   6       node count N (>= 1)
//   7       brick count M (the brick buffer holds M * brick words words)
//   8       brick words: S^3 (float32), ceil(S^3 / 2) (unorm16), ceil(S^3 / 4) (unorm8), S = B + 2 b
//   9       total index words: 20 + 16 N
//   10-12   spacing (float bits, finite, > 0): world size of one voxel
//   13-15   1 / spacing (float bits, finite, > 0; computed on the host, so both targets map rays
//           into voxel space with the same multiplications)
//   16-18   origin (float bits, finite): world position of voxel-space 0 (0 for volumes)
//   19      reserved, 0
//   20 + 16 n   node n's record (node 0 is the root; nodes level by level; the existing children
//           of a node are consecutive, in octant order):
//     +0    first child index; SYLVA_OCT_NONE when the node has no children
//     +1    bits 0-7: child mask (bit o set when octant o exists; 0 = a leaf of the octree);
//           bits 8-12: level l; bits 16-17: brick state (SYLVA_OCT_BRICK_*: 0 absent, 1 on the
//           host only, 2 resident in the brick buffer bound beside this index); bits 18-19:
//           the view-dependent cut (section 5; sylva/octree/cut.hpp writes them, 0 in a fresh
//           encoding = the full-resolution cut): bit 18 SYLVA_OCT_CUT_LEAF, the node is a leaf
//           of the cut (the walk does not descend below it); bit 19 SYLVA_OCT_CUT_BELOW, the node
//           lies below a cut leaf (outside the working set: a neighbour pointer landing on it
//           makes the walk descend again from the root); never both; other bits 0
//     +2    bits 0-15: coordinate x; bits 16-31: coordinate y (among the level's nodes)
//     +3    bits 0-15: coordinate z; bits 16-31: 0
//     +4..9 neighbour pointers across the faces -x, +x, -y, +y, -z, +z (Fig. 3): the node of the
//           same level just across, else the deepest coarser node containing the place just
//           across; SYLVA_OCT_NONE across the volume's boundary
//     +10   min (float bits): least density trilinear sampling in the node's box can return from
//           its brick or any brick below it
//     +11   max (float bits): the greatest
//     +12   brick index into the brick buffer (< M); SYLVA_OCT_NONE: no brick
//     +13..15 reserved, 0 (the out-of-core store's bookkeeping)
// Bricks are a separate buffer `bricks` of M * brick words words; sample (x, y, z) of brick i
// (each in [0, S), S = B + 2 b, x fastest) is sample j = x + S * (y + S * z) of the brick's words
// (from word i * brick words) and holds the (coarse) voxel c * B - b + (x, y, z) of the node's
// level, clamped to that level's extent (ceil(dims / 2^(L - 1 - l)) coarse voxels per axis):
//   float32  word j: the float bits of the normalised density
//   unorm16  bits 16 (j & 1) .. + 15 of word j >> 1: q, density q / 65535 (the paper's 16-bit texels)
//   unorm8   bits 8 (j & 3) .. + 7 of word j >> 2: q, density q / 255
// (sylva/shared/octree_brick.h: sylva_oct_brick_value). The integer formats read exactly as the grid samplers read a uint8 /
// uint16 volume normalised over its type's range (sylva/shared/grid_sample.h: (v - 0) / 255), so
// such a volume's octree renders the marcher's image bit for bit in a quarter (half) of the
// float32 bricks' memory; other densities are rounded to the nearest step (octree/build.hpp).
#ifndef SYLVA_SHARED_OCTREE_LAYOUT_H
#define SYLVA_SHARED_OCTREE_LAYOUT_H

#include "sylva/shared/lang.h"

#define SYLVA_OCT_MAGIC 0x54434F53u
#define SYLVA_OCT_VERSION 1u
#define SYLVA_OCT_HEADER_WORDS 20u
#define SYLVA_OCT_NODE_WORDS 16u
#define SYLVA_OCT_NONE 0xFFFFFFFFu
#define SYLVA_OCT_MAX_LEVELS 17u
#define SYLVA_OCT_MAX_DIM 16777215u
#define SYLVA_OCT_FORMAT_FLOAT32 0u
#define SYLVA_OCT_FORMAT_UNORM16 2u
#define SYLVA_OCT_FORMAT_UNORM8 3u
#define SYLVA_OCT_BRICK_ABSENT 0u
#define SYLVA_OCT_BRICK_HOST 1u
#define SYLVA_OCT_BRICK_RESIDENT 2u
#define SYLVA_OCT_CUT_LEAF 0x40000u
#define SYLVA_OCT_CUT_BELOW 0x80000u

SYLVA_BEGIN_NAMESPACE

/// The decoded header. `valid` is 1 only when every check of sylva_oct_read_header passed.
struct SylvaOctHeader {
    uvec3 dims;
    uint brick_size;
    uint border;
    uint levels;
    uint format;
    uint node_count;
    uint brick_count;
    uint brick_words;
    vec3 spacing;
    vec3 inv_spacing;
    vec3 origin;
    uint valid;
};

/// Least lg with 2^lg >= c (c >= 1).
SYLVA_FN uint sylva_oct_log2_ceil(uint c) {
    uint lg = 0u;
    while (lg < 31u && (1u << lg) < c) lg = lg + 1u;
    return lg;
}

/// Levels of an octree over `dims` voxels in bricks of b: 1 + ceil(log2(max ceil(dims / b))).
SYLVA_FN uint sylva_oct_level_count(uvec3 dims, uint b) {
    uint n = max(max((dims.x + b - 1u) / b, (dims.y + b - 1u) / b), (dims.z + b - 1u) / b);
    return 1u + sylva_oct_log2_ceil(n);
}

/// True for a finite float strictly above 0.
SYLVA_FN bool sylva_oct_positive(float x) { return x > 0.0f && x < sylva_inf(); }
/// True for a finite float.
SYLVA_FN bool sylva_oct_finite(float x) { return x > -sylva_inf() && x < sylva_inf(); }

/// The header's fields as stored, unchecked (valid = 0): the readers below and the element
/// octree's (sylva/shared/octree_elem_iter.h) check them for their format.
SYLVA_FN SylvaOctHeader sylva_oct_decode_header(SYLVA_BUF(words)) {
    SylvaOctHeader h;
    h.dims = uvec3(SYLVA_LOAD(words, 2u), SYLVA_LOAD(words, 3u), SYLVA_LOAD(words, 4u));
    uint packed = SYLVA_LOAD(words, 5u);
    h.brick_size = packed & 255u;
    h.border = (packed >> 8u) & 255u;
    h.levels = (packed >> 16u) & 255u;
    h.format = packed >> 24u;
    h.node_count = SYLVA_LOAD(words, 6u);
    h.brick_count = SYLVA_LOAD(words, 7u);
    h.brick_words = SYLVA_LOAD(words, 8u);
    h.spacing = vec3(uintBitsToFloat(SYLVA_LOAD(words, 10u)), uintBitsToFloat(SYLVA_LOAD(words, 11u)),
                     uintBitsToFloat(SYLVA_LOAD(words, 12u)));
    h.inv_spacing = vec3(uintBitsToFloat(SYLVA_LOAD(words, 13u)), uintBitsToFloat(SYLVA_LOAD(words, 14u)),
                         uintBitsToFloat(SYLVA_LOAD(words, 15u)));
    h.origin = vec3(uintBitsToFloat(SYLVA_LOAD(words, 16u)), uintBitsToFloat(SYLVA_LOAD(words, 17u)),
                    uintBitsToFloat(SYLVA_LOAD(words, 18u)));
    h.valid = 0u;
    return h;
}

/// The checks every octree header passes whatever its format (word 5 bits 24-31): magic,
/// version, the total size in word 9, reserved word 19, extents, spacing, 1 / spacing, origin.
/// Brick size, border, levels and the sizes after the header depend on the format.
SYLVA_FN bool sylva_oct_common_header_ok(SYLVA_BUF(words), uint word_count, SylvaOctHeader h) {
    bool ok = word_count >= SYLVA_OCT_HEADER_WORDS && SYLVA_LOAD(words, 0u) == SYLVA_OCT_MAGIC &&
              SYLVA_LOAD(words, 1u) == SYLVA_OCT_VERSION && SYLVA_LOAD(words, 9u) == word_count &&
              SYLVA_LOAD(words, 19u) == 0u;
    ok = ok && h.dims.x >= 1u && h.dims.y >= 1u && h.dims.z >= 1u && h.dims.x <= SYLVA_OCT_MAX_DIM &&
         h.dims.y <= SYLVA_OCT_MAX_DIM && h.dims.z <= SYLVA_OCT_MAX_DIM;
    ok = ok && sylva_oct_positive(h.spacing.x) && sylva_oct_positive(h.spacing.y) && sylva_oct_positive(h.spacing.z);
    ok = ok && sylva_oct_positive(h.inv_spacing.x) && sylva_oct_positive(h.inv_spacing.y) &&
         sylva_oct_positive(h.inv_spacing.z);
    ok = ok && sylva_oct_finite(h.origin.x) && sylva_oct_finite(h.origin.y) && sylva_oct_finite(h.origin.z);
    return ok;
}

/// True for a brick format of the volume octree (float32, unorm16, unorm8).
SYLVA_FN bool sylva_oct_brick_format_ok(uint format) {
    return format == SYLVA_OCT_FORMAT_FLOAT32 || format == SYLVA_OCT_FORMAT_UNORM16 || format == SYLVA_OCT_FORMAT_UNORM8;
}

/// Words of one brick of `side`^3 samples in `format` (side <= 132: no overflow).
SYLVA_FN uint sylva_oct_brick_word_count(uint side, uint format) {
    uint samples = side * side * side;
    if (format == SYLVA_OCT_FORMAT_UNORM16) return (samples + 1u) / 2u;
    if (format == SYLVA_OCT_FORMAT_UNORM8) return (samples + 3u) / 4u;
    return samples;
}

/// Reads and checks the header of an index of `word_count` words beside a brick buffer of
/// `brick_buffer_words` words: the common checks, a brick format of this octree, brick size,
/// border, level count, node count against the size, brick words and count against the brick
/// buffer. Invalid: valid = 0. Node records are not checked here (sylva/octree/validate.hpp
/// does; the iterator stops with an error on inconsistent ones).
SYLVA_FN SylvaOctHeader sylva_oct_read_header(SYLVA_BUF(words), uint word_count, uint brick_buffer_words) {
    SylvaOctHeader h = sylva_oct_decode_header(SYLVA_PASS_BUF(words));
    bool ok = sylva_oct_common_header_ok(SYLVA_PASS_BUF(words), word_count, h) && sylva_oct_brick_format_ok(h.format);
    ok = ok && h.brick_size >= 4u && h.brick_size <= 64u && (h.brick_size & (h.brick_size - 1u)) == 0u &&
         h.border >= 1u && h.border <= 2u;
    ok = ok && h.levels == sylva_oct_level_count(h.dims, h.brick_size) && h.levels <= SYLVA_OCT_MAX_LEVELS;
    uint side = h.brick_size + 2u * h.border;
    ok = ok && h.brick_words == sylva_oct_brick_word_count(side, h.format);
    // Node count against the size, without overflow: (word_count - 20) / 16 records exactly.
    ok = ok && h.node_count >= 1u && (word_count - SYLVA_OCT_HEADER_WORDS) / SYLVA_OCT_NODE_WORDS == h.node_count &&
         (word_count - SYLVA_OCT_HEADER_WORDS) % SYLVA_OCT_NODE_WORDS == 0u;
    ok = ok && h.brick_words > 0u && brick_buffer_words / h.brick_words == h.brick_count &&
         brick_buffer_words % h.brick_words == 0u;
    if (ok) h.valid = 1u;
    return h;
}

/// Word offset of node n's record.
SYLVA_FN uint sylva_oct_node_at(uint n) { return SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n; }

/// Fields of node n's record (see the table above).
SYLVA_FN uint sylva_oct_first_child(SYLVA_BUF(words), uint n) { return SYLVA_LOAD(words, sylva_oct_node_at(n)); }
SYLVA_FN uint sylva_oct_flags(SYLVA_BUF(words), uint n) { return SYLVA_LOAD(words, sylva_oct_node_at(n) + 1u); }
SYLVA_FN uint sylva_oct_child_mask(uint flags) { return flags & 255u; }
SYLVA_FN uint sylva_oct_level(uint flags) { return (flags >> 8u) & 31u; }
SYLVA_FN uint sylva_oct_brick_state(uint flags) { return (flags >> 16u) & 3u; }
SYLVA_FN uvec3 sylva_oct_coord(SYLVA_BUF(words), uint n) {
    uint xy = SYLVA_LOAD(words, sylva_oct_node_at(n) + 2u);
    uint z = SYLVA_LOAD(words, sylva_oct_node_at(n) + 3u);
    return uvec3(xy & 0xFFFFu, xy >> 16u, z & 0xFFFFu);
}
SYLVA_FN uint sylva_oct_neighbour(SYLVA_BUF(words), uint n, uint face) {
    return SYLVA_LOAD(words, sylva_oct_node_at(n) + 4u + face);
}
SYLVA_FN vec2 sylva_oct_range(SYLVA_BUF(words), uint n) {
    return vec2(uintBitsToFloat(SYLVA_LOAD(words, sylva_oct_node_at(n) + 10u)),
                uintBitsToFloat(SYLVA_LOAD(words, sylva_oct_node_at(n) + 11u)));
}
SYLVA_FN uint sylva_oct_brick(SYLVA_BUF(words), uint n) { return SYLVA_LOAD(words, sylva_oct_node_at(n) + 12u); }

/// Index of child `octant` of a node whose first child and mask are given: children are stored
/// consecutively, so it is first + the number of existing octants before it.
SYLVA_FN uint sylva_oct_child(uint first, uint mask, uint octant) {
    return first + uint(bitCount(mask & ((1u << octant) - 1u)));
}

/// Width in voxels of a node of level l: B * 2^(L - 1 - l) (l < L).
SYLVA_FN uint sylva_oct_width(SYLVA_IN(SylvaOctHeader) h, uint level) { return h.brick_size << (h.levels - 1u - level); }

/// Voxel-space box [lo, hi] of the node of level l with coordinates c, clipped to the volume.
SYLVA_FN void sylva_oct_box(SYLVA_IN(SylvaOctHeader) h, uint level, uvec3 c, SYLVA_OUT(vec3) lo, SYLVA_OUT(vec3) hi) {
    uint w = sylva_oct_width(h, level);
    lo = vec3(float(c.x * w), float(c.y * w), float(c.z * w));
    hi = vec3(float(min(c.x * w + w, h.dims.x)), float(min(c.y * w + w, h.dims.y)), float(min(c.z * w + w, h.dims.z)));
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_OCTREE_LAYOUT_H
