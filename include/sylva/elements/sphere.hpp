// sylva/elements/sphere.hpp -- spherical particles with Gaussian weight (Kinkelin section 4.2)
// and their packing into the shared record of sylva/shared/particles.h. The type itself is
// written once in the shared subset (sylva/shared/sphere_element.h), like any user element.
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
#include "sylva/shared/sphere_element.h"

namespace sylva {

/// Packs straight RGBA in [0, 1] into RGBA8 (R in bits 0-7 ... A in bits 24-31).
inline std::uint32_t pack_rgba8(const vec4& c) {
    auto q = [](float v) { return static_cast<std::uint32_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); };
    return q(c.r) | (q(c.g) << 8) | (q(c.b) << 16) | (q(c.a) << 24);
}

}  // namespace sylva

namespace sylva::elements {

// Sphere is defined once, in the shared subset (sylva/shared/sphere_element.h); these members
// are C++ conveniences over the same protocol functions the GPU kernels call.
inline Aabb Sphere::bounds() const {
    Aabb b;
    sylva_elem_bounds(*this, b.lo, b.hi);
    return b;
}

inline std::optional<Interval> Sphere::intersect(const Ray& ray, Interval range) const {
    vec2 t = sylva_elem_interval(*this, ray.origin, ray.direction, range.t0, range.t1);
    if (!(t.x <= t.y)) return std::nullopt;
    return Interval{t.x, t.y};
}

/// The opacity the ray receives at its closest approach t_c, as the degenerate interval [t_c,
/// t_c] with optical depth -log(1 - a); the colour is quantised to RGBA8 as on the GPU.
inline std::optional<Contribution> Sphere::interact(const Ray& ray, Interval range) const {
    Sphere q = *this;
    q.rgba = sylva_unpack_rgba8(pack_rgba8(rgba));
    vec2 a = sylva_particle_approach(center, radius, ray.origin, ray.direction);
    vec4 m = sylva_elem_medium(q, ray.origin, ray.direction, range.t0, range.t1);
    if (!(a.y <= 1.0f) || a.x < range.t0 || a.x > range.t1) return std::nullopt;
    return Contribution{Interval{a.x, a.x}, vec3(m.x, m.y, m.z), m.w};
}

/// C++ side of the protocol: the record sylva_elem_load(Sphere) reads.
inline void sylva_elem_store(const Sphere& s, ::sylva::shared::RecordOut out) {
    out.v3(0u, s.center);
    out.f(3u, s.radius);
    out.f(4u, s.kappa);
    out.u(5u, pack_rgba8(s.rgba));
}

inline Sphere as_sphere(const Sphere& s) { return s; }

}  // namespace sylva::elements

namespace sylva {

using elements::Sphere;
using elements::as_sphere;

/// Anything that can be drawn as a radial particle: spheres, truncated Gaussian RBFs, user types.
template <class P>
concept RadialParticle = requires(const P& p) {
    { as_sphere(p) } -> std::same_as<Sphere>;
};

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
