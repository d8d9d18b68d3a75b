// sylva/volume/voxels.hpp -- the voxel-cuboid source of a BIH (Kinkelin sections 4.3, 6.1):
// every voxel whose normalised density reaches a threshold becomes one VoxelCuboid carrying
// its cell box, its density and its central-difference gradient (sylva/volume/gradient.hpp).
#ifndef SYLVA_VOLUME_VOXELS_HPP
#define SYLVA_VOLUME_VOXELS_HPP

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/elements/voxel.hpp"
#include "sylva/volume/gradient.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::volume {

namespace voxels_detail {

/// Counts the selected voxels of each z slice in [z0, z1); records the first NaN voxel.
inline void count_slices(const DensityGrid& g, float min_density, std::size_t z0, std::size_t z1,
                         std::vector<std::size_t>& counts, std::atomic<std::size_t>& first_nan) {
    std::size_t slice = std::size_t{g.dims.x} * g.dims.y;
    for (std::size_t z = z0; z < z1; ++z) {
        std::size_t n = 0;
        const float* d = g.values.data() + z * slice;
        for (std::size_t i = 0; i < slice; ++i) {
            if (std::isnan(d[i])) {
                std::size_t at = z * slice + i, seen = first_nan.load();
                while (at < seen && !first_nan.compare_exchange_weak(seen, at)) {
                }
            }
            n += d[i] >= min_density ? 1u : 0u;
        }
        counts[z] = n;
    }
}

/// Writes the cuboids of slice z from position `at` on.
inline void fill_slice(const DensityGrid& g, float min_density, std::uint32_t z, std::size_t at,
                       std::vector<VoxelCuboid>& out) {
    for (std::uint32_t y = 0; y < g.dims.y; ++y)
        for (std::uint32_t x = 0; x < g.dims.x; ++x) {
            float d = g.at(x, y, z);
            if (!(d >= min_density)) continue;
            out[at++] = VoxelCuboid{g.voxel_box(x, y, z), d, gradient_detail::gradient_unchecked(g, x, y, z)};
        }
}

}  // namespace voxels_detail

/// One VoxelCuboid per voxel whose normalised density is >= `min_density` (Kinkelin 6.1:
/// "usually 0.1 to remove most of the noise"): box = the voxel's cell
/// [v * spacing, (v + 1) * spacing], density = the voxel's value, gradient = its central
/// difference in density change per voxel. The order is the grid's (x fastest, then y, z),
/// whatever the executor. No voxel selected is a valid empty result; bih::build and
/// bih::build_full refuse an empty element list with sylva::Error, so callers decide.
/// Throws sylva::Error for an empty or inconsistent grid, a NaN in the grid (naming the voxel)
/// or a threshold that is not a finite number.
template <Executor X>
std::vector<VoxelCuboid> voxel_cuboids(const DensityGrid& grid, float min_density, X& exec) {
    gradient_detail::check_grid(grid, "volume::voxel_cuboids");
    if (!std::isfinite(min_density))
        throw Error("volume::voxel_cuboids: min_density " + std::to_string(min_density) + " is not a finite number");
    std::vector<std::size_t> counts(grid.dims.z, 0);
    std::atomic<std::size_t> first_nan{std::numeric_limits<std::size_t>::max()};
    exec.parallel_for(0, grid.dims.z, 1, [&](std::size_t z0, std::size_t z1) {
        voxels_detail::count_slices(grid, min_density, z0, z1, counts, first_nan);
    });
    if (std::size_t i = first_nan.load(); i != std::numeric_limits<std::size_t>::max())
        throw Error("volume::voxel_cuboids: voxel " + std::to_string(i) + " has a NaN density");
    std::vector<std::size_t> start(grid.dims.z + 1, 0);
    for (std::uint32_t z = 0; z < grid.dims.z; ++z) start[z + 1] = start[z] + counts[z];
    std::vector<VoxelCuboid> out(start.back());
    exec.parallel_for(0, grid.dims.z, 1, [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
            voxels_detail::fill_slice(grid, min_density, static_cast<std::uint32_t>(z), start[z], out);
    });
    return out;
}

/// voxel_cuboids on the calling thread (default threshold 0.1, Kinkelin 6.1 / Table 3).
inline std::vector<VoxelCuboid> voxel_cuboids(const DensityGrid& grid, float min_density = 0.1f) {
    SerialExecutor serial;
    return voxel_cuboids(grid, min_density, serial);
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_VOXELS_HPP
