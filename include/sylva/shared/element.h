// sylva/shared/element.h -- the element protocol: an element type written once in the shared
// C++/GLSL subset (docs/DESIGN.md, "The shared C++/GLSL subset") is a C++ type that satisfies
// sylva::Bounded, sylva::Intersectable and sylva::RayInteraction (sylva/core/concepts.hpp) and a
// GLSL type the generic kernels of sylva/shared/element_kernels.h run on the GPU.
//
// An element type T is a plain struct (no vec3 members cross to the GPU: records are 32-bit
// words) plus these functions, overloaded on T, in the user's namespace
// (SYLVA_USER_BEGIN_NAMESPACE(ns) ... SYLVA_USER_END_NAMESPACE, sylva/shared/lang.h):
//
//   SYLVA_FN uint sylva_elem_words(T x);
//       Words of one record (a constant; x is not read).
//   SYLVA_FN void sylva_elem_load(SYLVA_BUF(elems), uint e, SYLVA_OUT(T) x);
//       Reads record e, words [e * words, (e + 1) * words), with SYLVA_LOAD(elems, ...) or the
//       sylva_rec_* helpers below. The parameter must be named `elems` (the buffer-name rule of
//       lang.h: in GLSL it reads the shader's global buffer through sylva_load_elems).
//   SYLVA_FN void sylva_elem_bounds(T x, SYLVA_OUT(vec3) lo, SYLVA_OUT(vec3) hi);
//       A closed box that holds every point where the element acts on a ray.
//   SYLVA_FN vec2 sylva_elem_interval(T x, vec3 o, vec3 d, float t0, float t1);
//       The exact interval of the ray o + t d inside the element, clipped to [t0, t1]:
//       (t_in, t_out) with t_in <= t_out, or any pair with !(x <= y) when the ray misses it.
//   SYLVA_FN vec4 sylva_elem_medium(T x, vec3 o, vec3 d, float t0, float t1);
//       What the element does to the ray over [t0, t1] (inside its interval): straight RGB
//       emitted colour (x, y, z) and optical depth tau >= 0 (w; +inf for opaque). Composited
//       front to back with opacity 1 - exp(-tau) (sylva_composite_medium).
//   C++ only (#ifdef __cplusplus):
//   void sylva_elem_store(const T& x, ::sylva::shared::RecordOut out);
//       Writes the record sylva_elem_load reads (out.f / out.u / out.v3 / out.v4 at word offsets).
//
// Nothing else is needed: sylva/core/concepts.hpp recognises these functions (found by argument-
// dependent lookup), so bounds_of / intersect_element / interact_element, the BIH builder and the
// conformance checks take T as it is. GLSL has no namespaces: prefix the user's own helpers.
// The library's Sphere and GaussianRbf are written this way (sylva/shared/sphere_element.h).
//
// Exactness (docs/DESIGN.md, parity rules): hit sequences (element, t_in, t_out) are equal bit
// for bit on the host and on lavapipe when sylva_elem_interval uses only + - * / sqrt, min/max
// through sylva_min/sylva_max and sylva_canon where signs of zero matter; exp, log, pow, sin ...
// are not exact in Vulkan, so images, which composite 1 - exp(-tau), agree within a tolerance.
#ifndef SYLVA_SHARED_ELEMENT_H
#define SYLVA_SHARED_ELEMENT_H

#include "sylva/shared/lang.h"

#ifdef __cplusplus
namespace sylva::shared {
/// Where sylva_elem_store writes one record: `size` words at `data`. Writes past the record are
/// ignored (and counted in `overruns`, which sylva::pack_elements turns into an error).
struct RecordOut {
    std::uint32_t* data = nullptr;
    std::uint32_t size = 0;
    std::uint32_t* overruns = nullptr;
    void u(std::uint32_t k, std::uint32_t v) const {
        if (k < size) data[k] = v;
        else if (overruns) ++*overruns;
    }
    void f(std::uint32_t k, float v) const { u(k, floatBitsToUint(v)); }
    void v3(std::uint32_t k, vec3 v) const {
        f(k, v.x);
        f(k + 1u, v.y);
        f(k + 2u, v.z);
    }
    void v4(std::uint32_t k, vec4 v) const {
        v3(k, vec3(v.x, v.y, v.z));
        f(k + 3u, v.w);
    }
};
}  // namespace sylva::shared
#endif

SYLVA_BEGIN_NAMESPACE

/// Word `at` of the element records as a float.
SYLVA_FN float sylva_rec_f(SYLVA_BUF(elems), uint at) { return uintBitsToFloat(SYLVA_LOAD(elems, at)); }
/// Words at, at + 1, at + 2 as a vec3.
SYLVA_FN vec3 sylva_rec_vec3(SYLVA_BUF(elems), uint at) {
    return vec3(sylva_rec_f(SYLVA_PASS_BUF(elems), at), sylva_rec_f(SYLVA_PASS_BUF(elems), at + 1u),
                sylva_rec_f(SYLVA_PASS_BUF(elems), at + 2u));
}
/// Words at ... at + 3 as a vec4.
SYLVA_FN vec4 sylva_rec_vec4(SYLVA_BUF(elems), uint at) {
    vec3 a = sylva_rec_vec3(SYLVA_PASS_BUF(elems), at);
    return vec4(a.x, a.y, a.z, sylva_rec_f(SYLVA_PASS_BUF(elems), at + 3u));
}

/// Empty interval marker for sylva_elem_interval: (+inf, -inf).
SYLVA_FN vec2 sylva_no_interval() { return vec2(sylva_inf(), -sylva_inf()); }

/// Opacity of optical depth tau: 1 - exp(-tau), 0 for tau <= 0 or NaN, 1 for +inf.
SYLVA_FN float sylva_tau_alpha(float tau) {
    if (!(tau > 0.0f)) return 0.0f;
    if (tau == sylva_inf()) return 1.0f;
    return clamp(1.0f - exp(-tau), 0.0f, 1.0f);
}

/// Optical depth of opacity a in [0, 1]: -log(1 - a); +inf for a >= 1, 0 for a <= 0.
SYLVA_FN float sylva_alpha_tau(float a) {
    if (!(a > 0.0f)) return 0.0f;
    if (a >= 1.0f) return sylva_inf();
    return -log(1.0f - a);
}

/// One element hit: record index and the ray's interval inside the element.
struct SylvaHit {
    uint elem;
    float t0;
    float t1;
};

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_ELEMENT_H
