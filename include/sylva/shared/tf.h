// sylva/shared/tf.h -- the 1D transfer function of the volume integrators (Kinkelin section
// 6.2: "a 1D RGBA texture, 256 texels wide and using 8 bits per component"), in three kinds
// (parameter word 36, SYLVA_TF_KIND_*; sylva/shared/dvr_classify.h picks one):
//
// SYLVA_TF_KIND_RGBA8 (shared with sylva/volume/transfer_function.hpp): a buffer `tf` of
// `entries` words, one straight (not premultiplied) RGBA8 colour each:
//   bits  0-7   red      bits  8-15  green      bits 16-23  blue      bits 24-31  alpha
// SYLVA_TF_KIND_RGBA32F: a buffer `tf` of 4 `entries` words, entry i at words 4i .. 4i + 3: the
// float bits of straight red, green, blue, alpha (any size >= 1; 1 entry is a constant TF).
// Both: entry i holds the classification of normalised density i / (entries - 1); densities
// between two entries interpolate linearly, densities outside [0, 1] (and NaN, as 0) clamp to
// the ends.
// SYLVA_TF_KIND_HOOK: a function of the density, no table. In GLSL the shader defines
//   #define SYLVA_TF_USER
// before including (with `#define SYLVA_NO_TF` when it binds no table, lang.h) and defines
//   vec4 sylva_tf_user(float d) { ... }      // straight RGBA of normalised density d
// anywhere in the shader (declared here, so it may follow the includes); a shader
// without SYLVA_TF_USER classifies everything transparent under the hook kind. On the host the
// TF buffer view carries the callable (sylva::shared::Words::hook, set by the renderers from
// VolumeRenderParams::tf_hook). One shared-subset definition serves both (see
// tests/dvr/shaders/analytic_tf.h: the alpha = clamp((d - 0.1) / 0.9, 0, 1) 0.4).
// Alpha is the opacity of a sample of length `unit` (see dvr_common.h, opacity correction).
#ifndef SYLVA_SHARED_TF_H
#define SYLVA_SHARED_TF_H

#include "sylva/shared/lang.h"

#define SYLVA_TF_KIND_RGBA8 0u
#define SYLVA_TF_KIND_RGBA32F 1u
#define SYLVA_TF_KIND_HOOK 2u

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

/// Entry i of a float RGBA table: words 4i .. 4i + 3 as float bits.
SYLVA_FN vec4 sylva_tf_texel_f32(SYLVA_BUF(tf), uint i) {
    uint at = i * 4u;
    return vec4(uintBitsToFloat(SYLVA_LOAD(tf, at)), uintBitsToFloat(SYLVA_LOAD(tf, at + 1u)),
                uintBitsToFloat(SYLVA_LOAD(tf, at + 2u)), uintBitsToFloat(SYLVA_LOAD(tf, at + 3u)));
}

/// Straight RGBA of normalised density d from a float RGBA table of `entries` entries (4 words
/// each): the same interpolation and clamping as sylva_tf_lookup; 0 entries give transparent black.
SYLVA_FN vec4 sylva_tf_lookup_f32(SYLVA_BUF(tf), uint entries, float d) {
    if (entries == 0u) return vec4(0.0f);
    uint last = entries - 1u;
    SYLVA_PRECISE float x = sylva_tf_clamp01(d) * float(last);
    uint i0 = uint(x);  // x >= 0: truncation is floor
    if (i0 > last) i0 = last;
    uint i1 = (i0 < last) ? i0 + 1u : last;
    SYLVA_PRECISE float f = x - float(i0);
    return sylva_tf_lerp(sylva_tf_texel_f32(SYLVA_PASS_BUF(tf), i0), sylva_tf_texel_f32(SYLVA_PASS_BUF(tf), i1), f);
}

#if !defined(__cplusplus) && defined(SYLVA_TF_USER)
vec4 sylva_tf_user(float d);  // the shader defines it, before or after including this header
#endif

/// The hook kind: the shader's sylva_tf_user (GLSL, SYLVA_TF_USER defined) or the callable the
/// host's TF view carries; transparent black without one.
SYLVA_FN vec4 sylva_tf_hook(SYLVA_BUF(tf), float d) {
#ifdef __cplusplus
    return (tf.hook != nullptr && *tf.hook) ? (*tf.hook)(d) : vec4(0.0f);
#elif defined(SYLVA_TF_USER)
    return sylva_tf_user(d);
#else
    return vec4(0.0f);
#endif
}

/// Straight RGBA of normalised density d for a TF of kind `kind` (SYLVA_TF_KIND_*) with
/// `entries` entries (tables) in `tf`.
SYLVA_FN vec4 sylva_tf_classify(SYLVA_BUF(tf), uint kind, uint entries, float d) {
    if (kind == SYLVA_TF_KIND_RGBA32F) return sylva_tf_lookup_f32(SYLVA_PASS_BUF(tf), entries, d);
    if (kind == SYLVA_TF_KIND_HOOK) return sylva_tf_hook(SYLVA_PASS_BUF(tf), d);
    return sylva_tf_lookup(SYLVA_PASS_BUF(tf), entries, d);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_TF_H
