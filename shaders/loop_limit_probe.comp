#version 460
// Whether the device's loop limiter cuts long loops (sylva::vk::loops_limited): every invocation
// runs a loop of `trips` iterations (a push constant, so the compiler cannot fold it) that adds
// up words of binding 0, then asks sylva_loops_cut() (shared/loop_cut.glsl) whether the limiter
// has run out. Lavapipe up to Mesa 22.3 (Debian 12) ends the loops of a SIMD batch once 65,535
// iterations have run; Mesa 25 (bookworm-backports) and GPUs do not.
//
// Bindings: 0 input words (any, at least 1), 1 output, 3 words per invocation: the iterations
// run, 1 where the loops were cut (else 0), and the loop's sum (kept so the loop does work).
// Push constants: trips.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { uint words_in[]; };
layout(std430, binding = 1) writeonly buffer Out { uint out_words[]; };
layout(push_constant) uniform Push {
    uint trips;
} pc;

#include "sylva/shared/loop_cut.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint n = uint(words_in.length());
    uint ran = 0u;
    uint sum = 0u;
    for (uint k = 0u; k < pc.trips; k++) {
        sum = sum * 1664525u + words_in[(k + i) % n];
        ran = ran + 1u;
    }
    bool cut = sylva_loops_cut();
    out_words[3u * i] = ran;
    out_words[3u * i + 1u] = (cut || ran < pc.trips) ? 1u : 0u;
    out_words[3u * i + 2u] = sum;
}
