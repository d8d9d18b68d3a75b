// sylva/shared/iso_shell.h -- the cells a constant border adds around a grid, for the exact
// isosurface tracers (iso_render.h). Wald's tree (ikd_iter.h) and the cell DDA (cell_dda.h) hold
// the grid's own cells only, [0, C)^3 for C = hdr.cells: no surface exists outside the data. With
// a constant border, samples outside the grid read the border value b (as NanoVDB's background
// and VTK's constant border), so one layer of cells lies between the grid's faces and the first
// samples outside: the shell, the cells with an index -1 or C on some axis, whose corners mix
// face densities and b. A surface that reaches a face closes inside the shell. Beyond it every
// corner reads b, so no isovalue is crossed there (an isovalue equal to b is everywhere on the
// surface outside the grid, as it is in a constant cell inside; neither is drawn).
//
// The walk is the DDA of cell_dda.h (its stepping rule, sylva_dda_step) over the extended cells
// [-1, C]^3, the grid's own cells
// skipped (they are the tree's), in two phases: the cells before the grid's box, then, once the
// caller has walked the grid, the cells after it (sylva_shell_after). A ray is a segment, so the
// shell cells it crosses before entering the box [0, C]^3 all come before the grid's cells and
// those after leaving it after them: the three walks composite front to back.
//
//   SylvaShellIter sh;
//   sylva_shell_begin(sh, hdr, origin, direction, t_min, t_max, isos, iso_count, border, faces);
//   while (sylva_shell_next(sh, grid, cell_min, t0, t1)) { ... }  // before the grid
//   ... the tree's cells ...
//   sylva_shell_after(sh);
//   while (sylva_shell_next(sh, grid, cell_min, t0, t1)) { ... }  // after it
//
// Each cell's interval is its slab test over [t_min, t_max] in the cell space of sylva_ray_to_grid
// (the tree's and the DDA's arithmetic), and its corners (order of sylva_ikd_corners) read the
// grid where they lie inside it (normalised as the tree reads them) and b elsewhere; candidates
// are the cells whose corner [min, max] holds an isovalue (sylva_ikd_corners_hold; an integer
// grid's corners compared raw first, as the tree's cells are). Steps are
// bounded by the extended cells along the three axes, per phase.
//
// Face culling. A shell cell beside face F (index -1 or C on F's axis) has its in-grid corners on
// F, so its corners hold only F's densities and b. `faces` has bit 2a set when the low face of
// axis a (samples with index 0) may hold an isovalue together with b, bit 2a + 1 for the high face
// (index C): the caller computes it once a frame from the faces' ranges (sylva/render/iso.hpp,
// iso_border_faces). Each phase walks only the part of the ray that lies beside a face whose bit
// is set (sylva_shell_live: the union of those faces' slabs), a cell there beside a face whose
// bit is clear is skipped without reading it, and with no bit set there is no walk at all.
// 0x3F (all faces) is always correct.
#ifndef SYLVA_SHARED_ISO_SHELL_H
#define SYLVA_SHARED_ISO_SHELL_H

#include "sylva/shared/cell_dda.h"

SYLVA_BEGIN_NAMESPACE

struct SylvaShellIter {
    SylvaIkdHeader hdr;
    vec3 org;  ///< ray origin in cell space (sylva_ray_to_grid)
    vec3 d;    ///< cell-space direction
    vec3 rcp;
    uvec3 parallel;
    vec4 isos;
    uint iso_count;
    float border;  ///< the normalised density outside the grid
    uint faces;    ///< faces whose cells may hold an isovalue (see the top)
    float t_min;
    float t_max;
    float t_limit;   ///< cells entered after this end the phase
    float t_after;   ///< where the second phase starts (the grid box's exit); +inf: no second phase
    float t_end;     ///< where it ends (the extended box's exit)
    ivec3 cell;      ///< the cell to visit next
    ivec3 dir_step;  ///< +1, -1 or 0 per axis
    vec4 corners_lo;
    vec4 corners_hi;
    uint steps;  ///< cells visited so far, both phases
    uint max_steps;  ///< the bound of the current phase
    uint status;
};

/// The faces extended cell c lies beside (bit 2a: index -1 on axis a, bit 2a + 1: index C).
SYLVA_FN uint sylva_shell_cell_faces(ivec3 c, uvec3 cells) {
    return ((c.x < 0) ? 1u : 0u) | ((c.x >= int(cells.x)) ? 2u : 0u) | ((c.y < 0) ? 4u : 0u) |
           ((c.y >= int(cells.y)) ? 8u : 0u) | ((c.z < 0) ? 16u : 0u) | ((c.z >= int(cells.z)) ? 32u : 0u);
}

/// Density of sample v (any integer coordinates): the grid's, normalised as the tree reads it,
/// inside [0, C]^3; the border value outside.
SYLVA_FN float sylva_shell_sample(SYLVA_BUF(grid), SYLVA_IN(SylvaIkdHeader) h, ivec3 v, float border) {
    uvec3 n = uvec3(h.cells.x + 1u, h.cells.y + 1u, h.cells.z + 1u);
    if (v.x < 0 || v.y < 0 || v.z < 0 || uint(v.x) >= n.x || uint(v.y) >= n.y || uint(v.z) >= n.z) return border;
    uint i = uint(v.x) + n.x * (uint(v.y) + n.y * uint(v.z));
    if (h.grid_format == SYLVA_GRID_F32) return uintBitsToFloat(SYLVA_LOAD(grid, i));
    return sylva_grid_normalise(sylva_ikd_raw(SYLVA_PASS_BUF(grid), h.grid_format, i), h.value_lo, h.value_span);
}

/// The eight corner densities of extended cell c (order of sylva_ikd_corners).
SYLVA_FN void sylva_shell_corners(SYLVA_BUF(grid), SYLVA_IN(SylvaIkdHeader) h, ivec3 c, float border, SYLVA_OUT(vec4) lo,
                                  SYLVA_OUT(vec4) hi) {
    lo = vec4(sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y, c.z), border),
              sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y, c.z), border),
              sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y + 1, c.z), border),
              sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y + 1, c.z), border));
    hi = vec4(sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y, c.z + 1), border),
              sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y, c.z + 1), border),
              sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y + 1, c.z + 1), border),
              sylva_shell_sample(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y + 1, c.z + 1), border));
}

/// Raw value of sample v of an integer grid, or `none` outside [0, C]^3.
SYLVA_FN uint sylva_shell_raw(SYLVA_BUF(grid), SYLVA_IN(SylvaIkdHeader) h, ivec3 v, uint none) {
    uvec3 n = uvec3(h.cells.x + 1u, h.cells.y + 1u, h.cells.z + 1u);
    if (v.x < 0 || v.y < 0 || v.z < 0 || uint(v.x) >= n.x || uint(v.y) >= n.y || uint(v.z) >= n.z) return none;
    return sylva_ikd_raw(SYLVA_PASS_BUF(grid), h.grid_format, uint(v.x) + n.x * (uint(v.y) + n.y * uint(v.z)));
}

/// The density of a raw value of sylva_shell_raw (`none`: the border).
SYLVA_FN float sylva_shell_density(SYLVA_IN(SylvaIkdHeader) h, uint raw, uint none, float border) {
    return (raw == none) ? border : sylva_grid_normalise(raw, h.value_lo, h.value_span);
}

/// Reads extended cell c's corners into lo / hi (order of sylva_ikd_corners) and returns true
/// when their [min, max] holds one of the isovalues (sylva_ikd_corners_hold). An integer grid's
/// corners are compared raw first, as the tree's cells are (sylva_ikd_cell_holds_raw): the
/// density is non-decreasing in the raw value, so the min and max of the raw values give the
/// densities' min and max, and only a candidate's eight values are normalised (the same test,
/// two divisions a cell instead of eight).
SYLVA_FN bool sylva_shell_cell_holds(SYLVA_BUF(grid), SYLVA_IN(SylvaIkdHeader) h, ivec3 c, float border, vec4 isos,
                                     uint count, SYLVA_OUT(vec4) lo, SYLVA_OUT(vec4) hi) {
    if (h.grid_format == SYLVA_GRID_F32) {
        sylva_shell_corners(SYLVA_PASS_BUF(grid), h, c, border, lo, hi);
        return sylva_ikd_corners_hold(lo, hi, isos, count);
    }
    uint none = 0xFFFFFFFFu;  // above every raw value of 8 or 16 bits
    uvec4 a = uvec4(sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y, c.z), none),
                    sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y, c.z), none),
                    sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y + 1, c.z), none),
                    sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y + 1, c.z), none));
    uvec4 b = uvec4(sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y, c.z + 1), none),
                    sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y, c.z + 1), none),
                    sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x, c.y + 1, c.z + 1), none),
                    sylva_shell_raw(SYLVA_PASS_BUF(grid), h, ivec3(c.x + 1, c.y + 1, c.z + 1), none));
    uint mn = sylva_ikd_umin(sylva_ikd_umin(sylva_ikd_umin(a.x, a.y), sylva_ikd_umin(a.z, a.w)),
                             sylva_ikd_umin(sylva_ikd_umin(b.x, b.y), sylva_ikd_umin(b.z, b.w)));
    // The largest in-grid raw value: `none` maps to 0 here (a shell cell has an in-grid corner).
    uint mx = 0u;
    for (uint k = 0u; k < 4u; k++) {
        uint u = (k == 0u) ? a.x : ((k == 1u) ? a.y : ((k == 2u) ? a.z : a.w));
        uint w = (k == 0u) ? b.x : ((k == 1u) ? b.y : ((k == 2u) ? b.z : b.w));
        mx = sylva_ikd_umax(mx, sylva_ikd_umax((u == none) ? 0u : u, (w == none) ? 0u : w));
    }
    float dl = sylva_grid_normalise(mn, h.value_lo, h.value_span);
    float dh = sylva_grid_normalise(mx, h.value_lo, h.value_span);
    dl = sylva_min(dl, border);  // every shell cell has a corner outside
    dh = sylva_max(dh, border);
    lo = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    hi = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    if (!sylva_ikd_holds(isos, count, dl, dh)) return false;
    lo = vec4(sylva_shell_density(h, a.x, none, border), sylva_shell_density(h, a.y, none, border),
              sylva_shell_density(h, a.z, none, border), sylva_shell_density(h, a.w, none, border));
    hi = vec4(sylva_shell_density(h, b.x, none, border), sylva_shell_density(h, b.y, none, border),
              sylva_shell_density(h, b.z, none, border), sylva_shell_density(h, b.w, none, border));
    return true;
}

/// floor(x) clamped to [-1, n] before the conversion (a far origin's rounding can put x anywhere;
/// NaN gives -1), so no float-to-int conversion overflows.
SYLVA_FN int sylva_shell_index(float x, uint n) {
    float f = floor(x);
    return (f >= float(n)) ? int(n) : ((f > -1.0f) ? int(f) : -1);
}

/// The part of [ta, tb] where the ray lies beside a face whose bit is set: the union of the
/// intervals of those faces' slabs (the extended box cut to [-1, 0] or [C, C + 1] on the face's
/// axis), as [x, y]; x > y when it misses them all.
SYLVA_FN vec2 sylva_shell_live(SYLVA_IN(SylvaShellIter) it, float ta, float tb) {
    vec3 cf = vec3(float(it.hdr.cells.x), float(it.hdr.cells.y), float(it.hdr.cells.z));
    vec2 u = vec2(sylva_inf(), -sylva_inf());
    for (uint f = 0u; f < 6u; f++) {
        if (((it.faces >> f) & 1u) == 0u) continue;
        uint a = f >> 1u;
        float side = ((f & 1u) == 0u) ? -1.0f : ((a == 0u) ? cf.x : ((a == 1u) ? cf.y : cf.z));
        vec3 lo = vec3((a == 0u) ? side : -1.0f, (a == 1u) ? side : -1.0f, (a == 2u) ? side : -1.0f);
        vec3 hi = vec3((a == 0u) ? side + 1.0f : cf.x + 1.0f, (a == 1u) ? side + 1.0f : cf.y + 1.0f,
                       (a == 2u) ? side + 1.0f : cf.z + 1.0f);
        vec2 t = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, lo, hi, ta, tb);
        if (t.x <= t.y) u = vec2(sylva_min(u.x, t.x), sylva_max(u.y, t.y));
    }
    return u;
}

/// Starts a phase over [ta, tb]: from the extended cell holding the point where the ray first
/// lies beside a face that may hold an isovalue (clamped into [-1, C]^3; the slab tests decide
/// what is crossed) until the cells entered after the last such point; none when it never does.
SYLVA_FN void sylva_shell_place(SYLVA_INOUT(SylvaShellIter) it, float ta, float tb) {
    vec2 live = sylva_shell_live(it, ta, tb);
    it.status = SYLVA_ITER_DONE;
    if (!(live.x <= live.y)) return;
    float t = live.x;
    vec3 p = vec3(it.org.x + t * it.d.x, it.org.y + t * it.d.y, it.org.z + t * it.d.z);
    uvec3 c = it.hdr.cells;
    it.cell = ivec3(sylva_shell_index(p.x, c.x), sylva_shell_index(p.y, c.y), sylva_shell_index(p.z, c.z));
    it.t_limit = live.y;
    it.max_steps = it.steps + c.x + c.y + c.z + 9u;
    it.status = SYLVA_ITER_RUNNING;
}

/// Starts the walk of origin + t * direction over [t_min, t_max] (world space, as
/// sylva_ikd_begin) through the shell of a grid whose outside reads `border`, beside the `faces`
/// that may hold an isovalue (see the top; 0x3F: all); its first phase ends where the ray enters
/// the grid's box.
SYLVA_FN void sylva_shell_begin(SYLVA_OUT(SylvaShellIter) it, SylvaIkdHeader hdr, vec3 origin, vec3 direction,
                                float t_min, float t_max, vec4 isos, uint iso_count, float border, uint faces) {
    it.hdr = hdr;
    it.isos = isos;
    it.iso_count = (iso_count < 4u) ? iso_count : 4u;
    it.border = border;
    it.faces = faces & 63u;
    it.t_min = sylva_canon(t_min);
    it.t_max = sylva_canon(t_max);
    it.t_limit = it.t_max;
    it.t_after = sylva_inf();
    it.t_end = sylva_inf();
    it.cell = ivec3(0, 0, 0);
    it.dir_step = ivec3(0, 0, 0);
    it.corners_lo = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    it.corners_hi = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    it.org = vec3(0.0f, 0.0f, 0.0f);
    it.d = vec3(0.0f, 0.0f, 0.0f);
    it.rcp = vec3(0.0f, 0.0f, 0.0f);
    it.parallel = uvec3(0u, 0u, 0u);
    it.steps = 0u;
    it.max_steps = 0u;
    it.status = SYLVA_ITER_DONE;
    if (it.hdr.valid == 0u) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    bool nan_ray = sylva_ray_to_grid(origin, direction, it.hdr.origin, it.hdr.inv_spacing, t_min, t_max, it.org, it.rcp,
                                     it.parallel);
    it.d = vec3(direction.x * it.hdr.inv_spacing.x, direction.y * it.hdr.inv_spacing.y,
                direction.z * it.hdr.inv_spacing.z);
    uvec3 c = it.hdr.cells;
    vec3 cf = vec3(float(c.x), float(c.y), float(c.z));
    vec2 te = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, vec3(-1.0f, -1.0f, -1.0f),
                                      vec3(cf.x + 1.0f, cf.y + 1.0f, cf.z + 1.0f), it.t_min, it.t_max);
    if (nan_ray || it.iso_count == 0u || it.faces == 0u || !(border == border) || !(te.x <= te.y)) return;
    vec2 tg = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, vec3(0.0f, 0.0f, 0.0f), cf, it.t_min, it.t_max);
    bool grid_hit = tg.x <= tg.y;
    it.t_after = grid_hit ? tg.y : sylva_inf();
    it.t_end = te.y;
    it.dir_step = sylva_dda_dir_step(it.rcp, it.parallel);
    sylva_shell_place(it, te.x, grid_hit ? tg.x : te.y);
}

/// Starts the second phase: the shell cells after the grid's box (none when the ray missed the
/// box, or the walk was refused).
SYLVA_FN void sylva_shell_after(SYLVA_INOUT(SylvaShellIter) it) {
    if (it.status == SYLVA_ITER_ERROR) return;
    it.status = SYLVA_ITER_DONE;
    if (it.t_after < sylva_inf()) sylva_shell_place(it, it.t_after, it.t_end);
    it.t_after = sylva_inf();
}

/// Moves to the neighbour across the nearest exit plane (sylva_dda_step, the DDA's rule); false
/// when the walk leaves the extended cells or the phase's limit.
SYLVA_FN bool sylva_shell_advance(SYLVA_INOUT(SylvaShellIter) it) {
    ivec3 n;
    float t = sylva_dda_step(it.cell, it.dir_step, it.org, it.rcp, it.parallel, n);
    it.cell = n;
    if (t > it.t_limit || t >= sylva_inf()) return false;
    uvec3 g = it.hdr.cells;
    return n.x >= -1 && n.y >= -1 && n.z >= -1 && n.x <= int(g.x) && n.y <= int(g.y) && n.z <= int(g.z);
}

/// Advances to the next candidate cell of the shell in the current phase; `cell_min` is its
/// lowest corner in cell space (components -1 .. C). False when the phase is over.
SYLVA_FN bool sylva_shell_next(SYLVA_INOUT(SylvaShellIter) it, SYLVA_BUF(grid), SYLVA_OUT(vec3) cell_min,
                               SYLVA_OUT(float) t0, SYLVA_OUT(float) t1) {
    cell_min = vec3(0.0f, 0.0f, 0.0f);
    t0 = 0.0f;
    t1 = 0.0f;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (it.steps >= it.max_steps) {
            it.status = SYLVA_ITER_DONE;
            break;
        }
        it.steps = it.steps + 1u;
        ivec3 c = it.cell;
        vec3 lo = vec3(float(c.x), float(c.y), float(c.z));
        bool candidate = false;
        vec2 t = vec2(0.0f, 0.0f);
        uint beside = sylva_shell_cell_faces(c, it.hdr.cells);  // 0: a cell of the grid (the tree's)
        if (beside != 0u && (beside & ~it.faces) == 0u) {
            t = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, lo, vec3(lo.x + 1.0f, lo.y + 1.0f, lo.z + 1.0f),
                                        it.t_min, it.t_max);
            if (t.x <= t.y && t.x <= it.t_limit) {
                candidate = sylva_shell_cell_holds(SYLVA_PASS_BUF(grid), it.hdr, c, it.border, it.isos, it.iso_count,
                                                   it.corners_lo, it.corners_hi);
            }
        }
        if (!sylva_shell_advance(it)) it.status = SYLVA_ITER_DONE;
        if (candidate) {
            cell_min = lo;
            t0 = t.x;
            t1 = t.y;
            return true;
        }
    }
    return false;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ISO_SHELL_H
