// sylva/render/ess_occupancy.hpp -- the occupancy of empty-space skipping DVR: which voxels the
// kd-tree of sylva/render/kd_volume.hpp must keep so that its image is exactly the reference
// marcher's (Vidal et al. section 2.1; Zellmann et al. section 5).
//
// The occupancy (see the reasoning in sylva/shared/kd_dvr.h): a voxel is occupied when the
// transfer function is visible somewhere in the density range of its 3x3x3 neighbourhood (the
// voxels a trilinear sample in its cell reads). That covers the half-voxel reach of trilinear
// reconstruction, is exact for any TF, and keeps every visible sample half a voxel inside the
// occupied cells, so no further dilation is needed.
//
// The TF lookup maps a density d to the table segment s(d) = floor(clamp01(d) (N - 1))
// (sylva/shared/tf.h; monotone in d), and a density can be visible only in a segment with an
// entry of alpha > 0 at either end. So a voxel's neighbourhood reaches the segments
// [s(min - eps), s(max + eps)] (eps = 2^-20 absorbs the rounding of the three trilinear lerps),
// grouped into 256 buckets (bucket = s 256 / N; for N <= 256 one segment a bucket); a voxel on
// a face of the grid also reaches a constant border's value. Two ways to classify:
//  * Segment codes (ess_codes): per voxel one uint16, bits 0-7 the first and 8-15 the last
//    bucket. They depend only on the volume and the TF's entry count, not on its colours or
//    opacities: a TF change reclassifies them through a 65536-entry table, which is what
//    kdtree::Rebuilder does for a uint16 volume (and vk::KdRebuilder on the device). Computing
//    them takes several passes over 5 bytes a voxel (250-500 ms for a 256^3 volume).
//  * Block ranges (issue 15, item 5): one streaming pass (ess_block_ranges) keeps each 8^3
//    block's density range over the block and the voxels around it (its voxels'
//    neighbourhoods), independent of the TF. Under a TF (ess_block_verdicts) a block whose
//    buckets are all invisible is empty, all visible full; only the others are read
//    (ess_block_words), voxel by voxel with the same arithmetic (bucket is monotone, so the
//    bucket of a neighbourhood's minimum is the least bucket of its voxels), straight into the
//    binned builder's block words: the same occupancy as the codes, bit for bit. A native
//    uint8 / uint16 grid is read as its raw voxels (EssRawRows): its density is nondecreasing in
//    the raw value, so ranges and run bounds carry over, from a quarter (half) of the bytes and
//    16 (8) lanes a vector. On the aneurism with the CT preset 4,567 of 32,768 blocks are read,
//    and the first build of a binned tree takes 1.35-2.0 streaming passes instead of 40 (bonsai
//    2.8-3.9, engine 1.9-2.9, bench and sylva-render; README, "The first build a user runs").
//    On a Vulkan device the undecided blocks are read by shaders/kd_ess_boxes.comp with the
//    same arithmetic (sylva/shared/kd_ess_boxes.h, sylva/vulkan/kd_ess.hpp).
#ifndef SYLVA_RENDER_ESS_OCCUPANCY_HPP
#define SYLVA_RENDER_ESS_OCCUPANCY_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/kdtree/gpu_local_boxes.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"

namespace sylva {

/// Buckets of TF segments a segment code distinguishes (8 bits each end).
inline constexpr std::uint32_t kEssBuckets = 256;

/// The segment codes of a density grid for a TF of `entries` entries, as a uint16 volume
/// (range [0, 65535], so a classifier sees code / 65535): bits 0-7 the first, bits 8-15 the
/// last bucket of TF segments the voxel's 3x3x3 neighbourhood can reach (see above).
struct EssCodes {
    volume::Volume volume;
    std::uint32_t entries = 0;  ///< TF entry count N the codes were made for
    double ms = 0.0;            ///< time to compute them
};

/// Which codes are visible under one transfer function (or threshold): a prefix count over the
/// 256 buckets. A VoxelClassifier over the codes' normalised values (code / 65535).
class EssClassifier {
public:
    /// From per-segment visibility, one flag per entry s of a TF of N entries: segment s holds
    /// the densities the lookup maps to entries s and s + 1 (segment N - 1: density 1 alone).
    /// Bucket b is visible when one of its segments is.
    EssClassifier(const std::vector<std::uint8_t>& segment_visible, std::uint32_t entries) : entries_(entries) {
        if (entries < 2 || segment_visible.size() != entries)
            throw Error("kd-dvr: segment visibility for " + std::to_string(segment_visible.size()) + " segments, TF of " +
                        std::to_string(entries) + " entries");
        std::array<std::uint8_t, kEssBuckets> bucket{};
        for (std::uint32_t s = 0; s < entries; ++s)
            if (segment_visible[s]) bucket[bucket_of(s, entries)] = 1u;
        for (std::uint32_t b = 0; b < kEssBuckets; ++b) prefix_[b + 1] = prefix_[b] + bucket[b];
    }
    /// Bucket of segment s for a TF of n entries.
    static std::uint32_t bucket_of(std::uint32_t s, std::uint32_t n) {
        return static_cast<std::uint32_t>(std::uint64_t{s} * kEssBuckets / n);
    }
    /// True when the code's bucket range holds a visible bucket.
    [[nodiscard]] bool visible(std::uint32_t code) const {
        std::uint32_t lo = code & 255u, hi = (code >> 8) & 255u;
        return hi >= lo && prefix_[hi + 1] != prefix_[lo];
    }
    /// Number of visible buckets in [lo, hi] (0 when hi < lo).
    [[nodiscard]] std::uint32_t visible_in(std::uint32_t lo, std::uint32_t hi) const {
        return hi >= lo && hi < kEssBuckets ? prefix_[hi + 1] - prefix_[lo] : 0u;
    }
    /// VoxelClassifier: the normalised value of a code voxel.
    [[nodiscard]] bool operator()(float normalised) const {
        return visible(static_cast<std::uint32_t>(std::lround(std::clamp(normalised, 0.0f, 1.0f) * 65535.0f)));
    }
    [[nodiscard]] std::uint32_t entries() const { return entries_; }
    /// Number of visible buckets (0: nothing can be seen).
    [[nodiscard]] std::uint32_t visible_buckets() const { return prefix_[kEssBuckets]; }

private:
    std::array<std::uint32_t, kEssBuckets + 1> prefix_{};
    std::uint32_t entries_;
};
static_assert(volume::VoxelClassifier<EssClassifier>);

/// The transfer function `tf` (packed RGBA8 words, the renderer's table; sylva/shared/tf.h)
/// as an EssClassifier: segment s is visible when entry s or s + 1 has alpha > 0.
inline EssClassifier ess_classifier(std::span<const std::uint32_t> tf) {
    if (tf.size() < 2 || tf.size() > (std::size_t{1} << 24))
        throw Error("kd-dvr: the transfer function needs 2 to 2^24 entries, got " + std::to_string(tf.size()));
    auto n = static_cast<std::uint32_t>(tf.size());
    std::vector<std::uint8_t> vis(n);
    for (std::uint32_t s = 0; s < n; ++s) vis[s] = ((tf[s] >> 24) != 0u || (tf[std::min(s + 1, n - 1)] >> 24) != 0u) ? 1u : 0u;
    return EssClassifier(vis, n);
}

/// Density-threshold classification over segments of a TF of `entries` entries: segment s is
/// visible when its upper end (s + 1) / (N - 1) reaches `threshold`, i.e. when it holds
/// densities >= threshold (the BIH's voxel elements, Kinkelin section 6.1). The image equals
/// the marcher's only when the TF is transparent below the threshold.
inline EssClassifier ess_threshold_classifier(float threshold, std::uint32_t entries) {
    if (!std::isfinite(threshold)) throw Error("kd-dvr: the density threshold is not finite");
    if (entries < 2) throw Error("kd-dvr: the transfer function needs at least 2 entries");
    std::vector<std::uint8_t> vis(entries);
    for (std::uint32_t s = 0; s < entries; ++s)
        vis[s] = static_cast<float>(std::min(s + 1, entries - 1)) / static_cast<float>(entries - 1) >= threshold ? 1u : 0u;
    return EssClassifier(vis, entries);
}

namespace detail {

/// The margin around a neighbourhood's density range, 2^-20: above the rounding of the three
/// trilinear lerps a sample between the voxels takes.
inline constexpr float kEssEps = 1.0f / 1048576.0f;

inline double ess_ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// Buckets of the TF segments of densities (the shader's arithmetic), n entries.
struct EssBucketMap {
    std::uint32_t n;
    std::vector<std::uint8_t> of_segment;  ///< bucket of each segment

    explicit EssBucketMap(std::uint32_t entries) : n(entries), of_segment(entries) {
        for (std::uint32_t s = 0; s < n; ++s) of_segment[s] = static_cast<std::uint8_t>(EssClassifier::bucket_of(s, n));
    }
    [[nodiscard]] std::uint8_t operator()(float d) const {
        float x = shared::sylva_tf_clamp01(d) * static_cast<float>(n - 1);
        return of_segment[std::min(static_cast<std::uint32_t>(x), n - 1)];
    }
};

/// Buckets a constant border adds to the neighbourhoods of the grid's boundary voxels (their
/// out-of-grid neighbours read the border value, sylva/shared/grid_sample.h); for a clamped
/// border the neutral pair (255, 0): the edge voxel is already in the neighbourhood.
struct EssBorder {
    std::uint8_t lo = 255;
    std::uint8_t hi = 0;
};

inline EssBorder ess_border(const GridBorder& b, std::uint32_t entries) {
    b.check();
    if (b.mode == BorderMode::Clamp) return {};
    constexpr float eps = kEssEps;
    EssBucketMap bucket(entries);
    return {bucket(b.value - eps), bucket(b.value + eps)};
}

/// One pass of a 3-wide min (lo) / max (hi) filter over `count` lines of `n` entries along an
/// axis whose neighbours are `n` entries apart, in `outer` independent blocks; src -> dst. The
/// first and last lines also take the border's buckets.
template <Executor X>
void ess_filter_pass(const std::vector<std::uint8_t>& slo, const std::vector<std::uint8_t>& shi,
                     std::vector<std::uint8_t>& dlo, std::vector<std::uint8_t>& dhi, std::size_t n, std::size_t count,
                     std::size_t outer, EssBorder border, X& exec) {
    exec.parallel_for(0, outer * count, 1, [&](std::size_t j0, std::size_t j1) {
        for (std::size_t j = j0; j < j1; ++j) {
            std::size_t o = j / count, i = j % count, base = o * count * n;
            std::size_t a = base + (i > 0 ? i - 1 : i) * n, b = base + i * n, c = base + (i + 1 < count ? i + 1 : i) * n;
            bool edge = i == 0 || i + 1 == count;
            std::uint8_t elo = edge ? border.lo : 255, ehi = edge ? border.hi : 0;
            for (std::size_t k = 0; k < n; ++k) {
                dlo[b + k] = std::min(std::min(std::min(slo[a + k], slo[b + k]), slo[c + k]), elo);
                dhi[b + k] = std::max(std::max(std::max(shi[a + k], shi[b + k]), shi[c + k]), ehi);
            }
        }
    });
}

/// Per voxel the buckets of d - eps and d + eps (d = density(i)), then the 3-wide filter
/// along x, per row (the row's ends also take the border's buckets).
template <Executor X, class Density>
void ess_rows(const Density& density, volume::Dims dims, std::uint32_t entries, EssBorder border,
              std::vector<std::uint8_t>& lo, std::vector<std::uint8_t>& hi, X& exec) {
    constexpr float eps = kEssEps;
    std::uint32_t nx = dims.x;
    std::size_t rows = std::size_t{dims.y} * dims.z;
    EssBucketMap bucket(entries);
    exec.parallel_for(0, rows, 64, [&](std::size_t r0, std::size_t r1) {
        std::vector<std::uint8_t> blo(nx), bhi(nx);
        for (std::size_t r = r0; r < r1; ++r) {
            for (std::uint32_t x = 0; x < nx; ++x) {
                float v = density(r * nx + x);
                if (std::isnan(v)) throw Error("kd-dvr: the grid holds a NaN density");
                blo[x] = bucket(v - eps);
                bhi[x] = bucket(v + eps);
            }
            for (std::uint32_t x = 0; x < nx; ++x) {
                std::uint32_t a = x > 0 ? x - 1 : x, c = x + 1 < nx ? x + 1 : x;
                bool edge = x == 0 || x + 1 == nx;
                lo[r * nx + x] = std::min(std::min(std::min(blo[a], blo[x]), blo[c]), edge ? border.lo : std::uint8_t{255});
                hi[r * nx + x] = std::max(std::max(std::max(bhi[a], bhi[x]), bhi[c]), edge ? border.hi : std::uint8_t{0});
            }
        }
    });
}

/// The segment codes of the n voxels of `dims` whose densities `density(i)` gives.
template <Executor X, class Density>
EssCodes ess_codes_of(const Density& density, volume::Dims dims, vec3 spacing, std::uint32_t entries,
                      const GridBorder& gb, X& exec) {
    auto t0 = std::chrono::steady_clock::now();
    std::size_t n = volume::voxel_count(dims);
    if (entries < 2 || entries > (1u << 24)) throw Error("kd-dvr: the transfer function needs 2 to 2^24 entries");
    EssBorder border = ess_border(gb, entries);
    std::vector<std::uint8_t> lo(n), hi(n), lo2(n), hi2(n);
    ess_rows(density, dims, entries, border, lo, hi, exec);
    ess_filter_pass(lo, hi, lo2, hi2, dims.x, dims.y, dims.z, border, exec);                     // along y
    ess_filter_pass(lo2, hi2, lo, hi, std::size_t{dims.x} * dims.y, dims.z, 1, border, exec);  // along z
    std::vector<std::uint8_t>().swap(lo2);  // peak 4 bytes a voxel (not 6) while the codes are written
    std::vector<std::uint8_t>().swap(hi2);
    EssCodes c;
    c.entries = entries;
    c.volume.type = volume::ScalarType::U16;
    c.volume.dims = dims;
    c.volume.spacing = spacing;
    c.volume.range_lo = 0.0f;
    c.volume.range_hi = 65535.0f;
    c.volume.bytes.resize(n * 2);
    exec.parallel_for(0, n, std::size_t{1} << 16, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            auto code = static_cast<std::uint16_t>(lo[i] | (hi[i] << 8));
            std::memcpy(&c.volume.bytes[2 * i], &code, 2);
        }
    });
    c.ms = detail::ess_ms_since(t0);
    return c;
}

}  // namespace detail

/// The segment codes of `g` for a TF of `entries` entries (see EssCodes), in parallel, for a
/// marcher whose grid has the border `border` (the boundary voxels' neighbourhoods hold the
/// border value when it is constant). Throws sylva::Error when the values do not match the
/// dimensions or one is NaN.
template <Executor X>
EssCodes ess_codes(const volume::DensityGrid& g, std::uint32_t entries, X& exec, const GridBorder& border = {}) {
    std::size_t n = volume::voxel_count(g.dims);
    if (g.values.size() != n || n == 0)
        throw Error("kd-dvr: the grid holds " + std::to_string(g.values.size()) + " values for " + std::to_string(n) +
                    " voxels");
    return detail::ess_codes_of([&](std::size_t i) { return g.values[i]; }, g.dims, g.spacing, entries, border, exec);
}

/// The segment codes of grid words in any format (GridWords::native: no float copy), with the
/// grid's own border.
template <Executor X>
EssCodes ess_codes(const GridWords& g, std::uint32_t entries, X& exec) {
    g.check_words("kd-dvr");
    shared::Words w{g.words.data(), g.words.size()};
    shared::SylvaGridDesc desc = g.desc();
    if (is_sparse(g.sampling.format))
        return detail::ess_codes_of([&](std::size_t i) { return g.density(i); }, g.dims, g.spacing, entries,
                                    g.sampling.border, exec);
    return detail::ess_codes_of(
        [&](std::size_t i) { return shared::sylva_grid_word_density(w, desc, static_cast<std::uint32_t>(i)); }, g.dims,
        g.spacing, entries, g.sampling.border, exec);
}

/// The code of voxel i.
inline std::uint16_t ess_code(const EssCodes& c, std::size_t i) {
    std::uint16_t code;
    std::memcpy(&code, &c.volume.bytes[2 * i], 2);
    return code;
}

/// The occupancy of `codes` under `cls` (for builders fed directly), in parallel.
template <Executor X>
volume::Occupancy ess_occupancy(const EssCodes& codes, const EssClassifier& cls, X& exec) {
    if (cls.entries() != codes.entries)
        throw Error("kd-dvr: codes made for a TF of " + std::to_string(codes.entries) + " entries, classifier for " +
                    std::to_string(cls.entries()));
    std::size_t n = volume::voxel_count(codes.volume.dims);
    volume::Occupancy occ{codes.volume.dims, codes.volume.spacing, std::vector<std::uint8_t>(n)};
    exec.parallel_for(0, n, std::size_t{1} << 16, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) occ.voxels[i] = cls.visible(ess_code(codes, i)) ? 1u : 0u;
    });
    return occ;
}

// ---- block ranges: the occupancy without segment codes ----------------------------------------

namespace detail {

// The passes below read a grid row by row through a Rows type: `dims`; `value_type`, what a
// voxel is read as (float densities, or the raw uint8 / uint16 voxels of a native grid, whose
// density is a nondecreasing function of them, so that the least raw value of a neighbourhood
// has its least density); `row(x0, x1, y, z, scratch)`, a pointer p with p[x] the value of voxel
// (x, y, z) for x in [x0, x1) (into the grid, or written into scratch, which has dims.x
// entries); `prefetch(x0, x1, y, z)`; and `density(value)`. Raw voxels are read 4 (uint8) or 2
// (uint16) times fewer bytes than floats, and their ranges are taken 16 / 8 lanes a vector.

/// Rows of densities of a DensityGrid: pointers into its values.
struct EssFloatRows {
    using value_type = float;
    volume::Dims dims;
    const float* values;
    const float* row(std::uint32_t, std::uint32_t, std::uint32_t y, std::uint32_t z, float* /*scratch*/) const {
        return values + volume::voxel_index(dims, 0, y, z);
    }
    /// Asks for the cache lines of voxels [x0, x1) of row (y, z) ahead of their use.
    void prefetch(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z) const {
        const float* p = values + volume::voxel_index(dims, 0, y, z);
        for (std::uint32_t x = x0; x < x1; x += 16u) __builtin_prefetch(p + x);
        __builtin_prefetch(p + x1 - 1u);
    }
    static float density(float v) { return v; }
};

/// Rows of densities of grid words in any format, voxel by voxel into `scratch` (float grids,
/// sparse grids, and integer grids whose densities are not monotone in the raw values).
struct EssWordRows {
    using value_type = float;
    volume::Dims dims;
    const GridWords* grid;
    const float* row(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z, float* scratch) const {
        std::size_t at = volume::voxel_index(dims, 0, y, z);
        if (is_sparse(grid->sampling.format)) {
            for (std::uint32_t x = x0; x < x1; ++x) scratch[x] = grid->density(at + x);
        } else {
            shared::Words w{grid->words.data(), grid->words.size()};
            shared::SylvaGridDesc desc = grid->desc();
            for (std::uint32_t x = x0; x < x1; ++x)
                scratch[x] = shared::sylva_grid_word_density(w, desc, static_cast<std::uint32_t>(at + x));
        }
        return scratch;
    }
    void prefetch(std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t) const {}
    static float density(float v) { return v; }
};

/// Rows of the raw voxels of a dense uint8 / uint16 grid (GridWords::native), read as
/// themselves; `table` holds the density of every raw value (the samplers' arithmetic,
/// sylva_grid_raw_density), nondecreasing (ess_raw_density_table checks it).
template <class T>
struct EssRawRows {
    static_assert(std::is_same_v<T, std::uint8_t> || std::is_same_v<T, std::uint16_t>);
    using value_type = T;
    volume::Dims dims;
    const std::uint32_t* words;
    const float* table;
    const T* row(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z, T* scratch) const {
        std::size_t at = volume::voxel_index(dims, 0, y, z);
        if constexpr (sizeof(T) == 1) {
            // Voxel i is byte i & 3 of word i >> 2 (bits 8 (i & 3)): on a little-endian host,
            // byte i of the words, read through unsigned char (which may alias any object).
            return reinterpret_cast<const unsigned char*>(words) + at;
        } else {
            for (std::uint32_t x = x0; x < x1; ++x) {
                std::size_t i = at + x;
                scratch[x] = static_cast<T>(words[i >> 1] >> ((i & 1u) * 16u));
            }
            return scratch;
        }
    }
    void prefetch(std::uint32_t x0, std::uint32_t x1, std::uint32_t y, std::uint32_t z) const {
        const char* p = reinterpret_cast<const char*>(words) + (volume::voxel_index(dims, 0, y, z) + x0) * sizeof(T);
        for (std::size_t o = 0; o < std::size_t{x1 - x0} * sizeof(T); o += 64u) __builtin_prefetch(p + o);
        __builtin_prefetch(p + std::size_t{x1 - x0} * sizeof(T) - 1u);
    }
    [[nodiscard]] float density(T v) const { return table[v]; }
};

/// The density of every raw value of a dense uint8 / uint16 grid, as its samplers compute it;
/// empty when the grid is not one, or when the densities are not nondecreasing in the raw
/// value (then the raw passes would not be exact and the grid is read as floats).
inline std::vector<float> ess_raw_density_table(const GridWords& g) {
    if constexpr (std::endian::native != std::endian::little) return {};
    std::uint32_t values = g.sampling.format == GridFormat::U8 ? 256u : g.sampling.format == GridFormat::U16 ? 65536u : 0u;
    std::vector<float> table(values);
    shared::SylvaGridDesc desc = g.desc();
    for (std::uint32_t v = 0; v < values; ++v) {
        table[v] = shared::sylva_grid_raw_density(desc, v);
        if (!(v == 0u || table[v] >= table[v - 1u])) return {};  // NaN or decreasing
    }
    if (values > 0u && !std::isfinite(table[0])) return {};
    return table;
}

/// Calls f(rows) with the fastest exact Rows over grid words: raw uint8 / uint16 voxels for a
/// dense integer grid, floats otherwise.
template <class F>
decltype(auto) ess_with_rows(const GridWords& g, F&& f) {
    std::vector<float> table = ess_raw_density_table(g);
    if (!table.empty() && g.sampling.format == GridFormat::U8)
        return f(EssRawRows<std::uint8_t>{g.dims, g.words.data(), table.data()});
    if (!table.empty()) return f(EssRawRows<std::uint16_t>{g.dims, g.words.data(), table.data()});
    return f(EssWordRows{g.dims, &g});
}

/// The identity of min (the highest value) and of max (the lowest) over a value type.
template <class V>
constexpr V ess_min_identity() {
    if constexpr (std::numeric_limits<V>::has_infinity) return std::numeric_limits<V>::infinity();
    else return std::numeric_limits<V>::max();
}
template <class V>
constexpr V ess_max_identity() {
    if constexpr (std::numeric_limits<V>::has_infinity) return -std::numeric_limits<V>::infinity();
    else return std::numeric_limits<V>::lowest();
}

/// o[x] = min(a[x], b[x], c[x]) and p[x] = max(d[x], e[x], f[x]) for x < n: the 3-wide range
/// filters, written with restrict pointers so that they vectorize.
template <class V>
inline void ess_min3(const V* __restrict a, const V* __restrict b, const V* __restrict c, V* __restrict o, std::uint32_t n) {
    for (std::uint32_t x = 0; x < n; ++x) {
        V m = b[x] < a[x] ? b[x] : a[x];
        o[x] = c[x] < m ? c[x] : m;
    }
}
template <class V>
inline void ess_max3(const V* __restrict a, const V* __restrict b, const V* __restrict c, V* __restrict o, std::uint32_t n) {
    for (std::uint32_t x = 0; x < n; ++x) {
        V m = b[x] > a[x] ? b[x] : a[x];
        o[x] = c[x] > m ? c[x] : m;
    }
}

}  // namespace detail

/// The density range of every 8^3 block (kdtree::block_counts, x fastest) over its voxels and
/// the voxels next to them (the block grown by one voxel a side, clipped to the grid): the
/// union of its voxels' 3x3x3 neighbourhoods. Independent of the transfer function.
struct EssBlockRanges {
    volume::Dims dims{0};
    uvec3 blocks{0u};
    std::vector<float> lo, hi;
    double ms = 0.0;  ///< time of the pass that computed them
};

namespace detail {

/// Blocks along one axis whose grown range holds voxel coordinate c: c / 8, and the block
/// before when c starts a block, the block after when c ends one.
inline void ess_blocks_holding(std::uint32_t c, std::uint32_t blocks, std::uint32_t& first, std::uint32_t& last) {
    first = c / 8u;
    last = first;
    if (c % 8u == 0u && first > 0u) --first;
    if (c % 8u == 7u && last + 1u < blocks) ++last;
}

/// Adds row `v` (n values) into the running column ranges lo, hi, element by element; returns
/// true when the row holds a NaN (never for raw values).
template <class V>
inline bool ess_fold_row(const V* __restrict v, V* __restrict lo, V* __restrict hi, std::uint32_t n) {
    std::uint32_t nan = 0;
    for (std::uint32_t x = 0; x < n; ++x) {
        V t = v[x];
        if constexpr (std::is_floating_point_v<V>) nan |= static_cast<std::uint32_t>(t != t);
        lo[x] = t < lo[x] ? t : lo[x];
        hi[x] = t > hi[x] ? t : hi[x];
    }
    return nan != 0u;
}

/// One streaming pass: the grown ranges of every block of `rows`. Slabs of blocks (bz) in
/// parallel; each reads its 8 slices and the one on either side, folds every row into the
/// column ranges of the one or two rows of blocks (by) whose grown range holds it, then takes
/// each block's grown x-range of its row's columns, as densities.
template <class Rows, Executor X>
EssBlockRanges ess_block_ranges(const Rows& rows, X& exec) {
    using V = typename Rows::value_type;
    auto t0 = std::chrono::steady_clock::now();
    volume::Dims d = rows.dims;
    volume::voxel_count(d);
    EssBlockRanges r;
    r.dims = d;
    r.blocks = kdtree::block_counts(d);
    std::size_t nb = std::size_t{r.blocks.x} * r.blocks.y * r.blocks.z;
    r.lo.assign(nb, std::numeric_limits<float>::infinity());
    r.hi.assign(nb, -std::numeric_limits<float>::infinity());
    exec.parallel_for(0, r.blocks.z, 1, [&](std::size_t bz0, std::size_t bz1) {
        std::vector<V> scratch(d.x), clo(std::size_t{r.blocks.y} * d.x), chi(clo.size());
        for (auto bz = static_cast<std::uint32_t>(bz0); bz < bz1; ++bz) {
            std::fill(clo.begin(), clo.end(), ess_min_identity<V>());
            std::fill(chi.begin(), chi.end(), ess_max_identity<V>());
            std::uint32_t z0 = bz * 8u > 0u ? bz * 8u - 1u : 0u, z1 = std::min(d.z - 1u, bz * 8u + 8u);
            bool nan = false;
            for (std::uint32_t z = z0; z <= z1; ++z)
                for (std::uint32_t y = 0; y < d.y; ++y) {
                    const V* v = rows.row(0u, d.x, y, z, scratch.data());
                    std::uint32_t by0, by1;
                    ess_blocks_holding(y, r.blocks.y, by0, by1);
                    for (std::uint32_t by = by0; by <= by1; ++by)
                        nan |= ess_fold_row(v, clo.data() + std::size_t{by} * d.x, chi.data() + std::size_t{by} * d.x, d.x);
                }
            if (nan) throw Error("kd-dvr: the grid holds a NaN density");
            for (std::uint32_t by = 0; by < r.blocks.y; ++by) {
                const V* lo = clo.data() + std::size_t{by} * d.x;
                const V* hi = chi.data() + std::size_t{by} * d.x;
                std::size_t at = std::size_t{r.blocks.x} * (by + std::size_t{r.blocks.y} * bz);
                for (std::uint32_t bx = 0; bx < r.blocks.x; ++bx) {
                    std::uint32_t x0 = bx * 8u > 0u ? bx * 8u - 1u : 0u, x1 = std::min(d.x - 1u, bx * 8u + 8u);
                    V mn = ess_min_identity<V>(), mx = ess_max_identity<V>();
                    for (std::uint32_t x = x0; x <= x1; ++x) mn = std::min(mn, lo[x]), mx = std::max(mx, hi[x]);
                    r.lo[at + bx] = rows.density(mn);  // the density is nondecreasing in the value
                    r.hi[at + bx] = rows.density(mx);
                }
            }
        }
    });
    r.ms = ess_ms_since(t0);
    return r;
}

/// True when block b (coordinates) holds a voxel on a face of the grid.
inline bool ess_block_on_face(uvec3 b, uvec3 blocks) {
    return b.x == 0u || b.y == 0u || b.z == 0u || b.x + 1u == blocks.x || b.y + 1u == blocks.y ||
           b.z + 1u == blocks.z;
}

}  // namespace detail

/// The density ranges of the blocks of `g` (see EssBlockRanges), in parallel. Throws
/// sylva::Error when the values do not match the dimensions or one is NaN.
template <Executor X>
EssBlockRanges ess_block_ranges(const volume::DensityGrid& g, X& exec) {
    std::size_t n = volume::voxel_count(g.dims);
    if (g.values.size() != n || n == 0)
        throw Error("kd-dvr: the grid holds " + std::to_string(g.values.size()) + " values for " + std::to_string(n) +
                    " voxels");
    return detail::ess_block_ranges(detail::EssFloatRows{g.dims, g.values.data()}, exec);
}

/// The same over grid words in any format; a dense uint8 / uint16 grid is read as its raw
/// voxels (1 / 2 bytes a voxel).
template <Executor X>
EssBlockRanges ess_block_ranges(const GridWords& g, X& exec) {
    g.check_words("kd-dvr");
    return detail::ess_with_rows(g, [&](const auto& rows) { return detail::ess_block_ranges(rows, exec); });
}

/// Verdicts of the blocks under `cls` (kdtree::kBlockEmpty / kBlockFull / kBlockRead, one byte
/// a block, storage reused) from their grown ranges, with a constant border's buckets in the
/// blocks on a face of the grid. A decided block's voxels all have the verdict's occupancy.
inline void ess_block_verdicts(const EssBlockRanges& r, const EssClassifier& cls, const GridBorder& border,
                               std::vector<std::uint8_t>& out) {
    constexpr float eps = detail::kEssEps;
    detail::EssBucketMap bucket(cls.entries());
    detail::EssBorder eb = detail::ess_border(border, cls.entries());
    out.assign(r.lo.size(), kdtree::kBlockRead);
    for (std::size_t b = 0; b < r.lo.size(); ++b) {
        uvec3 c(static_cast<std::uint32_t>(b % r.blocks.x), static_cast<std::uint32_t>((b / r.blocks.x) % r.blocks.y),
                static_cast<std::uint32_t>(b / (std::size_t{r.blocks.x} * r.blocks.y)));
        std::uint32_t lo = bucket(r.lo[b] - eps), hi = bucket(r.hi[b] + eps);
        if (detail::ess_block_on_face(c, r.blocks)) lo = std::min<std::uint32_t>(lo, eb.lo), hi = std::max<std::uint32_t>(hi, eb.hi);
        std::uint32_t visible = cls.visible_in(lo, hi);
        out[b] = visible == 0u ? kdtree::kBlockEmpty : (visible == hi - lo + 1u ? kdtree::kBlockFull : kdtree::kBlockRead);
    }
}

namespace detail {

/// The smallest float x with bucket(x) >= b (bucket is monotone in x: clamped to [0, 1], then
/// non-decreasing), by bisection over the bits of the floats in [0, 1]; -inf when every x
/// reaches b, +inf when none does.
inline float ess_bucket_start(const EssBucketMap& bucket, std::uint32_t b) {
    constexpr float inf = std::numeric_limits<float>::infinity();
    if (b <= bucket(0.0f)) return -inf;
    if (b > bucket(1.0f)) return inf;
    std::uint32_t lo = std::bit_cast<std::uint32_t>(0.0f), hi = std::bit_cast<std::uint32_t>(1.0f);  // bucket(lo) < b <= bucket(hi)
    while (hi - lo > 1u) {
        std::uint32_t mid = lo + (hi - lo) / 2u;
        if (bucket(std::bit_cast<float>(mid)) >= b) hi = mid;
        else lo = mid;
    }
    return std::bit_cast<float>(hi);
}

/// The runs of visible buckets of a classifier as density intervals: the buckets of [l, h]
/// hold a visible one exactly when l < end[i] and h >= start[i] for some run i (buckets
/// between bucket(l) and bucket(h) that no density reaches are never visible). Empty `start`
/// and `usable` false when there are more than `max_runs` runs (then voxels are classified
/// through their buckets).
struct EssVisibleRuns {
    std::vector<float> start, end;
    bool usable = true;
};

inline EssVisibleRuns ess_visible_runs(const EssClassifier& cls, const EssBucketMap& bucket, std::size_t max_runs = 8) {
    EssVisibleRuns r;
    for (std::uint32_t b = 0; b < kEssBuckets;) {
        if (cls.visible_in(b, b) == 0u) {
            ++b;
            continue;
        }
        std::uint32_t e = b;
        while (e + 1u < kEssBuckets && cls.visible_in(e + 1u, e + 1u) != 0u) ++e;
        if (r.start.size() == max_runs) return {{}, {}, false};
        r.start.push_back(ess_bucket_start(bucket, b));
        r.end.push_back(ess_bucket_start(bucket, e + 1u));
        b = e + 1u;
    }
    return r;
}

/// The visible runs (EssVisibleRuns) as bounds on raw values, for Rows whose values are raw
/// voxels: a voxel whose neighbourhood holds raw values [lo, hi] reaches run i exactly when
/// hi >= start[i] and (end_all[i] or lo < end[i]), because the densities clamp(density(v) -+
/// eps, -1, 2) the float classification compares are nondecreasing in v. Runs no value reaches
/// are left out; `usable` false for float values or unusable runs (then voxels are classified
/// as densities).
template <class V>
struct EssRawRuns {
    std::vector<V> start, end;
    std::vector<std::uint8_t> end_all;  ///< every raw value lies below the run's end
    bool usable = false;
};

template <class Rows>
EssRawRuns<typename Rows::value_type> ess_raw_runs(const Rows& rows, const EssVisibleRuns& runs) {
    using V = typename Rows::value_type;
    EssRawRuns<V> r;
    if constexpr (!std::is_floating_point_v<V>) {
        if (!runs.usable) return r;
        constexpr std::uint32_t n = std::uint32_t{std::numeric_limits<V>::max()} + 1u;
        auto lower = [&](std::uint32_t v) { return std::clamp(rows.density(static_cast<V>(v)) - kEssEps, -1.0f, 2.0f); };
        auto upper = [&](std::uint32_t v) { return std::clamp(rows.density(static_cast<V>(v)) + kEssEps, -1.0f, 2.0f); };
        auto first_reaching = [&](auto&& f, float bound) {  // least v with f(v) >= bound, n when none
            std::uint32_t lo = 0, hi = n;
            while (lo < hi) {
                std::uint32_t mid = lo + (hi - lo) / 2u;
                if (f(mid) >= bound) hi = mid;
                else lo = mid + 1u;
            }
            return lo;
        };
        for (std::size_t i = 0; i < runs.start.size(); ++i) {
            std::uint32_t s = first_reaching(upper, runs.start[i]), e = first_reaching(lower, runs.end[i]);
            if (s == n || e == 0u) continue;  // no neighbourhood's range reaches the run
            r.start.push_back(static_cast<V>(s));
            r.end.push_back(static_cast<V>(e == n ? 0u : e));
            r.end_all.push_back(e == n ? 1u : 0u);
        }
        r.usable = true;
    }
    return r;
}

/// The block words of one row of blocks (by, bz): decided blocks from their verdicts; each run
/// of blocks to read classified voxel by voxel from its 3x3x3 neighbourhoods, min and max
/// taken separably (x, then y, then z) over the run's rows and the rows around them, in the
/// Rows' values (raw voxels of a native grid are compared as themselves).
template <class Rows>
struct EssBlockRowPass {
    using V = typename Rows::value_type;
    const Rows& rows;
    const EssClassifier& cls;
    const EssBucketMap& bucket;
    const EssVisibleRuns& runs;
    const EssRawRuns<V>& raw_runs;
    float border_lo, border_hi;  ///< a face voxel's range takes in [border_lo, border_hi] (min / max identities under a clamped border)
    const std::uint8_t* verdicts;
    uvec3 nb;
    std::uint32_t* words;
    // Scratch of the task running it: a row of values, x-filtered rows (up to 10 x 10 of the
    // run's width), y-filtered rows (10 x 8), one row of neighbourhood ranges as values and as
    // densities, of occupancy bytes, accumulators.
    std::vector<V> scratch, xlo, xhi, ylo, yhi, zlo, zhi;
    std::vector<float> dlo, dhi;
    std::vector<std::uint8_t> occ;
    std::vector<kdtree::detail::BlockAccumulator> acc;

    EssBlockRowPass(const Rows& r, const EssClassifier& c, const EssBucketMap& b, const EssVisibleRuns& v,
                    const EssRawRuns<V>& rv, const GridBorder& border, const std::uint8_t* verdict, std::uint32_t* w)
        : rows(r), cls(c), bucket(b), runs(v), raw_runs(rv), verdicts(verdict), nb(kdtree::block_counts(r.dims)),
          words(w), scratch(r.dims.x), zlo(r.dims.x), zhi(r.dims.x), dlo(r.dims.x), dhi(r.dims.x), occ(r.dims.x),
          acc(nb.x) {
        constexpr float eps = kEssEps;
        bool clamp = border.mode == BorderMode::Clamp;
        border_lo = clamp ? std::numeric_limits<float>::infinity() : border.value - eps;
        border_hi = clamp ? -std::numeric_limits<float>::infinity() : border.value + eps;
    }

    void run(std::uint32_t by, std::uint32_t bz) {
        kdtree::detail::for_each_block_run(rows.dims, nb, by, bz, verdicts, words,
                                           [&](std::uint32_t bx, std::uint32_t end) { read_run(bx, end, by, bz); });
    }

    /// The occupancy of a voxel whose neighbourhood's density range, eps included, is [lo, hi].
    [[nodiscard]] std::uint8_t classify_one(float lo, float hi) const {
        if (runs.usable) {
            for (std::size_t r = 0; r < runs.start.size(); ++r)
                if (hi >= runs.start[r] && lo < runs.end[r]) return 1u;
            return 0u;
        }
        return cls.visible_in(bucket(lo), bucket(hi)) != 0u ? 1u : 0u;
    }

    /// occ[0, w) of the voxels whose neighbourhood density ranges, eps included, are
    /// [dlo[x], dhi[x]].
    void classify(std::uint32_t w) {
        if (runs.usable) {
            std::fill(occ.begin(), occ.begin() + w, std::uint8_t{0});
            for (std::size_t r = 0; r < runs.start.size(); ++r) {
                const float s = runs.start[r], e = runs.end[r];
                for (std::uint32_t x = 0; x < w; ++x)
                    occ[x] |= static_cast<std::uint8_t>((dhi[x] >= s) & (dlo[x] < e));
            }
            return;
        }
        for (std::uint32_t x = 0; x < w; ++x) occ[x] = classify_one(dlo[x], dhi[x]);
    }

    /// occ[0, w) from the raw neighbourhood ranges [zlo[x], zhi[x]] (raw_runs usable).
    void classify_raw(std::uint32_t w) {
        std::uint8_t* __restrict o = occ.data();
        const V* __restrict lo = zlo.data();
        const V* __restrict hi = zhi.data();
        std::fill(o, o + w, std::uint8_t{0});
        for (std::size_t r = 0; r < raw_runs.start.size(); ++r) {
            const V s = raw_runs.start[r], e = raw_runs.end[r];
            if (raw_runs.end_all[r] != 0u) {
                for (std::uint32_t x = 0; x < w; ++x) o[x] |= static_cast<std::uint8_t>(hi[x] >= s);
            } else {
                for (std::uint32_t x = 0; x < w; ++x) o[x] |= static_cast<std::uint8_t>((hi[x] >= s) & (lo[x] < e));
            }
        }
    }

    /// The density range of a neighbourhood whose values are [lo, hi], eps included, held in
    /// [-1, 2]: the buckets clamp to [0, 1] anyway, and an infinite density then still compares
    /// below a run's end of +inf.
    [[nodiscard]] float lower(V lo) const { return std::clamp(rows.density(lo) - kEssEps, -1.0f, 2.0f); }
    [[nodiscard]] float upper(V hi) const { return std::clamp(rows.density(hi) + kEssEps, -1.0f, 2.0f); }

    /// occ[0, w) of row (y, z) of the run starting at voxel x0, from its neighbourhoods' value
    /// ranges [zlo, zhi]; a voxel on a face of the grid also takes in the border's range.
    void classify_row(std::uint32_t w, std::uint32_t x0, std::uint32_t y, std::uint32_t z) {
        const volume::Dims d = rows.dims;
        bool face_row = y == 0u || z == 0u || y + 1u == d.y || z + 1u == d.z;
        if constexpr (!std::is_floating_point_v<V>) {
            if (!face_row && raw_runs.usable) {
                classify_raw(w);
                for (std::uint32_t x : {0u, w - 1u})
                    if (x0 + x == 0u || x0 + x + 1u == d.x)
                        occ[x] = classify_one(std::min(lower(zlo[x]), border_lo), std::max(upper(zhi[x]), border_hi));
                return;
            }
        }
        for (std::uint32_t x = 0; x < w; ++x) dlo[x] = lower(zlo[x]), dhi[x] = upper(zhi[x]);
        if (face_row) {  // the whole row
            for (std::uint32_t x = 0; x < w; ++x) dlo[x] = std::min(dlo[x], border_lo), dhi[x] = std::max(dhi[x], border_hi);
        } else {
            for (std::uint32_t x : {0u, w - 1u})
                if (x0 + x == 0u || x0 + x + 1u == d.x) dlo[x] = std::min(dlo[x], border_lo), dhi[x] = std::max(dhi[x], border_hi);
        }
        classify(w);
    }

    void read_run(std::uint32_t bx, std::uint32_t end, std::uint32_t by, std::uint32_t bz) {
        const volume::Dims d = rows.dims;
        std::uint32_t x0 = bx * 8u, x1 = std::min(d.x, end * 8u), w = x1 - x0;
        std::uint32_t y0 = by * 8u, y1 = std::min(d.y, y0 + 8u), z0 = bz * 8u, z1 = std::min(d.z, z0 + 8u);
        std::uint32_t ya = y0 > 0u ? y0 - 1u : 0u, yb = std::min(d.y, y1 + 1u);  // rows read: [ya, yb)
        std::uint32_t za = z0 > 0u ? z0 - 1u : 0u, zb = std::min(d.z, z1 + 1u);
        std::uint32_t ny = yb - ya, nz = zb - za;
        xlo.resize(std::size_t{nz} * ny * w), xhi.resize(xlo.size());
        ylo.resize(std::size_t{nz} * 8u * w), yhi.resize(ylo.size());
        // x: the 3-wide range of every row the run's neighbourhoods reach (the grid's first
        // and last voxels have one neighbour along x).
        std::uint32_t xa = x0 > 0u ? x0 - 1u : 0u, xb = std::min(d.x, x1 + 1u);  // voxels read: [xa, xb)
        std::uint32_t i0 = x0 == 0u ? 1u : x0, i1 = x1 == d.x ? x1 - 1u : x1;    // interior voxels [i0, i1)
        for (std::uint32_t y = ya; y < yb; ++y) rows.prefetch(xa, xb, y, za);
        for (std::uint32_t z = za; z < zb; ++z)
            for (std::uint32_t y = ya; y < yb; ++y) {
                if (z + 1u < zb) rows.prefetch(xa, xb, y, z + 1u);  // the next slice's row, while this one is filtered
                const V* v = rows.row(xa, xb, y, z, scratch.data());
                V* lo = xlo.data() + (std::size_t{z - za} * ny + (y - ya)) * w;
                V* hi = xhi.data() + (std::size_t{z - za} * ny + (y - ya)) * w;
                if (i1 > i0) {
                    ess_min3(v + i0 - 1u, v + i0, v + i0 + 1u, lo + (i0 - x0), i1 - i0);
                    ess_max3(v + i0 - 1u, v + i0, v + i0 + 1u, hi + (i0 - x0), i1 - i0);
                }
                for (std::uint32_t x : {x0, x1 - 1u}) {
                    if (x >= i0 && x < i1) continue;
                    V a = v[x > 0u ? x - 1u : x], b = v[x], c = v[x + 1u < d.x ? x + 1u : x];
                    lo[x - x0] = std::min(std::min(a, b), c);
                    hi[x - x0] = std::max(std::max(a, b), c);
                }
            }
        // y: rows y0..y1 of every slice read.
        for (std::uint32_t z = 0; z < nz; ++z)
            for (std::uint32_t y = y0; y < y1; ++y) {
                std::uint32_t a = (y > 0u ? y - 1u : y) - ya, b = y - ya, c = (y + 1u < d.y ? y + 1u : y) - ya;
                std::size_t at = (std::size_t{z} * 8u + (y - y0)) * w;
                ess_min3(&xlo[(std::size_t{z} * ny + a) * w], &xlo[(std::size_t{z} * ny + b) * w],
                         &xlo[(std::size_t{z} * ny + c) * w], &ylo[at], w);
                ess_max3(&xhi[(std::size_t{z} * ny + a) * w], &xhi[(std::size_t{z} * ny + b) * w],
                         &xhi[(std::size_t{z} * ny + c) * w], &yhi[at], w);
            }
        // z, then the classification (eps, the border), the blocks' accumulators.
        std::fill(acc.begin(), acc.begin() + (end - bx), shared::sylva_kd_box_acc_zero());
        for (std::uint32_t z = z0; z < z1; ++z) {
            std::uint32_t a = (z > 0u ? z - 1u : z) - za, b = z - za, c = (z + 1u < d.z ? z + 1u : z) - za;
            for (std::uint32_t y = y0; y < y1; ++y) {
                std::size_t r = y - y0;
                ess_min3(&ylo[(std::size_t{a} * 8u + r) * w], &ylo[(std::size_t{b} * 8u + r) * w],
                         &ylo[(std::size_t{c} * 8u + r) * w], zlo.data(), w);
                ess_max3(&yhi[(std::size_t{a} * 8u + r) * w], &yhi[(std::size_t{b} * 8u + r) * w],
                         &yhi[(std::size_t{c} * 8u + r) * w], zhi.data(), w);
                classify_row(w, x0, y, z);
                for (std::uint32_t k = 0; k < end - bx; ++k)
                    shared::sylva_kd_box_accumulate(acc[k], kdtree::detail::row_mask(occ.data() + k * 8u, std::min(8u, w - k * 8u)),
                                                    y & 7u, z & 7u);
            }
        }
        std::size_t first = std::size_t{nb.x} * (by + std::size_t{nb.y} * bz);
        for (std::uint32_t k = 0; k < end - bx; ++k) words[first + bx + k] = shared::sylva_kd_box_acc_word(acc[k], false);
    }
};

template <class Rows, Executor X>
void ess_block_words(const Rows& rows, const EssClassifier& cls, const GridBorder& border,
                     const std::vector<std::uint8_t>& verdicts, X& exec, std::vector<std::uint32_t>& words) {
    uvec3 nb = kdtree::block_counts(rows.dims);
    if (verdicts.size() != std::size_t{nb.x} * nb.y * nb.z)
        throw Error("kd-dvr: " + std::to_string(verdicts.size()) + " block verdicts for a grid of " +
                    std::to_string(std::size_t{nb.x} * nb.y * nb.z) + " blocks");
    words.resize(verdicts.size());
    border.check();
    EssBucketMap bucket(cls.entries());
    EssVisibleRuns runs = ess_visible_runs(cls, bucket);
    EssRawRuns<typename Rows::value_type> raw_runs = ess_raw_runs(rows, runs);
    exec.parallel_for(0, std::size_t{nb.y} * nb.z, 1, [&](std::size_t lo, std::size_t hi) {
        EssBlockRowPass<Rows> pass(rows, cls, bucket, runs, raw_runs, border, verdicts.data(), words.data());
        for (std::size_t r = lo; r < hi; ++r)
            pass.run(static_cast<std::uint32_t>(r % nb.y), static_cast<std::uint32_t>(r / nb.y));
    });
}

}  // namespace detail

/// The block words (kdtree/gpu_local_boxes.hpp: one word a 8^3 block, its occupied voxels'
/// masks and count) of the ESS occupancy of `g` under `cls` for a marcher with border `border`:
/// blocks `verdicts` decides (ess_block_verdicts) without reading them, the others voxel by
/// voxel. Equal to kdtree::block_words over ess_occupancy(ess_codes(g, ...), cls). Into `words`
/// (resized, storage reused), rows of blocks in parallel.
template <Executor X>
void ess_block_words(const volume::DensityGrid& g, const EssClassifier& cls, const GridBorder& border,
                     const std::vector<std::uint8_t>& verdicts, X& exec, std::vector<std::uint32_t>& words) {
    if (g.values.size() != volume::voxel_count(g.dims)) throw Error("kd-dvr: the grid's values do not match its dimensions");
    detail::ess_block_words(detail::EssFloatRows{g.dims, g.values.data()}, cls, border, verdicts, exec, words);
}

/// The same over grid words in any format, with their own border; a dense uint8 / uint16 grid
/// is read as its raw voxels.
template <Executor X>
void ess_block_words(const GridWords& g, const EssClassifier& cls, const std::vector<std::uint8_t>& verdicts, X& exec,
                     std::vector<std::uint32_t>& words) {
    g.check_words("kd-dvr");
    detail::ess_with_rows(g, [&](const auto& rows) {
        detail::ess_block_words(rows, cls, g.sampling.border, verdicts, exec, words);
    });
}

}  // namespace sylva

#endif  // SYLVA_RENDER_ESS_OCCUPANCY_HPP
