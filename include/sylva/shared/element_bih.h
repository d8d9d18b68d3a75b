// sylva/shared/element_bih.h -- the BIH as an element index for the generic kernels of
// sylva/shared/element_kernels.h.
//
// An element index is an iterator state type I with these overloads (C++ and GLSL both resolve
// them by I, so several indices can sit in one translation unit):
//
//   void  sylva_index_init(SYLVA_OUT(I) it, SYLVA_BUF(words), uint word_count, vec3 o, vec3 d,
//                          float t_min, float t_max);
//   bool  sylva_index_leaf(SYLVA_INOUT(I) it, SYLVA_BUF(words), SYLVA_OUT(uint) first,
//                          SYLVA_OUT(uint) count, SYLVA_OUT(float) t_in);
//         The next leaf (records [first, first + count)) and the ray's entry into its box.
//   float sylva_index_bound(SYLVA_INOUT(I) it);
//         A lower bound on t_in of every leaf still to come (+inf when none): what makes
//         ordering exact where leaves overlap (element_kernels.h emits a hit once no later leaf
//         can hold an earlier one).
//   void  sylva_index_clip(SYLVA_INOUT(I) it, float t);
//         Leaves entered after t are no longer needed (a no-op is correct, only slower).
//   uint  sylva_index_status(SYLVA_INOUT(I) it);   SYLVA_ITER_RUNNING / DONE / ERROR
//   uint  sylva_index_steps(SYLVA_INOUT(I) it);    nodes visited (the heat map)
//
// The BIH's encoding must hold record ranges (payload kind SYLVA_PAYLOAD_RANGE, the default of
// sylva::bih::encode): other kinds end the iteration with status ERROR.
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
                               SYLVA_OUT(uint) count, SYLVA_OUT(float) t_in) {
    uint leaf;
    float t1;
    t_in = 0.0f;
    first = 0u;
    count = 0u;
    if (it.status == SYLVA_ITER_ERROR || !sylva_bih_next(it, SYLVA_PASS_BUF(words), leaf, t_in, t1)) return false;
    uvec2 p = sylva_bih_payload(SYLVA_PASS_BUF(words), it.hdr, leaf);
    first = p.x;
    count = p.y;
    return true;
}

/// The smallest entry among the subtrees still on the stack (and the node to visit next).
SYLVA_FN float sylva_index_bound(SYLVA_INOUT(SylvaBihIter) it) {
    float b = (it.node != SYLVA_NO_NODE) ? it.t_in : sylva_inf();
    for (uint i = 0u; i < it.sp; i++) b = sylva_min(b, SYLVA_BIH_STACK(it).st_in[i]);
    return b;
}

SYLVA_FN void sylva_index_clip(SYLVA_INOUT(SylvaBihIter) it, float t) { sylva_bih_clip(it, t); }

SYLVA_FN uint sylva_index_status(SYLVA_INOUT(SylvaBihIter) it) { return it.status; }
SYLVA_FN uint sylva_index_steps(SYLVA_INOUT(SylvaBihIter) it) { return it.steps; }

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ELEMENT_BIH_H
