// sylva/bih/lod.hpp -- static levels of detail of a full BIH over density elements (voxel
// cuboids or any bih::DensityElement: RBFs, particles with a density; Kinkelin section 5.2,
// Table 3's "default LoD"), their 8-byte-node encoding (Table 1, section 5.4) and a per-node
// min/max density word for iso-value culling (section 4.1).
//
// extract_lod walks the full BIH top-down. A node becomes an LoD leaf when it is a leaf of the
// full tree, when it sits at LodConfig::max_depth, or when its element density
// sum(V_element) / V_box is >= min_element_density and the standard deviation of its elements'
// normalised density is <= max_std_dev. The leaf then holds one merged VoxelCuboid (whatever the
// full tree's element type: the merged representation of a node): the node's
// enclosing box, the mean density and the mean gradient; its subtrees are discarded. Every
// other node keeps its planes and children, so LoD boxes are exactly full-tree node boxes.
#ifndef SYLVA_BIH_LOD_HPP
#define SYLVA_BIH_LOD_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include "sylva/bih/encode.hpp"
#include "sylva/bih/stats.hpp"
#include "sylva/bih/tree.hpp"
#include "sylva/bih/validate.hpp"
#include "sylva/core/error.hpp"
#include "sylva/elements/voxel.hpp"
#include "sylva/shared/bih_iter.h"
#include "sylva/shared/voxel.h"

namespace sylva::bih {

/// LoD leaf criteria and encoding. The defaults are Kinkelin's default LoD (section 5.2 and the
/// caption of Table 3): element density >= 75 %, standard deviation <= 1 %, chunk depth 2.
struct LodConfig {
    /// Nodes at this depth (root = 0) become leaves whatever they hold (section 5.2, "maximum
    /// depth in the tree"); the default SYLVA_BIH_DEPTH_CAP keeps the full tree's depth.
    std::uint32_t max_depth = SYLVA_BIH_DEPTH_CAP;
    /// Smallest element density sum(V_element) / V_box of a merged leaf (Table 3: 0.75).
    float min_element_density = 0.75f;
    /// Largest standard deviation of the normalised density in a merged leaf (Table 3: 0.01).
    float max_std_dev = 0.01f;
    /// Tree-chunk depth of the encoding (Table 3 and section 5.4: 2; at most 15).
    std::uint32_t chunk_depth = 2;
};

/// Throws sylva::Error when a criterion is NaN or negative or the chunk depth is over 15.
inline void check(const LodConfig& c) {
    if (std::isnan(c.min_element_density) || c.min_element_density < 0.0f)
        throw Error("bih::LodConfig: min_element_density " + std::to_string(c.min_element_density) +
                    " is NaN or negative");
    if (std::isnan(c.max_std_dev) || c.max_std_dev < 0.0f)
        throw Error("bih::LodConfig: max_std_dev " + std::to_string(c.max_std_dev) + " is NaN or negative");
    if (c.chunk_depth > 15)
        throw Error("bih::LodConfig: chunk_depth " + std::to_string(c.chunk_depth) + " is over 15");
}

/// The merge criteria of section 5.2 (without the depth limit): dense and uniform enough.
inline bool meets_merge_criteria(const NodeStats& s, const LodConfig& c) {
    return s.element_density >= c.min_element_density && s.std_dev() <= double(c.max_std_dev);
}

/// A static level of detail: `tree` is a BIH whose leaf i holds exactly `leaves[i]` (first = i,
/// count = 1, `order` the identity), over the full tree's root box. Encode it with encode_lod.
struct Lod {
    Tree tree;
    std::vector<VoxelCuboid> leaves;
    std::vector<std::uint32_t> source;  ///< the full-tree node each LoD node came from
    BuildStats stats;                   ///< nodes, leaves, single-child nodes, max depth of the LoD
    vec3 voxel_size{1.0f};              ///< world size of one voxel: the unit of the gradients
    double extract_ms = 0.0;

    /// Size of the 8-byte-node encoding without its header (Table 3's "Size in KBytes").
    [[nodiscard]] std::size_t node_bytes() const { return tree.nodes.size() * 8u; }
};

namespace detail {

/// One step of the top-down LoD walk: a full-tree node and where its LoD copy hangs.
struct LodItem {
    std::uint32_t full;
    std::uint32_t parent;  ///< LoD index of the parent, kNoChild for the root
    int slot;              ///< child slot in the parent
    std::uint32_t depth;
};

/// Emits the LoD copy of `it`; pushes its children when it stays an inner node.
inline void lod_visit(const FullBih& f, const LodConfig& cfg, const LodItem& it, Lod& lod,
                      std::vector<LodItem>& stack) {
    std::uint32_t self = static_cast<std::uint32_t>(lod.tree.nodes.size());
    lod.tree.nodes.emplace_back();
    lod.source.push_back(it.full);
    if (it.parent != kNoChild) lod.tree.nodes[it.parent].child[it.slot] = self;
    const Node& n = f.tree.nodes[it.full];
    const NodeStats& s = f.stats[it.full];
    Node& out = lod.tree.nodes[self];
    if (n.leaf() || it.depth >= cfg.max_depth || meets_merge_criteria(s, cfg)) {
        out.first = static_cast<std::uint32_t>(lod.leaves.size());
        out.count = 1;
        lod.leaves.push_back(VoxelCuboid{f.boxes[it.full], float(s.mean), s.mean_gradient});
        return;
    }
    out.make_inner(n.axis);  // children linked as they are emitted
    out.single = n.single;
    out.plane[0] = n.plane[0];
    out.plane[1] = n.plane[1];
    for (int c = 1; c >= 0; --c)  // left child popped first: the LoD is stored in pre-order
        if (has_child(n, c)) stack.push_back({n.child[c], self, c, it.depth + 1});
}

}  // namespace detail

/// Extracts a static LoD from a full BIH (see the top of this header). Throws sylva::Error for
/// a bad LodConfig or a FullBih whose stats/boxes do not match its tree.
inline Lod extract_lod(const FullBih& full, const LodConfig& config = {}) {
    auto start = std::chrono::steady_clock::now();
    check(config);
    std::size_t n = full.tree.nodes.size();
    if (n == 0 || full.stats.size() != n || full.boxes.size() != n)
        throw Error("bih::extract_lod: full BIH with " + std::to_string(n) + " nodes, " +
                    std::to_string(full.stats.size()) + " stats and " + std::to_string(full.boxes.size()) + " boxes");
    LodConfig cfg = config;
    cfg.max_depth = std::min<std::uint32_t>(cfg.max_depth, SYLVA_BIH_DEPTH_CAP);
    Lod lod;
    lod.voxel_size = full.voxel_size;
    lod.tree.bounds = full.tree.bounds;
    std::vector<detail::LodItem> stack{{0u, kNoChild, 0, 0u}};
    while (!stack.empty()) {
        detail::LodItem it = stack.back();
        stack.pop_back();
        if (it.full >= n || lod.tree.nodes.size() >= n)
            throw Error("bih::extract_lod: the full tree's links are corrupted");
        detail::lod_visit(full, cfg, it, lod, stack);
    }
    lod.tree.order.resize(lod.leaves.size());
    std::iota(lod.tree.order.begin(), lod.tree.order.end(), 0u);
    detail::measure(lod.tree);  // the builder's statistics: LoD children follow their parent too
    lod.tree.stats.elements = lod.leaves.size();
    lod.extract_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    lod.tree.stats.build_ms = lod.extract_ms;
    lod.stats = lod.tree.stats;
    return lod;
}

/// The LoD as 8-byte nodes (16-bit planes, voxel payloads, tree chunks of config.chunk_depth):
/// bih::encode(lod.tree, lod.leaves, VoxelPayload{}, {Fixed16, TreeChunks, chunk_depth}).
inline std::vector<std::uint32_t> encode_lod(const Lod& lod, const LodConfig& config = {}) {
    check(config);
    EncodeConfig ec{NodeFormat::Fixed16, Layout::TreeChunks, config.chunk_depth};
    return encode(lod.tree, std::span<const VoxelCuboid>(lod.leaves), VoxelPayload{}, ec);
}

namespace detail {

/// Conservative unorm16 of a density bound: `upper` rounds up, else down; clamped to [0, 1].
/// NaN (0 * inf: a flat leaf box with an infinite side) gives the widest bound, never culled.
inline std::uint32_t unorm16_bound(double v, bool upper) {
    if (std::isnan(v)) return upper ? 65535u : 0u;
    double q = upper ? std::ceil((v + 1e-6) * 65535.0) : std::floor((v - 1e-6) * 65535.0);
    return static_cast<std::uint32_t>(std::clamp(q, 0.0, 65535.0));
}

/// Reconstructed density range of encoded leaf `i` over its decoded world box [lo, hi].
inline vec2 decoded_leaf_range(const shared::Words& buf, const shared::SylvaBihHeader& h, std::uint32_t i, vec3 lo,
                               vec3 hi, vec3 voxel_size) {
    shared::SylvaVoxel v = shared::sylva_voxel_unpack(shared::sylva_bih_payload(buf, h, i));
    return reconstructed_range(v.density, v.gradient, Aabb{lo, hi}, voxel_size);
}

/// The encoded nodes in breadth-first order with their parents and decoded traversal-space
/// boxes (the boxes the shared iterator reports). The encoding must have passed validate().
struct DecodedBoxes {
    std::vector<std::uint32_t> order;
    std::vector<std::uint32_t> parent;
    std::vector<vec3> lo;
    std::vector<vec3> hi;
};

inline DecodedBoxes decode_boxes(const shared::Words& buf, const shared::SylvaBihHeader& h) {
    using namespace sylva::shared;
    DecodedBoxes d{{0u}, std::vector<std::uint32_t>(h.node_count, SYLVA_NO_NODE), std::vector<vec3>(h.node_count),
                   std::vector<vec3>(h.node_count)};
    bool fixed16 = (h.flags & SYLVA_BIH_FLAG_FLOAT_NODES) == 0u;
    d.lo[0] = fixed16 ? vec3(0.0f) : h.root_lo;
    d.hi[0] = fixed16 ? vec3(1.0f) : h.root_hi;
    for (std::size_t k = 0; k < d.order.size(); ++k) {
        std::uint32_t i = d.order[k];
        uint meta = sylva_bih_meta(buf, h, i);
        uint axis = sylva_bih_meta_type(meta);
        if (axis == SYLVA_BIH_LEAF) continue;
        vec2 planes = sylva_bih_planes(buf, h, i);
        auto add = [&](std::uint32_t kid, vec3 lo, vec3 hi) {
            d.lo[kid] = lo;
            d.hi[kid] = hi;
            d.parent[kid] = i;
            d.order.push_back(kid);
        };
        if (sylva_bih_meta_single(meta)) {  // single child within [A, B]
            uint kid = sylva_bih_first_child((h.flags & SYLVA_BIH_FLAG_CHUNKED) != 0u, i, meta);
            add(kid, sylva_with(d.lo[i], axis, planes.x), sylva_with(d.hi[i], axis, planes.y));
            continue;
        }
        uvec2 kids = sylva_bih_children(h, i, meta, planes);
        if (kids.x != SYLVA_NO_NODE) add(kids.x, d.lo[i], sylva_with(d.hi[i], axis, planes.x));
        if (kids.y != SYLVA_NO_NODE) add(kids.y, sylva_with(d.lo[i], axis, planes.y), d.hi[i]);
    }
    return d;
}

}  // namespace detail

/// Node-range words for iso-value culling (Kinkelin section 4.1), one per ENCODED node, at the
/// node's position in `words` (the node index the shared iterator reports):
///   bits  0-15  min density, unorm16 (q / 65535), rounded down
///   bits 16-31  max density, unorm16 (q / 65535), rounded up
/// The range bounds the density a renderer reconstructs in every leaf of the node's subtree:
/// d + g . ((x - c) / voxel_size) for x in the leaf's DECODED box (quantised planes, centre c),
/// with the decoded (quantised) density and gradient, clamped to [0, 1] and widened by 1e-6.
/// An iso-value outside [min, max] of a node is not crossed inside its subtree's leaves.
/// Throws sylva::Error when `words` is not a valid voxel-payload BIH encoding.
inline std::vector<std::uint32_t> encode_node_ranges(std::span<const std::uint32_t> words, vec3 voxel_size) {
    using namespace sylva::shared;
    validate(words);
    Words buf{words.data(), words.size()};
    SylvaBihHeader h = sylva_bih_read_header(buf, static_cast<uint>(std::min<std::size_t>(words.size(), 0xFFFFFFFFu)));
    if (((h.flags >> 8) & 255u) != SYLVA_PAYLOAD_VOXEL)
        throw Error("bih::encode_node_ranges: the encoding's payloads are not voxels");
    detail::DecodedBoxes d = detail::decode_boxes(buf, h);
    std::vector<vec2> range(h.node_count, vec2(sylva_inf(), -sylva_inf()));
    for (auto it = d.order.rbegin(); it != d.order.rend(); ++it) {  // children before parents
        std::uint32_t i = *it;
        if (sylva_bih_meta_type(sylva_bih_meta(buf, h, i)) == SYLVA_BIH_LEAF)
            range[i] = detail::decoded_leaf_range(buf, h, i, sylva_bih_to_world(h, d.lo[i]),
                                                  sylva_bih_to_world(h, d.hi[i]), voxel_size);
        if (std::uint32_t p = d.parent[i]; p != SYLVA_NO_NODE)
            range[p] = vec2(std::min(range[p].x, range[i].x), std::max(range[p].y, range[i].y));
    }
    std::vector<std::uint32_t> out(h.node_count, 0u);
    for (std::uint32_t i : d.order)
        out[i] = detail::unorm16_bound(range[i].x, false) | (detail::unorm16_bound(range[i].y, true) << 16);
    return out;
}

/// Node-range words of the LoD's encoding with `config` (see the overload above).
inline std::vector<std::uint32_t> encode_node_ranges(const Lod& lod, const LodConfig& config = {}) {
    std::vector<std::uint32_t> words = encode_lod(lod, config);
    return encode_node_ranges(std::span<const std::uint32_t>(words), lod.voxel_size);
}

}  // namespace sylva::bih

#endif  // SYLVA_BIH_LOD_HPP
