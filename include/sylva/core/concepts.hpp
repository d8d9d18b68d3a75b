// sylva/core/concepts.hpp -- the places where users plug in their own types.
//
//  * Bounded: an element with an axis-aligned box (member `bounds()` or ADL `bounds(e)`).
//  * Intersectable: an element that reports where a ray is inside it (member
//    `intersect(ray, range)` or ADL `intersect(e, ray, range)`), used by queries and references.
//  * RayInteraction: an element that acts on a ray over an interval: optical depth and colour
//    over the part of [t0, t1] the element covers (member `interact(ray, range)` or ADL
//    `interact(e, ray, range)`), used by integrators.
//  * Elements written once in the shared C++/GLSL subset (sylva/shared/element.h) satisfy all
//    three through the protocol functions sylva_elem_bounds / sylva_elem_interval /
//    sylva_elem_medium, found by argument-dependent lookup; a member or ADL bounds / intersect /
//    interact, where present, is preferred.
//  * PayloadEncoder: how the elements of one leaf pack into the 62 payload bits of a BIH leaf.
//  * Executor: parallel work (see sylva/core/executor.hpp).
#ifndef SYLVA_CORE_CONCEPTS_HPP
#define SYLVA_CORE_CONCEPTS_HPP

#include <algorithm>
#include <cmath>
#include <concepts>
#include <limits>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "sylva/core/aabb.hpp"
#include "sylva/core/ray.hpp"

namespace sylva {

/// What an element does to a ray over an interval: over `interval` (inside the queried range)
/// the ray passes through a medium of optical depth `optical_depth` that emits the straight
/// (not premultiplied) colour `rgb`; its opacity is 1 - exp(-optical_depth). Point-like models
/// (the Gaussian sphere particles of Kinkelin 4.2) report the point where they deposit as a
/// degenerate interval [t, t].
struct Contribution {
    Interval interval{};
    vec3 rgb{0.0f};
    float optical_depth = 0.0f;
    /// Opacity 1 - exp(-optical_depth): 0 for none, 1 for +inf.
    [[nodiscard]] float alpha() const {
        if (!(optical_depth > 0.0f)) return 0.0f;
        if (optical_depth == std::numeric_limits<float>::infinity()) return 1.0f;
        return std::clamp(1.0f - std::exp(-optical_depth), 0.0f, 1.0f);
    }
};

namespace detail {
// The shared element protocol (sylva/shared/element.h), found by argument-dependent lookup.
template <class E>
concept HasSharedBounds = requires(const E& e, vec3& lo, vec3& hi) { sylva_elem_bounds(e, lo, hi); };
template <class E>
concept HasSharedInterval = requires(const E& e, vec3 v, float t) {
    { sylva_elem_interval(e, v, v, t, t) } -> std::same_as<vec2>;
};
template <class E>
concept HasSharedMedium = requires(const E& e, vec3 v, float t) {
    { sylva_elem_medium(e, v, v, t, t) } -> std::same_as<vec4>;
};

template <class E>
concept HasMemberBounds = requires(const E& e) {
    { e.bounds() } -> std::convertible_to<Aabb>;
};
template <class E>
concept HasAdlBounds = requires(const E& e) {
    { bounds(e) } -> std::convertible_to<Aabb>;
};
struct BoundsFn {
    template <class E>
        requires HasMemberBounds<E> || HasAdlBounds<E> || HasSharedBounds<E>
    Aabb operator()(const E& e) const {
        if constexpr (HasMemberBounds<E>) return e.bounds();
        else if constexpr (HasAdlBounds<E>) return bounds(e);
        else {
            vec3 lo, hi;
            sylva_elem_bounds(e, lo, hi);
            return Aabb{lo, hi};
        }
    }
};

template <class E>
concept HasMemberIntersect = requires(const E& e, const Ray& r, Interval i) {
    { e.intersect(r, i) } -> std::same_as<std::optional<Interval>>;
};
template <class E>
concept HasAdlIntersect = requires(const E& e, const Ray& r, Interval i) {
    { intersect(e, r, i) } -> std::same_as<std::optional<Interval>>;
};
struct IntersectFn {
    template <class E>
        requires HasMemberIntersect<E> || HasAdlIntersect<E> || HasSharedInterval<E>
    std::optional<Interval> operator()(const E& e, const Ray& r, Interval i) const {
        if constexpr (HasMemberIntersect<E>) return e.intersect(r, i);
        else if constexpr (HasAdlIntersect<E>) return intersect(e, r, i);
        else {
            vec2 t = sylva_elem_interval(e, r.origin, r.direction, i.t0, i.t1);
            if (!(t.x <= t.y)) return std::nullopt;
            return Interval{t.x, t.y};
        }
    }
};

template <class E>
concept HasMemberInteract = requires(const E& e, const Ray& r, Interval i) {
    { e.interact(r, i) } -> std::same_as<std::optional<Contribution>>;
};
template <class E>
concept HasAdlInteract = requires(const E& e, const Ray& r, Interval i) {
    { interact(e, r, i) } -> std::same_as<std::optional<Contribution>>;
};
struct InteractFn {
    template <class E>
        requires HasMemberInteract<E> || HasAdlInteract<E> || (HasSharedInterval<E> && HasSharedMedium<E>)
    std::optional<Contribution> operator()(const E& e, const Ray& r, Interval i) const {
        if constexpr (HasMemberInteract<E>) return e.interact(r, i);
        else if constexpr (HasAdlInteract<E>) return interact(e, r, i);
        else {
            vec2 t = sylva_elem_interval(e, r.origin, r.direction, i.t0, i.t1);
            if (!(t.x <= t.y)) return std::nullopt;
            vec4 m = sylva_elem_medium(e, r.origin, r.direction, t.x, t.y);
            if (!(m.w > 0.0f)) return std::nullopt;
            return Contribution{Interval{t.x, t.y}, vec3(m.x, m.y, m.z), m.w};
        }
    }
};

/// The callables an Executor must accept; concepts test with these stand-ins.
struct RangeTask {
    void operator()(std::size_t, std::size_t) const {}
};
struct Task {
    void operator()() const {}
};
}  // namespace detail

/// The box of an element: `sylva::bounds(e)`.
inline constexpr detail::BoundsFn bounds_of{};
/// Where a ray is inside an element, within a range: `sylva::intersect_element(e, ray, range)`.
inline constexpr detail::IntersectFn intersect_element{};
/// What an element contributes to a ray: `sylva::interact_element(e, ray, range)`.
inline constexpr detail::InteractFn interact_element{};

/// An element with an axis-aligned bounding box.
template <class E>
concept Bounded = detail::HasMemberBounds<E> || detail::HasAdlBounds<E> || detail::HasSharedBounds<E>;

/// A bounded element whose overlap with a ray can be computed exactly.
template <class E>
concept Intersectable =
    Bounded<E> && (detail::HasMemberIntersect<E> || detail::HasAdlIntersect<E> || detail::HasSharedInterval<E>);

/// A bounded element that acts on a ray over an interval (optical depth and colour; particles,
/// RBFs, media ...).
template <class E>
concept RayInteraction =
    Bounded<E> && (detail::HasMemberInteract<E> || detail::HasAdlInteract<E> ||
                   (detail::HasSharedInterval<E> && detail::HasSharedMedium<E>));

/// Packs the elements of one leaf (in leaf order; `first` is the index of the first of them in
/// the builder's element order) into at most 62 bits. `kind` is stored in the encoding's header
/// so decoders know what the payload means (see SYLVA_PAYLOAD_* in sylva/shared/bih_layout.h).
template <class P, class E>
concept PayloadEncoder = Bounded<E> && requires(const P& p, std::span<const E> leaf, std::uint32_t first) {
    { P::kind } -> std::convertible_to<std::uint32_t>;
    { p.encode(leaf, first) } -> std::same_as<std::uint64_t>;
};

/// Runs work in parallel: `parallel_for(begin, end, grain, f)` calls f(lo, hi) on disjoint
/// subranges covering [begin, end) and returns when all are done; `invoke(f, g)` runs both
/// and returns when both are done; `concurrency()` says how many run at once.
template <class X>
concept Executor = requires(X& x, detail::RangeTask r, detail::Task t) {
    { x.concurrency() } -> std::convertible_to<std::size_t>;
    x.parallel_for(std::size_t{0}, std::size_t{1}, std::size_t{1}, r);
    x.invoke(t, t);
};

}  // namespace sylva

#endif  // SYLVA_CORE_CONCEPTS_HPP
