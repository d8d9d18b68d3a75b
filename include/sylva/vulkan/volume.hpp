// sylva/vulkan/volume.hpp -- the volume integrators of sylva/render/volume.hpp as compute
// shaders (shaders/dvr.comp, shaders/bih_dvr.comp, embedded SPIR-V): same parameters, same
// Frame. Leaf sequences of voxel BIHs come from vk::leaf_sequences (bih_leaves.comp does not
// look at payloads).
//
//   auto ctx = sylva::vk::Context::create();
//   sylva::vk::DeviceGrid grid(ctx, sylva::GridWords::from(density));
//   sylva::Frame ref = sylva::vk::render_dvr_vulkan(ctx, grid, params);
//   sylva::vk::DeviceVoxelBih bih(ctx, sylva::VoxelBihView{words, ranges, spacing, box});
//   sylva::Frame img = sylva::vk::render_bih_dvr_vulkan(ctx, bih, params);
#ifndef SYLVA_VULKAN_VOLUME_HPP
#define SYLVA_VULKAN_VOLUME_HPP

#include <algorithm>
#include <array>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

#include "sylva/render/volume.hpp"
#include "sylva/spirv/bih_dvr.h"
#include "sylva/spirv/dvr.h"
#include "sylva/vulkan/bih.hpp"
#include "sylva/vulkan/rays.hpp"
#include "sylva/vulkan/tf.hpp"
#include "sylva/vulkan/runner.hpp"
#include "sylva/vulkan/split_words.hpp"

namespace sylva::vk {

/// A density grid uploaded once (split over four bindings, so grids over 128 MiB work).
class DeviceGrid {
public:
    /// `shift` 0 picks the largest part the device allows; tests force small parts.
    DeviceGrid(Context& ctx, const GridWords& grid, std::uint32_t shift = 0)
        : words_(split_words(ctx, checked(grid), 4, shift)),
          parts_(used_parts(grid.words.size(), words_.shift)),
          dims_(grid.dims),
          spacing_(grid.spacing),
          sampling_(grid.sampling) {}
    [[nodiscard]] volume::Dims dims() const { return dims_; }
    /// Voxel format, value range and border of the grid (sylva/render/grid_view.hpp).
    [[nodiscard]] const GridSampling& sampling() const { return sampling_; }
    [[nodiscard]] vec3 spacing() const { return spacing_; }
    /// Specialization constants of dvr.comp (sylva/shared/dvr_main.glsl): split shift, parts
    /// holding data, voxel format, border mode (the last two fold the other samplers away).
    [[nodiscard]] std::array<std::uint32_t, 4> constants() const {
        return {words_.shift, parts_, static_cast<std::uint32_t>(sampling_.format),
                static_cast<std::uint32_t>(sampling_.border.mode)};
    }
    /// The marcher's kernel for this grid, built on first use and kept (lavapipe compiles a
    /// pipeline on its first dispatch, which costs more than a small frame).
    Kernel& kernel(Context& ctx) {
        if (!kernel_) kernel_.emplace(ctx, spirv::dvr, 8, 0, constants());
        return *kernel_;
    }
    /// A kernel of your SPIR-V built from sylva/shared/dvr_main.glsl (the marcher's bindings and
    /// specialization constants), for render_dvr_vulkan(ctx, grid, p, &kernel).
    [[nodiscard]] Kernel user_kernel(Context& ctx, std::span<const std::uint32_t> spirv) const {
        return Kernel(ctx, spirv, 8, 0, constants());
    }
    [[nodiscard]] Buffer* part(std::size_t i) { return &words_.parts[i]; }

private:
    static std::span<const std::uint32_t> checked(const GridWords& g) {
        g.check_words("vk::DeviceGrid");
        return g.words;
    }
    SplitWords words_;
    std::uint32_t parts_;
    volume::Dims dims_;
    vec3 spacing_;
    GridSampling sampling_;
    std::optional<Kernel> kernel_;
};

/// A voxel BIH and its optional node-range buffer uploaded once (each split over four bindings).
class DeviceVoxelBih {
public:
    /// Checks the header (voxel payload) and, when ranges are given, one word per node.
    DeviceVoxelBih(Context& ctx, const VoxelBihView& view, std::uint32_t shift = 0, std::uint32_t ranges_shift = 0)
        : header_(sylva::detail::voxel_bih_header(view.words, view.words.size())),
          bih_(ctx, view.words, shift),
          ranges_(split_words(ctx, checked_ranges(view, header_), 4, ranges_shift)),
          word_count_(view.words.size()),
          range_count_(view.ranges.size()),
          voxel_size_(view.voxel_size),
          grid_box_(view.grid_box) {}

    /// The parameter block for `p` (same checks as bih_dvr_params on the host).
    [[nodiscard]] std::vector<std::uint32_t> params(const VolumeRenderParams& p) const {
        return sylva::detail::pack_bih_dvr(header_, word_count_, voxel_size_, grid_box_, range_count_, p);
    }
    /// Specialization constants of bih_dvr.comp: BIH split shift, stack size, ranges shift,
    /// parts holding data of the BIH and of the ranges.
    [[nodiscard]] std::array<std::uint32_t, 5> constants() const {
        auto c = bih_.constants();
        return {c[0], c[1], ranges_.shift, used_parts(word_count_, c[0]), used_parts(range_count_, ranges_.shift)};
    }
    /// A kernel of your SPIR-V built from sylva/shared/bih_dvr_main.glsl (the BIH-DVR kernel's
    /// bindings and specialization constants, e.g. with a GLSL TF hook, sylva/shared/tf.h), for
    /// render_bih_dvr_vulkan(ctx, bih, p, &kernel).
    [[nodiscard]] Kernel user_kernel(Context& ctx, std::span<const std::uint32_t> spirv) const {
        return Kernel(ctx, spirv, 12, 0, constants());
    }
    /// The BIH-DVR kernel for this BIH, built on first use and kept (see DeviceGrid::kernel).
    Kernel& kernel(Context& ctx) {
        if (!kernel_) kernel_.emplace(ctx, spirv::bih_dvr, 12, 0, constants());
        return *kernel_;
    }
    [[nodiscard]] Buffer* part(std::size_t i) { return bih_.part(i); }
    [[nodiscard]] Buffer* range_part(std::size_t i) { return &ranges_.parts[i]; }

private:
    static std::span<const std::uint32_t> checked_ranges(const VoxelBihView& v, const shared::SylvaBihHeader& h) {
        if (!v.ranges.empty() && v.ranges.size() != h.node_count)
            throw Error("vk::DeviceVoxelBih: " + std::to_string(v.ranges.size()) + " node-range words for " +
                        std::to_string(h.node_count) + " nodes");
        return v.ranges;
    }
    shared::SylvaBihHeader header_;
    DeviceBih bih_;
    SplitWords ranges_;
    std::size_t word_count_;
    std::size_t range_count_;
    vec3 voxel_size_;
    Aabb grid_box_;
    std::optional<Kernel> kernel_;
};

namespace detail {

/// Dispatches an 8x8-tiled image kernel and reads back 5 words per pixel into a Frame.
inline Frame run_image_kernel(Context& ctx, Kernel& kernel, std::span<Buffer* const> inputs, Buffer& out,
                              std::uint32_t width, std::uint32_t height) {
    Frame f{width, height, std::vector<vec4>(std::size_t{width} * height), std::vector<std::uint32_t>(std::size_t{width} * height), 0.0};
    f.ms = ctx.dispatch(kernel, inputs, nullptr, 0, groups_for(width, 8), groups_for(height, 8));
    std::vector<std::uint32_t> px(std::size_t{width} * height * 5);
    out.download(px);
    for (std::size_t i = 0; i < f.rgba.size(); ++i) {
        std::memcpy(&f.rgba[i], &px[i * 5], 16);
        f.steps[i] = px[i * 5 + 4];
    }
    return f;
}

}  // namespace detail

/// Renders `grid` with the reference marcher on the device; same output as render_dvr_cpu.
/// With `kernel`, your build of sylva/shared/dvr_main.glsl (e.g. with a TF hook, sylva/shared/
/// tf.h; made with grid.user_kernel) runs instead of the library's dvr.comp.
inline Frame render_dvr_vulkan(Context& ctx, DeviceGrid& grid, const VolumeRenderParams& p, Kernel* kernel = nullptr) {
    std::vector<std::uint32_t> params = sylva::detail::pack_dvr(grid.dims(), grid.spacing(), p);
    grid.sampling().pack(params);
    Buffer tf = detail::tf_binding(ctx, p, kernel != nullptr);
    Buffer pb(ctx, params.size() * 4), out(ctx, std::size_t{p.width} * p.height * 5 * 4);
    pb.upload(params);
    Buffer rays = detail::ray_binding(ctx, p.camera, p.rays, p.width, p.height);
    std::array<Buffer*, 8> bind{grid.part(0), grid.part(1), grid.part(2), grid.part(3), &tf, &pb, &out, &rays};
    return detail::run_image_kernel(ctx, kernel ? *kernel : grid.kernel(ctx), bind, out, p.width, p.height);
}

/// Renders a voxel BIH in mode p.mode on the device; same output as render_bih_dvr_cpu. With
/// `kernel`, your build of sylva/shared/bih_dvr_main.glsl (e.g. with a TF hook; made with
/// bih.user_kernel) runs instead of the library's bih_dvr.comp.
inline Frame render_bih_dvr_vulkan(Context& ctx, DeviceVoxelBih& bih, const VolumeRenderParams& p,
                                   Kernel* kernel = nullptr) {
    std::vector<std::uint32_t> params = bih.params(p);
    Buffer tf = detail::tf_binding(ctx, p, kernel != nullptr);
    Buffer pb(ctx, params.size() * 4), out(ctx, std::size_t{p.width} * p.height * 5 * 4);
    pb.upload(params);
    Buffer rays = detail::ray_binding(ctx, p.camera, p.rays, p.width, p.height);
    std::array<Buffer*, 12> bind{bih.part(0),       bih.part(1),       bih.part(2),       bih.part(3),
                                 bih.range_part(0), bih.range_part(1), bih.range_part(2), bih.range_part(3),
                                 &tf,               &pb,               &out,              &rays};
    return detail::run_image_kernel(ctx, kernel ? *kernel : bih.kernel(ctx), bind, out, p.width, p.height);
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_VOLUME_HPP
