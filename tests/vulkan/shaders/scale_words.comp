// Multiplies every word by FACTOR (a define, 2 unless given): out[i] = in[i] * FACTOR.
#version 460
#extension GL_GOOGLE_include_directive : require

#ifndef FACTOR
#define FACTOR 2u
#endif

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Input { uint input_words[]; };
layout(std430, binding = 1) writeonly buffer Output { uint output_words[]; };
layout(push_constant) uniform Push { uint count; } push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < push.count) {
        output_words[i] = input_words[i] * FACTOR;
    }
}
