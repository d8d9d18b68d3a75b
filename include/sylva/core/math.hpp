// sylva/core/math.hpp -- GLM, the force-inline macro and small numeric helpers.
#ifndef SYLVA_CORE_MATH_HPP
#define SYLVA_CORE_MATH_HPP

#include <cmath>
#include <glm/glm.hpp>

#if defined(__GNUC__) || defined(__clang__)
#define SYLVA_FORCEINLINE inline __attribute__((always_inline))
#else
#define SYLVA_FORCEINLINE inline
#endif

namespace sylva {
using glm::uvec2;
using glm::uvec3;
using glm::vec2;
using glm::vec3;
using glm::vec4;

/// Component `axis` (0, 1, 2) of a vector.
SYLVA_FORCEINLINE float component(const vec3& v, int axis) { return v[axis]; }

/// True when all three components are finite (neither NaN nor infinite).
SYLVA_FORCEINLINE bool all_finite(const vec3& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
}  // namespace sylva

#endif  // SYLVA_CORE_MATH_HPP
