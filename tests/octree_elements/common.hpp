// Helpers for the element octree tests: element sets (tests/unit/generators.hpp), and the
// builds every test runs over.
#ifndef SYLVA_TESTS_OCTREE_ELEMENTS_COMMON_HPP
#define SYLVA_TESTS_OCTREE_ELEMENTS_COMMON_HPP

#include <sylva/core/executor.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>

#include "../unit/generators.hpp"

namespace octe_test {

/// The configurations the tests build with: the defaults, small leaves with a shallow cap, and
/// deep narrow leaves with a tight growth bound.
inline std::vector<sylva::octree::ElementConfig> configs() {
    sylva::octree::ElementConfig def, shallow, deep;
    shallow.leaf_elements = 2;
    shallow.max_depth = 5;
    deep.leaf_elements = 1;
    deep.max_growth = 2.0f;
    return {def, shallow, deep};
}

/// Spheres in a few tight Gaussian clusters (overlapping, unequal sizes).
inline std::vector<sylva::Sphere> clustered_spheres(std::size_t n, std::uint32_t seed) {
    std::vector<sylva::Sphere> out;
    for (const auto& b : sylva::testing::clustered_boxes(n, seed))
        out.push_back({b.box.center(), 0.5f * b.box.extent().x + 0.01f, sylva::vec4(0.8f, 0.6f, 0.3f, 0.4f), 2.0f});
    return out;
}

/// Bounds of a set.
template <class E>
sylva::Aabb scene_of(const std::vector<E>& es) {
    sylva::Aabb s;
    for (const E& e : es) s.extend(sylva::bounds_of(e));
    return s;
}

}  // namespace octe_test

#endif
