// sylva/shared/ikd_layout.h -- the encoding of Wald et al.'s implicit min/max kd-tree ("Faster
// Isosurface Ray Tracing using Implicit KD-Trees", sections 3.3 and 5), and its shared decoder.
//
// The tree. A grid of R voxels per axis has C = R - 1 cells per axis; cell c spans the samples
// c and c + 1 (voxel centres), so in cell space (see below) it is the box [c, c + 1]. The cell
// counts are padded virtually to powers of two P = 2^lg >= C (section 5.3, Fig. 5) and a
// balanced kd-tree of L = lg.x + lg.y + lg.z levels splits that padded box in halves, one axis
// per level (the axis with the most halvings left, x before y before z). A node of level l is
// the box of 2^w.x * 2^w.y * 2^w.z cells starting at cell (x0, y0, z0), a multiple of its size;
// its children are the two halves along the level's axis (section 5.1: one axis and one plane
// rule per level, no pointers: a node is found from (x0, y0, z0, l)). Boxes are clipped to the
// real cells [0, C]: a node or child that starts at or beyond C is virtual, never stored and
// never visited. Level L holds the cells themselves: they are not stored (section 5.2); their
// min/max come from the eight corner samples on the fly.
//
// Cell space. World point p maps to u = (p - origin) / spacing, where origin is the world
// position of sample (0, 0, 0) (the voxel centre 0.5 * spacing in sylva's grid convention).
//
// Words (32-bit), offset: meaning
//   0       magic SYLVA_IKD_MAGIC ("SIKD")
//   1       version SYLVA_IKD_VERSION
//   2-4     cells per axis C.x, C.y, C.z (each 1 .. 65535)
//   5       bits 0-7: levels L; bits 8-12, 16-20, 24-28: lg.x, lg.y, lg.z (P = 2^lg, the least
//           power of two >= C; L = lg.x + lg.y + lg.z <= 48)
//   6       stored nodes N (levels 0 .. L - 1)
//   7       bits 0-7: node format, the normalised [min, max] density of a node's cells, min
//           rounded down and max rounded up so culling stays conservative:
//             0 (SYLVA_IKD_FORMAT_UNORM16) one word a node: min as unorm16 in bits 0-15, max
//               in bits 16-31; N node words;
//             1 (SYLVA_IKD_FORMAT_UNORM8) half a word a node: node k in bits 16 (k & 1) ..
//               16 (k & 1) + 15 of node word k >> 1, min as unorm8 in its bits 0-7 and max in
//               bits 8-15 (Wald's 8-bit ranges, section 5.2); (N + 1) / 2 node words, the
//               unused half of the last one 0. Readers widen q to q * 257, the unorm16 code of
//               the same density q / 255 (sylva_ikd_node_word), so both formats are tested
//               alike;
//           bits 8-15: stored levels S <= L. Levels S .. L - 1 are bricks
//           (sylva/ikd/build.hpp Config::brick_levels): not stored, never culled, their cells
//           tested one by one; bits 16-31: 0
//   8-9     value range lo, hi (float bits): the raw values that mapped to densities 0 and 1
//   10-12   spacing (float bits, finite, > 0): world size of one cell
//   13-15   origin (float bits, finite): world position of sample (0, 0, 0)
//   16      total word count
//   17-19   1 / spacing (float bits, finite, > 0; computed on the host, so that both targets map
//           rays into cell space with the same multiplications)
//   20 + 2l level table entry of level l (l = 0 .. L - 1):
//           bits 0-1: split axis a (0 x, 1 y, 2 z); bits 8-12, 16-20, 24-28: log2 of the node
//           width in cells w.x, w.y, w.z (level 0: lg; level l + 1: level l's with w.a - 1)
//   21 + 2l first node of level l (index into the node words; level 0 starts at 0; levels
//           S .. L - 1 store none and hold the node count N)
//   20 + 2L the node words (format: word 7), level by level; node (x0, y0, z0) of level l is node
//           first_l + (x0 >> w.x) + r.x * ((y0 >> w.y) + r.y * (z0 >> w.z)), with
//           r = ceil(C / 2^w) the real nodes of the level per axis.
// The grid the cells read is a separate buffer `grid` of the (C.x + 1) (C.y + 1) (C.z + 1)
// samples, x fastest, in one of the dense formats of sylva/shared/grid_sample.h: SYLVA_GRID_F32
// (one word a sample, float bits of normalised densities) or SYLVA_GRID_U8 / U16 (raw values
// packed 4 / 2 a word, normalised on the fly with a value range, sylva_grid_normalise). The
// format and range are not part of the encoding: the reader is given them with the grid
// (sylva_ikd_read_header_grid; the renderer's parameter block, sylva/shared/iso_render.h).
#ifndef SYLVA_SHARED_IKD_LAYOUT_H
#define SYLVA_SHARED_IKD_LAYOUT_H

#include "sylva/shared/grid_sample.h"
#include "sylva/shared/lang.h"

#define SYLVA_IKD_MAGIC 0x444B4953u
#define SYLVA_IKD_VERSION 1u
#define SYLVA_IKD_HEADER_WORDS 20u
#define SYLVA_IKD_MAX_CELLS 65535u
#define SYLVA_IKD_MAX_LEVELS 48u
#define SYLVA_IKD_FORMAT_UNORM16 0u
#define SYLVA_IKD_FORMAT_UNORM8 1u

SYLVA_BEGIN_NAMESPACE

/// The decoded header. `valid` is 1 only when every check of sylva_ikd_read_header passed.
struct SylvaIkdHeader {
    uvec3 cells;
    uvec3 lg;
    uint levels;
    uint stored;  ///< levels with node words (S); the rest are bricks
    uint node_count;
    uint format;
    vec3 spacing;
    vec3 inv_spacing;
    vec3 origin;
    uint nodes_at;  ///< word offset of node 0
    uint grid_format;  ///< the grid's SYLVA_GRID_F32, _U8 or _U16 (given to the reader, not encoded)
    float value_lo;    ///< integer grids: raw value of density 0
    float value_span;  ///< integer grids: raw values per unit of density (> 0)
    uint valid;
};

/// Bits [at, at + 5) of w.
SYLVA_FN uint sylva_ikd_bits5(uint w, uint at) { return (w >> at) & 31u; }

/// Node words that hold n nodes in `format` (SYLVA_IKD_FORMAT_UNORM16 or _UNORM8).
SYLVA_FN uint sylva_ikd_node_words(uint n, uint format) {
    return (format == SYLVA_IKD_FORMAT_UNORM8) ? (n >> 1u) + (n & 1u) : n;
}

/// Least lg with 2^lg >= c (c >= 1).
SYLVA_FN uint sylva_ikd_log2_ceil(uint c) {
    uint lg = 0u;
    while (lg < 31u && (1u << lg) < c) lg = lg + 1u;
    return lg;
}

/// Real nodes per axis of a level whose nodes are 2^w cells wide: ceil(cells / 2^w).
SYLVA_FN uvec3 sylva_ikd_real_nodes(uvec3 cells, uvec3 w) {
    return uvec3((cells.x + (1u << w.x) - 1u) >> w.x, (cells.y + (1u << w.y) - 1u) >> w.y,
                 (cells.z + (1u << w.z) - 1u) >> w.z);
}

/// Node widths (log2, cells) of level l's table entry.
SYLVA_FN uvec3 sylva_ikd_level_widths(uint entry) {
    return uvec3(sylva_ikd_bits5(entry, 8u), sylva_ikd_bits5(entry, 16u), sylva_ikd_bits5(entry, 24u));
}

/// Checks the level table: widths start at lg and halve along each level's axis down to single
/// cells, and each stored level's first node follows the previous level's real nodes (levels
/// from `stored` on hold none). Returns the node count it implies, or 0xFFFFFFFF when the table
/// is inconsistent. Call it only for cell counts whose grid was checked to have fewer than
/// 2^32 samples.
SYLVA_FN uint sylva_ikd_check_levels(SYLVA_BUF(words), uvec3 cells, uvec3 lg, uint levels, uint stored) {
    uvec3 w = lg;
    uint first = 0u;
    for (uint l = 0u; l < levels; l++) {
        uint entry = SYLVA_LOAD(words, SYLVA_IKD_HEADER_WORDS + 2u * l);
        uint axis = entry & 3u;
        uvec3 lw = sylva_ikd_level_widths(entry);
        uint wa = (axis == 0u) ? w.x : ((axis == 1u) ? w.y : w.z);
        if (axis > 2u || lw.x != w.x || lw.y != w.y || lw.z != w.z || wa == 0u) return 0xFFFFFFFFu;
        if (SYLVA_LOAD(words, SYLVA_IKD_HEADER_WORDS + 2u * l + 1u) != first) return 0xFFFFFFFFu;
        uvec3 r = sylva_ikd_real_nodes(cells, w);
        uint n = (l < stored) ? r.x * r.y * r.z : 0u;  // <= the cell count, below 2^32 (grid checked)
        if (first + n < first) return 0xFFFFFFFFu;
        first = first + n;
        w = uvec3((axis == 0u) ? w.x - 1u : w.x, (axis == 1u) ? w.y - 1u : w.y, (axis == 2u) ? w.z - 1u : w.z);
    }
    if (w.x != 0u || w.y != 0u || w.z != 0u) return 0xFFFFFFFFu;
    return first;
}

/// Words of a dense grid of n samples in `format` (SYLVA_GRID_F32, U8 or U16; n < 2^32).
SYLVA_FN uint sylva_ikd_grid_words(uint n, uint format) {
    if (format == SYLVA_GRID_U8) return (n >> 2u) + (((n & 3u) != 0u) ? 1u : 0u);
    if (format == SYLVA_GRID_U16) return (n >> 1u) + (n & 1u);
    return n;
}

/// Reads and checks the header of an encoding of `word_count` words whose grid buffer holds
/// `grid_words` words of samples in `grid_format` (value range value_lo, value_span for the
/// integer formats): magic, version, cell counts, padding, level count, the level table, the
/// node count, the total size, a finite positive spacing and 1 / spacing, a finite origin, the
/// grid's format, range and word count. Invalid: valid = 0.
SYLVA_FN SylvaIkdHeader sylva_ikd_read_header_grid(SYLVA_BUF(words), uint word_count, uint grid_words, uint grid_format,
                                                   float value_lo, float value_span) {
    SylvaIkdHeader h;
    h.grid_format = grid_format;
    h.value_lo = value_lo;
    h.value_span = value_span;
    h.cells = uvec3(SYLVA_LOAD(words, 2u), SYLVA_LOAD(words, 3u), SYLVA_LOAD(words, 4u));
    uint packed = SYLVA_LOAD(words, 5u);
    h.levels = packed & 255u;
    h.lg = uvec3(sylva_ikd_bits5(packed, 8u), sylva_ikd_bits5(packed, 16u), sylva_ikd_bits5(packed, 24u));
    h.node_count = SYLVA_LOAD(words, 6u);
    h.format = SYLVA_LOAD(words, 7u) & 255u;
    h.stored = (SYLVA_LOAD(words, 7u) >> 8u) & 255u;
    h.spacing = vec3(uintBitsToFloat(SYLVA_LOAD(words, 10u)), uintBitsToFloat(SYLVA_LOAD(words, 11u)),
                     uintBitsToFloat(SYLVA_LOAD(words, 12u)));
    h.inv_spacing = vec3(uintBitsToFloat(SYLVA_LOAD(words, 17u)), uintBitsToFloat(SYLVA_LOAD(words, 18u)),
                         uintBitsToFloat(SYLVA_LOAD(words, 19u)));
    h.origin = vec3(uintBitsToFloat(SYLVA_LOAD(words, 13u)), uintBitsToFloat(SYLVA_LOAD(words, 14u)),
                    uintBitsToFloat(SYLVA_LOAD(words, 15u)));
    h.nodes_at = SYLVA_IKD_HEADER_WORDS + 2u * h.levels;
    h.valid = 0u;
    bool ok = word_count >= SYLVA_IKD_HEADER_WORDS && SYLVA_LOAD(words, 0u) == SYLVA_IKD_MAGIC &&
              SYLVA_LOAD(words, 1u) == SYLVA_IKD_VERSION &&
              (h.format == SYLVA_IKD_FORMAT_UNORM16 || h.format == SYLVA_IKD_FORMAT_UNORM8) &&
              (SYLVA_LOAD(words, 7u) >> 16u) == 0u;
    ok = ok && h.cells.x >= 1u && h.cells.y >= 1u && h.cells.z >= 1u && h.cells.x <= SYLVA_IKD_MAX_CELLS &&
         h.cells.y <= SYLVA_IKD_MAX_CELLS && h.cells.z <= SYLVA_IKD_MAX_CELLS;
    ok = ok && h.lg.x == sylva_ikd_log2_ceil(h.cells.x) && h.lg.y == sylva_ikd_log2_ceil(h.cells.y) &&
         h.lg.z == sylva_ikd_log2_ceil(h.cells.z) && h.levels == h.lg.x + h.lg.y + h.lg.z && h.stored <= h.levels;
    ok = ok && SYLVA_LOAD(words, 16u) == word_count && h.nodes_at <= word_count &&
         word_count - h.nodes_at == sylva_ikd_node_words(h.node_count, h.format);
    ok = ok && h.spacing.x > 0.0f && h.spacing.y > 0.0f && h.spacing.z > 0.0f && h.spacing.x < sylva_inf() &&
         h.spacing.y < sylva_inf() && h.spacing.z < sylva_inf();
    ok = ok && h.inv_spacing.x > 0.0f && h.inv_spacing.y > 0.0f && h.inv_spacing.z > 0.0f &&
         h.inv_spacing.x < sylva_inf() && h.inv_spacing.y < sylva_inf() && h.inv_spacing.z < sylva_inf();
    ok = ok && h.origin.x > -sylva_inf() && h.origin.x < sylva_inf() && h.origin.y > -sylva_inf() &&
         h.origin.y < sylva_inf() && h.origin.z > -sylva_inf() && h.origin.z < sylva_inf();
    ok = ok && (grid_format == SYLVA_GRID_F32 || grid_format == SYLVA_GRID_U8 || grid_format == SYLVA_GRID_U16);
    ok = ok && (grid_format == SYLVA_GRID_F32 || (value_span > 0.0f && value_span < sylva_inf() &&
                                                  value_lo > -sylva_inf() && value_lo < sylva_inf()));
    if (!ok) return h;
    // The grid: (C + 1)^3 samples (fewer than 2^32), in the words of its format.
    uint gx = h.cells.x + 1u;
    uint gy = h.cells.y + 1u;
    uint gz = h.cells.z + 1u;
    if (gx * gy / gy != gx || (gx * gy) * gz / gz != gx * gy) return h;
    if (sylva_ikd_grid_words(gx * gy * gz, grid_format) != grid_words) return h;
    if (sylva_ikd_check_levels(SYLVA_PASS_BUF(words), h.cells, h.lg, h.levels, h.stored) != h.node_count) return h;
    h.valid = 1u;
    return h;
}

/// sylva_ikd_read_header_grid for a float32 grid (SYLVA_GRID_F32) of `grid_words` words.
SYLVA_FN SylvaIkdHeader sylva_ikd_read_header(SYLVA_BUF(words), uint word_count, uint grid_words) {
    return sylva_ikd_read_header_grid(SYLVA_PASS_BUF(words), word_count, grid_words, SYLVA_GRID_F32, 0.0f, 1.0f);
}

/// Level l's table entry and first node.
SYLVA_FN uint sylva_ikd_level_entry(SYLVA_BUF(words), uint l) { return SYLVA_LOAD(words, SYLVA_IKD_HEADER_WORDS + 2u * l); }
SYLVA_FN uint sylva_ikd_level_first(SYLVA_BUF(words), uint l) {
    return SYLVA_LOAD(words, SYLVA_IKD_HEADER_WORDS + 2u * l + 1u);
}

/// Index of the node of level l (table entry `entry`) that starts at cell `o`.
SYLVA_FN uint sylva_ikd_node_index(SYLVA_BUF(words), uvec3 cells, uint l, uint entry, uvec3 o) {
    uvec3 w = sylva_ikd_level_widths(entry);
    uvec3 r = sylva_ikd_real_nodes(cells, w);
    return sylva_ikd_level_first(SYLVA_PASS_BUF(words), l) + (o.x >> w.x) + r.x * ((o.y >> w.y) + r.y * (o.z >> w.z));
}

/// Node k's range as a unorm16 pair (min | max << 16) whatever the header's format: an 8-bit
/// code q widens to q * 257, the unorm16 code of the same density q / 255 = q * 257 / 65535.
SYLVA_FN uint sylva_ikd_node_word(SYLVA_BUF(words), SYLVA_IN(SylvaIkdHeader) hdr, uint k) {
    if (hdr.format == SYLVA_IKD_FORMAT_UNORM8) {
        uint pair = (SYLVA_LOAD(words, hdr.nodes_at + (k >> 1u)) >> ((k & 1u) * 16u)) & 0xFFFFu;
        return ((pair & 0xFFu) * 257u) | (((pair >> 8u) * 257u) << 16u);
    }
    return SYLVA_LOAD(words, hdr.nodes_at + k);
}

/// Normalised [min, max] density of a node word (unorm16 pair).
SYLVA_FN vec2 sylva_ikd_node_range(uint word) {
    return vec2(float(word & 0xFFFFu) / 65535.0f, float(word >> 16u) / 65535.0f);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_IKD_LAYOUT_H
