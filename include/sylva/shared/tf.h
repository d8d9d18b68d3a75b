// sylva/shared/tf.h -- the 1D transfer function lookup of the volume integrators (Kinkelin
// section 6.2: "a 1D RGBA texture, 256 texels wide and using 8 bits per component").
//
// GPU format (shared with sylva/volume/transfer_function.hpp): a buffer `tf` of `entries` words,
// one straight (not premultiplied) RGBA8 colour each:
//   bits  0-7   red      bits  8-15  green      bits 16-23  blue      bits 24-31  alpha
// Entry i holds the classification of normalised density i / (entries - 1); densities between
// two entries interpolate linearly, densities outside [0, 1] (and NaN, as 0) clamp to the ends.
// Alpha is the opacity of a sample of length `unit` (see dvr_common.h, opacity correction).
#ifndef SYLVA_SHARED_TF_H
#define SYLVA_SHARED_TF_H

#include "sylva/shared/lang.h"

SYLVA_BEGIN_NAMESPACE

/// One RGBA8 word as straight colour in [0, 1].
SYLVA_FN vec4 sylva_tf_texel(uint c) {
    return vec4(float(c & 255u), float((c >> 8u) & 255u), float((c >> 16u) & 255u), float(c >> 24u)) *
           (1.0f / 255.0f);
}

/// x clamped to [0, 1]; NaN becomes 0 (never relies on how min/max treat NaN).
SYLVA_FN float sylva_tf_clamp01(float x) { return (x > 1.0f) ? 1.0f : ((x > 0.0f) ? x : 0.0f); }

/// a + (b - a) f per component, never contracted into fma (host/GPU parity).
SYLVA_FN vec4 sylva_tf_lerp(vec4 a, vec4 b, float f) {
    SYLVA_PRECISE vec4 r = vec4(a.x + (b.x - a.x) * f, a.y + (b.y - a.y) * f, a.z + (b.z - a.z) * f,
                                a.w + (b.w - a.w) * f);
    return r;
}

/// Straight RGBA of normalised density d: linear between the entries of `tf`, clamped at the
/// ends. `entries` is the number of words in `tf`; 0 gives transparent black.
SYLVA_FN vec4 sylva_tf_lookup(SYLVA_BUF(tf), uint entries, float d) {
    if (entries == 0u) return vec4(0.0f);
    uint last = entries - 1u;
    SYLVA_PRECISE float x = sylva_tf_clamp01(d) * float(last);
    uint i0 = uint(x);  // x >= 0: truncation is floor
    if (i0 > last) i0 = last;
    uint i1 = (i0 < last) ? i0 + 1u : last;
    SYLVA_PRECISE float f = x - float(i0);
    return sylva_tf_lerp(sylva_tf_texel(SYLVA_LOAD(tf, i0)), sylva_tf_texel(SYLVA_LOAD(tf, i1)), f);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_TF_H
