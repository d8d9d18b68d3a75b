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
// The levels are built one after another; the nodes of a level are split in parallel
// (detail::split_level): each node's list is counted into its octants, the children's lists
// are laid out in one pass in node order and written in parallel into one flat array per level,
// and each new node's neighbour pointers follow from its parent's (detail::link_child). The
// lists live in ElementTree::scratch, so rebuild_elements and refit_elements
// (sylva/octree/elements_refit.hpp) reuse them frame after frame.
#ifndef SYLVA_OCTREE_ELEMENTS_HPP
#define SYLVA_OCTREE_ELEMENTS_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
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
    /// Room for moving elements: the lattice covers the elements' box grown on every side by
    /// this fraction of its longest side. refit_elements keeps the lattice and must fall back to
    /// a rebuild once an element leaves it (the nodes are cells of the lattice, not boxes of the
    /// elements, so they cannot grow as a BVH's do); a margin as large as the motion between
    /// rebuilds keeps every refit a refit. In [0, 1]. 0 (the default) for still scenes: the
    /// margin's empty border costs the walk a few empty leaves. sylva-moving-bench and
    /// sylva-render --animate build with 0.05 for motions of up to 0.02 of the box (with 0 every
    /// one of their refits fell back to a rebuild).
    float refit_margin = 0.0f;
};

namespace detail {

/// An element's box in lattice units, padded.
struct CellBox {
    vec3 lo, hi;
};

/// A piece [j0, j1) of the list of node `node` of a level: per octant, first the entries it
/// sends there, then where it writes them (a leaf's piece: at[0] = its place in refs).
struct Segment {
    std::uint32_t node = 0;
    std::size_t j0 = 0, j1 = 0;
    std::array<std::size_t, 8> at{};
};

/// The builder's working lists, kept in an ElementTree so that rebuild_elements and
/// refit_elements allocate nothing once their capacities suffice. One level of nodes is
/// processed at a time: the reference lists of its nodes are concatenated in `lists[now]`
/// (node k of the level: [first[now][k], first[now][k + 1])), its split nodes' children's lists
/// are written into `lists[1 - now]`, its leaves' lists into ElementTree::refs.
struct ElementScratch {
    std::vector<CellBox> boxes;                  ///< per element: its padded box in lattice cells
    std::array<std::vector<std::uint32_t>, 2> lists;
    std::array<std::vector<std::size_t>, 2> first;
    std::vector<std::uint8_t> octants;           ///< per entry of lists[now]: the child octants it goes to (bit o)
    std::vector<std::uint32_t> masks;            ///< per node of the level: the octants it is split into (0: leaf)
    std::vector<Segment> segments;               ///< the level's lists cut into pieces
    std::vector<std::size_t> node_segment;       ///< node k's segments: [node_segment[k], node_segment[k + 1])

    /// Bytes held (capacities).
    [[nodiscard]] std::size_t bytes() const {
        return boxes.capacity() * sizeof(CellBox) + (lists[0].capacity() + lists[1].capacity() + masks.capacity()) * 4u +
               (first[0].capacity() + first[1].capacity() + node_segment.capacity()) * sizeof(std::size_t) +
               segments.capacity() * sizeof(Segment) + octants.capacity();
    }
};

}  // namespace detail

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
    /// The builder's lists, kept by rebuild_elements and refit_elements for the next frame
    /// (empty after build_elements, which releases them).
    detail::ElementScratch scratch;

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

/// Lattice geometry: the elements' box grown by cfg.refit_margin of its longest side and padded
/// by 2 cells, cubic cells, L from the extents.
inline void lattice(ElementTree& et, Aabb scene, const ElementConfig& cfg) {
    Tree& t = et.tree;
    t.brick_size = SYLVA_OCTE_CELLS;
    t.border = 1;
    std::uint32_t cells = SYLVA_OCTE_CELLS << cfg.max_depth;
    vec3 ext = scene.empty() ? vec3(0.0f) : scene.extent();
    float m = std::max({ext.x, ext.y, ext.z});
    if (cfg.refit_margin > 0.0f && m > 0.0f) {
        vec3 grow(cfg.refit_margin * m);
        scene = {scene.lo - grow, scene.hi + grow};
        ext = scene.extent();
        m = std::max({ext.x, ext.y, ext.z});
    }
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

/// Element boxes in lattice units (with 1 / spacing as the walk maps rays), padded, into
/// `out`; an element with an empty box gets lo > hi and is never listed.
template <Bounded E, Executor X>
void cell_boxes(std::span<const E> elements, const ElementTree& et, float pad, std::vector<CellBox>& out, X& exec) {
    out.resize(elements.size());
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
}

/// The octants of `node` that start inside the lattice (the children a split creates).
inline std::uint32_t lattice_octants(const Tree& t, const Node& node) {
    glm::u32vec3 mid = (2u * node.coord + 1u) * t.width(node.level + 1);
    glm::bvec3 upper = glm::lessThan(mid, t.dims);  // the upper half exists
    std::uint32_t mask = 0;
    for (std::uint32_t o = 0; o < 8; ++o)
        if ((!(o & 1u) || upper.x) && (!(o & 2u) || upper.y) && (!(o & 4u) || upper.z)) mask |= 1u << o;
    return mask;
}

/// The octants among `mask` that the padded box `b` overlaps, for a node whose children meet at
/// `fmid` (lattice cells): the lower half along an axis when lo <= the mid plane, the upper
/// half when hi >= it (closed boxes; the box overlaps the node already). Three comparisons per
/// axis instead of eight box tests.
inline std::uint32_t box_octants(const CellBox& b, vec3 fmid, std::uint32_t mask) {
    std::uint32_t sides[3];  // bit 0: lower half, bit 1: upper half
    for (int a = 0; a < 3; ++a) sides[a] = (b.lo[a] <= fmid[a] ? 1u : 0u) | (b.hi[a] >= fmid[a] ? 2u : 0u);
    std::uint32_t out = 0;
    for (std::uint32_t o = 0; o < 8; ++o)
        if (((sides[0] >> (o & 1u)) & 1u) && ((sides[1] >> ((o >> 1) & 1u)) & 1u) && ((sides[2] >> ((o >> 2) & 1u)) & 1u))
            out |= 1u << o;
    return out & mask;
}

/// Index of child octant o of `node` (which has it): children are consecutive in octant order.
inline std::uint32_t child_at(const Node& node, std::uint32_t o) {
    return node.first_child + std::uint32_t(std::popcount(node.child_mask & ((1u << o) - 1u)));
}

/// Neighbour pointers of child `c` of `parent` (both in t.nodes; the parent's own pointers and
/// the split of its level already set), as octree::link_neighbours defines them: the node at the
/// same level just across the face, else the deepest coarser node containing that place, else
/// none outside the lattice. Top down, no search: the place across a face is a sibling, or lies
/// in the parent's neighbour N across that face; when N is at the parent's level and split, the
/// place is one of N's children (every octant inside the lattice exists), else N is a leaf that
/// contains it.
inline void link_child(Tree& t, std::uint32_t parent, std::uint32_t c) {
    Node& node = t.nodes[c];
    const Node& p = t.nodes[parent];
    glm::u32vec3 r = t.level_nodes(node.level);
    for (std::uint32_t f = 0; f < 6; ++f) {
        std::uint32_t a = f / 2;
        node.neighbour[f] = kNone;
        if ((f & 1u) == 0u ? node.coord[a] == 0u : node.coord[a] + 1u >= r[a]) continue;  // outside
        glm::u32vec3 across = node.coord;
        across[a] = (f & 1u) ? across[a] + 1u : across[a] - 1u;
        std::uint32_t octant = (across.x & 1u) | ((across.y & 1u) << 1) | ((across.z & 1u) << 2);
        if ((across[a] >> 1) == (node.coord[a] >> 1)) {  // a sibling
            node.neighbour[f] = child_at(p, octant);
            continue;
        }
        std::uint32_t n = p.neighbour[f];
        if (n == kNone) continue;
        const Node& q = t.nodes[n];
        node.neighbour[f] = (q.level + 1u == node.level && !q.leaf()) ? child_at(q, octant) : n;
    }
}

inline void check_config(const ElementConfig& cfg) {
    if (cfg.max_depth > 16) throw Error("octree::build_elements: max_depth " + std::to_string(cfg.max_depth) + " is over 16");
    if (!(cfg.max_growth >= 1.0f && cfg.max_growth < 8.0f))
        throw Error("octree::build_elements: max_growth must be in [1, 8) (8 octants: 8 would never refuse a split)");
    if (!(cfg.overlap_pad >= 0.0f && cfg.overlap_pad <= 64.0f))
        throw Error("octree::build_elements: overlap_pad must be in [0, 64] cells");
    if (!(cfg.refit_margin >= 0.0f && cfg.refit_margin <= 1.0f))
        throw Error("octree::build_elements: refit_margin must be in [0, 1] (a fraction of the elements' box)");
}

/// The elements' box; throws naming the first element whose box is not finite.
template <Bounded E>
Aabb scene_box(std::span<const E> elements, const char* who = "octree::build_elements") {
    Aabb s;
    for (std::size_t i = 0; i < elements.size(); ++i) {
        Aabb b = bounds_of(elements[i]);
        if (b.empty()) continue;
        if (!b.finite()) throw Error(std::string(who) + ": element " + std::to_string(i) + "'s box is not finite");
        s.extend(b);
    }
    if (!s.empty() && !all_finite(s.extent()))
        throw Error(std::string(who) + ": the elements' box is too large for float arithmetic");
    return s;
}

/// Splits (or, for a refit, follows the existing splits of) one level of nodes, t.nodes[begin,
/// end), whose lists are sc.lists[now], in segments of at most kSegment entries so that the
/// few huge lists of the top levels are split in parallel too: counts each segment's entries
/// into the octants their boxes overlap (step 1, parallel), decides each node's split and lays
/// out the children's lists and the leaves' (step 2, serial, in node order: a build creates the
/// next level's nodes here), then writes the children's lists into sc.lists[1 - now] and the
/// leaves' into et.refs, and a build links the new nodes (step 3, parallel). Returns the number
/// of nodes of the next level.
inline std::size_t split_level(ElementTree& et, std::size_t begin, std::size_t end, int now, const ElementConfig& cfg,
                               bool refit, Executor auto& exec) {
    constexpr std::size_t kSegment = 16384;
    Tree& t = et.tree;
    ElementScratch& sc = et.scratch;
    const std::vector<std::uint32_t>& in = sc.lists[now];
    const std::vector<std::size_t>& first = sc.first[now];
    std::size_t count = end - begin;
    sc.segments.clear();
    sc.node_segment.resize(count + 1);
    for (std::size_t k = 0; k < count; ++k) {
        sc.node_segment[k] = sc.segments.size();
        std::size_t j = first[k];
        do {
            std::size_t j1 = std::min(first[k + 1], j + kSegment);
            sc.segments.push_back({std::uint32_t(k), j, j1, {}});
            j = j1;
        } while (j < first[k + 1]);
    }
    sc.node_segment[count] = sc.segments.size();
    sc.masks.resize(count);
    for (std::size_t k = 0; k < count; ++k) {
        const Node& node = t.nodes[begin + k];
        std::size_t size = first[k + 1] - first[k];
        sc.masks[k] = refit ? node.child_mask
                            : (size > cfg.leaf_elements && node.level + 1 < t.levels ? lattice_octants(t, node) : 0u);
    }
    sc.octants.resize(in.size());
    exec.parallel_for(0, sc.segments.size(), 4, [&](std::size_t s0, std::size_t s1) {
        for (std::size_t s = s0; s < s1; ++s) {
            Segment& seg = sc.segments[s];
            std::uint32_t mask = sc.masks[seg.node];
            if (!mask) continue;
            const Node& node = t.nodes[begin + seg.node];
            vec3 fmid((2u * node.coord + 1u) * t.width(node.level + 1));
            for (std::size_t j = seg.j0; j < seg.j1; ++j) {
                std::uint32_t o = box_octants(sc.boxes[in[j]], fmid, mask);
                sc.octants[j] = std::uint8_t(o);
                for (; o; o &= o - 1u) ++seg.at[std::countr_zero(o)];
            }
        }
    });
    std::vector<std::size_t>& next_first = sc.first[1 - now];
    next_first.clear();
    next_first.push_back(0);
    std::size_t children = 0;
    for (std::size_t k = 0; k < count; ++k) {
        std::size_t n = begin + k, size = first[k + 1] - first[k];
        std::span<Segment> segs(sc.segments.data() + sc.node_segment[k], sc.segments.data() + sc.node_segment[k + 1]);
        std::uint32_t& mask = sc.masks[k];
        if (mask && !refit) {
            std::size_t total = 0;
            for (const Segment& seg : segs)
                for (std::size_t c : seg.at) total += c;
            if (double(total) > double(cfg.max_growth) * double(size)) mask = 0;  // the split is refused
        }
        if (mask) {
            if (refit) {
                if (t.nodes[n].first_child != end + children)
                    throw Error("octree::refit_elements: node " + std::to_string(n) + "'s children are not where the level order puts them");
            } else {
                t.nodes[n].child_mask = mask;
                t.nodes[n].first_child = std::uint32_t(end + children);
            }
            for (std::uint32_t o = 0; o < 8; ++o) {
                if (!((mask >> o) & 1u)) continue;
                std::size_t at = next_first.back();
                for (Segment& seg : segs) std::swap(seg.at[o], at), at += seg.at[o];  // sizes -> write positions
                next_first.push_back(at);
                ++children;
                if (refit) continue;
                Node c;
                c.level = t.nodes[n].level + 1;
                c.coord = 2u * t.nodes[n].coord + glm::u32vec3(o & 1u, (o >> 1) & 1u, (o >> 2) & 1u);
                t.nodes.push_back(c);
            }
        } else if (size > 0) {
            t.nodes[n].brick = std::uint32_t(et.leaf_first.size() - 1);
            for (Segment& seg : segs) seg.at[0] = et.refs.size() + (seg.j0 - first[k]);
            if (et.refs.size() + size > 0xFFFFFFFFu)
                throw Error("octree::build_elements: more than 2^32 - 1 references (elements overlap too many leaves)");
            et.refs.resize(et.refs.size() + size);
            et.leaf_first.push_back(std::uint32_t(et.refs.size()));
        }
    }
    std::vector<std::uint32_t>& out = sc.lists[1 - now];
    out.resize(next_first.back());
    exec.parallel_for(0, sc.segments.size(), 4, [&](std::size_t s0, std::size_t s1) {
        for (std::size_t s = s0; s < s1; ++s) {
            Segment& seg = sc.segments[s];
            std::uint32_t mask = sc.masks[seg.node];
            if (!mask) {
                std::copy(in.begin() + std::ptrdiff_t(seg.j0), in.begin() + std::ptrdiff_t(seg.j1),
                          et.refs.begin() + std::ptrdiff_t(seg.at[0]));
                continue;
            }
            for (std::size_t j = seg.j0; j < seg.j1; ++j)
                for (std::uint32_t o = sc.octants[j]; o; o &= o - 1u) out[seg.at[std::countr_zero(o)]++] = in[j];
            if (refit || s != sc.node_segment[seg.node]) continue;
            std::uint32_t n = std::uint32_t(begin + seg.node), c0 = t.nodes[n].first_child;
            for (std::uint32_t c = c0; c < c0 + std::uint32_t(std::popcount(mask)); ++c) link_child(t, n, c);
        }
    });
    return children;
}

/// Lists the elements down the levels of et.tree from the root list already in
/// et.scratch.lists[0]: a build creates the nodes below the root (et.tree.nodes holds the root
/// alone), a refit keeps every node and only lists the leaves anew.
inline void distribute(ElementTree& et, const ElementConfig& cfg, bool refit, Executor auto& exec) {
    et.refs.clear();
    et.leaf_first.assign(1, 0u);
    for (Node& n : et.tree.nodes)
        if (n.leaf()) n.brick = kNone;
    std::size_t begin = 0, end = 1;
    int now = 0;
    while (begin < end) {
        std::size_t next = split_level(et, begin, end, now, cfg, refit, exec);
        begin = end;
        end += next;
        now = 1 - now;
    }
    if (refit && end != et.tree.nodes.size())
        throw Error("octree::refit_elements: the tree's nodes are not stored level by level from the root");
}

/// The root list: every element with a box, ascending.
inline void root_list(ElementScratch& sc) {
    std::vector<std::uint32_t>& l = sc.lists[0];
    l.clear();
    for (std::uint32_t i = 0; i < sc.boxes.size(); ++i)
        if (!(sc.boxes[i].lo.x > sc.boxes[i].hi.x)) l.push_back(i);
    sc.first[0].assign({std::size_t{0}, l.size()});
}

/// Builds `et` anew over `elements` into its own arrays (nodes, references, scratch). A bad
/// configuration or element throws before `et` is touched; where the build throws after it
/// started rewriting `et` (memory, more than 2^32 - 1 references), `et` is left empty (no
/// nodes), never half built.
template <Bounded E, Executor X>
void build_into(ElementTree& et, std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    auto start = std::chrono::steady_clock::now();
    check_config(cfg);
    if (elements.size() >= 0xFFFFFFFFu) throw Error("octree::build_elements: too many elements for 32-bit references");
    const Aabb scene = scene_box(elements);  // throws naming a non-finite element box
    try {
        et.element_count = elements.size();
        Tree& t = et.tree;
        t.nodes.clear();
        t.bricks.clear();
        lattice(et, scene, cfg);
        cell_boxes(elements, et, cfg.overlap_pad, et.scratch.boxes, exec);
        root_list(et.scratch);
        t.nodes.push_back(Node{});
        distribute(et, cfg, false, exec);
    } catch (...) {
        et = ElementTree{};
        throw;
    }
    et.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    et.tree.build_ms = et.build_ms;
}

}  // namespace detail

/// Builds the element octree of `elements` (any Bounded type; see the top of this header) on
/// `exec`. Throws sylva::Error for a bad configuration, a non-finite element box, or more than
/// 2^32 - 1 elements or references. Elements with empty boxes are never listed. The builder's
/// lists are released (rebuild_elements keeps them for the next frame).
template <Bounded E, Executor X>
ElementTree build_elements(std::span<const E> elements, const ElementConfig& cfg, X& exec) {
    ElementTree et;
    detail::build_into(et, elements, cfg, exec);
    et.scratch = {};
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
