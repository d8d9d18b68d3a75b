// capsule.h -- a user's element written once in sylva's shared C++/GLSL subset through the
// element protocol (sylva/shared/element.h; the subset's rules are in sylva/shared/lang.h and
// docs/DESIGN.md): a capsule (segment a-b, radius r) of constant extinction and colour. The same
// text is the C++ type consumer::Capsule (sylva's concepts find the protocol by ADL) and the GLSL
// struct Capsule that capsule.comp (the generic element kernel) and capsule_first_hit.comp (a
// hand-written kernel) compile against the installed headers.
//
// The interval is exact up to rounding: the capsule is convex and is the union of the finite
// cylinder around a-b and the balls at a and b, so the ray's interval in it is the hull of the
// parts' intervals. Only + - * / sqrt: hit sequences are equal bit for bit on host and lavapipe.
// Each part uses the closest-approach form (distance at the nearest point, then the half chord),
// not the textbook discriminant b^2 - a c, which cancels on grazing rays and can report hits
// outside bounds() (the conformance kit finds those: see sylva/testing/conformance.hpp).
//
// Record (12 words): 0-2 a, 3-5 b, 6 radius, 7 extinction per unit length, 8-10 RGB, 11 zero.
#ifndef CONSUMER_CAPSULE_H
#define CONSUMER_CAPSULE_H

#include "sylva/shared/element.h"

SYLVA_USER_BEGIN_NAMESPACE(consumer)

struct Capsule {
    vec3 a SYLVA_DEFAULT(vec3(0.0f));
    vec3 b SYLVA_DEFAULT(vec3(0.0f));
    float radius SYLVA_DEFAULT(0.1f);
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

/// The chord of a ray whose closest approach to a centre (or axis) is at tc, squared distance
/// dist2 there, against radius r; qa is the squared length of the direction (its part across
/// the axis for the cylinder). Empty when it passes outside.
SYLVA_FN vec2 consumer_chord(float tc, float dist2, float r, float qa) {
    float rr = r * r;
    if (!(dist2 <= rr) || !(qa > 0.0f)) return sylva_no_interval();
    float w = sqrt((rr - dist2) / qa);
    return vec2(tc - w, tc + w);
}

/// The interval of o + t d inside the ball of centre p and radius r.
SYLVA_FN vec2 consumer_ball(vec3 p, float r, vec3 o, vec3 d) {
    vec3 op = vec3(p.x - o.x, p.y - o.y, p.z - o.z);
    float qa = dot(d, d);
    if (!(qa > 0.0f)) return sylva_no_interval();
    float tc = dot(op, d) / qa;
    vec3 q = vec3(o.x + tc * d.x - p.x, o.y + tc * d.y - p.y, o.z + tc * d.z - p.z);
    return consumer_chord(tc, dot(q, q), r, qa);
}

/// The interval inside the cylinder of radius r around segment a-b, between its end planes.
SYLVA_FN vec2 consumer_tube(vec3 a, vec3 b, float r, vec3 o, vec3 d) {
    vec3 ba = vec3(b.x - a.x, b.y - a.y, b.z - a.z);
    vec3 oa = vec3(o.x - a.x, o.y - a.y, o.z - a.z);
    float len2 = dot(ba, ba);
    if (!(len2 > 0.0f)) return sylva_no_interval();
    float kd = dot(d, ba) / len2;
    float ko = dot(oa, ba) / len2;
    // Across the axis: the ray's offset op + t dp from the axis.
    vec3 dp = vec3(d.x - kd * ba.x, d.y - kd * ba.y, d.z - kd * ba.z);
    vec3 op = vec3(oa.x - ko * ba.x, oa.y - ko * ba.y, oa.z - ko * ba.z);
    float qa = dot(dp, dp);
    vec2 t = vec2(-sylva_inf(), sylva_inf());
    if (qa > 0.0f) {
        float tc = -dot(op, dp) / qa;
        vec3 q = vec3(op.x + tc * dp.x, op.y + tc * dp.y, op.z + tc * dp.z);
        t = consumer_chord(tc, dot(q, q), r, qa);
        if (!(t.x <= t.y)) return t;
    } else if (!(dot(op, op) <= r * r)) {
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

/// The hull of the tube's and the two balls' intervals, clipped to [t0, t1].
SYLVA_FN vec2 sylva_elem_interval(Capsule x, vec3 o, vec3 d, float t0, float t1) {
    vec2 pa = consumer_ball(x.a, x.radius, o, d);
    vec2 pb = consumer_ball(x.b, x.radius, o, d);
    vec2 pt = consumer_tube(x.a, x.b, x.radius, o, d);
    float lo = sylva_inf();
    float hi = -sylva_inf();
    if (pa.x <= pa.y) {
        lo = sylva_min(lo, pa.x);
        hi = sylva_max(hi, pa.y);
    }
    if (pb.x <= pb.y) {
        lo = sylva_min(lo, pb.x);
        hi = sylva_max(hi, pb.y);
    }
    if (pt.x <= pt.y) {
        lo = sylva_min(lo, pt.x);
        hi = sylva_max(hi, pt.y);
    }
    lo = sylva_max(lo, t0);
    hi = sylva_min(hi, t1);
    return (lo <= hi) ? vec2(lo, hi) : sylva_no_interval();
}

/// Constant extinction over [t0, t1]: optical depth extinction * path length, colour rgb.
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

#endif  // CONSUMER_CAPSULE_H
