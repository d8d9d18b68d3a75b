// benchmarks/volume_bench.cpp -- sylva-volume-bench: image quality and speed of BIH-based DVR
// against the reference ray marcher (Kinkelin sections 4.3 and 6.2, Figures 5-8, Tables 4, 6).
//
// For engine, aneurism and lobster (spacing 1, 1, 1.4), at resampling factors 1, 1.5 and 2:
//  * build: voxel cuboids (normalised density >= 0.1) of the (trilinearly resampled) grid, the
//    full BIH (build_full), the default LoD (extract_lod), its encoding (encode_lod);
//  * render one camera and one transfer function with the reference marcher on the ORIGINAL
//    grid (1,024 steps along the longest axis: the reference of every PSNR) and with single- and
//    multi-sample BIH-DVR on each factor's LoD (same lattice dt, same opacity unit; gradients in
//    units of the resampled grid's voxel);
//  * report PSNR / max abs / RMSE against the reference, rays/s on the host and on the Vulkan
//    device (lavapipe here: a CPU, so ratios between renderers are what matter), construction
//    rate and LoD size against the 16- and 8-bit original grid, beside the paper's figures.
// Output: tables on stdout, JSON records {case, impl, metric, value, unit} (--json), PNGs and
// step heat maps (--images). `--case procedural` needs no data (the smoke test).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <sylva/bih/encode.hpp>
#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/core/error.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/grid.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/resample.hpp>
#include <sylva/volume/transfer_function.hpp>
#include <sylva/volume/voxels.hpp>
#if SYLVA_HAVE_OIIO
#include <sylva/render/image.hpp>
#endif

#include "volume_bench_options.hpp"
#include "volume_bench_render.hpp"
#include "volume_bench_report.hpp"

namespace volume_bench {
namespace {

using namespace sylva;

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// ---- data -----------------------------------------------------------------------------------

/// A data set: a raw file in --data (with a spacing), or the procedural volume, and the warm
/// TF's opacity for it (low enough that the inside shows: Kinkelin's Fig. 5).
struct DataCase {
    std::string name, file;
    vec3 spacing{1.0f};
    float alpha = 0.1f;
};

std::vector<DataCase> selected_cases(const Options& o) {
    const std::vector<DataCase> real = {{"engine", "engine_256x256x128_uint8.raw", {1.0f, 1.0f, 1.0f}, 0.04f},
                                        {"aneurism", "aneurism_256x256x256_uint8.raw", {1.0f, 1.0f, 1.0f}, 0.4f},
                                        {"lobster", "lobster_301x324x56_uint8.raw", {1.0f, 1.0f, 1.4f}, 0.15f}};
    if (o.only == "procedural") return {{"procedural", "", vec3(1.0f), 0.1f}};
    std::vector<DataCase> out;
    for (const DataCase& c : real)
        if (o.only == "all" || o.only == c.name) out.push_back(c);
    return out;
}

/// The file of a case; throws sylva::Error naming the path when it is missing.
std::filesystem::path data_file(const Options& o, const DataCase& c) {
    std::filesystem::path path = std::filesystem::path(o.data) / c.file;
    if (!std::filesystem::is_regular_file(path))
        throw Error("volume " + path.string() + " not found (--data names the folder holding " + c.file + ")");
    return path;
}

/// The normalised density grid of a case; throws sylva::Error naming the path when missing.
volume::DensityGrid load(const Options& o, const DataCase& c) {
    if (c.file.empty()) return volume::marschner_lobb({64, 64, 64});
    return volume::normalize(volume::read_volume(data_file(o, c), c.spacing));
}

// ---- render parameters ----------------------------------------------------------------------

/// The warm TF: transparent up to density 0.1, then alpha rising linearly to `a` at 1 while the
/// colour goes dark red -> orange -> yellow -> white (density errors show as hue and opacity).
volume::TransferFunction warm(float a) {
    return volume::TransferFunction({{0.1f, {0.55f, 0.10f, 0.05f, 0.0f}},
                                     {0.4f, {0.95f, 0.45f, 0.10f, a / 3.0f}},
                                     {0.7f, {1.00f, 0.85f, 0.35f, 2.0f * a / 3.0f}},
                                     {1.0f, {1.00f, 1.00f, 0.95f, a}}});
}

/// The warm TF's opacity at density 1 for a case: --alpha, else the case's default.
float warm_alpha(const Options& o, const DataCase& c) { return o.alpha > 0.0f ? o.alpha : c.alpha; }

/// The transfer function of every image of a case (see --tf in the usage text).
volume::TransferFunction transfer_function(const Options& o, const DataCase& c) {
    if (o.tf == "ct") return volume::TransferFunction::ct_bone_tissue();
    if (o.tf == "ramp") return volume::TransferFunction::ramp(0.1f, 1.0f, vec4(1.0f, 0.85f, 0.6f, 0.5f));
    return warm(warm_alpha(o, c));
}

/// The TF in words, for the header of a case.
std::string describe_tf(const Options& o, const DataCase& c) {
    if (o.tf == "ct") return "ct_bone_tissue preset";
    if (o.tf == "ramp") return "ramp preset: alpha 0 at density 0.1 -> 0.5 at 1, rgb (1, 0.85, 0.6)";
    return "warm: alpha 0 at density 0.1 -> " + num(warm_alpha(o, c), 3) +
           " at 1 (per voxel), dark red -> orange -> yellow -> white";
}

/// The camera sits at this fraction of Camera::framing's distance (which fits the bounding
/// sphere, leaving a box small in the image).
constexpr float kCameraZoom = 0.8f;

/// One camera, TF, lattice and opacity unit for all renderers of a case, from the ORIGINAL grid:
/// dt = longest extent / 1024 (Kinkelin 6.2), unit = the smallest voxel side (TF alpha per voxel).
VolumeRenderParams render_params(const Options& o, const DataCase& c, const volume::DensityGrid& g) {
    VolumeRenderParams p;
    p.width = o.width;
    p.height = o.height;
    Camera cam = Camera::framing(g.world_box(), vec3(0.4f, 0.3f, 1.0f));
    cam.eye = cam.target + (cam.eye - cam.target) * kCameraZoom;
    p.camera = cam.frame(o.width, o.height);
    p.tf = transfer_function(o, c).packed_rgba8();
    p.dt = default_dt(g.world_box());
    p.unit = std::min(g.spacing.x, std::min(g.spacing.y, g.spacing.z));
    p.shading = o.shading;
    return p;
}

// ---- building -------------------------------------------------------------------------------

/// An encoded default LoD and what it took to build it.
struct BuiltLod {
    std::vector<std::uint32_t> words;      ///< 8-byte nodes, 16-bit planes (Kinkelin's Table 1)
    std::vector<std::uint32_t> words_f32;  ///< 12-byte nodes, float planes (--float-nodes only)
    vec3 voxel_size{1.0f};  ///< spacing of the grid the BIH was built from: the gradients' unit
    BuildRow row;
};

/// The grid a factor's BIH is built from: the original or its trilinear resampling.
volume::DensityGrid source_grid(const volume::DensityGrid& g, float factor, ThreadPool& pool) {
    if (factor == 1.0f) return g;
    return volume::resample_trilinear(g, factor, pool);
}

/// Voxel cuboids, full BIH, default LoD and its encoding over `g` resampled by `factor`; with
/// `float_nodes` also the same LoD with exact float planes.
BuiltLod build_lod(const std::string& data, const volume::DensityGrid& g, float factor, bool float_nodes,
                   ThreadPool& pool) {
    BuiltLod out;
    BuildRow& r = out.row;
    r.data = data;
    r.factor = factor;
    r.original_voxels = g.values.size();
    auto t0 = std::chrono::steady_clock::now();
    std::vector<VoxelCuboid> cuboids;
    {
        volume::DensityGrid src = source_grid(g, factor, pool);
        r.dims = src.dims;
        out.voxel_size = src.spacing;
        cuboids = volume::voxel_cuboids(src, 0.1f, pool);
    }
    r.voxels_ms = ms_since(t0);
    r.elements = cuboids.size();
    if (cuboids.empty()) throw Error(r.name() + ": no voxel reaches density 0.1: nothing to build");
    bih::LodConfig lc;
    bih::Lod lod;
    {
        bih::FullBih full = bih::build_full(std::span<const VoxelCuboid>(cuboids), bih::Config{}, pool);
        r.build_ms = full.total_ms;
        r.full_nodes = full.tree.nodes.size();
        std::vector<VoxelCuboid>().swap(cuboids);
        lod = bih::extract_lod(full, lc);
    }
    r.lod_ms = lod.extract_ms;
    t0 = std::chrono::steady_clock::now();
    out.words = bih::encode_lod(lod, lc);
    r.encode_ms = ms_since(t0);
    r.lod_nodes = lod.tree.nodes.size();
    r.lod_depth = lod.stats.max_depth;
    r.lod_bytes = lod.node_bytes();
    r.encoded_bytes = out.words.size() * 4;
    if (float_nodes) {
        bih::EncodeConfig ec{bih::NodeFormat::Float32, bih::Layout::TreeChunks, lc.chunk_depth};
        out.words_f32 = bih::encode(lod.tree, std::span<const VoxelCuboid>(lod.leaves), VoxelPayload{}, ec);
    }
    return out;
}

// ---- images ---------------------------------------------------------------------------------

/// Writes DIR/volume_<case>_<renderer>_x<factor>.png (and the heat map) when --images is set.
class Images {
public:
    explicit Images(std::string dir) : dir_(std::move(dir)) {
        if (dir_.empty()) return;
#if !SYLVA_HAVE_OIIO
        throw Error("--images: this sylva-volume-bench was built without OpenImageIO");
#else
        std::error_code ec;
        std::filesystem::create_directories(dir_, ec);
        if (ec) throw Error("--images: cannot create " + dir_ + ": " + ec.message());
#endif
    }
    void frame(const std::string& data, const std::string& renderer, float factor, const Frame& f) const {
#if SYLVA_HAVE_OIIO
        if (!dir_.empty()) write_frame(path(data, renderer, factor), f, vec3(0.0f));
#else
        (void)data, (void)renderer, (void)factor, (void)f;
#endif
    }
    void heat(const std::string& data, float factor, const Frame& f) const {
#if SYLVA_HAVE_OIIO
        if (!dir_.empty()) write_heatmap(path(data, "heat", factor), f);
#else
        (void)data, (void)factor, (void)f;
#endif
    }

private:
    [[nodiscard]] std::string path(const std::string& data, const std::string& renderer, float factor) const {
        return (std::filesystem::path(dir_) / ("volume_" + data + "_" + renderer + "_x" + factor_text(factor) + ".png"))
            .string();
    }
    std::string dir_;
};

// ---- one case -------------------------------------------------------------------------------

/// Runs the reference and every factor of one data set; appends rows. Each factor is one race
/// per backend: the reference marcher and BIH-DVR over that factor's LoD, interleaved, so the
/// speed ratios compare renders taken under the same load.
class CaseRun {
public:
    CaseRun(const Options& o, Renderers& r, const Images& img, ThreadPool& pool)
        : o_(o), r_(r), img_(img), pool_(pool) {}

    void run(const DataCase& c, std::vector<BuildRow>& builds, std::vector<RenderRow>& renders) {
        volume::DensityGrid g = load(o_, c);
        std::printf("\n%s: %s voxels, spacing %g %g %g; TF %s\n", c.name.c_str(), dims_text(g.dims).c_str(),
                    double(g.spacing.x), double(g.spacing.y), double(g.spacing.z), describe_tf(o_, c).c_str());
        VolumeRenderParams p = render_params(o_, c, g);
        GridWords grid = GridWords::from(g);
        std::size_t ref_at = renders.size();
        renders.push_back(RenderRow::make(c.name, "reference", 1.0f, std::size_t{p.width} * p.height));
        std::vector<double> ref_ms[2];
        for (float f : o_.factors) {
            builds.push_back(BuildRow{});
            factor(c.name, g, grid, f, p, builds.back(), renders, ref_ms);
            if (f == o_.factors.front()) renders[ref_at] = reference_row(c.name, p);
        }
        RenderRow& ref = renders[ref_at];
        for (int b : {Cpu, Vulkan})
            if (r_.uses(b)) ref.ms[b] = median(ref_ms[b]);
        std::printf("  reference: %s ms cpu, %s ms vulkan (median of all its runs), %.1f samples/pixel\n",
                    num(ref.ms[Cpu], 1).c_str(), num(ref.ms[Vulkan], 1).c_str(), ref.mean_steps);
    }

private:
    /// The reference row from the first race's frames (its times are filled in at the end).
    RenderRow reference_row(const std::string& data, const VolumeRenderParams& p) {
        RenderRow row = RenderRow::make(data, "reference", 1.0f, std::size_t{p.width} * p.height);
        row.mean_steps = mean_steps(ref_[r_.first()], "reference");
        if (r_.uses(Cpu) && r_.uses(Vulkan)) row.parity = compare_frames(ref_[Cpu], ref_[Vulkan]).max_abs;
        img_.frame(data, "reference", 1.0f, ref_[r_.first()]);
        return row;
    }

    void factor(const std::string& data, const volume::DensityGrid& g, const GridWords& grid, float f,
                const VolumeRenderParams& p, BuildRow& build, std::vector<RenderRow>& renders,
                std::vector<double> (&ref_ms)[2]) {
        BuiltLod lod = build_lod(data, g, f, o_.float_nodes, pool_);
        build = lod.row;
        std::printf("  x%-4s grid %-12s %9zu elements, build %8.0f ms, LoD %7.0f KB", factor_text(f).c_str(),
                    dims_text(build.dims).c_str(), build.elements, build.build_ms, kb(double(build.lod_bytes)));
        std::vector<VoxelBihView> views{VoxelBihView{lod.words, {}, lod.voxel_size, g.world_box()}};
        if (!lod.words_f32.empty()) views.push_back(VoxelBihView{lod.words_f32, {}, lod.voxel_size, g.world_box()});
        const std::vector<VolumeMode> modes{VolumeMode::BihSingle, VolumeMode::BihMulti};
        std::vector<Timed> frames[2];
        for (int b : {Cpu, Vulkan}) {
            if (!r_.uses(b)) continue;
            frames[b] = r_.race(grid, views, modes, p, b, o_.runs);
            ref_ms[b].insert(ref_ms[b].end(), frames[b][0].ms.begin(), frames[b][0].ms.end());
            ref_[b] = frames[b][0].frame;
        }
        for (std::size_t i = 1; i < 1 + views.size() * modes.size(); ++i) {
            std::string name = std::string((i - 1) % 2 == 0 ? "single" : "multi") + (i > 2 ? "-f32" : "");
            renders.push_back(bih_row(data, f, name, frames, i));
            std::printf(" | %s %6.2f dB %7.1f ms", name.c_str(), renders.back().quality.psnr,
                        renders.back().ms[r_.first()]);
        }
        img_.heat(data, f, frames[r_.first()][1].frame);
        std::printf("\n");
        std::fflush(stdout);
    }

    /// The row of image `i` of a race (frames[backend][i]; image 0 is the reference).
    RenderRow bih_row(const std::string& data, float f, const std::string& name, const std::vector<Timed> (&frames)[2],
                      std::size_t i) {
        RenderRow row = RenderRow::make(data, name, f, std::size_t{o_.width} * o_.height);
        for (int b : {Cpu, Vulkan}) {
            if (!r_.uses(b)) continue;
            row.ms[b] = frames[b][i].median_ms;
            row.ref_ms[b] = frames[b][0].median_ms;
        }
        const Frame& img = frames[r_.first()][i].frame;
        row.mean_steps = mean_steps(img, data + " " + name + " x" + factor_text(f));
        row.has_quality = true;
        row.quality = compare_frames(ref_[r_.first()], img);
        if (r_.uses(Cpu) && r_.uses(Vulkan))
            row.parity = compare_frames(frames[Cpu][i].frame, frames[Vulkan][i].frame).max_abs;
        img_.frame(data, name, f, img);
        return row;
    }

    const Options& o_;
    Renderers& r_;
    const Images& img_;
    ThreadPool& pool_;
    Frame ref_[2];
};

// ---- the whole run --------------------------------------------------------------------------

/// JSON records of every row, with the paper's figures for the cases that ran.
std::vector<Record> records(const std::vector<BuildRow>& builds, const std::vector<RenderRow>& renders,
                            const std::vector<Record>& paper) {
    std::vector<Record> out;
    for (const BuildRow& b : builds) add_build_records(b, out);
    auto find = [&](const std::string& data, const std::string& renderer, float f) -> const RenderRow* {
        for (const RenderRow& r : renders)
            if (r.data == data && r.renderer == renderer && (renderer == "reference" || r.factor == f)) return &r;
        return nullptr;
    };
    for (const RenderRow& r : renders) add_render_records(r, find(r.data, r.renderer, 1.0f), out);
    out.insert(out.end(), paper.begin(), paper.end());
    return out;
}

/// The 1-minute load average (Linux), or "-": the timings share the machine with whatever runs.
std::string load_average() {
    std::ifstream f("/proc/loadavg");
    std::string one;
    return f >> one ? one : std::string("-");
}

void print_header(const Options& o, const Renderers& r) {
    std::printf("sylva-volume-bench: %ux%u pixels, %zu runs per image (medians), factors", o.width, o.height, o.runs);
    for (float f : o.factors) std::printf(" %s", factor_text(f).c_str());
    std::printf("\n  backends: %s; load average %s\n", r.describe().c_str(), load_average().c_str());
    std::printf("  shading %s; camera: looking at the grid's centre from direction (0.4, 0.3, 1), fov 40, at %g of\n"
                "  the bounding-sphere distance; lattice dt = longest world extent / 1024; TF alpha per smallest\n"
                "  voxel side; early stop at 0.99; images over black. Reference = marcher on the ORIGINAL grid.\n",
                o.shading ? "on" : "off (as Kinkelin's Fig. 5)", double(kCameraZoom));
}

int run(const Options& o) {
    for (const DataCase& c : selected_cases(o))  // fail before any work when a volume is missing
        if (!c.file.empty()) data_file(o, c);
    ThreadPool pool(o.threads);
    Renderers renderers(o.backend, pool);
    Images images(o.images);
    print_header(o, renderers);
    std::vector<BuildRow> builds;
    std::vector<RenderRow> renders;
    std::vector<std::string> names;
    CaseRun runner(o, renderers, images, pool);
    for (const DataCase& c : selected_cases(o)) {
        runner.run(c, builds, renders);
        names.push_back(c.name);
    }
    std::vector<Record> paper = paper_records(names);
    print_build_table(builds, paper);
    print_quality_table(renders);
    print_speed_table(renders);
    std::printf("  (load average at the end: %s)\n", load_average().c_str());
    std::vector<Record> rs = records(builds, renders, paper);
    if (!o.json.empty()) {
        write_json(o.json, rs);
        std::printf("\nsylva-volume-bench: %zu records written to %s\n", rs.size(), o.json.c_str());
    }
    return 0;
}

}  // namespace
}  // namespace volume_bench

int main(int argc, char** argv) {
    using namespace volume_bench;
    Options o;
    std::unique_ptr<CLI::App> app = make_app(o);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    try {
        return run(o);
    } catch (const std::exception& e) {
        std::cerr << "sylva-volume-bench: " << e.what() << "\n";
        return 1;
    }
}
