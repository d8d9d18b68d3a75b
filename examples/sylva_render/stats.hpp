// sylva-render statistics: printed and written as one JSON object (nlohmann-json).
#ifndef SYLVA_RENDER_STATS_HPP
#define SYLVA_RENDER_STATS_HPP

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <sylva/bih/tree.hpp>
#include <sylva/core/error.hpp>
#include <sylva/render/particles.hpp>

namespace sylva_render {

/// The frame times (ms) of the last best_of, in render order: Stats::frame_ms (--repeat's
/// median and minimum).
inline std::vector<double>& repeat_frame_ms() {
    static std::vector<double> times;
    return times;
}

struct Stats {
    std::string index = "bih", backend, device, input;
    std::string order;  ///< particles: --order exact|leaf (the JSON key \"order\"; empty for volumes: not written)
    std::size_t elements = 0, nodes = 0, leaves = 0, bytes = 0, errors = 0;
    std::uint32_t max_depth = 0, heatmap_peak = 0, width = 0, height = 0;
    double build_ms = 0, encode_ms = 0, render_ms = 0, rays_per_s = 0, single_child_percent = 0, steps_mean = 0;
    std::uint32_t steps_max = 0;
    std::uint32_t repeat = 1;  ///< frames rendered (--repeat); the figures are the fastest one's
    /// Every --repeat frame's time in render order (ms): the JSON's frame_ms, ms_min, ms_median
    /// (best_of's record, taken by fill_frame; empty: render_ms alone).
    std::vector<double> frame_ms;
    std::string camera = "pinhole";  ///< --camera pinhole|ortho
    std::size_t visible_pixels = 0;  ///< pixels with alpha >= 1/255 (what an 8-bit image shows)
    /// Volume runs: Kinkelin Table 3's rows for what was built (empty for particles).
    struct VolumeRows {
        bool present = false;
        std::string mode, grid;
        float range_lo = 0.0f, range_hi = 1.0f;  ///< raw values mapped to density 0 and 1 (--range)
        std::string range_source;                ///< where that range came from
        std::size_t data_bytes = 0;              ///< the volume's voxels as read (procedural: float32)
        std::size_t voxels = 0, grid_bytes_16bit = 0;
        /// What the renderer's grid words take (uint8: 1 byte a voxel) and its index (kd-tree
        /// words, BIH + ranges, ...); grid_format uint8|sparse-uint8|float32, border clamp|zero.
        std::size_t grid_bytes = 0, index_bytes = 0;
        std::string grid_format = "float32", border = "zero";
        std::size_t full_nodes = 0, full_bytes = 0, full_bytes_paper = 0;
        double full_single_percent = 0, full_ms = 0;
        std::uint32_t full_depth = 0;
        std::size_t lod_nodes = 0, lod_leaves = 0, lod_bytes = 0;
        std::uint32_t lod_depth = 0;
        double lod_ms = 0;
    } volume;
    /// Volume runs with a kd-tree index (--index kd-vidal|kd-binned): Zellmann Table 1's columns
    /// and the rebuilds of --tf-sequence.
    struct KdRows {
        bool present = false;
        std::string builder, depth, classify, construction;
        std::uint64_t voxels = 0, occupied = 0;
        double occupancy_percent = 0, culled_percent = 0;
        double codes_ms = 0, ranges_ms = 0, classify_ms = 0, occupancy_ms = 0, split_ms = 0;
        /// One streaming pass over the volume as read (read, classify by a threshold, count;
        /// all threads; sylva-kd-bench's yardstick), timed just before the first build:
        /// build_ms's yardstick (issue 15, item 5).
        double stream_ms = 0;
        /// One rebuild of --tf-sequence.
        struct Rebuild {
            std::string tf;
            double occupancy_percent = 0, culled_percent = 0;
            std::size_t nodes = 0, leaves = 0, bytes = 0;
            std::uint32_t depth = 0;
            double codes_ms = 0, ranges_ms = 0, classify_ms = 0, occupancy_ms = 0, split_ms = 0, render_ms = 0;
            [[nodiscard]] double rebuild_ms() const { return codes_ms + ranges_ms + classify_ms + occupancy_ms + split_ms; }
        };
        std::vector<Rebuild> rebuilds;
    } kd;

    /// Isosurface runs (--index implicit-kd|dda): Wald et al.'s memory and traversal figures.
    struct IsoRows {
        bool present = false;
        std::vector<float> isos;
        std::size_t index_bytes = 0, cells = 0;
        std::uint32_t levels = 0;
        std::uint64_t cells_tested = 0, traversal_steps = 0, hits = 0;
        std::uint32_t packet_lanes = 1;  ///< rays a traversal step serves at most (--packets; 1: single rays)
    } iso;

    /// Bricked octree runs (--index octree): the structure and the cut rendered.
    struct OctreeRows {
        bool present = false;
        std::uint32_t brick_size = 0, levels = 0, cut_leaves = 0, cut_deepest = 0;
        std::size_t bricks = 0, octree_nodes = 0, index_bytes = 0, brick_bytes = 0, cut_nodes = 0;
        float lod_pixels = 0.0f;  ///< 0: the full-resolution cut
        float max_tf_error = 1.0f;  ///< the cut's TF-aware refinement (1: none)
        std::string brick_format = "float32";  ///< float32|unorm16|unorm8 (--grid native keeps uint8 / uint16 voxels)
    } octree;

    /// Out-of-core octree runs (--frames, a budget, or a brick store; ooc_scene.hpp).
    struct OocRows {
        bool present = false, feedback = true;
        std::size_t memory_budget = 0, device_budget = 0, host_cache_bytes = 0, host_cache_peak_bytes = 0;
        std::size_t device_pool_bytes = 0, peak_rss_bytes = 0;
        std::uint32_t device_slots = 0;
        std::uint64_t bricks_loaded = 0, bricks_evicted = 0, host_evicted = 0, device_evicted = 0, uploads = 0;
        std::uint64_t bad_bricks = 0, cancelled = 0;
        double host_hit_rate = 0, device_hit_rate = 0;
        /// One progressive frame.
        struct FrameRow {
            double ms = 0, update_ms = 0, render_ms = 0;
            std::uint64_t loaded = 0;
            std::uint32_t uploads = 0, requests = 0, cut_nodes = 0, cut_deepest = 0;
        };
        std::vector<FrameRow> frames;
    } ooc;

    /// Element octree runs over particles (--particles or --count with --index octree).
    struct ElementOctreeRows {
        bool present = false;
        std::uint32_t levels = 0;  ///< lattice levels (the deepest node is max_depth)
        std::size_t octree_nodes = 0, references = 0, index_bytes = 0, record_bytes = 0;
        double references_per_element = 0;
    } elements_octree;

    void fill(const sylva::bih::Tree& t, std::size_t encoded_bytes, const sylva::Frame& f) {
        elements = t.stats.elements;
        nodes = t.stats.nodes;
        leaves = t.stats.leaves;
        max_depth = t.stats.max_depth;
        single_child_percent = t.stats.percent_single_child();
        build_ms = t.stats.build_ms;
        bytes = encoded_bytes;
        fill_frame(f);
    }

    /// Render figures: size, time, rays/s, iterator steps, corrupted-encoding rays.
    void fill_frame(const sylva::Frame& f) {
        width = f.width;
        height = f.height;
        render_ms = f.ms;
        rays_per_s = f.ms > 0 ? static_cast<double>(f.rgba.size()) / (f.ms / 1000.0) : 0.0;
        const std::vector<double>& times = repeat_frame_ms();  // best_of's frames, f the fastest
        if (!times.empty() && *std::min_element(times.begin(), times.end()) == f.ms) {
            frame_ms = times;
            repeat = static_cast<std::uint32_t>(times.size());
        }
        double sum = 0;
        for (std::uint32_t s : f.steps) {
            if (s == 0xFFFFFFFFu) {
                ++errors;
                continue;
            }
            sum += s;
            steps_max = std::max(steps_max, s);
        }
        steps_mean = f.steps.empty() ? 0.0 : sum / static_cast<double>(f.steps.size());
        visible_pixels = 0;
        for (const sylva::vec4& c : f.rgba) visible_pixels += c.a >= 1.0f / 255.0f ? 1u : 0u;
    }

    void print(std::ostream& os) const {
        os << "input            " << input << "\n"
           << "index            " << index << " (" << elements << " elements, " << nodes << " nodes, " << leaves
           << " leaves, depth " << max_depth << ", " << single_child_percent << "% single-child)\n"
           << "bytes            " << bytes << "\n"
           << "build            " << build_ms << " ms (" << elements / std::max(build_ms, 1e-9) * 1000.0
           << " elements/s), encode " << encode_ms << " ms\n"
           << "render           " << backend << " on " << device << ": " << width << "x" << height << " in "
           << render_ms << " ms, " << rays_per_s << " rays/s"
           << (repeat > 1 ? " (fastest of " + std::to_string(repeat) + " frames; median " + std::to_string(ms_median()) +
                                " ms, " + std::to_string(rays_per_s_median()) + " rays/s)"
                          : std::string())
           << ", " << camera << " camera\n"
           << "iterator steps   mean " << steps_mean << ", max " << steps_max << "\n";
        if (volume.present) print_volume(os);
        if (kd.present) print_kd(os);
        if (iso.present) print_iso(os);
        if (octree.present)
            os << "octree           " << octree.octree_nodes << " nodes, " << octree.levels << " levels, "
               << octree.bricks << " bricks of " << octree.brick_size << "^3 (" << octree.brick_format << "); index "
               << octree.index_bytes << " B, bricks " << octree.brick_bytes << " B\n"
               << "cut              " << octree.cut_nodes << " nodes, " << octree.cut_leaves << " leaves, deepest level "
               << octree.cut_deepest
               << (octree.lod_pixels > 0.0f ? " (--lod-pixels " + std::to_string(octree.lod_pixels) +
                                                  (octree.max_tf_error < 1.0f
                                                       ? ", --max-tf-error " + std::to_string(octree.max_tf_error)
                                                       : std::string()) +
                                                  ")"
                                            : std::string(" (full resolution)"))
               << "\n";
        if (ooc.present) print_ooc(os);
        if (elements_octree.present)
            os << "element octree   " << elements_octree.octree_nodes << " nodes, " << elements_octree.levels
               << " lattice levels, " << elements_octree.references << " references ("
               << elements_octree.references_per_element << " per particle); index " << elements_octree.index_bytes
               << " B, records " << elements_octree.record_bytes << " B\n";
        if (errors) os << "ERRORS           " << errors << " rays ended on a corrupted encoding\n";
    }

    /// The out-of-core rows: budgets, caches, loads, the frames.
    void print_ooc(std::ostream& os) const {
        auto mb = [](std::size_t b) { return static_cast<double>(b) / (1024.0 * 1024.0); };
        double worst = 0, sum = 0;
        for (const OocRows::FrameRow& f : ooc.frames) worst = std::max(worst, f.ms), sum += f.ms;
        os << "out of core      " << ooc.frames.size() << " frames, mean " << (ooc.frames.empty() ? 0.0 : sum / double(ooc.frames.size()))
           << " ms, max " << worst << " ms; feedback " << (ooc.feedback ? "on" : "off") << "\n"
           << "  host cache     " << mb(ooc.host_cache_bytes) << " MB now, peak " << mb(ooc.host_cache_peak_bytes) << " of "
           << mb(ooc.memory_budget) << " MB; hit rate " << ooc.host_hit_rate << "\n"
           << "  device pool    " << mb(ooc.device_pool_bytes) << " MB (" << ooc.device_slots << " slots) of "
           << mb(ooc.device_budget) << " MB; hit rate " << ooc.device_hit_rate << "\n"
           << "  bricks         " << ooc.bricks_loaded << " loaded, " << ooc.uploads << " uploaded, " << ooc.bricks_evicted
           << " evicted (host " << ooc.host_evicted << ", device " << ooc.device_evicted << "), " << ooc.cancelled
           << " requests cancelled, " << ooc.bad_bricks << " bad\n"
           << "  peak RSS       " << mb(ooc.peak_rss_bytes) << " MB\n";
    }

    /// Kinkelin Table 3's rows for the volume that was built.
    void print_volume(std::ostream& os) const {
        const VolumeRows& v = volume;
        auto kb = [](std::size_t b) { return static_cast<double>(b) / 1024.0; };
        os << "grid             " << v.grid << " (" << v.voxels << " voxels, 16-bit size " << kb(v.grid_bytes_16bit)
           << " KB), mode " << v.mode << "\n"
           << "value range      [" << v.range_lo << ", " << v.range_hi << "] (" << v.range_source
           << ") maps to density [0, 1]\n";
        if (v.full_nodes == 0) return;
        os << "Table 3 (Kinkelin)\n"
           << "  BIH elements   " << elements << " (" << 100.0 * static_cast<double>(elements) / static_cast<double>(v.voxels)
           << "% of the voxels)\n"
           << "  construction   " << v.full_ms << " ms (build + node statistics)\n"
           << "  nodes          " << v.full_nodes << ", " << v.full_single_percent << "% with a single child, max depth "
           << v.full_depth << "\n"
           << "  size           " << kb(v.full_bytes_paper) << " KB at the paper's 40 B/node (" << kb(v.full_bytes)
           << " KB in this implementation)\n"
           << "  default LoD    " << v.lod_nodes << " nodes (" << v.lod_leaves << " leaves), max depth " << v.lod_depth
           << ", " << kb(v.lod_bytes) << " KB = "
           << 100.0 * static_cast<double>(v.lod_bytes) / static_cast<double>(std::max<std::size_t>(v.grid_bytes_16bit, 1))
           << "% of the 16-bit grid, extracted in " << v.lod_ms << " ms\n";
    }

    /// The implicit kd-tree's memory against the data (Wald Table III) and its traversal counts
    /// (Tables I and II).
    void print_iso(std::ostream& os) const {
        auto mb = [](std::size_t b) { return static_cast<double>(b) / (1024.0 * 1024.0); };
        os << "isosurfaces      " << iso.isos.size() << " (";
        for (std::size_t k = 0; k < iso.isos.size(); ++k) os << (k ? ", " : "") << iso.isos[k];
        os << "), " << iso.cells << " cells, " << iso.levels << " levels\n"
           << "  memory         index " << mb(iso.index_bytes) << " MB, data " << mb(volume.data_bytes) << " MB ("
           << (volume.data_bytes ? static_cast<double>(iso.index_bytes) / static_cast<double>(volume.data_bytes) : 0.0)
           << "x the data)\n"
           << "  traversal      " << iso.traversal_steps << " steps"
           << (iso.packet_lanes > 1 ? " of packets of " + std::to_string(iso.packet_lanes) + " rays" : std::string())
           << ", " << iso.cells_tested << " cells intersected, " << iso.hits << " hits\n";
    }

    /// The kd-tree's Table 1 columns (Zellmann et al.) and the --tf-sequence rebuilds.
    void print_kd(std::ostream& os) const {
        os << "kd-tree          " << kd.builder << ", " << kd.depth << " (" << kd.construction << "), occupancy from "
           << kd.classify << "\n"
           << "  occupancy      " << kd.occupancy_percent << "% (" << kd.occupied << " of " << kd.voxels
           << " voxels)\n"
           << "  empty culled   " << kd.culled_percent << "% of the empty voxels lie outside every leaf\n"
           << "  leaves         " << leaves << " (" << nodes << " nodes), depth " << max_depth << ", " << bytes
           << " bytes encoded\n"
           << "  build          segment codes " << kd.codes_ms << " ms, block ranges " << kd.ranges_ms
           << " ms, classify " << kd.classify_ms << " ms, SVT/occupancy " << kd.occupancy_ms << " ms, split "
           << kd.split_ms << " ms; " << build_ms / std::max(kd.stream_ms, 1e-9) << "x one streaming pass ("
           << kd.stream_ms << " ms)\n";
        if (kd.rebuilds.empty()) return;
        os << "TF sequence      rebuild after each transfer-function change (occupancy = classify + SVT/local boxes)\n";
        for (const KdRows::Rebuild& r : kd.rebuilds)
            os << "  " << r.tf << ": occupancy " << r.occupancy_percent << "%, culled " << r.culled_percent << "%, "
               << r.leaves << " leaves, depth " << r.depth << "; rebuild " << r.rebuild_ms() << " ms (codes "
               << r.codes_ms << ", occupancy " << r.classify_ms + r.occupancy_ms << ", split " << r.split_ms
               << "), render " << r.render_ms << " ms\n";
    }

    /// The fastest and the median of the --repeat frames (an even count: the mean of the middle
    /// two); render_ms when no frame times were recorded.
    [[nodiscard]] double ms_min() const {
        return frame_ms.empty() ? render_ms : *std::min_element(frame_ms.begin(), frame_ms.end());
    }
    [[nodiscard]] double ms_median() const {
        if (frame_ms.empty()) return render_ms;
        std::vector<double> t = frame_ms;
        std::sort(t.begin(), t.end());
        std::size_t n = t.size();
        return n % 2 == 1 ? t[n / 2] : 0.5 * (t[n / 2 - 1] + t[n / 2]);
    }
    [[nodiscard]] double rays_per_s_median() const {
        double ms = ms_median();
        return ms > 0.0 ? static_cast<double>(width) * height / (ms / 1000.0) : 0.0;
    }
    /// Every figure as one JSON object (nlohmann::ordered_json: the keys in the order they are
    /// set). A key set twice (index_bytes of the volume, then of its octree or implicit kd-tree;
    /// octree_nodes) keeps the later value. Non-finite numbers are written as null.
    [[nodiscard]] nlohmann::ordered_json to_json() const {
        nlohmann::ordered_json j;
        j["index"] = index;
        j["backend"] = backend;
        j["device"] = device;
        j["input"] = input;
        j["elements"] = elements;
        j["nodes"] = nodes;
        j["leaves"] = leaves;
        j["max_depth"] = max_depth;
        j["single_child_percent"] = single_child_percent;
        j["bytes"] = bytes;
        j["build_ms"] = build_ms;
        j["encode_ms"] = encode_ms;
        j["render_ms"] = render_ms;
        j["rays_per_s"] = rays_per_s;
        j["width"] = width;
        j["height"] = height;
        j["repeat"] = repeat;
        j["ms_min"] = ms_min();
        j["ms_median"] = ms_median();
        j["rays_per_s_median"] = rays_per_s_median();
        j["frame_ms"] = frame_ms;
        j["camera"] = camera;
        j["steps_mean"] = steps_mean;
        j["steps_max"] = steps_max;
        j["visible_pixels"] = visible_pixels;
        j["errors"] = errors;
        if (!order.empty()) j["order"] = order;
        if (volume.present) add_volume_json(j);
        if (kd.present) add_kd_json(j);
        if (octree.present) {
            j["brick_size"] = octree.brick_size;
            j["bricks"] = octree.bricks;
            j["octree_nodes"] = octree.octree_nodes;
            j["octree_levels"] = octree.levels;
            j["index_bytes"] = octree.index_bytes;
            j["brick_bytes"] = octree.brick_bytes;
            j["brick_format"] = octree.brick_format;
            j["cut_nodes"] = octree.cut_nodes;
            j["cut_leaves"] = octree.cut_leaves;
            j["cut_deepest_level"] = octree.cut_deepest;
            j["lod_pixels"] = json_float(octree.lod_pixels);
            j["max_tf_error"] = json_float(octree.max_tf_error);
        }
        if (ooc.present) add_ooc_json(j);
        if (elements_octree.present) {
            j["octree_nodes"] = elements_octree.octree_nodes;
            j["octree_levels"] = elements_octree.levels;
            j["references"] = elements_octree.references;
            j["references_per_element"] = elements_octree.references_per_element;
            j["index_bytes"] = elements_octree.index_bytes;
            j["record_bytes"] = elements_octree.record_bytes;
        }
        if (iso.present) {
            nlohmann::ordered_json isos = nlohmann::ordered_json::array();
            for (float v : iso.isos) isos.push_back(json_float(v));
            j["isos"] = std::move(isos);
            j["index_bytes"] = iso.index_bytes;
            j["cells"] = iso.cells;
            j["levels"] = iso.levels;
            j["cells_tested"] = iso.cells_tested;
            j["traversal_steps"] = iso.traversal_steps;
            j["packet_lanes"] = iso.packet_lanes;
            j["hits"] = iso.hits;
        }
        return j;
    }

    /// Writes to_json() to `path` (indented; bytes of names that are not UTF-8 become U+FFFD).
    void write_json(const std::string& path) const {
        std::ofstream out(path);
        if (!out) throw sylva::Error("cannot write stats file " + path);
        out << to_json().dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) << "\n";
        if (!out) throw sylva::Error("cannot write stats file " + path);
    }

    /// A float as the double of its shortest decimal form (0.1f as 0.1, not 0.10000000149011612).
    static double json_float(float x) {
        if (!std::isfinite(x)) return static_cast<double>(x);
        char buf[32];
        auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
        if (ec != std::errc()) return static_cast<double>(x);
        *end = '\0';
        return std::strtod(buf, nullptr);
    }

    void add_volume_json(nlohmann::ordered_json& j) const {
        const VolumeRows& v = volume;
        j["mode"] = v.mode;
        j["value_range"] = {json_float(v.range_lo), json_float(v.range_hi)};
        j["value_range_source"] = v.range_source;
        j["data_bytes"] = v.data_bytes;
        j["voxels"] = v.voxels;
        j["grid_bytes"] = v.grid_bytes;
        j["index_bytes"] = v.index_bytes;
        j["grid_format"] = v.grid_format;
        j["border"] = v.border;
        j["grid_bytes_16bit"] = v.grid_bytes_16bit;
        j["full_nodes"] = v.full_nodes;
        j["full_single_child_percent"] = v.full_single_percent;
        j["full_max_depth"] = v.full_depth;
        j["full_bytes"] = v.full_bytes;
        j["full_bytes_paper"] = v.full_bytes_paper;
        j["full_ms"] = v.full_ms;
        j["lod_nodes"] = v.lod_nodes;
        j["lod_leaves"] = v.lod_leaves;
        j["lod_max_depth"] = v.lod_depth;
        j["lod_bytes"] = v.lod_bytes;
        j["lod_ms"] = v.lod_ms;
    }

    void add_ooc_json(nlohmann::ordered_json& j) const {
        j["memory_budget"] = ooc.memory_budget;
        j["device_budget"] = ooc.device_budget;
        j["host_cache_bytes"] = ooc.host_cache_bytes;
        j["host_cache_peak_bytes"] = ooc.host_cache_peak_bytes;
        j["device_pool_bytes"] = ooc.device_pool_bytes;
        j["device_slots"] = ooc.device_slots;
        j["bricks_loaded"] = ooc.bricks_loaded;
        j["bricks_evicted"] = ooc.bricks_evicted;
        j["host_evicted"] = ooc.host_evicted;
        j["device_evicted"] = ooc.device_evicted;
        j["uploads"] = ooc.uploads;
        j["bad_bricks"] = ooc.bad_bricks;
        j["requests_cancelled"] = ooc.cancelled;
        j["host_hit_rate"] = ooc.host_hit_rate;
        j["device_hit_rate"] = ooc.device_hit_rate;
        j["peak_rss_bytes"] = ooc.peak_rss_bytes;
        j["feedback"] = ooc.feedback;
        nlohmann::ordered_json frames = nlohmann::ordered_json::array();
        for (const OocRows::FrameRow& f : ooc.frames)
            frames.push_back({{"ms", f.ms},
                              {"update_ms", f.update_ms},
                              {"render_ms", f.render_ms},
                              {"bricks_loaded", f.loaded},
                              {"uploads", f.uploads},
                              {"requests", f.requests},
                              {"cut_nodes", f.cut_nodes},
                              {"cut_deepest_level", f.cut_deepest}});
        j["frames"] = std::move(frames);
    }

    void add_kd_json(nlohmann::ordered_json& j) const {
        j["kd_builder"] = kd.builder;
        j["kd_depth"] = kd.depth;
        j["kd_classify"] = kd.classify;
        j["kd_construction"] = kd.construction;
        j["occupied"] = kd.occupied;
        j["occupancy_percent"] = kd.occupancy_percent;
        j["culled_percent"] = kd.culled_percent;
        j["codes_ms"] = kd.codes_ms;
        j["ranges_ms"] = kd.ranges_ms;
        j["classify_ms"] = kd.classify_ms;
        j["occupancy_ms"] = kd.occupancy_ms;
        j["split_ms"] = kd.split_ms;
        j["stream_ms"] = kd.stream_ms;
        j["build_over_stream"] = build_ms / std::max(kd.stream_ms, 1e-9);
        nlohmann::ordered_json seq = nlohmann::ordered_json::array();
        for (const KdRows::Rebuild& r : kd.rebuilds)
            seq.push_back({{"tf", r.tf},
                           {"occupancy_percent", r.occupancy_percent},
                           {"culled_percent", r.culled_percent},
                           {"nodes", r.nodes},
                           {"leaves", r.leaves},
                           {"max_depth", r.depth},
                           {"bytes", r.bytes},
                           {"codes_ms", r.codes_ms},
                           {"ranges_ms", r.ranges_ms},
                           {"classify_ms", r.classify_ms},
                           {"occupancy_ms", r.occupancy_ms},
                           {"split_ms", r.split_ms},
                           {"rebuild_ms", r.rebuild_ms()},
                           {"render_ms", r.render_ms}});
        j["tf_sequence"] = std::move(seq);
    }
};

/// Runs `frame()` n times (at least once) and returns the fastest frame: timings of warm
/// runs (caches filled, Vulkan pipelines compiled on the first dispatch). Every frame's time
/// goes to repeat_frame_ms().
template <class F>
sylva::Frame best_of(std::uint32_t n, F&& frame) {
    repeat_frame_ms().clear();
    sylva::Frame best = frame();
    repeat_frame_ms().push_back(best.ms);
    for (std::uint32_t i = 1; i < n; ++i) {
        sylva::Frame f = frame();
        repeat_frame_ms().push_back(f.ms);
        if (f.ms < best.ms) best = std::move(f);
    }
    return best;
}

}  // namespace sylva_render

#endif
