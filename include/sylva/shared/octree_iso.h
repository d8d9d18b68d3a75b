// sylva/shared/octree_iso.h -- first-hit isosurfaces over the bricked octree: the stackless walk
// of octree_iter.h enumerates the cut's leaves front to back; a leaf whose [min, max] stays below
// the iso value (or whose brick is not resident) is skipped unsampled (per-node range culling);
// inside the others the ray samples the brick trilinearly on the global lattice of dvr_common.h
// (step dt * 2^s in a brick s levels above the full resolution, as octree_dvr.h) and stops at
// the first lattice point whose density reaches the iso value. The hit is refined by
// SYLVA_OCT_ISO_BISECT bisections between that point and the lattice point before it (both read
// from the same brick; its border covers the previous point), and shaded with the brick's
// central-difference gradient (sylva_dvr_shade, Lambert + Blinn-Phong, shading always on) in the
// TF's colour at the iso value; the pixel is opaque.
//
// Exactness. Culling never changes the hit: a skipped leaf's range bounds every density its
// lattice points can read (sylva/octree/build.hpp: the range covers the box's trilinear reach
// plus one voxel for rounding), so none of them reaches the iso value. With the full-resolution
// cut the hit lattice point, the bisection and the shading read the same voxels as a grid
// marcher with sylva_grid_sample / sylva_grid_sample_gradient would (border 2; either border mode
// of the parameter block, octree_dvr.h), so the image equals that marcher's bit for bit
// (tests/octree/test_octree_iso.cpp checks it against one).
//
// Buffers: `words` the index, `bricks` the bricks, `tf` the RGBA8 transfer function (tf.h).
#ifndef SYLVA_SHARED_OCTREE_ISO_H
#define SYLVA_SHARED_OCTREE_ISO_H

#include "sylva/shared/octree_dvr.h"

#define SYLVA_OCT_ISO_BISECT 10u

SYLVA_BEGIN_NAMESPACE

/// Bisects [lo, hi] (density(lo) < iso <= density(hi) along origin + t d, from brick b)
/// SYLVA_OCT_ISO_BISECT times; returns the upper end (a point reaching iso).
SYLVA_FN float sylva_oct_iso_bisect(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, vec3 origin, vec3 d, float lo, float hi, float iso) {
    for (uint i = 0u; i < SYLVA_OCT_ISO_BISECT; i++) {
        SYLVA_PRECISE float mid = 0.5f * (lo + hi);
        if (sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, sylva_dvr_at(origin, d, mid)) >= iso) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    return hi;
}

/// Searches the lattice points t_k in [t_lo, t_hi) (step dt) of brick b for the first density
/// >= iso; true with the refined hit in t_hit. `t_first` is the ray's span start: a hit on the
/// first lattice point of the span (or one whose previous point also reaches iso in this brick)
/// is not refined. `steps` counts samples.
SYLVA_FN bool sylva_oct_iso_segment(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, vec3 origin, vec3 d, float t_lo, float t_hi,
                                    float dt, float iso, float t_first, SYLVA_INOUT(uint) steps, SYLVA_OUT(float) t_hit) {
    t_hit = 0.0f;
    for (uint k = sylva_lattice_first(t_lo, dt); steps < SYLVA_DVR_MAX_SAMPLES; k++) {
        float t = sylva_lattice_t(k, dt);
        if (!(t < t_hi)) break;
        steps = steps + 1u;
        if (sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, sylva_dvr_at(origin, d, t)) >= iso) {
            t_hit = t;
            if (k > 0u) {
                float tp = sylva_lattice_t(k - 1u, dt);
                if (tp >= t_first && sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, sylva_dvr_at(origin, d, tp)) < iso)
                    t_hit = sylva_oct_iso_bisect(SYLVA_PASS_BUF(bricks), b, origin, d, tp, t, iso);
            }
            return true;
        }
    }
    return false;
}

/// The shaded, opaque colour of a hit at t from brick b.
SYLVA_FN vec4 sylva_oct_iso_shade(SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_IN(SylvaDvrParams) p, SYLVA_IN(SylvaOctBrick) b, vec3 origin, vec3 d,
                                  float t) {
    vec4 c = sylva_dvr_classify(SYLVA_PASS_BUF(tf), p, p.iso);
    vec3 x = sylva_dvr_at(origin, d, t);
    vec3 g = sylva_oct_brick_gradient(SYLVA_PASS_BUF(bricks), b, x);
    SylvaDvrParams lit = p;
    lit.flags = p.flags | SYLVA_DVR_FLAG_SHADING;
    vec3 rgb = sylva_dvr_shade(lit, vec3(c.x, c.y, c.z), vec3(g.x / b.spacing.x, g.y / b.spacing.y, g.z / b.spacing.z), d);
    return vec4(rgb.x, rgb.y, rgb.z, 1.0f);
}

/// True when node's brick is searched: resident and the greatest density it can return
/// (sylva_oct_sampled_range: the border's too on a face, with a constant border) reaches p.iso.
SYLVA_FN bool sylva_oct_iso_visible(SYLVA_BUF(words), SYLVA_IN(SylvaDvrParams) p, SYLVA_IN(SylvaOctHeader) h, uint node, uint level,
                                    uvec3 c) {
    uint state = sylva_oct_brick_state(sylva_oct_flags(SYLVA_PASS_BUF(words), node));
    return state == SYLVA_OCT_BRICK_RESIDENT && sylva_oct_sampled_range(SYLVA_PASS_BUF(words), h, p, node, level, c).y >= p.iso;
}

/// sylva_oct_iso_ray that also marks in `seen` every cut leaf the ray reached up to its hit (the
/// `visits` leaves; visibility feedback, sylva/shared/octree_dvr.h).
SYLVA_FN vec4 sylva_oct_iso_ray_seen(SYLVA_BUF(words), SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_IN(SylvaDvrParams) p, SYLVA_IN(SylvaOctHeader) h,
                                     uint max_level, vec3 origin, vec3 direction, float t_min, float t_max, SYLVA_SEEN(seen),
                                     SYLVA_OUT(uint) steps, SYLVA_OUT(uint) visits, SYLVA_OUT(uint) status) {
    steps = 0u;
    visits = 0u;
    status = SYLVA_ITER_DONE;
    if (h.valid == 0u) {
        status = SYLVA_ITER_ERROR;
        return vec4(0.0f);
    }
    vec3 d = sylva_dvr_unit(direction);
    vec3 hi = vec3(float(h.dims.x) * h.spacing.x, float(h.dims.y) * h.spacing.y, float(h.dims.z) * h.spacing.z);
    vec2 span = sylva_dvr_clip(vec3(0.0f), hi, origin, d, t_min, t_max);  // the marcher's span
    if (!(span.x <= span.y) || !(p.dt > 0.0f) || sylva_dvr_dot(d, d) == 0.0f) return vec4(0.0f);
    SylvaOctIter it;
    sylva_oct_begin(it, h, origin, d, span.x, span.y, max_level);
    float t_lo = span.x;
    float dt = p.dt;
    bool last_visible = false;
    SylvaOctBrick b = sylva_oct_brick_of(SYLVA_PASS_BUF(words), h, p, 0u, 0u, uvec3(0u, 0u, 0u));
    uint node;
    float t0;
    float t1;
    float t_hit;
    while (sylva_oct_next(it, SYLVA_PASS_BUF(words), node, t0, t1)) {
        visits = visits + 1u;
        sylva_oct_mark_seen(seen, node);
        last_visible = sylva_oct_iso_visible(SYLVA_PASS_BUF(words), p, h, node, it.level, it.coord);
        if (last_visible) {
            b = sylva_oct_brick_of(SYLVA_PASS_BUF(words), h, p, node, it.level, it.coord);
            dt = sylva_oct_level_dt(p.dt, h.levels - 1u - it.level);
            if (sylva_oct_iso_segment(SYLVA_PASS_BUF(bricks), b, origin, d, t_lo, t1, dt, p.iso, span.x, steps, t_hit)) {
                status = SYLVA_ITER_DONE;
                return sylva_oct_iso_shade(SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), p, b, origin, d, t_hit);
            }
        }
        t_lo = t1;
    }
    status = it.status;
    // The marcher's span may end a rounding error after the walk's: the last leaf takes the rest.
    if (last_visible && it.status == SYLVA_ITER_DONE && t_lo < span.y &&
        sylva_oct_iso_segment(SYLVA_PASS_BUF(bricks), b, origin, d, t_lo, span.y, dt, p.iso, span.x, steps, t_hit))
        return sylva_oct_iso_shade(SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), p, b, origin, d, t_hit);
    return vec4(0.0f);
}

/// Renders one ray origin + t * direction (normalised here) over [t_min, t_max]: the first hit
/// of the iso value p.iso through the octree with header h, the cut's leaves at max_level (or
/// marked in the index). Returns the opaque shaded colour, or 0 when the ray misses; `steps` =
/// lattice samples, `visits` = leaves visited, `status` = the walk's final status.
SYLVA_FN vec4 sylva_oct_iso_ray(SYLVA_BUF(words), SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_IN(SylvaDvrParams) p, SYLVA_IN(SylvaOctHeader) h,
                                uint max_level, vec3 origin, vec3 direction, float t_min, float t_max,
                                SYLVA_OUT(uint) steps, SYLVA_OUT(uint) visits, SYLVA_OUT(uint) status) {
    return sylva_oct_iso_ray_seen(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), p, h, max_level, origin,
                                  direction, t_min, t_max, SYLVA_OCT_NO_SEEN, steps, visits, status);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_OCTREE_ISO_H
