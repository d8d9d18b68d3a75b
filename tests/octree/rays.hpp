// Rays for the octree walk tests: through the volume from outside, starting inside, along node
// faces and edges (axis-parallel, on node planes), through node corners (diagonals from lattice
// points), with zero and negative-zero direction components, on the volume's own faces, and
// with short t ranges.
#ifndef SYLVA_TESTS_OCTREE_RAYS_HPP
#define SYLVA_TESTS_OCTREE_RAYS_HPP

#include <cstdint>
#include <random>
#include <vector>

#include <sylva/octree/build.hpp>

namespace octree_test {

struct TestRay {
    sylva::vec3 o, d;
    float t0, t1;
};

/// `count` rays of every kind over `t`'s volume, in world space (spacing applied).
inline std::vector<TestRay> test_rays(const sylva::octree::Tree& t, std::uint32_t count, std::uint32_t seed) {
    using sylva::vec3;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), s(-1.0f, 1.0f);
    vec3 dims(t.dims);
    auto pick = [&](std::uint32_t n) { return std::uint32_t(u(rng) * float(n)) % n; };
    // A plane coordinate along axis a: a multiple of some level's width (0 and dims included).
    auto plane = [&](int a) {
        std::uint32_t w = t.width(pick(t.levels));
        std::uint32_t k = pick(t.dims[a] / w + 2);
        return std::min(float(k * w), dims[a]);
    };
    auto inside = [&] { return vec3(u(rng) * dims.x, u(rng) * dims.y, u(rng) * dims.z); };
    std::vector<TestRay> rays;
    for (std::uint32_t i = 0; i < count; ++i) {
        std::uint32_t kind = i % 8;
        vec3 o, d;
        float t0 = 0.0f, t1 = 1e30f;
        if (kind == 0 || kind == 1) {  // generic, from outside or inside
            d = vec3(s(rng), s(rng), s(rng));
            vec3 target = inside();
            o = kind == 0 ? target - d * (3.0f * glm::length(dims)) : target;
        } else if (kind == 2 || kind == 3) {  // axis-parallel along a face (2) or an edge (3)
            int a = int(pick(3)), b = (a + 1) % 3, c = (a + 2) % 3;
            o = inside();
            o[b] = plane(b);
            if (kind == 3) o[c] = plane(c);
            o[a] = u(rng) < 0.5f ? -1.0f : dims[a] + 1.0f;
            d = vec3(0.0f);
            d[a] = o[a] < 0.0f ? 1.0f : -1.0f;
            if (u(rng) < 0.3f) o[a] = u(rng) * dims[a];  // starting inside
        } else if (kind == 4 || kind == 5) {  // through corners: diagonals from lattice points
            for (int a = 0; a < 3; ++a) o[a] = plane(a);
            d = vec3(u(rng) < 0.5f ? -1.0f : 1.0f, u(rng) < 0.5f ? -1.0f : 1.0f, u(rng) < 0.5f ? -1.0f : 1.0f);
            if (kind == 5) d[pick(3)] = u(rng) < 0.5f ? 0.0f : -0.0f;  // in a face plane, through edges
            if (u(rng) < 0.5f) {
                o -= d * float(t.width(0));  // from outside (the lattice continues)
            }
        } else if (kind == 6) {  // one zero component, the origin on a plane of that axis
            d = vec3(s(rng), s(rng), s(rng));
            int a = int(pick(3));
            d[a] = u(rng) < 0.5f ? 0.0f : -0.0f;
            o = inside() - d * (2.0f * glm::length(dims));
            o[a] = plane(a);
        } else {  // short t ranges inside the volume
            d = glm::normalize(vec3(s(rng), s(rng), s(rng)) + vec3(1e-4f));
            o = inside();
            t0 = s(rng) * 0.5f * glm::length(dims);
            t1 = t0 + u(rng) * 0.5f * glm::length(dims);
        }
        rays.push_back({o * t.spacing, d * t.spacing, t0, t1});
    }
    return rays;
}

}  // namespace octree_test

#endif  // SYLVA_TESTS_OCTREE_RAYS_HPP
