// sylva/shared/kd_dvr_main.glsl -- the ESS-DVR compute kernel (sylva/shared/kd_dvr.h): the
// reference marcher's lattice samples inside the leaves of an empty-space kd-tree, front to
// back. shaders/kd_dvr.comp is this file alone; your shader may define a transfer-function hook
// first and include it, then run it with vk::DeviceKdTree::user_kernel and
// vk::render_kd_dvr_vulkan(ctx, grid, kd, p, &kernel) (as sylva/shared/dvr_main.glsl for the
// marcher):
//
//   #version 460
//   #extension GL_GOOGLE_include_directive : require
//   #define SYLVA_TF_USER                 // tf.h declares vec4 sylva_tf_user(float d)
//   #define SYLVA_NO_TF                   // no TF table is read (lang.h supplies the loader)
//   #include "sylva/shared/kd_dvr_main.glsl"
//   vec4 sylva_tf_user(float d) { ... }   // or #include your shared-subset header defining it
//
// Bindings: 0-3 the grid's density words (SYLVA_SPLIT_WORDS); 4-7 the encoded kd-tree
// (SYLVA_SPLIT_WORDS, sylva/shared/kd_layout.h); 8 the transfer function (sylva/shared/tf.h;
// not declared with SYLVA_NO_TF); 9 the parameter block (sylva/shared/dvr_common.h, word 34 the
// kd-tree's word count); 10 output, 5 words per pixel: premultiplied R, G, B, alpha (float bits)
// and the steps (kd iterator node visits + lattice samples; 0xFFFFFFFF: corrupted encoding); 11
// the caller's rays, 6 words a pixel (sylva/shared/rays.h; read only for SYLVA_RAYS_BUFFER, else
// a dummy).
// Specialization constants: 0 split shift of the grid, 1 grid parts holding data, 2 split
// shift of the kd-tree, 3 kd-tree parts holding data (1: fast loads, SYLVA_SPLIT_WORDS_COUNTED),
// 4 kd iterator stack entries (>= the tree's max depth).
layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const uint GRID_PARTS = 4u;
layout(constant_id = 2) const uint KD_SHIFT = 25u;
layout(constant_id = 3) const uint KD_PARTS = 4u;
layout(constant_id = 4) const int STACK_SIZE = 64;
// The grid's voxel format and border mode (vk::DeviceGrid::constants; 0xFFFFFFFF: from the
// parameter block), fixed so that the other samplers fold away (sylva/shared/dvr_main.glsl).
layout(constant_id = 5) const uint GRID_FORMAT = 0xFFFFFFFFu;
layout(constant_id = 6) const uint GRID_BORDER = 0xFFFFFFFFu;
#define SYLVA_KD_STACK_SIZE STACK_SIZE

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(grid, 0, SPLIT_SHIFT, GRID_PARTS)
SYLVA_SPLIT_WORDS_COUNTED(words, 4, KD_SHIFT, KD_PARTS)

#define SYLVA_IO_TF_BINDING 8
#define SYLVA_IO_PARAMS_BINDING 9
#define SYLVA_IO_PIXELS_BINDING 10
#define SYLVA_IO_RAYS_BINDING 11
#include "sylva/shared/dvr_kernel_io.glsl"

#include "sylva/shared/rays.h"
#include "sylva/shared/kd_dvr.h"
#include "sylva/shared/loop_cut.glsl"

void main() {
    SylvaDvrParams p = sylva_dvr_params(0u);
    if (GRID_FORMAT != 0xFFFFFFFFu) p.grid_format = GRID_FORMAT;
    if (GRID_BORDER != 0xFFFFFFFFu) p.border = GRID_BORDER;
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= p.width || px.y >= p.height) return;
    SylvaRay ray = sylva_pixel_ray(0u, 0u, p, px.x, px.y);
    uint steps;
    uint status;
    vec4 c = sylva_kd_dvr_march(0u, 0u, 0u, p, ray.origin, ray.dir, 0.0f, sylva_inf(), steps, status);
    bool cut = sylva_loops_cut();  // a ray the device's loop limiter cut short is marked
    sylva_io_store_pixel(px, p.width, c, (status == SYLVA_ITER_ERROR || cut) ? 0xFFFFFFFFu : steps);
}
