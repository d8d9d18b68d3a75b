// sylva/octree/octants.hpp -- empty-space skipping inside a brick: per node, the density range of
// each octant of its brick (B/2 voxels of the node's level a side, plus one voxel around, as the
// node's own [min, max]), and from them, once a transfer function, one mask word per node whose
// bit o is set when octant o can show anything (sylva/shared/octree_dvr.h,
// sylva_oct_dvr_ray_masked). The DVR then skips the octants of a leaf the TF leaves empty, at
// B/2 granularity, without deeper trees or more brick memory: on the aneurism with B = 16 the
// samples per ray fall to about those of B = 8 bricks (measured in sylva-octree-bench), whose
// borders would cost 1.7x the brick memory. The image is unchanged (the skipped samples have no
// opacity). Gobbetti et al. skip empty nodes only; this is the same test one level finer,
// computed from the brick itself (so it works for any octree, in-core or from a store).
#ifndef SYLVA_OCTREE_OCTANTS_HPP
#define SYLVA_OCTREE_OCTANTS_HPP

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/shared/octree_dvr.h"
#include "sylva/shared/octree_layout.h"

namespace sylva::octree {

/// Per node, per octant, the [min, max] of the brick samples trilinear sampling inside the
/// octant can read: `values[16 n + 2 o]` and `[16 n + 2 o + 1]`. Nodes without a resident
/// brick get [-inf, +inf] (never skipped). `face[n]`: bit o set when octant o of node n touches a
/// face of the volume (sylva_oct_face_octants), where a constant border blends in.
struct OctantRanges {
    std::vector<float> values;
    std::vector<std::uint8_t> face;
    [[nodiscard]] std::size_t nodes() const { return values.size() / 16u; }
};

namespace detail {

/// Octant o's ranges of one brick (S samples a side, border b, B voxels, samples in `format`,
/// its words from `base` of `bricks`): per axis, brick samples [b - 1, b + B/2] for the lower
/// half, [b + B/2 - 1, b + B] for the upper one.
inline void brick_octant_ranges(shared::Words bricks, std::uint32_t base, std::uint32_t format, std::uint32_t B, std::uint32_t b,
                                float* out) {
    const std::uint32_t S = B + 2u * b;
    for (std::uint32_t o = 0; o < 8; ++o) {
        std::uint32_t lo[3], hi[3];
        for (std::uint32_t k = 0; k < 3; ++k) {
            bool up = ((o >> k) & 1u) != 0u;
            lo[k] = up ? b + B / 2u - 1u : b - 1u;
            hi[k] = up ? b + B : b + B / 2u;
        }
        float a = std::numeric_limits<float>::infinity(), z = -a;
        for (std::uint32_t zz = lo[2]; zz <= hi[2]; ++zz)
            for (std::uint32_t y = lo[1]; y <= hi[1]; ++y)
                for (std::uint32_t x = lo[0]; x <= hi[0]; ++x) {
                    float v = shared::sylva_oct_brick_value(bricks, base, format, x + S * (y + S * zz));
                    a = std::min(a, v);
                    z = std::max(z, v);
                }
        out[2 * o] = a;
        out[2 * o + 1] = z;
    }
}

}  // namespace detail

/// The octant ranges of every node of an encoded octree (index `words`, `bricks` beside it),
/// in parallel. Throws sylva::Error for an invalid header (sylva_oct_read_header's checks).
template <Executor X>
OctantRanges octant_ranges(std::span<const std::uint32_t> words, std::span<const std::uint32_t> bricks, X& exec) {
    if (words.size() > 0xFFFFFFFFu || bricks.size() > 0xFFFFFFFFu) throw Error("octree::octant_ranges: buffers over 2^32 words");
    shared::Words w{words.data(), words.size()};
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(w, std::uint32_t(words.size()), std::uint32_t(bricks.size()));
    if (h.valid == 0u) throw Error("octree::octant_ranges: not a valid encoded octree");
    OctantRanges r;
    r.values.assign(std::size_t{h.node_count} * 16u, 0.0f);
    r.face.assign(h.node_count, 0u);
    const float inf = std::numeric_limits<float>::infinity();
    exec.parallel_for(0, h.node_count, 16, [&](std::size_t n0, std::size_t n1) {
        for (std::size_t n = n0; n < n1; ++n) {
            float* out = &r.values[16 * n];
            std::uint32_t node = std::uint32_t(n);
            r.face[n] = std::uint8_t(shared::sylva_oct_face_octants(h, shared::sylva_oct_level(shared::sylva_oct_flags(w, node)),
                                                                     shared::sylva_oct_coord(w, node)));
            std::uint32_t state = shared::sylva_oct_brick_state(shared::sylva_oct_flags(w, node));
            std::uint32_t brick = shared::sylva_oct_brick(w, node);
            if (state != SYLVA_OCT_BRICK_RESIDENT || brick >= h.brick_count) {
                for (std::uint32_t o = 0; o < 8; ++o) out[2 * o] = -inf, out[2 * o + 1] = inf;
                continue;
            }
            detail::brick_octant_ranges(shared::Words{bricks.data(), bricks.size()}, brick * h.brick_words, h.format,
                                        h.brick_size, h.border, out);
        }
    });
    return r;
}

/// One mask word per node for the transfer function whose opacity prefix counts are `tfsum`
/// (render/octree_volume.hpp: tf_opacity_prefix; entries + 1 words): bit o set unless the TF
/// gives zero opacity to all of octant o's range (the node-level test of octree_dvr.h).
///
/// Border. Samples near a face of the volume blend towards a constant border's value. Masks
/// made without `constant_border` know the voxels only: rendered with a constant border
/// (OctreeView::border), the octants on a face are then sampled whatever their bit. With
/// `constant_border` = v the ranges of octants on a face include v and every word gets
/// SYLVA_OCT_OCTMASK_BORDER (bit 8), which lets the renderer trust the face bits: masks for the
/// border the frame is rendered with (v = its value) skip as much with that border as without.
/// Such masks stay correct for a clamped border (they only set more bits); with another constant
/// they are wrong, so make them again when the border changes, as when the TF does.
inline std::vector<std::uint32_t> octant_masks(const OctantRanges& r, std::span<const std::uint32_t> tfsum,
                                               std::optional<float> constant_border = std::nullopt) {
    if (tfsum.empty()) throw Error("octree::octant_masks: no transfer function prefix counts");
    if (constant_border && !std::isfinite(*constant_border)) throw Error("octree::octant_masks: the border value is not finite");
    if (r.face.size() != r.nodes()) throw Error("octree::octant_masks: octant ranges without their face bits");
    shared::Words s{tfsum.data(), tfsum.size()};
    const std::uint32_t entries = std::uint32_t(tfsum.size() - 1u);
    std::vector<std::uint32_t> masks(r.nodes(), constant_border ? SYLVA_OCT_OCTMASK_BORDER : 0u);
    for (std::size_t n = 0; n < masks.size(); ++n)
        for (std::uint32_t o = 0; o < 8; ++o) {
            float lo = r.values[16 * n + 2 * o], hi = r.values[16 * n + 2 * o + 1];
            bool unbounded = !(lo > -std::numeric_limits<float>::infinity()) || !(hi < std::numeric_limits<float>::infinity());
            if (constant_border && ((r.face[n] >> o) & 1u) != 0u) {
                lo = std::min(lo, *constant_border);
                hi = std::max(hi, *constant_border);
            }
            if (unbounded || !shared::sylva_oct_tf_empty(s, entries, lo, hi)) masks[n] |= 1u << o;
        }
    return masks;
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_OCTANTS_HPP
