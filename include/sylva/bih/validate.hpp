// sylva/bih/validate.hpp -- checks an untrusted encoded BIH (from disk, from a user) with the
// shared decoder before anything traverses it.
#ifndef SYLVA_BIH_VALIDATE_HPP
#define SYLVA_BIH_VALIDATE_HPP

#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/bih/payload.hpp"
#include "sylva/core/error.hpp"
#include "sylva/shared/bih_iter.h"

namespace sylva::bih {

/// Throws sylva::Error naming the first problem: not a BIH, a node count or depth that the
/// buffer or the stack cannot hold, a child index out of range, a node reached twice (a cycle
/// or shared subtree), a tree deeper than its header says, a root box or traversal space that
/// is not finite (or a root box with lo > hi), a NaN plane, or (range payloads) a
/// leaf range outside `element_count` when that is non-zero.
inline void validate(std::span<const std::uint32_t> words, std::uint64_t element_count = 0) {
    using namespace sylva::shared;
    Words buf{words.data(), words.size()};
    if (words.size() < SYLVA_BIH_HEADER_WORDS) throw Error("bih::validate: buffer shorter than the 20-word header");
    if (words[0] != SYLVA_BIH_MAGIC) throw Error("bih::validate: bad magic (not an encoded BIH)");
    if (words[1] != SYLVA_BIH_VERSION) throw Error("bih::validate: unsupported version " + std::to_string(words[1]));
    SylvaBihHeader h = sylva_bih_read_header(buf, static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)));
    if (h.valid == 0u)
        throw Error("bih::validate: header inconsistent (node count " + std::to_string(h.node_count) +
                    ", depth " + std::to_string(h.max_depth) + ", " + std::to_string(words.size()) + " words)");
    // The encoder writes the builder's root box (finite, lo <= hi: it refuses anything else) and
    // the fixed16 traversal space from it; NaN or infinite words there would turn every decoded
    // leaf box (sylva_bih_to_world) into NaN.
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(h.root_lo[a]) || !std::isfinite(h.root_hi[a]) || !(h.root_lo[a] <= h.root_hi[a]) ||
            !std::isfinite(h.space_origin[a]) || !std::isfinite(h.space_scale[a]))
            throw Error("bih::validate: root box or traversal space is not finite and ordered on axis " + std::to_string(a));
    std::uint32_t kind = (h.flags >> 8) & 255u;
    std::vector<std::uint8_t> seen(h.node_count, 0);
    struct Item { std::uint32_t node, depth; };
    std::vector<Item> stack{{0u, 0u}};
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        std::string where = "node " + std::to_string(it.node);
        if (it.node >= h.node_count) throw Error("bih::validate: child index out of range at " + where);
        if (seen[it.node]) throw Error("bih::validate: " + where + " is reached twice (corrupted links)");
        seen[it.node] = 1;
        if (it.depth > h.max_depth) throw Error("bih::validate: " + where + " is deeper than the header's max depth");
        uint meta = sylva_bih_meta(buf, h, it.node);
        if (sylva_bih_meta_type(meta) == SYLVA_BIH_LEAF) {
            auto [first, count] = decode_range(std::uint64_t{sylva_bih_payload(buf, h, it.node).x} |
                                               (std::uint64_t{sylva_bih_payload(buf, h, it.node).y} << 32));
            if (kind == SYLVA_PAYLOAD_RANGE && element_count && std::uint64_t{first} + count > element_count)
                throw Error("bih::validate: leaf " + where + " refers to elements beyond " + std::to_string(element_count));
            continue;
        }
        vec2 planes = sylva_bih_planes(buf, h, it.node);
        if (std::isnan(planes.x) || std::isnan(planes.y)) throw Error("bih::validate: NaN plane at " + where);
        if (sylva_bih_meta_single(meta)) {
            uint child = sylva_bih_first_child((h.flags & SYLVA_BIH_FLAG_CHUNKED) != 0u, it.node, meta);
            stack.push_back({child, it.depth + 1});
            continue;
        }
        uvec2 kids = sylva_bih_children(h, it.node, meta, planes);
        if (kids.x == SYLVA_NO_NODE && kids.y == SYLVA_NO_NODE)
            throw Error("bih::validate: inner " + where + " has no children");
        if (kids.x != SYLVA_NO_NODE) stack.push_back({kids.x, it.depth + 1});
        if (kids.y != SYLVA_NO_NODE) stack.push_back({kids.y, it.depth + 1});
    }
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_VALIDATE_HPP
