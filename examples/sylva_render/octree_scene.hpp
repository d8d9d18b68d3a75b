// sylva-render, volume input with --index octree: Gobbetti et al.'s bricked octree
// (sylva/octree/build.hpp) rendered with DVR (sylva/shared/octree_dvr.h) or the first hit of one
// --iso value (sylva/shared/octree_iso.h) on the host or through Vulkan; without --lod-pixels
// through the full-resolution cut (the marcher's image), with it through the cut chosen for the
// view (sylva/octree/cut.hpp) within --cut-nodes nodes; with --frames (or a budget) out of core
// over the in-core tree as the brick source (ooc_scene.hpp). Header only: volume_scene.cpp, the one
// includer, dispatches here.
#ifndef SYLVA_RENDER_OCTREE_SCENE_HPP
#define SYLVA_RENDER_OCTREE_SCENE_HPP

#include <chrono>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/octree/brick_source.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/lod_error.hpp>
#include <sylva/octree/octants.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/volume/grid.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/octree_volume.hpp>
#endif

#include "ooc_scene.hpp"
#include "options.hpp"
#include "stats.hpp"
#include "volume_scene.hpp"

namespace sylva_render {

/// The bricks' format for --grid: with native (the default) a uint8 / uint16 volume normalised
/// over its type's range keeps its voxels exactly in unorm8 / unorm16 bricks (a quarter / half of
/// float32's memory, the same image); anything else, or --grid float32, takes float32 bricks.
inline sylva::octree::BrickFormat octree_brick_format(const Options& o, const sylva::volume::Volume* native) {
    using namespace sylva;
    if (o.grid_format == "float32" || native == nullptr || native->range_lo != 0.0f) return octree::BrickFormat::Float32;
    if (native->type == volume::ScalarType::U8 && native->range_hi == 255.0f) return octree::BrickFormat::Unorm8;
    if (native->type == volume::ScalarType::U16 && native->range_hi == 65535.0f) return octree::BrickFormat::Unorm16;
    return octree::BrickFormat::Float32;
}

inline int run_octree_volume(const Options& o, const sylva::volume::DensityGrid& g, const sylva::volume::Volume* native,
                             const sylva::VolumeRenderParams& vp, sylva::ThreadPool& pool, Stats& s) {
    using namespace sylva;
    const bool iso = o.mode == "iso";
    octree::Config cfg;
    cfg.brick_size = o.brick;
    cfg.format = octree_brick_format(o, native);
    s.octree.brick_format = brick_format_name(cfg.format);
    octree::Tree tree = octree::build(g, pool, cfg);
    if (o.out_of_core()) {  // the in-core tree as the brick source of the out-of-core path
        s.build_ms = tree.build_ms;
        s.elements = g.values.size();
        octree::TreeBrickSource src(std::move(tree));
        int rc = run_octree_ooc(o, src, pool, s);
        warn_if_nothing_visible(o, s, g, vp, std::cerr);
        return rc;
    }
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> words = octree::encode(tree);
    octree::Cut cut;
    if (o.lod_pixels > 0.0f) {
        // The TF-aware refinement (octree/lod_error.hpp) for DVR: the deviation tables once.
        std::optional<octree::LodDeviation> deviation;
        if (!iso && o.max_tf_error < 1.0f) deviation = octree::lod_deviation(words, tree.bricks, pool);
        cut = select_octree_cut(words, vp, {o.lod_pixels, o.cut_nodes, o.max_tf_error}, iso, grid_border(o),
                                deviation ? &*deviation : nullptr);
        octree::apply_cut(words, cut);
    } else {  // the full-resolution cut: every node
        cut.nodes = static_cast<std::uint32_t>(tree.nodes.size());
        for (const octree::Node& n : tree.nodes) cut.leaves += n.leaf() ? 1u : 0u;
        cut.deepest = tree.levels - 1u;
    }
    // Octant masks for the TF and the border (octree/octants.hpp): DVR skips the empty octants
    // of leaves.
    std::vector<std::uint32_t> octmask;
    const GridBorder border = grid_border(o);
    if (!iso)
        octmask = octree::octant_masks(octree::octant_ranges(words, tree.bricks, pool), tf_opacity_prefix(vp.tf),
                                       border.mode == BorderMode::Constant ? std::optional<float>(border.value) : std::nullopt);
    s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    OctreeView view{words, tree.bricks, 0xFFFFFFFFu, {}, octmask, grid_border(o)};
    Frame f;
    if (o.backend == "cpu") {
        s.device = "host, " + std::to_string(pool.concurrency()) + " threads";
        f = best_of(o.repeat, [&] { return iso ? render_octree_iso_cpu(view, vp, pool) : render_octree_dvr_cpu(view, vp, pool); });
    } else {
#ifdef SYLVA_RENDER_VULKAN
        vk::Context ctx = vk::Context::create();
        s.device = ctx.describe();
        vk::DeviceOctree dev(ctx, view);
        f = best_of(o.repeat, [&] {
            return iso ? vk::render_octree_iso_vulkan(ctx, dev, vp) : vk::render_octree_dvr_vulkan(ctx, dev, vp, {}, octmask);
        });
#else
        throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
    }
    Stats::VolumeRows& v = s.volume;
    v.present = true;
    v.mode = std::string(iso ? "iso, first hit" : "dvr") + " through the bricked octree (" +
             (o.lod_pixels > 0.0f ? "view-dependent cut" : "full-resolution cut") + ")";
    v.grid = std::to_string(g.dims.x) + "x" + std::to_string(g.dims.y) + "x" + std::to_string(g.dims.z);
    v.border = o.border;
    v.voxels = g.values.size();
    v.grid_bytes_16bit = g.values.size() * 2;
    Stats::OctreeRows& r = s.octree;
    r.present = true;
    r.brick_size = tree.brick_size;
    r.bricks = tree.brick_count();
    r.octree_nodes = tree.nodes.size();
    r.index_bytes = words.size() * 4;
    r.brick_bytes = tree.brick_bytes();
    r.cut_nodes = cut.nodes;
    r.cut_leaves = cut.leaves;
    r.cut_deepest = cut.deepest;
    r.levels = tree.levels;
    r.lod_pixels = o.lod_pixels;
    r.max_tf_error = (o.lod_pixels > 0.0f && !iso) ? o.max_tf_error : 1.0f;
    s.elements = g.values.size();
    s.nodes = tree.nodes.size();
    s.leaves = cut.leaves;
    s.max_depth = tree.levels;
    s.build_ms = tree.build_ms;
    s.bytes = r.index_bytes + r.brick_bytes;
    write_frame(o.output, f, vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    s.fill_frame(f);  // counts the rays that met a refused encoding (steps 0xFFFFFFFF) as errors
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    warn_if_nothing_visible(o, s, g, vp, std::cerr);
    return s.errors ? 1 : 0;
}

}  // namespace sylva_render

#endif
