// sylva/volume/grid.hpp -- uniform grids: typed views over voxel data, an owning typed volume,
// and the normalised density grid every classifier, builder and renderer reads.
//
// Conventions, shared by every volume stage:
//  * Voxel (x, y, z) is stored at index x + X * (y + Y * z) (x fastest), as in ../shared/data.
//  * Voxels are cells: voxel (x, y, z) covers the world box [v * spacing, (v + 1) * spacing]
//    with v = (x, y, z), so its centre is (v + 0.5) * spacing and the whole grid covers
//    [0, dims * spacing]. Trilinear reconstruction interpolates between voxel centres and
//    clamps to the edge voxels outside them.
//  * Normalised density is in [0, 1]: clamp((value - lo) / (hi - lo), 0, 1) over the volume's
//    value range [range_lo, range_hi], the division as written (uint8 over 0..255 is exactly
//    v / 255). The readers choose it (sylva/volume/value_range.hpp):
//    by default the file's stated range or the data's min/max.
#ifndef SYLVA_VOLUME_GRID_HPP
#define SYLVA_VOLUME_GRID_HPP

#include <bit>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/aabb.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/math.hpp"

namespace sylva::volume {

/// The voxel scalar types a volume may hold.
enum class ScalarType : std::uint8_t { U8, U16, F32 };

/// Bytes per voxel of a scalar type.
constexpr std::size_t scalar_bytes(ScalarType t) { return t == ScalarType::U8 ? 1u : (t == ScalarType::U16 ? 2u : 4u); }

/// The name used in file names and messages: "uint8", "uint16", "float32".
inline const char* scalar_name(ScalarType t) {
    return t == ScalarType::U8 ? "uint8" : (t == ScalarType::U16 ? "uint16" : "float32");
}

/// A voxel type a GridView can hold.
template <class T>
concept VoxelScalar = std::same_as<T, std::uint8_t> || std::same_as<T, std::uint16_t> || std::same_as<T, float>;

/// Grid dimensions in voxels, each >= 1.
using Dims = glm::u32vec3;

/// Number of voxels of `dims`; throws sylva::Error when a dimension is 0 or the product (or
/// the byte count for `bytes_per_voxel`) does not fit in size_t.
inline std::size_t voxel_count(Dims dims, std::size_t bytes_per_voxel = 1) {
    if (dims.x == 0 || dims.y == 0 || dims.z == 0)
        throw Error("volume: dimensions " + std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" +
                    std::to_string(dims.z) + " have a zero extent");
    std::size_t n = bytes_per_voxel;
    for (std::uint32_t d : {dims.x, dims.y, dims.z}) {
        if (n > std::numeric_limits<std::size_t>::max() / d)
            throw Error("volume: dimensions " + std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" +
                        std::to_string(dims.z) + " overflow the addressable size");
        n *= d;
    }
    return n / bytes_per_voxel;
}

/// Linear index of voxel (x, y, z).
inline std::size_t voxel_index(Dims dims, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return std::size_t{x} + std::size_t{dims.x} * (std::size_t{y} + std::size_t{dims.y} * std::size_t{z});
}

/// A non-owning typed view over voxel data with its spacing (world size of one voxel).
template <VoxelScalar T>
struct GridView {
    std::span<const T> data;
    Dims dims{0};
    vec3 spacing{1.0f};

    [[nodiscard]] T at(std::uint32_t x, std::uint32_t y, std::uint32_t z) const { return data[voxel_index(dims, x, y, z)]; }
    [[nodiscard]] std::size_t size() const { return data.size(); }
    /// World box of the whole grid: [0, dims * spacing].
    [[nodiscard]] Aabb world_box() const { return Aabb{vec3(0.0f), vec3(dims) * spacing}; }
};

/// Where the value range a volume is normalised with came from (sylva/volume/value_range.hpp).
enum class RangeSource : std::uint8_t {
    Type,      ///< the scalar type's full range (uint8 0..255, uint16 0..65535)
    Data,      ///< the data's min and max
    Stated,    ///< the file's own range (NRRD min:/max:)
    Explicit,  ///< given by the caller
    Constant,  ///< a constant volume's one value v widened to [min(v, 0), max(v, 0)] ([0, 1] for v = 0)
};

// Volume::bytes hold the voxels in the files' little-endian order (raw and NRRD readers; NRRD
// big-endian data are swapped to it) and are read in host order: value() copies them out with
// std::memcpy, and view() reinterprets them as T, which C++20 allows because allocating the
// std::byte array implicitly creates the uint16/float objects in it ([intro.object]/13) and the
// allocation is aligned for them. Host order equals file order only on little-endian hosts.
static_assert(std::endian::native == std::endian::little,
              "sylva::volume: voxel bytes are little-endian (the raw/NRRD file layout and what the GPU reads) and "
              "are read in host byte order; big-endian hosts are not supported");

/// An owning volume of one scalar type, as read from a file or generated.
struct Volume {
    ScalarType type = ScalarType::U8;
    Dims dims{0};
    vec3 spacing{1.0f};
    /// Raw little-endian voxel bytes, voxel_count(dims) * scalar_bytes(type) of them.
    std::vector<std::byte> bytes;
    /// Value range that maps to normalised density [0, 1], and where it came from. The readers
    /// set it with volume::apply_value_range (by default the stated range, else the data's
    /// min/max); a Volume built by hand starts with uint8's 0..255.
    float range_lo = 0.0f;
    float range_hi = 255.0f;
    RangeSource range_source = RangeSource::Type;
    /// The range the file states for its values (NRRD `min:` / `max:`), when it states one.
    std::optional<std::pair<float, float>> stated_range{};

    [[nodiscard]] std::size_t voxels() const { return bytes.size() / scalar_bytes(type); }

    /// Typed view; throws sylva::Error when T is not the stored type.
    template <VoxelScalar T>
    [[nodiscard]] GridView<T> view() const {
        constexpr ScalarType want = std::same_as<T, std::uint8_t>    ? ScalarType::U8
                                    : std::same_as<T, std::uint16_t> ? ScalarType::U16
                                                                     : ScalarType::F32;
        if (type != want)
            throw Error(std::string("volume: asked for a ") + scalar_name(want) + " view of a " + scalar_name(type) +
                        " volume");
        return GridView<T>{std::span<const T>(reinterpret_cast<const T*>(bytes.data()), voxels()), dims, spacing};
    }

    /// Raw value of voxel i as float.
    [[nodiscard]] float value(std::size_t i) const {
        switch (type) {
            case ScalarType::U8: return static_cast<float>(std::to_integer<std::uint8_t>(bytes[i]));
            case ScalarType::U16: {
                std::uint16_t v;
                std::memcpy(&v, &bytes[2 * i], 2);
                return static_cast<float>(v);
            }
            default: {
                float v;
                std::memcpy(&v, &bytes[4 * i], 4);
                return v;
            }
        }
    }
};

/// Normalised densities in [0, 1] over a grid of cells (the conventions above). This is what
/// classification, gradients, resampling, the voxel-cuboid source and the renderers read.
struct DensityGrid {
    Dims dims{0};
    vec3 spacing{1.0f};
    std::vector<float> values;

    [[nodiscard]] float at(std::uint32_t x, std::uint32_t y, std::uint32_t z) const { return values[voxel_index(dims, x, y, z)]; }
    /// Value at integer coordinates clamped to the grid (edge voxels repeat outside).
    [[nodiscard]] float clamped(std::int64_t x, std::int64_t y, std::int64_t z) const {
        auto c = [](std::int64_t v, std::uint32_t n) {
            return static_cast<std::uint32_t>(v < 0 ? 0 : (v >= std::int64_t{n} ? std::int64_t{n} - 1 : v));
        };
        return at(c(x, dims.x), c(y, dims.y), c(z, dims.z));
    }
    /// World box of the whole grid: [0, dims * spacing].
    [[nodiscard]] Aabb world_box() const { return Aabb{vec3(0.0f), vec3(dims) * spacing}; }
    /// World box of voxel (x, y, z).
    [[nodiscard]] Aabb voxel_box(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
        vec3 v(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
        return Aabb{v * spacing, (v + 1.0f) * spacing};
    }
    [[nodiscard]] GridView<float> view() const { return GridView<float>{values, dims, spacing}; }
};

/// Normalises a volume into densities in [0, 1] (see the conventions above). Throws
/// sylva::Error naming the first voxel when a float32 volume holds NaN or infinity, or when the
/// byte count does not match the dimensions.
inline DensityGrid normalize(const Volume& v) {
    std::size_t n = voxel_count(v.dims, scalar_bytes(v.type));
    if (v.bytes.size() != n * scalar_bytes(v.type))
        throw Error("volume: " + std::to_string(v.bytes.size()) + " bytes do not match " + std::to_string(n) + " " +
                    scalar_name(v.type) + " voxels");
    DensityGrid g{v.dims, v.spacing, std::vector<float>(n)};
    float lo = v.range_lo, span = v.range_hi - v.range_lo;
    for (std::size_t i = 0; i < n; ++i) {
        float x = v.value(i);
        if (!std::isfinite(x)) throw Error("volume: voxel " + std::to_string(i) + " is not a finite number");
        g.values[i] = span > 0.0f ? glm::clamp((x - lo) / span, 0.0f, 1.0f) : 0.0f;
    }
    return g;
}

/// Sets every density below `threshold` to 0 (values >= threshold stay as they are): the
/// "below threshold is empty" cut of a segmentation, which a border of constant 0 continues.
/// Returns how many voxels it zeroed. Throws sylva::Error for a non-finite threshold.
inline std::size_t threshold_to_zero(DensityGrid& g, float threshold) {
    if (!std::isfinite(threshold)) throw Error("volume: the threshold is not finite");
    std::size_t zeroed = 0;
    for (float& v : g.values)
        if (v < threshold && v != 0.0f) {
            v = 0.0f;
            ++zeroed;
        }
    return zeroed;
}

/// The same cut on raw voxel values of a volume of any type: every voxel whose raw value is
/// below `raw_threshold` becomes 0 (a raw 0, which is density 0 when range_lo is 0). Returns
/// how many voxels it changed. Throws sylva::Error for a non-finite threshold or a byte count
/// that does not match the dimensions.
inline std::size_t threshold_to_zero(Volume& v, float raw_threshold) {
    if (!std::isfinite(raw_threshold)) throw Error("volume: the threshold is not finite");
    std::size_t bytes = scalar_bytes(v.type), n = voxel_count(v.dims, bytes);
    if (v.bytes.size() != n * bytes)
        throw Error("volume: " + std::to_string(v.bytes.size()) + " bytes do not match " + std::to_string(n) + " " +
                    scalar_name(v.type) + " voxels");
    std::size_t zeroed = 0;
    for (std::size_t i = 0; i < n; ++i) {
        float x = v.value(i);
        if (x < raw_threshold && x != 0.0f) {
            std::memset(&v.bytes[i * bytes], 0, bytes);
            ++zeroed;
        }
    }
    return zeroed;
}

}  // namespace sylva::volume

#endif  // SYLVA_VOLUME_GRID_HPP
