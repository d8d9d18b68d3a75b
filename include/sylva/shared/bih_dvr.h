// sylva/shared/bih_dvr.h -- completely BIH-based volume rendering (Kinkelin section 4.3) over a
// BIH whose leaves are voxel cuboids (payload SYLVA_PAYLOAD_VOXEL, sylva/shared/voxel.h),
// traversed front to back with sylva_bih_init / sylva_bih_next (bih_iter.h).
//
// Each leaf holds the density d_c at its centre c and the per-voxel gradient g; inside it the
// density is d(x) = d_c + g . (x - c) / voxel_size (sylva_voxel_density_at), clamped to [0, 1];
// densities <= 0 contribute nothing (as in the marcher). Modes (SYLVA_VOLUME_MODE_*):
//  * single-sample: one sample per leaf segment [t_in, t_out], at its middle (for a linear
//    density the segment's mean), with opacity 1 - (1 - alpha)^(l / unit), l = t_out - t_in;
//  * multi-sample: the marcher's global lattice t_k = k dt inside [t_in, t_out), each sample
//    with the leaf's linear density; a leaf shorter than dt may get no sample (as the paper
//    says), and consecutive leaves keep equidistant samples;
//  * iso: the first point where the density along the ray reaches the iso value, shaded with
//    the leaf gradient in the TF's colour at the iso value, opaque. Along the ray the density
//    is each leaf's linear function (0 between leaves), so that point is either inside a leaf
//    (analytic crossing on the segment, rising through iso) or where the ray enters a leaf
//    that starts at or above iso: neighbouring leaves' linear functions disagree on their
//    shared face, and crossings only inside leaves would leave cracks where the density jumps
//    over the iso value there. Optional culling by the node-range buffer `ranges` skips the
//    subtrees whose maximum stays below iso (Kinkelin 4.1; sylva_bih_next_reaching).
// Colour is shaded (dvr_common.h) with the leaf gradient divided by the voxel size.
//
// Order. Kinkelin section 4 warns that overlapping sibling boxes can disorder the leaves; for
// voxel cuboids on a grid the boxes of different voxels only touch, so leaves come strictly
// front to back (with 16-bit planes, rounded outwards, neighbours may overlap by at most one
// 1/32768 step of the root box, which the renderers ignore).
// Every mode stops once the opacity reaches alpha_stop; `steps` is the iterator's node count
// (the heat map) and `status` its final status (SYLVA_ITER_ERROR for a corrupt encoding or a
// payload kind other than SYLVA_PAYLOAD_VOXEL).
#ifndef SYLVA_SHARED_BIH_DVR_H
#define SYLVA_SHARED_BIH_DVR_H

#include "sylva/shared/bih_iter.h"
#include "sylva/shared/dvr_classify.h"
#include "sylva/shared/dvr_common.h"
#include "sylva/shared/tf.h"
#include "sylva/shared/voxel.h"

SYLVA_BEGIN_NAMESPACE

/// Node-range culling (Kinkelin 4.1): `range` is a node's word of a node-range buffer, bits
/// 0-15 the minimum and bits 16-31 the maximum of the reconstructed density in the node's
/// subtree as unorm16 (q / 65535). True when the maximum, plus one unorm16 step (absorbing the
/// rounding of the reconstruction), is below `iso`: no leaf below can reach the iso value.
/// (A subtree entirely above iso is never culled: the surface lies where the ray enters it.)
SYLVA_FN bool sylva_bih_range_below(uint range, float iso) {
    float hi = float(range >> 16u) * (1.0f / 65535.0f);
    return hi + (1.0f / 65535.0f) < iso;
}

/// sylva_bih_next that skips every node (inner or leaf) whose density range, word `node` of
/// the buffer `ranges` (one word per encoded node index), stays below `iso`. A skipped node
/// counts as a step but its subtree is never visited.
SYLVA_FN bool sylva_bih_next_reaching(SYLVA_INOUT(SylvaBihIter) it, SYLVA_BUF(words), SYLVA_BUF(ranges), float iso,
                                      SYLVA_OUT(uint) leaf, SYLVA_OUT(float) t0, SYLVA_OUT(float) t1) {
    leaf = SYLVA_NO_NODE;
    t0 = 0.0f;
    t1 = 0.0f;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (!sylva_bih_advance(it)) break;
        if (sylva_bih_range_below(SYLVA_LOAD(ranges, it.node), iso)) {
            it.node = SYLVA_NO_NODE;
        } else if (sylva_bih_visit(it, SYLVA_PASS_BUF(words), leaf, t0, t1)) {
            return true;
        }
    }
    return false;
}

/// Starts the iterator on the unit direction d; refuses (status ERROR) a non-voxel payload.
SYLVA_FN void sylva_bih_dvr_start(SYLVA_OUT(SylvaBihIter) it, SYLVA_BUF(words), SylvaDvrParams p, vec3 o, vec3 d,
                                  float t_min, float t_max) {
    sylva_bih_init(it, SYLVA_PASS_BUF(words), p.word_count, o, d, t_min, t_max);
    if (((it.hdr.flags >> 8u) & 255u) != SYLVA_PAYLOAD_VOXEL) it.status = SYLVA_ITER_ERROR;
}

/// World-space centre of the last leaf the iterator returned.
SYLVA_FN vec3 sylva_bih_dvr_center(SylvaBihHeader h, vec3 lo, vec3 hi) {
    return sylva_bih_to_world(h, vec3(0.5f * lo.x + 0.5f * hi.x, 0.5f * lo.y + 0.5f * hi.y, 0.5f * lo.z + 0.5f * hi.z));
}

/// The leaf's linear density at x, clamped to [0, 1].
SYLVA_FN float sylva_bih_dvr_density(SylvaVoxel v, vec3 x, vec3 c, vec3 voxel_size) {
    return sylva_tf_clamp01(sylva_voxel_density_at(v, x, c, voxel_size));
}

/// Classifies, shades and composites one sample of a leaf covering `units` unit lengths.
SYLVA_FN void sylva_bih_dvr_sample(SYLVA_INOUT(SylvaDvrAcc) acc, SYLVA_BUF(tf), SylvaDvrParams p, float density,
                                   vec3 gradient, vec3 d, float units) {
    vec4 c = sylva_dvr_classify(SYLVA_PASS_BUF(tf), p, density);
    float a = sylva_dvr_opacity(p, c.w, units);
    if (a <= 0.0f) return;
    vec3 g = vec3(gradient.x / p.spacing.x, gradient.y / p.spacing.y, gradient.z / p.spacing.z);
    sylva_dvr_blend(acc, sylva_dvr_shade(p, vec3(c.x, c.y, c.z), g, d), a);
}

/// The next leaf whose segment is not empty once clipped to start where the ray is already
/// integrated (t_done): 16-bit planes round outwards, so neighbouring leaf boxes overlap by up
/// to 1/32768 of the root box, and without the clip that overlap would be integrated twice
/// (measured: PSNR against the marcher stopped rising with the resampling factor). Leaves of a
/// voxel grid otherwise come strictly front to back.
SYLVA_FN bool sylva_bih_dvr_next_segment(SYLVA_INOUT(SylvaBihIter) it, SYLVA_BUF(words), SYLVA_INOUT(float) t_done,
                                         SYLVA_OUT(uint) leaf, SYLVA_OUT(float) t0, SYLVA_OUT(float) t1) {
    while (sylva_bih_next(it, SYLVA_PASS_BUF(words), leaf, t0, t1)) {
        t0 = sylva_max(t0, t_done);
        t_done = sylva_max(t_done, t1);
        if (t1 > t0) return true;
    }
    return false;
}

/// Single-sample BIH-DVR of the ray origin + t * direction over [t_min, t_max] (direction
/// normalised here: t is world distance). Returns premultiplied RGB and opacity.
SYLVA_FN vec4 sylva_bih_dvr_single(SYLVA_BUF(words), SYLVA_BUF(tf), SylvaDvrParams p, vec3 origin, vec3 direction,
                                   float t_min, float t_max, SYLVA_OUT(uint) steps, SYLVA_OUT(uint) status) {
    vec3 d = sylva_dvr_unit(direction);
    SylvaBihIter it;
    sylva_bih_dvr_start(it, SYLVA_PASS_BUF(words), p, origin, d, t_min, t_max);
    SylvaDvrAcc acc = sylva_dvr_acc_zero();
    uint leaf;
    float t0;
    float t1;
    float t_done = t_min;
    while (acc.alpha < p.alpha_stop && sylva_bih_dvr_next_segment(it, SYLVA_PASS_BUF(words), t_done, leaf, t0, t1)) {
        SYLVA_PRECISE float len = t1 - t0;
        SylvaVoxel v = sylva_voxel_unpack(sylva_bih_payload(SYLVA_PASS_BUF(words), it.hdr, leaf));
        vec3 c = sylva_bih_dvr_center(it.hdr, it.leaf_lo, it.leaf_hi);
        SYLVA_PRECISE float mid = 0.5f * t0 + 0.5f * t1;
        float density = sylva_bih_dvr_density(v, sylva_dvr_at(origin, d, mid), c, p.spacing);
        if (density > 0.0f) sylva_bih_dvr_sample(acc, SYLVA_PASS_BUF(tf), p, density, v.gradient, d, len / p.unit);
    }
    steps = it.steps;
    status = it.status;
    return sylva_dvr_result(acc);
}

/// Composites the lattice samples t0 <= k dt < t1 of one leaf.
SYLVA_FN void sylva_bih_dvr_leaf_lattice(SYLVA_INOUT(SylvaDvrAcc) acc, SYLVA_BUF(tf), SylvaDvrParams p, SylvaVoxel v,
                                         vec3 c, vec3 o, vec3 d, float t0, float t1) {
    float units = p.dt / p.unit;
    uint k = sylva_lattice_first(t0, p.dt);
    for (uint n = 0u; n < SYLVA_DVR_MAX_SAMPLES; n++) {
        float t = sylva_lattice_t(k + n, p.dt);
        if (!(t < t1) || acc.alpha >= p.alpha_stop) break;
        float density = sylva_bih_dvr_density(v, sylva_dvr_at(o, d, t), c, p.spacing);
        if (density > 0.0f) sylva_bih_dvr_sample(acc, SYLVA_PASS_BUF(tf), p, density, v.gradient, d, units);
    }
}

/// Multi-sample BIH-DVR: the marcher's lattice, each sample with its leaf's linear density.
SYLVA_FN vec4 sylva_bih_dvr_multi(SYLVA_BUF(words), SYLVA_BUF(tf), SylvaDvrParams p, vec3 origin, vec3 direction,
                                  float t_min, float t_max, SYLVA_OUT(uint) steps, SYLVA_OUT(uint) status) {
    vec3 d = sylva_dvr_unit(direction);
    SylvaBihIter it;
    sylva_bih_dvr_start(it, SYLVA_PASS_BUF(words), p, origin, d, t_min, t_max);
    SylvaDvrAcc acc = sylva_dvr_acc_zero();
    uint leaf;
    float t0;
    float t1;
    bool usable = p.dt > 0.0f && p.unit > 0.0f;
    float t_done = t_min;
    while (usable && acc.alpha < p.alpha_stop &&
           sylva_bih_dvr_next_segment(it, SYLVA_PASS_BUF(words), t_done, leaf, t0, t1)) {
        SylvaVoxel v = sylva_voxel_unpack(sylva_bih_payload(SYLVA_PASS_BUF(words), it.hdr, leaf));
        vec3 c = sylva_bih_dvr_center(it.hdr, it.leaf_lo, it.leaf_hi);
        sylva_bih_dvr_leaf_lattice(acc, SYLVA_PASS_BUF(tf), p, v, c, origin, d, t0, t1);
    }
    steps = it.steps;
    status = it.status;
    return sylva_dvr_result(acc);
}

/// The first point of [t0, t1] where the leaf's linear density reaches `iso`: t0 when it
/// enters at or above iso, the analytic crossing when it rises through iso, +inf otherwise.
SYLVA_FN float sylva_bih_iso_reach(SylvaVoxel v, vec3 c, vec3 voxel_size, vec3 o, vec3 d, float t0, float t1,
                                   float iso) {
    SYLVA_PRECISE float a = sylva_voxel_density_at(v, sylva_dvr_at(o, d, t0), c, voxel_size) - iso;
    if (a >= 0.0f) return t0;
    SYLVA_PRECISE float b = sylva_voxel_density_at(v, sylva_dvr_at(o, d, t1), c, voxel_size) - iso;
    if (b < 0.0f) return sylva_inf();
    SYLVA_PRECISE float t = t0 + (t1 - t0) * (a / (a - b));
    return sylva_max(t0, sylva_min(t, t1));
}

/// The next leaf, with or without node-range culling.
SYLVA_FN bool sylva_bih_iso_next(SYLVA_INOUT(SylvaBihIter) it, SYLVA_BUF(words), SYLVA_BUF(ranges), SylvaDvrParams p,
                                 SYLVA_OUT(uint) leaf, SYLVA_OUT(float) t0, SYLVA_OUT(float) t1) {
    if ((p.flags & SYLVA_DVR_FLAG_ISO_CULLING) != 0u) {
        return sylva_bih_next_reaching(it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(ranges), p.iso, leaf, t0, t1);
    }
    return sylva_bih_next(it, SYLVA_PASS_BUF(words), leaf, t0, t1);
}

/// Iso-surface of the leaves' linear densities: the first point reaching p.iso. Returns the
/// shaded TF colour at the iso value, opaque, or transparent black when the ray misses;
/// `t_hit` receives the distance along the normalised direction (+inf on a miss).
SYLVA_FN vec4 sylva_bih_iso(SYLVA_BUF(words), SYLVA_BUF(ranges), SYLVA_BUF(tf), SylvaDvrParams p, vec3 origin,
                            vec3 direction, float t_min, float t_max, SYLVA_OUT(float) t_hit, SYLVA_OUT(uint) steps,
                            SYLVA_OUT(uint) status) {
    vec3 d = sylva_dvr_unit(direction);
    SylvaBihIter it;
    sylva_bih_dvr_start(it, SYLVA_PASS_BUF(words), p, origin, d, t_min, t_max);
    t_hit = sylva_inf();
    vec3 g = vec3(0.0f);
    uint leaf;
    float t0;
    float t1;
    while (sylva_bih_iso_next(it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(ranges), p, leaf, t0, t1)) {
        SylvaVoxel v = sylva_voxel_unpack(sylva_bih_payload(SYLVA_PASS_BUF(words), it.hdr, leaf));
        vec3 c = sylva_bih_dvr_center(it.hdr, it.leaf_lo, it.leaf_hi);
        float t = sylva_bih_iso_reach(v, c, p.spacing, origin, d, t0, t1, p.iso);
        if (t < t_hit) {  // leaves come front to back: what is left can only start after t
            t_hit = t;
            g = v.gradient;
            sylva_bih_clip(it, t);
        }
    }
    steps = it.steps;
    status = it.status;
    if (!(t_hit < sylva_inf()) || status == SYLVA_ITER_ERROR) return vec4(0.0f);
    vec4 c = sylva_dvr_classify(SYLVA_PASS_BUF(tf), p, p.iso);
    vec3 gw = vec3(g.x / p.spacing.x, g.y / p.spacing.y, g.z / p.spacing.z);
    vec3 rgb = sylva_dvr_shade(p, vec3(c.x, c.y, c.z), gw, d);
    return vec4(rgb.x, rgb.y, rgb.z, 1.0f);
}

/// One ray in the mode p.mode (single, multi or iso; anything else renders nothing).
SYLVA_FN vec4 sylva_bih_volume_ray(SYLVA_BUF(words), SYLVA_BUF(ranges), SYLVA_BUF(tf), SylvaDvrParams p, vec3 origin,
                                   vec3 direction, float t_min, float t_max, SYLVA_OUT(uint) steps,
                                   SYLVA_OUT(uint) status) {
    steps = 0u;
    status = SYLVA_ITER_DONE;
    if (p.mode == SYLVA_VOLUME_MODE_BIH_SINGLE) {
        return sylva_bih_dvr_single(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(tf), p, origin, direction, t_min, t_max,
                                    steps, status);
    }
    if (p.mode == SYLVA_VOLUME_MODE_BIH_MULTI) {
        return sylva_bih_dvr_multi(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(tf), p, origin, direction, t_min, t_max,
                                   steps, status);
    }
    if (p.mode == SYLVA_VOLUME_MODE_BIH_ISO) {
        float t_hit;
        return sylva_bih_iso(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(ranges), SYLVA_PASS_BUF(tf), p, origin, direction,
                             t_min, t_max, t_hit, steps, status);
    }
    return vec4(0.0f);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_BIH_DVR_H
