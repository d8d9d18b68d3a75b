#version 460
// The element kd-tree on the device: the GLSL compile check of sylva/shared/kd_elem_iter.h
// and sylva/shared/kd_elem_particles.h, and the device side of the kd_elements parity test.
//
// Bindings: 0 the index words; 1 particle records (8 words each, element order); 2 rays, 8 words
// each (origin xyz, direction xyz, t_min, t_max as float bits); 3 output, per ray
// 9 + 5 * max_leaves words: leaf count, walk status, walk steps, R, G, B, alpha (float bits),
// the integrator's status and steps, then per leaf (node, t0 bits, t1 bits, first, count).
// Push constants: ray count, max leaves, record count, alpha_stop (float bits).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Index { uint index_words[]; };
layout(std430, binding = 1) readonly buffer Elems { uint elem_words[]; };
layout(std430, binding = 2) readonly buffer Rays { uint rays[]; };
layout(std430, binding = 3) writeonly buffer Out { uint out_words[]; };
layout(push_constant) uniform Push {
    uint ray_count;
    uint max_leaves;
    uint records;
    uint alpha_stop_bits;
} pc;

uint sylva_load_words(uint i) { return i < uint(index_words.length()) ? index_words[i] : 0u; }
uint sylva_load_elems(uint i) { return i < uint(elem_words.length()) ? elem_words[i] : 0u; }

#include "sylva/shared/kd_elem_particles.h"

vec3 ray_vec3(uint at) {
    return vec3(uintBitsToFloat(rays[at]), uintBitsToFloat(rays[at + 1u]), uintBitsToFloat(rays[at + 2u]));
}

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.ray_count) return;
    uint at = r * 8u;
    vec3 o = ray_vec3(at);
    vec3 d = ray_vec3(at + 3u);
    float t_min = uintBitsToFloat(rays[at + 6u]);
    float t_max = uintBitsToFloat(rays[at + 7u]);
    uint word_count = uint(index_words.length());
    uint base = r * (9u + 5u * pc.max_leaves);
    SylvaKdElemIter it;
    sylva_kde_init(it, 0u, word_count, o, d, t_min, t_max);
    uint n = 0u;
    uint node;
    float t0;
    float t1;
    uint first;
    uint count;
    while (sylva_kde_next(it, 0u, node, t0, t1, first, count)) {
        if (n < pc.max_leaves) {
            uint e = base + 9u + 5u * n;
            out_words[e] = node;
            out_words[e + 1u] = floatBitsToUint(t0);
            out_words[e + 2u] = floatBitsToUint(t1);
            out_words[e + 3u] = first;
            out_words[e + 4u] = count;
        }
        n = n + 1u;
    }
    out_words[base] = n;
    out_words[base + 1u] = it.status;
    out_words[base + 2u] = it.steps;
    uint steps;
    uint status;
    vec4 c = sylva_kde_render_particles(0u, word_count, 0u, pc.records, o, d, t_min, t_max,
                                         uintBitsToFloat(pc.alpha_stop_bits), steps, status);
    out_words[base + 3u] = floatBitsToUint(c.x);
    out_words[base + 4u] = floatBitsToUint(c.y);
    out_words[base + 5u] = floatBitsToUint(c.z);
    out_words[base + 6u] = floatBitsToUint(c.w);
    out_words[base + 7u] = status;
    out_words[base + 8u] = steps;
}
