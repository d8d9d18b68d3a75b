// benchmarks/moving.hpp -- moving spheres (issue 14, item 5), shared by sylva-moving-bench and
// sylva-bench's case "moving".
//
// The same spheres (sylva-bench's uniform workload) move for F frames, each along its own
// direction by 2 % of the unit cube's side times sin(2 pi f / 16 + i); per frame every index
// follows the motion by refit and, separately, by rebuild:
//   bih     bih::refit / bih::rebuild of a bih::Config::for_queries() tree (plus the RangePayload encode)
//   kd      kdtree::refit_elements / rebuild_elements (plus kdtree::encode_elements)
//   octree  octree::update_elements (refit, or a rebuild where a sphere left the lattice) /
//           rebuild_elements (plus octree::encode_elements); both built with refit_margin 0.05
//   embree  Embree 3 over RTC_GEOMETRY_TYPE_SPHERE_POINT: refit = scene RTC_BUILD_QUALITY_LOW
//           with the geometry at RTC_BUILD_QUALITY_REFIT (Embree refits the geometry's BVH when
//           only the vertex buffer changed); rebuild = the default scene (MEDIUM) committed anew
// Reported per index and mode: cold (frame 1, the first update after the initial build) and
// steady (median of frames 2..F) update times, the initial build, and after the last frame the
// first-hit rate over R rays (the refitted tree's quality against the rebuilt one's). A check
// compares every index's first hits on the moved spheres against brute force over a sample of
// rays. All structures run in one process on the same spheres; the entrants are updated in
// alternating order between frames.
#ifndef SYLVA_BENCH_MOVING_HPP
#define SYLVA_BENCH_MOVING_HPP

#include <cstddef>
#include <string>

#include <sylva/core/executor.hpp>

#include "bench.hpp"

namespace bench {

/// What one moving-spheres run measures.
struct MovingArgs {
    std::size_t count = 1000000;  ///< spheres
    std::size_t frames = 8;       ///< frames of motion, at least 2 (cold: frame 1; steady: 2..F)
    std::size_t rays = 200000;    ///< rays of the first-hit rate after the last frame
};

/// What a run found besides its records.
struct MovingResult {
    std::size_t sample = 0;            ///< rays checked against brute force
    std::size_t mismatches = 0;        ///< (entrant, ray) pairs that disagree with brute force
    std::size_t octree_fallbacks = 0;  ///< octree refits that fell back to a rebuild (of F frames)
};

/// Runs the moving spheres on `pool`: adds the records (cases "moving/<N>/uniform/<index>/<mode>",
/// impl "sylva" or "embree"; the sylva rows name Embree's row of the same mode as their peer) to
/// `report`, prints the table on stdout and one progress line a frame, prefixed by `who`, on
/// stderr. The run failed when the result's mismatches are not 0. Throws on an Embree error.
MovingResult run_moving(const MovingArgs& args, sylva::ThreadPool& pool, Report& report, const std::string& who);

}  // namespace bench

#endif  // SYLVA_BENCH_MOVING_HPP
