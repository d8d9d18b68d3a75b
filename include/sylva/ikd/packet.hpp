// sylva/ikd/packet.hpp -- packet traversal of the implicit kd-tree on the host (Wald et al.
// section 4.3, "Coherent Ray Tracing"): up to L = 4, 8 or 16 rays whose direction components
// have the same signs walk the tree together, one node decision and one range test for all of
// them. Each ray keeps its own interval; a node is visited while any ray's interval in it is
// non-empty.
//
//   ikd::PacketIter it(words, grid, packet, isos, iso_count);     // 4 lanes; PacketIter8: 8
//   ikd::PacketCell c;
//   while (it.next(c)) { for each lane k in c.mask: intersect cell c.cell over [c.t0[k], c.t1[k]] }
//
// Per ray, the cells and intervals reported (the lanes of c.mask) are exactly those of the
// single-ray iterator (sylva/shared/ikd_iter.h) in the same order: the same slab arithmetic
// computes each child's interval from the parent's, and rays of one sign pattern agree on which
// child is near. steps() counts node and cell visits of the packet (Wald's Table I "SIMD" count);
// the single-ray iterators' steps summed give the "C" count. On x86 each group of four lanes'
// slab tests runs as one SSE2 test (the scalar test's operations lane by lane, so the same
// bits); -DSYLVA_IKD_PACKET_NO_SSE keeps the scalar loop. A renderer decodes the level table
// (levels()) and the isovalues' code bounds (iso_codes()) once a frame and hands them to every
// packet. Wald's packets are 4 rays (SSE); 8 took fewer steps a ray and were the fastest on the
// host (README, Wald section: sylva-iso-bench rows implicit-kd-packet, -packet8, -packet16).
#ifndef SYLVA_IKD_PACKET_HPP
#define SYLVA_IKD_PACKET_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>

#include "sylva/core/error.hpp"
#include "sylva/shared/ikd_iter.h"

#if defined(__SSE2__) && !defined(SYLVA_IKD_PACKET_NO_SSE)
#include <emmintrin.h>
#define SYLVA_IKD_PACKET_SSE 1
#endif

namespace sylva::ikd {

/// Lanes of a PacketIter (Wald's SSE packets).
inline constexpr int kPacketLanes = 4;

/// Up to L rays (world space; L = 4, 8 or 16); `active` marks the lanes in use (bit k: lane k).
template <int L>
struct BasicRayPacket {
    static_assert(L == 4 || L == 8 || L == 16, "ikd packets hold 4, 8 or 16 rays");
    std::array<vec3, L> origin{};
    std::array<vec3, L> direction{};
    std::array<float, L> t_min{}, t_max{};
    std::uint32_t active = 0;
};
using RayPacket = BasicRayPacket<kPacketLanes>;  ///< four rays (SSE width)
using RayPacket8 = BasicRayPacket<8>;            ///< eight rays (two SSE groups)
using RayPacket16 = BasicRayPacket<16>;          ///< sixteen rays (four SSE groups)

/// True when the active rays' direction components have the same sign per axis (+0 and -0
/// count as their signs), the condition of packet traversal.
template <int L>
bool same_signs(const BasicRayPacket<L>& p) {
    std::uint32_t first = 0xFFFFFFFFu;
    for (int k = 0; k < L; ++k) {
        if (!(p.active >> k & 1u)) continue;
        std::uint32_t s = (std::bit_cast<std::uint32_t>(p.direction[k].x) >> 31) |
                          (std::bit_cast<std::uint32_t>(p.direction[k].y) >> 31) << 1 |
                          (std::bit_cast<std::uint32_t>(p.direction[k].z) >> 31) << 2;
        if (first == 0xFFFFFFFFu) first = s;
        if (s != first) return false;
    }
    return true;
}

/// A candidate cell for the lanes of `mask`, each with its interval, and the cell's corners.
template <int L>
struct BasicPacketCell {
    glm::u32vec3 cell{0};
    std::uint32_t mask = 0;
    std::array<float, L> t0{}, t1{};
    vec4 corners_lo{0.0f}, corners_hi{0.0f};
};
using PacketCell = BasicPacketCell<kPacketLanes>;
using PacketCell8 = BasicPacketCell<8>;
using PacketCell16 = BasicPacketCell<16>;

/// The isovalues as node-word code bounds (shared::sylva_ikd_iso_codes) and as bounds on the
/// raw values of an integer grid (shared::sylva_ikd_grid_codes): a renderer computes them once
/// a frame and hands them to every packet.
struct IsoCodes {
    glm::u32vec4 at_most{0u}, below{0u};
    glm::u32vec4 raw_at_most{0u}, raw_below{0u};
    /// at_most and below in 8-bit node codes q (a unorm8 node widens q to q * 257): q * 257 <
    /// at_most exactly when q < ceil(at_most / 257), q * 257 >= below when q >= ceil(below /
    /// 257), so an unorm8 node is tested without widening, with the same outcome.
    glm::u32vec4 at_most8{0u}, below8{0u};
};

/// The code bounds of the first `iso_count` (at most 4) of `isos` for the grid `hdr` describes.
inline IsoCodes iso_codes(vec4 isos, std::uint32_t iso_count, const shared::SylvaIkdHeader& hdr) {
    IsoCodes c;
    shared::sylva_ikd_iso_codes(isos, std::min(iso_count, 4u), c.at_most, c.below);
    shared::sylva_ikd_grid_codes(hdr, isos, std::min(iso_count, 4u), c.raw_at_most, c.raw_below);
    c.at_most8 = (c.at_most + 256u) / 257u;
    c.below8 = (c.below + 256u) / 257u;
    return c;
}

/// The level table of an encoding, decoded once a frame for the packet traversal: per level
/// its split axis, the split's offset from a node's first cell, the node widths' log2 and the
/// terms of the node index (sylva_ikd_node_index: first + (x >> w.x) + r.x (y >> w.y) + r.x r.y
/// (z >> w.z), the same integers regrouped).
struct Levels {
    struct Level {
        std::uint32_t first = 0, row = 0, slice = 0;  ///< first node, r.x, r.x * r.y
        std::uint32_t half = 0;                       ///< 2^(w.axis - 1): the split's offset
        std::uint32_t cells = 0;                      ///< cells along the axis (a split at or past them is virtual)
        std::uint8_t axis = 0, shift = 0;             ///< split axis; 16 * axis (its field in a packed node)
        std::uint8_t wx = 0, wy = 0, wz = 0;
    };
    std::array<Level, SYLVA_IKD_MAX_LEVELS> level{};
};

/// The level table of `words`, whose header sylva_ikd_read_header[_grid] read into hdr (all
/// zero when hdr is not valid).
inline Levels levels(std::span<const std::uint32_t> words, const shared::SylvaIkdHeader& hdr) {
    Levels t;
    if (hdr.valid == 0u) return t;
    shared::Words w{words.data(), words.size()};
    for (std::uint32_t l = 0; l < hdr.levels && l < SYLVA_IKD_MAX_LEVELS; ++l) {
        std::uint32_t entry = shared::sylva_ikd_level_entry(w, l);
        glm::u32vec3 wl = shared::sylva_ikd_level_widths(entry);
        glm::u32vec3 r = shared::sylva_ikd_real_nodes(hdr.cells, wl);
        Levels::Level& v = t.level[l];
        v.first = shared::sylva_ikd_level_first(w, l);
        v.row = r.x;
        v.slice = r.x * r.y;
        // The header check keeps axis <= 2 and w.axis >= 1; the guards keep a header that was
        // read from other words than these (a caller's mistake) from shifting out of range.
        v.axis = static_cast<std::uint8_t>(std::min(entry & 3u, 2u));
        v.shift = static_cast<std::uint8_t>(16u * v.axis);
        v.cells = hdr.cells[v.axis];
        v.half = wl[v.axis] >= 1u ? 1u << (wl[v.axis] - 1u) : 0u;
        v.wx = static_cast<std::uint8_t>(wl.x);
        v.wy = static_cast<std::uint8_t>(wl.y);
        v.wz = static_cast<std::uint8_t>(wl.z);
    }
    return t;
}

namespace detail {

/// Four lanes of floats and the few operations the packet traversal needs, written once over
/// SSE2 (x86) or a plain loop (-DSYLVA_IKD_PACKET_NO_SSE). Each operation is the scalar one lane
/// by lane, so both give the same bits (IEEE add, sub, mul, div and sqrt round alike): min4(a, b) = a < b ? a : b (sylva_min(b, a)), max4(a, b)
/// = a > b ? a : b (sylva_max(b, a)), canon4 = sylva_canon.
#ifdef SYLVA_IKD_PACKET_SSE
using F4 = __m128;  ///< four floats
using M4 = __m128;  ///< four lane masks (all bits set or clear)
inline F4 load4(const float* p) { return _mm_load_ps(p); }
inline void store4(float* p, F4 a) { _mm_store_ps(p, a); }
inline F4 set4(float v) { return _mm_set1_ps(v); }
inline F4 add4(F4 a, F4 b) { return _mm_add_ps(a, b); }
inline F4 sub4(F4 a, F4 b) { return _mm_sub_ps(a, b); }
inline F4 mul4(F4 a, F4 b) { return _mm_mul_ps(a, b); }
inline F4 div4(F4 a, F4 b) { return _mm_div_ps(a, b); }
inline F4 sqrt4(F4 a) { return _mm_sqrt_ps(a); }
inline F4 min4(F4 a, F4 b) { return _mm_min_ps(a, b); }
inline F4 max4(F4 a, F4 b) { return _mm_max_ps(a, b); }
inline M4 lt4(F4 a, F4 b) { return _mm_cmplt_ps(a, b); }
inline M4 gt4(F4 a, F4 b) { return _mm_cmpgt_ps(a, b); }
inline M4 and4(M4 a, M4 b) { return _mm_and_ps(a, b); }
inline F4 select4(M4 m, F4 a, F4 b) { return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)); }
inline std::uint32_t le_bits4(F4 a, F4 b) { return static_cast<std::uint32_t>(_mm_movemask_ps(_mm_cmple_ps(a, b))); }
inline F4 canon4(F4 a) {
    __m128i b = _mm_castps_si128(a);
    return _mm_castsi128_ps(_mm_andnot_si128(_mm_cmpeq_epi32(b, _mm_set1_epi32(static_cast<int>(0x80000000u))), b));
}
inline M4 mask_of4(const std::int32_t* p) { return _mm_castsi128_ps(_mm_load_si128(reinterpret_cast<const __m128i*>(p))); }
#else
struct F4 {
    float v[kPacketLanes];
};
using M4 = F4;  // lanes hold 0 or 1
template <class Op>
inline F4 map4(F4 a, F4 b, Op op) {
    F4 r;
    for (int k = 0; k < kPacketLanes; ++k) r.v[k] = op(a.v[k], b.v[k]);
    return r;
}
inline F4 load4(const float* p) { return {{p[0], p[1], p[2], p[3]}}; }
inline void store4(float* p, F4 a) { std::copy(a.v, a.v + kPacketLanes, p); }
inline F4 set4(float v) { return {{v, v, v, v}}; }
inline F4 add4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x + y; }); }
inline F4 sub4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x - y; }); }
inline F4 mul4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x * y; }); }
inline F4 div4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x / y; }); }
inline F4 sqrt4(F4 a) {
    for (float& x : a.v) x = std::sqrt(x);
    return a;
}
inline F4 min4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x < y ? x : y; }); }
inline F4 max4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x > y ? x : y; }); }
inline M4 lt4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x < y ? 1.0f : 0.0f; }); }
inline M4 gt4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x > y ? 1.0f : 0.0f; }); }
inline M4 and4(M4 a, M4 b) { return map4(a, b, [](float x, float y) { return x * y; }); }
inline F4 select4(M4 m, F4 a, F4 b) {
    F4 r;
    for (int k = 0; k < kPacketLanes; ++k) r.v[k] = m.v[k] != 0.0f ? a.v[k] : b.v[k];
    return r;
}
inline std::uint32_t le_bits4(F4 a, F4 b) {
    std::uint32_t m = 0;
    for (int k = 0; k < kPacketLanes; ++k) m |= (a.v[k] <= b.v[k] ? 1u : 0u) << k;
    return m;
}
inline F4 canon4(F4 a) {
    for (float& x : a.v) x = shared::sylva_canon(x);
    return a;
}
inline M4 mask_of4(const std::int32_t* p) { return {{p[0] ? 1.0f : 0.0f, p[1] ? 1.0f : 0.0f, p[2] ? 1.0f : 0.0f, p[3] ? 1.0f : 0.0f}}; }
#endif

/// L lanes (4 or 8) as L / 4 groups of four; each operation is the group one, group by group.
template <int L>
struct VL {
    F4 g[L / 4];
};
template <int L, class Op>
inline VL<L> zip(const VL<L>& a, const VL<L>& b, Op op) {
    VL<L> r;
    for (int i = 0; i < L / 4; ++i) r.g[i] = op(a.g[i], b.g[i]);
    return r;
}
template <int L>
inline VL<L> vload(const float* p) {
    VL<L> r;
    for (int i = 0; i < L / 4; ++i) r.g[i] = load4(p + 4 * i);
    return r;
}
template <int L>
inline void vstore(float* p, const VL<L>& a) {
    for (int i = 0; i < L / 4; ++i) store4(p + 4 * i, a.g[i]);
}
template <int L>
inline VL<L> vset(float v) {
    VL<L> r;
    for (int i = 0; i < L / 4; ++i) r.g[i] = set4(v);
    return r;
}
template <int L>
inline VL<L> vmask_of(const std::int32_t* p) {
    VL<L> r;
    for (int i = 0; i < L / 4; ++i) r.g[i] = mask_of4(p + 4 * i);
    return r;
}
template <int L>
inline VL<L> vsub(const VL<L>& a, const VL<L>& b) { return zip(a, b, [](F4 x, F4 y) { return sub4(x, y); }); }
template <int L>
inline VL<L> vmul(const VL<L>& a, const VL<L>& b) { return zip(a, b, [](F4 x, F4 y) { return mul4(x, y); }); }
template <int L>
inline VL<L> vmin(const VL<L>& a, const VL<L>& b) { return zip(a, b, [](F4 x, F4 y) { return min4(x, y); }); }
template <int L>
inline VL<L> vmax(const VL<L>& a, const VL<L>& b) { return zip(a, b, [](F4 x, F4 y) { return max4(x, y); }); }
template <int L>
inline VL<L> vlt(const VL<L>& a, const VL<L>& b) { return zip(a, b, [](F4 x, F4 y) { return lt4(x, y); }); }
template <int L>
inline VL<L> vgt(const VL<L>& a, const VL<L>& b) { return zip(a, b, [](F4 x, F4 y) { return gt4(x, y); }); }
template <int L>
inline VL<L> vand(const VL<L>& a, const VL<L>& b) { return zip(a, b, [](F4 x, F4 y) { return and4(x, y); }); }
template <int L>
inline VL<L> vselect(const VL<L>& m, const VL<L>& a, const VL<L>& b) {
    VL<L> r;
    for (int i = 0; i < L / 4; ++i) r.g[i] = select4(m.g[i], a.g[i], b.g[i]);
    return r;
}
template <int L>
inline VL<L> vcanon(const VL<L>& a) {
    VL<L> r;
    for (int i = 0; i < L / 4; ++i) r.g[i] = canon4(a.g[i]);
    return r;
}
/// Bit k set where lane k of a <= lane k of b.
template <int L>
inline std::uint32_t vle_bits(const VL<L>& a, const VL<L>& b) {
    std::uint32_t m = 0;
    for (int i = 0; i < L / 4; ++i) m |= le_bits4(a.g[i], b.g[i]) << (4 * i);
    return m;
}

}  // namespace detail

/// The packet iterator (see the top of this header) over L = 4, 8 or 16 lanes.
template <int L>
class BasicPacketIter {
    static_assert(L == 4 || L == 8 || L == 16, "ikd packets hold 4, 8 or 16 rays");
    using RayPacket = BasicRayPacket<L>;
    using PacketCell = BasicPacketCell<L>;
    using V = detail::VL<L>;

public:
    /// Throws sylva::Error when the active rays' direction signs differ; an encoding the shared
    /// reader refuses gives status() == SYLVA_ITER_ERROR and no cells.
    BasicPacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid, const RayPacket& p,
                    vec4 isos, std::uint32_t iso_count)
        : BasicPacketIter(words, grid,
                          shared::sylva_ikd_read_header(shared::Words{words.data(), words.size()},
                                                        static_cast<std::uint32_t>(words.size()),
                                                        static_cast<std::uint32_t>(grid.size())),
                          p, isos, iso_count) {}

    /// The same with the header sylva_ikd_read_header (float32 grid) or
    /// sylva_ikd_read_header_grid (uint8 / uint16 grid) gave for these buffers (read once per
    /// frame by a renderer).
    BasicPacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid,
                    const shared::SylvaIkdHeader& hdr, const RayPacket& p, vec4 isos, std::uint32_t iso_count)
        : BasicPacketIter(words, grid, hdr, p, isos, iso_count, iso_codes(isos, iso_count, hdr)) {}

    /// ... and the isovalues' code bounds iso_codes(isos, iso_count, hdr), also computed once
    /// per frame by a renderer.
    BasicPacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid,
                    const shared::SylvaIkdHeader& hdr, const RayPacket& p, vec4 isos, std::uint32_t iso_count,
                    const IsoCodes& codes)
        : BasicPacketIter(words, grid, hdr, p, isos, iso_count, codes, nullptr) {}

    /// ... and the level table levels(words, hdr), decoded once a frame too; `table` must
    /// outlive the iterator.
    BasicPacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid,
                    const shared::SylvaIkdHeader& hdr, const RayPacket& p, vec4 isos, std::uint32_t iso_count,
                    const IsoCodes& codes, const Levels& table)
        : BasicPacketIter(words, grid, hdr, p, isos, iso_count, codes, &table) {}

    /// Ends lane k's traversal beyond t (its cells entered after t are no longer reported).
    void clip(int k, float t) { limit_[k] = std::min(limit_[k], t); }

    /// The next candidate cell of any lane; false when the traversal is over. As in the
    /// single-ray iterator, clip() limits act on the subtrees taken from the stack; the near
    /// child of a node is visited next without a stack round trip. The node being visited
    /// lives in locals (registers) and the stack holds the lanes' intervals as float4 rows.
    bool next(PacketCell& out) {
        if (status_ != SYLVA_ITER_RUNNING) return false;
        Node n{};
        bool have = false;  // n holds the near child of the last node split
        // The counters and the header fields read every step live in registers during the walk
        // (the stack's stores could alias the members).
        std::uint32_t steps = steps_, lane_steps = lane_steps_;
        const std::uint32_t levels = hdr_.levels, stored = hdr_.stored;
        bool found = false;
        for (;;) {
            if (!have && !pop(n)) break;
            have = false;
            ++steps;
            lane_steps += lane_count(n.mask);
            if (n.level >= levels) {
                if (cell(n, out)) {
                    found = true;
                    break;
                }
                continue;
            }
            const Levels::Level& lv = levels_->level[n.level];
            if (n.level < stored && !node_holds(lv, n.xyz)) continue;  // culled for every lane
            have = descend(n, lv);
            if (!have && status_ != SYLVA_ITER_RUNNING) break;  // the stack overflowed (unreachable)
        }
        steps_ = steps;
        lane_steps_ = lane_steps;
        if (found) return true;
        if (status_ == SYLVA_ITER_RUNNING) status_ = SYLVA_ITER_DONE;
        return false;
    }

    /// Lane k's ray origin in cell space (what the iterator maps it to; shading needs it too).
    [[nodiscard]] vec3 lane_origin(int k) const { return {lanes_.o[0][k], lanes_.o[1][k], lanes_.o[2][k]}; }
    [[nodiscard]] std::uint32_t steps() const { return steps_; }
    /// The tree's header (for mapping the lanes' rays into cell space as the iterator does).
    [[nodiscard]] const shared::SylvaIkdHeader& header() const { return hdr_; }
    /// Active lanes summed over the steps: lane_steps() / steps() is the average number of rays
    /// active in a packet step (Wald's "SIMD efficiency", section 4.3).
    [[nodiscard]] std::uint32_t lane_steps() const { return lane_steps_; }
    [[nodiscard]] std::uint32_t status() const { return status_; }

private:
    /// The constructors' work; `table` null: the iterator decodes its own level table.
    BasicPacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid,
                    const shared::SylvaIkdHeader& hdr, const RayPacket& p, vec4 isos, std::uint32_t iso_count,
                    const IsoCodes& codes, const Levels* table)
        : words_{words.data(), words.size()}, grid_{grid.data(), grid.size()}, hdr_(hdr), isos_(isos),
          iso_count_(iso_count), at_most_(codes.at_most), below_(codes.below), raw_at_most_(codes.raw_at_most),
          raw_below_(codes.raw_below), at_most8_(codes.at_most8), below8_(codes.below8) {
        if (!same_signs(p)) throw Error("ikd::PacketIter: the rays' direction signs differ");
        if (hdr_.valid == 0u) {
            status_ = SYLVA_ITER_ERROR;
            return;
        }
        std::uint32_t mask = 0;
        alignas(16) float t_in[L] = {}, t_out[L] = {};
        for (int k = 0; k < L; ++k) {
            limit_[k] = p.t_max[k];
            if (!(p.active >> k & 1u)) continue;
            vec3 org, rcp;
            glm::u32vec3 par;
            bool nan = shared::sylva_ray_to_grid(p.origin[k], p.direction[k], hdr_.origin, hdr_.inv_spacing, p.t_min[k],
                                                 p.t_max[k], org, rcp, par);
            vec2 t = shared::sylva_ikd_box_interval(org, rcp, par, hdr_.cells, glm::u32vec3(0), hdr_.lg,
                                                    shared::sylva_canon(p.t_min[k]), shared::sylva_canon(p.t_max[k]));
            if (!nan && iso_count > 0 && t.x <= t.y) {
                mask |= 1u << k;
                t_in[k] = t.x;
                t_out[k] = t.y;
            }
            lower_first_ = {std::signbit(rcp.x) ? 0u : 1u, std::signbit(rcp.y) ? 0u : 1u, std::signbit(rcp.z) ? 0u : 1u};
            for (int a = 0; a < 3; ++a) {
                lanes_.o[a][k] = org[a];
                lanes_.r[a][k] = rcp[a];
                lanes_.par[a][k] = par[a] ? -1 : 0;
                any_parallel_[a] = any_parallel_[a] || par[a] != 0u;
            }
        }
        // The root goes through pop() like every subtree, so its lanes see their limits.
        if (mask) push(0u, 0u, mask, detail::vload<L>(t_in), detail::vload<L>(t_out));
        if (table) {
            levels_ = table;
        } else {
            own_levels_ = std::make_unique<Levels>(levels(words, hdr_));
            levels_ = own_levels_.get();
        }
    }

    /// A subtree being visited: its first cell packed (x | y << 16 | z << 32: cells < 2^16 per
    /// axis, SYLVA_IKD_MAX_CELLS, so a child is its parent plus half << 16 axis), level, lanes
    /// and the lanes' intervals.
    struct Node {
        std::uint64_t xyz;
        std::uint32_t level, mask;
        V t_in, t_out;
    };
    static glm::u32vec3 unpack(std::uint64_t xyz) {
        return {static_cast<std::uint32_t>(xyz & 0xFFFFu), static_cast<std::uint32_t>((xyz >> 16) & 0xFFFFu),
                static_cast<std::uint32_t>(xyz >> 32)};
    }
    /// Set bits of an 8-bit mask (std::popcount is a library call without -mpopcnt).
    static constexpr std::array<std::uint8_t, 256> kLaneCount = [] {
        std::array<std::uint8_t, 256> t{};
        for (int m = 0; m < 256; ++m)
            for (int b = 0; b < 8; ++b) t[m] += static_cast<std::uint8_t>((m >> b) & 1);
        return t;
    }();
    static std::uint32_t lane_count(std::uint32_t mask) {
        std::uint32_t c = kLaneCount[mask & 255u];
        if constexpr (L > 8) c += kLaneCount[(mask >> 8) & 255u];
        return c;
    }
    static constexpr std::size_t kStack = 2 * SYLVA_IKD_MAX_LEVELS + 2;

    /// True when the stored node of level lv starting at cell o holds an isovalue
    /// (sylva_ikd_word_holds of sylva_ikd_node_word at sylva_ikd_node_index, through the level
    /// table; an unorm8 node is tested on its 8-bit codes).
    bool node_holds(const Levels::Level& lv, std::uint64_t xyz) const {
        glm::u32vec3 o = unpack(xyz);
        std::uint32_t i = lv.first + (o.x >> lv.wx) + lv.row * (o.y >> lv.wy) + lv.slice * (o.z >> lv.wz);
        if (hdr_.format != SYLVA_IKD_FORMAT_UNORM8)
            return shared::sylva_ikd_word_holds(words_[hdr_.nodes_at + i], at_most_, below_);
        std::uint32_t pair = words_[hdr_.nodes_at + (i >> 1u)] >> ((i & 1u) * 16u);
        std::uint32_t lo = pair & 0xFFu, hi = (pair >> 8u) & 0xFFu;
        return ((lo < at_most8_.x) & (hi >= below8_.x)) | ((lo < at_most8_.y) & (hi >= below8_.y)) |
               ((lo < at_most8_.z) & (hi >= below8_.z)) | ((lo < at_most8_.w) & (hi >= below8_.w));
    }

    /// Reports n's cell when its corners hold an isovalue.
    bool cell(const Node& n, PacketCell& out) {
        glm::u32vec3 c = unpack(n.xyz);
        if (!shared::sylva_ikd_cell_holds(grid_, hdr_, c, isos_, iso_count_, raw_at_most_, raw_below_, out.corners_lo,
                                          out.corners_hi))
            return false;
        out.cell = c;
        out.mask = n.mask;
        alignas(16) float t0[L], t1[L];
        detail::vstore<L>(t0, n.t_in);
        detail::vstore<L>(t1, n.t_out);
        std::copy(t0, t0 + L, out.t0.begin());
        std::copy(t1, t1 + L, out.t1.begin());
        return true;
    }

    void push(std::uint64_t xyz, std::uint32_t level, std::uint32_t mask, V t_in, V t_out) {
        if (sp_ >= kStack) {  // unreachable: depth <= 48 levels, one far child each
            status_ = SYLVA_ITER_ERROR;
            return;
        }
        write_row(xyz, level, mask, t_in, t_out);
        ++sp_;
    }

    /// Writes the stack row at sp_ (< kStack) without taking it.
    void write_row(std::uint64_t xyz, std::uint32_t level, std::uint32_t mask, V t_in, V t_out) {
        st_xyz_[sp_] = xyz;
        st_level_[sp_] = level;
        st_mask_[sp_] = mask;
        detail::vstore<L>(st_in_[sp_], t_in);
        detail::vstore<L>(st_out_[sp_], t_out);
    }

    /// Takes the next subtree from the stack into n, its lanes clipped to their limits (lanes
    /// whose interval starts after their limit drop out); false when the stack is empty.
    bool pop(Node& n) {
        V lim = detail::vload<L>(limit_.data());
        while (sp_ > 0) {
            --sp_;
            n.t_in = detail::vload<L>(st_in_[sp_]);
            n.mask = st_mask_[sp_] & detail::vle_bits(n.t_in, lim);
            if (!n.mask) continue;
            n.t_out = detail::vmin(lim, detail::vload<L>(st_out_[sp_]));  // std::min(t_out, limit)
            n.xyz = st_xyz_[sp_];
            n.level = st_level_[sp_];
            return true;
        }
        return false;
    }

    /// Splits n along its level's axis: n becomes the near child any lane enters (returns
    /// false when no lane enters either), the far one is pushed. Each lane's child intervals are its interval cut at the split plane
    /// (sylva_ikd_split_intervals, the single-ray arithmetic); when the upper child is virtual
    /// the lower one is n's real part and keeps n's lanes and intervals.
    bool descend(Node& n, const Levels::Level& lv) {
        using namespace detail;
        std::uint32_t axis = lv.axis;
        std::uint32_t split = static_cast<std::uint32_t>((n.xyz >> lv.shift) & 0xFFFFu) + lv.half;
        n.level += 1;
        if (split >= lv.cells) return true;
        V o = vload<L>(lanes_.o[axis]), s = vset<L>(static_cast<float>(split));
        V par = vmask_of<L>(lanes_.par[axis]);  // (read only when a lane is parallel to the axis)
        V ts = vcanon(vmul(vsub(s, o), vload<L>(lanes_.r[axis])));
        // The near child (the lower one when lower_first) is [t_in, sylva_min(t_out, ts)] =
        // vmin(ts, t_out), the far one [sylva_max(t_in, ts), t_out] = vmax(ts, t_in), whichever
        // side is near: the single ray's sylva_ikd_split_intervals.
        V near_in = n.t_in, near_out = vmin(ts, n.t_out), far_in = vmax(ts, n.t_in), far_out = n.t_out;
        bool lower_first = lower_first_[axis] != 0u;
        // Lanes parallel to the axis keep their interval on the side(s) of the plane they lie on.
        if (any_parallel_[axis]) {
            const V inf = vset<L>(shared::sylva_inf()), ninf = vset<L>(-shared::sylva_inf());
            V lo_gone = vand(par, vgt(o, s)), up_gone = vand(par, vlt(o, s));
            V near_gone = lower_first ? lo_gone : up_gone, far_gone = lower_first ? up_gone : lo_gone;
            near_in = vselect(near_gone, inf, vselect(par, n.t_in, near_in));
            near_out = vselect(near_gone, ninf, vselect(par, n.t_out, near_out));
            far_in = vselect(far_gone, inf, vselect(par, n.t_in, far_in));
            far_out = vselect(far_gone, ninf, vselect(par, n.t_out, far_out));
        }
        std::uint32_t near_mask = vle_bits(near_in, near_out) & n.mask, far_mask = vle_bits(far_in, far_out) & n.mask;
        std::uint64_t upper = n.xyz + (std::uint64_t{lv.half} << lv.shift);
        std::uint64_t near_xyz = lower_first ? n.xyz : upper, far_xyz = lower_first ? upper : n.xyz;
        // The far child goes on the stack when both are entered; its row is written either way
        // and kept only then (no branch on the lanes' data).
        if (sp_ >= kStack) {  // unreachable: depth <= 48 levels, one far child each
            status_ = SYLVA_ITER_ERROR;
            return false;
        }
        write_row(far_xyz, n.level, far_mask, far_in, far_out);
        sp_ = static_cast<std::uint16_t>(sp_ + ((near_mask != 0u && far_mask != 0u) ? 1u : 0u));
        if (near_mask != 0u) {  // (mostly taken: a branch is cheaper than selecting the lanes)
            n.xyz = near_xyz;
            n.mask = near_mask;
            n.t_in = near_in;
            n.t_out = near_out;
            return true;
        }
        n.xyz = far_xyz;
        n.mask = far_mask;
        n.t_in = far_in;
        n.t_out = far_out;
        return far_mask != 0u;  // false: no lane enters either child
    }

    /// The lanes' rays, structure of arrays: origin, reciprocal direction, parallel masks (-1).
    struct Lanes {
        alignas(16) float o[3][L]{};
        alignas(16) float r[3][L]{};
        alignas(16) std::int32_t par[3][L]{};
    };

    shared::Words words_, grid_;
    shared::SylvaIkdHeader hdr_{};
    vec4 isos_;
    std::uint32_t iso_count_;
    glm::u32vec4 at_most_{0u}, below_{0u};  ///< the isovalues as node-word code bounds
    glm::u32vec4 raw_at_most_{0u}, raw_below_{0u};  ///< ... and as raw-value bounds of an integer grid
    glm::u32vec4 at_most8_{0u}, below8_{0u};        ///< ... and as unorm8 node codes
    const Levels* levels_ = nullptr;                ///< the level table (the caller's or own_levels_)
    std::unique_ptr<Levels> own_levels_;
    Lanes lanes_;
    alignas(16) std::array<float, L> limit_{};
    glm::u32vec3 lower_first_{1u};
    std::array<bool, 3> any_parallel_{};  ///< per axis: an active lane's ray is parallel to it
    // The stack, rows below sp_ set before use (not cleared for every packet): packed first cell
    // (Node::xyz), level, lanes and intervals.
    std::uint64_t st_xyz_[kStack];
    std::uint32_t st_level_[kStack], st_mask_[kStack];
    alignas(16) float st_in_[kStack][L];
    alignas(16) float st_out_[kStack][L];
    std::uint16_t sp_ = 0;  ///< (16 bits: no stack row's type, so the rows' stores cannot alias it)
    std::uint32_t steps_ = 0, lane_steps_ = 0, status_ = SYLVA_ITER_RUNNING;
};

/// Four rays a packet (Wald's SSE packets), eight and sixteen (two and four SSE groups: one
/// node decision and one range test for more rays, each step with fewer of them active).
using PacketIter = BasicPacketIter<kPacketLanes>;
using PacketIter8 = BasicPacketIter<8>;
using PacketIter16 = BasicPacketIter<16>;

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_PACKET_HPP
