#version 460
// Records the candidate cells the shared implicit kd-tree iterator (walker 0) or the cell DDA
// (walker 1) yields for each ray: the GLSL compile check of sylva/shared/ikd_iter.h and
// sylva/shared/cell_dda.h, and the device side of the ikd parity test.
//
// Bindings: 0 the encoded tree; 1 the grid (float bits of normalised densities); 2 rays, 8 words
// each (origin xyz, direction xyz, t_min, t_max as float bits); 3 output, per ray 3 + 5 *
// max_cells words: cell count, final status, steps, then (cell x | y << 16, z, t0 bits, t1 bits,
// corner bits: the float bits of the cell's first corner).
// Push constants: ray count, max cells, iso count, walker, 4 isovalues (float).
// Specialization constant 0: stack entries (>= the tree's levels).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
layout(constant_id = 0) const int STACK_SIZE = 48;
#define SYLVA_IKD_STACK_SIZE STACK_SIZE

layout(std430, binding = 0) readonly buffer Tree { uint tree_words[]; };
layout(std430, binding = 1) readonly buffer Grid { uint grid_words[]; };
layout(std430, binding = 2) readonly buffer Rays { uint rays[]; };
layout(std430, binding = 3) writeonly buffer Cells { uint cells_out[]; };
layout(push_constant) uniform Push {
    uint ray_count;
    uint max_cells;
    uint iso_count;
    uint walker;
    vec4 isos;
} pc;

uint sylva_load_words(uint i) { return i < uint(tree_words.length()) ? tree_words[i] : 0u; }
uint sylva_load_grid(uint i) { return i < uint(grid_words.length()) ? grid_words[i] : 0u; }

#include "sylva/shared/cell_dda.h"

vec3 ray_vec3(uint at) {
    return vec3(uintBitsToFloat(rays[at]), uintBitsToFloat(rays[at + 1u]), uintBitsToFloat(rays[at + 2u]));
}

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.ray_count) return;
    uint at = r * 8u;
    vec3 o = ray_vec3(at);
    vec3 d = ray_vec3(at + 3u);
    float tmin = uintBitsToFloat(rays[at + 6u]);
    float tmax = uintBitsToFloat(rays[at + 7u]);
    SylvaIkdIter it;
    SylvaDdaIter dda;
    if (pc.walker == 0u) {
        sylva_ikd_init(it, 0u, uint(tree_words.length()), uint(grid_words.length()), o, d, tmin, tmax, pc.isos, pc.iso_count);
    } else {
        sylva_dda_init(dda, 0u, uint(tree_words.length()), uint(grid_words.length()), o, d, tmin, tmax, pc.isos, pc.iso_count);
    }
    uint base = r * (3u + 5u * pc.max_cells);
    uint n = 0u;
    uvec3 cell;
    float t0;
    float t1;
    while ((pc.walker == 0u) ? sylva_ikd_next(it, 0u, 0u, cell, t0, t1) : sylva_dda_next(dda, 0u, cell, t0, t1)) {
        if (n < pc.max_cells) {
            uint e = base + 3u + 5u * n;
            cells_out[e] = cell.x | (cell.y << 16u);
            cells_out[e + 1u] = cell.z;
            cells_out[e + 2u] = floatBitsToUint(t0);
            cells_out[e + 3u] = floatBitsToUint(t1);
            cells_out[e + 4u] = floatBitsToUint((pc.walker == 0u) ? it.corners_lo.x : dda.corners_lo.x);
        }
        n = n + 1u;
    }
    cells_out[base] = n;
    cells_out[base + 1u] = (pc.walker == 0u) ? it.status : dda.status;
    cells_out[base + 2u] = (pc.walker == 0u) ? it.steps : dda.steps;
}
