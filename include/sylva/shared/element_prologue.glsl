// sylva/shared/element_prologue.glsl -- GLSL only: the bindings and push constants of the generic
// element kernel (sylva/shared/element_main.glsl). A user's element shader is five lines:
//
//   #version 460
//   #extension GL_GOOGLE_include_directive : require
//   #include "sylva/shared/element_prologue.glsl"   // buffers, lang.h, sylva_load_elems
//   #include "my_element.h"                          // the element, written once (element.h)
//   #define SylvaElem MyElement
//   #include "sylva/shared/element_main.glsl"        // the kernel's main()
//
// Bindings (set 0): 0-3 the encoded BIH split over four buffers (sylva::vk::split_words);
// 4 the element records (`elems`, read by the element's sylva_elem_load); 5 rays (hits mode: 8
// floats each: origin, direction, t_min, t_max; image mode: the caller's rays, 6 floats a pixel,
// sylva/shared/ray_buffer.h, when ray_source is SYLVA_RAYS_BUFFER, else a dummy); 6 output (see
// element_main.glsl).
// Specialization constants: 0 split shift, 1 BIH stack entries (>= the tree's depth), 2 parts of
// the split index holding data (1: every load reads part 0 directly, SYLVA_SPLIT_WORDS_COUNTED;
// the default 4 suits any index).
// The kernels never read BIH node boxes, so the iterator keeps none (SYLVA_BIH_NO_BOXES,
// sylva/shared/bih_iter.h): on lavapipe this and the direct loads make the kernel about twice
// as fast.
// Push constants: 100 bytes, sylva::vk::ElementPush (sylva/vulkan/elements.hpp).
#ifndef SYLVA_SHARED_ELEMENT_PROLOGUE_GLSL
#define SYLVA_SHARED_ELEMENT_PROLOGUE_GLSL

layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const int STACK_SIZE = 64;
layout(constant_id = 2) const uint SPLIT_PARTS = 4u;
#define SYLVA_BIH_STACK_SIZE STACK_SIZE
#define SYLVA_BIH_NO_BOXES

#include "sylva/shared/lang.h"
#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS_COUNTED(words, 0, SPLIT_SHIFT, SPLIT_PARTS)
layout(std430, binding = 4) readonly buffer SylvaElems { uint sylva_elems_data[]; };
layout(std430, binding = 5) readonly buffer SylvaRays { float sylva_rays_data[]; };
layout(std430, binding = 6) buffer SylvaOut { uint sylva_out_data[]; };  // image mode reads it back to resume
layout(push_constant) uniform SylvaElementPush {
    float cam[12];      // eye, forward w, right u, up v (sylva/shared/camera.h); image mode
    uint width;         // image mode: pixels; hits mode: rays per grid row
    uint height;        // image mode: pixels; hits mode: grid rows
    uint word_count;    // words of the encoded BIH
    uint elem_count;    // records in `elems`
    uint mode;          // 0: hits per ray, 1: image
    uint max_hits;      // hits mode: hits kept per ray
    float alpha_stop;   // image mode: early ray termination
    uint ray_count;     // hits mode: rays in binding 5
    uint ray_source;    // image mode: SYLVA_RAYS_* (the camera as pinhole or orthographic, or binding 5)
    uint resume;        // image mode: 0 a fresh frame; 1 continue the rays a dispatch before paused
    uint loop_budget;   // image mode: loop iterations a ray may run a dispatch (0xFFFFFFFF: no limit)
    uint origin_x;      // image mode: the pixel the dispatch's invocation (0, 0) renders
    uint origin_y;
} sylva_pc;

/// Word i of the element records, 0 past their end (the host's Words does the same).
uint sylva_load_elems(uint i) { return i < uint(sylva_elems_data.length()) ? sylva_elems_data[i] : 0u; }
/// Word i of binding 5 (image mode's ray buffer), 0 past its end.
uint sylva_load_rays(uint i) { return i < uint(sylva_rays_data.length()) ? floatBitsToUint(sylva_rays_data[i]) : 0u; }

#endif  // SYLVA_SHARED_ELEMENT_PROLOGUE_GLSL
