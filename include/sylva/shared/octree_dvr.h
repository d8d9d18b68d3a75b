// sylva/shared/octree_dvr.h -- direct volume rendering over the bricked octree (Gobbetti et al.
// section 5.3): the stackless walk of octree_iter.h enumerates the cut's leaves front to back;
// inside each leaf the ray samples the leaf's brick on the global lattice of dvr_common.h,
// trilinearly, with the marcher's classification, opacity correction, shading and compositing.
// Leaves whose [min, max] the transfer function maps to zero opacity everywhere are skipped
// without sampling (section 4: empty nodes; the test is the paper's summed table of the
// opacity, here a prefix count of the TF entries with alpha > 0).
//
// Same image as the marcher (sylva/shared/dvr.h) when the cut is the octree's leaves: every
// lattice sample of the marcher's span [t_a, t_b) is taken exactly once (the leaves' intervals
// tile the ray; the first leaf starts at t_a and the last ends at t_b, so that the walk's
// voxel-space rounding never drops a sample), from a brick holding the same voxels (borders
// replicate them, clamped at the volume's edge as the marcher clamps), with the marcher's own
// arithmetic (the continuous voxel index from the world point, the same lerps). A sample
// rounded just outside its leaf reads the border; shading reads one voxel further, so
// bit-identical shaded images need border 2 (sylva/octree/build.hpp's default), unshaded ones
// border 1. Coarser cuts sample the coarse bricks (coarse voxels of spacing * 2^s over
// ceil(dims / 2^s) of them) with the step adapted to the level (section 5.3): dt * 2^s, every
// 2^s-th point of the same global lattice, with the opacity corrected for that step.
//
// Border modes (parameter words 38-39, grid_sample.h): with SYLVA_BORDER_CLAMP the brick
// aprons' clamped voxels give the clamping marcher's samples; with SYLVA_BORDER_CONSTANT every
// corner voxel outside the level's extent reads the border value instead of the brick (whatever
// the apron holds), with sylva_grid_sample_constant's arithmetic, so the full-resolution cut
// equals the marcher over a constant-border grid bit for bit too. A leaf touching a face of the
// volume then also blends towards the border value: its range for TF and iso culling is widened
// to include that value (sylva_oct_sampled_range), and its octants on the face are sampled
// unless the octant masks were made for that border (sylva_oct_dvr_mask).
//
// Buffers: `words` the index, `bricks` the bricks, `tf` the RGBA8 transfer function (tf.h),
// `tfsum` its opacity prefix counts: entries + 1 words (entries: parameter word 43), word i =
// the number of entries before entry i whose alpha is > 0 (sylva/render/octree_volume.hpp:
// tf_opacity_prefix; for a TF hook, entries whose neighbourhood the hook may show).
#ifndef SYLVA_SHARED_OCTREE_DVR_H
#define SYLVA_SHARED_OCTREE_DVR_H

#include "sylva/shared/dvr.h"
#include "sylva/shared/dvr_common.h"
#include "sylva/shared/grid_sample.h"
#include "sylva/shared/octree_brick.h"
#include "sylva/shared/octree_iter.h"
#include "sylva/shared/tf.h"

// Visibility feedback (Gobbetti et al. section 6, as a buffer instead of occlusion queries):
// the *_seen integrators mark, in a buffer of one word per node, every cut leaf a ray reached
// before it terminated (early ray termination, an iso hit, or the end of the volume): the word is
// set to 1, never cleared here (sylva/octree/residency.hpp clears it once a frame). Every writer
// writes the same value, so concurrent rays need no ordering: on the host a relaxed atomic store,
// in GLSL a plain store the shader defines as `void sylva_oct_store_seen(uint node)` (with
// `#define SYLVA_OCT_SEEN_STORE` before including this header; without it marking compiles to
// nothing). SYLVA_SEEN(name) declares the buffer parameter; SYLVA_OCT_NO_SEEN passes none (the
// plain integrators do: no cost when unbound beyond one test per leaf on the host).
#ifdef __cplusplus
#include <atomic>
namespace sylva::shared {
/// A writable feedback buffer (host); data == nullptr: none.
struct SeenWords {
    std::uint32_t* data = nullptr;
    std::size_t size = 0;
};
#define SYLVA_SEEN(name) const ::sylva::shared::SeenWords& name
#define SYLVA_OCT_NO_SEEN ::sylva::shared::SeenWords{}
/// No octant masks (sylva_oct_dvr_ray_masked below): every octant of a visible leaf is sampled.
#define SYLVA_OCT_NO_OCTMASK ::sylva::shared::Words{}
/// Marks node as reached (out-of-range nodes are ignored).
inline void sylva_oct_mark_seen(SYLVA_SEEN(seen), uint node) {
    if (seen.data != nullptr && node < seen.size)
        std::atomic_ref<std::uint32_t>(seen.data[node]).store(1u, std::memory_order_relaxed);
}
}  // namespace sylva::shared
#else
#define SYLVA_SEEN(name) uint name
#define SYLVA_OCT_NO_SEEN 0u
#define SYLVA_OCT_NO_OCTMASK 0u
void sylva_oct_mark_seen(uint seen, uint node) {
#ifdef SYLVA_OCT_SEEN_STORE
    sylva_oct_store_seen(node);
#endif
}
#endif

SYLVA_BEGIN_NAMESPACE

/// One node's brick as the sampler sees it.
struct SylvaOctBrick {
    uint base;      ///< word offset of the brick in the brick buffer
    ivec3 origin;   ///< voxel (of the node's level) held by brick sample (0, 0, 0): c * B - border
    uvec3 dims;     ///< the level's extent in voxels: ceil(dims / 2^s), s = L - 1 - level
    vec3 spacing;   ///< world size of one voxel of the level: spacing * 2^s
    uint side;      ///< samples per brick side, B + 2 * border
    uint format;    ///< SYLVA_OCT_FORMAT_* (octree_layout.h: float32, unorm16, unorm8 samples)
    uint border_mode;    ///< SYLVA_BORDER_* (parameter word 38)
    float border_value;  ///< density outside the volume for SYLVA_BORDER_CONSTANT (word 39)
};

/// The brick of node `node` (level, coordinates) of an octree with header h, sampled with the
/// border mode of the parameter block p.
SYLVA_FN SylvaOctBrick sylva_oct_brick_of(SYLVA_BUF(words), SYLVA_IN(SylvaOctHeader) h, SYLVA_IN(SylvaDvrParams) p, uint node, uint level,
                                          uvec3 coord) {
    SylvaOctBrick b;
    b.border_mode = p.border;
    b.border_value = p.border_value;
    uint s = h.levels - 1u - level;
    uint w = 1u << s;
    b.side = h.brick_size + 2u * h.border;
    b.format = h.format;
    b.base = sylva_oct_brick(SYLVA_PASS_BUF(words), node) * h.brick_words;
    b.origin = ivec3(int(coord.x * h.brick_size) - int(h.border), int(coord.y * h.brick_size) - int(h.border),
                     int(coord.z * h.brick_size) - int(h.border));
    b.dims = uvec3((h.dims.x + w - 1u) >> s, (h.dims.y + w - 1u) >> s, (h.dims.z + w - 1u) >> s);
    b.spacing = vec3(h.spacing.x * float(w), h.spacing.y * float(w), h.spacing.z * float(w));
    return b;
}

/// Brick-local index of voxel i of the level along one axis whose brick starts at voxel `origin`,
/// clamped into the brick's `side` samples (reads never leave the brick, whatever the point).
SYLVA_FN_HOT uint sylva_oct_brick_local(uint i, int origin, uint side) {
    return uint(clamp(int(i) - origin, 0, int(side) - 1));
}

/// Local sample (x, y, z) of the brick as a normalised density (its format's decoding).
SYLVA_FN_HOT float sylva_oct_brick_at(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, uint x, uint y, uint z) {
    return sylva_oct_brick_value(SYLVA_PASS_BUF(bricks), b.base, b.format, x + b.side * (y + b.side * z));
}

/// Trilinear density at world point p from the brick, edges clamped: sylva_grid_sample_clamped's
/// arithmetic (grid_sample.h) with the voxel reads taken from the brick.
SYLVA_FN_HOT float sylva_oct_brick_density_clamped(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, vec3 p) {
    vec3 u = vec3(sylva_grid_index(p.x, b.spacing.x, b.dims.x), sylva_grid_index(p.y, b.spacing.y, b.dims.y),
                  sylva_grid_index(p.z, b.spacing.z, b.dims.z));
    uvec3 i0 = uvec3(uint(u.x), uint(u.y), uint(u.z));
    uvec3 i1 = uvec3((i0.x + 1u < b.dims.x) ? i0.x + 1u : i0.x, (i0.y + 1u < b.dims.y) ? i0.y + 1u : i0.y,
                     (i0.z + 1u < b.dims.z) ? i0.z + 1u : i0.z);
    SYLVA_PRECISE vec3 f = vec3(u.x - float(i0.x), u.y - float(i0.y), u.z - float(i0.z));
    uvec3 l0 = uvec3(sylva_oct_brick_local(i0.x, b.origin.x, b.side), sylva_oct_brick_local(i0.y, b.origin.y, b.side),
                     sylva_oct_brick_local(i0.z, b.origin.z, b.side));
    uvec3 l1 = uvec3(sylva_oct_brick_local(i1.x, b.origin.x, b.side), sylva_oct_brick_local(i1.y, b.origin.y, b.side),
                     sylva_oct_brick_local(i1.z, b.origin.z, b.side));
    // sylva_grid_blend's order: z, then y, then x.
    float c00 = sylva_grid_lerp(sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l0.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l0.y, l1.z), f.z);
    float c01 = sylva_grid_lerp(sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l1.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l1.y, l1.z), f.z);
    float c10 = sylva_grid_lerp(sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l0.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l0.y, l1.z), f.z);
    float c11 = sylva_grid_lerp(sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l1.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l1.y, l1.z), f.z);
    return sylva_grid_lerp(sylva_grid_lerp(c00, c01, f.y), sylva_grid_lerp(c10, c11, f.y), f.x);
}

/// Voxel (x, y, z) of the brick's level: the border value outside the level's extent, else the
/// brick's sample (local index clamped into the brick).
SYLVA_FN_HOT float sylva_oct_brick_voxel_or_border(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, int x, int y, int z) {
    if (x < 0 || y < 0 || z < 0 || uint(x) >= b.dims.x || uint(y) >= b.dims.y || uint(z) >= b.dims.z) return b.border_value;
    return sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, sylva_oct_brick_local(uint(x), b.origin.x, b.side),
                              sylva_oct_brick_local(uint(y), b.origin.y, b.side), sylva_oct_brick_local(uint(z), b.origin.z, b.side));
}

/// Trilinear density at world point p from the brick, border constant: sylva_grid_sample_constant's
/// arithmetic (grid_sample.h) with the voxels inside the level read from the brick.
SYLVA_FN_HOT float sylva_oct_brick_density_constant(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, vec3 p) {
    SYLVA_PRECISE vec3 v = vec3(p.x / b.spacing.x - 0.5f, p.y / b.spacing.y - 0.5f, p.z / b.spacing.z - 0.5f);
    vec3 u = vec3(sylva_grid_clamp(v.x, -1.0f, float(b.dims.x)), sylva_grid_clamp(v.y, -1.0f, float(b.dims.y)),
                  sylva_grid_clamp(v.z, -1.0f, float(b.dims.z)));
    vec3 fl = vec3(floor(u.x), floor(u.y), floor(u.z));
    int x0 = int(fl.x);
    int y0 = int(fl.y);
    int z0 = int(fl.z);
    SYLVA_PRECISE vec3 f = vec3(u.x - fl.x, u.y - fl.y, u.z - fl.z);
#ifdef __cplusplus
    // The host takes the border-free reads when all eight corners are inside (the same values);
    // a shader keeps one read site per corner (its compile grows with every inlined read).
    if (x0 >= 0 && y0 >= 0 && z0 >= 0 && uint(x0) + 1u < b.dims.x && uint(y0) + 1u < b.dims.y &&
        uint(z0) + 1u < b.dims.z) {
        uvec3 l0 = uvec3(sylva_oct_brick_local(uint(x0), b.origin.x, b.side), sylva_oct_brick_local(uint(y0), b.origin.y, b.side),
                         sylva_oct_brick_local(uint(z0), b.origin.z, b.side));
        uvec3 l1 = uvec3(sylva_oct_brick_local(uint(x0) + 1u, b.origin.x, b.side),
                         sylva_oct_brick_local(uint(y0) + 1u, b.origin.y, b.side),
                         sylva_oct_brick_local(uint(z0) + 1u, b.origin.z, b.side));
        return sylva_grid_blend(sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l0.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l0.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l1.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l1.y, l0.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l0.y, l1.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l0.y, l1.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l0.x, l1.y, l1.z),
                                sylva_oct_brick_at(SYLVA_PASS_BUF(bricks), b, l1.x, l1.y, l1.z), f);
    }
#endif
    return sylva_grid_blend(sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0, y0, z0),
                            sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0 + 1, y0, z0),
                            sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0, y0 + 1, z0),
                            sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0 + 1, y0 + 1, z0),
                            sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0, y0, z0 + 1),
                            sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0 + 1, y0, z0 + 1),
                            sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0, y0 + 1, z0 + 1),
                            sylva_oct_brick_voxel_or_border(SYLVA_PASS_BUF(bricks), b, x0 + 1, y0 + 1, z0 + 1), f);
}

/// Trilinear density at world point p from the brick, in the brick's border mode.
SYLVA_FN_HOT float sylva_oct_brick_density(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, vec3 p) {
    if (b.border_mode == SYLVA_BORDER_CONSTANT) return sylva_oct_brick_density_constant(SYLVA_PASS_BUF(bricks), b, p);
    return sylva_oct_brick_density_clamped(SYLVA_PASS_BUF(bricks), b, p);
}

/// Central-difference gradient at p from the brick: sylva_grid_gradient's arithmetic.
SYLVA_FN vec3 sylva_oct_brick_gradient(SYLVA_BUF(bricks), SYLVA_IN(SylvaOctBrick) b, vec3 p) {
    vec3 s = b.spacing;
    SYLVA_PRECISE vec3 px0 = vec3(p.x - s.x, p.y, p.z);
    SYLVA_PRECISE vec3 px1 = vec3(p.x + s.x, p.y, p.z);
    SYLVA_PRECISE vec3 py0 = vec3(p.x, p.y - s.y, p.z);
    SYLVA_PRECISE vec3 py1 = vec3(p.x, p.y + s.y, p.z);
    SYLVA_PRECISE vec3 pz0 = vec3(p.x, p.y, p.z - s.z);
    SYLVA_PRECISE vec3 pz1 = vec3(p.x, p.y, p.z + s.z);
    float gx = sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, px1) - sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, px0);
    float gy = sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, py1) - sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, py0);
    float gz = sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, pz1) - sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, pz0);
    return vec3(gx, gy, gz) * 0.5f;
}

/// True when the TF gives zero opacity to every density in [lo, hi]: no entry the lookups of
/// such densities can blend (one entry of slack on each side for rounding) has alpha > 0.
SYLVA_FN bool sylva_oct_tf_empty(SYLVA_BUF(tfsum), uint entries, float lo, float hi) {
    if (entries == 0u) return true;
    uint last = entries - 1u;
    SYLVA_PRECISE float a = sylva_tf_clamp01(lo) * float(last);
    SYLVA_PRECISE float c = sylva_tf_clamp01(hi) * float(last);
    uint i0 = uint(a);
    i0 = (i0 > 0u) ? i0 - 1u : 0u;
    uint i1 = min(uint(c) + 2u, last);
    return SYLVA_LOAD(tfsum, i1 + 1u) == SYLVA_LOAD(tfsum, i0);
}

/// Samples the lattice points t_k in [t_lo, t_hi) from brick b: the marcher's per-sample work
/// (dvr.h) with density and gradient from the brick. `steps` counts the samples.
SYLVA_FN void sylva_oct_dvr_segment(SYLVA_INOUT(SylvaDvrAcc) acc, SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_IN(SylvaDvrParams) p,
                                    SYLVA_IN(SylvaOctBrick) b, vec3 origin, vec3 d, float t_lo, float t_hi, float dt, float units,
                                    SYLVA_INOUT(uint) steps) {
    for (uint k = sylva_lattice_first(t_lo, dt); steps < SYLVA_DVR_MAX_SAMPLES; k++) {
        float t = sylva_lattice_t(k, dt);
        if (!(t < t_hi) || acc.alpha >= p.alpha_stop) break;
        steps = steps + 1u;
        vec3 x = sylva_dvr_at(origin, d, t);
        float density = sylva_oct_brick_density(SYLVA_PASS_BUF(bricks), b, x);
        if (density > 0.0f) {
            vec4 c = sylva_dvr_classify(SYLVA_PASS_BUF(tf), p, density);
            float a = sylva_dvr_opacity(p, c.w, units);
            if (a > 0.0f) {
                vec3 rgb = vec3(c.x, c.y, c.z);
                if ((p.flags & SYLVA_DVR_FLAG_SHADING) != 0u) {
                    vec3 g = sylva_oct_brick_gradient(SYLVA_PASS_BUF(bricks), b, x);
                    rgb = sylva_dvr_shade(p, rgb, vec3(g.x / b.spacing.x, g.y / b.spacing.y, g.z / b.spacing.z), d);
                }
                sylva_dvr_blend(acc, rgb, a);
            }
        }
    }
}

/// Bit 8 of an octant mask word: the face octants' bits account for a constant border
/// (sylva/octree/octants.hpp, octant_masks with a border value; sylva_oct_dvr_mask).
#define SYLVA_OCT_OCTMASK_BORDER 256u

/// Octant masks (sylva/octree/octants.hpp builds them once a transfer function): one word per
/// node, bit o (octant o = x | y << 1 | z << 2 of the node's brick, B/2 voxels of its level a
/// side) set when the TF gives some opacity to the densities trilinear sampling inside that
/// octant can return (its voxels and one around, as the node's [min, max]). A leaf's samples in
/// an octant whose bit is clear all have zero opacity, so skipping them changes nothing: the
/// image stays the marcher's bit for bit; only `steps` counts fewer samples. The pieces of the
/// ray between the leaf's mid-planes each lie in one octant; a sample rounded across a plane
/// reads voxels within the margin of one the octant ranges include. Mask 255: sample it all.
/// Returns bits 0-8 (bit 8: SYLVA_OCT_OCTMASK_BORDER). In GLSL the masks are read only with SYLVA_OCT_OCTMASK defined (and `sylva_load_octmask`).
SYLVA_FN uint sylva_oct_octant_mask(SYLVA_BUF(octmask), uint use_mask, uint node) {
#if defined(__cplusplus) || defined(SYLVA_OCT_OCTMASK)
    if (use_mask != 0u) return SYLVA_LOAD(octmask, node) & 511u;
#endif
    return 255u;
}

/// Samples leaf piece [t_lo, t_hi) octant by octant, skipping octants whose bit in `mask` is
/// clear (see above); `it` is the walk, standing on the leaf.
SYLVA_FN void sylva_oct_dvr_octants(SYLVA_INOUT(SylvaDvrAcc) acc, SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_IN(SylvaDvrParams) p,
                                    SYLVA_IN(SylvaOctBrick) b, SYLVA_IN(SylvaOctIter) it, uint mask, vec3 origin, vec3 d, float t_lo,
                                    float t_hi, float dt, float units, SYLVA_INOUT(uint) steps) {
    if (mask == 255u) {
        sylva_oct_dvr_segment(acc, SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), p, b, origin, d, t_lo, t_hi, dt, units, steps);
        return;
    }
    if (mask == 0u) return;
    float half_width = float(sylva_oct_width(it.hdr, it.level) / 2u);
    vec3 mid = vec3(float(it.coord.x * sylva_oct_width(it.hdr, it.level)) + half_width,
                    float(it.coord.y * sylva_oct_width(it.hdr, it.level)) + half_width,
                    float(it.coord.z * sylva_oct_width(it.hdr, it.level)) + half_width);
    // Where the ray crosses the three mid-planes inside the piece, in order (+inf: not inside).
    float c0 = sylva_inf();
    float c1 = sylva_inf();
    float c2 = sylva_inf();
    for (uint k = 0u; k < 3u; k++) {
        float t = sylva_inf();
        if (sylva_kd_pick_u(it.parallel, k) == 0u)
            t = sylva_canon((sylva_kd_pick(mid, k) - sylva_kd_pick(it.org, k)) * sylva_kd_pick(it.rcp, k));
        if (!(t > t_lo && t < t_hi)) t = sylva_inf();
        if (t < c0) {
            c2 = c1;
            c1 = c0;
            c0 = t;
        } else if (t < c1) {
            c2 = c1;
            c1 = t;
        } else if (t < c2) {
            c2 = t;
        }
    }
    vec3 vd = vec3(d.x * it.hdr.inv_spacing.x, d.y * it.hdr.inv_spacing.y, d.z * it.hdr.inv_spacing.z);
    float a = t_lo;
    for (uint i = 0u; i < 4u && a < t_hi; i++) {
        float e = (i == 0u) ? c0 : ((i == 1u) ? c1 : ((i == 2u) ? c2 : t_hi));
        e = sylva_min(e, t_hi);
        if (!(e > a)) continue;
        float tm = 0.5f * a + 0.5f * e;
        vec3 x = vec3(it.org.x + tm * vd.x, it.org.y + tm * vd.y, it.org.z + tm * vd.z);
        uint o = ((x.x >= mid.x) ? 1u : 0u) | ((x.y >= mid.y) ? 2u : 0u) | ((x.z >= mid.z) ? 4u : 0u);
        if (((mask >> o) & 1u) != 0u)
            sylva_oct_dvr_segment(acc, SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), p, b, origin, d, a, e, dt, units, steps);
        a = e;
    }
}

/// The lattice step in a brick of coarse level s (voxels 2^s wide): dt * 2^s (section 5.3:
/// "stepping by a discrete number of intervals, which are directly associated to octree
/// levels"). Exact in float, so a coarse lattice is every 2^s-th point of the fine one; the
/// opacity correction uses the step (dt_s / unit), so coarse cuts keep the image's opacity.
SYLVA_FN float sylva_oct_level_dt(float dt, uint s) { return dt * float(1u << s); }

/// True when the node of level `level` with coordinates c touches a face of the volume (its box
/// starts at voxel 0 or reaches dims on some axis): its samples near that face read the border.
SYLVA_FN bool sylva_oct_on_face(SYLVA_IN(SylvaOctHeader) h, uint level, uvec3 c) {
    uint w = sylva_oct_width(h, level);
    return c.x == 0u || c.y == 0u || c.z == 0u || c.x * w + w >= h.dims.x || c.y * w + w >= h.dims.y ||
           c.z * w + w >= h.dims.z;
}

/// The octants (bit o = x | y << 1 | z << 2, as the octant masks) of node (level, c) that touch a
/// face of the volume: per axis the lower half when it starts at voxel 0 or reaches dims, the
/// upper half when it reaches dims.
SYLVA_FN uint sylva_oct_face_octants(SYLVA_IN(SylvaOctHeader) h, uint level, uvec3 c) {
    uint w = sylva_oct_width(h, level);
    uint half_w = w / 2u;
    uint m = 0u;
    if (c.x == 0u || c.x * w + half_w >= h.dims.x) m = m | 0x55u;
    if (c.x * w + w >= h.dims.x) m = m | 0xAAu;
    if (c.y == 0u || c.y * w + half_w >= h.dims.y) m = m | 0x33u;
    if (c.y * w + w >= h.dims.y) m = m | 0xCCu;
    if (c.z == 0u || c.z * w + half_w >= h.dims.z) m = m | 0x0Fu;
    if (c.z * w + w >= h.dims.z) m = m | 0xF0u;
    return m;
}

/// The densities sampling node (level, c) can return under p's border mode: the node's stored
/// [min, max], widened to include the border value for a node on a face of the volume when the
/// border is constant (section 4's culling stays conservative).
SYLVA_FN vec2 sylva_oct_sampled_range(SYLVA_BUF(words), SYLVA_IN(SylvaOctHeader) h, SYLVA_IN(SylvaDvrParams) p, uint node, uint level,
                                      uvec3 c) {
    vec2 r = sylva_oct_range(SYLVA_PASS_BUF(words), node);
    if (p.border == SYLVA_BORDER_CONSTANT && sylva_oct_on_face(h, level, c))
        r = vec2(sylva_min(r.x, p.border_value), sylva_max(r.y, p.border_value));
    return r;
}

/// True when node's brick is sampled: resident, and not empty under the TF over the densities
/// it can return (sylva_oct_sampled_range).
SYLVA_FN bool sylva_oct_dvr_visible(SYLVA_BUF(words), SYLVA_BUF(tfsum), SYLVA_IN(SylvaDvrParams) p, SYLVA_IN(SylvaOctHeader) h, uint node,
                                    uint level, uvec3 c) {
    uint state = sylva_oct_brick_state(sylva_oct_flags(SYLVA_PASS_BUF(words), node));
    if (state != SYLVA_OCT_BRICK_RESIDENT) return false;
    vec2 range = sylva_oct_sampled_range(SYLVA_PASS_BUF(words), h, p, node, level, c);
    return !sylva_oct_tf_empty(SYLVA_PASS_BUF(tfsum), p.skip_entries, range.x, range.y);
}

/// The octants of leaf `node` (level, c) to sample under p's border mode: its mask's bits, and
/// under a constant border the octants on a face of the volume too unless the masks were made
/// for that border (SYLVA_OCT_OCTMASK_BORDER): masks of the voxels alone do not know the
/// densities a face blends towards.
SYLVA_FN uint sylva_oct_dvr_mask(SYLVA_BUF(octmask), uint use_mask, SYLVA_IN(SylvaDvrParams) p, SYLVA_IN(SylvaOctHeader) h, uint node,
                                 uint level, uvec3 c) {
    uint m = sylva_oct_octant_mask(SYLVA_PASS_BUF(octmask), use_mask, node);
    if (p.border == SYLVA_BORDER_CONSTANT && (m & SYLVA_OCT_OCTMASK_BORDER) == 0u) m = m | sylva_oct_face_octants(h, level, c);
    return m & 255u;
}

/// sylva_oct_dvr_ray that also marks in `seen` every cut leaf the ray reached before it
/// terminated (the `visits` leaves; visibility feedback, top of this header) and, with
/// use_octmask 1, skips the octants of leaves that `octmask` marks empty (the same image).
SYLVA_FN vec4 sylva_oct_dvr_ray_masked(SYLVA_BUF(words), SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_BUF(tfsum),
                                       SYLVA_BUF(octmask), uint use_octmask, SYLVA_IN(SylvaDvrParams) p, SYLVA_IN(SylvaOctHeader) h,
                                       uint max_level, vec3 origin, vec3 direction, float t_min, float t_max,
                                       SYLVA_SEEN(seen), SYLVA_OUT(uint) steps, SYLVA_OUT(uint) visits,
                                       SYLVA_OUT(uint) status) {
    steps = 0u;
    visits = 0u;
    status = SYLVA_ITER_DONE;
    if (h.valid == 0u) {
        status = SYLVA_ITER_ERROR;
        return vec4(0.0f);
    }
    SylvaDvrAcc acc = sylva_dvr_acc_zero();
    vec3 d = sylva_dvr_unit(direction);
    vec3 hi = vec3(float(h.dims.x) * h.spacing.x, float(h.dims.y) * h.spacing.y, float(h.dims.z) * h.spacing.z);
    vec2 span = sylva_dvr_clip(vec3(0.0f), hi, origin, d, t_min, t_max);  // the marcher's span
    if (!(span.x <= span.y) || !(p.dt > 0.0f) || !(p.unit > 0.0f) || sylva_dvr_dot(d, d) == 0.0f) return vec4(0.0f);
    float dt = p.dt;
    float units = p.dt / p.unit;
    SylvaOctIter it;
    sylva_oct_begin(it, h, origin, d, span.x, span.y, max_level);
    float t_lo = span.x;
    bool last_visible = false;
    SylvaOctBrick b = sylva_oct_brick_of(SYLVA_PASS_BUF(words), h, p, 0u, 0u, uvec3(0u, 0u, 0u));
    uint node;
    float t0;
    float t1;
    while (acc.alpha < p.alpha_stop && sylva_oct_next(it, SYLVA_PASS_BUF(words), node, t0, t1)) {
        visits = visits + 1u;
        sylva_oct_mark_seen(seen, node);
        last_visible = sylva_oct_dvr_visible(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(tfsum), p, h, node, it.level, it.coord);
        if (last_visible) {
            b = sylva_oct_brick_of(SYLVA_PASS_BUF(words), h, p, node, it.level, it.coord);
            dt = sylva_oct_level_dt(p.dt, h.levels - 1u - it.level);
            units = dt / p.unit;
            uint mask = sylva_oct_dvr_mask(SYLVA_PASS_BUF(octmask), use_octmask, p, h, node, it.level, it.coord);
            sylva_oct_dvr_octants(acc, SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), p, b, it, mask, origin, d, t_lo, t1, dt,
                                  units, steps);
        }
        t_lo = t1;
    }
    // The marcher's span may end a rounding error after the walk's: the last leaf takes the rest.
    if (last_visible && it.status == SYLVA_ITER_DONE && t_lo < span.y)
        sylva_oct_dvr_segment(acc, SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), p, b, origin, d, t_lo, span.y, dt, units, steps);
    status = it.status;
    return sylva_dvr_result(acc);
}

/// sylva_oct_dvr_ray_masked without octant masks.
SYLVA_FN vec4 sylva_oct_dvr_ray_seen(SYLVA_BUF(words), SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_BUF(tfsum), SYLVA_IN(SylvaDvrParams) p,
                                     SYLVA_IN(SylvaOctHeader) h, uint max_level, vec3 origin, vec3 direction, float t_min, float t_max,
                                     SYLVA_SEEN(seen), SYLVA_OUT(uint) steps, SYLVA_OUT(uint) visits, SYLVA_OUT(uint) status) {
    return sylva_oct_dvr_ray_masked(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), SYLVA_PASS_BUF(tfsum),
                                    SYLVA_OCT_NO_OCTMASK, 0u, p, h, max_level, origin, direction, t_min, t_max, seen, steps,
                                    visits, status);
}

/// Renders one ray origin + t * direction (normalised here) over [t_min, t_max] through the
/// octree with header h (sylva_oct_read_header, once a frame), the cut's leaves at max_level.
/// Returns premultiplied RGB and opacity; `steps` = lattice samples taken, `visits` = leaves
/// visited, `status` = the walk's final status (SYLVA_ITER_ERROR: corrupted index).
SYLVA_FN vec4 sylva_oct_dvr_ray(SYLVA_BUF(words), SYLVA_BUF(bricks), SYLVA_BUF(tf), SYLVA_BUF(tfsum), SYLVA_IN(SylvaDvrParams) p,
                                SYLVA_IN(SylvaOctHeader) h, uint max_level, vec3 origin, vec3 direction, float t_min, float t_max,
                                SYLVA_OUT(uint) steps, SYLVA_OUT(uint) visits, SYLVA_OUT(uint) status) {
    return sylva_oct_dvr_ray_seen(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(bricks), SYLVA_PASS_BUF(tf), SYLVA_PASS_BUF(tfsum), p,
                                  h, max_level, origin, direction, t_min, t_max, SYLVA_OCT_NO_SEEN, steps, visits, status);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_OCTREE_DVR_H
