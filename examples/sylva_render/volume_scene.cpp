#include "volume_scene.hpp"

#include "ikd_scene.hpp"
#include "kd_scene.hpp"
#include "octree_scene.hpp"

#include <algorithm>
#include <chrono>
#include <iostream>
#include <optional>
#include <sstream>

#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/core/progress.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/resample.hpp>
#include <sylva/volume/transfer_function.hpp>
#include <sylva/volume/value_range.hpp>
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

/// The density grid of --volume: a procedural one, or a file normalised over --range (the range
/// used goes to the stats), resampled by --resample. A uint8 / uint16 file not resampled is also
/// kept as read in `raw`, for the renderers that read it natively (render_grid).
volume::DensityGrid load_grid(const Options& o, ThreadPool& pool, Stats& s, std::optional<volume::Volume>& raw_out) {
    Stats::VolumeRows& v = s.volume;
    std::optional<volume::DensityGrid> g = procedural_volume(o.volume, s.input);
    v.range_lo = 0.0f;
    v.range_hi = 1.0f;
    v.range_source = "procedural densities";
    if (!g) {
        s.input = o.volume;
        std::optional<vec3> spacing;
        if (o.spacing) spacing = vec3((*o.spacing)[0], (*o.spacing)[1], (*o.spacing)[2]);
        volume::Volume raw = volume::read_volume(o.volume, spacing, o.range);
        v.range_lo = raw.range_lo;
        v.range_hi = raw.range_hi;
        v.range_source = volume::range_source_name(raw.range_source);
        v.data_bytes = raw.bytes.size();
        g = volume::normalize(raw);
        if (raw.type != volume::ScalarType::F32 && o.resample == 1.0f) raw_out = std::move(raw);
    }
    if (v.data_bytes == 0) v.data_bytes = g->values.size() * 4;  // procedural: float32 densities
    if (o.resample != 1.0f) {
        *g = volume::resample_trilinear(*g, o.resample, pool);
        v.data_bytes = g->values.size() * 4;  // the resampled float32 grid is the data now
        s.input += ", resampled x" + std::to_string(o.resample);
    }
    return std::move(*g);
}

}  // namespace

GridWords render_grid(const Options& o, const volume::DensityGrid& g, const volume::Volume* raw, Stats& s) {
    GridBorder border = grid_border(o);
    s.volume.border = o.border;
    if ((o.grid_format == "native" || o.grid_format == "sparse") && raw) {
        bool sparse = o.grid_format == "sparse";
        GridWords w = sparse ? GridWords::sparse(*raw, border) : GridWords::native(*raw, border);
        s.volume.grid_bytes = w.grid_bytes();
        s.volume.grid_format = std::string(sparse ? "sparse-" : "") + volume::scalar_name(raw->type);
        return w;
    }
    GridWords w = GridWords::from(g, border);
    s.volume.grid_bytes = w.grid_bytes();
    s.volume.grid_format = "float32";
    return w;
}

namespace {

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
    Camera cam = Camera::framing(g.world_box(), from);
    p.camera = cam.frame(o.width, o.height);
    if (o.camera == "ortho") {  // the same eye and view direction, a rectangle as high as the bounding sphere
        p.camera = cam.ortho_frame(o.width, o.height, 0.5f * glm::length(g.world_box().extent()));
        p.rays.source = RaySource::Ortho;
    }
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
    if (cuboids.empty()) return {};  // nothing to build: a blank image and warn_if_nothing_visible's message
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

Frame render(const Options& o, const volume::DensityGrid& g, const volume::Volume* raw, const BuiltLod& lod,
             const VolumeRenderParams& p, ThreadPool& pool, Stats& s) {
    std::string& device = s.device;
    if (p.mode != VolumeMode::DvrReference && lod.words.empty()) {  // no element: nothing to traverse
        device = "host, nothing traversed (no element)";
        return blank_frame(p.width, p.height);
    }
    std::optional<GridWords> grid;
    if (p.mode == VolumeMode::DvrReference) grid = render_grid(o, g, raw, s);
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

/// Density of the first transfer-function entry with a visible alpha (> 0), or 2 when none is.
float first_visible_density(const std::vector<std::uint32_t>& tf) {
    for (std::size_t i = 0; i < tf.size(); ++i)
        if ((tf[i] >> 24) != 0u) return static_cast<float>(i) / static_cast<float>(tf.size() - 1);
    return 2.0f;
}

/// "0.1 (raw value 6553.5)": a density with the raw value it stands for under the volume's range.
std::string density_text(float d, const Stats::VolumeRows& v) {
    std::ostringstream os;
    os << d << " (raw value " << v.range_lo + d * (v.range_hi - v.range_lo) << ")";
    return os.str();
}

}  // namespace

Frame blank_frame(std::uint32_t width, std::uint32_t height) {
    Frame f;
    f.width = width;
    f.height = height;
    f.rgba.assign(std::size_t{width} * height, vec4(0.0f));
    f.steps.assign(std::size_t{width} * height, 0u);
    return f;
}

void warn_if_nothing_visible(const Options& o, const Stats& s, const volume::DensityGrid& g, const VolumeRenderParams& p,
                             std::ostream& err) {
    if (s.visible_pixels > 0) return;
    const Stats::VolumeRows& v = s.volume;
    auto [lo, hi] = std::minmax_element(g.values.begin(), g.values.end());
    float dlo = g.values.empty() ? 0.0f : *lo, dhi = g.values.empty() ? 0.0f : *hi;
    float tf_from = first_visible_density(p.tf);
    bool threshold_matters = o.index == "bih" || (o.kd_index() && o.kd_classify == "threshold");
    err << "sylva-render: nothing visible: all " << s.width << "x" << s.height
        << " pixels are fully transparent (the image is written all the same)\n"
        << "  value range    [" << v.range_lo << ", " << v.range_hi << "] (" << v.range_source
        << ") maps to density [0, 1]; the volume's densities lie in [" << dlo << ", " << dhi << "]\n";
    if (threshold_matters)
        err << "  threshold      " << density_text(o.threshold, v)
            << (s.elements == 0 ? ": no voxel reaches it, nothing was built" : "") << "\n";
    if (o.mode == "iso")
        for (float iso : o.isos) err << "  iso value      " << density_text(iso, v) << "\n";
    else err << "  transfer fn    transparent below density " << density_text(std::min(tf_from, 1.0f), v) << "\n";
    err << "  to see it      ";
    if (v.range_source == "type range" || v.range_source == "explicit") err << "--range auto (the data's min/max), ";
    if (threshold_matters) err << "a --threshold at or below " << dhi << ", ";
    if (o.mode == "iso") err << "an --iso value in [" << dlo << ", " << dhi << "]\n";
    else err << "a transfer function (--tf FILE) visible in [" << dlo << ", " << dhi << "]\n";
}

volume::TransferFunction read_tf_file(const std::string& path) {
    return volume::TransferFunction::from_file(path);  // .json in any letter case is JSON
}

int run_volume(const Options& o) {
    Stats s;
    s.backend = o.backend;
    s.index = o.index;
    s.repeat = o.repeat;
    s.camera = o.camera;
    if (o.octree_index() && is_store_path(o.volume)) return run_store_volume(o, s);  // out of core from disk
    ThreadPool pool(o.threads);
    std::optional<volume::Volume> raw;
    volume::DensityGrid g = load_grid(o, pool, s, raw);
    const volume::Volume* native = raw ? &*raw : nullptr;
    VolumeRenderParams p = render_params(o, g);
    if (o.kd_index()) return run_kd_volume(o, g, native, p, pool, s);
    if (o.ikd_index()) return run_ikd_volume(o, g, native, p, pool, s);
    if (o.octree_index()) return run_octree_volume(o, g, native, p, pool, s);
    BuiltLod lod;
    if (o.index == "bih") lod = build_lod(o, g, pool, s);
    else s.bytes = g.values.size() * 4;  // the float grid the marcher reads; elements stay 0: no index
    s.volume.index_bytes = o.index == "bih" ? (lod.words.size() + lod.ranges.size()) * 4 : 0;
    Stats::VolumeRows& v = s.volume;
    v.present = true;
    v.mode = o.index == "none" ? "dvr (reference marcher)" : (o.mode == "iso" ? "iso" : "dvr " + o.dvr + "-sample");
    v.grid = std::to_string(g.dims.x) + "x" + std::to_string(g.dims.y) + "x" + std::to_string(g.dims.z);
    v.voxels = g.values.size();
    v.grid_bytes_16bit = g.values.size() * 2;
    Frame f = render(o, g, native, lod, p, pool, s);
    if (o.index == "none" && s.volume.grid_bytes != 0) s.bytes = s.volume.grid_bytes;  // the words the marcher read
    write_frame(o.output, f, vec3(0.0f));
    if (!o.heatmap.empty()) s.heatmap_peak = write_heatmap(o.heatmap, f);
    s.fill_frame(f);
    if (!o.quiet) s.print(std::cout);
    if (!o.stats_json.empty()) s.write_json(o.stats_json);
    warn_if_nothing_visible(o, s, g, p, std::cerr);
    return s.errors ? 1 : 0;
}

}  // namespace sylva_render
