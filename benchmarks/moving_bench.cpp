// sylva-moving-bench: moving spheres (issue 14, item 5): the BIH, the element kd-tree and the
// element octree, each by refit and by rebuild, beside Embree's refit and rebuild on the same
// moving spheres (the workload, the entrants and the table: moving.hpp; sylva-bench runs the
// same as its case "moving"). Exit status 1 when a first hit disagrees with brute force.
//
//   sylva-moving-bench [--count N] [--frames F] [--rays R] [--threads T] [--json FILE] [--quick]
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>

#include <sylva/core/executor.hpp>

#include "bench.hpp"
#include "moving.hpp"

namespace {

struct Args {
    bench::MovingArgs moving;
    std::size_t threads = 0;
    std::string json;
};

Args parse(int argc, char** argv) {
    Args a;
    for (int i = 1; i < argc; ++i) {
        std::string s = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw std::invalid_argument(s + " needs a value");
            return argv[++i];
        };
        auto number = [&](double lo, double hi) {
            std::string v = value();
            char* end = nullptr;
            double x = std::strtod(v.c_str(), &end);
            if (v.empty() || *end || !(x >= lo && x <= hi)) throw std::invalid_argument(s + ": '" + v + "' is out of range");
            return static_cast<std::size_t>(x);
        };
        if (s == "--count") a.moving.count = number(1, 1e8);
        else if (s == "--frames") a.moving.frames = number(2, 1000);
        else if (s == "--rays") a.moving.rays = number(1, 1e8);
        else if (s == "--threads") a.threads = number(0, 1024);
        else if (s == "--json") a.json = value();
        else if (s == "--quick") a.moving.count = 10000, a.moving.frames = 3, a.moving.rays = 10000;
        else throw std::invalid_argument("unknown option '" + s + "'");
    }
    return a;
}

}  // namespace

int main(int argc, char** argv) try {
    Args a = parse(argc, argv);
    sylva::ThreadPool pool(a.threads);
    bench::Report report;
    bench::MovingResult r = bench::run_moving(a.moving, pool, report, "sylva-moving-bench");
    if (!a.json.empty()) report.write_json(a.json);
    return r.mismatches ? 1 : 0;
} catch (const std::exception& e) {
    std::cerr << "sylva-moving-bench: " << e.what() << "\n";
    return 2;
}
