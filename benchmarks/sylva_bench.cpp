// sylva-bench: sylva's BIH and element octree against Embree 3 on the same spheres and the same rays.
//
//   sylva-bench [--json FILE] [--sizes 1e4,1e5,1e6,1e7] [--rays N] [--runs K] [--threads T]
//               [--pass-seconds S] [--cases build,first,all,clustered,moving] [--frames F]
//               [--cold-runs K] [--load] [--quick]
//   (options.cpp; sylva-bench --help lists them)
//
// Cases (each time the median of --runs runs): BIH build and encode over N spheres (uniform,
// and clustered up to 1e6), first-hit and all-hits-in-order traversal (rays/s), and a
// streaming-read floor over the largest encoding. sylva runs in several configurations, each
// named in the case names and described under the tables and in the JSON ("config"): the
// paper's trimmed one-sphere leaves (fixed16, float32), 4 spheres a leaf (leaf4), and the
// query tree (bih::Config::for_queries(), elements in leaf order via bih::LeafRecords), and the
// element octree ("octree": octree::build_elements with its defaults, issue 12), and the element kd-tree ("kd": binned
// SAH, issue 14). --pass-seconds caps the rays and runs of the slow cases so that the default run
// stays near five minutes on two cores.
// Case "moving" (issue 14, item 5; only when named in --cases, as it takes minutes from 1e6 up):
// per size, the spheres move for --frames frames and the BIH, kd-tree and element octree follow by
// refit and by rebuild beside Embree's refit and rebuild (moving.hpp, as sylva-moving-bench); its
// first hits after the motion are checked against brute force (a mismatch fails the run).
// Cold and steady state (issue 15, item 2): every build is also timed as the first build of a
// fresh process (cold.cpp, --cold-runs of them, median: build_cold_ms); the other medians are
// the steady state, the runs after the first in this process. --load runs every case again
// beside a busy process on every core (processes.hpp; cases named load/...).
// Traversal results are cross-checked ray by ray against Embree (or, without it, the two node
// formats against each other); a disagreement that is not a grazed sphere or a tie, or more
// than 1 % disagreeing rays, fails the run (exit 1).
#include <algorithm>
#include <exception>
#include <fstream>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <sylva/core/executor.hpp>

#include "bench.hpp"
#include "cases.hpp"
#include "moving.hpp"
#include "processes.hpp"
#include "run_sylva.hpp"
#if SYLVA_BENCH_EMBREE
#include "run_embree.hpp"
#endif

namespace {

/// Clustered sets run up to this size (at 1e7 they would add two minutes for little news).
constexpr std::size_t kClusteredMax = 1000000;

/// The 1-minute load average (other work on the machine skews every number), or -1.
double load_average() {
    std::ifstream f("/proc/loadavg");
    double v = -1.0;
    f >> v;
    return f ? v : -1.0;
}

void print_header(const bench::Options& opt, std::size_t threads) {
    std::cout << "sylva-bench: " << threads << " threads, up to " << opt.runs << " runs per case (median), up to "
              << opt.rays << " rays, pass budget " << opt.pass_seconds << " s, load average " << load_average()
              << ", cold: " << opt.cold_runs << " fresh processes per build (quiet cases only)"
              << (opt.load ? ", every case again under load" : "")
              << ", sizes";
    for (std::size_t n : opt.sizes) std::cout << " " << bench::size_label(n);
    if (opt.run_moving) std::cout << ", moving: " << opt.frames << " frames" << (opt.run_build ? "" : " (moving only)");
#if SYLVA_BENCH_EMBREE
    std::cout << ", peer: embree " << RTC_VERSION_STRING << "\n";
#else
    std::cout << ", peer: none (built without Embree)\n";
#endif
}

/// The moving spheres at `n` (moving.hpp); a brute-force mismatch is a failure.
void run_moving_case(const bench::Options& opt, std::size_t n, sylva::ThreadPool& pool, bench::Report& report,
                     std::vector<std::string>& failures) {
    bench::MovingResult r = bench::run_moving({n, opt.frames, opt.rays}, pool, report, "sylva-bench");
    if (r.mismatches)
        failures.push_back("moving/" + bench::size_label(n) + "/uniform: " + std::to_string(r.mismatches) +
                           " first hits differ from brute force over " + std::to_string(r.sample) + " rays");
}

/// The uniform and (up to kClusteredMax) clustered cases of size n; `loaded`: under --load.
void run_cases(const bench::Context& c, std::size_t n, bool stream, bool loaded) {
    bench::run_case(c, n, bench::Distribution::Uniform, stream, loaded);
    if (c.opt.run_clustered && n <= kClusteredMax) bench::run_case(c, n, bench::Distribution::Clustered, false, loaded);
}

/// The cases of size n again beside a CompetingLoad (--load). Records the cores the load took
/// (its CPU seconds over the wall time); a load that took less than a tenth of a core did not
/// compete, and the run fails.
void run_loaded_cases(const bench::Context& c, std::size_t n) {
    bench::CompetingLoad load(c.pool.concurrency());
    auto t0 = bench::Clock::now();
    run_cases(c, n, false, true);
    double wall_s = bench::ms_since(t0) / 1000.0;
    double cpu_s = load.stop();
    double cores = cpu_s / std::max(wall_s, 1e-3);
    c.report.add("machine/load/" + bench::size_label(n), "machine", "load_busy_cores", std::max(cores, 0.0), "cores");
    if (cores < 0.1)
        c.failures.push_back("load/" + bench::size_label(n) + ": the competing load took " + std::to_string(cores) +
                             " cores (it did not run)");
}

int run(const bench::Options& opt) {
    if (!opt.json.empty() && !std::ofstream(opt.json, std::ios::app))
        throw std::runtime_error("cannot write '" + opt.json + "'");
    sylva::ThreadPool pool(opt.threads);
    print_header(opt, pool.concurrency());
    bench::Report report;
    if (opt.run_build) bench::describe_configs(report);
    report.add("machine", "machine", "threads", static_cast<double>(pool.concurrency()), "threads");
    report.add("machine", "machine", "load_average_start", load_average(), "processes");
    std::vector<std::string> failures;
    std::vector<sylva::Ray> rays = bench::make_rays(opt.rays, 0xB1A5u);
    bench::EmbreePeer* peer = nullptr;
#if SYLVA_BENCH_EMBREE
    bench::EmbreePeer embree(pool.concurrency());
    peer = &embree;
#endif
    bench::Context c{opt, pool, report, rays, peer, failures};
    if (opt.load) report.add("machine", "machine", "load_threads", static_cast<double>(pool.concurrency()), "threads");
    std::size_t largest = *std::max_element(opt.sizes.begin(), opt.sizes.end());
    for (std::size_t n : opt.sizes) {
        if (opt.run_build) {
            run_cases(c, n, n == largest, false);
            if (opt.load) run_loaded_cases(c, n);
        }
        if (opt.run_moving) run_moving_case(opt, n, pool, report, failures);
    }
    report.add("machine", "machine", "load_average_end", load_average(), "processes");
    report.print_table();
    if (opt.run_build) report.print_table(true);  // the summary: build and traversal throughput
    if (!opt.json.empty()) report.write_json(opt.json);
    for (const std::string& f : failures) std::cerr << "sylva-bench: FAILED: " << f << "\n";
    return failures.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    bench::Options opt;
    if (std::optional<int> status = bench::parse_options(argc, argv, opt)) return *status;
    try {
        if (opt.busy_child) return bench::busy_child_main(opt.busy_child, opt.threads ? opt.threads : 1);
        if (!opt.cold_child.empty()) return bench::cold_child_main(opt);
        return run(opt);
    } catch (const std::exception& e) {
        std::cerr << "sylva-bench: error: " << e.what() << "\n";
        return 1;
    }
}
