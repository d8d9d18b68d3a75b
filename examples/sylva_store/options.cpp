// sylva-store's command line, parsed by CLI11 (Debian libcli11-dev, header only): subcommands,
// typed options with range and set checks, and the help text are CLI11's, so the tool has no
// hand-written parser to get wrong; what CLI11 cannot say (sizes with K/M/G suffixes, value
// ranges, the level 0 that zstd does not have) is checked here after parsing.
#include "options.hpp"

#include <cctype>
#include <cmath>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace sylva_store {

namespace {

const char* kFooter =
    "INPUT: NAME_XxYxZ_TYPE.raw (read slice by slice), .nrrd/.nhdr (read whole), procedural:ml:N or\n"
    "procedural:ml:XxYxZ (Marschner-Lobb, generated slice by slice; procedural:ml = 128^3),\n"
    "procedural:nbody (192^3). --resample K upsamples trilinearly, slice by slice (the source is held).\n"
    "The store is an LMDB directory: the octree index (nodes, min/max, neighbours), every brick\n"
    "compressed with its XXH3 checksum, the build settings and a format version. The build never\n"
    "holds the volume: its memory stays under --memory (default 1G; K/M/G suffixes). A build that\n"
    "stops (kill, full disk) leaves an incomplete store; the same command with --resume finishes it.\n"
    "verify checks every brick's checksum: exit 1 and the bad brick keys when any fails or the store\n"
    "is incomplete. Exit status: 0 done, 1 error, 2 bad usage, 3 disk (map) full.";

/// The text options that need converting after CLI11 has parsed them.
struct Raw {
    std::string memory = "1G";
    std::string map_size;
    std::string range = "auto";
    std::vector<float> spacing;
};

/// The parser, bound to `o` and `raw`.
std::unique_ptr<CLI::App> make_app(Options& o, Raw& raw) {
    auto app = std::make_unique<CLI::App>("sylva-store: builds, describes and verifies out-of-core brick stores",
                                          "sylva-store");
    app->footer(kFooter);
    app->require_subcommand(1, 1);

    CLI::App* build = app->add_subcommand("build", "build a store from a volume, slice by slice");
    build->add_option("INPUT", o.input, "volume file or procedural:ml[:N|:XxYxZ] / procedural:nbody")->required();
    build->add_option("-o,--output", o.store, "the store directory to create")->required();
    build->add_option("--brick", o.brick, "brick size B (voxels a side)")->capture_default_str()
        ->check(CLI::IsMember(std::set<std::uint32_t>{4, 8, 16, 32, 64}));
    build->add_option("--border", o.border, "replicated samples per brick side")->capture_default_str()
        ->check(CLI::IsMember(std::set<std::uint32_t>{1, 2}));
    build->add_option("--compress", o.codec, "brick codec")->capture_default_str()
        ->check(CLI::IsMember(std::set<std::string>{"zstd", "lz4", "none"}));
    build->add_option("--brick-format", o.brick_format,
                      "brick samples: auto (unorm16 for uint8 / uint16 volumes, float32 otherwise), float32, "
                      "unorm16 or unorm8 (densities rounded to 65535 / 255 steps)")
        ->capture_default_str()
        ->check(CLI::IsMember(std::set<std::string>{"auto", "float32", "unorm16", "unorm8"}));
    build->add_option("--level", o.level, "zstd's level: 1 to 19, or -1 to -5 for its fast modes")->capture_default_str()
        ->check(CLI::Range(-5, 19))
        ->check([](const std::string& v) {
            return v == "0" ? std::string("0 is not a level (1..19, or -1..-5 for zstd's fast modes)") : std::string();
        });
    build->add_option("--memory", raw.memory, "memory budget of the build (K/M/G/T suffixes)")->capture_default_str();
    build->add_flag("--resume", o.resume, "finish an interrupted store of the same input and settings");
    build->add_option("--resample", o.resample, "upsample by K (trilinear, slice by slice)")->capture_default_str()
        ->check(CLI::Range(0.1, 16.0));
    build->add_option("--range", raw.range, "value range of files: auto, type or LO,HI")->capture_default_str();
    build->add_option("--spacing", raw.spacing, "voxel size X,Y,Z (world units)")
        ->delimiter(',')
        ->expected(3)
        ->check(CLI::Range(1e-6, 1e6));
    build->add_option("--threads", o.threads, "worker threads (0: all cores)")->capture_default_str()->check(CLI::Range(0, 1024));
    build->add_flag("--quiet", o.quiet, "no progress line");
    // For tests: a small LMDB map (a "full disk") and small committed batches; not in --help.
    build->add_option("--map-size", raw.map_size)->group("");
    build->add_option("--commit-bricks", o.commit_bricks)->group("")->check(CLI::Range(1.0, 1e9));

    CLI::App* info = app->add_subcommand("info", "print a store's settings, size and completeness");
    info->add_option("STORE", o.store, "the store directory")->required();
    CLI::App* verify = app->add_subcommand("verify", "check every brick's checksum");
    verify->add_option("STORE", o.store, "the store directory")->required();
    return app;
}

/// Checks and conversions CLI11 does not do.
void finish(Options& o, const Raw& raw, const CLI::App& app) {
    o.command = app.get_subcommands().front()->get_name();
    if (o.command != "build") return;
    o.memory = parse_bytes("--memory", raw.memory);
    if (!raw.map_size.empty()) o.map_size = parse_bytes("--map-size", raw.map_size);
    try {
        o.range = sylva::volume::ValueRange::parse(raw.range);
    } catch (const std::exception& e) {
        throw std::invalid_argument(std::string("--range: ") + e.what());
    }
    if (!raw.spacing.empty()) o.spacing = raw.spacing;
    bool procedural = o.input.rfind("procedural", 0) == 0;
    if (procedural && o.range.mode != sylva::volume::ValueRange::Mode::Auto)
        throw std::invalid_argument("--range applies to volume files; the procedural volumes are densities in [0, 1]");
}

}  // namespace

std::string usage() {
    Options o;
    Raw raw;
    return make_app(o, raw)->help("", CLI::AppFormatMode::All);
}

std::uint64_t parse_bytes(const std::string& opt, const std::string& v) {
    if (v.empty()) throw std::invalid_argument(opt + " needs a size");
    double scale = 1.0;
    std::string num = v;
    const std::string units = "KMGT";
    auto u = units.find(static_cast<char>(std::toupper(static_cast<unsigned char>(v.back()))));
    if (u != std::string::npos) {
        scale = std::pow(1024.0, double(u + 1));
        num.pop_back();
    }
    double x = 0.0;
    try {
        std::size_t used = 0;
        x = std::stod(num, &used) * scale;
        if (used != num.size()) x = -1.0;
    } catch (const std::exception&) {
        x = -1.0;
    }
    if (!(x >= 1.0 && x < 1.8e19)) throw std::invalid_argument(opt + ": '" + v + "' is not a size in bytes");
    return static_cast<std::uint64_t>(x);
}

Options parse(int argc, char** argv) {
    Options o;
    Raw raw;
    std::unique_ptr<CLI::App> app = make_app(o, raw);
    try {
        app->parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
        throw std::invalid_argument("help");
    } catch (const CLI::CallForAllHelp&) {
        throw std::invalid_argument("help");
    } catch (const CLI::ParseError& e) {
        throw std::invalid_argument(e.what());
    }
    finish(o, raw, *app);
    return o;
}

}  // namespace sylva_store
