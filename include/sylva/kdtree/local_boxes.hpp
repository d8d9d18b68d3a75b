// sylva/kdtree/local_boxes.hpp -- the local-AABB pass of Zellmann et al.'s binned builder
// (section 4.3): the tight box of the occupied voxels of every 8^3 block, empty blocks dropped,
// sorted along a z-order Morton curve of the block coordinates so that the blocks of any box
// lie in one conservative index range.
//
// The pass is one streaming read of the occupancy. Per block it OR-reduces three 8-bit masks:
// the x bits of every row, and one y bit and one z bit per row that holds an occupied voxel; the
// lowest and highest set bits of each mask are the block's tight box (box_from_acc). This is
// the same box the paper finds by binary search in an 8^3 partial SVT, computed without the
// table. The per-block accumulation and the box are one definition in the shared subset
// (sylva/shared/kd_local_boxes.h: sylva_kd_box_accumulate, sylva_kd_box_acc_word), which this
// pass, the dense host pass of gpu_local_boxes.hpp and the compute shader all call.
#ifndef SYLVA_KDTREE_LOCAL_BOXES_HPP
#define SYLVA_KDTREE_LOCAL_BOXES_HPP

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/shared/kd_local_boxes.h"
#include "sylva/volume/occupancy.hpp"

namespace sylva::kdtree {

using volume::VoxelBox;

/// Morton code of a block coordinate: bits of x, y, z interleaved (x lowest), 21 bits each.
inline std::uint64_t morton3(uvec3 c) {
    auto spread = [](std::uint64_t v) {
        v &= 0x1FFFFFu;
        v = (v | v << 32) & 0x1F00000000FFFFull;
        v = (v | v << 16) & 0x1F0000FF0000FFull;
        v = (v | v << 8) & 0x100F00F00F00F00Full;
        v = (v | v << 4) & 0x10C30C30C30C30C3ull;
        v = (v | v << 2) & 0x1249249249249249ull;
        return v;
    };
    return spread(c.x) | (spread(c.y) << 1) | (spread(c.z) << 2);
}

/// The tight box of block `block` from its accumulated masks (count > 0): lowest to highest
/// set bit of each mask, through the shader's block word (sylva/shared/kd_local_boxes.h).
inline VoxelBox box_from_acc(uvec3 block, const shared::SylvaKdBoxAcc& a) {
    std::uint32_t w = shared::sylva_kd_box_acc_word(a, false);
    uvec3 base = block * 8u;
    return VoxelBox{base + shared::sylva_kd_box_word_lo(w), base + shared::sylva_kd_box_word_last(w) + 1u};
}

/// The 8^3 local boxes of a grid: non-empty blocks only, ascending Morton code.
struct LocalBoxes {
    static constexpr std::uint32_t block = 8;
    volume::Dims dims{0};
    vec3 spacing{1.0f};
    uvec3 blocks{0u};             ///< blocks along each axis
    std::uint64_t occupied = 0;   ///< occupied voxels of the grid
    std::vector<std::uint64_t> codes;  ///< Morton code of each non-empty block, ascending
    std::vector<VoxelBox> boxes;       ///< its tight box, same order

    /// Blocks [lo, hi) (block coordinates) that overlap `region`, clipped to the grid.
    [[nodiscard]] VoxelBox block_range(const VoxelBox& region) const {
        VoxelBox r = volume::intersect(region, volume::full_box(dims));
        if (r.empty()) return VoxelBox{};
        return VoxelBox{r.lo / block, (r.hi - 1u) / block + 1u};
    }

    /// Entries [first, last) whose codes lie between the codes of the first and the last block
    /// of `region`: a superset of its blocks, since Morton order is monotone in each coordinate.
    [[nodiscard]] std::pair<std::size_t, std::size_t> morton_range(const VoxelBox& region) const {
        VoxelBox br = block_range(region);
        if (br.empty()) return {0, 0};
        auto first = std::lower_bound(codes.begin(), codes.end(), morton3(br.lo));
        auto last = std::upper_bound(first, codes.end(), morton3(br.hi - 1u));
        return {static_cast<std::size_t>(first - codes.begin()), static_cast<std::size_t>(last - codes.begin())};
    }

    /// Calls f(index) for every non-empty block that overlaps `region`, in Morton order.
    template <class F>
    void for_each(const VoxelBox& region, F&& f) const {
        VoxelBox br = block_range(region);
        auto [first, last] = morton_range(region);
        for (std::size_t i = first; i < last; ++i)
            if (br.contains(boxes[i].lo.x / block, boxes[i].lo.y / block, boxes[i].lo.z / block)) f(i);
    }
};

namespace detail {

/// The 8-bit x mask of up to 8 bytes that are each 0 or 1 (bit k = byte k).
inline std::uint32_t row_mask(const std::uint8_t* p, std::uint32_t n) {
    if (n == 8) {  // a whole block: one multiply gathers the eight low bits
        std::uint64_t w;
        std::memcpy(&w, p, 8);
        return static_cast<std::uint32_t>((w * 0x0102040810204080ull) >> 56);
    }
    std::uint32_t m = 0;
    for (std::uint32_t k = 0; k < n; ++k) m |= std::uint32_t{p[k]} << k;
    return m;
}

/// Local boxes of one row of blocks (by, bz), appended to `out`; returns its occupied voxels.
/// Per block the shader's accumulation (sylva_kd_box_accumulate) over each grid row's masks.
template <volume::OccupancySource S>
std::uint64_t block_row(const S& src, uvec3 nb, std::uint32_t by, std::uint32_t bz, std::vector<std::uint8_t>& row,
                        std::vector<shared::SylvaKdBoxAcc>& acc, std::vector<std::pair<std::uint64_t, VoxelBox>>& out) {
    volume::Dims d = src.dims;
    std::fill(acc.begin(), acc.end(), shared::sylva_kd_box_acc_zero());
    for (std::uint32_t z = bz * 8u; z < std::min(d.z, bz * 8u + 8u); ++z)
        for (std::uint32_t y = by * 8u; y < std::min(d.y, by * 8u + 8u); ++y) {
            src.row(0, d.x, y, z, row.data());
            for (std::uint32_t bx = 0; bx < nb.x; ++bx)
                shared::sylva_kd_box_accumulate(acc[bx], row_mask(row.data() + bx * 8u, std::min(8u, d.x - bx * 8u)),
                                                y & 7u, z & 7u);
        }
    std::uint64_t occupied = 0;
    for (std::uint32_t bx = 0; bx < nb.x; ++bx) {
        if (acc[bx].count == 0u) continue;
        occupied += acc[bx].count;
        out.emplace_back(morton3(uvec3(bx, by, bz)), box_from_acc(uvec3(bx, by, bz), acc[bx]));
    }
    return occupied;
}

}  // namespace detail

/// Computes the local boxes of `src` in parallel over rows of blocks, then sorts them along
/// the Morton curve. Throws sylva::Error for bad dimensions or more than 2^21 blocks an axis.
template <volume::OccupancySource S, Executor X>
LocalBoxes local_boxes(const S& src, X& exec) {
    volume::voxel_count(src.dims);
    LocalBoxes lb;
    lb.dims = src.dims;
    lb.spacing = src.spacing;
    lb.blocks = (uvec3(src.dims) + 7u) / 8u;
    if (std::max({lb.blocks.x, lb.blocks.y, lb.blocks.z}) > (1u << 21))
        throw Error("kdtree: more than 2^21 blocks along an axis overflow the 64-bit Morton code");
    std::vector<std::pair<std::uint64_t, VoxelBox>> all;
    std::mutex m;
    std::size_t rows = std::size_t{lb.blocks.y} * lb.blocks.z;
    exec.parallel_for(0, rows, 1, [&](std::size_t lo, std::size_t hi) {
        std::vector<std::uint8_t> row(src.dims.x);
        std::vector<shared::SylvaKdBoxAcc> acc(lb.blocks.x);
        std::vector<std::pair<std::uint64_t, VoxelBox>> found;
        std::uint64_t occupied = 0;
        for (std::size_t r = lo; r < hi; ++r)
            occupied += detail::block_row(src, lb.blocks, static_cast<std::uint32_t>(r % lb.blocks.y),
                                          static_cast<std::uint32_t>(r / lb.blocks.y), row, acc, found);
        std::lock_guard lock(m);
        all.insert(all.end(), found.begin(), found.end());
        lb.occupied += occupied;
    });
    std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    lb.codes.resize(all.size());
    lb.boxes.resize(all.size());
    for (std::size_t i = 0; i < all.size(); ++i) lb.codes[i] = all[i].first, lb.boxes[i] = all[i].second;
    return lb;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_LOCAL_BOXES_HPP
