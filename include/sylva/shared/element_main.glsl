// sylva/shared/element_main.glsl -- GLSL only: main() of the generic element kernel, for the
// element type the shader names with `#define SylvaElem T` (see element_prologue.glsl).
//
// Mode 0 (hits): one invocation per ray of binding 5 (ray_count rays, laid out as a width x
// height grid); writes
// 4 + 3 * max_hits words per ray: hits written, status (SYLVA_ITER_* in bits 0-7, index passes in
// bits 8-31),
// index steps, 1 if more hits followed the last one written, then per hit (record index,
// t0 bits, t1 bits), in order (sylva/shared/element_kernels.h). max_hits 1 is the first hit.
// Mode 1 (image): one invocation per pixel of a width x height image, its ray from the camera
// (pinhole or orthographic) or binding 5 (ray_source, sylva/shared/ray_buffer.h); writes 8 words
// per pixel: premultiplied R, G, B, opacity (float bits), steps, status (bits 0-7; bits 8-31
// the times the loop limiter cut the ray short), then the last hit composited (t0
// bits, record index; sylva_elements_composite_resume). A ray that spent loop_budget
// iterations pauses (after a hit) with status SYLVA_ITER_RUNNING, as does a ray the device's
// loop limiter cut short (sylva_loops_cut); a dispatch with
// `resume` 1 continues those rays from their 8 words and leaves the others as they are
// (sylva::vk::ElementKernel::render dispatches over the paused rays' rectangle, from pixel
// (origin_x, origin_y), until none is left running).
#ifndef SYLVA_SHARED_ELEMENT_MAIN_GLSL
#define SYLVA_SHARED_ELEMENT_MAIN_GLSL

#include "sylva/shared/ray_buffer.h"
#include "sylva/shared/element_bih.h"
#include "sylva/shared/element_kernels.h"
#include "sylva/shared/loop_cut.glsl"

void sylva_element_hits_main(uint r) {
    uint at = r * 8u;
    vec3 o = vec3(sylva_rays_data[at], sylva_rays_data[at + 1u], sylva_rays_data[at + 2u]);
    vec3 d = vec3(sylva_rays_data[at + 3u], sylva_rays_data[at + 4u], sylva_rays_data[at + 5u]);
    SylvaHitIter h;
    SylvaIndexIter it;
    sylva_hits_init(h, it, 0u, sylva_pc.word_count, sylva_pc.elem_count, o, d, sylva_rays_data[at + 6u],
                    sylva_rays_data[at + 7u]);
    sylva_hits_want(h, (sylva_pc.max_hits < 0xFFFFFFFFu) ? sylva_pc.max_hits + 1u : sylva_pc.max_hits);
    uint out_at = r * (4u + 3u * sylva_pc.max_hits);
    uint n = 0u;
    uint more = 0u;
    SylvaHit hit;
    while (sylva_hits_next(h, it, 0u, 0u, hit)) {
        if (n == sylva_pc.max_hits) {
            more = 1u;
            break;
        }
        sylva_out_data[out_at + 4u + 3u * n] = hit.elem;
        sylva_out_data[out_at + 5u + 3u * n] = floatBitsToUint(hit.t0);
        sylva_out_data[out_at + 6u + 3u * n] = floatBitsToUint(hit.t1);
        n = n + 1u;
    }
    // Fewer than max_hits and still running, or any cut at all: the device cut the loops short
    // (sylva/shared/loop_cut.glsl); mark the ray instead of handing out a short list.
    if (more == 0u && h.status == SYLVA_ITER_RUNNING) h.status = SYLVA_ITER_ERROR;
    if (sylva_loops_cut()) h.status = SYLVA_ITER_ERROR;
    sylva_out_data[out_at] = n;
    sylva_out_data[out_at + 1u] = h.status | (h.passes << 8u);
    sylva_out_data[out_at + 2u] = sylva_hits_steps(h, it);
    sylva_out_data[out_at + 3u] = more;
}

/// Times a ray may be cut short by the loop limiter before it is marked an error; each cut
/// halves the ray's loop budget.
#define SYLVA_MAX_CUTS 12u

void sylva_element_image_main(uvec2 px) {
    uint at = (px.y * sylva_pc.width + px.x) * 8u;
    SylvaCompositeResume r = sylva_composite_fresh();
    uint cuts = 0u;
    if (sylva_pc.resume != 0u) {
        uint word = sylva_out_data[at + 5u];
        if ((word & 255u) != SYLVA_ITER_RUNNING) return;  // finished in an earlier dispatch
        cuts = word >> 8u;
        r.rgba = vec4(uintBitsToFloat(sylva_out_data[at]), uintBitsToFloat(sylva_out_data[at + 1u]),
                      uintBitsToFloat(sylva_out_data[at + 2u]), uintBitsToFloat(sylva_out_data[at + 3u]));
        r.steps = sylva_out_data[at + 4u];
        r.last_t0 = uintBitsToFloat(sylva_out_data[at + 6u]);
        r.last_elem = sylva_out_data[at + 7u];
    }
    SylvaCompositeResume start = r;
    vec3 eye = vec3(sylva_pc.cam[0], sylva_pc.cam[1], sylva_pc.cam[2]);
    vec3 w = vec3(sylva_pc.cam[3], sylva_pc.cam[4], sylva_pc.cam[5]);
    vec3 u = vec3(sylva_pc.cam[6], sylva_pc.cam[7], sylva_pc.cam[8]);
    vec3 v = vec3(sylva_pc.cam[9], sylva_pc.cam[10], sylva_pc.cam[11]);
    SylvaRay ray = sylva_pixel_ray_from(0u, sylva_pc.ray_source, eye, w, u, v, px.x, px.y, sylva_pc.width, sylva_pc.height);
    uint budget = (cuts == 0u) ? sylva_pc.loop_budget : max(sylva_pc.loop_budget >> min(cuts, 31u), 16u);
    sylva_elements_composite_resume(0u, sylva_pc.word_count, 0u, sylva_pc.elem_count, ray.origin, ray.dir, 0.0f,
                                    sylva_inf(), sylva_pc.alpha_stop, budget, r);
    // Asked of every ray, whatever its status: a cut can also end a walk as if it were done.
    bool cut = sylva_loops_cut();
    if (cut) {
        // The limiter stopped this batch's loops part way, so nothing this stretch computed is to
        // be trusted (a status of done or error may be its doing): the ray starts the stretch
        // again in a later dispatch with half the budget, so that it pauses before the limiter,
        // or is marked an error after SYLVA_MAX_CUTS cuts.
        cuts = cuts + 1u;
        r = start;
        r.status = (cuts > SYLVA_MAX_CUTS) ? SYLVA_ITER_ERROR : SYLVA_ITER_RUNNING;
    }
    sylva_out_data[at] = floatBitsToUint(r.rgba.x);
    sylva_out_data[at + 1u] = floatBitsToUint(r.rgba.y);
    sylva_out_data[at + 2u] = floatBitsToUint(r.rgba.z);
    sylva_out_data[at + 3u] = floatBitsToUint(r.rgba.w);
    sylva_out_data[at + 4u] = r.steps;
    sylva_out_data[at + 5u] = r.status | (cuts << 8u);
    sylva_out_data[at + 6u] = floatBitsToUint(r.last_t0);
    sylva_out_data[at + 7u] = r.last_elem;
}

void main() {
    // A resuming dispatch covers the rectangle of the paused rays, from (origin_x, origin_y).
    uvec2 px = gl_GlobalInvocationID.xy + uvec2(sylva_pc.origin_x, sylva_pc.origin_y);
    if (px.x >= sylva_pc.width || px.y >= sylva_pc.height) return;
    if (sylva_pc.mode == 0u) {
        uint r = px.y * sylva_pc.width + px.x;
        if (r < sylva_pc.ray_count) sylva_element_hits_main(r);
    } else {
        sylva_element_image_main(px);
    }
}

#endif  // SYLVA_SHARED_ELEMENT_MAIN_GLSL
