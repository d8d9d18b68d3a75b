// benchmarks/run_sylva.hpp -- sylva's side of each case: BIH build, encode, first hit, all hits.
#ifndef SYLVA_BENCH_RUN_SYLVA_HPP
#define SYLVA_BENCH_RUN_SYLVA_HPP

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <sylva/bih/tree.hpp>
#include <sylva/core/executor.hpp>

#include "bench.hpp"

namespace bench {

/// A built tree and its two RangePayload encodings (the queries' inputs).
struct SylvaIndex {
    sylva::bih::Tree tree;
    std::vector<std::uint32_t> fixed16;
    std::vector<std::uint32_t> float32;
};

/// Times bih::build (default Config) and the encoders; records them under "build/<label>" and
/// "encode/<label>/...". Returns the index of the last run.
SylvaIndex bench_sylva_build(const std::vector<sylva::Sphere>& spheres, sylva::ThreadPool& pool,
                             const Options& opt, Report& report, const std::string& label);

/// One pass of bih::first_hit over all rays, in parallel on `pool`.
FirstHits sylva_first_hits(const std::vector<std::uint32_t>& words, const sylva::bih::Tree& tree,
                           const std::vector<sylva::Sphere>& spheres, std::span<const sylva::Ray> rays,
                           sylva::ThreadPool& pool);

/// One pass of bih::all_hits over all rays, in parallel on `pool`.
AllHits sylva_all_hits(const std::vector<std::uint32_t>& words, const sylva::bih::Tree& tree,
                       const std::vector<sylva::Sphere>& spheres, std::span<const sylva::Ray> rays,
                       sylva::ThreadPool& pool);

/// bih::all_hits of one ray as a list of element ids (for re-examining disagreements).
HitList sylva_hit_list(const std::vector<std::uint32_t>& words, const sylva::bih::Tree& tree,
                       const std::vector<sylva::Sphere>& spheres);

/// Mean inner and leaf nodes the iterator visits per ray (first hit: with the clipping that
/// bih::first_hit does), measured on up to 10000 of `rays` outside any timing.
struct TraversalCost {
    double nodes_per_ray = 0.0;
    double leaves_per_ray = 0.0;
};
TraversalCost sylva_cost(const std::vector<std::uint32_t>& words, const sylva::bih::Tree& tree,
                         const std::vector<sylva::Sphere>& spheres, std::span<const sylva::Ray> rays, bool first);

/// GB/s of a parallel streaming pass that sums `words` (median of `runs`): the rate at which
/// this machine can read the encoding at all.
double stream_gb_per_s(const std::vector<std::uint32_t>& words, sylva::ThreadPool& pool, std::size_t runs);

}  // namespace bench

#endif  // SYLVA_BENCH_RUN_SYLVA_HPP
