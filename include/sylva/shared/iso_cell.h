// sylva/shared/iso_cell.h -- the exact intersection of a ray with the isosurface rho = iso inside
// one trilinear cell (Wald et al., "Faster isosurface ray tracing using implicit kd-trees",
// section 4.2, which uses the root finding of Marmitt et al. 2004, "Fast and accurate ray-voxel
// intersection techniques for iso-surface ray tracing"). Part of the shared C++/GLSL subset
// (lang.h): the same text runs on the host and in a shader.
//
// Conventions. Everything is in cell-local coordinates: the cell is [0, 1]^3 and the caller maps
// its ray there (t is unchanged by that affine map; gradients come back per cell edge, so the
// caller scales them by 1 / spacing). The eight corner densities c_xyz, x, y, z in {0, 1}, are
// two vec4 (the order of sylva/shared/ikd_iter.h's corners_lo / corners_hi): corner index
// i = x + 2y + 4z is component (i & 3) of lo for i < 4 and of hi for i >= 4, i.e.
//   lo = (c000, c100, c010, c110)   the z = 0 face, components x, y, z, w
//   hi = (c001, c101, c011, c111)   the z = 1 face
// The density is the trilinear blend rho(p) = sum c_xyz wx wy wz with w0 = 1 - p, w1 = p per axis.
//
// Method (sylva_iso_cell_hit). Along the ray segment p(u) = o + (t0 + u (t1 - t0)) d, u in [0, 1],
// g(u) = rho(p(u)) - iso is a cubic, whose coefficients come from three nested linear blends of
// polynomials (Marmitt et al.). The corners are first shifted by iso and scaled by a power of two
// (exact) so that M = max |c_xyz - iso| lands in [1, 2); reparametrising by u keeps the
// coefficients O(1) for any ray length. The real roots of g' (a quadratic, solved with the
// cancellation-free formula; A = 0, B = 0 and all-zero cases are linear or constant) split [0, 1]
// into at most three monotone pieces, visited in order. In the first piece whose end values have
// opposite signs (or a zero at an end) the root is refined by safeguarded Newton (falling back to
// bisection when a step leaves the bracket or does not halve the previous one; at most
// SYLVA_ISO_ITERATIONS steps, stopping when the bracket cannot be split or the step vanishes),
// which converges to float precision.
//
// Tangent hits (the tolerance). A piece without a sign change still ends in a hit where g comes
// within SYLVA_ISO_TOUCH_REL * M of zero: at its end (an extremum of g, or t1), or, for the first
// piece, at t0. So g touching zero at an extremum (a double root) is reported there; a near miss
// is reported when |rho - iso| <= 4e-6 * max |c_xyz - iso|. M is between R / 2 and R (R the
// corner range max - min) whenever iso lies in [min, max], the only case with real crossings, so
// the tolerance is 4e-6 to 8e-6 of the corner range: about ten times the float rounding of g
// (a few 1e-7 M), and far below density differences that matter. Cells whose corners all equal
// iso (M = 0) report t0; constant cells different from iso never hit. A ray starting within the
// tolerance of the surface reports t0.
//
// Accuracy. A crossing where |dg/du| >= 1e-2 M (u = (t - t0) / (t1 - t0)) is found within
// 2e-5 * max(1, t1 - t0) of the exact root of the float inputs (measured: 1e-5); in general the
// error is about 2e-7 M / |dg/du|, so near-double roots are located less precisely.
#ifndef SYLVA_SHARED_ISO_CELL_H
#define SYLVA_SHARED_ISO_CELL_H

#include "sylva/shared/lang.h"

/// Tangent / near-miss tolerance on |rho - iso|, relative to max |c_xyz - iso| (see above).
#define SYLVA_ISO_TOUCH_REL 4.0e-6f
/// Cap on the safeguarded Newton / bisection steps per root.
#define SYLVA_ISO_ITERATIONS 48u

SYLVA_BEGIN_NAMESPACE

/// (1 - f) a + f b: exactly a at f = 0 and exactly b at f = 1.
SYLVA_FN float sylva_iso_blend(float a, float b, float f) { return (1.0f - f) * a + f * b; }

/// Trilinear density at cell-local point p (p outside [0, 1]^3 extrapolates the same polynomial).
SYLVA_FN float sylva_iso_cell_density(vec4 lo, vec4 hi, vec3 p) {
    float y0z0 = sylva_iso_blend(lo.x, lo.y, p.x);
    float y1z0 = sylva_iso_blend(lo.z, lo.w, p.x);
    float y0z1 = sylva_iso_blend(hi.x, hi.y, p.x);
    float y1z1 = sylva_iso_blend(hi.z, hi.w, p.x);
    return sylva_iso_blend(sylva_iso_blend(y0z0, y1z0, p.y), sylva_iso_blend(y0z1, y1z1, p.y), p.z);
}

/// Analytic gradient of the trilinear density at p, per unit of cell-local coordinate (world
/// gradient = this / spacing, component by component).
SYLVA_FN vec3 sylva_iso_cell_gradient(vec4 lo, vec4 hi, vec3 p) {
    float gx = sylva_iso_blend(sylva_iso_blend(lo.y - lo.x, lo.w - lo.z, p.y),
                               sylva_iso_blend(hi.y - hi.x, hi.w - hi.z, p.y), p.z);
    float gy = sylva_iso_blend(sylva_iso_blend(lo.z - lo.x, lo.w - lo.y, p.x),
                               sylva_iso_blend(hi.z - hi.x, hi.w - hi.y, p.x), p.z);
    float gz = sylva_iso_blend(sylva_iso_blend(hi.x - lo.x, hi.y - lo.y, p.x),
                               sylva_iso_blend(hi.z - lo.z, hi.w - lo.w, p.x), p.y);
    return vec3(gx, gy, gz);
}

/// Blend of two constants a, b at coordinate o + d t, as a polynomial in t: (t^0, t^1) coefficients.
SYLVA_FN vec2 sylva_iso_poly_lin(float a, float b, float o, float d) {
    return vec2(sylva_iso_blend(a, b, o), (b - a) * d);
}

/// Blend of two linear polynomials a, b at o + d t: (t^0, t^1, t^2) coefficients.
SYLVA_FN vec3 sylva_iso_poly_quad(vec2 a, vec2 b, float o, float d) {
    return vec3(sylva_iso_blend(a.x, b.x, o), sylva_iso_blend(a.y, b.y, o) + (b.x - a.x) * d, (b.y - a.y) * d);
}

/// Blend of two quadratics a, b at o + d t: (t^3, t^2, t^1, t^0) coefficients (highest first).
SYLVA_FN vec4 sylva_iso_poly_cubic(vec3 a, vec3 b, float o, float d) {
    return vec4((b.z - a.z) * d, sylva_iso_blend(a.z, b.z, o) + (b.y - a.y) * d,
                sylva_iso_blend(a.y, b.y, o) + (b.x - a.x) * d, sylva_iso_blend(a.x, b.x, o));
}

/// Coefficients (A, B, C, D) of rho(o + t d) = A t^3 + B t^2 + C t + D (Marmitt et al.): the
/// blends along x, then y, then z of the corner values, as polynomials in t.
SYLVA_FN vec4 sylva_iso_cell_cubic(vec4 lo, vec4 hi, vec3 o, vec3 d) {
    vec2 y0z0 = sylva_iso_poly_lin(lo.x, lo.y, o.x, d.x);
    vec2 y1z0 = sylva_iso_poly_lin(lo.z, lo.w, o.x, d.x);
    vec2 y0z1 = sylva_iso_poly_lin(hi.x, hi.y, o.x, d.x);
    vec2 y1z1 = sylva_iso_poly_lin(hi.z, hi.w, o.x, d.x);
    vec3 z0 = sylva_iso_poly_quad(y0z0, y1z0, o.y, d.y);
    vec3 z1 = sylva_iso_poly_quad(y0z1, y1z1, o.y, d.y);
    return sylva_iso_poly_cubic(z0, z1, o.z, d.z);
}

/// The cubic k = (A, B, C, D) at t (Horner).
SYLVA_FN float sylva_iso_cubic_eval(vec4 k, float t) { return ((k.x * t + k.y) * t + k.z) * t + k.w; }

/// Its derivative 3A t^2 + 2B t + C at t.
SYLVA_FN float sylva_iso_cubic_slope(vec4 k, float t) { return (3.0f * k.x * t + 2.0f * k.y) * t + k.z; }

/// Component i (0..3) of v.
SYLVA_FN float sylva_iso_pick(vec4 v, uint i) { return (i == 0u) ? v.x : ((i == 1u) ? v.y : ((i == 2u) ? v.z : v.w)); }

/// r when it lies strictly inside (0, 1), else 1 (an empty piece at the end).
SYLVA_FN float sylva_iso_inside(float r) { return (r > 0.0f && r < 1.0f) ? r : 1.0f; }

/// Real roots of the cubic's derivative 3A u^2 + 2B u + C strictly inside (0, 1), ascending;
/// missing roots are 1. Degenerate cases: A = 0 is linear, A = B = 0 has no root.
SYLVA_FN vec2 sylva_iso_turning_points(vec4 k) {
    float a = 3.0f * k.x;  // a u^2 + 2 b u + c
    float b = k.y;
    float c = k.z;
    float r0 = 1.0f;
    float r1 = 1.0f;
    if (a == 0.0f) {
        if (b != 0.0f) r0 = -c / (2.0f * b);
    } else {
        float disc = b * b - a * c;
        if (disc >= 0.0f) {
            float sq = sqrt(disc);
            float q = (b < 0.0f) ? sq - b : -(b + sq);  // -(b + sign(b) sqrt(disc)), no cancellation
            if (q != 0.0f) {  // q = 0 only for a double root at u = 0
                r0 = q / a;
                r1 = c / q;
            }
        }
    }
    r0 = sylva_iso_inside(r0);
    r1 = sylva_iso_inside(r1);
    return vec2(sylva_min(r0, r1), sylva_max(r0, r1));
}

/// Root of the cubic k on [a, b], where ga = k(a) and gb = k(b) have opposite signs or one is 0
/// and k is monotone: safeguarded Newton, bisection when a step leaves the bracket or is slow.
SYLVA_FN float sylva_iso_refine(vec4 k, float a, float b, float ga, float gb) {
    if (ga == 0.0f) return a;
    if (gb == 0.0f) return b;
    float u = a - ga * ((b - a) / (gb - ga));  // regula falsi start
    if (!(u > a && u < b)) u = 0.5f * (a + b);
    float step_old = b - a;
    for (uint i = 0u; i < SYLVA_ISO_ITERATIONS; i++) {
        float gu = sylva_iso_cubic_eval(k, u);
        if (gu == 0.0f) return u;
        if ((gu < 0.0f) == (ga < 0.0f)) {
            a = u;
            ga = gu;
        } else {
            b = u;
            gb = gu;
        }
        float mid = 0.5f * (a + b);
        if (!(mid > a && mid < b)) break;  // the bracket is two adjacent floats
        float du = sylva_iso_cubic_slope(k, u);
        float next = mid;
        if (du != 0.0f && abs(2.0f * gu) <= abs(step_old * du)) {
            float newton = u - gu / du;
            if (newton > a && newton < b) next = newton;
        }
        if (next == u) break;
        step_old = abs(next - u);
        u = next;
    }
    return (abs(ga) <= abs(gb)) ? a : b;
}

/// First u in [0, 1] where the cubic k is zero, or within tol of zero at a piece end (see the
/// header comment); false when there is none.
SYLVA_FN bool sylva_iso_first_zero(vec4 k, float tol, SYLVA_OUT(float) u) {
    vec2 r = sylva_iso_turning_points(k);
    vec4 bounds = vec4(0.0f, r.x, r.y, 1.0f);
    u = 1.0f;
    for (uint i = 0u; i < 3u; i++) {
        float a = sylva_iso_pick(bounds, i);
        float b = sylva_iso_pick(bounds, i + 1u);
        float ga = sylva_iso_cubic_eval(k, a);
        float gb = sylva_iso_cubic_eval(k, b);
        if ((ga <= 0.0f && gb >= 0.0f) || (ga >= 0.0f && gb <= 0.0f)) {
            u = sylva_iso_refine(k, a, b, ga, gb);
            return true;
        }
        if (i == 0u && abs(ga) <= tol) {
            u = a;
            return true;
        }
        if (abs(gb) <= tol) {
            u = b;
            return true;
        }
    }
    return false;
}

/// The largest |component| of two vectors.
SYLVA_FN float sylva_iso_max_abs(vec4 a, vec4 b) {
    float m = sylva_max(sylva_max(abs(a.x), abs(a.y)), sylva_max(abs(a.z), abs(a.w)));
    return sylva_max(m, sylva_max(sylva_max(abs(b.x), abs(b.y)), sylva_max(abs(b.z), abs(b.w))));
}

/// The power of two s with m * s in [1, 2) for finite m > 0 (clamped at the exponent range's
/// ends); scaling by it is exact.
SYLVA_FN float sylva_iso_pow2_scale(float m) {
    uint e = (floatBitsToUint(m) >> 23u) & 0xFFu;
    if (e > 253u) e = 253u;
    return uintBitsToFloat((254u - e) << 23u);
}

/// d * len, exactly 0 where d is 0 (whatever len).
SYLVA_FN float sylva_iso_span(float d, float len) { return (d == 0.0f) ? 0.0f : d * len; }

/// First hit of the ray o + t d (cell-local) with the isosurface rho = iso for t in [t0, t1]
/// (t0 <= t1, normally the ray's interval inside the cell): true and t_hit = the smallest such t,
/// or the first tangent / near-miss point within SYLVA_ISO_TOUCH_REL (see the header comment).
/// false (t_hit = t1) when there is none, or when !(t0 <= t1).
SYLVA_FN bool sylva_iso_cell_hit(vec4 lo, vec4 hi, vec3 o, vec3 d, float t0, float t1, float iso,
                                 SYLVA_OUT(float) t_hit) {
    t_hit = t1;
    if (!(t0 <= t1)) return false;
    vec4 sl = lo - vec4(iso);
    vec4 sh = hi - vec4(iso);
    float m = sylva_iso_max_abs(sl, sh);
    if (m == 0.0f) {  // every corner equals iso: the whole cell is on the surface
        t_hit = t0;
        return true;
    }
    float s = sylva_iso_pow2_scale(m);
    float len = t1 - t0;
    vec3 p0 = vec3(o.x + t0 * d.x, o.y + t0 * d.y, o.z + t0 * d.z);
    vec3 seg = vec3(sylva_iso_span(d.x, len), sylva_iso_span(d.y, len), sylva_iso_span(d.z, len));
    vec4 k = sylva_iso_cell_cubic(sl * s, sh * s, p0, seg);
    float u;
    if (!sylva_iso_first_zero(k, SYLVA_ISO_TOUCH_REL * (m * s), u)) return false;
    t_hit = (u >= 1.0f) ? t1 : sylva_min(t0 + u * len, t1);
    return true;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ISO_CELL_H
