// sylva/shared/octree_iter.h -- the stackless front-to-back traversal of the bricked octree with
// neighbour pointers (Gobbetti, Marton, Iglesias Guitian, section 5.2 and Fig. 5) as a resumable
// iterator whose fixed-size state the caller owns. It yields the leaves of the current cut the
// ray crosses, front to back, each with the ray's interval [t0, t1] inside it. No stack, no
// recursion, no heap, no callbacks: the same text runs on the host and in a shader.
//
//   SylvaOctIter it;
//   sylva_oct_init(it, words, word_count, brick_words, origin, direction, t_min, t_max, max_level);
//   uint node; float t0; float t1;
//   while (sylva_oct_next(it, words, node, t0, t1)) {
//       ... sample node's brick over [t0, t1]; stop early when opaque ...
//   }
//
// The walk (section 5.2): from the root, descend to the node of the cut that contains the ray
// at t (the entry point at first), choosing the child by the side of each axis's mid plane the
// ray is on at t (the step function of Fig. 5, written with the ray parameter of each mid plane
// so that it uses the slab test's own numbers); yield it with [t, exit]; leave it through the
// face of its first exit plane and follow that face's neighbour pointer, then descend again.
// Boxes are computed from (level, coordinates), never read. The state is the current node, its
// level and coordinates, and t.
//
// What is yielded, exactly: the cut leaves in which the ray spends a positive length, in order,
// with t0 = max(t_min, entry planes) and t1 = min(t_max, exit planes) computed as in
// sylva/shared/ray_box.h (so consecutive intervals share their end points bit for bit). A leaf
// the ray only touches (along an edge, at a corner, or through a zero-length piece) is skipped;
// on an axis the ray is parallel to, a point on a plane between two nodes belongs to the upper
// one (and the volume's upper boundary to the last): boxes are half-open [lo, hi) there, closed
// at the volume's end. Rays along faces and edges, through corners and starting inside the
// volume all follow these rules. The cut: a node is a leaf of the cut when it has no children,
// its level is max_level (max_level >= L - 1: the octree's leaves; 0: the root alone) or its
// record carries SYLVA_OCT_CUT_LEAF (a view-dependent cut, sylva/octree/cut.hpp). Neighbour
// pointers are those of the full octree: one that lands on a node marked SYLVA_OCT_CUT_BELOW
// (inside a cut leaf) restarts the descent from the root at t, which reaches that cut leaf.
//
// Corrupted encodings: a header sylva_oct_read_header refuses ends with status ERROR at init; a
// child or neighbour index out of range, a neighbour deeper than the node it is reached from or
// starting outside the volume, a child missing from the mask, or more steps than any valid walk
// takes, ends with status ERROR. Out-of-range loads read 0 (host) or what the shader's load
// function returns; the iterator never loops forever.
#ifndef SYLVA_SHARED_OCTREE_ITER_H
#define SYLVA_SHARED_OCTREE_ITER_H

#include "sylva/shared/octree_layout.h"
#include "sylva/shared/ray_box.h"

#ifndef SYLVA_ITER_RUNNING
#define SYLVA_ITER_RUNNING 0u
#define SYLVA_ITER_DONE 1u
#define SYLVA_ITER_ERROR 2u
#endif

SYLVA_BEGIN_NAMESPACE

struct SylvaOctIter {
    SylvaOctHeader hdr;
    vec3 org;        ///< ray origin in voxel space
    vec3 rcp;        ///< reciprocal of the voxel-space direction (+-inf where parallel)
    uvec3 parallel;  ///< 1 where the ray is parallel to an axis
    uint max_level;  ///< nodes at this level are leaves of the cut
    uint node;       ///< current node
    uint level;      ///< its level
    uvec3 coord;     ///< its coordinates
    float t_cur;     ///< the ray before t_cur has been yielded
    float t_end;     ///< min(t_max, the ray's exit from the volume)
    uint steps;      ///< nodes visited (descents, neighbour moves, leaves)
    uint step_limit; ///< more steps than a valid walk takes: ERROR
    uint status;
};

/// Starts a traversal of origin + t * direction over [t_min, t_max] (world space), with the
/// cut's leaves at level max_level (or the octree's leaves above it), with the header
/// sylva_oct_read_header gave (read and checked once a frame, not once a ray).
SYLVA_FN void sylva_oct_begin(SYLVA_OUT(SylvaOctIter) it, SYLVA_IN(SylvaOctHeader) hdr, vec3 origin, vec3 direction, float t_min,
                              float t_max, uint max_level) {
    it.hdr = hdr;
    it.max_level = max_level;
    it.node = 0u;
    it.level = 0u;
    it.coord = uvec3(0u, 0u, 0u);
    it.t_cur = 0.0f;
    it.t_end = 0.0f;
    it.steps = 0u;
    it.org = vec3(0.0f, 0.0f, 0.0f);
    it.rcp = vec3(0.0f, 0.0f, 0.0f);
    it.parallel = uvec3(0u, 0u, 0u);
    it.status = SYLVA_ITER_RUNNING;
    // Leaf crossings are at most the leaf bricks per axis summed (+2); each takes at most three
    // neighbour moves (a corner), each possibly followed by a restart from the root (a cut),
    // and L descents.
    uvec3 n = uvec3((hdr.dims.x + hdr.brick_size - 1u) / max(hdr.brick_size, 1u),
                    (hdr.dims.y + hdr.brick_size - 1u) / max(hdr.brick_size, 1u),
                    (hdr.dims.z + hdr.brick_size - 1u) / max(hdr.brick_size, 1u));
    it.step_limit = (n.x + n.y + n.z + 2u) * (4u * hdr.levels + 8u);
    if (hdr.valid == 0u) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    bool nan_ray = sylva_ray_to_grid(origin, direction, hdr.origin, hdr.inv_spacing, t_min, t_max, it.org, it.rcp,
                                     it.parallel);
    if (nan_ray) {
        it.status = SYLVA_ITER_DONE;
        return;
    }
    vec2 t = sylva_kd_box_interval_f(it.org, it.rcp, it.parallel, vec3(0.0f, 0.0f, 0.0f),
                                     vec3(float(hdr.dims.x), float(hdr.dims.y), float(hdr.dims.z)), t_min, t_max);
    it.t_cur = t.x;
    it.t_end = t.y;
    if (!(t.x < t.y)) it.status = SYLVA_ITER_DONE;
}

/// sylva_oct_begin with the header of `words` (`word_count` and `brick_buffer_words` are the
/// sizes of the index and brick buffers).
SYLVA_FN void sylva_oct_init(SYLVA_OUT(SylvaOctIter) it, SYLVA_BUF(words), uint word_count, uint brick_buffer_words,
                             vec3 origin, vec3 direction, float t_min, float t_max, uint max_level) {
    sylva_oct_begin(it, sylva_oct_read_header(SYLVA_PASS_BUF(words), word_count, brick_buffer_words), origin, direction,
                    t_min, t_max, max_level);
}

/// The cut's predicate: a node is a leaf of the current cut when it has no children (flags:
/// its record word +1), sits at max_level or is marked SYLVA_OCT_CUT_LEAF (the view-dependent
/// cut). Brick residency is not the walk's business: the out-of-core working set
/// (sylva/octree/residency.hpp) marks the cut so that its leaves are resident, and the
/// integrators (octree_dvr.h, octree_iso.h) sample only bricks in state SYLVA_OCT_BRICK_RESIDENT.
SYLVA_FN bool sylva_oct_is_cut_leaf(uint flags, uint level, uint max_level) {
    return sylva_oct_child_mask(flags) == 0u || level >= max_level || (flags & SYLVA_OCT_CUT_LEAF) != 0u;
}

/// Ends the traversal at t (early ray termination, first hits).
SYLVA_FN void sylva_oct_clip(SYLVA_INOUT(SylvaOctIter) it, float t) { it.t_end = sylva_min(it.t_end, t); }

/// The first exit plane of the current node's box: returns its ray parameter and sets `face`
/// (0 -x, 1 +x, 2 -y, 3 +y, 4 -z, 5 +z; the first axis among equal exits); +inf and face 6 when
/// the ray is parallel to every axis.
SYLVA_FN float sylva_oct_exit(SYLVA_IN(SylvaOctIter) it, SYLVA_OUT(uint) face) {
    vec3 lo;
    vec3 hi;
    sylva_oct_box(it.hdr, it.level, it.coord, lo, hi);
    float te = sylva_inf();
    face = 6u;
    for (uint k = 0u; k < 3u; k++) {
        if (sylva_kd_pick_u(it.parallel, k) == 0u) {
            float r = sylva_kd_pick(it.rcp, k);
            bool up = (floatBitsToUint(r) & 0x80000000u) == 0u;
            float plane = up ? sylva_kd_pick(hi, k) : sylva_kd_pick(lo, k);
            float t = sylva_canon((plane - sylva_kd_pick(it.org, k)) * r);
            if (t < te) {
                te = t;
                face = 2u * k + (up ? 1u : 0u);
            }
        }
    }
    return te;
}

/// Moves to the neighbour across `face` (Fig. 5's neighbour step; the box is recomputed from the
/// neighbour's level and coordinates); to the root when the neighbour lies below the cut
/// (SYLVA_OCT_CUT_BELOW), from which the next steps descend to the cut leaf at t. Ends the walk
/// (DONE) across the volume's boundary, and with ERROR on an index out of range, a deeper level
/// or a box outside the volume.
SYLVA_FN void sylva_oct_cross(SYLVA_INOUT(SylvaOctIter) it, SYLVA_BUF(words), uint face) {
    uint nb = (face < 6u) ? sylva_oct_neighbour(SYLVA_PASS_BUF(words), it.node, face) : SYLVA_OCT_NONE;
    if (nb == SYLVA_OCT_NONE) {
        it.status = SYLVA_ITER_DONE;
        return;
    }
    uint nflags = sylva_oct_flags(SYLVA_PASS_BUF(words), nb);
    uint lv = sylva_oct_level(nflags);
    uvec3 c = sylva_oct_coord(SYLVA_PASS_BUF(words), nb);
    if (nb >= it.hdr.node_count || lv > it.level) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    uint w = sylva_oct_width(it.hdr, lv);
    if (c.x >= (it.hdr.dims.x + w - 1u) / w || c.y >= (it.hdr.dims.y + w - 1u) / w || c.z >= (it.hdr.dims.z + w - 1u) / w) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    if ((nflags & SYLVA_OCT_CUT_BELOW) != 0u) {
        it.node = 0u;
        it.level = 0u;
        it.coord = uvec3(0u, 0u, 0u);
        return;
    }
    it.node = nb;
    it.level = lv;
    it.coord = c;
}

/// Upper (1) or lower (0) half along axis k of the current node for the ray at t_cur: the mid
/// plane's ray parameter against t_cur (the step function of Fig. 5), the origin against the
/// plane on an axis the ray is parallel to; lower when the upper half starts beyond the volume.
SYLVA_FN uint sylva_oct_half(SYLVA_IN(SylvaOctIter) it, uint k, uint child_width) {
    uint mid = (2u * sylva_kd_pick_u(it.coord, k) + 1u) * child_width;
    if (mid >= sylva_kd_pick_u(it.hdr.dims, k)) return 0u;
    float o = sylva_kd_pick(it.org, k);
    if (sylva_kd_pick_u(it.parallel, k) != 0u) return (o >= float(mid)) ? 1u : 0u;
    float r = sylva_kd_pick(it.rcp, k);
    float tm = sylva_canon((float(mid) - o) * r);
    bool up = (floatBitsToUint(r) & 0x80000000u) == 0u;
    if (up) return (it.t_cur >= tm) ? 1u : 0u;
    return (it.t_cur < tm) ? 1u : 0u;
}

/// Descends one level to the child containing the ray at t_cur (Fig. 5's down traversal).
SYLVA_FN void sylva_oct_descend(SYLVA_INOUT(SylvaOctIter) it, SYLVA_BUF(words), uint mask) {
    if (it.level + 1u >= it.hdr.levels) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    uint cw = sylva_oct_width(it.hdr, it.level + 1u);
    uvec3 b = uvec3(sylva_oct_half(it, 0u, cw), sylva_oct_half(it, 1u, cw), sylva_oct_half(it, 2u, cw));
    uint octant = b.x | (b.y << 1u) | (b.z << 2u);
    uint child = sylva_oct_child(sylva_oct_first_child(SYLVA_PASS_BUF(words), it.node), mask, octant);
    if (((mask >> octant) & 1u) == 0u || child >= it.hdr.node_count) {
        it.status = SYLVA_ITER_ERROR;
        return;
    }
    it.node = child;
    it.level = it.level + 1u;
    it.coord = uvec3(2u * it.coord.x + b.x, 2u * it.coord.y + b.y, 2u * it.coord.z + b.z);
}

/// Advances to the next leaf of the cut: its index and the ray's [t0, t1] inside it. Returns
/// false when the walk is over (status DONE) or stopped on a corrupted encoding (ERROR).
SYLVA_FN bool sylva_oct_next(SYLVA_INOUT(SylvaOctIter) it, SYLVA_BUF(words), SYLVA_OUT(uint) node, SYLVA_OUT(float) t0,
                             SYLVA_OUT(float) t1) {
    node = SYLVA_OCT_NONE;
    t0 = 0.0f;
    t1 = 0.0f;
    while (it.status == SYLVA_ITER_RUNNING) {
        if (!(it.t_cur < it.t_end)) {
            it.status = SYLVA_ITER_DONE;
            break;
        }
        it.steps = it.steps + 1u;
        if (it.steps > it.step_limit) {
            it.status = SYLVA_ITER_ERROR;
            break;
        }
        uint face;
        float te = sylva_oct_exit(it, face);
        if (te <= it.t_cur) {  // the ray has left this node: across the face to its neighbour
            sylva_oct_cross(it, SYLVA_PASS_BUF(words), face);
            continue;
        }
        uint flags = sylva_oct_flags(SYLVA_PASS_BUF(words), it.node);
        if (sylva_oct_is_cut_leaf(flags, it.level, it.max_level)) {
            node = it.node;
            t0 = it.t_cur;
            t1 = sylva_min(te, it.t_end);
            it.t_cur = t1;
            return true;
        }
        sylva_oct_descend(it, SYLVA_PASS_BUF(words), sylva_oct_child_mask(flags));
    }
    return false;
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_OCTREE_ITER_H
