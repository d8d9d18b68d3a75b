// sylva/shared/index_particles.h -- the particle integrator of sylva/shared/particles.h
// (Kinkelin 4.2, after Kaehler et al.: front-to-back compositing, no global sort) over any
// element index whose leaves tile the ray front to back and claim each element in one of them:
// the element kd-tree (sylva/shared/element_kd.h) and the element octree (element_octree.h).
// octree_particles.h and kd_elem_particles.h name it for their index; the text is one.
//
// The index is a parameter, as in sylva/shared/element_kernels.h: in C++ the template parameter
// SylvaIndexIter (its protocol functions, sylva/shared/element_bih.h, found by argument-dependent
// lookup); in GLSL the macro SylvaIndexIter, defined before including this header after the
// index's adapter header. The BIH does not qualify: its leaves overlap and come out of order.
//
// Records: the 8-word particle records of particles.h in the buffer `elems`, in the element
// order the index was built over (element e is record e). A particle contributes at its
// closest approach t_c; with straddling references it is listed in every leaf it overlaps, so
// a leaf composites only the particles whose t_c it claims (sylva_index_keeps: t_c in
// [t0, t1)), nearest first (sorted by (t_c, element) in every leaf, of any size, in windows of
// SYLVA_PARTICLE_SORT). The leaves come front to back and their intervals tile the ray, so the
// ray receives exactly the particles that pass within their radius at t_c in [t_min, t_max],
// in (t_c, element) order: the order of a brute-force sort, the same image through either
// index, bit for bit. The ray stops at the end of a leaf once its opacity reaches alpha_stop.
#ifndef SYLVA_SHARED_INDEX_PARTICLES_H
#define SYLVA_SHARED_INDEX_PARTICLES_H

#include "sylva/shared/particles.h"

/// Claimed particles a leaf sorts in a local list per pass over its references; more take
/// further passes.
#define SYLVA_PARTICLE_SORT 32u

#ifdef __cplusplus
#define SYLVA_INDEX_TEMPLATE template <class SylvaIndexIter>
#define SYLVA_INDEX_TARGS(I) <I>
#else
#ifndef SylvaIndexIter
#error "sylva/shared/index_particles.h: #define SylvaIndexIter <the index's iterator> before including it"
#endif
#define SYLVA_INDEX_TEMPLATE
#define SYLVA_INDEX_TARGS(I)
#endif

SYLVA_BEGIN_NAMESPACE

/// Closest approach (t_c, (d/r)^2) of the ray to record e of `elems`.
SYLVA_FN vec2 sylva_particle_record_approach(SYLVA_BUF(elems), uint e, vec3 o, vec3 d) {
    vec3 c = sylva_elem_center(SYLVA_PASS_BUF(elems), e);
    float r = uintBitsToFloat(SYLVA_LOAD(elems, e * SYLVA_PARTICLE_WORDS + 3u));
    return sylva_particle_approach(c, r, o, d);
}

/// True when (t, e) comes before (u, f) in the compositing order: by t_c, then by element.
SYLVA_FN bool sylva_particle_before(float t, uint e, float u, uint f) { return t < u || (t == u && e < f); }

/// Composites the particles of one leaf (references [first, first + count) of `words`) whose
/// t_c the leaf claims, in (t_c, element) order, in windows of SYLVA_PARTICLE_SORT: each pass
/// over the references keeps the SYLVA_PARTICLE_SORT least (t_c, element) after the last one
/// composited in a local list sorted by insertion, then composites them; a leaf that claims
/// more needs ceil(claimed / SYLVA_PARTICLE_SORT) passes (most need one). Passes, not a
/// selection of one particle per pass over the references: lavapipe ends every loop of a
/// shader invocation once 65535 loop iterations have run in it in all (its loop limiter counts
/// per invocation, not per loop), and one pass per particle over a leaf of hundreds of
/// references exceeds that. False on a reference past `records` (or the index's "none").
SYLVA_INDEX_TEMPLATE
SYLVA_FN bool sylva_index_particle_leaf(SYLVA_INOUT(SylvaComposite) acc, SYLVA_INOUT(SylvaIndexIter) it,
                                        SYLVA_BUF(words), SYLVA_BUF(elems), uint records, uint first, uint count,
                                        vec3 o, vec3 d, float t0, float t1) {
    float cand_t[SYLVA_PARTICLE_SORT];
    float cand_q[SYLVA_PARTICLE_SORT];
    uint cand_e[SYLVA_PARTICLE_SORT];
    float last_t = -sylva_inf();
    uint last_e = 0xFFFFFFFFu;  // none composited yet (records stay below 2^29)
    bool more = true;
    while (more) {
        more = false;
        uint m = 0u;
        for (uint k = 0u; k < count; k++) {
            uint e = sylva_index_element(it, SYLVA_PASS_BUF(words), first + k);
            if (e >= records) return false;  // also the index's "none" (0xFFFFFFFF)
            vec2 a = sylva_particle_record_approach(SYLVA_PASS_BUF(elems), e, o, d);
            if (!(a.y <= 1.0f) || !sylva_index_keeps(it, a.x, t0, t1)) continue;
            if (last_e != 0xFFFFFFFFu && !sylva_particle_before(last_t, last_e, a.x, e)) continue;  // composited
            if (m == SYLVA_PARTICLE_SORT) {
                more = true;  // the window is full: this one or the last in it waits for the next pass
                if (!sylva_particle_before(a.x, e, cand_t[m - 1u], cand_e[m - 1u])) continue;
                m = m - 1u;
            }
            uint j = m;
            while (j > 0u && sylva_particle_before(a.x, e, cand_t[j - 1u], cand_e[j - 1u])) {
                cand_t[j] = cand_t[j - 1u];
                cand_q[j] = cand_q[j - 1u];
                cand_e[j] = cand_e[j - 1u];
                j = j - 1u;
            }
            cand_t[j] = a.x;
            cand_q[j] = a.y;
            cand_e[j] = e;
            m = m + 1u;
        }
        for (uint i = 0u; i < m; i++) {
            uint e = cand_e[i];
            float kappa = uintBitsToFloat(SYLVA_LOAD(elems, e * SYLVA_PARTICLE_WORDS + 4u));
            uint rgba8 = SYLVA_LOAD(elems, e * SYLVA_PARTICLE_WORDS + 5u);
            sylva_composite_add(acc, sylva_unpack_rgba8(rgba8), sylva_radial_weight(cand_q[i], kappa));
        }
        if (m > 0u) {
            last_t = cand_t[m - 1u];
            last_e = cand_e[m - 1u];
        }
    }
    return true;
}

/// Renders one ray through the index (`records` 8-word records in `elems`, at most
/// SYLVA_PARTICLE_MAX_RECORDS); returns premultiplied RGB and opacity, the walk's steps and
/// final status: ERROR on a corrupted encoding, a reference past the records, or too many
/// records; RUNNING when the opacity reached alpha_stop before the walk ended.
SYLVA_INDEX_TEMPLATE
SYLVA_FN vec4 sylva_index_render_particles(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), uint records, vec3 o,
                                           vec3 d, float t_min, float t_max, float alpha_stop, SYLVA_OUT(uint) steps,
                                           SYLVA_OUT(uint) status) {
    SylvaIndexIter it;
    sylva_index_init(it, SYLVA_PASS_BUF(words), word_count, o, d, t_min, t_max);
    bool failed = records > SYLVA_PARTICLE_MAX_RECORDS;
    SylvaComposite acc;
    acc.rgb = vec3(0.0f);
    acc.alpha = 0.0f;
    float t0;
    float t1;
    uint first;
    uint count;
    while (!failed && acc.alpha < alpha_stop && sylva_index_leaf(it, SYLVA_PASS_BUF(words), first, count, t0, t1)) {
        failed = !sylva_index_particle_leaf SYLVA_INDEX_TARGS(SylvaIndexIter)(
            acc, it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(elems), records, first, count, o, d, t0, t1);
    }
    steps = sylva_index_steps(it);
    status = failed ? SYLVA_ITER_ERROR : sylva_index_status(it);
    return vec4(acc.rgb.x, acc.rgb.y, acc.rgb.z, acc.alpha);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_INDEX_PARTICLES_H
