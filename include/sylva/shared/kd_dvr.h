// sylva/shared/kd_dvr.h -- the reference DVR marcher (dvr.h) with empty-space skipping by an
// encoded empty-space kd-tree (kd_layout.h, kd_iter.h; Vidal et al., Zellmann et al.): the
// marcher's lattice samples t_k = k dt are taken only inside the leaves the ray crosses, front
// to back, with exactly the marcher's per-sample math (sylva_grid_density,
// sylva_dvr_march_sample), so the image is the plain marcher's, bit for bit, whenever the
// leaves hold every sample that can contribute.
//
// Which samples can contribute (what the tree must be built on; sylva/render/kd_volume.hpp
// builds that occupancy). A sample at world point x reads the eight voxels around
// u = x / spacing - 0.5: when x lies in the cell of voxel v, those voxels lie in v's 3x3x3
// neighbourhood, so trilinear reconstruction reaches half a voxel beyond a voxel. Its density
// is a convex blend of theirs and so lies in [min, max] of that neighbourhood (up to a few
// ulp of rounding, which the host absorbs by widening the range). Between two TF entries the
// lookup is linear, so a density can be visible only in a segment with a visible end entry:
// a voxel is "occupied" when its neighbourhood's density range touches such a segment. This
// already covers the half-voxel reach, and it is exact for any TF, also for a visible band
// between two densities that are both transparent (neighbours 0.2 and 0.8, alpha only near
// 0.5), which classifying each voxel's own density and then dilating by one voxel misses.
// It also leaves a margin: a sample whose trilinear corners are c and c + 1 (per axis) lies in
// [c + 0.5, c + 1.5], and the cells c and c + 1 both hold all of its corners in their
// neighbourhoods, so both are occupied whenever the sample is visible. Every visible sample
// thus lies at least half a voxel inside the union of the occupied cells (or on the grid's
// own boundary, where the marcher's span ends too), far more than the ~1e-4 voxel by which the
// iterator's voxel-space parameters and the marcher's world-space sample positions can
// disagree; no further dilation is needed (volume::dilate would only add empty space: +45 %
// steps per ray on the aneurism's deep tree).
//
// Rounding at leaf faces. For each leaf the samples are taken over the ray's interval in the
// leaf's box grown by SYLVA_KD_DVR_MARGIN voxels on every side, not over the iterator's
// [t0, t1]: where the ray passes from one leaf into the next across a shared face, or through
// an edge where three leaves meet, the voxel-space interval ends of different planes may
// disagree by a rounding step and leave a sliver of t (for grazing rays, a long one) that no
// leaf claims; grown boxes overlap, so no sample falls between them. Overlap would take a
// sample twice (a lattice sample on a shared face belongs to both closed boxes), so a running
// lattice index k_next (the first index not yet considered) makes every sample be taken at
// most once and in increasing order: leaf i takes k >= max(k_next, first k with t_k >= its
// start) while t_k < its end. Samples taken in the margin are genuine marcher samples (same
// math, same result), so extra ones cost time, never accuracy. Samples are also clipped to the
// marcher's own span (grid box and [t_min, t_max], computed as in sylva_dvr_march), so the
// samples taken are a subset of the marcher's, in the marcher's order, and every marcher
// sample left out is invisible: identical compositing, identical early termination.
//
// Steps (the traversal-cost heat map): kd iterator node visits + lattice samples taken
// (the plain marcher reports lattice samples only).
//
// Parameter block: dvr_common.h's, with word 34 the word count of the encoded kd-tree (the
// `words` buffer). The tree's grid must be the marcher's: same dims and spacing, origin 0
// (the host checks; sylva/render/kd_volume.hpp).
#ifndef SYLVA_SHARED_KD_DVR_H
#define SYLVA_SHARED_KD_DVR_H

#include "sylva/shared/dvr.h"
#include "sylva/shared/kd_iter.h"

/// How far (in voxels) each leaf box is grown before its samples are taken (see above): far
/// above the rounding of voxel-space ray parameters (~1e-4 voxel for coordinates up to a few
/// thousand voxels), far below the half-voxel margin of the occupancy. (Overridable for
/// experiments: define it before including.)
#ifndef SYLVA_KD_DVR_MARGIN
#define SYLVA_KD_DVR_MARGIN 0.0625f
#endif

SYLVA_BEGIN_NAMESPACE

/// The ray interval inside node `node`'s box grown by `margin` voxels, within [t0, t1].
SYLVA_FN vec2 sylva_kd_dvr_leaf_span(SYLVA_BUF(words), vec3 org, vec3 rcp, uvec3 par, uint node, float margin,
                                     float t0, float t1) {
    uvec3 lo = sylva_kd_box_lo(SYLVA_PASS_BUF(words), node);
    uvec3 hi = sylva_kd_box_hi(SYLVA_PASS_BUF(words), node);
    vec3 glo = vec3(float(lo.x) - margin, float(lo.y) - margin, float(lo.z) - margin);
    vec3 ghi = vec3(float(hi.x) + margin, float(hi.y) + margin, float(hi.z) + margin);
    return sylva_kd_box_interval_f(org, rcp, par, glo, ghi, t0, t1);
}

/// The marcher's samples k >= k_first with t_k < t_end, composited into acc; stops early at
/// alpha_stop or when `samples` reaches the cap. Returns the first index not taken.
SYLVA_FN uint sylva_kd_dvr_segment(SYLVA_INOUT(SylvaDvrAcc) acc, SYLVA_BUF(grid), SYLVA_BUF(tf), SylvaDvrParams p,
                                   vec3 origin, vec3 d, uint k_first, float t_end, SYLVA_INOUT(uint) samples) {
    float units = p.dt / p.unit;
    SylvaGridDesc g = sylva_dvr_grid(p);
    uint k = k_first;
    for (; samples < SYLVA_DVR_MAX_SAMPLES; k++) {
        float t = sylva_lattice_t(k, p.dt);
        if (!(t < t_end) || acc.alpha >= p.alpha_stop) break;
        samples = samples + 1u;
        vec3 x = sylva_dvr_at(origin, d, t);
        float density = sylva_grid_sample(SYLVA_PASS_BUF(grid), g, x);
        if (density > 0.0f) {
            sylva_dvr_march_sample_in(acc, SYLVA_PASS_BUF(grid), SYLVA_PASS_BUF(tf), p, g, x, density, d, units);
        }
    }
    return k;
}

/// sylva_dvr_march over [t_min, t_max] restricted to the leaves of the kd-tree `words`
/// (p.word_count words). Returns premultiplied RGB and opacity; `steps` receives iterator node
/// visits + lattice samples taken, `status` the iterator's final status (SYLVA_ITER_ERROR for
/// a corrupt encoding; the samples composited until then are returned).
SYLVA_FN vec4 sylva_kd_dvr_march(SYLVA_BUF(words), SYLVA_BUF(grid), SYLVA_BUF(tf), SylvaDvrParams p, vec3 origin,
                                 vec3 direction, float t_min, float t_max, SYLVA_OUT(uint) steps,
                                 SYLVA_OUT(uint) status) {
    steps = 0u;
    status = SYLVA_ITER_DONE;
    SylvaDvrAcc acc = sylva_dvr_acc_zero();
    vec3 d = sylva_dvr_unit(direction);
    vec2 span = sylva_dvr_clip(vec3(0.0f), sylva_dvr_grid_hi(p), origin, d, t_min, t_max);
    if (!(span.x <= span.y) || !(p.dt > 0.0f) || !(p.unit > 0.0f) || sylva_dvr_dot(d, d) == 0.0f) {
        return vec4(0.0f);
    }
    SylvaKdIter it;
    it.org = vec3(0.0f);  // set by init whenever next() can yield; defined here for the compiler
    it.rcp = vec3(0.0f);
    it.parallel = uvec3(0u);
    sylva_kd_init(it, SYLVA_PASS_BUF(words), p.word_count, origin, d, t_min, t_max);
    uint samples = 0u;
    uint k_next = 0u;
    uint leaf;
    float t0;
    float t1;
    while (acc.alpha < p.alpha_stop && samples < SYLVA_DVR_MAX_SAMPLES &&
           sylva_kd_next(it, SYLVA_PASS_BUF(words), leaf, t0, t1)) {
        vec2 s = sylva_kd_dvr_leaf_span(SYLVA_PASS_BUF(words), it.org, it.rcp, it.parallel, it.leaf_node,
                                        SYLVA_KD_DVR_MARGIN, span.x, span.y);
        if (!(s.x <= s.y)) continue;
        uint k_first = sylva_lattice_first(s.x, p.dt);
        if (k_first < k_next) k_first = k_next;
        uint k_end = sylva_kd_dvr_segment(acc, SYLVA_PASS_BUF(grid), SYLVA_PASS_BUF(tf), p, origin, d, k_first, s.y,
                                          samples);
        if (k_end > k_next) k_next = k_end;
    }
    steps = it.steps + samples;
    status = it.status;
    return sylva_dvr_result(acc);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_DVR_H
