// sylva/kdtree/build_parallel.hpp -- Zellmann et al.'s parallel multi-core builder (section 4.1):
// partial summed-volume tables in cache-sized blocks, built in parallel, and node splitting with
// boundary computations per block combined by union (Alg. 1).
//
// For a node, the blocks that overlap its box are culled when empty; every other block computes
// its local tight box of (block ∩ node) once, and then, per candidate plane, contributes it to
// the lower or upper side whole, or, when its occupied voxels straddle the plane, the local
// tight boxes of its two halves. Blocks run in parallel on the executor; the per-plane results
// are combined by union. The union of local tight boxes is the tight box of the union, so this
// builder produces exactly the tree of the serial one (build.hpp) for the same Config.
#ifndef SYLVA_KDTREE_BUILD_PARALLEL_HPP
#define SYLVA_KDTREE_BUILD_PARALLEL_HPP

#include <chrono>
#include <algorithm>
#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "sylva/core/executor.hpp"
#include "sylva/kdtree/build.hpp"
#include "sylva/volume/partial_svt.hpp"

namespace sylva::kdtree {

/// The splitter of Zellmann's multi-core builder: Alg. 1 over partial SVTs.
template <std::uint32_t B, Executor X>
struct PartialSvtSplitter {
    const volume::PartialSvt<B>* svt;
    X* exec;
    /// Nodes overlapping fewer non-empty blocks than this are evaluated on the calling thread
    /// (the driver already runs the nodes of a level in parallel).
    std::size_t parallel_blocks = 8;

    [[nodiscard]] VoxelBox root_box() const { return svt->tight_box(volume::full_box(svt->dims()), *exec); }
    [[nodiscard]] std::uint64_t occupied() const { return svt->total(); }

    void evaluate(const VoxelBox& box, int axis, std::span<const std::uint32_t> planes, std::span<Split> out) const {
        std::vector<std::size_t> ids;  // CULL: only blocks with occupied voxels
        svt->for_blocks(box, [&](std::size_t b) {
            if (svt->block_total(b)) ids.push_back(b);
        });
        if (ids.size() < parallel_blocks) {  // few blocks: not worth tasks
            std::vector<Split> acc(planes.size());
            for (std::size_t b : ids) contribute(b, box, axis, planes, acc);
            std::copy(acc.begin(), acc.end(), out.begin());
            return;
        }
        std::mutex m;
        exec->parallel_for(0, ids.size(), 2, [&](std::size_t lo, std::size_t hi) {
            std::vector<Split> acc(planes.size());
            for (std::size_t i = lo; i < hi; ++i) contribute(ids[i], box, axis, planes, acc);
            std::lock_guard lock(m);  // COMBINE
            for (std::size_t k = 0; k < planes.size(); ++k) {
                out[k].lower.extend(acc[k].lower);
                out[k].upper.extend(acc[k].upper);
            }
        });
    }

private:
    /// CALCULATELOCAL for one block and every plane.
    void contribute(std::size_t b, const VoxelBox& box, int axis, std::span<const std::uint32_t> planes,
                    std::vector<Split>& acc) const {
        VoxelBox whole = svt->tight_box_in_block(b, box);
        if (whole.empty()) return;
        for (std::size_t k = 0; k < planes.size(); ++k) {
            std::uint32_t p = planes[k];
            if (whole.hi[axis] <= p) {
                acc[k].lower.extend(whole);
            } else if (whole.lo[axis] >= p) {
                acc[k].upper.extend(whole);
            } else {
                VoxelBox lower = whole, upper = whole;
                lower.hi[axis] = p;
                upper.lo[axis] = p;
                acc[k].lower.extend(svt->tight_box_in_block(b, lower));
                acc[k].upper.extend(svt->tight_box_in_block(b, upper));
            }
        }
    }
};

/// Zellmann et al.'s parallel builder over prebuilt partial SVTs.
template <std::uint32_t B, Executor X>
Tree build(const volume::PartialSvt<B>& svt, const Config& cfg, X& exec) {
    return grow(PartialSvtSplitter<B, X>{&svt, &exec}, cfg, exec, svt.dims(), svt.spacing());
}

/// Builds the partial SVTs of `src` (B^3 blocks, Zellmann section 4.1: 32^3) in parallel, then
/// the tree; stats.occupancy_ms is the partial-SVT phase, stats.split_ms the splitting phase.
template <std::uint32_t B = 32, volume::OccupancySource Src, Executor X>
Tree build_parallel(const Src& src, const Config& cfg, X& exec) {
    auto t0 = std::chrono::steady_clock::now();
    volume::PartialSvt<B> svt(src, exec);
    double svt_ms = detail::ms_since(t0);
    Tree t = build(svt, cfg, exec);
    t.stats.occupancy_ms = svt_ms;
    return t;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_BUILD_PARALLEL_HPP
