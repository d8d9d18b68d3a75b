// sylva/shared/ray_box.h -- the ray/box slab test the kd-tree iterators share (kd_iter.h over
// encoded boxes, ikd_iter.h over the implicit tree's computed boxes), and the axis pickers and
// finiteness tests they use. Part of the shared C++/GLSL subset (lang.h).
//
// A ray is given in the box's own space by its origin, the reciprocal of its direction
// (sylva_safe_rcp: +-inf for a +-0 component) and a mask of the axes it is parallel to (those
// whose reciprocal is not finite). Boxes are closed: a ray touching a face visits the box.
#ifndef SYLVA_SHARED_RAY_BOX_H
#define SYLVA_SHARED_RAY_BOX_H

#include "sylva/shared/lang.h"

SYLVA_BEGIN_NAMESPACE

/// Component `axis` (0 = x, 1 = y, 2 = z) of v.
SYLVA_FN float sylva_kd_pick(vec3 v, uint axis) { return (axis == 0u) ? v.x : ((axis == 1u) ? v.y : v.z); }
/// Component `axis` of an unsigned vector.
SYLVA_FN uint sylva_kd_pick_u(uvec3 v, uint axis) { return (axis == 0u) ? v.x : ((axis == 1u) ? v.y : v.z); }

/// True when x is +-inf or NaN (bit tests, identical on every target).
SYLVA_FN bool sylva_kd_not_finite(float x) { return (floatBitsToUint(x) & 0x7FFFFFFFu) >= 0x7F800000u; }
/// True when x is NaN.
SYLVA_FN bool sylva_kd_nan(float x) { return (floatBitsToUint(x) & 0x7FFFFFFFu) > 0x7F800000u; }

/// Ray interval inside the closed voxel-space box [lo, hi] (float corners), intersected with
/// [t0, t1]; empty (x > y) when the ray misses it. `par` marks axes the ray is parallel to.
SYLVA_FN vec2 sylva_kd_box_interval_f(vec3 org, vec3 rcp, uvec3 par, vec3 lo, vec3 hi, float t0, float t1) {
    float a = t0;
    float b = t1;
    for (uint k = 0u; k < 3u; k++) {
        float l = sylva_kd_pick(lo, k);
        float h = sylva_kd_pick(hi, k);
        float o = sylva_kd_pick(org, k);
        if (sylva_kd_pick_u(par, k) != 0u) {
            if (o < l || o > h) {
                a = sylva_inf();
                b = -sylva_inf();
            }
        } else {
            float r = sylva_kd_pick(rcp, k);
            float ta = sylva_canon((l - o) * r);
            float tb = sylva_canon((h - o) * r);
            a = sylva_max(a, sylva_min(ta, tb));
            b = sylva_min(b, sylva_max(ta, tb));
        }
    }
    return vec2(a, b);
}

/// Maps the world ray origin + t * direction into a grid's space, where world point p is
/// (p - grid_origin) * inv_spacing (t is unchanged): the mapped origin, the safe reciprocal of
/// the mapped direction and the axes the ray is parallel to. Returns true when the origin, the
/// direction or the range [t_min, t_max] holds a NaN (such a ray visits nothing).
SYLVA_FN bool sylva_ray_to_grid(vec3 origin, vec3 direction, vec3 grid_origin, vec3 inv_spacing, float t_min, float t_max,
                                SYLVA_OUT(vec3) org, SYLVA_OUT(vec3) rcp, SYLVA_OUT(uvec3) par) {
    vec3 s = inv_spacing;
    org = vec3((origin.x - grid_origin.x) * s.x, (origin.y - grid_origin.y) * s.y, (origin.z - grid_origin.z) * s.z);
    vec3 d = vec3(direction.x * s.x, direction.y * s.y, direction.z * s.z);
    rcp = vec3(sylva_safe_rcp(d.x), sylva_safe_rcp(d.y), sylva_safe_rcp(d.z));
    par = uvec3(sylva_kd_not_finite(rcp.x) ? 1u : 0u, sylva_kd_not_finite(rcp.y) ? 1u : 0u,
                sylva_kd_not_finite(rcp.z) ? 1u : 0u);
    return sylva_kd_nan(org.x) || sylva_kd_nan(org.y) || sylva_kd_nan(org.z) || sylva_kd_nan(d.x) || sylva_kd_nan(d.y) ||
           sylva_kd_nan(d.z) || sylva_kd_nan(t_min) || sylva_kd_nan(t_max);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_RAY_BOX_H
