// sylva/render/octree_volume.hpp -- direct volume rendering and first-hit isosurfaces over the
// bricked octree on the host, with the shared integrators the shaders run
// (sylva/shared/octree_dvr.h, octree_iso.h), over all cores of an executor, and the cut chosen
// by view for a frame (sylva/octree/cut.hpp).
//
//   octree::Tree t = octree::build(grid, pool);
//   std::vector<std::uint32_t> words = octree::encode(t);
//   Frame f = render_octree_dvr_cpu(OctreeView{words, t.bricks}, p, pool);   // p as for the marcher
//
// With the full-resolution cut (the default max_level) and the builder's default border the
// image equals render_dvr_cpu's over the same grid bit for bit (same lattice, same dt) when both
// read the same border mode: OctreeView::border, like GridWords, defaults to a constant 0 (VTK's
// and NanoVDB's background outside the volume); GridBorder::clamp() repeats the edge voxels
// (sylva/shared/octree_dvr.h: how the bricks serve either).
//
//   std::vector<std::uint32_t> w = words;                        // a view-dependent cut:
//   octree::Cut c = select_octree_cut(w, p, {.lod_pixels = 1.0f, .max_nodes = 1u << 16}, false);
//   octree::apply_cut(w, c);
//   Frame f = render_octree_dvr_cpu(OctreeView{w, t.bricks}, p, pool);
#ifndef SYLVA_RENDER_OCTREE_VOLUME_HPP
#define SYLVA_RENDER_OCTREE_VOLUME_HPP

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/octree/cut.hpp"
#include "sylva/octree/lod_error.hpp"
#include "sylva/render/volume.hpp"
#include "sylva/shared/octree_dvr.h"
#include "sylva/shared/octree_iso.h"

namespace sylva {

/// An encoded bricked octree to render: the index words and the brick buffer
/// (sylva/octree/encode.hpp); the cut's leaves are the nodes at max_level (or the octree's
/// leaves above it; the default: the full-resolution leaves).
struct OctreeView {
    std::span<const std::uint32_t> words;
    std::span<const std::uint32_t> bricks;
    std::uint32_t max_level = 0xFFFFFFFFu;
    /// Visibility feedback (sylva/shared/octree_dvr.h): when not empty (one word per node), the
    /// renderers set word n to 1 for every cut leaf n a ray reached before terminating. The
    /// out-of-core working set reads it (sylva/octree/residency.hpp: Residency::feedback()).
    std::span<std::uint32_t> seen = {};
    /// Octant masks for the frame's transfer function (sylva/octree/octants.hpp: one word per
    /// node); when not empty the DVR skips the octants of leaves the TF leaves empty (the same
    /// image, fewer samples). Empty: every octant of a visible leaf is sampled.
    std::span<const std::uint32_t> octmask = {};
    /// What samples read outside the volume (sylva/render/grid_view.hpp): a constant 0 by
    /// default, as the marcher's GridWords; GridBorder::clamp() repeats the edge voxels.
    GridBorder border = {};
};

/// The TF's opacity prefix counts (sylva/shared/octree_dvr.h): entries + 1 words, word i = the
/// number of entries before entry i with alpha > 0 (the paper's summed table of the opacity,
/// section 4, as counts: only "any opacity at all" matters for skipping).
inline std::vector<std::uint32_t> tf_opacity_prefix(std::span<const std::uint32_t> tf) {
    std::vector<std::uint32_t> sum(tf.size() + 1, 0u);
    for (std::size_t i = 0; i < tf.size(); ++i) sum[i + 1] = sum[i] + ((tf[i] >> 24) != 0u ? 1u : 0u);
    return sum;
}

/// tf_opacity_prefix of p's transfer function: its RGBA8 table's, its float table's (alpha > 0),
/// or for a hook with tf_hook_visible a table of tf_skip_entries(p) entries, entry i visible when
/// the hook may show a density within two entries of it ([(i - 2) / (N - 1), (i + 2) / (N - 1)]:
/// sylva_oct_tf_empty reads one entry of slack on each side of a range, so every density an
/// empty verdict covers lies in some clear entry's interval). A hook without tf_hook_visible,
/// whose zeros the octree cannot know, gets an always-visible table (nothing skipped by the TF).
inline std::vector<std::uint32_t> tf_opacity_prefix(const VolumeRenderParams& p) {
    if (p.tf_kind == TfKind::Rgba8) return tf_opacity_prefix(p.tf);
    const std::uint32_t n = tf_skip_entries(p);
    std::vector<std::uint32_t> sum(std::size_t{n} + 1, 0u);
    for (std::uint32_t i = 0; i < n; ++i) {
        bool visible;
        if (p.tf_kind != TfKind::Hook) {
            visible = p.tf_rgba32f[std::size_t{i} * 4 + 3] > 0.0f;
        } else if (!p.tf_hook_visible) {
            visible = true;
        } else {
            const float step = 1.0f / float(n - 1u);
            visible = p.tf_hook_visible(std::max(0.0f, float(int(i) - 2) * step), std::min(1.0f, float(i + 2u) * step));
        }
        sum[i + 1] = sum[i] + (visible ? 1u : 0u);
    }
    return sum;
}

namespace detail {

/// The octree's header, checked; throws sylva::Error naming the problem.
inline shared::SylvaOctHeader octree_header(const OctreeView& o) {
    if (o.words.size() > 0xFFFFFFFFu || o.bricks.size() > 0xFFFFFFFFu)
        throw Error("render: octree buffers over 2^32 words");
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(shared::Words{o.words.data(), o.words.size()},
                                                             std::uint32_t(o.words.size()), std::uint32_t(o.bricks.size()));
    if (h.valid == 0u) throw Error("render: not a valid encoded octree (header, sizes or brick buffer)");
    return h;
}

/// The parameter block for an octree of header h read with border mode `border` (words 38-39;
/// the grid format and value-range words 40-42 keep their defaults: the bricks' format is the
/// octree header's, sylva/shared/octree_layout.h).
inline std::vector<std::uint32_t> pack_octree(const shared::SylvaOctHeader& h, GridBorder border, const VolumeRenderParams& p) {
    border.check();
    std::vector<std::uint32_t> w = pack_dvr(h.dims, h.spacing, p);
    GridSampling{.border = border}.pack(w);
    return w;
}

}  // namespace detail

/// Packs and checks the DVR parameters for the octree's volume (the marcher's, so the lattice
/// and dt are the same as the marcher's over the same grid).
inline std::vector<std::uint32_t> octree_dvr_params(const OctreeView& o, const VolumeRenderParams& p) {
    return detail::pack_octree(detail::octree_header(o), o.border, p);
}

/// Renders the octree with the shared integrator (p.mode is ignored); steps = lattice samples
/// taken, 0xFFFFFFFF where the index was found corrupt.
template <Executor X>
Frame render_octree_dvr_cpu(const OctreeView& o, const VolumeRenderParams& p, X& exec) {
    std::vector<std::uint32_t> params = octree_dvr_params(o, p);
    std::vector<std::uint32_t> tfsum = tf_opacity_prefix(p);
    TfWords tfw = tf_words(p);
    shared::Words pw{params.data(), params.size()}, ow{o.words.data(), o.words.size()},
        bw{o.bricks.data(), o.bricks.size()}, tw = tfw.view(), sw{tfsum.data(), tfsum.size()};
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
    shared::SylvaOctHeader h = detail::octree_header(o);
    shared::SeenWords seen{o.seen.data(), o.seen.size()};
    if (!o.octmask.empty() && o.octmask.size() != h.node_count)
        throw Error("render: " + std::to_string(o.octmask.size()) + " octant masks for " + std::to_string(h.node_count) +
                    " octree nodes");
    shared::Words mw{o.octmask.data(), o.octmask.size()};
    const std::uint32_t use_mask = o.octmask.empty() ? 0u : 1u;
    return detail::render_pixels(p, exec, [&](vec3 org, vec3 dir, std::uint32_t& steps) {
        std::uint32_t visits, status;
        vec4 c = shared::sylva_oct_dvr_ray_masked(ow, bw, tw, sw, mw, use_mask, sp, h, o.max_level, org, dir, 0.0f,
                                                  shared::sylva_inf(), seen, steps, visits, status);
        if (status == SYLVA_ITER_ERROR) steps = 0xFFFFFFFFu;
        return c;
    });
}

/// Renders the first hit of p.iso through the octree (sylva/shared/octree_iso.h; p.mode and
/// p.shading are ignored: the surface is always shaded, opaque, in the TF's colour at p.iso);
/// steps = lattice samples taken, 0xFFFFFFFF where the index was found corrupt.
template <Executor X>
Frame render_octree_iso_cpu(const OctreeView& o, const VolumeRenderParams& p, X& exec) {
    std::vector<std::uint32_t> params = octree_dvr_params(o, p);
    TfWords tfw = tf_words(p);
    shared::Words pw{params.data(), params.size()}, ow{o.words.data(), o.words.size()},
        bw{o.bricks.data(), o.bricks.size()}, tw = tfw.view();
    shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
    shared::SylvaOctHeader h = detail::octree_header(o);
    shared::SeenWords seen{o.seen.data(), o.seen.size()};
    return detail::render_pixels(p, exec, [&](vec3 org, vec3 dir, std::uint32_t& steps) {
        std::uint32_t visits, status;
        vec4 c = shared::sylva_oct_iso_ray_seen(ow, bw, tw, sp, h, o.max_level, org, dir, 0.0f, shared::sylva_inf(), seen,
                                                steps, visits, status);
        if (status == SYLVA_ITER_ERROR) steps = 0xFFFFFFFFu;
        return c;
    });
}

/// The nodes a frame of p cannot see anything in, never refined (section 4: empty nodes are
/// terminal): for DVR (`iso` false) those whose densities (sylva_oct_sampled_range: [min, max],
/// and on a face of the volume the constant border's value) the TF maps to zero opacity, for
/// isosurfaces those whose greatest density stays below p.iso. Keeps a view of `words` (the
/// index, checked by the caller: select_octree_cut reads its header).
struct OctreeTerminal {
    std::span<const std::uint32_t> words;
    std::vector<std::uint32_t> tfsum;
    shared::SylvaDvrParams border;  ///< only the border words (38, 39) are set
    shared::SylvaOctHeader header;
    std::uint32_t entries = 0;
    float iso_value = 0.0f;
    bool iso = false;
    OctreeTerminal(std::span<const std::uint32_t> w, const VolumeRenderParams& p, bool iso_mode, GridBorder b = {})
        : words(w), tfsum(tf_opacity_prefix(p)), border(border_params(b)),
          header(shared::sylva_oct_decode_header(shared::Words{w.data(), w.size()})), entries(tf_skip_entries(p)),
          iso_value(p.iso), iso(iso_mode) {}
    bool operator()(std::uint32_t n) const {
        shared::Words ow{words.data(), words.size()};
        vec2 r = shared::sylva_oct_sampled_range(ow, header, border, n, shared::sylva_oct_level(shared::sylva_oct_flags(ow, n)),
                                                 shared::sylva_oct_coord(ow, n));
        if (iso) return r.y < iso_value;
        return shared::sylva_oct_tf_empty(shared::Words{tfsum.data(), tfsum.size()}, entries, r.x, r.y);
    }

private:
    static shared::SylvaDvrParams border_params(GridBorder b) {
        b.check();
        std::vector<std::uint32_t> w(SYLVA_DVR_PARAM_WORDS, 0u);
        GridSampling{.border = b}.pack(w);
        return shared::sylva_dvr_params(shared::Words{w.data(), w.size()});
    }
};

/// octree::lod_tf_errors for p's transfer function: its classification (sylva_tf_classify, any
/// kind) at 1,024 evenly spaced densities, colour premultiplied by opacity.
inline std::vector<float> octree_tf_errors(const octree::LodDeviation& deviation, const VolumeRenderParams& p) {
    TfWords tfw = tf_words(p);
    shared::Words tw = tfw.view();
    const std::uint32_t kind = static_cast<std::uint32_t>(p.tf_kind), entries = tf_entries(p);
    std::vector<vec4> table(1024);
    for (std::size_t i = 0; i < table.size(); ++i) {
        vec4 c = shared::sylva_tf_classify(tw, kind, entries, float(i) / float(table.size() - 1));
        table[i] = vec4(vec3(c) * c.w, c.w);
    }
    return octree::lod_tf_errors(deviation, table);
}

/// The cut's view of a frame of p: its camera, pinhole or orthographic (p.rays.source; the
/// caller's rays are taken as seen from p.camera's pinhole).
inline octree::CutView octree_cut_view(const VolumeRenderParams& p) {
    return octree::cut_view(p.camera, p.width, p.height, p.rays.source == RaySource::Ortho);
}

/// The cut for a frame of p (octree_cut_view) under cfg, OctreeTerminal's nodes terminal (for
/// the border mode the frame is rendered with); with `deviation` (octree::lod_deviation of the
/// same octree) and for DVR, nodes whose coarse samples misrepresent their voxels under p's TF
/// by more than cfg.max_tf_error are refined too (octree_tf_errors).
inline octree::Cut select_octree_cut(std::span<const std::uint32_t> words, const VolumeRenderParams& p,
                                     const octree::CutConfig& cfg, bool iso, GridBorder border = {},
                                     const octree::LodDeviation* deviation = nullptr) {
    OctreeTerminal terminal(words, p, iso, border);
    std::vector<float> errors;
    if (deviation != nullptr && !iso) errors = octree_tf_errors(*deviation, p);
    return octree::select_cut(words, octree_cut_view(p), cfg, terminal, errors);
}

}  // namespace sylva

#endif  // SYLVA_RENDER_OCTREE_VOLUME_HPP
