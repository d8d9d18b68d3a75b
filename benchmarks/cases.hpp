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
void run_case(const Context& c, std::size_t n, Distribution d, bool stream);

}  // namespace bench

#endif  // SYLVA_BENCH_CASES_HPP
