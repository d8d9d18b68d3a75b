// sylva/bih/stats.hpp -- per-node statistics of a built BIH (Kinkelin section 5.2) and the
// "full" intermediate BIH of section 6.1 that levels of detail are extracted from.
//
// Every node gets the statistics of the elements in its subtree: count, summed element
// volume, element density sum(V_element) / V_box, mean and variance of the normalised density,
// mean gradient, and the min/max of the raw and of the linearly reconstructed density (for the
// iso-value culling of section 4.1). They are computed bottom-up: leaves from their elements,
// inner nodes by merging their children with the parallel formulas of Chan, Golub and LeVeque
// (mean and sum of squared deviations, in double). Node boxes are computed top-down from the
// root box (the tree's `bounds`) and the bounding planes, for both empty-child variants.
#ifndef SYLVA_BIH_STATS_HPP
#define SYLVA_BIH_STATS_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "sylva/bih/build.hpp"
#include "sylva/bih/tree.hpp"
#include "sylva/core/aabb.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/elements/voxel.hpp"

namespace sylva::bih {

namespace detail {
template <class E>
concept HasDensityMembers = requires(const E& e) {
    { e.density } -> std::convertible_to<float>;
    { e.gradient } -> std::convertible_to<vec3>;
};
template <class E>
concept HasDensityFunctions = requires(const E& e) {
    { element_density(e) } -> std::convertible_to<float>;
    { element_gradient(e) } -> std::convertible_to<vec3>;
};
}  // namespace detail

/// An element carrying a normalised density and a gradient (change of density across one voxel
/// along x, y, z): data members `density` and `gradient` (VoxelCuboid), or ADL functions
/// `element_density(e)` and `element_gradient(e)` (any other type: an RBF sample, a particle
/// with a mass; tests/refit/test_density.cpp uses Gaussian RBFs).
template <class E>
concept DensityElement = Bounded<E> && (detail::HasDensityMembers<E> || detail::HasDensityFunctions<E>);

/// The density of a DensityElement, whichever way it carries it.
template <DensityElement E>
float density_of(const E& e) {
    if constexpr (detail::HasDensityMembers<E>) return e.density;
    else return element_density(e);
}

/// The gradient of a DensityElement, whichever way it carries it.
template <DensityElement E>
vec3 gradient_of(const E& e) {
    if constexpr (detail::HasDensityMembers<E>) return e.gradient;
    else return element_gradient(e);
}

/// Statistics of the elements in one node's subtree (Kinkelin section 5.2). Elements count
/// equally (for the voxels of one grid, all of the same volume, this is the per-voxel mean).
struct NodeStats {
    std::uint32_t count = 0;         ///< elements in the subtree
    float element_density = 0.0f;   ///< sum(V_element) / V_box; 1 for a flat box; > 1 only if elements overlap
    double element_volume = 0.0;     ///< sum(V_element)
    double mean = 0.0;               ///< mean normalised density
    double m2 = 0.0;                 ///< sum of squared deviations from the mean
    vec3 mean_gradient{0.0f};        ///< mean gradient
    float min_density = 0.0f;        ///< smallest raw element density
    float max_density = 0.0f;        ///< largest raw element density
    float min_reconstructed = 0.0f;  ///< smallest d + g . o over the elements' boxes (unclamped)
    float max_reconstructed = 0.0f;  ///< largest d + g . o over the elements' boxes (unclamped)

    /// Population variance of the normalised density.
    [[nodiscard]] double variance() const { return count ? m2 / static_cast<double>(count) : 0.0; }
    /// Standard deviation of the normalised density (the LoD criterion of section 5.2).
    [[nodiscard]] double std_dev() const { return std::sqrt(variance()); }
};

/// Merges the statistics of two disjoint element sets (Chan et al.'s pairwise update).
/// Box-dependent `element_density` is left for the caller.
inline NodeStats merge(const NodeStats& a, const NodeStats& b) {
    if (a.count == 0) return b;
    if (b.count == 0) return a;
    NodeStats s;
    double na = a.count, nb = b.count, n = na + nb, delta = b.mean - a.mean;
    s.count = a.count + b.count;
    s.element_volume = a.element_volume + b.element_volume;
    s.mean = a.mean + delta * (nb / n);
    s.m2 = a.m2 + b.m2 + delta * delta * (na * nb / n);
    s.mean_gradient = vec3((glm::dvec3(a.mean_gradient) * na + glm::dvec3(b.mean_gradient) * nb) / n);
    s.min_density = std::min(a.min_density, b.min_density);
    s.max_density = std::max(a.max_density, b.max_density);
    s.min_reconstructed = std::min(a.min_reconstructed, b.min_reconstructed);
    s.max_reconstructed = std::max(a.max_reconstructed, b.max_reconstructed);
    return s;
}

/// Range of the linear reconstruction d + g . ((x - c) / voxel_size) over an element's box:
/// d -+ sum_a |g_a| * half_extent_a / voxel_size_a.
inline vec2 reconstructed_range(float density, vec3 gradient, const Aabb& box, vec3 voxel_size) {
    vec3 half = box.extent() * 0.5f;
    double reach = 0.0;
    for (int a = 0; a < 3; ++a)
        if (voxel_size[a] > 0.0f) reach += std::fabs(double(gradient[a])) * double(half[a]) / double(voxel_size[a]);
    return vec2(float(double(density) - reach), float(double(density) + reach));
}

/// Statistics of one element; throws sylva::Error naming it when density or gradient is NaN/inf.
template <DensityElement E>
NodeStats element_stats(const E& e, std::uint32_t index, vec3 voxel_size) {
    float d = density_of(e);
    vec3 g = gradient_of(e);
    if (!std::isfinite(d) || !all_finite(g))
        throw Error("bih::node_stats: element " + std::to_string(index) + " has a non-finite density or gradient");
    Aabb box = bounds_of(e);
    vec2 r = reconstructed_range(d, g, box, voxel_size);
    NodeStats s;
    s.count = 1;
    s.element_volume = box.empty() ? 0.0 : double(box.extent().x) * box.extent().y * box.extent().z;
    s.mean = d;
    s.mean_gradient = g;
    s.min_density = s.max_density = d;
    s.min_reconstructed = r.x;
    s.max_reconstructed = r.y;
    return s;
}

namespace detail {

/// True when child slot c of node n holds a stored child (a single-child node uses slot 0 only).
inline bool has_child(const Node& n, int c) { return !n.leaf() && n.child[c] != kNoChild && !(n.single && c == 1); }

/// Nodes in pre-order (parents before children); throws sylva::Error for an empty tree, a child
/// index out of range or a node reached twice.
inline std::vector<std::uint32_t> preorder(const Tree& t) {
    if (t.nodes.empty()) throw Error("bih::node_stats: empty tree");
    std::vector<std::uint32_t> out, stack{0u};
    std::vector<std::uint8_t> seen(t.nodes.size(), 0);
    out.reserve(t.nodes.size());
    while (!stack.empty()) {
        std::uint32_t i = stack.back();
        stack.pop_back();
        if (i >= t.nodes.size()) throw Error("bih::node_stats: child index " + std::to_string(i) + " out of range");
        if (seen[i]) throw Error("bih::node_stats: node " + std::to_string(i) + " is reached twice");
        seen[i] = 1;
        out.push_back(i);
        const Node& n = t.nodes[i];
        if (n.leaf()) continue;
        for (int c = 1; c >= 0; --c)
            if (has_child(n, c)) stack.push_back(n.child[c]);
    }
    return out;
}

/// The boxes of the children of inner node `n` whose box is `box`: child[0] ends at plane[0]
/// (lies within [plane[0], plane[1]] when `single`), child[1] starts at plane[1].
inline void child_boxes(const Node& n, const Aabb& box, Aabb out[2]) {
    out[0] = out[1] = box;
    if (n.single) {
        out[0].lo[n.axis] = n.plane[0];
        out[0].hi[n.axis] = n.plane[1];
        return;
    }
    out[0].hi[n.axis] = n.plane[0];
    out[1].lo[n.axis] = n.plane[1];
}

}  // namespace detail

/// The enclosing box of every node, top-down from the root box `tree.bounds` (Kinkelin Alg. 2):
/// a left child's box ends at plane[0], a right child's starts at plane[1], a single child
/// (the "elaborate" variant) lies within [plane[0], plane[1]]; with the +-inf variant the
/// stored child is trimmed on its one side. Throws sylva::Error for a malformed tree.
inline std::vector<Aabb> node_boxes(const Tree& tree) {
    std::vector<Aabb> boxes(tree.nodes.size());
    std::vector<std::uint32_t> order = detail::preorder(tree);
    boxes[0] = tree.bounds;
    for (std::uint32_t i : order) {
        const Node& n = tree.nodes[i];
        if (n.leaf()) continue;
        Aabb kids[2];
        detail::child_boxes(n, boxes[i], kids);
        for (int c = 0; c < 2; ++c)
            if (detail::has_child(n, c)) boxes[n.child[c]] = kids[c];
    }
    return boxes;
}

namespace detail {

/// Statistics of leaf `n` from its elements; throws for element references out of range.
template <DensityElement E>
NodeStats leaf_stats(const Tree& t, const Node& n, std::span<const E> elements, vec3 voxel_size) {
    if (std::size_t{n.first} + n.count > t.order.size())
        throw Error("bih::node_stats: a leaf refers to order entries beyond " + std::to_string(t.order.size()));
    NodeStats s;
    for (std::uint32_t k = 0; k < n.count; ++k) {
        std::uint32_t e = t.order[n.first + k];
        if (e >= elements.size())
            throw Error("bih::node_stats: a leaf refers to element " + std::to_string(e) + " of " +
                        std::to_string(elements.size()));
        s = merge(s, element_stats(elements[e], e, voxel_size));
    }
    return s;
}

inline float element_density(double element_volume, const Aabb& box) {
    vec3 e = box.extent();
    double v = double(e.x) * e.y * e.z;
    return v > 0.0 ? float(element_volume / v) : 1.0f;
}

}  // namespace detail

/// Per-node statistics of `tree` built over `elements`, bottom-up (leaves in parallel on
/// `exec`, then one merge pass children-before-parents). `boxes` are the node boxes
/// (node_boxes) and `voxel_size` the world size of one voxel, the unit of the gradients.
/// Throws sylva::Error for a malformed tree, mismatched sizes or a NaN density/gradient.
template <DensityElement E, Executor X>
std::vector<NodeStats> node_stats(const Tree& tree, std::span<const E> elements, std::span<const Aabb> boxes,
                                  vec3 voxel_size, X& exec) {
    std::vector<std::uint32_t> order = detail::preorder(tree);
    if (boxes.size() != tree.nodes.size())
        throw Error("bih::node_stats: " + std::to_string(boxes.size()) + " boxes for " +
                    std::to_string(tree.nodes.size()) + " nodes");
    std::vector<NodeStats> stats(tree.nodes.size());
    exec.parallel_for(0, tree.nodes.size(), 4096, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i)
            if (tree.nodes[i].leaf()) stats[i] = detail::leaf_stats(tree, tree.nodes[i], elements, voxel_size);
    });
    for (auto it = order.rbegin(); it != order.rend(); ++it) {
        const Node& n = tree.nodes[*it];
        if (!n.leaf()) {
            NodeStats s;
            for (int c = 0; c < 2; ++c)
                if (detail::has_child(n, c)) s = merge(s, stats[n.child[c]]);
            stats[*it] = s;
        }
        stats[*it].element_density = detail::element_density(stats[*it].element_volume, boxes[*it]);
    }
    return stats;
}

/// The world size of one voxel as seen from the elements: the smallest extent along each axis
/// (the grid spacing for the voxel cuboids of one grid, up to float rounding of cell corners).
template <Bounded E>
vec3 smallest_extent(std::span<const E> elements) {
    vec3 s(std::numeric_limits<float>::infinity());
    for (const E& e : elements) s = glm::min(s, bounds_of(e).extent());
    return s;
}

/// The intermediate "full" BIH of Kinkelin section 6.1: a tree partitioned down to one element
/// per leaf, with node boxes and statistics, from which levels of detail are extracted.
struct FullBih {
    Tree tree;
    std::vector<NodeStats> stats;  ///< per node, same index as tree.nodes
    std::vector<Aabb> boxes;       ///< enclosing box of every node
    vec3 voxel_size{1.0f};         ///< world size of one voxel (smallest element extent)
    double stats_ms = 0.0;         ///< time of the boxes + statistics pass after the build
    double total_ms = 0.0;         ///< build + statistics: the paper's "construction time"

    /// Bytes this structure holds: nodes, statistics, boxes and the element order.
    [[nodiscard]] std::size_t bytes() const {
        return tree.nodes.size() * (sizeof(Node) + sizeof(NodeStats) + sizeof(Aabb)) +
               tree.order.size() * sizeof(std::uint32_t);
    }
    /// Bytes per node of this implementation (bytes() / nodes).
    [[nodiscard]] double bytes_per_node() const {
        return tree.nodes.empty() ? 0.0 : double(bytes()) / double(tree.nodes.size());
    }
    /// The size Kinkelin's Table 3 reports for the same tree: 40 bytes per full node (6.1).
    [[nodiscard]] std::size_t paper_bytes() const { return tree.nodes.size() * 40u; }
};

/// Builds the full BIH over density elements (voxel cuboids, or any DensityElement: RBFs,
/// particles with a density) with bih::build and `config` (its defaults are section 5.1's: one
/// element per leaf, leaf boxes trimmed to the element) and right after it, in one bottom-up
/// pass, the node boxes and statistics. Throws sylva::Error for an empty element list (e.g. no
/// voxel reached the density threshold), NaN/inverted boxes, or NaN densities/gradients.
template <DensityElement E, Executor X>
FullBih build_full(std::span<const E> elements, const Config& config, X& exec) {
    if (elements.empty()) throw Error("bih::build_full: no elements (no voxel cuboids or other density elements: empty input)");
    FullBih f;
    f.tree = build(elements, config, exec);
    auto start = std::chrono::steady_clock::now();
    f.voxel_size = smallest_extent(elements);
    f.boxes = node_boxes(f.tree);
    f.stats = node_stats(f.tree, elements, std::span<const Aabb>(f.boxes), f.voxel_size, exec);
    f.stats_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    f.total_ms = f.tree.stats.build_ms + f.stats_ms;
    return f;
}

/// build_full on the calling thread.
template <DensityElement E>
FullBih build_full(std::span<const E> elements, const Config& config = {}) {
    SerialExecutor serial;
    return build_full(elements, config, serial);
}

/// build_full over voxel cuboids, for callers passing a container (a span is not deduced from it).
template <Executor X>
FullBih build_full(std::span<const VoxelCuboid> elements, const Config& config, X& exec) {
    return build_full<VoxelCuboid, X>(elements, config, exec);
}

/// The same on the calling thread.
inline FullBih build_full(std::span<const VoxelCuboid> elements, const Config& config = {}) {
    SerialExecutor serial;
    return build_full<VoxelCuboid, SerialExecutor>(elements, config, serial);
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_STATS_HPP
