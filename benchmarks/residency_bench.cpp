// sylva-residency-bench: the out-of-core bricked octree (issue 13; sylva/octree/residency.hpp)
// over a scripted orbit. Per frame: time (refinement + render), bricks loaded, uploads; over the
// run: median and max frame time (no frame waits for I/O: a frame over 2x the median is
// counted), host and device cache hit rates, peak RSS against the budgets. Then the last view
// is held until nothing more arrives, and its image is compared (PSNR) with the same view
// rendered with budgets large enough for the whole cut.
//
//   sylva-residency-bench [--source tree|store] [--volume procedural:ml:N | STORE] [--frames 60]
//                         [--memory-budget 256M] [--device-budget 128M] [--size 320x240]
//                         [--brick 16|32] [--lod-pixels 1] [--feedback on|off] [--threads T]
//                         [--json FILE] [--quick]
//
// --source tree builds the octree in core (TreeBrickSource: the RSS then includes the whole
// tree, so only the store's RSS measures the budgets); --source store reads a brick store made
// by sylva-store build (needs sylva::store). Records {case, impl, metric, value, unit} through
// bench::Report.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/octree/brick_source.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/residency.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/transfer_function.hpp>
#ifdef SYLVA_RESIDENCY_BENCH_STORE
#include <sylva/store/store.hpp>
#endif

#include "bench.hpp"
#include "cli.hpp"

using namespace sylva;

namespace {

struct Args {
    std::string source = "tree", volume = "procedural:ml:256", json;
    std::uint32_t frames = 60, width = 320, height = 240, brick = 32, threads = 0;
    std::size_t memory_budget = std::size_t{256} << 20, device_budget = std::size_t{128} << 20;
    float lod_pixels = 1.0f;
    bool feedback = true;
};

/// Why `v` is not a byte count (a number with an optional K, M or G suffix, powers of 1024, at
/// least 1 byte); empty when it is one (then in `bytes`).
std::string read_bytes(const std::string& v, std::size_t& bytes) {
    double scale = 1.0;
    std::string d = v;
    char u = d.empty() ? '0' : static_cast<char>(std::toupper(static_cast<unsigned char>(d.back())));
    if (u == 'K' || u == 'M' || u == 'G') {
        scale = u == 'K' ? 1024.0 : u == 'M' ? 1048576.0 : 1073741824.0;
        d.pop_back();
    }
    double x = 0.0;
    if (!CLI::detail::lexical_cast(d, x) || !(x * scale >= 1.0 && x * scale < 1.8e19))
        return "'" + v + "' is not a size in bytes (K/M/G suffixes)";
    bytes = static_cast<std::size_t>(x * scale);
    return std::string();
}

/// Adds the byte-count option `name` (K/M/G suffixes) writing `bytes`.
void add_bytes(CLI::App& app, const std::string& name, std::size_t& bytes, const std::string& description) {
    app.add_option_function<std::string>(
           name, [&bytes](const std::string& v) { read_bytes(v, bytes); }, description)
        ->type_name("BYTES")
        ->default_str(std::to_string(bytes >> 20) + "M")
        ->check(CLI::Validator(
            [](std::string& v) {
                std::size_t b = 0;
                return read_bytes(v, b);
            },
            ""));
}

/// The command line, bound to `a`; `quick` for --quick, applied by apply_quick after parsing.
std::unique_ptr<CLI::App> make_app(Args& a, bool& quick) {
    auto app = std::make_unique<CLI::App>(
        "sylva-residency-bench: the out-of-core bricked octree over a scripted orbit: frame times, bricks "
        "loaded, cache hit rates, peak RSS against the budgets, PSNR of the held last view",
        "sylva-residency-bench");
    app->footer(
        "--source tree builds the octree in core (TreeBrickSource: the RSS then includes the whole tree,\n"
        "so only the store's RSS measures the budgets); --source store reads a brick store made by\n"
        "sylva-store build (needs sylva::store). --quick: procedural:ml:64, 12 frames, 96x72, brick 16,\n"
        "budgets 4M and 2M; options given beside it keep their values.\n"
        "Exit status: 0 on success, 1 on errors, 2 on bad usage.");
    app->add_option("--source", a.source, "tree (built in core) or store (a brick store)")
        ->capture_default_str()
        ->check(CLI::IsMember({"tree", "store"}));
    app->add_option("--volume", a.volume, "procedural:ml:N (Marschner-Lobb N^3) for tree, a store directory for store")
        ->capture_default_str();
    app->add_option("--frames", a.frames, "frames of the orbit")->type_name("N")->capture_default_str()->check(CLI::Range(1u, 1000000u));
    add_bytes(*app, "--memory-budget", a.memory_budget, "host brick cache budget (K/M/G suffixes)");
    add_bytes(*app, "--device-budget", a.device_budget, "device brick pool budget (K/M/G suffixes)");
    bench_cli::add_size(*app, "--size", a.width, a.height, "image size");
    app->add_option("--brick", a.brick, "brick size of the in-core tree (16 or 32)")
        ->type_name("B")
        ->capture_default_str()
        ->check(CLI::Range(1u, 1024u));
    app->add_option("--lod-pixels", a.lod_pixels, "refine while a node's voxel projects larger than P pixels")
        ->type_name("P")
        ->capture_default_str()
        ->check(bench_cli::number_in(1e-3, 1e4));
    app->add_option_function<std::string>(
           "--feedback", [&a](const std::string& v) { a.feedback = v == "on"; },
           "visibility feedback: refine only nodes a ray reached in the previous frame")
        ->default_str("on")
        ->check(CLI::IsMember({"on", "off"}));
    app->add_option("--threads", a.threads, "host threads (default: all)")->type_name("T")->check(CLI::Range(1u, 1024u));
    app->add_option("--json", a.json, "write every figure as a JSON array of {case, impl, metric, value, unit}")
        ->type_name("FILE");
    app->add_flag("--quick", quick, "the smoke configuration (below)");
    return app;
}

/// --quick's values for the options not given on the command line.
void apply_quick(const CLI::App& app, Args& a) {
    auto unset = [&](const char* name) { return app.count(name) == 0; };
    if (unset("--volume")) a.volume = "procedural:ml:64";
    if (unset("--frames")) a.frames = 12;
    if (unset("--size")) a.width = 96, a.height = 72;
    if (unset("--brick")) a.brick = 16;
    if (unset("--memory-budget")) a.memory_budget = 4 << 20;
    if (unset("--device-budget")) a.device_budget = 2 << 20;
}

std::size_t peak_rss() {
    struct rusage u {};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<std::size_t>(u.ru_maxrss) * 1024u;
}

/// RssAnon and RssFile of /proc/self/status now, bytes (0 where unreadable): anonymous memory
/// (caches, pool, heap) apart from file pages mapped in (the store's LMDB map counts in the RSS
/// while its pages are resident, though the kernel may drop them at any time).
std::pair<std::size_t, std::size_t> rss_anon_file() {
    std::FILE* f = std::fopen("/proc/self/status", "r");
    if (!f) return {0, 0};
    char line[256];
    std::size_t anon = 0, file = 0;
    while (std::fgets(line, sizeof line, f)) {
        unsigned long kb = 0;
        if (std::sscanf(line, "RssAnon: %lu", &kb) == 1) anon = kb * 1024u;
        if (std::sscanf(line, "RssFile: %lu", &kb) == 1) file = kb * 1024u;
    }
    std::fclose(f);
    return {anon, file};
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double psnr(const Frame& a, const Frame& b) {
    double se = 0.0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        for (int c = 0; c < 4; ++c) {
            double d = std::clamp(double(a.rgba[i][c]), 0.0, 1.0) - std::clamp(double(b.rgba[i][c]), 0.0, 1.0);
            se += d * d;
        }
    double mse = se / double(std::max<std::size_t>(a.rgba.size() * 4, 1));
    return mse > 0.0 ? 10.0 * std::log10(1.0 / mse) : 999.0;
}

VolumeRenderParams view_params(const Args& a, const shared::SylvaOctHeader& h, std::uint32_t frame) {
    VolumeRenderParams p;
    p.width = a.width;
    p.height = a.height;
    Aabb box{vec3(0.0f), vec3(h.dims) * h.spacing};
    float ang = 6.2831853f * float(frame) / float(a.frames);
    vec3 from(0.4f * std::cos(ang) + std::sin(ang), 0.3f, -0.4f * std::sin(ang) + std::cos(ang));
    p.camera = Camera::framing(box, from).frame(a.width, a.height);
    p.tf = volume::TransferFunction::ct_bone_tissue().packed_rgba8();
    vec3 e = box.extent();
    p.dt = std::max(e.x, std::max(e.y, e.z)) / 1024.0f;
    p.unit = std::min(h.spacing.x, std::min(h.spacing.y, h.spacing.z));
    p.shading = false;
    return p;
}

/// Holds the view of frame `frame` until nothing is requested, uploaded or waiting (at most
/// `max` frames, the loader drained between frames); the last image.
template <class Res>
Frame settle(Res& res, octree::HostBrickPool& pool, const VolumeRenderParams& p, const OctreeTerminal& term, ThreadPool& exec,
             int max, int& frames) {
    Frame f;
    for (frames = 1; frames <= max; ++frames) {
        const octree::ResidencyFrame& r = res.update(octree::cut_view(p.camera, p.width, p.height), term);
        f = render_octree_dvr_cpu(OctreeView{r.words, pool.words, 0xFFFFFFFFu, res.feedback()}, p, exec);
        res.wait_loads();
        if (frames > 2 && r.requests == 0 && r.uploads == 0 && r.waiting == 0) break;
    }
    return f;
}

template <class S>
int run(const Args& a, const S& src, const std::string& case_name, bench::Report& rep) {
    ThreadPool exec(a.threads);
    octree::ResidencyConfig cfg;
    cfg.host_budget_bytes = a.memory_budget;
    cfg.device_budget_bytes = a.device_budget;
    cfg.lod_pixels = a.lod_pixels;
    cfg.visibility_feedback = a.feedback;
    cfg.report_bad_bricks = true;
    std::span<const std::uint32_t> index = src.index();
    std::size_t rss_before = peak_rss();
    octree::HostBrickPool pool(octree::pool_slots(index, cfg), index[8]);
    octree::Residency res(src, pool, cfg);
    VolumeRenderParams p = view_params(a, res.header(), 0);
    OctreeTerminal term(index, p, false);
    std::vector<double> ms, update_ms;
    std::size_t anon_max = 0, file_max = 0;  // sampled after every frame
    Frame f;
    std::uint64_t loaded_max = 0;
    std::printf("%s: %u frames of %ux%u, budgets host %.0f MB, device %.0f MB (%u slots of %zu bytes)\n", case_name.c_str(),
                a.frames, a.width, a.height, double(a.memory_budget) / 1048576.0, double(a.device_budget) / 1048576.0, res.slots(),
                res.brick_bytes());
    for (std::uint32_t i = 0; i < a.frames; ++i) {
        p.camera = view_params(a, res.header(), i).camera;
        auto t0 = std::chrono::steady_clock::now();
        const octree::ResidencyFrame& r = res.update(octree::cut_view(p.camera, p.width, p.height), term);
        f = render_octree_dvr_cpu(OctreeView{r.words, pool.words, 0xFFFFFFFFu, res.feedback()}, p, exec);
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        update_ms.push_back(r.ms);
        auto [anon, file] = rss_anon_file();
        anon_max = std::max(anon_max, anon);
        file_max = std::max(file_max, file);
        loaded_max = std::max(loaded_max, r.loaded);
        std::printf("  frame %3u  %8.2f ms (update %.2f)  loaded %5llu  uploads %4u  requests %5u  cut %6u nodes, deepest %u\n", i,
                    ms.back(), r.ms, static_cast<unsigned long long>(r.loaded), r.uploads, r.requests, r.cut.nodes, r.cut.deepest);
        rep.add(case_name, "orbit", "frame_ms_" + std::to_string(i), ms.back(), "ms");
        rep.add(case_name, "orbit", "bricks_loaded_" + std::to_string(i), double(r.loaded), "bricks");
    }
    double med = median(ms), worst = *std::max_element(ms.begin(), ms.end());
    // The refinement is the only part of a frame that could wait for I/O (it never does: what
    // is not resident is requested and the parent drawn); the render's time follows the cut.
    double upd_med = median(update_ms), upd_max = *std::max_element(update_ms.begin(), update_ms.end());
    std::size_t stalls = std::size_t(std::count_if(ms.begin(), ms.end(), [&](double m) { return m > 2.0 * med; }));
    octree::HostCacheCounters hc = res.host_counters();
    const octree::ResidencyCounters& c = res.counters();
    double host_hit = hc.hits + hc.misses ? double(hc.hits) / double(hc.hits + hc.misses) : 0.0;
    double dev_hit = c.device_hits + c.device_misses ? double(c.device_hits) / double(c.device_hits + c.device_misses) : 0.0;
    std::size_t rss = peak_rss();
    std::size_t image = std::size_t{a.width} * a.height * (16 + 4);
    double bound = 1.25 * double(a.memory_budget + a.device_budget) + double(image);
    // Hold the last view until it has converged, then the same view with room for everything.
    int settle_frames = 0;
    Frame held = settle(res, pool, p, term, exec, 400, settle_frames);
    // "Budgets large enough for the whole cut": the cut select_octree_cut picks for this view with
    // every brick available, and some room.
    octree::Cut whole_cut = select_octree_cut(index, p, {cfg.lod_pixels, cfg.max_nodes}, false);
    octree::ResidencyConfig big = cfg;
    big.host_budget_bytes = big.device_budget_bytes = (std::size_t{whole_cut.nodes} + 64) * index[8] * 4;
    big.max_uploads_per_frame = whole_cut.nodes + 64;
    std::printf("whole cut of the last view: %u nodes (%.1f MB of bricks)\n", whole_cut.nodes,
                double(big.device_budget_bytes) / 1048576.0);
    octree::HostBrickPool big_pool(octree::pool_slots(index, big), index[8]);
    octree::Residency ref(src, big_pool, big);
    int ref_frames = 0;
    Frame whole = settle(ref, big_pool, p, term, exec, 400, ref_frames);
    double q = psnr(held, whole);
    std::printf("frame time median %.2f ms, max %.2f ms (%.2fx), frames over 2x the median %zu\n", med, worst, worst / med, stalls);
    std::printf("refinement (update) median %.2f ms, max %.2f ms: %.3f of the median frame\n", upd_med, upd_max,
                upd_max / med);
    std::printf("host cache hit rate %.3f, device pool hit rate %.3f; loaded %llu, uploads %llu, evicted host %llu device %llu\n",
                host_hit, dev_hit, static_cast<unsigned long long>(res.loader_counters().loaded),
                static_cast<unsigned long long>(c.uploads), static_cast<unsigned long long>(hc.evicted),
                static_cast<unsigned long long>(c.device_evicted));
    std::printf("peak RSS %.1f MB (before the residency %.1f MB); 1.25 x budgets + image = %.1f MB\n", double(rss) / 1048576.0,
                double(rss_before) / 1048576.0, bound / 1048576.0);
    std::printf("anonymous RSS, max over the frames %.1f MB; file-backed RSS (the store's map) max %.1f MB\n",
                double(anon_max) / 1048576.0, double(file_max) / 1048576.0);
    std::printf("held view converged in %d frames; PSNR %.2f dB against budgets for the whole cut (%d frames)\n", settle_frames, q,
                ref_frames);
    rep.add(case_name, "orbit", "frame_ms_median", med, "ms");
    rep.add(case_name, "orbit", "frame_ms_max", worst, "ms");
    rep.add(case_name, "orbit", "frame_max_over_median", worst / med, "x");
    rep.add(case_name, "orbit", "frames_over_2x_median", double(stalls), "frames");
    rep.add(case_name, "orbit", "update_ms_median", upd_med, "ms");
    rep.add(case_name, "orbit", "update_ms_max", upd_max, "ms");
    rep.add(case_name, "orbit", "bricks_loaded_max_per_frame", double(loaded_max), "bricks");
    rep.add(case_name, "orbit", "bricks_loaded", double(res.loader_counters().loaded), "bricks");
    rep.add(case_name, "orbit", "host_hit_rate", host_hit, "ratio");
    rep.add(case_name, "orbit", "device_hit_rate", dev_hit, "ratio");
    rep.add(case_name, "orbit", "host_evicted", double(hc.evicted), "bricks");
    rep.add(case_name, "orbit", "device_evicted", double(c.device_evicted), "bricks");
    rep.add(case_name, "orbit", "host_cache_peak_bytes", double(hc.peak_bytes), "bytes");
    rep.add(case_name, "orbit", "device_pool_bytes", double(res.device_pool_bytes()), "bytes");
    rep.add(case_name, "orbit", "peak_rss_bytes", double(rss), "bytes");
    rep.add(case_name, "orbit", "peak_rss_before_bytes", double(rss_before), "bytes");
    rep.add(case_name, "orbit", "rss_bound_bytes", bound, "bytes");
    rep.add(case_name, "orbit", "rss_anon_max_bytes", double(anon_max), "bytes");
    rep.add(case_name, "orbit", "rss_file_max_bytes", double(file_max), "bytes");
    rep.add(case_name, "held", "psnr_vs_whole_cut", q, "dB");
    rep.add(case_name, "held", "settle_frames", double(settle_frames), "frames");
    rep.add(case_name, "held", "whole_cut_nodes", double(whole_cut.nodes), "nodes");
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    Args a;
    bool quick = false;
    std::unique_ptr<CLI::App> app = make_app(a, quick);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    if (quick) apply_quick(*app, a);
    try {
        bench::Report rep;
        if (a.source == "tree") {
            std::string n = a.volume.rfind("procedural:ml:", 0) == 0 ? a.volume.substr(14) : "";
            if (n.empty()) throw std::invalid_argument("--source tree takes --volume procedural:ml:N");
            std::uint32_t side = static_cast<std::uint32_t>(std::stoul(n));
            ThreadPool pool(a.threads);
            octree::Tree t = octree::build(volume::marschner_lobb({side, side, side}), pool, {a.brick, 2});
            octree::TreeBrickSource src(std::move(t));
            run(a, src, "tree-ml" + n, rep);
        } else {
#ifdef SYLVA_RESIDENCY_BENCH_STORE
            store::Store st = store::Store::open(a.volume);
            run(a, st, "store", rep);
#else
            throw std::invalid_argument("--source store: built without sylva::store");
#endif
        }
        if (!a.json.empty()) rep.write_json(a.json);
    } catch (const std::exception& e) {
        std::cerr << "sylva-residency-bench: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
