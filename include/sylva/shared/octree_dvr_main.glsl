// sylva/shared/octree_dvr_main.glsl -- the bricked octree's compute kernel: DVR
// (sylva/shared/octree_dvr.h) or first-hit isosurfaces (sylva/shared/octree_iso.h), the
// stackless neighbour-pointer walk over the cut's leaves, each sampled from its brick on the
// marcher's global lattice. shaders/octree_dvr.comp is this file alone; your shader may define a
// transfer-function hook first and include it, then run it with vk::DeviceOctree::user_kernel
// and vk::render_octree_dvr_vulkan(ctx, oct, p, {}, {}, &kernel) (as sylva/shared/dvr_main.glsl
// for the marcher):
//
//   #version 460
//   #extension GL_GOOGLE_include_directive : require
//   #define SYLVA_TF_USER                 // tf.h declares vec4 sylva_tf_user(float d)
//   #define SYLVA_NO_TF                   // no TF table is read (lang.h supplies the loader)
//   #include "sylva/shared/octree_dvr_main.glsl"
//   vec4 sylva_tf_user(float d) { ... }   // or #include your shared-subset header defining it
//
// Bindings: 0-3 the bricks (SYLVA_SPLIT_WORDS: brick buffers over 128 MiB); 4 the index words
// (sylva/shared/octree_layout.h); 5 the transfer function (sylva/shared/tf.h; not declared with
// SYLVA_NO_TF); 6 its opacity prefix counts (entries + 1 words; with a hook the host binds an
// always-visible table); 7 the parameter block (SYLVA_DVR_PARAM_WORDS words,
// sylva/shared/dvr_common.h; words 38-39 the border mode); 8 output, 5 words per pixel:
// premultiplied R, G, B, alpha (float bits) and the number of lattice samples taken (0xFFFFFFFF
// where the index was found corrupt). 9 visibility feedback, one word per node: set to 1 for
// every cut leaf a ray reached before it terminated (sylva/shared/octree_dvr.h; written only
// when the push constant `feedback` is 1, else a 4-byte dummy is bound and nothing is written).
// 10 octant masks, one word per node (sylva/octree/octants.hpp; read only when the push
// constant `octmask` is 1, else a dummy). 11 the caller's rays, 6 words a pixel
// (sylva/shared/rays.h; read only for SYLVA_RAYS_BUFFER).
// Push constants: max level (the cut), the brick buffer's word count (its parts are split),
// mode (0 DVR, 1 iso; the iso value is the parameter block's), feedback (1: write binding 9),
// octmask (1: DVR skips the octants binding 10 marks empty).
// Specialization constants: 0 split shift of the bricks, 1 parts holding data (1: fast loads),
// 2 the brick format (SYLVA_OCT_FORMAT_*; an index of another format is refused) and 3 the border
// mode (SYLVA_BORDER_*); 0xFFFFFFFF reads them from the index and the parameter block.
// vk::DeviceOctree::constants() fixes both, so that each pipeline holds one brick decoder and
// one border sampler: with every combination inlined into the sampler's many call sites,
// lavapipe's compile ran for over 15 minutes and 7 GB (stopped).
#ifndef SYLVA_SHARED_OCTREE_DVR_MAIN_GLSL
#define SYLVA_SHARED_OCTREE_DVR_MAIN_GLSL

// grid_sample.h (whose arithmetic the bricks reuse) declares grid reads; none happen here.
#define SYLVA_NO_GRID
layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const uint BRICK_PARTS = 4u;
layout(constant_id = 2) const uint BRICK_FORMAT = 0xFFFFFFFFu;
layout(constant_id = 3) const uint BORDER_MODE = 0xFFFFFFFFu;

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(bricks, 0, SPLIT_SHIFT, BRICK_PARTS)
layout(std430, binding = 4) readonly buffer Index { uint index_words[]; };
layout(std430, binding = 6) readonly buffer TfSum { uint tfsum_words[]; };
layout(std430, binding = 9) buffer Seen { uint seen_words[]; };
layout(std430, binding = 10) readonly buffer OctMask { uint octmask_words[]; };
#define SYLVA_IO_TF_BINDING 5
#define SYLVA_IO_PARAMS_BINDING 7
#define SYLVA_IO_PIXELS_BINDING 8
#define SYLVA_IO_RAYS_BINDING 11
#include "sylva/shared/dvr_kernel_io.glsl"
layout(push_constant) uniform Push {
    uint max_level;
    uint brick_buffer_words;
    uint mode;
    uint feedback;
    uint octmask;
} pc;

#define SYLVA_OCT_SEEN_STORE
void sylva_oct_store_seen(uint node) {
    if (pc.feedback != 0u && node < uint(seen_words.length())) seen_words[node] = 1u;
}

uint sylva_load_words(uint i) { return i < uint(index_words.length()) ? index_words[i] : 0u; }
uint sylva_load_tfsum(uint i) { return i < uint(tfsum_words.length()) ? tfsum_words[i] : 0u; }
#define SYLVA_OCT_OCTMASK
uint sylva_load_octmask(uint i) { return i < uint(octmask_words.length()) ? octmask_words[i] : 255u; }

#include "sylva/shared/rays.h"
#include "sylva/shared/octree_dvr.h"
#include "sylva/shared/octree_iso.h"
#include "sylva/shared/loop_cut.glsl"

void main() {
    SylvaDvrParams p = sylva_dvr_params(0u);
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= p.width || px.y >= p.height) return;
    SylvaRay ray = sylva_pixel_ray(0u, 0u, p, px.x, px.y);
    SylvaOctHeader h = sylva_oct_read_header(0u, uint(index_words.length()), pc.brick_buffer_words);
    if (BRICK_FORMAT != 0xFFFFFFFFu) {
        if (h.format != BRICK_FORMAT) h.valid = 0u;  // the pipeline decodes one format only
        h.format = BRICK_FORMAT;
    }
    if (BORDER_MODE != 0xFFFFFFFFu) p.border = BORDER_MODE;
    uint steps;
    uint visits;
    uint status;
    vec4 c;
    if (pc.mode == 1u) {
        c = sylva_oct_iso_ray_seen(0u, 0u, 0u, p, h, pc.max_level, ray.origin, ray.dir, 0.0f, sylva_inf(), 0u, steps, visits, status);
    } else {
        c = sylva_oct_dvr_ray_masked(0u, 0u, 0u, 0u, 0u, pc.octmask, p, h, pc.max_level, ray.origin, ray.dir, 0.0f, sylva_inf(), 0u,
                                     steps, visits, status);
    }
    uint at = (px.y * p.width + px.x) * 5u;
    pixels[at] = floatBitsToUint(c.x);
    pixels[at + 1u] = floatBitsToUint(c.y);
    pixels[at + 2u] = floatBitsToUint(c.z);
    pixels[at + 3u] = floatBitsToUint(c.w);
    // Lavapipe ends every loop of an invocation, silently, once 65,535 loop iterations have run
    // in all loops together. The DVR walk stops RUNNING only at early ray termination (alpha >=
    // alpha_stop; the host never returns RUNNING otherwise), so RUNNING below alpha_stop is a ray
    // the limiter cut short: marked as an error, never written as a short colour. The iso walk
    // never ends RUNNING on the host (DONE at a hit or at the end, ERROR on a bad index), so
    // any RUNNING iso ray was cut short.
    bool cut_short = status == SYLVA_ITER_RUNNING && (pc.mode == 1u || !(c.w >= p.alpha_stop));
    cut_short = cut_short || sylva_loops_cut();  // sylva/shared/loop_cut.glsl: any cut at all
    pixels[at + 4u] = (status == SYLVA_ITER_ERROR || cut_short) ? 0xFFFFFFFFu : steps;
}

#endif  // SYLVA_SHARED_OCTREE_DVR_MAIN_GLSL
