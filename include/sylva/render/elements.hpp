// sylva/render/elements.hpp -- the generic element kernels (sylva/shared/element_kernels.h) on the
// host: records for any element type written in the shared subset (sylva/shared/element.h),
// hits in order, first hit, and front-to-back compositing over a BIH of record ranges, with the
// same shared code the GPU runs (sylva/vulkan/elements.hpp).
#ifndef SYLVA_RENDER_ELEMENTS_HPP
#define SYLVA_RENDER_ELEMENTS_HPP

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/render/particles.hpp"
#include "sylva/shared/bih_layout.h"
#include "sylva/shared/element.h"
#include "sylva/shared/element_bih.h"
#include "sylva/shared/element_kd.h"
#include "sylva/shared/element_kernels.h"
#include "sylva/shared/element_octree.h"

namespace sylva {

/// An element type written once in the shared subset: the protocol of sylva/shared/element.h,
/// found by argument-dependent lookup (sylva_elem_store is the C++-only part).
template <class E>
concept SharedElement = std::default_initializable<E> && std::copyable<E> &&
    requires(const E& e, E& out, const shared::Words& w, vec3& v, shared::RecordOut rec) {
        { sylva_elem_words(e) } -> std::convertible_to<std::uint32_t>;
        sylva_elem_load(w, 0u, out);
        sylva_elem_bounds(e, v, v);
        { sylva_elem_interval(e, v, v, 0.0f, 0.0f) } -> std::same_as<vec2>;
        { sylva_elem_medium(e, v, v, 0.0f, 0.0f) } -> std::same_as<vec4>;
        sylva_elem_store(e, rec);
    };

/// Words of one record of E.
template <SharedElement E>
std::uint32_t element_words() {
    return static_cast<std::uint32_t>(sylva_elem_words(E{}));
}

/// The records of `elements` in `order` (a BIH's element order; empty: storage order), as
/// sylva_elem_load reads them. Throws sylva::Error when a record's size is 0, when the records
/// need more than 2^32 words, when sylva_elem_store writes past its record, or when the reloaded
/// element's box differs from the original's (store and load disagree).
template <SharedElement E>
std::vector<std::uint32_t> pack_elements(std::span<const E> elements, std::span<const std::uint32_t> order = {}) {
    const std::uint32_t n = element_words<E>();
    const std::size_t count = order.empty() ? elements.size() : order.size();
    if (n == 0) throw Error("pack_elements: sylva_elem_words is 0");
    if (count > 0xFFFFFFFFull / n) throw Error("pack_elements: " + std::to_string(count) + " records of " +
                                               std::to_string(n) + " words need more than 2^32 words");
    std::vector<std::uint32_t> w(count * n, 0u);
    std::uint32_t overruns = 0;
    for (std::size_t i = 0; i < count; ++i) {
        std::size_t src = order.empty() ? i : order[i];
        if (src >= elements.size())
            throw Error("pack_elements: order names element " + std::to_string(src) + " of " +
                        std::to_string(elements.size()));
        sylva_elem_store(elements[src], shared::RecordOut{&w[i * n], n, &overruns});
        if (overruns) throw Error("pack_elements: sylva_elem_store wrote past the record's " + std::to_string(n) + " words");
        E back{};
        sylva_elem_load(shared::Words{w.data(), w.size()}, static_cast<std::uint32_t>(i), back);
        Aabb a = bounds_of(elements[src]), b = bounds_of(back);
        if (!(a.lo == b.lo && a.hi == b.hi))
            throw Error("pack_elements: element " + std::to_string(src) +
                        " reloads with a different box: sylva_elem_store and sylva_elem_load disagree");
    }
    return w;
}

/// Element hits of one ray, in order (sylva_hits_next).
struct ElementHits {
    std::vector<shared::SylvaHit> hits;
    std::uint32_t status = 0;  ///< SYLVA_ITER_DONE, or SYLVA_ITER_ERROR for a corrupted encoding
    std::uint32_t steps = 0;   ///< index nodes visited, over all passes
    std::uint32_t passes = 0;  ///< index traversals (more than 1 when the hit window overflowed)
    bool more = false;         ///< hits followed the last one kept (max_hits reached)
};

/// The element indices the generic kernels take: the iterator state type of an index adapter.
/// BIH (bih::encode with RangePayload; records in tree order, pack_elements(es, tree.order)),
/// kd-tree (kdtree::encode_elements) and octree (octree::encode_elements) over elements
/// (records in the caller's order, pack_elements(es)).
using BihIndex = shared::SylvaBihIter;
using KdIndex = shared::SylvaKdElemIter;
using OctreeIndex = shared::SylvaOctElemIter;

/// Throws sylva::Error unless `words` is an encoding the index I reads (for the BIH: of record
/// ranges) and `records` a whole number of E's records; returns the record count.
template <SharedElement E, class I = BihIndex>
std::uint32_t check_element_inputs(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                                   const char* who) {
    if constexpr (std::is_same_v<I, BihIndex>) {
        if (words.size() < SYLVA_BIH_HEADER_WORDS || words[0] != SYLVA_BIH_MAGIC)
            throw Error(std::string(who) + ": not an encoded BIH");
    } else if constexpr (std::is_same_v<I, KdIndex>) {
        if (words.empty() || words[0] != SYLVA_KDE_MAGIC) throw Error(std::string(who) + ": not an encoded element kd-tree");
    }
    if (std::is_same_v<I, BihIndex> && ((words[2] >> 8) & 255u) != SYLVA_PAYLOAD_RANGE)
        throw Error(std::string(who) + ": the BIH's payload kind " + std::to_string((words[2] >> 8) & 255u) +
                    " is not record ranges (SYLVA_PAYLOAD_RANGE, 0)");
    if (words.size() > 0xFFFFFFFFu) throw Error(std::string(who) + ": encoding over 2^32 words");
    const std::uint32_t n = element_words<E>();
    if (records.size() % n != 0)
        throw Error(std::string(who) + ": " + std::to_string(records.size()) + " record words are not a whole number of " +
                    std::to_string(n) + "-word records");
    if (records.size() / n > 0xFFFFFFFFu) throw Error(std::string(who) + ": too many records");
    return static_cast<std::uint32_t>(records.size() / n);
}

/// The hits of `ray` over `range` in order, at most `max_hits` of them (host, shared kernel).
template <SharedElement E, class I = BihIndex>
ElementHits element_hits_cpu(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                             const Ray& ray, Interval range, std::uint32_t max_hits = 0xFFFFFFFFu) {
    std::uint32_t elem_count = check_element_inputs<E, I>(words, records, "element_hits_cpu");
    shared::Words w{words.data(), words.size()}, e{records.data(), records.size()};
    shared::SylvaHitIter h;
    I it;
    shared::sylva_hits_init<E, I>(h, it, w, static_cast<std::uint32_t>(words.size()), elem_count,
                                                     ray.origin, ray.direction, range.t0, range.t1);
    shared::sylva_hits_want(h, max_hits < 0xFFFFFFFFu ? max_hits + 1u : max_hits);  // +1: is there more?
    ElementHits out;
    shared::SylvaHit hit;
    while (shared::sylva_hits_next<E, I>(h, it, w, e, hit)) {
        if (out.hits.size() == max_hits) {
            out.more = true;
            break;
        }
        out.hits.push_back(hit);
    }
    out.status = h.status;
    out.steps = shared::sylva_hits_steps<E, I>(h, it);
    out.passes = h.passes;
    return out;
}

/// Renders elements front to back (sylva_elements_composite) on the host: premultiplied RGBA,
/// steps per pixel (0xFFFFFFFF marks an index error), same arithmetic as the GPU kernel.
template <SharedElement E, class I = BihIndex, Executor X>
Frame render_elements_cpu(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                          const CameraFrame& cam, std::uint32_t width, std::uint32_t height, X& exec,
                          const ParticleRenderConfig& cfg = {}) {
    std::uint32_t elem_count = check_element_inputs<E, I>(words, records, "render_elements_cpu");
    shared::Words w{words.data(), words.size()}, e{records.data(), records.size()};
    const std::uint32_t word_count = detail::word_count32(words);
    return detail::render_pixel_rays(cam, width, height, exec, cfg,
                                     [&](vec3 o, vec3 d, std::uint32_t& steps, std::uint32_t& status) {
                                         return shared::sylva_elements_composite<E, I>(
                                             w, word_count, e, elem_count, o, d, 0.0f, shared::sylva_inf(),
                                             cfg.alpha_stop, steps, status);
                                     });
}

/// Composites one ray through any RayInteraction type on the host (also C++-only types that do
/// not use the shared protocol): `words` an encoded BIH of record ranges built over `elements`
/// and `in_order` the elements in the tree's order (tree.order applied). Every element the ray
/// crosses within `range` (intersect_element over the leaves), sorted by (t0, index), then
/// interact_element over its own interval, front to back with opacity Contribution::alpha(),
/// until `alpha_stop`. Collects the ray's hits (no window): host-only, exact order.
template <class E>
    requires Intersectable<E> && RayInteraction<E>
vec4 composite_interactions(std::span<const std::uint32_t> words, std::span<const E> in_order, const Ray& ray,
                            Interval range, float alpha_stop, std::vector<shared::SylvaHit>& scratch) {
    shared::Words w{words.data(), words.size()};
    shared::SylvaBihIter it;
    shared::sylva_index_init(it, w, static_cast<std::uint32_t>(words.size()), ray.origin, ray.direction, range.t0,
                             range.t1);
    scratch.clear();
    std::uint32_t first, count;
    float t_in, t_out;
    while (shared::sylva_index_leaf(it, w, first, count, t_in, t_out)) {
        if (count > in_order.size() || first > in_order.size() - count)
            throw Error("composite_interactions: a leaf addresses elements past the " +
                        std::to_string(in_order.size()) + " given");
        for (std::uint32_t k = first; k < first + count; ++k)
            if (auto t = intersect_element(in_order[k], ray, range)) scratch.push_back({k, t->t0, t->t1});
    }
    if (it.status == SYLVA_ITER_ERROR) throw Error("composite_interactions: not an encoded BIH of record ranges");
    std::sort(scratch.begin(), scratch.end(), [](const shared::SylvaHit& a, const shared::SylvaHit& b) {
        return a.t0 < b.t0 || (a.t0 == b.t0 && a.elem < b.elem);
    });
    vec3 rgb(0.0f);
    float alpha = 0.0f;
    for (const auto& h : scratch) {
        if (!(alpha < alpha_stop)) break;
        auto c = interact_element(in_order[h.elem], ray, Interval{h.t0, h.t1});
        if (!c) continue;
        float k = (1.0f - alpha) * c->alpha();
        rgb = vec3(rgb.x + k * c->rgb.x, rgb.y + k * c->rgb.y, rgb.z + k * c->rgb.z);
        alpha = alpha + k;
    }
    return vec4(rgb, alpha);
}

}  // namespace sylva

#endif  // SYLVA_RENDER_ELEMENTS_HPP
