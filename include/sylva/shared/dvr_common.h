// sylva/shared/dvr_common.h -- what every volume integrator shares (the reference marcher of
// dvr.h and the BIH renderers of bih_dvr.h): the parameter block, the global sample lattice,
// opacity correction, front-to-back compositing and Lambert/Blinn-Phong shading.
//
// Rays. Integrators normalise the ray direction first, so the ray parameter t is the world
// distance from the ray origin (the eye). The sample lattice is global: sample k sits at
// t_k = fl(k * dt) for integers k >= 0, whatever box or leaf the ray is in, so consecutive
// segments (the grid box of the marcher, the leaves of multi-sample BIH-DVR; Kinkelin 4.3)
// keep equidistant samples. A segment [t0, t1) owns the samples with t0 <= t_k < t1.
//
// Opacity. The TF's alpha is the opacity of a sample of length `unit` (world units): a
// segment of length l gets alpha' = 1 - (1 - alpha)^(l / unit) (Kinkelin 4.3, opacity
// correction), so images do not depend on dt beyond sampling error.
//
// Parameter block: a buffer `params` of SYLVA_DVR_PARAM_WORDS words, the same on host and GPU
// (sylva/render/volume.hpp writes it), word offset: meaning
//   0-11   camera: eye, forward w, right u, up v (float bits; sylva/shared/camera.h)
//   12     image width        13  image height
//   14     mode: SYLVA_VOLUME_MODE_*
//   15     flags: bit 0 shading on, bit 1 iso culling by the node-range buffer (bih_iter.h)
//   16     dt: lattice spacing (world units, > 0)
//   17     unit: the length whose opacity the TF's alpha is (world units, > 0)
//   18     alpha_stop: early ray termination once the opacity reaches it (> 1: never)
//   19     iso value (normalised density)
//   20-22  light direction towards the light, unit length; (0, 0, 0) = headlight
//   23-26  ambient, diffuse, specular weights, Blinn-Phong shininess
//   27     number of TF entries (words of the `tf` buffer)
//   28-30  grid dimensions in voxels (marcher)
//   31-33  voxel size in world units (grid spacing; the BIH leaves' voxel size)
//   34     word count of the encoded BIH (BIH modes)
//   35     ray source: SYLVA_RAYS_* (pinhole camera from words 0-11, orthographic camera from
//          words 0-11, or the caller's ray buffer)
//   36     transfer function kind: SYLVA_TF_KIND_* (RGBA8 table, float RGBA table, shader hook)
//   37     opacity correction: SYLVA_OPACITY_* (exact power of Kinkelin 4.3, or none)
//   38     border mode of the grid samplers: SYLVA_BORDER_* (clamp to edge, or a constant)
//   39     border value (float bits; the normalised density read outside the grid)
//   40     grid voxel format: SYLVA_GRID_* (float32, uint8, uint16; sparse 8^3 bricks of uint8, uint16)
//   41     value offset lo (float bits): density = (raw - lo) / (hi - lo) for integer formats
//   42     value span hi - lo (float bits, > 0; the division is exact as written, v / max)
//   43     entries of the octree's opacity prefix table (sylva/shared/octree_dvr.h; the TF's
//          own entries, or a hook's sampled visibility: render/octree_volume.hpp); 0: word 27
//   44-47  reserved, 0
#ifndef SYLVA_SHARED_DVR_COMMON_H
#define SYLVA_SHARED_DVR_COMMON_H

#include "sylva/shared/lang.h"
#include "sylva/shared/tf.h"

#define SYLVA_DVR_PARAM_WORDS 48u
#define SYLVA_VOLUME_MODE_DVR 0u
#define SYLVA_VOLUME_MODE_BIH_SINGLE 1u
#define SYLVA_VOLUME_MODE_BIH_MULTI 2u
#define SYLVA_VOLUME_MODE_BIH_ISO 3u
#define SYLVA_DVR_FLAG_SHADING 1u
#define SYLVA_DVR_FLAG_ISO_CULLING 2u
#define SYLVA_RAYS_PINHOLE 0u
#define SYLVA_RAYS_ORTHO 1u
#define SYLVA_RAYS_BUFFER 2u
#define SYLVA_TF_KIND_RGBA8 0u
#define SYLVA_TF_KIND_RGBA32F 1u
#define SYLVA_TF_KIND_HOOK 2u
#define SYLVA_OPACITY_POWER 0u
#define SYLVA_OPACITY_NONE 1u
#define SYLVA_BORDER_CLAMP 0u
#define SYLVA_BORDER_CONSTANT 1u
#define SYLVA_GRID_F32 0u
#define SYLVA_GRID_U8 1u
#define SYLVA_GRID_U16 2u
#define SYLVA_GRID_SPARSE_U8 3u
#define SYLVA_GRID_SPARSE_U16 4u
/// Hard cap on the samples of one ray (loops stay bounded whatever the parameters).
#define SYLVA_DVR_MAX_SAMPLES 16777216u

SYLVA_BEGIN_NAMESPACE

/// The decoded parameter block (see the layout above).
struct SylvaDvrParams {
    uint width;
    uint height;
    uint mode;
    uint flags;
    float dt;
    float unit;
    float alpha_stop;
    float iso;
    vec3 light;
    float ambient;
    float diffuse;
    float specular;
    float shininess;
    uint tf_entries;
    uvec3 dims;
    vec3 spacing;
    uint word_count;
    uint ray_source;
    uint tf_kind;
    uint opacity;
    uint border;
    float border_value;
    uint grid_format;
    float value_lo;
    float value_span;
    uint skip_entries;
};

SYLVA_FN float sylva_param_f(SYLVA_BUF(params), uint at) { return uintBitsToFloat(SYLVA_LOAD(params, at)); }
SYLVA_FN vec3 sylva_param_v3(SYLVA_BUF(params), uint at) {
    return vec3(sylva_param_f(SYLVA_PASS_BUF(params), at), sylva_param_f(SYLVA_PASS_BUF(params), at + 1u),
                sylva_param_f(SYLVA_PASS_BUF(params), at + 2u));
}

/// Reads the parameter block.
SYLVA_FN SylvaDvrParams sylva_dvr_params(SYLVA_BUF(params)) {
    SylvaDvrParams p;
    p.width = SYLVA_LOAD(params, 12u);
    p.height = SYLVA_LOAD(params, 13u);
    p.mode = SYLVA_LOAD(params, 14u);
    p.flags = SYLVA_LOAD(params, 15u);
    p.dt = sylva_param_f(SYLVA_PASS_BUF(params), 16u);
    p.unit = sylva_param_f(SYLVA_PASS_BUF(params), 17u);
    p.alpha_stop = sylva_param_f(SYLVA_PASS_BUF(params), 18u);
    p.iso = sylva_param_f(SYLVA_PASS_BUF(params), 19u);
    p.light = sylva_param_v3(SYLVA_PASS_BUF(params), 20u);
    p.ambient = sylva_param_f(SYLVA_PASS_BUF(params), 23u);
    p.diffuse = sylva_param_f(SYLVA_PASS_BUF(params), 24u);
    p.specular = sylva_param_f(SYLVA_PASS_BUF(params), 25u);
    p.shininess = sylva_param_f(SYLVA_PASS_BUF(params), 26u);
    p.tf_entries = SYLVA_LOAD(params, 27u);
    p.dims = uvec3(SYLVA_LOAD(params, 28u), SYLVA_LOAD(params, 29u), SYLVA_LOAD(params, 30u));
    p.spacing = sylva_param_v3(SYLVA_PASS_BUF(params), 31u);
    p.word_count = SYLVA_LOAD(params, 34u);
    p.ray_source = SYLVA_LOAD(params, 35u);
    p.tf_kind = SYLVA_LOAD(params, 36u);
    p.opacity = SYLVA_LOAD(params, 37u);
    p.border = SYLVA_LOAD(params, 38u);
    p.border_value = sylva_param_f(SYLVA_PASS_BUF(params), 39u);
    p.grid_format = SYLVA_LOAD(params, 40u);
    p.value_lo = sylva_param_f(SYLVA_PASS_BUF(params), 41u);
    p.value_span = sylva_param_f(SYLVA_PASS_BUF(params), 42u);
    p.skip_entries = SYLVA_LOAD(params, 43u);
    if (p.skip_entries == 0u) p.skip_entries = p.tf_entries;
    return p;
}

/// x . y written out (no fma contraction, same rounding on both targets).
SYLVA_FN float sylva_dvr_dot(vec3 a, vec3 b) {
    SYLVA_PRECISE float r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}

/// v / |v| with a correctly rounded sqrt and division; the zero vector stays zero.
SYLVA_FN vec3 sylva_dvr_unit(vec3 v) {
    float len = sqrt(sylva_dvr_dot(v, v));
    if (!(len > 0.0f)) return vec3(0.0f);
    return vec3(v.x / len, v.y / len, v.z / len);
}

/// The point o + t d (never contracted into fma).
SYLVA_FN vec3 sylva_dvr_at(vec3 o, vec3 d, float t) {
    SYLVA_PRECISE vec3 x = vec3(o.x + t * d.x, o.y + t * d.y, o.z + t * d.z);
    return x;
}

/// Lattice position t_k = fl(k dt).
SYLVA_FN float sylva_lattice_t(uint k, float dt) {
    SYLVA_PRECISE float t = float(k) * dt;
    return t;
}

/// The first lattice index k >= 0 with t_k >= t0 (dt > 0; t0 / dt is kept below 2^24).
SYLVA_FN uint sylva_lattice_first(float t0, float dt) {
    if (!(t0 > 0.0f) || !(dt > 0.0f)) return 0u;
    float q = ceil(t0 / dt);
    uint k = (q < 16777216.0f) ? uint(q) : 16777216u;
    if (k > 0u && sylva_lattice_t(k - 1u, dt) >= t0) k = k - 1u;
    if (sylva_lattice_t(k, dt) < t0) k = k + 1u;
    return k;
}

/// Opacity of a segment `units` sample lengths long whose unit-length opacity is alpha:
/// 1 - (1 - alpha)^units (Kinkelin 4.3), alpha clamped to [0, 1].
SYLVA_FN float sylva_dvr_correct(float alpha, float units) {
    float a = sylva_tf_clamp01(alpha);
    if (!(units > 0.0f) || a <= 0.0f) return 0.0f;
    if (a >= 1.0f) return 1.0f;
    return 1.0f - exp2(units * log2(1.0f - a));
}

/// Front-to-back compositing state: premultiplied colour and opacity.
struct SylvaDvrAcc {
    vec3 rgb;
    float alpha;
};

SYLVA_FN SylvaDvrAcc sylva_dvr_acc_zero() {
    SylvaDvrAcc acc;
    acc.rgb = vec3(0.0f);
    acc.alpha = 0.0f;
    return acc;
}

/// Composites straight colour rgb with opacity a behind what is already accumulated.
SYLVA_FN void sylva_dvr_blend(SYLVA_INOUT(SylvaDvrAcc) acc, vec3 rgb, float a) {
    SYLVA_PRECISE float k = (1.0f - acc.alpha) * a;
    SYLVA_PRECISE vec3 c = vec3(acc.rgb.x + k * rgb.x, acc.rgb.y + k * rgb.y, acc.rgb.z + k * rgb.z);
    SYLVA_PRECISE float na = acc.alpha + k;
    acc.rgb = c;
    acc.alpha = na;
}

SYLVA_FN vec4 sylva_dvr_result(SylvaDvrAcc acc) { return vec4(acc.rgb.x, acc.rgb.y, acc.rgb.z, acc.alpha); }

/// x^e for x >= 0 (0 for x <= 0), identical formula on both targets.
SYLVA_FN float sylva_dvr_pow(float x, float e) { return (x > 0.0f) ? exp2(e * log2(x)) : 0.0f; }

/// Lambert + Blinn-Phong shading of straight colour rgb with world-space density gradient g,
/// seen along unit direction d. The normal is -g / |g|, turned towards the viewer (two-sided);
/// a zero gradient (or shading off) leaves rgb unshaded. The result is clamped to [0, 1].
SYLVA_FN vec3 sylva_dvr_shade(SylvaDvrParams p, vec3 rgb, vec3 g, vec3 d) {
    vec3 n = sylva_dvr_unit(vec3(-g.x, -g.y, -g.z));
    if ((p.flags & SYLVA_DVR_FLAG_SHADING) == 0u || sylva_dvr_dot(n, n) == 0.0f) return rgb;
    vec3 view = vec3(-d.x, -d.y, -d.z);
    if (sylva_dvr_dot(n, view) < 0.0f) n = vec3(-n.x, -n.y, -n.z);
    vec3 l = (sylva_dvr_dot(p.light, p.light) > 0.0f) ? p.light : view;
    float diff = sylva_max(sylva_dvr_dot(n, l), 0.0f);
    vec3 h = sylva_dvr_unit(vec3(l.x + view.x, l.y + view.y, l.z + view.z));
    float spec = p.specular * sylva_dvr_pow(sylva_dvr_dot(n, h), p.shininess);
    SYLVA_PRECISE float lit = p.ambient + p.diffuse * diff;
    SYLVA_PRECISE vec3 c = vec3(rgb.x * lit + spec, rgb.y * lit + spec, rgb.z * lit + spec);
    return vec3(sylva_tf_clamp01(c.x), sylva_tf_clamp01(c.y), sylva_tf_clamp01(c.z));
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_DVR_COMMON_H
