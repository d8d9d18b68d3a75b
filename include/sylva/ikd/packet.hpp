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
// the single-ray iterators' steps summed give the "C" count.
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
        : words_{words.data(), words.size()}, grid_{grid.data(), grid.size()}, isos_(isos), iso_count_(iso_count) {
        if (!same_signs(p)) throw Error("ikd::PacketIter: the rays' direction signs differ");
        hdr_ = shared::sylva_ikd_read_header(words_, static_cast<std::uint32_t>(words.size()),
                                              static_cast<std::uint32_t>(grid.size()));
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
        }
        if (root.mask) stack_[sp_++] = root;
    }

    /// Ends lane k's traversal beyond t (its cells entered after t are no longer reported).
    void clip(int k, float t) { limit_[k] = std::min(limit_[k], t); }

    /// The next candidate cell of any lane; false when the traversal is over.
    bool next(PacketCell& out) {
        while (status_ == SYLVA_ITER_RUNNING && sp_ > 0) {
            Entry f = stack_[--sp_];
            for (int k = 0; k < kPacketLanes; ++k)  // pop: lanes whose interval starts after their limit drop out
                if ((f.mask >> k & 1u) && !(f.t_in[k] <= limit_[k])) f.mask &= ~(1u << k);
                else if (f.mask >> k & 1u) f.t_out[k] = std::min(f.t_out[k], limit_[k]);
            if (!f.mask) continue;
            ++steps_;
            if (f.level >= hdr_.levels) {
                if (cell(f, out)) return true;
                continue;
            }
            std::uint32_t entry = shared::sylva_ikd_level_entry(words_, f.level);
            if (f.level < hdr_.stored) {
                std::uint32_t i = shared::sylva_ikd_node_index(words_, hdr_.cells, f.level, entry, f.node);
                vec2 r = shared::sylva_ikd_node_range(words_[hdr_.nodes_at + i]);
                if (!shared::sylva_ikd_holds(isos_, iso_count_, r.x, r.y)) continue;  // culled for every lane
            }
            descend(f, entry);
        }
        if (status_ == SYLVA_ITER_RUNNING) status_ = SYLVA_ITER_DONE;
        return false;
    }

    [[nodiscard]] std::uint32_t steps() const { return steps_; }
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

    /// Pushes f's children that any lane enters, far first, so the near one is popped next.
    void descend(const Entry& f, std::uint32_t entry) {
        std::uint32_t axis = entry & 3u;
        glm::u32vec3 w = shared::sylva_ikd_level_widths(entry), cw = w;
        cw[axis] -= 1;
        glm::u32vec3 up = f.node;
        up[axis] += 1u << cw[axis];
        bool up_real = up[axis] < hdr_.cells[axis];
        Entry lo{f.node, f.level + 1, 0, {}, {}}, hi{up, f.level + 1, 0, {}, {}};
        for (int k = 0; k < kPacketLanes; ++k) {
            if (!(f.mask >> k & 1u)) continue;
            vec2 tl = shared::sylva_ikd_box_interval(org_[k], rcp_[k], par_[k], hdr_.cells, f.node, cw, f.t_in[k], f.t_out[k]);
            vec2 tu = shared::sylva_ikd_box_interval(org_[k], rcp_[k], par_[k], hdr_.cells, up, cw, f.t_in[k], f.t_out[k]);
            if (tl.x <= tl.y) lo.mask |= 1u << k, lo.t_in[k] = tl.x, lo.t_out[k] = tl.y;
            if (up_real && tu.x <= tu.y) hi.mask |= 1u << k, hi.t_in[k] = tu.x, hi.t_out[k] = tu.y;
        }
        bool lower_first = lower_first_[axis] != 0u;
        const Entry& near = lower_first ? lo : hi;
        const Entry& far = lower_first ? hi : lo;
        if (sp_ + 2 > stack_.size()) {  // unreachable: depth <= 48 levels, one far child each
            status_ = SYLVA_ITER_ERROR;
            return;
        }
        if (far.mask) stack_[sp_++] = far;
        if (near.mask) stack_[sp_++] = near;
    }

    shared::Words words_, grid_;
    shared::SylvaIkdHeader hdr_{};
    vec4 isos_;
    std::uint32_t iso_count_;
    std::array<vec3, kPacketLanes> org_{}, rcp_{};
    std::array<glm::u32vec3, kPacketLanes> par_{};
    std::array<float, kPacketLanes> limit_{};
    glm::u32vec3 lower_first_{1u};
    std::array<Entry, 2 * SYLVA_IKD_MAX_LEVELS + 2> stack_{};
    std::size_t sp_ = 0;
    std::uint32_t steps_ = 0, status_ = SYLVA_ITER_RUNNING;
};

}  // namespace sylva::ikd

#endif  // SYLVA_IKD_PACKET_HPP
