// sylva/bih/build.hpp -- Bounding Interval Hierarchy construction (Kinkelin sections 3.1, 5.1;
// Waechter and Keller 2006), generic over any range of bounded elements.
//
// Each node is split in the middle of its box's longest axis; elements go left when the centre
// of their box is on or left of the plane, right otherwise (an in-place partition of an index
// permutation); the two bounding planes are the maximum of the left boxes and the minimum of
// the right boxes, computed during the partition. Empty children follow Config::empty_children.
// Where the midpoint makes no progress (every element on one side and no plane trims the box),
// the builder trims the axis with the most slack instead, and where the box is already tight,
// splits at the middle of the element centres; elements whose centres all coincide stay in one
// leaf. Every path ends at Config::max_depth (at most SYLVA_BIH_DEPTH_CAP), so the build always
// terminates and the iterator's stack can never overflow.
#ifndef SYLVA_BIH_BUILD_HPP
#define SYLVA_BIH_BUILD_HPP

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/bih/tree.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/shared/bih_layout.h"

namespace sylva::bih {

/// How a node with one empty child is stored (Kinkelin section 3.1).
enum class EmptyChildren {
    Infinite,  ///< the empty child's plane is -inf / +inf; one side of the child is trimmed
    TrimBoth,  ///< "elaborate": both planes bound the single child, trimming two sides per level
};

/// Builder settings. Defaults follow Kinkelin section 5.1 (one element per leaf, leaf boxes
/// trimmed until they equal the element's box).
struct Config {
    /// A node with at most this many elements may become a leaf (section 5.1: 1).
    std::uint32_t max_leaf_elements = 1;
    /// Keep splitting such a node until its box equals the box of its elements, so the leaf box
    /// can stand in for the element (section 3.3: "implicit AABB").
    bool trim_leaves = true;
    /// Representation of nodes with one empty child (section 3.1).
    EmptyChildren empty_children = EmptyChildren::TrimBoth;
    /// Nodes at this depth become leaves whatever they hold; clamped to SYLVA_BIH_DEPTH_CAP.
    std::uint32_t max_depth = SYLVA_BIH_DEPTH_CAP;
    /// Subtrees with more elements than this are built as parallel tasks on the executor.
    std::size_t parallel_threshold = 1u << 15;
    /// Called with the fraction of elements placed in leaves (0..1), possibly from several threads.
    std::function<void(double)> on_progress;
};

namespace detail {

/// Per-element data the build reads: the box and its centre, computed once.
struct Prims {
    std::vector<Aabb> box;
    std::vector<vec3> center;
};

template <Bounded E, Executor X>
Prims gather_prims(std::span<const E> elements, X& exec) {
    Prims p;
    p.box.resize(elements.size());
    p.center.resize(elements.size());
    std::atomic<std::size_t> bad{std::numeric_limits<std::size_t>::max()};
    exec.parallel_for(0, elements.size(), 4096, [&](std::size_t lo, std::size_t hi) {
        for (std::size_t i = lo; i < hi; ++i) {
            Aabb b = bounds_of(elements[i]);
            if (!b.finite() || b.empty()) {
                std::size_t expected = bad.load();
                while (i < expected && !bad.compare_exchange_weak(expected, i)) {
                }
            }
            p.box[i] = b;
            p.center[i] = b.lo * 0.5f + b.hi * 0.5f;  // no overflow for huge boxes
        }
    });
    if (std::size_t i = bad.load(); i != std::numeric_limits<std::size_t>::max()) {
        const Aabb& b = p.box[i];
        throw Error("bih::build: element " + std::to_string(i) +
                    (b.finite() ? " has an inverted box (lo > hi)" : " has non-finite bounds (NaN or inf)"));
    }
    return p;
}

/// The box of elements order[begin, end).
inline Aabb union_of(const Prims& p, const std::uint32_t* order, std::size_t begin, std::size_t end) {
    Aabb u;
    for (std::size_t i = begin; i < end; ++i) u.extend(p.box[order[i]]);
    return u;
}

/// Builds one subtree into a local node array (indices local to it); subtrees built in
/// parallel are appended to their parent's array afterwards.
template <Executor X>
class SubtreeBuilder {
public:
    SubtreeBuilder(const Prims& prims, std::uint32_t* order, const Config& cfg, X& exec,
                   std::atomic<std::size_t>& placed, std::size_t total)
        : p_(prims), order_(order), cfg_(cfg), exec_(exec), placed_(placed), total_(total) {}

    /// Builds the subtree over order[begin, end) with box `box`; returns its nodes, root first.
    std::vector<Node> build(std::size_t begin, std::size_t end, const Aabb& box, std::uint32_t depth) {
        std::vector<Node> out;
        out.reserve(2 * (end - begin) + 1);
        node(out, begin, end, box, depth);
        return out;
    }

private:
    struct Split {
        enum Kind { Leaf, Two, One } kind = Leaf;
        int axis = 0;
        std::size_t mid = 0;  ///< elements [begin, mid) go left
        float plane[2] = {0.0f, 0.0f};
        Aabb box[2];
    };

    void node(std::vector<Node>& out, std::size_t begin, std::size_t end, const Aabb& box, std::uint32_t depth) {
        std::uint32_t self = static_cast<std::uint32_t>(out.size());
        out.emplace_back();
        Split s = choose(begin, end, box, depth);
        if (s.kind == Split::Leaf) {
            make_leaf(out[self], begin, end);
            return;
        }
        out[self].axis = static_cast<std::uint8_t>(s.axis);
        out[self].plane[0] = s.plane[0];
        out[self].plane[1] = s.plane[1];
        if (s.kind == Split::One) {
            bool left = s.mid == end;
            bool single = cfg_.empty_children == EmptyChildren::TrimBoth;
            out[self].single = single;
            std::uint32_t c = static_cast<std::uint32_t>(out.size());
            out[self].child[(single || left) ? 0 : 1] = c;
            node(out, begin, end, s.box[0], depth + 1);
            return;
        }
        children(out, self, begin, s.mid, end, s, depth);
    }

    void children(std::vector<Node>& out, std::uint32_t self, std::size_t begin, std::size_t mid, std::size_t end,
                  const Split& s, std::uint32_t depth) {
        bool parallel = exec_.concurrency() > 1 && (end - begin) > cfg_.parallel_threshold;
        if (!parallel) {
            out[self].child[0] = static_cast<std::uint32_t>(out.size());
            node(out, begin, mid, s.box[0], depth + 1);
            out[self].child[1] = static_cast<std::uint32_t>(out.size());
            node(out, mid, end, s.box[1], depth + 1);
            return;
        }
        std::vector<Node> left, right;
        exec_.invoke([&] { left = build(begin, mid, s.box[0], depth + 1); },
                     [&] { right = build(mid, end, s.box[1], depth + 1); });
        out[self].child[0] = append(out, left);
        out[self].child[1] = append(out, right);
    }

    /// Appends a subtree built elsewhere, shifting its child indices; returns its root index.
    static std::uint32_t append(std::vector<Node>& out, const std::vector<Node>& sub) {
        std::uint32_t base = static_cast<std::uint32_t>(out.size());
        for (Node n : sub) {
            for (auto& c : n.child)
                if (c != kNoChild) c += base;
            out.push_back(n);
        }
        return base;
    }

    void make_leaf(Node& n, std::size_t begin, std::size_t end) {
        n.axis = kLeaf;
        n.first = static_cast<std::uint32_t>(begin);
        n.count = static_cast<std::uint32_t>(end - begin);
        if (cfg_.on_progress) {
            std::size_t before = placed_.fetch_add(end - begin);
            std::size_t step = std::max<std::size_t>(total_ / 100, 1);
            if (before / step != (before + end - begin) / step)
                cfg_.on_progress(static_cast<double>(before + end - begin) / static_cast<double>(total_));
        }
    }

    Split choose(std::size_t begin, std::size_t end, const Aabb& box, std::uint32_t depth) {
        if (depth >= cfg_.max_depth) return Split{};
        bool small = (end - begin) <= cfg_.max_leaf_elements;
        Aabb u;
        if (small) {
            if (!cfg_.trim_leaves) return Split{};
            u = union_of(p_, order_, begin, end);
            if (u == box) return Split{};
        }
        Split s = midpoint(begin, end, box);
        if (s.kind != Split::Leaf) return s;
        if (!small) u = union_of(p_, order_, begin, end);
        if (!(u == box)) return trim(begin, end, box, u);
        return centroid_split(begin, end, box);
    }

    /// The paper's rule: middle of the longest axis. Returns Leaf when it makes no progress.
    Split midpoint(std::size_t begin, std::size_t end, const Aabb& box) {
        Split s;
        s.axis = box.longest_axis();
        float cut = box.lo[s.axis] * 0.5f + box.hi[s.axis] * 0.5f;
        s.mid = partition(begin, end, s.axis, cut, s.plane[0], s.plane[1]);
        if (s.mid != begin && s.mid != end) {
            s.kind = Split::Two;
            s.box[0] = s.box[1] = box;
            s.box[0].hi[s.axis] = s.plane[0];
            s.box[1].lo[s.axis] = s.plane[1];
            return s;
        }
        return one_sided(begin, end, box, s);
    }

    /// All elements fell on one side of the plane: a node with one empty child if that trims.
    Split one_sided(std::size_t begin, std::size_t end, const Aabb& box, Split s) {
        int a = s.axis;
        bool left = s.mid == end;
        float lo = box.lo[a], hi = box.hi[a];
        if (cfg_.empty_children == EmptyChildren::TrimBoth) {
            Aabb u = union_of(p_, order_, begin, end);
            lo = u.lo[a];
            hi = u.hi[a];
        } else if (left) {
            hi = s.plane[0];
        } else {
            lo = s.plane[1];
        }
        if (lo == box.lo[a] && hi == box.hi[a]) return Split{};
        return one_child(box, a, lo, hi, left ? end : begin, left);
    }

    /// A node with one child trimmed to [lo, hi] along `axis`; `mid` == end marks a left child.
    Split one_child(const Aabb& box, int axis, float lo, float hi, std::size_t mid, bool left) {
        Split s;
        s.kind = Split::One;
        s.mid = mid;
        s.axis = axis;
        s.box[0] = box;
        s.box[0].lo[axis] = lo;
        s.box[0].hi[axis] = hi;
        const float inf = std::numeric_limits<float>::infinity();
        if (cfg_.empty_children == EmptyChildren::TrimBoth) {
            s.plane[0] = lo;
            s.plane[1] = hi;
        } else {
            s.plane[0] = left ? hi : -inf;
            s.plane[1] = left ? inf : lo;
        }
        return s;
    }

    /// Trims the box towards the elements' box `u` on the axis with the most slack.
    Split trim(std::size_t begin, std::size_t end, const Aabb& box, const Aabb& u) {
        int best = 0;
        float slack = -1.0f;
        for (int a = 0; a < 3; ++a) {
            float sl = (u.lo[a] - box.lo[a]) + (box.hi[a] - u.hi[a]);
            if (sl > slack) {
                slack = sl;
                best = a;
            }
        }
        bool infinite = cfg_.empty_children == EmptyChildren::Infinite;
        bool left = !infinite || u.hi[best] < box.hi[best];  // Infinite: cut the side with slack
        float lo = (infinite && left) ? box.lo[best] : u.lo[best];
        float hi = (infinite && !left) ? box.hi[best] : u.hi[best];
        return one_child(box, best, lo, hi, left ? end : begin, left);
    }

    /// Box already tight: split at the middle of the centres' extent; Leaf if they coincide.
    Split centroid_split(std::size_t begin, std::size_t end, const Aabb& box) {
        Aabb c;
        for (std::size_t i = begin; i < end; ++i) c.extend(p_.center[order_[i]]);
        Split s;
        s.axis = c.longest_axis();
        if (!(c.hi[s.axis] > c.lo[s.axis])) return s;
        float cut = c.lo[s.axis] * 0.5f + c.hi[s.axis] * 0.5f;
        if (!(cut < c.hi[s.axis])) cut = c.lo[s.axis];
        s.mid = partition(begin, end, s.axis, cut, s.plane[0], s.plane[1]);
        s.kind = Split::Two;
        s.box[0] = s.box[1] = box;
        s.box[0].hi[s.axis] = s.plane[0];
        s.box[1].lo[s.axis] = s.plane[1];
        return s;
    }

    /// In-place partition of order[begin, end) by centre <= cut along `axis`, computing the left
    /// maximum and right minimum planes on the way; returns the first right position.
    std::size_t partition(std::size_t begin, std::size_t end, int axis, float cut, float& left_max,
                          float& right_min) {
        left_max = -std::numeric_limits<float>::infinity();
        right_min = std::numeric_limits<float>::infinity();
        std::size_t i = begin, j = end;
        while (i < j) {
            std::uint32_t e = order_[i];
            if (p_.center[e][axis] <= cut) {
                left_max = std::max(left_max, p_.box[e].hi[axis]);
                ++i;
            } else {
                right_min = std::min(right_min, p_.box[e].lo[axis]);
                std::swap(order_[i], order_[--j]);
            }
        }
        return i;
    }

    const Prims& p_;
    std::uint32_t* order_;
    const Config& cfg_;
    X& exec_;
    std::atomic<std::size_t>& placed_;
    std::size_t total_;
};

/// Fills in the statistics of a finished tree.
inline void measure(Tree& t) {
    BuildStats& s = t.stats;
    s.nodes = t.nodes.size();
    std::vector<std::uint32_t> depth(t.nodes.size(), 0);
    for (std::size_t i = 0; i < t.nodes.size(); ++i) {  // children always follow their parent
        const Node& n = t.nodes[i];
        s.max_depth = std::max(s.max_depth, depth[i]);
        if (n.leaf()) {
            ++s.leaves;
            s.max_leaf_elements = std::max(s.max_leaf_elements, n.count);
            continue;
        }
        if (n.children() == 1) ++s.single_child_nodes;
        for (std::uint32_t c : n.child)
            if (c != kNoChild) depth[c] = depth[i] + 1;
    }
}

}  // namespace detail

/// Builds a BIH over `elements`. Throws sylva::Error for an empty input, more than 2^32 - 1
/// elements, or an element whose box is not finite or inverted (lo > hi); the message names
/// the element. The elements are not modified; the tree refers to them through `order`.
template <Bounded E, Executor X>
Tree build(std::span<const E> elements, const Config& config, X& exec) {
    auto start = std::chrono::steady_clock::now();
    if (elements.empty()) throw Error("bih::build: no elements (empty input)");
    if (elements.size() >= std::numeric_limits<std::uint32_t>::max())
        throw Error("bih::build: too many elements (" + std::to_string(elements.size()) + ", at most 2^32 - 2)");
    Config cfg = config;
    cfg.max_depth = std::min<std::uint32_t>(cfg.max_depth, SYLVA_BIH_DEPTH_CAP);
    cfg.max_leaf_elements = std::max<std::uint32_t>(cfg.max_leaf_elements, 1);

    Tree t;
    detail::Prims prims = detail::gather_prims(elements, exec);
    t.order.resize(elements.size());
    std::iota(t.order.begin(), t.order.end(), 0u);
    t.bounds = detail::union_of(prims, t.order.data(), 0, t.order.size());
    std::atomic<std::size_t> placed{0};
    detail::SubtreeBuilder<X> builder(prims, t.order.data(), cfg, exec, placed, elements.size());
    t.nodes = builder.build(0, elements.size(), t.bounds, 0);
    t.stats.elements = elements.size();
    detail::measure(t);
    t.stats.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return t;
}

/// Builds on the calling thread.
template <Bounded E>
Tree build(std::span<const E> elements, const Config& config = {}) {
    SerialExecutor serial;
    return build(elements, config, serial);
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_BUILD_HPP
