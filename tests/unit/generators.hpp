// Element sets and rays for tests: random, clustered and degenerate.
#ifndef SYLVA_TESTS_GENERATORS_HPP
#define SYLVA_TESTS_GENERATORS_HPP

#include <optional>
#include <random>
#include <vector>

#include <sylva/elements/box.hpp>
#include <sylva/elements/sphere.hpp>

namespace sylva::testing {

inline std::vector<BoxElement> random_boxes(std::size_t n, std::uint32_t seed, float size = 0.05f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), s(0.0f, size);
    std::vector<BoxElement> out(n);
    for (auto& b : out) {
        vec3 lo{u(rng), u(rng), u(rng)};
        b.box = {lo, lo + vec3(s(rng), s(rng), s(rng))};
    }
    return out;
}

/// Gaussian clusters around a few centres: strongly varying density.
inline std::vector<BoxElement> clustered_boxes(std::size_t n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 10.0f);
    std::normal_distribution<float> g(0.0f, 0.3f);
    std::exponential_distribution<float> s(8.0f);
    std::vector<vec3> centres(5);
    for (auto& c : centres) c = {u(rng), u(rng), u(rng)};
    std::vector<BoxElement> out(n);
    for (std::size_t i = 0; i < n; ++i) {
        vec3 c = centres[i % centres.size()] + vec3(g(rng), g(rng), g(rng));
        vec3 h{s(rng), s(rng), s(rng)};
        out[i].box = {c - h, c + h};
    }
    return out;
}

/// Zero-size points, coincident copies, flat boxes and a few huge ones.
inline std::vector<BoxElement> degenerate_boxes(std::size_t n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<BoxElement> out;
    for (std::size_t i = 0; i < n; ++i) {
        vec3 p{u(rng), u(rng), u(rng)};
        switch (i % 5) {
            case 0: out.push_back({{p, p}}); break;                                         // point
            case 1: out.push_back({{vec3(0.5f), vec3(0.5f) + vec3(0.1f)}}); break;          // coincident
            case 2: out.push_back({{p, p + vec3(0.2f, 0.0f, 0.2f)}}); break;                // flat in y
            case 3: out.push_back({{vec3(std::floor(p.x * 4) / 4), vec3(std::floor(p.x * 4) / 4 + 0.25f)}}); break;
            default: out.push_back({{p - vec3(0.01f), p + vec3(0.01f)}}); break;
        }
    }
    out.push_back({{vec3(-1e4f), vec3(1e4f)}});  // huge
    out.push_back({{vec3(-5.0f, 0.25f, 0.25f), vec3(5.0f, 0.25f, 0.75f)}});
    return out;
}

/// Disjoint unit cells of an n^3 grid (no overlap: leaf order must be exact).
inline std::vector<BoxElement> grid_boxes(int n) {
    std::vector<BoxElement> out;
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x)
                if ((x * 7 + y * 3 + z * 5) % 4 != 0) out.push_back({{vec3(x, y, z), vec3(x + 1, y + 1, z + 1)}});
    return out;
}

/// Spheres and rays that pass within a few ulps of a sphere's rim (ray k grazes sphere k % 64):
/// q = (d/r)^2 lands on both sides of 1, where a sphere test that is not bit-exact with
/// Sphere::intersect (another formula, a division skipped) disagrees with brute force.
struct GrazingSet {
    std::vector<Sphere> spheres;
    std::vector<Ray> rays;
    /// The sphere ray k grazes.
    [[nodiscard]] std::uint32_t target(std::size_t k) const { return static_cast<std::uint32_t>(k % spheres.size()); }
};
inline GrazingSet grazing_set(std::size_t rays, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), rad(0.01f, 0.2f);
    std::uniform_int_distribution<int> ulps(-40, 40);
    GrazingSet g;
    g.spheres.resize(64);
    for (auto& s : g.spheres) s = Sphere{{u(rng), u(rng), u(rng)}, rad(rng), vec4(1.0f), 2.0f};
    for (std::size_t k = 0; k < rays; ++k) {
        const Sphere& s = g.spheres[g.target(k)];
        vec3 dir = glm::normalize(vec3(u(rng), u(rng), u(rng)) + vec3(0.0f, 0.0f, 1e-3f));
        vec3 side = glm::normalize(glm::cross(dir, vec3(u(rng), u(rng), u(rng))));
        float dist = s.radius * (1.0f + static_cast<float>(ulps(rng)) * 0x1p-24f);
        g.rays.push_back(Ray{s.center + side * dist - dir * 3.0f, dir});
    }
    return g;
}

/// A user element without a default constructor (query structures must copy it, not default it).
struct PinnedBox {
    explicit PinnedBox(const Aabb& b) : box(b) {}
    Aabb box;
    [[nodiscard]] Aabb bounds() const { return box; }
    [[nodiscard]] std::optional<Interval> intersect(const Ray& ray, Interval range) const {
        return clip(ray, box, range);
    }
};

inline std::vector<Sphere> random_spheres(std::size_t n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), r(0.005f, 0.05f), c(0.0f, 1.0f);
    std::vector<Sphere> out(n);
    for (auto& s : out) s = Sphere{{u(rng), u(rng), u(rng)}, r(rng), {c(rng), c(rng), c(rng), c(rng)}, 2.0f};
    return out;
}

/// Rays through `box`: random origins around it (a quarter inside), random directions, and
/// every tenth ray with one or two direction components set to +0 or -0.
inline std::vector<Ray> random_rays(std::size_t n, const Aabb& box, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), d(-1.0f, 1.0f);
    vec3 lo = box.lo, ext = box.extent();
    std::vector<Ray> out(n);
    for (std::size_t i = 0; i < n; ++i) {
        bool inside = i % 4 == 0;
        vec3 f = inside ? vec3(u(rng), u(rng), u(rng)) : vec3(u(rng), u(rng), u(rng)) * 3.0f - vec3(1.0f);
        vec3 o = lo + f * ext;
        vec3 target = lo + vec3(u(rng), u(rng), u(rng)) * ext;
        vec3 dir = inside ? vec3(d(rng), d(rng), d(rng)) : target - o;
        if (i % 10 == 1) dir.x = (i % 20 == 1) ? 0.0f : -0.0f;
        if (i % 30 == 2) dir.y = -0.0f, dir.z = 0.0f, dir.x = (dir.x == 0.0f ? 1.0f : dir.x);
        out[i] = {o, dir};
    }
    return out;
}

/// 3000 random spheres with the awkward cases planted (a point, coincident twins, a radius whose
/// square underflows) and 20000 random rays plus a ray with no direction and one through the
/// twins' centres.
struct SphereCases {
    std::vector<Sphere> spheres;
    std::vector<Ray> rays;
};
inline SphereCases sphere_cases(std::uint32_t seed) {
    SphereCases c{random_spheres(3000, seed), random_rays(20000, {vec3(-1.0f), vec3(1.0f)}, seed + 1)};
    c.spheres[7].radius = 0.0f;     // a point: never hit
    c.spheres[8] = c.spheres[9];    // coincident twins: both reported, ordered by index
    c.spheres[10].radius = 1e-30f;  // r * r underflows to 0: never hit
    c.rays.push_back({vec3(0.0f), vec3(0.0f)});  // no direction: no hits
    c.rays.push_back({c.spheres[8].center - vec3(2.0f, 0.0f, 0.0f), vec3(1.0f, 0.0f, 0.0f)});
    return c;
}

}  // namespace sylva::testing

#endif
