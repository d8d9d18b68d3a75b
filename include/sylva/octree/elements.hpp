// sylva/octree/elements.hpp -- an octree over any bounded element type (issue 12, item 5):
// the same nodes as the bricked volume octree (sylva/octree/build.hpp: levels and coordinates,
// boxes computed from them, Gobbetti et al.'s neighbour pointers of section 4 / Fig. 3), whose
// leaves reference elements instead of bricks. Encoded by sylva/octree/elements_encode.hpp,
// walked by sylva/shared/octree_elem_iter.h (the volume octree's stackless walk).
//
// Scheme: straddling references. The elements' bounding box (padded by 2 cells) is cut into a
// lattice of cubic cells; a node is split top down while it holds more than
// Config::leaf_elements elements and the split does not multiply its references by more than
// Config::max_growth; every child octant that starts inside the padded box exists (empty ones
// are leaves without references, so the walk never meets a hole). Each leaf lists every
// element whose box, padded by Config::overlap_pad cells, overlaps the leaf's closed box.
// Why not a loose octree (elements at the deepest node whose doubled box holds them): the
// stackless walk yields leaves with their tight intervals, front to back; elements kept in
// inner, loose nodes lie outside those intervals, so the walk could not give them in order
// without a second, stack-based pass over the ancestors and their loose neighbours. Straddling
// keeps one walk, exact order (a hit is kept by the leaf whose [t0, t1) holds its entry t), and
// pays in duplicated references, bounded by max_growth per split. Measured with
// sylva-octree-elements-bench (2 loaded cores): 2.6-2.8 references per sphere on 1e5 uniform or
// clustered spheres, 8-9 on the overlapping particles of the galaxy and the halo; index 1.8-3.3x
// the default BIH's bytes; the particle frame within 0.8-2.5x of the BIH's time, in exact order.
// The levels are built one after another; the nodes of a level are split in parallel.
#ifndef SYLVA_OCTREE_ELEMENTS_HPP
#define SYLVA_OCTREE_ELEMENTS_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/octree/build.hpp"
#include "sylva/shared/octree_elem_iter.h"

namespace sylva::octree {

/// Settings of octree::build_elements.
struct ElementConfig {
    /// A node holding more elements than this is split (while max_depth and max_growth allow).
    /// 8: the BIH's query trees use leaves of a few elements too (Kinkelin section 5.1).
    std::uint32_t leaf_elements = 8;
    /// Deepest level (the root is 0); at most 16, the layout's 16-bit coordinates. The lattice
    /// is 4 * 2^max_depth cells along the box's longest axis.
    std::uint32_t max_depth = 16;
    /// A split is refused when the children's references would exceed max_growth times the
    /// node's: that stops the splitting of nodes whose elements overlap most of their octants
    /// (coincident or huge elements, elements as large as the node), where splitting only
    /// duplicates references. In [1, 8). The bound applies per split, so duplication compounds
    /// over levels where elements are dense and overlapping; measured (sylva-octree-elements-bench,
    /// 2 loaded cores) on the 2e5-particle synthetic galaxy: 2 -> 3.5 references per particle,
    /// 4.8 MB, 320x240 frame 276 ms; 3 -> 8.2, 14.5 MB, 210 ms; 4 -> 30, 53 MB, 169 ms and a 3x
    /// slower build. On 1e5 uniform or clustered spheres 3 and 4 build the same tree (2.6-2.8
    /// references per sphere). 3 trades a quarter of the particle frame rate for 3.7x less memory.
    float max_growth = 3.0f;
    /// Element boxes are grown by this many lattice cells (a quarter of the deepest leaf) before
    /// the overlap test, so that rounding in the walk's voxel-space arithmetic never puts an
    /// element's entry point in a leaf that does not list it.
    float overlap_pad = 1.0f;
};

/// The built element octree: the node tree (octree::Tree's geometry: dims in lattice cells,
/// B = 4, no bricks; a leaf's `brick` is its index in `leaf_first`, kNone for a leaf without
/// references and for inner nodes) and the reference lists.
struct ElementTree {
    Tree tree;
    vec3 origin{0.0f};                    ///< world position of lattice point 0
    std::size_t element_count = 0;        ///< elements built over (references are below it)
    std::vector<std::uint32_t> refs;      ///< concatenated reference lists, ascending per list
    std::vector<std::uint32_t> leaf_first;  ///< list i is refs[leaf_first[i] .. leaf_first[i + 1])
    double build_ms = 0.0;

    /// References of list i (a leaf's `brick`).
    [[nodiscard]] std::span<const std::uint32_t> list(std::uint32_t i) const {
        return {refs.data() + leaf_first[i], refs.data() + leaf_first[i + 1]};
    }
    /// The world box of node n (its lattice box mapped back; for tests and statistics).
    [[nodiscard]] Aabb world_box(const Node& n) const {
        return {origin + vec3(tree.box_lo(n)) * tree.spacing, origin + vec3(tree.box_hi(n)) * tree.spacing};
    }
};

namespace detail {

/// An element's box in lattice units, padded.
struct CellBox {
    vec3 lo, hi;
};

/// Lattice geometry: the elements' box padded by 2 cells, cubic cells, L from the extents.
inline void lattice(ElementTree& et, const Aabb& scene, const ElementConfig& cfg) {
    Tree& t = et.tree;
    t.brick_size = SYLVA_OCTE_CELLS;
    t.border = 1;
    std::uint32_t cells = SYLVA_OCTE_CELLS << cfg.max_depth;
    vec3 ext = scene.empty() ? vec3(0.0f) : scene.extent();
    float m = std::max({ext.x, ext.y, ext.z});
    float s = m / float(cells - 4u);
    if (!(s >= 1e-30f) || !std::isfinite(1.0f / s)) s = 1.0f;  // a point (or a tiny box): one cell
    vec3 lo = scene.empty() ? vec3(0.0f) : scene.lo;
    et.origin = lo - vec3(2.0f * s);
    t.spacing = vec3(s);
    for (int a = 0; a < 3; ++a) {
        double n = std::ceil(double(ext[a]) / double(s)) + 4.0;
        t.dims[a] = std::uint32_t(std::clamp(n, 1.0, double(cells)));
    }
    t.levels = level_count(t.dims, t.brick_size);
}

/// Element boxes in lattice units (with 1 / spacing as the walk maps rays), padded; an element
/// with an empty box gets lo > hi and is never listed.
template <Bounded E, Executor X>
std::vector<CellBox> cell_boxes(std::span<const E> elements, const ElementTree& et, float pad, X& exec) {
    std::vector<CellBox> out(elements.size());
    vec3 inv = 1.0f / et.tree.spacing;
    exec.parallel_for(0, elements.size(), 4096, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            Aabb b = bounds_of(elements[i]);
            if (b.empty()) {
                out[i] = {vec3(1.0f), vec3(0.0f)};
                continue;
            }
            out[i] = {(b.lo - et.origin) * inv - vec3(pad), (b.hi - et.origin) * inv + vec3(pad)};
        }
    });
    return out;
}

/// One node under construction: its place and the elements overlapping it.
struct Pending {
    std::uint32_t level = 0;
    glm::u32vec3 coord{0};
    std::vector<std::uint32_t> elems;
    std::array<std::vector<std::uint32_t>, 8> child;  ///< filled when the node is split
    std::uint32_t mask = 0;
};

/// Decides whether `p` is split and fills its children's lists (octants that start inside the
/// lattice only). An element overlaps the lower half along an axis when its lo <= the mid plane
/// and the upper half when its hi >= it (closed boxes; it overlaps the node already), so it
/// goes to the octants of those halves: three comparisons, not eight box tests.
inline void split(Pending& p, const Tree& t, const std::vector<CellBox>& boxes, const ElementConfig& cfg) {
    if (p.elems.size() <= cfg.leaf_elements || p.level + 1 >= t.levels) return;
    std::uint32_t w = t.width(p.level + 1);
    glm::u32vec3 mid = (2u * p.coord + 1u) * w;
    glm::bvec3 upper = glm::lessThan(mid, t.dims);  // the upper half exists
    vec3 fmid(mid);
    for (std::uint32_t o = 0; o < 8; ++o)
        if ((!(o & 1u) || upper.x) && (!(o & 2u) || upper.y) && (!(o & 4u) || upper.z)) p.mask |= 1u << o;
    std::size_t total = 0;
    for (std::uint32_t e : p.elems) {
        const CellBox& b = boxes[e];
        std::uint32_t sides[3];  // bit 0: lower half, bit 1: upper half
        for (int a = 0; a < 3; ++a)
            sides[a] = (b.lo[a] <= fmid[a] ? 1u : 0u) | (upper[a] && b.hi[a] >= fmid[a] ? 2u : 0u);
        for (std::uint32_t o = 0; o < 8; ++o) {
            if (((sides[0] >> (o & 1u)) & 1u) && ((sides[1] >> ((o >> 1) & 1u)) & 1u) && ((sides[2] >> ((o >> 2) & 1u)) & 1u)) {
                p.child[o].push_back(e);
                ++total;
            }
        }
    }
    if (double(total) > double(cfg.max_growth) * double(p.elems.size())) {
        p.mask = 0;
        for (auto& c : p.child) std::vector<std::uint32_t>().swap(c);
    }
}

/// Neighbour pointers as octree::link_neighbours defines them (same level just across, else the
/// deepest coarser node containing that place, else none), with one hash table of the nodes
/// (level, coordinates) instead of that function's dense per-level tables: an element octree is
/// 17 levels deep (65536^3 places at the deepest) and sparse. Parallel over the nodes.
template <Executor X>
void link_sparse(Tree& t, X& exec) {
    auto key = [](std::uint32_t l, glm::u32vec3 c) {
        return (std::uint64_t{l} << 48) | (std::uint64_t{c.z} << 32) | (std::uint64_t{c.y} << 16) | std::uint64_t{c.x};
    };
    std::unordered_map<std::uint64_t, std::uint32_t> at;
    at.reserve(t.nodes.size() * 2);
    for (std::size_t n = 0; n < t.nodes.size(); ++n) at.emplace(key(t.nodes[n].level, t.nodes[n].coord), std::uint32_t(n));
    exec.parallel_for(0, t.nodes.size(), 1024, [&](std::size_t n0, std::size_t n1) {
        for (std::size_t n = n0; n < n1; ++n) {
            Node& node = t.nodes[n];
            glm::u32vec3 r = t.level_nodes(node.level);
            for (std::uint32_t f = 0; f < 6; ++f) {
                std::uint32_t a = f / 2;
                node.neighbour[f] = kNone;
                if ((f & 1u) == 0u ? node.coord[a] == 0u : node.coord[a] + 1u >= r[a]) continue;  // outside
                glm::u32vec3 c = node.coord;
                c[a] = (f & 1u) ? c[a] + 1u : c[a] - 1u;
                for (std::uint32_t l = node.level + 1; l-- > 0;) {
                    auto it = at.find(key(l, c >> (node.level - l)));
                    if (it != at.end()) {
                        node.neighbour[f] = it->second;
                        break;
                    }
                }
            }
        }
    });
}

inline void check_config(const ElementConfig& cfg) {
    if (cfg.max_depth > 16) throw Error("octree::build_elements: max_depth " + std::to_string(cfg.max_depth) + " is over 16");
    if (!(cfg.max_growth >= 1.0f && cfg.max_growth < 8.0f))
        throw Error("octree::build_elements: max_growth must be in [1, 8) (8 octants: 8 would never refuse a split)");
    if (!(cfg.overlap_pad >= 0.0f && cfg.overlap_pad <= 64.0f))
        throw Error("octree::build_elements: overlap_pad must be in [0, 64] cells");
}

/// The elements' box; throws naming the first element whose box is not finite.
template <Bounded E>
Aabb scene_box(std::span<const E> elements) {
    Aabb s;
    for (std::size_t i = 0; i < elements.size(); ++i) {
        Aabb b = bounds_of(elements[i]);
        if (b.empty()) continue;
        if (!b.finite()) throw Error("octree::build_elements: element " + std::to_string(i) + "'s box is not finite");
        s.extend(b);
    }
    if (!s.empty() && !all_finite(s.extent()))
        throw Error("octree::build_elements: the elements' box is too large for float arithmetic");
    return s;
}

}  // namespace detail

/// Builds the element octree of `elements` (any Bounded type; see the top of this header) on
/// `exec`. Throws sylva::Error for a bad configuration, a non-finite element box, or more than
/// 2^32 - 1 elements. Elements with empty boxes are never listed.
template <Bounded E, Executor X>
ElementTree build_elements(std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    auto start = std::chrono::steady_clock::now();
    detail::check_config(cfg);
    if (elements.size() >= 0xFFFFFFFFu) throw Error("octree::build_elements: too many elements for 32-bit references");
    ElementTree et;
    et.element_count = elements.size();
    detail::lattice(et, detail::scene_box(elements), cfg);
    Tree& t = et.tree;
    std::vector<detail::CellBox> boxes = detail::cell_boxes(elements, et, cfg.overlap_pad, exec);
    std::vector<detail::Pending> level(1);
    for (std::uint32_t i = 0; i < elements.size(); ++i)
        if (!(boxes[i].lo.x > boxes[i].hi.x)) level[0].elems.push_back(i);
    et.leaf_first.push_back(0);
    while (!level.empty()) {
        exec.parallel_for(0, level.size(), 1, [&](std::size_t a, std::size_t b) {
            for (std::size_t i = a; i < b; ++i) detail::split(level[i], t, boxes, cfg);
        });
        std::vector<detail::Pending> next;
        std::size_t first = t.nodes.size() + level.size();
        for (detail::Pending& p : level) {
            Node n;
            n.level = p.level;
            n.coord = p.coord;
            n.child_mask = p.mask;
            if (p.mask) {
                n.first_child = std::uint32_t(first + next.size());
                for (std::uint32_t o = 0; o < 8; ++o) {
                    if (((p.mask >> o) & 1u) == 0u) continue;
                    detail::Pending c;
                    c.level = p.level + 1;
                    c.coord = 2u * p.coord + glm::u32vec3(o & 1u, (o >> 1) & 1u, (o >> 2) & 1u);
                    c.elems = std::move(p.child[o]);
                    next.push_back(std::move(c));
                }
            } else if (!p.elems.empty()) {
                n.brick = std::uint32_t(et.leaf_first.size() - 1);
                et.refs.insert(et.refs.end(), p.elems.begin(), p.elems.end());
                et.leaf_first.push_back(std::uint32_t(et.refs.size()));
            }
            t.nodes.push_back(n);
        }
        level = std::move(next);
    }
    detail::link_sparse(t, exec);
    et.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    t.build_ms = et.build_ms;
    return et;
}

/// A spatially coherent order of `elements`: their box centres' Morton codes on a 2^10 grid
/// over the elements' bounds, ties (and empty boxes, last) by index. The references of an
/// element octree index the array it was built over, in that array's order; elements that
/// arrive in no spatial order (files, generators) make every leaf read scattered memory.
/// Building over `elements` permuted by this order (element k of the copy is
/// elements[order[k]]) lets queries and the particle integrator read neighbouring elements from
/// neighbouring memory; map results back through `order`.
template <Bounded E>
std::vector<std::uint32_t> morton_order(std::span<const E> elements) {
    Aabb scene;
    for (const E& e : elements) {
        Aabb b = bounds_of(e);
        if (!b.empty() && b.finite()) scene.extend(b);
    }
    auto spread = [](std::uint64_t x) {  // 10 bits -> every third of 30
        x &= 0x3FFu;
        x = (x | (x << 16)) & 0x030000FFu;
        x = (x | (x << 8)) & 0x0300F00Fu;
        x = (x | (x << 4)) & 0x030C30C3u;
        x = (x | (x << 2)) & 0x09249249u;
        return x;
    };
    vec3 ext = scene.empty() ? vec3(1.0f) : glm::max(scene.extent(), vec3(1e-30f));
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(elements.size());
    for (std::size_t i = 0; i < elements.size(); ++i) {
        Aabb b = bounds_of(elements[i]);
        std::uint64_t code = ~std::uint64_t{0};
        if (!b.empty() && b.finite()) {
            vec3 f = glm::clamp((b.center() - scene.lo) / ext, vec3(0.0f), vec3(1.0f)) * 1023.0f;
            code = spread(std::uint64_t(f.x)) | (spread(std::uint64_t(f.y)) << 1) | (spread(std::uint64_t(f.z)) << 2);
        }
        keys[i] = {code, std::uint32_t(i)};
    }
    std::sort(keys.begin(), keys.end());
    std::vector<std::uint32_t> order(elements.size());
    for (std::size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
    return order;
}

/// octree::build_elements on the calling thread.
template <Bounded E>
ElementTree build_elements(std::span<const E> elements, const ElementConfig& cfg = {}) {
    SerialExecutor serial;
    return build_elements(elements, cfg, serial);
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_ELEMENTS_HPP
