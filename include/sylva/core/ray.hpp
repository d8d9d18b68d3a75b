// sylva/core/ray.hpp -- rays, parameter intervals and the reference ray-box test.
#ifndef SYLVA_CORE_RAY_HPP
#define SYLVA_CORE_RAY_HPP

#include <limits>
#include <optional>

#include "sylva/core/aabb.hpp"

namespace sylva {

/// The ray origin + t * direction. The direction need not be normalised; +-0 components are fine.
struct Ray {
    vec3 origin{0.0f};
    vec3 direction{0.0f, 0.0f, 1.0f};
    [[nodiscard]] vec3 at(float t) const { return origin + t * direction; }
};

/// A closed parameter interval [t0, t1]; empty when t0 > t1.
struct Interval {
    float t0 = 0.0f;
    float t1 = std::numeric_limits<float>::infinity();
    [[nodiscard]] bool empty() const { return t0 > t1; }
    friend bool operator==(const Interval&, const Interval&) = default;
};

/// Reference closed slab test, written independently of the shared iterator: the part of
/// `range` where the ray is inside `box`, or nothing. A direction component of +-0 means the
/// ray is parallel to that slab: inside for all t if the origin lies in it (boundary included).
[[nodiscard]] inline std::optional<Interval> clip(const Ray& ray, const Aabb& box, Interval range) {
    for (int a = 0; a < 3; ++a) {
        float o = ray.origin[a], d = ray.direction[a];
        if (d == 0.0f) {
            if (o < box.lo[a] || o > box.hi[a]) return std::nullopt;
            continue;
        }
        float ta = (box.lo[a] - o) / d, tb = (box.hi[a] - o) / d;
        if (ta > tb) std::swap(ta, tb);
        range.t0 = ta > range.t0 ? ta : range.t0;
        range.t1 = tb < range.t1 ? tb : range.t1;
    }
    if (range.empty()) return std::nullopt;
    return range;
}

}  // namespace sylva

#endif  // SYLVA_CORE_RAY_HPP
