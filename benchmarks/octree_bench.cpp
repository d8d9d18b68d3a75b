// benchmarks/octree_bench.cpp -- sylva-octree-bench: Gobbetti et al.'s bricked octree against the
// reference marcher (issue 12's targets).
//
// For each data set (aneurism, bonsai, engine, lobster with spacing 1, 1, 1.4, ...; or the
// procedural Marschner-Lobb volume): builds the octree (--brick, border 2), renders one camera
// and transfer function with
//   * marcher       the reference ray marcher over the grid (1,024 steps along the longest axis),
//   * octree-full   DVR through the full-resolution cut (must equal the marcher bit for bit),
//   * octree-lod    DVR through the cut chosen for the view (--lod-pixels P, --cut-nodes N),
//   * iso-full / iso-lod   first hit of --iso through the full and the view's cut,
// each the median of --runs renders interleaved with the others (host threads), and reports
// pixels differing and PSNR against the marcher (the iso cut against the full iso image),
// rays/s and the speed-up over the marcher, build time, index and brick bytes, cut nodes.
// Output: a table on stdout and JSON records {case, impl, metric, value, unit} (--json).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <sylva/core/error.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/octants.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/transfer_function.hpp>

#include "bench.hpp"
#include "cli.hpp"

#ifndef SYLVA_OCTREE_BENCH_DATA
#define SYLVA_OCTREE_BENCH_DATA "../shared/data"
#endif

namespace {

using namespace sylva;

struct Options {
    std::string data = SYLVA_OCTREE_BENCH_DATA, json, only = "all";
    std::uint32_t width = 512, height = 512, brick = 32, cut_nodes = 1u << 20;
    std::size_t runs = 3, threads = 0;
    float lod_pixels = 1.0f, iso = 0.3f, max_tf_error = octree::CutConfig{}.max_tf_error;
    bool shading = false;
    std::string border = "zero", brick_format = "float32";
};

/// The command line, bound to `o`.
std::unique_ptr<CLI::App> make_app(Options& o) {
    auto app = std::make_unique<CLI::App>(
        "sylva-octree-bench: the bricked octree (Gobbetti et al.) against the reference marcher: the "
        "full-resolution cut's pixels differing (0 expected), the view cut's PSNR and rays/s against the marcher",
        "sylva-octree-bench");
    app->footer("Exit status: 0 on success, 1 on errors (a missing volume names its path), 2 on bad usage.");
    app->add_option("--data", o.data, "folder with the volumes")->type_name("DIR")->capture_default_str();
    app->add_option("--case", o.only,
                    "aneurism, bonsai, engine, lobster, all of them, or procedural (Marschner-Lobb, no data needed)")
        ->type_name("NAME")
        ->capture_default_str()
        ->check(CLI::IsMember({"aneurism", "bonsai", "engine", "lobster", "all", "procedural"}));
    bench_cli::add_size(*app, "--size", o.width, o.height, "image size");
    app->add_option("--runs", o.runs, "renders per impl, interleaved; medians are reported")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t{1}, std::size_t{100}));
    app->add_option("--threads", o.threads, "host threads (default: all)")
        ->type_name("N")
        ->check(CLI::Range(std::size_t{1}, std::size_t{1024}));
    app->add_option("--brick", o.brick, "brick size (voxels a side; border 2)")
        ->capture_default_str()
        ->check(CLI::IsMember({16u, 32u}));
    app->add_option("--lod-pixels", o.lod_pixels, "the view's cut refines while a node's voxel projects larger than P pixels")
        ->type_name("P")
        ->capture_default_str()
        ->check(bench_cli::number_in(1e-3, 1e4));
    app->add_option("--max-tf-error", o.max_tf_error,
                    "the TF-aware cut (octree-lod-tf*) refines nodes under the pixel size while their classified "
                    "samples may differ from their voxels' by more than this (octree/lod_error.hpp)")
        ->type_name("E")
        ->capture_default_str()
        ->check(bench_cli::number_in(0.0, 1.0));
    app->add_option("--cut-nodes", o.cut_nodes, "node budget of the view's cut")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(1u, 0xFFFFFFFFu));
    app->add_option("--iso", o.iso, "isovalue of the first-hit images (iso-full, iso-lod)")
        ->type_name("V")
        ->capture_default_str()
        ->check(bench_cli::number_in(0.0, 1.0));
    app->add_flag("--shading", o.shading, "Blinn-Phong shading from the gradient");
    app->add_option("--border", o.border, "what samples read outside the volume: zero (a constant 0) or clamp, for the "
                                          "marcher and the octree alike")
        ->type_name("MODE")
        ->capture_default_str()
        ->check(CLI::IsMember({"zero", "clamp"}));
    app->add_option("--brick-format", o.brick_format,
                    "how bricks store samples: float32, unorm16 or unorm8 (the uint8 volumes' voxels exactly)")
        ->type_name("FORMAT")
        ->capture_default_str()
        ->check(CLI::IsMember({"float32", "unorm16", "unorm8"}));
    app->add_option("--json", o.json, "write every figure as a JSON array of {case, impl, metric, value, unit}")
        ->type_name("FILE");
    return app;
}

struct DataCase {
    std::string name, file;
    vec3 spacing{1.0f};
    float alpha = 0.1f;
};

std::vector<DataCase> cases(const Options& o) {
    const std::vector<DataCase> real = {{"aneurism", "aneurism_256x256x256_uint8.raw", vec3(1.0f), 0.4f},
                                        {"bonsai", "bonsai_256x256x256_uint8.raw", vec3(1.0f), 0.1f},
                                        {"engine", "engine_256x256x128_uint8.raw", vec3(1.0f), 0.04f},
                                        {"lobster", "lobster_301x324x56_uint8.raw", vec3(1.0f, 1.0f, 1.4f), 0.15f}};
    if (o.only == "procedural") return {{"procedural", "", vec3(1.0f), 0.1f}};
    std::vector<DataCase> out;
    for (const DataCase& c : real)
        if (o.only == "all" || o.only == c.name) out.push_back(c);
    return out;
}

volume::DensityGrid load(const Options& o, const DataCase& c) {
    if (c.file.empty()) return volume::marschner_lobb({128, 128, 128});
    std::filesystem::path path = std::filesystem::path(o.data) / c.file;
    if (!std::filesystem::is_regular_file(path)) throw Error("volume " + path.string() + " not found (--data DIR)");
    return volume::normalize(volume::read_volume(path, c.spacing));
}

/// sylva-volume-bench's warm TF: transparent to 0.1, alpha rising to `a` at 1.
VolumeRenderParams params(const Options& o, const DataCase& c, const volume::DensityGrid& g) {
    VolumeRenderParams p;
    p.width = o.width;
    p.height = o.height;
    Camera cam = Camera::framing(g.world_box(), vec3(0.4f, 0.3f, 1.0f));
    cam.eye = cam.target + (cam.eye - cam.target) * 0.8f;
    p.camera = cam.frame(o.width, o.height);
    float a = c.alpha;
    p.tf = volume::TransferFunction({{0.1f, {0.55f, 0.10f, 0.05f, 0.0f}},
                                     {0.4f, {0.95f, 0.45f, 0.10f, a / 3.0f}},
                                     {0.7f, {1.00f, 0.85f, 0.35f, 2.0f * a / 3.0f}},
                                     {1.0f, {1.00f, 1.00f, 0.95f, a}}})
               .packed_rgba8();
    p.dt = default_dt(g.world_box());
    p.unit = std::min(g.spacing.x, std::min(g.spacing.y, g.spacing.z));
    p.shading = o.shading;
    p.iso = o.iso;
    return p;
}

struct Record {
    std::string case_name, impl, metric;
    double value;
    std::string unit;
};

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

/// Renders every image `runs` times in turn (after one untimed small render each); the last
/// frame of each and its median time.
template <class Render>
std::vector<std::pair<Frame, double>> race(Render&& render, std::size_t n, const VolumeRenderParams& p, std::size_t runs) {
    VolumeRenderParams warm = p;
    warm.width = warm.height = 8;
    for (std::size_t i = 0; i < n; ++i) render(i, warm);
    std::vector<std::pair<Frame, double>> out(n);
    std::vector<std::vector<double>> ms(n);
    for (std::size_t r = 0; r < runs; ++r)
        for (std::size_t i = 0; i < n; ++i) {
            out[i].first = render(i, p);
            ms[i].push_back(out[i].first.ms);
        }
    for (std::size_t i = 0; i < n; ++i) out[i].second = median(ms[i]);
    return out;
}

void run_case(const Options& o, const DataCase& c, ThreadPool& pool, std::vector<Record>& rec) {
    volume::DensityGrid g = load(o, c);
    VolumeRenderParams p = params(o, c, g);
    octree::Config cfg;
    cfg.brick_size = o.brick;
    cfg.format = octree::brick_format_from_name(o.brick_format);
    octree::Tree t = octree::build(g, pool, cfg);
    std::vector<std::uint32_t> full = octree::encode(t);
    std::vector<std::uint32_t> lod = full, lod_iso = full;
    const GridBorder border = o.border == "clamp" ? GridBorder::clamp() : GridBorder{};
    octree::Cut cut = select_octree_cut(full, p, {o.lod_pixels, o.cut_nodes}, false, border);
    octree::apply_cut(lod, cut);
    octree::Cut cut_iso = select_octree_cut(full, p, {o.lod_pixels, o.cut_nodes}, true, border);
    octree::apply_cut(lod_iso, cut_iso);
    // The TF-aware cut (octree/lod_error.hpp): the deviation tables once per octree.
    auto t_dev = std::chrono::steady_clock::now();
    octree::LodDeviation deviation = octree::lod_deviation(full, t.bricks, pool);
    double deviation_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_dev).count();
    octree::CutConfig tf_cfg{o.lod_pixels, o.cut_nodes, o.max_tf_error};
    octree::Cut cut_tf = select_octree_cut(full, p, tf_cfg, false, border, &deviation);
    std::vector<std::uint32_t> lod_tf = full;
    octree::apply_cut(lod_tf, cut_tf);
    GridWords gw = GridWords::from(g, border);
    // Octant masks (octree/octants.hpp): the ranges once per octree, the masks once per TF.
    auto t_oct = std::chrono::steady_clock::now();
    octree::OctantRanges oct_ranges = octree::octant_ranges(full, t.bricks, pool);
    double octant_ranges_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_oct).count();
    std::vector<std::uint32_t> octmask = octree::octant_masks(
        oct_ranges, tf_opacity_prefix(p.tf), border.mode == BorderMode::Constant ? std::optional<float>(border.value) : std::nullopt);
    const char* names[] = {"marcher", "octree-full", "octree-lod", "iso-full", "iso-lod", "octree-full-octants",
                           "octree-lod-octants", "octree-lod-tf", "octree-lod-tf-octants"};
    constexpr std::size_t kImpls = 9;
    auto render = [&](std::size_t i, const VolumeRenderParams& q) {
        switch (i) {
            case 0: return render_dvr_cpu(gw, q, pool);
            case 1: return render_octree_dvr_cpu(OctreeView{full, t.bricks, 0xFFFFFFFFu, {}, {}, border}, q, pool);
            case 2: return render_octree_dvr_cpu(OctreeView{lod, t.bricks, 0xFFFFFFFFu, {}, {}, border}, q, pool);
            case 3: return render_octree_iso_cpu(OctreeView{full, t.bricks, 0xFFFFFFFFu, {}, {}, border}, q, pool);
            case 4: return render_octree_iso_cpu(OctreeView{lod_iso, t.bricks, 0xFFFFFFFFu, {}, {}, border}, q, pool);
            case 5: return render_octree_dvr_cpu(OctreeView{full, t.bricks, 0xFFFFFFFFu, {}, octmask, border}, q, pool);
            case 7: return render_octree_dvr_cpu(OctreeView{lod_tf, t.bricks, 0xFFFFFFFFu, {}, {}, border}, q, pool);
            case 8: return render_octree_dvr_cpu(OctreeView{lod_tf, t.bricks, 0xFFFFFFFFu, {}, octmask, border}, q, pool);
            default: return render_octree_dvr_cpu(OctreeView{lod, t.bricks, 0xFFFFFFFFu, {}, octmask, border}, q, pool);
        }
    };
    auto res = race(render, kImpls, p, o.runs);
    double pixels = double(o.width) * o.height;
    auto add = [&](const std::string& impl, const std::string& metric, double v, const std::string& unit) {
        rec.push_back({c.name, impl, metric, v, unit});
    };
    add("octree", "build_ms", t.build_ms, "ms");
    add("octree", "octree_nodes", double(t.nodes.size()), "nodes");
    add("octree", "index_bytes", double(full.size() * 4), "bytes");
    add("octree", "brick_bytes", double(t.brick_bytes()), "bytes");
    add("octree", "octant_ranges_ms", octant_ranges_ms, "ms");
    add("octree-lod", "cut_nodes", cut.nodes, "nodes");
    add("octree-lod", "cut_leaves", cut.leaves, "nodes");
    add("octree", "lod_deviation_ms", deviation_ms, "ms");
    add("octree-lod-tf", "cut_nodes", cut_tf.nodes, "nodes");
    add("octree-lod-tf", "cut_leaves", cut_tf.leaves, "nodes");
    add("iso-lod", "cut_nodes", cut_iso.nodes, "nodes");
    for (std::size_t i = 0; i < kImpls; ++i) {
        add(names[i], "rays_per_s", pixels / (res[i].second / 1e3), "rays/s");
        add(names[i], "speedup_vs_marcher", res[0].second / res[i].second, "x");
        double steps = 0.0;
        for (std::uint32_t s : res[i].first.steps) steps += s;
        add(names[i], "samples_per_ray", steps / pixels, "samples");
    }
    for (std::size_t i : {1u, 2u, 5u, 6u, 7u, 8u}) {
        ImageDifference d = compare_frames(res[0].first, res[i].first);
        add(names[i], "pixels_differing_vs_marcher", double(d.pixels_differing), "pixels");
        add(names[i], "psnr_vs_marcher", std::isfinite(d.psnr) ? d.psnr : 999.0, "dB (999: identical)");
        add(names[i], "max_abs_vs_marcher", d.max_abs, "unorm");
    }
    ImageDifference di = compare_frames(res[3].first, res[4].first);
    add("iso-lod", "psnr_vs_iso_full", std::isfinite(di.psnr) ? di.psnr : 999.0, "dB (999: identical)");
    add("iso-lod", "pixels_differing_vs_iso_full", double(di.pixels_differing), "pixels");
}

/// The records as JSON through the benchmarks' shared writer (report.cpp); a value that is not
/// finite is written as 0, as before.
void write_json(const std::string& path, const std::vector<Record>& rs) {
    bench::Report report;
    for (const Record& r : rs)
        report.add(r.case_name, r.impl, r.metric, std::isfinite(r.value) ? r.value : 0.0, r.unit);
    report.write_json(path);
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    std::unique_ptr<CLI::App> app = make_app(o);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    try {
        ThreadPool pool(o.threads);
        std::vector<Record> rec;
        std::cout << "sylva-octree-bench: " << o.width << "x" << o.height << ", brick " << o.brick << ", --lod-pixels "
                  << o.lod_pixels << ", cut budget " << o.cut_nodes << " nodes, iso " << o.iso << ", "
                  << pool.concurrency() << " host threads, median of " << o.runs << " runs\n";
        for (const DataCase& c : cases(o)) {
            std::size_t from = rec.size();
            run_case(o, c, pool, rec);
            for (std::size_t i = from; i < rec.size(); ++i)
                std::printf("%-11s %-12s %-30s %14.6g %s\n", rec[i].case_name.c_str(), rec[i].impl.c_str(),
                            rec[i].metric.c_str(), rec[i].value, rec[i].unit.c_str());
            std::fflush(stdout);
        }
        if (!o.json.empty()) {
            write_json(o.json, rec);
            std::cout << rec.size() << " records written to " << o.json << "\n";
        }
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "sylva-octree-bench: " << e.what() << "\n";
        return 1;
    }
}
