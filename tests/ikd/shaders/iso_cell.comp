#version 460
// The GLSL compile check of sylva/shared/iso_cell.h: evaluates every public function of the
// ray-isosurface cell intersection once per record.
//
// Bindings: 0 input, 20 words per record (float bits): corners lo xyzw (c000, c100, c010, c110),
// hi xyzw (c001, c101, c011, c111), ray origin xyz, direction xyz, t0, t1, iso, unused;
// 1 output, 11 words per record: density at the origin, gradient xyz at the origin, cubic
// coefficients A B C D (float bits), hit flag (0 / 1), t_hit (float bits), the cubic at t0.
// Push constant: record count.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Cells { uint cells_in[]; };
layout(std430, binding = 1) writeonly buffer Results { uint results_out[]; };
layout(push_constant) uniform Push {
    uint record_count;
} pc;

#include "sylva/shared/iso_cell.h"

float in_float(uint at) { return uintBitsToFloat(cells_in[at]); }
vec3 in_vec3(uint at) { return vec3(in_float(at), in_float(at + 1u), in_float(at + 2u)); }
vec4 in_vec4(uint at) { return vec4(in_float(at), in_float(at + 1u), in_float(at + 2u), in_float(at + 3u)); }

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.record_count) return;
    uint at = r * 20u;
    vec4 lo = in_vec4(at);
    vec4 hi = in_vec4(at + 4u);
    vec3 o = in_vec3(at + 8u);
    vec3 d = in_vec3(at + 11u);
    float t0 = in_float(at + 14u);
    float t1 = in_float(at + 15u);
    float iso = in_float(at + 16u);
    float rho = sylva_iso_cell_density(lo, hi, o);
    vec3 grad = sylva_iso_cell_gradient(lo, hi, o);
    vec4 k = sylva_iso_cell_cubic(lo, hi, o, d);
    float t_hit;
    bool hit = sylva_iso_cell_hit(lo, hi, o, d, t0, t1, iso, t_hit);
    uint out_at = r * 11u;
    results_out[out_at] = floatBitsToUint(rho);
    results_out[out_at + 1u] = floatBitsToUint(grad.x);
    results_out[out_at + 2u] = floatBitsToUint(grad.y);
    results_out[out_at + 3u] = floatBitsToUint(grad.z);
    results_out[out_at + 4u] = floatBitsToUint(k.x);
    results_out[out_at + 5u] = floatBitsToUint(k.y);
    results_out[out_at + 6u] = floatBitsToUint(k.z);
    results_out[out_at + 7u] = floatBitsToUint(k.w);
    results_out[out_at + 8u] = hit ? 1u : 0u;
    results_out[out_at + 9u] = floatBitsToUint(t_hit);
    results_out[out_at + 10u] = floatBitsToUint(sylva_iso_cubic_eval(k, t0));
}
