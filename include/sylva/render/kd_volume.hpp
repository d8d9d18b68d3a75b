// sylva/render/kd_volume.hpp -- DVR with empty-space skipping by an empty-space kd-tree on the
// host (sylva/shared/kd_dvr.h over all cores of an executor), and the occupancy that makes its
// image exactly the reference marcher's (Vidal et al. section 2.1; Zellmann et al. section 5).
//
//   ThreadPool pool;
//   GridWords grid = GridWords::from(density);
//   NeighbourhoodRanges ranges = neighbourhood_ranges(density, pool);  // once per volume
//   EssOccupancy occ = ess_occupancy(ranges, p.tf, pool);              // per transfer function
//   kdtree::Tree tree = kdtree::build_vidal(occ.occupancy, kdtree::Config::deep());
//   std::vector<std::uint32_t> words = kdtree::encode(tree);
//   Frame ess = render_kd_dvr_cpu(grid, words, p, pool);   // == render_dvr_cpu(grid, p, pool)
//
// The occupancy (see the reasoning in sylva/shared/kd_dvr.h): a voxel is occupied when the
// transfer function is visible somewhere in the density range of its 3x3x3 neighbourhood (the
// voxels a trilinear sample in its cell reads). That covers the half-voxel reach of trilinear
// reconstruction, is exact for any TF, and keeps every visible sample half a voxel inside the
// occupied cells, so no further dilation is needed. The neighbourhood ranges do not
// depend on the transfer function: compute them once, and reclassify in one table lookup per
// voxel when the transfer function changes.
#ifndef SYLVA_RENDER_KD_VOLUME_HPP
#define SYLVA_RENDER_KD_VOLUME_HPP

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/shared/kd_dvr.h"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"

namespace sylva {

/// Per voxel, the density range of its 3x3x3 neighbourhood (clamped at the grid's edges) as
/// unorm16 rounded outwards: lo = floor(min * 65535), hi = ceil(max * 65535), densities
/// clamped to [0, 1] first (the TF lookup clamps the same way, so this loses nothing).
struct NeighbourhoodRanges {
    volume::Dims dims{0};
    vec3 spacing{1.0f};
    std::vector<std::uint16_t> lo, hi;
};

/// Which quantised density intervals are visible: entry q says whether a density in
/// [q / 65535, (q + 1) / 65535] (widened by 2^-20 for rounding) can be visible; stored as a
/// prefix count over q, so a range [a, b] is tested in two loads.
struct VisibleDensities {
    std::vector<std::uint32_t> prefix;  ///< 65537 entries: prefix[q] = visible intervals below q

    /// True when some density in [a / 65535, b / 65535] is visible (a <= b).
    [[nodiscard]] bool any(std::uint32_t a, std::uint32_t b) const {
        std::uint32_t last = b > a ? b - 1 : a;
        return prefix[last + 1] != prefix[a];
    }
};

/// What ess_occupancy produced.
struct EssOccupancy {
    volume::Occupancy occupancy;  ///< the occupancy to build the kd-tree on
    std::uint64_t occupied = 0;   ///< its occupied voxels
    double ms = 0.0;              ///< classification time (one table lookup per voxel)
};

namespace detail {

inline double kd_ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// Element-wise min of lo and max of hi over three neighbouring lines a, b, c (b the centre).
inline void range_combine(const std::uint16_t* alo, const std::uint16_t* blo, const std::uint16_t* clo,
                          const std::uint16_t* ahi, const std::uint16_t* bhi, const std::uint16_t* chi,
                          std::uint16_t* olo, std::uint16_t* ohi, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
        olo[i] = std::min(std::min(alo[i], blo[i]), clo[i]);
        ohi[i] = std::max(std::max(ahi[i], bhi[i]), chi[i]);
    }
}

/// One pass of the separable 3-wide min/max filter along y (stride = one row) or z (one slice):
/// `lines` lines of `n` entries, `count` of them along the axis; reads src, writes dst.
template <Executor X>
void range_pass(NeighbourhoodRanges& src, NeighbourhoodRanges& dst, std::size_t n, std::size_t count,
                std::size_t outer, X& exec) {
    exec.parallel_for(0, outer * count, 1, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t j = lo; j < hi; ++j) {
            std::size_t o = j / count, i = j % count;
            std::size_t a = i > 0 ? i - 1 : i, c = i + 1 < count ? i + 1 : i;
            std::size_t base = o * count * n;
            range_combine(&src.lo[base + a * n], &src.lo[base + i * n], &src.lo[base + c * n], &src.hi[base + a * n],
                          &src.hi[base + i * n], &src.hi[base + c * n], &dst.lo[base + i * n], &dst.hi[base + i * n], n);
        }
    });
}

/// Quantises the densities and applies the filter along x (per row).
template <Executor X>
void range_rows(const volume::DensityGrid& g, NeighbourhoodRanges& out, X& exec) {
    std::uint32_t nx = g.dims.x;
    std::size_t rows = std::size_t{g.dims.y} * g.dims.z;
    exec.parallel_for(0, rows, 64, [&](std::size_t r0, std::size_t r1) {
        std::vector<std::uint16_t> qlo(nx), qhi(nx);
        for (std::size_t r = r0; r < r1; ++r) {
            const float* v = &g.values[r * nx];
            for (std::uint32_t x = 0; x < nx; ++x) {
                float d = std::clamp(v[x], 0.0f, 1.0f) * 65535.0f;
                qlo[x] = static_cast<std::uint16_t>(std::floor(d));
                qhi[x] = static_cast<std::uint16_t>(std::ceil(d));
            }
            for (std::uint32_t x = 0; x < nx; ++x) {
                std::uint32_t a = x > 0 ? x - 1 : x, c = x + 1 < nx ? x + 1 : x;
                out.lo[r * nx + x] = std::min(std::min(qlo[a], qlo[x]), qlo[c]);
                out.hi[r * nx + x] = std::max(std::max(qhi[a], qhi[x]), qhi[c]);
            }
        }
    });
}

/// Visible-interval table from a per-interval predicate over [dlo, dhi] densities.
template <class Pred>
VisibleDensities visible_table(Pred&& visible) {
    constexpr float eps = 1.0f / 1048576.0f;  // 2^-20: above the rounding of three lerps
    VisibleDensities v;
    v.prefix.assign(65537, 0u);
    for (std::uint32_t q = 0; q < 65536; ++q) {
        float dlo = static_cast<float>(q) / 65535.0f - eps, dhi = static_cast<float>(q + 1) / 65535.0f + eps;
        v.prefix[q + 1] = v.prefix[q] + (visible(dlo, dhi) ? 1u : 0u);
    }
    return v;
}

}  // namespace detail

/// The neighbourhood density ranges of `g` (see NeighbourhoodRanges), in parallel. Throws
/// sylva::Error when the value count does not match the dimensions or a density is NaN.
template <Executor X>
NeighbourhoodRanges neighbourhood_ranges(const volume::DensityGrid& g, X& exec) {
    std::size_t n = volume::voxel_count(g.dims);
    if (g.values.size() != n || n == 0)
        throw Error("kd-dvr: the grid holds " + std::to_string(g.values.size()) + " values for " + std::to_string(n) +
                    " voxels");
    for (float v : g.values)
        if (std::isnan(v)) throw Error("kd-dvr: the grid holds a NaN density");
    NeighbourhoodRanges a{g.dims, g.spacing, std::vector<std::uint16_t>(n), std::vector<std::uint16_t>(n)};
    NeighbourhoodRanges b{g.dims, g.spacing, std::vector<std::uint16_t>(n), std::vector<std::uint16_t>(n)};
    detail::range_rows(g, a, exec);
    detail::range_pass(a, b, g.dims.x, g.dims.y, g.dims.z, exec);                         // along y
    detail::range_pass(b, a, std::size_t{g.dims.x} * g.dims.y, g.dims.z, 1, exec);      // along z
    return a;
}

/// Which density intervals the transfer function `tf` (packed RGBA8 words, the renderer's
/// table; sylva/shared/tf.h) can make visible: those that reach a table segment with an entry of
/// alpha > 0 at either end. Segments are found with the shader's own arithmetic
/// (x = clamp01(d) * (N - 1), floor), which is monotone in d.
inline VisibleDensities visible_densities(std::span<const std::uint32_t> tf) {
    if (tf.size() < 2) throw Error("kd-dvr: the transfer function needs at least 2 entries");
    std::uint32_t last = static_cast<std::uint32_t>(tf.size() - 1);
    std::vector<std::uint32_t> seg(tf.size() + 1, 0u);  // prefix count of visible segments
    for (std::uint32_t i = 0; i <= last; ++i) {
        bool vis = (tf[i] >> 24) != 0u || (tf[std::min(i + 1, last)] >> 24) != 0u;
        seg[i + 1] = seg[i] + (vis ? 1u : 0u);
    }
    auto segment = [last](float d) {
        float x = shared::sylva_tf_clamp01(d) * static_cast<float>(last);
        return std::min(static_cast<std::uint32_t>(x), last);
    };
    return detail::visible_table([&](float dlo, float dhi) { return seg[segment(dhi) + 1] != seg[segment(dlo)]; });
}

/// Density-threshold classification: intervals that reach `threshold` (as the BIH's
/// voxel elements, Kinkelin section 6.1). The image equals the marcher's only when the
/// transfer function is transparent below the threshold.
inline VisibleDensities visible_at_or_above(float threshold) {
    if (!std::isfinite(threshold)) throw Error("kd-dvr: the density threshold is not finite");
    return detail::visible_table([threshold](float, float dhi) { return dhi >= threshold; });
}

/// The kd-tree occupancy for empty-space-skipping DVR: voxels whose neighbourhood range is
/// visible under `vis` (see the top of this header), in parallel.
template <Executor X>
EssOccupancy ess_occupancy(const NeighbourhoodRanges& r, const VisibleDensities& vis, X& exec) {
    auto t0 = std::chrono::steady_clock::now();
    std::size_t n = r.lo.size();
    if (r.hi.size() != n || n != volume::voxel_count(r.dims) || vis.prefix.size() != 65537)
        throw Error("kd-dvr: neighbourhood ranges or visibility table of the wrong size");
    volume::Occupancy occ{r.dims, r.spacing, std::vector<std::uint8_t>(n)};
    exec.parallel_for(0, n, std::size_t{1} << 16, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i) occ.voxels[i] = vis.any(r.lo[i], r.hi[i]) ? 1u : 0u;
    });
    EssOccupancy out;
    out.occupied = occ.count();
    out.occupancy = std::move(occ);
    out.ms = detail::kd_ms_since(t0);
    return out;
}

/// The same for a transfer function's packed RGBA8 words.
template <Executor X>
EssOccupancy ess_occupancy(const NeighbourhoodRanges& r, std::span<const std::uint32_t> tf, X& exec) {
    return ess_occupancy(r, visible_densities(tf), exec);
}

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
    shared::Words pw{words.data(), words.size()}, kw{kd.data(), kd.size()}, gw{grid.words.data(), grid.words.size()},
        tw{p.tf.data(), p.tf.size()};
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
