// sylva/octree/lod_error.hpp -- what a coarse brick loses, under a transfer function: per node
// of the bricked octree, for each bin of the node's own (filtered) sample values, the range of
// the full-resolution voxels those samples stand for (LodDeviation, once per octree, from the
// bricks), and from it, once a transfer function, a bound on how far the node's classified
// samples at its coarse voxels lie from the classified voxels under them (lod_tf_errors; between
// coarse voxel centres a sample interpolates neighbours, so there it is an estimate). The view's cut (octree/cut.hpp) refines a node
// whose voxels project under CutConfig::lod_pixels while that bound exceeds
// CutConfig::max_tf_error.
//
// Why: Gobbetti et al. refine by projected size alone (one voxel per pixel). A box-filtered
// level averages thin opaque structures (the aneurism's vessels) into translucent ones, and at
// images where a coarse voxel projects to about a pixel this costs the image 10 dB and more
// (README, "Bricked octree"). Transfer-function-aware level selection from per-block value
// summaries follows Ljung, Lundstrom and Ynnerman, "Transfer function based adaptive
// decompression for volume rendering of large medical data sets" (IEEE VolVis 2004): a node's
// summary is data-only, so a new TF costs a pass over 64 bins a node, not over the voxels.
//
// The summary: node n, bin k of kLodErrorBins over [0, 1] of the node's own brick samples (its
// coarse voxels: the mean of the full-resolution voxels under each), `lo[n * bins + k]` and
// `hi[...]` are the least and greatest full-resolution voxel under the coarse voxels whose sample
// falls in bin k, in 1/255 steps rounded outward (lo > hi: no coarse voxel in the bin). Octree
// leaves are full resolution and keep empty tables. Computed bottom-up from the bricks alone
// (a coarse voxel's range is the union of its 8 children's, a leaf voxel's its value), so it
// works for any octree, in core or read from a store; coarse voxels under no child (outside the
// volume) add nothing. Nodes whose brick or a child's brick is not resident get [0, 1] in every
// bin (always refined when the bound is asked for).
#ifndef SYLVA_OCTREE_LOD_ERROR_HPP
#define SYLVA_OCTREE_LOD_ERROR_HPP

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/shared/octree_brick.h"
#include "sylva/shared/octree_layout.h"

namespace sylva::octree {

/// Bins of a node's own sample values in LodDeviation.
inline constexpr std::uint32_t kLodErrorBins = 64;

/// Per node and bin of its own sample values, the full-resolution densities under them (top).
struct LodDeviation {
    std::vector<std::uint8_t> lo, hi;  ///< node * kLodErrorBins + bin; 1/255 steps, lo > hi: empty
    [[nodiscard]] std::size_t nodes() const { return lo.size() / kLodErrorBins; }
};

namespace detail {

inline std::uint32_t lod_bin(float v) {
    const float c = std::clamp(v, 0.0f, 1.0f) * float(kLodErrorBins);
    return std::min(static_cast<std::uint32_t>(c), kLodErrorBins - 1u);
}

inline std::uint8_t lod_floor255(float v) { return static_cast<std::uint8_t>(std::floor(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }
inline std::uint8_t lod_ceil255(float v) { return static_cast<std::uint8_t>(std::ceil(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }

/// Per coarse voxel of an inner node (B^3, x fastest), the [min, max] of the full-resolution
/// voxels under it in 1/255 steps rounded outward (as the tables keep them, so the tables come
/// out the same as from float ranges): `range[2 i]`, `range[2 i + 1]`. 64 KiB a node at B = 32.
using VoxelRanges = std::vector<std::uint8_t>;

}  // namespace detail

/// The LodDeviation of an encoded octree (index `words`, `bricks` beside it), level by level from
/// the deepest, nodes of a level in parallel. Throws sylva::Error for an invalid header or a
/// child outside its parent.
template <Executor X>
LodDeviation lod_deviation(std::span<const std::uint32_t> words, std::span<const std::uint32_t> bricks, X& exec) {
    if (words.size() > 0xFFFFFFFFu || bricks.size() > 0xFFFFFFFFu) throw Error("octree::lod_deviation: buffers over 2^32 words");
    shared::Words w{words.data(), words.size()}, bw{bricks.data(), bricks.size()};
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(w, std::uint32_t(words.size()), std::uint32_t(bricks.size()));
    if (h.valid == 0u) throw Error("octree::lod_deviation: not a valid encoded octree");
    const std::uint32_t N = kLodErrorBins, B = h.brick_size, b = h.border, S = B + 2u * b, half = B / 2u;
    LodDeviation d;
    d.lo.assign(std::size_t{h.node_count} * N, 255u);
    d.hi.assign(std::size_t{h.node_count} * N, 0u);
    std::vector<std::vector<std::uint32_t>> by_level(h.levels);
    for (std::uint32_t n = 0; n < h.node_count; ++n) {
        const std::uint32_t level = shared::sylva_oct_level(shared::sylva_oct_flags(w, n));
        if (level >= h.levels) throw Error("octree::lod_deviation: a node's level is past the header's levels");
        by_level[level].push_back(n);
    }
    auto resident = [&](std::uint32_t n) {
        return shared::sylva_oct_brick_state(shared::sylva_oct_flags(w, n)) == SYLVA_OCT_BRICK_RESIDENT &&
               shared::sylva_oct_brick(w, n) < h.brick_count;
    };
    auto sample = [&](std::uint32_t n, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
        return shared::sylva_oct_brick_value(bw, shared::sylva_oct_brick(w, n) * h.brick_words, h.format,
                                             (x + b) + S * ((y + b) + S * (z + b)));
    };
    // The voxel ranges of the inner nodes of the level below the one being processed.
    std::vector<detail::VoxelRanges> ranges(h.node_count);
    for (std::uint32_t level = h.levels; level-- > 0;) {
        const std::vector<std::uint32_t>& nodes = by_level[level];
        std::atomic<bool> bad_child{false};
        exec.parallel_for(0, nodes.size(), 1, [&](std::size_t i0, std::size_t i1) {
            for (std::size_t i = i0; i < i1; ++i) {
                const std::uint32_t n = nodes[i];
                const std::uint32_t mask = shared::sylva_oct_child_mask(shared::sylva_oct_flags(w, n));
                if (mask == 0u) continue;  // a leaf: full resolution
                std::uint8_t* lo = &d.lo[std::size_t{n} * N];
                std::uint8_t* hi = &d.hi[std::size_t{n} * N];
                const std::uint32_t first = shared::sylva_oct_first_child(w, n), kids = std::uint32_t(std::popcount(mask));
                bool whole = !resident(n) || std::uint64_t{first} + kids > h.node_count;
                for (std::uint32_t k = 0; k < kids && !whole; ++k) whole = !resident(first + k);
                detail::VoxelRanges& own = ranges[n];
                own.assign(std::size_t{2} * B * B * B, std::uint8_t{0});
                std::vector<std::uint8_t> covered(std::size_t{B} * B * B, 0u);
                const glm::u32vec3 pc = shared::sylva_oct_coord(w, n);
                for (std::uint32_t k = 0; k < kids && !whole; ++k) {
                    const std::uint32_t c = first + k;
                    const glm::u32vec3 oct = shared::sylva_oct_coord(w, c) - 2u * pc;
                    if (oct.x > 1u || oct.y > 1u || oct.z > 1u ||
                        shared::sylva_oct_level(shared::sylva_oct_flags(w, c)) != level + 1u) {
                        bad_child = true;
                        return;
                    }
                    const bool inner = shared::sylva_oct_child_mask(shared::sylva_oct_flags(w, c)) != 0u;
                    const detail::VoxelRanges* cr = inner ? &ranges[c] : nullptr;
                    if (cr != nullptr && cr->size() != own.size()) {  // a child without ranges: not resident below
                        whole = true;
                        break;
                    }
                    // The parent's coarse voxels in this octant: (oct * B/2 + (x, y, z)), each over
                    // the child's voxels 2 (x, y, z) + {0, 1}^3.
                    for (std::uint32_t z = 0; z < half; ++z)
                        for (std::uint32_t y = 0; y < half; ++y)
                            for (std::uint32_t x = 0; x < half; ++x) {
                                std::uint8_t a = 255u, e = 0u;
                                if (cr != nullptr) {
                                    for (std::uint32_t q = 0; q < 8; ++q) {
                                        const std::uint32_t cx = 2 * x + (q & 1u), cy = 2 * y + ((q >> 1) & 1u), cz = 2 * z + (q >> 2);
                                        const std::size_t at = 2 * (cx + B * (cy + std::size_t{B} * cz));
                                        a = std::min(a, (*cr)[at]);
                                        e = std::max(e, (*cr)[at + 1]);
                                    }
                                } else {  // a leaf child: its voxels
                                    float fa = std::numeric_limits<float>::infinity(), fe = -fa;
                                    for (std::uint32_t q = 0; q < 8; ++q) {
                                        const float u = sample(c, 2 * x + (q & 1u), 2 * y + ((q >> 1) & 1u), 2 * z + (q >> 2));
                                        fa = std::min(fa, u);
                                        fe = std::max(fe, u);
                                    }
                                    a = detail::lod_floor255(fa);
                                    e = detail::lod_ceil255(fe);
                                }
                                const glm::u32vec3 v = oct * half + glm::u32vec3(x, y, z);
                                const std::size_t at = v.x + B * (v.y + std::size_t{B} * v.z);
                                own[2 * at] = a;
                                own[2 * at + 1] = e;
                                covered[at] = 1u;
                                const std::uint32_t bin = detail::lod_bin(sample(n, v.x, v.y, v.z));
                                lo[bin] = std::min(lo[bin], a);
                                hi[bin] = std::max(hi[bin], e);
                            }
                }
                if (whole) {
                    std::fill(lo, lo + N, std::uint8_t{0});
                    std::fill(hi, hi + N, std::uint8_t{255});
                    own.clear();  // the parent treats it as unknown too
                    continue;
                }
                for (std::size_t v = 0; v < covered.size(); ++v)  // outside the volume: the node's own sample
                    if (covered[v] == 0u) {
                        const float c = sample(n, std::uint32_t(v % B), std::uint32_t(v / B % B), std::uint32_t(v / B / B));
                        own[2 * v] = detail::lod_floor255(c);
                        own[2 * v + 1] = detail::lod_ceil255(c);
                    }
            }
        });
        if (bad_child) throw Error("octree::lod_deviation: a child outside its parent (or not on the next level)");
        // The level below is done with (freed only now: a corrupted index may give two parents
        // one child, and they run in parallel).
        if (level + 1u < h.levels)
            for (std::uint32_t c : by_level[level + 1u]) detail::VoxelRanges().swap(ranges[c]);
    }
    return d;
}

/// Per node, a bound on how far its classified samples lie from those of the voxels under them,
/// for a transfer function given as `premultiplied`: RGBA with colour times opacity, sampled at
/// `entries` >= 2 evenly spaced densities over [0, 1] (linear between them, as the renderers
/// interpolate their tables; pass the table itself or a finer sampling of a hook). For each bin
/// of the node's own values and each channel, the larger of (greatest over the voxels' range -
/// least over the bin) and (greatest over the bin - least over the voxels' range); the node's
/// bound is the largest over its non-empty bins. 0 for leaves of the octree.
inline std::vector<float> lod_tf_errors(const LodDeviation& d, std::span<const vec4> premultiplied) {
    const std::size_t E = premultiplied.size();
    if (E < 2) throw Error("octree::lod_tf_errors: the transfer function needs at least 2 entries");
    if (d.lo.size() != d.hi.size() || d.lo.size() % kLodErrorBins != 0)
        throw Error("octree::lod_tf_errors: the deviation tables do not match");
    // Extremes over entry ranges by a sparse table (levels of powers of two).
    std::vector<std::vector<vec4>> mn{std::vector<vec4>(premultiplied.begin(), premultiplied.end())}, mx = mn;
    for (std::size_t len = 2; len <= E; len *= 2) {
        const std::vector<vec4>&pm = mn.back(), &px = mx.back();
        std::vector<vec4> a(E - len + 1), z(E - len + 1);
        for (std::size_t i = 0; i + len <= E; ++i) {
            a[i] = glm::min(pm[i], pm[i + len / 2]);
            z[i] = glm::max(px[i], px[i + len / 2]);
        }
        mn.push_back(std::move(a));
        mx.push_back(std::move(z));
    }
    // Entries whose interpolation intervals meet densities [lo, hi].
    auto extremes = [&](float lo, float hi, vec4& a, vec4& z) {
        const float last = float(E - 1);
        const std::size_t i0 = static_cast<std::size_t>(std::floor(std::clamp(lo, 0.0f, 1.0f) * last));
        const std::size_t i1 = std::min(E - 1, static_cast<std::size_t>(std::ceil(std::clamp(hi, 0.0f, 1.0f) * last)));
        const std::size_t len = i1 - i0 + 1, k = std::bit_width(len) - 1;
        a = glm::min(mn[k][i0], mn[k][i1 + 1 - (std::size_t{1} << k)]);
        z = glm::max(mx[k][i0], mx[k][i1 + 1 - (std::size_t{1} << k)]);
    };
    std::vector<float> err(d.nodes(), 0.0f);
    for (std::size_t n = 0; n < err.size(); ++n) {
        float e = 0.0f;
        for (std::uint32_t k = 0; k < kLodErrorBins; ++k) {
            const std::uint8_t lo = d.lo[n * kLodErrorBins + k], hi = d.hi[n * kLodErrorBins + k];
            if (lo > hi) continue;
            vec4 ua, uz, ca, cz;
            extremes(float(lo) / 255.0f, float(hi) / 255.0f, ua, uz);
            extremes(float(k) / float(kLodErrorBins), float(k + 1) / float(kLodErrorBins), ca, cz);
            const vec4 worst = glm::max(uz - ca, cz - ua);
            e = std::max(e, std::max(std::max(worst.x, worst.y), std::max(worst.z, worst.w)));
        }
        err[n] = e;
    }
    return err;
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_LOD_ERROR_HPP
