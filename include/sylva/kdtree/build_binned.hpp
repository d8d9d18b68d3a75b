// sylva/kdtree/build_binned.hpp -- Zellmann et al.'s binned builder (section 4.3, the GPU
// variant, here on the CPU): precomputed 8^3 local boxes, Morton-sorted; per node a fixed
// number of candidate planes (bins) on an 8-voxel raster; tight boxes by combining the local
// boxes found by a Morton range query.
//
// Planes on the block raster never cut a block, so each block lies wholly on one side of every
// candidate plane. A node's blocks are binned once into the bins - 1 + 1 intervals between its
// planes; the lower and upper boxes of plane k are the unions of the intervals below and above
// it (a prefix and a suffix sweep). Every box the builder produces is a union of whole blocks'
// local boxes, hence tight, and a block that overlaps a node's box has all its occupied voxels
// in it; so this builder gives exactly the tree of the serial builder run with the same binned
// planes (Config::binned()), while Vidal's every-Δl planes give a slightly different tree.
#ifndef SYLVA_KDTREE_BUILD_BINNED_HPP
#define SYLVA_KDTREE_BUILD_BINNED_HPP

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "sylva/core/executor.hpp"
#include "sylva/kdtree/build.hpp"
#include "sylva/kdtree/local_boxes.hpp"

namespace sylva::kdtree {

/// The splitter of the binned builder.
template <Executor X>
struct BinnedSplitter {
    const LocalBoxes* boxes;
    X* exec;
    /// Nodes with more candidate blocks than this bin them in parallel.
    std::size_t parallel_blocks = 4096;

    [[nodiscard]] VoxelBox root_box() const {
        VoxelBox u;
        for (const VoxelBox& b : boxes->boxes) u.extend(b);
        return u;
    }
    [[nodiscard]] std::uint64_t occupied() const { return boxes->occupied; }

    void evaluate(const VoxelBox& box, int axis, std::span<const std::uint32_t> planes, std::span<Split> out) const {
        std::vector<VoxelBox> bins(planes.size() + 1);  // interval j: above planes [0, j), below the rest
        auto [first, last] = boxes->morton_range(box);
        if (last - first > parallel_blocks) {
            std::mutex m;
            exec->parallel_for(first, last, 1024, [&](std::size_t lo, std::size_t hi) {
                std::vector<VoxelBox> local(bins.size());
                bin_range(box, axis, planes, lo, hi, local);
                std::lock_guard lock(m);
                for (std::size_t j = 0; j < bins.size(); ++j) bins[j].extend(local[j]);
            });
        } else {
            bin_range(box, axis, planes, first, last, bins);
        }
        VoxelBox below;
        for (std::size_t k = 0; k < planes.size(); ++k) {
            below.extend(bins[k]);
            out[k].lower = below;
        }
        VoxelBox above;
        for (std::size_t k = planes.size(); k-- > 0;) {
            above.extend(bins[k + 1]);
            out[k].upper = above;
        }
    }

private:
    /// Bins the entries [lo, hi) of the Morton range that overlap `box`.
    void bin_range(const VoxelBox& box, int axis, std::span<const std::uint32_t> planes, std::size_t lo, std::size_t hi,
                   std::vector<VoxelBox>& bins) const {
        VoxelBox br = boxes->block_range(box);
        for (std::size_t i = lo; i < hi; ++i) {
            const VoxelBox& b = boxes->boxes[i];
            if (!br.contains(b.lo.x / LocalBoxes::block, b.lo.y / LocalBoxes::block, b.lo.z / LocalBoxes::block))
                continue;
            VoxelBox c = volume::intersect(b, box);
            if (c.empty()) continue;
            auto j = std::upper_bound(planes.begin(), planes.end(), c.lo[axis]) - planes.begin();
            bins[static_cast<std::size_t>(j)].extend(c);
        }
    }
};

/// The binned builder over precomputed local boxes. Candidate planes are always binned
/// (cfg.bins, cfg.raster); the raster must be a multiple of the 8-voxel block, or planes
/// could cut blocks (sylva::Error).
template <Executor X>
Tree build(const LocalBoxes& boxes, Config cfg, X& exec) {
    if (cfg.raster == 0 || cfg.raster % LocalBoxes::block != 0)
        throw Error("kdtree: the binned builder's raster must be a multiple of the 8-voxel block");
    cfg.planes = Planes::Binned;
    return grow(BinnedSplitter<X>{&boxes, &exec}, cfg, exec, boxes.dims, boxes.spacing);
}

/// Computes the local boxes of `src` in parallel, then the binned tree; stats.occupancy_ms is
/// the local-box phase, stats.split_ms the splitting phase.
template <volume::OccupancySource Src, Executor X>
Tree build_binned(const Src& src, const Config& cfg, X& exec) {
    auto t0 = std::chrono::steady_clock::now();
    LocalBoxes boxes = local_boxes(src, exec);
    double boxes_ms = detail::ms_since(t0);
    Tree t = build(boxes, cfg, exec);
    t.stats.occupancy_ms = boxes_ms;
    return t;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_BUILD_BINNED_HPP
