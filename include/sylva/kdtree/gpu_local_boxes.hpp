// sylva/kdtree/gpu_local_boxes.hpp -- the local-AABB pass of Zellmann et al.'s GPU builder
// (section 4.3) in the layout of the compute shader: one word per 8^3 block (dense, blocks x
// fastest; layout in sylva/shared/kd_local_boxes.h), then a gather along the z-order Morton
// curve into the LocalBoxes the binned builder reads (sylva/kdtree/local_boxes.hpp).
//
//  * BlockOrder          every block of a grid in ascending Morton order. It depends only on
//                        the dimensions, so a rebuild after a transfer-function change reuses it
//                        and gathers the non-empty blocks already sorted (no sort per build;
//                        the paper sorts the boxes after every pass).
//  * block_words         the pass on the host from any OccupancySource (rows of blocks in
//                        parallel; the fast host path of kdtree/rebuild.hpp).
//  * BoxSource,          what the device pass reads: the raw voxels (uint8, uint16, float32,
//    BoxClassifier       or a materialised occupancy) and the classification (a per-value bit
//                        table for integer voxels, any VoxelClassifier; a threshold or the
//                        transfer function's float alpha entries for float voxels).
//  * reference_block_words  the shared code of shaders/kd_local_boxes.comp run on the host.
//  * gather_local_boxes  block words -> LocalBoxes, reusing the output's storage.
#ifndef SYLVA_KDTREE_GPU_LOCAL_BOXES_HPP
#define SYLVA_KDTREE_GPU_LOCAL_BOXES_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/kdtree/local_boxes.hpp"
#include "sylva/shared/kd_local_boxes.h"
#include "sylva/volume/classify.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"

namespace sylva::kdtree {

/// Blocks along each axis of a grid of `dims` voxels (8^3 blocks, edge blocks clipped).
inline uvec3 block_counts(volume::Dims dims) { return (uvec3(dims) + 7u) / 8u; }

/// The box of block `block` encoded in block word `w` (empty for an empty block).
inline VoxelBox block_word_box(uvec3 block, std::uint32_t w) {
    if (shared::sylva_kd_box_word_count(w) == 0u) return VoxelBox{};
    uvec3 base = block * 8u;
    return VoxelBox{base + shared::sylva_kd_box_word_lo(w), base + shared::sylva_kd_box_word_last(w) + 1u};
}

/// Every block of a grid, ascending along the z-order Morton curve of the block coordinates.
struct BlockOrder {
    volume::Dims dims{0};
    uvec3 blocks{0u};
    std::vector<std::uint32_t> index;  ///< linear block index (x fastest), ascending code
    std::vector<std::uint64_t> code;   ///< its Morton code (morton3)

    /// The order of a grid of `dims`; throws sylva::Error for bad dimensions, more than 2^21
    /// blocks along an axis (the 64-bit Morton code) or 2^32 blocks in all.
    static BlockOrder of(volume::Dims dims) {
        volume::voxel_count(dims);
        BlockOrder o;
        o.dims = dims;
        o.blocks = block_counts(dims);
        if (std::max({o.blocks.x, o.blocks.y, o.blocks.z}) > (1u << 21))
            throw Error("kdtree: more than 2^21 blocks along an axis overflow the 64-bit Morton code");
        std::uint64_t n = std::uint64_t{o.blocks.x} * o.blocks.y * o.blocks.z;
        if (n > 0xFFFFFFFFull) throw Error("kdtree: " + std::to_string(n) + " blocks overflow 32-bit block indices");
        o.index.reserve(static_cast<std::size_t>(n));
        o.code.reserve(static_cast<std::size_t>(n));
        // Ascending Morton order without a sort: the cube of power-of-two side around the grid,
        // walked depth first, children in code order (x the lowest bit), cells outside skipped.
        std::uint32_t side = std::bit_ceil(std::max({o.blocks.x, o.blocks.y, o.blocks.z}));
        struct Cell {
            uvec3 lo;
            std::uint32_t side;
        };
        std::vector<Cell> stack{{uvec3(0u), side}};
        while (!stack.empty()) {
            Cell c = stack.back();
            stack.pop_back();
            if (c.lo.x >= o.blocks.x || c.lo.y >= o.blocks.y || c.lo.z >= o.blocks.z) continue;
            if (c.side == 1u) {
                o.index.push_back(c.lo.x + o.blocks.x * (c.lo.y + o.blocks.y * c.lo.z));
                o.code.push_back(morton3(c.lo));
                continue;
            }
            std::uint32_t h = c.side / 2u;
            for (std::uint32_t k = 8; k-- > 0;)  // pushed last to first: child 0 comes off first
                stack.push_back({c.lo + uvec3(k & 1u, (k >> 1) & 1u, (k >> 2) & 1u) * h, h});
        }
        return o;
    }
    [[nodiscard]] std::size_t size() const { return index.size(); }
    /// Block coordinates of linear block index i.
    [[nodiscard]] uvec3 coord(std::uint32_t i) const {
        return uvec3(i % blocks.x, (i / blocks.x) % blocks.y, i / (blocks.x * blocks.y));
    }
};

/// Turns dense block words into Morton-sorted local boxes, reusing `out`'s storage: the same
/// LocalBoxes kdtree::local_boxes computes. Throws sylva::Error when the word count does not
/// match the order, or naming the first block (in Morton order) flagged with a bad value.
inline void gather_local_boxes(std::span<const std::uint32_t> words, const BlockOrder& order, vec3 spacing,
                               LocalBoxes& out) {
    if (words.size() != order.size())
        throw Error("kdtree: " + std::to_string(words.size()) + " block words for " + std::to_string(order.size()) +
                    " blocks");
    out.dims = order.dims;
    out.spacing = spacing;
    out.blocks = order.blocks;
    out.occupied = 0;
    out.codes.clear();
    out.boxes.clear();
    for (std::size_t k = 0; k < order.size(); ++k) {
        std::uint32_t w = words[order.index[k]];
        if (w == 0u) continue;
        uvec3 b = order.coord(order.index[k]);
        if (w & SYLVA_KD_BOX_BAD)
            throw Error("kdtree: block (" + std::to_string(b.x) + ", " + std::to_string(b.y) + ", " + std::to_string(b.z) +
                        ") holds a voxel that is not a finite number");
        out.occupied += shared::sylva_kd_box_word_count(w);
        out.codes.push_back(order.code[k]);
        out.boxes.push_back(block_word_box(b, w));
    }
}

/// The raw voxels the device pass reads (non-owning: the data must outlive it).
struct BoxSource {
    std::uint32_t source = SYLVA_KD_BOX_SOURCE_U8;  ///< SYLVA_KD_BOX_SOURCE_*: the packing
    volume::Dims dims{0};
    vec3 spacing{1.0f};
    std::span<const std::byte> bytes;  ///< voxels, x fastest, little endian
    float range_lo = 0.0f;             ///< volumes: the raw value that maps to density 0
    float range_span = 0.0f;           ///< volumes: range_hi - range_lo (<= 0: an empty range, density 0)
    bool normalise = true;             ///< false for density grids (values used as they are)
    bool occupancy = false;            ///< bytes are a materialised occupancy (0 / 1)

    /// Bytes per voxel.
    [[nodiscard]] std::size_t voxel_bytes() const {
        return source == SYLVA_KD_BOX_SOURCE_U8 ? 1u : (source == SYLVA_KD_BOX_SOURCE_U16 ? 2u : 4u);
    }
    /// Bytes of one z-slice.
    [[nodiscard]] std::size_t slice_bytes() const { return std::size_t{dims.x} * dims.y * voxel_bytes(); }

    /// A volume's voxels (any scalar type). Throws when its byte count does not match.
    static BoxSource of(const volume::Volume& v) {
        std::size_t n = volume::voxel_count(v.dims, volume::scalar_bytes(v.type));
        if (v.bytes.size() != n * volume::scalar_bytes(v.type))
            throw Error("kdtree: " + std::to_string(v.bytes.size()) + " bytes do not match " + std::to_string(n) + " " +
                        volume::scalar_name(v.type) + " voxels");
        BoxSource s;
        s.source = v.type == volume::ScalarType::U8    ? SYLVA_KD_BOX_SOURCE_U8
                   : v.type == volume::ScalarType::U16 ? SYLVA_KD_BOX_SOURCE_U16
                                                       : SYLVA_KD_BOX_SOURCE_F32;
        s.dims = v.dims;
        s.spacing = v.spacing;
        s.bytes = std::span<const std::byte>(v.bytes);
        s.range_lo = v.range_lo;
        s.range_span = volume::detail::value_span(v);
        return s;
    }
    /// A normalised density grid (float32, values classified as they are).
    static BoxSource of(const volume::DensityGrid& g) {
        if (g.values.size() != volume::voxel_count(g.dims))
            throw Error("kdtree: " + std::to_string(g.values.size()) + " densities do not match the grid's dimensions");
        BoxSource s;
        s.source = SYLVA_KD_BOX_SOURCE_F32;
        s.dims = g.dims;
        s.spacing = g.spacing;
        s.bytes = std::as_bytes(std::span<const float>(g.values));
        s.normalise = false;
        return s;
    }
    /// A materialised occupancy (its bytes are the voxels; a non-zero byte is occupied).
    static BoxSource of(const volume::Occupancy& o) {
        if (o.voxels.size() != volume::voxel_count(o.dims))
            throw Error("kdtree: " + std::to_string(o.voxels.size()) + " occupancy bytes do not match the dimensions");
        BoxSource s;
        s.dims = o.dims;
        s.spacing = o.spacing;
        s.bytes = std::as_bytes(std::span<const std::uint8_t>(o.voxels));
        s.occupancy = true;
        return s;
    }
};

/// How the device pass classifies (layout of the buffers in sylva/shared/kd_local_boxes.h).
struct BoxClassifier {
    std::uint32_t classify = SYLVA_KD_BOX_CLASSIFY_LUT;  ///< SYLVA_KD_BOX_CLASSIFY_*
    float cut = 0.0f;                   ///< threshold or min_alpha
    std::vector<std::uint32_t> lut;     ///< integer voxels: one bit per raw value
    std::vector<std::uint32_t> alphas;  ///< ALPHA: float bits of the transfer function's alpha entries
    std::vector<std::uint8_t> table;    ///< scratch: the per-value verdicts, one byte each
};

namespace detail {

/// Packs one byte (0 / 1) per value into one bit per value, reusing `bits`.
inline void pack_bits(const std::vector<std::uint8_t>& bytes, std::vector<std::uint32_t>& bits) {
    bits.assign((bytes.size() + 31) / 32, 0u);
    for (std::size_t v = 0; v < bytes.size(); ++v)
        if (bytes[v]) bits[v >> 5] |= 1u << (v & 31u);
}

inline std::uint32_t bits_of(float f) { return std::bit_cast<std::uint32_t>(f); }

}  // namespace detail

/// The classifier's verdict on every raw value of an integer source, one byte (0 / 1) each,
/// into `table` (storage reused): the table volume::ClassifiedVolume builds (occupancy: value
/// != 0). Throws sylva::Error for a float32 source.
template <volume::VoxelClassifier C>
void value_table(const BoxSource& s, const C& classify, std::vector<std::uint8_t>& table) {
    if (s.source == SYLVA_KD_BOX_SOURCE_F32) throw Error("kdtree: float32 voxels have no per-value table");
    table.resize(s.source == SYLVA_KD_BOX_SOURCE_U8 ? 256u : 65536u);
    for (std::size_t i = 0; i < table.size(); ++i)
        table[i] = s.occupancy ? (i != 0) : (classify(volume::detail::normalised(static_cast<float>(i), s.range_lo, s.range_span)) ? 1u : 0u);
}

/// The device classification of `classify` over `s`, into `out` (storage reused). Integer
/// voxels take any classifier (through the per-value table); float32 voxels only
/// volume::DensityThreshold and volume::TransferFunctionAlpha, which the shader evaluates
/// itself (sylva::Error otherwise).
template <volume::VoxelClassifier C>
void assign_box_classifier(const BoxSource& s, const C& classify, BoxClassifier& out) {
    out.alphas.clear();
    if (s.source != SYLVA_KD_BOX_SOURCE_F32) {
        value_table(s, classify, out.table);
        out.classify = SYLVA_KD_BOX_CLASSIFY_LUT;
        out.cut = 0.0f;
        detail::pack_bits(out.table, out.lut);
        return;
    }
    out.lut.clear();
    if constexpr (std::is_same_v<C, volume::DensityThreshold>) {
        out.classify = SYLVA_KD_BOX_CLASSIFY_THRESHOLD;
        out.cut = classify.min_density;
    } else if constexpr (std::is_same_v<C, volume::TransferFunctionAlpha>) {
        out.classify = SYLVA_KD_BOX_CLASSIFY_ALPHA;
        out.cut = classify.min_alpha();
        for (const vec4& e : classify.transfer_function().entries()) out.alphas.push_back(detail::bits_of(e.a));
    } else {
        throw Error("kdtree: float32 voxels are classified on the device only by DensityThreshold or "
                    "TransferFunctionAlpha");
    }
}

/// The same, returned.
template <volume::VoxelClassifier C>
BoxClassifier box_classifier(const BoxSource& s, const C& classify) {
    BoxClassifier c;
    assign_box_classifier(s, classify, c);
    return c;
}

/// The parameter block of the pass (layout in sylva/shared/kd_local_boxes.h).
inline std::array<std::uint32_t, SYLVA_KD_BOX_PARAM_WORDS> box_params(const BoxSource& s, const BoxClassifier& c) {
    return {s.dims.x, s.dims.y, s.dims.z, s.source, c.classify, detail::bits_of(c.cut), detail::bits_of(s.range_lo),
            detail::bits_of(s.range_span), s.normalise ? 1u : 0u, static_cast<std::uint32_t>(c.alphas.size())};
}

/// Block layers (8 z-slices each) per slab so that a slab's voxels fit `max_bytes` (and 32-bit
/// voxel indices); throws sylva::Error when one layer does not.
inline std::uint32_t slab_layers(const BoxSource& s, std::size_t max_bytes) {
    std::size_t layer = s.slice_bytes() * 8u, cap = std::min<std::size_t>(max_bytes, 0xFFFFFFFCull);
    std::uint32_t layers = block_counts(s.dims).z;
    if (std::size_t{s.dims.z} * s.slice_bytes() <= cap) return layers;
    if (layer > cap)
        throw Error("kdtree: one layer of 8^3 blocks holds " + std::to_string(layer) + " bytes, more than a slab's " +
                    std::to_string(cap));
    return static_cast<std::uint32_t>(cap / layer);
}

/// The voxels of slices [z0, z1) as words (zero-padded to whole words).
inline std::vector<std::uint32_t> slab_words(const BoxSource& s, std::uint32_t z0, std::uint32_t z1) {
    std::size_t first = std::size_t{z0} * s.slice_bytes(), bytes = std::size_t{z1 - z0} * s.slice_bytes();
    std::vector<std::uint32_t> w((bytes + 3) / 4, 0u);
    std::memcpy(w.data(), s.bytes.data() + first, bytes);
    return w;
}

/// The shared code of shaders/kd_local_boxes.comp run on the host, one slab of `layers` block
/// layers at a time: the words the device must produce (blocks decided by `verdicts`, one byte
/// a block, where given; every block read otherwise).
inline std::vector<std::uint32_t> reference_block_words(const BoxSource& s, const BoxClassifier& c,
                                                        std::uint32_t layers = 1,
                                                        std::span<const std::uint8_t> verdicts = {}) {
    uvec3 nb = block_counts(s.dims);
    std::vector<std::uint32_t> words(std::size_t{nb.x} * nb.y * nb.z);
    std::array<std::uint32_t, SYLVA_KD_BOX_PARAM_WORDS> params = box_params(s, c);
    shared::Words pw{params.data(), params.size()}, lut{c.lut.data(), c.lut.size()}, alphas{c.alphas.data(), c.alphas.size()};
    std::vector<std::uint32_t> vw((words.size() + 3) / 4, 0u);  // all zero: read every block
    if (!verdicts.empty()) std::memcpy(vw.data(), verdicts.data(), std::min(verdicts.size(), words.size()));
    shared::Words vwords{vw.data(), vw.size()};
    for (std::uint32_t bz0 = 0; bz0 < nb.z; bz0 += layers) {
        std::uint32_t bz1 = std::min(nb.z, bz0 + layers);
        std::vector<std::uint32_t> slab = slab_words(s, bz0 * 8u, std::min(s.dims.z, bz1 * 8u));
        shared::Words voxels{slab.data(), slab.size()};
        shared::SylvaKdBoxParams p = shared::sylva_kd_box_params(pw, bz0 * 8u);
        for (std::uint32_t bz = bz0; bz < bz1; ++bz)
            for (std::uint32_t by = 0; by < nb.y; ++by)
                for (std::uint32_t bx = 0; bx < nb.x; ++bx) {
                    std::size_t i = bx + std::size_t{nb.x} * (by + std::size_t{nb.y} * bz);
                    words[i] = shared::sylva_kd_box_decide(voxels, lut, alphas, vwords, p, uvec3(bx, by, bz),
                                                           static_cast<std::uint32_t>(i));
                }
    }
    return words;
}

// ---- block value ranges: the blocks a rebuild can decide without reading them ------------------

/// What one classification-independent pass learnt about every 8^3 block's raw values (Zellmann
/// et al. section 5 compare against OSPRay's min-max grid; here the ranges only let a rebuild
/// skip blocks, the boxes stay exact).
struct BlockValues {
    std::vector<float> lo, hi;      ///< smallest / largest raw value (integers are exact in float)
    std::vector<std::uint8_t> bad;  ///< 1: the block holds a bad float value (NaN; any non-finite in volumes)
    [[nodiscard]] std::size_t size() const { return lo.size(); }
};

/// Verdicts of block_verdicts, one byte a block.
inline constexpr std::uint8_t kBlockRead = SYLVA_KD_BOX_READ;    ///< some values occupied, some not: read it
inline constexpr std::uint8_t kBlockEmpty = SYLVA_KD_BOX_EMPTY;  ///< no value of its range is occupied
inline constexpr std::uint8_t kBlockFull = SYLVA_KD_BOX_FULL;    ///< every value of its range is: all its voxels are

namespace detail {

template <class T>
bool bad_value(T v, bool any_nonfinite) {
    if constexpr (std::is_same_v<T, float>) return any_nonfinite ? !std::isfinite(v) : std::isnan(v);
    else return false;
}

/// The value ranges of the row of blocks (by, bz).
template <class T>
void block_row_values(const BoxSource& s, uvec3 nb, std::uint32_t by, std::uint32_t bz, BlockValues& out) {
    const T* data = reinterpret_cast<const T*>(s.bytes.data());
    std::size_t first = std::size_t{nb.x} * (by + std::size_t{nb.y} * bz);
    for (std::uint32_t z = bz * 8u; z < std::min(s.dims.z, bz * 8u + 8u); ++z)
        for (std::uint32_t y = by * 8u; y < std::min(s.dims.y, by * 8u + 8u); ++y) {
            const T* row = data + volume::voxel_index(s.dims, 0, y, z);
            for (std::uint32_t bx = 0; bx < nb.x; ++bx) {
                float lo = out.lo[first + bx], hi = out.hi[first + bx];
                for (std::uint32_t x = bx * 8u; x < std::min(s.dims.x, bx * 8u + 8u); ++x) {
                    T v = row[x];
                    if (bad_value(v, s.normalise)) {
                        out.bad[first + bx] = 1;
                        continue;
                    }
                    lo = std::min(lo, static_cast<float>(v));
                    hi = std::max(hi, static_cast<float>(v));
                }
                out.lo[first + bx] = lo;
                out.hi[first + bx] = hi;
            }
        }
}

}  // namespace detail

/// One pass over the raw voxels of `s`: the value range of every block, into `out` (storage
/// reused), rows of blocks in parallel. Materialised occupancies give ranges of their bytes.
template <Executor X>
void block_values(const BoxSource& s, X& exec, BlockValues& out) {
    uvec3 nb = block_counts(s.dims);
    std::size_t n = std::size_t{nb.x} * nb.y * nb.z;
    out.lo.assign(n, std::numeric_limits<float>::infinity());
    out.hi.assign(n, -std::numeric_limits<float>::infinity());
    out.bad.assign(n, 0);
    exec.parallel_for(0, std::size_t{nb.y} * nb.z, 1, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t r = lo; r < hi; ++r) {
            auto by = static_cast<std::uint32_t>(r % nb.y), bz = static_cast<std::uint32_t>(r / nb.y);
            if (s.source == SYLVA_KD_BOX_SOURCE_U8) detail::block_row_values<std::uint8_t>(s, nb, by, bz, out);
            else if (s.source == SYLVA_KD_BOX_SOURCE_U16) detail::block_row_values<std::uint16_t>(s, nb, by, bz, out);
            else detail::block_row_values<float>(s, nb, by, bz, out);
        }
    });
}

namespace detail {

/// Density of a raw float value as the classified sources compute it (monotone in the value).
inline float box_density(const BoxSource& s, float x) {
    return s.normalise ? volume::detail::normalised(x, s.range_lo, s.range_span) : x;
}

/// TransferFunction::at's entry index of density d (monotone in d).
inline std::size_t tf_index(float d, std::size_t entries) {
    float x = (d > 0.0f ? std::min(d, 1.0f) : 0.0f) * static_cast<float>(entries - 1);
    return std::min(static_cast<std::size_t>(x), entries - 2);
}

/// Float voxels under a transfer function: empty where every entry the block's density range
/// interpolates between has alpha exactly 0 (then every lookup is 0 + 0 f = 0, never above
/// min_alpha); never full (interpolation rounds).
inline void tf_verdicts(const BoxSource& s, const BlockValues& v, const volume::TransferFunctionAlpha& c,
                        std::vector<std::uint32_t>& nonzero, std::vector<std::uint8_t>& out) {
    const auto& e = c.transfer_function().entries();
    nonzero.assign(e.size() + 1, 0u);
    for (std::size_t i = 0; i < e.size(); ++i) nonzero[i + 1] = nonzero[i] + (e[i].a != 0.0f ? 1u : 0u);
    for (std::size_t b = 0; b < v.size(); ++b) {
        if (v.bad[b]) continue;
        std::size_t i0 = tf_index(box_density(s, v.lo[b]), e.size()), i1 = tf_index(box_density(s, v.hi[b]), e.size()) + 1;
        if (nonzero[i1 + 1] == nonzero[i0]) out[b] = kBlockEmpty;
    }
}

}  // namespace detail

/// The verdict of every block under a classification, into `out` (one byte a block, storage
/// reused): kBlockEmpty or kBlockFull where the block's value range decides it, else
/// kBlockRead. Exact for integer voxels (through `table`, the per-value verdicts of
/// value_table: occupied values counted by a prefix sum in `scratch`), for float voxels under
/// volume::DensityThreshold (density is monotone in the raw value) and, for empty blocks only,
/// under volume::TransferFunctionAlpha; other float classifiers read every block. Blocks with
/// bad values are always read, so their error surfaces as in a fresh build.
template <volume::VoxelClassifier C>
void block_verdicts(const BoxSource& s, const BlockValues& v, const C& classify, const std::vector<std::uint8_t>& table,
                    std::vector<std::uint32_t>& scratch, std::vector<std::uint8_t>& out) {
    out.assign(v.size(), kBlockRead);
    if (s.source != SYLVA_KD_BOX_SOURCE_F32) {
        scratch.assign(table.size() + 1, 0u);
        for (std::size_t i = 0; i < table.size(); ++i) scratch[i + 1] = scratch[i] + table[i];
        for (std::size_t b = 0; b < v.size(); ++b) {
            auto lo = static_cast<std::uint32_t>(v.lo[b]), hi = static_cast<std::uint32_t>(v.hi[b]);
            std::uint32_t occupied = scratch[hi + 1] - scratch[lo];
            out[b] = occupied == 0 ? kBlockEmpty : (occupied == hi - lo + 1 ? kBlockFull : kBlockRead);
        }
    } else if constexpr (std::is_same_v<C, volume::DensityThreshold>) {
        for (std::size_t b = 0; b < v.size(); ++b) {
            if (v.bad[b]) continue;
            if (!(detail::box_density(s, v.hi[b]) >= classify.min_density)) out[b] = kBlockEmpty;
            else if (detail::box_density(s, v.lo[b]) >= classify.min_density) out[b] = kBlockFull;
        }
    } else if constexpr (std::is_same_v<C, volume::TransferFunctionAlpha>) {
        detail::tf_verdicts(s, v, classify, scratch, out);
    }
}

namespace detail {
/// Masks and count of one block while its rows stream by (the shared accumulator).
using BlockAccumulator = shared::SylvaKdBoxAcc;
}  // namespace detail

/// The block word of a block whose every voxel is occupied.
inline std::uint32_t full_block_word(volume::Dims dims, uvec3 b) { return shared::sylva_kd_box_full_word(uvec3(dims), b); }

namespace detail {

/// The row of blocks (by, bz) of a grid of `d` voxels under `verdicts` (null: every block is
/// read): the words of decided blocks written without reading, each run [bx, end) of blocks to
/// read handed to read_run(bx, end), which writes their words.
template <class ReadRun>
void for_each_block_run(volume::Dims d, uvec3 nb, std::uint32_t by, std::uint32_t bz, const std::uint8_t* verdicts,
                        std::uint32_t* words, ReadRun&& read_run) {
    std::size_t first = std::size_t{nb.x} * (by + std::size_t{nb.y} * bz);
    auto read = [&](std::uint32_t bx) { return verdicts == nullptr || verdicts[first + bx] == kBlockRead; };
    for (std::uint32_t bx = 0; bx < nb.x;) {
        if (!read(bx)) {
            words[first + bx] = verdicts[first + bx] == kBlockFull ? full_block_word(d, uvec3(bx, by, bz)) : 0u;
            ++bx;
            continue;
        }
        std::uint32_t end = bx + 1;
        while (end < nb.x && read(end)) ++end;
        read_run(bx, end);
        bx = end;
    }
}

/// Words of the row of blocks (by, bz) under `verdicts` (for_each_block_run): runs of blocks to
/// read as sub-rows of the grid (`verdicts` null: every block is read). The one host loop of the
/// 8^3 pass; per block it runs the shader's accumulation (sylva_kd_box_accumulate,
/// sylva_kd_box_acc_word).
template <volume::OccupancySource S>
void block_row_words(const S& src, uvec3 nb, std::uint32_t by, std::uint32_t bz, const std::uint8_t* verdicts,
                     std::vector<std::uint8_t>& row, std::vector<BlockAccumulator>& acc, std::uint32_t* words) {
    volume::Dims d = src.dims;
    std::size_t first = std::size_t{nb.x} * (by + std::size_t{nb.y} * bz);
    for_each_block_run(d, nb, by, bz, verdicts, words, [&](std::uint32_t bx, std::uint32_t end) {
        std::uint32_t x0 = bx * 8u, x1 = std::min(d.x, end * 8u);
        std::fill(acc.begin(), acc.begin() + (end - bx), shared::sylva_kd_box_acc_zero());
        for (std::uint32_t z = bz * 8u; z < std::min(d.z, bz * 8u + 8u); ++z)
            for (std::uint32_t y = by * 8u; y < std::min(d.y, by * 8u + 8u); ++y) {
                src.row(x0, x1, y, z, row.data());
                for (std::uint32_t k = 0; k < end - bx; ++k)
                    shared::sylva_kd_box_accumulate(acc[k], row_mask(row.data() + k * 8u, std::min(8u, x1 - x0 - k * 8u)),
                                                    y & 7u, z & 7u);
            }
        for (std::uint32_t k = 0; k < end - bx; ++k) words[first + bx + k] = shared::sylva_kd_box_acc_word(acc[k], false);
    });
}

}  // namespace detail

/// The pass on the host: one word per block of `src` into `words` (resized, storage reused),
/// rows of blocks in parallel on `exec`. Errors of the source (bad values) propagate.
template <volume::OccupancySource S, Executor X>
void block_words(const S& src, X& exec, std::vector<std::uint32_t>& words) {
    volume::voxel_count(src.dims);
    uvec3 nb = block_counts(src.dims);
    words.resize(std::size_t{nb.x} * nb.y * nb.z);
    exec.parallel_for(0, std::size_t{nb.y} * nb.z, 1, [&](std::size_t lo, std::size_t hi) {
        std::vector<std::uint8_t> row(src.dims.x);
        std::vector<detail::BlockAccumulator> acc(nb.x);
        for (std::size_t r = lo; r < hi; ++r)
            detail::block_row_words(src, nb, static_cast<std::uint32_t>(r % nb.y), static_cast<std::uint32_t>(r / nb.y),
                                    nullptr, row, acc, words.data());
    });
}

/// block_words reading only the blocks whose verdict (block_verdicts) is kBlockRead: the same
/// words as block_words(src, exec, words) when the verdicts come from `src`'s classification.
template <volume::OccupancySource S, Executor X>
void block_words(const S& src, const std::vector<std::uint8_t>& verdicts, X& exec, std::vector<std::uint32_t>& words) {
    uvec3 nb = block_counts(src.dims);
    if (verdicts.size() != std::size_t{nb.x} * nb.y * nb.z)
        throw Error("kdtree: " + std::to_string(verdicts.size()) + " block verdicts for a grid of " +
                    std::to_string(std::size_t{nb.x} * nb.y * nb.z) + " blocks");
    words.resize(verdicts.size());
    exec.parallel_for(0, std::size_t{nb.y} * nb.z, 1, [&](std::size_t lo, std::size_t hi) {
        std::vector<std::uint8_t> row(src.dims.x);
        std::vector<detail::BlockAccumulator> acc(nb.x);
        for (std::size_t r = lo; r < hi; ++r)
            detail::block_row_words(src, nb, static_cast<std::uint32_t>(r % nb.y), static_cast<std::uint32_t>(r / nb.y),
                                    verdicts.data(), row, acc, words.data());
    });
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_GPU_LOCAL_BOXES_HPP
