// 03_octree_custom_element: a capsule defined outside the library, indexed by the element
// octree: build (octree::build_elements), encode, validate, then first hit and all hits in
// order (octree::first_hit, octree::all_hits) checked against brute force over every element.
// Any element with bounds() and intersect() works (sylva/core/concepts.hpp: Intersectable).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>
#include <span>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/octree/elements_validate.hpp>

namespace my {
/// A capsule: every point within `radius` of the segment [a, b] (a != b), with a constant
/// extinction coefficient (the octree ignores it; it is the user's data).
struct Capsule {
    sylva::vec3 a, b;
    float radius, sigma;
    sylva::Aabb bounds() const { return {glm::min(a, b) - radius, glm::max(a, b) + radius}; }

    /// The capsule is convex and is the union of two spheres and a finite cylinder, so the ray
    /// is inside it on one interval: from the least entry to the greatest exit of the three.
    std::optional<sylva::Interval> intersect(const sylva::Ray& r, sylva::Interval range) const {
        const float inf = std::numeric_limits<float>::infinity();
        sylva::Interval hull{inf, -inf};
        auto add = [&](float t0, float t1) {
            if (t0 <= t1) hull = {std::min(hull.t0, t0), std::max(hull.t1, t1)};
        };
        // |p + t q|^2 = r^2, for the end spheres (p = o - centre) and the cylinder (components
        // perpendicular to the axis).
        auto quadratic = [&](sylva::vec3 p, sylva::vec3 q, float& t0, float& t1) {
            float qq = glm::dot(q, q), pq = glm::dot(p, q), c = glm::dot(p, p) - radius * radius;
            if (qq == 0.0f) {  // parallel to the axis: inside for all t, or never
                t0 = -inf, t1 = inf;
                return c <= 0.0f;
            }
            float disc = pq * pq - qq * c;
            if (disc < 0.0f) return false;
            float s = std::sqrt(disc);
            t0 = (-pq - s) / qq, t1 = (-pq + s) / qq;
            return true;
        };
        float t0, t1;
        for (sylva::vec3 c : {a, b})
            if (quadratic(r.origin - c, r.direction, t0, t1)) add(t0, t1);
        sylva::vec3 axis = b - a;
        float len = glm::length(axis);
        sylva::vec3 u = axis / len, o = r.origin - a;
        float ou = glm::dot(o, u), du = glm::dot(r.direction, u);
        if (quadratic(o - ou * u, r.direction - du * u, t0, t1)) {
            if (du != 0.0f) {  // clip to the slab 0 <= (o + t d).u <= len
                float s0 = -ou / du, s1 = (len - ou) / du;
                add(std::max(t0, std::min(s0, s1)), std::min(t1, std::max(s0, s1)));
            } else if (ou >= 0.0f && ou <= len) {
                add(t0, t1);
            }
        }
        sylva::Interval t{std::max(range.t0, hull.t0), std::min(range.t1, hull.t1)};
        if (t.empty()) return std::nullopt;
        return t;
    }
};
static_assert(sylva::Intersectable<Capsule>);
}  // namespace my

int main() {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    auto point = [&] { return sylva::vec3(u(rng), u(rng), u(rng)); };
    std::vector<my::Capsule> caps;
    for (int i = 0; i < 10000; ++i) {
        sylva::vec3 a = point(), dir = glm::normalize(point() - 0.5f);
        caps.push_back({a, a + (0.005f + 0.03f * u(rng)) * dir, 0.002f + 0.006f * u(rng), 1.0f + 4.0f * u(rng)});
    }
    std::span<const my::Capsule> elems(caps);

    sylva::ThreadPool pool(2);
    sylva::octree::ElementTree et = sylva::octree::build_elements(elems, sylva::octree::ElementConfig{}, pool);
    std::vector<std::uint32_t> words = sylva::octree::encode_elements(et);
    sylva::octree::validate_elements(words, caps.size());  // throws sylva::Error on a bad index

    // Brute force: test every capsule, sort by (entry t, index) as the octree orders hits.
    auto brute_force = [&](const sylva::Ray& r) {
        std::vector<sylva::bih::ElementHit> hits;
        for (std::uint32_t e = 0; e < caps.size(); ++e)
            if (auto t = caps[e].intersect(r, {})) hits.push_back({e, *t});
        std::sort(hits.begin(), hits.end(), sylva::bih::hit_before);
        return hits;
    };

    int rays = 2000, mismatches = 0;
    std::size_t hits = 0;
    double depth = 0.0;  // optical depth summed over all rays, from the ordered hit lists
    std::vector<sylva::bih::ElementHit> got;
    for (int i = 0; i < rays; ++i) {  // from a sphere around the scene towards a point inside it
        sylva::vec3 target = point(), origin = 0.5f + 1.5f * glm::normalize(point() - 0.5f);
        sylva::Ray r{origin, target - origin};
        std::vector<sylva::bih::ElementHit> want = brute_force(r);
        sylva::octree::all_hits(words, elems, r, got);
        std::optional<sylva::bih::ElementHit> first = sylva::octree::first_hit(words, elems, r);
        bool ok = got == want && (want.empty() ? !first : first && *first == want.front());
        if (!ok && mismatches < 3)
            std::printf("ray %d: octree %zu hits, brute force %zu\n", i, got.size(), want.size());
        mismatches += !ok;
        hits += want.size();
        for (const auto& h : got) depth += caps[h.element].sigma * (h.t.t1 - h.t.t0) * glm::length(r.direction);
    }
    std::printf("%zu capsules: %zu nodes, %.2f references per capsule, %zu index words, built in %.1f ms\n",
                caps.size(), et.tree.nodes.size(), double(et.refs.size()) / double(caps.size()), words.size(), et.build_ms);
    std::printf("%d rays: %zu hits, mean optical depth %.3f, %d mismatches against brute force\n", rays, hits,
                depth / rays, mismatches);
    return mismatches == 0 && hits > 0 ? 0 : 1;
}
