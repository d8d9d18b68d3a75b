// sylva/vulkan/octree_volume.hpp -- DVR and first-hit isosurfaces over the bricked octree as a
// compute shader (shaders/octree_dvr.comp, embedded SPIR-V running sylva/shared/octree_dvr.h and
// octree_iso.h): same parameters and Frame as render_octree_dvr_cpu / render_octree_iso_cpu
// (sylva/render/octree_volume.hpp). A view-dependent cut travels in the index words
// (sylva/octree/cut.hpp): upload the words with the cut applied, or set_index() a new cut.
//
//   auto ctx = sylva::vk::Context::create();
//   sylva::vk::DeviceOctree oct(ctx, sylva::OctreeView{words, tree.bricks});
//   sylva::Frame img = sylva::vk::render_octree_dvr_vulkan(ctx, oct, params);
#ifndef SYLVA_VULKAN_OCTREE_VOLUME_HPP
#define SYLVA_VULKAN_OCTREE_VOLUME_HPP

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

#include "sylva/render/octree_volume.hpp"
#include "sylva/spirv/octree_dvr.h"
#include "sylva/vulkan/runner.hpp"
#include "sylva/vulkan/split_words.hpp"
#include "sylva/vulkan/volume.hpp"

namespace sylva::vk {

/// An encoded octree uploaded once: the index in one buffer, the bricks split over four
/// bindings (brick buffers over 128 MiB work).
class DeviceOctree {
public:
    /// Checks the header against the brick buffer (throws sylva::Error naming the problem);
    /// `shift` 0 picks the largest part the device allows, tests force small parts.
    DeviceOctree(Context& ctx, const OctreeView& view, std::uint32_t shift = 0)
        : header_(sylva::detail::octree_header(view)),
          bricks_(split_words(ctx, view.bricks, 4, shift)),
          parts_(used_parts(view.bricks.size(), bricks_.shift)),
          index_(ctx, view.words.size() * 4),
          brick_words_(static_cast<std::uint32_t>(view.bricks.size())),
          max_level_(view.max_level),
          header_words_(view.words.begin(), view.words.begin() + SYLVA_OCT_HEADER_WORDS) {
        index_.upload(view.words);
    }
    [[nodiscard]] const shared::SylvaOctHeader& header() const { return header_; }
    [[nodiscard]] std::uint32_t brick_words() const { return brick_words_; }
    [[nodiscard]] std::uint32_t max_level() const { return max_level_; }
    /// The kernel for this octree's brick split, built on first use and kept.
    Kernel& kernel(Context& ctx) {
        std::array<std::uint32_t, 2> constants{bricks_.shift, parts_};
        if (!kernel_) kernel_.emplace(ctx, spirv::octree_dvr, 9, 12, constants);
        return *kernel_;
    }
    [[nodiscard]] Buffer* brick_part(std::size_t i) { return &bricks_.parts[i]; }
    [[nodiscard]] Buffer* index() { return &index_; }
    /// Replaces the index words by the same octree's words with another cut (same size and
    /// header; throws sylva::Error otherwise).
    void set_index(std::span<const std::uint32_t> words) {
        if (words.size() * 4 != index_.size_bytes() || words.size() < SYLVA_OCT_HEADER_WORDS ||
            !std::equal(words.begin(), words.begin() + SYLVA_OCT_HEADER_WORDS, header_words_.begin()))
            throw Error("vulkan octree: set_index needs the same octree's words (a new cut only)");
        index_.upload(words);
    }

private:
    shared::SylvaOctHeader header_;
    SplitWords bricks_;
    std::uint32_t parts_;
    Buffer index_;
    std::uint32_t brick_words_;
    std::uint32_t max_level_;
    std::vector<std::uint32_t> header_words_;
    std::optional<Kernel> kernel_;
};

namespace detail {

inline Frame render_octree_vulkan(Context& ctx, DeviceOctree& oct, const VolumeRenderParams& p, std::uint32_t mode) {
    std::vector<std::uint32_t> params = sylva::detail::pack_dvr(oct.header().dims, oct.header().spacing, p);
    std::vector<std::uint32_t> tfsum = tf_opacity_prefix(p.tf);
    Buffer tf(ctx, p.tf.size() * 4), sum(ctx, tfsum.size() * 4), pb(ctx, params.size() * 4),
        out(ctx, std::size_t{p.width} * p.height * 5 * 4);
    tf.upload(p.tf);
    sum.upload(tfsum);
    pb.upload(params);
    std::array<Buffer*, 9> bind{oct.brick_part(0), oct.brick_part(1), oct.brick_part(2), oct.brick_part(3), oct.index(),
                                &tf,               &sum,              &pb,               &out};
    std::array<std::uint32_t, 3> push{oct.max_level(), oct.brick_words(), mode};
    Frame f{p.width, p.height, std::vector<vec4>(std::size_t{p.width} * p.height),
            std::vector<std::uint32_t>(std::size_t{p.width} * p.height), 0.0};
    f.ms = ctx.dispatch(oct.kernel(ctx), bind, push.data(), sizeof push, groups_for(p.width, 8), groups_for(p.height, 8));
    std::vector<std::uint32_t> px(std::size_t{p.width} * p.height * 5);
    out.download(px);
    for (std::size_t i = 0; i < f.rgba.size(); ++i) {
        std::memcpy(&f.rgba[i], &px[i * 5], 16);
        f.steps[i] = px[i * 5 + 4];
    }
    return f;
}

}  // namespace detail

/// Renders the octree on the device with its view's cut; same output as render_octree_dvr_cpu
/// (lattice samples, statuses exact; colours within the transcendentals' few ulp).
inline Frame render_octree_dvr_vulkan(Context& ctx, DeviceOctree& oct, const VolumeRenderParams& p) {
    return detail::render_octree_vulkan(ctx, oct, p, 0u);
}

/// The first hit of p.iso on the device; same output as render_octree_iso_cpu (hits and samples
/// exact; colours within the shading's transcendentals' few ulp).
inline Frame render_octree_iso_vulkan(Context& ctx, DeviceOctree& oct, const VolumeRenderParams& p) {
    return detail::render_octree_vulkan(ctx, oct, p, 1u);
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_OCTREE_VOLUME_HPP
