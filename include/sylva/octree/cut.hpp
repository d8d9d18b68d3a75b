// sylva/octree/cut.hpp -- the view-dependent working set (cut) of the bricked octree (Gobbetti,
// Marton, Iglesias Guitian, section 5: "refine while a node's voxels project larger than a
// pixel", "a priority ... the projected size", a budget on the nodes held), and its encoding in
// the index's flag words so that the shared walk (sylva/shared/octree_iter.h) and the
// integrators on it, host and GLSL, descend only to the cut's leaves.
//
//   octree::CutView v = octree::cut_view(camera_frame, width, height);
//   octree::Cut c = octree::select_cut(words, v, {.lod_pixels = 1.0f, .max_nodes = 4096},
//                                      [&](std::uint32_t n) { return false; });  // nothing terminal
//   octree::apply_cut(words, c);   // bits 18-19 of each record's word +1 (octree_layout.h)
//
// Selection: the root is in the working set; the node whose voxels (world size = the largest
// spacing * 2^(L - 1 - level)) project largest, seen from the eye at the nearest point of the
// node's box, is refined first (its existing children join the set) while that projection
// exceeds lod_pixels (an orthographic view: voxel size / pixel size, the same at any distance)
// and the set stays within max_nodes (inner nodes count: the paper's budget
// is the nodes whose bricks are held). Octree leaves and nodes the caller calls terminal (empty
// under the TF, or an isovalue outside [min, max]) are never refined. A node whose box holds the
// eye projects infinitely large. Refinement stops at the first node that does not fit the
// budget: the set never exceeds it and what is refined is always the largest projections.
// Given per-node transfer-function errors (octree/lod_error.hpp; not in the paper), nodes whose
// projection is at most lod_pixels are refined too while their error exceeds max_tf_error, in
// the same order and within the same budget.
#ifndef SYLVA_OCTREE_CUT_HPP
#define SYLVA_OCTREE_CUT_HPP

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/shared/octree_layout.h"

namespace sylva::octree {

/// Budgets of the cut (section 5).
struct CutConfig {
    /// Refine while a node's voxel projects larger than this many pixels (the paper: 1). > 0.
    float lod_pixels = 1.0f;
    /// Nodes in the working set (inner nodes and cut leaves), >= 1.
    std::uint32_t max_nodes = 1u << 20;
    /// With per-node transfer-function errors (select_cut's `tf_error`, octree/lod_error.hpp),
    /// a node whose voxels project under lod_pixels is refined still while its bound exceeds
    /// this (premultiplied RGBA of the TF, 0..1; 1 never refines: the projection alone). Not in
    /// the paper, whose criterion is the projection alone (26.6 dB against the marcher on the
    /// aneurism at 128^2); 1/64 keeps the four data sets of sylva-octree-bench at >= 47 dB there
    /// (1/32: 40.2-41.5 dB on the bonsai and engine; README, "Bricked octree").
    float max_tf_error = 1.0f / 64.0f;
};

/// What the cut depends on in the view: the eye (world space) and the angle one pixel subtends
/// (pinhole), or the world size of a pixel (orthographic: every voxel of a level projects alike,
/// wherever it is).
struct CutView {
    vec3 eye{0.0f};
    float pixel_angle = 1.0f;   ///< pinhole: tangent of one pixel's angle at the image centre (vertical);
                                ///< orthographic: a pixel's height in world units
    bool orthographic = false;  ///< the camera of RaySource::Ortho (sylva/shared/camera.h)
};

/// The cut's view of a camera frame rendered at width x height: a pinhole frame's v is half the
/// image height at distance 1 (a pixel is 2 |v| / height of the distance), an orthographic
/// frame's v is half the view rectangle's height in world units (a pixel is 2 |v| / height).
inline CutView cut_view(const CameraFrame& cam, std::uint32_t /*width*/, std::uint32_t height, bool orthographic = false) {
    return {cam.eye, 2.0f * glm::length(cam.v) / static_cast<float>(std::max(height, 1u)), orthographic};
}

/// Per node: where it stands in the cut.
enum class CutState : std::uint8_t { Inner = 0, Leaf = 1, Below = 2 };

/// A selected cut.
struct Cut {
    std::vector<CutState> state;  ///< per node
    std::uint32_t nodes = 0;      ///< working set: inner nodes + leaves
    std::uint32_t leaves = 0;     ///< cut leaves
    std::uint32_t deepest = 0;    ///< deepest level of a cut leaf
};

namespace detail {

/// Projected size in pixels of one voxel of node n (level, coordinates) seen from the view.
inline float projected_voxel(const shared::SylvaOctHeader& h, std::uint32_t level, glm::u32vec3 c, const CutView& v) {
    vec3 lo, hi;
    shared::sylva_oct_box(h, level, c, lo, hi);
    vec3 wlo = h.origin + lo * h.spacing, whi = h.origin + hi * h.spacing;
    vec3 q = glm::clamp(v.eye, wlo, whi);
    float dist = glm::length(v.eye - q);
    float voxel = std::max(h.spacing.x, std::max(h.spacing.y, h.spacing.z)) * float(1u << (h.levels - 1u - level));
    if (v.orthographic) return voxel / v.pixel_angle;
    if (!(dist > 0.0f)) return std::numeric_limits<float>::infinity();
    return voxel / (dist * v.pixel_angle);
}

}  // namespace detail

/// Selects the cut of the encoded index `words` for view v under cfg; `terminal(n)` true keeps
/// node n a leaf of the cut (empty nodes). With `tf_error` (one bound a node, octree::
/// lod_tf_errors), nodes projecting under cfg.lod_pixels are refined too while their bound
/// exceeds cfg.max_tf_error, largest projections first, within the same budget. Throws
/// sylva::Error on an invalid header or budgets, or a `tf_error` of another node count.
template <class Terminal>
Cut select_cut(std::span<const std::uint32_t> words, const CutView& v, const CutConfig& cfg, Terminal&& terminal,
               std::span<const float> tf_error = {}) {
    using namespace sylva::shared;
    if (!(cfg.lod_pixels > 0.0f) || !std::isfinite(cfg.lod_pixels)) throw Error("octree cut: lod_pixels must be > 0");
    if (!(cfg.max_tf_error >= 0.0f)) throw Error("octree cut: max_tf_error must be >= 0");
    if (cfg.max_nodes < 1u) throw Error("octree cut: the node budget must be >= 1");
    if (!(v.pixel_angle > 0.0f) || !std::isfinite(v.pixel_angle)) throw Error("octree cut: the pixel angle must be > 0");
    Words buf{words.data(), words.size()};
    if (words.size() < SYLVA_OCT_HEADER_WORDS || words.size() > 0xFFFFFFFFu) throw Error("octree cut: not a valid encoded octree");
    // The brick buffer is not needed here: check the header against the size it declares.
    std::uint64_t brick_words = std::uint64_t{words[7]} * words[8];
    if (brick_words > 0xFFFFFFFFu) throw Error("octree cut: not a valid encoded octree (brick buffer over 2^32 words)");
    SylvaOctHeader h = sylva_oct_read_header(buf, static_cast<std::uint32_t>(words.size()), static_cast<std::uint32_t>(brick_words));
    if (h.valid == 0u) throw Error("octree cut: not a valid encoded octree");
    if (!tf_error.empty() && tf_error.size() != h.node_count)
        throw Error("octree cut: " + std::to_string(tf_error.size()) + " transfer-function errors for " +
                    std::to_string(h.node_count) + " nodes");
    Cut cut;
    cut.state.assign(h.node_count, CutState::Below);
    using Item = std::pair<float, std::uint32_t>;
    std::priority_queue<Item> open;
    auto add = [&](std::uint32_t n) {
        std::uint32_t f = sylva_oct_flags(buf, n);
        cut.state[n] = CutState::Leaf;
        cut.nodes += 1;
        open.emplace(detail::projected_voxel(h, sylva_oct_level(f), sylva_oct_coord(buf, n), v), n);
    };
    add(0u);
    while (!open.empty()) {
        auto [size, n] = open.top();
        const bool by_size = size > cfg.lod_pixels;
        if (!by_size && tf_error.empty()) break;
        open.pop();
        if (!by_size && !(tf_error[n] > cfg.max_tf_error)) continue;  // small and faithful: stays a leaf
        std::uint32_t f = sylva_oct_flags(buf, n), mask = sylva_oct_child_mask(f);
        if (mask == 0u || terminal(n)) continue;  // stays a leaf of the cut
        std::uint32_t kids = static_cast<std::uint32_t>(std::popcount(mask));
        if (std::uint64_t{cut.nodes} + kids > cfg.max_nodes) break;  // the budget
        cut.state[n] = CutState::Inner;
        std::uint32_t first = sylva_oct_first_child(buf, n);
        for (std::uint32_t k = 0; k < kids; ++k) add(first + k);
    }
    for (std::uint32_t n = 0; n < h.node_count; ++n)
        if (cut.state[n] == CutState::Leaf) {
            cut.leaves += 1;
            cut.deepest = std::max(cut.deepest, sylva_oct_level(sylva_oct_flags(buf, n)));
        }
    return cut;
}

/// Writes cut c into the index (bits 18-19 of each record's word +1; octree_layout.h):
/// SYLVA_OCT_CUT_LEAF on its leaves, SYLVA_OCT_CUT_BELOW below them, neither inside.
inline void apply_cut(std::span<std::uint32_t> words, const Cut& c) {
    for (std::size_t n = 0; n < c.state.size(); ++n) {
        std::size_t at = SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n + 1;
        if (at >= words.size()) throw Error("octree cut: the cut has more nodes than the index");
        std::uint32_t f = words[at] & ~(SYLVA_OCT_CUT_LEAF | SYLVA_OCT_CUT_BELOW);
        if (c.state[n] == CutState::Leaf) f |= SYLVA_OCT_CUT_LEAF;
        if (c.state[n] == CutState::Below) f |= SYLVA_OCT_CUT_BELOW;
        words[at] = f;
    }
}

/// Removes any cut from the index: the full-resolution cut.
inline void clear_cut(std::span<std::uint32_t> words) {
    for (std::size_t at = SYLVA_OCT_HEADER_WORDS + 1; at < words.size(); at += SYLVA_OCT_NODE_WORDS)
        words[at] &= ~(SYLVA_OCT_CUT_LEAF | SYLVA_OCT_CUT_BELOW);
}

}  // namespace sylva::octree

#endif  // SYLVA_OCTREE_CUT_HPP
