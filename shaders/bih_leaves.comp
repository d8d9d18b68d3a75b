#version 460
// Records the leaf sequence the shared BIH iterator yields for each ray: what the host/GPU
// parity tests compare word for word.
//
// Bindings: 0-3 the encoded BIH split over four buffers (SYLVA_SPLIT_WORDS); 4 rays, 8 words
// each (origin xyz, direction xyz, t_min, t_max as float bits); 5 output, per ray
// 3 + 3 * max_leaves words: leaf count, final status, steps, then (node, t0 bits, t1 bits).
// Specialization constants: 0 split shift, 1 stack entries (>= the tree's max depth).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const int STACK_SIZE = 64;
#define SYLVA_BIH_STACK_SIZE STACK_SIZE

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS(words, 0, SPLIT_SHIFT)
layout(std430, binding = 4) readonly buffer Rays { uint rays[]; };
layout(std430, binding = 5) writeonly buffer Leaves { uint leaves_out[]; };
layout(push_constant) uniform Push {
    uint ray_count;
    uint word_count;
    uint max_leaves;
} pc;

#include "sylva/shared/bih_iter.h"

vec3 ray_vec3(uint at) {
    return vec3(uintBitsToFloat(rays[at]), uintBitsToFloat(rays[at + 1u]), uintBitsToFloat(rays[at + 2u]));
}

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.ray_count) return;
    uint at = r * 8u;
    SylvaBihIter it;
    sylva_bih_init(it, 0u, pc.word_count, ray_vec3(at), ray_vec3(at + 3u), uintBitsToFloat(rays[at + 6u]),
                   uintBitsToFloat(rays[at + 7u]));
    uint base = r * (3u + 3u * pc.max_leaves);
    uint n = 0u;
    uint leaf;
    float t0;
    float t1;
    while (sylva_bih_next(it, 0u, leaf, t0, t1)) {
        if (n < pc.max_leaves) {
            leaves_out[base + 3u + 3u * n] = leaf;
            leaves_out[base + 4u + 3u * n] = floatBitsToUint(t0);
            leaves_out[base + 5u + 3u * n] = floatBitsToUint(t1);
        }
        n = n + 1u;
    }
    leaves_out[base] = n;
    leaves_out[base + 1u] = it.status;
    leaves_out[base + 2u] = it.steps;
}
