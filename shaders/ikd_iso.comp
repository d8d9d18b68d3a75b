#version 460
// Exact isosurfaces over the implicit kd-tree or the reference cell DDA
// (sylva/shared/iso_render.h; Wald et al.).
//
// Bindings: 0 the encoded tree (sylva/shared/ikd_layout.h); 1 the grid (float bits of
// normalised densities, or uint8 / uint16 samples packed in words: parameter words 30-32); 2 the parameter block (SYLVA_ISO_PARAM_WORDS words); 3 output, 8 words
// per pixel: premultiplied R, G, B, alpha (float bits), traversal steps, candidate cells
// intersected, hits, final status; 4 the caller's rays, 6 words a pixel (sylva/shared/rays.h;
// read only when the ray source word 29 is SYLVA_RAYS_BUFFER, else a dummy).
// Specialization constant 0: stack entries (>= the tree's levels).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const int STACK_SIZE = 48;
#define SYLVA_IKD_STACK_SIZE STACK_SIZE
// rays.h brings dvr_common.h, whose TF reads this shader never makes: no TF loader (lang.h).
#define SYLVA_NO_TF

layout(std430, binding = 0) readonly buffer Tree { uint tree_words[]; };
layout(std430, binding = 1) readonly buffer Grid { uint grid_words[]; };
layout(std430, binding = 2) readonly buffer Params { uint param_words[]; };
layout(std430, binding = 3) writeonly buffer Pixels { uint pixels[]; };
layout(std430, binding = 4) readonly buffer Rays { uint ray_words[]; };

uint sylva_load_words(uint i) { return i < uint(tree_words.length()) ? tree_words[i] : 0u; }
uint sylva_load_grid(uint i) { return i < uint(grid_words.length()) ? grid_words[i] : 0u; }
uint sylva_load_params(uint i) { return i < uint(param_words.length()) ? param_words[i] : 0u; }
uint sylva_load_rays(uint i) { return i < uint(ray_words.length()) ? ray_words[i] : 0u; }

#include "sylva/shared/iso_render.h"
#include "sylva/shared/rays.h"
#include "sylva/shared/loop_cut.glsl"

void main() {
    SylvaIsoParams p = sylva_iso_read_params(0u);
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= p.width || px.y >= p.height) return;
    SylvaIkdHeader hdr = sylva_iso_read_header(0u, p);
    SylvaIsoRay r = (p.ray_source == SYLVA_RAYS_BUFFER)
                        ? sylva_iso_trace_ray(0u, 0u, p, hdr, sylva_rays_load(0u, px.x, px.y, p.width))
                        : sylva_iso_pixel(0u, 0u, p, hdr, px.x, px.y);
    uint at = (px.y * p.width + px.x) * 8u;
    pixels[at] = floatBitsToUint(r.rgba.x);
    pixels[at + 1u] = floatBitsToUint(r.rgba.y);
    pixels[at + 2u] = floatBitsToUint(r.rgba.z);
    pixels[at + 3u] = floatBitsToUint(r.rgba.w);
    pixels[at + 4u] = r.steps;
    pixels[at + 5u] = r.cells;
    pixels[at + 6u] = r.hits;
    pixels[at + 7u] = sylva_loops_cut() ? SYLVA_ITER_ERROR : r.status;  // a ray the loop limiter cut is marked
}
