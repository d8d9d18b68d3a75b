// sylva/octree/elements_encode.hpp -- writes an element octree (sylva/octree/elements.hpp) as
// the index words of sylva/shared/octree_elem_iter.h (octree_layout.h's node records, format
// SYLVA_OCTE_FORMAT_ELEMENTS, reference lists after the records), and the element queries over
// it: first hit and all hits in (entry t, element) order, as the BIH's (sylva/bih/query.hpp).
#ifndef SYLVA_OCTREE_ELEMENTS_ENCODE_HPP
#define SYLVA_OCTREE_ELEMENTS_ENCODE_HPP

#include <algorithm>
#include <bit>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/bih/query.hpp"
#include "sylva/core/error.hpp"
#include "sylva/octree/elements.hpp"
#include "sylva/octree/encode.hpp"
#include "sylva/shared/octree_elem_iter.h"

namespace sylva::octree {

/// The index words of `et` (layout: sylva/shared/octree_elem_iter.h). Throws sylva::Error when
/// the tree does not fit the layout (extents, levels, more than 2^32 - 1 words).
inline std::vector<std::uint32_t> encode_elements(const ElementTree& et) {
    const Tree& t = et.tree;
    detail::check_encodable(t);
    std::size_t lists = et.leaf_first.empty() ? 0 : et.leaf_first.size() - 1;
    std::size_t nodes_end = SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * t.nodes.size();
    std::size_t total = nodes_end + lists + et.refs.size();
    if (total > 0xFFFFFFFFu || et.element_count > 0xFFFFFFFFu)
        throw Error("octree::encode_elements: " + std::to_string(total) + " words exceed 2^32 - 1");
    std::vector<std::uint32_t> w(total, 0u);
    w[0] = SYLVA_OCT_MAGIC;
    w[1] = SYLVA_OCT_VERSION;
    for (int a = 0; a < 3; ++a) {
        w[2 + a] = t.dims[a];
        w[10 + a] = std::bit_cast<std::uint32_t>(t.spacing[a]);
        w[13 + a] = std::bit_cast<std::uint32_t>(1.0f / t.spacing[a]);
        w[16 + a] = std::bit_cast<std::uint32_t>(et.origin[a]);
    }
    w[5] = t.brick_size | (t.border << 8) | (t.levels << 16) | (SYLVA_OCTE_FORMAT_ELEMENTS << 24);
    w[6] = static_cast<std::uint32_t>(t.nodes.size());
    w[7] = static_cast<std::uint32_t>(et.element_count);
    w[8] = static_cast<std::uint32_t>(total - nodes_end);
    w[9] = static_cast<std::uint32_t>(total);
    // List i's words, in list order after the records: count, then the references.
    std::vector<std::uint32_t> at(lists);
    std::size_t cursor = nodes_end;
    for (std::size_t i = 0; i < lists; ++i) {
        at[i] = static_cast<std::uint32_t>(cursor);
        auto refs = et.list(std::uint32_t(i));
        w[cursor++] = static_cast<std::uint32_t>(refs.size());
        for (std::uint32_t e : refs) w[cursor++] = e;
    }
    for (std::size_t n = 0; n < t.nodes.size(); ++n) {
        const Node& node = t.nodes[n];
        if (node.brick != kNone && (!node.leaf() || node.brick >= lists))
            throw Error("octree::encode_elements: node " + std::to_string(n) + " names a reference list it cannot have");
        std::uint32_t* r = &w[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n];
        detail::write_node(t, node, SYLVA_OCT_BRICK_RESIDENT, r);
        r[10] = 0u;
        r[11] = 0u;
        r[12] = node.brick == kNone ? SYLVA_OCT_NONE : at[node.brick];
    }
    return w;
}

namespace detail {

/// Walks `words` along `ray` and calls on_leaf(it, t0, t1, first, count) per leaf with
/// references until it returns false. Throws when the encoding is refused, does not match the
/// `size` elements, or the walk stops with an error.
template <class F>
void walk_elements(std::span<const std::uint32_t> words, std::size_t size, const Ray& ray, Interval range, F&& on_leaf) {
    shared::Words w{words.data(), words.size()};
    auto count = static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu));
    shared::SylvaOctElemIter it;
    shared::sylva_octe_init(it, w, count, ray.origin, ray.direction, range.t0, range.t1);
    if (it.walk.hdr.valid == 0u) throw Error("octree element query: the encoding's header is refused");
    if (it.elem_count != size)
        throw Error("octree element query: the encoding was built over " + std::to_string(it.elem_count) +
                    " elements, not " + std::to_string(size));
    std::uint32_t node, first, n;
    float t0, t1;
    while (shared::sylva_octe_next(it, w, node, t0, t1, first, n))
        if (!on_leaf(it, t0, t1, first, n)) return;
    if (it.walk.status == SYLVA_ITER_ERROR) throw Error("octree element query: the walk met a corrupted encoding");
}

/// Element index of reference word `at`, checked.
inline std::uint32_t element_at(shared::SylvaOctElemIter& it, std::span<const std::uint32_t> words, std::uint32_t at) {
    shared::Words w{words.data(), words.size()};
    std::uint32_t e = shared::sylva_octe_element(it, w, at);
    if (e == SYLVA_OCT_NONE) throw Error("octree element query: a reference is past the elements");
    return e;
}

}  // namespace detail

/// Every element the ray hits within `range`, in (entry t, element) order (bih::hit_before),
/// into `out`: each leaf keeps the hits whose entry t it claims and sorts them.
template <Intersectable E>
void all_hits(std::span<const std::uint32_t> words, std::span<const E> elements, const Ray& ray,
              std::vector<bih::ElementHit>& out, Interval range = {}) {
    out.clear();
    detail::walk_elements(words, elements.size(), ray, range, [&](shared::SylvaOctElemIter& it, float t0, float t1,
                                                                  std::uint32_t first, std::uint32_t n) {
        std::size_t from = out.size();
        for (std::uint32_t k = 0; k < n; ++k) {
            std::uint32_t e = detail::element_at(it, words, first + k);
            if (auto t = intersect_element(elements[e], ray, range))
                if (shared::sylva_octe_claims(it, t->t0, t0, t1)) out.push_back({e, *t});
        }
        std::sort(out.begin() + std::ptrdiff_t(from), out.end(), bih::hit_before);
        return true;
    });
}

/// The first element the ray hits within `range` (least entry t, then least index), or none.
template <Intersectable E>
std::optional<bih::ElementHit> first_hit(std::span<const std::uint32_t> words, std::span<const E> elements,
                                         const Ray& ray, Interval range = {}) {
    std::optional<bih::ElementHit> best;
    detail::walk_elements(words, elements.size(), ray, range, [&](shared::SylvaOctElemIter& it, float, float t1,
                                                                  std::uint32_t first, std::uint32_t n) {
        for (std::uint32_t k = 0; k < n; ++k) {
            std::uint32_t e = detail::element_at(it, words, first + k);
            if (auto t = intersect_element(elements[e], ray, range)) {
                bih::ElementHit h{e, *t};
                if (!best || bih::hit_before(h, *best)) best = h;
            }
        }
        // An element not met yet lies beyond t1 (else a leaf met so far would list it): a best
        // hit entered before t1 is final. One entered exactly at t1 may tie with a later one.
        return !(best && best->t.t0 < t1);
    });
    return best;
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_ELEMENTS_ENCODE_HPP
