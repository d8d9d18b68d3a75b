// sylva/vulkan/octree_particles.hpp -- particles through the element octree as a compute shader
// (shaders/octree_particles.comp, embedded SPIR-V running sylva/shared/octree_particles.h): the
// device twin of render_particles_octree_cpu (sylva/render/octree_particles.hpp), same inputs,
// same Frame. Step counts and error marks equal the host's; colours agree within the few ulp
// by which exp() and division differ between the host and the device (docs/DESIGN.md, What is
// exact where).
//
//   auto ctx = sylva::vk::Context::create();
//   sylva::vk::DeviceElementOctree oct(ctx, words, records);   // encode_elements + pack_particles
//   sylva::Frame img = sylva::vk::render_particles_octree_vulkan(ctx, oct, cam, width, height);
#ifndef SYLVA_VULKAN_OCTREE_PARTICLES_HPP
#define SYLVA_VULKAN_OCTREE_PARTICLES_HPP

#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/render/particles.hpp"
#include "sylva/shared/octree_particles.h"
#include "sylva/spirv/octree_particles.h"
#include "sylva/vulkan/rays.hpp"
#include "sylva/vulkan/runner.hpp"
#include "sylva/vulkan/split_words.hpp"
#include "sylva/vulkan/volume.hpp"

namespace sylva::vk {

/// An encoded element octree over particles and their records, uploaded once (each split over
/// four bindings, so either may exceed one binding's 128 MiB) for repeated frames.
class DeviceElementOctree {
public:
    /// `words`: encode_elements output; `records`: the particles' 8-word records in the octree's
    /// element order (pack_particles with the identity order). Throws sylva::Error when the
    /// records are not whole, hold fewer particles than the octree's element count, or either
    /// array exceeds four parts (or 2^32 words). The index itself is not validated here (see
    /// octree::validate_elements): a corrupted one makes its rays stop with an error.
    /// `shift` 0 picks the largest part the device allows; tests force small parts.
    DeviceElementOctree(Context& ctx, std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                        std::uint32_t shift = 0)
        : record_count_(checked_records(words, records)),
          words_(split_words(ctx, checked_size(words, "index"), 4, shift)),
          elems_(split_words(ctx, checked_size(records, "record"), 4, shift)),
          word_count_(static_cast<std::uint32_t>(words.size())),
          constants_{words_.shift, used_parts(words.size(), words_.shift), elems_.shift,
                     used_parts(records.size(), elems_.shift)} {}

    [[nodiscard]] std::uint32_t word_count() const { return word_count_; }
    [[nodiscard]] std::uint32_t record_count() const { return record_count_; }
    /// The kernel for this octree's splits, built on first use and kept.
    Kernel& kernel(Context& ctx) {
        if (!kernel_) kernel_.emplace(ctx, spirv::octree_particles, 10, 72, constants_);
        return *kernel_;
    }
    /// Bindings 0-7 (index parts, record parts) followed by `out`.
    [[nodiscard]] std::array<Buffer*, 10> bindings(Buffer& out, Buffer& rays) {
        return {&words_.parts[0], &words_.parts[1], &words_.parts[2], &words_.parts[3], &elems_.parts[0],
                &elems_.parts[1], &elems_.parts[2], &elems_.parts[3], &out,             &rays};
    }

private:
    static std::uint32_t checked_records(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records) {
        if (records.size() % SYLVA_PARTICLE_WORDS != 0 || records.size() / SYLVA_PARTICLE_WORDS > SYLVA_PARTICLE_MAX_RECORDS)
            throw Error("vk::DeviceElementOctree: " + std::to_string(records.size()) +
                        " record words are not a whole number of 8-word particle records below 2^29");
        if (words.size() > 7 && words[7] > records.size() / SYLVA_PARTICLE_WORDS)
            throw Error("vk::DeviceElementOctree: the octree names " + std::to_string(words[7]) +
                        " elements, the records hold " + std::to_string(records.size() / SYLVA_PARTICLE_WORDS));
        return static_cast<std::uint32_t>(records.size() / SYLVA_PARTICLE_WORDS);
    }
    static std::span<const std::uint32_t> checked_size(std::span<const std::uint32_t> w, const char* what) {
        if (w.size() > 0xFFFFFFFFu)
            throw Error(std::string("vk::DeviceElementOctree: the ") + what + " words exceed 32-bit word indices");
        return w;
    }

    std::uint32_t record_count_;
    SplitWords words_;
    SplitWords elems_;
    std::uint32_t word_count_;
    std::array<std::uint32_t, 4> constants_;
    std::optional<Kernel> kernel_;
};

/// Renders the particles through the element octree on the device; same output as
/// render_particles_octree_cpu (steps and 0xFFFFFFFF error marks equal; colours within a few
/// ulp). A ray that lavapipe's loop guard cut short is marked 0xFFFFFFFF too (the host never
/// leaves a ray short of alpha_stop without DONE or ERROR).
inline Frame render_particles_octree_vulkan(Context& ctx, DeviceElementOctree& oct, const CameraFrame& cam,
                                            std::uint32_t width, std::uint32_t height,
                                            const ParticleRenderConfig& cfg = {}) {
    check_rays(cfg.rays, width, height);
    Buffer out(ctx, std::max<std::size_t>(std::size_t{width} * height * 5 * 4, 4));
    Buffer rays = detail::ray_binding(ctx, cam, cfg.rays, width, height);
    struct {
        std::array<float, 12> cam;
        std::uint32_t width, height, word_count, records;
        float alpha_stop;
        std::uint32_t ray_source;
    } push{cam.floats(), width,           height, oct.word_count(), oct.record_count(),
           cfg.alpha_stop, static_cast<std::uint32_t>(cfg.rays.source)};
    static_assert(sizeof push == 72);
    auto bind = oct.bindings(out, rays);
    Frame f{width, height, std::vector<vec4>(std::size_t{width} * height), std::vector<std::uint32_t>(std::size_t{width} * height), 0.0};
    if (width == 0 || height == 0) return f;
    f.ms = ctx.dispatch(oct.kernel(ctx), bind, &push, sizeof push, groups_for(width, 8), groups_for(height, 8));
    std::vector<std::uint32_t> px(std::size_t{width} * height * 5);
    out.download(px);
    for (std::size_t i = 0; i < f.rgba.size(); ++i) {
        std::memcpy(&f.rgba[i], &px[i * 5], 16);
        f.steps[i] = px[i * 5 + 4];
    }
    return f;
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_OCTREE_PARTICLES_HPP
