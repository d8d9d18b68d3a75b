// sylva/shared/grid_sample.h -- trilinear sampling of a density grid held as 32-bit words, in
// one of three voxel formats, with a border mode, and the central-difference gradient computed
// on the fly (Kinkelin section 6.2, traditional DVR).
//
// Grid words (buffer `grid`), voxel i = x + dims.x * (y + dims.y * z) (x fastest):
//   SYLVA_GRID_F32  one voxel a word: the float bits of a normalised density
//   SYLVA_GRID_U8   four voxels a word: voxel i in bits 8 (i & 3) .. 8 (i & 3) + 7 of word i >> 2
//   SYLVA_GRID_U16  two voxels a word: voxel i in bits 16 (i & 1) .. of word i >> 1
// (little-endian byte order, so a uint8/uint16 volume's bytes are its words unchanged).
//   SYLVA_GRID_SPARSE_U8, SYLVA_GRID_SPARSE_U16  bricks of 8^3 voxels, uniform bricks not stored:
//     words [0, B) are the brick table, B = bx * by * bz with b? = (dims.? + 7) >> 3, brick
//     (x >> 3, y >> 3, z >> 3) at entry bx' + bx * (by' + by * bz'). An entry with bit 31 set is
//     a uniform brick: every voxel of it inside the grid has the raw value in bits 0-15 (bits
//     16-30 are 0). An entry with bit 31 clear is the word offset (>= B) of the brick's 512
//     voxels, local voxel l = (x & 7) + 8 ((y & 7) + 8 (z & 7)) packed as in U8 (128 words a
//     brick) or U16 (256 words); voxels of a brick beyond the grid's faces are never read.
//     Checked on the host by GridWords::check_words (sylva/render/volume.hpp); a corrupt entry
//     reads 0 past the buffer, never out of bounds.
// An integer voxel of raw value v reads as density clamp((v - lo) / span, 0, 1) with lo = value_lo
// and span = value_span (> 0) -- the division as written, so lo = 0, span = 255 gives exactly
// v / 255, the value volume::normalize stores (sylva/volume/grid.hpp).
//
// Cell convention of sylva/volume/grid.hpp: voxel v covers [v * spacing, (v + 1) * spacing], so
// world point p has the continuous voxel index u = p / spacing - 0.5; the density is the
// trilinear blend of the eight voxels around u. Outside the voxel centres the border mode
// decides (docs/DESIGN.md; VTK and NanoVDB read a background value there):
//   SYLVA_BORDER_CLAMP     u is clamped to [0, dims - 1]: edge voxels repeat outside.
//   SYLVA_BORDER_CONSTANT  voxels outside [0, dims) read border_value (normalised density);
//                          u is clamped to [-1, dims] first (further out every corner is border).
// Both modes compute the same arithmetic wherever u lies within [0, dims - 1] on every axis.
// Callers keep the voxel count below 2^32 (the host checks it).
#ifndef SYLVA_SHARED_GRID_SAMPLE_H
#define SYLVA_SHARED_GRID_SAMPLE_H

#include "sylva/shared/lang.h"

// The border and format codes of the parameter block (sylva/shared/dvr_common.h, words 38, 40).
#ifndef SYLVA_BORDER_CLAMP
#define SYLVA_BORDER_CLAMP 0u
#define SYLVA_BORDER_CONSTANT 1u
#endif
#ifndef SYLVA_GRID_F32
#define SYLVA_GRID_F32 0u
#define SYLVA_GRID_U8 1u
#define SYLVA_GRID_U16 2u
#endif
#ifndef SYLVA_GRID_SPARSE_U8
#define SYLVA_GRID_SPARSE_U8 3u
#define SYLVA_GRID_SPARSE_U16 4u
#endif
/// Sparse formats: bit 31 of a brick-table entry marks a uniform brick (raw value in bits 0-15).
#define SYLVA_GRID_UNIFORM_BIT 0x80000000u

SYLVA_BEGIN_NAMESPACE

/// What a sampler needs to know about the grid (from the parameter block: sylva_dvr_grid in
/// sylva/shared/dvr.h).
struct SylvaGridDesc {
    uvec3 dims;
    vec3 spacing;
    uint border;         ///< SYLVA_BORDER_*
    float border_value;  ///< density outside the grid (SYLVA_BORDER_CONSTANT)
    uint format;         ///< SYLVA_GRID_*
    float value_lo;      ///< integer formats: raw value of density 0
    float value_span;    ///< integer formats: raw values per unit of density (> 0)
};

/// A float32 grid with edge clamping (the sampler before border modes and formats).
SYLVA_FN SylvaGridDesc sylva_grid_f32_clamped(uvec3 dims, vec3 spacing) {
    SylvaGridDesc g;
    g.dims = dims;
    g.spacing = spacing;
    g.border = SYLVA_BORDER_CLAMP;
    g.border_value = 0.0f;
    g.format = SYLVA_GRID_F32;
    g.value_lo = 0.0f;
    g.value_span = 1.0f;
    return g;
}

/// x clamped to [lo, hi]; NaN becomes lo.
SYLVA_FN float sylva_grid_clamp(float x, float lo, float hi) { return (x > hi) ? hi : ((x >= lo) ? x : lo); }

/// a + (b - a) f, never contracted into fma (host/GPU parity).
SYLVA_FN float sylva_grid_lerp(float a, float b, float f) {
    SYLVA_PRECISE float r = a + (b - a) * f;
    return r;
}

/// Normalised density of raw integer value `raw` in the value range (lo, span): clamp((raw - lo)
/// / span, 0, 1), the division as written (the one definition every integer-grid reader uses).
/// Non-decreasing in raw for span > 0 (each rounding is monotonic), so the min / max of raw
/// values maps to the min / max of their densities.
SYLVA_FN_HOT float sylva_grid_normalise(uint raw, float lo, float span) {
    SYLVA_PRECISE float d = (float(raw) - lo) / span;
    return sylva_grid_clamp(d, 0.0f, 1.0f);
}

/// Normalised density of raw integer value `raw` in g's value range.
SYLVA_FN_HOT float sylva_grid_raw_density(SYLVA_IN(SylvaGridDesc) g, uint raw) {
    return sylva_grid_normalise(raw, g.value_lo, g.value_span);
}

/// Normalised density of voxel index i (< the voxel count) of a dense grid (SYLVA_GRID_F32, U8
/// or U16) in g's format.
SYLVA_FN_HOT float sylva_grid_word_density(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uint i) {
    if (g.format == SYLVA_GRID_F32) return uintBitsToFloat(SYLVA_LOAD(grid, i));
    uint raw;
    if (g.format == SYLVA_GRID_U8) {
        raw = (SYLVA_LOAD(grid, i >> 2u) >> ((i & 3u) * 8u)) & 255u;
    } else {
        raw = (SYLVA_LOAD(grid, i >> 1u) >> ((i & 1u) * 16u)) & 65535u;
    }
    return sylva_grid_raw_density(g, raw);
}

/// Sparse formats: the brick-table entry of the brick holding voxel (x, y, z).
SYLVA_FN uint sylva_grid_sparse_entry(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uint x, uint y, uint z) {
    uint bx = (g.dims.x + 7u) >> 3u;
    uint by = (g.dims.y + 7u) >> 3u;
    return SYLVA_LOAD(grid, (x >> 3u) + bx * ((y >> 3u) + by * (z >> 3u)));
}

/// Sparse formats: the raw value of voxel (x, y, z) of the brick whose table entry is e.
SYLVA_FN uint sylva_grid_sparse_raw(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uint e, uint x, uint y, uint z) {
    if ((e & SYLVA_GRID_UNIFORM_BIT) != 0u) return e & 65535u;
    uint l = (x & 7u) + 8u * ((y & 7u) + 8u * (z & 7u));
    if (g.format == SYLVA_GRID_SPARSE_U8) return (SYLVA_LOAD(grid, e + (l >> 2u)) >> ((l & 3u) * 8u)) & 255u;
    return (SYLVA_LOAD(grid, e + (l >> 1u)) >> ((l & 1u) * 16u)) & 65535u;
}

/// Density of voxel (x, y, z) of a dense grid (SYLVA_GRID_F32, U8, U16); indices inside dims.
SYLVA_FN_HOT float sylva_grid_dense_voxel(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uint x, uint y, uint z) {
    return sylva_grid_word_density(SYLVA_PASS_BUF(grid), g, x + g.dims.x * (y + g.dims.y * z));
}

/// Density of voxel (x, y, z) of a sparse grid; indices inside dims.
SYLVA_FN_APART float sylva_grid_sparse_voxel(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uint x, uint y, uint z) {
    uint e = sylva_grid_sparse_entry(SYLVA_PASS_BUF(grid), g, x, y, z);
    return sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, x, y, z));
}

/// Density of voxel (x, y, z) in any format; indices must be inside dims (reads past the buffer
/// give 0).
SYLVA_FN float sylva_grid_voxel_of(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uint x, uint y, uint z) {
    if (g.format >= SYLVA_GRID_SPARSE_U8) return sylva_grid_sparse_voxel(SYLVA_PASS_BUF(grid), g, x, y, z);
    return sylva_grid_word_density(SYLVA_PASS_BUF(grid), g, x + g.dims.x * (y + g.dims.y * z));
}

/// Density of voxel (x, y, z) of a float32 grid (kept for callers of the float-only sampler).
SYLVA_FN float sylva_grid_voxel(SYLVA_BUF(grid), uvec3 dims, uint x, uint y, uint z) {
    return uintBitsToFloat(SYLVA_LOAD(grid, x + dims.x * (y + dims.y * z)));
}

/// Continuous voxel index of world coordinate p along one axis: p / s - 0.5 clamped to [0, n - 1].
SYLVA_FN float sylva_grid_index(float p, float s, uint n) {
    SYLVA_PRECISE float u = p / s - 0.5f;
    return sylva_grid_clamp(u, 0.0f, float((n > 0u) ? n - 1u : 0u));
}

/// The trilinear blend of eight corner densities c<x><y><z> with weights f: z first, then y,
/// then x, each step a + (b - a) f: the order and arithmetic of NanoVDB's TrilinearSampler, so
/// the same eight values and weights give NanoVDB's density bit for bit.
SYLVA_FN_HOT float sylva_grid_blend(float c000, float c100, float c010, float c110, float c001, float c101, float c011,
                                float c111, vec3 f) {
    float c00 = sylva_grid_lerp(c000, c001, f.z);
    float c01 = sylva_grid_lerp(c010, c011, f.z);
    float c10 = sylva_grid_lerp(c100, c101, f.z);
    float c11 = sylva_grid_lerp(c110, c111, f.z);
    return sylva_grid_lerp(sylva_grid_lerp(c00, c01, f.y), sylva_grid_lerp(c10, c11, f.y), f.x);
}

/// The trilinear blend of the eight voxels {i0, i1} per axis (inside the grid) of a sparse grid:
/// one brick-table read when the eight share a brick (a uniform brick then returns its density:
/// the blend of eight equal values is that value exactly), one per voxel otherwise.
SYLVA_FN_HOT float sylva_grid_trilinear_sparse(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uvec3 i0, uvec3 i1, vec3 f) {
    if ((i0.x >> 3u) == (i1.x >> 3u) && (i0.y >> 3u) == (i1.y >> 3u) && (i0.z >> 3u) == (i1.z >> 3u)) {
        uint e = sylva_grid_sparse_entry(SYLVA_PASS_BUF(grid), g, i0.x, i0.y, i0.z);
        if ((e & SYLVA_GRID_UNIFORM_BIT) != 0u) return sylva_grid_raw_density(g, e & 65535u);
        return sylva_grid_blend(
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i0.x, i0.y, i0.z)),
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i1.x, i0.y, i0.z)),
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i0.x, i1.y, i0.z)),
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i1.x, i1.y, i0.z)),
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i0.x, i0.y, i1.z)),
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i1.x, i0.y, i1.z)),
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i0.x, i1.y, i1.z)),
            sylva_grid_raw_density(g, sylva_grid_sparse_raw(SYLVA_PASS_BUF(grid), g, e, i1.x, i1.y, i1.z)), f);
    }
    return sylva_grid_blend(sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i0.x, i0.y, i0.z),
                            sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i1.x, i0.y, i0.z),
                            sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i0.x, i1.y, i0.z),
                            sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i1.x, i1.y, i0.z),
                            sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i0.x, i0.y, i1.z),
                            sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i1.x, i0.y, i1.z),
                            sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i0.x, i1.y, i1.z),
                            sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, i1.x, i1.y, i1.z), f);
}

/// The trilinear blend of the eight voxels {i0, i1} per axis (inside the grid) with weights f
/// (sylva_grid_blend: z first, then y, then x). Dense grids read their words directly (no per-voxel format test:
/// one cost the dense marcher 10-30 % of its speed), sparse grids through their brick table.
SYLVA_FN_HOT float sylva_grid_trilinear(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, uvec3 i0, uvec3 i1, vec3 f) {
    if (g.format >= SYLVA_GRID_SPARSE_U8) return sylva_grid_trilinear_sparse(SYLVA_PASS_BUF(grid), g, i0, i1, f);
    return sylva_grid_blend(sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i0.x, i0.y, i0.z),
                            sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i1.x, i0.y, i0.z),
                            sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i0.x, i1.y, i0.z),
                            sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i1.x, i1.y, i0.z),
                            sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i0.x, i0.y, i1.z),
                            sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i1.x, i0.y, i1.z),
                            sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i0.x, i1.y, i1.z),
                            sylva_grid_dense_voxel(SYLVA_PASS_BUF(grid), g, i1.x, i1.y, i1.z), f);
}

/// Density of the voxel at signed coordinates (x, y, z): border_value outside the grid.
SYLVA_FN float sylva_grid_voxel_or_border(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, int x, int y, int z) {
    if (x < 0 || y < 0 || z < 0 || uint(x) >= g.dims.x || uint(y) >= g.dims.y || uint(z) >= g.dims.z) {
        return g.border_value;
    }
    return sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), g, uint(x), uint(y), uint(z));
}

/// Trilinear density at world point p, border constant (SYLVA_BORDER_CONSTANT).
SYLVA_FN float sylva_grid_sample_constant(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, vec3 p) {
    SYLVA_PRECISE vec3 v = vec3(p.x / g.spacing.x - 0.5f, p.y / g.spacing.y - 0.5f, p.z / g.spacing.z - 0.5f);
    vec3 u = vec3(sylva_grid_clamp(v.x, -1.0f, float(g.dims.x)), sylva_grid_clamp(v.y, -1.0f, float(g.dims.y)),
                  sylva_grid_clamp(v.z, -1.0f, float(g.dims.z)));
    vec3 fl = vec3(floor(u.x), floor(u.y), floor(u.z));
    int x0 = int(fl.x);
    int y0 = int(fl.y);
    int z0 = int(fl.z);
    SYLVA_PRECISE vec3 f = vec3(u.x - fl.x, u.y - fl.y, u.z - fl.z);
    if (x0 >= 0 && y0 >= 0 && z0 >= 0 && uint(x0) + 1u < g.dims.x && uint(y0) + 1u < g.dims.y &&
        uint(z0) + 1u < g.dims.z) {  // all eight corners inside: the clamped sampler's reads, no border test
        return sylva_grid_trilinear(SYLVA_PASS_BUF(grid), g, uvec3(uint(x0), uint(y0), uint(z0)),
                                    uvec3(uint(x0) + 1u, uint(y0) + 1u, uint(z0) + 1u), f);
    }
    return sylva_grid_blend(sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0, y0, z0),
                            sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0 + 1, y0, z0),
                            sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0, y0 + 1, z0),
                            sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0 + 1, y0 + 1, z0),
                            sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0, y0, z0 + 1),
                            sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0 + 1, y0, z0 + 1),
                            sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0, y0 + 1, z0 + 1),
                            sylva_grid_voxel_or_border(SYLVA_PASS_BUF(grid), g, x0 + 1, y0 + 1, z0 + 1), f);
}

/// Trilinear density at world point p, edges clamped (SYLVA_BORDER_CLAMP).
SYLVA_FN float sylva_grid_sample_clamped(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, vec3 p) {
    uvec3 dims = g.dims;
    vec3 u = vec3(sylva_grid_index(p.x, g.spacing.x, dims.x), sylva_grid_index(p.y, g.spacing.y, dims.y),
                  sylva_grid_index(p.z, g.spacing.z, dims.z));
    uvec3 i0 = uvec3(uint(u.x), uint(u.y), uint(u.z));  // u >= 0: truncation is floor
    uvec3 i1 = uvec3((i0.x + 1u < dims.x) ? i0.x + 1u : i0.x, (i0.y + 1u < dims.y) ? i0.y + 1u : i0.y,
                     (i0.z + 1u < dims.z) ? i0.z + 1u : i0.z);
    SYLVA_PRECISE vec3 f = vec3(u.x - float(i0.x), u.y - float(i0.y), u.z - float(i0.z));
    return sylva_grid_trilinear(SYLVA_PASS_BUF(grid), g, i0, i1, f);
}

/// Trilinear density at world point p of the grid g (format and border mode of g).
SYLVA_FN float sylva_grid_sample(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, vec3 p) {
    if (g.border == SYLVA_BORDER_CONSTANT) return sylva_grid_sample_constant(SYLVA_PASS_BUF(grid), g, p);
    return sylva_grid_sample_clamped(SYLVA_PASS_BUF(grid), g, p);
}

/// Central-difference gradient at world point p from six trilinear samples one voxel away:
/// (d(p + s e_i) - d(p - s e_i)) / 2 per axis, i.e. the change of density across one voxel
/// (the convention of the voxel payload, sylva/shared/voxel.h). Divide by spacing for the
/// world-space gradient. Samples outside the grid follow g's border mode.
SYLVA_FN vec3 sylva_grid_sample_gradient(SYLVA_BUF(grid), SYLVA_IN(SylvaGridDesc) g, vec3 p) {
    vec3 s = g.spacing;
    SYLVA_PRECISE vec3 px0 = vec3(p.x - s.x, p.y, p.z);
    SYLVA_PRECISE vec3 px1 = vec3(p.x + s.x, p.y, p.z);
    SYLVA_PRECISE vec3 py0 = vec3(p.x, p.y - s.y, p.z);
    SYLVA_PRECISE vec3 py1 = vec3(p.x, p.y + s.y, p.z);
    SYLVA_PRECISE vec3 pz0 = vec3(p.x, p.y, p.z - s.z);
    SYLVA_PRECISE vec3 pz1 = vec3(p.x, p.y, p.z + s.z);
    float gx = sylva_grid_sample(SYLVA_PASS_BUF(grid), g, px1) - sylva_grid_sample(SYLVA_PASS_BUF(grid), g, px0);
    float gy = sylva_grid_sample(SYLVA_PASS_BUF(grid), g, py1) - sylva_grid_sample(SYLVA_PASS_BUF(grid), g, py0);
    float gz = sylva_grid_sample(SYLVA_PASS_BUF(grid), g, pz1) - sylva_grid_sample(SYLVA_PASS_BUF(grid), g, pz0);
    return vec3(gx, gy, gz) * 0.5f;
}

/// Trilinear density of a float32 grid, edges clamped (sylva_grid_sample with
/// sylva_grid_f32_clamped; kept for callers that read a plain float grid).
SYLVA_FN float sylva_grid_density(SYLVA_BUF(grid), uvec3 dims, vec3 spacing, vec3 p) {
    return sylva_grid_sample_clamped(SYLVA_PASS_BUF(grid), sylva_grid_f32_clamped(dims, spacing), p);
}

/// sylva_grid_sample_gradient of a float32 grid with edges clamped.
SYLVA_FN vec3 sylva_grid_gradient(SYLVA_BUF(grid), uvec3 dims, vec3 spacing, vec3 p) {
    return sylva_grid_sample_gradient(SYLVA_PASS_BUF(grid), sylva_grid_f32_clamped(dims, spacing), p);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_GRID_SAMPLE_H
