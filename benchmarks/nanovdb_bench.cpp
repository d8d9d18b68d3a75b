// sylva-nanovdb-bench: the same-camera comparison with NanoVDB (issue 17). For each volume of
// ../shared/data (aneurism, bonsai, engine; uint8):
//  * NanoVDB: a float grid (GridBuilder) of the normalised densities v / 255 whose active set
//    is every non-zero voxel dilated by one voxel (the trilinear reach), rendered with a plain
//    march (accessor + trilinear SampleFromVoxels at every lattice point) and with HDDA empty-
//    space skipping (TreeMarcher over leaf nodes: lattice points inside the leaves only);
//  * sylva: the uint8 grid read natively (GridWords::native, 1 byte a voxel, border constant 0;
//    and GridWords::sparse: 8^3 bricks, the uniform ones held by their value in the brick table),
//    a plain march and the ESS kd-tree (EssRebuilder, deep config) skipping, with the shared
//    per-sample functions of the renderers (sylva_grid_sample, the kd iterator and leaf spans of
//    kd_dvr.h, the lattice and compositing of dvr_common.h).
// The same two sylva renderers once more through the public renderer API, as an embedding
// renderer calls them (rows sylva-api-plain, sylva-api-kd): render_dvr_cpu / render_kd_dvr_cpu
// with the bench's rays as a PixelRays buffer, the analytic TF as a host hook (TfKind::Hook),
// OpacityCorrection::None, dt = 1; their images must equal the hand loops' bit for bit (the
// bench stops otherwise). Their steps per ray are the renderers' (Frame::steps), samples 0.
// And the bricked octree through the API (sylva-api-octree: unorm8 bricks of 16^3, octant
// masks, the hook's visibility query for skipping), whose image must equal the API marcher's.
// Same rays for all: an orthographic camera (one ray a pixel, pixels one voxel apart on an image
// plane in front of the volume), a 1-voxel lattice t_k = k fixed to the image plane, samples
// only inside the volume's box [0, dims], outside the data reading 0. Same analytic transfer
// function: alpha = clamp((d - 0.1) / 0.9, 0, 1) * 0.4, colour (d, d^2, 1 - d), no opacity
// correction (the lattice step is the TF's unit), front-to-back compositing with early
// termination at 0.99. 2 threads (sylva::ThreadPool) for every renderer.
//
// Reported per volume and renderer: median rays/s over --runs renders, samples and steps per
// ray (steps: lattice samples + traversal steps: kd node visits / HDDA marcher steps), build
// time cold (first build in the process) and warm (the same build again; sylva: the
// EssRebuilder's second rebuild), the cold build's peak heap (operator new, counted here; for
// NanoVDB plus its grid buffer), bytes of grid + index, and the image against the reference (max |diff| of the
// float RGBA and identical pixels, float bits and RGBA8).
//
//   sylva-nanovdb-bench [--volumes aneurism,bonsai,engine] [--runs 5] [--threads 2]
//                       [--view 0.3,0.2,1] [--data DIR] [--json FILE]   (CLI11; --help lists them)
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <new>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

// NanoVDB's HDDA leaves mDelta unset on axes the ray does not move along (it never reads it
// there); GCC's -Wmaybe-uninitialized flags the inlined step. Silenced for NanoVDB's text only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/HDDA.h>
#include <nanovdb/util/Ray.h>
#include <nanovdb/util/SampleFromVoxels.h>
#pragma GCC diagnostic pop
#include <nlohmann/json.hpp>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/octants.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/shared/kd_dvr.h>
#include <sylva/volume/read_raw.hpp>

#include "cli.hpp"

#ifndef SYLVA_DATA_DIR
#define SYLVA_DATA_DIR "../shared/data"
#endif

namespace {

using namespace sylva;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    std::size_t n = v.size();
    return n == 0 ? 0.0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

// Heap accounting for the builds' peak memory: every operator new / delete of the process is
// counted (malloc_usable_size), and the peak above the level at the build's start is reported,
// plus, for NanoVDB, its grid buffer (malloc'ed by its HostBuffer, the final grid's size).
std::atomic<std::size_t> g_heap{0}, g_heap_peak{0};

void heap_add(void* p) {
    if (p == nullptr) return;
    std::size_t now = g_heap.fetch_add(malloc_usable_size(p)) + malloc_usable_size(p);
    std::size_t peak = g_heap_peak.load();
    while (now > peak && !g_heap_peak.compare_exchange_weak(peak, now)) {
    }
}
void heap_sub(void* p) {
    if (p != nullptr) g_heap.fetch_sub(malloc_usable_size(p));
}
std::size_t reset_peak() {
    g_heap_peak.store(g_heap.load());
    return g_heap.load();
}

// ---- the shared camera, lattice and transfer function ----------------------------------------

struct Rays {
    std::uint32_t width = 0, height = 0;
    std::vector<vec3> origin;
    vec3 dir{0.0f};
    float span_lo = 0.0f;  // unused; spans are per ray
};

/// Orthographic rays one voxel apart on a plane in front of the volume, looking along `view`.
Rays ortho_rays(volume::Dims dims, vec3 view) {
    // A unit direction the renderers' own normalisation (sylva_dvr_unit) leaves unchanged, so the
    // renderer API rows march the hand loops' t bit for bit.
    vec3 d = shared::sylva_dvr_unit(view);
    for (int i = 0; i < 8 && shared::sylva_dvr_unit(d) != d; ++i) d = shared::sylva_dvr_unit(d);
    vec3 up = std::abs(d.y) < 0.9f ? vec3(0, 1, 0) : vec3(1, 0, 0);
    vec3 u = glm::normalize(glm::cross(d, up)), v = glm::cross(u, d);
    vec3 c = vec3(dims) * 0.5f;
    float r = 0.5f * glm::length(vec3(dims));
    auto n = static_cast<std::uint32_t>(std::ceil(2.0f * r));
    Rays rays;
    rays.width = rays.height = n;
    rays.dir = d;
    vec3 eye = c - d * (r + 1.0f);
    rays.origin.resize(std::size_t{n} * n);
    for (std::uint32_t y = 0; y < n; ++y)
        for (std::uint32_t x = 0; x < n; ++x) {
            float sx = float(x) + 0.5f - 0.5f * float(n), sy = 0.5f * float(n) - float(y) - 0.5f;
            rays.origin[std::size_t{y} * n + x] = eye + sx * u + sy * v;
        }
    return rays;
}

constexpr float kDt = 1.0f;         // lattice step: one voxel
constexpr float kAlphaStop = 0.99f;  // early ray termination

/// The analytic TF: straight colour and alpha of density d.
inline vec4 analytic_tf(float d) {
    float a = std::clamp((d - 0.1f) / 0.9f, 0.0f, 1.0f) * 0.4f;
    return vec4(d, d * d, 1.0f - d, a);
}

/// One lattice sample of density d composited into acc (dvr_common.h's blend, no correction).
inline void composite(shared::SylvaDvrAcc& acc, float d) {
    if (!(d > 0.0f)) return;
    vec4 c = analytic_tf(d);
    if (c.w <= 0.0f) return;
    shared::sylva_dvr_blend(acc, vec3(c.x, c.y, c.z), c.w);
}

struct RayResult {
    vec4 rgba;
    std::uint32_t samples;
    std::uint32_t steps;
};

struct Image {
    std::vector<vec4> rgba;
    std::uint64_t samples = 0, steps = 0;
    double ms = 0.0;
};

/// Renders every ray with `ray(origin, dir) -> RayResult` over the executor.
template <class F>
Image render(const Rays& rays, ThreadPool& pool, F&& ray) {
    Image img;
    img.rgba.resize(rays.origin.size());
    std::vector<std::uint32_t> samples(rays.origin.size()), steps(rays.origin.size());
    auto t0 = Clock::now();
    parallel_take(pool, 0, rays.height, kRowsPerTake, [&](std::size_t y0, std::size_t y1) {  // as sylva's renderers take rows
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < rays.width; ++x) {
                std::size_t i = y * rays.width + x;
                RayResult r = ray(rays.origin[i], rays.dir);
                img.rgba[i] = r.rgba;
                samples[i] = r.samples;
                steps[i] = r.steps;
            }
    });
    img.ms = ms_since(t0);
    for (std::size_t i = 0; i < samples.size(); ++i) {
        img.samples += samples[i];
        img.steps += steps[i];
    }
    return img;
}

/// The part of the ray inside the volume's box [0, dims] (world = voxel units here).
inline vec2 box_span(volume::Dims dims, vec3 o, vec3 d) {
    return shared::sylva_dvr_clip(vec3(0.0f), vec3(dims), o, d, 0.0f, shared::sylva_inf());
}

// ---- sylva ----------------------------------------------------------------------------------

RayResult sylva_plain(const shared::Words& gw, const shared::SylvaGridDesc& g, vec3 o, vec3 d) {
    RayResult r{vec4(0.0f), 0, 0};
    vec2 span = box_span(g.dims, o, d);
    if (!(span.x <= span.y)) return r;
    shared::SylvaDvrAcc acc = shared::sylva_dvr_acc_zero();
    for (std::uint32_t k = shared::sylva_lattice_first(span.x, kDt);; ++k) {
        float t = shared::sylva_lattice_t(k, kDt);
        if (!(t < span.y) || acc.alpha >= kAlphaStop) break;
        ++r.samples;
        composite(acc, shared::sylva_grid_sample(gw, g, shared::sylva_dvr_at(o, d, t)));
    }
    r.steps = r.samples;
    r.rgba = shared::sylva_dvr_result(acc);
    return r;
}

/// sylva_kd_dvr_march's loop (kd_dvr.h) with the analytic TF.
RayResult sylva_kd(const shared::Words& kw, std::uint32_t kd_words, const shared::Words& gw,
                   const shared::SylvaGridDesc& g, vec3 o, vec3 d) {
    RayResult r{vec4(0.0f), 0, 0};
    vec2 span = box_span(g.dims, o, d);
    if (!(span.x <= span.y)) return r;
    shared::SylvaDvrAcc acc = shared::sylva_dvr_acc_zero();
    shared::SylvaKdIter it;
    shared::sylva_kd_init(it, kw, kd_words, o, d, 0.0f, shared::sylva_inf());
    std::uint32_t k_next = 0, leaf;
    float t0, t1;
    while (acc.alpha < kAlphaStop && shared::sylva_kd_next(it, kw, leaf, t0, t1)) {
        vec2 s = shared::sylva_kd_dvr_leaf_span(kw, it.org, it.rcp, it.parallel, it.leaf_node, SYLVA_KD_DVR_MARGIN,
                                                span.x, span.y);
        if (!(s.x <= s.y)) continue;
        std::uint32_t k = std::max(shared::sylva_lattice_first(s.x, kDt), k_next);
        for (;; ++k) {
            float t = shared::sylva_lattice_t(k, kDt);
            if (!(t < s.y) || acc.alpha >= kAlphaStop) break;
            ++r.samples;
            composite(acc, shared::sylva_grid_sample(gw, g, shared::sylva_dvr_at(o, d, t)));
        }
        k_next = std::max(k_next, k);
    }
    r.steps = it.steps + r.samples;
    r.rgba = shared::sylva_dvr_result(acc);
    return r;
}

// ---- NanoVDB --------------------------------------------------------------------------------

using NanoGrid = nanovdb::NanoGrid<float>;

/// The float grid of densities v / 255 with the active set = non-zero voxels dilated by one
/// voxel (the trilinear reach), also onto the layer at index -1 below each axis: a sample at
/// u in [-0.5, 0) reads voxels -1 and 0, and its leaf must exist for a walk to sample it.
nanovdb::GridHandle<nanovdb::HostBuffer> nano_build(const volume::Volume& v) {
    const auto* raw = reinterpret_cast<const std::uint8_t*>(v.bytes.data());
    volume::Dims n = v.dims, m = v.dims + 1u;  // the mask covers [-1, n - 1] on each axis
    std::vector<std::uint8_t> active(volume::voxel_count(m), 0u);
    for (std::uint32_t z = 0; z < n.z; ++z)
        for (std::uint32_t y = 0; y < n.y; ++y)
            for (std::uint32_t x = 0; x < n.x; ++x) {
                if (raw[volume::voxel_index(n, x, y, z)] == 0) continue;
                for (std::uint32_t c = z; c <= std::min(z + 2, n.z); ++c)  // mask index = voxel + 1
                    for (std::uint32_t b = y; b <= std::min(y + 2, n.y); ++b)
                        for (std::uint32_t a = x; a <= std::min(x + 2, n.x); ++a) active[volume::voxel_index(m, a, b, c)] = 1u;
            }
    nanovdb::GridBuilder<float> builder(0.0f);
    auto acc = builder.getAccessor();
    for (std::uint32_t c = 0; c < m.z; ++c)
        for (std::uint32_t b = 0; b < m.y; ++b)
            for (std::uint32_t a = 0; a < m.x; ++a) {
                if (!active[volume::voxel_index(m, a, b, c)]) continue;
                int x = int(a) - 1, y = int(b) - 1, z = int(c) - 1;
                bool inside = x >= 0 && y >= 0 && z >= 0;
                float d = inside ? float(raw[volume::voxel_index(n, x, y, z)]) / 255.0f : 0.0f;
                acc.setValue(nanovdb::Coord(x, y, z), d);
            }
    return builder.getHandle(1.0, nanovdb::Vec3d(0.0), "density");
}

template <class Acc>
inline float nano_sample(Acc& acc, vec3 o, vec3 d, float t) {
    vec3 x = shared::sylva_dvr_at(o, d, t);
    auto sampler = nanovdb::createSampler<1, Acc, false>(acc);
    return sampler(nanovdb::Vec3f(x.x - 0.5f, x.y - 0.5f, x.z - 0.5f));  // voxel centres at integers
}

RayResult nano_plain(const NanoGrid& grid, volume::Dims dims, vec3 o, vec3 d) {
    RayResult r{vec4(0.0f), 0, 0};
    vec2 span = box_span(dims, o, d);
    if (!(span.x <= span.y)) return r;
    auto acc = grid.getAccessor();
    shared::SylvaDvrAcc a = shared::sylva_dvr_acc_zero();
    for (std::uint32_t k = shared::sylva_lattice_first(span.x, kDt);; ++k) {
        float t = shared::sylva_lattice_t(k, kDt);
        if (!(t < span.y) || a.alpha >= kAlphaStop) break;
        ++r.samples;
        composite(a, nano_sample(acc, o, d, t));
    }
    r.steps = r.samples;
    r.rgba = shared::sylva_dvr_result(a);
    return r;
}

/// HDDA skipping (NanoVDB's hierarchical DDA, the pattern of its ZeroCrossing): the index-space
/// ray (same t) walks the tree's nodes with nanovdb::HDDA at the size the accessor reports
/// (getDim: an empty internal tile is crossed in one step), never finer than a leaf (8^3); the
/// lattice points in [time, next) of every leaf cell are sampled, each at most once.
/// (NanoVDB's TreeMarcher was tried first: it drops spans -- its own comments warn of clipped
/// corners -- 6 % of the engine's pixels differed from the plain march by up to 0.12.)
RayResult nano_hdda(const NanoGrid& grid, volume::Dims dims, vec3 o, vec3 d) {
    using RayT = nanovdb::Ray<float>;
    using AccT = decltype(grid.getAccessor());
    constexpr int kLeafDim = int(nanovdb::LeafNode<float>::DIM);
    RayResult r{vec4(0.0f), 0, 0};
    vec2 span = box_span(dims, o, d);
    if (!(span.x <= span.y)) return r;
    AccT acc = grid.getAccessor();     // the walk's (node sizes, leaves)
    AccT sample = grid.getAccessor();  // the samples'
    RayT iray(nanovdb::Vec3f(o.x - 0.5f, o.y - 0.5f, o.z - 0.5f), nanovdb::Vec3f(d.x, d.y, d.z), span.x, span.y);
    auto dim_at = [&](const nanovdb::Coord& ijk) { return std::max(int(acc.getDim(ijk, iray)), kLeafDim); };
    nanovdb::HDDA<RayT, nanovdb::Coord> hdda;
    hdda.init(iray, span.x, span.y, dim_at(nanovdb::RoundDown<nanovdb::Coord>(iray(span.x))));
    shared::SylvaDvrAcc a = shared::sylva_dvr_acc_zero();
    std::uint32_t steps = 0, k_next = 0;
    while (a.alpha < kAlphaStop) {
        ++steps;
        if (hdda.update(iray, dim_at(hdda.voxel()))) continue;  // another node size here: re-entered
        if (hdda.dim() == kLeafDim && acc.probeLeaf(hdda.voxel()) != nullptr) {
            float t_end = std::min(hdda.next(), span.y);
            std::uint32_t k = std::max(shared::sylva_lattice_first(hdda.time(), kDt), k_next);
            for (;; ++k) {
                float t = shared::sylva_lattice_t(k, kDt);
                if (!(t < t_end) || a.alpha >= kAlphaStop) break;
                ++r.samples;
                composite(a, nano_sample(sample, o, d, t));
            }
            k_next = std::max(k_next, k);
        }
        if (!hdda.step()) break;
    }
    r.steps = steps + r.samples;
    r.rgba = shared::sylva_dvr_result(a);
    return r;
}

// ---- comparison and report ------------------------------------------------------------------

struct Diff {
    double max_abs = 0.0;
    std::size_t same_bits = 0, same_rgba8 = 0, pixels = 0;
};

std::uint32_t rgba8(vec4 c) {
    auto q = [](float x) { return static_cast<std::uint32_t>(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f)); };
    return q(c.x) | (q(c.y) << 8) | (q(c.z) << 16) | (q(c.w) << 24);
}

Diff compare(const Image& a, const Image& b) {
    Diff d;
    d.pixels = a.rgba.size();
    for (std::size_t i = 0; i < a.rgba.size(); ++i) {
        for (int c = 0; c < 4; ++c) d.max_abs = std::max(d.max_abs, double(std::abs(a.rgba[i][c] - b.rgba[i][c])));
        d.same_bits += std::memcmp(&a.rgba[i], &b.rgba[i], sizeof(vec4)) == 0;
        d.same_rgba8 += rgba8(a.rgba[i]) == rgba8(b.rgba[i]);
    }
    return d;
}

struct Options {
    std::vector<std::string> volumes{"aneurism", "bonsai", "engine"};
    std::size_t runs = 5;
    std::size_t threads = 2;
    vec3 view{0.3f, 0.2f, 1.0f};
    std::string data = SYLVA_DATA_DIR;
    std::string json;
};

/// Why `text` is not a view direction "x,y,z" (three finite numbers, not all 0); empty when it is
/// one (then in `view`).
std::string read_view(const std::string& text, vec3& view) {
    std::stringstream in(text);
    std::string part;
    float c[3] = {0.0f, 0.0f, 0.0f};
    int n = 0;
    bool ok = true;
    for (; ok && std::getline(in, part, ','); ++n) {
        double x = 0.0;
        ok = n < 3 && CLI::detail::lexical_cast(part, x) && std::isfinite(x) && std::abs(x) <= 1e30;
        if (ok) c[n] = static_cast<float>(x);
    }
    if (!ok || n != 3 || (c[0] == 0.0f && c[1] == 0.0f && c[2] == 0.0f))
        return "'" + text + "' is not a direction x,y,z (three numbers, not all 0)";
    view = vec3(c[0], c[1], c[2]);
    return std::string();
}

/// The command line, bound to `o`.
std::unique_ptr<CLI::App> make_app(Options& o) {
    auto app = std::make_unique<CLI::App>(
        "sylva-nanovdb-bench: the same-camera comparison with NanoVDB: its plain march and HDDA skipping "
        "beside sylva's native uint8 grid, plain march and ESS kd-tree, on the same rays",
        "sylva-nanovdb-bench");
    app->footer(
        "Volumes: NAME picks the file NAME_*.raw under --data (a uint8 volume); a missing one is left out.\n"
        "Same rays for all: an orthographic camera along --view, one ray a pixel, pixels one voxel apart,\n"
        "a 1-voxel lattice; the analytic TF alpha = clamp((d - 0.1) / 0.9, 0, 1) * 0.4, colour\n"
        "(d, d^2, 1 - d), early termination at 0.99. Reported per volume and renderer (nanovdb-plain,\n"
        "nanovdb-hdda, sylva-plain, sylva-kd): median rays/s over --runs renders, samples and steps per\n"
        "ray, build time cold and warm, the cold build's peak heap, grid and index bytes, and the image\n"
        "against the reference renderer (max |diff| and identical pixels). --json: one JSON object a line.\n"
        "Exit status: 0 when a volume ran, 1 on errors, 2 on bad usage, 77 when every volume is missing.");
    app->option_defaults()->take_last();  // an option given twice: the last value counts
    app->add_option("--volumes", o.volumes, "comma-separated volume names (below)")
        ->type_name("LIST")
        ->delimiter(',')
        ->default_str("aneurism,bonsai,engine")
        ->check(CLI::Validator(
            [](std::string& v) {
                bool ok = !v.empty() && v.find_first_of("/\\") == std::string::npos;
                return ok ? std::string() : "'" + v + "' is not a volume name (aneurism, bonsai, engine, ...)";
            },
            ""));
    app->add_option("--runs", o.runs, "timed renders per renderer; the median is reported")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t{1}, std::size_t{1000}));
    app->add_option("--threads", o.threads, "threads of every renderer and the kd-tree build")
        ->type_name("T")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t{1}, std::size_t{1024}));
    app->add_option_function<std::string>(
           "--view", [&o](const std::string& v) { read_view(v, o.view); }, "view direction of the orthographic camera")
        ->type_name("X,Y,Z")
        ->default_str("0.3,0.2,1")
        ->check(CLI::Validator(
            [](std::string& v) {
                vec3 unused(0.0f);
                return read_view(v, unused);
            },
            ""));
    app->add_option("--data", o.data, "folder with the volumes")->type_name("DIR")->capture_default_str();
    app->add_option("--json", o.json, "write one JSON object a row (volume, renderer, figures) a line")
        ->type_name("FILE");
    return app;
}

std::filesystem::path volume_file(const Options& o, const std::string& name) {
    for (const auto& e : std::filesystem::directory_iterator(o.data))
        if (e.path().filename().string().rfind(name + "_", 0) == 0 && e.path().extension() == ".raw") return e.path();
    return {};
}

struct Row {
    std::string volume, renderer;
    double rays_per_s = 0.0, samples_per_ray = 0.0, steps_per_ray = 0.0;
    double build_cold_ms = 0.0, build_warm_ms = 0.0, build_peak_mb = 0.0;
    std::size_t grid_bytes = 0, index_bytes = 0;
    std::string reference;
    Diff diff;
};

/// The bench's rays as a renderer's VolumeRenderParams: a ray buffer, the analytic TF as a host
/// hook, no opacity correction, the 1-voxel lattice, early termination at kAlphaStop.
VolumeRenderParams api_params(const Rays& rays) {
    VolumeRenderParams p;
    p.width = rays.width;
    p.height = rays.height;
    std::vector<float> buf(rays.origin.size() * 6);
    for (std::size_t i = 0; i < rays.origin.size(); ++i) {
        const vec3& o = rays.origin[i];
        float* r = &buf[i * 6];
        r[0] = o.x, r[1] = o.y, r[2] = o.z, r[3] = rays.dir.x, r[4] = rays.dir.y, r[5] = rays.dir.z;
    }
    p.rays = PixelRays::from_buffer(std::move(buf));
    p.tf_kind = TfKind::Hook;
    p.tf_hook = analytic_tf;
    p.opacity = OpacityCorrection::None;
    p.dt = kDt;
    p.unit = kDt;
    p.alpha_stop = kAlphaStop;
    return p;
}

/// Times a renderer of the public API (`frame()` -> Frame) as timed() does; the image and the
/// steps come back as an Image.
template <class F>
Image timed_api(std::size_t runs, double pixels, double& rays_per_s, F&& frame) {
    frame();  // warm-up
    std::vector<double> ms;
    Frame f;
    for (std::size_t r = 0; r < runs; ++r) {
        f = frame();
        ms.push_back(f.ms);
    }
    rays_per_s = pixels / (median(ms) / 1000.0);
    Image img;
    img.rgba = f.rgba;
    for (std::uint32_t s : f.steps) img.steps += s;
    img.ms = median(ms);
    return img;
}

template <class F>
Image timed(const Rays& rays, ThreadPool& pool, std::size_t runs, double& rays_per_s, F&& ray) {
    render(rays, pool, ray);  // warm-up (caches, page faults)
    std::vector<double> ms;
    Image img;
    for (std::size_t r = 0; r < runs; ++r) {
        img = render(rays, pool, ray);
        ms.push_back(img.ms);
    }
    rays_per_s = double(rays.origin.size()) / (median(ms) / 1000.0);
    return img;
}

void print(const Row& r) {
    std::printf("%-9s %-18s %9.2f Mrays/s %7.1f samples/ray %7.1f steps/ray  build cold %8.1f ms warm %8.1f ms peak %7.1f MB"
                "  grid %6.2f MB index %6.2f MB  vs %-12s max|diff| %.3g, identical %zu/%zu (rgba8 %zu)\n",
                r.volume.c_str(), r.renderer.c_str(), r.rays_per_s / 1e6, r.samples_per_ray, r.steps_per_ray,
                r.build_cold_ms, r.build_warm_ms, r.build_peak_mb, r.grid_bytes / 1e6, r.index_bytes / 1e6,
                r.reference.c_str(), r.diff.max_abs, r.diff.same_bits, r.diff.pixels, r.diff.same_rgba8);
    std::fflush(stdout);
}

nlohmann::json to_json(const Row& r, std::size_t threads, std::size_t runs) {
    return {{"volume", r.volume},
            {"renderer", r.renderer},
            {"threads", threads},
            {"runs", runs},
            {"rays_per_s", r.rays_per_s},
            {"samples_per_ray", r.samples_per_ray},
            {"steps_per_ray", r.steps_per_ray},
            {"build_cold_ms", r.build_cold_ms},
            {"build_warm_ms", r.build_warm_ms},
            {"build_peak_mb", r.build_peak_mb},
            {"grid_bytes", r.grid_bytes},
            {"index_bytes", r.index_bytes},
            {"reference", r.reference},
            {"max_abs_diff", r.diff.max_abs},
            {"identical_pixels", r.diff.same_bits},
            {"identical_rgba8", r.diff.same_rgba8},
            {"pixels", r.diff.pixels}};
}

std::vector<Row> bench_volume(const Options& o, const std::string& name, const std::filesystem::path& file,
                              ThreadPool& pool) {
    volume::Volume v = volume::read_raw(file, volume::parse_raw_name(file.filename().string()));
    v.range_lo = 0.0f;
    v.range_hi = 255.0f;  // density v / 255 on both sides
    v.spacing = vec3(1.0f);
    if (v.type != volume::ScalarType::U8) throw Error("nanovdb-bench: " + name + " is not uint8");
    Rays rays = ortho_rays(v.dims, o.view);
    double npx = double(rays.origin.size());
    std::vector<Row> rows;

    // NanoVDB: cold and warm builds, then the two renderers.
    std::size_t heap0 = reset_peak();
    auto t0 = Clock::now();
    auto handle = nano_build(v);
    double nano_cold = ms_since(t0);
    double nano_peak = double(g_heap_peak.load() - heap0 + handle.size()) / 1e6;
    t0 = Clock::now();
    { auto again = nano_build(v); }
    double nano_warm = ms_since(t0);
    const NanoGrid* grid = handle.grid<float>();
    if (grid == nullptr) throw Error("nanovdb-bench: NanoVDB gave no float grid");

    // sylva: the uint8 grid as it is, the ESS kd-tree of the TF's visible densities (d > 0.1).
    GridWords gw = GridWords::native(v);  // border constant 0 (the default)
    kdtree::Config cfg = kdtree::Config::deep();
    EssClassifier cls = ess_threshold_classifier(0.1f, 256);
    heap0 = reset_peak();
    t0 = Clock::now();
    std::vector<std::uint32_t> kd;
    {
        EssRebuilder<ThreadPool> ess_cold(gw, cfg, pool);
        kd = kdtree::encode(ess_cold.rebuild(cls));
    }
    double kd_cold = ms_since(t0);
    double kd_peak = double(g_heap_peak.load() - heap0) / 1e6;
    EssRebuilder<ThreadPool> ess(gw, cfg, pool);
    kd = kdtree::encode(ess.rebuild(cls));
    t0 = Clock::now();
    kd = kdtree::encode(ess.rebuild(cls));
    double kd_warm = ms_since(t0);

    shared::Words words{gw.words.data(), gw.words.size()}, kw{kd.data(), kd.size()};
    shared::SylvaGridDesc desc = gw.desc();
    auto kd_count = static_cast<std::uint32_t>(kd.size());

    Row base;
    base.volume = name;
    auto row = [&](const char* renderer, const Image& img, double rps) {
        Row r = base;
        r.renderer = renderer;
        r.rays_per_s = rps;
        r.samples_per_ray = double(img.samples) / npx;
        r.steps_per_ray = double(img.steps) / npx;
        return r;
    };
    double rps = 0.0;
    Image nplain = timed(rays, pool, o.runs, rps, [&](vec3 or_, vec3 d) { return nano_plain(*grid, v.dims, or_, d); });
    Row r1 = row("nanovdb-plain", nplain, rps);
    r1.build_cold_ms = nano_cold;
    r1.build_warm_ms = nano_warm;
    r1.build_peak_mb = nano_peak;
    r1.grid_bytes = handle.size();
    r1.reference = "sylva-plain";
    Image nhdda = timed(rays, pool, o.runs, rps, [&](vec3 or_, vec3 d) { return nano_hdda(*grid, v.dims, or_, d); });
    Row r2 = row("nanovdb-hdda", nhdda, rps);
    r2.build_cold_ms = nano_cold;
    r2.build_warm_ms = nano_warm;
    r2.build_peak_mb = nano_peak;
    r2.grid_bytes = handle.size();
    r2.reference = "nanovdb-plain";
    r2.diff = compare(nhdda, nplain);
    Image splain = timed(rays, pool, o.runs, rps, [&](vec3 or_, vec3 d) { return sylva_plain(words, desc, or_, d); });
    Row r3 = row("sylva-plain", splain, rps);
    r3.grid_bytes = gw.grid_bytes();
    r3.reference = "nanovdb-plain";
    r3.diff = compare(splain, nplain);
    r1.diff = compare(nplain, splain);
    Image skd = timed(rays, pool, o.runs, rps, [&](vec3 or_, vec3 d) { return sylva_kd(kw, kd_count, words, desc, or_, d); });
    Row r4 = row("sylva-kd", skd, rps);
    r4.build_cold_ms = kd_cold;
    r4.build_warm_ms = kd_warm;
    r4.build_peak_mb = kd_peak;
    r4.grid_bytes = gw.grid_bytes();
    r4.index_bytes = kd.size() * 4;
    r4.reference = "nanovdb-hdda";
    r4.diff = compare(skd, nhdda);
    Row r5 = r4;
    r5.renderer = "sylva-kd";
    r5.reference = "sylva-plain";
    r5.diff = compare(skd, splain);

    // sylva over the sparse grid (GridWords::sparse: 8^3 bricks, uniform ones held in the table),
    // the same kd-tree built from the sparse words: build = packing + the ESS build.
    heap0 = reset_peak();
    t0 = Clock::now();
    std::vector<std::uint32_t> kd_s;
    {
        GridWords sw_cold = GridWords::sparse(v);
        EssRebuilder<ThreadPool> ess_cold(sw_cold, cfg, pool);
        kd_s = kdtree::encode(ess_cold.rebuild(cls));
    }
    double sparse_cold = ms_since(t0);
    double sparse_peak = double(g_heap_peak.load() - heap0) / 1e6;
    t0 = Clock::now();
    GridWords sw = GridWords::sparse(v);
    double pack_warm = ms_since(t0);
    EssRebuilder<ThreadPool> ess_s(sw, cfg, pool);
    kd_s = kdtree::encode(ess_s.rebuild(cls));
    t0 = Clock::now();
    kd_s = kdtree::encode(ess_s.rebuild(cls));
    double sparse_warm = pack_warm + ms_since(t0);
    if (kd_s != kd) throw Error("nanovdb-bench: the kd-tree of the sparse grid differs from the dense grid's");
    shared::Words swords{sw.words.data(), sw.words.size()};
    shared::SylvaGridDesc sdesc = sw.desc();
    Image ssplain = timed(rays, pool, o.runs, rps, [&](vec3 or_, vec3 d) { return sylva_plain(swords, sdesc, or_, d); });
    Row r6 = row("sylva-plain-sparse", ssplain, rps);
    r6.grid_bytes = sw.grid_bytes();
    r6.reference = "sylva-plain";
    r6.diff = compare(ssplain, splain);
    Image sskd = timed(rays, pool, o.runs, rps, [&](vec3 or_, vec3 d) { return sylva_kd(kw, kd_count, swords, sdesc, or_, d); });
    Row r7 = row("sylva-kd-sparse", sskd, rps);
    r7.build_cold_ms = sparse_cold;
    r7.build_warm_ms = sparse_warm;
    r7.build_peak_mb = sparse_peak;
    r7.grid_bytes = sw.grid_bytes();
    r7.index_bytes = kd.size() * 4;
    r7.reference = "nanovdb-hdda";
    r7.diff = compare(sskd, nhdda);
    Row r8 = r7;
    r8.reference = "sylva-kd";
    r8.diff = compare(sskd, skd);
    // The public renderer API over the same dense grid, tree, rays and TF.
    VolumeRenderParams ap = api_params(rays);
    Image aplain = timed_api(o.runs, npx, rps, [&] { return render_dvr_cpu(gw, ap, pool); });
    Row r9 = row("sylva-api-plain", aplain, rps);
    r9.grid_bytes = gw.grid_bytes();
    r9.reference = "sylva-plain";
    r9.diff = compare(aplain, splain);
    Image akd = timed_api(o.runs, npx, rps, [&] { return render_kd_dvr_cpu(gw, kd, ap, pool); });
    Row r10 = row("sylva-api-kd", akd, rps);
    r10.build_cold_ms = kd_cold;
    r10.build_warm_ms = kd_warm;
    r10.build_peak_mb = kd_peak;
    r10.grid_bytes = gw.grid_bytes();
    r10.index_bytes = kd.size() * 4;
    r10.reference = "sylva-kd";
    r10.diff = compare(akd, skd);
    if (r9.diff.same_bits != r9.diff.pixels || r10.diff.same_bits != r10.diff.pixels)
        throw Error("nanovdb-bench: " + name + ": the renderer API's image differs from the per-ray loop's (" +
                    std::to_string(r9.diff.pixels - r9.diff.same_bits) + " plain, " +
                    std::to_string(r10.diff.pixels - r10.diff.same_bits) + " kd pixels, max |diff| " +
                    std::to_string(r9.diff.max_abs) + ", RGBA8-identical " + std::to_string(r9.diff.same_rgba8) + " of " +
                    std::to_string(r9.diff.pixels) + ")");
    // The bricked octree through the same API (sylva-api-octree): unorm8 bricks of 16^3 (border
    // 1: unshaded samples read no further, sylva/shared/octree_dvr.h) holding
    // the same voxels (v / 255 exactly), the constant 0 border, the hook's visibility (alpha 0 at
    // d <= 0.1) for its empty-node and octant tests. Build: the float grid the builder reads, the
    // octree, its encoding and the octant masks; cold = the first in the process.
    VolumeRenderParams aq = ap;
    aq.tf_hook_visible = [](float, float hi) { return hi > 0.1f; };
    auto build_octree = [&](octree::Tree& t, std::vector<std::uint32_t>& words, std::vector<std::uint32_t>& masks) {
        t = octree::build(volume::normalize(v), pool, {16, 1, octree::BrickFormat::Unorm8});
        words = octree::encode(t);
        masks = octree::octant_masks(octree::octant_ranges(words, t.bricks, pool), tf_opacity_prefix(aq), 0.0f);
    };
    octree::Tree ot;
    std::vector<std::uint32_t> owords, omasks;
    heap0 = reset_peak();
    t0 = Clock::now();
    build_octree(ot, owords, omasks);
    double oct_cold = ms_since(t0);
    double oct_peak = double(g_heap_peak.load() - heap0) / 1e6;
    t0 = Clock::now();
    build_octree(ot, owords, omasks);
    double oct_warm = ms_since(t0);
    OctreeView oview{owords, ot.bricks, 0xFFFFFFFFu, {}, omasks};
    Image aoct = timed_api(o.runs, npx, rps, [&] { return render_octree_dvr_cpu(oview, aq, pool); });
    Row r11 = row("sylva-api-octree", aoct, rps);
    r11.build_cold_ms = oct_cold;
    r11.build_warm_ms = oct_warm;
    r11.build_peak_mb = oct_peak;
    r11.grid_bytes = ot.brick_bytes();
    r11.index_bytes = (owords.size() + omasks.size()) * 4;
    r11.reference = "sylva-api-plain";
    r11.diff = compare(aoct, aplain);
    if (r11.diff.same_bits != r11.diff.pixels)
        throw Error("nanovdb-bench: " + name + ": the octree's image differs from the marcher's (" +
                    std::to_string(r11.diff.pixels - r11.diff.same_bits) + " pixels)");
    Row r12 = r11;
    r12.reference = "nanovdb-hdda";
    r12.diff = compare(aoct, nhdda);
    rows = {r1, r2, r3, r4, r5, r6, r7, r8, r9, r10, r11, r12};
    return rows;
}

}  // namespace

// The counting allocator: malloc / aligned_alloc under operator new, free under delete (GCC
// cannot see that the two pair up once inlined into the standard allocators).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t n) {
    void* p = std::malloc(n == 0 ? 1 : n);
    if (p == nullptr) throw std::bad_alloc();
    heap_add(p);
    return p;
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, std::align_val_t a) {
    std::size_t al = static_cast<std::size_t>(a);
    void* p = std::aligned_alloc(al, (std::max<std::size_t>(n, 1) + al - 1) / al * al);
    if (p == nullptr) throw std::bad_alloc();
    heap_add(p);
    return p;
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void operator delete(void* p) noexcept {
    heap_sub(p);
    std::free(p);
}
void operator delete[](void* p) noexcept { operator delete(p); }
void operator delete(void* p, std::size_t) noexcept { operator delete(p); }
void operator delete[](void* p, std::size_t) noexcept { operator delete(p); }
void operator delete(void* p, std::align_val_t) noexcept { operator delete(p); }
void operator delete[](void* p, std::align_val_t) noexcept { operator delete(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { operator delete(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { operator delete(p); }
#pragma GCC diagnostic pop

int main(int argc, char** argv) {
    Options o;
    std::unique_ptr<CLI::App> app = make_app(o);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    try {
        ThreadPool pool(o.threads);
        std::ofstream json;
        if (!o.json.empty()) json.open(o.json);
        std::printf("sylva-nanovdb-bench: %zu threads, %zu runs (median), view %g,%g,%g, NanoVDB %s\n", o.threads,
                    o.runs, o.view.x, o.view.y, o.view.z, nanovdb::Version().c_str());
        int missing = 0;
        for (const std::string& name : o.volumes) {
            std::filesystem::path file =
                std::filesystem::exists(o.data) ? volume_file(o, name) : std::filesystem::path{};
            if (file.empty()) {
                std::printf("%s: volume missing in %s, left out\n", name.c_str(), o.data.c_str());
                ++missing;
                continue;
            }
            for (const Row& r : bench_volume(o, name, file, pool)) {
                print(r);
                if (json.is_open()) json << to_json(r, o.threads, o.runs).dump() << "\n";
            }
        }
        return missing == int(o.volumes.size()) ? 77 : 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sylva-nanovdb-bench: %s\n", e.what());
        return 1;
    }
}
