// sylva-render, volume input with a kd-tree index (--index kd-vidal|kd-binned): the reference
// marcher with empty-space skipping (sylva/shared/kd_dvr.h), on the host or through Vulkan.
// The occupancy comes from the TF's alpha over each voxel's 3x3x3 neighbourhood (or from
// --threshold), the tree from kdtree::Rebuilder (vk::KdRebuilder's device local boxes for
// kd-binned on Vulkan), so --tf-sequence shows rebuilds after transfer-function changes.
// Header only: volume_scene.cpp, the one includer, dispatches here.
#ifndef SYLVA_RENDER_KD_SCENE_HPP
#define SYLVA_RENDER_KD_SCENE_HPP

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/kdtree/rebuild.hpp>
#include <sylva/kdtree/subvolumes.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/classify.hpp>
#include <sylva/volume/grid.hpp>
#include <sylva/volume/occupancy.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/kd_ess.hpp>
#include <sylva/vulkan/kd_volume.hpp>
#endif

#include "boxes.hpp"
#include "options.hpp"
#include "stats.hpp"
#include "volume_scene.hpp"

namespace sylva_render {
namespace kd_detail {

using namespace sylva;

inline double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

inline kdtree::Config kd_config(const Options& o) {
    kdtree::Config c = o.kd == "shallow" ? kdtree::Config::shallow() : kdtree::Config::deep();
    return o.index == "kd-binned" ? c.binned() : c;
}

/// The occupancy classifier: the TF's visible segments, or densities >= --threshold.
inline EssClassifier classifier(const Options& o, const std::vector<std::uint32_t>& tf) {
    if (o.kd_classify == "threshold") return ess_threshold_classifier(o.threshold, static_cast<std::uint32_t>(tf.size()));
    return ess_classifier(tf);
}

/// "out.png" -> "out_tf2.png": where the k-th image of --tf-sequence goes.
inline std::string numbered(const std::string& path, std::size_t k) {
    std::filesystem::path p(path);
    return (p.parent_path() / (p.stem().string() + "_tf" + std::to_string(k) + p.extension().string())).string();
}

/// The device state of a Vulkan run: context, grid, and the device occupancy pass of kd-binned.
struct Device {
#ifdef SYLVA_RENDER_VULKAN
    std::optional<vk::Context> ctx;
    std::optional<vk::DeviceGrid> grid;
    std::optional<vk::EssKdRebuilder<ThreadPool>> rebuilder;
#endif
};

/// Rebuilds the ESS tree under changing transfer functions: on the host EssRebuilder (kd-binned
/// from block ranges, kd-vidal over segment codes); for kd-binned on Vulkan vk::EssKdRebuilder
/// (block ranges and verdicts on the host, the undecided blocks' voxels on the device from the
/// marcher's grid, the splitting on the host: the same tree, no segment codes).
class KdBuilder {
public:
    KdBuilder(const Options& o, const volume::DensityGrid& g, const GridWords& gw, ThreadPool& pool, Device& dev)
        : o_(o), grid_(g), words_(gw), pool_(pool), dev_(dev), cfg_(kd_config(o)) {}

    kdtree::Tree rebuild(const EssClassifier& cls) {
        codes_ms_ = 0.0;
        ranges_ms_ = 0.0;
        if (!on_device()) {
            if (!host_ && raw_words()) host_.emplace(words_, cfg_, pool_);  // 1 / 2 bytes a voxel read
            if (!host_) host_.emplace(grid_, cfg_, pool_, grid_border(o_));
            kdtree::Tree t = host_->rebuild(cls);
            timings_ = host_->timings();
            codes_ms_ = host_->codes_ms();
            ranges_ms_ = host_->ranges_ms();
            return t;
        }
#ifdef SYLVA_RENDER_VULKAN
        if (!dev_.rebuilder) dev_.rebuilder.emplace(*dev_.ctx, *dev_.grid, words_, cfg_, pool_);
        kdtree::Tree t = dev_.rebuilder->rebuild(cls);
        timings_ = dev_.rebuilder->timings();
        ranges_ms_ = dev_.rebuilder->ranges_ms();
        return t;
#else
        throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
    }
    [[nodiscard]] const kdtree::RebuildTimings& timings() const { return timings_; }
    [[nodiscard]] double codes_ms() const { return codes_ms_; }
    /// Time of the block ranges' streaming pass (kd-binned, first build only).
    [[nodiscard]] double ranges_ms() const { return ranges_ms_; }
    [[nodiscard]] double total_ms() const { return codes_ms_ + ranges_ms_ + timings_.total_ms(); }
    [[nodiscard]] bool on_device() const { return o_.backend == "vulkan" && o_.index == "kd-binned"; }
    [[nodiscard]] std::string construction() const {
        if (on_device()) return "block ranges on the host, undecided blocks' voxels on the Vulkan device, splitting on the host";
        if (cfg_.planes != kdtree::Planes::Binned) return "host: segment codes, partial SVTs";
        return raw_words() ? "host: block ranges over the raw voxels, binned local boxes"
                           : "host: block ranges, binned local boxes";
    }

private:
    /// True when the marcher's grid holds the raw uint8 / uint16 voxels (--grid native), which
    /// the host builder reads as themselves (the same tree as from the floats, from fewer bytes).
    [[nodiscard]] bool raw_words() const {
        return words_.sampling.format == GridFormat::U8 || words_.sampling.format == GridFormat::U16;
    }

    const Options& o_;
    const volume::DensityGrid& grid_;
    const GridWords& words_;
    ThreadPool& pool_;
    Device& dev_;
    kdtree::Config cfg_;
    std::optional<EssRebuilder<ThreadPool>> host_;
    kdtree::RebuildTimings timings_;
    double codes_ms_ = 0.0, ranges_ms_ = 0.0;
};

/// The yardstick of the build (issue 15, item 5): one streaming pass over the volume as read
/// (its own voxel type where sylva-render kept it, else the density grid), classifying every
/// voxel by a density threshold and counting the occupied ones on all threads, the pass
/// sylva-kd-bench times beside its builds (volume::count_occupied); the median of three, ms.
inline double stream_pass_ms(const volume::DensityGrid& g, const volume::Volume* raw, ThreadPool& pool) {
    std::vector<double> ms;
    std::uint64_t count = 0;
    for (int run = 0; run < 3; ++run) {
        auto t0 = std::chrono::steady_clock::now();
        count += raw ? volume::count_occupied(volume::classified(*raw, volume::DensityThreshold{0.5f}), pool)
                     : volume::count_occupied(volume::classified(g, volume::DensityThreshold{0.5f}), pool);
        ms.push_back(ms_since(t0));
    }
    if (count > 3 * g.values.size()) throw Error("stream pass: more occupied voxels than voxels");
    std::sort(ms.begin(), ms.end());
    return ms[1];
}

/// Renders with ESS DVR (the fastest of --repeat frames; the tree is uploaded once).
inline Frame render(const Options& o, const GridWords& gw, const std::vector<std::uint32_t>& words,
             const VolumeRenderParams& p, ThreadPool& pool, Device& dev) {
    if (o.backend == "cpu") return best_of(o.repeat, [&] { return render_kd_dvr_cpu(gw, words, p, pool); });
#ifdef SYLVA_RENDER_VULKAN
    vk::DeviceKdTree kd(*dev.ctx, words);
    return best_of(o.repeat, [&] { return vk::render_kd_dvr_vulkan(*dev.ctx, *dev.grid, kd, p); });
#else
    (void)dev;
    throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
}

/// Fills the kd rows of one built tree.
inline Stats::KdRows::Rebuild row(const std::string& tf, const kdtree::Tree& t, std::size_t bytes, const KdBuilder& b) {
    Stats::KdRows::Rebuild r;
    r.tf = tf;
    r.occupancy_percent = t.stats.percent_occupied();
    r.culled_percent = t.stats.percent_culled();
    r.nodes = t.nodes.size();
    r.leaves = t.leaves.size();
    r.depth = t.stats.max_depth;
    r.bytes = bytes;
    r.codes_ms = b.codes_ms();
    r.ranges_ms = b.ranges_ms();
    r.classify_ms = b.timings().classify_ms;
    r.occupancy_ms = b.timings().occupancy_ms;
    r.split_ms = b.timings().split_ms;
    return r;
}

/// Replays --tf-sequence: a rebuild and a rendering for each transfer function.
inline void replay(const Options& o, const GridWords& gw, VolumeRenderParams p, KdBuilder& builder, ThreadPool& pool,
            Device& dev, Stats& s) {
    for (std::size_t k = 0; k < o.tf_sequence.size(); ++k) {
        const std::string& file = o.tf_sequence[k];
        volume::TransferFunction tf = read_tf_file(file);
        if (!tf.any_opaque())
            throw Error("--tf-sequence " + file + ": the transfer function has no opaque entry: nothing would be visible");
        p.tf = tf.packed_rgba8();
        kdtree::Tree t = builder.rebuild(classifier(o, p.tf));
        std::vector<std::uint32_t> words = kdtree::encode(t);
        Stats::KdRows::Rebuild r = row(file, t, words.size() * 4, builder);
        Frame f = render(o, gw, words, p, pool, dev);
        r.render_ms = f.ms;
        write_frame(numbered(o.output, k + 1), f, vec3(0.0f));
        s.kd.rebuilds.push_back(r);
        if (!o.quiet)
            std::cout << "rebuilt for " << file << ": " << r.leaves << " leaves, occupancy " << r.occupancy_percent
                      << "%, " << r.rebuild_ms() << " ms; rendered in " << f.ms << " ms\n";
    }
}

inline void fill_stats(const Options& o, const volume::DensityGrid& g, const kdtree::Tree& t, std::size_t bytes,
                const KdBuilder& b, Stats& s) {
    Stats::KdRows& k = s.kd;
    k.present = true;
    k.builder = o.index == "kd-vidal" ? "Vidal (planes every dl voxels, tight boxes from 32^3 partial SVTs)"
                                      : "binned (Zellmann 4.3: 4 bins on the 8-voxel raster, 8^3 local boxes)";
    k.depth = o.kd == "shallow" ? "shallow (Vidal's halting criteria)" : "deep (8^3-voxel leaves)";
    k.classify = o.kd_classify == "threshold" ? "density >= " + std::to_string(o.threshold)
                                              : "the TF's alpha over each voxel's 3x3x3 neighbourhood";
    k.construction = b.construction();
    k.voxels = g.values.size();
    k.occupied = t.stats.occupied;
    k.occupancy_percent = t.stats.percent_occupied();
    k.culled_percent = t.stats.percent_culled();
    k.codes_ms = b.codes_ms();
    k.ranges_ms = b.ranges_ms();
    k.classify_ms = b.timings().classify_ms;
    k.occupancy_ms = b.timings().occupancy_ms;
    k.split_ms = b.timings().split_ms;
    s.elements = t.stats.occupied;
    s.nodes = t.nodes.size();
    s.leaves = t.leaves.size();
    s.max_depth = t.stats.max_depth;
    s.build_ms = b.total_ms();
    s.bytes = bytes;
}

}  // namespace kd_detail

inline int run_kd_volume(const Options& o, const sylva::volume::DensityGrid& g, const sylva::volume::Volume* raw,
                         const sylva::VolumeRenderParams& p, sylva::ThreadPool& pool, Stats& s) {
    using namespace sylva;
    using namespace kd_detail;
    GridWords gw = render_grid(o, g, raw, s);  // --grid native: 1 byte a voxel for uint8 data
    Device dev;
    if (o.backend == "vulkan") {
#ifdef SYLVA_RENDER_VULKAN
        dev.ctx.emplace(vk::Context::create());
        dev.grid.emplace(*dev.ctx, gw);
        s.device = dev.ctx->describe();
#else
        throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
    } else {
        s.device = "host, " + std::to_string(pool.concurrency()) + " threads";
    }
    KdBuilder builder(o, g, gw, pool, dev);
    s.kd.stream_ms = stream_pass_ms(g, raw, pool);
    kdtree::Tree t = builder.rebuild(classifier(o, p.tf));
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> words = kdtree::encode(t);
    s.encode_ms = ms_since(t0);
    fill_stats(o, g, t, words.size() * 4, builder, s);
    s.volume.index_bytes = words.size() * 4;
    Stats::VolumeRows& v = s.volume;
    v.present = true;
    v.mode = "dvr, reference marcher with empty-space skipping (" + o.index + ", " + o.kd + ")";
    v.grid = std::to_string(g.dims.x) + "x" + std::to_string(g.dims.y) + "x" + std::to_string(g.dims.z);
    v.voxels = g.values.size();
    v.grid_bytes_16bit = g.values.size() * 2;

    Frame f = render(o, gw, words, p, pool, dev);
    write_frame(o.output, f, vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    if (!o.boxes.empty()) {
        Frame framed = f;
        std::vector<Aabb> boxes = kdtree::world_boxes(t, kdtree::leaf_boxes(t));
        draw_boxes(framed, p.camera, p.rays.source == RaySource::Ortho, boxes, vec4(0.2f, 1.0f, 0.4f, 1.0f));
        write_frame(o.boxes, framed, vec3(0.0f));
    }
    s.fill_frame(f);
    replay(o, gw, p, builder, pool, dev, s);
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    warn_if_nothing_visible(o, s, g, p, std::cerr);  // about the first rendering (the replay's are files)
    return s.errors ? 1 : 0;
}

}  // namespace sylva_render

#endif
