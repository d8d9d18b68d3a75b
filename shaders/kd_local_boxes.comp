#version 460
// The local-AABB pass of the binned kd-tree builder (Zellmann et al. section 4.3): one
// invocation per 8^3 block of a slab of the volume writes the block's word (tight box of its
// occupied voxels, occupied count, bad-value flag), sylva/shared/kd_local_boxes.h.
//
// Bindings: 0 the slab's voxels (packed words); 1 the per-value bit table (integer voxels);
// 2 the transfer function's alpha entries (float bits); 3 the parameter block
// (SYLVA_KD_BOX_PARAM_WORDS words); 4 output, one word per block of the whole grid (x fastest);
// 5 the blocks' verdicts, one byte a block of the whole grid (all zero: read every block).
// Push constants: first voxel slice of the slab, first block layer (z) of the slab, layers.
// Specialization constants: 0 source, 1 classify (the parameter block's words 3 and 4, fixed
// per pipeline so that the per-voxel branches fold away).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint SOURCE = 0u;
layout(constant_id = 1) const uint CLASSIFY = 0u;

layout(std430, binding = 0) readonly buffer Voxels { uint voxel_words[]; };
layout(std430, binding = 1) readonly buffer Lut { uint lut_words[]; };
layout(std430, binding = 2) readonly buffer Alphas { uint alpha_words[]; };
layout(std430, binding = 3) readonly buffer Params { uint param_words[]; };
layout(std430, binding = 4) writeonly buffer Blocks { uint block_words[]; };
layout(std430, binding = 5) readonly buffer Verdicts { uint verdict_words[]; };
layout(push_constant) uniform Push {
    uint slab_z0;
    uint first_layer;
    uint layers;
} pc;

uint sylva_load_voxels(uint i) { return i < uint(voxel_words.length()) ? voxel_words[i] : 0u; }
uint sylva_load_lut(uint i) { return i < uint(lut_words.length()) ? lut_words[i] : 0u; }
uint sylva_load_alphas(uint i) { return i < uint(alpha_words.length()) ? alpha_words[i] : 0u; }
uint sylva_load_params(uint i) { return i < uint(param_words.length()) ? param_words[i] : 0u; }
uint sylva_load_verdicts(uint i) { return i < uint(verdict_words.length()) ? verdict_words[i] : 0u; }

#include "sylva/shared/kd_local_boxes.h"

void main() {
    SylvaKdBoxParams p = sylva_kd_box_params(0u, pc.slab_z0);
    p.source = SOURCE;
    p.classify = CLASSIFY;
    uint nx = (p.dims.x + 7u) >> 3u;
    uint per_layer = nx * ((p.dims.y + 7u) >> 3u);
    uint i = gl_GlobalInvocationID.x;
    if (i >= per_layer * pc.layers) return;
    uint layer = i / per_layer;
    uint in_layer = i - layer * per_layer;
    uvec3 b = uvec3(in_layer % nx, in_layer / nx, pc.first_layer + layer);
    uint at = pc.first_layer * per_layer + i;
    block_words[at] = sylva_kd_box_decide(0u, 0u, 0u, 0u, p, b, at);
}
