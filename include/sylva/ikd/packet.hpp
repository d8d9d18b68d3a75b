// sylva/ikd/packet.hpp -- packet traversal of the implicit kd-tree on the host (Wald et al.
// section 4.3, "Coherent Ray Tracing"): up to four rays whose direction components have the same
// signs walk the tree together, one node decision and one range test for all of them. Each ray
// keeps its own interval; a node is visited while any ray's interval in it is non-empty.
//
//   ikd::PacketIter it(words, grid, packet, isos, iso_count);
//   ikd::PacketCell c;
//   while (it.next(c)) { for each lane k in c.mask: intersect cell c.cell over [c.t0[k], c.t1[k]] }
//
// Per ray, the cells and intervals reported (the lanes of c.mask) are exactly those of the
// single-ray iterator (sylva/shared/ikd_iter.h) in the same order: the same slab arithmetic
// computes each child's interval from the parent's, and rays of one sign pattern agree on which
// child is near. steps() counts node and cell visits of the packet (Wald's Table I "SIMD" count);
// the single-ray iterators' steps summed give the "C" count. On x86 the four lanes' slab tests
// run as one SSE2 test (the scalar test's operations lane by lane, so the same bits);
// -DSYLVA_IKD_PACKET_NO_SSE keeps the scalar loop.
#ifndef SYLVA_IKD_PACKET_HPP
#define SYLVA_IKD_PACKET_HPP

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <span>

#include "sylva/core/error.hpp"
#include "sylva/shared/ikd_iter.h"

#if defined(__SSE2__) && !defined(SYLVA_IKD_PACKET_NO_SSE)
#include <emmintrin.h>
#define SYLVA_IKD_PACKET_SSE 1
#endif

namespace sylva::ikd {

/// Lanes of a packet.
inline constexpr int kPacketLanes = 4;

/// Up to four rays (world space); `active` marks the lanes in use (bit k: lane k).
struct RayPacket {
    std::array<vec3, kPacketLanes> origin{};
    std::array<vec3, kPacketLanes> direction{};
    std::array<float, kPacketLanes> t_min{}, t_max{};
    std::uint32_t active = 0;
};

/// True when the active rays' direction components have the same sign per axis (+0 and -0
/// count as their signs), the condition of packet traversal.
inline bool same_signs(const RayPacket& p) {
    std::uint32_t first = 0xFFFFFFFFu;
    for (int k = 0; k < kPacketLanes; ++k) {
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
struct PacketCell {
    glm::u32vec3 cell{0};
    std::uint32_t mask = 0;
    std::array<float, kPacketLanes> t0{}, t1{};
    vec4 corners_lo{0.0f}, corners_hi{0.0f};
};

/// The isovalues as node-word code bounds (shared::sylva_ikd_iso_codes) and as bounds on the
/// raw values of an integer grid (shared::sylva_ikd_grid_codes): a renderer computes them once
/// a frame and hands them to every packet.
struct IsoCodes {
    glm::u32vec4 at_most{0u}, below{0u};
    glm::u32vec4 raw_at_most{0u}, raw_below{0u};
};

/// The code bounds of the first `iso_count` (at most 4) of `isos` for the grid `hdr` describes.
inline IsoCodes iso_codes(vec4 isos, std::uint32_t iso_count, const shared::SylvaIkdHeader& hdr) {
    IsoCodes c;
    shared::sylva_ikd_iso_codes(isos, std::min(iso_count, 4u), c.at_most, c.below);
    shared::sylva_ikd_grid_codes(hdr, isos, std::min(iso_count, 4u), c.raw_at_most, c.raw_below);
    return c;
}

namespace detail {

/// Four lanes of floats and the few operations the packet traversal needs, written once over
/// SSE2 (x86) or a plain loop (-DSYLVA_IKD_PACKET_NO_SSE). Each operation is the scalar one lane
/// by lane, so both give the same bits: min4(a, b) = a < b ? a : b (sylva_min(b, a)), max4(a, b)
/// = a > b ? a : b (sylva_max(b, a)), canon4 = sylva_canon.
#ifdef SYLVA_IKD_PACKET_SSE
using F4 = __m128;  ///< four floats
using M4 = __m128;  ///< four lane masks (all bits set or clear)
inline F4 load4(const float* p) { return _mm_load_ps(p); }
inline void store4(float* p, F4 a) { _mm_store_ps(p, a); }
inline F4 set4(float v) { return _mm_set1_ps(v); }
inline F4 sub4(F4 a, F4 b) { return _mm_sub_ps(a, b); }
inline F4 mul4(F4 a, F4 b) { return _mm_mul_ps(a, b); }
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
inline F4 sub4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x - y; }); }
inline F4 mul4(F4 a, F4 b) { return map4(a, b, [](float x, float y) { return x * y; }); }
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

}  // namespace detail

/// The packet iterator (see the top of this header).
class PacketIter {
public:
    /// Throws sylva::Error when the active rays' direction signs differ; an encoding the shared
    /// reader refuses gives status() == SYLVA_ITER_ERROR and no cells.
    PacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid, const RayPacket& p, vec4 isos,
               std::uint32_t iso_count)
        : PacketIter(words, grid,
                     shared::sylva_ikd_read_header(shared::Words{words.data(), words.size()},
                                                   static_cast<std::uint32_t>(words.size()),
                                                   static_cast<std::uint32_t>(grid.size())),
                     p, isos, iso_count) {}

    /// The same with the header sylva_ikd_read_header (float32 grid) or
    /// sylva_ikd_read_header_grid (uint8 / uint16 grid) gave for these buffers (read once per
    /// frame by a renderer).
    PacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid,
               const shared::SylvaIkdHeader& hdr, const RayPacket& p, vec4 isos, std::uint32_t iso_count)
        : PacketIter(words, grid, hdr, p, isos, iso_count, iso_codes(isos, iso_count, hdr)) {}

    /// ... and the isovalues' code bounds iso_codes(isos, iso_count, hdr), also computed once
    /// per frame by a renderer.
    PacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid,
               const shared::SylvaIkdHeader& hdr, const RayPacket& p, vec4 isos, std::uint32_t iso_count,
               const IsoCodes& codes)
        : words_{words.data(), words.size()}, grid_{grid.data(), grid.size()}, hdr_(hdr), isos_(isos),
          iso_count_(iso_count), at_most_(codes.at_most), below_(codes.below), raw_at_most_(codes.raw_at_most),
          raw_below_(codes.raw_below) {
        if (!same_signs(p)) throw Error("ikd::PacketIter: the rays' direction signs differ");
        if (hdr_.valid == 0u) {
            status_ = SYLVA_ITER_ERROR;
            return;
        }
        std::uint32_t mask = 0;
        alignas(16) float t_in[kPacketLanes] = {}, t_out[kPacketLanes] = {};
        for (int k = 0; k < kPacketLanes; ++k) {
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
        if (mask) push(glm::u32vec3(0u), 0u, mask, detail::load4(t_in), detail::load4(t_out));
    }

    /// Ends lane k's traversal beyond t (its cells entered after t are no longer reported).
    void clip(int k, float t) { limit_[k] = std::min(limit_[k], t); }

    /// The next candidate cell of any lane; false when the traversal is over. As in the
    /// single-ray iterator, clip() limits act on the subtrees taken from the stack; the near
    /// child of a node is visited next without a stack round trip. The node being visited
    /// lives in locals (registers) and the stack holds the lanes' intervals as float4 rows.
    bool next(PacketCell& out) {
        Node n{};
        bool have = false;  // n holds the near child of the last node split
        while (status_ == SYLVA_ITER_RUNNING) {
            if (!have && !pop(n)) break;
            have = false;
            ++steps_;
            lane_steps_ += kLaneCount[n.mask & 15u];
            if (n.level >= hdr_.levels) {
                if (cell(n, out)) return true;
                continue;
            }
            std::uint32_t entry = shared::sylva_ikd_level_entry(words_, n.level);
            if (n.level < hdr_.stored) {
                std::uint32_t i = shared::sylva_ikd_node_index(words_, hdr_.cells, n.level, entry, n.node);
                if (!shared::sylva_ikd_word_holds(shared::sylva_ikd_node_word(words_, hdr_, i), at_most_, below_)) continue;  // culled for every lane
            }
            have = descend(n, entry);
        }
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
    /// A subtree being visited: its first cell, level, lanes and the lanes' intervals.
    struct Node {
        glm::u32vec3 node;
        std::uint32_t level, mask;
        detail::F4 t_in, t_out;
    };
    /// Set bits of a 4-bit mask (std::popcount is a library call without -mpopcnt).
    static constexpr std::uint8_t kLaneCount[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
    static constexpr std::size_t kStack = 2 * SYLVA_IKD_MAX_LEVELS + 2;

    /// Reports n's cell when its corners hold an isovalue.
    bool cell(const Node& n, PacketCell& out) {
        if (!shared::sylva_ikd_cell_holds(grid_, hdr_, n.node, isos_, iso_count_, raw_at_most_, raw_below_,
                                          out.corners_lo, out.corners_hi))
            return false;
        out.cell = n.node;
        out.mask = n.mask;
        alignas(16) float t0[kPacketLanes], t1[kPacketLanes];
        detail::store4(t0, n.t_in);
        detail::store4(t1, n.t_out);
        std::copy(t0, t0 + kPacketLanes, out.t0.begin());
        std::copy(t1, t1 + kPacketLanes, out.t1.begin());
        return true;
    }

    void push(glm::u32vec3 node, std::uint32_t level, std::uint32_t mask, detail::F4 t_in, detail::F4 t_out) {
        if (sp_ >= kStack) {  // unreachable: depth <= 48 levels, one far child each
            status_ = SYLVA_ITER_ERROR;
            return;
        }
        st_xy_[sp_] = node.x | node.y << 16;
        st_zl_[sp_] = node.z | level << 16;
        st_mask_[sp_] = mask;
        detail::store4(st_in_[sp_], t_in);
        detail::store4(st_out_[sp_], t_out);
        ++sp_;
    }

    /// Takes the next subtree from the stack into n, its lanes clipped to their limits (lanes
    /// whose interval starts after their limit drop out); false when the stack is empty.
    bool pop(Node& n) {
        detail::F4 lim = detail::load4(limit_.data());
        while (sp_ > 0) {
            --sp_;
            n.t_in = detail::load4(st_in_[sp_]);
            n.mask = st_mask_[sp_] & detail::le_bits4(n.t_in, lim);
            if (!n.mask) continue;
            n.t_out = detail::min4(lim, detail::load4(st_out_[sp_]));  // std::min(t_out, limit)
            n.node = glm::u32vec3(st_xy_[sp_] & 0xFFFFu, st_xy_[sp_] >> 16, st_zl_[sp_] & 0xFFFFu);
            n.level = st_zl_[sp_] >> 16;
            return true;
        }
        return false;
    }

    /// Splits n along its level's axis: n becomes the near child any lane enters (returns
    /// false when no lane enters either), the far one is pushed. Each lane's child intervals are its interval cut at the split plane
    /// (sylva_ikd_split_intervals, the single-ray arithmetic); when the upper child is virtual
    /// the lower one is n's real part and keeps n's lanes and intervals.
    bool descend(Node& n, std::uint32_t entry) {
        using namespace detail;
        std::uint32_t axis = entry & 3u;
        std::uint32_t split = n.node[axis] + (1u << (shared::sylva_ikd_bits5(entry, 8u + 8u * axis) - 1u));
        n.level += 1;
        if (split >= hdr_.cells[axis]) return true;
        F4 o = load4(lanes_.o[axis]), s = set4(static_cast<float>(split));
        M4 par = mask_of4(lanes_.par[axis]);  // (read only when a lane is parallel to the axis)
        F4 ts = canon4(mul4(sub4(s, o), load4(lanes_.r[axis])));
        // sylva_min(t_out, ts) = min4(ts, t_out); sylva_max(t_in, ts) = max4(ts, t_in).
        F4 cut_out = min4(ts, n.t_out), cut_in = max4(ts, n.t_in);
        bool lower_first = lower_first_[axis] != 0u;
        F4 lo_in = lower_first ? n.t_in : cut_in, lo_out = lower_first ? cut_out : n.t_out;
        F4 up_in = lower_first ? cut_in : n.t_in, up_out = lower_first ? n.t_out : cut_out;
        // Lanes parallel to the axis keep their interval on the side(s) of the plane they lie on.
        if (any_parallel_[axis]) {
            const F4 inf = set4(shared::sylva_inf()), ninf = set4(-shared::sylva_inf());
            M4 lo_gone = and4(par, gt4(o, s)), up_gone = and4(par, lt4(o, s));
            lo_in = select4(lo_gone, inf, select4(par, n.t_in, lo_in));
            lo_out = select4(lo_gone, ninf, select4(par, n.t_out, lo_out));
            up_in = select4(up_gone, inf, select4(par, n.t_in, up_in));
            up_out = select4(up_gone, ninf, select4(par, n.t_out, up_out));
        }
        std::uint32_t lo_mask = le_bits4(lo_in, lo_out) & n.mask, up_mask = le_bits4(up_in, up_out) & n.mask;
        glm::u32vec3 up_node = n.node;
        up_node[axis] = split;
        std::uint32_t near_mask = lower_first ? lo_mask : up_mask, far_mask = lower_first ? up_mask : lo_mask;
        if (near_mask && far_mask) {
            if (lower_first) push(up_node, n.level, up_mask, up_in, up_out);
            else push(n.node, n.level, lo_mask, lo_in, lo_out);
        }
        bool go_lower = lo_mask && (lower_first || !up_mask);
        if (!go_lower && !up_mask) return false;  // no lane enters either child
        if (!go_lower) n.node = up_node;
        n.mask = go_lower ? lo_mask : up_mask;
        n.t_in = go_lower ? lo_in : up_in;
        n.t_out = go_lower ? lo_out : up_out;
        return true;
    }

    /// The lanes' rays, structure of arrays: origin, reciprocal direction, parallel masks (-1).
    struct Lanes {
        alignas(16) float o[3][kPacketLanes]{};
        alignas(16) float r[3][kPacketLanes]{};
        alignas(16) std::int32_t par[3][kPacketLanes]{};
    };

    shared::Words words_, grid_;
    shared::SylvaIkdHeader hdr_{};
    vec4 isos_;
    std::uint32_t iso_count_;
    glm::u32vec4 at_most_{0u}, below_{0u};  ///< the isovalues as node-word code bounds
    glm::u32vec4 raw_at_most_{0u}, raw_below_{0u};  ///< ... and as raw-value bounds of an integer grid
    Lanes lanes_;
    alignas(16) std::array<float, kPacketLanes> limit_{};
    glm::u32vec3 lower_first_{1u};
    std::array<bool, 3> any_parallel_{};  ///< per axis: an active lane's ray is parallel to it
    // The stack, rows below sp_ set before use (not cleared for every packet): packed first cell
    // (x | y << 16, z | level << 16, as the single-ray stack), lanes and intervals.
    std::uint32_t st_xy_[kStack], st_zl_[kStack], st_mask_[kStack];
    alignas(16) float st_in_[kStack][kPacketLanes];
    alignas(16) float st_out_[kStack][kPacketLanes];
    std::size_t sp_ = 0;
    std::uint32_t steps_ = 0, lane_steps_ = 0, status_ = SYLVA_ITER_RUNNING;
};

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_PACKET_HPP
