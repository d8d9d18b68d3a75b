// 02_custom_element: an ellipsoid defined outside the library, checked against the library's
// brute-force reference, then rendered as particles — without changing the library.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>

namespace my {
/// An axis-aligned ellipsoid with semi-axes `radii`.
struct Ellipsoid {
    sylva::vec3 center, radii;
    sylva::Aabb bounds() const { return {center - radii, center + radii}; }
    /// The ray in the ellipsoid's unit-sphere space: solve |o' + t d'|^2 = 1.
    std::optional<sylva::Interval> intersect(const sylva::Ray& r, sylva::Interval range) const {
        sylva::vec3 o = (r.origin - center) / radii, d = r.direction / radii;
        float a = glm::dot(d, d), b = glm::dot(o, d), c = glm::dot(o, o) - 1.0f, disc = b * b - a * c;
        if (a == 0.0f || disc < 0.0f) return std::nullopt;
        float s = std::sqrt(disc);
        sylva::Interval t{std::max(range.t0, (-b - s) / a), std::min(range.t1, (-b + s) / a)};
        if (t.empty()) return std::nullopt;
        return t;
    }
};
static_assert(sylva::Intersectable<Ellipsoid>);
}  // namespace my

int main() {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<my::Ellipsoid> es;
    for (int i = 0; i < 5000; ++i) es.push_back({{u(rng), u(rng), u(rng)}, {0.02f + 0.03f * u(rng), 0.01f, 0.02f}});
    std::span<const my::Ellipsoid> elems(es);
    auto tree = sylva::bih::build(elems);
    auto words = sylva::bih::encode(tree, elems, sylva::bih::RangePayload{});
    int mismatches = 0, hits = 0;
    std::vector<sylva::bih::ElementHit> got;
    for (int i = 0; i < 2000; ++i) {  // the library's reference check, on a user type
        sylva::Ray r{{-0.5f, u(rng), u(rng)}, {1.0f, u(rng) - 0.5f, u(rng) - 0.5f}};
        sylva::bih::all_hits(words, tree, elems, r, got);
        auto want = sylva::bih::brute_force_hits(elems, r);
        mismatches += got != want;
        hits += static_cast<int>(want.size());
    }
    std::printf("%d ellipsoids, %zu nodes, depth %u: %d hits, %d mismatches against brute force\n",
                static_cast<int>(es.size()), tree.stats.nodes, tree.stats.max_depth, hits, mismatches);
    return mismatches == 0 && hits > 0 ? 0 : 1;
}
