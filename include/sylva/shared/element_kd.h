// sylva/shared/element_kd.h -- the kd-tree over elements (sylva/shared/kd_elem_iter.h) as an
// element index for the generic kernels of sylva/shared/element_kernels.h (the adapter protocol
// is described in sylva/shared/element_bih.h). Its leaves tile the ray front to back, an element
// listed in several leaves is kept by the one that claims its entry t (sylva_kde_claims), so
// every later hit starts at or after the current leaf's end: that end is the bound. Records are
// in the caller's element order (the references are element indices).
#ifndef SYLVA_SHARED_ELEMENT_KD_H
#define SYLVA_SHARED_ELEMENT_KD_H

#include "sylva/shared/kd_elem_iter.h"

SYLVA_BEGIN_NAMESPACE

SYLVA_FN void sylva_index_init(SYLVA_OUT(SylvaKdElemIter) it, SYLVA_BUF(words), uint word_count, vec3 o, vec3 d,
                               float t_min, float t_max) {
    sylva_kde_init(it, SYLVA_PASS_BUF(words), word_count, o, d, t_min, t_max);
}

SYLVA_FN bool sylva_index_leaf(SYLVA_INOUT(SylvaKdElemIter) it, SYLVA_BUF(words), SYLVA_OUT(uint) first,
                               SYLVA_OUT(uint) count, SYLVA_OUT(float) t_in, SYLVA_OUT(float) t_out) {
    uint node;
    return sylva_kde_next(it, SYLVA_PASS_BUF(words), node, t_in, t_out, first, count);
}

SYLVA_FN uint sylva_index_element(SYLVA_INOUT(SylvaKdElemIter) it, SYLVA_BUF(words), uint at) {
    return sylva_kde_element(it, SYLVA_PASS_BUF(words), at);
}

SYLVA_FN bool sylva_index_keeps(SYLVA_INOUT(SylvaKdElemIter) it, float t, float t_in, float t_out) {
    return sylva_kde_claims(it, t, t_in, t_out);
}

/// Later leaves start where the current one ends.
SYLVA_FN float sylva_index_bound(SYLVA_INOUT(SylvaKdElemIter) it, float t_out) {
    SYLVA_UNUSED(it);
    return t_out;
}

SYLVA_FN void sylva_index_clip(SYLVA_INOUT(SylvaKdElemIter) it, float t) { sylva_kde_clip(it, t); }
SYLVA_FN uint sylva_index_status(SYLVA_INOUT(SylvaKdElemIter) it) { return it.status; }
SYLVA_FN uint sylva_index_steps(SYLVA_INOUT(SylvaKdElemIter) it) { return it.steps; }

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ELEMENT_KD_H
