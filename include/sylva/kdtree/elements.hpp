// sylva/kdtree/elements.hpp -- a kd-tree over any bounded element type (issue 14, item 4), with
// refit and a rebuild that reuses memory for moving elements (item 5). Encoded by
// sylva/kdtree/elements_encode.hpp, walked by sylva/shared/kd_elem_iter.h.
//
// Scheme: spatial splits with straddling references, chosen by the surface area heuristic with
// binning (Wald and Havran 2006, "On building fast kd-trees for ray tracing, and on doing that
// in O(N log^2 N)", section 4.3's binned approximation; MacDonald and Booth's SAH). A node's
// cell is split at one of Config::bins - 1 planes per axis; the elements whose padded box
// overlaps the closed lower part go down, those overlapping the upper part go up (both when
// they straddle). The plane of least cost C_t + C_i (A_L N_L + A_R N_R) / A is taken when it
// costs less than the leaf, C_i N. Leaves tile the root cell, so the walk gives them front to
// back with intervals that tile the ray, and the caller orders hits across leaves exactly by
// claiming an element's entry t in one leaf (the element octree's rule,
// sylva/octree/elements.hpp). Why a kd-tree beside the BIH and the octree: SAH planes adapt to
// clustered elements where the octree's midpoint cells cannot, and exact order comes from the
// disjoint cells where the BIH's overlapping children give none.
//
// Moving elements: refit_elements keeps every node and plane and redistributes the elements'
// new boxes down the same planes (the root cell grows to the new box; the cells still tile it),
// so queries stay exact whatever the motion; only the SAH quality ages. rebuild_elements builds
// anew into the tree's own arrays and scratch (no allocation once their capacity suffices).
#ifndef SYLVA_KDTREE_ELEMENTS_HPP
#define SYLVA_KDTREE_ELEMENTS_HPP

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/shared/kd_elem_iter.h"

namespace sylva::kdtree {

/// Settings of kdtree::build_elements.
struct ElementConfig {
    /// A node with at most this many elements is a leaf whatever the SAH says. 8, as the
    /// element octree: measured on 1e5 uniform spheres (2 loaded cores, 1e5 rays), first hits
    /// ran at the same rate with 2, 4 and 8 (0.115, 0.117, 0.117 Mrays/s) while the build took
    /// 312, 219 and 156 ms and the tree 207k, 113k and 53k nodes.
    std::uint32_t leaf_elements = 8;
    /// Deepest leaf (root 0); at most SYLVA_KDE_STACK_SIZE, the shared iterator's stack.
    std::uint32_t max_depth = 40;
    /// Candidate planes per axis: bins - 1 (Wald and Havran section 4.3 bin; 32 is within a few
    /// percent of the exact sweep's cost on ray-tracing scenes). In [2, 256].
    std::uint32_t bins = 32;
    /// SAH costs: a traversal step and an element test (Wald and Havran use K_T = 15, K_I = 20).
    float cost_traverse = 1.0f;
    float cost_intersect = 1.5f;
    /// Element boxes are grown by this fraction of the root box's largest extent before the
    /// overlap tests, so that rounding in the walk's plane crossings never puts an element's
    /// entry t in a leaf that does not list it.
    float overlap_pad = 1e-5f;
    /// Subtrees over more elements than this are built as parallel tasks (the top levels only).
    std::size_t parallel_threshold = 4096;
};

/// One node: an inner node splits its cell along `axis` at `split` (lower child at its index
/// + 1, upper child at `upper`); a leaf (axis SYLVA_KDE_LEAF) lists refs[first, first + count).
struct ElementNode {
    float split = 0.0f;
    std::uint32_t axis = SYLVA_KDE_LEAF;
    std::uint32_t upper = 0;
    std::uint32_t first = 0;
    std::uint32_t count = 0;
    [[nodiscard]] bool leaf() const { return axis == SYLVA_KDE_LEAF; }
};

/// The built tree: nodes in pre-order, the leaves' reference lists, the root cell.
struct ElementTree {
    std::vector<ElementNode> nodes;
    std::vector<std::uint32_t> refs;
    Aabb box;                        ///< the root cell: the elements' box, padded
    std::size_t element_count = 0;
    std::uint32_t depth = 0;         ///< deepest leaf
    std::size_t leaves = 0;
    double build_ms = 0.0;
    /// Scratch kept between rebuilds and refits (padded element boxes).
    std::vector<Aabb> scratch_boxes;

    [[nodiscard]] std::span<const std::uint32_t> list(const ElementNode& n) const { return {refs.data() + n.first, n.count}; }
};

namespace detail {

/// Nodes and references one build task made; indices local to it.
struct Fragment {
    std::vector<ElementNode> nodes;
    std::vector<std::uint32_t> refs;
    std::uint32_t depth = 0;
    std::size_t leaves = 0;
};

/// Appends `f` to `out`, shifting its node and reference indices.
inline void append(Fragment& out, const Fragment& f) {
    auto node_base = static_cast<std::uint32_t>(out.nodes.size());
    auto ref_base = static_cast<std::uint32_t>(out.refs.size());
    for (ElementNode n : f.nodes) {
        if (n.leaf()) n.first += ref_base;
        else n.upper += node_base;
        out.nodes.push_back(n);
    }
    out.refs.insert(out.refs.end(), f.refs.begin(), f.refs.end());
    out.depth = std::max(out.depth, f.depth);
    out.leaves += f.leaves;
}

inline float half_area(vec3 e) { return e.x * e.y + e.y * e.z + e.z * e.x; }

/// A split choice: axis (SYLVA_KDE_LEAF for a leaf) and plane.
struct Choice {
    std::uint32_t axis = SYLVA_KDE_LEAF;
    float split = 0.0f;
};

/// What the build distributes: an element's padded box and its index. The records move with
/// the splits (copied to both children when they straddle), so every pass reads them in
/// sequence instead of gathering boxes through indices.
struct Rec {
    float lo[3];
    std::uint32_t index;
    float hi[3];
    std::uint32_t pad;
};

/// Binned SAH over the records `r` in `cell` (Wald and Havran 4.3): per axis, the bins of the
/// boxes' lo and hi (clamped to the cell) give N_L and N_R at each bin boundary; one pass over
/// the records bins all three axes.
inline Choice sah(const std::vector<Rec>& r, const Aabb& cell, const ElementConfig& cfg) {
    Choice best;
    const std::size_t n = r.size();
    if (n <= cfg.leaf_elements) return best;
    vec3 ext = cell.extent();
    float area = std::max(half_area(ext), 1e-30f);
    float best_cost = cfg.cost_intersect * float(n);
    // Nodes of few elements use fewer bins (at least 8, at most one per element): the cost
    // sweep, not the binning, dominated the build of small nodes.
    const std::uint32_t bins = std::min<std::uint32_t>(cfg.bins, std::max<std::uint32_t>(8u, std::uint32_t(std::min<std::size_t>(n, 256))));
    const float inv_area = 1.0f / area;
    std::array<std::array<std::uint32_t, 256>, 3> lo_count, hi_count;  // only [0, bins) used: zero those
    for (int a = 0; a < 3; ++a) {
        std::fill_n(lo_count[a].begin(), bins, 0u);
        std::fill_n(hi_count[a].begin(), bins, 0u);
    }
    float scale[3], top = float(bins - 1);
    for (int a = 0; a < 3; ++a) scale[a] = ext[a] > 0.0f ? float(bins) / ext[a] : 0.0f;
    for (const Rec& e : r) {
        for (int a = 0; a < 3; ++a) {
            float l = (e.lo[a] - cell.lo[a]) * scale[a], h = (e.hi[a] - cell.lo[a]) * scale[a];
            ++lo_count[a][std::uint32_t(std::clamp(l, 0.0f, top))];
            ++hi_count[a][std::uint32_t(std::clamp(h, 0.0f, top))];
        }
    }
    for (std::uint32_t a = 0; a < 3; ++a) {
        if (!(ext[a] > 0.0f)) continue;
        // Boundary k (1..bins-1): N_L = boxes starting in bins < k, N_R = boxes ending in bins >= k.
        std::uint32_t left = 0, right = std::uint32_t(n);
        for (std::uint32_t k = 1; k < bins; ++k) {
            left += lo_count[a][k - 1];
            right -= hi_count[a][k - 1];
            float split = cell.lo[a] + float(k) * (ext[a] / float(bins));
            vec3 el = ext, er = ext;
            el[a] = split - cell.lo[a];
            er[a] = cell.hi[a] - split;
            float cost = cfg.cost_traverse +
                         cfg.cost_intersect * (half_area(el) * float(left) + half_area(er) * float(right)) * inv_area;
            if (cost < best_cost && !(left == n && right == n)) {
                best_cost = cost;
                best.axis = a;
                best.split = split;
            }
        }
    }
    return best;
}

/// Builds (or, with a template tree, refits) the subtree over the records `r` in `cell`.
/// Build: the SAH chooses; refit: the template's node at `at` decides, so the result has its
/// topology.
template <Executor X>
class Builder {
public:
    Builder(const ElementConfig& cfg, X& exec, const std::vector<ElementNode>* tmpl) : cfg_(cfg), exec_(exec), tmpl_(tmpl) {
        std::size_t c = exec.concurrency(), d = 0;
        while ((std::size_t{1} << d) < c) ++d;
        parallel_depth_ = c > 1 ? std::uint32_t(2 * d + 2) : 0u;
    }

    void node(Fragment& out, std::vector<Rec> r, const Aabb& cell, std::uint32_t depth, std::uint32_t at) {
        Choice c = choose(r, cell, depth, at);
        if (c.axis == SYLVA_KDE_LEAF) {
            ElementNode leaf;
            leaf.first = std::uint32_t(out.refs.size());
            leaf.count = std::uint32_t(r.size());
            for (const Rec& e : r) out.refs.push_back(e.index);
            out.nodes.push_back(leaf);
            out.depth = std::max(out.depth, depth);
            ++out.leaves;
            return;
        }
        std::size_t nl = 0, nu = 0;
        for (const Rec& e : r) {  // closed cells: a box touching the plane goes to both
            nl += e.lo[c.axis] <= c.split;
            nu += e.hi[c.axis] >= c.split;
        }
        std::vector<Rec> lower(nl), upper(nu);
        nl = nu = 0;
        for (const Rec& e : r) {
            if (e.lo[c.axis] <= c.split) lower[nl++] = e;
            if (e.hi[c.axis] >= c.split) upper[nu++] = e;
        }
        std::size_t n = r.size();
        std::vector<Rec>().swap(r);
        Aabb lc = cell, uc = cell;
        lc.hi[c.axis] = c.split;
        uc.lo[c.axis] = c.split;
        std::uint32_t self = std::uint32_t(out.nodes.size());
        ElementNode inner;
        inner.axis = c.axis;
        inner.split = c.split;
        out.nodes.push_back(inner);
        std::uint32_t at_lower = tmpl_ ? at + 1 : 0, at_upper = tmpl_ ? (*tmpl_)[at].upper : 0;
        if (depth < parallel_depth_ && n > cfg_.parallel_threshold) {
            Fragment fl, fu;
            exec_.invoke([&] { node(fl, std::move(lower), lc, depth + 1, at_lower); },
                         [&] { node(fu, std::move(upper), uc, depth + 1, at_upper); });
            append(out, fl);
            out.nodes[self].upper = std::uint32_t(out.nodes.size());
            append(out, fu);
            return;
        }
        node(out, std::move(lower), lc, depth + 1, at_lower);
        out.nodes[self].upper = std::uint32_t(out.nodes.size());
        node(out, std::move(upper), uc, depth + 1, at_upper);
    }

private:
    Choice choose(const std::vector<Rec>& r, const Aabb& cell, std::uint32_t depth, std::uint32_t at) const {
        if (tmpl_) {
            const ElementNode& t = (*tmpl_)[at];
            return t.leaf() ? Choice{} : Choice{t.axis, t.split};
        }
        if (depth >= cfg_.max_depth) return {};
        return sah(r, cell, cfg_);
    }

    const ElementConfig& cfg_;
    X& exec_;
    const std::vector<ElementNode>* tmpl_;
    std::uint32_t parallel_depth_ = 0;
};

inline void check_config(const ElementConfig& cfg) {
    if (cfg.max_depth > SYLVA_KDE_STACK_SIZE)
        throw Error("kdtree::build_elements: max_depth " + std::to_string(cfg.max_depth) + " is over " +
                    std::to_string(SYLVA_KDE_STACK_SIZE) + " (the iterator's stack)");
    if (cfg.bins < 2 || cfg.bins > 256) throw Error("kdtree::build_elements: bins must be in [2, 256]");
    if (!(cfg.cost_traverse >= 0.0f && cfg.cost_intersect > 0.0f && std::isfinite(cfg.cost_traverse) &&
          std::isfinite(cfg.cost_intersect)))
        throw Error("kdtree::build_elements: SAH costs must be finite, cost_intersect > 0");
    if (!(cfg.overlap_pad >= 0.0f && cfg.overlap_pad <= 0.01f))
        throw Error("kdtree::build_elements: overlap_pad must be in [0, 0.01]");
}

/// Fills `boxes` with the padded element boxes (empty boxes stay empty and are never listed)
/// and returns the root cell. Throws naming the first element whose box is not finite.
template <Bounded E, Executor X>
Aabb padded_boxes(std::span<const E> elements, const ElementConfig& cfg, std::vector<Aabb>& boxes, X& exec) {
    boxes.resize(elements.size());
    std::size_t blocks = (elements.size() + 16383) / 16384;
    std::vector<Aabb> part(blocks);
    std::vector<std::size_t> bad(blocks, elements.size());
    exec.parallel_for(0, blocks, 1, [&](std::size_t b0, std::size_t b1) {
        for (std::size_t b = b0; b < b1; ++b) {
            for (std::size_t i = b * 16384, end = std::min(elements.size(), i + 16384); i < end; ++i) {
                Aabb x = bounds_of(elements[i]);
                boxes[i] = x;
                if (x.empty()) continue;
                if (!x.finite()) bad[b] = std::min(bad[b], i);
                else part[b].extend(x);
            }
        }
    });
    for (std::size_t b : bad)
        if (b < elements.size()) throw Error("kdtree::build_elements: element " + std::to_string(b) + "'s box is not finite");
    Aabb scene;
    for (const Aabb& u : part) scene.extend(u);
    if (scene.empty()) return scene;
    vec3 ext = scene.extent();
    float pad = cfg.overlap_pad * std::max({ext.x, ext.y, ext.z, 1e-30f});
    if (!all_finite(ext) || !std::isfinite(pad)) throw Error("kdtree::build_elements: the elements' box is too large for float arithmetic");
    exec.parallel_for(0, boxes.size(), 16384, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i)
            if (!boxes[i].empty()) boxes[i] = {boxes[i].lo - vec3(pad), boxes[i].hi + vec3(pad)};
    });
    return {scene.lo - vec3(2.0f * pad), scene.hi + vec3(2.0f * pad)};
}

/// Builds (tmpl null) or refits (tmpl: the old nodes) into `t`, reusing its arrays.
template <Bounded E, Executor X>
void build_into(ElementTree& t, std::span<const E> elements, const ElementConfig& cfg, X& exec,
                const std::vector<ElementNode>* tmpl) {
    auto start = std::chrono::steady_clock::now();
    check_config(cfg);
    if (elements.size() >= (std::size_t{1} << 30))
        throw Error("kdtree::build_elements: too many elements (at most 2^30 - 1: the meta word's count field)");
    Aabb cell = padded_boxes(elements, cfg, t.scratch_boxes, exec);
    std::vector<Rec> recs;
    recs.reserve(elements.size());
    for (std::uint32_t i = 0; i < elements.size(); ++i) {
        const Aabb& b = t.scratch_boxes[i];
        if (!b.empty()) recs.push_back({{b.lo.x, b.lo.y, b.lo.z}, i, {b.hi.x, b.hi.y, b.hi.z}, 0u});
    }
    if (cell.empty()) cell = {vec3(0.0f), vec3(0.0f)};
    if (tmpl) cell.extend(t.box);  // the old planes must still cut the root cell
    Fragment root;
    root.nodes = std::move(t.nodes);
    root.refs = std::move(t.refs);
    root.nodes.clear();
    root.refs.clear();
    Builder<X> b(cfg, exec, tmpl);
    b.node(root, std::move(recs), cell, 0, 0);
    t.nodes = std::move(root.nodes);
    t.refs = std::move(root.refs);
    t.box = cell;
    t.element_count = elements.size();
    t.depth = root.depth;
    t.leaves = root.leaves;
    t.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace detail

/// Builds the kd-tree of `elements` (any Bounded type) on `exec`. Throws sylva::Error for a bad
/// configuration, a non-finite element box, or 2^30 elements or more. Elements with empty boxes
/// are never listed; an input without any gives one empty leaf.
template <Bounded E, Executor X>
ElementTree build_elements(std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    ElementTree t;
    detail::build_into(t, elements, cfg, exec, nullptr);
    return t;
}

/// build_elements on the calling thread.
template <Bounded E>
ElementTree build_elements(std::span<const E> elements, const ElementConfig& cfg = {}) {
    SerialExecutor serial;
    return build_elements(elements, cfg, serial);
}

/// Builds `t` anew over `elements` (moved), reusing its node, reference and scratch arrays.
/// The result equals build_elements(elements, cfg) node for node.
template <Bounded E, Executor X>
void rebuild_elements(ElementTree& t, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    detail::build_into(t, elements, cfg, exec, nullptr);
}

/// Refit: keeps every node and plane of `t` and lists each leaf's elements anew from their
/// current boxes (the root cell grows to hold them). `cfg` must be the configuration `t` was
/// built with (its overlap_pad pads the boxes). Throws sylva::Error when `elements` is not the
/// set `t` was built over (another count) or a box is not finite; then `t` is left as it was.
template <Bounded E, Executor X>
void refit_elements(ElementTree& t, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    if (elements.size() != t.element_count || t.nodes.empty())
        throw Error("kdtree::refit_elements: the tree was built over " + std::to_string(t.element_count) +
                    " elements, not " + std::to_string(elements.size()));
    std::vector<ElementNode> tmpl = t.nodes;  // the topology (the nodes are rewritten in place)
    detail::build_into(t, elements, cfg, exec, &tmpl);
}

}  // namespace sylva::kdtree

#endif  // SYLVA_KDTREE_ELEMENTS_HPP
