// benchmarks/kinkelin_tables.cpp -- sylva-tables: Kinkelin's Table 3 (lobster, engine) and
// Table 6 (aneurism at resampling factors 1, 1.5, 2) measured with sylva and printed beside
// the paper's figures.
//
//   sylva-tables [--data DIR] [--json FILE] [--threads N] [--runs N] [--case NAME] [--help]
//
// Per case: BIH elements (voxels with normalised density >= 0.1), construction time of the
// full BIH (build + node statistics, median of --runs), nodes, % single-child nodes, max depth
// (root = 0), full size (ours and at the paper's 40 bytes a node), and the default LoD (75 %
// element density, 1 % std. dev., chunk depth 2): extraction time (median), nodes, depth, size
// at 8 bytes a node, and that size relative to the 16-bit source grid. Sizes are KB = ceil(bytes
// / 1024), which reproduces the paper's rounding (e.g. 726,844 x 40 B = 28,393 KB). Each case
// is also measured with the +-inf empty-child variant ("/inf-planes"). JSON records are
// {case, impl: "sylva" | "paper", metric, value, unit}.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/volume/grid.hpp>
#include <sylva/volume/read_raw.hpp>
#include <sylva/volume/resample.hpp>
#include <sylva/volume/voxels.hpp>

#include "cli.hpp"

#ifndef SYLVA_DATA_DIR
#define SYLVA_DATA_DIR "../shared/data"
#endif

namespace {

using namespace sylva;

struct Options {
    std::string data = SYLVA_DATA_DIR;
    std::string json;
    std::size_t threads = 0;  ///< 0: hardware concurrency
    std::size_t runs = 3;
    std::string only;
};

/// The command line, bound to `o`.
std::unique_ptr<CLI::App> make_app(Options& o) {
    auto app = std::make_unique<CLI::App>(
        "sylva-tables: Kinkelin's Tables 3 and 6 (full voxel BIH, node statistics, default LoD) measured "
        "beside the paper's figures",
        "sylva-tables");
    app->footer(
        "Exit status: 0 on success, 1 when a volume is missing or unreadable (unless the environment\n"
        "sets SYLVA_ALLOW_MISSING_DATA=1: then those cases are left out), 2 on bad usage.");
    app->add_option("--data", o.data, "folder with the volumes")->type_name("DIR")->capture_default_str();
    app->add_option("--json", o.json, "write every figure as a JSON array of {case, impl, metric, value, unit}")->type_name("FILE");
    app->add_option("--threads", o.threads, "worker threads (default: hardware concurrency)")
        ->type_name("N")
        ->check(CLI::Range(std::size_t{1}, std::size_t{4096}));
    app->add_option("--runs", o.runs, "timed runs per case; medians are reported")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t{1}, std::size_t{4096}));
    app->add_option("--case", o.only, "only the cases whose name contains NAME (lobster, engine, aneurism, ...)")->type_name("NAME");
    return app;
}

// ---- the paper's figures ----------------------------------------------------------------------

/// One figure of Table 3 or 6; absent where the paper gives none.
struct Figure {
    const char* metric;
    double value;
};

/// A measured case and the paper's figures for it.
struct Case {
    std::string name;
    std::string table;
    std::string file;
    volume::Dims dims;
    vec3 spacing;
    float factor;  ///< resampling factor (Table 6); 1 = the source grid
    std::vector<Figure> paper;
};

std::vector<Case> cases() {
    std::vector<Figure> lobster = {{"elements", 341256}, {"elements_percent", 6.25}, {"grid_kb", 10667},
                                   {"build_ms", 702}, {"nodes", 726844}, {"single_percent", 6.1},
                                   {"max_depth", 24}, {"full_kb_40B", 28393}, {"lod_ms", 78},
                                   {"lod_nodes", 515349}, {"lod_max_depth", 24}, {"lod_kb", 4027},
                                   {"lod_grid_percent", 37.75}};
    std::vector<Figure> engine = {{"elements", 1352439}, {"elements_percent", 8.06}, {"grid_kb", 16384},
                                  {"build_ms", 2777}, {"nodes", 2780802}, {"single_percent", 2.73},
                                  {"max_depth", 23}, {"full_kb_40B", 108626}, {"lod_ms", 281},
                                  {"lod_nodes", 1367240}, {"lod_max_depth", 23}, {"lod_kb", 10682},
                                  {"lod_grid_percent", 65.2}};
    auto aneurism = [](double elements, double ms, double depth, double kb) {
        return std::vector<Figure>{{"elements", elements}, {"grid_kb", 32768}, {"build_ms", ms},
                                   {"lod_max_depth", depth}, {"lod_kb", kb}};
    };
    const std::string lob = "lobster_301x324x56_uint8.raw", eng = "engine_256x256x128_uint8.raw",
                      ane = "aneurism_256x256x256_uint8.raw";
    std::vector<Case> out = {
        {"lobster", "Table 3", lob, {301, 324, 56}, {1.0f, 1.0f, 1.4f}, 1.0f, lobster},
        {"lobster/spacing1", "Table 3 (spacing 1 1 1)", lob, {301, 324, 56}, {1.0f, 1.0f, 1.0f}, 1.0f, lobster},
        {"engine", "Table 3", eng, {256, 256, 128}, {1.0f, 1.0f, 1.0f}, 1.0f, engine},
        {"aneurism/x1", "Table 6", ane, {256, 256, 256}, {1.0f, 1.0f, 1.0f}, 1.0f, aneurism(113453, 267, 24, 1841)},
        {"aneurism/x1.5", "Table 6", ane, {256, 256, 256}, {1.0f, 1.0f, 1.0f}, 1.5f, aneurism(409511, 930, 27, 5944)},
        {"aneurism/x2", "Table 6", ane, {256, 256, 256}, {1.0f, 1.0f, 1.0f}, 2.0f, aneurism(976669, 2221, 27, 13079)},
    };
    return out;
}

// ---- measuring ------------------------------------------------------------------------------

struct Record {
    std::string case_name, impl, metric;
    double value;
    std::string unit;
};

/// The unit of a metric, from its name.
std::string unit_of(const std::string& metric) {
    if (metric.ends_with("_ms")) return "ms";
    if (metric.ends_with("_kb") || metric.find("_kb_") != std::string::npos) return "KB";
    if (metric.ends_with("percent")) return "%";
    if (metric == "bytes_per_node") return "B";
    return "count";
}

/// KB as the paper counts them: ceil(bytes / 1024).
double kb(double bytes) { return std::ceil(bytes / 1024.0); }

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

/// An 8-bit raw volume normalised by 255, as Kinkelin's tables count (the type range, whatever
/// the data's max); std::nullopt (with the reader's message) when it cannot be read.
std::optional<volume::DensityGrid> load(const std::string& dir, const Case& c) {
    try {
        return volume::normalize(volume::read_raw(dir + "/" + c.file, {c.dims, volume::ScalarType::U8, c.spacing},
                                                  volume::ValueRange::of_type()));
    } catch (const Error& e) {
        std::cerr << "sylva-tables: " << e.what() << "\n";
        return std::nullopt;
    }
}

/// Source grid of a case: the volume, resampled when the case asks for it.
volume::DensityGrid source_grid(const volume::DensityGrid& g, float factor, ThreadPool& pool) {
    if (factor != 1.0f) return volume::resample_trilinear(g, factor, pool);
    return g;
}

/// Measures one case with one empty-child variant over `src` (the source grid `grid`, resampled
/// for Table 6); appends its records.
void measure(const volume::DensityGrid& grid, const volume::DensityGrid& src, bih::EmptyChildren variant,
             const std::string& name, std::size_t runs, ThreadPool& pool, std::vector<Record>& out) {
    auto add = [&](const std::string& metric, double v) { out.push_back({name, "sylva", metric, v, unit_of(metric)}); };
    auto t0 = std::chrono::steady_clock::now();
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(src, 0.1f, pool);
    double voxels_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    bih::Config cfg;
    cfg.empty_children = variant;
    std::vector<double> build_ms, lod_ms;
    bih::FullBih full;
    bih::Lod lod;
    for (std::size_t r = 0; r < runs; ++r) {
        full = bih::build_full(cuboids, cfg, pool);
        build_ms.push_back(full.total_ms);
        lod = bih::extract_lod(full, bih::LodConfig{});
        lod_ms.push_back(lod.extract_ms);
    }
    const bih::BuildStats& s = full.tree.stats;
    double grid_bytes = 2.0 * double(grid.values.size());  // the 16-bit source grid
    add("elements", double(cuboids.size()));
    add("elements_percent", 100.0 * double(cuboids.size()) / double(src.values.size()));
    add("grid_kb", kb(grid_bytes));
    add("voxels_ms", voxels_ms);
    add("build_ms", median(build_ms));
    add("nodes", double(s.nodes));
    add("single_percent", s.percent_single_child());
    add("max_depth", s.max_depth);
    add("full_kb_40B", kb(double(full.paper_bytes())));
    add("full_kb_ours", kb(double(full.bytes())));
    add("bytes_per_node", full.bytes_per_node());
    add("lod_ms", median(lod_ms));
    add("lod_nodes", double(lod.stats.nodes));
    add("lod_max_depth", lod.stats.max_depth);
    add("lod_kb", kb(double(lod.node_bytes())));
    add("lod_grid_percent", 100.0 * kb(double(lod.node_bytes())) / kb(grid_bytes));
}

// ---- reporting ------------------------------------------------------------------------------

const Record* find(const std::vector<Record>& rs, const std::string& c, const std::string& impl, const std::string& m) {
    for (const Record& r : rs)
        if (r.case_name == c && r.impl == impl && r.metric == m) return &r;
    return nullptr;
}

std::string format(double v) {
    char buf[32];
    if (v == std::floor(v) && std::fabs(v) < 1e15) {  // whole numbers with thousands separators
        std::string digits = std::to_string(static_cast<long long>(std::fabs(v))), out = v < 0 ? "-" : "";
        for (std::size_t i = 0; i < digits.size(); ++i) {
            if (i > 0 && (digits.size() - i) % 3 == 0) out.push_back(',');
            out.push_back(digits[i]);
        }
        return out;
    }
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
}

/// Prints one case as metric | sylva | paper | difference, and collects differences over 10 %.
void print_case(const std::string& name, const std::string& title, const std::vector<Record>& rs,
                std::vector<std::string>& over) {
    std::printf("\n%s  (%s)\n  %-18s %14s %14s %9s\n", name.c_str(), title.c_str(), "metric", "sylva", "paper", "diff");
    for (const Record& r : rs) {
        if (r.case_name != name || r.impl != "sylva") continue;
        const Record* p = find(rs, name, "paper", r.metric);
        std::string paper = p ? format(p->value) : "-", diff = "";
        if (p && p->value != 0.0) {
            double d = 100.0 * (r.value - p->value) / p->value;
            char buf[32];
            std::snprintf(buf, sizeof buf, "%+.2f%%", d);
            diff = buf;
            if (std::fabs(d) > 10.0) over.push_back(name + " " + r.metric + " " + diff);
        }
        std::printf("  %-18s %14s %14s %9s  %s\n", r.metric.c_str(), format(r.value).c_str(), paper.c_str(),
                    diff.c_str(), r.unit.c_str());
    }
}

/// The records as a JSON array, one record a line (nlohmann-json writes strings and numbers).
void write_json(const std::string& path, const std::vector<Record>& rs) {
    std::ofstream f(path);
    if (!f) throw Error("sylva-tables: cannot write " + path);
    f << "[\n";
    for (std::size_t i = 0; i < rs.size(); ++i) {
        if (!std::isfinite(rs[i].value))
            throw Error("sylva-tables: " + rs[i].case_name + " " + rs[i].metric + " is not finite");
        nlohmann::ordered_json rec{{"case", rs[i].case_name}, {"impl", rs[i].impl}, {"metric", rs[i].metric},
                                   {"value", rs[i].value}, {"unit", rs[i].unit}};
        f << "  " << rec.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace)
          << (i + 1 < rs.size() ? ",\n" : "\n");
    }
    f << "]\n";
    if (!f) throw Error("sylva-tables: writing " + path + " failed");
}

/// Runs every selected case; returns false when a volume could not be read.
bool run(const Options& o, std::vector<Record>& records, std::vector<std::pair<std::string, std::string>>& shown) {
    ThreadPool pool(o.threads);
    bool ok = true;
    std::printf("sylva-tables: %zu threads, %zu runs per case (medians), data %s\n", pool.concurrency(), o.runs,
                o.data.c_str());
    for (const Case& c : cases()) {
        if (!o.only.empty() && c.name.find(o.only) == std::string::npos) continue;
        std::optional<volume::DensityGrid> grid = load(o.data, c);
        if (!grid) {
            const char* allow = std::getenv("SYLVA_ALLOW_MISSING_DATA");
            bool allowed = allow && std::string(allow) == "1";
            if (allowed) std::printf("%s: volume missing, left out (SYLVA_ALLOW_MISSING_DATA=1)\n", c.name.c_str());
            ok = ok && allowed;
            continue;
        }
        volume::DensityGrid src = source_grid(*grid, c.factor, pool);
        for (bool inf : {false, true}) {
            std::string name = c.name + (inf ? "/inf-planes" : "");
            std::string title = c.table + (inf ? ", +-inf empty children" : ", trimmed single children");
            measure(*grid, src, inf ? bih::EmptyChildren::Infinite : bih::EmptyChildren::TrimBoth, name, o.runs, pool,
                    records);
            for (const Figure& f : c.paper) records.push_back({name, "paper", f.metric, f.value, unit_of(f.metric)});
            shown.emplace_back(name, title);
            std::fflush(stdout);
        }
    }
    return ok;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    std::unique_ptr<CLI::App> app = make_app(o);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    try {
        std::vector<Record> records;
        std::vector<std::pair<std::string, std::string>> shown;
        bool ok = run(o, records, shown);
        std::vector<std::string> over;
        for (const auto& [name, title] : shown) print_case(name, title, records, over);
        std::printf("\nDifferences over 10 %% from the paper:\n");
        for (const std::string& s : over) std::printf("  %s\n", s.c_str());
        if (over.empty()) std::printf("  (none)\n");
        if (!o.json.empty()) write_json(o.json, records);
        return ok ? 0 : 1;
    } catch (const std::exception& e) {
        std::cerr << "sylva-tables: " << e.what() << "\n";
        return 1;
    }
}
