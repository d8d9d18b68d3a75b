#include "options.hpp"

#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace sylva_render {

const char* usage() {
    return "usage: sylva-render [--particles FILE | --volume FILE|procedural[:ml|nbody]]\n"
           "                    [--index bih|kd-vidal|kd-binned|implicit-kd|dda|octree|none]\n"
           "                    [--backend cpu|vulkan] [--size WxH] -o OUT.png|OUT.exr [--stats-json FILE]\n"
           "                    [--heatmap FILE] [--view X,Y,Z] [--threads T] [--quiet]\n"
           "particles:          [--count N] [--radius-factor F] [--opacity A] [--alpha-stop A]\n"
           "                    [--payload inline|range] [--nodes fixed16|float32] [--layout chunks|preorder]\n"
           "                    [--chunk-depth D] [--empty-children trim-both|infinite]\n"
           "volumes:            [--mode dvr|iso] [--dvr single|multi] [--tf FILE | --tf-preset ct|ramp]\n"
           "                    [--range auto|type|LO,HI] [--threshold D] [--resample F] [--spacing X,Y,Z]\n"
           "                    [--border clamp|zero] [--grid native|float32]\n"
           "                    [--lod-density F] [--lod-stddev F] [--lod-depth N] [--iso V[,V2,...]]\n"
           "                    [--iso-cull on|off] [--steps N] [--shading] [--opacity A] [--alpha-stop A]\n"
           "kd-trees (volumes): [--kd shallow|deep] [--kd-classify alpha|threshold] [--boxes FILE]\n"
           "                    [--tf-sequence TF1,TF2,...]\n"
           "isosurfaces:        [--index implicit-kd|dda] [--iso V1[,V2,V3,V4]] [--ikd-bricks N]\n"
           "octree (volumes):   [--index octree] [--brick 16|32] [--lod-pixels P] [--cut-nodes N] [--mode dvr|iso]\n"
           "octree (particles): --particles FILE --index octree, or --count N --index octree (the galaxy)\n"
           "kd-tree (particles): --index kd (the element kd-tree: the octree's exact image)\n"
           "moving particles:   [--animate N] [--update refit|rebuild] (--index bih|kd|octree, cpu or vulkan;\n"
           "                    vulkan: one context and kernel for all frames, each uploads its encoding and\n"
           "                    records; --order leaf --index kd: cpu only)\n"
           "particle order:     [--order exact|leaf] (exact, the default: bih, kd and octree through the generic\n"
           "                    element kernel, the same image; leaf: each index's own integrator, the BIH's per-leaf sort)\n"
           "out of core:        [--index octree] [--memory-budget SIZE] [--device-budget SIZE] [--frames N]\n"
           "                    [--frames-out DIR] [--orbit] [--feedback on|off]; --volume STORE (a brick\n"
           "                    store directory made by sylva-store build) always renders out of core\n"
           "                    (32 frames unless --frames; --brick is the store's)\n"
           "timing (volumes):   [--repeat N] renders N frames and reports the fastest and the median\n"
           "                    (warm caches, pipelines compiled; JSON ms_min, ms_median, frame_ms)\n"
           "camera (volumes):   [--camera pinhole|ortho] pinhole (default) or orthographic rays framing\n"
           "                    the volume from --view (ortho: a view rectangle as high as the volume's\n"
           "                    bounding sphere, rays along the view direction)\n"
           "--index kd-vidal|kd-binned renders the reference marcher with empty-space skipping by a\n"
           "kd-tree (Vidal et al.; Zellmann et al.): the same image, fewer samples.\n"
           "--index implicit-kd renders exact isosurfaces of up to 4 --iso values over Wald et al.'s\n"
           "implicit min/max kd-tree (--index dda: every cell, the reference; the same image). One\n"
           "isovalue is opaque; with several, all but the last are translucent.\n"
           "--index octree renders a volume's DVR or the first hit of one --iso value through Gobbetti\n"
           "et al.'s bricked octree; without --lod-pixels the full-resolution cut (the marcher's image),\n"
           "with it a cut refined while a node's voxels project larger than P pixels, within --cut-nodes\n"
           "nodes.\n"
           "With --particles (or --count and no input: the galaxy) --index octree renders the particles\n"
           "through the element octree, in exact depth order, on either backend.\n"
           "With no input it renders a procedural galaxy of --count particles (default 1,000,000);\n"
           "with --mode, or --index octree without --count, and no input, a procedural volume.\n"
           "Volume files: NAME_XxYxZ_TYPE.raw, .nrrd, .nhdr.\n"
           "--range picks the raw values that map to density 0 and 1, which the threshold, the transfer\n"
           "function, --iso and the LoD read: auto (default) = the file's min/max fields, else the data's\n"
           "min/max; type = 0..255 / 0..65535; LO,HI as given.\n"
           "SYLVA_VULKAN_DEVICE=auto|cpu|gpu|INDEX|NAME picks the Vulkan device.\n";
}

namespace {
double number(const std::string& opt, const std::string& v, double lo, double hi) {
    char* end = nullptr;
    double x = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || !(x >= lo && x <= hi))
        throw std::invalid_argument(opt + ": '" + v + "' is not a number in [" + std::to_string(lo) + ", " +
                                    std::to_string(hi) + "]");
    return x;
}
std::string one_of(const std::string& opt, const std::string& v, std::initializer_list<const char*> allowed) {
    for (const char* a : allowed)
        if (v == a) return v;
    std::string list;
    for (const char* a : allowed) list += std::string(list.empty() ? "" : "|") + a;
    throw std::invalid_argument(opt + ": '" + v + "' is not one of " + list);
}
void parse_size(const std::string& v, Options& o) {
    auto x = v.find('x');
    if (x == std::string::npos) throw std::invalid_argument("--size: '" + v + "' is not WxH");
    o.width = static_cast<std::uint32_t>(number("--size", v.substr(0, x), 1, 16384));
    o.height = static_cast<std::uint32_t>(number("--size", v.substr(x + 1), 1, 16384));
}
std::vector<float> parse_vec3(const std::string& opt, const std::string& v) {
    std::vector<float> out;
    std::stringstream ss(v);
    for (std::string part; std::getline(ss, part, ',');) out.push_back(static_cast<float>(number(opt, part, -1e6, 1e6)));
    if (out.size() != 3) throw std::invalid_argument(opt + ": '" + v + "' is not X,Y,Z");
    return out;
}
std::vector<std::string> parse_list(const std::string& opt, const std::string& v) {
    std::vector<std::string> out;
    std::stringstream ss(v);
    for (std::string part; std::getline(ss, part, ',');) {
        if (part.empty()) throw std::invalid_argument(opt + ": '" + v + "' has an empty entry");
        out.push_back(part);
    }
    if (out.empty()) throw std::invalid_argument(opt + " needs at least one file");
    return out;
}
std::vector<float> parse_isos(const std::string& v) {
    std::vector<float> out;
    std::stringstream ss(v);
    for (std::string part; std::getline(ss, part, ',');) out.push_back(static_cast<float>(number("--iso", part, 0, 1)));
    if (out.empty() || out.size() > 4) throw std::invalid_argument("--iso: '" + v + "' is not 1 to 4 values V1,V2,...");
    return out;
}
std::size_t parse_bytes(const std::string& opt, const std::string& v) {
    std::string digits = v;
    double scale = 1.0;
    if (!v.empty()) {
        char u = static_cast<char>(std::toupper(static_cast<unsigned char>(v.back())));
        if (u == 'K' || u == 'M' || u == 'G') {
            scale = u == 'K' ? 1024.0 : u == 'M' ? 1048576.0 : 1073741824.0;
            digits.pop_back();
        }
    }
    double x = number(opt, digits, 1, 1e15) * scale;
    if (x > 1e15) throw std::invalid_argument(opt + ": '" + v + "' is too large");
    return static_cast<std::size_t>(x);
}
sylva::volume::ValueRange parse_range(const std::string& v) {
    try {
        return sylva::volume::ValueRange::parse(v);
    } catch (const std::exception& e) {
        throw std::invalid_argument(std::string("--range: ") + e.what());
    }
}
bool is_directory_with(const std::string& dir, const char* file) {
    std::error_code ec;
    return !dir.empty() && std::filesystem::is_directory(dir, ec) && std::filesystem::exists(std::filesystem::path(dir) / file, ec);
}
}  // namespace

Options parse(int argc, char** argv) {
    Options o;
    bool ooc_given = false;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
            return argv[++i];
        };
        if (a == "--particles") o.particles = value();
        else if (a == "--volume") o.volume = value();
        else if (a == "--index") o.index = one_of(a, value(), {"bih", "kd", "kd-vidal", "kd-binned", "implicit-kd", "dda", "octree", "none"});
        else if (a == "--animate") o.animate = static_cast<std::uint32_t>(number(a, value(), 1, 100000));
        else if (a == "--update") o.update = one_of(a, value(), {"refit", "rebuild"});
        else if (a == "--order") o.order = one_of(a, value(), {"exact", "leaf"});
        else if (a == "--brick") o.brick = static_cast<std::uint32_t>(std::stoul(one_of(a, value(), {"16", "32"})));
        else if (a == "--lod-pixels") o.lod_pixels = static_cast<float>(number(a, value(), 1e-3, 1e4));
        else if (a == "--cut-nodes") o.cut_nodes = static_cast<std::uint32_t>(number(a, value(), 1, 4294967295.0));
        else if (a == "--kd") o.kd = one_of(a, value(), {"shallow", "deep"});
        else if (a == "--kd-classify") o.kd_classify = one_of(a, value(), {"alpha", "threshold"});
        else if (a == "--boxes") o.boxes = value();
        else if (a == "--tf-sequence") o.tf_sequence = parse_list(a, value());
        else if (a == "--repeat") o.repeat = static_cast<std::uint32_t>(number(a, value(), 1, 1000));
        else if (a == "--memory-budget") o.memory_budget = parse_bytes(a, value()), ooc_given = true;
        else if (a == "--device-budget") o.device_budget = parse_bytes(a, value()), ooc_given = true;
        else if (a == "--frames") o.frames = static_cast<std::uint32_t>(number(a, value(), 1, 100000)), ooc_given = true;
        else if (a == "--frames-out") o.frames_out = value(), ooc_given = true;
        else if (a == "--orbit") o.orbit = true, ooc_given = true;
        else if (a == "--feedback") o.feedback = one_of(a, value(), {"on", "off"}) == "on", ooc_given = true;
        else if (a == "--mode") o.mode = one_of(a, value(), {"dvr", "iso"});
        else if (a == "--dvr") o.dvr = one_of(a, value(), {"single", "multi"});
        else if (a == "--tf") o.tf = value();
        else if (a == "--tf-preset") o.tf_preset = one_of(a, value(), {"ct", "ramp"});
        else if (a == "--threshold") o.threshold = static_cast<float>(number(a, value(), 0, 1));
        else if (a == "--border") o.border = one_of(a, value(), {"clamp", "zero"});
        else if (a == "--grid") o.grid_format = one_of(a, value(), {"native", "float32"});
        else if (a == "--resample") o.resample = static_cast<float>(number(a, value(), 0.1, 8));
        else if (a == "--spacing") o.spacing = parse_vec3(a, value());
        else if (a == "--range") o.range = parse_range(value());
        else if (a == "--lod-density") o.lod_density = static_cast<float>(number(a, value(), 0, 1));
        else if (a == "--lod-stddev") o.lod_stddev = static_cast<float>(number(a, value(), 0, 1));
        else if (a == "--lod-depth") o.lod_depth = static_cast<std::uint32_t>(number(a, value(), 0, 64));
        else if (a == "--iso") o.isos = parse_isos(value()), o.iso = o.isos.front();
        else if (a == "--ikd-bricks") o.ikd_bricks = static_cast<std::uint32_t>(number(a, value(), 0, 12));
        else if (a == "--iso-cull") o.iso_cull = one_of(a, value(), {"on", "off"}) == "on";
        else if (a == "--steps") o.steps = static_cast<std::uint32_t>(number(a, value(), 1, 1 << 16));
        else if (a == "--shading") o.shading = true;
        else if (a == "--backend") o.backend = one_of(a, value(), {"cpu", "vulkan"});
        else if (a == "--camera") o.camera = one_of(a, value(), {"pinhole", "ortho"});
        else if (a == "--size") parse_size(value(), o);
        else if (a == "-o" || a == "--output") o.output = value();
        else if (a == "--stats-json") o.stats_json = value();
        else if (a == "--heatmap") o.heatmap = value();
        else if (a == "--count") o.count = static_cast<std::size_t>(number(a, value(), 1, 1e8)), o.count_given = true;
        else if (a == "--radius-factor") o.radius_factor = static_cast<float>(number(a, value(), 1e-3, 1e3));
        else if (a == "--opacity") o.opacity = static_cast<float>(number(a, value(), 0, 1));
        else if (a == "--alpha-stop") o.alpha_stop = static_cast<float>(number(a, value(), 0, 2));
        else if (a == "--payload") o.payload = one_of(a, value(), {"inline", "range"});
        else if (a == "--nodes") o.nodes = one_of(a, value(), {"fixed16", "float32"});
        else if (a == "--layout") o.layout = one_of(a, value(), {"chunks", "preorder"});
        else if (a == "--chunk-depth") o.chunk_depth = static_cast<std::uint32_t>(number(a, value(), 0, 15));
        else if (a == "--empty-children") o.empty_children = one_of(a, value(), {"trim-both", "infinite"});
        else if (a == "--threads") o.threads = static_cast<std::uint32_t>(number(a, value(), 0, 1024));
        else if (a == "--view") o.view = parse_vec3(a, value());
        else if (a == "--quiet") o.quiet = true;
        else throw std::invalid_argument("unknown option '" + a + "'");
    }
    if (o.output.empty()) throw std::invalid_argument("-o OUT.png is required");
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
    if (o.particle_octree()) {
        for (const char* opt : {"--brick", "--lod-pixels", "--cut-nodes"})
            for (int i = 1; i < argc; ++i)
                if (std::string(argv[i]) == opt)
                    throw std::invalid_argument(std::string(opt) + " applies to the bricked octree of volumes, not to particles");
    }
    if (o.volume_input())
        for (int i = 1; i < argc; ++i)
            if (std::string(argv[i]) == "--order")
                throw std::invalid_argument("--order exact|leaf orders particles, not volumes");
    if (!o.octree_index()) {
        for (const char* opt : {"--brick", "--lod-pixels", "--cut-nodes"})
            for (int i = 1; i < argc; ++i)
                if (std::string(argv[i]) == opt) throw std::invalid_argument(std::string(opt) + " needs --index octree");
    }
    if (ooc_given && !(o.octree_index() && o.volume_input()))
        throw std::invalid_argument("--memory-budget, --device-budget, --frames, --frames-out, --orbit and --feedback need "
                                    "--index octree and a volume (out-of-core rendering)");
    if (ooc_given && o.frames == 0) o.frames = 32;
    if (o.octree_index() && o.volume_input() && o.frames == 0 && is_directory_with(o.volume, "data.mdb")) o.frames = 32;
    if (is_directory_with(o.volume, "data.mdb"))
        for (int i = 1; i < argc; ++i)
            if (std::string(argv[i]) == "--brick" || std::string(argv[i]) == "--resample")
                throw std::invalid_argument(std::string(argv[i]) + " does not apply to a brick store (its bricks are built)");
    if (!o.octree_index() && is_directory_with(o.volume, "data.mdb"))
        throw std::invalid_argument("--volume " + o.volume + " is a brick store: it renders with --index octree");
    if (o.octree_index() && o.dvr == "multi")
        throw std::invalid_argument("--dvr multi is BIH-DVR's; --index octree samples the marcher's lattice");
    if (o.ikd_index() && o.mode == "dvr")
        throw std::invalid_argument("--index " + o.index + " renders isosurfaces (--mode iso), not --mode dvr");
    if (o.ikd_index()) o.mode = "iso";
    if (o.camera == "ortho" && (!o.volume_input() || o.out_of_core()))
        throw std::invalid_argument("--camera ortho renders in-core volumes (not particles or out-of-core octrees)");
    if (o.camera == "ortho" && !o.boxes.empty())
        throw std::invalid_argument("--boxes projects with the pinhole camera; drop it with --camera ortho");
    if (o.isos.size() > 1 && !o.ikd_index())
        throw std::invalid_argument("several --iso values need --index implicit-kd or dda");
    if (o.octree_index() && o.volume_input() && o.mode.empty()) o.mode = "dvr";
    if (o.kd_index() && o.mode == "iso")
        throw std::invalid_argument("--index " + o.index + " renders --mode dvr only (the marcher with empty-space skipping)");
    if (o.range.mode != sylva::volume::ValueRange::Mode::Auto && (!o.volume_input() || o.procedural_volume()))
        throw std::invalid_argument("--range applies to volume files; the procedural volumes are densities in [0, 1] already");
    if (!o.kd_index() && (!o.boxes.empty() || !o.tf_sequence.empty()))
        throw std::invalid_argument("--boxes and --tf-sequence need a kd-tree: --index kd-vidal or kd-binned");
    return o;
}

}  // namespace sylva_render
