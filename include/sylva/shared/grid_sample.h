// sylva/shared/grid_sample.h -- trilinear sampling of a float32 density grid held as words, and
// the central-difference gradient computed on the fly (Kinkelin section 6.2, traditional DVR).
//
// The grid is a buffer `grid` of dims.x * dims.y * dims.z words, each the float bits of a
// normalised density; voxel (x, y, z) is word x + dims.x * (y + dims.y * z) (x fastest).
// Cell convention of sylva/volume/grid.hpp: voxel v covers [v * spacing, (v + 1) * spacing], so
// world point p has the continuous voxel index u = p / spacing - 0.5, clamped to [0, dims - 1]
// (edge voxels repeat outside their centres); the density is the trilinear blend of the eight
// voxels around u. Callers keep the voxel count below 2^32 (the host checks it).
#ifndef SYLVA_SHARED_GRID_SAMPLE_H
#define SYLVA_SHARED_GRID_SAMPLE_H

#include "sylva/shared/lang.h"

SYLVA_BEGIN_NAMESPACE

/// x clamped to [lo, hi]; NaN becomes lo.
SYLVA_FN float sylva_grid_clamp(float x, float lo, float hi) { return (x > hi) ? hi : ((x >= lo) ? x : lo); }

/// a + (b - a) f, never contracted into fma (host/GPU parity).
SYLVA_FN float sylva_grid_lerp(float a, float b, float f) {
    SYLVA_PRECISE float r = a + (b - a) * f;
    return r;
}

/// Density of voxel (x, y, z); indices must be inside dims (reads past the buffer give 0).
SYLVA_FN float sylva_grid_voxel(SYLVA_BUF(grid), uvec3 dims, uint x, uint y, uint z) {
    return uintBitsToFloat(SYLVA_LOAD(grid, x + dims.x * (y + dims.y * z)));
}

/// Continuous voxel index of world coordinate p along one axis: p / s - 0.5 clamped to [0, n - 1].
SYLVA_FN float sylva_grid_index(float p, float s, uint n) {
    SYLVA_PRECISE float u = p / s - 0.5f;
    return sylva_grid_clamp(u, 0.0f, float((n > 0u) ? n - 1u : 0u));
}

/// Trilinear density at world point p of a grid with `dims` voxels of size `spacing`.
SYLVA_FN float sylva_grid_density(SYLVA_BUF(grid), uvec3 dims, vec3 spacing, vec3 p) {
    vec3 u = vec3(sylva_grid_index(p.x, spacing.x, dims.x), sylva_grid_index(p.y, spacing.y, dims.y),
                  sylva_grid_index(p.z, spacing.z, dims.z));
    uvec3 i0 = uvec3(uint(u.x), uint(u.y), uint(u.z));  // u >= 0: truncation is floor
    uvec3 i1 = uvec3((i0.x + 1u < dims.x) ? i0.x + 1u : i0.x, (i0.y + 1u < dims.y) ? i0.y + 1u : i0.y,
                     (i0.z + 1u < dims.z) ? i0.z + 1u : i0.z);
    SYLVA_PRECISE vec3 f = vec3(u.x - float(i0.x), u.y - float(i0.y), u.z - float(i0.z));
    float c00 = sylva_grid_lerp(sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i0.x, i0.y, i0.z),
                                sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i1.x, i0.y, i0.z), f.x);
    float c10 = sylva_grid_lerp(sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i0.x, i1.y, i0.z),
                                sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i1.x, i1.y, i0.z), f.x);
    float c01 = sylva_grid_lerp(sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i0.x, i0.y, i1.z),
                                sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i1.x, i0.y, i1.z), f.x);
    float c11 = sylva_grid_lerp(sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i0.x, i1.y, i1.z),
                                sylva_grid_voxel(SYLVA_PASS_BUF(grid), dims, i1.x, i1.y, i1.z), f.x);
    return sylva_grid_lerp(sylva_grid_lerp(c00, c10, f.y), sylva_grid_lerp(c01, c11, f.y), f.z);
}

/// Central-difference gradient at world point p from six trilinear samples one voxel away:
/// (d(p + s e_i) - d(p - s e_i)) / 2 per axis, i.e. the change of density across one voxel
/// (the convention of the voxel payload, sylva/shared/voxel.h). Divide by spacing for the
/// world-space gradient.
SYLVA_FN vec3 sylva_grid_gradient(SYLVA_BUF(grid), uvec3 dims, vec3 spacing, vec3 p) {
    SYLVA_PRECISE vec3 px0 = vec3(p.x - spacing.x, p.y, p.z);
    SYLVA_PRECISE vec3 px1 = vec3(p.x + spacing.x, p.y, p.z);
    SYLVA_PRECISE vec3 py0 = vec3(p.x, p.y - spacing.y, p.z);
    SYLVA_PRECISE vec3 py1 = vec3(p.x, p.y + spacing.y, p.z);
    SYLVA_PRECISE vec3 pz0 = vec3(p.x, p.y, p.z - spacing.z);
    SYLVA_PRECISE vec3 pz1 = vec3(p.x, p.y, p.z + spacing.z);
    float gx = sylva_grid_density(SYLVA_PASS_BUF(grid), dims, spacing, px1) -
               sylva_grid_density(SYLVA_PASS_BUF(grid), dims, spacing, px0);
    float gy = sylva_grid_density(SYLVA_PASS_BUF(grid), dims, spacing, py1) -
               sylva_grid_density(SYLVA_PASS_BUF(grid), dims, spacing, py0);
    float gz = sylva_grid_density(SYLVA_PASS_BUF(grid), dims, spacing, pz1) -
               sylva_grid_density(SYLVA_PASS_BUF(grid), dims, spacing, pz0);
    return vec3(gx, gy, gz) * 0.5f;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_GRID_SAMPLE_H
