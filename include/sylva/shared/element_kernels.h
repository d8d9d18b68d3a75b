// sylva/shared/element_kernels.h -- generic kernels over any element type (sylva/shared/element.h)
// and any element index (sylva/shared/element_bih.h): element hits in exact front-to-back order,
// first hit, and front-to-back compositing of the elements' media over their intervals.
//
// The element type and the index are parameters: in C++ template parameters <SylvaElem,
// SylvaIndexIter> (the protocol functions are found by argument-dependent lookup); in GLSL the
// shader defines the macro SylvaElem (the element struct) before including this header, and
// optionally SylvaIndexIter (default SylvaBihIter, after including its index header).
//
//   SylvaHitIter h; SylvaBihIter it; SylvaHit hit;
//   sylva_hits_init(h, it, words, word_count, elem_count, o, d, t_min, t_max);   (C++: <E, I>)
//   while (sylva_hits_next<E, I>(h, it, words, elems, hit)) { ... hit.elem, hit.t0, hit.t1 ... }
//
// Order: hits come sorted by (t0, record index), exactly, whatever the overlap of leaves. Leaves
// of an index may overlap and come out of order; the iterator holds hits in a window of
// SYLVA_HIT_WINDOW entries (default 64) and hands one out only once every leaf still to come
// starts strictly after it (sylva_index_bound), which streams them with early termination.
// When more hits are pending than the window holds, it keeps the earliest, lets the index skip
// what starts after them (sylva_index_clip) and, once they are handed out, traverses again for
// the hits after the last one handed out (a k-nearest-along-the-ray pass): memory stays bounded
// and the order exact; `passes` counts the traversals.
// Element indices past elem_count end the ray with SYLVA_ITER_ERROR.
//
// In GLSL the window is a private global (like the BIH stack): one hit iterator per invocation.
#ifndef SYLVA_SHARED_ELEMENT_KERNELS_H
#define SYLVA_SHARED_ELEMENT_KERNELS_H

#include "sylva/shared/element.h"
#include "sylva/shared/particles.h"

#ifndef SYLVA_HIT_WINDOW
#define SYLVA_HIT_WINDOW 64
#endif

#ifdef __cplusplus
#define SYLVA_ELEM_TEMPLATE template <class SylvaElem, class SylvaIndexIter>
#define SYLVA_ELEM_TARGS <SylvaElem, SylvaIndexIter>
#else
#ifndef SylvaElem
#error "sylva/shared/element_kernels.h: #define SylvaElem <your element struct> before including it"
#endif
#ifndef SylvaIndexIter
#define SylvaIndexIter SylvaBihIter
#endif
#define SYLVA_ELEM_TEMPLATE
#define SYLVA_ELEM_TARGS
#endif

SYLVA_BEGIN_NAMESPACE

/// Pending hits, kept sorted by decreasing (t0, elem): the earliest is at count - 1.
struct SylvaHitWindow {
    uint w_elem[SYLVA_HIT_WINDOW];
    float w_t0[SYLVA_HIT_WINDOW];
    float w_t1[SYLVA_HIT_WINDOW];
};

/// State of an ordered hit iterator (the index iterator is held beside it by the caller).
struct SylvaHitIter {
    vec3 org;
    vec3 dir;
    float t_min;
    float t_max;
    uint word_count;  ///< words of the index encoding (to restart it for another pass)
    uint elem_count;  ///< records in the element buffer
    uint leaf_first;  ///< the current leaf's records still to test: [leaf_first + leaf_k, leaf_first + leaf_count)
    uint leaf_count;
    uint leaf_k;
    float leaf_t_in;  ///< the current leaf's ray interval [leaf_t_in, leaf_t_out]
    float leaf_t_out;
    uint count;       ///< hits in the window
    uint done;        ///< 1 once the index has no more leaves in this pass
    uint truncated;   ///< 1 when this pass dropped hits that did not fit the window
    uint emitted;     ///< 1 once a hit was handed out; (last_t0, last_elem) is the last one
    float last_t0;
    uint last_elem;
    uint passes;      ///< traversals of the index so far (1 unless the window overflowed)
    uint steps_before;///< index steps of the passes before this one
    uint wanted;      ///< hits the caller will ask for (0xFFFFFFFF: all); sylva_hits_want
    float clip_t;     ///< this pass skips leaves entered after clip_t, so it keeps no hit past it
    uint work;        ///< loop iterations run so far, bar the index's (for a device's loop budget)
    uint status;      ///< SYLVA_ITER_* of the index
#ifdef __cplusplus
    SylvaHitWindow window;
#endif
};

#ifdef __cplusplus
#define SYLVA_HIT_WINDOW_OF(h) (h).window
#else
SylvaHitWindow sylva_hit_window_private;
#define SYLVA_HIT_WINDOW_OF(h) sylva_hit_window_private
#endif

/// True when hit (e, t) comes before hit (f, u): smaller entry, then smaller record index.
SYLVA_FN bool sylva_hit_before(uint e, float t, uint f, float u) { return t < u || (t == u && e < f); }

/// Drops the latest hit of a full window (index 0; the window is sorted latest first).
SYLVA_FN void sylva_hit_drop_latest(SYLVA_INOUT(SylvaHitIter) h) {
    for (uint i = 1u; i < h.count; i++) {
        SYLVA_HIT_WINDOW_OF(h).w_elem[i - 1u] = SYLVA_HIT_WINDOW_OF(h).w_elem[i];
        SYLVA_HIT_WINDOW_OF(h).w_t0[i - 1u] = SYLVA_HIT_WINDOW_OF(h).w_t0[i];
        SYLVA_HIT_WINDOW_OF(h).w_t1[i - 1u] = SYLVA_HIT_WINDOW_OF(h).w_t1[i];
    }
    h.count = h.count - 1u;
    h.truncated = 1u;
    h.work = h.work + h.count;
}

/// Inserts a hit into the window, keeping it sorted latest first. A hit not after the last one
/// handed out is ignored (an earlier pass gave it); a full window keeps its earliest hits.
SYLVA_FN void sylva_hit_insert(SYLVA_INOUT(SylvaHitIter) h, uint e, float t0, float t1) {
    if (h.emitted != 0u && !sylva_hit_before(h.last_elem, h.last_t0, e, t0)) return;
    if (h.count == uint(SYLVA_HIT_WINDOW)) {
        if (!sylva_hit_before(e, t0, SYLVA_HIT_WINDOW_OF(h).w_elem[0], SYLVA_HIT_WINDOW_OF(h).w_t0[0])) {
            h.truncated = 1u;  // later than all kept: the next pass finds it
            return;
        }
        sylva_hit_drop_latest(h);
    }
    uint i = h.count;
    while (i > 0u && sylva_hit_before(SYLVA_HIT_WINDOW_OF(h).w_elem[i - 1u], SYLVA_HIT_WINDOW_OF(h).w_t0[i - 1u], e, t0)) {
        SYLVA_HIT_WINDOW_OF(h).w_elem[i] = SYLVA_HIT_WINDOW_OF(h).w_elem[i - 1u];
        SYLVA_HIT_WINDOW_OF(h).w_t0[i] = SYLVA_HIT_WINDOW_OF(h).w_t0[i - 1u];
        SYLVA_HIT_WINDOW_OF(h).w_t1[i] = SYLVA_HIT_WINDOW_OF(h).w_t1[i - 1u];
        i = i - 1u;
    }
    h.work = h.work + (h.count - i);
    SYLVA_HIT_WINDOW_OF(h).w_elem[i] = e;
    SYLVA_HIT_WINDOW_OF(h).w_t0[i] = t0;
    SYLVA_HIT_WINDOW_OF(h).w_t1[i] = t1;
    h.count = h.count + 1u;
}

/// Takes the earliest hit out of the window.
SYLVA_FN void sylva_hit_pop(SYLVA_INOUT(SylvaHitIter) h, SYLVA_OUT(SylvaHit) hit) {
    h.count = h.count - 1u;
    hit.elem = SYLVA_HIT_WINDOW_OF(h).w_elem[h.count];
    hit.t0 = SYLVA_HIT_WINDOW_OF(h).w_t0[h.count];
    hit.t1 = SYLVA_HIT_WINDOW_OF(h).w_t1[h.count];
    h.emitted = 1u;
    h.last_t0 = hit.t0;
    h.last_elem = hit.elem;
}

/// Starts a pass over the index (the first, or another after a window overflow).
SYLVA_ELEM_TEMPLATE
SYLVA_FN void sylva_hits_start_pass(SYLVA_INOUT(SylvaHitIter) h, SYLVA_INOUT(SylvaIndexIter) it, SYLVA_BUF(words)) {
    sylva_index_init(it, SYLVA_PASS_BUF(words), h.word_count, h.org, h.dir, h.t_min, h.t_max);
    h.leaf_first = 0u;
    h.leaf_count = 0u;
    h.leaf_k = 0u;
    h.leaf_t_in = sylva_inf();
    h.leaf_t_out = sylva_inf();
    h.done = 0u;
    h.truncated = 0u;
    h.clip_t = sylva_inf();
    h.passes = h.passes + 1u;
    h.status = sylva_index_status(it);
    if (h.status == SYLVA_ITER_ERROR) h.done = 1u;
}

/// Starts an ordered hit iteration of the ray o + t d over [t_min, t_max].
SYLVA_ELEM_TEMPLATE
SYLVA_FN void sylva_hits_init(SYLVA_OUT(SylvaHitIter) h, SYLVA_OUT(SylvaIndexIter) it, SYLVA_BUF(words),
                              uint word_count, uint elem_count, vec3 o, vec3 d, float t_min, float t_max) {
    h.org = o;
    h.dir = d;
    h.t_min = t_min;
    h.t_max = t_max;
    h.word_count = word_count;
    h.elem_count = elem_count;
    h.count = 0u;
    h.emitted = 0u;
    h.last_t0 = 0.0f;
    h.last_elem = 0u;
    h.passes = 0u;
    h.steps_before = 0u;
    h.wanted = 0xFFFFFFFFu;
    h.work = 0u;
    sylva_hits_start_pass SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words));
}

/// Tells the iterator that only the first n hits will be asked for (first hit: 1): once n are
/// known, the index skips leaves entered after the n-th (asking for more stays correct: another
/// pass finds them).
SYLVA_FN void sylva_hits_want(SYLVA_INOUT(SylvaHitIter) h, uint n) { h.wanted = n; }

/// Index nodes visited so far, over all passes.
SYLVA_ELEM_TEMPLATE
SYLVA_FN uint sylva_hits_steps(SYLVA_INOUT(SylvaHitIter) h, SYLVA_INOUT(SylvaIndexIter) it) {
    return h.steps_before + sylva_index_steps(it);
}

/// Tests the current leaf's next element against the ray and keeps it when hit (and the leaf
/// claims its entry); once the window is full, the index may skip what starts after the
/// window's latest hit. An element index past the records ends the ray with ERROR.
SYLVA_ELEM_TEMPLATE
SYLVA_FN void sylva_hits_test_next(SYLVA_INOUT(SylvaHitIter) h, SYLVA_INOUT(SylvaIndexIter) it, SYLVA_BUF(words),
                                   SYLVA_BUF(elems)) {
    uint e = sylva_index_element(it, SYLVA_PASS_BUF(words), h.leaf_first + h.leaf_k);
    h.leaf_k = h.leaf_k + 1u;
    if (e >= h.elem_count || sylva_index_status(it) == SYLVA_ITER_ERROR) {
        h.status = SYLVA_ITER_ERROR;
        return;
    }
    SylvaElem x;
    sylva_elem_load(SYLVA_PASS_BUF(elems), e, x);
    vec2 t = sylva_elem_interval(x, h.org, h.dir, h.t_min, h.t_max);
    if (!(t.x <= t.y) || !sylva_index_keeps(it, t.x, h.leaf_t_in, h.leaf_t_out)) return;
    if (t.x > h.clip_t) {
        h.truncated = 1u;  // a skipped leaf may hold earlier hits: the next pass finds this one
        return;
    }
    sylva_hit_insert(h, e, t.x, t.y);
    // Leaves entered after the latest hit still needed are skipped (a full window, or the hits
    // the caller wants); what the clip skips, another pass finds if it is asked for. The window
    // never keeps a hit past the clip, so nothing skipped comes before a hit handed out.
    if (h.count >= h.wanted) {
        while (h.count > h.wanted) sylva_hit_drop_latest(h);
    }
    if (h.count == uint(SYLVA_HIT_WINDOW) || h.count >= h.wanted) {
        h.clip_t = sylva_min(h.clip_t, SYLVA_HIT_WINDOW_OF(h).w_t0[0]);
        sylva_index_clip(it, h.clip_t);
        h.truncated = 1u;
    }
}

/// Fetches the next leaf; false when the pass is over (DONE or ERROR).
SYLVA_ELEM_TEMPLATE
SYLVA_FN bool sylva_hits_fetch_leaf(SYLVA_INOUT(SylvaHitIter) h, SYLVA_INOUT(SylvaIndexIter) it, SYLVA_BUF(words)) {
    uint first;
    uint count;
    float t_in;
    float t_out;
    if (!sylva_index_leaf(it, SYLVA_PASS_BUF(words), first, count, t_in, t_out)) {
        h.done = 1u;
        h.status = sylva_index_status(it);
        return false;
    }
    h.leaf_first = first;
    h.leaf_count = count;
    h.leaf_k = 0u;
    h.leaf_t_in = t_in;
    h.leaf_t_out = t_out;
    return true;
}

/// The next hit in order; false when there is none (h.status says DONE or ERROR; after an
/// ERROR no further hit is handed out).
SYLVA_ELEM_TEMPLATE
SYLVA_FN bool sylva_hits_next(SYLVA_INOUT(SylvaHitIter) h, SYLVA_INOUT(SylvaIndexIter) it, SYLVA_BUF(words),
                              SYLVA_BUF(elems), SYLVA_OUT(SylvaHit) hit) {
    hit.elem = 0u;
    hit.t0 = 0.0f;
    hit.t1 = 0.0f;
    // A new pass (after a window overflow) is started outside the loop that tests elements and
    // fetches leaves: on a SIMD device every statement of a loop body runs each iteration,
    // masked, whether any lane takes it or not, and a pass restarts the index (its header
    // reads). Lavapipe, halo 640x480: 7 % of a frame.
    bool another_pass = true;
    while (another_pass) {
        another_pass = false;
        while (h.status != SYLVA_ITER_ERROR) {
            h.work = h.work + 1u;
            bool leaf_left = h.leaf_k < h.leaf_count;
            if (h.count > 0u) {
                // Safe once every leaf still to come starts strictly after the hit: a later leaf may
                // hold a hit at the same t with a smaller index. Dropped hits all come after it.
                float bound = leaf_left ? h.leaf_t_in : sylva_inf();
                if (h.done == 0u) bound = sylva_min(bound, sylva_index_bound(it, h.leaf_t_out));
                if (h.done != 0u || SYLVA_HIT_WINDOW_OF(h).w_t0[h.count - 1u] < bound) {
                    sylva_hit_pop(h, hit);
                    return true;
                }
            }
            if (leaf_left) {
                sylva_hits_test_next SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(elems));
            } else if (h.done == 0u) {
                sylva_hits_fetch_leaf SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words));
            } else if (h.truncated != 0u) {
                another_pass = true;
                break;
            } else {
                return false;
            }
        }
        if (another_pass) {
            h.steps_before = h.steps_before + sylva_index_steps(it);
            sylva_hits_start_pass SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words));
        }
    }
    // Only an ERROR leaves the loops, or a device that cut them short (lavapipe ends loops after
    // 65,535 iterations): either way the ray is marked, never handed out short.
    h.status = SYLVA_ITER_ERROR;
    h.count = 0u;
    return false;
}

/// Nearest hit (smallest t0, then smallest record index) of the ray over [t_min, t_max].
/// `status` receives the index's final status, `steps` the nodes it visited.
SYLVA_ELEM_TEMPLATE
SYLVA_FN bool sylva_elements_first_hit(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), uint elem_count, vec3 o,
                                       vec3 d, float t_min, float t_max, SYLVA_OUT(SylvaHit) hit,
                                       SYLVA_OUT(uint) steps, SYLVA_OUT(uint) status) {
    SylvaHitIter h;
    SylvaIndexIter it;
    sylva_hits_init SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words), word_count, elem_count, o, d, t_min, t_max);
    sylva_hits_want(h, 1u);
    bool found = sylva_hits_next SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(elems), hit);
    steps = sylva_hits_steps SYLVA_ELEM_TARGS(h, it);
    status = h.status;
    return found;
}

/// Adds one medium (straight RGB, optical depth) front to back.
SYLVA_FN void sylva_composite_medium(SYLVA_INOUT(SylvaComposite) acc, vec4 medium) {
    float a = sylva_tau_alpha(medium.w);
    float k = (1.0f - acc.alpha) * a;
    acc.rgb = vec3(acc.rgb.x + k * medium.x, acc.rgb.y + k * medium.y, acc.rgb.z + k * medium.z);
    acc.alpha = acc.alpha + k;
}

/// Where a ray's compositing stands, for a device that resumes it in another dispatch (a device
/// that cuts loops short: lavapipe ends a batch of invocations' loops after 65,535 iterations). `rgba`:
/// premultiplied colour and opacity so far; `last_elem` / `last_t0`: the last hit composited
/// (SYLVA_NO_NODE: none yet); `steps`: index nodes visited so far, over all dispatches;
/// `status`: SYLVA_ITER_RUNNING while the ray stopped at its loop budget and is to be resumed,
/// else DONE or ERROR.
struct SylvaCompositeResume {
    vec4 rgba;
    uint last_elem;
    float last_t0;
    uint steps;
    uint status;
};

/// A ray whose compositing has not started.
SYLVA_FN SylvaCompositeResume sylva_composite_fresh() {
    SylvaCompositeResume r;
    r.rgba = vec4(0.0f);
    r.last_elem = SYLVA_NO_NODE;
    r.last_t0 = 0.0f;
    r.steps = 0u;
    r.status = SYLVA_ITER_RUNNING;
    return r;
}

/// Composites the elements the ray crosses, front to back in hit order, each over its own
/// interval [t0, t1] (sylva_elem_medium), until the opacity reaches alpha_stop, continuing from
/// `r` (sylva_composite_fresh, or a stretch that paused): after the last hit composited it starts
/// a pass for the hits after it, which is how a window overflow continues (the same hits in the
/// same order, so the same colour as in one stretch). After a hit, once the loop iterations of
/// this stretch (the hit iterator's, plus three times the index steps, which bound the index's
/// loops) exceed `budget`, it pauses, leaving r.status RUNNING; budget 0xFFFFFFFF: no limit. A
/// stretch always composites a hit before it pauses, so stretches make progress; the work before
/// that first hit is not bounded.
SYLVA_ELEM_TEMPLATE
SYLVA_FN void sylva_elements_composite_resume(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), uint elem_count,
                                              vec3 o, vec3 d, float t_min, float t_max, float alpha_stop, uint budget,
                                              SYLVA_INOUT(SylvaCompositeResume) r) {
    SylvaHitIter h;
    SylvaIndexIter it;
    sylva_hits_init SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words), word_count, elem_count, o, d, t_min, t_max);
    if (r.last_elem != SYLVA_NO_NODE) {
        h.emitted = 1u;
        h.last_t0 = r.last_t0;
        h.last_elem = r.last_elem;
    }
    SylvaComposite acc;
    acc.rgb = vec3(r.rgba.x, r.rgba.y, r.rgba.z);
    acc.alpha = r.rgba.w;
    SylvaHit hit;
    bool over_budget = false;
    while (acc.alpha < alpha_stop && !over_budget &&
           sylva_hits_next SYLVA_ELEM_TARGS(h, it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(elems), hit)) {
        SylvaElem x;
        sylva_elem_load(SYLVA_PASS_BUF(elems), hit.elem, x);
        sylva_composite_medium(acc, sylva_elem_medium(x, o, d, hit.t0, hit.t1));
        r.last_elem = hit.elem;
        r.last_t0 = hit.t0;
        // The index's loop iterations are bounded by three times its steps (visits, pops, one
        // more a leaf handed out).
        uint steps = sylva_hits_steps SYLVA_ELEM_TARGS(h, it);
        over_budget = budget != 0xFFFFFFFFu && (h.work > budget || steps > (budget - h.work) / 3u);
    }
    // Paused: the index may have finished its pass (status DONE) with hits still in the window.
    bool paused = over_budget && h.status != SYLVA_ITER_ERROR && acc.alpha < alpha_stop;
    // Still running below alpha_stop without pausing: a device cut the loop short (see
    // sylva_hits_next); the ray is marked, never drawn short.
    if (!paused && acc.alpha < alpha_stop && h.status == SYLVA_ITER_RUNNING) h.status = SYLVA_ITER_ERROR;
    r.rgba = vec4(acc.rgb.x, acc.rgb.y, acc.rgb.z, acc.alpha);
    r.steps = r.steps + sylva_hits_steps SYLVA_ELEM_TARGS(h, it);
    r.status = paused ? SYLVA_ITER_RUNNING : (h.status == SYLVA_ITER_ERROR ? SYLVA_ITER_ERROR : SYLVA_ITER_DONE);
}

/// Composites the elements the ray crosses, front to back in hit order, each over its own
/// interval [t0, t1] (sylva_elem_medium), until the opacity reaches alpha_stop. Returns
/// premultiplied RGB and opacity.
SYLVA_ELEM_TEMPLATE
SYLVA_FN vec4 sylva_elements_composite(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), uint elem_count, vec3 o,
                                       vec3 d, float t_min, float t_max, float alpha_stop, SYLVA_OUT(uint) steps,
                                       SYLVA_OUT(uint) status) {
    SylvaCompositeResume r = sylva_composite_fresh();
    sylva_elements_composite_resume SYLVA_ELEM_TARGS(SYLVA_PASS_BUF(words), word_count, SYLVA_PASS_BUF(elems), elem_count,
                                                     o, d, t_min, t_max, alpha_stop, 0xFFFFFFFFu, r);
    steps = r.steps;
    status = r.status;
    return r.rgba;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ELEMENT_KERNELS_H
