// sylva-render's command line, parsed by CLI11 (Debian libcli11-dev, header only): every option
// is a CLI11 option with its check (a value set, a number range, a size, a list), grouped in the
// help by what it applies to; the checks of options against each other follow the parse.
#include "options.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <initializer_list>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <utility>

#include <CLI/CLI.hpp>

#include <sylva/render/image.hpp>

namespace sylva_render {

namespace {

// ---- value conversions: each throws std::invalid_argument saying why the text is bad ----------

/// `x` as the messages and the help write a limit or a default: whole numbers as their digits,
/// others as the shortest ostream form (0.001).
std::string label(double x) {
    if (x == std::floor(x) && std::fabs(x) < 1e16) return std::to_string(static_cast<long long>(x));
    std::ostringstream out;
    out << x;
    return out.str();
}

/// `v` read by strtod (also 1e6, 0.5) when it is a number in [lo, hi].
double number(const std::string& v, double lo, double hi) {
    char* end = nullptr;
    double x = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || !(x >= lo && x <= hi))
        throw std::invalid_argument("'" + v + "' is not a number in [" + label(lo) + ", " + label(hi) + "]");
    return x;
}

std::pair<std::uint32_t, std::uint32_t> parse_size(const std::string& v) {
    auto x = v.find('x');
    if (x == std::string::npos) throw std::invalid_argument("'" + v + "' is not WxH");
    return {static_cast<std::uint32_t>(number(v.substr(0, x), 1, 16384)),
            static_cast<std::uint32_t>(number(v.substr(x + 1), 1, 16384))};
}

std::vector<float> parse_vec3(const std::string& v) {
    std::vector<float> out;
    std::stringstream ss(v);
    for (std::string part; std::getline(ss, part, ',');) out.push_back(static_cast<float>(number(part, -1e6, 1e6)));
    if (out.size() != 3) throw std::invalid_argument("'" + v + "' is not X,Y,Z");
    return out;
}

/// --view and --spacing.
std::optional<std::vector<float>> read_vec3(const std::string& v) { return parse_vec3(v); }

std::vector<std::string> parse_list(const std::string& v) {
    std::vector<std::string> out;
    std::stringstream ss(v);
    for (std::string part; std::getline(ss, part, ',');) {
        if (part.empty()) throw std::invalid_argument("'" + v + "' has an empty entry");
        out.push_back(part);
    }
    if (out.empty()) throw std::invalid_argument("'" + v + "' names no file");
    return out;
}

std::vector<float> parse_isos(const std::string& v) {
    std::vector<float> out;
    std::stringstream ss(v);
    for (std::string part; std::getline(ss, part, ',');) out.push_back(static_cast<float>(number(part, 0, 1)));
    if (out.empty() || out.size() > 4) throw std::invalid_argument("'" + v + "' is not 1 to 4 values V1,V2,...");
    return out;
}

std::size_t parse_bytes(const std::string& v) {
    std::string digits = v;
    double scale = 1.0;
    if (!v.empty()) {
        char u = static_cast<char>(std::toupper(static_cast<unsigned char>(v.back())));
        if (u == 'K' || u == 'M' || u == 'G') {
            scale = u == 'K' ? 1024.0 : u == 'M' ? 1048576.0 : 1073741824.0;
            digits.pop_back();
        }
    }
    double x = number(digits, 1, 1e15) * scale;
    if (x > 1e15) throw std::invalid_argument("'" + v + "' is too large");
    return static_cast<std::size_t>(x);
}

/// A byte count as the help shows a default (256M).
std::string bytes_label(std::size_t b) {
    if (b % (std::size_t{1} << 30) == 0) return std::to_string(b >> 30) + "G";
    if (b % (std::size_t{1} << 20) == 0) return std::to_string(b >> 20) + "M";
    if (b % (std::size_t{1} << 10) == 0) return std::to_string(b >> 10) + "K";
    return std::to_string(b);
}

sylva::volume::ValueRange parse_range(const std::string& v) {
    try {
        return sylva::volume::ValueRange::parse(v);
    } catch (const std::invalid_argument&) {
        throw;
    } catch (const std::exception& e) {
        throw std::invalid_argument(e.what());
    }
}

bool is_directory_with(const std::string& dir, const char* file) {
    std::error_code ec;
    return !dir.empty() && std::filesystem::is_directory(dir, ec) &&
           std::filesystem::exists(std::filesystem::path(dir) / file, ec);
}

// ---- CLI11 options -------------------------------------------------------------------------------

/// Adds options to one help group of `app`. Each value option is read as text and converted by a
/// function that throws std::invalid_argument: CLI11 reports its message as "OPTION: message"
/// (exit status 2), the parse stores the converted value of the last occurrence.
struct Group {
    CLI::App& app;
    std::string name;

    /// `text` broken into lines of at most `width` characters at spaces (its own line breaks kept),
    /// for the help's description column.
    static std::string wrap(const std::string& text, std::size_t width = 64) {
        std::string out, line, word;
        auto flush_word = [&] {
            if (word.empty()) return;
            if (!line.empty() && line.size() + 1 + word.size() > width) out += line + "\n", line.clear();
            line += (line.empty() ? "" : " ") + word;
            word.clear();
        };
        for (char c : text) {
            if (c == ' ') flush_word();
            else if (c == '\n') flush_word(), out += line + "\n", line.clear();
            else word += c;
        }
        flush_word();
        return out + line;
    }

    /// The help's description: `desc` and, when not empty, "[default D]", wrapped.
    static std::string described(const std::string& desc, const std::string& dflt) {
        return wrap(dflt.empty() ? desc : desc + " [default " + dflt + "]");
    }

    /// An option whose text `convert` reads (throwing std::invalid_argument why not) and `store`
    /// keeps.
    template <class Convert, class Store>
    CLI::Option* checked(const std::string& opt, Convert convert, Store store, const std::string& text,
                         const std::string& desc, const std::string& dflt = "") {
        CLI::Option* o = app.add_option_function<std::string>(
            opt, [convert, store](const std::string& v) { store(convert(v)); }, described(desc, dflt));
        o->check(CLI::Validator(
            [convert](std::string& v) {
                try {
                    (void)convert(v);
                    return std::string();
                } catch (const std::invalid_argument& e) {
                    return std::string(e.what());
                }
            },
            ""));
        return o->option_text(text)->type_name(text)->group(name);
    }

    /// An option whose text `convert` reads into `target`.
    template <class T, class Convert>
    CLI::Option* converted(const std::string& opt, T& target, Convert convert, const std::string& text,
                           const std::string& desc, const std::string& dflt = "") {
        return checked(opt, convert, [&target](auto v) { target = std::move(v); }, text, desc, dflt);
    }

    /// A text option (a file name).
    CLI::Option* text(const std::string& opt, std::string& target, const std::string& text, const std::string& desc) {
        return app.add_option(opt, target, wrap(desc))->option_text(text)->group(name);
    }

    /// One of `values` (the help's label is "a|b|c" unless `text` is given).
    CLI::Option* choice(const std::string& opt, std::string& target, std::initializer_list<const char*> values,
                        const std::string& desc, std::string text = "") {
        std::vector<std::string> allowed(values.begin(), values.end());
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : "|") + a;
        auto one_of = [allowed, list](const std::string& v) {
            for (const std::string& a : allowed)
                if (v == a) return v;
            throw std::invalid_argument("'" + v + "' is not one of " + list);
        };
        return converted(opt, target, one_of, text.empty() ? list : text, desc, target);
    }

    /// An on|off switch.
    CLI::Option* on_off(const std::string& opt, bool& target, const std::string& desc) {
        auto read = [](const std::string& v) {
            if (v != "on" && v != "off") throw std::invalid_argument("'" + v + "' is not one of on|off");
            return v == "on";
        };
        return converted(opt, target, read, "on|off", desc, target ? "on" : "off");
    }

    /// A number in [lo, hi] (strtod's syntax: 1e6 too), stored as T (whole types truncate);
    /// the help adds "[LO..HI, default D]", D the target's value unless `dflt` is given ("": none).
    template <class T>
    CLI::Option* number(const std::string& opt, T& target, double lo, double hi, const std::string& text,
                        const std::string& desc, std::optional<std::string> dflt = std::nullopt) {
        auto read = [lo, hi](const std::string& v) { return static_cast<T>(sylva_render::number(v, lo, hi)); };
        std::string d = dflt ? *dflt : label(static_cast<double>(target));
        std::string range = label(lo) + ".." + label(hi);
        CLI::Option* o = converted(opt, target, read, text, desc);
        return o->description(wrap(desc + " [" + range + (d.empty() ? "" : ", default " + d) + "]"));
    }

    CLI::Option* flag(const std::string& opt, bool& target, const std::string& desc) {
        return app.add_flag(opt, target, wrap(desc))->group(name);
    }
};

/// The usage lines of today's tools: the common options, then "[OPTIONS]" for the groups below.
class Formatter : public CLI::Formatter {
public:
    std::string make_usage(const CLI::App*, std::string) const override {
        return "Usage: sylva-render [--particles FILE | --volume FILE|STORE|procedural[:ml|nbody]] [--index INDEX]\n"
               "                    [--backend cpu|vulkan] [--size WxH] -o OUT.png|OUT.exr [--stats-json FILE]\n"
               "                    [--heatmap FILE] [OPTIONS]\n\n";
    }
    /// A group: its name, then its options (one blank line between groups, not CLI11's two).
    std::string make_group(std::string group, bool is_positional, std::vector<const CLI::Option*> opts) const override {
        std::string out = group + ":\n";
        for (const CLI::Option* opt : opts) out += make_option(opt, is_positional);
        return out;
    }
};

const char* kDescription =
    "sylva-render: builds a spatial index over particles (a file or a procedural galaxy) or over a\n"
    "volume (a file, a brick store or a procedural volume), renders it on the host or through Vulkan\n"
    "and writes the image, a traversal-cost heat map and statistics.";

const char* kFooter =
    "--index kd renders particles through the element kd-tree (the element octree's exact image);\n"
    "--index octree with --particles, or with --count and no input (the galaxy), through the element\n"
    "octree, in exact depth order, on either backend.\n"
    "--index kd-vidal|kd-binned renders the reference marcher with empty-space skipping by a\n"
    "kd-tree (Vidal et al.; Zellmann et al.): the same image, fewer samples.\n"
    "--index implicit-kd renders exact isosurfaces of up to 4 --iso values over Wald et al.'s\n"
    "implicit min/max kd-tree (--index dda: every cell, the reference; the same image). One\n"
    "isovalue is opaque; with several, all but the last are translucent.\n"
    "--index octree renders a volume's DVR or the first hit of one --iso value through Gobbetti\n"
    "et al.'s bricked octree; without --lod-pixels the full-resolution cut (the marcher's image),\n"
    "with it a cut refined while a node's voxels project larger than P pixels, within --cut-nodes\n"
    "nodes. --volume STORE (a brick store directory made by sylva-store build) always renders out\n"
    "of core (32 frames unless --frames; --brick is the store's).\n"
    "With no input sylva-render renders a procedural galaxy of --count particles (default 1,000,000);\n"
    "with --mode, a kd-tree or isosurface index, or --index octree without --count, and no input, a\n"
    "procedural volume.\n"
    "Volume files: NAME_XxYxZ_TYPE.raw, .nrrd, .nhdr.\n"
    "--range picks the raw values that map to density 0 and 1, which the threshold, the transfer\n"
    "function, --iso and the LoD read: auto (default) = the file's min/max fields, else the data's\n"
    "min/max; type = 0..255 / 0..65535; LO,HI as given.\n"
    "SYLVA_VULKAN_DEVICE=auto|cpu|gpu|INDEX|NAME picks the Vulkan device.\n"
    "Exit status: 0 done, 1 error, 2 bad usage.";

void add_general(CLI::App& app, Options& o) {
    Group g{app, "Options"};
    g.text("--particles", o.particles, "FILE", "particles: float32 x,y,z triples (NAME_Nx3_float32.raw)");
    g.text("--volume", o.volume, "VOLUME",
           "a volume: FILE (NAME_XxYxZ_TYPE.raw, .nrrd, .nhdr), STORE (a brick store directory made by "
           "sylva-store build) or procedural[:ml|nbody]");
    g.choice("--index", o.index, {"bih", "kd", "kd-vidal", "kd-binned", "implicit-kd", "dda", "octree", "none"},
             "bih|kd|kd-vidal|kd-binned|implicit-kd|dda|octree|none:\n"
             "bih: the BIH (particles, volumes)\n"
             "kd: the element kd-tree (particles)\n"
             "kd-vidal, kd-binned: the marcher with kd-tree empty-space skipping (volumes)\n"
             "implicit-kd: exact isosurfaces; dda: the same over every cell (volumes)\n"
             "octree: the bricked octree (volumes) or the element octree (particles)\n"
             "none: the reference marcher (volumes)",
             "INDEX");
    g.choice("--backend", o.backend, {"cpu", "vulkan"}, "render on the host or through Vulkan");
    std::string size = std::to_string(o.width) + "x" + std::to_string(o.height);
    g.checked("--size", parse_size, [&o](std::pair<std::uint32_t, std::uint32_t> wh) {
        std::tie(o.width, o.height) = wh;
    }, "WxH", "image size, each side 1..16384", size);
    g.text("-o,--output", o.output, "OUT.png|OUT.exr", "the image (required)");
    g.text("--stats-json", o.stats_json, "FILE", "the statistics as one JSON object");
    g.text("--heatmap", o.heatmap, "FILE", "the traversal cost of each pixel as an image");
    g.converted("--view", o.view, read_vec3, "X,Y,Z", "direction from the centre to the eye",
                "0.4,0.7,1 for particles, 0.4,0.3,1 for volumes");
    g.choice("--camera", o.camera, {"pinhole", "ortho"},
             "primary rays framing the volume or the particles from --view (ortho: a view rectangle as high as "
             "their bounding sphere, rays along the view direction)");
    g.number("--threads", o.threads, 0, 1024, "T", "worker threads, 0: all cores");
    g.flag("--quiet", o.quiet, "no progress bars and no statistics on stdout");
}

void add_particles(CLI::App& app, Options& o) {
    Group g{app, "particles (a --particles file, or with no input the procedural galaxy)"};
    g.number("--count", o.count, 1, 1e8, "N", "particles of the galaxy");
    g.number("--radius-factor", o.radius_factor, 1e-3, 1e3, "F", "radius in mean spacings (files)");
    g.number("--opacity", o.opacity, 0, 1, "A", "particle opacity (files)");
    g.number("--alpha-stop", o.alpha_stop, 0, 2, "A",
             "early ray termination at this alpha (particles and volumes; 2: never)");
    g.choice("--payload", o.payload, {"inline", "range"}, "BIH leaves: one particle inline, or ranges of records");
    g.choice("--nodes", o.nodes, {"fixed16", "float32"}, "BIH split planes: 16-bit fixed point or float");
    g.choice("--layout", o.layout, {"chunks", "preorder"}, "BIH node order: tree chunks or preorder");
    g.number("--chunk-depth", o.chunk_depth, 0, 15, "D", "levels a tree chunk holds");
    g.choice("--empty-children", o.empty_children, {"trim-both", "infinite"}, "BIH empty children");
    g.choice("--order", o.order, {"exact", "leaf"},
             "exact: bih, kd and octree through the generic element kernel, the same image; leaf: each "
             "index's own integrator (the BIH's per-leaf sort, Kinkelin 4.2; --index kd: cpu only)");

    Group m{app, "moving particles (--index bih|kd|octree, cpu or vulkan)"};
    m.number("--animate", o.animate, 1, 100000, "N",
             "move the particles for N frames (vulkan: one context and kernel for all frames, each "
             "uploads its encoding and records)",
             "none: a still image");
    m.choice("--update", o.update, {"refit", "rebuild"}, "how the index follows the motion each frame");
}

void add_volumes(CLI::App& app, Options& o) {
    Group g{app, "volumes (a --volume, or with --mode and no input the procedural volume)"};
    g.choice("--mode", o.mode, {"dvr", "iso"}, "direct volume rendering, or the first hit of --iso [default dvr]");
    g.choice("--dvr", o.dvr, {"single", "multi"}, "BIH-DVR samples per leaf (Kinkelin 4.3)");
    g.text("--tf", o.tf, "FILE", "transfer function (.json or text control points)");
    g.choice("--tf-preset", o.tf_preset, {"ct", "ramp"}, "transfer function without --tf");
    g.converted("--range", o.range, parse_range, "auto|type|LO,HI", "raw values mapped to density 0 and 1 (files)",
                "auto");
    g.number("--threshold", o.threshold, 0, 1, "D", "voxels of density >= D are the BIH's elements");
    g.number("--resample", o.resample, 0.1, 8, "F", "trilinear supersampling factor (Kinkelin 6.2)");
    g.converted("--spacing", o.spacing, read_vec3, "X,Y,Z", "voxel size (overrides the file's)");
    g.choice("--border", o.border, {"clamp", "zero"}, "what samples read outside the voxel centres");
    g.choice("--grid", o.grid_format, {"native", "sparse", "float32"},
             "uint8/uint16 files read as stored (1/2 bytes a voxel), in 8^3 bricks with uniform ones not stored, or a float copy");
    g.number("--lod-density", o.lod_density, 0, 1, "F", "min element density of an LoD leaf (Kinkelin Table 3)");
    g.number("--lod-stddev", o.lod_stddev, 0, 1, "F", "max std-dev of an LoD leaf's densities");
    g.number("--lod-depth", o.lod_depth, 0, 64, "N", "max LoD depth");
    g.converted("--iso", o.isos, parse_isos, "V[,V2,...]",
                "isovalue(s) in 0..1 for --mode iso (up to 4 with --index implicit-kd|dda)", "0.5");
    g.on_off("--iso-cull", o.iso_cull, "skip nodes whose density range excludes the isovalue");
    g.number("--steps", o.steps, 1, 1 << 16, "N", "samples along the longest axis (reference marcher, multi)");
    g.flag("--shading", o.shading, "Lambert shading from the gradient (always with --mode iso)");
    g.number("--repeat", o.repeat, 1, 1000, "N",
             "render N frames and report the fastest and the median (warm caches, pipelines compiled; "
             "JSON ms_min, ms_median, frame_ms); volumes, and particles but for --order leaf with --index kd|octree");
}

/// The options of one volume index each: kd-trees, the implicit kd-tree, the octree, out of core.
void add_volume_indices(CLI::App& app, Options& o) {
    Group k{app, "kd-trees (volumes: --index kd-vidal|kd-binned)"};
    k.choice("--kd", o.kd, {"shallow", "deep"}, "Vidal's halting criteria or Zellmann's 8^3 leaves");
    k.choice("--kd-classify", o.kd_classify, {"alpha", "threshold"}, "occupancy from the TF's alpha or --threshold");
    k.text("--boxes", o.boxes, "FILE", "the image with the kd-tree's leaf boxes drawn over it");
    k.converted("--tf-sequence", o.tf_sequence, parse_list, "TF1,TF2,...",
                "replay transfer functions, rebuilding the kd-tree for each");

    Group i{app, "isosurfaces (volumes: --index implicit-kd|dda)"};
    i.number("--ikd-bricks", o.ikd_bricks, 0, 12, "N",
             "bottom levels of the implicit kd-tree not stored (0: slim tree)");
    i.converted("--ikd-node-bits", o.ikd_node_bits, [](const std::string& v) -> std::uint32_t {
        if (v != "8" && v != "16") throw std::invalid_argument("'" + v + "' is not one of 8|16");
        return v == "8" ? 8u : 16u;
    }, "8|16", "bits of a node's min and max in the implicit kd-tree", label(o.ikd_node_bits));
    i.converted("--packets", o.packets, [](const std::string& v) -> std::uint32_t {
        if (v != "1" && v != "4" && v != "8" && v != "16") throw std::invalid_argument("'" + v + "' is not one of 1|4|8|16");
        return static_cast<std::uint32_t>(std::stoul(v));
    }, "1|4|8|16", "rays of a tile walking the implicit kd-tree together (--backend cpu; 1: single rays, 4: "
                   "Wald's 2x2 packets)", label(o.packets));

    Group t{app, "octree (volumes: --index octree)"};
    t.converted("--brick", o.brick, [](const std::string& v) -> std::uint32_t {
        if (v != "16" && v != "32") throw std::invalid_argument("'" + v + "' is not one of 16|32");
        return v == "16" ? 16u : 32u;
    }, "16|32", "brick size", label(o.brick));
    t.number("--lod-pixels", o.lod_pixels, 1e-3, 1e4, "P",
             "view-dependent cut: refine while a node's voxels project larger than P pixels",
             "none: the full-resolution cut");
    t.number("--max-tf-error", o.max_tf_error, 0, 1, "E",
             "with --lod-pixels, DVR: refine nodes under P pixels too while their samples, classified by the "
             "TF, may differ from their voxels' by more than E (sylva/octree/lod_error.hpp; 1: the projection alone, "
             "as the paper)",
             "1/64");
    t.number("--cut-nodes", o.cut_nodes, 1, 4294967295.0, "N", "node budget of the cut");

    Group c{app, "out of core (--index octree and a volume)"};
    c.converted("--memory-budget", o.memory_budget, parse_bytes, "SIZE", "host brick cache (K, M, G suffixes)",
                bytes_label(o.memory_budget));
    c.converted("--device-budget", o.device_budget, parse_bytes, "SIZE", "device brick pool (K, M, G suffixes)",
                bytes_label(o.device_budget));
    c.number("--frames", o.frames, 1, 100000, "N", "progressive frames",
             "0: in core; 32 with an out-of-core option or a store");
    c.text("--frames-out", o.frames_out, "DIR", "every frame as DIR/frame_NNNN.png");
    c.flag("--orbit", o.orbit, "the view turns once about the vertical axis over the frames");
    c.on_off("--feedback", o.feedback, "refine only nodes rays reached the frame before");
}

/// The parser, bound to `o`.
std::unique_ptr<CLI::App> make_app(Options& o) {
    auto app = std::make_unique<CLI::App>(kDescription, "sylva-render");
    app->formatter(std::make_shared<Formatter>());
    app->get_formatter()->column_width(34);
    app->footer(kFooter);
    app->allow_extras();  // reported as "unknown option" after the parse
    app->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    add_general(*app, o);
    add_particles(*app, o);
    add_volumes(*app, o);
    add_volume_indices(*app, o);
    return app;
}

bool given(const CLI::App& app, const char* opt) { return app.count(opt) > 0; }

/// Built without OpenImageIO (SYLVA_HAVE_OIIO=0) image.hpp writes .ppm and .pfm only: other
/// names are refused here, before any work, not after the render.
void check_image_names(const Options& o) {
#if defined(SYLVA_HAVE_OIIO) && !SYLVA_HAVE_OIIO
    auto writable = [](const std::string& name) {  // any case, as image.hpp
        return sylva::detail::ends_with(name, ".ppm") || sylva::detail::ends_with(name, ".pfm");
    };
    for (const std::string* name : {&o.output, &o.heatmap, &o.boxes})
        if (!name->empty() && !writable(*name))
            throw std::invalid_argument("cannot write " + *name + ": this sylva-render was built without OpenImageIO "
                                        "(libopenimageio-dev), which writes PNG and EXR; name a .ppm or .pfm file");
    if (!o.frames_out.empty())
        throw std::invalid_argument("--frames-out writes PNG frames: this sylva-render was built without OpenImageIO");
#else
    (void)o;
#endif
}

/// Which input and index the options ask for, and the particle options with them.
void check_input(const Options& o, const CLI::App& app) {
    if (o.output.empty()) throw std::invalid_argument("-o OUT.png is required");
    check_image_names(o);
    if (!o.particles.empty() && !o.volume.empty()) throw std::invalid_argument("--particles and --volume exclude each other");
    if (!o.particles.empty() && !o.mode.empty()) throw std::invalid_argument("--mode applies to volumes, not --particles");
    if (o.index == "none" && !o.volume_input())
        throw std::invalid_argument("--index none renders volumes only (the reference marcher); particles need --index bih");
    if (o.kd_index() && !o.volume_input())
        throw std::invalid_argument("--index " + o.index + " renders volumes only; particles need --index bih");
    if (o.ikd_index() && !o.volume_input())
        throw std::invalid_argument("--index " + o.index + " renders volumes only; particles need --index bih");
    if (o.index == "kd" && o.volume_input())
        throw std::invalid_argument("--index kd renders particles (the element kd-tree); volumes use --index kd-vidal or kd-binned");
    if (o.animate > 0 && o.volume_input())
        throw std::invalid_argument("--animate moves particles (--index bih, kd or octree), not volumes");
    if (o.order == "leaf" && o.particle_kd() && o.backend == "vulkan") throw std::invalid_argument(leaf_kd_host_only);
    if (o.particle_octree())
        for (const char* opt : {"--brick", "--lod-pixels", "--cut-nodes", "--max-tf-error"})
            if (given(app, opt))
                throw std::invalid_argument(std::string(opt) + " applies to the bricked octree of volumes, not to particles");
    if (o.volume_input() && given(app, "--order"))
        throw std::invalid_argument("--order exact|leaf orders particles, not volumes");
    if (!o.octree_index())
        for (const char* opt : {"--brick", "--lod-pixels", "--cut-nodes", "--max-tf-error"})
            if (given(app, opt)) throw std::invalid_argument(std::string(opt) + " needs --index octree");
    if (given(app, "--max-tf-error") && !given(app, "--lod-pixels"))
        throw std::invalid_argument("--max-tf-error refines the view's cut: it needs --lod-pixels");
}

/// The volume options against the index, the input and each other; sets what they imply (the
/// frames of out-of-core runs, the mode of implicit-kd, dda and octree).
void check_volume(Options& o, const CLI::App& app) {
    bool ooc_given = false;
    for (const char* opt : {"--memory-budget", "--device-budget", "--frames", "--frames-out", "--orbit", "--feedback"})
        ooc_given = ooc_given || given(app, opt);
    if (ooc_given && !(o.octree_index() && o.volume_input()))
        throw std::invalid_argument("--memory-budget, --device-budget, --frames, --frames-out, --orbit and --feedback need "
                                    "--index octree and a volume (out-of-core rendering)");
    if (ooc_given && o.frames == 0) o.frames = 32;
    bool store = is_directory_with(o.volume, "data.mdb");
    if (o.octree_index() && o.volume_input() && o.frames == 0 && store) o.frames = 32;
    if (store)
        for (const char* opt : {"--brick", "--resample"})
            if (given(app, opt))
                throw std::invalid_argument(std::string(opt) + " does not apply to a brick store (its bricks are built)");
    if (!o.octree_index() && store)
        throw std::invalid_argument("--volume " + o.volume + " is a brick store: it renders with --index octree");
    if (o.frames > 0 && given(app, "--max-tf-error"))
        throw std::invalid_argument("--max-tf-error: the out-of-core octree refines by projection only (its cut is the "
                                    "loader's; the deviation tables need every brick)");
    if (o.octree_index() && o.dvr == "multi")
        throw std::invalid_argument("--dvr multi is BIH-DVR's; --index octree samples the marcher's lattice");
    if (o.ikd_index() && o.mode == "dvr")
        throw std::invalid_argument("--index " + o.index + " renders isosurfaces (--mode iso), not --mode dvr");
    if (o.ikd_index()) o.mode = "iso";
    if (given(app, "--packets") && !(o.index == "implicit-kd" && o.backend == "cpu"))
        throw std::invalid_argument("--packets: packets walk the implicit kd-tree on the host (--index implicit-kd "
                                    "--backend cpu)");
    if (o.ikd_index() && o.grid_format == "sparse")
        throw std::invalid_argument("--grid sparse: the implicit kd-tree and the DDA read dense grids (--grid native or float32)");
    if (o.isos.size() > 1 && !o.ikd_index())
        throw std::invalid_argument("several --iso values need --index implicit-kd or dda");
    if (o.octree_index() && o.volume_input() && o.mode.empty()) o.mode = "dvr";
    if (o.kd_index() && o.mode == "iso")
        throw std::invalid_argument("--index " + o.index + " renders --mode dvr only (the marcher with empty-space skipping)");
    if (o.range.mode != sylva::volume::ValueRange::Mode::Auto && (!o.volume_input() || o.procedural_volume()))
        throw std::invalid_argument("--range applies to volume files; the procedural volumes are densities in [0, 1] already");
    if (!o.kd_index() && (!o.boxes.empty() || !o.tf_sequence.empty()))
        throw std::invalid_argument("--boxes and --tf-sequence need a kd-tree: --index kd-vidal or kd-binned");
}

}  // namespace

std::string usage() {
    Options o;
    return make_app(o)->help();
}

Options parse(int argc, char** argv) {
    Options o;
    std::unique_ptr<CLI::App> app = make_app(o);
    try {
        app->parse(argc, argv);
    } catch (const CLI::ArgumentMismatch& e) {  // "--index: 1 required INDEX missing"
        std::string what = e.what();
        std::size_t colon = what.find(':');
        bool missing =
            colon != std::string::npos && what.size() > 8 && what.compare(what.size() - 8, 8, " missing") == 0;
        throw std::invalid_argument(missing ? what.substr(0, colon) + " needs a value" : what);
    } catch (const CLI::ParseError& e) {  // help is handled by main before the parse
        throw std::invalid_argument(e.what());
    }
    std::vector<std::string> extras = app->remaining();
    if (!extras.empty()) throw std::invalid_argument("unknown option '" + extras.front() + "'");
    o.count_given = given(*app, "--count");
    o.iso = o.isos.front();
    check_input(o, *app);
    check_volume(o, *app);
    return o;
}

}  // namespace sylva_render
