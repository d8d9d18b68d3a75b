// sylva/shared/bih_dvr_main.glsl -- the BIH-DVR compute kernel (sylva/shared/bih_dvr.h):
// single-sample, multi-sample and iso modes over a voxel-cuboid BIH, the mode chosen by the
// parameter block. shaders/bih_dvr.comp is this file alone; your shader may define a transfer-
// function hook first and include it, then run it with vk::DeviceVoxelBih::user_kernel and
// vk::render_bih_dvr_vulkan(ctx, bih, p, &kernel) (as sylva/shared/dvr_main.glsl for the
// marcher: #define SYLVA_TF_USER and SYLVA_NO_TF, include this file, define sylva_tf_user).
//
// Bindings: 0-3 the encoded BIH (SYLVA_SPLIT_WORDS); 4-7 the node-range buffer, one word per
// encoded node (SYLVA_SPLIT_WORDS; dummies when iso culling is off); 8 the transfer function
// (sylva/shared/tf.h; not declared with SYLVA_NO_TF); 9 the parameter block
// (sylva/shared/dvr_common.h); 10 output, 5 words per pixel: premultiplied R, G, B, alpha
// (float bits) and the iterator's step count (0xFFFFFFFF: corrupted encoding); 11 the caller's
// rays, 6 words a pixel (sylva/shared/rays.h; read only for SYLVA_RAYS_BUFFER, else a dummy).
// Specialization constants: 0 split shift of the BIH, 1 stack entries (>= the tree's max
// depth), 2 split shift of the node ranges, 3 and 4 parts holding data of the BIH and of the
// ranges (1: fast loads, see SYLVA_SPLIT_WORDS_COUNTED).
layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const int STACK_SIZE = 64;
layout(constant_id = 2) const uint RANGES_SHIFT = 25u;
layout(constant_id = 3) const uint WORD_PARTS = 4u;
layout(constant_id = 4) const uint RANGE_PARTS = 4u;
#define SYLVA_BIH_STACK_SIZE STACK_SIZE

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(words, 0, SPLIT_SHIFT, WORD_PARTS)
SYLVA_SPLIT_WORDS_COUNTED(ranges, 4, RANGES_SHIFT, RANGE_PARTS)

#define SYLVA_IO_TF_BINDING 8
#define SYLVA_IO_PARAMS_BINDING 9
#define SYLVA_IO_PIXELS_BINDING 10
#define SYLVA_IO_RAYS_BINDING 11
#include "sylva/shared/dvr_kernel_io.glsl"

#include "sylva/shared/rays.h"
#include "sylva/shared/bih_dvr.h"
#include "sylva/shared/loop_cut.glsl"

void main() {
    SylvaDvrParams p = sylva_dvr_params(0u);
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= p.width || px.y >= p.height) return;
    SylvaRay ray = sylva_pixel_ray(0u, 0u, p, px.x, px.y);
    uint steps;
    uint status;
    vec4 c = sylva_bih_volume_ray(0u, 0u, 0u, p, ray.origin, ray.dir, 0.0f, sylva_inf(), steps, status);
    bool cut = sylva_loops_cut();  // a ray the device's loop limiter cut short is marked
    sylva_io_store_pixel(px, p.width, c, (status == SYLVA_ITER_ERROR || cut) ? 0xFFFFFFFFu : steps);
}
