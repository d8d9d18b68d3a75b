// sylva/kdtree/elements_encode.hpp -- writes an element kd-tree (sylva/kdtree/elements.hpp) as
// the index words of sylva/shared/kd_elem_iter.h, checks such words (validate_elements), and
// the element queries over them: first hit and all hits in (entry t, element) order, as the
// BIH's and the element octree's (sylva/bih/query.hpp, sylva/octree/elements_encode.hpp).
#ifndef SYLVA_KDTREE_ELEMENTS_ENCODE_HPP
#define SYLVA_KDTREE_ELEMENTS_ENCODE_HPP

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/bih/query.hpp"
#include "sylva/core/error.hpp"
#include "sylva/kdtree/elements.hpp"
#include "sylva/shared/kd_elem_iter.h"

namespace sylva::kdtree {

/// The index words of `t` (layout: sylva/shared/kd_elem_iter.h). Throws sylva::Error when the
/// tree does not fit the layout (more than 2^30 - 1 nodes or references a leaf, 2^32 words).
inline std::vector<std::uint32_t> encode_elements(const ElementTree& t) {
    std::size_t nodes_end = SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS * t.nodes.size();
    std::size_t total = nodes_end + t.refs.size();
    if (t.nodes.empty() || total > 0xFFFFFFFFu || t.nodes.size() >= (std::size_t{1} << 30) ||
        t.element_count > 0xFFFFFFFFu || t.depth > SYLVA_KDE_STACK_SIZE)
        throw Error("kdtree::encode_elements: the tree (" + std::to_string(t.nodes.size()) + " nodes, " +
                    std::to_string(t.refs.size()) + " references, depth " + std::to_string(t.depth) +
                    ") does not fit the layout");
    std::vector<std::uint32_t> w(total, 0u);
    w[0] = SYLVA_KDE_MAGIC;
    w[1] = SYLVA_KDE_VERSION;
    w[2] = std::uint32_t(t.nodes.size());
    w[3] = std::uint32_t(t.element_count);
    w[4] = std::uint32_t(t.refs.size());
    w[5] = std::uint32_t(total);
    w[6] = t.depth;
    for (int a = 0; a < 3; ++a) {
        w[8 + a] = std::bit_cast<std::uint32_t>(t.box.lo[a]);
        w[11 + a] = std::bit_cast<std::uint32_t>(t.box.hi[a]);
    }
    for (std::size_t n = 0; n < t.nodes.size(); ++n) {
        const ElementNode& node = t.nodes[n];
        std::uint32_t* r = &w[SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS * n];
        if (node.leaf()) {
            if (std::size_t{node.first} + node.count > t.refs.size() || node.count >= (1u << 30))
                throw Error("kdtree::encode_elements: leaf " + std::to_string(n) + " lists references past the tree's");
            r[0] = SYLVA_KDE_LEAF | (node.count << SYLVA_KDE_INDEX_SHIFT);
            r[1] = std::uint32_t(nodes_end + node.first);
        } else {
            if (node.axis > 2 || node.upper <= n + 1 || node.upper >= t.nodes.size())
                throw Error("kdtree::encode_elements: node " + std::to_string(n) + " has a bad axis or upper child");
            r[0] = node.axis | (node.upper << SYLVA_KDE_INDEX_SHIFT);
            r[1] = std::bit_cast<std::uint32_t>(node.split);
        }
    }
    std::copy(t.refs.begin(), t.refs.end(), w.begin() + std::ptrdiff_t(nodes_end));
    return w;
}

/// Checks encoded words in full, beyond what the iterator checks as it goes: the header; every
/// node reached exactly once from the root (pre-order: lower child n + 1, upper child after the
/// lower subtree); split planes finite and inside the cell; depth within the header's; every
/// reference list inside the reference words and ascending, every reference below the element
/// count; every reference word used by exactly one leaf. Throws sylva::Error naming the first
/// problem.
inline void validate_elements(std::span<const std::uint32_t> words) {
    shared::Words w{words.data(), words.size()};
    if (words.size() > 0xFFFFFFFFu) throw Error("kdtree::validate_elements: more than 2^32 - 1 words");
    shared::SylvaKdeHeader h = shared::sylva_kde_read_header(w, std::uint32_t(words.size()));
    if (h.valid == 0u) throw Error("kdtree::validate_elements: the header is refused (magic, version, sizes, depth or box)");
    const std::size_t refs_begin = SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS * std::size_t{h.node_count};
    std::vector<std::uint8_t> ref_used(h.ref_words, 0);
    struct Item {
        std::uint32_t node, depth;
        Aabb cell;
    };
    std::vector<Item> stack{{0u, 0u, {h.lo, h.hi}}};
    std::uint32_t expect = 0;  // pre-order: nodes are met in index order
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        std::string at = "kdtree::validate_elements: node " + std::to_string(it.node);
        if (it.node != expect) throw Error(at + " is not where pre-order puts it (" + std::to_string(expect) + ")");
        ++expect;
        if (it.depth > h.depth) throw Error(at + " is deeper than the header's depth " + std::to_string(h.depth));
        const std::uint32_t* r = &words[SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS * std::size_t{it.node}];
        std::uint32_t axis = r[0] & SYLVA_KDE_AXIS_MASK, index = r[0] >> SYLVA_KDE_INDEX_SHIFT;
        if (axis == SYLVA_KDE_LEAF) {
            if (index == 0) continue;
            if (r[1] < refs_begin || std::size_t{r[1]} + index > words.size())
                throw Error(at + ": its reference list is outside the reference words");
            for (std::uint32_t k = 0; k < index; ++k) {
                std::size_t q = r[1] + k;
                if (words[q] >= h.elem_count) throw Error(at + ": reference " + std::to_string(words[q]) + " is not below the element count");
                if (k > 0 && words[q] <= words[q - 1]) throw Error(at + ": its references are not ascending");
                if (ref_used[q - refs_begin]++) throw Error(at + ": reference word " + std::to_string(q) + " is shared with another leaf");
            }
            continue;
        }
        float split = std::bit_cast<float>(r[1]);
        if (index <= it.node + 1 || index >= h.node_count) throw Error(at + ": bad upper child " + std::to_string(index));
        if (!std::isfinite(split) || split < it.cell.lo[axis] || split > it.cell.hi[axis])
            throw Error(at + ": split plane outside its cell");
        Item lower{it.node + 1, it.depth + 1, it.cell}, upper{index, it.depth + 1, it.cell};
        lower.cell.hi[axis] = split;
        upper.cell.lo[axis] = split;
        stack.push_back(upper);  // visited after the lower subtree, which must end at `index`
        stack.push_back(lower);
        if (stack.size() > 2 * std::size_t{h.node_count} + 2) throw Error(at + ": the links do not form a tree");
    }
    if (expect != h.node_count) throw Error("kdtree::validate_elements: " + std::to_string(h.node_count - expect) + " nodes are not reached from the root");
    for (std::size_t q = 0; q < ref_used.size(); ++q)
        if (!ref_used[q]) throw Error("kdtree::validate_elements: reference word " + std::to_string(refs_begin + q) + " belongs to no leaf");
}

namespace detail {

/// Walks `words` along `ray` and calls on_leaf(it, t0, t1, first, count) per leaf with
/// references until it returns false. Throws when the encoding is refused, does not match the
/// `size` elements, or the walk stops with an error.
template <class F>
void walk_elements(std::span<const std::uint32_t> words, std::size_t size, const Ray& ray, Interval range, F&& on_leaf) {
    shared::Words w{words.data(), words.size()};
    auto count = static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu));
    shared::SylvaKdElemIter it;
    shared::sylva_kde_init(it, w, count, ray.origin, ray.direction, range.t0, range.t1);
    if (it.hdr.valid == 0u) throw Error("kd-tree element query: the encoding's header is refused");
    if (it.elem_count != size)
        throw Error("kd-tree element query: the encoding was built over " + std::to_string(it.elem_count) + " elements, not " +
                    std::to_string(size));
    std::uint32_t node, first, n;
    float t0, t1;
    while (shared::sylva_kde_next(it, w, node, t0, t1, first, n))
        if (!on_leaf(it, t0, t1, first, n)) return;
    if (it.status == SYLVA_ITER_ERROR) throw Error("kd-tree element query: the walk met a corrupted encoding");
}

/// Element index of reference word `at`, checked.
inline std::uint32_t element_at(shared::SylvaKdElemIter& it, std::span<const std::uint32_t> words, std::uint32_t at) {
    shared::Words w{words.data(), words.size()};
    std::uint32_t e = shared::sylva_kde_element(it, w, at);
    if (e == SYLVA_KDE_NONE) throw Error("kd-tree element query: a reference is past the elements");
    return e;
}

}  // namespace detail

/// Every element the ray hits within `range`, in (entry t, element) order (bih::hit_before),
/// into `out`: each leaf keeps the hits whose entry t it claims and sorts them.
template <Intersectable E>
void all_hits(std::span<const std::uint32_t> words, std::span<const E> elements, const Ray& ray,
              std::vector<bih::ElementHit>& out, Interval range = {}) {
    out.clear();
    detail::walk_elements(words, elements.size(), ray, range,
                          [&](shared::SylvaKdElemIter& it, float t0, float t1, std::uint32_t first, std::uint32_t n) {
                              std::size_t from = out.size();
                              for (std::uint32_t k = 0; k < n; ++k) {
                                  std::uint32_t e = detail::element_at(it, words, first + k);
                                  if (auto t = intersect_element(elements[e], ray, range))
                                      if (shared::sylva_kde_claims(it, t->t0, t0, t1)) out.push_back({e, *t});
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
    detail::walk_elements(words, elements.size(), ray, range,
                          [&](shared::SylvaKdElemIter& it, float, float t1, std::uint32_t first, std::uint32_t n) {
                              for (std::uint32_t k = 0; k < n; ++k) {
                                  std::uint32_t e = detail::element_at(it, words, first + k);
                                  if (auto t = intersect_element(elements[e], ray, range)) {
                                      bih::ElementHit h{e, *t};
                                      if (!best || bih::hit_before(h, *best)) best = h;
                                  }
                              }
                              // An element not met yet is entered at or after t1: a best hit
                              // entered before t1 is final.
                              return !(best && best->t.t0 < t1);
                          });
    return best;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_ELEMENTS_ENCODE_HPP
