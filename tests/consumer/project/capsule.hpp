// capsule.hpp -- the host side of the user's capsule (capsule.h): a C++ type that satisfies
// sylva's Bounded and Intersectable concepts, and its packing into the GPU record.
#ifndef CONSUMER_CAPSULE_HPP
#define CONSUMER_CAPSULE_HPP

#include <sylva/core/concepts.hpp>

#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

#include "capsule.h"

namespace consumer {

struct Capsule {
    sylva::vec3 a{0.0f};
    sylva::vec3 b{0.0f};
    float radius = 0.1f;
    float extinction = 1.0f;

    [[nodiscard]] sylva::Aabb bounds() const {
        return {glm::min(a, b) - sylva::vec3(radius), glm::max(a, b) + sylva::vec3(radius)};
    }
    [[nodiscard]] std::optional<sylva::Interval> intersect(const sylva::Ray& ray, sylva::Interval range) const {
        vec2 t = capsule_interval(a, b, radius, ray.origin, ray.direction, range.t0, range.t1);
        if (!(t.x <= t.y)) return std::nullopt;
        return sylva::Interval{t.x, t.y};
    }
};

/// The records of capsule.h (CAPSULE_WORDS words each), in the given element order.
inline std::vector<std::uint32_t> pack_capsules(std::span<const Capsule> capsules, std::span<const std::uint32_t> order) {
    std::vector<std::uint32_t> words(order.size() * CAPSULE_WORDS);
    for (std::size_t i = 0; i < order.size(); ++i) {
        const Capsule& c = capsules[order[i]];
        const std::array<float, 8> f{c.a.x, c.a.y, c.a.z, c.radius, c.b.x, c.b.y, c.b.z, c.extinction};
        std::memcpy(&words[i * CAPSULE_WORDS], f.data(), sizeof f);
    }
    return words;
}

/// n capsules in [0, 1]^3 from a fixed seed (a small LCG: same scene everywhere).
inline std::vector<Capsule> make_capsules(std::size_t n, std::uint32_t seed = 12345u) {
    std::uint32_t s = seed;
    auto next = [&s] {
        s = s * 1664525u + 1013904223u;
        return static_cast<float>(s >> 8) / 16777216.0f;
    };
    std::vector<Capsule> out(n);
    for (Capsule& c : out) {
        c.a = sylva::vec3(next(), next(), next());
        c.b = c.a + (sylva::vec3(next(), next(), next()) - 0.5f) * 0.15f;
        c.radius = 0.005f + 0.02f * next();
        c.extinction = 0.5f + 4.0f * next();
    }
    return out;
}

}  // namespace consumer

#endif  // CONSUMER_CAPSULE_HPP
