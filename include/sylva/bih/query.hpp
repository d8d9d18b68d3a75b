// sylva/bih/query.hpp -- host-side use of the shared iterator: a C++ leaf iterator and the
// first-hit and all-hits-in-order queries built on it.
#ifndef SYLVA_BIH_QUERY_HPP
#define SYLVA_BIH_QUERY_HPP

#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <tuple>
#include <vector>

#include "sylva/bih/payload.hpp"
#include "sylva/bih/tree.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/shared/bih_iter.h"

namespace sylva::bih {

/// One leaf visited by a ray: its node position, interval and box (world space), payload.
struct LeafHit {
    std::uint32_t node = 0;
    Interval t;
    Aabb box;
    std::uint64_t payload = 0;
};

/// Iterates the leaves an encoded BIH yields for one ray, front to back. The encoding must
/// outlive the iterator. `status()` tells DONE from ERROR (a corrupted encoding) at the end.
class LeafIterator {
public:
    LeafIterator(std::span<const std::uint32_t> words, const Ray& ray, Interval range = {})
        : words_{words.data(), words.size()} {
        shared::sylva_bih_init(it_, words_, static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)),
                               ray.origin, ray.direction, range.t0, range.t1);
    }
    /// The next leaf, or nothing when the traversal is over.
    std::optional<LeafHit> next() {
        std::uint32_t leaf;
        float t0, t1;
        if (!shared::sylva_bih_next(it_, words_, leaf, t0, t1)) return std::nullopt;
        uvec2 p = shared::sylva_bih_payload(words_, it_.hdr, leaf);
        LeafHit h{leaf, {t0, t1}, {}, std::uint64_t{p.x} | (std::uint64_t{p.y} << 32)};
        h.box.lo = shared::sylva_bih_to_world(it_.hdr, it_.leaf_lo);
        h.box.hi = shared::sylva_bih_to_world(it_.hdr, it_.leaf_hi);
        return h;
    }
    /// Prunes everything entered after t.
    void clip(float t) { shared::sylva_bih_clip(it_, t); }
    [[nodiscard]] std::uint32_t steps() const { return it_.steps; }
    [[nodiscard]] std::uint32_t status() const { return it_.status; }

private:
    shared::Words words_;
    shared::SylvaBihIter it_;
};

/// A hit of a ray with one element: the element's index in the caller's array and where the
/// ray is inside it.
struct ElementHit {
    std::uint32_t element = 0;
    Interval t;
    friend bool operator==(const ElementHit&, const ElementHit&) = default;
};

/// The order of hits everywhere: entry t first, then element index (deterministic ties).
inline bool hit_before(const ElementHit& a, const ElementHit& b) {
    return a.t.t0 < b.t.t0 || (a.t.t0 == b.t.t0 && a.element < b.element);
}

/// Iterates the element hits of one ray in leaf order (RangePayload encodings): each leaf's
/// elements are intersected exactly; misses are skipped. Not sorted across overlapping leaves.
template <Intersectable E>
class HitIterator {
public:
    HitIterator(std::span<const std::uint32_t> words, const Tree& tree, std::span<const E> elements, const Ray& ray,
                Interval range = {})
        : leaves_(words, ray, range), tree_(tree), elements_(elements), ray_(ray), range_(range) {}
    /// The next element hit, or nothing when the traversal is over.
    std::optional<ElementHit> next() {
        for (;;) {
            while (k_ < count_) {
                std::uint32_t e = tree_.order[first_ + k_++];
                if (auto t = intersect_element(elements_[e], ray_, range_)) return ElementHit{e, *t};
            }
            auto leaf = leaves_.next();
            if (!leaf) return std::nullopt;
            std::tie(first_, count_) = decode_range(leaf->payload);
            k_ = 0;
        }
    }
    /// Prunes leaves entered after t (elements of the current leaf are still reported).
    void clip(float t) { leaves_.clip(t); }

private:
    LeafIterator leaves_;
    const Tree& tree_;
    std::span<const E> elements_;
    Ray ray_;
    Interval range_;
    std::uint32_t first_ = 0, count_ = 0, k_ = 0;
};

/// The nearest element hit in `range` (smallest entry t; ties: smallest element index).
/// `words` must be encoded with RangePayload over `tree`.
template <Intersectable E>
std::optional<ElementHit> first_hit(std::span<const std::uint32_t> words, const Tree& tree,
                                    std::span<const E> elements, const Ray& ray, Interval range = {}) {
    std::optional<ElementHit> best;
    HitIterator<E> hits(words, tree, elements, ray, range);
    while (auto h = hits.next()) {
        if (!best || hit_before(*h, *best)) {
            best = h;
            hits.clip(h->t.t0);  // overlapping siblings may still hold an earlier hit
        }
    }
    return best;
}

/// Every element hit in `range`, sorted by entry t (ties: element index). The leaves arrive
/// almost sorted, so an insertion sort keeps this linear in practice.
template <Intersectable E>
void all_hits(std::span<const std::uint32_t> words, const Tree& tree, std::span<const E> elements, const Ray& ray,
              std::vector<ElementHit>& out, Interval range = {}) {
    out.clear();
    HitIterator<E> hits(words, tree, elements, ray, range);
    while (auto h = hits.next()) {
        std::size_t i = out.size();
        out.push_back(*h);
        for (; i > 0 && hit_before(*h, out[i - 1]); --i) out[i] = out[i - 1];
        out[i] = *h;
    }
}

/// Brute-force reference: tests every element. What the queries must reproduce exactly.
template <Intersectable E>
std::vector<ElementHit> brute_force_hits(std::span<const E> elements, const Ray& ray, Interval range = {}) {
    std::vector<ElementHit> hits;
    for (std::uint32_t e = 0; e < elements.size(); ++e)
        if (auto t = intersect_element(elements[e], ray, range)) hits.push_back({e, *t});
    std::sort(hits.begin(), hits.end(), hit_before);
    return hits;
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_QUERY_HPP
