// sylva/vulkan/kd_build.hpp -- the GPU construction pass of Zellmann et al.'s binned kd-tree
// builder (section 4.3) on a Vulkan device: the 8^3 local boxes of a classified volume computed
// by shaders/kd_local_boxes.comp (the shared code of sylva/shared/kd_local_boxes.h), read back
// and gathered along the Morton curve into kdtree::LocalBoxes; the node splitting then runs on
// the host (kdtree/build_binned.hpp), as the paper's recursion does on the CPU.
//
//   auto ctx = sylva::vk::Context::create();
//   sylva::vk::LocalBoxPass pass(ctx, volume);                    // voxels uploaded once
//   sylva::kdtree::LocalBoxes boxes = pass.local_boxes(sylva::volume::TransferFunctionAlpha(tf));
//   sylva::kdtree::Tree t = sylva::kdtree::build(boxes, sylva::kdtree::Config::deep().binned(), pool);
//
//   sylva::vk::KdRebuilder r(ctx, volume, sylva::kdtree::Config::deep().binned(), pool);
//   sylva::kdtree::Tree t2 = r.rebuild(tf);                        // as kdtree::Rebuilder
//
// The voxels are copied to the device at construction, in slabs of whole 8-voxel block
// layers that each fit one storage-buffer binding (lavapipe: 128 MiB), so any volume whose
// single block layer fits works; each pass re-uploads only the classification (a per-value
// bit table for integer voxels, the threshold or the transfer function's alpha entries for
// float voxels) and dispatches once per slab. vk::KdRebuilder also sends every block's verdict
// (kdtree::block_verdicts: what the block's value range decides), so the device reads only the
// blocks their ranges leave open.
#ifndef SYLVA_VULKAN_KD_BUILD_HPP
#define SYLVA_VULKAN_KD_BUILD_HPP

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/kdtree/build_binned.hpp"
#include "sylva/kdtree/gpu_local_boxes.hpp"
#include "sylva/kdtree/rebuild.hpp"
#include "sylva/spirv/kd_local_boxes.h"
#include "sylva/vulkan/runner.hpp"

namespace sylva::vk {

/// Settings of the device local-box pass.
struct LocalBoxPassConfig {
    /// Most bytes of voxels one dispatch reads (one slab, whole 8-voxel block layers); 0 = the
    /// device's maxStorageBufferRange (lavapipe: 128 MiB). Tests set it small to run several
    /// slabs.
    std::size_t max_slab_bytes = 0;
};

/// Where the time of one device pass went (milliseconds).
struct LocalBoxPassTimings {
    double upload_ms = 0.0;    ///< classification table and parameters to the device
    double device_ms = 0.0;    ///< the dispatches on the device (timestamp queries), summed
    double dispatch_ms = 0.0;  ///< the dispatches on the host clock (record, submit, wait)
    double readback_ms = 0.0;  ///< block words back to the host
    double gather_ms = 0.0;    ///< the Morton gather into LocalBoxes (0 for block_words)
    /// Host wall time of the whole pass.
    [[nodiscard]] double total_ms() const { return upload_ms + dispatch_ms + readback_ms + gather_ms; }
};

namespace detail {

inline double kd_ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// Throws sylva::Error naming `who` unless `cfg` is a valid binned config (the device passes
/// give local boxes, which only the binned builder takes).
inline void check_device_binned(const kdtree::Config& cfg, const char* who) {
    if (cfg.planes != kdtree::Planes::Binned)
        throw Error(std::string(who) + ": the device pass builds binned trees only (use Config::binned())");
    if (cfg.raster == 0 || cfg.raster % kdtree::LocalBoxes::block != 0)
        throw Error("kdtree: the binned builder's raster must be a multiple of the 8-voxel block");
    kdtree::detail::check_config(cfg);
}

}  // namespace detail

/// A volume's voxels on the device and the kernel that computes their local boxes.
/// The Context must outlive the pass; the volume need not (its voxels are copied).
class LocalBoxPass {
public:
    /// Uploads the voxels of `s` in slabs. Throws sylva::Error when one block layer does not fit
    /// a slab, or the block words do not fit one binding.
    LocalBoxPass(Context& ctx, const kdtree::BoxSource& s, LocalBoxPassConfig cfg = {})
        : ctx_(&ctx),
          source_(s),
          layers_(kdtree::slab_layers(s, cfg.max_slab_bytes ? std::min(cfg.max_slab_bytes, ctx.max_storage_buffer_range())
                                                            : ctx.max_storage_buffer_range())),
          blocks_(kdtree::block_counts(s.dims)),
          out_(ctx, checked_block_bytes(ctx, blocks_)),
          params_(ctx, SYLVA_KD_BOX_PARAM_WORDS * 4),
          verdicts_(ctx, std::size_t{blocks_.x} * blocks_.y * blocks_.z) {
        for (std::uint32_t bz0 = 0; bz0 < blocks_.z; bz0 += layers_) {
            std::size_t z0 = std::size_t{bz0} * 8u, z1 = std::min<std::size_t>(s.dims.z, (std::size_t{bz0} + layers_) * 8u);
            slabs_.emplace_back(ctx, (z1 - z0) * s.slice_bytes());
            slabs_.back().upload_bytes(s.bytes.subspan(z0 * s.slice_bytes(), (z1 - z0) * s.slice_bytes()));
        }
        source_.bytes = {};  // not read after this point
    }
    /// Any volume, density grid or occupancy (kdtree::BoxSource::of).
    template <class V>
        requires requires(const V& v) { kdtree::BoxSource::of(v); }
    LocalBoxPass(Context& ctx, const V& v, LocalBoxPassConfig cfg = {}) : LocalBoxPass(ctx, kdtree::BoxSource::of(v), cfg) {}

    /// The dense block words (layout in sylva/shared/kd_local_boxes.h) under `c`, into `out`.
    /// `verdicts` (kdtree::block_verdicts of the same classification, one byte a block) let the
    /// device skip the blocks their value ranges decide; empty reads every block.
    void block_words(const kdtree::BoxClassifier& c, std::vector<std::uint32_t>& out,
                     std::span<const std::uint8_t> verdicts = {}) {
        timings_ = LocalBoxPassTimings{};
        auto t0 = std::chrono::steady_clock::now();
        upload_classifier(c);
        upload_verdicts(verdicts);
        timings_.upload_ms = detail::kd_ms_since(t0);
        t0 = std::chrono::steady_clock::now();
        Kernel& k = kernel(c.classify);
        for (std::size_t i = 0; i < slabs_.size(); ++i) timings_.device_ms += dispatch_slab(k, i);
        timings_.dispatch_ms = detail::kd_ms_since(t0);
        t0 = std::chrono::steady_clock::now();
        out.resize(std::size_t{blocks_.x} * blocks_.y * blocks_.z);
        out_.download(out);
        timings_.readback_ms = detail::kd_ms_since(t0);
    }
    /// The same for any classifier (kdtree::assign_box_classifier says which run on the device).
    template <volume::VoxelClassifier C>
    void block_words(const C& classify, std::vector<std::uint32_t>& out) {
        kdtree::assign_box_classifier(source_, classify, classifier_);
        block_words(classifier_, out);
    }

    /// The Morton-sorted local boxes under `c`, into `out` (storage reused): the LocalBoxes
    /// kdtree::local_boxes computes on the host. The Morton order is computed on first use.
    void local_boxes(const kdtree::BoxClassifier& c, kdtree::LocalBoxes& out, std::span<const std::uint8_t> verdicts = {}) {
        block_words(c, words_, verdicts);
        auto t0 = std::chrono::steady_clock::now();
        if (order_.size() == 0) order_ = kdtree::BlockOrder::of(source_.dims);
        kdtree::gather_local_boxes(words_, order_, source_.spacing, out);
        timings_.gather_ms = detail::kd_ms_since(t0);
    }
    template <volume::VoxelClassifier C>
    void local_boxes(const C& classify, kdtree::LocalBoxes& out) {
        kdtree::assign_box_classifier(source_, classify, classifier_);
        local_boxes(classifier_, out);
    }
    template <volume::VoxelClassifier C>
    [[nodiscard]] kdtree::LocalBoxes local_boxes(const C& classify) {
        kdtree::LocalBoxes out;
        local_boxes(classify, out);
        return out;
    }

    /// Phases of the last pass.
    [[nodiscard]] const LocalBoxPassTimings& timings() const { return timings_; }
    /// The source's description (its bytes are no longer referenced).
    [[nodiscard]] const kdtree::BoxSource& source() const { return source_; }
    /// Number of slabs (dispatches a pass).
    [[nodiscard]] std::size_t slab_count() const { return slabs_.size(); }

private:
    static std::size_t checked_block_bytes(const Context& ctx, uvec3 blocks) {
        std::size_t bytes = std::size_t{blocks.x} * blocks.y * blocks.z * 4u;
        if (bytes > ctx.max_storage_buffer_range())
            throw Error("vk::LocalBoxPass: " + std::to_string(bytes / 4) + " block words exceed one storage binding");
        return bytes;
    }

    void upload_classifier(const kdtree::BoxClassifier& c) {
        auto params = kdtree::box_params(source_, c);
        params_.upload(params);
        if (c.classify == SYLVA_KD_BOX_CLASSIFY_ALPHA && c.alphas.size() < 2)
            throw Error("vk::LocalBoxPass: a transfer function needs at least 2 alpha entries");
        upload_words(lut_, c.lut);
        upload_words(alphas_, c.alphas);
    }
    /// Uploads the verdicts, or zeros (read every block) once when none are given.
    void upload_verdicts(std::span<const std::uint8_t> verdicts) {
        std::size_t blocks = std::size_t{blocks_.x} * blocks_.y * blocks_.z;
        if (!verdicts.empty() && verdicts.size() != blocks)
            throw Error("vk::LocalBoxPass: " + std::to_string(verdicts.size()) + " verdicts for " + std::to_string(blocks) +
                        " blocks");
        if (verdicts.empty()) {
            if (verdicts_set_) verdicts_.fill(0u);
            verdicts_set_ = false;
            return;
        }
        verdicts_.upload_bytes(std::as_bytes(verdicts));
        verdicts_set_ = true;
    }
    /// Keeps a buffer at least as large as `words` (reallocated only to grow) and uploads them.
    void upload_words(std::optional<Buffer>& b, const std::vector<std::uint32_t>& words) {
        if (!b || b->size_bytes() < words.size() * 4) b.emplace(*ctx_, words.size() * 4);
        if (!words.empty()) b->upload(words);
    }

    /// The kernel specialised for this source and classification, built on first use and kept
    /// (lavapipe compiles a pipeline on its first dispatch).
    Kernel& kernel(std::uint32_t classify) {
        if (classify > SYLVA_KD_BOX_CLASSIFY_ALPHA) throw Error("vk::LocalBoxPass: unknown classification");
        std::optional<Kernel>& k = kernels_[classify];
        std::array<std::uint32_t, 2> constants{source_.source, classify};
        if (!k) k.emplace(*ctx_, spirv::kd_local_boxes, 6, 3 * 4, constants);
        return *k;
    }

    double dispatch_slab(Kernel& kernel, std::size_t i) {
        std::uint32_t first = static_cast<std::uint32_t>(i) * layers_;
        std::uint32_t layers = std::min(layers_, blocks_.z - first);
        struct Push {
            std::uint32_t slab_z0, first_layer, layers;
        } push{first * 8u, first, layers};
        std::array<Buffer*, 6> bind{&slabs_[i], &*lut_, &*alphas_, &params_, &out_, &verdicts_};
        return ctx_->dispatch(kernel, bind, &push, sizeof push,
                              groups_for(std::size_t{blocks_.x} * blocks_.y * layers, 64));
    }

    Context* ctx_;
    kdtree::BoxSource source_;
    std::uint32_t layers_;
    uvec3 blocks_;
    std::vector<Buffer> slabs_;
    Buffer out_;
    Buffer params_;
    Buffer verdicts_;
    bool verdicts_set_ = false;
    std::optional<Buffer> lut_, alphas_;
    std::array<std::optional<Kernel>, 3> kernels_;
    kdtree::BoxClassifier classifier_;
    kdtree::BlockOrder order_;
    std::vector<std::uint32_t> words_;
    LocalBoxPassTimings timings_;
};

/// One binned build with the local-box pass on the device: `pass`'s boxes under `classify`,
/// then the node splitting on the host (stats.occupancy_ms is the device pass's wall time).
/// The same tree as kdtree::build_binned(volume::classified(v, classify), cfg, exec).
template <volume::VoxelClassifier C, Executor X>
kdtree::Tree build_binned(LocalBoxPass& pass, const C& classify, const kdtree::Config& cfg, X& exec) {
    kdtree::LocalBoxes boxes = pass.local_boxes(classify);
    kdtree::Tree t = kdtree::build(boxes, cfg, exec);
    t.stats.occupancy_ms = pass.timings().total_ms();
    return t;
}

/// kdtree::Rebuilder with the local-box pass on the device: binned trees only (the pass gives
/// local boxes; Config::planes must be Planes::Binned). Same trees as kdtree::Rebuilder and the
/// fresh binned build. The Context and executor must outlive it; the volume need not.
template <Executor X>
class KdRebuilder {
public:
    /// A volume of any scalar type (voxels copied to the device); throws sylva::Error for a
    /// config that is not binned or is invalid, or as LocalBoxPass does.
    KdRebuilder(Context& ctx, const volume::Volume& v, const kdtree::Config& cfg, X& exec, LocalBoxPassConfig pass_cfg = {})
        : pass_(ctx, kdtree::BoxSource::of(v), pass_cfg), exec_(&exec) {
        set_config(cfg);
        prepare(kdtree::BoxSource::of(v));
    }
    /// A normalised density grid (classified as it is).
    KdRebuilder(Context& ctx, const volume::DensityGrid& g, const kdtree::Config& cfg, X& exec,
                LocalBoxPassConfig pass_cfg = {})
        : pass_(ctx, kdtree::BoxSource::of(g), pass_cfg), exec_(&exec) {
        set_config(cfg);
        prepare(kdtree::BoxSource::of(g));
    }

    /// The tree under `tf`: voxels whose alpha exceeds `min_alpha`.
    kdtree::Tree rebuild(const volume::TransferFunction& tf, float min_alpha = 0.0f) {
        return rebuild(volume::TransferFunctionAlpha(tf, min_alpha));
    }
    /// The tree under any classifier the device pass takes (kdtree::assign_box_classifier).
    template <volume::VoxelClassifier C>
    kdtree::Tree rebuild(const C& classify) {
        timings_ = kdtree::RebuildTimings{};
        auto t0 = std::chrono::steady_clock::now();
        kdtree::assign_box_classifier(pass_.source(), classify, classifier_);
        kdtree::block_verdicts(pass_.source(), values_, classify, classifier_.table, scratch_, verdicts_);
        timings_.blocks_read = static_cast<std::size_t>(std::count(verdicts_.begin(), verdicts_.end(), kdtree::kBlockRead));
        timings_.classify_ms = detail::kd_ms_since(t0);
        pass_.local_boxes(classifier_, boxes_, verdicts_);
        timings_.occupancy_ms = pass_.timings().total_ms();
        kdtree::Tree t = kdtree::build(boxes_, cfg_, *exec_);
        timings_.split_ms = t.stats.split_ms;
        t.stats.occupancy_ms = timings_.classify_ms + timings_.occupancy_ms;
        return t;
    }

    /// Throws sylva::Error unless `cfg` is a valid binned config.
    void set_config(const kdtree::Config& cfg) {
        detail::check_device_binned(cfg, "vk::KdRebuilder");
        cfg_ = cfg;
    }
    [[nodiscard]] const kdtree::Config& config() const { return cfg_; }
    [[nodiscard]] const kdtree::RebuildTimings& timings() const { return timings_; }
    /// The device pass of the last rebuild, phase by phase.
    [[nodiscard]] const LocalBoxPassTimings& pass_timings() const { return pass_.timings(); }
    [[nodiscard]] const kdtree::LocalBoxes& local_boxes() const { return boxes_; }
    /// The classification-independent preparation (block value ranges), milliseconds.
    [[nodiscard]] double prepare_ms() const { return prepare_ms_; }

private:
    void prepare(const kdtree::BoxSource& s) {
        auto t0 = std::chrono::steady_clock::now();
        kdtree::block_values(s, *exec_, values_);
        prepare_ms_ = detail::kd_ms_since(t0);
    }

    LocalBoxPass pass_;
    X* exec_;
    kdtree::Config cfg_;
    kdtree::RebuildTimings timings_;
    kdtree::BoxClassifier classifier_;
    kdtree::LocalBoxes boxes_;
    kdtree::BlockValues values_;
    double prepare_ms_ = 0.0;
    std::vector<std::uint32_t> scratch_;
    std::vector<std::uint8_t> verdicts_;
};

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_KD_BUILD_HPP
