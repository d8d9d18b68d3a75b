// sylva/shared/particles.h -- semi-transparent particles (Kinkelin section 4.2, after Kaehler
// et al. 2007): weight, packed record, and a front-to-back compositing integrator over a BIH.
//
// A particle is a sphere (centre c, radius r, straight RGBA colour, falloff kappa). A ray whose
// closest approach to c is d <= r at parameter t_c receives alpha * exp(-kappa (d/r)^2) there;
// a Gaussian RBF of width sigma truncated at k sigma is the sphere r = k sigma,
// kappa = k^2 / 2. Contributions are composited front to back in the order the iterator yields
// leaves (within a leaf, sorted by t_c for up to SYLVA_LEAF_SORT elements) and the ray stops
// once its opacity reaches `alpha_stop` (early ray termination).
//
// Payloads (bih_layout.h header bits 8-15):
//  SYLVA_PAYLOAD_RANGE: leaf = (first, count) into a buffer `elems` of 8-word records:
//    word 0-2 centre (float bits), 3 radius, 4 kappa, 5 RGBA8 (R bits 0-7 ... A bits 24-31),
//    6-7 zero.
//  SYLVA_PAYLOAD_PARTICLE_RGBA: the leaf box is the particle's box (trimmed leaves) and the
//    payload holds bits 0-31 RGBA8, bits 32-61 kappa's float bits 2-31 (its two lowest
//    mantissa bits dropped).
#ifndef SYLVA_SHARED_PARTICLES_H
#define SYLVA_SHARED_PARTICLES_H

#include "sylva/shared/bih_iter.h"

#define SYLVA_PARTICLE_WORDS 8u
#define SYLVA_LEAF_SORT 8u
/// Most records a range payload may address: record e's last word, e * 8 + 7, must fit 32 bits
/// (GLSL has no 64-bit integers by default). Leaves reaching past it end the ray with an error.
#define SYLVA_PARTICLE_MAX_RECORDS 0x20000000u

SYLVA_BEGIN_NAMESPACE

SYLVA_FN vec4 sylva_unpack_rgba8(uint c) {
    return vec4(float(c & 255u), float((c >> 8u) & 255u), float((c >> 16u) & 255u), float(c >> 24u)) *
           (1.0f / 255.0f);
}

/// Weight exp(-kappa q) of a particle at normalised squared distance q = (d/r)^2; 0 past r.
SYLVA_FN float sylva_radial_weight(float q, float kappa) { return (q <= 1.0f) ? exp(-kappa * q) : 0.0f; }

/// Closest approach of the ray to a particle: (t_c, (d/r)^2); q > 1 means the ray misses.
SYLVA_FN vec2 sylva_particle_approach(vec3 c, float r, vec3 o, vec3 d) {
    float dd = dot(d, d);
    if (!(r > 0.0f) || !(dd > 0.0f)) return vec2(0.0f, 2.0f);
    vec3 oc = vec3(c.x - o.x, c.y - o.y, c.z - o.z);
    float tc = dot(oc, d) / dd;
    vec3 p = vec3(o.x + tc * d.x - c.x, o.y + tc * d.y - c.y, o.z + tc * d.z - c.z);
    return vec2(tc, dot(p, p) / (r * r));
}

/// Front-to-back compositing state: premultiplied colour and opacity.
struct SylvaComposite {
    vec3 rgb;
    float alpha;
};

SYLVA_FN void sylva_composite_add(SYLVA_INOUT(SylvaComposite) acc, vec4 rgba, float weight) {
    float a = clamp(rgba.w * weight, 0.0f, 1.0f);
    float k = (1.0f - acc.alpha) * a;
    acc.rgb = vec3(acc.rgb.x + k * rgba.x, acc.rgb.y + k * rgba.y, acc.rgb.z + k * rgba.z);
    acc.alpha = acc.alpha + k;
}

/// Adds one particle if the ray passes within its radius inside [t0, t1].
SYLVA_FN void sylva_particle_add(SYLVA_INOUT(SylvaComposite) acc, vec3 c, float r, float kappa, uint rgba8,
                                 vec3 o, vec3 d, float t0, float t1) {
    vec2 a = sylva_particle_approach(c, r, o, d);
    if (a.y <= 1.0f && a.x >= t0 && a.x <= t1) {
        sylva_composite_add(acc, sylva_unpack_rgba8(rgba8), sylva_radial_weight(a.y, kappa));
    }
}

SYLVA_FN vec3 sylva_elem_center(SYLVA_BUF(elems), uint e) {
    uint at = e * SYLVA_PARTICLE_WORDS;  // not sylva_load_vec3: that one reads `words` (lang.h)
    return vec3(uintBitsToFloat(SYLVA_LOAD(elems, at)), uintBitsToFloat(SYLVA_LOAD(elems, at + 1u)),
                uintBitsToFloat(SYLVA_LOAD(elems, at + 2u)));
}

SYLVA_FN float sylva_elem_tc(SYLVA_BUF(elems), uint e, vec3 o, vec3 d) {
    vec3 c = sylva_elem_center(SYLVA_PASS_BUF(elems), e);
    float r = uintBitsToFloat(SYLVA_LOAD(elems, e * SYLVA_PARTICLE_WORDS + 3u));
    return sylva_particle_approach(c, r, o, d).x;
}

SYLVA_FN void sylva_elem_add(SYLVA_INOUT(SylvaComposite) acc, SYLVA_BUF(elems), uint e, vec3 o, vec3 d,
                             float t0, float t1) {
    uint at = e * SYLVA_PARTICLE_WORDS;
    vec3 c = sylva_elem_center(SYLVA_PASS_BUF(elems), e);
    float r = uintBitsToFloat(SYLVA_LOAD(elems, at + 3u));
    float kappa = uintBitsToFloat(SYLVA_LOAD(elems, at + 4u));
    sylva_particle_add(acc, c, r, kappa, SYLVA_LOAD(elems, at + 5u), o, d, t0, t1);
}

/// True when a range leaf's records [first, first + count) all lie below
/// SYLVA_PARTICLE_MAX_RECORDS, so `e * SYLVA_PARTICLE_WORDS` cannot wrap (checked before any
/// multiplication; reads past the record buffer itself are caught by the load).
SYLVA_FN bool sylva_range_addressable(uint first, uint count) {
    return first < SYLVA_PARTICLE_MAX_RECORDS && count <= SYLVA_PARTICLE_MAX_RECORDS - first;
}

/// Composites the elements [first, first + count) of a range leaf, nearest t_c first when the
/// leaf holds at most SYLVA_LEAF_SORT of them (selection by (t_c, index)), in storage order
/// otherwise. Callers check sylva_range_addressable(first, count) first.
SYLVA_FN void sylva_range_leaf(SYLVA_INOUT(SylvaComposite) acc, SYLVA_BUF(elems), uint first, uint count, vec3 o,
                               vec3 d, float t0, float t1) {
    if (count > SYLVA_LEAF_SORT) {
        for (uint k = 0u; k < count; k++) sylva_elem_add(acc, SYLVA_PASS_BUF(elems), first + k, o, d, t0, t1);
        return;
    }
    float last_t = -sylva_inf();
    uint last_k = 0xFFFFFFFFu;
    for (uint n = 0u; n < count; n++) {
        uint best_k = 0xFFFFFFFFu;
        float best_t = sylva_inf();
        for (uint k = 0u; k < count; k++) {
            float t = sylva_elem_tc(SYLVA_PASS_BUF(elems), first + k, o, d);
            bool after_last = (t > last_t) || (t == last_t && (last_k == 0xFFFFFFFFu || k > last_k));
            bool better = (best_k == 0xFFFFFFFFu) || t < best_t || (t == best_t && k < best_k);
            if (after_last && better) {
                best_t = t;
                best_k = k;
            }
        }
        if (best_k == 0xFFFFFFFFu) break;  // NaN t_c: nothing more to order
        sylva_elem_add(acc, SYLVA_PASS_BUF(elems), first + best_k, o, d, t0, t1);
        last_t = best_t;
        last_k = best_k;
    }
}

/// Composites an inline particle leaf: the leaf box (world space) is the particle's box.
SYLVA_FN void sylva_inline_leaf(SYLVA_INOUT(SylvaComposite) acc, uvec2 payload, vec3 lo, vec3 hi, vec3 o, vec3 d,
                                float t0, float t1) {
    vec3 c = vec3(0.5f * lo.x + 0.5f * hi.x, 0.5f * lo.y + 0.5f * hi.y, 0.5f * lo.z + 0.5f * hi.z);
    float r = ((hi.x - lo.x) + (hi.y - lo.y) + (hi.z - lo.z)) * (1.0f / 6.0f);
    float kappa = uintBitsToFloat(payload.y << 2u);
    sylva_particle_add(acc, c, r, kappa, payload.x, o, d, t0, t1);
}

#if SYLVA_BIH_BOXES  // inline leaves read the leaf's box: not in shaders that define SYLVA_BIH_NO_BOXES
/// Renders one ray through a particle BIH; returns premultiplied RGB and opacity. `steps`
/// receives the number of nodes visited (the heat map), `status` the iterator's final status.
/// Encodings whose payload kind is neither SYLVA_PAYLOAD_RANGE nor SYLVA_PAYLOAD_PARTICLE_RGBA
/// (a LoD or voxel BIH, a user kind), and range leaves past SYLVA_PARTICLE_MAX_RECORDS, end
/// with status SYLVA_ITER_ERROR; a wrong kind draws nothing.
SYLVA_FN vec4 sylva_render_particles(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), vec3 o, vec3 d,
                                     float t_min, float t_max, float alpha_stop, SYLVA_OUT(uint) steps,
                                     SYLVA_OUT(uint) status) {
    SylvaBihIter it;
    sylva_bih_init(it, SYLVA_PASS_BUF(words), word_count, o, d, t_min, t_max);
    uint kind = (it.hdr.flags >> 8u) & 255u;
    bool inline_leaves = kind == SYLVA_PAYLOAD_PARTICLE_RGBA;
    if (it.status != SYLVA_ITER_ERROR && !inline_leaves && kind != SYLVA_PAYLOAD_RANGE) {
        it.status = SYLVA_ITER_ERROR;  // not a particle encoding: its payloads are no record ranges
    }
    SylvaComposite acc;
    acc.rgb = vec3(0.0f);
    acc.alpha = 0.0f;
    uint leaf;
    float t0;
    float t1;
    while (acc.alpha < alpha_stop && sylva_bih_next(it, SYLVA_PASS_BUF(words), leaf, t0, t1)) {
        uvec2 p = sylva_bih_payload(SYLVA_PASS_BUF(words), it.hdr, leaf);
        if (inline_leaves) {
            sylva_inline_leaf(acc, p, sylva_bih_to_world(it.hdr, it.leaf_lo), sylva_bih_to_world(it.hdr, it.leaf_hi),
                              o, d, t_min, t_max);
        } else if (sylva_range_addressable(p.x, p.y)) {
            sylva_range_leaf(acc, SYLVA_PASS_BUF(elems), p.x, p.y, o, d, t_min, t_max);
        } else {
            it.status = SYLVA_ITER_ERROR;
            break;
        }
    }
    steps = it.steps;
    status = it.status;
    return vec4(acc.rgb.x, acc.rgb.y, acc.rgb.z, acc.alpha);
}
#endif

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_PARTICLES_H
