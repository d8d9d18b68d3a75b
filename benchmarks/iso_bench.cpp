// sylva-iso-bench: exact isosurface ray casting with Wald et al.'s implicit min/max kd-tree
// against the reference cell DDA, side by side in one run, on the same rays (issue 11):
//   * memory (Table III): the index against the data, for the default (bricked) tree and the
//     paper's slim tree without leaves;
//   * speed (Fig. 7, Table I): rays/s, traversal steps, cells intersected and hits per ray, at
//     one camera framing the volume, medians of --runs renders after a warm-up;
//   * 2x2 ray packets through the default tree (Wald 4.3; Table I's "SIMD" steps);
//   * the images of the tree, its packets and the DDA must be identical (checked every case).
// Peer on the same camera, rays, size and isovalue, on the same thread pool:
//   * bih-iso: Kinkelin's voxel BIH with its level of detail in VolumeMode::BihIso (first sample
//     reaching the isovalue in a leaf's linear density, node-range iso culling), built and
//     rendered with sylva-render's defaults (threshold 0.1, LoD depth 64 / density 0.75 /
//     std-dev 0.01, chunk depth 2, dt = longest extent / 1024, shading); build_ms is the wall time
//     of cuboids + BIH + LoD + encoding + node ranges, index_bytes the BIH and range words.
//     Sampled, not exact: pixels_differing_from_tree counts pixels whose hit / miss differs
//     from the implicit kd-tree's (reported, never fatal).
// Cases: the aneurism and bonsai of ../shared/data (8-bit), Marschner-Lobb at 32^3 .. 512^3
// (float32 grids, densities in [0, 1]). JSON records {"case", "impl", "metric", "value", "unit"}.
//   sylva-iso-bench [--cases aneurism,bonsai,ml32,ml64,ml128,ml256,ml512] [--size N] [--runs R]
//                   [--iso V] [--json FILE] [--threads T]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/render/iso.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read.hpp>
#include <sylva/volume/transfer_function.hpp>
#include <sylva/volume/voxels.hpp>


#include "cli.hpp"

using namespace sylva;

namespace {

struct Options {
    std::vector<std::string> cases{"aneurism", "bonsai", "ml32", "ml64", "ml128", "ml256"};
    std::uint32_t size = 512;
    std::size_t runs = 5;
    float iso = 0.3f;
    std::string json;
    std::uint32_t threads = 0;
};

struct Record {
    std::string c, impl, metric;
    double value;
    std::string unit;
};

const char* usage() {
    return "usage: sylva-iso-bench [--cases aneurism,bonsai,ml32,ml64,ml128,ml256,ml512] [--size N] [--runs R]\n"
           "                       [--iso V] [--json FILE] [--threads T]\n";
}

Options parse(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--cases") {
            o.cases.clear();
            std::stringstream ss(bench_cli::value_of(i, argc, argv));
            for (std::string c; std::getline(ss, c, ',');)
                o.cases.push_back(bench_cli::one_of("--cases", c, {"aneurism", "bonsai", "ml32", "ml64", "ml128", "ml256", "ml512"}));
        } else if (a == "--size") {
            o.size = static_cast<std::uint32_t>(bench_cli::parse_count(a, bench_cli::value_of(i, argc, argv), 4096));
        } else if (a == "--runs") {
            o.runs = bench_cli::parse_count(a, bench_cli::value_of(i, argc, argv), 1000);
        } else if (a == "--iso") {
            std::string v = bench_cli::value_of(i, argc, argv);
            char* end = nullptr;
            o.iso = std::strtof(v.c_str(), &end);
            if (v.empty() || *end != '\0' || !(o.iso >= 0.0f && o.iso <= 1.0f))
                throw bench_cli::UsageError("--iso: '" + v + "' is not a density in [0, 1]");
        } else if (a == "--json") {
            o.json = bench_cli::value_of(i, argc, argv);
        } else if (a == "--threads") {
            o.threads = static_cast<std::uint32_t>(bench_cli::parse_count(a, bench_cli::value_of(i, argc, argv), 1024));
        } else {
            throw bench_cli::UsageError("unknown option '" + a + "'");
        }
    }
    return o;
}

/// The density grid of a case; nullopt (with a message) when a data file is missing.
std::optional<volume::DensityGrid> grid_of(const std::string& c) {
    if (c.rfind("ml", 0) == 0) {
        std::uint32_t n = static_cast<std::uint32_t>(std::stoul(c.substr(2)));
        return volume::marschner_lobb({n, n, n});
    }
    std::string path = std::string(SYLVA_ISO_BENCH_DATA) + "/" + c + "_256x256x256_uint8.raw";
    try {
        return volume::normalize(volume::read_volume(path));
    } catch (const Error& e) {
        std::cerr << "sylva-iso-bench: " << e.what() << " (case left out)\n";
        return std::nullopt;
    }
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

/// Renders `runs` frames (after one warm-up) with walker w; fills the rays/s median and the
/// per-ray counts; returns the last frame.
Frame measure(const std::vector<std::uint32_t>& words, const GridWords& gw, IsoRenderParams p, IsoWalker w,
              std::size_t runs, ThreadPool& pool, const std::string& c, const std::string& impl,
              std::vector<Record>& out, bool packets = false) {
    p.walker = w;
    IsoCounters n;
    auto render = [&] {
        return packets ? render_iso_cpu_packets(words, gw, p, pool, &n) : render_iso_cpu(words, gw, p, pool, &n);
    };
    Frame f = render();
    std::vector<double> ms;
    for (std::size_t r = 0; r < runs; ++r) {
        f = render();
        ms.push_back(f.ms);
    }
    double rays = double(p.width) * p.height, med = median(ms);
    out.push_back({c, impl, "rays_per_s", rays / (med / 1000.0), "rays/s"});
    out.push_back({c, impl, "frame_ms", med, "ms"});
    out.push_back({c, impl, "steps_per_ray", double(n.steps) / rays, "steps"});
    out.push_back({c, impl, "cells_per_ray", double(n.cells) / rays, "cells"});
    out.push_back({c, impl, "hits", double(n.hits), "hits"});
    if (packets) out.push_back({c, impl, "active_rays_per_step", double(n.lane_steps) / double(n.steps), "rays"});
    return f;
}

/// Pixels whose hit / miss (opacity > 0) differs between a and b.
std::size_t hit_differences(const Frame& a, const Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size() && i < b.rgba.size(); ++i) n += (a.rgba[i].w > 0.0f) != (b.rgba[i].w > 0.0f);
    return n;
}

/// Kinkelin's voxel BIH in iso mode, as sylva-render --mode iso builds and renders it by default.
void run_bih_iso(const volume::DensityGrid& g, const IsoRenderParams& ip, const Frame& tree, std::size_t runs,
                 ThreadPool& pool, const std::string& c, std::vector<Record>& out) {
    const std::string impl = "bih-iso";
    const float iso = ip.isos.front().value;
    auto t0 = std::chrono::steady_clock::now();
    // sylva-render's --threshold 0.1 (lowered to the isovalue below it, so the surface has voxels)
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, std::min(0.1f, iso), pool);
    if (cuboids.empty()) {
        std::cerr << "sylva-iso-bench: " << c << ": no voxel reaches the BIH threshold (bih-iso left out)\n";
        return;
    }
    bih::FullBih full = bih::build_full(std::span<const VoxelCuboid>(cuboids), bih::Config{}, pool);
    bih::LodConfig lc{64, 0.75f, 0.01f, 2};  // sylva-render's --lod-depth, --lod-density, --lod-stddev, --chunk-depth
    bih::Lod lod = bih::extract_lod(full, lc);
    std::vector<std::uint32_t> words = bih::encode_lod(lod, lc), ranges = bih::encode_node_ranges(lod, lc);
    double build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    VolumeRenderParams p;  // sylva-render's defaults for --mode iso
    p.camera = ip.camera;
    p.width = ip.width;
    p.height = ip.height;
    p.tf = volume::TransferFunction::ct_bone_tissue().packed_rgba8();
    vec3 e = g.world_box().extent();
    p.dt = std::max(e.x, std::max(e.y, e.z)) / 1024.0f;  // --steps 1024
    p.unit = std::min(g.spacing.x, std::min(g.spacing.y, g.spacing.z));
    p.shading = true;
    p.alpha_stop = 0.99f;
    p.iso = iso;
    p.mode = VolumeMode::BihIso;
    p.iso_culling = true;
    VoxelBihView view{words, ranges, g.spacing, g.world_box()};
    Frame f = render_bih_dvr_cpu(view, p, pool);  // warm-up
    std::vector<double> ms;
    for (std::size_t r = 0; r < runs; ++r) {
        f = render_bih_dvr_cpu(view, p, pool);
        ms.push_back(f.ms);
    }
    double rays = double(p.width) * p.height, med = median(ms);
    std::size_t hits = 0;
    for (const vec4& px : f.rgba) hits += px.w > 0.0f;
    out.push_back({c, impl, "build_ms", build_ms, "ms"});
    out.push_back({c, impl, "index_bytes", double((words.size() + ranges.size()) * 4), "bytes"});
    out.push_back({c, impl, "rays_per_s", rays / (med / 1000.0), "rays/s"});
    out.push_back({c, impl, "frame_ms", med, "ms"});
    out.push_back({c, impl, "hits", double(hits), "hits"});
    out.push_back({c, impl, "pixels_differing_from_tree", double(hit_differences(f, tree)), "pixels"});
}


void run_case(const std::string& c, const Options& o, ThreadPool& pool, std::vector<Record>& out) {
    std::optional<volume::DensityGrid> g = grid_of(c);
    if (!g) return;
    std::size_t data_bytes = c.rfind("ml", 0) == 0 ? g->values.size() * 2 : g->values.size();  // ML: 16-bit, as Table III
    GridWords gw = GridWords::from(*g);
    IsoRenderParams p;
    p.width = p.height = o.size;
    p.camera = Camera::framing(g->world_box(), vec3(0.4f, 0.3f, 1.0f)).frame(o.size, o.size);
    p.isos = {{o.iso, vec4(0.93f, 0.86f, 0.75f, 1.0f)}};
    Frame images[2];
    int k = 0;
    for (std::uint32_t bricks : {ikd::Config{}.brick_levels, 0u}) {
        std::string impl = bricks ? "implicit-kd" : "implicit-kd-slim";
        ikd::Tree t = ikd::build(*g, pool, ikd::Config{bricks});
        std::vector<std::uint32_t> words = ikd::encode(t);
        out.push_back({c, impl, "build_ms", t.build_ms, "ms"});
        out.push_back({c, impl, "index_bytes", double(words.size() * 4), "bytes"});
        out.push_back({c, impl, "index_per_data", double(words.size() * 4) / double(data_bytes), "x"});
        images[k++] = measure(words, gw, p, IsoWalker::Tree, o.runs, pool, c, impl, out);
        if (bricks != 0) {  // 2x2 packets (Wald 4.3, Table I): the same image in fewer steps
            Frame pk = measure(words, gw, p, IsoWalker::Tree, o.runs, pool, c, impl + "-packet", out, true);
            bool same = std::memcmp(pk.rgba.data(), images[0].rgba.data(), pk.rgba.size() * sizeof(vec4)) == 0;
            out.push_back({c, impl + "-packet", "image_equals_single", same ? 1.0 : 0.0, "bool"});
            if (!same) std::cerr << "sylva-iso-bench: " << c << ": the packets' image differs from single rays'\n";
        }
        if (bricks == 0) {
            Frame dda = measure(words, gw, p, IsoWalker::Dda, o.runs, pool, c, "dda", out);
            bool same = dda.rgba.size() == images[0].rgba.size() &&
                        std::memcmp(dda.rgba.data(), images[0].rgba.data(), dda.rgba.size() * sizeof(vec4)) == 0;
            out.push_back({c, "dda", "image_equals_tree", same ? 1.0 : 0.0, "bool"});
            if (!same) std::cerr << "sylva-iso-bench: " << c << ": the DDA's image differs from the tree's\n";
        }
    }
    run_bih_iso(*g, p, images[0], o.runs, pool, c, out);
    out.push_back({c, "data", "data_bytes", double(data_bytes), "bytes"});
}

void print(const std::vector<Record>& rs) {
    std::printf("%-10s %-18s %-26s %14s %s\n", "case", "impl", "metric", "value", "unit");
    for (const Record& r : rs) std::printf("%-10s %-18s %-26s %14.4g %s\n", r.c.c_str(), r.impl.c_str(), r.metric.c_str(), r.value, r.unit.c_str());
}

void write_json(const std::string& path, const std::vector<Record>& rs) {
    std::ofstream f(path);
    f << "[\n";
    for (std::size_t i = 0; i < rs.size(); ++i)
        f << "  {\"case\": \"" << rs[i].c << "\", \"impl\": \"" << rs[i].impl << "\", \"metric\": \"" << rs[i].metric
          << "\", \"value\": " << rs[i].value << ", \"unit\": \"" << rs[i].unit << "\"}" << (i + 1 < rs.size() ? "," : "") << "\n";
    f << "]\n";
    if (!f) throw Error("sylva-iso-bench: cannot write " + path);
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    try {
        o = parse(argc, argv);
    } catch (const bench_cli::UsageError& e) {
        std::cerr << "sylva-iso-bench: " << e.what() << "\n" << usage();
        return 2;
    }
    try {
        ThreadPool pool(o.threads);
        std::vector<Record> records;
        for (const std::string& c : o.cases) run_case(c, o, pool, records);
        print(records);
        if (!o.json.empty()) write_json(o.json, records);
        for (const Record& r : records)
            if ((r.metric == "image_equals_tree" || r.metric == "image_equals_single") && r.value != 1.0) return 1;
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "sylva-iso-bench: " << e.what() << "\n";
        return 1;
    }
}
