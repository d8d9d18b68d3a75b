// sylva/vulkan/bih.hpp -- the shared BIH iterator and particle integrator run as compute
// shaders (shaders/bih_leaves.comp, shaders/particles.comp, embedded SPIR-V).
#ifndef SYLVA_VULKAN_BIH_HPP
#define SYLVA_VULKAN_BIH_HPP

#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <memory>
#include <span>
#include <vector>

#include "sylva/core/ray.hpp"
#include "sylva/render/particles.hpp"
#include "sylva/shared/bih_layout.h"
#include "sylva/spirv/bih_leaves.h"
#include "sylva/spirv/particles.h"
#include "sylva/vulkan/rays.hpp"
#include "sylva/vulkan/runner.hpp"
#include "sylva/vulkan/split_words.hpp"

namespace sylva::vk {

/// An encoded BIH uploaded once (split over four bindings) for repeated dispatches.
class DeviceBih {
public:
    /// `shift` 0 picks the largest part the device allows; tests force small parts.
    DeviceBih(Context& ctx, std::span<const std::uint32_t> words, std::uint32_t shift = 0)
        : words_(split_words(ctx, words, 4, shift)), word_count_(static_cast<std::uint32_t>(words.size())) {
        if (words.size() < SYLVA_BIH_HEADER_WORDS || words[0] != SYLVA_BIH_MAGIC)
            throw Error("vk::DeviceBih: not an encoded BIH");
        depth_ = words[4];
        kind_ = (words[2] >> 8) & 255u;
        if (depth_ > SYLVA_BIH_DEPTH_CAP) throw Error("vk::DeviceBih: depth over the cap");
    }
    /// The payload kind (header bits 8-15).
    [[nodiscard]] std::uint32_t kind() const { return kind_; }
    /// Specialization constants: split shift, and a stack for the tree's depth (stack_entries_for).
    [[nodiscard]] std::array<std::uint32_t, 2> constants() const {
        return {words_.shift, stack_entries_for(depth_, SYLVA_BIH_DEPTH_CAP)};
    }
    [[nodiscard]] std::uint32_t word_count() const { return word_count_; }
    [[nodiscard]] Buffer* part(std::size_t i) { return &words_.parts[i]; }

private:
    SplitWords words_;
    std::uint32_t word_count_;
    std::uint32_t depth_ = 0;
    std::uint32_t kind_ = 0;
};

/// Leaf sequences the GPU iterator yields per ray, in the layout of shaders/bih_leaves.comp
/// (per ray: count, status, steps, then max_leaves x (node, t0 bits, t1 bits)).
inline std::vector<std::uint32_t> leaf_sequences(Context& ctx, DeviceBih& bih, std::span<const Ray> rays,
                                                 std::span<const Interval> ranges, std::uint32_t max_leaves) {
    std::vector<std::uint32_t> in(rays.size() * 8);
    for (std::size_t i = 0; i < rays.size(); ++i) {
        float f[8] = {rays[i].origin.x,    rays[i].origin.y,    rays[i].origin.z, rays[i].direction.x,
                      rays[i].direction.y, rays[i].direction.z, ranges[i].t0,     ranges[i].t1};
        std::memcpy(&in[i * 8], f, sizeof f);
    }
    std::size_t stride = 3 + 3 * std::size_t{max_leaves};
    Buffer ray_buf(ctx, in.size() * 4), out_buf(ctx, rays.size() * stride * 4);
    ray_buf.upload(in);
    auto constants = bih.constants();
    Kernel kernel(ctx, spirv::bih_leaves, 6, 12, constants);
    struct { std::uint32_t ray_count, word_count, max_leaves; } push{static_cast<std::uint32_t>(rays.size()),
                                                                     bih.word_count(), max_leaves};
    std::array<Buffer*, 6> bind{bih.part(0), bih.part(1), bih.part(2), bih.part(3), &ray_buf, &out_buf};
    ctx.dispatch(kernel, bind, &push, sizeof push, groups_for(rays.size(), 64));
    std::vector<std::uint32_t> out(rays.size() * stride);
    out_buf.download(out);
    return out;
}

/// The particle integrator (shaders/particles.comp) for repeated frames on one context: its
/// pipelines are made per BIH split shift and stack depth (the specialization constants) on first
/// use and kept, so frames over BIHs that change (moving particles, refit or rebuilt, uploaded
/// anew each frame) compile nothing after the first. render_particles_vulkan is one frame of it.
class ParticleKernel {
public:
    explicit ParticleKernel(Context& ctx) : ctx_(&ctx) {}

    /// Renders `bih` with `records` (pack_particles output uploaded to a buffer; a dummy for
    /// inline payloads); same output as render_particles_cpu. Throws sylva::Error when the
    /// encoding's payload kind is not a particle kind (check_particle_payload).
    Frame render(DeviceBih& bih, Buffer& records, const CameraFrame& cam, std::uint32_t width, std::uint32_t height,
                 const ParticleRenderConfig& cfg = {}) {
        check_particle_payload(bih.kind(), records.size_bytes() / 4, "vk::ParticleKernel::render");
        check_rays(cfg.rays, width, height);
        Buffer out_buf(*ctx_, std::size_t{width} * height * 5 * 4);
        Buffer rays = detail::ray_binding(*ctx_, cam, cfg.rays, width, height);
        struct {
            std::array<float, 12> cam;
            std::uint32_t width, height, word_count;
            float alpha_stop;
            std::uint32_t ray_source;
        } push{cam.floats(), width, height, bih.word_count(), cfg.alpha_stop, static_cast<std::uint32_t>(cfg.rays.source)};
        static_assert(sizeof push == 68);
        std::array<Buffer*, 7> bind{bih.part(0), bih.part(1), bih.part(2), bih.part(3), &records, &out_buf, &rays};
        Frame f{width, height, std::vector<vec4>(std::size_t{width} * height), std::vector<std::uint32_t>(std::size_t{width} * height), 0.0};
        f.ms = ctx_->dispatch(kernel_for(bih), bind, &push, sizeof push, groups_for(width, 8), groups_for(height, 8));
        std::vector<std::uint32_t> px(std::size_t{width} * height * 5);
        out_buf.download(px);
        for (std::size_t i = 0; i < f.rgba.size(); ++i) {
            std::memcpy(&f.rgba[i], &px[i * 5], 16);
            f.steps[i] = px[i * 5 + 4];
        }
        return f;
    }

private:
    /// Specialization constants of particles.comp: split shift, stack entries, parts holding data.
    Kernel& kernel_for(const DeviceBih& bih) {
        auto c = bih.constants();
        std::array<std::uint32_t, 3> key{c[0], c[1], used_parts(bih.word_count(), c[0])};
        auto found = kernels_.find(key);
        if (found == kernels_.end())
            found = kernels_.emplace(key, std::make_unique<Kernel>(*ctx_, spirv::particles, 7, 68, key)).first;
        return *found->second;
    }

    Context* ctx_;
    std::map<std::array<std::uint32_t, 3>, std::unique_ptr<Kernel>> kernels_;
};

/// Renders an encoded particle BIH on the device; same output as render_particles_cpu. Throws
/// sylva::Error when the encoding's payload kind is not a particle kind (check_particle_payload).
inline Frame render_particles_vulkan(Context& ctx, DeviceBih& bih, std::span<const std::uint32_t> records,
                                     const CameraFrame& cam, std::uint32_t width, std::uint32_t height,
                                     const ParticleRenderConfig& cfg = {}) {
    check_particle_payload(bih.kind(), records.size(), "render_particles_vulkan");
    Buffer elems(ctx, records.size() * 4);
    if (!records.empty()) elems.upload(records);
    return ParticleKernel(ctx).render(bih, elems, cam, width, height, cfg);
}

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_BIH_HPP
