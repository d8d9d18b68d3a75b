// sylva/shared/kd_local_boxes.h -- the local-AABB pass of Zellmann et al.'s GPU kd-tree builder
// (section 4.3): per 8^3 block of a classified volume, the tight box of its occupied voxels.
// The same text runs on the host (sylva/kdtree/gpu_local_boxes.hpp, the reference) and in
// shaders/kd_local_boxes.comp (sylva/vulkan/kd_build.hpp), so both give identical words.
//
// The paper fits each block's box by binary search in an 8^3 partial SVT held in shared
// memory; here one invocation reads its block row by row and OR-reduces three 8-bit masks (the
// x bits of every row, one y and one z bit per row holding an occupied voxel): the lowest and
// highest set bits of each mask are the box, exactly the paper's box, without the table.
//
// Buffers (32-bit words; GLSL picks them by parameter NAME, see lang.h):
//   voxels  the voxels of a slab of whole z-slices [slab_z0, ...), x fastest, packed:
//           uint8 four a word (voxel i in bits 8 (i & 3) ..), uint16 two a word (bits
//           16 (i & 1) ..), float32 one a word (float bits). Voxel indices count from the slab's
//           first voxel and stay below 2^32 (the host cuts slabs to make sure).
//   lut     SYLVA_KD_BOX_CLASSIFY_LUT: bit v (word v >> 5, bit v & 31) set when raw value v is
//           occupied (8 words for uint8, 2048 for uint16)
//   alphas  SYLVA_KD_BOX_CLASSIFY_ALPHA: the transfer function's alpha entries as float bits
//           (TransferFunction::entries()[i].a, not the 8-bit GPU table: the host classifier
//           TransferFunctionAlpha interpolates the float entries, and so does this pass)
//   verdicts one byte a block (block i: word i >> 2, bits 8 (i & 3) ..), what the block's value
//           range decides (kdtree::block_verdicts): SYLVA_KD_BOX_READ (0: read the voxels),
//           _EMPTY (no voxel occupied) or _FULL (every voxel occupied); all zero reads every block
//   params  SYLVA_KD_BOX_PARAM_WORDS words, at word offsets:
//           0-2 grid dimensions x, y, z     3 source (SYLVA_KD_BOX_SOURCE_*)
//           4   classify (SYLVA_KD_BOX_CLASSIFY_*)
//           5   cut (float bits): THRESHOLD occupied when density >= cut; ALPHA when alpha > cut
//           6   range_lo (float bits)       7 range_span (float bits): range_hi - range_lo
//           8   normalise: 1 = density clamp((raw - range_lo) / range_span, 0, 1) (0 when
//               range_span <= 0; the division as written, as volume::normalize) and non-finite
//               raw values are bad (volume::ClassifiedVolume); 0 = density = raw value and only
//               NaN is bad (volume::ClassifiedGrid)
//           9   transfer-function entries (ALPHA; >= 2)
//
// Block word (one per block, blocks numbered x fastest), 0 for an empty block:
//   bits  0-2  box lo.x - 8 bx     bits  3-5  lo.y - 8 by     bits  6-8  lo.z - 8 bz
//   bits  9-11 box hi.x - 1 - 8 bx bits 12-14 hi.y - 1 - 8 by bits 15-17 hi.z - 1 - 8 bz
//   bits 18-27 occupied voxels of the block (0 .. 512; 0 = empty, bits 0-17 then 0)
//   bit  31    a voxel of the block holds a bad float value (the host throws sylva::Error)
#ifndef SYLVA_SHARED_KD_LOCAL_BOXES_H
#define SYLVA_SHARED_KD_LOCAL_BOXES_H

#include "sylva/shared/lang.h"

#define SYLVA_KD_BOX_SOURCE_U8 0u
#define SYLVA_KD_BOX_SOURCE_U16 1u
#define SYLVA_KD_BOX_SOURCE_F32 2u
#define SYLVA_KD_BOX_CLASSIFY_LUT 0u
#define SYLVA_KD_BOX_CLASSIFY_THRESHOLD 1u
#define SYLVA_KD_BOX_CLASSIFY_ALPHA 2u
#define SYLVA_KD_BOX_PARAM_WORDS 10u
#define SYLVA_KD_BOX_BAD 0x80000000u
#define SYLVA_KD_BOX_COUNT_SHIFT 18u
#define SYLVA_KD_BOX_READ 0u
#define SYLVA_KD_BOX_EMPTY 1u
#define SYLVA_KD_BOX_FULL 2u

SYLVA_BEGIN_NAMESPACE

/// The parameter block, decoded once per invocation (slab_z0 comes with the dispatch).
struct SylvaKdBoxParams {
    uvec3 dims;
    uint slab_z0;
    uint source;
    uint classify;
    float cut;
    float range_lo;
    float range_span;
    uint normalise;
    uint tf_entries;
};

/// Reads the parameter block (layout above) for a slab starting at voxel slice `slab_z0`.
SYLVA_FN SylvaKdBoxParams sylva_kd_box_params(SYLVA_BUF(params), uint slab_z0) {
    SylvaKdBoxParams p;
    p.dims = uvec3(SYLVA_LOAD(params, 0u), SYLVA_LOAD(params, 1u), SYLVA_LOAD(params, 2u));
    p.slab_z0 = slab_z0;
    p.source = SYLVA_LOAD(params, 3u);
    p.classify = SYLVA_LOAD(params, 4u);
    p.cut = uintBitsToFloat(SYLVA_LOAD(params, 5u));
    p.range_lo = uintBitsToFloat(SYLVA_LOAD(params, 6u));
    p.range_span = uintBitsToFloat(SYLVA_LOAD(params, 7u));
    p.normalise = SYLVA_LOAD(params, 8u);
    p.tf_entries = SYLVA_LOAD(params, 9u);
    return p;
}

/// True when bit v of a 256-bit table held in two uvec4 (word q of lo for q < 4, else of hi).
SYLVA_FN bool sylva_kd_box_bit256(uvec4 lo, uvec4 hi, uint v) {
    uint q = v >> 5u;
    uvec4 h = (q < 4u) ? lo : hi;
    return ((h[q & 3u] >> (v & 31u)) & 1u) != 0u;
}

/// True when bit v of the value table is set.
SYLVA_FN bool sylva_kd_box_lut(SYLVA_BUF(lut), uint v) { return ((SYLVA_LOAD(lut, v >> 5u) >> (v & 31u)) & 1u) != 0u; }

/// True for NaN (any_nonfinite false) or for NaN and +-infinity (true), from the bits.
SYLVA_FN bool sylva_kd_box_bad(float x, bool any_nonfinite) {
    uint b = floatBitsToUint(x);
    if ((b & 0x7f800000u) != 0x7f800000u) return false;
    return any_nonfinite || (b & 0x007fffffu) != 0u;
}

/// Normalised density of a raw float value: volume::detail::normalised (clamped), or the value
/// itself for a density grid.
SYLVA_FN float sylva_kd_box_density(SylvaKdBoxParams p, float x) {
    if (p.normalise == 0u) return x;
    if (!(p.range_span > 0.0f)) return 0.0f;
    SYLVA_PRECISE float d = (x - p.range_lo) / p.range_span;
    return (d > 1.0f) ? 1.0f : ((d > 0.0f) ? d : 0.0f);
}

/// Alpha of density d, interpolated between the float entries exactly as
/// volume::TransferFunction::at: x = clamp(d, 0, 1) (N - 1), i = min(floor(x), N - 2).
SYLVA_FN float sylva_kd_box_alpha(SYLVA_BUF(alphas), uint entries, float d) {
    float n1 = float(entries - 1u);
    float c = (d > 0.0f) ? ((1.0f < d) ? 1.0f : d) : 0.0f;
    SYLVA_PRECISE float x = c * n1;
    uint i = uint(x);
    if (i > entries - 2u) i = entries - 2u;
    SYLVA_PRECISE float f = x - float(i);
    float a0 = uintBitsToFloat(SYLVA_LOAD(alphas, i));
    float a1 = uintBitsToFloat(SYLVA_LOAD(alphas, i + 1u));
    SYLVA_PRECISE float a = a0 + (a1 - a0) * f;
    return a;
}

/// Classifies one float voxel: 0 empty, 1 occupied, 2 a bad value (counted empty).
SYLVA_FN uint sylva_kd_box_float(SYLVA_BUF(alphas), SylvaKdBoxParams p, float x) {
    if (sylva_kd_box_bad(x, p.normalise != 0u)) return 2u;
    float d = sylva_kd_box_density(p, x);
    if (p.classify == SYLVA_KD_BOX_CLASSIFY_THRESHOLD) return (d >= p.cut) ? 1u : 0u;
    return (sylva_kd_box_alpha(SYLVA_PASS_BUF(alphas), p.tf_entries, d) > p.cut) ? 1u : 0u;
}

/// The occupancy mask of the n (<= 8) voxels of a row starting at slab voxel `at` (bit k =
/// voxel at + k), plus 256 when one of them holds a bad float value. Integer voxels are read a
/// word at a time (four uint8 or two uint16 a load); uint8 values look up the 256-bit table
/// (lut_lo, lut_hi), uint16 values the `lut` buffer.
SYLVA_FN uint sylva_kd_box_row(SYLVA_BUF(voxels), SYLVA_BUF(lut), SYLVA_BUF(alphas), SylvaKdBoxParams p, uvec4 lut_lo,
                               uvec4 lut_hi, uint at, uint n) {
    uint m = 0u;
    if (p.source == SYLVA_KD_BOX_SOURCE_U8 && n == 8u) {  // a whole row: eight bytes from two or three words
        uint w = at >> 2u;
        uint s = (at & 3u) * 8u;
        uint w0 = SYLVA_LOAD(voxels, w);
        uint w1 = SYLVA_LOAD(voxels, w + 1u);
        uint lo = w0;
        uint hi = w1;
        if (s != 0u) {
            uint w2 = SYLVA_LOAD(voxels, w + 2u);
            lo = (w0 >> s) | (w1 << (32u - s));
            hi = (w1 >> s) | (w2 << (32u - s));
        }
        for (uint k = 0u; k < 4u; k++) {
            if (sylva_kd_box_bit256(lut_lo, lut_hi, (lo >> (k * 8u)) & 255u)) m = m | (1u << k);
            if (sylva_kd_box_bit256(lut_lo, lut_hi, (hi >> (k * 8u)) & 255u)) m = m | (16u << k);
        }
        return m;
    }
    if (p.source == SYLVA_KD_BOX_SOURCE_U16 && n == 8u && (at & 1u) == 0u) {  // a whole aligned row: four words
        for (uint k = 0u; k < 4u; k++) {
            uint w = SYLVA_LOAD(voxels, (at >> 1u) + k);
            if (sylva_kd_box_lut(SYLVA_PASS_BUF(lut), w & 65535u)) m = m | (1u << (2u * k));
            if (sylva_kd_box_lut(SYLVA_PASS_BUF(lut), w >> 16u)) m = m | (2u << (2u * k));
        }
        return m;
    }
    uint cur = 0u;
    for (uint k = 0u; k < n; k++) {
        uint i = at + k;
        uint v = 0u;
        if (p.source == SYLVA_KD_BOX_SOURCE_U8) {
            if (k == 0u || (i & 3u) == 0u) cur = SYLVA_LOAD(voxels, i >> 2u);
            v = sylva_kd_box_bit256(lut_lo, lut_hi, (cur >> ((i & 3u) * 8u)) & 255u) ? 1u : 0u;
        } else if (p.source == SYLVA_KD_BOX_SOURCE_U16) {
            if (k == 0u || (i & 1u) == 0u) cur = SYLVA_LOAD(voxels, i >> 1u);
            v = sylva_kd_box_lut(SYLVA_PASS_BUF(lut), (cur >> ((i & 1u) * 16u)) & 65535u) ? 1u : 0u;
        } else {
            v = sylva_kd_box_float(SYLVA_PASS_BUF(alphas), p, uintBitsToFloat(SYLVA_LOAD(voxels, i)));
        }
        if (v == 1u) m = m | (1u << k);
        if (v == 2u) m = m | 256u;
    }
    return m;
}

/// The block word from the three OR-reduced masks, the count and the bad flag.
SYLVA_FN uint sylva_kd_box_word(uint mx, uint my, uint mz, uint count, bool bad) {
    uint w = bad ? SYLVA_KD_BOX_BAD : 0u;
    if (count == 0u) return w;
    w = w | uint(findLSB(mx)) | (uint(findLSB(my)) << 3u) | (uint(findLSB(mz)) << 6u);
    w = w | (uint(findMSB(mx)) << 9u) | (uint(findMSB(my)) << 12u) | (uint(findMSB(mz)) << 15u);
    return w | (count << SYLVA_KD_BOX_COUNT_SHIFT);
}

/// Masks and count of one 8^3 block while its rows are read (the one accumulation every pass
/// uses: this shader's blocks and the host's rows of blocks, sylva/kdtree/local_boxes.hpp and
/// gpu_local_boxes.hpp): bit i of mx is set when a voxel with local x = i is occupied, likewise
/// my and mz; count is the number of occupied voxels.
struct SylvaKdBoxAcc {
    uint mx;
    uint my;
    uint mz;
    uint count;
};

SYLVA_FN SylvaKdBoxAcc sylva_kd_box_acc_zero() {
    SylvaKdBoxAcc a;
    a.mx = 0u;
    a.my = 0u;
    a.mz = 0u;
    a.count = 0u;
    return a;
}

/// ORs the occupancy mask m (bit k = local x k) of the block's row at local (ly, lz) into a.
SYLVA_FN void sylva_kd_box_accumulate(SYLVA_INOUT(SylvaKdBoxAcc) a, uint m, uint ly, uint lz) {
    if (m == 0u) return;
    a.mx = a.mx | m;
    a.my = a.my | (1u << ly);
    a.mz = a.mz | (1u << lz);
    a.count = a.count + uint(bitCount(m));
}

/// The block word of an accumulated block.
SYLVA_FN uint sylva_kd_box_acc_word(SylvaKdBoxAcc a, bool bad) {
    return sylva_kd_box_word(a.mx, a.my, a.mz, a.count, bad);
}

/// The block word of block `b` (block coordinates; its voxels must lie in the slab).
SYLVA_FN uint sylva_kd_box_block(SYLVA_BUF(voxels), SYLVA_BUF(lut), SYLVA_BUF(alphas), SylvaKdBoxParams p, uvec3 b) {
    uvec4 lut_lo = uvec4(0u);
    uvec4 lut_hi = uvec4(0u);
    if (p.source == SYLVA_KD_BOX_SOURCE_U8) {
        lut_lo = uvec4(SYLVA_LOAD(lut, 0u), SYLVA_LOAD(lut, 1u), SYLVA_LOAD(lut, 2u), SYLVA_LOAD(lut, 3u));
        lut_hi = uvec4(SYLVA_LOAD(lut, 4u), SYLVA_LOAD(lut, 5u), SYLVA_LOAD(lut, 6u), SYLVA_LOAD(lut, 7u));
    }
    uvec3 base = uvec3(b.x * 8u, b.y * 8u, b.z * 8u);
    uvec3 n = uvec3(min(8u, p.dims.x - base.x), min(8u, p.dims.y - base.y), min(8u, p.dims.z - base.z));
    SylvaKdBoxAcc acc = sylva_kd_box_acc_zero();
    bool bad = false;
    for (uint z = 0u; z < n.z; z++) {
        for (uint y = 0u; y < n.y; y++) {
            uint at = base.x + p.dims.x * (base.y + y + p.dims.y * (base.z + z - p.slab_z0));
            uint r = sylva_kd_box_row(SYLVA_PASS_BUF(voxels), SYLVA_PASS_BUF(lut), SYLVA_PASS_BUF(alphas), p, lut_lo,
                                      lut_hi, at, n.x);
            if (r > 255u) bad = true;
            sylva_kd_box_accumulate(acc, r & 255u, y, z);
        }
    }
    return sylva_kd_box_acc_word(acc, bad);
}

/// The block word of block `b` when every one of its voxels is occupied (edge blocks clipped).
SYLVA_FN uint sylva_kd_box_full_word(uvec3 dims, uvec3 b) {
    uvec3 n = uvec3(min(8u, dims.x - b.x * 8u), min(8u, dims.y - b.y * 8u), min(8u, dims.z - b.z * 8u));
    return sylva_kd_box_word((1u << n.x) - 1u, (1u << n.y) - 1u, (1u << n.z) - 1u, n.x * n.y * n.z, false);
}

/// The verdict of block `i` (byte i of `verdicts`): SYLVA_KD_BOX_READ, _EMPTY or _FULL.
SYLVA_FN uint sylva_kd_box_verdict(SYLVA_BUF(verdicts), uint i) {
    return (SYLVA_LOAD(verdicts, i >> 2u) >> ((i & 3u) * 8u)) & 255u;
}

/// The word of block `b` (linear index i): decided by its verdict, else read.
SYLVA_FN uint sylva_kd_box_decide(SYLVA_BUF(voxels), SYLVA_BUF(lut), SYLVA_BUF(alphas), SYLVA_BUF(verdicts),
                                  SylvaKdBoxParams p, uvec3 b, uint i) {
    uint v = sylva_kd_box_verdict(SYLVA_PASS_BUF(verdicts), i);
    if (v == SYLVA_KD_BOX_EMPTY) return 0u;
    if (v == SYLVA_KD_BOX_FULL) return sylva_kd_box_full_word(p.dims, b);
    return sylva_kd_box_block(SYLVA_PASS_BUF(voxels), SYLVA_PASS_BUF(lut), SYLVA_PASS_BUF(alphas), p, b);
}

/// Fields of a block word: local box corners (lo, hi - 1, each 0..7) and the count.
SYLVA_FN uvec3 sylva_kd_box_word_lo(uint w) { return uvec3(w & 7u, (w >> 3u) & 7u, (w >> 6u) & 7u); }
SYLVA_FN uvec3 sylva_kd_box_word_last(uint w) { return uvec3((w >> 9u) & 7u, (w >> 12u) & 7u, (w >> 15u) & 7u); }
SYLVA_FN uint sylva_kd_box_word_count(uint w) { return (w >> SYLVA_KD_BOX_COUNT_SHIFT) & 1023u; }

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_KD_LOCAL_BOXES_H
