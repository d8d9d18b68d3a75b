// benchmarks/volume_bench_report.hpp -- what sylva-volume-bench measures (one row per built
// LoD and per rendered image), the paper's figures beside them, the tables on stdout and the
// JSON records {case, impl, metric, value, unit}.
#ifndef SYLVA_VOLUME_BENCH_REPORT_HPP
#define SYLVA_VOLUME_BENCH_REPORT_HPP

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <sylva/core/error.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/volume/grid.hpp>

namespace volume_bench {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// "1", "1.5", "2": the factor as it appears in case names and file names.
inline std::string factor_text(float f) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%g", static_cast<double>(f));
    return buf;
}

inline std::string dims_text(sylva::volume::Dims d) {
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z);
}

/// KB as Kinkelin counts them: ceil(bytes / 1024).
inline double kb(double bytes) { return std::ceil(bytes / 1024.0); }

/// One built LoD: the full BIH over the voxel cuboids of a (resampled) grid and its default LoD.
struct BuildRow {
    std::string data;  ///< engine, aneurism, lobster, procedural
    float factor = 1.0f;
    sylva::volume::Dims dims{0};           ///< the grid the BIH was built from
    std::size_t original_voxels = 0;       ///< voxels of the source file's grid
    std::size_t elements = 0;              ///< voxel cuboids (density >= 0.1)
    double voxels_ms = 0.0;                ///< resampling + voxel cuboids
    double build_ms = 0.0;                 ///< build_full: BIH + node statistics ("construction")
    double lod_ms = 0.0, encode_ms = 0.0;  ///< extract_lod, encode_lod
    std::size_t full_nodes = 0, lod_nodes = 0, lod_bytes = 0, encoded_bytes = 0;
    std::uint32_t lod_depth = 0;

    [[nodiscard]] std::string name() const { return data + "/x" + factor_text(factor); }
    [[nodiscard]] double elements_per_s() const { return build_ms > 0.0 ? double(elements) / (build_ms / 1e3) : kNaN; }
    [[nodiscard]] double grid16_bytes() const { return 2.0 * double(original_voxels); }
    [[nodiscard]] double grid8_bytes() const { return double(original_voxels); }
};

/// Where an image was rendered.
enum Backend : int { Cpu = 0, Vulkan = 1 };
inline const char* backend_name(int b) { return b == Cpu ? "cpu" : "vulkan"; }

/// One rendered image (reference marcher, or single/multi BIH-DVR at one factor) on up to two
/// backends; quality against the reference on the same camera and transfer function.
struct RenderRow {
    std::string data, renderer;  ///< renderer: reference, single, multi
    float factor = 1.0f;
    std::size_t pixels = 0;
    double ms[2] = {kNaN, kNaN};      ///< median render time per backend (NaN: not run)
    double ref_ms[2] = {kNaN, kNaN};  ///< the reference's median in the same interleaved runs
    double mean_steps = kNaN;     ///< iterator node visits (BIH) or lattice samples (marcher) per pixel
    bool has_quality = false;
    sylva::ImageDifference quality;  ///< against the reference (first backend run)
    double parity = kNaN;            ///< max abs difference between the cpu and vulkan images

    static RenderRow make(std::string data, std::string renderer, float factor, std::size_t pixels) {
        RenderRow r;
        r.data = std::move(data);
        r.renderer = std::move(renderer);
        r.factor = factor;
        r.pixels = pixels;
        return r;
    }
    [[nodiscard]] std::string name() const {
        return renderer == "reference" ? data + "/reference" : data + "/x" + factor_text(factor) + "/" + renderer;
    }
    [[nodiscard]] double rays_per_s(int b) const { return ms[b] > 0.0 ? double(pixels) / (ms[b] / 1e3) : kNaN; }
    /// How many times faster than the reference marcher timed beside it (NaN for the reference).
    [[nodiscard]] double speed_vs_reference(int b) const { return ref_ms[b] / ms[b]; }
};

/// One JSON record.
struct Record {
    std::string case_name, impl, metric;
    double value;
    std::string unit;
};

/// A figure from the paper: case, metric, value, unit, source.
struct PaperFigure {
    const char* case_name;
    const char* metric;
    double value;
    const char* unit;
};

/// The figures of Kinkelin's Tables 3, 4, 5, 6 and Figures 6, 8 that the bench measures too.
/// Engine: Table 3 gives 256x256x128 = 16,384 KB of 16-bit grid (our file); Table 4 lists the
/// DVR grid as 32,768 KB although its BIH-DVR 1 column repeats Table 3's engine figures.
inline std::vector<PaperFigure> paper_figures() {
    return {
        {"vertebra/table5", "elements", 16481795, "count"},  // the largest grid of Table 3 / 5
        {"vertebra/table5", "build_ms", 40435, "ms"},
        {"engine/x1", "elements", 1352439, "count"},  // Table 3
        {"engine/x1", "build_ms", 2777, "ms"},
        {"engine/x1", "lod_max_depth", 23, "count"},
        {"engine/x1", "lod_kb", 10682, "KB"},
        {"engine/x1", "grid16_kb", 16384, "KB"},
        {"engine/x1.5", "build_ms", 10218, "ms"},  // Table 4
        {"engine/x1.5", "lod_max_depth", 25, "count"},
        {"engine/x1.5", "lod_kb", 32769, "KB"},
        {"lobster/x1", "elements", 341256, "count"},  // Table 3
        {"lobster/x1", "build_ms", 702, "ms"},
        {"lobster/x1", "lod_max_depth", 24, "count"},
        {"lobster/x1", "lod_kb", 4027, "KB"},
        {"lobster/x1", "grid16_kb", 10667, "KB"},
        {"aneurism/x1", "elements", 113453, "count"},  // Table 6
        {"aneurism/x1", "build_ms", 267, "ms"},
        {"aneurism/x1", "lod_max_depth", 24, "count"},
        {"aneurism/x1", "lod_kb", 1841, "KB"},
        {"aneurism/x1", "grid16_kb", 32768, "KB"},
        {"aneurism/x1.5", "elements", 409511, "count"},
        {"aneurism/x1.5", "build_ms", 930, "ms"},
        {"aneurism/x1.5", "lod_max_depth", 27, "count"},
        {"aneurism/x1.5", "lod_kb", 5944, "KB"},
        {"aneurism/x1.5", "grid16_kb", 32768, "KB"},
        {"aneurism/x2", "elements", 976669, "count"},
        {"aneurism/x2", "build_ms", 2221, "ms"},
        {"aneurism/x2", "lod_max_depth", 27, "count"},
        {"aneurism/x2", "lod_kb", 13079, "KB"},
        {"aneurism/x2", "grid16_kb", 32768, "KB"},
        // Fig. 6: single-sample BIH-DVR 1.5 "still rendered at 75% of the original BIH's speed";
        // Fig. 8: "the performance of BIH-DVR 2 is almost identical to traditional DVR".
        {"engine/x1.5/single", "speed_vs_x1", 0.75, "ratio"},
        {"aneurism/x2/single", "speed_vs_reference", 1.0, "ratio"},
    };
}

/// The paper's records, with the derived rates (elements/s) and ratios (LoD / grid) where both
/// figures exist, for the cases in `names` (and the vertebra's rate always).
inline std::vector<Record> paper_records(const std::vector<std::string>& names) {
    std::vector<Record> out;
    auto wanted = [&](const std::string& c) {
        if (c.starts_with("vertebra")) return true;
        for (const std::string& n : names)
            if (c == n || c.starts_with(n + "/")) return true;
        return false;
    };
    std::vector<PaperFigure> figs = paper_figures();
    auto find = [&](const std::string& c, const char* m) {
        for (const PaperFigure& f : figs)
            if (c == f.case_name && std::string(m) == f.metric) return f.value;
        return kNaN;
    };
    for (const PaperFigure& f : figs) {
        if (!wanted(f.case_name)) continue;
        out.push_back({f.case_name, "paper", f.metric, f.value, f.unit});
        std::string m = f.metric;
        if (m == "build_ms" && !std::isnan(find(f.case_name, "elements")))
            out.push_back({f.case_name, "paper", "elements_per_s", find(f.case_name, "elements") / (f.value / 1e3),
                           "elements/s"});
        if (m == "lod_kb" && !std::isnan(find(f.case_name, "grid16_kb")))
            out.push_back({f.case_name, "paper", "lod_grid16_percent", 100.0 * f.value / find(f.case_name, "grid16_kb"),
                           "%"});
    }
    return out;
}

inline void add_build_records(const BuildRow& r, std::vector<Record>& out) {
    auto add = [&](const char* metric, double v, const char* unit) { out.push_back({r.name(), "sylva", metric, v, unit}); };
    add("elements", double(r.elements), "count");
    add("voxels_ms", r.voxels_ms, "ms");
    add("build_ms", r.build_ms, "ms");
    add("elements_per_s", r.elements_per_s(), "elements/s");
    add("full_nodes", double(r.full_nodes), "count");
    add("lod_ms", r.lod_ms, "ms");
    add("encode_ms", r.encode_ms, "ms");
    add("lod_nodes", double(r.lod_nodes), "count");
    add("lod_max_depth", r.lod_depth, "count");
    add("lod_kb", kb(double(r.lod_bytes)), "KB");
    add("lod_encoded_bytes", double(r.encoded_bytes), "B");
    add("grid16_kb", kb(r.grid16_bytes()), "KB");
    add("grid8_kb", kb(r.grid8_bytes()), "KB");
    add("lod_grid16_percent", 100.0 * double(r.lod_bytes) / r.grid16_bytes(), "%");
    add("lod_grid8_percent", 100.0 * double(r.lod_bytes) / r.grid8_bytes(), "%");
    add("source_grid16_kb", kb(2.0 * double(r.dims.x) * r.dims.y * r.dims.z), "KB");
}

/// Records of one image; `x1` is the same renderer's factor-1 row (nullptr when absent).
inline void add_render_records(const RenderRow& r, const RenderRow* x1, std::vector<Record>& out) {
    auto add = [&](const std::string& metric, double v, const char* unit) {
        if (!std::isnan(v)) out.push_back({r.name(), "sylva", metric, v, unit});
    };
    for (int b : {Cpu, Vulkan}) {
        std::string s = backend_name(b);
        add("render_ms_" + s, r.ms[b], "ms");
        add("rays_per_s_" + s, r.rays_per_s(b), "rays/s");
        add("speed_vs_reference_" + s, r.speed_vs_reference(b), "ratio");
        if (x1 && r.factor != 1.0f) add("speed_vs_x1_" + s, x1->ms[b] / r.ms[b], "ratio");
    }
    add("mean_steps", r.mean_steps, "count");
    if (r.has_quality) {
        add("psnr_db", std::isinf(r.quality.psnr) ? 999.0 : r.quality.psnr, "dB");
        add("max_abs_diff", r.quality.max_abs, "unorm");
        add("rmse", r.quality.rmse, "unorm");
    }
    add("parity_cpu_vulkan_max_abs_diff", r.parity, "unorm");
}

inline std::string json_string(const std::string& s) {
    std::string out = "\"";
    for (char ch : s) {
        if (ch == '"' || ch == '\\') out += '\\';
        out += ch;
    }
    return out + "\"";
}

inline void write_json(const std::string& path, const std::vector<Record>& rs) {
    std::ofstream f(path);
    if (!f) throw sylva::Error("sylva-volume-bench: cannot write " + path);
    f << "[\n";
    for (std::size_t i = 0; i < rs.size(); ++i) {
        char num[40];
        std::snprintf(num, sizeof num, "%.9g", std::isfinite(rs[i].value) ? rs[i].value : 0.0);
        f << "  {\"case\": " << json_string(rs[i].case_name) << ", \"impl\": " << json_string(rs[i].impl)
          << ", \"metric\": " << json_string(rs[i].metric) << ", \"value\": " << num
          << ", \"unit\": " << json_string(rs[i].unit) << "}" << (i + 1 < rs.size() ? ",\n" : "\n");
    }
    f << "]\n";
    if (!f) throw sylva::Error("sylva-volume-bench: writing " + path + " failed");
}

// ---- tables on stdout ---------------------------------------------------------------------

/// A number with `digits` decimals, "-" for NaN.
inline std::string num(double v, int digits = 2) {
    if (std::isnan(v)) return "-";
    if (std::isinf(v)) return "inf";
    char buf[48];
    std::snprintf(buf, sizeof buf, "%.*f", digits, v);
    return buf;
}

/// The paper's figure for a case and metric, NaN when it gives none.
inline double paper_value(const std::vector<Record>& paper, const std::string& c, const std::string& m) {
    for (const Record& r : paper)
        if (r.case_name == c && r.metric == m) return r.value;
    return kNaN;
}

inline void print_build_table(const std::vector<BuildRow>& rows, const std::vector<Record>& paper) {
    std::printf("\nBuild: voxel cuboids (density >= 0.1) -> full BIH -> default LoD (75%% element density, 1%% std dev,"
                " chunk depth 2)\n");
    std::printf("  %-16s %-12s %10s %9s %9s %10s %8s %10s %7s %9s %8s %8s %9s\n", "case", "grid", "elements",
                "build ms", "paper ms", "M el/s", "paper", "LoD nodes", "depth", "LoD KB", "paper KB", "%grid16",
                "%grid8");
    for (const BuildRow& r : rows) {
        std::string n = r.name();
        std::printf("  %-16s %-12s %10zu %9s %9s %10s %8s %10zu %3u/%-3s %9s %8s %8s %9s\n", n.c_str(),
                    dims_text(r.dims).c_str(), r.elements, num(r.build_ms, 0).c_str(),
                    num(paper_value(paper, n, "build_ms"), 0).c_str(), num(r.elements_per_s() / 1e6, 3).c_str(),
                    num(paper_value(paper, n, "elements_per_s") / 1e6, 3).c_str(), r.lod_nodes, r.lod_depth,
                    num(paper_value(paper, n, "lod_max_depth"), 0).c_str(), num(kb(double(r.lod_bytes)), 0).c_str(),
                    num(paper_value(paper, n, "lod_kb"), 0).c_str(),
                    num(100.0 * double(r.lod_bytes) / r.grid16_bytes(), 1).c_str(),
                    num(100.0 * double(r.lod_bytes) / r.grid8_bytes(), 1).c_str());
    }
    std::printf("  (paper construction rate, Table 5's vertebra: %s M elements/s; %%grid = LoD bytes / the ORIGINAL"
                " grid at 16 and 8 bits)\n",
                num(paper_value(paper, "vertebra/table5", "elements_per_s") / 1e6, 3).c_str());
}

inline void print_quality_table(const std::vector<RenderRow>& rows) {
    std::printf("\nQuality against the reference marcher (original grid, 1,024 steps on the longest axis):\n");
    std::printf("  %-25s %9s %9s %9s %12s\n", "image", "PSNR dB", "max abs", "RMSE", "cpu/vk diff");
    for (const RenderRow& r : rows) {
        if (!r.has_quality) continue;
        std::printf("  %-25s %9s %9s %9s %12s\n", r.name().c_str(), num(r.quality.psnr, 2).c_str(),
                    num(r.quality.max_abs, 4).c_str(), num(r.quality.rmse, 4).c_str(), num(r.parity, 6).c_str());
    }
}

inline void print_speed_table(const std::vector<RenderRow>& rows) {
    std::printf("\nSpeed (median render; rays/s = pixels / time; x ref = reference time / this time, both from\n"
                "the same interleaved runs; the reference row: median of all its runs):\n");
    std::printf("  %-25s %9s %11s %7s %9s %11s %7s %11s\n", "image", "cpu ms", "cpu Mray/s", "x ref", "vk ms",
                "vk Mray/s", "x ref", "mean steps");
    for (const RenderRow& r : rows) {
        double cpu_ratio = r.speed_vs_reference(Cpu), vk_ratio = r.speed_vs_reference(Vulkan);
        std::printf("  %-25s %9s %11s %7s %9s %11s %7s %11s\n", r.name().c_str(), num(r.ms[Cpu], 1).c_str(),
                    num(r.rays_per_s(Cpu) / 1e6, 3).c_str(), num(cpu_ratio, 2).c_str(), num(r.ms[Vulkan], 1).c_str(),
                    num(r.rays_per_s(Vulkan) / 1e6, 3).c_str(), num(vk_ratio, 2).c_str(),
                    num(r.mean_steps, 1).c_str());
    }
}

}  // namespace volume_bench

#endif  // SYLVA_VOLUME_BENCH_REPORT_HPP
