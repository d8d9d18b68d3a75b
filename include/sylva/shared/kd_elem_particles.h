// sylva/shared/kd_elem_particles.h -- the particle integrator of sylva/shared/particles.h
// (Kinkelin 4.2, after Kaehler et al.: front-to-back compositing, no global sort) over the
// element kd-tree (sylva/shared/kd_elem_iter.h): the element octree's integrator
// (octree_particles.h) with the kd-tree's iterator. Records: the 8-word particle records of
// particles.h in the element order the kd-tree was built over (element e is record e). Each
// leaf composites the particles whose closest approach t_c it claims (sylva_kde_claims), in
// (t_c, element) order; the leaves tile the ray front to back, so the ray receives the particles
// in the order of a brute-force sort, the same image as the element octree's, bit for bit.
// TODO(issue 14, item 2): one integrator over any ordered element iterator instead of this
// twin of octree_particles.h.
#ifndef SYLVA_SHARED_KD_ELEM_PARTICLES_H
#define SYLVA_SHARED_KD_ELEM_PARTICLES_H

#include "sylva/shared/kd_elem_iter.h"
#include "sylva/shared/particles.h"

/// Claimed particles a leaf sorts in a local list per pass over its references; more take
/// further passes.
#define SYLVA_KDE_SORT 32u

SYLVA_BEGIN_NAMESPACE

/// Closest approach (t_c, (d/r)^2) of the ray to record e of `elems`.
SYLVA_FN vec2 sylva_kde_approach(SYLVA_BUF(elems), uint e, vec3 o, vec3 d) {
    vec3 c = sylva_elem_center(SYLVA_PASS_BUF(elems), e);
    float r = uintBitsToFloat(SYLVA_LOAD(elems, e * SYLVA_PARTICLE_WORDS + 3u));
    return sylva_particle_approach(c, r, o, d);
}

/// True when (t, e) comes before (u, f) in the compositing order: by t_c, then by element.
SYLVA_FN bool sylva_kde_before(float t, uint e, float u, uint f) { return t < u || (t == u && e < f); }

/// Composites the particles of one leaf (references [first, first + count) of `words`) whose
/// t_c the leaf claims, in (t_c, element) order, in windows of SYLVA_KDE_SORT: each pass over
/// the references keeps the SYLVA_KDE_SORT least (t_c, element) after the last one composited
/// in a local list sorted by insertion, then composites them; a leaf that claims more needs
/// ceil(claimed / SYLVA_KDE_SORT) passes (most need one). Passes, not a selection of one
/// particle per pass over the references: lavapipe ends every loop of a shader invocation once
/// 65535 loop iterations have run in it in all (its loop limiter counts per invocation, not
/// per loop), and one pass per particle over a leaf of hundreds of references exceeds that.
/// False (status ERROR) on a reference past `records` or past the element count.
SYLVA_FN bool sylva_kde_particle_leaf(SYLVA_INOUT(SylvaComposite) acc, SYLVA_INOUT(SylvaKdElemIter) it,
                                       SYLVA_BUF(words), SYLVA_BUF(elems), uint records, uint first, uint count,
                                       vec3 o, vec3 d, float t0, float t1) {
    float cand_t[SYLVA_KDE_SORT];
    float cand_q[SYLVA_KDE_SORT];
    uint cand_e[SYLVA_KDE_SORT];
    float last_t = -sylva_inf();
    uint last_e = SYLVA_KDE_NONE;
    bool more = true;
    while (more) {
        more = false;
        uint m = 0u;
        for (uint k = 0u; k < count; k++) {
            uint e = sylva_kde_element(it, SYLVA_PASS_BUF(words), first + k);
            if (e == SYLVA_KDE_NONE || e >= records) {
                it.status = SYLVA_ITER_ERROR;
                return false;
            }
            vec2 a = sylva_kde_approach(SYLVA_PASS_BUF(elems), e, o, d);
            if (!(a.y <= 1.0f) || !sylva_kde_claims(it, a.x, t0, t1)) continue;
            if (last_e != SYLVA_KDE_NONE && !sylva_kde_before(last_t, last_e, a.x, e)) continue;  // composited
            if (m == SYLVA_KDE_SORT) {
                more = true;  // the window is full: this one or the last in it waits for the next pass
                if (!sylva_kde_before(a.x, e, cand_t[m - 1u], cand_e[m - 1u])) continue;
                m = m - 1u;
            }
            uint j = m;
            while (j > 0u && sylva_kde_before(a.x, e, cand_t[j - 1u], cand_e[j - 1u])) {
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

/// Renders one ray through a particle element kd-tree (`records` 8-word records in `elems`, at
/// most SYLVA_PARTICLE_MAX_RECORDS); returns premultiplied RGB and opacity, the walk's steps and
/// final status (ERROR on a corrupted encoding, a reference past the records, or too many
/// records).
SYLVA_FN vec4 sylva_kde_render_particles(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), uint records, vec3 o,
                                          vec3 d, float t_min, float t_max, float alpha_stop, SYLVA_OUT(uint) steps,
                                          SYLVA_OUT(uint) status) {
    SylvaKdElemIter it;
    sylva_kde_init(it, SYLVA_PASS_BUF(words), word_count, o, d, t_min, t_max);
    if (records > SYLVA_PARTICLE_MAX_RECORDS) it.status = SYLVA_ITER_ERROR;
    SylvaComposite acc;
    acc.rgb = vec3(0.0f);
    acc.alpha = 0.0f;
    uint node;
    float t0;
    float t1;
    uint first;
    uint count;
    while (acc.alpha < alpha_stop && sylva_kde_next(it, SYLVA_PASS_BUF(words), node, t0, t1, first, count)) {
        if (!sylva_kde_particle_leaf(acc, it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(elems), records, first, count, o,
                                      d, t0, t1))
            break;
    }
    steps = it.steps;
    status = it.status;
    return vec4(acc.rgb.x, acc.rgb.y, acc.rgb.z, acc.alpha);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_ELEM_PARTICLES_H
