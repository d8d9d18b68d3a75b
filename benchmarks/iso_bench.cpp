// sylva-iso-bench: exact isosurface ray casting with Wald et al.'s implicit min/max kd-tree
// against the reference cell DDA, side by side in one run, on the same rays (issue 11):
//   * memory (Table III): the index against the data, for the default (bricked) tree and the
//     paper's slim tree without leaves;
//   * speed (Fig. 7, Table I): rays/s, traversal steps, cells intersected and hits per ray, at
//     one camera framing the volume, medians of --runs frames after a cold one; the impls of a
//     case take turns frame by frame (round robin), so a change of load on a shared machine
//     falls on all of them alike and their ratios hold;
//   * 2x2 ray packets through the default tree (Wald 4.3; Table I's "SIMD" steps);
//   * a second tree, by default implicit-kd-b6 (bricks of 6 unstored levels, ~4^3 cells, a
//     quarter of the default's index; --alt-bricks N --alt-bits 8|16 pick another, named
//     implicit-kd-bN[-u16]), for the memory / speed trade-offs of ikd::Config;
//   * cold and steady state: build_ms is the first build of the tree in the process (its
//     allocations touch fresh pages), build_ms_again a second build of the same tree (the
//     allocator's pages are warm); first_frame_ms is the first frame of an impl (frame buffers
//     and the index touched for the first time), frame_ms the median of the --runs frames after.
//     A machine started minutes ago pays more for first touches than a process can show (its
//     hypervisor maps pages on first use), so the cold figures here are a lower bound;
//   * the integer volumes also read natively (GridWords::native, 1 or 2 bytes a sample,
//     normalised on the fly to the same densities; rows *-u8grid for the 8-bit files, *-u16grid
//     for Marschner-Lobb: the default tree, its packets, the DDA), with grid_bytes of the float32
//     copy and of the integer grid;
//   * the images of the tree, its packets and the DDA must be identical (checked every case);
//   * --drop A,B (instead of --cases): Fig. 7's drop in rays/s from Marschner-Lobb case A to B
//     (e.g. ml32,ml512) for single rays and packets of 8 over the float32 and uint16 grids, the
//     two sizes' frames alternating round by round (run_drop), as the median, min and max of the
//     rounds' ratios. A ratio across two cases otherwise compares frames taken seconds apart.
// Peers on the same camera, rays, size and isovalue, on the same thread pool (rows as
// render_iso_cpu splits them):
//   * nanovdb-hdda (when NanoVDB was found at configure time, SYLVA_ISO_BENCH_NANOVDB): a NanoVDB
//     float grid of the same densities (GridBuilder, header only), walked with NanoVDB's
//     hierarchical DDA (HDDA + ReadAccessor::getDim) down to voxels; each active voxel i is the
//     cell i..i+1, whose 8 corners come from the ReadAccessor and whose hit is sylva's exact one
//     (iso_cell.h, shaded by iso_render.h), so the image is compared with the tree's pixel for
//     pixel (image_equals_tree, else pixels_differing; a difference is reported, not fatal, while
//     it stays under 0.1% of the pixels). Active voxels: every voxel whose cell (it and its +1
//     neighbours) has a corner off the background 0, i.e. the non-zero voxels dilated by one
//     towards lower indices: exactly the cells that can hold an isovalue != 0, for any such
//     isovalue (all voxels when the isovalue is 0). index_bytes: the NanoVDB grid buffer.
//   * bih-iso: Kinkelin's voxel BIH with its level of detail in VolumeMode::BihIso (first sample
//     reaching the isovalue in a leaf's linear density, node-range iso culling), built and
//     rendered with sylva-render's defaults (threshold 0.1, LoD depth 64 / density 0.75 /
//     std-dev 0.01, chunk depth 2, dt = longest extent / 1024, shading); build_ms is the wall time
//     of cuboids + BIH + LoD + encoding + node ranges, index_bytes the BIH and range words.
//     Sampled, not exact: pixels_differing_from_tree counts pixels whose hit / miss differs
//     from the implicit kd-tree's (reported, never fatal).
// Cases: the aneurism and bonsai of ../shared/data (8-bit), Marschner-Lobb at 32^3 .. 512^3 as
// 16-bit data, the paper's (volume::marschner_lobb's densities rounded to unorm16; before
// 2026-12-07 the float32 densities themselves). Every walker reads the float32 densities
// normalised from the integer data unless its row says *-u8grid / *-u16grid.
// JSON records {"case", "impl", "metric", "value", "unit"}.
//   sylva-iso-bench [--cases aneurism,bonsai,ml32,ml64,ml128,ml256,ml512,ml1024] [--size N] [--runs R]
//                   [--iso V] [--json FILE] [--threads T] [--no-peers] [--alt-bricks N] [--alt-bits 8|16]
//   sylva-iso-bench --drop ml32,ml512 [--size N] [--runs R] [--iso V] [--json FILE] [--threads T]
// --no-peers leaves out nanovdb-hdda and bih-iso (whose builds dominate the run at ML 512^3).
// ml1024 needs more than 24 GB even with --no-peers (the float32 grid, its GridWords copy, the
// slim tree's 4 GB of nodes and the build's level temporaries): on the project's 24 GB machines
// it was stopped at 24 GB resident before its first frame.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>
#include <iostream>
#include <optional>
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

#ifdef SYLVA_ISO_BENCH_NANOVDB
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/HDDA.h>
#include <nanovdb/util/Ray.h>
#endif

#include "bench.hpp"
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
    bool peers = true;
    std::uint32_t alt_bricks = 6;  ///< the second tree: brick levels ...
    std::uint32_t alt_bits = 8;    ///< ... and node bits
    std::vector<std::string> drop;  ///< --drop A,B: Fig. 7's drop from ML case A to B, side by side
};

struct Record {
    std::string c, impl, metric;
    double value;
    std::string unit;
};

/// The command line, bound to `o`.
std::unique_ptr<CLI::App> make_app(Options& o) {
    auto app = std::make_unique<CLI::App>(
        "sylva-iso-bench: exact isosurfaces through Wald's implicit kd-tree against the reference cell DDA on "
        "the same rays (memory, rays/s, steps), with NanoVDB's HDDA and the voxel BIH as peers",
        "sylva-iso-bench");
    app->footer(
        "Cases: aneurism and bonsai (../shared/data, 8-bit), mlN: Marschner-Lobb at N^3 (16-bit data,\n"
        "also read as float32).\n"
        "ml1024 needs more than 24 GB even with --no-peers. The images of the tree, its packets and\n"
        "the DDA must be identical; a peer's may differ on up to 0.1% of the pixels.\n"
        "Exit status: 0 on success, 1 on errors or differing images, 2 on bad usage.");
    app->add_option("--cases", o.cases, "comma-separated cases")
        ->type_name("LIST")
        ->capture_default_str()
        ->delimiter(',')
        ->check(CLI::IsMember({"aneurism", "bonsai", "ml32", "ml64", "ml128", "ml256", "ml512", "ml1024"}));
    app->add_option("--size", o.size, "image width and height in pixels")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(1u, 4096u));
    app->add_option("--runs", o.runs, "timed frames per impl after a cold one; medians are reported")
        ->type_name("R")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t{1}, std::size_t{1000}));
    app->add_option("--iso", o.iso, "isovalue, a density in [0, 1]")
        ->type_name("V")
        ->capture_default_str()
        ->check(bench_cli::number_in(0.0, 1.0));
    app->add_option("--json", o.json, "write every figure as a JSON array of {case, impl, metric, value, unit}")
        ->type_name("FILE");
    app->add_option("--threads", o.threads, "worker threads (default: hardware concurrency)")
        ->type_name("T")
        ->check(CLI::Range(1u, 1024u));
    app->add_option("--alt-bricks", o.alt_bricks, "brick levels of the second tree (implicit-kd-bN[-u16])")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(0u, 12u));
    app->add_option("--alt-bits", o.alt_bits, "node bits of the second tree")
        ->type_name("8|16")
        ->capture_default_str()
        ->check(CLI::IsMember({8u, 16u}));
    app->add_option("--drop", o.drop,
                    "two Marschner-Lobb cases, e.g. ml32,ml512: render them in alternation, frame by frame, "
                    "and report each walker's drop in rays/s from the first to the second (Fig. 7) as the "
                    "median of the rounds' ratios; runs instead of --cases")
        ->type_name("A,B")
        ->delimiter(',')
        ->expected(2)
        ->check(CLI::IsMember({"ml32", "ml64", "ml128", "ml256", "ml512", "ml1024"}));
    app->add_flag_callback("--no-peers", [&o] { o.peers = false; },
                           "leave out nanovdb-hdda and bih-iso (their builds dominate the run at ML 512^3)");
    return app;
}

/// A case's density grid and the integer volume it was normalised from (rendered natively
/// too): uint8 for the files, uint16 for Marschner-Lobb.
struct CaseData {
    volume::DensityGrid grid;
    std::optional<volume::Volume> raw;
};

/// Marschner-Lobb at n^3 as 16-bit data, the paper's (Wald et al. 5.2 assume 16-bit densities,
/// Table III lists ML as 16-bit): volume::marschner_lobb's densities rounded to unorm16, value
/// range 0..65535.
volume::Volume marschner_lobb_u16(std::uint32_t n) {
    volume::DensityGrid g = volume::marschner_lobb({n, n, n});
    volume::Volume v;
    v.type = volume::ScalarType::U16;
    v.dims = g.dims;
    v.spacing = g.spacing;
    v.bytes.resize(g.values.size() * 2);
    for (std::size_t i = 0; i < g.values.size(); ++i) {
        auto q = static_cast<std::uint16_t>(std::lround(std::clamp(g.values[i], 0.0f, 1.0f) * 65535.0f));
        std::memcpy(v.bytes.data() + 2 * i, &q, 2);
    }
    v.range_lo = 0.0f;
    v.range_hi = 65535.0f;
    v.range_source = volume::RangeSource::Type;
    return v;
}

/// The data of a case; nullopt (with a message) when a data file is missing.
std::optional<CaseData> grid_of(const std::string& c) {
    if (c.rfind("ml", 0) == 0) {
        volume::Volume v = marschner_lobb_u16(static_cast<std::uint32_t>(std::stoul(c.substr(2))));
        volume::DensityGrid g = volume::normalize(v);
        return CaseData{std::move(g), std::move(v)};
    }
    std::string path = std::string(SYLVA_ISO_BENCH_DATA) + "/" + c + "_256x256x256_uint8.raw";
    try {
        volume::Volume v = volume::read_volume(path);
        volume::DensityGrid g = volume::normalize(v);
        return CaseData{std::move(g), std::move(v)};
    } catch (const Error& e) {
        std::cerr << "sylva-iso-bench: " << e.what() << " (case left out)\n";
        return std::nullopt;
    }
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

/// One impl's renderer in the round-robin timing of a case: render() draws a frame and fills
/// `n` (counters of the last frame); `packets` adds Table I's active rays per step.
struct Contender {
    std::string impl;
    std::function<Frame(IsoCounters&)> render;
    bool packets = false;
    IsoCounters n{};
    Frame last{};
    double first_ms = 0.0;
    std::vector<double> ms{};
};

/// Times the contenders side by side: one cold frame each, then `runs` rounds in which every
/// contender renders one frame in turn, so a change of load on the machine falls on all of them
/// alike; records the median frame (rays/s) and the counters of each.
void time_round_robin(std::vector<Contender>& cs, std::size_t runs, const IsoRenderParams& p, const std::string& c,
                      std::vector<Record>& out) {
    for (Contender& k : cs) {
        k.last = k.render(k.n);
        k.first_ms = k.last.ms;
    }
    for (std::size_t r = 0; r < runs; ++r)
        for (Contender& k : cs) {
            k.last = k.render(k.n);
            k.ms.push_back(k.last.ms);
        }
    double rays = double(p.width) * p.height;
    for (Contender& k : cs) {
        double med = median(k.ms);
        out.push_back({c, k.impl, "first_frame_ms", k.first_ms, "ms"});
        out.push_back({c, k.impl, "rays_per_s", rays / (med / 1000.0), "rays/s"});
        out.push_back({c, k.impl, "frame_ms", med, "ms"});
        out.push_back({c, k.impl, "steps_per_ray", double(k.n.steps) / rays, "steps"});
        out.push_back({c, k.impl, "cells_per_ray", double(k.n.cells) / rays, "cells"});
        out.push_back({c, k.impl, "hits", double(k.n.hits), "hits"});
        if (k.packets)
            out.push_back({c, k.impl, "active_rays_per_step", double(k.n.lane_steps) / double(k.n.steps), "rays"});
    }
}

/// A contender rendering through render_iso_cpu (walker w; lanes 0) or its packet twin with
/// packets of `lanes` (4 or 8) rays.
Contender iso_contender(std::string impl, const std::vector<std::uint32_t>& words, const GridWords& gw,
                        IsoRenderParams p, IsoWalker w, ThreadPool& pool, int lanes = 0) {
    p.walker = w;
    Contender k;
    k.impl = std::move(impl);
    k.packets = lanes != 0;
    PacketLanes width = lanes == 16 ? PacketLanes::Sixteen : lanes == 8 ? PacketLanes::Eight : PacketLanes::Four;
    k.render = [&words, &gw, p, &pool, lanes, width](IsoCounters& n) {
        return lanes != 0 ? render_iso_cpu_packets(words, gw, p, pool, &n, width) : render_iso_cpu(words, gw, p, pool, &n);
    };
    return k;
}

/// Pixels whose hit / miss (opacity > 0) differs between a and b.
std::size_t hit_differences(const Frame& a, const Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size() && i < b.rgba.size(); ++i) n += (a.rgba[i].w > 0.0f) != (b.rgba[i].w > 0.0f);
    return n;
}

/// Kinkelin's voxel BIH in iso mode, as sylva-render --mode iso builds and renders it by default:
/// built here (its build records pushed), rendered as a contender; nullopt when no voxel reaches
/// the threshold. `store` keeps the encoding alive while the contender runs.
struct BihIsoIndex {
    std::vector<std::uint32_t> words, ranges;
    VolumeRenderParams p;
    VoxelBihView view;
};
std::optional<Contender> bih_iso_contender(const volume::DensityGrid& g, const IsoRenderParams& ip, ThreadPool& pool,
                                           const std::string& c, std::unique_ptr<BihIsoIndex>& store,
                                           std::vector<Record>& out) {
    const std::string impl = "bih-iso";
    const float iso = ip.isos.front().value;
    auto t0 = std::chrono::steady_clock::now();
    // sylva-render's --threshold 0.1 (lowered to the isovalue below it, so the surface has voxels)
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, std::min(0.1f, iso), pool);
    if (cuboids.empty()) {
        std::cerr << "sylva-iso-bench: " << c << ": no voxel reaches the BIH threshold (bih-iso left out)\n";
        return std::nullopt;
    }
    bih::FullBih full = bih::build_full(std::span<const VoxelCuboid>(cuboids), bih::Config{}, pool);
    bih::LodConfig lc{64, 0.75f, 0.01f, 2};  // sylva-render's --lod-depth, --lod-density, --lod-stddev, --chunk-depth
    bih::Lod lod = bih::extract_lod(full, lc);
    store = std::make_unique<BihIsoIndex>();
    store->words = bih::encode_lod(lod, lc);
    store->ranges = bih::encode_node_ranges(lod, lc);
    double build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    VolumeRenderParams& p = store->p;  // sylva-render's defaults for --mode iso
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
    store->view = VoxelBihView{store->words, store->ranges, g.spacing, g.world_box()};
    out.push_back({c, impl, "build_ms", build_ms, "ms"});
    out.push_back({c, impl, "index_bytes", double((store->words.size() + store->ranges.size()) * 4), "bytes"});
    Contender k;
    k.impl = impl;
    BihIsoIndex* ix = store.get();
    k.render = [ix, &pool](IsoCounters& n) {
        Frame f = render_bih_dvr_cpu(ix->view, ix->p, pool);
        n = IsoCounters{};
        for (const vec4& px : f.rgba) n.hits += px.w > 0.0f;  // pixels with a hit
        return f;
    };
    return k;
}

#ifdef SYLVA_ISO_BENCH_NANOVDB
/// Pixels whose colour differs bit for bit.
std::size_t pixel_differences(const Frame& a, const Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size() && i < b.rgba.size(); ++i)
        n += std::memcmp(&a.rgba[i], &b.rgba[i], sizeof(vec4)) != 0;
    return n;
}

/// A NanoVDB float grid of g's densities, index space = sylva's cell space (voxel size 1, origin
/// 0: sample (i, j, k) at index (i, j, k), so voxel i's HDDA box [i, i + 1] is sylva's cell i).
/// Active: the voxels whose cell has a corner off the background 0 (see the top; all when
/// `iso` is 0); inactive voxels are background (0) and not stored.
nanovdb::GridHandle<nanovdb::HostBuffer> nanovdb_grid(const volume::DensityGrid& g, float iso) {
    const volume::Dims n = g.dims;
    auto at = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) { return std::size_t{x} + std::size_t{n.x} * (y + std::size_t{n.y} * z); };
    // off[i]: voxel i or one of its +1 neighbours (the cell's other corners) is not 0, or iso is 0
    std::vector<std::uint8_t> off(g.values.size(), 0);
    for (std::size_t i = 0; i < off.size(); ++i) off[i] = g.values[i] != 0.0f || iso == 0.0f;
    for (int axis = 0; axis < 3; ++axis)  // dilate towards lower indices, one axis at a time (separable)
        for (std::uint32_t z = 0; z < n.z; ++z)
            for (std::uint32_t y = 0; y < n.y; ++y)
                for (std::uint32_t x = 0; x < n.x; ++x) {
                    std::uint32_t q[3] = {x, y, z};
                    if (q[axis] + 1 >= n[axis]) continue;
                    ++q[axis];
                    off[at(x, y, z)] |= off[at(q[0], q[1], q[2])];  // q comes later in the loop: not yet dilated
                }
    nanovdb::GridBuilder<float> builder(0.0f);
    auto acc = builder.getAccessor();
    for (std::uint32_t z = 0; z < n.z; ++z)
        for (std::uint32_t y = 0; y < n.y; ++y)
            for (std::uint32_t x = 0; x < n.x; ++x)
                if (off[at(x, y, z)]) acc.setValue(nanovdb::Coord(int(x), int(y), int(z)), g.values[at(x, y, z)]);
    return builder.getHandle<>(1.0, nanovdb::Vec3d(0.0), "density");
}

/// One pixel through the NanoVDB grid: the ray sylva_iso_pixel traces, mapped to cell space as
/// sylva_ray_to_grid maps it, clipped to the cells' box [0, cells] with sylva's slab test, then
/// NanoVDB's HDDA over the tree: empty tiles and nodes are leapt at their size (getDim), inside
/// leaves the HDDA steps voxel by voxel, front to back. Each active voxel in the grid's cells is
/// a cell: its 8 corners from the ReadAccessor, sylva's candidate test, its interval from
/// sylva's slab test of the cell's box (the arithmetic both sylva walkers share), and sylva's
/// exact hit and shading (sylva_iso_shade_cell).
template <class Acc>
shared::SylvaIsoRay nanovdb_pixel(Acc& acc, const shared::SylvaIsoParams& sp, const shared::SylvaIkdHeader& hdr,
                                  std::uint32_t x, std::uint32_t y) {
    using RayT = nanovdb::Ray<float>;
    shared::SylvaIsoRay r{vec4(0.0f), 0u, 0u, 0u, SYLVA_ITER_DONE};
    vec3 dc = shared::sylva_camera_dir(sp.w, sp.u, sp.v, x, y, sp.width, sp.height);
    float len = std::sqrt(dc.x * dc.x + dc.y * dc.y + dc.z * dc.z);
    vec3 dir(dc.x / len, dc.y / len, dc.z / len);
    vec3 org, rcp;
    glm::u32vec3 par;
    if (shared::sylva_ray_to_grid(sp.eye, dir, hdr.origin, hdr.inv_spacing, 0.0f, shared::sylva_inf(), org, rcp, par))
        return r;
    const vec3 s = hdr.inv_spacing;
    const vec3 d(dir.x * s.x, dir.y * s.y, dir.z * s.z);
    const glm::uvec3 cells = hdr.cells;
    vec2 tb = shared::sylva_kd_box_interval_f(org, rcp, par, vec3(0.0f), vec3(cells), 0.0f, shared::sylva_inf());
    if (!(tb.x <= tb.y)) return r;
    // NanoVDB's ray starts where the ray enters the cells' box (its times count from there:
    // smaller numbers, finer rounding of its positions); the cells' intervals stay sylva's.
    const float t_in = tb.x;
    RayT ray(nanovdb::Vec3f(org.x + t_in * d.x, org.y + t_in * d.y, org.z + t_in * d.z), nanovdb::Vec3f(d.x, d.y, d.z),
             0.0f, tb.y - t_in);
    auto clamp_to = [](int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); };
    auto inside = [&](const nanovdb::Coord& c) {
        return c[0] >= 0 && c[1] >= 0 && c[2] >= 0 && std::uint32_t(c[0]) < cells.x && std::uint32_t(c[1]) < cells.y &&
               std::uint32_t(c[2]) < cells.z;
    };
    // The voxel where the ray is at time t, clamped into the box [lo, hi] the ray is known to be
    // in (rounding at a face can put ray(t) a hair outside).
    auto voxel_at = [&](float t, const nanovdb::Coord& lo, const nanovdb::Coord& hi) {
        nanovdb::Coord c = nanovdb::RoundDown<nanovdb::Coord>(ray(t));
        for (int a = 0; a < 3; ++a) c[a] = clamp_to(c[a], lo[a], hi[a]);
        return c;
    };
    // When the ray enters the box [lo, lo + dim) (slab test; in [0, t1]).
    auto entry = [&](const nanovdb::Coord& lo, int dim) {
        float t = 0.0f;
        for (int a = 0; a < 3; ++a) {
            if (ray.dir()[a] == 0.0f) continue;
            float t_lo = (float(lo[a]) - ray.eye()[a]) * ray.invDir()[a];
            float t_hi = (float(lo[a] + dim) - ray.eye()[a]) * ray.invDir()[a];
            t = std::max(t, std::min(t_lo, t_hi));
        }
        return std::min(t, ray.t1());
    };
    nanovdb::Coord ijk = voxel_at(0.0f, nanovdb::Coord(0), nanovdb::Coord(int(cells.x) - 1, int(cells.y) - 1, int(cells.z) - 1));
    nanovdb::HDDA<RayT, nanovdb::Coord> hdda(ray, int(acc.getDim(ijk, ray)));
    const std::uint32_t max_steps = 4u * (cells.x + cells.y + cells.z) + 16u;  // a guard, never reached
    std::uint32_t steps = 0;
    while (r.rgba.w < sp.alpha_stop && steps < max_steps) {
        ++steps;
        if (hdda.dim() == 1) {
            const nanovdb::Coord& v = hdda.voxel();
            if (inside(v) && acc.isActive(v)) {
                vec4 lo(acc.getValue(v), acc.getValue(v.offsetBy(1, 0, 0)), acc.getValue(v.offsetBy(0, 1, 0)),
                        acc.getValue(v.offsetBy(1, 1, 0)));
                vec4 hi(acc.getValue(v.offsetBy(0, 0, 1)), acc.getValue(v.offsetBy(1, 0, 1)),
                        acc.getValue(v.offsetBy(0, 1, 1)), acc.getValue(v.offsetBy(1, 1, 1)));
                if (shared::sylva_ikd_corners_hold(lo, hi, sp.isos, sp.iso_count)) {
                    glm::uvec3 cell{std::uint32_t(v[0]), std::uint32_t(v[1]), std::uint32_t(v[2])};
                    vec3 lo_c(float(cell.x), float(cell.y), float(cell.z));
                    vec3 hi_c(float(cell.x + 1u), float(cell.y + 1u), float(cell.z + 1u));
                    vec2 t = shared::sylva_kd_box_interval_f(org, rcp, par, lo_c, hi_c, 0.0f, shared::sylva_inf());
                    if (t.x < t.y) {  // touched only: skipped, as sylva_iso_trace skips it
                        ++r.cells;
                        r.rgba = shared::sylva_iso_shade_cell(r.rgba, sp, cell, lo, hi, org, d, s, dir, t.x, t.y, r.hits);
                    }
                }
            }
        }
        const int dim = hdda.dim();
        if (!hdda.step()) break;
        // The voxel or node entered (a node by its corner); the voxel whose node size getDim
        // gives: exact after a voxel step, where the ray enters after a node step.
        const nanovdb::Coord region = hdda.voxel();
        const float t_entry = entry(region, dim);
        nanovdb::Coord next = dim == 1 ? region : voxel_at(t_entry, region, region.offsetBy(dim - 1));
        const int next_dim = int(acc.getDim(next, ray));
        // A new step size: the HDDA restarts at the exact entry time. Its own update() would take
        // its accumulated time, nudged forward by ENFORCE_FORWARD_STEPPING (about 1e-6 t at
        // corners), and could start past a cell the ray crosses for less than that.
        if (next_dim != dim) hdda.init(ray, t_entry, ray.t1(), next_dim);
    }
    r.steps = steps;
    return r;
}

/// Renders the frame with nanovdb_pixel over the pool, rows as render_iso_cpu splits them.
Frame render_nanovdb(const nanovdb::NanoGrid<float>& grid, const IsoRenderParams& p, const shared::SylvaIkdHeader& hdr,
                     ThreadPool& pool, IsoCounters& n) {
    std::vector<std::uint32_t> params = iso_params(p, 0, 0);
    shared::SylvaIsoParams sp = shared::sylva_iso_read_params(shared::Words{params.data(), params.size()});
    Frame f;
    f.width = p.width;
    f.height = p.height;
    f.rgba.assign(std::size_t{p.width} * p.height, vec4(0.0f));
    f.steps.assign(f.rgba.size(), 0u);
    std::atomic<std::uint64_t> steps{0}, cells{0}, hits{0};
    auto start = std::chrono::steady_clock::now();
    parallel_take(pool, 0, p.height, kRowsPerTake, [&](std::size_t y0, std::size_t y1) {
        auto acc = grid.getAccessor();  // one ReadAccessor (and its node cache) per block of rows, as render_iso_cpu takes them
        std::uint64_t ns = 0, nc = 0, nh = 0;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::uint32_t x = 0; x < p.width; ++x) {
                shared::SylvaIsoRay r = nanovdb_pixel(acc, sp, hdr, x, static_cast<std::uint32_t>(y));
                std::size_t i = y * p.width + x;
                f.rgba[i] = r.rgba;
                f.steps[i] = r.steps;
                ns += r.steps;
                nc += r.cells;
                nh += r.hits;
            }
        steps += ns;
        cells += nc;
        hits += nh;
    });
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    n.steps = steps;
    n.cells = cells;
    n.hits = hits;
    return f;
}

/// The NanoVDB peer on the case's grid, camera and isovalue: built here (its build records
/// pushed), rendered as a contender; `store` keeps the grid alive while the contender runs.
Contender nanovdb_contender(const volume::DensityGrid& g, const IsoRenderParams& p, const shared::SylvaIkdHeader& hdr,
                            ThreadPool& pool, const std::string& c,
                            std::unique_ptr<nanovdb::GridHandle<nanovdb::HostBuffer>>& store, std::vector<Record>& out) {
    const std::string impl = "nanovdb-hdda";
    auto t0 = std::chrono::steady_clock::now();
    store = std::make_unique<nanovdb::GridHandle<nanovdb::HostBuffer>>(nanovdb_grid(g, p.isos.front().value));
    double build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const nanovdb::NanoGrid<float>* grid = store->grid<float>();
    if (!grid) throw Error("sylva-iso-bench: NanoVDB built no float grid");
    out.push_back({c, impl, "build_ms", build_ms, "ms"});
    out.push_back({c, impl, "index_bytes", double(store->size()), "bytes"});
    Contender k;
    k.impl = impl;
    k.render = [grid, p, hdr, &pool](IsoCounters& n) { return render_nanovdb(*grid, p, hdr, pool, n); };
    return k;
}

/// NanoVDB's image against the tree's: equal, or the pixels differing (reported, see the top).
void compare_nanovdb(const Frame& f, const Frame& tree, const std::string& c, std::vector<Record>& out) {
    const std::string impl = "nanovdb-hdda";
    std::size_t differing = pixel_differences(f, tree);
    out.push_back({c, impl, "image_equals_tree", differing == 0 ? 1.0 : 0.0, "bool"});
    if (differing != 0) {
        out.push_back({c, impl, "pixels_differing", double(differing), "pixels"});
        std::cerr << "sylva-iso-bench: " << c << ": NanoVDB's image differs from the tree's in " << differing
                  << " pixels (" << hit_differences(f, tree) << " of them hit / miss)\n";
    }
}
#endif

/// True when a and b hold the same pixels bit for bit.
bool same_image(const Frame& a, const Frame& b) {
    return a.rgba.size() == b.rgba.size() && std::memcmp(a.rgba.data(), b.rgba.data(), a.rgba.size() * sizeof(vec4)) == 0;
}

void check_same(const Frame& a, const Frame& b, const std::string& c, const std::string& impl, const std::string& metric,
                const std::string& what, std::vector<Record>& out) {
    bool same = same_image(a, b);
    out.push_back({c, impl, metric, same ? 1.0 : 0.0, "bool"});
    if (!same) std::cerr << "sylva-iso-bench: " << c << ": " << what << "\n";
}

/// Every case's frame (and --drop's): o.size^2 pixels, one camera framing the volume, the
/// isovalue o.iso, opaque.
IsoRenderParams frame_params(const volume::DensityGrid& g, const Options& o) {
    IsoRenderParams p;
    p.width = p.height = o.size;
    p.camera = Camera::framing(g.world_box(), vec3(0.4f, 0.3f, 1.0f)).frame(o.size, o.size);
    p.isos = {{o.iso, vec4(0.93f, 0.86f, 0.75f, 1.0f)}};
    return p;
}

void run_case(const std::string& c, const Options& o, ThreadPool& pool, std::vector<Record>& out) {
    std::optional<CaseData> data = grid_of(c);
    if (!data) return;
    const volume::DensityGrid* g = &data->grid;
    std::size_t data_bytes = c.rfind("ml", 0) == 0 ? g->values.size() * 2 : g->values.size();  // ML: 16-bit, as Table III
    GridWords gw = GridWords::from(*g);
    const IsoRenderParams p = frame_params(*g, o);
    // The three trees (the default; the second tree, by default 6 brick levels; the paper's slim
    // tree, 16-bit nodes and no bricks), each built twice: cold, then again.
    const ikd::Config configs[3] = {ikd::Config{}, ikd::Config{o.alt_bricks, o.alt_bits}, ikd::Config{0u, 16u}};
    const std::string alt = "implicit-kd-b" + std::to_string(o.alt_bricks) + (o.alt_bits == 16 ? "-u16" : "");
    const std::string names[3] = {"implicit-kd", alt, "implicit-kd-slim"};
    std::vector<std::uint32_t> words[3];
    for (int t = 0; t < 3; ++t) {
        ikd::Tree tree = ikd::build(*g, pool, configs[t]);
        words[t] = ikd::encode(tree);
        out.push_back({c, names[t], "build_ms", tree.build_ms, "ms"});
        out.push_back({c, names[t], "build_ms_again", ikd::build(*g, pool, configs[t]).build_ms, "ms"});
        out.push_back({c, names[t], "index_bytes", double(words[t].size() * 4), "bytes"});
        out.push_back({c, names[t], "index_per_data", double(words[t].size() * 4) / double(data_bytes), "x"});
    }
    // The cell space (origin, 1 / spacing, cells) every walker maps rays into.
    shared::SylvaIkdHeader hdr = shared::sylva_ikd_read_header(shared::Words{words[0].data(), words[0].size()},
                                                                static_cast<std::uint32_t>(words[0].size()),
                                                                static_cast<std::uint32_t>(gw.words.size()));
    std::vector<Contender> cs;
    cs.push_back(iso_contender(names[0], words[0], gw, p, IsoWalker::Tree, pool));
    cs.push_back(iso_contender("implicit-kd-packet", words[0], gw, p, IsoWalker::Tree, pool, 4));
    cs.push_back(iso_contender("implicit-kd-packet8", words[0], gw, p, IsoWalker::Tree, pool, 8));
    cs.push_back(iso_contender("implicit-kd-packet16", words[0], gw, p, IsoWalker::Tree, pool, 16));
    cs.push_back(iso_contender(names[1], words[1], gw, p, IsoWalker::Tree, pool));
    cs.push_back(iso_contender(alt + "-packet", words[1], gw, p, IsoWalker::Tree, pool, 4));
    cs.push_back(iso_contender(names[2], words[2], gw, p, IsoWalker::Tree, pool));
    cs.push_back(iso_contender("dda", words[2], gw, p, IsoWalker::Dda, pool));
    // The integer volumes read natively (GridWords::native: 1 or 2 bytes a sample, normalised on
    // the fly, the same densities): the default tree, its packets and the DDA again.
    std::optional<GridWords> native;
    if (data->raw) {
        native = GridWords::native(*data->raw);
        const bool u16 = data->raw->type == volume::ScalarType::U16;
        const std::string grid = u16 ? "-u16grid" : "-u8grid";
        out.push_back({c, "grid-float32", "grid_bytes", double(gw.grid_bytes()), "bytes"});
        out.push_back({c, u16 ? "grid-uint16" : "grid-uint8", "grid_bytes", double(native->grid_bytes()), "bytes"});
        cs.push_back(iso_contender(names[0] + grid, words[0], *native, p, IsoWalker::Tree, pool));
        cs.push_back(iso_contender("implicit-kd-packet" + grid, words[0], *native, p, IsoWalker::Tree, pool, 4));
        cs.push_back(iso_contender("implicit-kd-packet8" + grid, words[0], *native, p, IsoWalker::Tree, pool, 8));
        cs.push_back(iso_contender("dda" + grid, words[2], *native, p, IsoWalker::Dda, pool));
    }
    const std::size_t trees = cs.size();
    std::unique_ptr<BihIsoIndex> bih_store;
#ifdef SYLVA_ISO_BENCH_NANOVDB
    std::unique_ptr<nanovdb::GridHandle<nanovdb::HostBuffer>> nanovdb_store;
#endif
    if (o.peers) {
#ifdef SYLVA_ISO_BENCH_NANOVDB
        cs.push_back(nanovdb_contender(*g, p, hdr, pool, c, nanovdb_store, out));
#endif
        if (std::optional<Contender> k = bih_iso_contender(*g, p, pool, c, bih_store, out)) cs.push_back(std::move(*k));
    }
    time_round_robin(cs, o.runs, p, c, out);
    const Frame& tree = cs[0].last;
    check_same(cs[1].last, tree, c, cs[1].impl, "image_equals_single", "the packets' image differs from single rays'", out);
    for (std::size_t k = 2; k < trees; ++k)
        check_same(cs[k].last, tree, c, cs[k].impl, "image_equals_tree", cs[k].impl + "'s image differs from the default tree's", out);
    for (std::size_t k = trees; k < cs.size(); ++k) {
#ifdef SYLVA_ISO_BENCH_NANOVDB
        if (cs[k].impl == "nanovdb-hdda") compare_nanovdb(cs[k].last, tree, c, out);
#endif
        if (cs[k].impl == "bih-iso")  // sampled: reported, never fatal
            out.push_back({c, "bih-iso", "pixels_differing_from_tree", double(hit_differences(cs[k].last, tree)), "pixels"});
    }
    out.push_back({c, "data", "data_bytes", double(data_bytes), "bytes"});
}

/// One size of --drop: the data, its grids and the default tree, and the frame parameters;
/// in place (the contenders hold references to its words and grids).
struct DropSide {
    std::string c;
    std::optional<CaseData> data;
    GridWords gw, native;
    std::vector<std::uint32_t> words;
    IsoRenderParams p;
};

/// Fig. 7 side by side (--drop A,B): the default tree over Marschner-Lobb at sizes A and B,
/// single rays and packets of 8, over the float32 densities and over the uint16 samples. After
/// one cold frame each, every round renders each walker's frame at A and at B back to back (B
/// first in odd rounds), so a change of the machine's speed during the run falls on both sizes
/// alike, which the per-case round robin cannot promise for a ratio across two cases measured
/// seconds apart. Per walker: rays/s and steps at each size (median frames), and the drop A -> B
/// as the median, min and max over the rounds of frame_ms(B) / frame_ms(A), and as the ratio of
/// the median rays/s. Each size's four images must be the same, bit for bit.
void run_drop(const Options& o, ThreadPool& pool, std::vector<Record>& out) {
    DropSide sides[2];
    for (int s = 0; s < 2; ++s) {
        DropSide& d = sides[s];
        d.c = o.drop[static_cast<std::size_t>(s)];
        d.data = grid_of(d.c);
        if (!d.data) throw Error("--drop: no data for " + d.c);
        d.gw = GridWords::from(d.data->grid);
        d.native = GridWords::native(*d.data->raw);
        d.words = ikd::encode(ikd::build(d.data->grid, pool, ikd::Config{}));
        d.p = frame_params(d.data->grid, o);
    }
    std::vector<Contender> cs[2];
    for (DropSide& d : sides) {
        std::vector<Contender>& k = cs[&d - sides];
        k.push_back(iso_contender("implicit-kd", d.words, d.gw, d.p, IsoWalker::Tree, pool));
        k.push_back(iso_contender("implicit-kd-u16grid", d.words, d.native, d.p, IsoWalker::Tree, pool));
        k.push_back(iso_contender("implicit-kd-packet8", d.words, d.gw, d.p, IsoWalker::Tree, pool, 8));
        k.push_back(iso_contender("implicit-kd-packet8-u16grid", d.words, d.native, d.p, IsoWalker::Tree, pool, 8));
    }
    const std::size_t walkers = cs[0].size();
    for (auto& k : cs)
        for (Contender& w : k) w.first_ms = (w.last = w.render(w.n)).ms;
    std::vector<std::vector<double>> ratio(walkers);
    for (std::size_t r = 0; r < o.runs; ++r)
        for (std::size_t w = 0; w < walkers; ++w) {
            for (int i = 0; i < 2; ++i) {
                Contender& k = cs[(r % 2 == 0) ? i : 1 - i][w];
                k.last = k.render(k.n);
                k.ms.push_back(k.last.ms);
            }
            ratio[w].push_back(cs[1][w].ms.back() / cs[0][w].ms.back());
        }
    const std::string c = sides[0].c + "-" + sides[1].c;
    const double rays = double(o.size) * o.size;
    for (std::size_t w = 0; w < walkers; ++w) {
        double rate[2];
        for (int s = 0; s < 2; ++s) {
            const Contender& k = cs[s][w];
            rate[s] = rays / (median(k.ms) / 1000.0);
            out.push_back({c, k.impl, "rays_per_s_" + sides[s].c, rate[s], "rays/s"});
            out.push_back({c, k.impl, "first_frame_ms_" + sides[s].c, k.first_ms, "ms"});
            out.push_back({c, k.impl, "steps_per_ray_" + sides[s].c, double(k.n.steps) / rays, "steps"});
        }
        const auto [lo, hi] = std::minmax_element(ratio[w].begin(), ratio[w].end());
        out.push_back({c, cs[0][w].impl, "drop", median(ratio[w]), "x"});
        out.push_back({c, cs[0][w].impl, "drop_min", *lo, "x"});
        out.push_back({c, cs[0][w].impl, "drop_max", *hi, "x"});
        out.push_back({c, cs[0][w].impl, "drop_of_medians", rate[0] / rate[1], "x"});
    }
    for (int s = 0; s < 2; ++s)
        for (std::size_t w = 1; w < walkers; ++w)
            check_same(cs[s][w].last, cs[s][0].last, sides[s].c, cs[s][w].impl, "image_equals_tree",
                       cs[s][w].impl + "'s image differs from the default tree's", out);
}

void print(const std::vector<Record>& rs) {
    std::printf("%-10s %-18s %-26s %14s %s\n", "case", "impl", "metric", "value", "unit");
    for (const Record& r : rs) std::printf("%-10s %-18s %-26s %14.4g %s\n", r.c.c_str(), r.impl.c_str(), r.metric.c_str(), r.value, r.unit.c_str());
}

/// The records as JSON through the benchmarks' shared writer (report.cpp: escaped strings,
/// numbers checked finite).
void write_json(const std::string& path, const std::vector<Record>& rs) {
    bench::Report report;
    for (const Record& r : rs) report.add(r.c, r.impl, r.metric, r.value, r.unit);
    report.write_json(path);
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    std::unique_ptr<CLI::App> app = make_app(o);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    try {
        ThreadPool pool(o.threads);
#ifndef SYLVA_ISO_BENCH_NANOVDB
        std::cerr << "sylva-iso-bench: built without NanoVDB (nanovdb/NanoVDB.h not found at configure time): "
                     "the nanovdb-hdda peer is left out\n";
#endif
        std::vector<Record> records;
        if (!o.drop.empty())
            run_drop(o, pool, records);
        else
            for (const std::string& c : o.cases) run_case(c, o, pool, records);
        print(records);
        if (!o.json.empty()) write_json(o.json, records);
        for (const Record& r : records) {
            bool peer = r.impl == "nanovdb-hdda";  // a peer's difference is reported; fatal over 0.1% of the pixels
            if (!peer && (r.metric == "image_equals_tree" || r.metric == "image_equals_single") && r.value != 1.0) return 1;
            if (peer && r.metric == "pixels_differing" && r.value > 1e-3 * double(o.size) * o.size) return 1;
        }
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "sylva-iso-bench: " << e.what() << "\n";
        return 1;
    }
}
