// sylva/shared/kd_elem_iter.h -- the kd-tree over any bounded element type
// (sylva/kdtree/elements.hpp): its flat encoding and its ordered, front-to-back leaf iterator in
// the shared C++/GLSL subset (sylva/shared/lang.h), with the shape of the element octree's
// (octree_elem_iter.h): init, next leaf (its ray interval [t0, t1] and its reference list),
// element lookup, claims, clip.
//
// Index words (all 32-bit; floats as their bits):
//   0       magic SYLVA_KDE_MAGIC ('SKDE')
//   1       version SYLVA_KDE_VERSION
//   2       node count N >= 1
//   3       element count E: every reference is < E
//   4       reference words R (the words after the node records)
//   5       total words: SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS N + R
//   6       depth of the deepest leaf (root 0); at most SYLVA_KDE_STACK_SIZE
//   7       0
//   8-10    root box lo (x, y, z), 11-13 root box hi: the elements' padded box
//   14-15   0
//   16 + 2n node n's record, pre-order (an inner node's lower child is n + 1):
//     +0    meta: bits 0-1 (SYLVA_KDE_AXIS_MASK) the split axis 0..2, or SYLVA_KDE_LEAF (3);
//           bits 2-31 (>> SYLVA_KDE_INDEX_SHIFT): an inner node's upper child (n + 1 < it < N),
//           a leaf's reference count c (0: no element overlaps the leaf)
//     +1    inner: the split plane (float); leaf: word offset of its first reference
//   16 + 2N .. end: the leaves' references, element indices in the caller's element order,
//           ascending per leaf
//
// Straddling references: a leaf lists every element whose padded box (kdtree::ElementConfig::
// overlap_pad) overlaps its closed cell; the lower child of a split at s holds the cell's part
// with coordinate <= s, the upper child the part >= s. The leaves' cells tile the root box
// without overlap, so the leaves come front to back with intervals that tile the ray: each leaf
// starts where the previous one ended, bit for bit. An element met in several leaves is kept
// (a hit, a particle's contribution) only in the leaf that claims its entry t
// (sylva_kde_claims: t in [t0, t1), or t == t1 at the walk's end): exact ordering across leaves.
//
//   SylvaKdElemIter it;
//   sylva_kde_init(it, words, word_count, origin, direction, t_min, t_max);
//   uint node; float t0; float t1; uint first; uint count;
//   while (sylva_kde_next(it, words, node, t0, t1, first, count)) {
//       for (uint k = 0u; k < count; k++) { uint e = sylva_kde_element(it, words, first + k); ... }
//   }
//
// Robustness: a refused header (magic, version, sizes, depth over the stack, a non-finite or
// inverted box) ends with ERROR at init; a child index that does not follow its parent, a
// reference list outside the reference words, a reference not below E (sylva_kde_element) or
// more steps than nodes end with ERROR. Loads never leave the buffer; the walk visits each node
// at most once, so it ends after at most N steps.
//
// In GLSL the stack is a private global (one live iterator per invocation, as kd_iter.h); in
// C++ it is part of the state.
#ifndef SYLVA_SHARED_KD_ELEM_ITER_H
#define SYLVA_SHARED_KD_ELEM_ITER_H

#include "sylva/shared/ray_box.h"

#ifndef SYLVA_ITER_RUNNING
#define SYLVA_ITER_RUNNING 0u
#define SYLVA_ITER_DONE 1u
#define SYLVA_ITER_ERROR 2u
#endif

#define SYLVA_KDE_MAGIC 0x45444B53u
#define SYLVA_KDE_VERSION 1u
#define SYLVA_KDE_HEADER_WORDS 16u
#define SYLVA_KDE_NODE_WORDS 2u
/// Meta word: bits 0-1 axis or leaf, bits 2-31 upper child or reference count.
#define SYLVA_KDE_AXIS_MASK 3u
#define SYLVA_KDE_INDEX_SHIFT 2u
#define SYLVA_KDE_LEAF 3u
#define SYLVA_KDE_NONE 0xFFFFFFFFu
/// Stack entries: the deepest tree the iterator walks (the builder caps max_depth below it).
#define SYLVA_KDE_STACK_SIZE 64

SYLVA_BEGIN_NAMESPACE

struct SylvaKdeHeader {
    uint valid;
    uint node_count;
    uint elem_count;
    uint ref_words;
    uint depth;
    vec3 lo;
    vec3 hi;
};

SYLVA_FN vec3 sylva_kde_load_vec3(SYLVA_BUF(words), uint at) {
    return vec3(uintBitsToFloat(SYLVA_LOAD(words, at)), uintBitsToFloat(SYLVA_LOAD(words, at + 1u)),
                uintBitsToFloat(SYLVA_LOAD(words, at + 2u)));
}

/// Reads and checks the header (word_count: the buffer's size); valid = 0 on any failed check.
SYLVA_FN SylvaKdeHeader sylva_kde_read_header(SYLVA_BUF(words), uint word_count) {
    SylvaKdeHeader h;
    h.valid = 0u;
    h.node_count = 0u;
    h.elem_count = 0u;
    h.ref_words = 0u;
    h.depth = 0u;
    h.lo = vec3(0.0f);
    h.hi = vec3(0.0f);
    if (word_count < SYLVA_KDE_HEADER_WORDS) return h;
    if (SYLVA_LOAD(words, 0u) != SYLVA_KDE_MAGIC || SYLVA_LOAD(words, 1u) != SYLVA_KDE_VERSION) return h;
    h.node_count = SYLVA_LOAD(words, 2u);
    h.elem_count = SYLVA_LOAD(words, 3u);
    h.ref_words = SYLVA_LOAD(words, 4u);
    h.depth = SYLVA_LOAD(words, 6u);
    h.lo = sylva_kde_load_vec3(SYLVA_PASS_BUF(words), 8u);
    h.hi = sylva_kde_load_vec3(SYLVA_PASS_BUF(words), 11u);
    uint body = word_count - SYLVA_KDE_HEADER_WORDS;
    bool ok = SYLVA_LOAD(words, 5u) == word_count && h.node_count >= 1u && h.node_count <= body / SYLVA_KDE_NODE_WORDS &&
              body - SYLVA_KDE_NODE_WORDS * h.node_count == h.ref_words && h.depth <= uint(SYLVA_KDE_STACK_SIZE);
    for (uint a = 0u; a < 3u; a++) {
        float l = sylva_kd_pick(h.lo, a);
        float u = sylva_kd_pick(h.hi, a);
        ok = ok && !sylva_kd_not_finite(l) && !sylva_kd_not_finite(u) && l <= u;
    }
    if (ok) h.valid = 1u;
    return h;
}

/// Subtrees still to visit: node and ray interval inside its cell.
struct SylvaKdeStack {
    uint st_node[SYLVA_KDE_STACK_SIZE];
    float st_in[SYLVA_KDE_STACK_SIZE];
    float st_out[SYLVA_KDE_STACK_SIZE];
};

struct SylvaKdElemIter {
    SylvaKdeHeader hdr;
    vec3 org;        ///< ray origin
    vec3 rcp;        ///< safe reciprocal of the direction (+-inf where parallel)
    uvec3 parallel;  ///< 1 where the ray is parallel to an axis
    float t_end;     ///< end of the ray inside the root box (the last leaf claims t == t_end)
    float t_limit;   ///< subtrees entered after this are pruned (sylva_kde_clip)
    uint node;       ///< node to visit next, SYLVA_KDE_NONE to pop
    float t_in;
    float t_out;
    uint refs_begin;  ///< first reference word
    uint word_count;
    uint elem_count;
    uint sp;
    uint steps;  ///< nodes visited so far
    uint status;
#ifdef __cplusplus
    SylvaKdeStack stack;
#endif
};

#ifdef __cplusplus
#define SYLVA_KDE_STACK(it) (it).stack
#else
SylvaKdeStack sylva_kde_stack_private;
#define SYLVA_KDE_STACK(it) sylva_kde_stack_private
#endif

/// Starts a front-to-back walk of origin + t * direction over [t_min, t_max] through `words`.
SYLVA_FN void sylva_kde_init(SYLVA_OUT(SylvaKdElemIter) it, SYLVA_BUF(words), uint word_count, vec3 origin,
                             vec3 direction, float t_min, float t_max) {
    it.hdr = sylva_kde_read_header(SYLVA_PASS_BUF(words), word_count);
    it.refs_begin = SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS * it.hdr.node_count;
    it.word_count = word_count;
    it.elem_count = it.hdr.elem_count;
    it.sp = 0u;
    it.steps = 0u;
    it.node = SYLVA_KDE_NONE;
    it.t_in = 0.0f;
    it.t_out = 0.0f;
    it.t_end = 0.0f;
    it.t_limit = t_max;
    it.org = vec3(0.0f);
    it.rcp = vec3(0.0f);
    it.parallel = uvec3(0u);
    it.status = SYLVA_ITER_RUNNING;
    if (it.hdr.valid == 0u) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    bool nan_ray = sylva_ray_to_grid(origin, direction, vec3(0.0f), vec3(1.0f), t_min, t_max, it.org, it.rcp, it.parallel);
    vec2 t = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, it.hdr.lo, it.hdr.hi, t_min, t_max);
    if (nan_ray || !(t.x <= t.y)) {
        it.status = SYLVA_ITER_DONE;
        return;
    }
    it.node = 0u;
    it.t_in = t.x;
    it.t_out = t.y;
    it.t_end = t.y;
}

/// Prunes every subtree the ray would enter after t (first hits, early ray termination).
SYLVA_FN void sylva_kde_clip(SYLVA_INOUT(SylvaKdElemIter) it, float t) { it.t_limit = sylva_min(it.t_limit, t); }

SYLVA_FN void sylva_kde_push(SYLVA_INOUT(SylvaKdElemIter) it, uint node, float t0, float t1) {
    if (it.sp >= uint(SYLVA_KDE_STACK_SIZE)) {  // unreachable for headers whose depth fits
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    SYLVA_KDE_STACK(it).st_node[it.sp] = node;
    SYLVA_KDE_STACK(it).st_in[it.sp] = t0;
    SYLVA_KDE_STACK(it).st_out[it.sp] = t1;
    it.sp = it.sp + 1u;
}

/// Pops the next subtree that starts no later than t_limit; false when none is left.
SYLVA_FN bool sylva_kde_pop(SYLVA_INOUT(SylvaKdElemIter) it) {
    while (it.sp > 0u) {
        it.sp = it.sp - 1u;
        if (SYLVA_KDE_STACK(it).st_in[it.sp] <= it.t_limit) {
            it.node = SYLVA_KDE_STACK(it).st_node[it.sp];
            it.t_in = SYLVA_KDE_STACK(it).st_in[it.sp];
            it.t_out = SYLVA_KDE_STACK(it).st_out[it.sp];
            return true;
        }
    }
    return false;
}

/// Inner node n split along `axis` at `split`, children n + 1 (lower) and `upper`: the ray
/// continues in the near child it crosses and pushes the far one when it crosses both. The near
/// child gets [t_in, ts], the far one [ts, t_out] (ts where the ray meets the plane), so the
/// leaves' intervals tile the ray. A ray parallel to the plane stays on its origin's side (the
/// lower one when it lies in the plane: an element it can hit there overlaps both children).
SYLVA_FN void sylva_kde_descend(SYLVA_INOUT(SylvaKdElemIter) it, uint n, uint axis, float split, uint upper) {
    float o = sylva_kd_pick(it.org, axis);
    if (sylva_kd_pick_u(it.parallel, axis) != 0u) {
        it.node = (o <= split) ? n + 1u : upper;
        return;
    }
    float r = sylva_kd_pick(it.rcp, axis);
    bool lower_first = (floatBitsToUint(r) & 0x80000000u) == 0u;
    uint near_child = lower_first ? n + 1u : upper;
    uint far_child = lower_first ? upper : n + 1u;
    float ts = sylva_canon((split - o) * r);
    if (ts >= it.t_out) {
        it.node = near_child;
    } else if (ts <= it.t_in) {
        it.node = far_child;
    } else {
        sylva_kde_push(it, far_child, ts, it.t_out);
        it.node = near_child;
        it.t_out = ts;
    }
}

/// The next leaf with references, front to back: its node, the ray's [t0, t1] in its cell and
/// its reference words [first, first + count). False at the end (status DONE) or on a corrupted
/// encoding (ERROR).
SYLVA_FN bool sylva_kde_next(SYLVA_INOUT(SylvaKdElemIter) it, SYLVA_BUF(words), SYLVA_OUT(uint) node,
                             SYLVA_OUT(float) t0, SYLVA_OUT(float) t1, SYLVA_OUT(uint) first, SYLVA_OUT(uint) count) {
    node = SYLVA_KDE_NONE;
    t0 = 0.0f;
    t1 = 0.0f;
    first = 0u;
    count = 0u;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (it.node == SYLVA_KDE_NONE && !sylva_kde_pop(it)) {
            it.status = SYLVA_ITER_DONE;
            break;
        }
        if (it.node >= it.hdr.node_count || it.steps >= it.hdr.node_count) {
            it.status = SYLVA_ITER_ERROR;
            break;
        }
        it.steps = it.steps + 1u;
        uint n = it.node;
        uint at = SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS * n;
        uint meta = SYLVA_LOAD(words, at);
        uint index = meta >> SYLVA_KDE_INDEX_SHIFT;
        uint axis = meta & SYLVA_KDE_AXIS_MASK;
        uint word1 = SYLVA_LOAD(words, at + 1u);
        if (axis == SYLVA_KDE_LEAF) {
            it.node = SYLVA_KDE_NONE;
            if (index == 0u) continue;  // a leaf no element overlaps
            if (word1 < it.refs_begin || word1 >= it.word_count || index > it.word_count - word1) {
                it.status = SYLVA_ITER_ERROR;
                break;
            }
            node = n;
            t0 = it.t_in;
            t1 = it.t_out;
            first = word1;
            count = index;
            return true;
        }
        if (index <= n + 1u || index >= it.hdr.node_count || sylva_kd_not_finite(uintBitsToFloat(word1))) {
            it.status = SYLVA_ITER_ERROR;
            break;
        }
        sylva_kde_descend(it, n, axis, uintBitsToFloat(word1), index);
    }
    return false;
}

/// Reference word `at` (from [first, first + count)) as an element index; SYLVA_KDE_NONE and
/// status ERROR when it is not below the element count.
SYLVA_FN uint sylva_kde_element(SYLVA_INOUT(SylvaKdElemIter) it, SYLVA_BUF(words), uint at) {
    uint e = SYLVA_LOAD(words, at);
    if (e >= it.elem_count) {
        it.status = SYLVA_ITER_ERROR;
        return SYLVA_KDE_NONE;
    }
    return e;
}

/// True when an element whose entry (or closest approach) is at t belongs to the leaf yielded
/// with [t0, t1]: t in [t0, t1), or t == t1 at the walk's end. Each t is claimed by one leaf.
SYLVA_FN bool sylva_kde_claims(SYLVA_INOUT(SylvaKdElemIter) it, float t, float t0, float t1) {
    return t >= t0 && (t < t1 || (t == t1 && t1 >= it.t_end));
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_ELEM_ITER_H
