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

    /// The same with the header sylva_ikd_read_header gave for these buffers (read once per
    /// frame by a renderer).
    PacketIter(std::span<const std::uint32_t> words, std::span<const std::uint32_t> grid,
               const shared::SylvaIkdHeader& hdr, const RayPacket& p, vec4 isos, std::uint32_t iso_count)
        : words_{words.data(), words.size()}, grid_{grid.data(), grid.size()}, hdr_(hdr), isos_(isos),
          iso_count_(iso_count) {
        if (!same_signs(p)) throw Error("ikd::PacketIter: the rays' direction signs differ");
        if (hdr_.valid == 0u) {
            status_ = SYLVA_ITER_ERROR;
            return;
        }
        Entry root;
        for (int k = 0; k < kPacketLanes; ++k) {
            limit_[k] = p.t_max[k];
            if (!(p.active >> k & 1u)) continue;
            bool nan = shared::sylva_ray_to_grid(p.origin[k], p.direction[k], hdr_.origin, hdr_.inv_spacing, p.t_min[k],
                                                 p.t_max[k], org_[k], rcp_[k], par_[k]);
            vec2 t = shared::sylva_ikd_box_interval(org_[k], rcp_[k], par_[k], hdr_.cells, glm::u32vec3(0), hdr_.lg,
                                                    p.t_min[k], p.t_max[k]);
            if (!nan && iso_count > 0 && t.x <= t.y) {
                root.mask |= 1u << k;
                root.t_in[k] = t.x;
                root.t_out[k] = t.y;
            }
            lower_first_ = {std::signbit(rcp_[k].x) ? 0u : 1u, std::signbit(rcp_[k].y) ? 0u : 1u,
                            std::signbit(rcp_[k].z) ? 0u : 1u};
            for (int a = 0; a < 3; ++a) {
                lanes_.o[a][k] = org_[k][a];
                lanes_.r[a][k] = rcp_[k][a];
                lanes_.par[a][k] = par_[k][a] ? -1 : 0;
            }
        }
        if (root.mask) stack_[sp_++] = root;
        // (the root goes through pop() like every subtree, so its lanes see their limits)
    }

    /// Ends lane k's traversal beyond t (its cells entered after t are no longer reported).
    void clip(int k, float t) { limit_[k] = std::min(limit_[k], t); }

    /// The next candidate cell of any lane; false when the traversal is over. As in the
    /// single-ray iterator, clip() limits act on the subtrees taken from the stack; the near
    /// child of a node is visited next without a stack round trip.
    bool next(PacketCell& out) {
        while (status_ == SYLVA_ITER_RUNNING) {
            if (!have_ && !pop()) break;
            have_ = false;
            ++steps_;
            lane_steps_ += static_cast<std::uint32_t>(std::popcount(cur_.mask));
            if (cur_.level >= hdr_.levels) {
                if (cell(cur_, out)) return true;
                continue;
            }
            std::uint32_t entry = shared::sylva_ikd_level_entry(words_, cur_.level);
            if (cur_.level < hdr_.stored) {
                std::uint32_t i = shared::sylva_ikd_node_index(words_, hdr_.cells, cur_.level, entry, cur_.node);
                vec2 r = shared::sylva_ikd_node_range(words_[hdr_.nodes_at + i]);
                if (!shared::sylva_ikd_holds(isos_, iso_count_, r.x, r.y)) continue;  // culled for every lane
            }
            descend(entry);
        }
        if (status_ == SYLVA_ITER_RUNNING) status_ = SYLVA_ITER_DONE;
        return false;
    }

    [[nodiscard]] std::uint32_t steps() const { return steps_; }
    /// The tree's header (for mapping the lanes' rays into cell space as the iterator does).
    [[nodiscard]] const shared::SylvaIkdHeader& header() const { return hdr_; }
    /// Active lanes summed over the steps: lane_steps() / steps() is the average number of rays
    /// active in a packet step (Wald's "SIMD efficiency", section 4.3).
    [[nodiscard]] std::uint32_t lane_steps() const { return lane_steps_; }
    [[nodiscard]] std::uint32_t status() const { return status_; }

private:
    struct Entry {
        glm::u32vec3 node{0};
        std::uint32_t level = 0, mask = 0;
        std::array<float, kPacketLanes> t_in{}, t_out{};
    };

    /// Reports f's cell when its corners hold an isovalue.
    bool cell(const Entry& f, PacketCell& out) {
        shared::sylva_ikd_corners(grid_, hdr_.cells, f.node, out.corners_lo, out.corners_hi);
        if (!shared::sylva_ikd_corners_hold(out.corners_lo, out.corners_hi, isos_, iso_count_)) return false;
        out.cell = f.node;
        out.mask = f.mask;
        out.t0 = f.t_in;
        out.t1 = f.t_out;
        return true;
    }

    /// Takes the next subtree from the stack into cur_, its lanes clipped to their limits (lanes
    /// whose interval starts after their limit drop out); false when the stack is empty.
    bool pop() {
        while (sp_ > 0) {
            cur_ = stack_[--sp_];
            for (int k = 0; k < kPacketLanes; ++k) {
                if (!(cur_.mask >> k & 1u)) continue;
                if (!(cur_.t_in[k] <= limit_[k])) cur_.mask &= ~(1u << k);
                else cur_.t_out[k] = std::min(cur_.t_out[k], limit_[k]);
            }
            if (cur_.mask) return true;
        }
        return false;
    }

    /// Splits cur_: continues with the near child any lane enters and pushes the far one.
    void descend(std::uint32_t entry) {
        const Entry f = cur_;
        std::uint32_t axis = entry & 3u;
        glm::u32vec3 w = shared::sylva_ikd_level_widths(entry), cw = w;
        cw[axis] -= 1;
        glm::u32vec3 up = f.node;
        up[axis] += 1u << cw[axis];
        bool up_real = up[axis] < hdr_.cells[axis];
        Entry lo{f.node, f.level + 1, 0, {}, {}}, hi{up, f.level + 1, 0, {}, {}};
        intervals(f, f.node, cw, lo);
        if (up_real) intervals(f, up, cw, hi);
        bool lower_first = lower_first_[axis] != 0u;
        const Entry& near = lower_first ? lo : hi;
        const Entry& far = lower_first ? hi : lo;
        if (sp_ + 2 > stack_.size()) {  // unreachable: depth <= 48 levels, one far child each
            status_ = SYLVA_ITER_ERROR;
            return;
        }
        if (far.mask && near.mask) {
            stack_[sp_++] = far;
            cur_ = near;
        } else {
            cur_ = near.mask ? near : far;  // one child, or none (then have_ stays false)
        }
        have_ = cur_.mask != 0;
    }

    /// The lanes' intervals (within f's) in the real part of the box of width 2^w cells at o:
    /// sylva_ikd_box_interval for each lane of f.mask; fills out's mask, t_in and t_out.
    void intervals(const Entry& f, glm::u32vec3 o, glm::u32vec3 w, Entry& out) const {
        glm::u32vec3 c = hdr_.cells;
        float lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = static_cast<float>(o[a]);
            hi[a] = static_cast<float>(std::min(o[a] + (1u << w[a]), c[a]));
        }
#ifdef SYLVA_IKD_PACKET_SSE
        const __m128 inf = _mm_set1_ps(shared::sylva_inf()), ninf = _mm_set1_ps(-shared::sylva_inf());
        const __m128i negzero = _mm_set1_epi32(static_cast<int>(0x80000000u));
        auto canon = [&](__m128 x) {  // sylva_canon: -0 -> +0 by bits
            __m128i b = _mm_castps_si128(x);
            return _mm_castsi128_ps(_mm_andnot_si128(_mm_cmpeq_epi32(b, negzero), b));
        };
        __m128 ta_acc = _mm_loadu_ps(f.t_in.data()), tb_acc = _mm_loadu_ps(f.t_out.data());
        for (int a = 0; a < 3; ++a) {
            __m128 o4 = _mm_load_ps(lanes_.o[a]), r4 = _mm_load_ps(lanes_.r[a]);
            __m128 par = _mm_castsi128_ps(_mm_load_si128(reinterpret_cast<const __m128i*>(lanes_.par[a])));
            __m128 l = _mm_set1_ps(lo[a]), h = _mm_set1_ps(hi[a]);
            __m128 ta = canon(_mm_mul_ps(_mm_sub_ps(l, o4), r4)), tb = canon(_mm_mul_ps(_mm_sub_ps(h, o4), r4));
            // sylva_max(acc, sylva_min(ta, tb)) and sylva_min(acc, sylva_max(ta, tb)): minps/maxps
            // return their second operand on ties and NaN, as sylva_min/max return their first.
            __m128 na = _mm_max_ps(_mm_min_ps(tb, ta), ta_acc), nb = _mm_min_ps(_mm_max_ps(tb, ta), tb_acc);
            __m128 outside = _mm_and_ps(par, _mm_or_ps(_mm_cmplt_ps(o4, l), _mm_cmpgt_ps(o4, h)));
            ta_acc = _mm_or_ps(_mm_andnot_ps(par, na), _mm_and_ps(par, ta_acc));  // parallel: unchanged...
            tb_acc = _mm_or_ps(_mm_andnot_ps(par, nb), _mm_and_ps(par, tb_acc));
            ta_acc = _mm_or_ps(_mm_andnot_ps(outside, ta_acc), _mm_and_ps(outside, inf));  // ...or empty
            tb_acc = _mm_or_ps(_mm_andnot_ps(outside, tb_acc), _mm_and_ps(outside, ninf));
        }
        int hit = _mm_movemask_ps(_mm_cmple_ps(ta_acc, tb_acc)) & static_cast<int>(f.mask);
        out.mask = static_cast<std::uint32_t>(hit);
        _mm_storeu_ps(out.t_in.data(), ta_acc);
        _mm_storeu_ps(out.t_out.data(), tb_acc);
#else
        for (int k = 0; k < kPacketLanes; ++k) {
            if (!(f.mask >> k & 1u)) continue;
            vec2 t = shared::sylva_kd_box_interval_f(org_[k], rcp_[k], par_[k], vec3(lo[0], lo[1], lo[2]),
                                                     vec3(hi[0], hi[1], hi[2]), f.t_in[k], f.t_out[k]);
            if (t.x <= t.y) out.mask |= 1u << k, out.t_in[k] = t.x, out.t_out[k] = t.y;
        }
#endif
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
    std::array<vec3, kPacketLanes> org_{}, rcp_{};
    std::array<glm::u32vec3, kPacketLanes> par_{};
    Lanes lanes_;
    std::array<float, kPacketLanes> limit_{};
    glm::u32vec3 lower_first_{1u};
    std::array<Entry, 2 * SYLVA_IKD_MAX_LEVELS + 2> stack_{};
    std::size_t sp_ = 0;
    Entry cur_{};
    bool have_ = false;
    std::uint32_t steps_ = 0, lane_steps_ = 0, status_ = SYLVA_ITER_RUNNING;
};

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_PACKET_HPP
