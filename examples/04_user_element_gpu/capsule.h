// capsule.h -- a user's element written once in sylva's shared C++/GLSL subset: a capsule
// (segment a-b, radius r) of constant extinction and colour. Included by C++ (namespace demo;
// demo::Capsule satisfies sylva::Bounded, Intersectable and RayInteraction) and by the GLSL
// shader capsule.comp. The protocol is sylva/shared/element.h; the rules of the subset are in
// sylva/shared/lang.h and docs/DESIGN.md.
//
// Record (12 words): 0-2 a, 3-5 b, 6 radius, 7 extinction (per unit length), 8-10 RGB, 11 zero.
#ifndef DEMO_CAPSULE_H
#define DEMO_CAPSULE_H

#include "sylva/shared/element.h"

SYLVA_USER_BEGIN_NAMESPACE(demo)

struct Capsule {
    vec3 a SYLVA_DEFAULT(vec3(0.0f));
    vec3 b SYLVA_DEFAULT(vec3(0.0f));
    float radius SYLVA_DEFAULT(1.0f);
    float extinction SYLVA_DEFAULT(1.0f);
    vec3 rgb SYLVA_DEFAULT(vec3(1.0f));
};

SYLVA_FN uint sylva_elem_words(Capsule x) {
    SYLVA_UNUSED(x);
    return 12u;
}

SYLVA_FN void sylva_elem_load(SYLVA_BUF(elems), uint e, SYLVA_OUT(Capsule) x) {
    uint at = e * 12u;
    x.a = sylva_rec_vec3(SYLVA_PASS_BUF(elems), at);
    x.b = sylva_rec_vec3(SYLVA_PASS_BUF(elems), at + 3u);
    x.radius = sylva_rec_f(SYLVA_PASS_BUF(elems), at + 6u);
    x.extinction = sylva_rec_f(SYLVA_PASS_BUF(elems), at + 7u);
    x.rgb = sylva_rec_vec3(SYLVA_PASS_BUF(elems), at + 8u);
}

SYLVA_FN void sylva_elem_bounds(Capsule x, SYLVA_OUT(vec3) lo, SYLVA_OUT(vec3) hi) {
    float r = x.radius;
    lo = vec3(sylva_min(x.a.x, x.b.x) - r, sylva_min(x.a.y, x.b.y) - r, sylva_min(x.a.z, x.b.z) - r);
    hi = vec3(sylva_max(x.a.x, x.b.x) + r, sylva_max(x.a.y, x.b.y) + r, sylva_max(x.a.z, x.b.z) + r);
}

/// The interval of o + t d inside the ball of centre p and radius r (empty: x > y).
SYLVA_FN vec2 demo_ball(vec3 p, float r, vec3 o, vec3 d) {
    vec3 op = vec3(o.x - p.x, o.y - p.y, o.z - p.z);
    float qa = dot(d, d);
    float qb = dot(op, d);
    float qc = dot(op, op) - r * r;
    float disc = qb * qb - qa * qc;
    if (!(disc >= 0.0f) || !(qa > 0.0f)) return sylva_no_interval();
    float s = sqrt(disc);
    return vec2((-qb - s) / qa, (-qb + s) / qa);
}

/// The interval inside the cylinder of radius r around segment a-b, between its end planes.
SYLVA_FN vec2 demo_tube(vec3 a, vec3 b, float r, vec3 o, vec3 d) {
    vec3 ba = vec3(b.x - a.x, b.y - a.y, b.z - a.z);
    vec3 oa = vec3(o.x - a.x, o.y - a.y, o.z - a.z);
    float len2 = dot(ba, ba);
    if (!(len2 > 0.0f)) return sylva_no_interval();
    float kd = dot(d, ba) / len2;
    float ko = dot(oa, ba) / len2;
    vec3 dp = vec3(d.x - kd * ba.x, d.y - kd * ba.y, d.z - kd * ba.z);
    vec3 op = vec3(oa.x - ko * ba.x, oa.y - ko * ba.y, oa.z - ko * ba.z);
    float qa = dot(dp, dp);
    float qb = dot(op, dp);
    float qc = dot(op, op) - r * r;
    vec2 t = vec2(-sylva_inf(), sylva_inf());
    if (qa > 0.0f) {
        float disc = qb * qb - qa * qc;
        if (!(disc >= 0.0f)) return sylva_no_interval();
        float s = sqrt(disc);
        t = vec2((-qb - s) / qa, (-qb + s) / qa);
    } else if (!(qc <= 0.0f)) {
        return sylva_no_interval();  // parallel to the axis, outside the radius
    }
    // End planes: 0 <= ko + t kd <= 1 along the axis.
    if (kd != 0.0f) {
        float ta = (0.0f - ko) / kd;
        float tb = (1.0f - ko) / kd;
        t = vec2(sylva_max(t.x, sylva_min(ta, tb)), sylva_min(t.y, sylva_max(ta, tb)));
    } else if (!(ko >= 0.0f && ko <= 1.0f)) {
        return sylva_no_interval();
    }
    return t;
}

/// The capsule is convex: its interval is the hull of the tube's and the two balls' intervals.
SYLVA_FN vec2 sylva_elem_interval(Capsule x, vec3 o, vec3 d, float t0, float t1) {
    vec2 pa = demo_ball(x.a, x.radius, o, d);
    vec2 pb = demo_ball(x.b, x.radius, o, d);
    vec2 pt = demo_tube(x.a, x.b, x.radius, o, d);
    float lo = sylva_inf();
    float hi = -sylva_inf();
    if (pa.x <= pa.y) { lo = sylva_min(lo, pa.x); hi = sylva_max(hi, pa.y); }
    if (pb.x <= pb.y) { lo = sylva_min(lo, pb.x); hi = sylva_max(hi, pb.y); }
    if (pt.x <= pt.y) { lo = sylva_min(lo, pt.x); hi = sylva_max(hi, pt.y); }
    lo = sylva_max(lo, t0);
    hi = sylva_min(hi, t1);
    return (lo <= hi) ? vec2(lo, hi) : sylva_no_interval();
}

/// Constant extinction over [t0, t1]: optical depth extinction * length of the path.
SYLVA_FN vec4 sylva_elem_medium(Capsule x, vec3 o, vec3 d, float t0, float t1) {
    SYLVA_UNUSED(o);
    float path = (t1 - t0) * sqrt(dot(d, d));
    return vec4(x.rgb.x, x.rgb.y, x.rgb.z, x.extinction * sylva_max(path, 0.0f));
}

#ifdef __cplusplus
/// C++ only: the record sylva_elem_load reads.
inline void sylva_elem_store(const Capsule& x, ::sylva::shared::RecordOut out) {
    out.v3(0u, x.a);
    out.v3(3u, x.b);
    out.f(6u, x.radius);
    out.f(7u, x.extinction);
    out.v3(8u, x.rgb);
}
#endif

SYLVA_USER_END_NAMESPACE

#endif  // DEMO_CAPSULE_H
