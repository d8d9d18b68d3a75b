// sylva/bih/query.hpp -- host-side queries over an encoded BIH: a C++ leaf iterator over the
// shared one, and the first-hit and all-hits-in-order element queries.
//
// The element queries run a host walker (detail::Walker) instead of the shared iterator: the
// shared node functions in a host loop, so the same leaves in the same order with the same
// intervals (a test checks this against sylva_bih_next), but without the node boxes element queries do not need,
// with one bounds check per node instead of one per load, and a 12-byte stack entry. They take
// the elements either through the tree's order (tree + elements) or already in leaf order
// (LeafRecords: no order[] indirection, spheres tested four at a time).
#ifndef SYLVA_BIH_QUERY_HPP
#define SYLVA_BIH_QUERY_HPP

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

// SSE2 paths where the target has them; SYLVA_BIH_QUERY_NO_SSE selects the portable scalar
// paths instead (the tests build them too; they give the same hits).
#if (defined(__SSE2__) || defined(_M_X64)) && !defined(SYLVA_BIH_QUERY_NO_SSE)
#include <emmintrin.h>
#define SYLVA_BIH_QUERY_SSE 1
#endif

#include "sylva/bih/payload.hpp"
#include "sylva/bih/tree.hpp"
#include "sylva/core/concepts.hpp"
#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/elements/sphere.hpp"
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

namespace detail {

/// Starts loading the cache line at p (the host queries' nodes and records ahead of use).
inline void prefetch(const void* p) {
#if defined(__GNUC__) || defined(__clang__)
    __builtin_prefetch(p);
#else
    (void)p;
#endif
}

/// Walker layouts: read from the header at run time, or fixed at compile time for the two
/// tree-chunk encodings (the default Fixed16 one and Float32), which saves a few cycles a node.
inline constexpr int kAnyLayout = 0;
inline constexpr int kFixed16Chunks = 1;
inline constexpr int kFloat32Chunks = 2;

/// The compile-time layout that fits an encoding's header (kAnyLayout if none does).
inline int layout_of(std::span<const std::uint32_t> words) {
    if (words.size() < SYLVA_BIH_HEADER_WORDS) return kAnyLayout;
    std::uint32_t f = words[2] & (SYLVA_BIH_FLAG_FLOAT_NODES | SYLVA_BIH_FLAG_CHUNKED);
    if (f == SYLVA_BIH_FLAG_CHUNKED) return kFixed16Chunks;
    if (f == (SYLVA_BIH_FLAG_CHUNKED | SYLVA_BIH_FLAG_FLOAT_NODES)) return kFloat32Chunks;
    return kAnyLayout;
}

/// The shared iterator's traversal (sylva_bih_next: Kinkelin Alg. 1 and 2) without node boxes,
/// for queries that only need leaves and intervals. Every decision about a node is the shared
/// code's own functions (meta accessors, sylva_bih_decode_q, sylva_bih_children_at,
/// sylva_bih_split_intervals, sylva_bih_single_interval, sylva_bih_left_first); only the loop,
/// the stack and the register state are the walker's. So it yields the same leaves in the same
/// order with bit-identical t0/t1, the same step count and status (a test checks all four). Loads are unchecked: the header check of sylva_bih_read_header
/// guarantees node_count nodes fit in the buffer, and every node index is checked against
/// node_count before it is read. Faster than the shared iterator on the host: no boxes, one
/// bounds check per node, the state in registers, the child chosen with selects, the children's
/// cache line prefetched while the node's planes are decoded.
template <int Layout = kAnyLayout>
class Walker {
public:
    /// Starts as sylva_bih_init does: same header checks, traversal space and root interval.
    Walker(std::span<const std::uint32_t> words, const Ray& ray, Interval range)
        : words_(words.data()), t_limit_(range.t1) {
        shared::Words w{words.data(), words.size()};
        shared::SylvaBihHeader h =
            shared::sylva_bih_read_header(w, static_cast<std::uint32_t>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)));
        if (h.valid == 0u || h.max_depth > SYLVA_BIH_DEPTH_CAP) return;  // status ERROR, no leaves
        if (Layout != kAnyLayout && Layout != layout_of(words)) return;  // not the layout compiled for
        status_ = SYLVA_ITER_RUNNING;
        node_count_ = h.node_count;
        stride_ = h.stride;
        chunked_ = (h.flags & SYLVA_BIH_FLAG_CHUNKED) != 0u;
        bool fixed16 = (h.flags & SYLVA_BIH_FLAG_FLOAT_NODES) == 0u;
        float t0 = range.t0, t1 = range.t1;
        for (int a = 0; a < 3; ++a) {
            float scale = h.space_scale[a], d = ray.direction[a] * scale;
            org_[a] = (ray.origin[a] - h.space_origin[a]) * scale;
            par_[a] = d == 0.0f ? 1u : 0u;
            rcp_[a] = shared::sylva_safe_rcp(d);
            near_[a] = shared::sylva_bih_left_first(rcp_[a]) ? 0u : 1u;
            vec2 ab = shared::sylva_slab(fixed16 ? 0.0f : h.root_lo[a], fixed16 ? 1.0f : h.root_hi[a], org_[a], rcp_[a],
                                         par_[a]);
            t0 = shared::sylva_max(t0, ab.x);
            t1 = shared::sylva_min(t1, ab.y);
        }
        if (t0 <= t1) set(0u, vec2(t0, t1));
    }

    /// The next leaf: its node position and the ray's interval in it. False at the end.
    bool next(std::uint32_t& leaf, float& t0, float& t1) {
        return run([&](std::uint32_t l, float a, float b) {
            leaf = l;
            t0 = a;
            t1 = b;
            return true;  // stop here; the next call resumes
        });
    }

    /// Calls on_leaf(leaf, t0, t1) for every remaining leaf, in the order next() gives them
    /// (for the queries: no return to the caller between leaves). on_leaf may call clip().
    template <class F>
    void for_each_leaf(F&& on_leaf) {
        run([&](std::uint32_t l, float a, float b) {
            on_leaf(l, a, b);
            return false;
        });
    }

    /// The 62-bit payload of a leaf next() returned (as sylva_bih_payload).
    [[nodiscard]] std::uint64_t payload(std::uint32_t leaf) const {
        const std::uint32_t* at = words_ + SYLVA_BIH_HEADER_WORDS + std::size_t{leaf} * stride();
        return std::uint64_t{at[0]} | (std::uint64_t{shared::sylva_bih_meta_payload_hi(at[stride() - 1])} << 32);
    }
    /// Prunes everything entered after t (as sylva_bih_clip).
    void clip(float t) { t_limit_ = shared::sylva_min(t_limit_, t); }
    [[nodiscard]] std::uint32_t steps() const { return steps_; }
    [[nodiscard]] std::uint32_t status() const { return status_; }

private:
    /// The traversal loop (sylva_bih_next). The state lives in locals while it runs and is
    /// written back on return. `leaf_found` returns true to stop after a leaf.
    template <class F>
    bool run(F&& leaf_found) {
        if (status_ != SYLVA_ITER_RUNNING) return false;
        State s{node_, t_in_, t_out_, sp_, steps_};
        std::uint32_t status = SYLVA_ITER_RUNNING;
        bool stopped = false;
        while (status == SYLVA_ITER_RUNNING) {
            if (s.node == SYLVA_NO_NODE && !pop(s)) {
                status = SYLVA_ITER_DONE;
                break;
            }
            if (s.node >= node_count_ || s.steps >= node_count_) {  // corrupted links
                status = SYLVA_ITER_ERROR;
                break;
            }
            ++s.steps;
            const std::uint32_t* at = words_ + SYLVA_BIH_HEADER_WORDS + std::size_t{s.node} * stride();
            std::uint32_t meta = at[stride() - 1];
            std::uint32_t axis = shared::sylva_bih_meta_type(meta);
            if (axis == SYLVA_BIH_LEAF) {
                std::uint32_t leaf = s.node;
                s.node = SYLVA_NO_NODE;
                if (leaf_found(leaf, s.t_in, s.t_out)) {
                    stopped = true;
                    break;
                }
                continue;
            }
            std::uint32_t link = shared::sylva_bih_first_child(chunked(), s.node, meta);
            prefetch(words_ + SYLVA_BIH_HEADER_WORDS + std::size_t{std::min(link, node_count_ - 1u)} * stride());
            vec2 planes = stride() == 3u ? vec2(bits_float(at[0]), bits_float(at[1]))
                                        : vec2(shared::sylva_bih_decode_q(at[0] & 0xFFFFu),
                                               shared::sylva_bih_decode_q(at[0] >> 16u));
            if (shared::sylva_bih_meta_single(meta))
                descend_single(s, axis, link, planes);
            else if (!descend(s, axis, meta, planes))
                status = SYLVA_ITER_ERROR;
        }
        node_ = s.node;
        t_in_ = s.t_in;
        t_out_ = s.t_out;
        sp_ = s.sp;
        steps_ = s.steps;
        status_ = stopped ? SYLVA_ITER_RUNNING : status;
        return stopped;
    }

    struct Entry {
        std::uint32_t node;
        float t_in, t_out;
    };
    struct State {
        std::uint32_t node;
        float t_in, t_out;
        std::uint32_t sp, steps;
    };

    [[nodiscard]] std::uint32_t stride() const {
        if constexpr (Layout == kFixed16Chunks) return 2u;
        if constexpr (Layout == kFloat32Chunks) return 3u;
        return stride_;
    }
    [[nodiscard]] bool chunked() const {
        if constexpr (Layout != kAnyLayout) return true;
        return chunked_;
    }

    static float bits_float(std::uint32_t u) {
        float f;
        std::memcpy(&f, &u, 4);
        return f;
    }

    SYLVA_FORCEINLINE bool pop(State& s) const {  // sylva_bih_pop
        while (s.sp > 0) {
            const Entry& e = stack_[--s.sp];
            if (e.t_in <= t_limit_) {
                s.node = e.node;
                s.t_in = e.t_in;
                s.t_out = shared::sylva_min(e.t_out, t_limit_);
                return true;
            }
        }
        return false;
    }

    /// sylva_bih_children + sylva_bih_descend. The nearer child hit is entered, the farther one
    /// pushed when both are hit; false when the stack would overflow (a corrupted tree).
    SYLVA_FORCEINLINE bool descend(State& s, std::uint32_t axis, std::uint32_t meta, vec2 planes) {
        uvec2 kids = shared::sylva_bih_children_at(chunked(), s.node, meta, planes);
        vec4 lr = shared::sylva_bih_split_intervals(s.t_in, s.t_out, planes, org_[axis], rcp_[axis], par_[axis]);
        Entry kid[2] = {{kids.x, lr.x, lr.y}, {kids.y, lr.z, lr.w}};
        std::uint32_t hit[2] = {(kids.x != SYLVA_NO_NODE && kid[0].t_in <= kid[0].t_out) ? 1u : 0u,
                                (kids.y != SYLVA_NO_NODE && kid[1].t_in <= kid[1].t_out) ? 1u : 0u};
        std::uint32_t near = near_[axis], far = near ^ 1u;  // index 0 = left
        stack_[s.sp] = kid[far];  // kept only when both are hit
        s.sp += hit[near] & hit[far];
        const Entry& go = kid[hit[near] ? near : far];
        s.node = (hit[near] | hit[far]) ? go.node : SYLVA_NO_NODE;
        s.t_in = go.t_in;
        s.t_out = go.t_out;
        return s.sp <= SYLVA_BIH_DEPTH_CAP;
    }

    SYLVA_FORCEINLINE void descend_single(State& s, std::uint32_t axis, std::uint32_t child, vec2 planes) const {
        vec2 t = shared::sylva_bih_single_interval(s.t_in, s.t_out, planes, org_[axis], rcp_[axis], par_[axis]);
        s.node = t.x <= t.y ? child : SYLVA_NO_NODE;
        s.t_in = t.x;
        s.t_out = t.y;
    }

    void set(std::uint32_t node, vec2 t) {
        node_ = node;
        t_in_ = t.x;
        t_out_ = t.y;
    }

    const std::uint32_t* words_;
    std::uint32_t status_ = SYLVA_ITER_ERROR, node_count_ = 0, stride_ = 2, steps_ = 0, sp_ = 0;
    bool chunked_ = false;
    float org_[3] = {}, rcp_[3] = {};
    std::uint32_t par_[3] = {};
    std::uint32_t near_[3] = {};  ///< nearer child per axis: 0 left (direction +), 1 right (-)
    float t_limit_ = 0.0f, t_in_ = 0.0f, t_out_ = 0.0f;
    std::uint32_t node_ = SYLVA_NO_NODE;
    Entry stack_[SYLVA_BIH_DEPTH_CAP + 1];  ///< +1: the far child is written before the overflow check
};

}  // namespace detail

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

namespace detail {

/// (first, count) of a RangePayload leaf, checked against the `size` elements it indexes.
inline std::pair<std::uint32_t, std::uint32_t> leaf_range(std::uint64_t payload, std::size_t size) {
    auto [first, count] = decode_range(payload);
    if (std::uint64_t{first} + count > size)
        throw Error("bih query: leaf range [" + std::to_string(first) + ", +" + std::to_string(count) +
                    ") is beyond the " + std::to_string(size) + " elements (encoding and elements do not match)");
    return {first, count};
}

/// Elements reached through the tree's order (the encoding's ranges index `order`).
template <Intersectable E>
struct OrderedSource {
    std::span<const E> elements;
    std::span<const std::uint32_t> order;

    /// Calls sink(ElementHit) for each element of the leaf the ray hits, in leaf order.
    template <class Sink>
    void leaf_hits(std::uint64_t payload, const Ray& ray, Interval range, Sink&& sink) const {
        auto [first, count] = leaf_range(payload, order.size());
        for (std::uint32_t k = 0; k < count; ++k) {
            std::uint32_t e = order[first + k];
            if (e >= elements.size())
                throw Error("bih query: tree order refers to element " + std::to_string(e) + " of " +
                            std::to_string(elements.size()));
            if (auto t = intersect_element(elements[e], ray, range)) sink(ElementHit{e, *t});
        }
    }
};

}  // namespace detail

/// Iterates the element hits of one ray in leaf order (RangePayload encodings): each leaf's
/// elements are intersected exactly; misses are skipped. Not sorted across overlapping leaves.
/// Throws sylva::Error when a leaf's range does not fit the tree (a mismatched encoding).
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
                if (e >= elements_.size()) throw Error("bih::HitIterator: tree order refers to a missing element");
                if (auto t = intersect_element(elements_[e], ray_, range_)) return ElementHit{e, *t};
            }
            std::uint32_t leaf;
            float t0, t1;
            if (!leaves_.next(leaf, t0, t1)) return std::nullopt;
            std::tie(first_, count_) = detail::leaf_range(leaves_.payload(leaf), tree_.order.size());
            k_ = 0;
        }
    }
    /// Prunes leaves entered after t (elements of the current leaf are still reported).
    void clip(float t) { leaves_.clip(t); }

private:
    detail::Walker<> leaves_;
    const Tree& tree_;
    std::span<const E> elements_;
    Ray ray_;
    Interval range_;
    std::uint32_t first_ = 0, count_ = 0, k_ = 0;
};

/// A sphere as the queries read it: centre and radius, 16 bytes.
struct SphereRecord {
    float c[3];
    float r;
    [[nodiscard]] static SphereRecord of(const Sphere& s) { return {{s.center.x, s.center.y, s.center.z}, s.radius}; }
    /// The box of the sphere it came from, as Sphere::bounds computes it (the same bits).
    [[nodiscard]] Aabb bounds() const {
        Sphere s;
        s.center = vec3(c[0], c[1], c[2]);
        s.radius = r;
        return s.bounds();
    }
};

namespace detail {

/// What a source needs per ray to test spheres four at a time: the ray's terms in the form of
/// Sphere::intersect (same operations in the same order, so the same bits).
struct SphereProbe {
    Ray ray;
    Interval range;
    bool valid;  ///< dot(d, d) > 0: otherwise no sphere is hit
#ifdef SYLVA_BIH_QUERY_SSE
    __m128 o[3], d[3], dd, t0, t1;
#endif
    SphereProbe(const Ray& r, Interval i) : ray(r), range(i) {
        float dd_s = glm::dot(r.direction, r.direction);
        valid = dd_s > 0.0f;
#ifdef SYLVA_BIH_QUERY_SSE
        for (int a = 0; a < 3; ++a) {
            o[a] = _mm_set1_ps(r.origin[a]);
            d[a] = _mm_set1_ps(r.direction[a]);
        }
        dd = _mm_set1_ps(dd_s);
        t0 = _mm_set1_ps(i.t0);
        t1 = _mm_set1_ps(i.t1);
#endif
    }
};

#ifdef SYLVA_BIH_QUERY_SSE
/// Lanes where fl(pp / rr) <= 1, without the division: for x >= 0, fl(x) <= 1 exactly when
/// x <= 1 + 2^-24 (the tie rounds to 1), and pp <= rr (1 + 2^-24) is exact in double. rr == 0
/// (and NaN) lanes fail, as their q is inf or NaN.
SYLVA_FORCEINLINE int inside4(__m128 pp, __m128 rr) {
    const __m128d k = _mm_set1_pd(1.0 + 0x1p-24);
    __m128d lo = _mm_cmple_pd(_mm_cvtps_pd(pp), _mm_mul_pd(_mm_cvtps_pd(rr), k));
    __m128d hi = _mm_cmple_pd(_mm_cvtps_pd(_mm_movehl_ps(pp, pp)), _mm_mul_pd(_mm_cvtps_pd(_mm_movehl_ps(rr, rr)), k));
    int positive = _mm_movemask_ps(_mm_cmpgt_ps(rr, _mm_setzero_ps()));
    return (_mm_movemask_pd(lo) | (_mm_movemask_pd(hi) << 2)) & positive;
}

/// Lanes whose squared distance pp from the ray and squared radius rr sphere4 goes on to test
/// exactly: a superset of inside4, as pp <= rr (1 + 2^-24) implies pp < fl(rr (1 + 2^-21)) for
/// normal rr (tiny rr, where the product may not grow, always pass).
SYLVA_FORCEINLINE int maybe_inside4(__m128 pp, __m128 rr) {
    __m128 maybe = _mm_or_ps(_mm_cmple_ps(pp, _mm_mul_ps(rr, _mm_set1_ps(1.0f + 0x1p-21f))),
                             _mm_cmplt_ps(rr, _mm_set1_ps(0x1p-100f)));
    return _mm_movemask_ps(maybe);
}

/// The ray's closest approach to four spheres: tc (as Sphere::intersect computes it) and the
/// squared distance pp there.
SYLVA_FORCEINLINE void approach4(const SphereProbe& p, __m128 cx, __m128 cy, __m128 cz, __m128& tc, __m128& pp) {
    __m128 ocx = _mm_sub_ps(cx, p.o[0]), ocy = _mm_sub_ps(cy, p.o[1]), ocz = _mm_sub_ps(cz, p.o[2]);
    __m128 dot = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ocx, p.d[0]), _mm_mul_ps(ocy, p.d[1])), _mm_mul_ps(ocz, p.d[2]));
    tc = _mm_div_ps(dot, p.dd);
    __m128 px = _mm_sub_ps(_mm_add_ps(p.o[0], _mm_mul_ps(tc, p.d[0])), cx);
    __m128 py = _mm_sub_ps(_mm_add_ps(p.o[1], _mm_mul_ps(tc, p.d[1])), cy);
    __m128 pz = _mm_sub_ps(_mm_add_ps(p.o[2], _mm_mul_ps(tc, p.d[2])), cz);
    pp = _mm_add_ps(_mm_add_ps(_mm_mul_ps(px, px), _mm_mul_ps(py, py)), _mm_mul_ps(pz, pz));
}

/// The lanes of four spheres that sphere4 would test exactly (no branch: for batches).
SYLVA_FORCEINLINE int sphere4_maybe(const SphereProbe& p, __m128 cx, __m128 cy, __m128 cz, __m128 r) {
    __m128 tc, pp;
    approach4(p, cx, cy, cz, tc, pp);
    return maybe_inside4(pp, _mm_mul_ps(r, r));
}

/// Entry and exit t of four spheres (transposed: centres cx, cy, cz and radii r) and the mask of
/// those hit; sylva::Sphere::intersect's arithmetic lane by lane, so the same bits. Most groups
/// miss: their exit is the exact test of q <= 1 (inside4) before any division by r^2 or square
/// root. std::max(a, b) is (a < b) ? b : a, which is _mm_max_ps(b, a); std::min likewise.
SYLVA_FORCEINLINE int sphere4(const SphereProbe& p, __m128 cx, __m128 cy, __m128 cz, __m128 r, __m128& t0,
                              __m128& t1) {
    __m128 tc, pp;
    approach4(p, cx, cy, cz, tc, pp);
    __m128 rr = _mm_mul_ps(r, r);
    if (maybe_inside4(pp, rr) == 0) return 0;  // most groups: a cheap float test first
    int inside = inside4(pp, rr) & _mm_movemask_ps(_mm_cmpgt_ps(r, _mm_setzero_ps()));
    if (inside == 0) return 0;
    __m128 q = _mm_div_ps(pp, rr);
    __m128 half = _mm_sqrt_ps(_mm_div_ps(_mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_set1_ps(1.0f), q), r), r), p.dd));
    t0 = _mm_max_ps(_mm_sub_ps(tc, half), p.t0);
    t1 = _mm_min_ps(_mm_add_ps(tc, half), p.t1);
    return inside & _mm_movemask_ps(_mm_cmpngt_ps(t0, t1));
}
#endif

}  // namespace detail

/// The elements of a tree in its leaf order, with their indices in the caller's array: each
/// leaf's elements are one contiguous run, so the queries read them without the tree's order[]
/// indirection. Spheres are kept as 16-byte SphereRecords and tested four at a time; other
/// elements are copied as they are. Made once per tree, like its encoding; the queries take
/// it with an encoding of the same tree (RangePayload).
template <Intersectable E>
class LeafRecords {
public:
    static constexpr bool kSpheres = std::is_same_v<E, Sphere>;
    using Record = std::conditional_t<kSpheres, SphereRecord, E>;
    using Probe = std::conditional_t<kSpheres, detail::SphereProbe, std::pair<Ray, Interval>>;

    LeafRecords() = default;
    /// Gathers `elements` in the order of `tree` (built over them); spheres in parallel on `exec`.
    /// Throws sylva::Error when the tree's order does not fit the elements.
    template <Executor X>
    LeafRecords(const Tree& tree, std::span<const E> elements, X& exec) : ids_(tree.order.begin(), tree.order.end()) {
        for (std::uint32_t e : ids_)
            if (e >= elements.size())
                throw Error("bih::LeafRecords: the tree's order refers to element " + std::to_string(e) + " of the " +
                            std::to_string(elements.size()) + " given");
        if constexpr (kSpheres) {
            records_.resize(ids_.size() + 3);  // 3 spare zero-radius records: four-wide loads stay inside
            exec.parallel_for(0, ids_.size(), 16384, [&](std::size_t lo, std::size_t hi) {
                for (std::size_t k = lo; k < hi; ++k) {
                    records_[k] = SphereRecord::of(elements[ids_[k]]);
                }
            });
        } else {  // any element type, default-constructible or not
            records_.reserve(ids_.size());
            for (std::uint32_t e : ids_) records_.push_back(elements[e]);
        }
    }
    /// The same on the calling thread.
    LeafRecords(const Tree& tree, std::span<const E> elements) : LeafRecords(tree, elements, serial()) {}

    /// Number of elements.
    [[nodiscard]] std::size_t size() const { return ids_.size(); }
    /// Index in the caller's array of the element at leaf position k (the tree's order).
    [[nodiscard]] std::span<const std::uint32_t> ids() const { return ids_; }
    /// The records in leaf order (spheres: plus 3 spare ones at the end).
    [[nodiscard]] std::span<const Record> records() const { return records_; }

    /// Calls sink(ElementHit) for each element of the leaf the ray hits, in leaf order.
    template <class Sink>
    void leaf_hits(std::uint64_t payload, const Probe& probe, Sink&& sink) const {
        auto [first, count] = detail::leaf_range(payload, ids_.size());
        if constexpr (kSpheres) {
            sphere_hits(first, count, probe, sink);
        } else {
            for (std::uint32_t k = first; k < first + count; ++k)
                if (auto t = intersect_element(records_[k], probe.first, probe.second)) sink(ElementHit{ids_[k], *t});
        }
    }

private:
    static SerialExecutor& serial() {
        static SerialExecutor s;  // stateless
        return s;
    }

    template <class Sink>
    void sphere_hits(std::uint32_t first, std::uint32_t count, const detail::SphereProbe& p, Sink& sink) const {
        if (!p.valid) return;
#ifdef SYLVA_BIH_QUERY_SSE
        for (std::uint32_t k = first; k < first + count; k += 4) {
            const float* f = records_[k].c;
            __m128 a = _mm_loadu_ps(f), b = _mm_loadu_ps(f + 4), c = _mm_loadu_ps(f + 8), d = _mm_loadu_ps(f + 12);
            _MM_TRANSPOSE4_PS(a, b, c, d);
            // Set by sphere4 whenever mask is non-zero; zeroed so that GCC 12 at -Og (the
            // sanitizer builds) does not take the stores below for uses of uninitialised values.
            __m128 t0 = _mm_setzero_ps(), t1 = _mm_setzero_ps();
            int mask = detail::sphere4(p, a, b, c, d, t0, t1) & ((1 << std::min(first + count - k, 4u)) - 1);
            if (!mask) continue;
            alignas(16) float lo[4], hi[4];
            _mm_store_ps(lo, t0);
            _mm_store_ps(hi, t1);
            for (int lane = 0; lane < 4; ++lane)
                if (mask & (1 << lane)) sink(ElementHit{ids_[k + lane], Interval{lo[lane], hi[lane]}});
        }
#else
        for (std::uint32_t k = first; k < first + count; ++k) {
            Sphere sp;
            sp.center = vec3(records_[k].c[0], records_[k].c[1], records_[k].c[2]);
            sp.radius = records_[k].r;
            if (auto t = sp.intersect(p.ray, p.range)) sink(ElementHit{ids_[k], *t});
        }
#endif
    }

    std::vector<Record> records_;
    std::vector<std::uint32_t> ids_;
};

namespace detail {

template <class E>
std::pair<Ray, Interval> make_probe(const OrderedSource<E>&, const Ray& ray, Interval range) {
    return {ray, range};
}
template <class E>
typename LeafRecords<E>::Probe make_probe(const LeafRecords<E>&, const Ray& ray, Interval range) {
    return typename LeafRecords<E>::Probe(ray, range);
}
template <class E, class Sink>
void source_hits(const OrderedSource<E>& s, std::uint64_t payload, const std::pair<Ray, Interval>& p, Sink&& sink) {
    s.leaf_hits(payload, p.first, p.second, sink);
}
template <class E, class Sink>
void source_hits(const LeafRecords<E>& s, std::uint64_t payload, const typename LeafRecords<E>::Probe& p, Sink&& sink) {
    s.leaf_hits(payload, p, sink);
}

/// Calls f(walker) with a walker compiled for the encoding's layout.
template <class F>
decltype(auto) with_walker(std::span<const std::uint32_t> words, const Ray& ray, Interval range, F&& f) {
    switch (layout_of(words)) {
        case kFixed16Chunks: {
            Walker<kFixed16Chunks> w(words, ray, range);
            return f(w);
        }
        case kFloat32Chunks: {
            Walker<kFloat32Chunks> w(words, ray, range);
            return f(w);
        }
        default: {
            Walker<kAnyLayout> w(words, ray, range);
            return f(w);
        }
    }
}

/// The nearest hit over the leaves of one ray: every leaf is tested, and leaves entered after
/// the best entry so far are pruned (overlapping siblings may still hold an earlier hit).
template <class Source>
std::optional<ElementHit> nearest(std::span<const std::uint32_t> words, const Source& src, const Ray& ray,
                                  Interval range) {
    auto probe = make_probe(src, ray, range);
    return with_walker(words, ray, range, [&](auto& leaves) {
        std::optional<ElementHit> best;
        leaves.for_each_leaf([&](std::uint32_t leaf, float, float) {
            source_hits(src, leaves.payload(leaf), probe, [&](const ElementHit& h) {
                if (!best || hit_before(h, *best)) {
                    best = h;
                    leaves.clip(h.t.t0);
                }
            });
        });
        return best;
    });
}

/// Every hit over the leaves of one ray, sorted by hit_before. Leaves arrive front to back, so
/// an insertion sort keeps this linear in practice.
template <class Source>
void every(std::span<const std::uint32_t> words, const Source& src, const Ray& ray, std::vector<ElementHit>& out,
           Interval range) {
    out.clear();
    auto probe = make_probe(src, ray, range);
    with_walker(words, ray, range, [&](auto& leaves) {
        leaves.for_each_leaf([&](std::uint32_t leaf, float, float) {
            source_hits(src, leaves.payload(leaf), probe, [&](const ElementHit& h) {
                std::size_t i = out.size();
                out.push_back(h);
                for (; i > 0 && hit_before(h, out[i - 1]); --i) out[i] = out[i - 1];
                out[i] = h;
            });
        });
    });
}

}  // namespace detail

/// The nearest element hit in `range` (smallest entry t; ties: smallest element index).
/// `words` must be encoded with RangePayload over `tree`.
template <Intersectable E>
std::optional<ElementHit> first_hit(std::span<const std::uint32_t> words, const Tree& tree,
                                    std::span<const E> elements, const Ray& ray, Interval range = {}) {
    return detail::nearest(words, detail::OrderedSource<E>{elements, tree.order}, ray, range);
}

/// The same over elements in leaf order; `words` must encode the tree `records` was made from.
template <Intersectable E>
std::optional<ElementHit> first_hit(std::span<const std::uint32_t> words, const LeafRecords<E>& records,
                                    const Ray& ray, Interval range = {}) {
    return detail::nearest(words, records, ray, range);
}

/// Every element hit in `range`, sorted by entry t (ties: element index).
/// `words` must be encoded with RangePayload over `tree`.
template <Intersectable E>
void all_hits(std::span<const std::uint32_t> words, const Tree& tree, std::span<const E> elements, const Ray& ray,
              std::vector<ElementHit>& out, Interval range = {}) {
    detail::every(words, detail::OrderedSource<E>{elements, tree.order}, ray, out, range);
}

/// The same over elements in leaf order; `words` must encode the tree `records` was made from.
template <Intersectable E>
void all_hits(std::span<const std::uint32_t> words, const LeafRecords<E>& records, const Ray& ray,
              std::vector<ElementHit>& out, Interval range = {}) {
    detail::every(words, records, ray, out, range);
}

/// Brute-force reference: tests every element. What the queries must reproduce exactly.
/// Throws sylva::Error when there are more elements than ElementHit's 32-bit index can name.
template <Intersectable E>
std::vector<ElementHit> brute_force_hits(std::span<const E> elements, const Ray& ray, Interval range = {}) {
    if (elements.size() > std::size_t{0xFFFFFFFFu})
        throw Error("bih::brute_force_hits: " + std::to_string(elements.size()) +
                    " elements are more than a 32-bit element index names");
    std::vector<ElementHit> hits;
    for (std::size_t e = 0; e < elements.size(); ++e)
        if (auto t = intersect_element(elements[e], ray, range)) hits.push_back({static_cast<std::uint32_t>(e), *t});
    std::sort(hits.begin(), hits.end(), hit_before);
    return hits;
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_QUERY_HPP
