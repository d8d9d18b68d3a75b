// Scenes and brute-force references for the generic element kernels (tests/elements_gpu).
#ifndef SYLVA_TESTS_ELEMENTS_GPU_SCENES_HPP
#define SYLVA_TESTS_ELEMENTS_GPU_SCENES_HPP

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>
#include <span>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/elements/rbf.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/render/elements.hpp>

#include "capsule.h"

namespace elements_gpu {
using namespace sylva;

/// n capsules in the unit cube, lengths up to `len`, radii up to `rad`: they overlap a lot.
inline std::vector<demo::Capsule> capsules(std::size_t n, std::uint32_t seed, float len = 0.25f, float rad = 0.06f) {
    std::mt19937 g(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), s(-1.0f, 1.0f);
    std::vector<demo::Capsule> out(n);
    for (auto& c : out) {
        c.a = vec3(u(g), u(g), u(g));
        c.b = c.a + len * vec3(s(g), s(g), s(g));
        c.radius = 0.005f + rad * u(g);
        c.extinction = 2.0f + 30.0f * u(g);
        c.rgb = vec3(u(g), u(g), u(g));
    }
    return out;
}

inline std::vector<Sphere> spheres(std::size_t n, std::uint32_t seed) {
    std::mt19937 g(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Sphere> out(n);
    for (auto& p : out) p = Sphere{vec3(u(g), u(g), u(g)), 0.01f + 0.06f * u(g), vec4(u(g), u(g), u(g), 0.2f + 0.8f * u(g)), 1.0f + 2.0f * u(g)};
    return out;
}

inline std::vector<GaussianRbf> rbfs(std::size_t n, std::uint32_t seed) {
    std::mt19937 g(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<GaussianRbf> out(n);
    for (auto& p : out) p = GaussianRbf{vec3(u(g), u(g), u(g)), 0.005f + 0.02f * u(g), 2.0f + u(g), vec4(u(g), u(g), u(g), 0.3f + 0.7f * u(g))};
    return out;
}

/// Rays from outside, from inside the cube, axis-parallel ones and clipped ranges.
inline void rays(std::size_t n, std::uint32_t seed, std::vector<Ray>& out, std::vector<Interval>& ranges) {
    std::mt19937 g(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), s(-1.0f, 1.0f);
    for (std::size_t i = 0; i < n; ++i) {
        vec3 o, d;
        Interval r{};
        switch (i % 4) {
            case 0: o = vec3(0.5f) + 1.5f * glm::normalize(vec3(s(g), s(g), s(g))); d = vec3(u(g), u(g), u(g)) - o; break;
            case 1: o = vec3(u(g), u(g), u(g)); d = vec3(s(g), s(g), s(g)); break;
            case 2: o = vec3(-0.5f, u(g), u(g)); d = vec3(1.0f, 0.0f, 0.0f); break;  // parallel to two axes
            default:
                o = vec3(u(g), u(g), -0.5f); d = vec3(0.1f * s(g), 0.1f * s(g), 1.0f);
                r = Interval{0.4f + 0.3f * u(g), 1.0f + 0.5f * u(g)};
        }
        out.push_back({o, d});
        ranges.push_back(r);
    }
}

/// A BIH of record ranges over `elems` and their records in the tree's order.
template <class E>
struct Scene {
    std::vector<E> elems;
    std::vector<std::uint32_t> words, records;
    explicit Scene(std::vector<E> e, bih::Config cfg = {}) : elems(std::move(e)) {
        std::span<const E> es(elems);
        bih::Tree t = bih::build(es, cfg);
        words = bih::encode(t, es, bih::RangePayload{});
        records = pack_elements(es, std::span<const std::uint32_t>(t.order.data(), t.order.size()));
    }
    [[nodiscard]] std::uint32_t count() const { return static_cast<std::uint32_t>(elems.size()); }
};

/// A kd-tree (K = KdIndex) or an octree (K = OctreeIndex) over `elems`; records in their order.
template <class E, class K>
struct IndexScene {
    std::vector<E> elems;
    std::vector<std::uint32_t> words, records;
    explicit IndexScene(std::vector<E> e) : elems(std::move(e)) {
        std::span<const E> es(elems);
        if constexpr (std::is_same_v<K, KdIndex>) words = kdtree::encode_elements(kdtree::build_elements(es));
        else words = octree::encode_elements(octree::build_elements(es));
        records = pack_elements(es);
    }
    [[nodiscard]] std::uint32_t count() const { return static_cast<std::uint32_t>(elems.size()); }
};

/// Brute force over all records: every hit of the ray, sorted by (t0, record index).
template <class E>
std::vector<shared::SylvaHit> brute_hits(std::span<const std::uint32_t> records, std::uint32_t count, const Ray& r,
                                         Interval range) {
    shared::Words w{records.data(), records.size()};
    std::vector<shared::SylvaHit> out;
    for (std::uint32_t e = 0; e < count; ++e) {
        E x{};
        sylva_elem_load(w, e, x);
        if (auto t = intersect_element(x, r, range)) out.push_back({e, t->t0, t->t1});
    }
    std::sort(out.begin(), out.end(), [](const shared::SylvaHit& a, const shared::SylvaHit& b) {
        return a.t0 < b.t0 || (a.t0 == b.t0 && a.elem < b.elem);
    });
    return out;
}

/// Brute force compositing: the sorted hits, each element's interact_element over its own
/// interval, composited front to back with opacity Contribution::alpha().
template <class E>
vec4 brute_composite(std::span<const std::uint32_t> records, std::uint32_t count, const Ray& r, float stop) {
    shared::Words w{records.data(), records.size()};
    vec3 rgb(0.0f);
    float alpha = 0.0f;
    for (const auto& h : brute_hits<E>(records, count, r, Interval{0.0f, shared::sylva_inf()})) {
        if (!(alpha < stop)) break;
        E x{};
        sylva_elem_load(w, h.elem, x);
        auto c = interact_element(x, r, Interval{h.t0, h.t1});
        if (!c) continue;
        float k = (1.0f - alpha) * c->alpha();
        rgb += k * c->rgb;
        alpha += k;
    }
    return vec4(rgb, alpha);
}

inline bool same_hits(const std::vector<shared::SylvaHit>& a, const std::vector<shared::SylvaHit>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (a[i].elem != b[i].elem || std::memcmp(&a[i].t0, &b[i].t0, 4) != 0 || std::memcmp(&a[i].t1, &b[i].t1, 4) != 0)
            return false;
    return true;
}

inline CameraFrame view(std::uint32_t w, std::uint32_t h) {
    Camera cam;
    cam.eye = vec3(1.9f, 1.4f, 2.3f);
    cam.target = vec3(0.5f);
    return cam.frame(w, h);
}

}  // namespace elements_gpu

#endif
