// sylva/vulkan/kd_ess.hpp -- the first build of a binned ESS kd-tree with its occupancy on a
// Vulkan device (issue 15, item 5, for --backend vulkan): the block ranges' streaming pass on
// the host once per volume (sylva/render/ess_occupancy.hpp), per transfer function the blocks'
// verdicts on the host, the voxels of the blocks the verdicts leave open classified on the
// device from the marcher's own grid (shaders/kd_ess_boxes.comp, the shared code of
// sylva/shared/kd_ess_boxes.h), their row masks folded into block words and gathered along the
// Morton curve, then the node splitting on the host (Zellmann et al. section 4.3). The same
// tree as sylva::EssRebuilder over the same grid words, without segment codes.
//
//   auto ctx = sylva::vk::Context::create();
//   sylva::GridWords words = sylva::GridWords::native(volume);
//   sylva::vk::DeviceGrid grid(ctx, words);                      // the marcher's grid
//   sylva::vk::EssKdRebuilder ess(ctx, grid, words, sylva::kdtree::Config::deep().binned(), pool);
//   sylva::kdtree::Tree t = ess.rebuild(sylva::ess_classifier(tf_words));   // per TF
//
// The device reads only the listed blocks (the ones whose verdict is kBlockRead), in batches
// of at most EssBoxPassConfig::batch_blocks blocks; an invocation the device's loop limiter
// cut short (lavapipe, sylva/shared/loop_cut.glsl) flags its column of rows, and the host
// computes that column itself with the same shared code.
#ifndef SYLVA_VULKAN_KD_ESS_HPP
#define SYLVA_VULKAN_KD_ESS_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/kdtree/build_binned.hpp"
#include "sylva/kdtree/gpu_local_boxes.hpp"
#include "sylva/kdtree/rebuild.hpp"
#include "sylva/render/ess_occupancy.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/shared/kd_ess_boxes.h"
#include "sylva/spirv/kd_ess_boxes.h"
#include "sylva/vulkan/kd_build.hpp"
#include "sylva/vulkan/runner.hpp"
#include "sylva/vulkan/volume.hpp"

namespace sylva::vk {

/// The parameter block of the ESS pass (layout in sylva/shared/kd_ess_boxes.h) for grid words
/// of `dims` sampled as `s`, under a TF of `entries` entries. Throws sylva::Error for an entry
/// count outside 2 .. 2^24.
inline std::array<std::uint32_t, SYLVA_KD_ESS_PARAM_WORDS> kd_ess_params(volume::Dims dims, const GridSampling& s,
                                                                          std::uint32_t entries) {
    if (entries < 2u || entries > (1u << 24))
        throw Error("kd-ess: a transfer function of " + std::to_string(entries) + " entries (2 to 2^24)");
    s.border.check();
    constexpr float inf = std::numeric_limits<float>::infinity();
    bool clamp = s.border.mode == BorderMode::Clamp;
    constexpr float eps = sylva::detail::kEssEps;
    float lo = clamp ? inf : s.border.value - eps;
    float hi = clamp ? -inf : s.border.value + eps;
    auto bits = [](float f) { return std::bit_cast<std::uint32_t>(f); };
    return {dims.x, dims.y, dims.z, static_cast<std::uint32_t>(s.format), bits(s.value_lo), bits(s.value_span),
            bits(lo), bits(hi), entries};
}

/// The prefix count of a classifier's visible buckets: word b = visible buckets below b (257
/// words).
inline std::vector<std::uint32_t> kd_ess_visible_words(const EssClassifier& cls) {
    std::vector<std::uint32_t> w(kEssBuckets + 1, 0u);
    for (std::uint32_t b = 0; b < kEssBuckets; ++b) w[b + 1] = w[b] + cls.visible_in(b, b);
    return w;
}

/// The linear indices (x fastest) of the blocks whose verdict is kBlockRead, into `out`.
inline void kd_ess_listed(const std::vector<std::uint8_t>& verdicts, std::vector<std::uint32_t>& out) {
    out.clear();
    for (std::size_t i = 0; i < verdicts.size(); ++i)
        if (verdicts[i] == kdtree::kBlockRead) out.push_back(static_cast<std::uint32_t>(i));
}

/// Words per listed block of the device pass's output: 3 per column of rows (masks of rows 0-3,
/// 4-7, the loop limiter's flag), 8 columns.
inline constexpr std::size_t kEssBlockWords = 24;

/// The shared code of shaders/kd_ess_boxes.comp run on the host: the masks of column ly (rows
/// lz = 0 .. 7, a byte each, sylva_kd_ess_column) of block `block` (linear index) of grid words
/// `g` under params `pw` and visible words `vw`.
inline uvec2 reference_ess_column(const GridWords& g, std::span<const std::uint32_t> pw, std::span<const std::uint32_t> vw,
                                  std::uint32_t block, std::uint32_t ly) {
    shared::Words grid{g.words.data(), g.words.size()}, params{pw.data(), pw.size()}, visible{vw.data(), vw.size()};
    shared::SylvaKdEssParams p = shared::sylva_kd_ess_params(params);
    uvec3 nb = kdtree::block_counts(g.dims);
    uvec3 b(block % nb.x, (block / nb.x) % nb.y, block / (nb.x * nb.y));
    return shared::sylva_kd_ess_column(grid, visible, p, b, ly);
}

/// Dense block words (kdtree/gpu_local_boxes.hpp) from the verdicts and the output of the
/// listed blocks (kEssBlockWords a block, in listed order; the limiter's flags are ignored),
/// into `words` (resized, storage reused): decided blocks from their verdict, listed ones
/// folded row by row with the shared accumulator.
inline void kd_ess_fold(volume::Dims dims, const std::vector<std::uint8_t>& verdicts,
                        std::span<const std::uint32_t> listed, std::span<const std::uint32_t> out,
                        std::vector<std::uint32_t>& words) {
    uvec3 nb = kdtree::block_counts(dims);
    if (verdicts.size() != std::size_t{nb.x} * nb.y * nb.z || out.size() != listed.size() * kEssBlockWords)
        throw Error("kd-ess: " + std::to_string(verdicts.size()) + " verdicts, " + std::to_string(out.size()) +
                    " output words for " + std::to_string(listed.size()) + " listed blocks");
    words.resize(verdicts.size());
    for (std::size_t i = 0; i < verdicts.size(); ++i) {
        uvec3 b(static_cast<std::uint32_t>(i % nb.x), static_cast<std::uint32_t>((i / nb.x) % nb.y),
                static_cast<std::uint32_t>(i / (std::size_t{nb.x} * nb.y)));
        words[i] = verdicts[i] == kdtree::kBlockFull ? kdtree::full_block_word(dims, b) : 0u;
    }
    for (std::size_t k = 0; k < listed.size(); ++k) {
        shared::SylvaKdBoxAcc acc = shared::sylva_kd_box_acc_zero();
        for (std::uint32_t ly = 0; ly < 8u; ++ly)
            for (std::uint32_t lz = 0; lz < 8u; ++lz) {
                std::uint32_t w = out[k * kEssBlockWords + ly * 3u + (lz >> 2)];
                shared::sylva_kd_box_accumulate(acc, (w >> (8u * (lz & 3u))) & 255u, ly, lz);
            }
        words.at(listed[k]) = shared::sylva_kd_box_acc_word(acc, false);
    }
}

/// Settings of the device pass.
struct EssBoxPassConfig {
    /// Most blocks one dispatch reads (8 a workgroup); their output (96 bytes a block) comes
    /// back after each. Tests set it small to run several batches.
    std::uint32_t batch_blocks = 65535;
};

/// Where the time of one device pass went (milliseconds).
struct EssBoxPassTimings {
    double upload_ms = 0.0;    ///< parameters, visible buckets and listed blocks to the device
    double device_ms = 0.0;    ///< the dispatches on the device (timestamp queries), summed
    double dispatch_ms = 0.0;  ///< the dispatches on the host clock (record, submit, wait)
    double readback_ms = 0.0;  ///< the columns' masks back to the host
    double fold_ms = 0.0;      ///< masks into block words (and columns the loop limiter cut, on the host)
    std::size_t cut_columns = 0;  ///< columns of 8 rows the device's loop limiter cut short (computed on the host)
    [[nodiscard]] double total_ms() const { return upload_ms + dispatch_ms + readback_ms + fold_ms; }
};

/// The ESS occupancy's block words of the listed blocks on the device, from a DeviceGrid and
/// the grid words it was made from (kept by reference: they must outlive the pass; the host
/// reads their words only for columns the loop limiter cut, and their border at every pass:
/// the border is a parameter, not part of the device grid). The Context and DeviceGrid must
/// outlive it.
class EssBoxPass {
public:
    /// Throws sylva::Error when the device grid does not hold `g` (dimensions, format).
    EssBoxPass(Context& ctx, DeviceGrid& dgrid, const GridWords& g, EssBoxPassConfig cfg = {})
        : ctx_(&ctx), dgrid_(&dgrid), grid_(&g), cfg_(cfg), params_buf_(ctx, SYLVA_KD_ESS_PARAM_WORDS * 4),
          visible_(ctx, (kEssBuckets + 1) * 4) {
        g.check_words("kd-ess");
        if (dgrid.dims() != g.dims || dgrid.sampling().format != g.sampling.format)
            throw Error("kd-ess: the device grid does not hold these grid words (dimensions or format differ)");
        if (cfg.batch_blocks == 0 || cfg.batch_blocks > 65535)
            throw Error("kd-ess: batch_blocks must be 1 .. 65535, got " + std::to_string(cfg.batch_blocks));
    }

    /// The block words under `cls` (dense, x fastest) into `words`: blocks `verdicts` decides
    /// (sylva::ess_block_verdicts) from the verdicts, the others read on the device. Equal to
    /// sylva::ess_block_words over the grid words.
    void block_words(const EssClassifier& cls, const std::vector<std::uint8_t>& verdicts, std::vector<std::uint32_t>& words) {
        uvec3 nb = kdtree::block_counts(grid_->dims);
        if (verdicts.size() != std::size_t{nb.x} * nb.y * nb.z)
            throw Error("kd-ess: " + std::to_string(verdicts.size()) + " block verdicts for a grid of " +
                        std::to_string(std::size_t{nb.x} * nb.y * nb.z) + " blocks");
        timings_ = EssBoxPassTimings{};
        auto t0 = std::chrono::steady_clock::now();
        params_ = kd_ess_params(grid_->dims, grid_->sampling, cls.entries());
        params_buf_.upload(params_);
        std::vector<std::uint32_t> visible = kd_ess_visible_words(cls);
        visible_.upload(visible);
        kd_ess_listed(verdicts, listed_);
        masks_.resize(listed_.size() * kEssBlockWords);
        timings_.upload_ms = kdtree::detail::ms_since(t0);
        for (std::size_t first = 0; first < listed_.size(); first += cfg_.batch_blocks)
            run_batch(first, std::min<std::size_t>(cfg_.batch_blocks, listed_.size() - first));
        t0 = std::chrono::steady_clock::now();
        for (std::size_t c = 0; c < masks_.size(); c += 3)
            if (masks_[c + 2] != 0u) {  // a column the loop limiter cut: computed here
                uvec2 m = reference_ess_column(*grid_, params_, visible, listed_[c / kEssBlockWords],
                                               static_cast<std::uint32_t>((c % kEssBlockWords) / 3));
                masks_[c] = m.x, masks_[c + 1] = m.y, masks_[c + 2] = 0u;
                ++timings_.cut_columns;
            }
        kd_ess_fold(grid_->dims, verdicts, listed_, masks_, words);
        timings_.fold_ms = kdtree::detail::ms_since(t0);
    }

    [[nodiscard]] const EssBoxPassTimings& timings() const { return timings_; }

private:
    /// The push constants of shaders/kd_ess_boxes.comp.
    struct Push {
        std::uint32_t first, listed;
    };

    void run_batch(std::size_t first, std::size_t count) {
        auto t0 = std::chrono::steady_clock::now();
        if (!listed_buf_ || listed_buf_->size_bytes() < count * 4) listed_buf_.emplace(*ctx_, count * 4);
        if (!masks_buf_ || masks_buf_->size_bytes() < count * kEssBlockWords * 4)
            masks_buf_.emplace(*ctx_, count * kEssBlockWords * 4);
        listed_buf_->upload(std::span<const std::uint32_t>(listed_).subspan(first, count));
        timings_.upload_ms += kdtree::detail::ms_since(t0);
        t0 = std::chrono::steady_clock::now();
        if (!kernel_) {
            auto c = dgrid_->constants();  // split shift, parts, format (not the border: a parameter)
            kernel_.emplace(*ctx_, spirv::kd_ess_boxes, 8, sizeof(Push), std::array<std::uint32_t, 3>{c[0], c[1], c[2]});
        }
        Push push{0u, static_cast<std::uint32_t>(count)};
        std::array<Buffer*, 8> bind{dgrid_->part(0), dgrid_->part(1), dgrid_->part(2), dgrid_->part(3),
                                    &params_buf_,    &visible_,       &*listed_buf_,   &*masks_buf_};
        timings_.device_ms += ctx_->dispatch(*kernel_, bind, &push, sizeof push, groups_for(count * 8u, 64));
        timings_.dispatch_ms += kdtree::detail::ms_since(t0);
        t0 = std::chrono::steady_clock::now();
        masks_buf_->download(std::span<std::uint32_t>(masks_).subspan(first * kEssBlockWords, count * kEssBlockWords));
        timings_.readback_ms += kdtree::detail::ms_since(t0);
    }

    Context* ctx_;
    DeviceGrid* dgrid_;
    const GridWords* grid_;
    EssBoxPassConfig cfg_;
    std::array<std::uint32_t, SYLVA_KD_ESS_PARAM_WORDS> params_{};
    Buffer params_buf_, visible_;
    std::optional<Buffer> listed_buf_, masks_buf_;
    std::optional<Kernel> kernel_;
    std::vector<std::uint32_t> listed_, masks_;
    EssBoxPassTimings timings_;
};

/// sylva::EssRebuilder for binned trees with the occupancy's undecided blocks read on the
/// device (see the top of this header): the same trees, no segment codes. The Context, the
/// DeviceGrid, the grid words and the executor must outlive it.
template <Executor X>
class EssKdRebuilder {
public:
    /// Throws sylva::Error for a config that is not binned or is invalid, or as EssBoxPass does.
    EssKdRebuilder(Context& ctx, DeviceGrid& dgrid, const GridWords& g, const kdtree::Config& cfg, X& exec,
                   EssBoxPassConfig pass_cfg = {})
        : pass_(ctx, dgrid, g, pass_cfg), grid_(&g), exec_(&exec) {
        set_config(cfg);
    }

    /// The tree under the transfer function `tf` (packed RGBA8 words, as rendered).
    kdtree::Tree rebuild(std::span<const std::uint32_t> tf) { return rebuild(ess_classifier(tf)); }
    /// The tree under any EssClassifier; the first call also runs the block ranges' pass.
    kdtree::Tree rebuild(const EssClassifier& cls) {
        ranges_ms_ = 0.0;
        if (!ranges_) {
            auto t0 = std::chrono::steady_clock::now();
            ranges_.emplace(ess_block_ranges(*grid_, *exec_));
            order_ = kdtree::BlockOrder::of(grid_->dims);
            ranges_ms_ = kdtree::detail::ms_since(t0);
        }
        timings_ = kdtree::RebuildTimings{};
        auto t0 = std::chrono::steady_clock::now();
        ess_block_verdicts(*ranges_, cls, grid_->sampling.border, verdicts_);
        timings_.blocks_read = static_cast<std::size_t>(std::count(verdicts_.begin(), verdicts_.end(), kdtree::kBlockRead));
        timings_.classify_ms = kdtree::detail::ms_since(t0);
        t0 = std::chrono::steady_clock::now();
        pass_.block_words(cls, verdicts_, words_);
        kdtree::gather_local_boxes(words_, order_, grid_->spacing, boxes_);
        timings_.occupancy_ms = kdtree::detail::ms_since(t0);
        kdtree::Tree t = kdtree::build(boxes_, cfg_, *exec_);
        timings_.split_ms = t.stats.split_ms;
        t.stats.occupancy_ms = ranges_ms_ + timings_.classify_ms + timings_.occupancy_ms;
        return t;
    }

    /// Throws sylva::Error unless `cfg` is a valid binned config.
    void set_config(const kdtree::Config& cfg) {
        detail::check_device_binned(cfg, "vk::EssKdRebuilder");
        cfg_ = cfg;
    }
    [[nodiscard]] const kdtree::Config& config() const { return cfg_; }
    /// Phases of the last rebuild (classify_ms: block verdicts; occupancy_ms: the device pass,
    /// folding and the Morton gather; split_ms; blocks_read).
    [[nodiscard]] const kdtree::RebuildTimings& timings() const { return timings_; }
    /// The device pass of the last rebuild, phase by phase.
    [[nodiscard]] const EssBoxPassTimings& pass_timings() const { return pass_.timings(); }
    /// Time the last rebuild spent on the block ranges' streaming pass (0 but for the first).
    [[nodiscard]] double ranges_ms() const { return ranges_ms_; }
    /// The block ranges (null before the first rebuild).
    [[nodiscard]] const EssBlockRanges* block_ranges() const { return ranges_ ? &*ranges_ : nullptr; }
    [[nodiscard]] const kdtree::LocalBoxes& local_boxes() const { return boxes_; }
    /// The block words of the last rebuild (dense, x fastest).
    [[nodiscard]] const std::vector<std::uint32_t>& block_words() const { return words_; }

private:
    EssBoxPass pass_;
    const GridWords* grid_;
    X* exec_;
    kdtree::Config cfg_;
    std::optional<EssBlockRanges> ranges_;
    kdtree::BlockOrder order_;
    std::vector<std::uint8_t> verdicts_;
    std::vector<std::uint32_t> words_;
    kdtree::LocalBoxes boxes_;
    kdtree::RebuildTimings timings_;
    double ranges_ms_ = 0.0;
};

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_KD_ESS_HPP
