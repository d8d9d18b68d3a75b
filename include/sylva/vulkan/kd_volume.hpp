// sylva/vulkan/kd_volume.hpp -- DVR with empty-space skipping by a kd-tree (sylva/shared/kd_dvr.h)
// as a compute shader (shaders/kd_dvr.comp, embedded SPIR-V): same parameters, same Frame as
// sylva::render_kd_dvr_cpu (sylva/render/kd_volume.hpp).
//
//   auto ctx = sylva::vk::Context::create();
//   sylva::vk::DeviceGrid grid(ctx, sylva::GridWords::from(density));   // once per volume
//   sylva::vk::DeviceKdTree kd(ctx, words);                             // per (re)built tree
//   sylva::Frame img = sylva::vk::render_kd_dvr_vulkan(ctx, grid, kd, params);
#ifndef SYLVA_VULKAN_KD_VOLUME_HPP
#define SYLVA_VULKAN_KD_VOLUME_HPP

#include <algorithm>
#include <array>
#include <optional>
#include <span>
#include <vector>

#include "sylva/render/kd_volume.hpp"
#include "sylva/spirv/kd_dvr.h"
#include "sylva/vulkan/runner.hpp"
#include "sylva/vulkan/split_words.hpp"
#include "sylva/vulkan/volume.hpp"

namespace sylva::vk {

/// An encoded kd-tree uploaded once (split over four bindings) for repeated ESS-DVR frames.
class DeviceKdTree {
public:
    /// Checks the header (sylva::Error when it is not a valid kd-tree). `shift` 0 picks the
    /// largest part the device allows; tests force small parts.
    DeviceKdTree(Context& ctx, std::span<const std::uint32_t> words, std::uint32_t shift = 0)
        : header_(checked(words)),
          words_(split_words(ctx, words, 4, shift)),
          word_count_(static_cast<std::uint32_t>(words.size())) {}

    [[nodiscard]] std::uint32_t word_count() const { return word_count_; }
    [[nodiscard]] volume::Dims dims() const { return header_.dims; }
    [[nodiscard]] vec3 spacing() const { return header_.spacing; }
    [[nodiscard]] vec3 origin() const { return header_.origin; }
    [[nodiscard]] Buffer* part(std::size_t i) { return &words_.parts[i]; }

    /// The ESS-DVR kernel for this tree over `grid`, built on first use and kept while the
    /// grid's constants stay the same (lavapipe compiles a pipeline on its first dispatch).
    Kernel& kernel(Context& ctx, const DeviceGrid& grid) {
        std::array<std::uint32_t, 7> c = constants(grid);
        if (!kernel_ || c != kernel_constants_) {
            kernel_.reset();
            kernel_.emplace(ctx, spirv::kd_dvr, 12, 0, c);
            kernel_constants_ = c;
        }
        return *kernel_;
    }

    /// A kernel of your SPIR-V built from sylva/shared/kd_dvr_main.glsl (the ESS kernel's
    /// bindings and specialization constants for this tree over `grid`, e.g. with a GLSL TF
    /// hook, sylva/shared/tf.h), for render_kd_dvr_vulkan(ctx, grid, kd, p, &kernel).
    [[nodiscard]] Kernel user_kernel(Context& ctx, const DeviceGrid& grid, std::span<const std::uint32_t> spirv) const {
        return Kernel(ctx, spirv, 12, 0, constants(grid));
    }

    /// Specialization constants of kd_dvr.comp: grid shift and parts, kd shift and parts,
    /// stack entries (for the tree's depth, stack_entries_for), the grid's format and border.
    [[nodiscard]] std::array<std::uint32_t, 7> constants(const DeviceGrid& grid) const {
        auto g = grid.constants();
        return {g[0], g[1], words_.shift, used_parts(word_count_, words_.shift),
                stack_entries_for(header_.max_depth, SYLVA_KD_DEPTH_CAP), g[2], g[3]};
    }

private:
    static shared::SylvaKdHeader checked(std::span<const std::uint32_t> words) {
        if (words.size() > 0xFFFFFFFFu) throw Error("vk::DeviceKdTree: encoding over 2^32 words");
        shared::SylvaKdHeader h =
            shared::sylva_kd_read_header(shared::Words{words.data(), words.size()}, static_cast<std::uint32_t>(words.size()));
        if (h.valid == 0u) throw Error("vk::DeviceKdTree: not a valid encoded kd-tree (header, node count or depth)");
        return h;
    }
    shared::SylvaKdHeader header_;
    SplitWords words_;
    std::uint32_t word_count_;
    std::optional<Kernel> kernel_;
    std::array<std::uint32_t, 7> kernel_constants_{};
};

/// Renders `grid` with the marcher restricted to the leaves of `kd` on the device; same output
/// as render_kd_dvr_cpu. With `kernel`, your build of sylva/shared/kd_dvr_main.glsl (e.g. with a
/// TF hook; made with kd.user_kernel for this grid) runs instead of the library's kd_dvr.comp.
/// Throws sylva::Error when the tree's grid is not the volume's.
inline Frame render_kd_dvr_vulkan(Context& ctx, DeviceGrid& grid, DeviceKdTree& kd, const VolumeRenderParams& p,
                                  Kernel* kernel = nullptr) {
    std::vector<std::uint32_t> params = sylva::detail::pack_dvr(grid.dims(), grid.spacing(), p);
    grid.sampling().pack(params);
    if (kd.dims() != uvec3(grid.dims()) || kd.spacing() != grid.spacing() || kd.origin() != vec3(0.0f))
        throw Error("vk::render_kd_dvr_vulkan: the kd-tree's grid (dims, spacing or origin 0) is not the volume's");
    params[34] = kd.word_count();
    Buffer tf = detail::tf_binding(ctx, p, kernel != nullptr);
    Buffer pb(ctx, params.size() * 4), out(ctx, std::size_t{p.width} * p.height * 5 * 4);
    pb.upload(params);
    Buffer rays = detail::ray_binding(ctx, p.camera, p.rays, p.width, p.height);
    std::array<Buffer*, 12> bind{grid.part(0), grid.part(1), grid.part(2), grid.part(3), kd.part(0), kd.part(1),
                                 kd.part(2),   kd.part(3),   &tf,          &pb,          &out,         &rays};
    return detail::run_image_kernel(ctx, kernel ? *kernel : kd.kernel(ctx, grid), bind, out, p.width, p.height);
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_KD_VOLUME_HPP
