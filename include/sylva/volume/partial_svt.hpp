// sylva/volume/partial_svt.hpp -- partial summed-volume tables (Zellmann et al. section 4.1):
// the grid cut into B^3 blocks (32^3 by default, sized for a core's L1 cache), each with its
// own 16-bit summed-volume table, built in parallel through an Executor.
//
// A block's table counts only its own voxels, so 16 bits suffice for any grid (B^3 <= 65535),
// blocks are independent (an embarrassingly parallel build), and a box query sums the eq.-6
// counts of the blocks it overlaps. Tight boxes are found block by block and combined by union
// (Zellmann et al. Fig. 2 and Alg. 1). Edge blocks of grids whose dimensions are not multiples
// of B are clipped to the grid. Blocks without occupied voxels skip their table entirely (only
// their total, 0, is stored), which makes sparse volumes cheap. The build reads the source a
// whole grid row at a time (rows of blocks in parallel) and scatters the rows into the blocks,
// so a volume classified on the fly is read in its own order, not block by block.
#ifndef SYLVA_VOLUME_PARTIAL_SVT_HPP
#define SYLVA_VOLUME_PARTIAL_SVT_HPP

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <numeric>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"

namespace sylva::volume {

/// Partial SVTs over B^3 blocks with 16-bit entries.
template <std::uint32_t B = 32>
class PartialSvt {
    static_assert(B >= 1 && B * B * B <= 65535u, "a block's count must fit 16 bits");

public:
    /// Edge length of a block in voxels.
    static constexpr std::uint32_t block = B;
    static constexpr std::size_t block_voxels = std::size_t{B} * B * B;

    PartialSvt() = default;
    template <OccupancySource S, Executor X>
    PartialSvt(const S& src, X& exec) {
        assign(src, exec);
    }

    /// (Re)builds every block's table from `src` in parallel, reusing the storage (a rebuild
    /// after a transfer-function change allocates nothing). Throws sylva::Error for bad dims.
    template <OccupancySource S, Executor X>
    void assign(const S& src, X& exec) {
        voxel_count(src.dims);  // rejects zero and overflowing dimensions
        dims_ = src.dims;
        spacing_ = src.spacing;
        blocks_ = (uvec3(dims_) + uvec3(B - 1)) / uvec3(B);
        std::size_t n = block_count();
        totals_.assign(n, 0u);
        sums_.resize(n * block_voxels);
        std::size_t block_rows = std::size_t{blocks_.y} * blocks_.z;
        exec.parallel_for(0, block_rows, 1, [&](std::size_t lo, std::size_t hi) {
            std::vector<std::uint8_t> row(dims_.x), v1(std::size_t{blocks_.x} * B * std::min(B, dims_.y) * std::min(B, dims_.z));
            for (std::size_t r = lo; r < hi; ++r) build_block_row(src, r, row.data(), v1.data());
        });
    }

    [[nodiscard]] Dims dims() const { return dims_; }
    [[nodiscard]] vec3 spacing() const { return spacing_; }
    /// Number of blocks along each axis.
    [[nodiscard]] uvec3 blocks() const { return blocks_; }
    [[nodiscard]] std::size_t block_count() const { return std::size_t{blocks_.x} * blocks_.y * blocks_.z; }
    [[nodiscard]] std::size_t block_index(uvec3 c) const { return c.x + std::size_t{blocks_.x} * (c.y + std::size_t{blocks_.y} * c.z); }
    [[nodiscard]] uvec3 block_coord(std::size_t b) const {
        return uvec3(static_cast<std::uint32_t>(b % blocks_.x), static_cast<std::uint32_t>((b / blocks_.x) % blocks_.y),
                     static_cast<std::uint32_t>(b / (std::size_t{blocks_.x} * blocks_.y)));
    }
    /// The voxels of block b, clipped to the grid.
    [[nodiscard]] VoxelBox block_box(std::size_t b) const {
        uvec3 lo = block_coord(b) * B;
        return VoxelBox{lo, glm::min(lo + uvec3(B), uvec3(dims_))};
    }
    /// Occupied voxels of block b.
    [[nodiscard]] std::uint32_t block_total(std::size_t b) const { return totals_[b]; }
    /// Occupied voxels of the grid.
    [[nodiscard]] std::uint64_t total() const {
        return std::accumulate(totals_.begin(), totals_.end(), std::uint64_t{0});
    }
    /// The range of blocks [lo, hi) (block coordinates) overlapping `region` (clipped to the grid).
    [[nodiscard]] VoxelBox block_range(const VoxelBox& region) const {
        VoxelBox r = intersect(region, full_box(dims_));
        if (r.empty()) return VoxelBox{};
        return VoxelBox{r.lo / B, (r.hi - 1u) / B + 1u};
    }

    /// Occupied voxels of `region` inside block b: eight lookups in the block's table (eq. 6).
    [[nodiscard]] std::uint32_t count_in_block(std::size_t b, const VoxelBox& region) const {
        if (totals_[b] == 0) return 0;
        VoxelBox bb = block_box(b);
        return count_local(b, bb, intersect(region, bb));
    }
    /// Occupied voxels of `region`: the sum over the blocks it overlaps.
    [[nodiscard]] std::uint64_t count(const VoxelBox& region) const {
        std::uint64_t n = 0;
        for_blocks(region, [&](std::size_t b) { n += count_in_block(b, region); });
        return n;
    }

    /// Tight box of the occupied voxels of `region` inside block b (binary search, eq. 3).
    [[nodiscard]] VoxelBox tight_box_in_block(std::size_t b, const VoxelBox& region) const {
        if (totals_[b] == 0) return VoxelBox{};
        VoxelBox bb = block_box(b);
        return shrink_to_occupied(intersect(region, bb), [&](const VoxelBox& r) { return count_local(b, bb, r); });
    }

    /// Tight box of the occupied voxels of `region`: the union of the blocks' local boxes.
    [[nodiscard]] VoxelBox tight_box(const VoxelBox& region) const {
        VoxelBox u;
        for_blocks(region, [&](std::size_t b) { u.extend(tight_box_in_block(b, region)); });
        return u;
    }

    /// The same, with the blocks' local boxes computed in parallel and combined by union
    /// (Zellmann et al. Alg. 1, CalculateLocal + Combine).
    template <Executor X>
    [[nodiscard]] VoxelBox tight_box(const VoxelBox& region, X& exec) const {
        std::vector<std::size_t> ids;
        for_blocks(region, [&](std::size_t b) {
            if (totals_[b]) ids.push_back(b);
        });
        VoxelBox u;
        std::mutex m;
        exec.parallel_for(0, ids.size(), 4, [&](std::size_t lo, std::size_t hi) {
            VoxelBox local;
            for (std::size_t i = lo; i < hi; ++i) local.extend(tight_box_in_block(ids[i], region));
            std::lock_guard lock(m);
            u.extend(local);
        });
        return u;
    }

    /// Calls f(block index) for every block overlapping `region`, x fastest.
    template <class F>
    void for_blocks(const VoxelBox& region, F&& f) const {
        VoxelBox br = block_range(region);
        for (std::uint32_t z = br.lo.z; z < br.hi.z; ++z)
            for (std::uint32_t y = br.lo.y; y < br.hi.y; ++y)
                for (std::uint32_t x = br.lo.x; x < br.hi.x; ++x) f(block_index(uvec3(x, y, z)));
    }

private:
    /// Eq. 6 in block b, whose box is bb, for a region r inside bb (empty: 0).
    [[nodiscard]] std::uint32_t count_local(std::size_t b, const VoxelBox& bb, const VoxelBox& r) const {
        if (r.empty()) return 0;
        uvec3 l = r.lo - bb.lo, h = r.hi - bb.lo;
        const std::uint16_t* t = sums_.data() + b * block_voxels;
        auto p = [t](std::uint32_t x, std::uint32_t y, std::uint32_t z) -> std::int32_t {
            return (x == 0 || y == 0 || z == 0) ? 0 : std::int32_t{t[(x - 1) + B * ((y - 1) + B * (z - 1))]};
        };
        std::int32_t c = p(h.x, h.y, h.z) - p(l.x, h.y, h.z) - p(h.x, l.y, h.z) - p(h.x, h.y, l.z) + p(l.x, l.y, h.z) +
                         p(l.x, h.y, l.z) + p(h.x, l.y, l.z) - p(l.x, l.y, l.z);
        return static_cast<std::uint32_t>(c);
    }

    /// Builds the row of blocks r (r = by + blocks.y * bz): classifies whole grid rows (one
    /// streaming read), scatters them into the blocks' occupancy `v1` (per block, x fastest
    /// with stride B, then y and z over the row's extents), then counts and sums each block.
    template <OccupancySource S>
    void build_block_row(const S& src, std::size_t r, std::uint8_t* row, std::uint8_t* v1) {
        std::size_t first = block_index(uvec3(0u, static_cast<std::uint32_t>(r % blocks_.y),
                                              static_cast<std::uint32_t>(r / blocks_.y)));
        VoxelBox bb = block_box(first);
        uvec3 e = bb.hi - bb.lo;
        std::size_t stride = std::size_t{B} * e.y * e.z;  // bytes of one block in v1
        for (std::uint32_t z = 0; z < e.z; ++z)
            for (std::uint32_t y = 0; y < e.y; ++y) {
                src.row(0, dims_.x, bb.lo.y + y, bb.lo.z + z, row);
                for (std::uint32_t bx = 0; bx < blocks_.x; ++bx)
                    std::memcpy(v1 + bx * stride + B * (y + e.y * z), row + bx * B, std::min(B, dims_.x - bx * B));
            }
        for (std::uint32_t bx = 0; bx < blocks_.x; ++bx) sum_block(first + bx, v1 + bx * stride);
    }

    /// Counts block b from its occupancy `v1` (layout of build_block_row) and, unless it is
    /// empty, sums it into the block's table (eq. 5 in the running-row form of svt.hpp).
    void sum_block(std::size_t b, const std::uint8_t* v1) {
        VoxelBox bb = block_box(b);
        uvec3 e = bb.hi - bb.lo;
        std::uint32_t total = 0;
        for (std::uint32_t z = 0; z < e.z; ++z)
            for (std::uint32_t y = 0; y < e.y; ++y) total += detail::count_ones(v1 + B * (y + e.y * z), e.x);
        totals_[b] = total;
        if (total == 0) return;
        std::uint16_t* t = sums_.data() + b * block_voxels;
        static constexpr std::uint16_t zeros[B] = {};
        for (std::uint32_t z = 0; z < e.z; ++z)
            for (std::uint32_t y = 0; y < e.y; ++y) {
                std::uint16_t* out = t + B * (y + B * z);
                const std::uint16_t* below = y ? out - B : zeros;
                const std::uint16_t* back = z ? out - B * B : zeros;
                const std::uint16_t* back_below = (y && z) ? out - B * B - B : zeros;
                const std::uint8_t* in = v1 + B * (y + e.y * z);
                std::uint16_t run = 0;
                for (std::uint32_t x = 0; x < e.x; ++x) {
                    run = static_cast<std::uint16_t>(run + in[x]);
                    out[x] = static_cast<std::uint16_t>(run + below[x] + back[x] - back_below[x]);
                }
            }
    }

    Dims dims_{0};
    vec3 spacing_{1.0f};
    uvec3 blocks_{0u};
    std::vector<std::uint16_t> sums_;
    std::vector<std::uint32_t> totals_;
};

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_PARTIAL_SVT_HPP
