#include "options.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace sylva_store {

const char* usage() {
    return "usage: sylva-store build INPUT -o STORE [--brick 16|32] [--border 1|2] [--compress zstd|lz4|none]\n"
           "                   [--level N] [--memory BYTES] [--resume] [--resample K] [--range auto|type|LO,HI]\n"
           "                   [--spacing X,Y,Z] [--threads T] [--quiet]\n"
           "       sylva-store info STORE\n"
           "       sylva-store verify STORE\n"
           "INPUT: NAME_XxYxZ_TYPE.raw (read slice by slice), .nrrd/.nhdr (read whole), procedural:ml:N or\n"
           "procedural:ml:XxYxZ (Marschner-Lobb, generated slice by slice; procedural:ml = 128^3),\n"
           "procedural:nbody (192^3). --resample K upsamples trilinearly, slice by slice (the source is held).\n"
           "The store is an LMDB directory: the octree index (nodes, min/max, neighbours), every brick\n"
           "compressed with its XXH3 checksum, the build settings and a format version. The build never\n"
           "holds the volume: its memory stays under --memory (default 1G; K/M/G suffixes). A build that\n"
           "stops (kill, full disk) leaves an incomplete store; the same command with --resume finishes it.\n"
           "--level: zstd's level, 1 (default) to 19, or -1 to -5 for its fast modes.\n"
           "verify checks every brick's checksum: exit 1 and the bad brick keys when any fails or the store\n"
           "is incomplete.\n";
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
}  // namespace

std::uint64_t parse_bytes(const std::string& opt, const std::string& v) {
    if (v.empty()) throw std::invalid_argument(opt + " needs a size");
    double scale = 1.0;
    std::string num = v;
    char last = v.back();
    const std::string units = "KMGT";
    auto u = units.find(static_cast<char>(std::toupper(static_cast<unsigned char>(last))));
    if (u != std::string::npos) {
        scale = std::pow(1024.0, double(u + 1));
        num.pop_back();
    }
    double x = number(opt, num, 0, 1e15) * scale;
    if (!(x >= 1.0 && x < 1.8e19)) throw std::invalid_argument(opt + ": '" + v + "' is not a size in bytes");
    return static_cast<std::uint64_t>(x);
}

Options parse(int argc, char** argv) {
    Options o;
    if (argc < 2) throw std::invalid_argument("no command (build, info or verify)");
    o.command = one_of("command", argv[1], {"build", "info", "verify"});
    std::vector<std::string> positional;
    for (int i = 2; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
            return argv[++i];
        };
        if (a == "-o" || a == "--output") o.store = value();
        else if (a == "--brick") o.brick = static_cast<std::uint32_t>(std::stoul(one_of(a, value(), {"4", "8", "16", "32", "64"})));
        else if (a == "--border") o.border = static_cast<std::uint32_t>(std::stoul(one_of(a, value(), {"1", "2"})));
        else if (a == "--compress") o.codec = one_of(a, value(), {"zstd", "lz4", "none"});
        else if (a == "--level") {
            o.level = static_cast<int>(number(a, value(), -5, 19));
            if (o.level == 0) throw std::invalid_argument("--level: 0 is not a level (1..19, or -1..-5 for zstd's fast modes)");
        }
        else if (a == "--memory") o.memory = parse_bytes(a, value());
        else if (a == "--resume") o.resume = true;
        else if (a == "--resample") o.resample = static_cast<float>(number(a, value(), 0.1, 16));
        else if (a == "--range") {
            try {
                o.range = sylva::volume::ValueRange::parse(value());
            } catch (const std::exception& e) {
                throw std::invalid_argument(std::string("--range: ") + e.what());
            }
        } else if (a == "--spacing") {
            std::vector<float> s;
            std::stringstream ss(value());
            for (std::string part; std::getline(ss, part, ',');) s.push_back(static_cast<float>(number(a, part, 1e-6, 1e6)));
            if (s.size() != 3) throw std::invalid_argument("--spacing needs X,Y,Z");
            o.spacing = s;
        } else if (a == "--threads") o.threads = static_cast<std::uint32_t>(number(a, value(), 0, 1024));
        else if (a == "--quiet") o.quiet = true;
        else if (a == "--map-size") o.map_size = parse_bytes(a, value());
        else if (a == "--commit-bricks") o.commit_bricks = static_cast<std::uint64_t>(number(a, value(), 1, 1e9));
        else if (a == "-h" || a == "--help") throw std::invalid_argument("help");
        else if (!a.empty() && a[0] == '-') throw std::invalid_argument("unknown option '" + a + "'");
        else positional.push_back(a);
    }
    if (o.command == "build") {
        if (positional.size() != 1) throw std::invalid_argument("build needs one INPUT");
        o.input = positional[0];
        if (o.store.empty()) throw std::invalid_argument("build needs -o STORE");
    } else {
        if (positional.size() != 1 || !o.store.empty()) throw std::invalid_argument(o.command + " needs one STORE");
        o.store = positional[0];
    }
    bool procedural = o.input.rfind("procedural", 0) == 0;
    if (procedural && o.range.mode != sylva::volume::ValueRange::Mode::Auto)
        throw std::invalid_argument("--range applies to volume files; the procedural volumes are densities in [0, 1]");
    return o;
}

}  // namespace sylva_store
