#version 460
// Renders particles through the element octree with the shared integrator
// (sylva/shared/octree_particles.h over sylva/shared/octree_elem_iter.h): the same text the host
// renderer (sylva/render/octree_particles.hpp) runs, one invocation per pixel.
//
// Bindings: 0-3 the element octree's index words (SYLVA_SPLIT_WORDS_COUNTED: indices over
// 128 MiB work); 4-7 the particle records, 8 words each in the octree's element order
// (sylva/shared/particles.h); 8 output, 5 words per pixel: premultiplied R, G, B, alpha (float
// bits) and the walk's step count, 0xFFFFFFFF where the ray stopped with an error; 9 the
// caller's rays, 6 words a pixel (sylva/shared/ray_buffer.h; read only when ray_source is
// SYLVA_RAYS_BUFFER, else a dummy).
// Push constants: camera (12 floats, sylva/shared/camera.h), width, height, index word count,
// record count, alpha_stop, ray source (SYLVA_RAYS_*: the camera as pinhole or orthographic, or
// binding 9).
// Specialization constants: 0/1 split shift and parts holding data of the index, 2/3 the same
// for the records (parts 1: every load reads part 0 directly).
//
// Loop guard: lavapipe ends a loop silently after 65535 iterations, leaving the walk RUNNING.
// On the host the integrator returns RUNNING only once the opacity reached alpha_stop, so a
// RUNNING ray below alpha_stop is reported as an error here instead of a silently short ray.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const uint WORDS_SHIFT = 25u;
layout(constant_id = 1) const uint WORDS_PARTS = 4u;
layout(constant_id = 2) const uint ELEMS_SHIFT = 25u;
layout(constant_id = 3) const uint ELEMS_PARTS = 4u;

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(words, 0, WORDS_SHIFT, WORDS_PARTS)
SYLVA_SPLIT_WORDS_COUNTED(elems, 4, ELEMS_SHIFT, ELEMS_PARTS)
layout(std430, binding = 8) writeonly buffer Pixels { uint pixels[]; };
layout(std430, binding = 9) readonly buffer Rays { uint ray_words[]; };
layout(push_constant) uniform Push {
    float cam[12];  // eye, forward w, right u, up v (sylva/shared/camera.h)
    uint width;
    uint height;
    uint word_count;
    uint records;
    float alpha_stop;
    uint ray_source;
} pc;

uint sylva_load_rays(uint i) { return i < uint(ray_words.length()) ? ray_words[i] : 0u; }

#include "sylva/shared/ray_buffer.h"
#include "sylva/shared/octree_particles.h"
#include "sylva/shared/loop_cut.glsl"

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= pc.width || px.y >= pc.height) return;
    vec3 eye = vec3(pc.cam[0], pc.cam[1], pc.cam[2]);
    vec3 w = vec3(pc.cam[3], pc.cam[4], pc.cam[5]);
    vec3 u = vec3(pc.cam[6], pc.cam[7], pc.cam[8]);
    vec3 v = vec3(pc.cam[9], pc.cam[10], pc.cam[11]);
    SylvaRay ray = sylva_pixel_ray_from(0u, pc.ray_source, eye, w, u, v, px.x, px.y, pc.width, pc.height);
    uint steps;
    uint status;
    vec4 c = sylva_octe_render_particles(0u, pc.word_count, 0u, pc.records, ray.origin, ray.dir, 0.0f, sylva_inf(),
                                         pc.alpha_stop, steps, status);
    bool cut_short = (status == SYLVA_ITER_RUNNING && c.w < pc.alpha_stop) || sylva_loops_cut();
    uint at = (px.y * pc.width + px.x) * 5u;
    pixels[at] = floatBitsToUint(c.x);
    pixels[at + 1u] = floatBitsToUint(c.y);
    pixels[at + 2u] = floatBitsToUint(c.z);
    pixels[at + 3u] = floatBitsToUint(c.w);
    pixels[at + 4u] = (status == SYLVA_ITER_ERROR || cut_short) ? 0xFFFFFFFFu : steps;
}
