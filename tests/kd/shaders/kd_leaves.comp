#version 460
// Records the leaf sequence the shared kd-tree iterator yields for each ray (the GLSL compile
// check of sylva/shared/kd_iter.h; the layout mirrors shaders/bih_leaves.comp for parity runs).
//
// Bindings: 0 the encoded kd-tree; 1 rays, 8 words each (origin xyz, direction xyz, t_min,
// t_max as float bits); 2 output, per ray 3 + 3 * max_leaves words: leaf count, final status,
// steps, then (leaf, t0 bits, t1 bits).
// Specialization constant 0: stack entries (>= the tree's max depth).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
layout(constant_id = 0) const int STACK_SIZE = 64;
#define SYLVA_KD_STACK_SIZE STACK_SIZE

layout(std430, binding = 0) readonly buffer Tree { uint tree_words[]; };
layout(std430, binding = 1) readonly buffer Rays { uint rays[]; };
layout(std430, binding = 2) writeonly buffer Leaves { uint leaves_out[]; };
layout(push_constant) uniform Push {
    uint ray_count;
    uint max_leaves;
} pc;

uint sylva_load_words(uint i) { return i < uint(tree_words.length()) ? tree_words[i] : 0u; }

#include "sylva/shared/kd_iter.h"

vec3 ray_vec3(uint at) {
    return vec3(uintBitsToFloat(rays[at]), uintBitsToFloat(rays[at + 1u]), uintBitsToFloat(rays[at + 2u]));
}

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.ray_count) return;
    uint at = r * 8u;
    SylvaKdIter it;
    sylva_kd_init(it, 0u, uint(tree_words.length()), ray_vec3(at), ray_vec3(at + 3u), uintBitsToFloat(rays[at + 6u]),
                  uintBitsToFloat(rays[at + 7u]));
    uint base = r * (3u + 3u * pc.max_leaves);
    uint n = 0u;
    uint leaf;
    float t0;
    float t1;
    while (sylva_kd_next(it, 0u, leaf, t0, t1)) {
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
