// sylva-moving-bench: moving spheres (issue 14, item 5): the BIH, the element kd-tree and the
// element octree, each by refit and by rebuild, beside Embree's refit and rebuild on the same
// moving spheres (the workload, the entrants and the table: moving.hpp; sylva-bench runs the
// same as its case "moving"). Exit status 1 when a first hit disagrees with brute force or on an
// error, 2 on bad usage.
//
//   sylva-moving-bench [--count N] [--frames F] [--rays R] [--threads T] [--json FILE] [--quick]
//   (CLI11: sylva-moving-bench --help lists them)
#include <exception>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <sylva/core/executor.hpp>

#include "bench.hpp"
#include "cli.hpp"
#include "moving.hpp"

namespace {

struct Args {
    bench::MovingArgs moving;
    std::size_t threads = 0;  ///< 0: hardware concurrency
    std::string json;
};

/// The command line, bound to `a`; `quick` for --quick, applied by apply_quick after parsing.
std::unique_ptr<CLI::App> make_app(Args& a, bool& quick) {
    auto app = std::make_unique<CLI::App>(
        "sylva-moving-bench: moving spheres: the BIH, the element kd-tree and the element octree, each by refit "
        "and by rebuild, beside Embree's refit and rebuild on the same spheres",
        "sylva-moving-bench");
    app->footer(
        "The spheres (sylva-bench's uniform workload) move for F frames; per frame every index follows by\n"
        "refit and, separately, by rebuild. Reported per index and mode: cold (frame 1) and steady (median\n"
        "of frames 2..F) update times, the initial build, and after the last frame the first-hit rate over\n"
        "R rays; every index's first hits are checked against brute force over a sample of rays.\n"
        "sylva-bench --cases moving runs the same. Counts are whole numbers, also written as 1e6.\n"
        "--quick: 1e4 spheres, 3 frames, 1e4 rays; options given beside it keep their values.\n"
        "Exit status: 0 on success, 1 on errors or when a first hit disagrees with brute force, 2 on bad usage.");
    app->option_defaults()->take_last();  // an option given twice: the last value counts
    app->add_option("--count", a.moving.count, "spheres")
        ->type_name("N")
        ->transform(bench_cli::count_in(1, 1e8))
        ->default_str("1e6");
    app->add_option("--frames", a.moving.frames, "frames of motion (cold: frame 1; steady: 2..F)")
        ->type_name("F")
        ->transform(bench_cli::count_in(2, 1000))
        ->capture_default_str();
    app->add_option("--rays", a.moving.rays, "rays of the first-hit rate after the last frame")
        ->type_name("R")
        ->transform(bench_cli::count_in(1, 1e8))
        ->default_str("2e5");
    app->add_option("--threads", a.threads, "worker threads, 0 = hardware concurrency")
        ->type_name("T")
        ->transform(bench_cli::count_in(0, 1024))
        ->capture_default_str();
    app->add_option("--json", a.json, "write every figure as a JSON array of {case, impl, metric, value, unit}")
        ->type_name("FILE");
    app->add_flag("--quick", quick, "the smoke configuration (below)");
    return app;
}

/// --quick's values for the options not given on the command line.
void apply_quick(const CLI::App& app, Args& a) {
    auto unset = [&](const char* name) { return app.count(name) == 0; };
    if (unset("--count")) a.moving.count = 10000;
    if (unset("--frames")) a.moving.frames = 3;
    if (unset("--rays")) a.moving.rays = 10000;
}

}  // namespace

int main(int argc, char** argv) {
    Args a;
    bool quick = false;
    std::unique_ptr<CLI::App> app = make_app(a, quick);
    if (std::optional<int> status = bench_cli::parse(*app, argc, argv)) return *status;
    if (quick) apply_quick(*app, a);
    try {
        sylva::ThreadPool pool(a.threads);
        bench::Report report;
        bench::MovingResult r = bench::run_moving(a.moving, pool, report, "sylva-moving-bench");
        if (!a.json.empty()) report.write_json(a.json);
        return r.mismatches ? 1 : 0;
    } catch (const std::exception& e) {
        std::cerr << "sylva-moving-bench: error: " << e.what() << "\n";
        return 1;
    }
}
