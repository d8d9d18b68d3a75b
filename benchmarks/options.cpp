// benchmarks/options.cpp -- sylva-bench's command line.
#include <cmath>
#include <cstdlib>
#include <string>
#include <string_view>

#include "bench.hpp"

namespace bench {

std::string usage() {
    return "usage: sylva-bench [--json FILE] [--sizes 1e4,1e5,1e6,1e7] [--rays N] [--runs K]\n"
           "                   [--threads T] [--pass-seconds S] [--cases LIST] [--frames F]\n"
           "                   [--quick] [--help]\n"
           "  --json FILE   write every measurement as one JSON array of\n"
           "                {case, impl, metric, value, unit} records\n"
           "  --sizes LIST  sphere counts, comma separated (default 1e4,1e5,1e6,1e7; --quick: 1e4,1e5)\n"
           "  --rays N      rays per traversal case (default 1e6; --quick: 1e5)\n"
           "  --runs K      timed runs per case, the median is reported (default 5; builds: at\n"
           "                least 9, as single builds at 1e4 take 1-2 ms)\n"
           "  --threads T   worker threads for sylva and embree (default: hardware concurrency)\n"
           "  --pass-seconds S\n"
           "                keeps the default run short: a traversal case traces only the first\n"
           "                rays sylva gets through in about S seconds (at least 1e4), and a build\n"
           "                or encode stops repeating once its runs took 10 S; the counts used\n"
           "                are reported (default 1, --quick: 0.2; 0 = all --rays, all --runs)\n"
           "  --cases LIST  what runs, comma separated, of build,first,all,clustered,moving (default:\n"
           "                build,first,all,clustered; builds and encodings run with any of these\n"
           "                four, the traversals need them). moving is not in the default (from 1e6\n"
           "                up it takes minutes a size): per size N, N uniform spheres move for\n"
           "                --frames frames and the BIH, kd-tree and element octree follow by refit\n"
           "                and by rebuild beside Embree's refit and rebuild (as sylva-moving-bench):\n"
           "                build, cold and steady update times, the first-hit rate over all --rays\n"
           "                after the motion (no --runs, no --pass-seconds cap), first hits checked\n"
           "                against brute force\n"
           "  --frames F    frames of the moving case, at least 2 (default 6; --quick: 3)\n"
           "  --quick       the small configuration (for smoke tests)\n"
           "Exit status: 0 on success, 1 on an error or when implementations disagree, 2 on bad usage.\n";
}

namespace {

/// A positive count written as an integer or in e-notation ("1e6", "2.5e5").
std::size_t parse_count(std::string_view option, const std::string& text) {
    char* end = nullptr;
    double v = std::strtod(text.c_str(), &end);
    bool ok = !text.empty() && end == text.c_str() + text.size() && std::isfinite(v) && v >= 1.0 && v <= 4e9 &&
              v == std::floor(v);
    if (!ok) throw UsageError{std::string(option) + ": '" + text + "' is not a positive whole number"};
    return static_cast<std::size_t>(v);
}

std::vector<std::size_t> parse_sizes(const std::string& text) {
    std::vector<std::size_t> out;
    std::size_t start = 0;
    while (start <= text.size()) {
        std::size_t comma = text.find(',', start);
        if (comma == std::string::npos) comma = text.size();
        out.push_back(parse_count("--sizes", text.substr(start, comma - start)));
        start = comma + 1;
    }
    return out;
}

void parse_cases(Options& o, const std::string& text) {
    o.run_build = o.run_first = o.run_all = o.run_clustered = o.run_moving = false;
    std::size_t start = 0;
    while (start <= text.size()) {
        std::size_t comma = text.find(',', start);
        if (comma == std::string::npos) comma = text.size();
        std::string c = text.substr(start, comma - start);
        if (c == "moving") {
            o.run_moving = true;
        } else {
            if (c == "first") o.run_first = true;
            else if (c == "all") o.run_all = true;
            else if (c == "clustered") o.run_clustered = true;
            else if (c != "build")
                throw UsageError{"--cases: '" + c + "' is not one of build, first, all, clustered, moving"};
            o.run_build = true;
        }
        start = comma + 1;
    }
}

double parse_seconds(const std::string& text) {
    char* end = nullptr;
    double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v) || v < 0.0)
        throw UsageError{"--pass-seconds: '" + text + "' is not a number of seconds >= 0"};
    return v;
}

std::size_t parse_frames(const std::string& text) {
    std::size_t f = parse_count("--frames", text);
    if (f < 2 || f > 1000) throw UsageError{"--frames: '" + text + "' is not in 2..1000"};
    return f;
}

void apply_defaults(Options& o, bool sizes_given, bool rays_given) {
    if (o.pass_seconds < 0.0) o.pass_seconds = o.quick ? 0.2 : 1.0;
    if (o.frames == 0) o.frames = o.quick ? 3 : 6;
    if (!sizes_given)
        o.sizes = o.quick ? std::vector<std::size_t>{10000, 100000}
                          : std::vector<std::size_t>{10000, 100000, 1000000, 10000000};
    if (!rays_given) o.rays = o.quick ? 100000 : 1000000;
}

}  // namespace

Options parse_options(int argc, char** argv) {
    Options o;
    bool sizes_given = false, rays_given = false;
    for (int i = 1; i < argc; ++i) {
        std::string_view arg = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw UsageError{std::string(arg) + " needs a value"};
            return argv[++i];
        };
        if (arg == "--json") {
            o.json = value();
            if (o.json.empty()) throw UsageError{"--json: empty file name"};
        } else if (arg == "--sizes") {
            o.sizes = parse_sizes(value());
            sizes_given = true;
        } else if (arg == "--rays") {
            o.rays = parse_count(arg, value());
            rays_given = true;
        } else if (arg == "--runs") {
            o.runs = parse_count(arg, value());
        } else if (arg == "--threads") {
            o.threads = parse_count(arg, value());
        } else if (arg == "--pass-seconds") {
            o.pass_seconds = parse_seconds(value());
        } else if (arg == "--frames") {
            o.frames = parse_frames(value());
        } else if (arg == "--cases") {
            parse_cases(o, value());
        } else if (arg == "--quick") {
            o.quick = true;
        } else if (arg == "--help" || arg == "-h") {
            o.help = true;
        } else {
            throw UsageError{"unknown option '" + std::string(arg) + "'"};
        }
    }
    apply_defaults(o, sizes_given, rays_given);
    return o;
}

}  // namespace bench
