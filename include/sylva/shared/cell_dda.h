// sylva/shared/cell_dda.h -- the reference the implicit kd-tree is measured against: an
// Amanatides-Woo walk ("A Fast Voxel Traversal Algorithm for Ray Tracing", 1987) over every
// cell a ray crosses, front to back, yielding those whose corner densities span one of up to
// four isovalues: the candidate cells of sylva/shared/ikd_iter.h, found without a tree.
//
//   SylvaDdaIter it;
//   sylva_dda_init(it, words, word_count, grid_words, origin, direction, t_min, t_max, isos, iso_count);
//   uvec3 cell; float t0; float t1;
//   while (sylva_dda_next(it, grid, cell, t0, t1)) { ... it.corners_lo / corners_hi ... }
//
// It reads the geometry (cells, spacing, origin) from the header of an implicit kd-tree
// encoding (sylva/shared/ikd_layout.h), so both walk the same cells in the same cell space.
// Each cell's interval is the slab test of its own box (sylva/shared/ray_box.h) over
// [t_min, t_max], the arithmetic the tree's iterator reproduces exactly: the two yield equal
// intervals for equal cells, and an integrator fed by either computes identical hits. The walk
// picks the next cell by the nearest of the three next planes (ties: x, then y, then z); a ray
// through an edge or corner may therefore skip a cell it only touches (an interval of length 0),
// which the tree reports (closed boxes). Each plane's t is computed from its integer coordinate,
// never accumulated, so it does not drift. Steps are bounded by the cells along the three axes.
#ifndef SYLVA_SHARED_CELL_DDA_H
#define SYLVA_SHARED_CELL_DDA_H

#include "sylva/shared/ikd_iter.h"

SYLVA_BEGIN_NAMESPACE

struct SylvaDdaIter {
    SylvaIkdHeader hdr;
    vec3 org;
    vec3 rcp;
    uvec3 parallel;
    vec4 isos;
    uint iso_count;
    float t_min;
    float t_max;
    float t_limit;  ///< cells entered after this are not visited (sylva_dda_clip)
    ivec3 cell;     ///< the cell to visit next
    ivec3 dir_step; ///< +1, -1 or 0 per axis
    vec4 corners_lo;
    vec4 corners_hi;
    uint steps;  ///< cells visited so far
    uint max_steps;
    uint status;
    uvec4 raw_at_most;  ///< the isovalues as bounds on an integer grid's raw values (sylva_ikd_grid_codes)
    uvec4 raw_below;
};

/// t of the plane `coord` along one axis (+inf when the ray is parallel to it).
SYLVA_FN float sylva_dda_plane_t(float coord, float o, float r, uint par) {
    return (par != 0u) ? sylva_inf() : sylva_canon((coord - o) * r);
}

/// The DDA's step along each axis: +1 or -1 by the sign of the reciprocal direction, 0 where the
/// ray is parallel to the axis.
SYLVA_FN ivec3 sylva_dda_dir_step(vec3 rcp, uvec3 parallel) {
    return ivec3((parallel.x != 0u) ? 0 : ((floatBitsToUint(rcp.x) >> 31u) != 0u ? -1 : 1),
                 (parallel.y != 0u) ? 0 : ((floatBitsToUint(rcp.y) >> 31u) != 0u ? -1 : 1),
                 (parallel.z != 0u) ? 0 : ((floatBitsToUint(rcp.z) >> 31u) != 0u ? -1 : 1));
}

/// The neighbour of cell c across its nearest exit plane (ties: x, then y, then z) for steps s,
/// and the t of that plane (+inf when the ray is parallel to all three): the stepping rule of the
/// DDA and of the border's shell walk (iso_shell.h).
SYLVA_FN float sylva_dda_step(ivec3 c, ivec3 s, vec3 org, vec3 rcp, uvec3 par, SYLVA_OUT(ivec3) next) {
    float tx = sylva_dda_plane_t(float(c.x + ((s.x > 0) ? 1 : 0)), org.x, rcp.x, par.x);
    float ty = sylva_dda_plane_t(float(c.y + ((s.y > 0) ? 1 : 0)), org.y, rcp.y, par.y);
    float tz = sylva_dda_plane_t(float(c.z + ((s.z > 0) ? 1 : 0)), org.z, rcp.z, par.z);
    if (tx <= ty && tx <= tz) {
        next = ivec3(c.x + s.x, c.y, c.z);
    } else if (ty <= tz) {
        next = ivec3(c.x, c.y + s.y, c.z);
    } else {
        next = ivec3(c.x, c.y, c.z + s.z);
    }
    return sylva_min(tx, sylva_min(ty, tz));
}

/// Starts a walk with a header sylva_ikd_read_header gave (as sylva_ikd_begin).
SYLVA_FN void sylva_dda_begin(SYLVA_OUT(SylvaDdaIter) it, SylvaIkdHeader hdr, vec3 origin, vec3 direction, float t_min,
                              float t_max, vec4 isos, uint iso_count) {
    it.hdr = hdr;
    it.isos = isos;
    it.iso_count = (iso_count < 4u) ? iso_count : 4u;
    sylva_ikd_grid_codes(hdr, isos, it.iso_count, it.raw_at_most, it.raw_below);
    it.t_min = sylva_canon(t_min);  // as sylva_ikd_begin: no signed zero among the bounds
    it.t_max = sylva_canon(t_max);
    it.t_limit = t_max;
    it.cell = ivec3(0, 0, 0);
    it.dir_step = ivec3(0, 0, 0);
    it.corners_lo = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    it.corners_hi = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    it.org = vec3(0.0f, 0.0f, 0.0f);
    it.rcp = vec3(0.0f, 0.0f, 0.0f);
    it.parallel = uvec3(0u, 0u, 0u);
    it.steps = 0u;
    it.max_steps = 0u;
    it.status = SYLVA_ITER_RUNNING;
    if (it.hdr.valid == 0u) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    bool nan_ray = sylva_ray_to_grid(origin, direction, it.hdr.origin, it.hdr.inv_spacing, t_min, t_max, it.org, it.rcp,
                                     it.parallel);
    vec3 d = vec3(direction.x * it.hdr.inv_spacing.x, direction.y * it.hdr.inv_spacing.y,
                  direction.z * it.hdr.inv_spacing.z);
    uvec3 c = it.hdr.cells;
    vec2 t = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, vec3(0.0f, 0.0f, 0.0f),
                                     vec3(float(c.x), float(c.y), float(c.z)), it.t_min, it.t_max);
    if (nan_ray || it.iso_count == 0u || !(t.x <= t.y)) {
        it.status = SYLVA_ITER_DONE;
        return;
    }
    // The cell holding the entry point, clamped into the grid; the slab test of each visited
    // cell (sylva_dda_next) decides what is really crossed.
    vec3 p = vec3(it.org.x + t.x * d.x, it.org.y + t.x * d.y, it.org.z + t.x * d.z);
    it.cell = ivec3(clamp(int(floor(p.x)), 0, int(c.x) - 1), clamp(int(floor(p.y)), 0, int(c.y) - 1),
                    clamp(int(floor(p.z)), 0, int(c.z) - 1));
    it.dir_step = sylva_dda_dir_step(it.rcp, it.parallel);
    it.max_steps = c.x + c.y + c.z + 3u;
}

/// Starts a walk (same arguments as sylva_ikd_init).
SYLVA_FN void sylva_dda_init(SYLVA_OUT(SylvaDdaIter) it, SYLVA_BUF(words), uint word_count, uint grid_words,
                             vec3 origin, vec3 direction, float t_min, float t_max, vec4 isos, uint iso_count) {
    sylva_dda_begin(it, sylva_ikd_read_header(SYLVA_PASS_BUF(words), word_count, grid_words), origin, direction, t_min,
                    t_max, isos, iso_count);
}

/// Prunes the cells entered after t.
SYLVA_FN void sylva_dda_clip(SYLVA_INOUT(SylvaDdaIter) it, float t) { it.t_limit = sylva_min(it.t_limit, t); }

/// Moves to the neighbour across the nearest exit plane of the current cell; false when the
/// walk leaves the grid.
SYLVA_FN bool sylva_dda_advance(SYLVA_INOUT(SylvaDdaIter) it) {
    ivec3 n;
    float t = sylva_dda_step(it.cell, it.dir_step, it.org, it.rcp, it.parallel, n);
    it.cell = n;
    if (t > it.t_limit || t >= sylva_inf()) return false;
    uvec3 g = it.hdr.cells;
    return n.x >= 0 && n.y >= 0 && n.z >= 0 && uint(n.x) < g.x && uint(n.y) < g.y && uint(n.z) < g.z;
}

/// Advances to the next candidate cell (as sylva_ikd_next).
SYLVA_FN_HOT bool sylva_dda_next(SYLVA_INOUT(SylvaDdaIter) it, SYLVA_BUF(grid), SYLVA_OUT(uvec3) cell, SYLVA_OUT(float) t0,
                             SYLVA_OUT(float) t1) {
    cell = uvec3(0u, 0u, 0u);
    t0 = 0.0f;
    t1 = 0.0f;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (it.steps >= it.max_steps) {
            it.status = SYLVA_ITER_DONE;
            break;
        }
        it.steps = it.steps + 1u;
        uvec3 c = uvec3(uint(it.cell.x), uint(it.cell.y), uint(it.cell.z));
        vec2 t = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, vec3(float(c.x), float(c.y), float(c.z)),
                                         vec3(float(c.x + 1u), float(c.y + 1u), float(c.z + 1u)), it.t_min, it.t_max);
        bool inside = t.x <= t.y && t.x <= it.t_limit;
        bool candidate = false;
        if (inside) {  // the tree iterator's corner loads and range test, for the same cell
            candidate = sylva_ikd_cell_holds(SYLVA_PASS_BUF(grid), it.hdr, c, it.isos, it.iso_count, it.raw_at_most,
                                             it.raw_below, it.corners_lo, it.corners_hi);
        }
        if (!sylva_dda_advance(it)) it.status = SYLVA_ITER_DONE;
        if (candidate) {
            cell = c;
            t0 = t.x;
            t1 = t.y;
            return true;
        }
    }
    return false;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_CELL_DDA_H
