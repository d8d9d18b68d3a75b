// sylva/elements/voxel.hpp -- voxel cuboids (Kinkelin section 4.3): a box carrying the
// normalised density at its centre and the per-voxel gradient, and the payload encoder that
// packs them into a BIH leaf (14-bit density + 3 x 16-bit gradient, Table 1; the bit layout is
// documented in sylva/shared/voxel.h).
#ifndef SYLVA_ELEMENTS_VOXEL_HPP
#define SYLVA_ELEMENTS_VOXEL_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>

#include "sylva/core/aabb.hpp"
#include "sylva/shared/bih_layout.h"
#include "sylva/shared/voxel.h"

namespace sylva {

/// One voxel (or a merged block of voxels) as a BIH element.
struct VoxelCuboid {
    Aabb box;                  ///< world box of the cuboid
    float density = 0.0f;      ///< normalised density at the centre, in [0, 1]
    vec3 gradient{0.0f};       ///< change of density across one voxel along x, y, z
    [[nodiscard]] Aabb bounds() const { return box; }
};

/// 14-bit unsigned fixed point of a density in [0, 1] (clamped; NaN becomes 0).
inline std::uint32_t quantize_density14(float d) {
    if (!(d > 0.0f)) return 0u;
    return static_cast<std::uint32_t>(std::lround(std::min(d, 1.0f) * float(SYLVA_VOXEL_DENSITY_MAX)));
}

/// 16-bit two's-complement fixed point of a gradient component in [-1, 1] (clamped; NaN is 0).
inline std::uint32_t quantize_gradient16(float g) {
    if (!(g == g)) return 0u;
    long q = std::lround(std::clamp(g, -1.0f, 1.0f) * float(SYLVA_VOXEL_GRADIENT_MAX));
    return static_cast<std::uint32_t>(q) & 0xFFFFu;
}

/// Packs density and gradient into the 62-bit SYLVA_PAYLOAD_VOXEL layout.
inline std::uint64_t pack_voxel(float density, vec3 gradient) {
    return std::uint64_t{quantize_density14(density)} | (std::uint64_t{quantize_gradient16(gradient.x)} << 14) |
           (std::uint64_t{quantize_gradient16(gradient.y)} << 30) | (std::uint64_t{quantize_gradient16(gradient.z)} << 46);
}

/// Payload encoder for voxel leaves. A leaf holding several cuboids (a depth-capped leaf)
/// stores their volume-weighted mean density and gradient.
struct VoxelPayload {
    static constexpr std::uint32_t kind = SYLVA_PAYLOAD_VOXEL;
    [[nodiscard]] std::uint64_t encode(std::span<const VoxelCuboid> leaf, std::uint32_t) const {
        double w = 0.0, d = 0.0;
        glm::dvec3 g(0.0);
        for (const VoxelCuboid& v : leaf) {
            double vol = std::max(double(v.box.volume()), 1e-30);
            w += vol;
            d += vol * v.density;
            g += vol * glm::dvec3(v.gradient);
        }
        if (w <= 0.0) return 0u;
        return pack_voxel(float(d / w), vec3(g / w));
    }
};

}  // namespace sylva

#endif  // SYLVA_ELEMENTS_VOXEL_HPP
