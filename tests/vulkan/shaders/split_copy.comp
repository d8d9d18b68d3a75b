// Reads a split word array through SYLVA_SPLIT_WORDS and the shared SYLVA_LOAD macro and copies it
// out: out[i] = words[i]. The part size is the specialization constant SPLIT_SHIFT (constant_id 0).
#version 460
#extension GL_GOOGLE_include_directive : require

#include "sylva/shared/lang.h"
#include "sylva/shared/split_words.glsl"

layout(local_size_x = 64) in;
layout(constant_id = 0) const uint SPLIT_SHIFT = 25u;

SYLVA_SPLIT_WORDS(words, 0, SPLIT_SHIFT)

layout(std430, binding = 4) writeonly buffer Output { uint output_words[]; };
layout(push_constant) uniform Push { uint count; } push;

/// Shared-style reader: takes the dummy buffer handle and loads through the bridge macro.
uint read_word(SYLVA_BUF(words), uint i) { return SYLVA_LOAD(words, i); }

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < push.count) {
        output_words[i] = read_word(SYLVA_PASS_BUF(words), i);
    }
}
