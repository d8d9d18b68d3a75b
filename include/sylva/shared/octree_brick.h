// sylva/shared/octree_brick.h -- the samples of a bricked-octree brick in its format
// (sylva/shared/octree_layout.h: float32, unorm16, unorm8). Read through the `bricks` buffer: a
// GLSL shader including this defines `uint sylva_load_bricks(uint i)` (octree_dvr_main.glsl
// does, over its split brick bindings).
#ifndef SYLVA_SHARED_OCTREE_BRICK_H
#define SYLVA_SHARED_OCTREE_BRICK_H

#include "sylva/shared/octree_layout.h"

#ifdef __cplusplus
#include <array>
#include <cstdint>
#endif

SYLVA_BEGIN_NAMESPACE

/// Normalised density of sample j of the brick whose words start at `base`, in `format`
/// (octree_layout.h): the float bits, or q / 65535, q / 255 (the division as the grid samplers write it).
#ifdef __cplusplus
/// q / 255 for every q, as floats: the host reads unorm8 samples from this table instead of
/// dividing (the same bits; a division at each of a sample's eight corners cost 20 % of the
/// octree's speed).
inline const std::array<float, 256>& sylva_oct_unorm8_table() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (std::uint32_t q = 0; q < 256u; ++q) t[q] = float(q) / 255.0f;
        return t;
    }();
    return table;
}
#endif

/// One load whatever the format (a shader inlines this at every corner of every sample: one
/// load site instead of three keeps its compile small). The host takes float32 samples and
/// unorm8's table first.
SYLVA_FN_HOT float sylva_oct_brick_value(SYLVA_BUF(bricks), uint base, uint format, uint j) {
#ifdef __cplusplus
    if (format == SYLVA_OCT_FORMAT_FLOAT32) return uintBitsToFloat(SYLVA_LOAD(bricks, base + j));
    if (format == SYLVA_OCT_FORMAT_UNORM8)
        return sylva_oct_unorm8_table()[(SYLVA_LOAD(bricks, base + (j >> 2u)) >> ((j & 3u) * 8u)) & 255u];
#endif
    uint lg = (format == SYLVA_OCT_FORMAT_UNORM8) ? 2u : ((format == SYLVA_OCT_FORMAT_UNORM16) ? 1u : 0u);
    uint w = SYLVA_LOAD(bricks, base + (j >> lg));
    if (lg == 0u) return uintBitsToFloat(w);
    uint bits = 32u >> lg;               // 8 or 16
    uint top = (1u << bits) - 1u;        // 255 or 65535
    uint q = (w >> ((j & ((1u << lg) - 1u)) * bits)) & top;
    return float(q) / float(top);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_OCTREE_BRICK_H
