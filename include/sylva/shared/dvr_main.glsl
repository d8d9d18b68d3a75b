// sylva/shared/dvr_main.glsl -- the reference DVR marcher's compute kernel (sylva/shared/dvr.h)
// over a density grid: shaders/dvr.comp is this file alone; your shader may define a transfer-
// function hook (or a ray generator) first and include it, then run it with
// vk::DeviceGrid::user_kernel and vk::render_dvr_vulkan(ctx, grid, p, &kernel):
//
//   #version 460
//   #extension GL_GOOGLE_include_directive : require
//   #define SYLVA_TF_USER                 // tf.h declares vec4 sylva_tf_user(float d)
//   #define SYLVA_NO_TF                   // no TF table is read (lang.h supplies the loader)
//   #include "sylva/shared/dvr_main.glsl"
//   vec4 sylva_tf_user(float d) { ... }   // or #include your shared-subset header defining it
//
// (tests/dvr/shaders/dvr_analytic_tf.comp does this with the shared-subset TF of
// tests/dvr/shaders/analytic_tf.h, which the host test calls as its tf_hook.)
//
// Bindings: 0-3 the grid's words (SYLVA_SPLIT_WORDS: grids over 128 MiB); 4 the transfer
// function table (sylva/shared/tf.h; not declared with SYLVA_NO_TF); 5 the parameter block
// (SYLVA_DVR_PARAM_WORDS words, sylva/shared/dvr_common.h: camera, image size, dims, ...);
// 6 output, 5 words per pixel: premultiplied R, G, B, alpha (float bits) and the number of
// lattice samples visited; 7 the caller's rays, 6 words a pixel (sylva/shared/rays.h; read only
// when the ray source word is SYLVA_RAYS_BUFFER, else a dummy is bound).
// Specialization constants: 0 split shift of the grid, 1 parts holding data (1: fast loads),
// 2 the grid's voxel format and 3 its border mode (SYLVA_GRID_*, SYLVA_BORDER_*; the default
// 0xFFFFFFFF reads them from the parameter block). vk::DeviceGrid::constants() fixes both, so
// that the samplers of the other formats and border fold away: lavapipe's compile of a kernel
// holding every format's sampler, with its grid split over four bindings, ran for minutes.
layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const uint GRID_PARTS = 4u;
layout(constant_id = 2) const uint GRID_FORMAT = 0xFFFFFFFFu;
layout(constant_id = 3) const uint GRID_BORDER = 0xFFFFFFFFu;

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(grid, 0, SPLIT_SHIFT, GRID_PARTS)

#define SYLVA_IO_TF_BINDING 4
#define SYLVA_IO_PARAMS_BINDING 5
#define SYLVA_IO_PIXELS_BINDING 6
#define SYLVA_IO_RAYS_BINDING 7
#include "sylva/shared/dvr_kernel_io.glsl"

#include "sylva/shared/rays.h"
#include "sylva/shared/dvr.h"
#include "sylva/shared/loop_cut.glsl"

void main() {
    SylvaDvrParams p = sylva_dvr_params(0u);
    if (GRID_FORMAT != 0xFFFFFFFFu) p.grid_format = GRID_FORMAT;
    if (GRID_BORDER != 0xFFFFFFFFu) p.border = GRID_BORDER;
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= p.width || px.y >= p.height) return;
    SylvaRay ray = sylva_pixel_ray(0u, 0u, p, px.x, px.y);
    uint steps;
    vec4 c = sylva_dvr_march(0u, 0u, p, ray.origin, ray.dir, 0.0f, sylva_inf(), steps);
    bool cut = sylva_loops_cut();  // a ray the device's loop limiter cut short is marked
    sylva_io_store_pixel(px, p.width, c, cut ? 0xFFFFFFFFu : steps);
}
