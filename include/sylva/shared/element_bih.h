// sylva/shared/element_bih.h -- the BIH as an element index for the generic kernels of
// sylva/shared/element_kernels.h.
//
// An element index is an iterator state type I with these overloads (C++ and GLSL both resolve
// them by I, so several indices can sit in one translation unit); element_kd.h and
// element_octree.h adapt the kd-tree and the octree over elements the same way:
//
//   void  sylva_index_init(SYLVA_OUT(I) it, SYLVA_BUF(words), uint word_count, vec3 o, vec3 d,
//                          float t_min, float t_max);
//   bool  sylva_index_leaf(SYLVA_INOUT(I) it, SYLVA_BUF(words), SYLVA_OUT(uint) first,
//                          SYLVA_OUT(uint) count, SYLVA_OUT(float) t_in, SYLVA_OUT(float) t_out);
//         The next leaf: its references [first, first + count) and the ray's interval in it.
//   uint  sylva_index_element(SYLVA_INOUT(I) it, SYLVA_BUF(words), uint at);
//         Reference `at` of the current leaf as a record index (BIH: `at` itself).
//   bool  sylva_index_keeps(SYLVA_INOUT(I) it, float t, float t_in, float t_out);
//         Whether the leaf with [t_in, t_out] keeps a hit entering at t: indices that list an
//         element in several leaves keep it in one (kd-tree, octree: the leaf that claims t).
//   float sylva_index_bound(SYLVA_INOUT(I) it, float t_out);
//         A lower bound on the entry of every hit still to come from later leaves (+inf when
//         none; t_out is the current leaf's end). It makes ordering exact where leaves overlap:
//         element_kernels.h hands a hit out once everything to come starts strictly after it.
//   void  sylva_index_clip(SYLVA_INOUT(I) it, float t);
//         Leaves entered after t are no longer needed (a no-op is correct, only slower).
//   uint  sylva_index_status(SYLVA_INOUT(I) it);   SYLVA_ITER_RUNNING / DONE / ERROR
//   uint  sylva_index_steps(SYLVA_INOUT(I) it);    nodes visited (the heat map)
//
// The BIH's encoding must hold record ranges (payload kind SYLVA_PAYLOAD_RANGE, the default of
// sylva::bih::encode): other kinds end the iteration with status ERROR. Its siblings overlap, so
// its bound is the smallest entry among the subtrees still on the traversal stack.
#ifndef SYLVA_SHARED_ELEMENT_BIH_H
#define SYLVA_SHARED_ELEMENT_BIH_H

#include "sylva/shared/bih_iter.h"

SYLVA_BEGIN_NAMESPACE

SYLVA_FN void sylva_index_init(SYLVA_OUT(SylvaBihIter) it, SYLVA_BUF(words), uint word_count, vec3 o, vec3 d,
                               float t_min, float t_max) {
    sylva_bih_init(it, SYLVA_PASS_BUF(words), word_count, o, d, t_min, t_max);
    if (it.status != SYLVA_ITER_ERROR && ((it.hdr.flags >> 8u) & 255u) != SYLVA_PAYLOAD_RANGE) {
        it.status = SYLVA_ITER_ERROR;  // leaves do not hold record ranges
    }
}

SYLVA_FN bool sylva_index_leaf(SYLVA_INOUT(SylvaBihIter) it, SYLVA_BUF(words), SYLVA_OUT(uint) first,
                               SYLVA_OUT(uint) count, SYLVA_OUT(float) t_in, SYLVA_OUT(float) t_out) {
    uint leaf;
    t_in = 0.0f;
    t_out = 0.0f;
    first = 0u;
    count = 0u;
    if (it.status == SYLVA_ITER_ERROR || !sylva_bih_next(it, SYLVA_PASS_BUF(words), leaf, t_in, t_out)) return false;
    uvec2 p = sylva_bih_payload(SYLVA_PASS_BUF(words), it.hdr, leaf);
    first = p.x;
    count = p.y;
    return true;
}

/// A range leaf's references are the records themselves.
SYLVA_FN uint sylva_index_element(SYLVA_INOUT(SylvaBihIter) it, SYLVA_BUF(words), uint at) {
    SYLVA_UNUSED(it);
    SYLVA_UNUSED(words);
    return at;
}

/// Every BIH leaf keeps its hits: an element sits in one leaf.
SYLVA_FN bool sylva_index_keeps(SYLVA_INOUT(SylvaBihIter) it, float t, float t_in, float t_out) {
    SYLVA_UNUSED(it);
    SYLVA_UNUSED(t);
    SYLVA_UNUSED(t_in);
    SYLVA_UNUSED(t_out);
    return true;
}

/// The smallest entry among the subtrees still on the stack (and the node to visit next).
SYLVA_FN float sylva_index_bound(SYLVA_INOUT(SylvaBihIter) it, float t_out) {
    SYLVA_UNUSED(t_out);
    float b = (it.node != SYLVA_NO_NODE) ? it.t_in : sylva_inf();
    return sylva_min(b, sylva_bih_stack_min_in(it));
}

SYLVA_FN void sylva_index_clip(SYLVA_INOUT(SylvaBihIter) it, float t) { sylva_bih_clip(it, t); }

SYLVA_FN uint sylva_index_status(SYLVA_INOUT(SylvaBihIter) it) { return it.status; }
SYLVA_FN uint sylva_index_steps(SYLVA_INOUT(SylvaBihIter) it) { return it.steps; }

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ELEMENT_BIH_H
