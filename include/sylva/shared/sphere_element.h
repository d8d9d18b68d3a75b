// sylva/shared/sphere_element.h -- the library's Sphere and GaussianRbf, written once in the
// shared subset through the element protocol (sylva/shared/element.h), exactly as a user writes
// an element: the C++ types sylva::Sphere / sylva::GaussianRbf (sylva/elements/sphere.hpp,
// rbf.hpp add C++-only members and packing) and the GLSL structs Sphere / GaussianRbf.
//
// Sphere (Kinkelin section 4.2, after Kaehler et al. 2007): centre c, radius r, straight RGBA,
// falloff kappa. Its interval is the chord of the ball; it deposits opacity
// a = clamp(A exp(-kappa (d/r)^2), 0, 1) at the ray's closest approach t_c, so its medium over
// [t0, t1] is optical depth -log(1 - a) when t_c lies in [t0, t1], 0 otherwise.
// Record (8 words, the particle record of sylva/shared/particles.h): 0-2 centre, 3 radius,
// 4 kappa, 5 RGBA8 (R bits 0-7 ... A bits 24-31), 6-7 zero.
//
// GaussianRbf: exp(-d^2 / (2 sigma^2)) truncated at d = truncation * sigma, i.e. the sphere of
// radius truncation * sigma and kappa truncation^2 / 2. Record (8 words): 0-2 centre, 3 sigma,
// 4 truncation, 5 RGBA8, 6-7 zero.
#ifndef SYLVA_SHARED_SPHERE_ELEMENT_H
#define SYLVA_SHARED_SPHERE_ELEMENT_H

#include "sylva/shared/element.h"
#include "sylva/shared/particles.h"

#ifdef __cplusplus
#include <optional>
#include "sylva/core/concepts.hpp"
namespace sylva::elements {
struct Sphere;
struct GaussianRbf;
}  // namespace sylva::elements
#endif

SYLVA_USER_BEGIN_NAMESPACE(sylva::elements)

/// A sphere particle (see the file comment). Colour is straight RGBA, stored as RGBA8.
struct Sphere {
    vec3 center SYLVA_DEFAULT(vec3(0.0f));
    float radius SYLVA_DEFAULT(1.0f);
    vec4 rgba SYLVA_DEFAULT(vec4(1.0f));
    float kappa SYLVA_DEFAULT(2.0f);  ///< falloff; Kaehler et al. use values around 2
#ifdef __cplusplus
    // C++ conveniences; the protocol functions below are the definition.
    [[nodiscard]] Aabb bounds() const;
    [[nodiscard]] std::optional<Interval> intersect(const Ray& ray, Interval range) const;
    [[nodiscard]] std::optional<Contribution> interact(const Ray& ray, Interval range) const;
#endif
};

SYLVA_FN uint sylva_elem_words(Sphere x) {
    SYLVA_UNUSED(x);
    return SYLVA_PARTICLE_WORDS;
}

SYLVA_FN void sylva_elem_load(SYLVA_BUF(elems), uint e, SYLVA_OUT(Sphere) x) {
    uint at = e * SYLVA_PARTICLE_WORDS;
    x.center = sylva_rec_vec3(SYLVA_PASS_BUF(elems), at);
    x.radius = sylva_rec_f(SYLVA_PASS_BUF(elems), at + 3u);
    x.kappa = sylva_rec_f(SYLVA_PASS_BUF(elems), at + 4u);
    x.rgba = sylva_unpack_rgba8(SYLVA_LOAD(elems, at + 5u));
}

SYLVA_FN void sylva_elem_bounds(Sphere x, SYLVA_OUT(vec3) lo, SYLVA_OUT(vec3) hi) {
    lo = vec3(x.center.x - x.radius, x.center.y - x.radius, x.center.z - x.radius);
    hi = vec3(x.center.x + x.radius, x.center.y + x.radius, x.center.z + x.radius);
}

/// The chord of the ball, clipped to [t0, t1].
SYLVA_FN vec2 sylva_elem_interval(Sphere x, vec3 o, vec3 d, float t0, float t1) {
    vec2 a = sylva_particle_approach(x.center, x.radius, o, d);
    if (!(a.y <= 1.0f)) return sylva_no_interval();
    float half_chord = sqrt((1.0f - a.y) * x.radius * x.radius / dot(d, d));
    float lo = sylva_max(t0, a.x - half_chord);
    float hi = sylva_min(t1, a.x + half_chord);
    return (lo <= hi) ? vec2(lo, hi) : sylva_no_interval();
}

/// Opacity deposited at the closest approach t_c, when t_c lies in [t0, t1].
SYLVA_FN vec4 sylva_elem_medium(Sphere x, vec3 o, vec3 d, float t0, float t1) {
    vec2 a = sylva_particle_approach(x.center, x.radius, o, d);
    if (!(a.y <= 1.0f) || a.x < t0 || a.x > t1) return vec4(0.0f);
    float alpha = clamp(x.rgba.w * sylva_radial_weight(a.y, x.kappa), 0.0f, 1.0f);
    return vec4(x.rgba.x, x.rgba.y, x.rgba.z, sylva_alpha_tau(alpha));
}

/// A truncated Gaussian radial basis function (see the file comment).
struct GaussianRbf {
    vec3 center SYLVA_DEFAULT(vec3(0.0f));
    float sigma SYLVA_DEFAULT(1.0f);
    float truncation SYLVA_DEFAULT(3.0f);  ///< support radius in units of sigma
    vec4 rgba SYLVA_DEFAULT(vec4(1.0f));
#ifdef __cplusplus
    /// The same function written as a sphere: radius k sigma, kappa k^2 / 2.
    [[nodiscard]] Sphere sphere() const;
    [[nodiscard]] Aabb bounds() const;
    [[nodiscard]] std::optional<Interval> intersect(const Ray& ray, Interval range) const;
    [[nodiscard]] std::optional<Contribution> interact(const Ray& ray, Interval range) const;
#endif
};

/// The sphere of radius truncation * sigma and kappa truncation^2 / 2.
SYLVA_FN Sphere sylva_rbf_sphere(GaussianRbf g) {
    Sphere s;
    s.center = g.center;
    s.radius = g.truncation * g.sigma;
    s.rgba = g.rgba;
    s.kappa = 0.5f * g.truncation * g.truncation;
    return s;
}

SYLVA_FN uint sylva_elem_words(GaussianRbf x) {
    SYLVA_UNUSED(x);
    return 8u;
}

SYLVA_FN void sylva_elem_load(SYLVA_BUF(elems), uint e, SYLVA_OUT(GaussianRbf) x) {
    uint at = e * 8u;
    x.center = sylva_rec_vec3(SYLVA_PASS_BUF(elems), at);
    x.sigma = sylva_rec_f(SYLVA_PASS_BUF(elems), at + 3u);
    x.truncation = sylva_rec_f(SYLVA_PASS_BUF(elems), at + 4u);
    x.rgba = sylva_unpack_rgba8(SYLVA_LOAD(elems, at + 5u));
}

SYLVA_FN void sylva_elem_bounds(GaussianRbf x, SYLVA_OUT(vec3) lo, SYLVA_OUT(vec3) hi) {
    sylva_elem_bounds(sylva_rbf_sphere(x), lo, hi);
}

SYLVA_FN vec2 sylva_elem_interval(GaussianRbf x, vec3 o, vec3 d, float t0, float t1) {
    return sylva_elem_interval(sylva_rbf_sphere(x), o, d, t0, t1);
}

SYLVA_FN vec4 sylva_elem_medium(GaussianRbf x, vec3 o, vec3 d, float t0, float t1) {
    return sylva_elem_medium(sylva_rbf_sphere(x), o, d, t0, t1);
}

SYLVA_USER_END_NAMESPACE

#endif  // SYLVA_SHARED_SPHERE_ELEMENT_H
