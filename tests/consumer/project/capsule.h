// capsule.h -- a user's element written once in sylva's shared C++/GLSL subset (the rules are in
// sylva/shared/lang.h and docs/DESIGN.md): a capsule (segment a-b, radius r) of constant
// extinction. The same text compiles as C++ (capsule.hpp wraps it in a type the library's
// concepts accept) and as GLSL (capsule_first_hit.comp includes it).
//
// The ray's interval in the capsule is exact up to rounding: the capsule is convex and is the
// union of the finite cylinder around a-b and the balls at a and b, so the ray's interval in it
// is [min entry, max exit] over the parts the ray meets. Only +, -, *, / and sqrt are used.
#ifndef CONSUMER_CAPSULE_H
#define CONSUMER_CAPSULE_H

#include "sylva/shared/lang.h"

#ifdef __cplusplus
namespace consumer {
using namespace sylva::shared;
#endif

/// Words per capsule record in the element buffer: a.xyz, r, b.xyz, extinction (float bits).
#define CAPSULE_WORDS 8u

/// Grows [lo, hi] (x = lo, y = hi; empty when x > y) by [t0, t1].
SYLVA_FN vec2 capsule_union(vec2 acc, float t0, float t1) {
    return vec2(acc.x < t0 ? acc.x : t0, acc.y > t1 ? acc.y : t1);
}

/// The ray's interval inside the ball (p, r), added to acc.
SYLVA_FN vec2 capsule_ball(vec2 acc, vec3 p, float r, vec3 o, vec3 d) {
    vec3 op = vec3(o.x - p.x, o.y - p.y, o.z - p.z);
    float dd = dot(d, d);
    float b = dot(op, d);
    float c = dot(op, op) - r * r;
    float disc = b * b - dd * c;
    if (!(disc >= 0.0f) || !(dd > 0.0f)) return acc;
    float s = sqrt(disc);
    return capsule_union(acc, (-b - s) / dd, (-b + s) / dd);
}

/// The ray's interval inside the finite cylinder around a-b (radius r), added to acc.
SYLVA_FN vec2 capsule_cylinder(vec2 acc, vec3 a, vec3 b, float r, vec3 o, vec3 d) {
    vec3 ba = vec3(b.x - a.x, b.y - a.y, b.z - a.z);
    float baba = dot(ba, ba);
    if (!(baba > 0.0f)) return acc;
    vec3 oa = vec3(o.x - a.x, o.y - a.y, o.z - a.z);
    float dpar = dot(d, ba) / baba;
    float opar = dot(oa, ba) / baba;
    // The slab 0 <= opar + t dpar <= 1 between the end caps.
    float s0 = -3.0e38f;
    float s1 = 3.0e38f;
    if (dpar != 0.0f) {
        float u = (0.0f - opar) / dpar;
        float v = (1.0f - opar) / dpar;
        s0 = u < v ? u : v;
        s1 = u < v ? v : u;
    } else if (opar < 0.0f || opar > 1.0f) {
        return acc;
    }
    // The infinite cylinder: |(o + t d) - a - ((o + t d - a).ba / baba) ba|^2 <= r^2.
    vec3 dp = vec3(d.x - ba.x * dpar, d.y - ba.y * dpar, d.z - ba.z * dpar);
    vec3 op = vec3(oa.x - ba.x * opar, oa.y - ba.y * opar, oa.z - ba.z * opar);
    float qa = dot(dp, dp);
    float qb = dot(op, dp);
    float qc = dot(op, op) - r * r;
    float c0 = -3.0e38f;
    float c1 = 3.0e38f;
    if (qa > 0.0f) {
        float disc = qb * qb - qa * qc;
        if (!(disc >= 0.0f)) return acc;
        float s = sqrt(disc);
        c0 = (-qb - s) / qa;
        c1 = (-qb + s) / qa;
    } else if (qc > 0.0f) {
        return acc;  // parallel to the axis, outside the radius
    }
    float t0 = s0 > c0 ? s0 : c0;
    float t1 = s1 < c1 ? s1 : c1;
    if (t0 > t1) return acc;
    return capsule_union(acc, t0, t1);
}

/// The ray's interval [x, y] inside the capsule within [t_min, t_max]; x > y when it misses.
SYLVA_FN vec2 capsule_interval(vec3 a, vec3 b, float r, vec3 o, vec3 d, float t_min, float t_max) {
    vec2 acc = vec2(3.0e38f, -3.0e38f);
    if (!(r > 0.0f)) return acc;
    acc = capsule_ball(acc, a, r, o, d);
    acc = capsule_ball(acc, b, r, o, d);
    acc = capsule_cylinder(acc, a, b, r, o, d);
    float t0 = acc.x > t_min ? acc.x : t_min;
    float t1 = acc.y < t_max ? acc.y : t_max;
    return vec2(t0, t1);
}

#ifdef __cplusplus
}  // namespace consumer
#endif

#endif  // CONSUMER_CAPSULE_H
