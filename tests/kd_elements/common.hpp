// Helpers for the element kd-tree and refit tests: a user element the library does not ship
// (a capsule: segment, radius), element sets, and brute-force references over all elements.
#ifndef SYLVA_TESTS_KD_ELEMENTS_COMMON_HPP
#define SYLVA_TESTS_KD_ELEMENTS_COMMON_HPP

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include <sylva/bih/query.hpp>
#include <sylva/core/concepts.hpp>
#include <sylva/elements/rbf.hpp>
#include <sylva/elements/sphere.hpp>

#include "../unit/generators.hpp"

namespace kde_test {

using namespace sylva;

/// A capsule: the points within `radius` of the segment [a, b]. Convex, so the ray's interval
/// is the hull of its intervals in the two end spheres and the finite cylinder.
struct Capsule {
    vec3 a, b;
    float radius;
    [[nodiscard]] Aabb bounds() const { return {glm::min(a, b) - vec3(radius), glm::max(a, b) + vec3(radius)}; }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& ray, Interval range) const {
        float lo = INFINITY, hi = -INFINITY;
        auto take = [&](float t0, float t1) {
            lo = std::min(lo, t0);
            hi = std::max(hi, t1);
        };
        for (vec3 c : {a, b}) {  // end spheres
            vec3 oc = ray.origin - c;
            float A = glm::dot(ray.direction, ray.direction), B = glm::dot(oc, ray.direction);
            float C = glm::dot(oc, oc) - radius * radius, disc = B * B - A * C;
            if (A > 0.0f && disc >= 0.0f) take((-B - std::sqrt(disc)) / A, (-B + std::sqrt(disc)) / A);
        }
        vec3 ax = b - a;
        float len = glm::length(ax);
        if (len > 0.0f) {  // the cylinder between the end planes
            vec3 u = ax / len, oa = ray.origin - a;
            vec3 dp = ray.direction - glm::dot(ray.direction, u) * u, op = oa - glm::dot(oa, u) * u;
            float A = glm::dot(dp, dp), B = glm::dot(op, dp), C = glm::dot(op, op) - radius * radius;
            float disc = B * B - A * C;
            if (A > 1e-12f && disc >= 0.0f) {
                for (float t : {(-B - std::sqrt(disc)) / A, (-B + std::sqrt(disc)) / A}) {
                    float s = glm::dot(oa + t * ray.direction, u);
                    if (s >= 0.0f && s <= len) take(t, t);
                }
            }
        }
        float t0 = std::max(lo, range.t0), t1 = std::min(hi, range.t1);
        if (!(t0 <= t1)) return std::nullopt;
        return Interval{t0, t1};
    }
};

inline std::vector<Capsule> random_capsules(std::size_t n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), l(-0.08f, 0.08f), r(0.004f, 0.03f);
    std::vector<Capsule> out(n);
    for (auto& c : out) {
        vec3 p(u(rng), u(rng), u(rng));
        c = {p, p + vec3(l(rng), l(rng), l(rng)), r(rng)};
    }
    return out;
}

inline std::vector<GaussianRbf> random_rbfs(std::size_t n, std::uint32_t seed) {
    std::vector<GaussianRbf> out;
    for (const Sphere& p : testing::random_spheres(n, seed)) out.push_back({p.center, p.radius / 3.0f, 3.0f, p.rgba});
    return out;
}

/// Spheres in a few tight clusters (overlapping, unequal sizes).
inline std::vector<Sphere> clustered_spheres(std::size_t n, std::uint32_t seed) {
    std::vector<Sphere> out;
    for (const auto& b : testing::clustered_boxes(n, seed))
        out.push_back({b.box.center(), 0.5f * b.box.extent().x + 0.01f, vec4(0.8f, 0.6f, 0.3f, 0.4f), 2.0f});
    return out;
}

template <class E>
Aabb scene_of(const std::vector<E>& es) {
    Aabb s;
    for (const E& e : es) s.extend(bounds_of(e));
    return s;
}

/// Brute force: every element the ray hits, in (entry t, index) order.
template <class E>
std::vector<bih::ElementHit> brute_all(const std::vector<E>& es, const Ray& r, Interval range = {}) {
    std::vector<bih::ElementHit> out;
    for (std::uint32_t i = 0; i < es.size(); ++i)
        if (auto t = intersect_element(es[i], r, range)) out.push_back({i, *t});
    std::sort(out.begin(), out.end(), bih::hit_before);
    return out;
}

template <class E>
std::optional<bih::ElementHit> brute_first(const std::vector<E>& es, const Ray& r, Interval range = {}) {
    auto all = brute_all(es, r, range);
    if (all.empty()) return std::nullopt;
    return all.front();
}

/// Deterministic motion: element i moves along its own direction by `step` per frame.
inline Sphere moved(const Sphere& s, std::uint32_t i, float step) {
    Sphere m = s;
    float a = float(i) * 2.399963f;
    m.center += step * vec3(std::cos(a), std::sin(a), std::cos(1.7f * a));
    return m;
}

}  // namespace kde_test

#endif
