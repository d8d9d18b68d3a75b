// sylva/volume/svt.hpp -- the full summed-volume table of a binary occupancy (Vidal et al.
// section 2.1.2, eqs. 4-6): O(1) occupancy of any box, and tight boxes by binary search.
//
// V2(i, j, k) = number of occupied voxels in [0, i] x [0, j] x [0, k]. The table has one entry
// per voxel, of an unsigned integer type wide enough for the voxel count (uint32 up to
// 2^32 - 1 voxels, uint64 beyond: make_svt chooses). Box counts are computed with modular
// arithmetic in that type (eq. 6), exact because every true count fits it.
#ifndef SYLVA_VOLUME_SVT_HPP
#define SYLVA_VOLUME_SVT_HPP

#include <concepts>
#include <cstdint>
#include <limits>
#include <string>
#include <variant>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"

namespace sylva::volume {

/// A summed-volume table with entries of type C.
template <std::unsigned_integral C>
class SummedVolumeTable {
public:
    using count_type = C;

    SummedVolumeTable() = default;
    /// Builds the table of `src` (see assign).
    template <OccupancySource S>
    explicit SummedVolumeTable(const S& src) {
        assign(src);
    }

    /// (Re)builds the table of `src`, reusing the storage. Each row is classified and summed
    /// straight into the table (Vidal eq. 5, built in place: no copy of V1 beside V2). Throws
    /// sylva::Error when the voxel count does not fit C, or for bad dimensions.
    template <OccupancySource S>
    void assign(const S& src) {
        std::size_t n = voxel_count(src.dims);
        if (n > std::numeric_limits<C>::max())
            throw Error("svt: " + std::to_string(n) + " voxels overflow a " + std::to_string(sizeof(C) * 8) +
                        "-bit summed-volume table");
        dims_ = src.dims;
        spacing_ = src.spacing;
        table_.resize(n);
        std::vector<std::uint8_t> row(dims_.x);
        std::vector<C> zeros(dims_.x, C{0}), run(dims_.x);
        for (std::uint32_t z = 0; z < dims_.z; ++z)
            for (std::uint32_t y = 0; y < dims_.y; ++y) {
                src.row(0, dims_.x, y, z, row.data());
                sum_row(row.data(), run.data(), y, z, zeros.data());
            }
    }

    [[nodiscard]] Dims dims() const { return dims_; }
    [[nodiscard]] vec3 spacing() const { return spacing_; }
    /// The raw table, x fastest.
    [[nodiscard]] const std::vector<C>& table() const { return table_; }
    /// Number of occupied voxels in the whole grid.
    [[nodiscard]] std::uint64_t total() const { return table_.empty() ? 0 : table_.back(); }

    /// Number of occupied voxels in `box` (clipped to the grid): eight lookups (Vidal eq. 6).
    [[nodiscard]] std::uint64_t count(const VoxelBox& box) const {
        VoxelBox b = intersect(box, full_box(dims_));
        if (b.empty()) return 0;
        uvec3 l = b.lo, h = b.hi;
        C r = prefix(h.x, h.y, h.z) - prefix(l.x, h.y, h.z) - prefix(h.x, l.y, h.z) - prefix(h.x, h.y, l.z) +
              prefix(l.x, l.y, h.z) + prefix(l.x, h.y, l.z) + prefix(h.x, l.y, l.z) - prefix(l.x, l.y, l.z);
        return static_cast<std::uint64_t>(r);
    }

    /// Tight box of the occupied voxels in `region` (clipped to the grid); empty when none.
    [[nodiscard]] VoxelBox tight_box(const VoxelBox& region) const {
        return shrink_to_occupied(intersect(region, full_box(dims_)), [this](const VoxelBox& b) { return count(b); });
    }

private:
    /// Occupied voxels in [0, x) x [0, y) x [0, z), for x, y, z in [0, dims].
    [[nodiscard]] C prefix(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
        if (x == 0 || y == 0 || z == 0) return C{0};
        return table_[voxel_index(dims_, x - 1, y - 1, z - 1)];
    }

    /// Eq. 5 for one row: with R = the running sum of V1 along the row,
    /// V2(i,j,k) = R + V2(i,j-1,k) + V2(i,j,k-1) - V2(i,j-1,k-1), which is eq. 5 with its
    /// (i-1) terms folded into R. Missing neighbours (j or k = 0) read a row of zeros. R goes
    /// to `run` first, so the second loop (three rows in, one out) vectorises.
    void sum_row(const std::uint8_t* v1, C* __restrict run, std::uint32_t y, std::uint32_t z, const C* zeros) {
        C* __restrict out = table_.data() + voxel_index(dims_, 0, y, z);
        std::size_t slice = std::size_t{dims_.x} * dims_.y;
        const C* __restrict below = y ? out - dims_.x : zeros;
        const C* __restrict back = z ? out - slice : zeros;
        const C* __restrict back_below = (y && z) ? out - slice - dims_.x : zeros;
        C r = 0;
        for (std::uint32_t x = 0; x < dims_.x; ++x) run[x] = r += v1[x];
        for (std::uint32_t x = 0; x < dims_.x; ++x) out[x] = run[x] + below[x] + back[x] - back_below[x];
    }

    Dims dims_{0};
    vec3 spacing_{1.0f};
    std::vector<C> table_;
};

/// A table of the width the grid needs.
using AnySvt = std::variant<SummedVolumeTable<std::uint32_t>, SummedVolumeTable<std::uint64_t>>;

/// True when a grid of `dims` has more voxels than a 32-bit table can count.
inline bool svt_needs_64bit(Dims dims) {
    return std::uint64_t{dims.x} * dims.y * dims.z > std::numeric_limits<std::uint32_t>::max();
}

/// Builds the table of `src` with 32-bit entries when the voxel count fits them, else 64-bit.
template <OccupancySource S>
AnySvt make_svt(const S& src) {
    if (svt_needs_64bit(src.dims)) return AnySvt(std::in_place_index<1>, src);
    return AnySvt(std::in_place_index<0>, src);
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_SVT_HPP
