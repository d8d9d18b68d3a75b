// sylva/shared/voxel.h -- voxel-cuboid leaves (Kinkelin sections 4.3, 3.3 and Table 1): the
// packed density + gradient payload and the linear density reconstruction inside a leaf.
//
// Payload SYLVA_PAYLOAD_VOXEL (62 bits; bih_layout.h gives them as uvec2(bits 0-31, 32-61)):
//   bits  0-13  density, unsigned 14-bit fixed point: d = q / 16383, d in [0, 1]
//   bits 14-29  gradient x, signed 16-bit (two's complement): g = q / 32767, clamped to [-1, 1]
//   bits 30-45  gradient y (bits 30-31 of word 0, bits 0-13 of word 1)
//   bits 46-61  gradient z (bits 14-29 of word 1)
// The gradient is the change of normalised density across one voxel along each axis (the
// central difference (d[i+1] - d[i-1]) / 2 of the source grid, or of the resampled grid for
// supersampled sources). Inside a leaf with centre c the density is reconstructed as
//   d(x) = d_center + g . ((x - c) / voxel_size)
// which for a single-voxel leaf is exactly Kinkelin's d(x) = d_center + g . o(x) with
// o(x) = (x - c) / s in [-0.5, 0.5]^3; for a merged LoD leaf the same per-voxel gradient
// extends over the larger box.
#ifndef SYLVA_SHARED_VOXEL_H
#define SYLVA_SHARED_VOXEL_H

#include "sylva/shared/lang.h"

#define SYLVA_VOXEL_DENSITY_MAX 16383u
#define SYLVA_VOXEL_GRADIENT_MAX 32767

SYLVA_BEGIN_NAMESPACE

/// A decoded voxel leaf: normalised density at the leaf centre and per-voxel gradient.
struct SylvaVoxel {
    float density;
    vec3 gradient;
};

/// Signed 16-bit field (two's complement in the low 16 bits of q) to [-1, 1].
SYLVA_FN float sylva_voxel_snorm16(uint q) {
    int v = int(q & 0xFFFFu);
    if (v >= 32768) v = v - 65536;
    return clamp(float(v) * (1.0f / 32767.0f), -1.0f, 1.0f);
}

/// Unpacks a SYLVA_PAYLOAD_VOXEL payload given as (bits 0-31, bits 32-61).
SYLVA_FN SylvaVoxel sylva_voxel_unpack(uvec2 p) {
    SylvaVoxel v;
    v.density = float(p.x & 0x3FFFu) * (1.0f / 16383.0f);
    uint gx = (p.x >> 14u) & 0xFFFFu;
    uint gy = (p.x >> 30u) | ((p.y & 0x3FFFu) << 2u);
    uint gz = (p.y >> 14u) & 0xFFFFu;
    v.gradient = vec3(sylva_voxel_snorm16(gx), sylva_voxel_snorm16(gy), sylva_voxel_snorm16(gz));
    return v;
}

/// Density reconstructed at point x of a leaf with centre c (all in world space).
SYLVA_FN float sylva_voxel_density_at(SylvaVoxel v, vec3 x, vec3 c, vec3 voxel_size) {
    vec3 o = vec3((x.x - c.x) / voxel_size.x, (x.y - c.y) / voxel_size.y, (x.z - c.z) / voxel_size.z);
    return v.density + dot(v.gradient, o);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_VOXEL_H
