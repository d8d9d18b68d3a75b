// sylva/render/kd_volume.hpp -- DVR with empty-space skipping by an empty-space kd-tree on the
// host (sylva/shared/kd_dvr.h over all cores of an executor), and the occupancy that makes its
// image exactly the reference marcher's (Vidal et al. section 2.1; Zellmann et al. section 5).
//
//   ThreadPool pool;
//   GridWords grid = GridWords::from(density);
//   EssRebuilder ess(density, kdtree::Config::deep(), pool);   // once per volume
//   kdtree::Tree tree = ess.rebuild(p.tf);                      // per transfer function
//   std::vector<std::uint32_t> words = kdtree::encode(tree);
//   Frame img = render_kd_dvr_cpu(grid, words, p, pool);        // == render_dvr_cpu(grid, p, pool)
//
// The occupancy (see the reasoning in sylva/shared/kd_dvr.h): a voxel is occupied when the
// transfer function is visible somewhere in the density range of its 3x3x3 neighbourhood (the
// voxels a trilinear sample in its cell reads). That covers the half-voxel reach of trilinear
// reconstruction, is exact for any TF, and keeps every visible sample half a voxel inside the
// occupied cells, so no further dilation is needed.
//
// How it is computed. The TF lookup maps a density d to the table segment
// s(d) = floor(clamp01(d) (N - 1)) (sylva/shared/tf.h; monotone in d), and a density can be
// visible only in a segment with an entry of alpha > 0 at either end. So each voxel gets the
// segment range [s(min - eps), s(max + eps)] of its neighbourhood (eps = 2^-20 absorbs the
// rounding of the three trilinear lerps), stored as one uint16 "segment code": the segments
// grouped into 256 buckets (bucket = s 256 / N; for N <= 256 one segment a bucket),
// bits 0-7 the first bucket and bits 8-15 the last. The codes depend only on the volume and the
// TF's entry count, not on its colours or opacities: a transfer-function change reclassifies
// the codes through a 65536-entry table, which is exactly what kdtree::Rebuilder (rebuild.hpp)
// does for a uint16 volume, so EssRebuilder hands it the codes as a uint16 volume and reuses
// its partial SVTs / Morton block order and local-box arrays across rebuilds (and
// vk::KdRebuilder can compute the binned builder's local boxes on the device).
#ifndef SYLVA_RENDER_KD_VOLUME_HPP
#define SYLVA_RENDER_KD_VOLUME_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/kdtree/rebuild.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/shared/kd_dvr.h"
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
    constexpr float eps = 1.0f / 1048576.0f;
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
    constexpr float eps = 1.0f / 1048576.0f;  // 2^-20: above the rounding of three lerps
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

/// Rebuilds the ESS kd-tree of one density grid when the transfer function changes, through
/// kdtree::Rebuilder over the segment codes (recomputed only when the TF's entry count
/// changes). The grid and the executor must outlive it. The tree is exact for a marcher whose
/// grid has the same border (GridWords::from's default, constant 0, for a DensityGrid).
template <Executor X>
class EssRebuilder {
public:
    EssRebuilder(const volume::DensityGrid& g, const kdtree::Config& cfg, X& exec, const GridBorder& border = {})
        : grid_(&g), exec_(&exec), cfg_(cfg), border_(border) {
        kdtree::detail::check_config(cfg);
        border.check();
    }
    /// Over grid words in any format (GridWords::native), with the grid's own border.
    EssRebuilder(const GridWords& g, const kdtree::Config& cfg, X& exec)
        : words_(&g), exec_(&exec), cfg_(cfg), border_(g.sampling.border) {
        kdtree::detail::check_config(cfg);
        g.check_words("kd-dvr");
    }
    EssRebuilder(const EssRebuilder&) = delete;
    EssRebuilder& operator=(const EssRebuilder&) = delete;

    /// The tree under the transfer function `tf` (packed RGBA8 words, as rendered).
    kdtree::Tree rebuild(std::span<const std::uint32_t> tf) { return rebuild(ess_classifier(tf)); }
    /// The tree under any EssClassifier (ess_classifier, ess_threshold_classifier).
    kdtree::Tree rebuild(const EssClassifier& cls) {
        codes_ms_ = 0.0;
        prepare(cls.entries());
        return rebuilder_->rebuild(cls);
    }
    /// The codes the trees are built on (after the first rebuild).
    [[nodiscard]] const EssCodes& codes() const { return *codes_; }
    /// Phases of the last rebuild (classify_ms: the 65536-entry table; occupancy_ms: partial
    /// SVTs or local boxes; split_ms).
    [[nodiscard]] const kdtree::RebuildTimings& timings() const { return rebuilder_->timings(); }
    /// Time the last rebuild spent computing segment codes (0 unless the TF's entry count changed).
    [[nodiscard]] double codes_ms() const { return codes_ms_; }
    void set_config(const kdtree::Config& cfg) {
        kdtree::detail::check_config(cfg);
        cfg_ = cfg;
        if (rebuilder_) rebuilder_->set_config(cfg);
    }

private:
    void prepare(std::uint32_t entries) {
        if (codes_ && codes_->entries == entries) return;
        rebuilder_.reset();
        codes_ = std::make_unique<EssCodes>(grid_ != nullptr ? ess_codes(*grid_, entries, *exec_, border_)
                                                             : ess_codes(*words_, entries, *exec_));
        codes_ms_ = codes_->ms;
        rebuilder_.emplace(codes_->volume, cfg_, *exec_);
    }
    const volume::DensityGrid* grid_ = nullptr;
    const GridWords* words_ = nullptr;
    X* exec_;
    kdtree::Config cfg_;
    GridBorder border_;
    std::unique_ptr<EssCodes> codes_;
    std::optional<kdtree::Rebuilder<X>> rebuilder_;
    double codes_ms_ = 0.0;
};

namespace detail {

/// Checks that `kd` is an encoded kd-tree over the grid the marcher reads (same dims, same
/// spacing bits, origin 0) and returns its word count.
inline std::uint32_t check_kd_for_grid(std::span<const std::uint32_t> kd, volume::Dims dims, vec3 spacing) {
    if (kd.size() > 0xFFFFFFFFu) throw Error("kd-dvr: kd-tree encoding over 2^32 words");
    auto count = static_cast<std::uint32_t>(kd.size());
    shared::SylvaKdHeader h = shared::sylva_kd_read_header(shared::Words{kd.data(), kd.size()}, count);
    if (h.valid == 0u) throw Error("kd-dvr: not a valid encoded kd-tree (header, node count or depth)");
    if (h.dims != uvec3(dims))
        throw Error("kd-dvr: the kd-tree's grid is " + std::to_string(h.dims.x) + "x" + std::to_string(h.dims.y) +
                    "x" + std::to_string(h.dims.z) + ", the volume's " + std::to_string(dims.x) + "x" +
                    std::to_string(dims.y) + "x" + std::to_string(dims.z));
    for (int a = 0; a < 3; ++a) {
        if (std::bit_cast<std::uint32_t>(h.spacing[a]) != std::bit_cast<std::uint32_t>(spacing[a]))
            throw Error("kd-dvr: the kd-tree's voxel spacing differs from the volume's");
        if (h.origin[a] != 0.0f) throw Error("kd-dvr: the kd-tree's grid origin must be 0 (the marcher's grid box)");
    }
    return count;
}

}  // namespace detail

/// Packs and checks the parameters of ESS DVR: the marcher's (dvr_params) with word 34 the
/// kd-tree's word count; throws sylva::Error when the tree does not fit the grid.
inline std::vector<std::uint32_t> kd_dvr_params(const GridWords& grid, std::span<const std::uint32_t> kd,
                                                const VolumeRenderParams& p) {
    std::vector<std::uint32_t> w = dvr_params(grid, p);
    w[34] = detail::check_kd_for_grid(kd, grid.dims, grid.spacing);
    return w;
}

/// Renders `grid` with the marcher restricted to the leaves of the encoded kd-tree `kd`
/// (p.mode is ignored). steps = kd iterator node visits + lattice samples taken,
/// 0xFFFFFFFF where the encoding was found corrupt.
template <Executor X>
Frame render_kd_dvr_cpu(const GridWords& grid, std::span<const std::uint32_t> kd, const VolumeRenderParams& p,
                        X& exec) {
    std::vector<std::uint32_t> words = kd_dvr_params(grid, kd, p);
    TfWords tfw = tf_words(p);
    shared::Words pw{words.data(), words.size()}, kw{kd.data(), kd.size()}, gw{grid.words.data(), grid.words.size()},
        tw = tfw.view();
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
    return detail::render_pixels(p, exec, [&](vec3 o, vec3 d, std::uint32_t& steps) {
        std::uint32_t status;
        vec4 c = shared::sylva_kd_dvr_march(kw, gw, tw, sp, o, d, 0.0f, shared::sylva_inf(), steps, status);
        if (status == SYLVA_ITER_ERROR) steps = 0xFFFFFFFFu;
        return c;
    });
}

}  // namespace sylva

#endif  // SYLVA_RENDER_KD_VOLUME_HPP
