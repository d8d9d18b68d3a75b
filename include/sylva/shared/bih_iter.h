// sylva/shared/bih_iter.h -- ordered front-to-back BIH traversal (Kinkelin Alg. 1 and 2) as a
// resumable iterator whose fixed-size state the caller owns. No recursion, no heap, no callbacks.
//
//   SylvaBihIter it;
//   sylva_bih_init(it, nodes, word_count, origin, direction, t_min, t_max);
//   uint leaf; float t0; float t1;
//   while (sylva_bih_next(it, nodes, leaf, t0, t1)) { ... it.leaf_lo / it.leaf_hi ... }
//
// sylva_bih_next is sylva_bih_advance (pop, bounds checks, step count) then sylva_bih_visit
// (hand out a leaf or descend); variants that skip nodes between the two build on them (e.g.
// iso-value culling by node ranges, sylva/shared/bih_dvr.h).
//
// Leaves come in order of traversal: front to back, except where two sibling boxes overlap
// (Kinkelin section 4): a leaf of the second child may then start before the last leaf of the
// first child ended. Intervals are closed: a ray that only touches a box visits it.
// Rays parallel to a plane, origins inside the volume and +-0 direction components follow
// IEEE semantics: +0 and -0 behave as +inf and -inf reciprocals, and a ray lying in a plane
// is inside the closed half-space of both children it touches.
//
// In GLSL the stack lives in a private global (see SYLVA_BIH_STACK below), so a shader
// invocation runs one BIH iterator at a time; in C++ the caller owns all of the state.
//
// Node boxes: the iterator carries each node's box (it.lo / it.hi) and hands out the leaf's
// (it.leaf_lo / it.leaf_hi) for callers that need it (inline particle leaves, BIH-DVR). A GLSL
// shader that never reads them defines SYLVA_BIH_NO_BOXES before including this header: the
// box fields and the stack's box entries are then left out (reading one is a compile error) and
// only the intervals are kept. On lavapipe a stack entry read or written costs a scalar load
// or store per SIMD lane, and every push and pop runs masked in every iteration, so the six box
// words of an entry were over a third of the element kernel's time (halo 640x480: 0.83 s to
// 0.55 s a frame). Traversal order and intervals do not depend on the boxes; C++ always keeps
// them (the struct is one type for every translation unit).
// The stack holds SYLVA_BIH_STACK_SIZE entries (define it before including; default the hard
// cap SYLVA_BIH_DEPTH_CAP). Trees deeper than the stack are refused at init (status ERROR),
// every child index is checked against the node count and the steps are bounded by it, so a
// corrupted encoding ends the iteration with status ERROR instead of reading out of bounds or
// looping.
#ifndef SYLVA_SHARED_BIH_ITER_H
#define SYLVA_SHARED_BIH_ITER_H

#include "sylva/shared/bih_layout.h"

#ifndef SYLVA_BIH_STACK_SIZE
#define SYLVA_BIH_STACK_SIZE 64
#endif

#if defined(SYLVA_BIH_NO_BOXES) && !defined(__cplusplus)
#define SYLVA_BIH_BOXES 0
#else
#define SYLVA_BIH_BOXES 1
#endif

#define SYLVA_ITER_RUNNING 0u
#define SYLVA_ITER_DONE 1u
#define SYLVA_ITER_ERROR 2u
#define SYLVA_NO_NODE 0xFFFFFFFFu

SYLVA_BEGIN_NAMESPACE

/// The traversal stack: subtrees still to visit, with their intervals and boxes.
struct SylvaBihStack {
    uint st_node[SYLVA_BIH_STACK_SIZE];
    float st_in[SYLVA_BIH_STACK_SIZE];
    float st_out[SYLVA_BIH_STACK_SIZE];
    float st_min_in[SYLVA_BIH_STACK_SIZE];  ///< the smallest st_in of entries 0..i (sylva_bih_stack_min_in)
#if SYLVA_BIH_BOXES
    vec3 st_lo[SYLVA_BIH_STACK_SIZE];
    vec3 st_hi[SYLVA_BIH_STACK_SIZE];
#endif
};

struct SylvaBihIter {
    SylvaBihHeader hdr;
    vec3 org;           ///< ray origin in traversal space
    vec3 rcp;           ///< safe reciprocal of the direction in traversal space
    uvec3 parallel;     ///< 1 where the direction component is +-0
    float t_limit;      ///< nodes entered after this are pruned (see sylva_bih_clip)
    uint node;          ///< node to visit next, SYLVA_NO_NODE to pop
    float t_in;
    float t_out;
#if SYLVA_BIH_BOXES
    vec3 lo;            ///< box of `node`, traversal space
    vec3 hi;
    vec3 leaf_lo;       ///< box of the last leaf returned, traversal space
    vec3 leaf_hi;
#endif
    uint sp;
    uint steps;         ///< nodes visited so far (the traversal-cost heat map)
    uint status;
#ifdef __cplusplus
    SylvaBihStack stack;
#endif
};

// GLSL copies `inout` arguments in and out on every call; a stack inside the iterator would be
// copied at each step (hundreds of words), so in GLSL the stack is a per-invocation private
// global instead: one live BIH iterator per shader invocation. In C++ it is part of the state.
#ifdef __cplusplus
#define SYLVA_BIH_STACK(it) (it).stack
#else
SylvaBihStack sylva_bih_stack_private;
#define SYLVA_BIH_STACK(it) sylva_bih_stack_private
#endif

/// Ray interval inside the closed slab [lo, hi] along one axis.
SYLVA_FN vec2 sylva_slab(float lo, float hi, float o, float r, uint par) {
    if (par != 0u) {
        return (o >= lo && o <= hi) ? vec2(-sylva_inf(), sylva_inf()) : vec2(sylva_inf(), -sylva_inf());
    }
    float ta = sylva_canon((lo - o) * r);
    float tb = sylva_canon((hi - o) * r);
    return vec2(sylva_min(ta, tb), sylva_max(ta, tb));
}

/// Ray interval inside the closed half-space x <= p (upper = true) or x >= p (upper = false).
SYLVA_FN vec2 sylva_half_space(float p, bool upper, float o, float r, uint par) {
    if (par != 0u) {
        bool inside = upper ? (o <= p) : (o >= p);
        return inside ? vec2(-sylva_inf(), sylva_inf()) : vec2(sylva_inf(), -sylva_inf());
    }
    float t = sylva_canon((p - o) * r);
    bool before = (r > 0.0f) == upper;  // the half-space is entered first, left through p
    return before ? vec2(-sylva_inf(), t) : vec2(t, sylva_inf());
}

SYLVA_FN float sylva_pick(vec3 v, uint axis) { return (axis == 0u) ? v.x : ((axis == 1u) ? v.y : v.z); }
SYLVA_FN uint sylva_pick_u(uvec3 v, uint axis) { return (axis == 0u) ? v.x : ((axis == 1u) ? v.y : v.z); }
SYLVA_FN vec3 sylva_with(vec3 v, uint axis, float x) {
    return vec3((axis == 0u) ? x : v.x, (axis == 1u) ? x : v.y, (axis == 2u) ? x : v.z);
}

/// Starts a traversal of the ray origin + t * direction over [t_min, t_max] (world space).
SYLVA_FN void sylva_bih_init(SYLVA_OUT(SylvaBihIter) it, SYLVA_BUF(words), uint word_count, vec3 origin,
                             vec3 direction, float t_min, float t_max) {
    it.hdr = sylva_bih_read_header(SYLVA_PASS_BUF(words), word_count);
    it.sp = 0u;
    it.steps = 0u;
    it.node = SYLVA_NO_NODE;
    it.t_limit = t_max;
    // Defined before the refusal below, so that no field of a refused iterator is read unset.
    it.org = vec3(0.0f);
    it.rcp = vec3(0.0f);
    it.parallel = uvec3(0u);
#if SYLVA_BIH_BOXES
    it.leaf_lo = vec3(0.0f);
    it.leaf_hi = vec3(0.0f);
    it.lo = vec3(0.0f);
    it.hi = vec3(0.0f);
#endif
    it.t_in = 0.0f;
    it.t_out = 0.0f;
    if (it.hdr.valid == 0u || it.hdr.max_depth > uint(SYLVA_BIH_STACK_SIZE)) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    it.status = SYLVA_ITER_RUNNING;
    vec3 s = it.hdr.space_scale;
    it.org = vec3((origin.x - it.hdr.space_origin.x) * s.x, (origin.y - it.hdr.space_origin.y) * s.y,
                  (origin.z - it.hdr.space_origin.z) * s.z);
    vec3 d = vec3(direction.x * s.x, direction.y * s.y, direction.z * s.z);
    it.parallel = uvec3((d.x == 0.0f) ? 1u : 0u, (d.y == 0.0f) ? 1u : 0u, (d.z == 0.0f) ? 1u : 0u);
    it.rcp = vec3(sylva_safe_rcp(d.x), sylva_safe_rcp(d.y), sylva_safe_rcp(d.z));
    bool fixed16 = (it.hdr.flags & SYLVA_BIH_FLAG_FLOAT_NODES) == 0u;
    vec3 root_lo = fixed16 ? vec3(0.0f) : it.hdr.root_lo;
    vec3 root_hi = fixed16 ? vec3(1.0f) : it.hdr.root_hi;
#if SYLVA_BIH_BOXES
    it.lo = root_lo;
    it.hi = root_hi;
#endif
    float t0 = t_min;
    float t1 = t_max;
    for (uint a = 0u; a < 3u; a++) {
        vec2 ab = sylva_slab(sylva_pick(root_lo, a), sylva_pick(root_hi, a), sylva_pick(it.org, a),
                             sylva_pick(it.rcp, a), sylva_pick_u(it.parallel, a));
        t0 = sylva_max(t0, ab.x);
        t1 = sylva_min(t1, ab.y);
    }
    if (t0 <= t1) {
        it.node = 0u;
        it.t_in = t0;
        it.t_out = t1;
    }
}

/// Prunes everything the ray would enter after t (e.g. once a first hit at t is known).
SYLVA_FN void sylva_bih_clip(SYLVA_INOUT(SylvaBihIter) it, float t) { it.t_limit = sylva_min(it.t_limit, t); }

/// Pushes a subtree entered over t (its box, where boxes are kept: sylva_bih_push_box).
SYLVA_FN void sylva_bih_push(SYLVA_INOUT(SylvaBihIter) it, uint node, vec2 t) {
    if (it.sp >= uint(SYLVA_BIH_STACK_SIZE)) {  // unreachable for valid trees (depth <= stack)
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    SYLVA_BIH_STACK(it).st_node[it.sp] = node;
    SYLVA_BIH_STACK(it).st_in[it.sp] = t.x;
    SYLVA_BIH_STACK(it).st_out[it.sp] = t.y;
    SYLVA_BIH_STACK(it).st_min_in[it.sp] = (it.sp > 0u) ? sylva_min(SYLVA_BIH_STACK(it).st_min_in[it.sp - 1u], t.x) : t.x;
    it.sp = it.sp + 1u;
}

#if SYLVA_BIH_BOXES
/// The box of the subtree sylva_bih_push just added (nothing after a push that overflowed).
SYLVA_FN void sylva_bih_push_box(SYLVA_INOUT(SylvaBihIter) it, vec3 lo, vec3 hi) {
    if (it.status == SYLVA_ITER_ERROR || it.sp == 0u) return;
    SYLVA_BIH_STACK(it).st_lo[it.sp - 1u] = lo;
    SYLVA_BIH_STACK(it).st_hi[it.sp - 1u] = hi;
}
#endif

/// Pops the next subtree that still starts before t_limit; false when none is left.
SYLVA_FN bool sylva_bih_pop(SYLVA_INOUT(SylvaBihIter) it) {
    while (it.sp > 0u) {
        it.sp = it.sp - 1u;
        if (SYLVA_BIH_STACK(it).st_in[it.sp] <= it.t_limit) {
            it.node = SYLVA_BIH_STACK(it).st_node[it.sp];
            it.t_in = SYLVA_BIH_STACK(it).st_in[it.sp];
            it.t_out = sylva_min(SYLVA_BIH_STACK(it).st_out[it.sp], it.t_limit);
#if SYLVA_BIH_BOXES
            it.lo = SYLVA_BIH_STACK(it).st_lo[it.sp];
            it.hi = SYLVA_BIH_STACK(it).st_hi[it.sp];
#endif
            return true;
        }
    }
    return false;
}

/// The smallest entry t among the subtrees on the stack (+inf when it is empty), in O(1): pops
/// leave the prefix minima of the entries below them intact.
SYLVA_FN float sylva_bih_stack_min_in(SYLVA_INOUT(SylvaBihIter) it) {
    return (it.sp > 0u) ? SYLVA_BIH_STACK(it).st_min_in[it.sp - 1u] : sylva_inf();
}

/// Where the children of inner node `n` are stored: (left, right); SYLVA_NO_NODE if empty.
SYLVA_FN uvec2 sylva_bih_children_at(bool chunked, uint n, uint meta, vec2 planes) {
    uint first = sylva_bih_first_child(chunked, n, meta);
    uint second = chunked ? first + 1u : sylva_bih_meta_index(meta);
    bool left_empty = planes.x == -sylva_inf();
    bool right_empty = planes.y == sylva_inf();
    uint left = left_empty ? SYLVA_NO_NODE : first;
    uint right = right_empty ? SYLVA_NO_NODE : (left_empty ? first : second);
    return uvec2(left, right);
}

SYLVA_FN uvec2 sylva_bih_children(SylvaBihHeader h, uint n, uint meta, vec2 planes) {
    return sylva_bih_children_at((h.flags & SYLVA_BIH_FLAG_CHUNKED) != 0u, n, meta, planes);
}

/// The ray's intervals in the left child (x <= plane A: .x, .y) and the right child
/// (x >= plane B: .z, .w) of a two-child node entered over [t_in, t_out]; o, r, par: the ray's
/// origin, reciprocal direction and parallel flag along the split axis. Empty when x > y.
SYLVA_FN vec4 sylva_bih_split_intervals(float t_in, float t_out, vec2 planes, float o, float r, uint par) {
    vec2 hl = sylva_half_space(planes.x, true, o, r, par);
    vec2 hr = sylva_half_space(planes.y, false, o, r, par);
    return vec4(sylva_max(t_in, hl.x), sylva_min(t_out, hl.y), sylva_max(t_in, hr.x), sylva_min(t_out, hr.y));
}

/// Whether the left child is the nearer one: the ray runs towards + along the axis (r = +0 and
/// +inf count as +, the sign bit decides).
SYLVA_FN bool sylva_bih_left_first(float r) { return (floatBitsToUint(r) & 0x80000000u) == 0u; }

/// The ray's interval in the single child of a single-child node (within [plane A, plane B]).
SYLVA_FN vec2 sylva_bih_single_interval(float t_in, float t_out, vec2 planes, float o, float r, uint par) {
    vec2 ab = sylva_slab(planes.x, planes.y, o, r, par);
    return vec2(sylva_max(t_in, ab.x), sylva_min(t_out, ab.y));
}

/// Descends into one child of a two-child node; returns true when it was entered.
SYLVA_FN void sylva_bih_descend(SYLVA_INOUT(SylvaBihIter) it, uint axis, uvec2 kids, vec2 planes) {
    float o = sylva_pick(it.org, axis);
    float r = sylva_pick(it.rcp, axis);
    uint par = sylva_pick_u(it.parallel, axis);
    vec4 lr = sylva_bih_split_intervals(it.t_in, it.t_out, planes, o, r, par);
    vec2 tl = vec2(lr.x, lr.y);
    vec2 tr = vec2(lr.z, lr.w);
    bool hit_l = kids.x != SYLVA_NO_NODE && tl.x <= tl.y;
    bool hit_r = kids.y != SYLVA_NO_NODE && tr.x <= tr.y;
#if SYLVA_BIH_BOXES
    vec3 lo_r = sylva_with(it.lo, axis, planes.y);
    vec3 hi_l = sylva_with(it.hi, axis, planes.x);
#endif
    bool left_first = sylva_bih_left_first(r);
    if (hit_l && hit_r) {
        if (left_first) {
            sylva_bih_push(it, kids.y, tr);
#if SYLVA_BIH_BOXES
            sylva_bih_push_box(it, lo_r, it.hi);
#endif
        } else {
            sylva_bih_push(it, kids.x, tl);
#if SYLVA_BIH_BOXES
            sylva_bih_push_box(it, it.lo, hi_l);
#endif
        }
    }
    if (hit_l && (left_first || !hit_r)) {
        it.node = kids.x;
        it.t_in = tl.x;
        it.t_out = tl.y;
#if SYLVA_BIH_BOXES
        it.hi = hi_l;
#endif
    } else if (hit_r) {
        it.node = kids.y;
        it.t_in = tr.x;
        it.t_out = tr.y;
#if SYLVA_BIH_BOXES
        it.lo = lo_r;
#endif
    } else {
        it.node = SYLVA_NO_NODE;
    }
}

/// Enters the single child of a single-child node, which lies within [plane A, plane B].
SYLVA_FN void sylva_bih_descend_single(SYLVA_INOUT(SylvaBihIter) it, uint axis, uint child, vec2 planes) {
    vec2 t = sylva_bih_single_interval(it.t_in, it.t_out, planes, sylva_pick(it.org, axis), sylva_pick(it.rcp, axis),
                                       sylva_pick_u(it.parallel, axis));
    float t0 = t.x;
    float t1 = t.y;
    if (t0 <= t1) {
        it.node = child;
        it.t_in = t0;
        it.t_out = t1;
#if SYLVA_BIH_BOXES
        it.lo = sylva_with(it.lo, axis, planes.x);
        it.hi = sylva_with(it.hi, axis, planes.y);
#endif
    } else {
        it.node = SYLVA_NO_NODE;
    }
}

/// Moves to the next node to visit (popping the stack when needed) and counts the step.
/// False when the traversal is over (status DONE) or the encoding is corrupt (status ERROR).
SYLVA_FN bool sylva_bih_advance(SYLVA_INOUT(SylvaBihIter) it) {
    if (it.node == SYLVA_NO_NODE && !sylva_bih_pop(it)) {
        it.status = SYLVA_ITER_DONE;
        return false;
    }
    // A valid tree visits each node at most once per ray: more steps mean corrupted links.
    if (it.node >= it.hdr.node_count || it.steps >= it.hdr.node_count) {
        it.status = SYLVA_ITER_ERROR;
        return false;
    }
    it.steps = it.steps + 1u;
    return true;
}

/// Visits it.node: a leaf is handed out through leaf/t0/t1 (true); an inner node is descended
/// into (false; the outputs are left as they are).
SYLVA_FN bool sylva_bih_visit(SYLVA_INOUT(SylvaBihIter) it, SYLVA_BUF(words), SYLVA_INOUT(uint) leaf,
                              SYLVA_INOUT(float) t0, SYLVA_INOUT(float) t1) {
    uint n = it.node;
    uint meta = sylva_bih_meta(SYLVA_PASS_BUF(words), it.hdr, n);
    uint type = sylva_bih_meta_type(meta);
    if (type == SYLVA_BIH_LEAF) {
        leaf = n;
        t0 = it.t_in;
        t1 = it.t_out;
#if SYLVA_BIH_BOXES
        it.leaf_lo = it.lo;
        it.leaf_hi = it.hi;
#endif
        it.node = SYLVA_NO_NODE;
        return true;
    }
    vec2 planes = sylva_bih_planes(SYLVA_PASS_BUF(words), it.hdr, n);
    if (sylva_bih_meta_single(meta)) {
        uint child = sylva_bih_first_child((it.hdr.flags & SYLVA_BIH_FLAG_CHUNKED) != 0u, n, meta);
        sylva_bih_descend_single(it, type, child, planes);
    } else {
        sylva_bih_descend(it, type, sylva_bih_children(it.hdr, n, meta, planes), planes);
    }
    return false;
}

/// Advances to the next leaf hit by the ray. Returns false when the traversal is over
/// (status DONE) or the encoding was found corrupt (status ERROR).
SYLVA_FN bool sylva_bih_next(SYLVA_INOUT(SylvaBihIter) it, SYLVA_BUF(words), SYLVA_OUT(uint) leaf,
                             SYLVA_OUT(float) t0, SYLVA_OUT(float) t1) {
    leaf = SYLVA_NO_NODE;
    t0 = 0.0f;
    t1 = 0.0f;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (!sylva_bih_advance(it)) break;
        if (sylva_bih_visit(it, SYLVA_PASS_BUF(words), leaf, t0, t1)) return true;
    }
    return false;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_BIH_ITER_H
