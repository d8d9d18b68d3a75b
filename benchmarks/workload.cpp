// benchmarks/workload.cpp -- spheres, rays, and the comparison of per-ray results.
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "bench.hpp"

namespace bench {

using sylva::vec3;

const char* name(Distribution d) { return d == Distribution::Uniform ? "uniform" : "clustered"; }

namespace {

/// Radius scale a * n^(-1/3): with a = 0.2 about 3 % of the cube is covered whatever n is,
/// and a ray through the cube crosses ~2 spheres at 1e4 and ~20 at 1e7.
float radius_scale(std::size_t n) { return 0.2f / std::cbrt(static_cast<float>(n)); }

sylva::Sphere sphere(vec3 c, float r, std::mt19937& rng) {
    std::uniform_real_distribution<float> colour(0.0f, 1.0f);
    return sylva::Sphere{c, r, {colour(rng), colour(rng), colour(rng), colour(rng)}, 2.0f};
}

}  // namespace

std::vector<sylva::Sphere> make_spheres(std::size_t n, Distribution d, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), spread(0.5f, 1.5f);
    std::vector<sylva::Sphere> out;
    out.reserve(n);
    float a = radius_scale(n);
    if (d == Distribution::Uniform) {
        for (std::size_t i = 0; i < n; ++i) out.push_back(sphere({u(rng), u(rng), u(rng)}, a * spread(rng), rng));
        return out;
    }
    // 32 Gaussian clusters (sigma 0.05) cover about 1/8 of the cube: radii halved to match.
    std::vector<vec3> centres(32);
    std::uniform_real_distribution<float> inner(0.15f, 0.85f);
    for (auto& c : centres) c = {inner(rng), inner(rng), inner(rng)};
    std::normal_distribution<float> g(0.0f, 0.05f);
    for (std::size_t i = 0; i < n; ++i) {
        vec3 c = glm::clamp(centres[i % centres.size()] + vec3(g(rng), g(rng), g(rng)), vec3(0.0f), vec3(1.0f));
        out.push_back(sphere(c, 0.5f * a * spread(rng), rng));
    }
    return out;
}

std::vector<sylva::Ray> make_rays(std::size_t n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::normal_distribution<float> g(0.0f, 1.0f);
    std::vector<sylva::Ray> out(n);
    for (auto& r : out) {
        vec3 dir;
        do dir = {g(rng), g(rng), g(rng)};
        while (glm::dot(dir, dir) < 1e-6f);
        r.origin = vec3(0.5f) + 2.0f * glm::normalize(dir);  // outside the cube (half diagonal 0.87)
        vec3 target{u(rng), u(rng), u(rng)};
        r.direction = glm::normalize(target - r.origin);
    }
    return out;
}

std::string size_label(std::size_t n) {
    int e = 0;
    std::size_t m = n;
    while (m >= 10 && m % 10 == 0) {
        m /= 10;
        ++e;
    }
    if (e < 3) return std::to_string(n);
    return std::to_string(m) + "e" + std::to_string(e);
}

std::size_t disagreements(const FirstHits& a, const FirstHits& b) {
    if (a.id.size() != b.id.size()) throw std::logic_error("disagreements: ray counts differ");
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.id.size(); ++i) n += a.id[i] != b.id[i];
    return n;
}

std::size_t disagreements(const AllHits& a, const AllHits& b) {
    if (a.count.size() != b.count.size()) throw std::logic_error("disagreements: ray counts differ");
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.count.size(); ++i) n += a.count[i] != b.count[i] || a.set[i] != b.set[i];
    return n;
}

double median(std::vector<double> s) {
    if (s.empty()) return 0.0;
    std::sort(s.begin(), s.end());
    std::size_t m = s.size() / 2;
    return s.size() % 2 ? s[m] : 0.5 * (s[m - 1] + s[m]);
}

}  // namespace bench
