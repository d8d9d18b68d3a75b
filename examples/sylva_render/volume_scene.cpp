#include "volume_scene.hpp"

#include "kd_scene.hpp"

#include <chrono>
#include <iostream>
#include <optional>

#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/core/progress.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/resample.hpp>
#include <sylva/volume/transfer_function.hpp>
#include <sylva/volume/voxels.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/volume.hpp>
#endif

using namespace sylva;

namespace sylva_render {
namespace {

/// The procedural volumes: "procedural" / "procedural:nbody" (a sparse N-body-like density,
/// 192^3) and "procedural:ml" (Marschner-Lobb, 128^3).
std::optional<volume::DensityGrid> procedural_volume(const std::string& name, std::string& input) {
    if (name == "procedural" || name == "procedural:nbody" || name.empty()) {
        input = "procedural sparse N-body volume (192^3)";
        return volume::sparse_nbody({192, 192, 192}, 7u);
    }
    if (name == "procedural:ml") {
        input = "procedural Marschner-Lobb volume (128^3)";
        return volume::marschner_lobb({128, 128, 128});
    }
    if (name.rfind("procedural:", 0) == 0)
        throw Error("--volume " + name + ": unknown procedural volume (procedural:nbody or procedural:ml)");
    return std::nullopt;
}

volume::DensityGrid load_grid(const Options& o, ThreadPool& pool, std::string& input) {
    std::optional<volume::DensityGrid> g = procedural_volume(o.volume, input);
    if (!g) {
        input = o.volume;
        std::optional<vec3> spacing;
        if (o.spacing) spacing = vec3((*o.spacing)[0], (*o.spacing)[1], (*o.spacing)[2]);
        g = volume::normalize(volume::read_volume(o.volume, spacing));
    }
    if (o.resample != 1.0f) {
        *g = volume::resample_trilinear(*g, o.resample, pool);
        input += ", resampled x" + std::to_string(o.resample);
    }
    return std::move(*g);
}

volume::TransferFunction transfer_function(const Options& o) {
    if (!o.tf.empty()) return read_tf_file(o.tf);
    if (o.tf_preset == "ramp") return volume::TransferFunction::ramp(o.threshold, 1.0f, vec4(1.0f, 0.85f, 0.6f, 0.5f));
    return volume::TransferFunction::ct_bone_tissue();
}

VolumeRenderParams render_params(const Options& o, const volume::DensityGrid& g) {
    VolumeRenderParams p;
    vec3 from = o.view ? vec3((*o.view)[0], (*o.view)[1], (*o.view)[2]) : vec3(0.4f, 0.3f, 1.0f);
    p.width = o.width;
    p.height = o.height;
    p.camera = Camera::framing(g.world_box(), from).frame(o.width, o.height);
    volume::TransferFunction tf = transfer_function(o);
    if (!tf.any_opaque()) throw Error("the transfer function has no opaque entry: nothing would be visible");
    p.tf = tf.packed_rgba8();
    vec3 e = g.world_box().extent();
    p.dt = std::max(e.x, std::max(e.y, e.z)) / static_cast<float>(o.steps);
    p.unit = std::min(g.spacing.x, std::min(g.spacing.y, g.spacing.z));  // TF alpha: per voxel
    p.shading = o.shading || o.mode == "iso";
    p.alpha_stop = o.alpha_stop;
    p.iso = o.iso;
    p.iso_culling = o.iso_cull;
    if (o.index == "none") p.mode = VolumeMode::DvrReference;
    else if (o.mode == "iso") p.mode = VolumeMode::BihIso;
    else p.mode = o.dvr == "multi" ? VolumeMode::BihMulti : VolumeMode::BihSingle;
    return p;
}

/// The full BIH over the voxel cuboids and its LoD, encoded with node ranges.
struct BuiltLod {
    std::vector<std::uint32_t> words, ranges;
};

BuiltLod build_lod(const Options& o, const volume::DensityGrid& g, ThreadPool& pool, Stats& s) {
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, o.threshold, pool);
    if (cuboids.empty())
        throw Error("no voxel reaches the density threshold " + std::to_string(o.threshold) + ": nothing to build");
    bih::Config cfg;
    ProgressBar bar("building BIH");
    if (!o.quiet) cfg.on_progress = [&bar](double f) { bar.update(f); };
    bih::FullBih full = bih::build_full(std::span<const VoxelCuboid>(cuboids), cfg, pool);
    bih::LodConfig lc{o.lod_depth, o.lod_density, o.lod_stddev, o.chunk_depth};
    bih::Lod lod = bih::extract_lod(full, lc);
    auto t0 = std::chrono::steady_clock::now();
    BuiltLod out{bih::encode_lod(lod, lc), {}};
    if (o.mode == "iso" && o.iso_cull) out.ranges = bih::encode_node_ranges(lod, lc);
    s.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    Stats::VolumeRows& v = s.volume;
    v.full_nodes = full.tree.nodes.size();
    v.full_single_percent = full.tree.stats.percent_single_child();
    v.full_depth = full.tree.stats.max_depth;
    v.full_bytes = full.bytes();
    v.full_bytes_paper = full.paper_bytes();
    v.full_ms = full.total_ms;
    v.lod_nodes = lod.tree.nodes.size();
    v.lod_leaves = lod.stats.leaves;
    v.lod_depth = lod.stats.max_depth;
    v.lod_bytes = lod.node_bytes();
    v.lod_ms = lod.extract_ms;
    s.elements = cuboids.size();
    s.nodes = lod.tree.nodes.size();
    s.leaves = lod.stats.leaves;
    s.max_depth = lod.stats.max_depth;
    s.single_child_percent = lod.stats.percent_single_child();
    s.build_ms = full.total_ms + lod.extract_ms;
    s.bytes = (out.words.size() + out.ranges.size()) * 4;
    return out;
}

Frame render(const Options& o, const volume::DensityGrid& g, const BuiltLod& lod, const VolumeRenderParams& p,
             ThreadPool& pool, std::string& device) {
    std::optional<GridWords> grid;
    if (p.mode == VolumeMode::DvrReference) grid = GridWords::from(g);
    VoxelBihView view{lod.words, lod.ranges, g.spacing, g.world_box()};
    if (o.backend == "cpu") {
        device = "host, " + std::to_string(pool.concurrency()) + " threads";
        return best_of(o.repeat, [&] { return render_volume_cpu(VolumeScene{grid ? &*grid : nullptr, view}, p, pool); });
    }
#ifdef SYLVA_RENDER_VULKAN
    vk::Context ctx = vk::Context::create();
    device = ctx.describe();
    if (grid) {
        vk::DeviceGrid dg(ctx, *grid);
        return best_of(o.repeat, [&] { return vk::render_dvr_vulkan(ctx, dg, p); });
    }
    vk::DeviceVoxelBih db(ctx, view);
    return best_of(o.repeat, [&] { return vk::render_bih_dvr_vulkan(ctx, db, p); });
#else
    (void)view;
    throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
}

}  // namespace

volume::TransferFunction read_tf_file(const std::string& path) {
    bool json = path.size() >= 5 && path.substr(path.size() - 5) == ".json";
    return json ? volume::TransferFunction::from_json(path) : volume::TransferFunction::from_text(path);
}

int run_volume(const Options& o) {
    Stats s;
    s.backend = o.backend;
    s.index = o.index;
    s.repeat = o.repeat;
    ThreadPool pool(o.threads);
    volume::DensityGrid g = load_grid(o, pool, s.input);
    VolumeRenderParams p = render_params(o, g);
    if (o.kd_index()) return run_kd_volume(o, g, p, pool, s);
    BuiltLod lod;
    if (o.index == "bih") lod = build_lod(o, g, pool, s);
    else s.bytes = g.values.size() * 4;  // the float grid the marcher reads; elements stay 0: no index
    Stats::VolumeRows& v = s.volume;
    v.present = true;
    v.mode = o.index == "none" ? "dvr (reference marcher)" : (o.mode == "iso" ? "iso" : "dvr " + o.dvr + "-sample");
    v.grid = std::to_string(g.dims.x) + "x" + std::to_string(g.dims.y) + "x" + std::to_string(g.dims.z);
    v.voxels = g.values.size();
    v.grid_bytes_16bit = g.values.size() * 2;
    Frame f = render(o, g, lod, p, pool, s.device);
    write_frame(o.output, f, vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    s.fill_frame(f);
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    return s.errors ? 1 : 0;
}

}  // namespace sylva_render
