// benchmarks/options.cpp -- sylva-bench's command line (CLI11, benchmarks/cli.hpp).
#include <cmath>
#include <string>
#include <vector>

#include "bench.hpp"
#include "cli.hpp"

namespace bench {

namespace {

constexpr double kMaxCount = 4e9;  // sizes, rays, runs and threads: whole numbers in 1..4e9

void add_options(CLI::App& app, Options& o, std::vector<std::string>& cases) {
    app.option_defaults()->take_last();  // an option given twice: the last value counts
    app.add_option("--json", o.json, "write every measurement as one JSON array of {case, impl, metric, value, unit} records")
        ->type_name("FILE")
        ->check(bench_cli::non_empty());
    app.add_option("--sizes", o.sizes, "sphere counts, comma separated (--quick: 1e4,1e5)")
        ->type_name("LIST")
        ->delimiter(',')
        ->transform(bench_cli::count_in(1, kMaxCount))
        ->default_str("1e4,1e5,1e6,1e7");
    app.add_option("--rays", o.rays, "rays per traversal case (--quick: 1e5)")
        ->type_name("N")
        ->transform(bench_cli::count_in(1, kMaxCount))
        ->default_str("1e6");
    app.add_option("--runs", o.runs, "timed runs per case, the median is reported (builds: at least 9, below)")
        ->type_name("K")
        ->transform(bench_cli::count_in(1, kMaxCount))
        ->capture_default_str();
    app.add_option("--threads", o.threads, "worker threads for sylva and embree (default: hardware concurrency)")
        ->type_name("T")
        ->transform(bench_cli::count_in(1, kMaxCount));
    app.add_option("--pass-seconds", o.pass_seconds, "time cap of the slow cases, 0 = none (below; --quick: 0.2)")
        ->type_name("S")
        ->default_str("1")
        ->check(CLI::Validator(
            [](std::string& v) {
                double x = 0.0;
                bool ok = CLI::detail::lexical_cast(v, x) && std::isfinite(x) && x >= 0.0;
                return ok ? std::string() : "'" + v + "' is not a number of seconds >= 0";
            },
            "SECONDS >= 0"));
    app.add_option("--cases", cases, "what runs, comma separated (below)")
        ->type_name("LIST")
        ->delimiter(',')
        ->default_str("build,first,all,clustered")
        ->check(CLI::IsMember({"build", "first", "all", "clustered", "moving"}));
    app.add_option("--frames", o.frames, "frames of the moving case, at least 2 (--quick: 3)")
        ->type_name("F")
        ->transform(bench_cli::count_in(2, 1000))
        ->capture_default_str();
    app.add_option("--cold-runs", o.cold_runs,
                   "fresh processes per builder and case, each timing one first build (cold memory); the median "
                   "is reported beside the steady state, 0 = none (--quick: 1)")
        ->type_name("K")
        ->transform(bench_cli::count_in(0, 100))
        ->capture_default_str();
    app.add_flag("--load", o.load,
                 "run every case a second time beside a busy process on every core (cases named load/...)");
    // The helper processes (processes.hpp): not for users, so not in --help.
    app.add_option("--cold-child", o.cold_child)
        ->group("")
        ->check(CLI::IsMember({"default", "leaf4", "query", "wide", "octree", "kd", "embree"}));
    app.add_option("--cold-distribution", o.cold_distribution)->group("")->check(CLI::IsMember({"uniform", "clustered"}));
    app.add_option("--busy-child", o.busy_child)->group("")->check(CLI::PositiveNumber);
    app.add_flag("--quick", o.quick,
                 "the small configuration (for smoke tests): sizes 1e4,1e5, 1e5 rays, pass budget 0.2 s, 3 frames, "
                 "unless given");
}

const char* kFooter =
    "--pass-seconds S keeps the default run short: a traversal case traces only the first rays sylva\n"
    "gets through in about S seconds (at least 1e4), and a build or encode stops repeating once its\n"
    "runs took 10 S; the counts used are reported (0 = all --rays, all --runs). Builds run at least 9\n"
    "times (within that budget), as single builds at 1e4 take 1-2 ms.\n"
    "Cases (--cases): build, first, all, clustered, moving. Builds and encodings run with any of the\n"
    "first four (the traversals need them): first-hit and all-hits-in-order traversals, the clustered\n"
    "spheres (up to 1e6). moving is not in the default (from 1e6 up it takes minutes a size): per\n"
    "size N, N uniform spheres move for --frames frames and the BIH, kd-tree and element octree\n"
    "follow by refit and by rebuild beside Embree's refit and rebuild (as sylva-moving-bench):\n"
    "build, cold and steady update times, the first-hit rate over all --rays after the motion (no\n"
    "--runs, no --pass-seconds cap), first hits checked against brute force.\n"
    "Cold and steady state: each build case is also timed in --cold-runs fresh processes of this program,\n"
    "one first build each after a 64-sphere warm-up build (threads started, code loaded; the builder's\n"
    "memory untouched): build_cold_ms, the median. One untimed child of the default tree runs first in\n"
    "each case (cold_warmup_ms), so that no builder's child is the first after the parent's own work.\n"
    "build_ms, rays_per_s and the other medians are the steady state: the runs after the first in this\n"
    "process (rays_per_s_first_pass is the first; every pass writes into result arrays sized and filled\n"
    "before its clock starts). Every timed build, pass and frame starts 2 ms after the one before\n"
    "(untimed), when the threads that poll after their work (sylva's pool, TBB's workers) are asleep.\n"
    "--load runs every case again (named load/...) beside a busy process on every core that alternates\n"
    "integer work with passes over 8 MiB a thread; the ratios under load are in the same tables.\n"
    "Sizes, rays, runs and threads are whole numbers, also written as 1e6 or 2.5e5.\n"
    "Exit status: 0 on success, 1 on an error or when implementations disagree, 2 on bad usage.";

/// --quick's values for the options not given; the parts --cases names.
void apply(const CLI::App& app, Options& o, const std::vector<std::string>& cases) {
    auto unset = [&](const char* name) { return app.count(name) == 0; };
    if (o.quick) {
        if (unset("--sizes")) o.sizes = {10000, 100000};
        if (unset("--rays")) o.rays = 100000;
        if (unset("--pass-seconds")) o.pass_seconds = 0.2;
        if (unset("--frames")) o.frames = 3;
        if (unset("--cold-runs")) o.cold_runs = 1;
    }
    if (unset("--cases")) return;
    o.run_build = o.run_first = o.run_all = o.run_clustered = o.run_moving = false;
    for (const std::string& c : cases) {
        if (c == "moving") {
            o.run_moving = true;
            continue;
        }
        o.run_build = true;
        o.run_first = o.run_first || c == "first";
        o.run_all = o.run_all || c == "all";
        o.run_clustered = o.run_clustered || c == "clustered";
    }
}

}  // namespace

std::optional<int> parse_options(int argc, char** argv, Options& o) {
    CLI::App app(
        "sylva-bench: sylva's BIH, element octree and element kd-tree against Embree 3 on the same spheres and "
        "the same rays: builds, encodings, first-hit and all-hits traversals, moving spheres",
        "sylva-bench");
    app.footer(kFooter);
    std::vector<std::string> cases;
    add_options(app, o, cases);
    if (std::optional<int> status = bench_cli::parse(app, argc, argv)) return status;
    apply(app, o, cases);
    return std::nullopt;
}

}  // namespace bench
