// sylva-render, --index octree out of core (issue 13): the bricked octree rendered progressively
// over --frames N frames from a BrickSource -- the on-disk brick store (sylva/store/store.hpp;
// --volume STORE, a directory made by sylva-store build) or, for an ordinary volume file or a
// procedural volume, the in-core octree (octree::TreeBrickSource) -- through the host cache,
// the asynchronous loader, the device pool and the per-frame refinement with visibility
// feedback (sylva/octree/residency.hpp), within --memory-budget and --device-budget, on the host
// or through Vulkan. Writes the last frame (-o) and, with --frames-out DIR, every frame.
// Header only: octree_scene.hpp, included by volume_scene.cpp, dispatches here.
#ifndef SYLVA_RENDER_OOC_SCENE_HPP
#define SYLVA_RENDER_OOC_SCENE_HPP

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/octree/brick_source.hpp>
#include <sylva/octree/residency.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/volume/transfer_function.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/octree_volume.hpp>
#endif
#ifdef SYLVA_RENDER_STORE
#include <sylva/store/store.hpp>
#endif

#include "options.hpp"
#include "stats.hpp"
#include "volume_scene.hpp"

namespace sylva_render {

using sylva::octree::brick_format_name;  // a brick format (an index's word 5 bits 24-31) in the statistics

/// Peak resident set size of this process in bytes (getrusage: ru_maxrss is in KiB on Linux).
inline std::size_t peak_rss_bytes() {
    struct rusage u {};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<std::size_t>(u.ru_maxrss) * 1024u;
}

/// The render parameters for the octree's volume (what render_params does for a grid): the view
/// framing the world box (--camera pinhole, or ortho: a rectangle as high as the bounding
/// sphere), --tf / --tf-preset, dt = longest extent / --steps, unit = the voxel.
inline sylva::VolumeRenderParams ooc_params(const Options& o, const sylva::shared::SylvaOctHeader& h, sylva::vec3 from) {
    using namespace sylva;
    VolumeRenderParams p;
    p.width = o.width;
    p.height = o.height;
    Aabb box{vec3(0.0f), vec3(h.dims) * h.spacing};
    Camera cam = Camera::framing(box, from);
    p.camera = cam.frame(o.width, o.height);
    if (o.camera == "ortho") {
        p.camera = cam.ortho_frame(o.width, o.height, 0.5f * glm::length(box.extent()));
        p.rays.source = RaySource::Ortho;
    }
    volume::TransferFunction tf = !o.tf.empty() ? read_tf_file(o.tf)
                                  : o.tf_preset == "ramp"
                                      ? volume::TransferFunction::ramp(o.threshold, 1.0f, vec4(1.0f, 0.85f, 0.6f, 0.5f))
                                      : volume::TransferFunction::ct_bone_tissue();
    if (!tf.any_opaque()) throw Error("the transfer function has no opaque entry: nothing would be visible");
    p.tf = tf.packed_rgba8();
    vec3 e = box.extent();
    p.dt = std::max(e.x, std::max(e.y, e.z)) / static_cast<float>(o.steps);
    p.unit = std::min(h.spacing.x, std::min(h.spacing.y, h.spacing.z));
    p.shading = o.shading || o.mode == "iso";
    p.alpha_stop = o.alpha_stop;
    p.iso = o.iso;
    return p;
}

/// The view direction of frame i: --view (or the default), turned about the vertical axis by
/// 2 pi i / N with --orbit.
inline sylva::vec3 ooc_view(const Options& o, std::uint32_t i) {
    sylva::vec3 from = o.view ? sylva::vec3((*o.view)[0], (*o.view)[1], (*o.view)[2]) : sylva::vec3(0.4f, 0.3f, 1.0f);
    if (!o.orbit) return from;
    float a = 6.2831853f * static_cast<float>(i) / static_cast<float>(std::max(o.frames, 1u));
    return {from.x * std::cos(a) + from.z * std::sin(a), from.y, -from.x * std::sin(a) + from.z * std::cos(a)};
}

/// Renders one frame of the working set on the host or the device.
struct OocRenderer {
    const Options& o;
    sylva::ThreadPool& pool;
    bool iso;
    sylva::Frame host(std::span<const std::uint32_t> words, std::span<const std::uint32_t> bricks, std::span<std::uint32_t> seen,
                      const sylva::VolumeRenderParams& p) {
        sylva::OctreeView v{words, bricks, 0xFFFFFFFFu, seen, {}, grid_border(o)};
        return iso ? sylva::render_octree_iso_cpu(v, p, pool) : sylva::render_octree_dvr_cpu(v, p, pool);
    }
};

/// Runs the progressive frames over `src` with pool buffer `buf` rendered by `draw(frame, p,
/// seen)`; fills the stats' out-of-core rows and returns the last frame.
template <class S, class Buf, class Draw>
sylva::Frame ooc_frames(const Options& o, const S& src, Buf& buf, const sylva::octree::ResidencyConfig& cfg, bool iso,
                        Draw&& draw, Stats& s) {
    using namespace sylva;
    octree::Residency res(src, buf, cfg);
    VolumeRenderParams p = ooc_params(o, res.header(), ooc_view(o, 0));
    OctreeTerminal terminal(src.index(), p, iso, grid_border(o));
    Frame f;
    Stats::OocRows& r = s.ooc;
    if (!o.frames_out.empty()) {
        std::error_code ec;
        std::filesystem::create_directories(o.frames_out, ec);
        if (ec) throw Error("--frames-out " + o.frames_out + ": cannot create the directory (" + ec.message() + ")");
    }
    for (std::uint32_t i = 0; i < o.frames; ++i) {
        auto t0 = std::chrono::steady_clock::now();
        if (o.orbit) p.camera = ooc_params(o, res.header(), ooc_view(o, i)).camera;
        const octree::ResidencyFrame& fr = res.update(octree_cut_view(p), terminal);
        f = draw(fr, p, res.feedback());
        double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        r.frames.push_back({ms, fr.ms, f.ms, fr.loaded, fr.uploads, fr.requests, fr.cut.nodes, fr.cut.deepest});
        if (!o.frames_out.empty()) {
            char name[32];
            std::snprintf(name, sizeof name, "frame_%04u.png", i);
            write_frame((std::filesystem::path(o.frames_out) / name).string(), f, vec3(0.0f));
        }
    }
    const octree::ResidencyCounters& c = res.counters();
    octree::HostCacheCounters hc = res.host_counters();
    octree::LoaderCounters lc = res.loader_counters();
    r.present = true;
    r.memory_budget = cfg.host_budget_bytes;
    r.device_budget = cfg.device_budget_bytes;
    r.host_cache_bytes = hc.bytes;
    r.host_cache_peak_bytes = hc.peak_bytes;
    r.device_pool_bytes = res.device_pool_bytes();
    r.device_slots = res.slots();
    r.bricks_loaded = lc.loaded;
    r.bricks_evicted = hc.evicted + c.device_evicted;
    r.host_evicted = hc.evicted;
    r.device_evicted = c.device_evicted;
    r.uploads = c.uploads;
    r.bad_bricks = c.bad_bricks;
    r.cancelled = lc.cancelled;
    r.host_hit_rate = hc.hits + hc.misses ? double(hc.hits) / double(hc.hits + hc.misses) : 0.0;
    r.device_hit_rate = c.device_hits + c.device_misses ? double(c.device_hits) / double(c.device_misses + c.device_hits) : 0.0;
    r.feedback = cfg.visibility_feedback;
    const octree::Cut& cut = res.frame().cut;
    s.octree.cut_nodes = cut.nodes;
    s.octree.cut_leaves = cut.leaves;
    s.octree.cut_deepest = cut.deepest;
    s.octree.index_bytes = res.frame().words.size() * 4;
    s.leaves = cut.leaves;
    r.peak_rss_bytes = peak_rss_bytes();
    return f;
}

/// Progressive out-of-core frames over any BrickSource, on the backend o.backend.
template <class S>
int run_octree_ooc(const Options& o, const S& src, sylva::ThreadPool& pool, Stats& s) {
    using namespace sylva;
    const bool iso = o.mode == "iso";
    octree::ResidencyConfig cfg;
    cfg.host_budget_bytes = o.memory_budget;
    cfg.device_budget_bytes = o.device_budget;
    cfg.lod_pixels = o.lod_pixels > 0.0f ? o.lod_pixels : 1.0f;
    cfg.max_nodes = o.cut_nodes;
    cfg.visibility_feedback = o.feedback;
    std::span<const std::uint32_t> index = src.index();
    const std::uint32_t slots = octree::pool_slots(index, cfg), brick_words = index[8];
    Frame f;
    if (o.backend == "cpu") {
        s.device = "host, " + std::to_string(pool.concurrency()) + " threads";
        octree::HostBrickPool buf(slots, brick_words);
        OocRenderer r{o, pool, iso};
        f = ooc_frames(o, src, buf, cfg, iso,
                       [&](const octree::ResidencyFrame& fr, const VolumeRenderParams& p, std::span<std::uint32_t> seen) {
                           return r.host(fr.words, buf.words, seen, p);
                       }, s);
    } else {
#ifdef SYLVA_RENDER_VULKAN
        vk::Context ctx = vk::Context::create();
        s.device = ctx.describe();
        std::vector<std::uint32_t> words0(index.begin(), index.end());
        words0[7] = slots;
        vk::DeviceOctree dev(ctx, words0, std::size_t{slots} * brick_words);
        dev.set_border(grid_border(o));
        words0 = {};
        vk::DeviceBrickPool buf{&dev, brick_words};
        f = ooc_frames(o, src, buf, cfg, iso,
                       [&](const octree::ResidencyFrame& fr, const VolumeRenderParams& p, std::span<std::uint32_t> seen) {
                           dev.set_index(fr.words);
                           return iso ? vk::render_octree_iso_vulkan(ctx, dev, p, seen) : vk::render_octree_dvr_vulkan(ctx, dev, p, seen);
                       }, s);
#else
        throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
    }
    shared::SylvaOctHeader h = shared::sylva_oct_decode_header(shared::Words{index.data(), index.size()});
    Stats::OctreeRows& r = s.octree;
    r.present = true;
    r.brick_size = h.brick_size;
    r.bricks = h.brick_count;
    r.octree_nodes = h.node_count;
    r.brick_bytes = std::size_t{h.brick_count} * h.brick_words * 4;
    r.brick_format = brick_format_name(static_cast<octree::BrickFormat>(h.format));
    r.levels = h.levels;
    r.lod_pixels = cfg.lod_pixels;
    Stats::VolumeRows& v = s.volume;
    v.present = true;
    v.mode = std::string(iso ? "iso, first hit" : "dvr") + " through the bricked octree, out of core (" +
             std::to_string(o.frames) + " progressive frames)";
    v.grid = std::to_string(h.dims.x) + "x" + std::to_string(h.dims.y) + "x" + std::to_string(h.dims.z);
    v.voxels = std::size_t{h.dims.x} * h.dims.y * h.dims.z;
    v.grid_bytes_16bit = v.voxels * 2;
    v.border = o.border;
    if (s.elements == 0) s.elements = v.voxels;  // a store: the volume's voxels
    s.nodes = h.node_count;
    s.bytes = r.index_bytes + s.ooc.device_pool_bytes;  // what the renderer reads: frame index + pool
    s.max_depth = h.levels;
    write_frame(o.output, f, vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    s.fill_frame(f);
    s.ooc.peak_rss_bytes = peak_rss_bytes();
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    return s.errors ? 1 : 0;
}

/// True when --volume names a brick store (a directory holding data.mdb, sylva-store build).
inline bool is_store_path(const std::string& path) {
    std::error_code ec;
    return !path.empty() && std::filesystem::is_directory(path, ec) &&
           std::filesystem::exists(std::filesystem::path(path) / "data.mdb", ec);
}

/// --volume STORE: the out-of-core frames straight from the store.
inline int run_store_volume(const Options& o, Stats& s) {
#ifdef SYLVA_RENDER_STORE
    sylva::ThreadPool pool(o.threads);
    sylva::store::Store st = sylva::store::Store::open(o.volume);
    s.input = o.volume + " (brick store, " + std::to_string(st.file_bytes()) + " bytes on disk)";
    s.volume.range_source = "the store's";
    return run_octree_ooc(o, st, pool, s);
#else
    (void)s;
    throw sylva::Error("--volume " + o.volume + " is a brick store, but this sylva-render was built without the store "
                       "(liblmdb-dev, libzstd-dev, liblz4-dev, libxxhash-dev)");
#endif
}

}  // namespace sylva_render

#endif
