// sylva/kdtree/query.hpp -- host-side convenience over the shared iterator (shared/kd_iter.h).
#ifndef SYLVA_KDTREE_QUERY_HPP
#define SYLVA_KDTREE_QUERY_HPP

#include <algorithm>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "sylva/core/ray.hpp"
#include "sylva/shared/kd_iter.h"

namespace sylva::kdtree {

/// One leaf a ray passes through: its leaf index, its node and where the ray is inside it.
struct LeafHit {
    std::uint32_t leaf = 0;
    std::uint32_t node = 0;
    Interval t;
    friend bool operator==(const LeafHit&, const LeafHit&) = default;
};

/// The leaves along a ray, front to back, through the shared iterator.
class LeafIterator {
public:
    LeafIterator(std::span<const std::uint32_t> words, const Ray& ray, Interval range = {})
        : words_{words.data(), words.size()} {
        shared::sylva_kd_init(it_, words_, static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)),
                              ray.origin, ray.direction, range.t0, range.t1);
    }
    /// The next leaf, or nothing when the traversal is over.
    std::optional<LeafHit> next() {
        std::uint32_t leaf;
        float t0, t1;
        if (!shared::sylva_kd_next(it_, words_, leaf, t0, t1)) return std::nullopt;
        return LeafHit{leaf, it_.leaf_node, {t0, t1}};
    }
    /// Prunes everything entered after t (early ray termination).
    void clip(float t) { shared::sylva_kd_clip(it_, t); }
    [[nodiscard]] std::uint32_t steps() const { return it_.steps; }
    /// SYLVA_ITER_RUNNING, SYLVA_ITER_DONE or SYLVA_ITER_ERROR (corrupted encoding).
    [[nodiscard]] std::uint32_t status() const { return it_.status; }

private:
    shared::Words words_;
    shared::SylvaKdIter it_;
};

/// Every leaf along the ray, in iterator order.
inline std::vector<LeafHit> leaves_along(std::span<const std::uint32_t> words, const Ray& ray, Interval range = {}) {
    std::vector<LeafHit> out;
    LeafIterator it(words, ray, range);
    while (auto h = it.next()) out.push_back(*h);
    return out;
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_QUERY_HPP
