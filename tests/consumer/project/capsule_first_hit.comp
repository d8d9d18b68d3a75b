#version 460
// A hand-written user shader over sylva's installed headers (no generic kernel): per ray, the
// first capsule hit (least entry t, then least element index, as sylva::bih::first_hit) and the
// number of capsules hit, walking an encoded BIH (RangePayload) with the shared iterator and
// testing capsule.h, the same text the host compiles. It exercises the generic host API
// (vk::upload_buffer, vk::Bindings, vk::Kernel) that any user kernel binds through.
//
// Bindings: 0-3 the encoded BIH (SYLVA_SPLIT_WORDS); 4 capsule records in the tree's leaf order
// (12 words each, sylva::pack_elements); 5 the tree's order (leaf position -> element index); 6 rays, 8 floats
// each (origin, direction, t0, t1); 7 output, 5 words per ray: element (0xFFFFFFFF: none),
// entry t, exit t (float bits), capsules hit, iterator status.
// Specialization constants: 0 split shift, 1 stack entries (>= the tree's depth).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;
layout(constant_id = 1) const int STACK_SIZE = 64;
#define SYLVA_BIH_STACK_SIZE STACK_SIZE

#include "sylva/shared/split_words.glsl"
SYLVA_SPLIT_WORDS(words, 0, SPLIT_SHIFT)
layout(std430, binding = 4) readonly buffer Capsules { uint capsule_words[]; };
layout(std430, binding = 5) readonly buffer Order { uint order_of[]; };
layout(std430, binding = 6) readonly buffer Rays { float rays[]; };
layout(std430, binding = 7) writeonly buffer Hits { uint hits[]; };
layout(push_constant) uniform Push {
    uint ray_count;
    uint word_count;
    uint element_count;
} pc;

// The element protocol reads records through sylva_load_elems (the buffer-name rule of lang.h).
uint sylva_load_elems(uint i) { return i < uint(capsule_words.length()) ? capsule_words[i] : 0u; }

#include "sylva/shared/bih_iter.h"
#include "capsule.h"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.ray_count) return;
    vec3 o = vec3(rays[i * 8u], rays[i * 8u + 1u], rays[i * 8u + 2u]);
    vec3 d = vec3(rays[i * 8u + 3u], rays[i * 8u + 4u], rays[i * 8u + 5u]);
    float t_min = rays[i * 8u + 6u];
    float t_max = rays[i * 8u + 7u];
    SylvaBihIter it;
    sylva_bih_init(it, 0u, pc.word_count, o, d, t_min, t_max);
    uint best = 0xFFFFFFFFu;
    vec2 best_t = vec2(0.0f);
    uint count = 0u;
    uint status = 0u;
    uint leaf;
    float l0;
    float l1;
    while (sylva_bih_next(it, 0u, leaf, l0, l1)) {
        uvec2 payload = sylva_bih_payload(0u, it.hdr, leaf);
        if (payload.x > pc.element_count || payload.y > pc.element_count - payload.x) {
            status = 1u;  // a range past the elements: a mismatched encoding
            break;
        }
        for (uint k = 0u; k < payload.y; ++k) {
            Capsule c;
            sylva_elem_load(0u, payload.x + k, c);
            vec2 t = sylva_elem_interval(c, o, d, t_min, t_max);
            if (!(t.x <= t.y)) continue;
            ++count;
            uint e = order_of[payload.x + k];
            if (best == 0xFFFFFFFFu || t.x < best_t.x || (t.x == best_t.x && e < best)) {
                best = e;
                best_t = t;
            }
        }
    }
    if (it.status == SYLVA_ITER_ERROR) status = 2u;
    hits[i * 5u] = best;
    hits[i * 5u + 1u] = floatBitsToUint(best_t.x);
    hits[i * 5u + 2u] = floatBitsToUint(best_t.y);
    hits[i * 5u + 3u] = count;
    hits[i * 5u + 4u] = status;
}
