#version 460
// Records the leaves the shared stackless octree walk (sylva/shared/octree_iter.h) yields for
// each ray: the GLSL compile check of the iterator and the device side of the octree parity test.
//
// Bindings: 0 the index words; 1 the brick buffer (unused by the walk; its size in words is a
// push constant, since a Vulkan buffer cannot be empty and a brickless octree has none); 2 rays, 8 words each (origin xyz, direction xyz, t_min, t_max as float bits); 3 output,
// per ray 3 + 3 * max_leaves words: leaf count, final status, steps, then (node, t0 bits,
// t1 bits).
// Push constants: ray count, max leaves, max level (the cut), brick buffer words.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Index { uint index_words[]; };
layout(std430, binding = 1) readonly buffer Bricks { uint brick_words[]; };
layout(std430, binding = 2) readonly buffer Rays { uint rays[]; };
layout(std430, binding = 3) writeonly buffer Leaves { uint leaves_out[]; };
layout(push_constant) uniform Push {
    uint ray_count;
    uint max_leaves;
    uint max_level;
    uint brick_buffer_words;
} pc;

uint sylva_load_words(uint i) { return i < uint(index_words.length()) ? index_words[i] : 0u; }

#include "sylva/shared/octree_iter.h"

vec3 ray_vec3(uint at) {
    return vec3(uintBitsToFloat(rays[at]), uintBitsToFloat(rays[at + 1u]), uintBitsToFloat(rays[at + 2u]));
}

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.ray_count) return;
    uint at = r * 8u;
    SylvaOctIter it;
    if (brick_words.length() == 0) return;  // keeps the binding alive
    sylva_oct_init(it, 0u, uint(index_words.length()), pc.brick_buffer_words, ray_vec3(at), ray_vec3(at + 3u),
                   uintBitsToFloat(rays[at + 6u]), uintBitsToFloat(rays[at + 7u]), pc.max_level);
    uint base = r * (3u + 3u * pc.max_leaves);
    uint n = 0u;
    uint node;
    float t0;
    float t1;
    while (sylva_oct_next(it, 0u, node, t0, t1)) {
        if (n < pc.max_leaves) {
            uint e = base + 3u + 3u * n;
            leaves_out[e] = node;
            leaves_out[e + 1u] = floatBitsToUint(t0);
            leaves_out[e + 2u] = floatBitsToUint(t1);
        }
        n = n + 1u;
    }
    leaves_out[base] = n;
    leaves_out[base + 1u] = it.status;
    leaves_out[base + 2u] = it.steps;
}
