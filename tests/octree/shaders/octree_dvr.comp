#version 460
// Renders one ray per invocation with the shared octree DVR integrator (sylva/shared/octree_dvr.h):
// the GLSL compile check of the integrator and the device side of the octree DVR parity test.
//
// Bindings: 0 the index words; 1 the bricks; 2 the RGBA8 transfer function; 3 its opacity prefix
// counts; 4 the DVR parameter block (sylva/shared/dvr_common.h); 5 rays, 6 words each (origin
// xyz, direction xyz as float bits); 6 output, 7 words per ray: r, g, b, a (float bits), lattice
// samples, leaves visited, final status.
// Push constants: ray count, max level (the cut).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Index { uint index_words[]; };
layout(std430, binding = 1) readonly buffer Bricks { uint brick_words[]; };
layout(std430, binding = 2) readonly buffer Tf { uint tf_words[]; };
layout(std430, binding = 3) readonly buffer TfSum { uint tfsum_words[]; };
layout(std430, binding = 4) readonly buffer Params { uint param_words[]; };
layout(std430, binding = 5) readonly buffer Rays { uint rays[]; };
layout(std430, binding = 6) writeonly buffer Out { uint out_words[]; };
layout(push_constant) uniform Push {
    uint ray_count;
    uint max_level;
} pc;

uint sylva_load_words(uint i) { return i < uint(index_words.length()) ? index_words[i] : 0u; }
uint sylva_load_bricks(uint i) { return i < uint(brick_words.length()) ? brick_words[i] : 0u; }
uint sylva_load_tf(uint i) { return i < uint(tf_words.length()) ? tf_words[i] : 0u; }
uint sylva_load_tfsum(uint i) { return i < uint(tfsum_words.length()) ? tfsum_words[i] : 0u; }
uint sylva_load_params(uint i) { return i < uint(param_words.length()) ? param_words[i] : 0u; }
// grid_sample.h (whose arithmetic the bricks reuse) declares grid reads too; none happen here.
uint sylva_load_grid(uint i) { return 0u; }

#include "sylva/shared/octree_dvr.h"

vec3 ray_vec3(uint at) {
    return vec3(uintBitsToFloat(rays[at]), uintBitsToFloat(rays[at + 1u]), uintBitsToFloat(rays[at + 2u]));
}

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.ray_count) return;
    SylvaDvrParams p = sylva_dvr_params(0u);
    SylvaOctHeader h = sylva_oct_read_header(0u, uint(index_words.length()), uint(brick_words.length()));
    uint steps;
    uint visits;
    uint status;
    vec4 c = sylva_oct_dvr_ray(0u, 0u, 0u, 0u, p, h, pc.max_level, ray_vec3(6u * r), ray_vec3(6u * r + 3u), 0.0f,
                               sylva_inf(), steps, visits, status);
    uint o = 7u * r;
    out_words[o] = floatBitsToUint(c.x);
    out_words[o + 1u] = floatBitsToUint(c.y);
    out_words[o + 2u] = floatBitsToUint(c.z);
    out_words[o + 3u] = floatBitsToUint(c.w);
    out_words[o + 4u] = steps;
    out_words[o + 5u] = visits;
    out_words[o + 6u] = status;
}
