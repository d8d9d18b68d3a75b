// sylva/core/aabb.hpp -- axis-aligned boxes.
#ifndef SYLVA_CORE_AABB_HPP
#define SYLVA_CORE_AABB_HPP

#include <limits>

#include "sylva/core/math.hpp"

namespace sylva {

/// A closed axis-aligned box [lo, hi]. The default box is empty (lo > hi) and absorbs any
/// box it is extended by. A box with lo == hi on an axis is flat there and still valid.
struct Aabb {
    vec3 lo{std::numeric_limits<float>::infinity()};
    vec3 hi{-std::numeric_limits<float>::infinity()};

    /// True when the box contains no point.
    [[nodiscard]] bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    /// True when both corners are finite numbers.
    [[nodiscard]] bool finite() const { return all_finite(lo) && all_finite(hi); }
    [[nodiscard]] vec3 extent() const { return hi - lo; }
    [[nodiscard]] vec3 center() const { return (lo + hi) * 0.5f; }
    /// Index of the longest axis (the first of equals).
    [[nodiscard]] int longest_axis() const {
        vec3 e = extent();
        return (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    }
    [[nodiscard]] float volume() const {
        vec3 e = extent();
        return empty() ? 0.0f : e.x * e.y * e.z;
    }
    /// Half the surface area (0 for an empty box): the surface-area heuristic's measure.
    [[nodiscard]] float half_area() const {
        vec3 e = glm::max(extent(), vec3(0.0f));
        return e.x * e.y + e.y * e.z + e.z * e.x;
    }
    void extend(const Aabb& b) {
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    void extend(const vec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    [[nodiscard]] bool contains(const Aabb& b) const {
        return glm::all(glm::lessThanEqual(lo, b.lo)) && glm::all(glm::greaterThanEqual(hi, b.hi));
    }
    friend bool operator==(const Aabb&, const Aabb&) = default;
};

}  // namespace sylva

#endif  // SYLVA_CORE_AABB_HPP
