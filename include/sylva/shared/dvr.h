// sylva/shared/dvr.h -- the reference ray marcher ("traditional DVR", Kinkelin section 6.2)
// that every other volume renderer is compared with.
//
// The ray is clipped to the grid box [0, dims * spacing] and to [t_min, t_max]; it is sampled
// on the global lattice t_k = k dt of dvr_common.h (t from the ray origin, not restarting at
// the box entry), dt = longest world extent / 1024 by default (chosen on the host). Each
// sample: trilinear density (grid_sample.h) -> TF (tf.h) -> opacity correction
// 1 - (1 - alpha)^(dt / unit) -> optional Lambert/Blinn-Phong shading from the on-the-fly
// central-difference gradient (six more samples) -> front-to-back compositing. Samples of
// density <= 0 are skipped (TF entry 0 counts as transparent); the ray stops once its opacity
// reaches alpha_stop (early ray termination).
#ifndef SYLVA_SHARED_DVR_H
#define SYLVA_SHARED_DVR_H

#include "sylva/shared/dvr_classify.h"
#include "sylva/shared/dvr_common.h"
#include "sylva/shared/grid_sample.h"
#include "sylva/shared/tf.h"

SYLVA_BEGIN_NAMESPACE

/// Ray interval inside the closed slab [lo, hi] of one axis (d == 0: all or nothing).
SYLVA_FN vec2 sylva_dvr_slab(float lo, float hi, float o, float d) {
    if (d == 0.0f) return (o >= lo && o <= hi) ? vec2(-sylva_inf(), sylva_inf()) : vec2(sylva_inf(), -sylva_inf());
    float r = sylva_safe_rcp(d);
    float ta = sylva_canon((lo - o) * r);
    float tb = sylva_canon((hi - o) * r);
    return vec2(sylva_min(ta, tb), sylva_max(ta, tb));
}

/// The part of [t_min, t_max] where the ray is inside the box [lo, hi]; empty when x > y.
SYLVA_FN vec2 sylva_dvr_clip(vec3 lo, vec3 hi, vec3 o, vec3 d, float t_min, float t_max) {
    vec2 sx = sylva_dvr_slab(lo.x, hi.x, o.x, d.x);
    vec2 sy = sylva_dvr_slab(lo.y, hi.y, o.y, d.y);
    vec2 sz = sylva_dvr_slab(lo.z, hi.z, o.z, d.z);
    float t0 = sylva_max(sylva_max(t_min, sx.x), sylva_max(sy.x, sz.x));
    float t1 = sylva_min(sylva_min(t_max, sx.y), sylva_min(sy.y, sz.y));
    return vec2(t0, t1);
}

/// World box of the grid: [0, dims * spacing].
SYLVA_FN vec3 sylva_dvr_grid_hi(SylvaDvrParams p) {
    return vec3(float(p.dims.x) * p.spacing.x, float(p.dims.y) * p.spacing.y, float(p.dims.z) * p.spacing.z);
}

/// The grid the marcher samples: dims, spacing, border mode, voxel format and value range of
/// the parameter block (words 28-33, 38-42; sylva/shared/grid_sample.h).
SYLVA_FN SylvaGridDesc sylva_dvr_grid(SylvaDvrParams p) {
    SylvaGridDesc g;
    g.dims = p.dims;
    g.spacing = p.spacing;
    g.border = p.border;
    g.border_value = p.border_value;
    g.format = p.grid_format;
    g.value_lo = p.value_lo;
    g.value_span = p.value_span;
    return g;
}

/// Classifies, shades and composites one marcher sample of density `density` at x of the grid g
/// (sylva_dvr_grid(p), built once a ray by the caller and passed by reference on the host: a
/// descriptor rebuilt and copied every sample cost the host marcher 2.7x its speed in
/// store-to-load stalls, docs/DESIGN.md).
SYLVA_FN void sylva_dvr_march_sample_in(SYLVA_INOUT(SylvaDvrAcc) acc, SYLVA_BUF(grid), SYLVA_BUF(tf), SylvaDvrParams p,
                                        SYLVA_IN(SylvaGridDesc) g, vec3 x, float density, vec3 d, float units) {
    vec4 c = sylva_dvr_classify(SYLVA_PASS_BUF(tf), p, density);
    float a = sylva_dvr_opacity(p, c.w, units);
    if (a <= 0.0f) return;
    vec3 rgb = vec3(c.x, c.y, c.z);
    if ((p.flags & SYLVA_DVR_FLAG_SHADING) != 0u) {
        vec3 gr = sylva_grid_sample_gradient(SYLVA_PASS_BUF(grid), g, x);
        rgb = sylva_dvr_shade(p, rgb, vec3(gr.x / p.spacing.x, gr.y / p.spacing.y, gr.z / p.spacing.z), d);
    }
    sylva_dvr_blend(acc, rgb, a);
}

/// Classifies, shades and composites one marcher sample of density `density` at x.
SYLVA_FN void sylva_dvr_march_sample(SYLVA_INOUT(SylvaDvrAcc) acc, SYLVA_BUF(grid), SYLVA_BUF(tf), SylvaDvrParams p,
                                     vec3 x, float density, vec3 d, float units) {
    sylva_dvr_march_sample_in(acc, SYLVA_PASS_BUF(grid), SYLVA_PASS_BUF(tf), p, sylva_dvr_grid(p), x, density, d, units);
}

/// Marches the ray origin + t * direction (direction normalised here, so t is world distance)
/// over [t_min, t_max] through the grid; returns premultiplied RGB and opacity. `steps`
/// receives the number of lattice samples visited (the cost heat map).
SYLVA_FN vec4 sylva_dvr_march(SYLVA_BUF(grid), SYLVA_BUF(tf), SylvaDvrParams p, vec3 origin, vec3 direction,
                              float t_min, float t_max, SYLVA_OUT(uint) steps) {
    steps = 0u;
    SylvaDvrAcc acc = sylva_dvr_acc_zero();
    vec3 d = sylva_dvr_unit(direction);
    vec2 span = sylva_dvr_clip(vec3(0.0f), sylva_dvr_grid_hi(p), origin, d, t_min, t_max);
    if (!(span.x <= span.y) || !(p.dt > 0.0f) || !(p.unit > 0.0f) || sylva_dvr_dot(d, d) == 0.0f) {
        return vec4(0.0f);
    }
    float units = p.dt / p.unit;
    SylvaGridDesc g = sylva_dvr_grid(p);
    for (uint k = sylva_lattice_first(span.x, p.dt); steps < SYLVA_DVR_MAX_SAMPLES; k++) {
        float t = sylva_lattice_t(k, p.dt);
        if (!(t < span.y) || acc.alpha >= p.alpha_stop) break;
        steps = steps + 1u;
        vec3 x = sylva_dvr_at(origin, d, t);
        float density = sylva_grid_sample(SYLVA_PASS_BUF(grid), g, x);
        if (density > 0.0f) sylva_dvr_march_sample_in(acc, SYLVA_PASS_BUF(grid), SYLVA_PASS_BUF(tf), p, g, x, density, d, units);
    }
    return sylva_dvr_result(acc);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_DVR_H
