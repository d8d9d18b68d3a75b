// benchmarks/volume_bench_options.hpp -- the command line of sylva-volume-bench.
#ifndef SYLVA_VOLUME_BENCH_OPTIONS_HPP
#define SYLVA_VOLUME_BENCH_OPTIONS_HPP

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli.hpp"

#ifndef SYLVA_VOLUME_BENCH_DATA
#define SYLVA_VOLUME_BENCH_DATA "../shared/data"
#endif

namespace volume_bench {

using bench_cli::one_of;
using bench_cli::parse_count;
using bench_cli::UsageError;

struct Options {
    std::string data = SYLVA_VOLUME_BENCH_DATA;
    std::string json;
    std::uint32_t width = 320, height = 240;
    std::size_t runs = 3;
    std::size_t threads = 0;
    std::string backend = "cpu";
    std::string only = "all";
    std::string images;
    std::string tf = "warm";
    float alpha = 0.0f;  ///< the warm TF's opacity at density 1; 0 = the data set's default
    bool shading = false;
    bool float_nodes = false;
    std::vector<float> factors{1.0f, 1.5f, 2.0f};
    bool help = false;
};

inline const char* usage() {
    return "usage: sylva-volume-bench [--data DIR] [--json FILE] [--size WxH] [--runs N] [--threads N]\n"
           "                          [--backend cpu|vulkan|both] [--case engine|aneurism|lobster|all|procedural]\n"
           "                          [--images DIR] [--factors 1,1.5,2] [--tf warm|ramp|ct] [--alpha A]\n"
           "                          [--shading] [--float-nodes] [--help]\n"
           "  Image quality and speed of BIH-DVR (Kinkelin 4.3, 6.2) against the reference marcher.\n"
           "  --data DIR      folder with the volumes (default " SYLVA_VOLUME_BENCH_DATA ")\n"
           "  --json FILE     every figure as a JSON array of {case, impl, metric, value, unit}\n"
           "  --size WxH      image size (default 320x240)\n"
           "  --runs N        timed renders per image; medians are reported (default 3)\n"
           "  --threads N     host threads (default: all)\n"
           "  --backend B     cpu (host threads), vulkan (the Vulkan device: lavapipe here) or both\n"
           "  --case C        engine, aneurism, lobster (spacing 1,1,1.4), all of them (default), or\n"
           "                  procedural (a 64^3 Marschner-Lobb volume; needs no data: the smoke test)\n"
           "  --images DIR    write volume_<case>_<renderer>_x<factor>.png (reference, single, multi,\n"
           "                  heat = single-sample iterator steps) into DIR\n"
           "  --factors LIST  resampling factors of the BIH source grid (default 1,1.5,2)\n"
           "  --tf T          warm (default): low base opacity (Kinkelin's Fig. 5), alpha 0 at density 0.1\n"
           "                  rising linearly to A at 1, colour dark red -> orange -> yellow -> white;\n"
           "                  ramp: sylva-render's ramp preset (alpha 0 at 0.1 -> 0.5 at 1, one colour);\n"
           "                  ct: the ct_bone_tissue preset (faint tissue, nearly opaque bone)\n"
           "  --alpha A       the warm TF's alpha at density 1, per unit (voxel) length; default per data\n"
           "                  set: engine 0.04, aneurism 0.4, lobster 0.15, procedural 0.1\n"
           "  --shading       Blinn-Phong shading from the gradient (default off, as Kinkelin's Fig. 5)\n"
           "  --float-nodes   also render the same LoDs encoded with 12-byte float-plane nodes\n"
           "                  (single-f32, multi-f32): isolates the error of the 16-bit planes\n"
           "Exit status: 0 on success, 1 on errors (a missing volume names its path), 2 on bad usage.\n";
}

/// "WxH" with both in 1..8192.
inline void parse_size(const std::string& text, Options& o) {
    std::size_t x = text.find('x');
    if (x == std::string::npos) throw UsageError("--size: '" + text + "' is not WxH (e.g. 320x240)");
    o.width = static_cast<std::uint32_t>(parse_count("--size width", text.substr(0, x), 8192));
    o.height = static_cast<std::uint32_t>(parse_count("--size height", text.substr(x + 1), 8192));
}

/// A comma-separated list of factors, each finite in [0.25, 4].
inline std::vector<float> parse_factors(const std::string& text) {
    std::vector<float> out;
    std::size_t begin = 0;
    while (begin <= text.size()) {
        std::size_t end = text.find(',', begin);
        std::string item = text.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
        char* stop = nullptr;
        float f = std::strtof(item.c_str(), &stop);
        if (item.empty() || *stop != '\0' || !std::isfinite(f) || f < 0.25f || f > 4.0f)
            throw UsageError("--factors: '" + item + "' is not a number in 0.25..4");
        out.push_back(f);
        if (end == std::string::npos) break;
        begin = end + 1;
    }
    return out;
}

/// An opacity in (0, 1].
inline float parse_alpha(const std::string& text) {
    char* stop = nullptr;
    float a = std::strtof(text.c_str(), &stop);
    if (text.empty() || *stop != '\0' || !(a > 0.0f && a <= 1.0f))
        throw UsageError("--alpha: '" + text + "' is not a number in (0, 1]");
    return a;
}

inline Options parse_options(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&] { return bench_cli::value_of(i, argc, argv); };
        if (a == "--data") o.data = value();
        else if (a == "--json") o.json = value();
        else if (a == "--size") parse_size(value(), o);
        else if (a == "--runs") o.runs = parse_count(a, value(), 100);
        else if (a == "--threads") o.threads = parse_count(a, value(), 1024);
        else if (a == "--backend") o.backend = one_of(a, value(), {"cpu", "vulkan", "both"});
        else if (a == "--case") o.only = one_of(a, value(), {"engine", "aneurism", "lobster", "all", "procedural"});
        else if (a == "--images") o.images = value();
        else if (a == "--factors") o.factors = parse_factors(value());
        else if (a == "--tf") o.tf = one_of(a, value(), {"warm", "ramp", "ct"});
        else if (a == "--alpha") o.alpha = parse_alpha(value());
        else if (a == "--shading") o.shading = true;
        else if (a == "--float-nodes") o.float_nodes = true;
        else if (a == "--help" || a == "-h") o.help = true;
        else throw UsageError("unknown option '" + a + "'");
    }
    return o;
}

}  // namespace volume_bench

#endif  // SYLVA_VOLUME_BENCH_OPTIONS_HPP
