// sylva-render statistics: printed and written as one JSON object.
#ifndef SYLVA_RENDER_STATS_HPP
#define SYLVA_RENDER_STATS_HPP

#include <algorithm>
#include <fstream>
#include <ostream>
#include <string>

#include <sylva/bih/tree.hpp>
#include <sylva/core/error.hpp>
#include <sylva/render/particles.hpp>

namespace sylva_render {

struct Stats {
    std::string index = "bih", backend, device, input;
    std::size_t elements = 0, nodes = 0, leaves = 0, bytes = 0, errors = 0;
    std::uint32_t max_depth = 0, heatmap_peak = 0, width = 0, height = 0;
    double build_ms = 0, encode_ms = 0, render_ms = 0, rays_per_s = 0, single_child_percent = 0, steps_mean = 0;
    std::uint32_t steps_max = 0;

    void fill(const sylva::bih::Tree& t, std::size_t encoded_bytes, const sylva::Frame& f) {
        elements = t.stats.elements;
        nodes = t.stats.nodes;
        leaves = t.stats.leaves;
        max_depth = t.stats.max_depth;
        single_child_percent = t.stats.percent_single_child();
        build_ms = t.stats.build_ms;
        bytes = encoded_bytes;
        width = f.width;
        height = f.height;
        render_ms = f.ms;
        rays_per_s = f.ms > 0 ? static_cast<double>(f.rgba.size()) / (f.ms / 1000.0) : 0.0;
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
    }

    void print(std::ostream& os) const {
        os << "input            " << input << "\n"
           << "index            " << index << " (" << elements << " elements, " << nodes << " nodes, " << leaves
           << " leaves, depth " << max_depth << ", " << single_child_percent << "% single-child)\n"
           << "bytes            " << bytes << "\n"
           << "build            " << build_ms << " ms (" << elements / std::max(build_ms, 1e-9) * 1000.0
           << " elements/s), encode " << encode_ms << " ms\n"
           << "render           " << backend << " on " << device << ": " << width << "x" << height << " in "
           << render_ms << " ms, " << rays_per_s << " rays/s\n"
           << "iterator steps   mean " << steps_mean << ", max " << steps_max << "\n";
        if (errors) os << "ERRORS           " << errors << " rays ended on a corrupted encoding\n";
    }

    static std::string quoted(const std::string& s) {
        std::string out = "\"";
        for (char c : s) {
            if (c == '"' || c == '\\') out += '\\';
            if (static_cast<unsigned char>(c) >= 0x20) out += c;
        }
        return out + "\"";
    }

    void write_json(const std::string& path) const {
        std::ofstream out(path);
        if (!out) throw sylva::Error("cannot write stats file " + path);
        out << "{\"index\": " << quoted(index) << ", \"backend\": " << quoted(backend)
            << ", \"device\": " << quoted(device) << ", \"input\": " << quoted(input) << ", \"elements\": " << elements
            << ", \"nodes\": " << nodes << ", \"leaves\": " << leaves << ", \"max_depth\": " << max_depth
            << ", \"single_child_percent\": " << single_child_percent << ", \"bytes\": " << bytes
            << ", \"build_ms\": " << build_ms << ", \"encode_ms\": " << encode_ms << ", \"render_ms\": " << render_ms
            << ", \"rays_per_s\": " << rays_per_s << ", \"width\": " << width << ", \"height\": " << height
            << ", \"steps_mean\": " << steps_mean << ", \"steps_max\": " << steps_max << ", \"errors\": " << errors
            << "}\n";
        if (!out) throw sylva::Error("cannot write stats file " + path);
    }
};

}  // namespace sylva_render

#endif
