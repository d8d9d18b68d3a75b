#version 460
// Renders particles through a BIH with the shared integrator (sylva/shared/particles.h).
//
// Bindings: 0-3 the encoded BIH (SYLVA_SPLIT_WORDS); 4 particle records (range payloads; a
// dummy for inline payloads); 5 output, 5 words per pixel: premultiplied R, G, B, alpha
// (float bits) and the iterator's step count; 6 the caller's rays, 6 words a pixel
// (sylva/shared/ray_buffer.h; read only when ray_source is SYLVA_RAYS_BUFFER, else a dummy).
// Push constants: the camera (12 floats), width, height, BIH word count, alpha_stop, ray source
// (SYLVA_RAYS_*: the camera as pinhole or orthographic, or binding 6).
// Specialization constants: 0 split shift, 1 stack entries (>= the tree's max depth), 2 parts of
// the split BIH holding data (1: loads read part 0 directly, SYLVA_SPLIT_WORDS_COUNTED).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const int STACK_SIZE = 64;
layout(constant_id = 2) const uint SPLIT_PARTS = 4u;
#define SYLVA_BIH_STACK_SIZE STACK_SIZE

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(words, 0, SPLIT_SHIFT, SPLIT_PARTS)
layout(std430, binding = 4) readonly buffer Elems { uint elems[]; };
layout(std430, binding = 5) writeonly buffer Pixels { uint pixels[]; };
layout(std430, binding = 6) readonly buffer Rays { uint ray_words[]; };
layout(push_constant) uniform Push {
    float cam[12];  // eye, forward w, right u, up v (sylva/shared/camera.h)
    uint width;
    uint height;
    uint word_count;
    float alpha_stop;
    uint ray_source;
} pc;

uint sylva_load_elems(uint i) { return i < uint(elems.length()) ? elems[i] : 0u; }
uint sylva_load_rays(uint i) { return i < uint(ray_words.length()) ? ray_words[i] : 0u; }

#include "sylva/shared/ray_buffer.h"
#include "sylva/shared/particles.h"
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
    vec4 c = sylva_render_particles(0u, pc.word_count, 0u, ray.origin, ray.dir, 0.0f, sylva_inf(), pc.alpha_stop, steps, status);
    uint at = (px.y * pc.width + px.x) * 5u;
    pixels[at] = floatBitsToUint(c.x);
    pixels[at + 1u] = floatBitsToUint(c.y);
    pixels[at + 2u] = floatBitsToUint(c.z);
    pixels[at + 3u] = floatBitsToUint(c.w);
    bool cut = sylva_loops_cut();  // a ray the device's loop limiter cut short is marked
    pixels[at + 4u] = (status == SYLVA_ITER_ERROR || cut) ? 0xFFFFFFFFu : steps;
}
