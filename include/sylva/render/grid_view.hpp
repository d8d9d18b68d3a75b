// sylva/render/grid_view.hpp -- how the grid samplers read a volume (sylva/shared/grid_sample.h):
// the voxel format of the grid words (float32 densities, or uint8 / uint16 raw values packed
// four / two a word and normalised on the fly with a value range), and the border mode (what a
// sample reads outside the voxel centres: the edge voxel, or a constant).
//
//   volume::Volume v = volume::read_raw(...);                  // uint8, 256^3
//   GridWords g = GridWords::native(v);                          // 16.8 MB of words, no float copy
//   GridWords f = GridWords::from(volume::normalize(v));        // 67.1 MB, the same image
//   GridWords s = GridWords::sparse(v);                          // 8^3 bricks, uniform ones in
//                                                                // the table: 3.7 MB, same image
//
// Exactness. An integer voxel of raw value r reads as clamp((r - lo) / span, 0, 1), the division
// as written (sylva/shared/grid_sample.h), which is what volume::normalize stores for the same
// range (sylva/volume/grid.hpp), so a native grid and its normalised float copy give the same
// densities bit for bit, and the renderers the same images.
//
// Border (word 38-39 of the parameter block, sylva/shared/dvr_common.h). Constant 0 is the
// default for DVR, as VTK and NanoVDB read a background value outside the data; clamping to the
// edge voxel is the other choice (and what the octree's brick aprons hold: the octree renderers
// always clamp).
#ifndef SYLVA_RENDER_GRID_VIEW_HPP
#define SYLVA_RENDER_GRID_VIEW_HPP

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/shared/dvr_common.h"
#include "sylva/shared/grid_sample.h"
#include "sylva/volume/grid.hpp"

namespace sylva {

/// Voxel format of grid words (SYLVA_GRID_*).
enum class GridFormat : std::uint32_t {
    F32 = SYLVA_GRID_F32,  ///< one normalised density a word (float bits)
    U8 = SYLVA_GRID_U8,    ///< four raw uint8 values a word (voxel i in bits 8 (i & 3) ..)
    U16 = SYLVA_GRID_U16,  ///< two raw uint16 values a word (voxel i in bits 16 (i & 1) ..)
    /// 8^3 bricks of uint8 / uint16 raw values behind a brick table, uniform bricks stored as
    /// their value in the table (sylva/shared/grid_sample.h has the layout; GridWords::sparse).
    SparseU8 = SYLVA_GRID_SPARSE_U8,
    SparseU16 = SYLVA_GRID_SPARSE_U16,
};

/// Whether f is one of the sparse (bricked) formats.
constexpr bool is_sparse(GridFormat f) { return f == GridFormat::SparseU8 || f == GridFormat::SparseU16; }

/// What a sample reads outside the voxel centres (SYLVA_BORDER_*).
enum class BorderMode : std::uint32_t {
    Clamp = SYLVA_BORDER_CLAMP,        ///< the edge voxel repeats outside
    Constant = SYLVA_BORDER_CONSTANT,  ///< a constant normalised density (GridBorder::value)
};

/// A border mode with its value.
struct GridBorder {
    BorderMode mode = BorderMode::Constant;  ///< default: constant 0 (VTK's and NanoVDB's background)
    float value = 0.0f;                      ///< normalised density outside the grid (Constant)

    static GridBorder clamp() { return GridBorder{BorderMode::Clamp, 0.0f}; }
    static GridBorder constant(float v) { return GridBorder{BorderMode::Constant, v}; }
    /// Throws sylva::Error for a non-finite border value.
    void check() const {
        if (mode != BorderMode::Clamp && mode != BorderMode::Constant) throw Error("grid: unknown border mode");
        if (!std::isfinite(value)) throw Error("grid: the border value is not finite");
    }
};

/// The sampler's view of grid words besides dims and spacing: format, value range, border.
struct GridSampling {
    GridFormat format = GridFormat::F32;
    float value_lo = 0.0f;    ///< integer formats: raw value of density 0
    float value_span = 1.0f;  ///< integer formats: hi - lo (> 0)
    GridBorder border{};

    /// Words 38-42 of the parameter block (sylva/shared/dvr_common.h); `params` holds them.
    void pack(std::span<std::uint32_t> params) const {
        params[38] = static_cast<std::uint32_t>(border.mode);
        params[39] = std::bit_cast<std::uint32_t>(border.value);
        params[40] = static_cast<std::uint32_t>(format);
        params[41] = std::bit_cast<std::uint32_t>(value_lo);
        params[42] = std::bit_cast<std::uint32_t>(value_span);
    }
    /// Throws sylva::Error for a bad format, range or border.
    void check() const {
        border.check();
        if (format != GridFormat::F32 && format != GridFormat::U8 && format != GridFormat::U16 && !is_sparse(format))
            throw Error("grid: unknown voxel format " + std::to_string(static_cast<std::uint32_t>(format)));
        if (!std::isfinite(value_lo) || !std::isfinite(value_span) || !(value_span > 0.0f))
            throw Error("grid: the value range must be finite with hi > lo");
    }
    /// The shared sampler's descriptor for a grid of `dims` voxels of size `spacing`.
    [[nodiscard]] shared::SylvaGridDesc desc(volume::Dims dims, vec3 spacing) const {
        shared::SylvaGridDesc g;
        g.dims = uvec3(dims);
        g.spacing = spacing;
        g.border = static_cast<std::uint32_t>(border.mode);
        g.border_value = border.value;
        g.format = static_cast<std::uint32_t>(format);
        g.value_lo = value_lo;
        g.value_span = value_span;
        return g;
    }
};

/// Voxels a 32-bit word holds in format f (sparse formats: in a stored brick).
constexpr std::size_t voxels_per_word(GridFormat f) {
    return (f == GridFormat::U8 || f == GridFormat::SparseU8) ? 4u
                                                               : ((f == GridFormat::U16 || f == GridFormat::SparseU16) ? 2u : 1u);
}

/// Bytes one voxel takes in format f (sparse formats: in a stored brick).
constexpr std::size_t grid_voxel_bytes(GridFormat f) { return 4u / voxels_per_word(f); }

/// Words of a dense grid of n voxels in format f (the last word padded with zero voxels).
constexpr std::size_t grid_word_count(GridFormat f, std::size_t n) {
    return (n + voxels_per_word(f) - 1) / voxels_per_word(f);
}

/// The grid format that reads a volume's scalar type natively.
inline GridFormat native_format(volume::ScalarType t) {
    return t == volume::ScalarType::U8 ? GridFormat::U8 : (t == volume::ScalarType::U16 ? GridFormat::U16 : GridFormat::F32);
}

/// The voxel bytes of an integer volume as grid words (little-endian, so the bytes unchanged,
/// the last word padded with zeros).
inline std::vector<std::uint32_t> pack_voxel_words(const volume::Volume& v) {
    if (v.type == volume::ScalarType::F32) throw Error("grid: float32 volumes are normalised, not packed");
    std::size_t n = volume::voxel_count(v.dims, volume::scalar_bytes(v.type));
    if (v.bytes.size() != n * volume::scalar_bytes(v.type))
        throw Error("grid: " + std::to_string(v.bytes.size()) + " bytes do not match " + std::to_string(n) + " " +
                    volume::scalar_name(v.type) + " voxels");
    std::vector<std::uint32_t> words(grid_word_count(native_format(v.type), n), 0u);
    if (!v.bytes.empty()) std::memcpy(words.data(), v.bytes.data(), v.bytes.size());
    return words;
}

/// Sparse formats: edge of a brick in voxels, and the brick table's size for a grid of `dims`.
inline constexpr std::uint32_t sparse_brick_edge = 8;
inline std::size_t sparse_table_words(volume::Dims dims) {
    auto bricks = [](std::uint32_t n) { return (std::size_t{n} + sparse_brick_edge - 1) / sparse_brick_edge; };
    return bricks(dims.x) * bricks(dims.y) * bricks(dims.z);
}

/// Sparse formats: words of one stored brick (512 voxels).
constexpr std::size_t sparse_brick_words(GridFormat f) { return 512u / voxels_per_word(f); }

/// An integer volume's voxels as sparse grid words (sylva/shared/grid_sample.h): 8^3 bricks in
/// table order, a brick whose voxels inside the grid all hold one value is stored as that value
/// in its table entry, the others as 512 voxels after the table (voxels beyond the grid's faces
/// are 0). Lossless: every voxel reads its own raw value. Throws sylva::Error for a float32
/// volume (sparse grids hold uint8 or uint16 voxels) or bytes that do not match the dims.
inline std::vector<std::uint32_t> pack_sparse_words(const volume::Volume& v) {
    if (v.type == volume::ScalarType::F32) throw Error("grid: sparse grids hold uint8 or uint16 voxels, not float32");
    const std::size_t vb = volume::scalar_bytes(v.type);
    std::size_t n = volume::voxel_count(v.dims, vb);
    if (v.bytes.size() != n * vb)
        throw Error("grid: " + std::to_string(v.bytes.size()) + " bytes do not match " + std::to_string(n) + " " +
                    volume::scalar_name(v.type) + " voxels");
    const GridFormat f = v.type == volume::ScalarType::U8 ? GridFormat::SparseU8 : GridFormat::SparseU16;
    const std::size_t table = sparse_table_words(v.dims), brick_words = sparse_brick_words(f);
    if (table > 0x7FFFFFFFu) throw Error("grid: too many bricks for a sparse grid");
    auto raw = [&](std::size_t i) -> std::uint32_t {
        if (vb == 1) return std::to_integer<std::uint32_t>(v.bytes[i]);
        std::uint16_t r;
        std::memcpy(&r, &v.bytes[2 * i], 2);
        return r;
    };
    std::vector<std::uint32_t> words(table, 0u);
    const std::uint32_t e = sparse_brick_edge, bx = std::uint32_t((v.dims.x + e - 1) / e), by = std::uint32_t((v.dims.y + e - 1) / e);
    std::vector<std::uint32_t> brick(512);
    for (std::size_t b = 0; b < table; ++b) {
        const std::uint32_t x0 = std::uint32_t(b % bx) * e, y0 = std::uint32_t((b / bx) % by) * e,
                            z0 = std::uint32_t(b / (std::size_t{bx} * by)) * e;
        bool uniform = true;
        std::uint32_t first = raw(x0 + std::size_t{v.dims.x} * (y0 + std::size_t{v.dims.y} * z0));
        std::fill(brick.begin(), brick.end(), 0u);
        for (std::uint32_t lz = 0; lz < e && z0 + lz < v.dims.z; ++lz)
            for (std::uint32_t ly = 0; ly < e && y0 + ly < v.dims.y; ++ly)
                for (std::uint32_t lx = 0; lx < e && x0 + lx < v.dims.x; ++lx) {
                    std::uint32_t r = raw((x0 + lx) + std::size_t{v.dims.x} * ((y0 + ly) + std::size_t{v.dims.y} * (z0 + lz)));
                    brick[lx + e * (ly + e * lz)] = r;
                    uniform = uniform && r == first;
                }
        if (uniform) {
            words[b] = SYLVA_GRID_UNIFORM_BIT | first;
            continue;
        }
        if (words.size() > 0x7FFFFFFFu - brick_words) throw Error("grid: a sparse grid over 2^31 words");
        words[b] = static_cast<std::uint32_t>(words.size());
        std::size_t at = words.size();
        words.resize(at + brick_words, 0u);
        for (std::uint32_t l = 0; l < 512; ++l) {
            if (vb == 1) words[at + l / 4] |= brick[l] << (8 * (l % 4));
            else words[at + l / 2] |= brick[l] << (16 * (l % 2));
        }
    }
    return words;
}

/// Checks sparse grid words of a grid of `dims` in format f: the table fits, every entry is a
/// uniform value in the format's range (bits 16-30 zero) or the offset of a brick after the
/// table that ends inside the words. Throws sylva::Error naming the first bad entry.
inline void check_sparse_words(std::span<const std::uint32_t> words, volume::Dims dims, GridFormat f) {
    const std::size_t table = sparse_table_words(dims), brick_words = sparse_brick_words(f);
    if (words.size() < table)
        throw Error("grid: " + std::to_string(words.size()) + " sparse grid words hold no brick table of " +
                    std::to_string(table) + " entries (truncated)");
    const std::uint32_t max_raw = f == GridFormat::SparseU8 ? 255u : 65535u;
    for (std::size_t b = 0; b < table; ++b) {
        std::uint32_t w = words[b];
        if ((w & SYLVA_GRID_UNIFORM_BIT) != 0u) {
            if ((w & 0x7FFFFFFFu) > max_raw)
                throw Error("grid: sparse brick " + std::to_string(b) + " is uniform with value " +
                            std::to_string(w & 0x7FFFFFFFu) + " beyond the format's " + std::to_string(max_raw));
        } else if (w < table || std::size_t{w} + brick_words > words.size()) {
            throw Error("grid: sparse brick " + std::to_string(b) + " at word " + std::to_string(w) +
                        " is outside the brick area [" + std::to_string(table) + ", " + std::to_string(words.size()) +
                        ") (corrupt or truncated)");
        }
    }
}

}  // namespace sylva

#endif  // SYLVA_RENDER_GRID_VIEW_HPP
