// sylva/shared/octree_elem_iter.h -- the element octree (sylva/octree/elements.hpp): its
// encoding, which is the volume octree's (sylva/shared/octree_layout.h) with a second format,
// and its ordered leaf iterator, which is the volume octree's stackless neighbour-pointer walk
// (sylva/shared/octree_iter.h, Gobbetti et al. section 5.2, Fig. 5) with element references.
//
// Voxel space. The elements' bounding box, padded by 2 lattice cells on each side, is cut into
// a lattice of cubic cells of world size `spacing` (the same on every axis); dims is the padded
// box in cells. Node boxes follow octree_layout.h exactly (B = 4, W_l = 4 * 2^(L - 1 - l)).
//
// Index words: octree_layout.h's table, with these differences (format 1 in word 5):
//   5       bits 0-7: B = 4 (cells per side of a deepest leaf); bits 8-15: 1 (no bricks: unused,
//           kept in the volume range); bits 16-23: levels L; bits 24-31:
//           SYLVA_OCTE_FORMAT_ELEMENTS (1)
//   7       element count E: every reference is < E
//   8       reference words R: the words after the node records
//   9       total index words: 20 + 16 N + R
//   16-18   origin: world position of lattice point 0 (the padded box's corner)
//   20 + 16 n  node n's record, as octree_layout.h, except:
//     +1    brick state bits 16-17: SYLVA_OCT_BRICK_RESIDENT (2) on a leaf with references (the
//           list is in this buffer), SYLVA_OCT_BRICK_ABSENT (0) otherwise
//     +10, +11  0 (no densities)
//     +12   word offset (into this index) of the leaf's reference list; SYLVA_OCT_NONE on inner
//           nodes and on leaves that no element overlaps
//   20 + 16 N .. end  reference lists: word 0 the count c >= 1, words 1..c the element indices
//           (the caller's element order), ascending
// Every leaf lists each element whose box, padded by a fraction of a cell (Config::overlap_pad),
// overlaps the leaf's closed box: "straddling references". An element is therefore met in
// every leaf the ray crosses inside it, and the caller keeps an element hit (or a particle's
// contribution) only in the leaf whose interval [t0, t1) holds its entry t (its t_c), which the
// padding guarantees is one of the element's leaves despite rounding.
//
//   SylvaOctElemIter it;
//   sylva_octe_init(it, words, word_count, origin, direction, t_min, t_max);
//   uint node; float t0; float t1; uint first; uint count;
//   while (sylva_octe_next(it, words, node, t0, t1, first, count)) {
//       for (uint k = 0u; k < count; k++) { uint e = SYLVA_LOAD(words, first + k); ... }
//   }
//
// Leaves come front to back, as octree_iter.h yields them, skipping leaves without references.
// Corrupted encodings: a refused header ends with ERROR at init; a reference list outside the
// reference words, or with a count of 0, ends with ERROR; element indices are checked by the
// caller against it.elem_count (sylva_octe_element does). Loads never leave the buffer.
#ifndef SYLVA_SHARED_OCTREE_ELEM_ITER_H
#define SYLVA_SHARED_OCTREE_ELEM_ITER_H

#include "sylva/shared/octree_iter.h"

/// Word 5 bits 24-31 of an element octree (a volume octree has SYLVA_OCT_FORMAT_FLOAT32, 0).
#define SYLVA_OCTE_FORMAT_ELEMENTS 1u
/// Cells per side of the deepest leaves (the layout's brick size B).
#define SYLVA_OCTE_CELLS 4u

SYLVA_BEGIN_NAMESPACE

/// Reads and checks an element octree's header (word_count: the index's size). The result is
/// octree_layout.h's header with brick_count = element count and brick_words = reference words;
/// valid = 0 on any failed check (magic, version, format 1, extents, B = 4, levels, sizes,
/// spacing, 1 / spacing, origin).
SYLVA_FN SylvaOctHeader sylva_octe_read_header(SYLVA_BUF(words), uint word_count) {
    SylvaOctHeader h = sylva_oct_decode_header(SYLVA_PASS_BUF(words));
    bool ok = sylva_oct_common_header_ok(SYLVA_PASS_BUF(words), word_count, h) && h.format == SYLVA_OCTE_FORMAT_ELEMENTS;
    ok = ok && h.brick_size == SYLVA_OCTE_CELLS && h.border == 1u;
    ok = ok && h.levels == sylva_oct_level_count(h.dims, h.brick_size) && h.levels <= SYLVA_OCT_MAX_LEVELS;
    // 20 + 16 N + R == word_count, without overflow.
    uint body = word_count - SYLVA_OCT_HEADER_WORDS;
    ok = ok && h.node_count >= 1u && h.node_count <= body / SYLVA_OCT_NODE_WORDS &&
         body - SYLVA_OCT_NODE_WORDS * h.node_count == h.brick_words;
    if (ok) h.valid = 1u;
    return h;
}

/// The element octree's iterator: octree_iter.h's walk plus where the reference lists are.
struct SylvaOctElemIter {
    SylvaOctIter walk;  ///< the stackless neighbour-pointer walk; walk.status is the status
    uint refs_begin;    ///< first reference word (20 + 16 N)
    uint word_count;    ///< index size
    uint elem_count;    ///< E: references must be below it
};

/// Starts a front-to-back walk of origin + t * direction over [t_min, t_max] (world space)
/// through the element octree `words` of `word_count` words, down to its leaves.
SYLVA_FN void sylva_octe_init(SYLVA_OUT(SylvaOctElemIter) it, SYLVA_BUF(words), uint word_count, vec3 origin,
                              vec3 direction, float t_min, float t_max) {
    SylvaOctHeader h = sylva_octe_read_header(SYLVA_PASS_BUF(words), word_count);
    it.refs_begin = SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * h.node_count;
    it.word_count = word_count;
    it.elem_count = h.brick_count;
    sylva_oct_begin(it.walk, h, origin, direction, t_min, t_max, 0xFFFFFFFFu);
    // octree_iter.h bounds the steps by the deepest cells a ray can cross, (4 * 2^16 * 3) *
    // (4 L + 8) = 1.5e7 for a 17-level element octree: far beyond what a corrupted walk should
    // spin through, and beyond lavapipe's guard on loop iterations (65535, after which the loop
    // silently exits with the status still RUNNING). A valid walk enters each node during one
    // piece of the ray (neighbour pointers lead to inner nodes only at the same level), so
    // (N + 2) (4 L + 8) bounds it too; the smaller bound ends corrupted walks sooner.
    uint by_nodes = (min(h.node_count, 0x00FFFFFFu) + 2u) * (4u * min(h.levels, 32u) + 8u);
    it.walk.step_limit = min(it.walk.step_limit, by_nodes);
}

/// The next leaf with references: its node, the ray's [t0, t1] in it, and its reference list
/// as word offsets [first, first + count) into `words`. False at the end (it.walk.status DONE)
/// or on a corrupted encoding (ERROR).
SYLVA_FN bool sylva_octe_next(SYLVA_INOUT(SylvaOctElemIter) it, SYLVA_BUF(words), SYLVA_OUT(uint) node,
                              SYLVA_OUT(float) t0, SYLVA_OUT(float) t1, SYLVA_OUT(uint) first, SYLVA_OUT(uint) count) {
    first = 0u;
    count = 0u;
    while (sylva_oct_next(it.walk, SYLVA_PASS_BUF(words), node, t0, t1)) {
        uint at = sylva_oct_brick(SYLVA_PASS_BUF(words), node);
        if (at == SYLVA_OCT_NONE) continue;  // a leaf no element overlaps
        uint c = (at >= it.refs_begin && at < it.word_count) ? SYLVA_LOAD(words, at) : 0u;
        if (c == 0u || c > it.word_count - at - 1u) {
            it.walk.status = SYLVA_ITER_ERROR;
            return false;
        }
        first = at + 1u;
        count = c;
        return true;
    }
    return false;
}

/// Reference word `at` (from [first, first + count)) as an element index; SYLVA_OCT_NONE and
/// status ERROR when it is not below the element count.
SYLVA_FN uint sylva_octe_element(SYLVA_INOUT(SylvaOctElemIter) it, SYLVA_BUF(words), uint at) {
    uint e = SYLVA_LOAD(words, at);
    if (e >= it.elem_count) {
        it.walk.status = SYLVA_ITER_ERROR;
        return SYLVA_OCT_NONE;
    }
    return e;
}

/// True when an element whose entry (or closest approach) is at t belongs to the leaf the
/// walk yielded with [t0, t1]: t in [t0, t1), or t == t1 at the walk's end. Consecutive leaves
/// share their end points bit for bit, so each t is claimed by exactly one leaf.
SYLVA_FN bool sylva_octe_claims(SylvaOctElemIter it, float t, float t0, float t1) {
    return t >= t0 && (t < t1 || (t == t1 && t1 >= it.walk.t_end));
}

/// Ends the walk at t (first hits, early ray termination).
SYLVA_FN void sylva_octe_clip(SYLVA_INOUT(SylvaOctElemIter) it, float t) { sylva_oct_clip(it.walk, t); }

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_OCTREE_ELEM_ITER_H
