// sylva/shared/kd_iter.h -- front-to-back traversal of an encoded empty-space kd-tree
// (sylva/shared/kd_layout.h) as a resumable iterator whose fixed-size state the caller owns.
// No recursion, no heap, no callbacks: the same text runs on the host and in a shader.
//
//   SylvaKdIter it;
//   sylva_kd_init(it, words, word_count, origin, direction, t_min, t_max);
//   uint leaf; float t0; float t1;
//   while (sylva_kd_next(it, words, leaf, t0, t1)) { ... integrate [t0, t1] in leaf ... }
//
// `leaf` is the leaf index (the position in the leaf list); it.leaf_node is its node, whose box
// sylva_kd_box_lo / sylva_kd_box_hi decode. [t0, t1] is where the ray is inside the leaf's
// closed box, within [t_min, t_max]; t is the world-space ray parameter (the iterator maps the
// ray into voxel space, which leaves t unchanged up to rounding).
//
// Order. The children of a node lie on either side of its split plane, so visiting the near
// child first gives the leaves front to back: each leaf's t0 is at least the previous leaf's
// t1, and a ray that crosses from one leaf into an adjacent one gets the same t for the shared
// face from both (the face is one integer plane), so consecutive intervals neither overlap nor
// leave a gap. The one exception is a ray lying exactly in a split plane (direction component
// +-0 there, origin on the plane): it touches the boxes on both sides along a common segment;
// both are reported (closed boxes), the lower side first for +0 and the upper first for -0.
// A direction component of +-0, or one so small that its reciprocal overflows, is parallel to
// that axis: the ray is inside a slab for all t when its origin is (boundary included).
// A ray with a NaN origin, direction or range yields no leaves.
//
// Robustness. Trees deeper than the stack are refused at init (status ERROR). Every child and
// leaf index is checked against the header's counts, children must follow their parent, and
// the steps are bounded by the node count, so a corrupted encoding ends with status ERROR
// instead of reading out of bounds or looping.
//
// In GLSL the stack is a private global (one live kd iterator per shader invocation), as in
// bih_iter.h; in C++ it is part of the state. Its size is SYLVA_KD_STACK_SIZE entries (define
// it before including; default the hard cap SYLVA_KD_DEPTH_CAP).
#ifndef SYLVA_SHARED_KD_ITER_H
#define SYLVA_SHARED_KD_ITER_H

#include "sylva/shared/kd_layout.h"
#include "sylva/shared/ray_box.h"

#ifndef SYLVA_KD_STACK_SIZE
#define SYLVA_KD_STACK_SIZE 64
#endif

#ifndef SYLVA_ITER_RUNNING
#define SYLVA_ITER_RUNNING 0u
#define SYLVA_ITER_DONE 1u
#define SYLVA_ITER_ERROR 2u
#endif
#define SYLVA_KD_NO_NODE 0xFFFFFFFFu

SYLVA_BEGIN_NAMESPACE

/// Subtrees still to visit: node and ray interval inside its box.
struct SylvaKdStack {
    uint st_node[SYLVA_KD_STACK_SIZE];
    float st_in[SYLVA_KD_STACK_SIZE];
    float st_out[SYLVA_KD_STACK_SIZE];
};

struct SylvaKdIter {
    SylvaKdHeader hdr;
    vec3 org;        ///< ray origin in voxel space
    vec3 rcp;        ///< reciprocal of the voxel-space direction (+-inf where parallel)
    uvec3 parallel;  ///< 1 where the ray is parallel to an axis
    float t_limit;   ///< subtrees entered after this are pruned (see sylva_kd_clip)
    uint node;       ///< node to visit next, SYLVA_KD_NO_NODE to pop
    float t_in;
    float t_out;
    uint leaf_node;  ///< node of the last leaf returned
    uint sp;
    uint steps;      ///< nodes visited so far (the traversal-cost heat map)
    uint status;
#ifdef __cplusplus
    SylvaKdStack stack;
#endif
};

#ifdef __cplusplus
#define SYLVA_KD_STACK(it) (it).stack
#else
SylvaKdStack sylva_kd_stack_private;
#define SYLVA_KD_STACK(it) sylva_kd_stack_private
#endif

/// sylva_kd_box_interval_f for a box with integer corners (the encoded node boxes).
SYLVA_FN vec2 sylva_kd_box_interval(vec3 org, vec3 rcp, uvec3 par, uvec3 lo, uvec3 hi, float t0, float t1) {
    return sylva_kd_box_interval_f(org, rcp, par, vec3(float(lo.x), float(lo.y), float(lo.z)),
                                   vec3(float(hi.x), float(hi.y), float(hi.z)), t0, t1);
}

/// The same for the box of node `i` of the `words` buffer.
SYLVA_FN vec2 sylva_kd_node_interval(SYLVA_BUF(words), vec3 org, vec3 rcp, uvec3 par, uint i, float t0, float t1) {
    return sylva_kd_box_interval(org, rcp, par, sylva_kd_box_lo(SYLVA_PASS_BUF(words), i),
                                 sylva_kd_box_hi(SYLVA_PASS_BUF(words), i), t0, t1);
}

/// Starts a traversal of the ray origin + t * direction over [t_min, t_max] (world space).
SYLVA_FN void sylva_kd_init(SYLVA_OUT(SylvaKdIter) it, SYLVA_BUF(words), uint word_count, vec3 origin, vec3 direction,
                            float t_min, float t_max) {
    it.hdr = sylva_kd_read_header(SYLVA_PASS_BUF(words), word_count);
    it.sp = 0u;
    it.steps = 0u;
    it.node = SYLVA_KD_NO_NODE;
    it.leaf_node = SYLVA_KD_NO_NODE;
    it.t_limit = t_max;
    it.t_in = 0.0f;
    it.t_out = 0.0f;
    it.status = SYLVA_ITER_RUNNING;
    if (it.hdr.valid == 0u || it.hdr.max_depth > uint(SYLVA_KD_STACK_SIZE)) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    bool nan_ray = sylva_ray_to_grid(origin, direction, it.hdr.origin, it.hdr.inv_spacing, t_min, t_max, it.org, it.rcp,
                                     it.parallel);
    if (nan_ray || it.hdr.node_count == 0u) {
        it.status = SYLVA_ITER_DONE;
        return;
    }
    vec2 t = sylva_kd_node_interval(SYLVA_PASS_BUF(words), it.org, it.rcp, it.parallel, 0u, t_min, t_max);
    if (t.x <= t.y) {
        it.node = 0u;
        it.t_in = t.x;
        it.t_out = t.y;
    }
}

/// Prunes everything the ray would enter after t (early ray termination, first hits).
SYLVA_FN void sylva_kd_clip(SYLVA_INOUT(SylvaKdIter) it, float t) { it.t_limit = sylva_min(it.t_limit, t); }

SYLVA_FN void sylva_kd_push(SYLVA_INOUT(SylvaKdIter) it, uint node, vec2 t) {
    if (it.sp >= uint(SYLVA_KD_STACK_SIZE)) {  // unreachable for valid trees (depth <= stack)
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    SYLVA_KD_STACK(it).st_node[it.sp] = node;
    SYLVA_KD_STACK(it).st_in[it.sp] = t.x;
    SYLVA_KD_STACK(it).st_out[it.sp] = t.y;
    it.sp = it.sp + 1u;
}

/// Pops the next subtree that still starts before t_limit; false when none is left.
SYLVA_FN bool sylva_kd_pop(SYLVA_INOUT(SylvaKdIter) it) {
    while (it.sp > 0u) {
        it.sp = it.sp - 1u;
        if (SYLVA_KD_STACK(it).st_in[it.sp] <= it.t_limit) {
            it.node = SYLVA_KD_STACK(it).st_node[it.sp];
            it.t_in = SYLVA_KD_STACK(it).st_in[it.sp];
            it.t_out = sylva_min(SYLVA_KD_STACK(it).st_out[it.sp], it.t_limit);
            return true;
        }
    }
    return false;
}

/// Visits inner node n split along `axis` with children `first` (lower) and first + 1 (upper):
/// continues with the near child that the ray hits and pushes the far one when both are hit.
SYLVA_FN void sylva_kd_descend(SYLVA_INOUT(SylvaKdIter) it, SYLVA_BUF(words), uint axis, uint first) {
    vec2 tl = sylva_kd_node_interval(SYLVA_PASS_BUF(words), it.org, it.rcp, it.parallel, first, it.t_in, it.t_out);
    vec2 tu = sylva_kd_node_interval(SYLVA_PASS_BUF(words), it.org, it.rcp, it.parallel, first + 1u, it.t_in, it.t_out);
    bool hit_l = tl.x <= tl.y;
    bool hit_u = tu.x <= tu.y;
    bool lower_first = (floatBitsToUint(sylva_kd_pick(it.rcp, axis)) & 0x80000000u) == 0u;
    if (hit_l && hit_u) {
        if (lower_first) {
            sylva_kd_push(it, first + 1u, tu);
        } else {
            sylva_kd_push(it, first, tl);
        }
    }
    if (hit_l && (lower_first || !hit_u)) {
        it.node = first;
        it.t_in = tl.x;
        it.t_out = tl.y;
    } else if (hit_u) {
        it.node = first + 1u;
        it.t_in = tu.x;
        it.t_out = tu.y;
    } else {
        it.node = SYLVA_KD_NO_NODE;
    }
}

/// Advances to the next leaf hit by the ray. Returns false when the traversal is over
/// (status DONE) or the encoding was found corrupt (status ERROR).
SYLVA_FN bool sylva_kd_next(SYLVA_INOUT(SylvaKdIter) it, SYLVA_BUF(words), SYLVA_OUT(uint) leaf, SYLVA_OUT(float) t0,
                            SYLVA_OUT(float) t1) {
    leaf = SYLVA_KD_NO_NODE;
    t0 = 0.0f;
    t1 = 0.0f;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (it.node == SYLVA_KD_NO_NODE && !sylva_kd_pop(it)) {
            it.status = SYLVA_ITER_DONE;
            break;
        }
        // A valid tree visits each node at most once per ray: more steps mean corrupted links.
        if (it.node >= it.hdr.node_count || it.steps >= it.hdr.node_count) {
            it.status = SYLVA_ITER_ERROR;
            break;
        }
        it.steps = it.steps + 1u;
        uint n = it.node;
        uint meta = sylva_kd_meta(SYLVA_PASS_BUF(words), n);
        uint index = sylva_kd_meta_index(meta);
        if (sylva_kd_meta_type(meta) == SYLVA_KD_LEAF) {
            if (index >= it.hdr.leaf_count) {
                it.status = SYLVA_ITER_ERROR;
                break;
            }
            leaf = index;
            t0 = it.t_in;
            t1 = it.t_out;
            it.leaf_node = n;
            it.node = SYLVA_KD_NO_NODE;
            return true;
        }
        if (index <= n || index + 1u >= it.hdr.node_count) {
            it.status = SYLVA_ITER_ERROR;
            break;
        }
        sylva_kd_descend(it, SYLVA_PASS_BUF(words), sylva_kd_meta_type(meta), index);
    }
    return false;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_ITER_H
