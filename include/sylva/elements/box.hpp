// sylva/elements/box.hpp -- a plain axis-aligned box element (solid, opaque-free): the simplest
// Intersectable, used by tests and as a template for user types.
#ifndef SYLVA_ELEMENTS_BOX_HPP
#define SYLVA_ELEMENTS_BOX_HPP

#include "sylva/core/concepts.hpp"

namespace sylva {

struct BoxElement {
    Aabb box;
    [[nodiscard]] Aabb bounds() const { return box; }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& ray, Interval range) const {
        return clip(ray, box, range);
    }
};

}  // namespace sylva

#endif  // SYLVA_ELEMENTS_BOX_HPP
