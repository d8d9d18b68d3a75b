// sylva/shared/dvr_kernel_io.glsl -- the buffers every volume image kernel shares (GLSL only):
// the transfer function, the parameter block, the output pixels and the caller's rays, with
// their bounds-checked loaders, and the store of one output pixel. The kernel names the
// bindings first:
//
//   #define SYLVA_IO_TF_BINDING 4       // not declared with SYLVA_NO_TF (a TF hook, sylva/shared/tf.h)
//   #define SYLVA_IO_PARAMS_BINDING 5   // SYLVA_DVR_PARAM_WORDS words, sylva/shared/dvr_common.h
//   #define SYLVA_IO_PIXELS_BINDING 6   // 5 words a pixel: premultiplied R, G, B, alpha, a count
//   #define SYLVA_IO_RAYS_BINDING 7     // 6 words a pixel, sylva/shared/rays.h
//   #include "sylva/shared/dvr_kernel_io.glsl"
//
// Used by dvr_main.glsl, kd_dvr_main.glsl and bih_dvr_main.glsl.
#ifndef SYLVA_SHARED_DVR_KERNEL_IO_GLSL
#define SYLVA_SHARED_DVR_KERNEL_IO_GLSL

layout(std430, binding = SYLVA_IO_PARAMS_BINDING) readonly buffer Params { uint param_words[]; };
layout(std430, binding = SYLVA_IO_PIXELS_BINDING) writeonly buffer Pixels { uint pixels[]; };
layout(std430, binding = SYLVA_IO_RAYS_BINDING) readonly buffer Rays { uint ray_words[]; };

#ifndef SYLVA_NO_TF
layout(std430, binding = SYLVA_IO_TF_BINDING) readonly buffer Tf { uint tf_words[]; };
uint sylva_load_tf(uint i) { return i < uint(tf_words.length()) ? tf_words[i] : 0u; }
#endif
uint sylva_load_params(uint i) { return i < uint(param_words.length()) ? param_words[i] : 0u; }
uint sylva_load_rays(uint i) { return i < uint(ray_words.length()) ? ray_words[i] : 0u; }

/// Writes pixel px of an image `width` wide: premultiplied colour c and the count `last`.
void sylva_io_store_pixel(uvec2 px, uint width, vec4 c, uint last) {
    uint at = (px.y * width + px.x) * 5u;
    pixels[at] = floatBitsToUint(c.x);
    pixels[at + 1u] = floatBitsToUint(c.y);
    pixels[at + 2u] = floatBitsToUint(c.z);
    pixels[at + 3u] = floatBitsToUint(c.w);
    pixels[at + 4u] = last;
}

#endif  // SYLVA_SHARED_DVR_KERNEL_IO_GLSL
