// sylva/volume/gradient.hpp -- voxel gradients of a density grid by central differences
// (Kinkelin sections 4.3 and 6.1: "the gradients are obtained by central differencing").
//
// Units: change of normalised density per voxel along each grid axis, not per world unit,
// so spacing does not enter. This is what a VoxelCuboid carries and what sylva/shared/voxel.h
// reconstructs with: d(x) = d_center + g . ((x - c) / voxel_size).
//   interior voxel:  g = (d[i + 1] - d[i - 1]) / 2
//   first voxel:     g = d[1] - d[0]            (one-sided forward difference)
//   last voxel:      g = d[n - 1] - d[n - 2]    (one-sided backward difference)
//   axis of 1 voxel: g = 0
// The one-sided borders keep the gradient of a linear ramp exact up to the edge (a clamped
// central difference would halve it there).
#ifndef SYLVA_VOLUME_GRADIENT_HPP
#define SYLVA_VOLUME_GRADIENT_HPP

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::volume {

namespace gradient_detail {

/// Throws sylva::Error when `g` has a zero dimension or its value count does not match.
inline void check_grid(const DensityGrid& g, const char* who) {
    std::size_t n = voxel_count(g.dims);  // throws for zero or overflowing dimensions
    if (g.values.size() != n)
        throw Error(std::string(who) + ": density grid holds " + std::to_string(g.values.size()) +
                    " values for " + std::to_string(n) + " voxels");
}

/// Difference along one axis at coordinate c of n, neighbours `stride` values apart.
inline float axis_difference(const float* d, std::uint32_t c, std::uint32_t n, std::size_t stride) {
    if (n < 2) return 0.0f;
    if (c == 0) return d[stride] - d[0];
    if (c == n - 1) return d[0] - d[-static_cast<std::ptrdiff_t>(stride)];
    return (d[stride] - d[-static_cast<std::ptrdiff_t>(stride)]) * 0.5f;
}

/// Gradient at (x, y, z) without argument checks.
inline vec3 gradient_unchecked(const DensityGrid& g, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    const float* d = g.values.data() + voxel_index(g.dims, x, y, z);
    std::size_t sy = g.dims.x, sz = std::size_t{g.dims.x} * g.dims.y;
    return vec3(axis_difference(d, x, g.dims.x, 1), axis_difference(d, y, g.dims.y, sy),
                axis_difference(d, z, g.dims.z, sz));
}

}  // namespace gradient_detail

/// Central-difference gradient of voxel (x, y, z) in density change per voxel (one-sided at
/// the borders, see the top of this header). Throws sylva::Error for an inconsistent grid or
/// a voxel outside it.
inline vec3 gradient_at(const DensityGrid& grid, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    gradient_detail::check_grid(grid, "volume::gradient_at");
    if (x >= grid.dims.x || y >= grid.dims.y || z >= grid.dims.z)
        throw Error("volume::gradient_at: voxel (" + std::to_string(x) + ", " + std::to_string(y) + ", " +
                    std::to_string(z) + ") is outside the grid");
    return gradient_detail::gradient_unchecked(grid, x, y, z);
}

/// Gradients of every voxel, in the grid's order (x fastest); z slices run in parallel on
/// `exec`. Throws sylva::Error for an empty or inconsistent grid.
template <Executor X>
std::vector<vec3> gradients(const DensityGrid& grid, X& exec) {
    gradient_detail::check_grid(grid, "volume::gradients");
    std::vector<vec3> out(grid.values.size());
    exec.parallel_for(0, grid.dims.z, 1, [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
            for (std::uint32_t y = 0; y < grid.dims.y; ++y)
                for (std::uint32_t x = 0; x < grid.dims.x; ++x)
                    out[voxel_index(grid.dims, x, y, static_cast<std::uint32_t>(z))] =
                        gradient_detail::gradient_unchecked(grid, x, y, static_cast<std::uint32_t>(z));
    });
    return out;
}

/// Gradients of every voxel, on the calling thread.
inline std::vector<vec3> gradients(const DensityGrid& grid) {
    SerialExecutor serial;
    return gradients(grid, serial);
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_GRADIENT_HPP
