// sylva/volume/resample.hpp -- trilinear reconstruction of a density grid, and supersampling
// by it (Kinkelin section 6.2: "by super-sampling the source grid (using trilinear filtering)
// and using the interpolated voxels as BIH elements, the visual quality can be greatly
// improved"; factors 1.5 for the engine, 1.5 and 2 for the aneurism, Tables 4 and 6).
//
// The reconstruction (the reference every renderer must match), for a world position p:
//   u   = p / spacing - 0.5                 continuous voxel index (voxel centres at integers)
//   u   = clamp(u, 0, dims - 1)             per axis: edge voxels repeat outside their centres
//   i0  = floor(u), i1 = min(i0 + 1, dims - 1), f = u - i0
//   lerp(a, b, f) = a + (b - a) * f, applied along z first (four times), then y (twice),
//   then x: the trilinear blend of the 8 voxels {i0, i1}^3 (NanoVDB's TrilinearSampler's order
//   and arithmetic; the renderers' sylva_grid_blend). (lerp, not GLSL's mix, which is
//   a * (1 - f) + b * f: lerp returns a exactly when a == b, so constant regions stay exact.)
// NaN or infinite positions are errors.
//
// Resampling by a factor k: the new grid covers the same world box [0, dims * spacing] with
// new_dims = round(dims * k) voxels per axis (half away from zero; at least 1), so its spacing
// is dims * spacing / new_dims (exactly spacing / k only when dims * k is whole). Each new voxel
// is the reconstruction above at its own centre, (j + 0.5) * new_spacing.
#ifndef SYLVA_VOLUME_RESAMPLE_HPP
#define SYLVA_VOLUME_RESAMPLE_HPP

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <new>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"

namespace sylva::volume {

namespace detail::resample {

/// One axis of a trilinear lookup: the two voxel indices and the weight of the second.
struct AxisWeights {
    std::uint32_t i0 = 0, i1 = 0;
    float f = 0.0f;
};

/// The lookup along one axis for world coordinate `world` (see the header comment).
inline AxisWeights axis_weights(float world, float spacing, std::uint32_t n) {
    float u = world / spacing - 0.5f;
    u = std::clamp(u, 0.0f, static_cast<float>(n - 1));
    AxisWeights w;
    w.i0 = static_cast<std::uint32_t>(u);  // u >= 0: truncation is floor
    w.i1 = std::min(w.i0 + 1u, n - 1u);
    w.f = u - static_cast<float>(w.i0);
    return w;
}

inline float lerp(float a, float b, float f) { return a + (b - a) * f; }

/// The trilinear blend of the 8 voxels named by the three axis lookups: z, then y, then x.
inline float trilinear(const DensityGrid& g, const AxisWeights& x, const AxisWeights& y, const AxisWeights& z) {
    float c00 = lerp(g.at(x.i0, y.i0, z.i0), g.at(x.i0, y.i0, z.i1), z.f);
    float c01 = lerp(g.at(x.i0, y.i1, z.i0), g.at(x.i0, y.i1, z.i1), z.f);
    float c10 = lerp(g.at(x.i1, y.i0, z.i0), g.at(x.i1, y.i0, z.i1), z.f);
    float c11 = lerp(g.at(x.i1, y.i1, z.i0), g.at(x.i1, y.i1, z.i1), z.f);
    return lerp(lerp(c00, c01, y.f), lerp(c10, c11, y.f), x.f);
}

/// Throws unless the grid's values match its dimensions and its spacing is finite and positive.
inline void check_grid(const DensityGrid& g, const char* what) {
    std::size_t n = voxel_count(g.dims);
    if (g.values.size() != n)
        throw Error(std::string(what) + ": density grid holds " + std::to_string(g.values.size()) + " values for " +
                    std::to_string(n) + " voxels");
    if (!all_finite(g.spacing) || !(g.spacing.x > 0.0f) || !(g.spacing.y > 0.0f) || !(g.spacing.z > 0.0f))
        throw Error(std::string(what) + ": spacing must be finite and positive");
}

}  // namespace detail::resample

/// The trilinear reconstruction of `grid` at world position `world` (exact rule at the top of
/// this header). Throws sylva::Error when `world` is NaN or infinite. Does not re-check the grid
/// (hot path): its values must match its dimensions.
inline float sample_trilinear(const DensityGrid& grid, vec3 world) {
    if (!all_finite(world)) throw Error("sample_trilinear: position is NaN or infinite");
    using namespace detail::resample;
    return trilinear(grid, axis_weights(world.x, grid.spacing.x, grid.dims.x),
                     axis_weights(world.y, grid.spacing.y, grid.dims.y),
                     axis_weights(world.z, grid.spacing.z, grid.dims.z));
}

/// Dimensions after resampling by `factor`: round(dims * factor) per axis (at least 1). Throws
/// sylva::Error when factor is not finite and positive or a dimension would not fit 32 bits.
inline Dims resampled_dims(Dims dims, float factor) {
    if (!std::isfinite(factor) || !(factor > 0.0f))
        throw Error("resample: factor " + std::to_string(factor) + " must be finite and positive");
    Dims out;
    for (int a = 0; a < 3; ++a) {
        double n = std::round(double(dims[a]) * double(factor));
        if (n > 4294967295.0)
            throw Error("resample: " + std::to_string(dims[a]) + " voxels times " + std::to_string(factor) +
                        " overflows a 32-bit dimension");
        out[a] = static_cast<std::uint32_t>(std::max(n, 1.0));
    }
    return out;
}

/// Supersamples (factor > 1) or subsamples `grid` by trilinear reconstruction (rules at the top
/// of this header), in parallel over z slices on `executor`. Throws sylva::Error for a factor
/// that is not finite and positive, for resulting dimensions that overflow, when the new grid
/// cannot be allocated, and for an inconsistent source grid.
template <Executor E>
DensityGrid resample_trilinear(const DensityGrid& grid, float factor, E& executor) {
    using namespace detail::resample;
    check_grid(grid, "resample");
    DensityGrid out;
    out.dims = resampled_dims(grid.dims, factor);
    std::size_t n = voxel_count(out.dims, sizeof(float));
    out.spacing = vec3(grid.dims) * grid.spacing / vec3(out.dims);
    try {
        out.values.resize(n);
    } catch (const std::bad_alloc&) {
        throw Error("resample: cannot allocate " + std::to_string(n) + " voxels");
    }
    std::vector<AxisWeights> axes[3];
    for (int a = 0; a < 3; ++a)
        for (std::uint32_t j = 0; j < out.dims[a]; ++j)
            axes[a].push_back(
                axis_weights((static_cast<float>(j) + 0.5f) * out.spacing[a], grid.spacing[a], grid.dims[a]));
    executor.parallel_for(0, out.dims.z, 1, [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z)
            for (std::uint32_t y = 0; y < out.dims.y; ++y) {
                float* row = &out.values[voxel_index(out.dims, 0, y, static_cast<std::uint32_t>(z))];
                for (std::uint32_t x = 0; x < out.dims.x; ++x)
                    row[x] = trilinear(grid, axes[0][x], axes[1][y], axes[2][z]);
            }
    });
    return out;
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_RESAMPLE_HPP
