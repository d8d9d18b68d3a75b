// sylva/vulkan/iso.hpp -- exact isosurface rendering of sylva/render/iso.hpp as a compute shader
// (shaders/ikd_iso.comp, embedded SPIR-V): same parameters, same Frame, same counters.
//
//   auto ctx = sylva::vk::Context::create();
//   sylva::vk::DeviceIso iso(ctx, words, sylva::GridWords::from(grid));  // or ::native(volume)
//   sylva::IsoCounters n;
//   sylva::Frame img = iso.render(ctx, params, &n);
#ifndef SYLVA_VULKAN_ISO_HPP
#define SYLVA_VULKAN_ISO_HPP

#include <array>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/render/iso.hpp"
#include "sylva/spirv/ikd_iso.h"
#include "sylva/vulkan/rays.hpp"
#include "sylva/vulkan/runner.hpp"

namespace sylva::vk {

/// An encoded implicit kd-tree and its grid uploaded once. Each must fit one storage binding
/// (lavapipe: 128 MiB, a grid of 32 M samples); larger ones are refused with sylva::Error.
class DeviceIso {
public:
    DeviceIso(Context& ctx, std::span<const std::uint32_t> tree_words, const GridWords& grid)
        : tree_(ctx, checked(ctx, tree_words.size(), "tree") * 4), grid_(ctx, checked(ctx, dense_words(grid), "grid") * 4),
          tree_words_(tree_words.size()), grid_words_(grid.words.size()), sampling_(grid.sampling),
          faces_(iso_face_ranges(tree_words, grid)) {
        tree_.upload(tree_words);
        grid_.upload(grid.words);
    }

    /// Renders as render_iso_cpu does (p.walker picks the tree or the DDA).
    Frame render(Context& ctx, const IsoRenderParams& p, IsoCounters* counters = nullptr) {
        std::vector<std::uint32_t> params = iso_params(p, tree_words_, grid_words_, sampling_, iso_border_faces(faces_, p));
        Buffer pb(ctx, params.size() * 4), out(ctx, std::size_t{p.width} * p.height * 8 * 4);
        pb.upload(params);
        if (!kernel_) {
            std::array<std::uint32_t, 1> stack{SYLVA_IKD_MAX_LEVELS};
            kernel_.emplace(ctx, spirv::ikd_iso, 5, 0, stack);
        }
        Buffer rays = detail::ray_binding(ctx, p.camera, p.rays, p.width, p.height);
        std::array<Buffer*, 5> bind{&tree_, &grid_, &pb, &out, &rays};
        Frame f{p.width, p.height, std::vector<vec4>(std::size_t{p.width} * p.height),
                std::vector<std::uint32_t>(std::size_t{p.width} * p.height), 0.0};
        f.ms = ctx.dispatch(*kernel_, bind, nullptr, 0, groups_for(p.width, 8), groups_for(p.height, 8));
        std::vector<std::uint32_t> px(std::size_t{p.width} * p.height * 8);
        out.download(px);
        IsoCounters n;
        for (std::size_t i = 0; i < f.rgba.size(); ++i) {
            const std::uint32_t* w = &px[i * 8];
            std::memcpy(&f.rgba[i], w, 16);
            bool error = w[7] == SYLVA_ITER_ERROR;
            f.steps[i] = error ? 0xFFFFFFFFu : w[4];
            n.steps += w[4];
            n.cells += w[5];
            n.hits += w[6];
            n.errors += error ? 1u : 0u;
        }
        if (counters) *counters = n;
        return f;
    }

private:
    /// The word count of a dense grid (check_iso_grid throws for a sparse one, a bad range or
    /// word count).
    static std::size_t dense_words(const GridWords& g) {
        check_iso_grid(g);
        return g.words.size();
    }
    static std::size_t checked(Context& ctx, std::size_t words, const char* what) {
        if (words * 4 > ctx.max_storage_buffer_range())
            throw Error(std::string("vk::DeviceIso: the ") + what + " (" + std::to_string(words * 4) +
                        " bytes) exceeds the device's storage buffer range of " +
                        std::to_string(ctx.max_storage_buffer_range()) + " bytes");
        return words;
    }
    Buffer tree_, grid_;
    std::size_t tree_words_, grid_words_;
    GridSampling sampling_;
    IsoFaceRanges faces_;  ///< the grid's face ranges, read once: the border's face culling
    std::optional<Kernel> kernel_;
};

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_ISO_HPP
