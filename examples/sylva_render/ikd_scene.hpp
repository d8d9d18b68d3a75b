// sylva-render, volume input with --index implicit-kd|dda: exact isosurfaces of up to four
// --iso values (sylva/render/iso.hpp, sylva/vulkan/iso.hpp) found through Wald et al.'s implicit
// min/max kd-tree, or through every cell with the reference DDA (the same image). Header only:
// volume_scene.cpp, the one includer, dispatches here.
#ifndef SYLVA_RENDER_IKD_SCENE_HPP
#define SYLVA_RENDER_IKD_SCENE_HPP

#include <chrono>
#include <iostream>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/iso.hpp>
#include <sylva/volume/grid.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/iso.hpp>
#endif

#include "options.hpp"
#include "stats.hpp"
#include "volume_scene.hpp"

namespace sylva_render {
namespace ikd_detail {

/// The surfaces of --iso: one opaque bone-white surface; with several, translucent colours for
/// all but the last, which is opaque.
inline std::vector<sylva::IsoSurface> surfaces(const Options& o) {
    using sylva::vec4;
    const vec4 palette[3] = {vec4(0.35f, 0.6f, 0.95f, 0.35f), vec4(0.95f, 0.55f, 0.3f, 0.35f), vec4(0.5f, 0.9f, 0.5f, 0.35f)};
    std::vector<sylva::IsoSurface> out;
    for (std::size_t k = 0; k < o.isos.size(); ++k)
        out.push_back({o.isos[k], k + 1 == o.isos.size() ? vec4(0.93f, 0.86f, 0.75f, 1.0f) : palette[k % 3]});
    return out;
}

}  // namespace ikd_detail

inline int run_ikd_volume(const Options& o, const sylva::volume::DensityGrid& g, const sylva::volume::Volume* raw,
                          const sylva::VolumeRenderParams& vp, sylva::ThreadPool& pool, Stats& s) {
    using namespace sylva;
    ikd::Config cfg;
    cfg.brick_levels = o.ikd_bricks;
    cfg.node_bits = o.ikd_node_bits;
    cfg.range_lo = s.volume.range_lo;
    cfg.range_hi = s.volume.range_hi;
    ikd::Tree tree = ikd::build(g, pool, cfg);
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> words = ikd::encode(tree);
    s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    GridWords gw = render_grid(o, g, raw, s);  // --grid native: the file's uint8 / uint16 samples as read
    IsoRenderParams p;
    p.camera = vp.camera;
    p.rays = vp.rays;  // --camera
    p.width = o.width;
    p.height = o.height;
    p.isos = ikd_detail::surfaces(o);
    p.walker = o.index == "dda" ? IsoWalker::Dda : IsoWalker::Tree;
    p.alpha_stop = o.alpha_stop;
    // --border zero: samples outside read 0 and surfaces close at the faces (the shell cells,
    // shared/iso_shell.h); clamp: the grid's cells only, as Wald (a clamped outside would only
    // extrude the faces' surfaces).
    const GridBorder border = grid_border(o);
    if (border.mode == BorderMode::Constant) p.border = border.value;
    IsoCounters n;
    Frame f;
    if (o.backend == "cpu") {
        s.device = "host, " + std::to_string(pool.concurrency()) + " threads";
        bool packets = p.walker == IsoWalker::Tree && o.packets > 1;  // the same image; fewer steps
        s.iso.packet_lanes = packets ? o.packets : 1u;
        f = best_of(o.repeat, [&] {
            return packets ? render_iso_cpu_packets(words, gw, p, pool, &n, static_cast<PacketLanes>(o.packets))
                           : render_iso_cpu(words, gw, p, pool, &n);
        });
    } else {
#ifdef SYLVA_RENDER_VULKAN
        vk::Context ctx = vk::Context::create();
        s.device = ctx.describe();
        vk::DeviceIso dev(ctx, words, gw);
        f = best_of(o.repeat, [&] { return dev.render(ctx, p, &n); });
#else
        throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
    }
    Stats::VolumeRows& v = s.volume;
    v.present = true;
    v.mode = std::string("iso, exact roots in trilinear cells (") +
             (o.index == "dda" ? "every cell along the ray: DDA" : "implicit min/max kd-tree") + ")";
    v.grid = std::to_string(g.dims.x) + "x" + std::to_string(g.dims.y) + "x" + std::to_string(g.dims.z);
    v.voxels = g.values.size();
    v.grid_bytes_16bit = g.values.size() * 2;
    Stats::IsoRows& r = s.iso;
    r.present = true;
    r.isos = o.isos;
    r.index_bytes = o.index == "dda" ? 0 : words.size() * 4;
    r.cells = tree.cell_count();
    r.levels = static_cast<std::uint32_t>(tree.levels.size());
    r.cells_tested = n.cells;
    r.traversal_steps = n.steps;
    r.hits = n.hits;
    s.elements = tree.cell_count();
    s.nodes = o.index == "dda" ? 0 : tree.ranges.size();
    s.leaves = tree.cell_count();
    s.max_depth = static_cast<std::uint32_t>(tree.levels.size());
    s.build_ms = o.index == "dda" ? 0.0 : tree.build_ms;
    s.bytes = r.index_bytes;
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
