// sylva/shared/ikd_iter.h -- front-to-back traversal of the implicit min/max kd-tree
// (sylva/shared/ikd_layout.h; Wald et al., sections 3.2 and 4.1) as a resumable iterator whose
// fixed-size state the caller owns. It yields the candidate cells of up to four isovalues: the
// cells the ray crosses whose corner densities span one of them, front to back, with the ray's
// interval [t0, t1] inside each. Nodes whose [min, max] holds none of the isovalues are culled
// with their whole subtree. No recursion, no heap, no callbacks: the same text runs on the host
// and in a shader.
//
//   SylvaIkdIter it;
//   sylva_ikd_init(it, words, word_count, grid_words, origin, direction, t_min, t_max, isos, iso_count);
//   uvec3 cell; float t0; float t1;
//   while (sylva_ikd_next(it, words, grid, cell, t0, t1)) {
//       ... it.corners_lo / it.corners_hi are the cell's eight corner densities ...
//   }
// sylva_ikd_init reads a float32 grid; for a uint8 / uint16 grid give sylva_ikd_begin the header
// of sylva_ikd_read_header_grid (format and value range).
//
// Order and intervals are those of sylva/shared/kd_iter.h: children are visited near side first
// (by the sign of the direction along the split axis), boxes are closed, a ray lying in a split
// plane reports the cells on both sides, and t is the world-space ray parameter (the ray is
// mapped into cell space, which leaves t unchanged up to rounding). The stack holds at most one
// far child per level, so SYLVA_IKD_STACK_SIZE >= L suffices; trees deeper than the stack, and
// headers that fail sylva_ikd_read_header, end with status ERROR at init. Node words can hold any
// bits: they only decide culling, so a corrupted node word can drop or add candidate cells but
// never makes the iterator read outside the buffers or loop.
//
// Corner order (what sylva/shared/iso_cell.h reads): corners_lo = densities at (x, y, z) offsets
// (0,0,0), (1,0,0), (0,1,0), (1,1,0); corners_hi = the same at z + 1.
#ifndef SYLVA_SHARED_IKD_ITER_H
#define SYLVA_SHARED_IKD_ITER_H

#include "sylva/shared/grid_sample.h"
#include "sylva/shared/ikd_layout.h"
#include "sylva/shared/ray_box.h"

#ifndef SYLVA_IKD_STACK_SIZE
#define SYLVA_IKD_STACK_SIZE 48
#endif

#ifndef SYLVA_ITER_RUNNING
#define SYLVA_ITER_RUNNING 0u
#define SYLVA_ITER_DONE 1u
#define SYLVA_ITER_ERROR 2u
#endif
#define SYLVA_IKD_NO_NODE 0xFFFFFFFFu

SYLVA_BEGIN_NAMESPACE

/// Subtrees still to visit: packed node (x0 | y0 << 16, z0 | level << 16) and ray interval.
struct SylvaIkdStack {
    uint st_xy[SYLVA_IKD_STACK_SIZE];
    uint st_zl[SYLVA_IKD_STACK_SIZE];
    float st_in[SYLVA_IKD_STACK_SIZE];
    float st_out[SYLVA_IKD_STACK_SIZE];
};

struct SylvaIkdIter {
    SylvaIkdHeader hdr;
    vec3 org;        ///< ray origin in cell space
    vec3 rcp;        ///< reciprocal of the cell-space direction (+-inf where parallel)
    uvec3 parallel;  ///< 1 where the ray is parallel to an axis
    vec4 isos;       ///< the isovalues (normalised densities); the first iso_count count
    uint iso_count;
    uvec4 iso_at_most;  ///< the isovalues as node-word code bounds (sylva_ikd_iso_codes)
    uvec4 iso_below;
    uvec4 raw_at_most;  ///< the isovalues as bounds on an integer grid's raw values (sylva_ikd_grid_codes)
    uvec4 raw_below;
    float t_limit;  ///< subtrees entered after this are pruned (sylva_ikd_clip)
    uvec3 node;     ///< first cell of the node to visit next
    uint level;     ///< its level; SYLVA_IKD_NO_NODE: pop the stack
    float t_in;
    float t_out;
    vec4 corners_lo;  ///< corner densities of the last cell returned (z = 0 face)
    vec4 corners_hi;  ///< ... and of its z = 1 face
    uint sp;
    uint steps;  ///< nodes and cells visited so far (Wald's traversal steps)
    uint status;
#ifdef __cplusplus
    SylvaIkdStack stack;
#endif
};

#ifdef __cplusplus
#define SYLVA_IKD_STACK(it) (it).stack
#else
SylvaIkdStack sylva_ikd_stack_private;
#define SYLVA_IKD_STACK(it) sylva_ikd_stack_private
#endif

/// True when one of the first `count` isovalues lies in [lo, hi] (NaN isovalues never do).
SYLVA_FN bool sylva_ikd_holds(vec4 isos, uint count, float lo, float hi) {
    bool found = false;
    for (uint k = 0u; k < 4u; k++) {
        float v = (k == 0u) ? isos.x : ((k == 1u) ? isos.y : ((k == 2u) ? isos.z : isos.w));
        if (k < count && v >= lo && v <= hi) found = true;
    }
    return found;
}

/// Number of raw values q in [0, top] whose density sylva_grid_normalise(q, lo, span) is <= v:
/// 0 .. top + 1, 0 for a NaN v. That density grows with q, so the values <= v are 0 .. count - 1.
SYLVA_FN uint sylva_ikd_raw_at_most(float v, float lo, float span, uint top) {
    if (!(v >= sylva_grid_normalise(0u, lo, span))) return 0u;  // NaN or below value 0's density
    if (v >= sylva_grid_normalise(top, lo, span)) return top + 1u;
    float g = v * span + lo;  // within a value or two of the answer; the loops settle it
    uint q = (g > 0.0f) ? ((g < float(top)) ? uint(g) : top) : 0u;
    while (q > 0u && sylva_grid_normalise(q, lo, span) > v) q = q - 1u;
    while (q < top && sylva_grid_normalise(q + 1u, lo, span) <= v) q = q + 1u;
    return (sylva_grid_normalise(q, lo, span) <= v) ? q + 1u : q;
}

/// Number of raw values q in [0, top] whose density is < v: 0 .. top + 1 (top + 1 for a NaN v,
/// so that no range holds it).
SYLVA_FN uint sylva_ikd_raw_below(float v, float lo, float span, uint top) {
    float d0 = sylva_grid_normalise(0u, lo, span);
    if (v <= d0) return 0u;
    if (!(v > d0) || v > sylva_grid_normalise(top, lo, span)) return top + 1u;  // NaN, or above every value
    float g = v * span + lo;
    uint q = (g > 0.0f) ? ((g < float(top)) ? uint(g) : top) : 0u;
    while (q > 0u && sylva_grid_normalise(q, lo, span) >= v) q = q - 1u;
    while (q < top && sylva_grid_normalise(q + 1u, lo, span) < v) q = q + 1u;
    return (sylva_grid_normalise(q, lo, span) < v) ? q + 1u : q;
}

/// Number of unorm16 codes q whose density float(q) / 65535 (sylva_ikd_node_range) is <= v:
/// 0 .. 65536, 0 for a NaN v.
SYLVA_FN uint sylva_ikd_codes_at_most(float v) { return sylva_ikd_raw_at_most(v, 0.0f, 65535.0f, 65535u); }

/// The first unorm16 code whose density is >= v: 0 .. 65535, or 65536 when there is none (v > 1
/// or NaN). Below 65536 it is the number of codes whose density is < v.
SYLVA_FN uint sylva_ikd_codes_below(float v) { return sylva_ikd_raw_below(v, 0.0f, 65535.0f, 65535u); }

/// The first `count` isovalues as bounds on raw values q in [0, top] of density
/// sylva_grid_normalise(q, lo, span): iso k lies in [density(a), density(b)] exactly when
/// a < at_most[k] and b >= below[k]. Isovalues from `count` on get at_most = 0 and never match.
SYLVA_FN void sylva_ikd_value_bounds(vec4 isos, uint count, float lo, float span, uint top, SYLVA_OUT(uvec4) at_most,
                                     SYLVA_OUT(uvec4) below) {
    at_most = uvec4(0u, 0u, 0u, 0u);
    below = uvec4(0u, 0u, 0u, 0u);
    if (count > 0u) { at_most.x = sylva_ikd_raw_at_most(isos.x, lo, span, top); below.x = sylva_ikd_raw_below(isos.x, lo, span, top); }
    if (count > 1u) { at_most.y = sylva_ikd_raw_at_most(isos.y, lo, span, top); below.y = sylva_ikd_raw_below(isos.y, lo, span, top); }
    if (count > 2u) { at_most.z = sylva_ikd_raw_at_most(isos.z, lo, span, top); below.z = sylva_ikd_raw_below(isos.z, lo, span, top); }
    if (count > 3u) { at_most.w = sylva_ikd_raw_at_most(isos.w, lo, span, top); below.w = sylva_ikd_raw_below(isos.w, lo, span, top); }
}

/// The isovalues as unorm16 code bounds, so that a node word is tested without converting it:
/// iso k lies in node_range(word) exactly when (word & 0xFFFF) < at_most[k] and word >> 16 >=
/// below[k] (the float test of sylva_ikd_holds, decided in integers: same culling, bit for bit).
/// Isovalues from `count` on get at_most = 0 and never match.
SYLVA_FN void sylva_ikd_iso_codes(vec4 isos, uint count, SYLVA_OUT(uvec4) at_most, SYLVA_OUT(uvec4) below) {
    sylva_ikd_value_bounds(isos, count, 0.0f, 65535.0f, 65535u, at_most, below);
}

/// The isovalues as bounds on the raw values of the header's integer grid (uint8: top 255,
/// uint16: 65535; sylva_ikd_cell_holds tests cells with them); 0 for a float32 grid.
SYLVA_FN void sylva_ikd_grid_codes(SYLVA_IN(SylvaIkdHeader) h, vec4 isos, uint count, SYLVA_OUT(uvec4) at_most,
                                   SYLVA_OUT(uvec4) below) {
    at_most = uvec4(0u, 0u, 0u, 0u);
    below = uvec4(0u, 0u, 0u, 0u);
    if (h.grid_format == SYLVA_GRID_F32) return;
    uint top = (h.grid_format == SYLVA_GRID_U8) ? 255u : 65535u;
    sylva_ikd_value_bounds(isos, count, h.value_lo, h.value_span, top, at_most, below);
}

/// True when node word `word` (unorm16 min | max << 16) holds one of the isovalues whose code
/// bounds sylva_ikd_iso_codes gave.
SYLVA_FN bool sylva_ikd_word_holds(uint word, uvec4 at_most, uvec4 below) {
    uint lo = word & 0xFFFFu;
    uint hi = word >> 16u;
    return (lo < at_most.x && hi >= below.x) || (lo < at_most.y && hi >= below.y) ||
           (lo < at_most.z && hi >= below.z) || (lo < at_most.w && hi >= below.w);
}

/// Ray interval (within [t0, t1]) in the real part of the box of the node of width 2^w cells
/// starting at cell o: [o, min(o + 2^w, C)] for C = `cells`.
SYLVA_FN vec2 sylva_ikd_box_interval(vec3 org, vec3 rcp, uvec3 par, uvec3 cells, uvec3 o, uvec3 w, float t0, float t1) {
    uvec3 hi = uvec3(min(o.x + (1u << w.x), cells.x), min(o.y + (1u << w.y), cells.y), min(o.z + (1u << w.z), cells.z));
    return sylva_kd_box_interval_f(org, rcp, par, vec3(float(o.x), float(o.y), float(o.z)),
                                   vec3(float(hi.x), float(hi.y), float(hi.z)), t0, t1);
}

/// Starts a traversal of origin + t * direction over [t_min, t_max] (world space) for the first
/// `iso_count` (1 .. 4) of `isos`, with the header sylva_ikd_read_header gave: a renderer reads
/// and checks it once per frame, not once per ray (the level-table check loops over the levels).
SYLVA_FN void sylva_ikd_begin(SYLVA_OUT(SylvaIkdIter) it, SylvaIkdHeader hdr, vec3 origin, vec3 direction, float t_min,
                              float t_max, vec4 isos, uint iso_count) {
    it.hdr = hdr;
    it.isos = isos;
    it.iso_count = (iso_count < 4u) ? iso_count : 4u;
    sylva_ikd_iso_codes(isos, it.iso_count, it.iso_at_most, it.iso_below);
    sylva_ikd_grid_codes(hdr, isos, it.iso_count, it.raw_at_most, it.raw_below);
    it.sp = 0u;
    it.steps = 0u;
    it.level = SYLVA_IKD_NO_NODE;
    it.node = uvec3(0u, 0u, 0u);
    it.t_limit = t_max;
    it.t_in = 0.0f;
    it.t_out = 0.0f;
    it.corners_lo = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    it.corners_hi = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    it.org = vec3(0.0f, 0.0f, 0.0f);
    it.rcp = vec3(0.0f, 0.0f, 0.0f);
    it.parallel = uvec3(0u, 0u, 0u);
    it.status = SYLVA_ITER_RUNNING;
    if (it.hdr.valid == 0u || it.hdr.levels > uint(SYLVA_IKD_STACK_SIZE)) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    // Multiplications by the header's 1 / spacing: divisions may differ between targets.
    bool nan_ray = sylva_ray_to_grid(origin, direction, it.hdr.origin, it.hdr.inv_spacing, t_min, t_max, it.org, it.rcp,
                                     it.parallel);
    if (nan_ray || it.iso_count == 0u) {
        it.status = SYLVA_ITER_DONE;
        return;
    }
    // No signed zero among the interval's bounds (sylva_ikd_split_intervals relies on it).
    vec2 t = sylva_ikd_box_interval(it.org, it.rcp, it.parallel, it.hdr.cells, uvec3(0u, 0u, 0u), it.hdr.lg,
                                    sylva_canon(t_min), sylva_canon(t_max));
    if (t.x <= t.y) {
        it.level = 0u;
        it.t_in = t.x;
        it.t_out = t.y;
    }
}

/// sylva_ikd_begin with the header of `words` (`word_count` and `grid_words` are the sizes of
/// the two buffers).
SYLVA_FN void sylva_ikd_init(SYLVA_OUT(SylvaIkdIter) it, SYLVA_BUF(words), uint word_count, uint grid_words,
                             vec3 origin, vec3 direction, float t_min, float t_max, vec4 isos, uint iso_count) {
    sylva_ikd_begin(it, sylva_ikd_read_header(SYLVA_PASS_BUF(words), word_count, grid_words), origin, direction, t_min,
                    t_max, isos, iso_count);
}

/// Prunes everything the ray would enter after t (first hits, early termination).
SYLVA_FN void sylva_ikd_clip(SYLVA_INOUT(SylvaIkdIter) it, float t) { it.t_limit = sylva_min(it.t_limit, t); }

SYLVA_FN void sylva_ikd_push(SYLVA_INOUT(SylvaIkdIter) it, uvec3 o, uint level, vec2 t) {
    if (it.sp >= uint(SYLVA_IKD_STACK_SIZE)) {  // unreachable: one entry per level at most
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    SYLVA_IKD_STACK(it).st_xy[it.sp] = o.x | (o.y << 16u);
    SYLVA_IKD_STACK(it).st_zl[it.sp] = o.z | (level << 16u);
    SYLVA_IKD_STACK(it).st_in[it.sp] = t.x;
    SYLVA_IKD_STACK(it).st_out[it.sp] = t.y;
    it.sp = it.sp + 1u;
}

/// Pops the next subtree that still starts before t_limit; false when none is left.
SYLVA_FN bool sylva_ikd_pop(SYLVA_INOUT(SylvaIkdIter) it) {
    while (it.sp > 0u) {
        it.sp = it.sp - 1u;
        if (SYLVA_IKD_STACK(it).st_in[it.sp] <= it.t_limit) {
            uint xy = SYLVA_IKD_STACK(it).st_xy[it.sp];
            uint zl = SYLVA_IKD_STACK(it).st_zl[it.sp];
            it.node = uvec3(xy & 0xFFFFu, xy >> 16u, zl & 0xFFFFu);
            it.level = zl >> 16u;
            it.t_in = SYLVA_IKD_STACK(it).st_in[it.sp];
            it.t_out = sylva_min(SYLVA_IKD_STACK(it).st_out[it.sp], it.t_limit);
            return true;
        }
    }
    return false;
}

/// The children's intervals from the parent's [t_in, t_out] and the one plane that splits it
/// (Wald et al. 3.2): the child boxes share every slab of the parent's but the split axis's, so
/// a child's interval is the parent's cut at the split plane's t, ts = canon((s - o) * r), the
/// value sylva_kd_box_interval_f would compute for that plane. Without signed zeros or NaNs
/// (sylva_ikd_begin canonicalises t_min and t_max; products are canonical and never NaN) the
/// min and max of a set of floats do not depend on the order, and rounding is monotonic, so the
/// result equals the slab test of the child's own box, bit for bit: the cell intervals stay those
/// of sylva/shared/cell_dda.h. Returns (lower.t0, lower.t1, upper.t0, upper.t1); a ray parallel
/// to the axis keeps the parent's interval on the side(s) of the plane its origin lies on.
SYLVA_FN vec4 sylva_ikd_split_intervals(float o, float r, uint par, float s, float t_in, float t_out) {
    vec4 t = vec4(t_in, t_out, t_in, t_out);
    if (par != 0u) {
        if (o > s) {
            t.x = sylva_inf();
            t.y = -sylva_inf();
        }
        if (o < s) {
            t.z = sylva_inf();
            t.w = -sylva_inf();
        }
        return t;
    }
    float ts = sylva_canon((s - o) * r);
    if ((floatBitsToUint(r) & 0x80000000u) == 0u) {  // lower child first: it ends at ts
        t.y = sylva_min(t_out, ts);
        t.z = sylva_max(t_in, ts);
    } else {  // upper child first: it ends at ts
        t.x = sylva_max(t_in, ts);
        t.w = sylva_min(t_out, ts);
    }
    return t;
}

/// Splits the current node (table entry `entry`) along its axis: continues with the near child
/// the ray hits and pushes the far one when both are hit. A child starting at or beyond the
/// real cells is virtual and skipped; when the upper child is virtual the lower one is the
/// parent's real part and keeps its interval.
SYLVA_FN void sylva_ikd_descend(SYLVA_INOUT(SylvaIkdIter) it, uint entry) {
    uint axis = entry & 3u;
    uvec3 w = sylva_ikd_level_widths(entry);
    uint half_w = 1u << (sylva_kd_pick_u(w, axis) - 1u);
    uvec3 lo = it.node;
    uint split = sylva_kd_pick_u(lo, axis) + half_w;
    uvec3 up = uvec3((axis == 0u) ? split : lo.x, (axis == 1u) ? split : lo.y, (axis == 2u) ? split : lo.z);
    uint child_level = it.level + 1u;
    bool up_real = split < sylva_kd_pick_u(it.hdr.cells, axis);
    vec4 t = vec4(it.t_in, it.t_out, sylva_inf(), -sylva_inf());
    if (up_real) {
        t = sylva_ikd_split_intervals(sylva_kd_pick(it.org, axis), sylva_kd_pick(it.rcp, axis),
                                      sylva_kd_pick_u(it.parallel, axis), float(split), it.t_in, it.t_out);
    }
    bool hit_l = t.x <= t.y;
    bool hit_u = t.z <= t.w;
    bool lower_first = (floatBitsToUint(sylva_kd_pick(it.rcp, axis)) & 0x80000000u) == 0u;
    if (hit_l && hit_u) {
        if (lower_first) {
            sylva_ikd_push(it, up, child_level, vec2(t.z, t.w));
        } else {
            sylva_ikd_push(it, lo, child_level, vec2(t.x, t.y));
        }
    }
    it.level = child_level;
    if (hit_l && (lower_first || !hit_u)) {
        it.node = lo;
        it.t_in = t.x;
        it.t_out = t.y;
    } else if (hit_u) {
        it.node = up;
        it.t_in = t.z;
        it.t_out = t.w;
    } else {
        it.level = SYLVA_IKD_NO_NODE;
    }
}

/// Sample indices of cell c's corners in a grid of `cells` cells: i the (0, 0, 0) corner, j = the
/// (0, 0, 1) corner, gx the samples per row (the other corners are offsets 1, gx, gx + 1 from
/// them). The header check keeps the grid's sample count below 2^32, so none wraps.
SYLVA_FN_HOT void sylva_ikd_corner_index(uvec3 cells, uvec3 c, SYLVA_OUT(uint) gx, SYLVA_OUT(uint) i, SYLVA_OUT(uint) j) {
    gx = cells.x + 1u;
    uint gxy = gx * (cells.y + 1u);
    i = c.x + gx * c.y + gxy * c.z;
    j = i + gxy;
}

/// The eight corner densities of cell c of a float32 grid of `cells` cells: lo = the z = c.z face
/// ((0,0), (1,0), (0,1), (1,1) in x, y), hi = the z = c.z + 1 face in the same order
/// (indices: sylva_ikd_corner_index).
SYLVA_FN_HOT void sylva_ikd_corners(SYLVA_BUF(grid), uvec3 cells, uvec3 c, SYLVA_OUT(vec4) lo, SYLVA_OUT(vec4) hi) {
    uint gx;
    uint i;
    uint j;
    sylva_ikd_corner_index(cells, c, gx, i, j);
    lo = vec4(uintBitsToFloat(SYLVA_LOAD(grid, i)), uintBitsToFloat(SYLVA_LOAD(grid, i + 1u)),
              uintBitsToFloat(SYLVA_LOAD(grid, i + gx)), uintBitsToFloat(SYLVA_LOAD(grid, i + gx + 1u)));
    hi = vec4(uintBitsToFloat(SYLVA_LOAD(grid, j)), uintBitsToFloat(SYLVA_LOAD(grid, j + 1u)),
              uintBitsToFloat(SYLVA_LOAD(grid, j + gx)), uintBitsToFloat(SYLVA_LOAD(grid, j + gx + 1u)));
}

/// True when the corners' [min, max] holds one of the first `count` isovalues.
SYLVA_FN_HOT bool sylva_ikd_corners_hold(vec4 a, vec4 b, vec4 isos, uint count) {
    float lo = sylva_min(sylva_min(sylva_min(a.x, a.y), sylva_min(a.z, a.w)), sylva_min(sylva_min(b.x, b.y), sylva_min(b.z, b.w)));
    float hi = sylva_max(sylva_max(sylva_max(a.x, a.y), sylva_max(a.z, a.w)), sylva_max(sylva_max(b.x, b.y), sylva_max(b.z, b.w)));
    return sylva_ikd_holds(isos, count, lo, hi);
}

/// Raw value of sample i of an integer grid (SYLVA_GRID_U8 or U16; layout of grid_sample.h).
SYLVA_FN_HOT uint sylva_ikd_raw(SYLVA_BUF(grid), uint format, uint i) {
    if (format == SYLVA_GRID_U8) return SYLVA_LOAD_U8(grid, i);
    return SYLVA_LOAD_U16(grid, i);
}

SYLVA_FN uint sylva_ikd_umin(uint a, uint b) { return (b < a) ? b : a; }
SYLVA_FN uint sylva_ikd_umax(uint a, uint b) { return (b > a) ? b : a; }

/// The candidate test of sylva_ikd_cell_holds for an integer grid (h.grid_format U8 / U16): the
/// cell's raw min and max against the isovalues' raw bounds (sylva_ikd_grid_codes: the same
/// test as on the densities, bit for bit, since the density is non-decreasing in the raw
/// value); only a candidate's eight values are normalised (lo / hi are 0 for the others).
/// Inlined on the host: as a call inside the walkers' loops it made the float32 path's DDA
/// 10-20 % slower (docs/DESIGN.md, SYLVA_FN_HOT).
SYLVA_FN_HOT bool sylva_ikd_cell_holds_raw(SYLVA_BUF(grid), SYLVA_IN(SylvaIkdHeader) h, uvec3 c, uvec4 raw_at_most,
                                             uvec4 raw_below, SYLVA_OUT(vec4) lo, SYLVA_OUT(vec4) hi) {
    uint f = h.grid_format;
    uint gx;
    uint i;
    uint j;
    sylva_ikd_corner_index(h.cells, c, gx, i, j);
    uvec4 a = uvec4(sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, i), sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, i + 1u),
                    sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, i + gx), sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, i + gx + 1u));
    uvec4 b = uvec4(sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, j), sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, j + 1u),
                    sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, j + gx), sylva_ikd_raw(SYLVA_PASS_BUF(grid), f, j + gx + 1u));
    uint mn = sylva_ikd_umin(sylva_ikd_umin(sylva_ikd_umin(a.x, a.y), sylva_ikd_umin(a.z, a.w)),
                             sylva_ikd_umin(sylva_ikd_umin(b.x, b.y), sylva_ikd_umin(b.z, b.w)));
    uint mx = sylva_ikd_umax(sylva_ikd_umax(sylva_ikd_umax(a.x, a.y), sylva_ikd_umax(a.z, a.w)),
                             sylva_ikd_umax(sylva_ikd_umax(b.x, b.y), sylva_ikd_umax(b.z, b.w)));
    lo = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    hi = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    bool holds = (mn < raw_at_most.x && mx >= raw_below.x) || (mn < raw_at_most.y && mx >= raw_below.y) ||
                 (mn < raw_at_most.z && mx >= raw_below.z) || (mn < raw_at_most.w && mx >= raw_below.w);
    if (!holds) return false;
    float l = h.value_lo;
    float s = h.value_span;
    lo = vec4(sylva_grid_normalise(a.x, l, s), sylva_grid_normalise(a.y, l, s), sylva_grid_normalise(a.z, l, s),
              sylva_grid_normalise(a.w, l, s));
    hi = vec4(sylva_grid_normalise(b.x, l, s), sylva_grid_normalise(b.y, l, s), sylva_grid_normalise(b.z, l, s),
              sylva_grid_normalise(b.w, l, s));
    return true;
}

/// Reads cell c's eight corner densities into lo / hi (the order of sylva_ikd_corners) and
/// returns true when their [min, max] holds one of the first `count` isovalues: the candidate
/// test of the tree iterator, the DDA and the packets. A float32 grid is read as by
/// sylva_ikd_corners; an integer grid through sylva_ikd_cell_holds_raw, with the isovalues'
/// raw bounds (sylva_ikd_grid_codes).
SYLVA_FN_HOT bool sylva_ikd_cell_holds(SYLVA_BUF(grid), SYLVA_IN(SylvaIkdHeader) h, uvec3 c, vec4 isos, uint count,
                                       uvec4 raw_at_most, uvec4 raw_below, SYLVA_OUT(vec4) lo, SYLVA_OUT(vec4) hi) {
    if (h.grid_format != SYLVA_GRID_F32)
        return sylva_ikd_cell_holds_raw(SYLVA_PASS_BUF(grid), h, c, raw_at_most, raw_below, lo, hi);
    sylva_ikd_corners(SYLVA_PASS_BUF(grid), h.cells, c, lo, hi);
    return sylva_ikd_corners_hold(lo, hi, isos, count);
}

/// Grids of at least this many words (1 MiB, as the WideTree's kFarNodes) get their bricks'
/// samples prefetched (sylva_ikd_prefetch_brick); smaller ones stay in a core's cache.
#define SYLVA_IKD_PREFETCH_WORDS 262144u

/// Host, grids of SYLVA_IKD_PREFETCH_WORDS words or more: asks for the cache lines of the samples
/// of the brick of 2^w cells at cell o (the first sample of each of its rows of samples), when
/// the walk enters the brick, so that they load while it descends the brick's levels to the
/// cells. In a shader nothing. No effect on results. Why: at Marschner-Lobb 512^3 (a 268 MB
/// uint16 grid) a step of the walk cost about a fifth more than at 32^3, the grid's loads
/// missing the caches and the TLB; with the prefetch the 512^3 frames were 3-8 % faster (README,
/// Wald section, "A brick's samples asked for early").
SYLVA_FN_HOT void sylva_ikd_prefetch_brick(SYLVA_BUF(grid), SYLVA_IN(SylvaIkdHeader) h, uvec3 o, uvec3 w) {
#ifdef __cplusplus
    if (grid.size < SYLVA_IKD_PREFETCH_WORDS) return;
    uint shift = (h.grid_format == SYLVA_GRID_U8) ? 2u : ((h.grid_format == SYLVA_GRID_U16) ? 1u : 0u);
    uint gx = h.cells.x + 1u;
    uint gxy = gx * (h.cells.y + 1u);
    uint y1 = sylva_ikd_umin(o.y + (1u << w.y), h.cells.y);
    uint z1 = sylva_ikd_umin(o.z + (1u << w.z), h.cells.z);
    for (uint z = o.z; z <= z1; z++) {
        for (uint y = o.y; y <= y1; y++) SYLVA_PREFETCH(grid, (o.x + gx * y + gxy * z) >> shift);
    }
#else
    SYLVA_UNUSED(h);
    SYLVA_UNUSED(o);
    SYLVA_UNUSED(w);
#endif
}

/// Advances to the next candidate cell. Returns false when the traversal is over (status DONE)
/// or the header was refused at init (status ERROR).
SYLVA_FN_HOT bool sylva_ikd_next(SYLVA_INOUT(SylvaIkdIter) it, SYLVA_BUF(words), SYLVA_BUF(grid), SYLVA_OUT(uvec3) cell,
                             SYLVA_OUT(float) t0, SYLVA_OUT(float) t1) {
    cell = uvec3(0u, 0u, 0u);
    t0 = 0.0f;
    t1 = 0.0f;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (it.level == SYLVA_IKD_NO_NODE && !sylva_ikd_pop(it)) {
            it.status = SYLVA_ITER_DONE;
            break;
        }
        it.steps = it.steps + 1u;
        if (it.level >= it.hdr.levels) {  // a cell: its range from the corners, on the fly
            it.level = SYLVA_IKD_NO_NODE;
            if (sylva_ikd_cell_holds(SYLVA_PASS_BUF(grid), it.hdr, it.node, it.isos, it.iso_count, it.raw_at_most,
                                     it.raw_below, it.corners_lo, it.corners_hi)) {
                cell = it.node;
                t0 = it.t_in;
                t1 = it.t_out;
                return true;
            }
            continue;
        }
        uint entry = sylva_ikd_level_entry(SYLVA_PASS_BUF(words), it.level);
        if (it.level < it.hdr.stored) {  // below: a brick's levels, not stored, never culled
            uint index = sylva_ikd_node_index(SYLVA_PASS_BUF(words), it.hdr.cells, it.level, entry, it.node);
            if (!sylva_ikd_word_holds(sylva_ikd_node_word(SYLVA_PASS_BUF(words), it.hdr, index), it.iso_at_most,
                                      it.iso_below)) {
                it.level = SYLVA_IKD_NO_NODE;  // culled with its subtree (section 4.1)
                continue;
            }
        }
        else if (it.level == it.hdr.stored) {  // a brick's root
            sylva_ikd_prefetch_brick(SYLVA_PASS_BUF(grid), it.hdr, it.node, sylva_ikd_level_widths(entry));
        }
        sylva_ikd_descend(it, entry);
    }
    return false;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_IKD_ITER_H
