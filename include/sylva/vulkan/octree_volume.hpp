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
          header_words_(view.words.begin(), view.words.begin() + SYLVA_OCT_HEADER_WORDS),
          border_(view.border) {
        border_.check();
        index_.upload(view.words);
    }
    /// An octree whose bricks arrive later (the out-of-core brick pool,
    /// sylva/octree/residency.hpp): `words` the index (word 7 = the pool's slots), a zeroed brick
    /// buffer of `brick_buffer_words` words filled by write_bricks().
    DeviceOctree(Context& ctx, std::span<const std::uint32_t> words, std::size_t brick_buffer_words, std::uint32_t shift = 0)
        : header_(pool_header(words, brick_buffer_words)),
          bricks_(empty_split(ctx, brick_buffer_words, shift)),
          parts_(used_parts(brick_buffer_words, bricks_.shift)),
          index_(ctx, words.size() * 4),
          brick_words_(static_cast<std::uint32_t>(brick_buffer_words)),
          max_level_(0xFFFFFFFFu),
          header_words_(words.begin(), words.begin() + SYLVA_OCT_HEADER_WORDS) {
        index_.upload(words);
    }
    /// Copies `words` into the brick buffer from word `first` (across its parts).
    void write_bricks(std::size_t first, std::span<const std::uint32_t> words) {
        if (first + words.size() > brick_words_) throw Error("vulkan octree: write_bricks beyond the brick buffer");
        const std::size_t part = std::size_t{1} << bricks_.shift;
        while (!words.empty()) {
            std::size_t p = first >> bricks_.shift, at = first & (part - 1), n = std::min(words.size(), part - at);
            bricks_.parts[p].upload(words.first(n), at);
            words = words.subspan(n);
            first += n;
        }
    }
    /// The feedback buffer of `words` words (zeroed), made on first use and kept.
    Buffer& feedback(Context& ctx, std::size_t words) {
        if (!seen_ || seen_->size_bytes() != words * 4) seen_.emplace(ctx, words * 4);
        else seen_->fill(0u);
        return *seen_;
    }
    /// A 4-byte buffer bound where no feedback is wanted.
    Buffer& no_feedback(Context& ctx) {
        if (!dummy_) dummy_.emplace(ctx, 4);
        return *dummy_;
    }
    /// The octant masks (one word per node, sylva/octree/octants.hpp), uploaded when they
    /// change; a 4-byte dummy when `masks` is empty (the kernel then reads none).
    Buffer& octant_masks(Context& ctx, std::span<const std::uint32_t> masks) {
        if (masks.empty()) {
            if (!mask_dummy_) mask_dummy_.emplace(ctx, 4);
            return *mask_dummy_;
        }
        if (masks.size() != header_.node_count)
            throw Error("vulkan octree: " + std::to_string(masks.size()) + " octant masks for " +
                        std::to_string(header_.node_count) + " octree nodes");
        if (!masks_ || masks_->size_bytes() != masks.size() * 4) masks_.emplace(ctx, masks.size() * 4);
        if (!std::equal(masks.begin(), masks.end(), mask_words_.begin(), mask_words_.end())) {
            masks_->upload(masks);
            mask_words_.assign(masks.begin(), masks.end());
        }
        return *masks_;
    }
    [[nodiscard]] const shared::SylvaOctHeader& header() const { return header_; }
    [[nodiscard]] std::uint32_t brick_words() const { return brick_words_; }
    [[nodiscard]] std::uint32_t max_level() const { return max_level_; }
    /// What samples read outside the volume (OctreeView::border; a constant 0 for an octree made
    /// from a pool's words until set_border).
    [[nodiscard]] GridBorder border() const { return border_; }
    /// Sets the border mode of later renders (throws sylva::Error for a non-finite value); a new
    /// mode builds the library kernel again on its next use (a user kernel is made for one mode).
    void set_border(GridBorder b) {
        b.check();
        if (b.mode != border_.mode) kernel_.reset();
        border_ = b;
    }
    /// Specialization constants of octree_dvr.comp: the bricks' split shift, parts holding data,
    /// brick format and border mode (sylva/shared/octree_dvr_main.glsl).
    [[nodiscard]] std::array<std::uint32_t, 4> constants() const {
        return {bricks_.shift, parts_, header_.format, static_cast<std::uint32_t>(border_.mode)};
    }
    /// The kernel for this octree's brick split, built on first use and kept.
    Kernel& kernel(Context& ctx) {
        if (!kernel_) kernel_.emplace(ctx, spirv::octree_dvr, 12, 20, constants());
        return *kernel_;
    }
    /// A kernel of your SPIR-V built from sylva/shared/octree_dvr_main.glsl (the octree kernel's
    /// bindings, push and specialization constants, e.g. with a GLSL TF hook, sylva/shared/tf.h),
    /// for render_octree_dvr_vulkan / render_octree_iso_vulkan(..., &kernel), made for the
    /// octree's brick format and current border mode.
    [[nodiscard]] Kernel user_kernel(Context& ctx, std::span<const std::uint32_t> spirv) const {
        return Kernel(ctx, spirv, 12, 20, constants());
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
    static shared::SylvaOctHeader pool_header(std::span<const std::uint32_t> words, std::size_t brick_buffer_words) {
        if (brick_buffer_words > 0xFFFFFFFFu) throw Error("vulkan octree: brick pool over 2^32 words");
        shared::SylvaOctHeader h = shared::sylva_oct_read_header(shared::Words{words.data(), words.size()},
                                                                 std::uint32_t(words.size()), std::uint32_t(brick_buffer_words));
        if (words.size() > 0xFFFFFFFFu || h.valid == 0u)
            throw Error("vulkan octree: not a valid encoded octree for a pool of " + std::to_string(brick_buffer_words) + " words");
        return h;
    }
    static SplitWords empty_split(Context& ctx, std::size_t words, std::uint32_t shift) {
        if (shift == 0) shift = default_split_shift(ctx);
        const std::size_t part = std::size_t{1} << shift;
        if (words > 4 * part) throw Error("vulkan octree: a brick pool of " + std::to_string(words) + " words exceeds 4 bindings");
        SplitWords split;
        split.shift = shift;
        for (std::size_t p = 0; p < 4; ++p) {
            std::size_t first = p * part, count = first < words ? std::min(part, words - first) : 0;
            split.parts.emplace_back(ctx, count * 4);
        }
        return split;
    }

    shared::SylvaOctHeader header_;
    SplitWords bricks_;
    std::uint32_t parts_;
    Buffer index_;
    std::uint32_t brick_words_;
    std::uint32_t max_level_;
    std::vector<std::uint32_t> header_words_;
    GridBorder border_{};
    std::optional<Kernel> kernel_;
    std::optional<Buffer> seen_, dummy_, masks_, mask_dummy_;
    std::vector<std::uint32_t> mask_words_;  ///< what masks_ holds
};

/// The device pool of sylva/octree/residency.hpp on a DeviceOctree: slot s is brick words
/// [s * brick_words, (s + 1) * brick_words) of its brick buffer.
struct DeviceBrickPool {
    DeviceOctree* octree = nullptr;
    std::uint32_t brick_words = 0;
    void write_brick(std::uint32_t slot, std::span<const std::uint32_t> brick) {
        octree->write_bricks(std::size_t{slot} * brick_words, brick);
    }
};

namespace detail {

inline Frame render_octree_vulkan(Context& ctx, DeviceOctree& oct, const VolumeRenderParams& p, std::uint32_t mode,
                                  std::span<std::uint32_t> seen, std::span<const std::uint32_t> octmask, Kernel* kernel) {
    std::vector<std::uint32_t> params = sylva::detail::pack_octree(oct.header(), oct.border(), p);
    std::vector<std::uint32_t> tfsum = tf_opacity_prefix(p);
    Buffer tf = detail::tf_binding(ctx, p, kernel != nullptr);
    Buffer sum(ctx, tfsum.size() * 4), pb(ctx, params.size() * 4), out(ctx, std::size_t{p.width} * p.height * 5 * 4);
    sum.upload(tfsum);
    pb.upload(params);
    Buffer& fb = seen.empty() ? oct.no_feedback(ctx) : oct.feedback(ctx, seen.size());
    Buffer& mb = oct.octant_masks(ctx, octmask);
    Buffer rays = detail::ray_binding(ctx, p.camera, p.rays, p.width, p.height);
    std::array<Buffer*, 12> bind{oct.brick_part(0), oct.brick_part(1), oct.brick_part(2), oct.brick_part(3), oct.index(),
                                 &tf,               &sum,              &pb,               &out,              &fb,
                                 &mb,               &rays};
    std::array<std::uint32_t, 5> push{oct.max_level(), oct.brick_words(), mode, seen.empty() ? 0u : 1u,
                                      octmask.empty() ? 0u : 1u};
    Frame f{p.width, p.height, std::vector<vec4>(std::size_t{p.width} * p.height),
            std::vector<std::uint32_t>(std::size_t{p.width} * p.height), 0.0};
    f.ms = ctx.dispatch(kernel ? *kernel : oct.kernel(ctx), bind, push.data(), sizeof push, groups_for(p.width, 8), groups_for(p.height, 8));
    std::vector<std::uint32_t> px(std::size_t{p.width} * p.height * 5);
    out.download(px);
    for (std::size_t i = 0; i < f.rgba.size(); ++i) {
        std::memcpy(&f.rgba[i], &px[i * 5], 16);
        f.steps[i] = px[i * 5 + 4];
    }
    if (!seen.empty()) {
        std::vector<std::uint32_t> marks = fb.download_words();
        for (std::size_t i = 0; i < seen.size() && i < marks.size(); ++i) seen[i] |= marks[i];
    }
    return f;
}

}  // namespace detail

/// Renders the octree on the device with its view's cut; same output as render_octree_dvr_cpu
/// (lattice samples, statuses exact; colours within the transcendentals' few ulp).
/// With `seen` (one word per node) the visibility feedback of sylva/shared/octree_dvr.h is
/// OR-ed into it (nonzero: a ray reached the cut leaf). With `octmask` (one word per node,
/// sylva/octree/octants.hpp) empty octants of leaves are skipped: the same image, fewer samples.
/// With `kernel`, your build of sylva/shared/octree_dvr_main.glsl (e.g. with a TF hook; made with
/// oct.user_kernel) runs instead of the library's octree_dvr.comp.
inline Frame render_octree_dvr_vulkan(Context& ctx, DeviceOctree& oct, const VolumeRenderParams& p,
                                      std::span<std::uint32_t> seen = {}, std::span<const std::uint32_t> octmask = {},
                                      Kernel* kernel = nullptr) {
    return detail::render_octree_vulkan(ctx, oct, p, 0u, seen, octmask, kernel);
}

/// The first hit of p.iso on the device; same output as render_octree_iso_cpu (hits and samples
/// exact; colours within the shading's transcendentals' few ulp). `kernel` as for
/// render_octree_dvr_vulkan.
inline Frame render_octree_iso_vulkan(Context& ctx, DeviceOctree& oct, const VolumeRenderParams& p,
                                      std::span<std::uint32_t> seen = {}, Kernel* kernel = nullptr) {
    return detail::render_octree_vulkan(ctx, oct, p, 1u, seen, {}, kernel);
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_OCTREE_VOLUME_HPP
