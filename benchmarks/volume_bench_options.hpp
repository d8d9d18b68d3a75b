// benchmarks/volume_bench_options.hpp -- the command line of sylva-volume-bench.
#ifndef SYLVA_VOLUME_BENCH_OPTIONS_HPP
#define SYLVA_VOLUME_BENCH_OPTIONS_HPP

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"

#ifndef SYLVA_VOLUME_BENCH_DATA
#define SYLVA_VOLUME_BENCH_DATA "../shared/data"
#endif

namespace volume_bench {

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
};

/// The command line, bound to `o`.
inline std::unique_ptr<CLI::App> make_app(Options& o) {
    auto app = std::make_unique<CLI::App>(
        "sylva-volume-bench: image quality and speed of BIH-DVR (Kinkelin 4.3, 6.2) against the reference marcher",
        "sylva-volume-bench");
    app->footer(
        "--tf T: warm (default): low base opacity (Kinkelin's Fig. 5), alpha 0 at density 0.1 rising\n"
        "        linearly to A at 1, colour dark red -> orange -> yellow -> white;\n"
        "        ramp: sylva-render's ramp preset (alpha 0 at 0.1 -> 0.5 at 1, one colour);\n"
        "        ct: the ct_bone_tissue preset (faint tissue, nearly opaque bone).\n"
        "--alpha A defaults per data set: engine 0.04, aneurism 0.4, lobster 0.15, procedural 0.1.\n"
        "Exit status: 0 on success, 1 on errors (a missing volume names its path), 2 on bad usage.");
    app->add_option("--data", o.data, "folder with the volumes")->type_name("DIR")->capture_default_str();
    app->add_option("--json", o.json, "every figure as a JSON array of {case, impl, metric, value, unit}")
        ->type_name("FILE");
    bench_cli::add_size(*app, "--size", o.width, o.height, "image size");
    app->add_option("--runs", o.runs, "timed renders per image; medians are reported")
        ->type_name("N")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t{1}, std::size_t{100}));
    app->add_option("--threads", o.threads, "host threads (default: all)")
        ->type_name("N")
        ->check(CLI::Range(std::size_t{1}, std::size_t{1024}));
    app->add_option("--backend", o.backend, "cpu (host threads), vulkan (the Vulkan device: lavapipe here) or both")
        ->type_name("B")
        ->capture_default_str()
        ->check(CLI::IsMember({"cpu", "vulkan", "both"}));
    app->add_option("--case", o.only,
                    "engine, aneurism, lobster (spacing 1,1,1.4), all of them, or procedural (a 64^3 "
                    "Marschner-Lobb volume; needs no data: the smoke test)")
        ->type_name("C")
        ->capture_default_str()
        ->check(CLI::IsMember({"engine", "aneurism", "lobster", "all", "procedural"}));
    app->add_option("--images", o.images,
                    "write volume_<case>_<renderer>_x<factor>.png (reference, single, multi, heat = single-sample "
                    "iterator steps) into DIR")
        ->type_name("DIR");
    app->add_option("--factors", o.factors, "resampling factors of the BIH source grid, each in 0.25..4")
        ->type_name("LIST")
        ->capture_default_str()
        ->delimiter(',')
        ->check(bench_cli::number_in(0.25, 4.0));
    app->add_option("--tf", o.tf, "transfer function (below)")
        ->type_name("T")
        ->capture_default_str()
        ->check(CLI::IsMember({"warm", "ramp", "ct"}));
    app->add_option("--alpha", o.alpha, "the warm TF's alpha at density 1, per unit (voxel) length, in (0, 1]")
        ->type_name("A")
        ->check(CLI::Validator(
            [](std::string& v) {
                float a = 0.0f;
                return CLI::detail::lexical_cast(v, a) && a > 0.0f && a <= 1.0f
                           ? std::string()
                           : "'" + v + "' is not a number in (0, 1]";
            },
            ""));
    app->add_flag("--shading", o.shading, "Blinn-Phong shading from the gradient (default off, as Kinkelin's Fig. 5)");
    app->add_flag("--float-nodes", o.float_nodes,
                  "also render the same LoDs encoded with 12-byte float-plane nodes (single-f32, multi-f32): "
                  "isolates the error of the 16-bit planes");
    return app;
}

}  // namespace volume_bench

#endif  // SYLVA_VOLUME_BENCH_OPTIONS_HPP
