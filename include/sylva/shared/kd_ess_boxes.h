// sylva/shared/kd_ess_boxes.h -- the occupancy of empty-space-skipping DVR (the voxels whose
// 3x3x3 neighbourhood reaches a visible TF segment; sylva/render/ess_occupancy.hpp) for the
// 8^3 blocks the block ranges leave open, on the device: one invocation per column of 8 rows
// (ly fixed, lz = 0 .. 7) of a block, their occupancy masks. The same text runs on the host
// (the reference, sylva/vulkan/kd_ess.hpp) and in shaders/kd_ess_boxes.comp, so both give
// identical masks; the host folds a block's 64 row masks into its block word
// (sylva/shared/kd_local_boxes.h) and the binned builder takes it from there (Zellmann et al.
// section 4.3).
//
// Per voxel: lo / hi = the least / greatest density of its neighbourhood (neighbours outside
// the grid left out; reading a clamped coordinate again reads a voxel already in it), then
// lo' = clamp(lo - 2^-20, -1, 2), hi' = clamp(hi + 2^-20, -1, 2) (the margin of the three
// trilinear lerps, kEssEps), a voxel on a face of the grid also takes in the border's range
// [border_lo, border_hi] (constant border: value -+ 2^-20; clamped: +inf / -inf, neutral),
// and the voxel is occupied when a visible bucket lies in [bucket(lo'), bucket(hi')] with
// bucket(d) = s 256 / N, s = min(uint(clamp01(d) (N - 1)), N - 1): the arithmetic of
// EssBucketMap and EssClassifier on the host, bit for bit.
//
// Buffers (32-bit words; GLSL picks them by parameter NAME, see lang.h):
//   grid     the marcher's grid words, any SYLVA_GRID_* format (sylva/shared/grid_sample.h)
//   visible  257 words: visible[b] = visible buckets below bucket b (visible[0] = 0), the
//            prefix count of EssClassifier
//   params   SYLVA_KD_ESS_PARAM_WORDS words, at word offsets:
//            0-2 grid dimensions x, y, z   3 grid format (SYLVA_GRID_*)
//            4 value_lo, 5 value_span (float bits; integer formats)
//            6 border_lo, 7 border_hi (float bits)   8 TF entries N (2 .. 2^24)
#ifndef SYLVA_SHARED_KD_ESS_BOXES_H
#define SYLVA_SHARED_KD_ESS_BOXES_H

#include "sylva/shared/grid_sample.h"
#include "sylva/shared/lang.h"

#define SYLVA_KD_ESS_PARAM_WORDS 9u
/// The margin around a neighbourhood's density range (kEssEps on the host): 2^-20.
#define SYLVA_KD_ESS_EPS 9.5367431640625e-07f

SYLVA_BEGIN_NAMESPACE

/// The parameter block, decoded.
struct SylvaKdEssParams {
    SylvaGridDesc grid;
    float border_lo;
    float border_hi;
    uint entries;
};

/// Reads the parameter block (layout above).
SYLVA_FN SylvaKdEssParams sylva_kd_ess_params(SYLVA_BUF(params)) {
    SylvaKdEssParams p;
    p.grid.dims = uvec3(SYLVA_LOAD(params, 0u), SYLVA_LOAD(params, 1u), SYLVA_LOAD(params, 2u));
    p.grid.spacing = vec3(1.0f);
    p.grid.border = SYLVA_BORDER_CLAMP;
    p.grid.border_value = 0.0f;
    p.grid.format = SYLVA_LOAD(params, 3u);
    p.grid.value_lo = uintBitsToFloat(SYLVA_LOAD(params, 4u));
    p.grid.value_span = uintBitsToFloat(SYLVA_LOAD(params, 5u));
    p.border_lo = uintBitsToFloat(SYLVA_LOAD(params, 6u));
    p.border_hi = uintBitsToFloat(SYLVA_LOAD(params, 7u));
    p.entries = SYLVA_LOAD(params, 8u);
    return p;
}

/// x held in [lo, hi] (no NaN reaches it: the host's range pass refuses NaN densities).
SYLVA_FN float sylva_kd_ess_hold(float x, float lo, float hi) { return (x < lo) ? lo : ((x > hi) ? hi : x); }

/// Bucket of density d for a TF of n entries (EssBucketMap): s 256 / n of its segment s.
SYLVA_FN uint sylva_kd_ess_bucket(float d, uint n) {
    float c = (d > 1.0f) ? 1.0f : ((d > 0.0f) ? d : 0.0f);
    SYLVA_PRECISE float x = c * float(n - 1u);
    uint s = min(uint(x), n - 1u);
    return (s * 256u) / n;  // s < 2^24: no overflow
}

/// True when a visible bucket lies in [lo, hi] (EssClassifier::visible_in != 0).
SYLVA_FN bool sylva_kd_ess_visible(SYLVA_BUF(visible), uint lo, uint hi) {
    return hi >= lo && SYLVA_LOAD(visible, hi + 1u) != SYLVA_LOAD(visible, lo);
}

/// Coordinate c + d - 1 (d in 0..2) held inside [0, n - 1].
SYLVA_FN uint sylva_kd_ess_near(uint c, uint d, uint n) {
    int v = int(c) + int(d) - 1;
    return uint((v < 0) ? 0 : ((v > int(n) - 1) ? int(n) - 1 : v));
}

/// The 3x3 (y, z) and then 3-wide (x) density range of the 8 voxels x0 .. x0 + 7 of row (y,
/// z): components 0-3 of lo0 / hi0 are voxels x0 .. x0 + 3, of lo1 / hi1 the next four.
/// Coordinates outside the grid are held at its faces (a voxel already in the range).
struct SylvaKdEssSlice {
    vec4 lo0;
    vec4 lo1;
    vec4 hi0;
    vec4 hi1;
};

SYLVA_FN float sylva_kd_ess_min3(float a, float b, float c) {
    float m = (b < a) ? b : a;
    return (c < m) ? c : m;
}

SYLVA_FN float sylva_kd_ess_max3(float a, float b, float c) {
    float m = (b > a) ? b : a;
    return (c > m) ? c : m;
}

/// The ranges of row (y, z) over the rows y - 1 .. y + 1 of slice z (30 voxel reads).
SYLVA_FN SylvaKdEssSlice sylva_kd_ess_slice(SYLVA_BUF(grid), SYLVA_IN(SylvaKdEssParams) p, uint x0, uint y, uint z) {
    uvec3 d = p.grid.dims;
    float clo[10];
    float chi[10];
    for (uint c = 0u; c < 10u; c++) {
        uint x = sylva_kd_ess_near(x0, c, d.x);
        float v0 = sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), p.grid, x, sylva_kd_ess_near(y, 0u, d.y), z);
        float v1 = sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), p.grid, x, y, z);
        float v2 = sylva_grid_voxel_of(SYLVA_PASS_BUF(grid), p.grid, x, sylva_kd_ess_near(y, 2u, d.y), z);
        clo[c] = sylva_kd_ess_min3(v0, v1, v2);
        chi[c] = sylva_kd_ess_max3(v0, v1, v2);
    }
    SylvaKdEssSlice r;
    r.lo0 = vec4(sylva_kd_ess_min3(clo[0], clo[1], clo[2]), sylva_kd_ess_min3(clo[1], clo[2], clo[3]),
                 sylva_kd_ess_min3(clo[2], clo[3], clo[4]), sylva_kd_ess_min3(clo[3], clo[4], clo[5]));
    r.lo1 = vec4(sylva_kd_ess_min3(clo[4], clo[5], clo[6]), sylva_kd_ess_min3(clo[5], clo[6], clo[7]),
                 sylva_kd_ess_min3(clo[6], clo[7], clo[8]), sylva_kd_ess_min3(clo[7], clo[8], clo[9]));
    r.hi0 = vec4(sylva_kd_ess_max3(chi[0], chi[1], chi[2]), sylva_kd_ess_max3(chi[1], chi[2], chi[3]),
                 sylva_kd_ess_max3(chi[2], chi[3], chi[4]), sylva_kd_ess_max3(chi[3], chi[4], chi[5]));
    r.hi1 = vec4(sylva_kd_ess_max3(chi[4], chi[5], chi[6]), sylva_kd_ess_max3(chi[5], chi[6], chi[7]),
                 sylva_kd_ess_max3(chi[6], chi[7], chi[8]), sylva_kd_ess_max3(chi[7], chi[8], chi[9]));
    return r;
}

/// The occupancy mask (bit k: voxel x0 + k) of the row whose neighbourhood ranges are
/// [lo, hi] (n voxels; face_row: the row lies on a face of the grid).
SYLVA_FN uint sylva_kd_ess_mask(SYLVA_BUF(visible), SYLVA_IN(SylvaKdEssParams) p, vec4 lo0, vec4 lo1, vec4 hi0, vec4 hi1,
                                uint x0, uint n, bool face_row) {
    uint m = 0u;
    for (uint k = 0u; k < n; k++) {
        float lo = (k < 4u) ? lo0[k & 3u] : lo1[k & 3u];
        float hi = (k < 4u) ? hi0[k & 3u] : hi1[k & 3u];
        SYLVA_PRECISE float lm = lo - SYLVA_KD_ESS_EPS;
        SYLVA_PRECISE float hm = hi + SYLVA_KD_ESS_EPS;
        lm = sylva_kd_ess_hold(lm, -1.0f, 2.0f);
        hm = sylva_kd_ess_hold(hm, -1.0f, 2.0f);
        if (face_row || x0 + k == 0u || x0 + k + 1u == p.grid.dims.x) {
            lm = (p.border_lo < lm) ? p.border_lo : lm;
            hm = (p.border_hi > hm) ? p.border_hi : hm;
        }
        if (sylva_kd_ess_visible(SYLVA_PASS_BUF(visible), sylva_kd_ess_bucket(lm, p.entries),
                                 sylva_kd_ess_bucket(hm, p.entries)))
            m = m | (1u << k);
    }
    return m;
}

/// The occupancy masks of the 8 rows (ly, lz = 0 .. 7) of block b: the mask of row lz in bits
/// 8 (lz & 3) .. of component lz >> 2 (bit k: voxel 8 b.x + k). Rows outside the grid are 0,
/// and so are bits past its last voxel. The slices' ranges roll along z: 10 slices of 30 reads
/// for 8 rows.
SYLVA_FN uvec2 sylva_kd_ess_column(SYLVA_BUF(grid), SYLVA_BUF(visible), SYLVA_IN(SylvaKdEssParams) p, uvec3 b, uint ly) {
    uvec3 d = p.grid.dims;
    uint x0 = b.x * 8u;
    uint y = b.y * 8u + ly;
    uint z0 = b.z * 8u;
    uvec2 out_masks = uvec2(0u);
    if (y >= d.y || z0 >= d.z || x0 >= d.x) return out_masks;
    uint n = min(8u, d.x - x0);
    uint nz = min(8u, d.z - z0);
    // Slices z0 - 1 .. z0 + nz (held in the grid), one call site (a smaller kernel to compile):
    // a, c, e are the last three; row lz = s - 2 once three are in.
    SylvaKdEssSlice a;
    SylvaKdEssSlice c;
    a.lo0 = vec4(0.0f), a.lo1 = vec4(0.0f), a.hi0 = vec4(0.0f), a.hi1 = vec4(0.0f);
    c = a;
    for (uint s = 0u; s < nz + 2u; s++) {
        uint z = (s == 0u) ? sylva_kd_ess_near(z0, 0u, d.z) : min(z0 + s - 1u, d.z - 1u);
        SylvaKdEssSlice e = sylva_kd_ess_slice(SYLVA_PASS_BUF(grid), p, x0, y, z);
        if (s >= 2u) {
            uint lz = s - 2u;
            bool face_row = y == 0u || y + 1u == d.y || z0 + lz == 0u || z0 + lz + 1u == d.z;
            uint m = sylva_kd_ess_mask(SYLVA_PASS_BUF(visible), p, min(min(a.lo0, c.lo0), e.lo0), min(min(a.lo1, c.lo1), e.lo1),
                                       max(max(a.hi0, c.hi0), e.hi0), max(max(a.hi1, c.hi1), e.hi1), x0, n, face_row);
            if (lz < 4u) out_masks.x = out_masks.x | (m << (8u * lz));
            else out_masks.y = out_masks.y | (m << (8u * (lz - 4u)));
        }
        a = c;
        c = e;
    }
    return out_masks;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_ESS_BOXES_H
