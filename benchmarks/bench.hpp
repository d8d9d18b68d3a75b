// benchmarks/bench.hpp -- the pieces of sylva-bench: options, workloads, timing, records.
//
// Every case runs sylva and its peers on the same elements and the same rays in one process;
// each timed quantity is the median of Options::runs runs.
#ifndef SYLVA_BENCH_BENCH_HPP
#define SYLVA_BENCH_BENCH_HPP

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <sylva/core/ray.hpp>
#include <sylva/elements/sphere.hpp>

namespace bench {

// ---- command line ---------------------------------------------------------------------------

struct Options {
    std::string json;                       ///< --json FILE: where the records go ("" = nowhere)
    /// --sizes: element counts (default 1e4, 1e5, 1e6, 1e7; --quick: 1e4, 1e5)
    std::vector<std::size_t> sizes{10000, 100000, 1000000, 10000000};
    std::size_t rays = 1000000;             ///< --rays: rays per traversal case (--quick: 1e5)
    std::size_t runs = 5;                   ///< --runs: timed runs per case (median reported)
    std::size_t threads = 0;                ///< --threads: worker threads (0 = hardware)
    double pass_seconds = 1.0;              ///< --pass-seconds: time cap per pass (0 = none; --quick: 0.2)
    bool quick = false;                     ///< --quick: small sizes and fewer rays
    std::size_t frames = 6;                 ///< --frames: frames of the moving case, 2..1000 (--quick: 3)
    /// --cases: which parts run (build and encode run with any of build, first, all, clustered:
    /// the traversals need them); moving runs only when named
    bool run_build = true, run_first = true, run_all = true, run_clustered = true, run_moving = false;
    /// --cold-runs: fresh processes per builder and case that each time one first build (cold
    /// memory, issue 15 item 2); the median is reported; 0 = none (--quick: 1)
    std::size_t cold_runs = 3;
    bool load = false;  ///< --load: every case again beside a busy process on every core

    // Hidden options: this executable run as one of its helper processes (processes.hpp).
    std::string cold_child;                      ///< --cold-child IMPL: time one cold build, print it
    std::string cold_distribution = "uniform";   ///< --cold-distribution: the child's spheres
    long busy_child = 0;  ///< --busy-child PID: the competing load of --load, started by process PID

    /// Runs of each build: at least 9 (within the build budget), as one build at 10^4 spheres
    /// takes 1-2 ms and medians of 3 such builds scattered by +-30 % between runs.
    [[nodiscard]] std::size_t build_runs() const { return runs > 9 ? runs : 9; }
    /// Time cap of the repeated (interleaved) builds of one case: 20 passes of the slowest.
    [[nodiscard]] double build_budget_ms() const { return pass_seconds > 0.0 ? 20000.0 * pass_seconds : 0.0; }
    /// Time cap of the repeated runs of one encoder: 10 passes.
    [[nodiscard]] double encode_budget_ms() const { return pass_seconds > 0.0 ? 10000.0 * pass_seconds : 0.0; }
};

/// Parses argv into `o` (CLI11, options.cpp). Empty when the run goes on; else the exit status:
/// 0 after --help (printed on stdout), 2 after bad usage (reported on stderr).
std::optional<int> parse_options(int argc, char** argv, Options& o);

// ---- workloads ------------------------------------------------------------------------------

/// How sphere centres are spread over the unit cube.
enum class Distribution { Uniform, Clustered };
const char* name(Distribution d);

/// Spheres in [0, 1]^3 whose radii shrink with n^(-1/3), so a ray crosses a few to a few tens.
std::vector<sylva::Sphere> make_spheres(std::size_t n, Distribution d, std::uint32_t seed);
/// Rays from a sphere of radius 2 around the cube towards uniform points inside it.
std::vector<sylva::Ray> make_rays(std::size_t n, std::uint32_t seed);
/// "1e6" for powers of ten, the plain number otherwise.
std::string size_label(std::size_t n);
/// The seed of the sphere set of `n` spheres (the same in the parent and in the cold children).
inline std::uint32_t sphere_seed(std::size_t n) { return static_cast<std::uint32_t>(n) ^ 0x5EEDu; }

// ---- per-ray results, compared across implementations ---------------------------------------

inline constexpr std::uint32_t kNoHit = 0xFFFFFFFFu;

/// Order-independent fingerprint of a set of element ids (sum of mixed ids).
inline std::uint64_t mix_id(std::uint32_t id) {
    std::uint64_t z = id + 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/// A traversal pass's results. A race sizes them (prepare) before it starts the clock, so a
/// pass writes into arrays whose pages are already in use: the first pass in a process would
/// otherwise also time the first touch of 12 MB of result arrays per 10^6 rays (about 30 ms
/// on one thread here), which an entrant whose arrays the heap serves from pages it has
/// already touched does not pay.
struct FirstHits {
    std::vector<std::uint32_t> id;  ///< element index of the nearest hit, or kNoHit
    void prepare(std::size_t rays) { id.assign(rays, kNoHit); }
};
struct AllHits {
    std::vector<std::uint32_t> count;  ///< hits per ray
    std::vector<std::uint64_t> set;    ///< sum of mix_id over the ray's hits
    void prepare(std::size_t rays) {
        count.assign(rays, 0);
        set.assign(rays, 0);
    }
};
std::size_t disagreements(const FirstHits& a, const FirstHits& b);
std::size_t disagreements(const AllHits& a, const AllHits& b);

/// The ids one implementation finds along a ray (any order).
using HitList = std::function<std::vector<std::uint32_t>(const sylva::Ray&)>;
/// Disagreeing rays not explained by a grazed sphere or a tie, re-examined in double precision.
std::size_t unexplained(const FirstHits& got, const FirstHits& ref, const std::vector<sylva::Sphere>& spheres,
                        std::span<const sylva::Ray> rays);
std::size_t unexplained(const AllHits& got, const AllHits& ref, const std::vector<sylva::Sphere>& spheres,
                        std::span<const sylva::Ray> rays, const HitList& got_list, const HitList& ref_list);

// ---- timing ---------------------------------------------------------------------------------

using Clock = std::chrono::steady_clock;
inline double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
/// Median of the samples (mean of the middle two for an even count).
double median(std::vector<double> samples);
/// The steady-state samples: all but the first, which pays for first touches of memory and
/// caches in this process (when there is only one, that one).
inline std::vector<double> steady(std::vector<double> samples) {
    if (samples.size() > 1) samples.erase(samples.begin());
    return samples;
}

/// A rate: `count` things in `ms` milliseconds, per second.
inline double per_s(double count, double ms) { return count / (std::max(ms, 1e-6) / 1000.0); }

/// Waits 2 ms, untimed, before each timed call of a race: threads that poll after their last
/// task (sylva::ThreadPool's, for ThreadPool::kDefaultSpin; TBB's after an Embree commit, ~0.2 ms
/// of CPU in the first 250 us after it, measured with a throw-away probe) are asleep by then, so
/// that no timed call shares its cores with the tail of the call before it, whoever made it.
/// The calling thread waits busy, as an application's own single-threaded work would keep it:
/// after a sleep of the caller the kernel here often woke a pool's worker onto the caller's core,
/// and a 10^4-sphere build then ran on one core (README, "A pool that polls before it sleeps").
inline void settle() {
    const auto start = Clock::now();
    while (Clock::now() - start < std::chrono::milliseconds(2)) {
    }
}

/// Wall time of one call of f, in milliseconds.
template <class F>
double time_ms(F&& f) {
    auto t0 = Clock::now();
    f();
    return ms_since(t0);
}

/// Samples of `run` (which returns the milliseconds it measured): `runs` of them, or fewer
/// once they add up to `budget_ms` (0 = no budget); always at least one.
template <class F>
std::vector<double> samples(std::size_t runs, double budget_ms, F&& run) {
    std::vector<double> ms;
    double total = 0.0;
    for (std::size_t r = 0; r < runs; ++r) {
        settle();
        ms.push_back(run());
        total += ms.back();
        if (budget_ms > 0.0 && total >= budget_ms) break;
    }
    return ms;
}

// ---- records --------------------------------------------------------------------------------

/// One measured number. `peer` (not written to JSON) is the case the table compares it with;
/// `config` names the sylva configuration that produced it (written to JSON when set).
struct Record {
    std::string case_name;
    std::string impl;
    std::string metric;
    double value = 0.0;
    std::string unit;
    std::string peer;
    std::string config;
};

class Report {
public:
    void add(std::string case_name, std::string impl, std::string metric, double value, std::string unit,
             std::string peer = {}, std::string config = {});
    /// Describes a configuration name used in `config` fields (printed under the tables).
    void describe(const std::string& config, const std::string& text);
    [[nodiscard]] const std::vector<Record>& records() const { return records_; }
    /// Writes all records as one JSON array; throws std::runtime_error when the file fails.
    void write_json(const std::string& path) const;
    /// Prints the table: sylva beside embree, with the ratio sylva / embree; `summary`: only
    /// the throughput rows that have an embree peer.
    void print_table(bool summary = false) const;

private:
    [[nodiscard]] const Record* find(const std::string& case_name, const std::string& impl,
                                     const std::string& metric) const;
    /// True when a non-embree record names `peer`'s case as its peer, for the same metric.
    [[nodiscard]] bool paired(const Record& peer) const;
    std::vector<Record> records_;
    std::vector<std::pair<std::string, std::string>> configs_;
};

}  // namespace bench

#endif  // SYLVA_BENCH_BENCH_HPP
