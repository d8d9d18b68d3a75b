// sylva/volume/classify.hpp -- which voxels matter: a classifier says, for a normalised density,
// whether the voxel becomes an element of a spatial index (Kinkelin section 6.1: "all voxels
// with a configurable minimum normalized density value (usually 0.1 to remove most of the
// noise)"), or, under a transfer function, whether it is visible at all.
#ifndef SYLVA_VOLUME_CLASSIFY_HPP
#define SYLVA_VOLUME_CLASSIFY_HPP

#include <concepts>
#include <cstddef>
#include <string>

#include "sylva/core/error.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/transfer_function.hpp"

namespace sylva::volume {

/// A callable `bool(float normalised_density)`: true when a voxel of that density matters.
/// Classifiers are small values, copied freely and called concurrently (const, no state).
template <class C>
concept VoxelClassifier = std::copy_constructible<C> && requires(const C& c, float density) {
    { c(density) } -> std::convertible_to<bool>;
};

/// Voxels with normalised density >= min_density.
struct DensityThreshold {
    /// Kinkelin section 6.1 and Tables 3 and 6: voxels with normalised density >= 0.1 are the
    /// BIH elements (341,256 in lobster, 1,352,439 in engine, 113,453 in the 256^3 aneurism).
    float min_density = 0.1f;
    [[nodiscard]] bool operator()(float density) const { return density >= min_density; }
};

/// Voxels a transfer function does not make fully transparent: TransferFunction::at(d).a >
/// min_alpha (the interpolated table lookup, as the renderers see it). Holds its own copy of
/// the function.
///
/// Rounding: a density that is a table position only up to float rounding picks up a sliver of
/// its neighbour entry. With 256 entries, uint8 value 25 gives d = 25 / 255 and the lookup
/// x = d * 255 lands a few 1e-6 above entry 25, so a function that is transparent up to 0.1 and
/// rises after it still gives that voxel an alpha of about 1e-9. With min_alpha = 0 (alpha > 0,
/// the default) such voxels count; pass a small min_alpha (1e-6 is plenty) to drop them.
class TransferFunctionAlpha {
public:
    explicit TransferFunctionAlpha(TransferFunction tf, float min_alpha = 0.0f)
        : tf_(std::move(tf)), min_alpha_(min_alpha) {
        if (!(min_alpha >= 0.0f && min_alpha < 1.0f))
            throw Error("TransferFunctionAlpha: min_alpha " + std::to_string(min_alpha) + " is not in [0, 1)");
    }
    [[nodiscard]] bool operator()(float density) const { return tf_.at(density).a > min_alpha_; }
    [[nodiscard]] const TransferFunction& transfer_function() const { return tf_; }
    [[nodiscard]] float min_alpha() const { return min_alpha_; }

private:
    TransferFunction tf_;
    float min_alpha_ = 0.0f;
};

static_assert(VoxelClassifier<DensityThreshold>);
static_assert(VoxelClassifier<TransferFunctionAlpha>);

/// Number of voxels of `grid` that `classify` accepts. Throws sylva::Error when the grid's
/// value count does not match its dimensions.
template <VoxelClassifier C>
std::size_t count_classified(const DensityGrid& grid, const C& classify) {
    std::size_t n = voxel_count(grid.dims);
    if (grid.values.size() != n)
        throw Error("classify: density grid holds " + std::to_string(grid.values.size()) + " values for " +
                    std::to_string(n) + " voxels");
    std::size_t count = 0;
    for (float d : grid.values) count += classify(d) ? 1u : 0u;
    return count;
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_CLASSIFY_HPP
