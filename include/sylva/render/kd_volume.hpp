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
// The occupancy, and the two ways of computing it, are in sylva/render/ess_occupancy.hpp.
// EssRebuilder builds binned trees (Config::binned(), Zellmann section 4.3) from block ranges:
// one streaming pass over the densities once per volume, then per TF the 8^3 blocks' verdicts
// and a voxel-by-voxel read of the undecided blocks only. Other trees (partial SVTs, Vidal's
// planes) are built by kdtree::Rebuilder over segment codes, computed again only when the TF's
// entry count changes. Both give the tree of the same occupancy.
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
#include "sylva/kdtree/build_binned.hpp"
#include "sylva/kdtree/gpu_local_boxes.hpp"
#include "sylva/kdtree/rebuild.hpp"
#include "sylva/render/ess_occupancy.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/shared/kd_dvr.h"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"

namespace sylva {

/// Rebuilds the ESS kd-tree of one density grid when the transfer function changes (see the
/// top of this header): binned configs from block ranges (computed once, at the first
/// rebuild), others through kdtree::Rebuilder over segment codes (recomputed only when the TF's
/// entry count changes). The grid and the executor must outlive it. The tree is exact for a
/// marcher whose grid has the same border (GridWords::from's default, constant 0, for a
/// DensityGrid).
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
        ranges_ms_ = 0.0;
        if (cfg_.planes == kdtree::Planes::Binned) return rebuild_from_blocks(cls);
        prepare_codes(cls.entries());
        kdtree::Tree t = rebuilder_->rebuild(cls);
        timings_ = rebuilder_->timings();
        return t;
    }
    /// The segment codes the last non-binned tree was built on (null before one).
    [[nodiscard]] const EssCodes* codes() const { return codes_.get(); }
    /// The block ranges binned trees are built from (null before the first binned rebuild).
    [[nodiscard]] const EssBlockRanges* block_ranges() const { return ranges_ ? &*ranges_ : nullptr; }
    /// Phases of the last rebuild (classify_ms: block verdicts, or the codes' 65536-entry table;
    /// occupancy_ms: the undecided blocks' voxels and the local boxes, or partial SVTs;
    /// split_ms; blocks_read).
    [[nodiscard]] const kdtree::RebuildTimings& timings() const { return timings_; }
    /// Time the last rebuild spent computing segment codes (0 unless a non-binned rebuild met a
    /// new TF entry count).
    [[nodiscard]] double codes_ms() const { return codes_ms_; }
    /// Time the last rebuild spent on the block ranges' streaming pass (0 but for the first
    /// binned rebuild).
    [[nodiscard]] double ranges_ms() const { return ranges_ms_; }
    /// The whole of the last rebuild: codes or ranges, verdicts, occupancy and splitting.
    [[nodiscard]] double total_ms() const { return codes_ms_ + ranges_ms_ + timings_.total_ms(); }
    void set_config(const kdtree::Config& cfg) {
        kdtree::detail::check_config(cfg);
        cfg_ = cfg;
        if (rebuilder_) rebuilder_->set_config(cfg);
    }

private:
    void prepare_codes(std::uint32_t entries) {
        if (codes_ && codes_->entries == entries) {
            if (!rebuilder_) rebuilder_.emplace(codes_->volume, cfg_, *exec_);
            return;
        }
        rebuilder_.reset();
        codes_ = std::make_unique<EssCodes>(grid_ != nullptr ? ess_codes(*grid_, entries, *exec_, border_)
                                                             : ess_codes(*words_, entries, *exec_));
        codes_ms_ = codes_->ms;
        rebuilder_.emplace(codes_->volume, cfg_, *exec_);
    }

    kdtree::Tree rebuild_from_blocks(const EssClassifier& cls) {
        if (!ranges_) {
            ranges_.emplace(grid_ != nullptr ? ess_block_ranges(*grid_, *exec_) : ess_block_ranges(*words_, *exec_));
            ranges_ms_ = ranges_->ms;
            auto t0 = std::chrono::steady_clock::now();
            order_ = kdtree::BlockOrder::of(ranges_->dims);
            ranges_ms_ += detail::ess_ms_since(t0);
        }
        timings_ = kdtree::RebuildTimings{};
        auto t0 = std::chrono::steady_clock::now();
        ess_block_verdicts(*ranges_, cls, border_, verdicts_);
        timings_.blocks_read =
            static_cast<std::size_t>(std::count(verdicts_.begin(), verdicts_.end(), kdtree::kBlockRead));
        timings_.classify_ms = detail::ess_ms_since(t0);
        auto t1 = std::chrono::steady_clock::now();
        if (grid_ != nullptr) ess_block_words(*grid_, cls, border_, verdicts_, *exec_, block_words_);
        else ess_block_words(*words_, cls, verdicts_, *exec_, block_words_);
        kdtree::gather_local_boxes(block_words_, order_, grid_ != nullptr ? grid_->spacing : words_->spacing, boxes_);
        timings_.occupancy_ms = detail::ess_ms_since(t1);
        kdtree::Tree t = kdtree::build(boxes_, cfg_, *exec_);
        timings_.split_ms = t.stats.split_ms;
        t.stats.occupancy_ms = ranges_ms_ + timings_.classify_ms + timings_.occupancy_ms;
        return t;
    }

    const volume::DensityGrid* grid_ = nullptr;
    const GridWords* words_ = nullptr;
    X* exec_;
    kdtree::Config cfg_;
    GridBorder border_;
    std::unique_ptr<EssCodes> codes_;
    std::optional<kdtree::Rebuilder<X>> rebuilder_;
    std::optional<EssBlockRanges> ranges_;
    kdtree::BlockOrder order_;
    std::vector<std::uint8_t> verdicts_;
    std::vector<std::uint32_t> block_words_;
    kdtree::LocalBoxes boxes_;
    kdtree::RebuildTimings timings_;
    double codes_ms_ = 0.0, ranges_ms_ = 0.0;
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
