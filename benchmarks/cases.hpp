// benchmarks/cases.hpp -- one benchmark case: a sphere set, built and traced by every
// implementation on the same rays, with the results cross-checked.
#ifndef SYLVA_BENCH_CASES_HPP
#define SYLVA_BENCH_CASES_HPP

#include <string>
#include <vector>

#include <sylva/core/executor.hpp>

#include "bench.hpp"

namespace bench {

class EmbreePeer;  // run_embree.hpp; null when built without Embree

/// What every case shares.
struct Context {
    const Options& opt;
    sylva::ThreadPool& pool;
    Report& report;
    const std::vector<sylva::Ray>& rays;
    EmbreePeer* embree;
    std::vector<std::string>& failures;  ///< cross-checks that failed (the run exits non-zero)
};

/// Builds, encodes and traces `n` spheres spread by `d`. `stream` adds the memory-bandwidth floor.
/// `loaded` (--load, a CompetingLoad running): the case names start with "load/" and the cold
/// builds are left out (they measure memory, not sharing the cores).
void run_case(const Context& c, std::size_t n, Distribution d, bool stream, bool loaded = false);

/// The cold first builds of `n` spheres spread by `d` (cold.cpp): every builder in
/// c.opt.cold_runs fresh processes; records build_cold_ms and build_cold_elements_per_s under
/// "build/<label>..." beside the steady-state build_ms.
void cold_builds(const Context& c, std::size_t n, Distribution d, const std::string& label);
/// The body of a cold child (`--cold-child IMPL --sizes N --cold-distribution D`): one timed
/// first build, printed as "cold_build_ms X" on stdout.
int cold_child_main(const Options& opt);

}  // namespace bench

#endif  // SYLVA_BENCH_CASES_HPP
