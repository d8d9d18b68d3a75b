// sylva/elements/sphere.hpp -- spherical particles with Gaussian weight (Kinkelin section 4.2)
// and their packing into the shared record of sylva/shared/particles.h.
#ifndef SYLVA_ELEMENTS_SPHERE_HPP
#define SYLVA_ELEMENTS_SPHERE_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/shared/particles.h"

namespace sylva {

/// Packs straight RGBA in [0, 1] into RGBA8 (R in bits 0-7 ... A in bits 24-31).
inline std::uint32_t pack_rgba8(const vec4& c) {
    auto q = [](float v) { return static_cast<std::uint32_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); };
    return q(c.r) | (q(c.g) << 8) | (q(c.b) << 16) | (q(c.a) << 24);
}

/// A sphere particle: weight exp(-kappa (d/r)^2) for rays passing at distance d <= radius.
/// Colour is straight (not premultiplied) RGBA; it is stored as RGBA8 on the GPU.
struct Sphere {
    vec3 center{0.0f};
    float radius = 1.0f;
    vec4 rgba{1.0f};
    float kappa = 2.0f;  ///< falloff; Kaehler et al. use values around 2

    [[nodiscard]] Aabb bounds() const { return {center - vec3(radius), center + vec3(radius)}; }

    /// Where the ray is inside the ball, within `range`.
    [[nodiscard]] std::optional<Interval> intersect(const Ray& ray, Interval range) const {
        vec2 a = shared::sylva_particle_approach(center, radius, ray.origin, ray.direction);
        if (!(a.y <= 1.0f)) return std::nullopt;
        float half = std::sqrt((1.0f - a.y) * radius * radius / glm::dot(ray.direction, ray.direction));
        Interval t{std::max(range.t0, a.x - half), std::min(range.t1, a.x + half)};
        if (t.empty()) return std::nullopt;
        return t;
    }

    /// The weighted colour the ray receives at its closest approach (same maths as the shaders).
    [[nodiscard]] std::optional<Contribution> interact(const Ray& ray, Interval range) const {
        vec2 a = shared::sylva_particle_approach(center, radius, ray.origin, ray.direction);
        if (!(a.y <= 1.0f) || a.x < range.t0 || a.x > range.t1) return std::nullopt;
        vec4 c = shared::sylva_unpack_rgba8(pack_rgba8(rgba));
        c.a = std::clamp(c.a * shared::sylva_radial_weight(a.y, kappa), 0.0f, 1.0f);
        return Contribution{a.x, c};
    }
};

/// Anything that can be drawn as a radial particle: spheres, truncated Gaussian RBFs, user types.
template <class P>
concept RadialParticle = requires(const P& p) {
    { as_sphere(p) } -> std::same_as<Sphere>;
};
inline Sphere as_sphere(const Sphere& s) { return s; }

/// The 8-word records of sylva/shared/particles.h, in the given element order.
template <RadialParticle P>
std::vector<std::uint32_t> pack_particles(std::span<const P> particles, std::span<const std::uint32_t> order) {
    std::vector<std::uint32_t> w(order.size() * SYLVA_PARTICLE_WORDS, 0u);
    for (std::size_t i = 0; i < order.size(); ++i) {
        Sphere s = as_sphere(particles[order[i]]);
        float f[5] = {s.center.x, s.center.y, s.center.z, s.radius, s.kappa};
        std::memcpy(&w[i * SYLVA_PARTICLE_WORDS], f, sizeof f);
        w[i * SYLVA_PARTICLE_WORDS + 5] = pack_rgba8(s.rgba);
    }
    return w;
}

/// Payload encoder for trimmed single-particle leaves: the leaf box is the particle's box and
/// the payload carries RGBA8 and kappa (SYLVA_PAYLOAD_PARTICLE_RGBA). A leaf that holds several
/// particles (coincident ones, or a depth-capped leaf) is drawn as one particle over the leaf
/// box with their mean colour and mean kappa.
struct ParticlePayload {
    static constexpr std::uint32_t kind = SYLVA_PAYLOAD_PARTICLE_RGBA;
    template <RadialParticle P>
    [[nodiscard]] std::uint64_t encode(std::span<const P> leaf, std::uint32_t) const {
        vec4 c{0.0f};
        float kappa = 0.0f;
        for (const P& p : leaf) {
            Sphere s = as_sphere(p);
            c += s.rgba;
            kappa += s.kappa;
        }
        float n = static_cast<float>(std::max<std::size_t>(leaf.size(), 1));
        std::uint32_t kbits;
        float k = kappa / n;
        std::memcpy(&kbits, &k, 4);
        return std::uint64_t{pack_rgba8(c / n)} | (std::uint64_t{kbits >> 2} << 32);
    }
};

}  // namespace sylva

#endif  // SYLVA_ELEMENTS_SPHERE_HPP
