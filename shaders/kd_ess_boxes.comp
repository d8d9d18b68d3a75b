#version 460
// The ESS occupancy of the 8^3 blocks the block ranges leave open (sylva/shared/kd_ess_boxes.h;
// sylva/vulkan/kd_ess.hpp): one invocation per column of 8 rows of a listed block (8 blocks a
// workgroup), each writing its rows' occupancy masks.
//
// Bindings: 0-3 the marcher's grid words (SYLVA_SPLIT_WORDS, vk::DeviceGrid's parts); 4 the
// parameter block (SYLVA_KD_ESS_PARAM_WORDS words); 5 the visible-bucket prefix (257 words);
// 6 the listed blocks' linear indices (x fastest); 7 output, 3 words per column, 24 a listed
// block (column ly at 3 ly: the masks of rows lz = 0 .. 3 and 4 .. 7, a byte each
// (sylva_kd_ess_column), then 1 where the device's loop limiter cut the invocation short,
// which the host then computes itself, else 0).
// Push constants: the first listed block of this dispatch, the number listed in all.
// Specialization constants: 0 split shift, 1 parts holding data, 2 the grid's voxel format
// (vk::DeviceGrid::constants()' first three; the format folds the other samplers away).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const uint GRID_PARTS = 4u;
layout(constant_id = 2) const uint GRID_FORMAT = 0xFFFFFFFFu;

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(grid, 0, SPLIT_SHIFT, GRID_PARTS)

layout(std430, binding = 4) readonly buffer Params { uint param_words[]; };
layout(std430, binding = 5) readonly buffer Visible { uint visible_words[]; };
layout(std430, binding = 6) readonly buffer Listed { uint listed_blocks[]; };
layout(std430, binding = 7) writeonly buffer Masks { uint mask_words[]; };
layout(push_constant) uniform Push {
    uint first;
    uint listed;
} pc;

uint sylva_load_params(uint i) { return i < uint(param_words.length()) ? param_words[i] : 0u; }
uint sylva_load_visible(uint i) { return i < uint(visible_words.length()) ? visible_words[i] : 0u; }

#include "sylva/shared/kd_ess_boxes.h"
#include "sylva/shared/loop_cut.glsl"

void main() {
    uint k = pc.first + gl_GlobalInvocationID.x / 8u;
    if (k >= pc.listed) return;
    SylvaKdEssParams p = sylva_kd_ess_params(0u);
    if (GRID_FORMAT != 0xFFFFFFFFu) p.grid.format = GRID_FORMAT;
    uint i = listed_blocks[k];
    uint bx = (p.grid.dims.x + 7u) >> 3u;
    uint by = (p.grid.dims.y + 7u) >> 3u;
    uvec3 b = uvec3(i % bx, (i / bx) % by, i / (bx * by));
    uint ly = gl_GlobalInvocationID.x & 7u;
    uvec2 m = sylva_kd_ess_column(0u, 0u, p, b, ly);
    uint at = k * 24u + ly * 3u;
    mask_words[at] = m.x;
    mask_words[at + 1u] = m.y;
    mask_words[at + 2u] = sylva_loops_cut() ? 1u : 0u;
}
