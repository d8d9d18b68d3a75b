// sylva-kd-bench: empty-space kd-tree construction (Vidal et al.; Zellmann et al.) on real volumes
// and the generated sparse N-body volume (volume::sparse_nbody at 256^3, 512^3, 1024^3).
//
//   sylva-kd-bench [--data DIR] [--runs N] [--quick] [--cases LIST] [--sections LIST] [--json FILE]
//
// Sections, per data set (--sections builders,levels,replay,gpu; all by default):
//  * builders  Vidal's serial builder on a full SVT, Zellmann's parallel builder on 32^3 partial
//              SVTs and the binned builder on 8^3 local boxes (4 bins), shallow (Vidal's halting
//              criteria) and deep (leaves down to 8^3) trees, 1 and 2 threads: % of empty space
//              culled, leaves, nodes, depth, the occupancy phase (SVT / partial SVTs / local
//              boxes, classifying the volume on the fly) and the splitting phase, and their sum
//              over one streaming pass (read + classify + count) timed just before every build.
//              Zellmann et al.'s Table 1 rows are printed beside the data sets it has.
//  * levels    Vidal et al.'s "space removed" (Table 1: the % of the initial volume, the whole
//              grid, that the subvolumes leave out) by level of subdivision: level L is the tree
//              cut below depth L - 1 (level 1 = the root's box alone), L = 1..10, with the number
//              of subvolumes, for the shallow and deep trees.
//  * replay    a sequence of transfer functions (alpha > 0 decides occupancy): kdtree::Rebuilder
//              (and vk::KdRebuilder on the device) against a fresh build of the same tree, the two
//              timed side by side for every function; rebuild / fresh ratio, the rebuild's phases
//              (classification table and block verdicts, occupancy pass, splitting), the % of
//              8^3 blocks whose voxels were read, and the one-time preparation (block order and
//              value ranges) the rebuilder did at construction.
//  * gpu       the local-box pass on the Vulkan device (lavapipe here) against the host pass
//              (kdtree::local_boxes on 1 and 2 threads), timed side by side.
// Times are medians of --runs runs after a warm-up (the machine is shared: medians of several
// runs and ratios of runs measured side by side); 1024^3 builds take at most 3 runs, the replay
// runs each function twice (once from 512^3 on). JSON: an array of records
// {"case", "impl", "metric", "value", "unit"}.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/build_parallel.hpp>
#include <sylva/kdtree/rebuild.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/volume/classify.hpp>
#include <sylva/volume/occupancy.hpp>
#include <sylva/volume/partial_svt.hpp>
#include <sylva/volume/procedural.hpp>
#include <sylva/volume/read_raw.hpp>
#include <sylva/volume/svt.hpp>
#include <sylva/volume/transfer_function.hpp>
#if SYLVA_KD_BENCH_VULKAN
#include <sylva/vulkan/kd_build.hpp>
#endif

#include "cli.hpp"

using namespace sylva;

namespace {

struct Options {
    std::string data = SYLVA_KD_BENCH_DATA;
    int runs = 5;
    bool quick = false;
    std::vector<std::string> cases;     ///< empty = all (quick: engine, nbody128)
    std::vector<std::string> sections;  ///< empty = all
    std::string json;
    [[nodiscard]] bool section(const char* s) const {
        return sections.empty() || std::find(sections.begin(), sections.end(), s) != sections.end();
    }
};

/// A data set under a threshold, with Zellmann Table 1's rows where the paper has one.
struct Case {
    std::string name, file;  ///< file "" = the generated sparse N-body volume
    float threshold = 0.1f;
    std::uint32_t nbody = 0;  ///< edge of the generated volume
    const char* paper = nullptr;
};

// ---- measurement helpers ---------------------------------------------------------------------

double now_ms() {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// The JSON records of the whole run.
struct Report {
    struct Record {
        std::string case_name, impl, metric;
        double value;
        std::string unit;
    };
    std::vector<Record> records;
    void add(const std::string& c, const std::string& impl, const std::string& metric, double value, const char* unit) {
        records.push_back({c, impl, metric, value, unit});
    }
    void write(const std::string& path) const {
        std::ofstream f(path);
        f << "[\n";
        for (std::size_t i = 0; i < records.size(); ++i) {
            const Record& r = records[i];
            f << "  {\"case\": \"" << r.case_name << "\", \"impl\": \"" << r.impl << "\", \"metric\": \"" << r.metric
              << "\", \"value\": " << r.value << ", \"unit\": \"" << r.unit << "\"}" << (i + 1 < records.size() ? "," : "")
              << "\n";
        }
        f << "]\n";
        std::printf("\n%zu records written to %s\n", records.size(), path.c_str());
    }
};

/// The yardstick: one streaming pass (read + classify + count) over the source, sampled before
/// every timed build so that load from elsewhere hits it as it hits the builds.
struct StreamPass {
    std::function<std::uint64_t()> pass;
    std::vector<double> ms;
    void sample() {
        double t0 = now_ms();
        pass();
        ms.push_back(now_ms() - t0);
    }
};

// ---- section: builders -----------------------------------------------------------------------

/// One builder configuration, its median phases over the runs.
struct Row {
    std::string builder, tree;
    int threads = 1;
    double occupancy_ms = 0, split_ms = 0, total_ms = 0, stream_ms = 0, ratio = 0;
    double culled = 0;
    std::size_t leaves = 0, nodes = 0;
    std::uint32_t depth = 0;
};

/// Medians of `runs` builds after one untimed warm-up; each build is preceded by a streaming
/// pass, and the row's ratio is the median of the per-run total / stream ratios.
template <class F>
Row time_build(const std::string& builder, const std::string& tree, int threads, int runs, StreamPass& stream,
               F&& build) {
    build();
    Row row{builder, tree, threads};
    std::vector<double> occ, split, total, stream_ms, ratio;
    for (int r = 0; r < runs; ++r) {
        stream.sample();
        kdtree::Tree t = build();
        occ.push_back(t.stats.occupancy_ms);
        split.push_back(t.stats.split_ms);
        total.push_back(t.stats.occupancy_ms + t.stats.split_ms);
        stream_ms.push_back(stream.ms.back());
        ratio.push_back(total.back() / stream.ms.back());
        row.culled = t.stats.percent_culled();
        row.leaves = t.leaves.size();
        row.nodes = t.nodes.size();
        row.depth = t.stats.max_depth;
    }
    row.occupancy_ms = median(occ);
    row.split_ms = median(split);
    row.total_ms = median(total);
    row.stream_ms = median(stream_ms);
    row.ratio = median(ratio);
    return row;
}

/// Rebuilds `table` from `src` (reusing its storage, as after a transfer-function change:
/// Zellmann section 4.1 allocates the partial SVTs once per volume), then the tree.
template <class Table, class Build, class Assign>
kdtree::Tree rebuild_table(Table& table, Assign&& assign, Build&& build) {
    double t0 = now_ms();
    assign(table);
    double occupancy_ms = now_ms() - t0;
    kdtree::Tree t = build(table);
    t.stats.occupancy_ms = occupancy_ms;
    return t;
}

std::vector<std::pair<const char*, kdtree::Config>> tree_kinds() {
    return {{"shallow", kdtree::Config::shallow()}, {"deep", kdtree::Config::deep()}};
}

/// Vidal's serial builder (one thread: it ignores the executor). The table lives only here
/// (4 or 8 bytes a voxel).
template <volume::OccupancySource S>
void run_vidal(const S& src, int runs, StreamPass& stream, std::vector<Row>& rows) {
    if (volume::svt_needs_64bit(src.dims)) return;  // 64-bit tables: out of this machine's memory budget
    volume::SummedVolumeTable<std::uint32_t> svt;
    for (auto [tree, cfg] : tree_kinds())
        rows.push_back(time_build("vidal-svt", tree, 1, runs, stream, [&] {
            return rebuild_table(svt, [&](auto& t) { t.assign(src); }, [&](auto& t) { return kdtree::build(t, cfg); });
        }));
}

/// Zellmann's parallel builder and the binned builder on `threads` threads of `exec`.
template <volume::OccupancySource S, Executor X>
void run_parallel(const S& src, X& exec, int threads, int runs, StreamPass& stream, std::vector<Row>& rows) {
    {
        volume::PartialSvt<32> psvt;
        for (auto [tree, cfg] : tree_kinds())
            rows.push_back(time_build("zellmann-psvt32", tree, threads, runs, stream, [&] {
                return rebuild_table(psvt, [&](auto& t) { t.assign(src, exec); },
                                     [&](auto& t) { return kdtree::build(t, cfg, exec); });
            }));
    }
    for (auto [tree, cfg] : tree_kinds())
        rows.push_back(time_build("binned-8^3-4bins", tree, threads, runs, stream,
                                  [&] { return kdtree::build_binned(src, cfg.binned(), exec); }));
}

/// The ESS tree as sylva-render --index kd-binned builds it the first time (issue 15, item 5):
/// occupancy from the TF over every voxel's 3x3x3 neighbourhood, a deep binned tree, 2
/// threads, everything from scratch every run (EssRebuilder constructed anew). "ess-blocks":
/// block ranges (one streaming pass), the undecided blocks' voxels, over the grid the marcher
/// reads (`gw`: a file's uint8 / uint16 voxels as stored, as --grid native); "ess-codes":
/// segment codes of the density grid and kdtree::Rebuilder over them (the path before, and that
/// of Vulkan).
template <Executor X>
void run_ess(const GridWords& gw, const volume::DensityGrid& g, X& exec, int runs, StreamPass& stream,
             std::vector<Row>& rows) {
    std::vector<std::uint32_t> tf = volume::TransferFunction::ct_bone_tissue().packed_rgba8();
    kdtree::Config cfg = kdtree::Config::deep().binned();
    rows.push_back(time_build("ess-blocks-tf", "deep", 2, runs, stream, [&] {
        EssRebuilder<X> ess(gw, cfg, exec);
        kdtree::Tree t = ess.rebuild(tf);
        t.stats.occupancy_ms = ess.total_ms() - t.stats.split_ms;
        return t;
    }));
    rows.push_back(time_build("ess-codes-tf", "deep", 2, runs, stream, [&] {
        double t0 = now_ms();
        EssCodes codes = ess_codes(g, static_cast<std::uint32_t>(tf.size()), exec);
        kdtree::Rebuilder<X> r(codes.volume, cfg, exec);
        kdtree::Tree t = r.rebuild(ess_classifier(tf));
        t.stats.occupancy_ms = now_ms() - t0 - t.stats.split_ms;
        return t;
    }));
}

void print_rows(const std::vector<Row>& rows) {
    std::printf("  %-17s %-7s %3s %10s %10s %10s %8s %8s %7s %7s %5s\n", "builder", "tree", "thr", "occup.ms",
                "split.ms", "total.ms", "x stream", "culled%", "leaves", "nodes", "depth");
    for (const Row& r : rows)
        std::printf("  %-17s %-7s %3d %10.2f %10.2f %10.2f %8.2f %8.1f %7zu %7zu %5u\n", r.builder.c_str(),
                    r.tree.c_str(), r.threads, r.occupancy_ms, r.split_ms, r.total_ms, r.ratio, r.culled, r.leaves,
                    r.nodes, r.depth);
}

void report_rows(const std::string& c, const std::vector<Row>& rows, Report& rep) {
    for (const Row& r : rows) {
        std::string impl = r.builder + "/" + r.tree + "/" + std::to_string(r.threads) + "t";
        rep.add(c, impl, "occupancy_ms", r.occupancy_ms, "ms");
        rep.add(c, impl, "split_ms", r.split_ms, "ms");
        rep.add(c, impl, "total_ms", r.total_ms, "ms");
        rep.add(c, impl, "total_over_stream", r.ratio, "x");
        rep.add(c, impl, "culled", r.culled, "%");
        rep.add(c, impl, "leaves", double(r.leaves), "count");
        rep.add(c, impl, "nodes", double(r.nodes), "count");
        rep.add(c, impl, "depth", double(r.depth), "count");
    }
}

template <volume::OccupancySource S>
void section_builders(const Case& c, const S& src, const GridWords& gw, const volume::DensityGrid& grid, const Options& o,
                      Report& rep) {
    std::vector<Row> rows;
    SerialExecutor serial;
    ThreadPool pool(2);
    StreamPass s1{[&] { return volume::count_occupied(src, serial); }, {}};
    StreamPass s2{[&] { return volume::count_occupied(src, pool); }, {}};
    int runs = c.nbody >= 1024 ? std::min(o.runs, 3) : o.runs;
    // The headline: the first build a user runs, classification included, over one streaming pass.
    std::vector<Row> ess;
    if (volume::voxel_count(grid.dims) > (std::size_t{1} << 27)) {
        std::printf("  ESS build: left out above 512^3 voxels (the segment codes' row would take 6 bytes a voxel)\n");
    } else {
        run_ess(gw, grid, pool, runs, s2, ess);
        std::printf("  ESS build as sylva-render --index kd-binned runs it (CT TF over 3x3x3 neighbourhoods, deep binned "
                "tree, 2 threads, from scratch): %.2f ms = %.2fx one streaming pass (%.2f ms); with segment codes "
                "%.2f ms = %.2fx\n",
                    ess[0].total_ms, ess[0].ratio, ess[0].stream_ms, ess[1].total_ms, ess[1].ratio);
    }
    run_vidal(src, runs, s1, rows);
    run_parallel(src, serial, 1, runs, s1, rows);
    run_parallel(src, pool, 2, runs, s2, rows);
    std::printf("  builders (medians of %d runs); streaming pass %.2f ms (1 thread), %.2f ms (2 threads)\n", runs,
                median(s1.ms), median(s2.ms));
    rows.insert(rows.end(), ess.begin(), ess.end());
    print_rows(rows);
    if (c.paper) std::printf("  Zellmann Table 1 (CPU: 16 threads, Xeon Gold 5122; GPU: Titan V): %s\n", c.paper);
    rep.add(c.name, "stream/1t", "stream_ms", median(s1.ms), "ms");
    rep.add(c.name, "stream/2t", "stream_ms", median(s2.ms), "ms");
    report_rows(c.name, rows, rep);
}

// ---- section: levels (Vidal's space removed) ------------------------------------------------

/// Voxels and boxes of the tree cut below `depth`: nodes at that depth and shallower leaves.
std::pair<std::uint64_t, std::size_t> cut_volume(const kdtree::Tree& t, std::uint32_t depth) {
    std::uint64_t v = 0;
    std::size_t boxes = 0;
    for (const kdtree::Node& n : t.nodes)
        if (n.depth == depth || (n.depth < depth && n.is_leaf())) v += n.box.volume(), ++boxes;
    return {v, boxes};
}

template <volume::OccupancySource S>
void section_levels(const Case& c, const S& src, Report& rep) {
    ThreadPool pool(2);
    std::printf("  Vidal's space removed (%% of the whole grid outside the subvolumes) by level of subdivision\n"
                "  (level L = the tree cut below depth L - 1; [subvolumes])\n  %-22s",
                "tree");
    for (int l = 1; l <= 10; ++l) std::printf(" %11d", l);
    std::printf("\n");
    for (auto [name, cfg] : {std::pair{"shallow (Vidal)", kdtree::Config::shallow()},
                             std::pair{"deep", kdtree::Config::deep()},
                             std::pair{"deep binned", kdtree::Config::deep().binned()}}) {
        kdtree::Tree t = cfg.planes == kdtree::Planes::Binned ? kdtree::build_binned(src, cfg, pool)
                                                              : kdtree::build_parallel(src, cfg, pool);
        std::printf("  %-22s", name);
        for (std::uint32_t l = 1; l <= 10; ++l) {
            auto [v, boxes] = cut_volume(t, l - 1);
            double removed = 100.0 * double(t.stats.voxels - v) / double(t.stats.voxels);
            std::printf(" %5.1f [%4zu]", removed, boxes);
            rep.add(c.name, std::string("levels/") + name, "space_removed_level" + std::to_string(l), removed, "%");
            rep.add(c.name, std::string("levels/") + name, "subvolumes_level" + std::to_string(l), double(boxes), "count");
        }
        std::printf("\n");
    }
    std::printf("  Vidal Table 1 (8 models, 256^3/512^3): level 1: 1 subvolume, 0 %%; level 2: 2-4, 19-67 %%; "
                "level 3: 4-13, 27-76 %%\n");
}

// ---- section: replay of transfer functions ---------------------------------------------------

/// The replay: ramps whose opaque range moves up the density axis, the CT preset, and back.
std::vector<std::pair<std::string, volume::TransferFunction>> replay_tfs() {
    std::vector<std::pair<std::string, volume::TransferFunction>> v;
    for (float lo : {0.10f, 0.20f, 0.30f, 0.40f, 0.50f, 0.60f}) {
        char name[32];
        std::snprintf(name, sizeof name, "ramp %.2f-%.2f", lo, lo + 0.2f);
        v.emplace_back(name, volume::TransferFunction::ramp(lo, lo + 0.2f, vec4(1.0f)));
    }
    v.emplace_back("ct preset", volume::TransferFunction::ct_bone_tissue());
    v.emplace_back("ramp 0.10-0.30", volume::TransferFunction::ramp(0.10f, 0.30f, vec4(1.0f)));
    return v;
}

/// A fresh build: classify, allocate and build everything from scratch.
template <class V, Executor X>
kdtree::Tree fresh_build(const V& vol, const volume::TransferFunction& tf, const kdtree::Config& cfg, X& exec) {
    double t0 = now_ms();
    auto src = volume::classified(vol, volume::TransferFunctionAlpha(tf));
    kdtree::Tree t = cfg.planes == kdtree::Planes::Binned ? kdtree::build_binned(src, cfg, exec)
                                                          : kdtree::build_parallel(src, cfg, exec);
    double total = now_ms() - t0;
    t.stats.occupancy_ms = total - t.stats.split_ms;
    return t;
}

/// Side-by-side medians of the replay for one rebuilder and config.
struct ReplayResult {
    std::vector<double> rebuild, fresh, ratio, classify, occupancy, split, read;
    double prepare_ms = 0;
};

template <class V, class R, Executor X>
ReplayResult replay(const V& vol, R& rebuilder, const kdtree::Config& cfg, X& exec, int runs) {
    ReplayResult res;
    auto tfs = replay_tfs();
    rebuilder.rebuild(tfs.front().second);  // warm-up
    fresh_build(vol, tfs.front().second, cfg, exec);
    for (int r = 0; r < runs; ++r)
        for (const auto& [name, tf] : tfs) {
            bool fresh_first = (r % 2) == 1;  // alternate the order: neither side always runs warm
            kdtree::Tree a, t;
            if (fresh_first) a = fresh_build(vol, tf, cfg, exec);
            double t0 = now_ms();
            t = rebuilder.rebuild(tf);
            double b = now_ms() - t0;
            if (!fresh_first) a = fresh_build(vol, tf, cfg, exec);
            double f = a.stats.occupancy_ms + a.stats.split_ms;
            if (a.nodes != t.nodes) throw Error("sylva-kd-bench: rebuild and fresh build differ under " + name);
            res.rebuild.push_back(b);
            res.fresh.push_back(f);
            res.ratio.push_back(b / f);
            res.classify.push_back(rebuilder.timings().classify_ms);
            res.occupancy.push_back(rebuilder.timings().occupancy_ms);
            res.split.push_back(rebuilder.timings().split_ms);
            uvec3 nb = kdtree::block_counts(vol.dims);
            if (cfg.planes == kdtree::Planes::Binned)
                res.read.push_back(100.0 * double(rebuilder.timings().blocks_read) / double(std::size_t{nb.x} * nb.y * nb.z));
        }
    res.prepare_ms = rebuilder.prepare_ms();
    return res;
}

void print_replay(const Case& c, const std::string& impl, const ReplayResult& r, Report& rep) {
    std::printf("  %-30s %9.2f %9.2f %8.3f %9.3f %9.2f %9.2f", impl.c_str(), median(r.rebuild), median(r.fresh),
                median(r.ratio), median(r.classify), median(r.occupancy), median(r.split));
    if (r.read.empty()) {  // partial SVTs: every voxel is read, nothing is prepared
        std::printf(" %7s %9s\n", "-", "-");
    } else {
        std::printf(" %7.1f %9.1f\n", median(r.read), r.prepare_ms);
        rep.add(c.name, "replay/" + impl, "blocks_read", median(r.read), "%");
        rep.add(c.name, "replay/" + impl, "prepare_once_ms", r.prepare_ms, "ms");
    }
    rep.add(c.name, "replay/" + impl, "rebuild_ms", median(r.rebuild), "ms");
    rep.add(c.name, "replay/" + impl, "fresh_ms", median(r.fresh), "ms");
    rep.add(c.name, "replay/" + impl, "rebuild_over_fresh", median(r.ratio), "x");
    rep.add(c.name, "replay/" + impl, "classify_ms", median(r.classify), "ms");
    rep.add(c.name, "replay/" + impl, "occupancy_ms", median(r.occupancy), "ms");
    rep.add(c.name, "replay/" + impl, "split_ms", median(r.split), "ms");
}

#if SYLVA_KD_BENCH_VULKAN
std::optional<vk::Context> device_context() {
    try {
        return vk::Context::create();
    } catch (const Error& e) {
        std::printf("  no Vulkan device (%s): device rows left out\n", e.what());
        return std::nullopt;
    }
}
#endif

/// Runs of the replay: every function is a sample already; big grids replay once.
int replay_runs(const Case& c, const Options& o) { return c.nbody >= 512 ? 1 : std::min(o.runs, 2); }

template <class V>
void section_replay(const Case& c, const V& vol, const Options& o, Report& rep) {
    ThreadPool pool(2);
    int runs = replay_runs(c, o);
    std::printf("  replay of %zu transfer functions x %d runs, medians (rebuild and fresh build timed side by side)\n",
                replay_tfs().size(), runs);
    std::printf("  %-30s %9s %9s %8s %9s %9s %9s %7s %9s\n", "rebuilder / tree / threads", "rebuild", "fresh", "ratio",
                "class.ms", "occup.ms", "split.ms", "read%", "prep.ms");
    for (auto [tree, cfg] : {std::pair{"binned deep", kdtree::Config::deep().binned()},
                             std::pair{"binned shallow", kdtree::Config::shallow().binned()},
                             std::pair{"psvt32 deep", kdtree::Config::deep()},
                             std::pair{"psvt32 shallow", kdtree::Config::shallow()}}) {
        kdtree::Rebuilder r(vol, cfg, pool);
        print_replay(c, std::string("host/") + tree + "/2t", replay(vol, r, cfg, pool, runs), rep);
    }
#if SYLVA_KD_BENCH_VULKAN
    if (!o.section("gpu")) return;
    std::optional<vk::Context> ctx = device_context();
    if (!ctx) return;
    for (auto [tree, cfg] : {std::pair{"binned deep", kdtree::Config::deep().binned()},
                             std::pair{"binned shallow", kdtree::Config::shallow().binned()}}) {
        vk::KdRebuilder r(*ctx, vol, cfg, pool);
        print_replay(c, std::string(ctx->is_cpu() ? "lavapipe/" : "device/") + tree + "/2t",
                     replay(vol, r, cfg, pool, runs), rep);
    }
#endif
}

// ---- section: gpu local-box pass vs host -----------------------------------------------------

#if SYLVA_KD_BENCH_VULKAN
template <class V>
void section_gpu(const Case& c, const V& vol, const Options& o, Report& rep) {
    std::optional<vk::Context> ctx = device_context();
    if (!ctx) return;
    SerialExecutor serial;
    ThreadPool pool(2);
    volume::DensityThreshold th{c.threshold};
    auto src = volume::classified(vol, th);
    double t0 = now_ms();
    vk::LocalBoxPass pass(*ctx, vol);
    double upload = now_ms() - t0;
    kdtree::LocalBoxes dev = pass.local_boxes(th), host = kdtree::local_boxes(src, pool);  // warm-up
    if (dev.codes != host.codes || dev.boxes != host.boxes) throw Error("sylva-kd-bench: device boxes differ from the host's");
    std::vector<double> d_total, d_device, d_dispatch, d_gather, h1, h2, r1, r2;
    for (int r = 0; r < o.runs; ++r) {
        t0 = now_ms();
        kdtree::local_boxes(src, serial);
        h1.push_back(now_ms() - t0);
        t0 = now_ms();
        kdtree::local_boxes(src, pool);
        h2.push_back(now_ms() - t0);
        t0 = now_ms();
        pass.local_boxes(th, dev);
        d_total.push_back(now_ms() - t0);
        d_device.push_back(pass.timings().device_ms);
        d_dispatch.push_back(pass.timings().dispatch_ms);
        d_gather.push_back(pass.timings().readback_ms + pass.timings().gather_ms);
        r1.push_back(d_total.back() / h1.back());
        r2.push_back(d_total.back() / h2.back());
    }
    std::printf("  local-box pass (threshold %.2f), medians of %d runs side by side; %s, %zu slab(s), volume upload "
                "%.1f ms once\n",
                c.threshold, o.runs, ctx->device_name().c_str(), pass.slab_count(), upload);
    std::printf("  host 1 thread %.2f ms, host 2 threads %.2f ms; device pass %.2f ms (device clock %.2f, dispatch "
                "%.2f, readback + gather %.2f); device / host: %.2fx (1 thread), %.2fx (2 threads)\n",
                median(h1), median(h2), median(d_total), median(d_device), median(d_dispatch), median(d_gather),
                median(r1), median(r2));
    std::string dev_impl = ctx->is_cpu() ? "lavapipe" : "device";
    rep.add(c.name, "local_boxes/host/1t", "ms", median(h1), "ms");
    rep.add(c.name, "local_boxes/host/2t", "ms", median(h2), "ms");
    rep.add(c.name, "local_boxes/" + dev_impl, "ms", median(d_total), "ms");
    rep.add(c.name, "local_boxes/" + dev_impl, "device_clock_ms", median(d_device), "ms");
    rep.add(c.name, "local_boxes/" + dev_impl, "upload_once_ms", upload, "ms");
    rep.add(c.name, "local_boxes/" + dev_impl, "over_host_1t", median(r1), "x");
    rep.add(c.name, "local_boxes/" + dev_impl, "over_host_2t", median(r2), "x");
}
#endif

// ---- driver ----------------------------------------------------------------------------------

/// Every section on one data set (a Volume or a DensityGrid).
template <class V>
void run_case(const Case& c, const V& vol, const Options& o, Report& rep) {
    SerialExecutor serial;
    auto src = volume::classified(vol, volume::DensityThreshold{c.threshold});
    std::uint64_t occupied = volume::count_occupied(src, serial), voxels = volume::voxel_count(vol.dims);
    std::printf("\n%s %ux%ux%u, threshold %.2f: occupancy %.3f %% (%llu voxels)\n", c.file.empty() ? "nbody" : c.name.c_str(), vol.dims.x,
                vol.dims.y, vol.dims.z, c.threshold, 100.0 * double(occupied) / double(voxels),
                static_cast<unsigned long long>(occupied));
    rep.add(c.name, "volume", "occupancy", 100.0 * double(occupied) / double(voxels), "%");
    if (o.section("builders")) {
        if constexpr (std::is_same_v<V, volume::DensityGrid>) {
            section_builders(c, src, GridWords::from(vol), vol, o, rep);
        } else {
            volume::DensityGrid g = volume::normalize(vol);  // untimed, as sylva-render does at load
            section_builders(c, src, GridWords::native(vol), g, o, rep);
        }
    }
    if (o.section("levels")) section_levels(c, src, rep);
    if (o.section("replay")) section_replay(c, vol, o, rep);
#if SYLVA_KD_BENCH_VULKAN
    if (o.section("gpu")) section_gpu(c, vol, o, rep);
#endif
}

/// The command line, bound to `o`.
std::unique_ptr<CLI::App> make_app(Options& o) {
    auto app = std::make_unique<CLI::App>(
        "sylva-kd-bench: empty-space kd-tree builds (Vidal serial, Zellmann parallel and binned) beside a "
        "streaming pass and Zellmann's Table 1",
        "sylva-kd-bench");
    app->footer(
        "Cases: bonsai, aneurism, engine (files under --data; a missing one is skipped), nbody128 ...\n"
        "nbody1024 (the sparse N-body volume, generated). Sections, per case:\n"
        "  builders  Vidal's serial, Zellmann's parallel and the binned builder, shallow and deep trees,\n"
        "            1 and 2 threads, beside one streaming pass and Zellmann's Table 1; first, the headline:\n"
        "            the ESS build sylva-render --index kd-binned runs (TF over 3x3x3 neighbourhoods,\n"
        "            classification included) over one streaming pass, from block ranges and from\n"
        "            segment codes (up to 512^3 voxels)\n"
        "  levels    Vidal's space removed by level of subdivision (his Table 1)\n"
        "  replay    a sequence of transfer functions: kdtree::Rebuilder against fresh builds\n"
        "  gpu       the local-box pass on the Vulkan device against the host (Vulkan builds only)\n"
        "Times are medians of --runs runs after a warm-up.\n"
        "Exit status: 0 when a case ran, 1 on errors or when every case was missing, 2 on bad usage.");
    app->add_option("--data", o.data, "folder with the volumes")->type_name("DIR")->capture_default_str();
    app->add_option("--runs", o.runs, "timed runs per measurement; medians are reported")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(1, 1000));
    app->add_flag("--quick", o.quick, "the smoke configuration: cases engine,nbody128 unless --cases");
    app->add_option("--cases", o.cases, "comma-separated cases (default: all but nbody128)")
        ->type_name("LIST")
        ->delimiter(',')
        ->check(CLI::IsMember({"bonsai", "aneurism", "engine", "nbody128", "nbody256", "nbody512", "nbody1024"}));
    app->add_option("--sections", o.sections, "comma-separated sections to run (default: all)")
        ->type_name("LIST")
        ->delimiter(',')
        ->check(CLI::IsMember({"builders", "levels", "replay", "gpu"}));
    app->add_option("--json", o.json, "write every figure as a JSON array of {case, impl, metric, value, unit}")
        ->type_name("FILE");
    return app;
}

std::vector<Case> all_cases() {
    return {
        {"bonsai", "bonsai_256x256x256_uint8.raw", 0.30f, 0,
         "occupancy 6.87 %; CPU partial SVTs 27 ms, shallow 79.9 % culled split 42 ms, deep 96.9 % split 56 ms; "
         "GPU SVTs 1 ms, shallow 76.7 % split 2 ms, deep 97.5 % split 98 ms"},
        {"aneurism", "aneurism_256x256x256_uint8.raw", 0.10f, 0,
         "occupancy 1.01 %; CPU partial SVTs 27 ms, shallow 54.7 % culled split 41 ms, deep 81.9 % split 110 ms; "
         "GPU SVTs 1 ms, shallow 52.6 % split 2 ms, deep 82.6 % split 198 ms"},
        {"engine", "engine_256x256x128_uint8.raw", 0.10f, 0, nullptr},
        {"nbody128", "", 0.40f, 128, nullptr},
        {"nbody256", "", 0.40f, 256,
         "occupancy 0.14 %; CPU partial SVTs 26 ms, shallow 71.6 % culled split 31 ms, deep 88.7 % split 66 ms; "
         "GPU SVTs 1 ms, shallow 67.6 % split 1 ms, deep 87.1 % split 118 ms"},
        {"nbody512", "", 0.40f, 512,
         "occupancy 0.14 %; CPU partial SVTs 111 ms, shallow 72.0 % culled split 52 ms, deep 94.2 % split 270 ms; "
         "GPU SVTs 6 ms, shallow 69.2 % split 2 ms, deep 93.4 % split 510 ms"},
        {"nbody1024", "", 0.40f, 1024,
         "occupancy 0.15 %; CPU partial SVTs 826 ms, shallow 54.0 % culled split 514 ms, deep 96.5 % split 1331 ms; "
         "GPU SVTs 48 ms, shallow 69.0 % split 5 ms, deep 91.4 % split 1002 ms"},
    };
}

std::vector<Case> selected_cases(const Options& o) {
    std::vector<std::string> names = o.cases;
    if (names.empty() && o.quick) names = {"engine", "nbody128"};
    if (names.empty()) names = {"bonsai", "aneurism", "engine", "nbody256", "nbody512", "nbody1024"};
    std::vector<Case> out;
    for (const std::string& n : names) {
        auto all = all_cases();
        auto it = std::find_if(all.begin(), all.end(), [&](const Case& c) { return c.name == n; });
        if (it == all.end()) throw Error("sylva-kd-bench: unknown case '" + n + "'");
        out.push_back(*it);
    }
    return out;
}

/// Generates or reads one case and runs it; false when its file is missing.
bool run_one(const Case& c, const Options& o, Report& rep) {
    if (c.file.empty()) {  // generated: sparse_nbody, classified as a float density grid
        double t0 = now_ms();
        volume::DensityGrid g = volume::sparse_nbody({c.nbody, c.nbody, c.nbody}, 1);
        std::printf("\n(sparse_nbody %u^3 generated in %.1f s, %.2f GiB of float densities)", c.nbody,
                    (now_ms() - t0) / 1000.0, double(g.values.size()) * 4.0 / double(1u << 30));
        run_case(c, g, o, rep);
        return true;
    }
    std::filesystem::path p = std::filesystem::path(o.data) / c.file;
    if (!std::filesystem::exists(p)) {
        std::fprintf(stderr, "sylva-kd-bench: %s is missing, skipped\n", p.string().c_str());
        return false;
    }
    volume::Volume v = volume::read_raw(p, volume::parse_raw_name(p.filename().string()));
    run_case(c, v, o, rep);
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    std::unique_ptr<CLI::App> app = make_app(o);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    double load[3] = {0, 0, 0};
    if (getloadavg(load, 3) < 0) load[0] = -1;
    std::printf("sylva-kd-bench: data %s, medians of %d runs, hardware threads %u, load average %.2f\n", o.data.c_str(),
                o.runs, std::thread::hardware_concurrency(), load[0]);
    Report rep;
    int done = 0;
    try {
        for (const Case& c : selected_cases(o)) done += run_one(c, o, rep) ? 1 : 0;
    } catch (const Error& e) {
        std::fprintf(stderr, "sylva-kd-bench: %s\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "sylva-kd-bench: out of memory\n");
        return 1;
    }
    if (!o.json.empty()) rep.write(o.json);
    return done ? 0 : 1;
}
