// sylva/shared/iso_render.h -- exact isosurface ray casting (Wald et al., sections 4.1 and 4.2):
// the candidate cells of the implicit kd-tree (ikd_iter.h) or of the reference cell DDA
// (cell_dda.h), the exact ray-isosurface root in each (iso_cell.h), up to four isovalues each
// with a colour and an opacity, shaded (two-sided Lambert with a headlight) and composited front
// to back until the opacity reaches alpha_stop. Part of the shared C++/GLSL subset.
//
// Both walkers yield the same cells in the same order with bit-identical intervals (cell_dda.h),
// and cells a ray only touches (intervals of length 0, which only the tree reports) are skipped
// here, so both give identical images, hit for hit. Inside a cell the hits of the isovalues are
// composited in the order of t; a second crossing of the same isovalue inside one cell (a cubic
// can cross three times) is not composited (it cannot change an opaque surface's image).
// With a constant border (word 33) the cells between the grid's faces and the border's samples
// (iso_shell.h) are composited too: those before the grid's box ahead of the walker's cells,
// those after it behind them, so a surface that reaches a face closes there.
//
// Parameter block: a buffer `params` of SYLVA_ISO_PARAM_WORDS words (sylva/render/iso.hpp writes
// it), word offset: meaning
//   0-11   camera: eye, forward w, right u, up v (float bits; sylva/shared/camera.h)
//   12     image width        13  image height
//   14     isovalue count (1 .. 4)
//   15     walker: SYLVA_ISO_WALK_TREE or SYLVA_ISO_WALK_DDA
//   16-19  isovalues (normalised densities, float bits)
//   20-23  colour of each isovalue, RGBA8 (R bits 0-7 ... A bits 24-31; A = the surface's opacity)
//   24     alpha_stop (float bits): the ray ends once its opacity reaches it
//   25-26  ambient and diffuse weights (float bits)
//   27     word count of the tree encoding    28  word count of the grid
//   29     ray source: SYLVA_RAYS_* (camera.h: pinhole or orthographic from words 0-11; or the
//          caller's ray buffer, read by the shader with rays.h's sylva_rays_load)
//   30     grid format: SYLVA_GRID_F32, _U8 or _U16 (sylva/shared/grid_sample.h)
//   31-32  value range of an integer grid: raw value of density 0, raw values per unit (float
//          bits; the float32 grid: 0 and 1)
//   33     border: SYLVA_ISO_BORDER_CELLS (0: the grid's cells only, as Wald) or
//          SYLVA_ISO_BORDER_CONSTANT (1: samples outside read word 34, and the shell of cells
//          between the faces and them is walked too: sylva/shared/iso_shell.h)
//   34     the border's normalised density (float bits; read when word 33 is 1)
//   35     border faces: bit 2a / 2a + 1 set when the low / high face of axis a may hold an
//          isovalue together with the border value (iso_shell.h's face culling; 0x3F: all)
#ifndef SYLVA_SHARED_ISO_RENDER_H
#define SYLVA_SHARED_ISO_RENDER_H

#include "sylva/shared/camera.h"
#include "sylva/shared/cell_dda.h"
#include "sylva/shared/ikd_iter.h"
#include "sylva/shared/iso_cell.h"
#include "sylva/shared/iso_shell.h"

#define SYLVA_ISO_PARAM_WORDS 36u
#define SYLVA_ISO_WALK_TREE 0u
#define SYLVA_ISO_WALK_DDA 1u
#define SYLVA_ISO_BORDER_CELLS 0u
#define SYLVA_ISO_BORDER_CONSTANT 1u

SYLVA_BEGIN_NAMESPACE

struct SylvaIsoParams {
    vec3 eye;
    vec3 w;
    vec3 u;
    vec3 v;
    uint width;
    uint height;
    uint iso_count;
    uint walker;
    vec4 isos;
    uvec4 colours;
    float alpha_stop;
    float ambient;
    float diffuse;
    uint tree_words;
    uint grid_words;
    uint ray_source;
    uint grid_format;
    float value_lo;
    float value_span;
    uint border_mode;
    float border;
    uint border_faces;
};

SYLVA_FN vec3 sylva_iso_load3(SYLVA_BUF(params), uint at) {
    return vec3(uintBitsToFloat(SYLVA_LOAD(params, at)), uintBitsToFloat(SYLVA_LOAD(params, at + 1u)),
                uintBitsToFloat(SYLVA_LOAD(params, at + 2u)));
}

/// Decodes the parameter block (layout above).
SYLVA_FN SylvaIsoParams sylva_iso_read_params(SYLVA_BUF(params)) {
    SylvaIsoParams p;
    p.eye = sylva_iso_load3(SYLVA_PASS_BUF(params), 0u);
    p.w = sylva_iso_load3(SYLVA_PASS_BUF(params), 3u);
    p.u = sylva_iso_load3(SYLVA_PASS_BUF(params), 6u);
    p.v = sylva_iso_load3(SYLVA_PASS_BUF(params), 9u);
    p.width = SYLVA_LOAD(params, 12u);
    p.height = SYLVA_LOAD(params, 13u);
    p.iso_count = SYLVA_LOAD(params, 14u);
    p.walker = SYLVA_LOAD(params, 15u);
    p.isos = vec4(uintBitsToFloat(SYLVA_LOAD(params, 16u)), uintBitsToFloat(SYLVA_LOAD(params, 17u)),
                  uintBitsToFloat(SYLVA_LOAD(params, 18u)), uintBitsToFloat(SYLVA_LOAD(params, 19u)));
    p.colours = uvec4(SYLVA_LOAD(params, 20u), SYLVA_LOAD(params, 21u), SYLVA_LOAD(params, 22u), SYLVA_LOAD(params, 23u));
    p.alpha_stop = uintBitsToFloat(SYLVA_LOAD(params, 24u));
    p.ambient = uintBitsToFloat(SYLVA_LOAD(params, 25u));
    p.diffuse = uintBitsToFloat(SYLVA_LOAD(params, 26u));
    p.tree_words = SYLVA_LOAD(params, 27u);
    p.grid_words = SYLVA_LOAD(params, 28u);
    p.ray_source = SYLVA_LOAD(params, 29u);
    p.grid_format = SYLVA_LOAD(params, 30u);
    p.value_lo = uintBitsToFloat(SYLVA_LOAD(params, 31u));
    p.value_span = uintBitsToFloat(SYLVA_LOAD(params, 32u));
    p.border_mode = SYLVA_LOAD(params, 33u);
    p.border = uintBitsToFloat(SYLVA_LOAD(params, 34u));
    p.border_faces = SYLVA_LOAD(params, 35u);
    return p;
}

/// The tree's header checked against the grid the parameters describe (sizes, format, range);
/// read once for all rays.
SYLVA_FN SylvaIkdHeader sylva_iso_read_header(SYLVA_BUF(words), SylvaIsoParams p) {
    return sylva_ikd_read_header_grid(SYLVA_PASS_BUF(words), p.tree_words, p.grid_words, p.grid_format, p.value_lo,
                                      p.value_span);
}

/// What one ray did: premultiplied colour, and counters for the statistics.
struct SylvaIsoRay {
    vec4 rgba;
    uint steps;  ///< traversal steps (tree nodes and cells visited, or DDA cells)
    uint cells;  ///< candidate cells whose intersection was computed
    uint hits;   ///< surface hits composited
    uint status;
};

/// Component k of a vector, by index.
SYLVA_FN float sylva_iso_comp(vec4 v, uint k) { return (k == 0u) ? v.x : ((k == 1u) ? v.y : ((k == 2u) ? v.z : v.w)); }
SYLVA_FN uint sylva_iso_comp_u(uvec4 v, uint k) { return (k == 0u) ? v.x : ((k == 1u) ? v.y : ((k == 2u) ? v.z : v.w)); }

/// Composites the surface of isovalue k hit at cell-local point q into acc (premultiplied).
SYLVA_FN vec4 sylva_iso_composite(vec4 acc, SylvaIsoParams p, uint k, vec4 lo, vec4 hi, vec3 q, vec3 inv_spacing,
                                  vec3 dir) {
    vec3 gl = sylva_iso_cell_gradient(lo, hi, q);
    vec3 g = vec3(gl.x * inv_spacing.x, gl.y * inv_spacing.y, gl.z * inv_spacing.z);
    float len = sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
    float facing = (len > 0.0f) ? abs(g.x * dir.x + g.y * dir.y + g.z * dir.z) / len : 1.0f;
    uint c = sylva_iso_comp_u(p.colours, k);
    float a = float(c >> 24u) / 255.0f;
    float shade = p.ambient + p.diffuse * facing;
    vec3 rgb = vec3(float(c & 255u) / 255.0f, float((c >> 8u) & 255u) / 255.0f, float((c >> 16u) & 255u) / 255.0f);
    float wgt = (1.0f - acc.w) * a;
    return vec4(acc.x + wgt * rgb.x * shade, acc.y + wgt * rgb.y * shade, acc.z + wgt * rgb.z * shade, acc.w + wgt);
}

/// Intersects one candidate cell [t0, t1] whose lowest corner is `cell_min` (cell space; a shell
/// cell's components may be -1) with every isovalue and composites its hits in the order of t.
/// `org` and `d` are the ray in cell space (d unnormalised, t the world parameter).
SYLVA_FN vec4 sylva_iso_shade_cell_at(vec4 acc, SylvaIsoParams p, vec3 cell_min, vec4 lo, vec4 hi, vec3 org, vec3 d,
                                      vec3 inv_spacing, vec3 dir, float t0, float t1, SYLVA_INOUT(uint) hits) {
    vec3 o = vec3(org.x - cell_min.x, org.y - cell_min.y, org.z - cell_min.z);
    vec4 th = vec4(sylva_inf(), sylva_inf(), sylva_inf(), sylva_inf());
    for (uint k = 0u; k < 4u; k++) {
        float t = sylva_inf();
        if (k < p.iso_count && sylva_iso_cell_hit(lo, hi, o, d, t0, t1, sylva_iso_comp(p.isos, k), t)) {
            th = vec4((k == 0u) ? t : th.x, (k == 1u) ? t : th.y, (k == 2u) ? t : th.z, (k == 3u) ? t : th.w);
        }
    }
    for (uint n = 0u; n < 4u; n++) {  // the hits in order of t (ties: lower isovalue index first)
        uint best = 4u;
        float bt = sylva_inf();
        for (uint k = 0u; k < 4u; k++) {
            if (sylva_iso_comp(th, k) < bt) {
                bt = sylva_iso_comp(th, k);
                best = k;
            }
        }
        if (best == 4u || acc.w >= p.alpha_stop) break;
        vec3 q = vec3(o.x + bt * d.x, o.y + bt * d.y, o.z + bt * d.z);
        acc = sylva_iso_composite(acc, p, best, lo, hi, q, inv_spacing, dir);
        hits = hits + 1u;
        th = vec4((best == 0u) ? sylva_inf() : th.x, (best == 1u) ? sylva_inf() : th.y,
                  (best == 2u) ? sylva_inf() : th.z, (best == 3u) ? sylva_inf() : th.w);
    }
    return acc;
}

/// sylva_iso_shade_cell_at for cell `cell` of the grid (the tree's and the DDA's cells).
SYLVA_FN vec4 sylva_iso_shade_cell(vec4 acc, SylvaIsoParams p, uvec3 cell, vec4 lo, vec4 hi, vec3 org, vec3 d,
                                   vec3 inv_spacing, vec3 dir, float t0, float t1, SYLVA_INOUT(uint) hits) {
    return sylva_iso_shade_cell_at(acc, p, vec3(float(cell.x), float(cell.y), float(cell.z)), lo, hi, org, d,
                                   inv_spacing, dir, t0, t1, hits);
}

/// Composites the candidate cells of the shell walk's current phase (sylva/shared/iso_shell.h)
/// into r until the ray's opacity reaches alpha_stop.
SYLVA_FN void sylva_iso_shell_phase(SYLVA_INOUT(SylvaIsoRay) r, SYLVA_INOUT(SylvaShellIter) sh, SYLVA_BUF(grid),
                                    SylvaIsoParams p, vec3 dir) {
    vec3 cmin;
    float t0;
    float t1;
    while (r.rgba.w < p.alpha_stop && sylva_shell_next(sh, SYLVA_PASS_BUF(grid), cmin, t0, t1)) {
        if (!(t0 < t1)) continue;  // touched only, as the grid's cells
        r.cells = r.cells + 1u;
        r.rgba = sylva_iso_shade_cell_at(r.rgba, p, cmin, sh.corners_lo, sh.corners_hi, sh.org, sh.d, sh.hdr.inv_spacing,
                                         dir, t0, t1, r.hits);
    }
}

/// Traces the ray eye + t dir (dir unit length) through the candidate cells of the walker
/// p.walker names (the tree, or the reference DDA); `hdr` is the tree's header
/// (sylva_iso_read_header(words, p), read once for all rays).
SYLVA_FN SylvaIsoRay sylva_iso_trace(SYLVA_BUF(words), SYLVA_BUF(grid), SylvaIsoParams p, SylvaIkdHeader hdr, vec3 eye,
                                     vec3 dir) {
    SylvaIsoRay r;
    r.rgba = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    r.cells = 0u;
    r.hits = 0u;
    bool tree = p.walker != SYLVA_ISO_WALK_DDA;
    SylvaIkdIter it;
    SylvaDdaIter dda;
    if (tree) {
        sylva_ikd_begin(it, hdr, eye, dir, 0.0f, sylva_inf(), p.isos, p.iso_count);
    } else {
        sylva_dda_begin(dda, hdr, eye, dir, 0.0f, sylva_inf(), p.isos, p.iso_count);
    }
    vec3 s = tree ? it.hdr.inv_spacing : dda.hdr.inv_spacing;
    vec3 org = tree ? it.org : dda.org;
    vec3 d = vec3(dir.x * s.x, dir.y * s.y, dir.z * s.z);
    bool shell = p.border_mode == SYLVA_ISO_BORDER_CONSTANT && p.border_faces != 0u;
    SylvaShellIter sh;
    if (shell) {  // the shell cells before the grid
        sylva_shell_begin(sh, hdr, eye, dir, 0.0f, sylva_inf(), p.isos, p.iso_count, p.border, p.border_faces);
        sylva_iso_shell_phase(r, sh, SYLVA_PASS_BUF(grid), p, dir);
    }
    uvec3 cell;
    float t0;
    float t1;
    while (r.rgba.w < p.alpha_stop && (tree ? sylva_ikd_next(it, SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(grid), cell, t0, t1)
                                            : sylva_dda_next(dda, SYLVA_PASS_BUF(grid), cell, t0, t1))) {
        if (!(t0 < t1)) continue;  // touched only: the DDA does not report it (see the top)
        r.cells = r.cells + 1u;
        vec4 lo = tree ? it.corners_lo : dda.corners_lo;
        vec4 hi = tree ? it.corners_hi : dda.corners_hi;
        r.rgba = sylva_iso_shade_cell(r.rgba, p, cell, lo, hi, org, d, s, dir, t0, t1, r.hits);
    }
    r.steps = tree ? it.steps : dda.steps;
    r.status = tree ? it.status : dda.status;
    if (shell) {  // ... and after it, unless the ray is done
        if (r.rgba.w < p.alpha_stop) {
            sylva_shell_after(sh);
            sylva_iso_shell_phase(r, sh, SYLVA_PASS_BUF(grid), p, dir);
        }
        r.steps = r.steps + sh.steps;
    }
    return r;
}

/// Traces the primary ray r, its direction normalised here, through the walker the parameters
/// name.
SYLVA_FN SylvaIsoRay sylva_iso_trace_ray(SYLVA_BUF(words), SYLVA_BUF(grid), SylvaIsoParams p, SylvaIkdHeader hdr,
                                         SylvaRay r) {
    vec3 d = r.dir;
    float len = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    vec3 dir = vec3(d.x / len, d.y / len, d.z / len);
    return sylva_iso_trace(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(grid), p, hdr, r.origin, dir);
}

/// Renders pixel (x, y) with the camera of words 0-11 (pinhole, or orthographic when the ray
/// source word says so; a ray buffer is read by the caller, see word 29).
SYLVA_FN SylvaIsoRay sylva_iso_pixel(SYLVA_BUF(words), SYLVA_BUF(grid), SylvaIsoParams p, SylvaIkdHeader hdr, uint x,
                                     uint y) {
    SylvaRay r = sylva_camera_ray(p.ray_source, p.eye, p.w, p.u, p.v, x, y, p.width, p.height);
    return sylva_iso_trace_ray(SYLVA_PASS_BUF(words), SYLVA_PASS_BUF(grid), p, hdr, r);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ISO_RENDER_H
