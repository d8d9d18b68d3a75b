// sylva/vulkan/elements.hpp -- the generic element kernels on a Vulkan device: a user's element
// shader (five lines, see sylva/shared/element_prologue.glsl) compiled to SPIR-V, bound to an
// encoded BIH (DeviceBih) and the element records (pack_elements). Same results as the host's
// sylva/render/elements.hpp: hit sequences equal bit for bit when the element's interval avoids
// transcendental functions; images within a tolerance (docs/DESIGN.md, parity rules).
//
//   sylva::vk::Context ctx;
//   sylva::vk::DeviceBih bih(ctx, words);
//   sylva::vk::ElementKernel kernel(ctx, my_spirv);          // e.g. an embedded sylva::spirv::<name>
//   sylva::vk::DeviceRecords recs(ctx, records);
//   auto hits  = kernel.hits(bih, recs, rays, ranges, 16);   // per ray, in order
//   auto frame = kernel.render(bih, recs, camera, 640, 480);
#ifndef SYLVA_VULKAN_ELEMENTS_HPP
#define SYLVA_VULKAN_ELEMENTS_HPP

#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/ray.hpp"
#include "sylva/render/camera.hpp"
#include "sylva/render/elements.hpp"
#include "sylva/vulkan/bih.hpp"
#include "sylva/vulkan/kernel.hpp"
#include "sylva/vulkan/loop_limit.hpp"
#include "sylva/vulkan/rays.hpp"
#include "sylva/vulkan/runner.hpp"

namespace sylva::vk {

/// Push constants of sylva/shared/element_prologue.glsl (100 bytes).
struct ElementPush {
    std::array<float, 12> cam{};
    std::uint32_t width = 0, height = 0, word_count = 0, elem_count = 0;
    std::uint32_t mode = 0, max_hits = 0;
    float alpha_stop = 0.99f;
    std::uint32_t ray_count = 0;
    std::uint32_t ray_source = 0;  ///< image mode: SYLVA_RAYS_* (ParticleRenderConfig::rays)
    std::uint32_t resume = 0;      ///< image mode: 1 continues the rays the previous dispatch paused
    std::uint32_t loop_budget = 0xFFFFFFFFu;  ///< image mode: loop iterations a ray may run a dispatch
    std::uint32_t origin_x = 0, origin_y = 0;  ///< image mode: the pixel of invocation (0, 0)
};
static_assert(sizeof(ElementPush) == 100);

/// Loop iterations a ray of the image kernel may run in one dispatch on a device that cuts long
/// loops (vk::loops_limited: lavapipe up to Mesa 22.3, Debian 12's own). It ends all loops of a
/// SIMD batch of 8 invocations once 65,535 iterations have run in them together; the kernel
/// notices (sylva_loops_cut in element_main.glsl) and such a ray runs its stretch again in a
/// later dispatch with half its budget, so the limiter costs time, never a wrong or missing
/// pixel. A ray past its budget pauses once it composited a hit and resumes from it in the next
/// dispatch (sylva_elements_composite_resume), at the cost of walking its index again. 16,000
/// measured best of 8,000-24,000 on the halo (32,314 particles, 640 x 480: no pixel lost on the
/// BIH or the element octree, 0.9-1.2 s a frame).
inline constexpr std::uint32_t kCpuDeviceLoopBudget = 16000;

/// Element records uploaded once. `record_words` is sylva::element_words<E>() of their type.
class DeviceRecords {
public:
    DeviceRecords(Context& ctx, std::span<const std::uint32_t> records, std::uint32_t record_words)
        : buffer_(ctx, std::max<std::size_t>(records.size(), 1) * 4) {
        if (record_words == 0 || records.size() % record_words != 0)
            throw Error("vk::DeviceRecords: " + std::to_string(records.size()) +
                        " words are not a whole number of " + std::to_string(record_words) + "-word records");
        if (records.size() / record_words > 0xFFFFFFFFu) throw Error("vk::DeviceRecords: too many records");
        if (!records.empty()) buffer_.upload(records);
        count_ = static_cast<std::uint32_t>(records.size() / record_words);
    }
    /// Records held.
    [[nodiscard]] std::uint32_t count() const { return count_; }
    [[nodiscard]] Buffer* buffer() { return &buffer_; }

private:
    Buffer buffer_;
    std::uint32_t count_ = 0;
};

/// The encoding of an element kd-tree (kdtree::encode_elements) or element octree
/// (octree::encode_elements) uploaded for the element kernels, split over four bindings like a
/// DeviceBih. Their shaders pick the index with `#define SylvaIndexIter SylvaKdElemIter` (or
/// SylvaOctElemIter) after including sylva/shared/element_kd.h (element_octree.h).
class DeviceElementIndex {
public:
    DeviceElementIndex(Context& ctx, std::span<const std::uint32_t> words, std::uint32_t shift = 0)
        : words_(split_words(ctx, words, 4, shift)), word_count_(static_cast<std::uint32_t>(words.size())) {
        if (words.empty() || words.size() > 0xFFFFFFFFu) throw Error("vk::DeviceElementIndex: empty or too large encoding");
    }
    /// Specialization constants: split shift, and 1 (the BIH stack is unused).
    [[nodiscard]] std::array<std::uint32_t, 2> constants() const { return {words_.shift, 1u}; }
    [[nodiscard]] std::uint32_t word_count() const { return word_count_; }
    [[nodiscard]] Buffer* part(std::size_t i) { return &words_.parts[i]; }

private:
    SplitWords words_;
    std::uint32_t word_count_;
};

/// A user's element shader: SPIR-V of a .comp that includes element_prologue.glsl, the element
/// header and element_main.glsl. Pipelines are made per BIH stack depth, split shift and parts
/// holding data (the specialization constants) and kept.
class ElementKernel {
public:
    /// Copies the SPIR-V; checks it (sylva::vk::Kernel) when the first pipeline is made.
    ElementKernel(Context& ctx, std::span<const std::uint32_t> spirv) : ctx_(&ctx), spirv_(spirv.begin(), spirv.end()) {
        if (spirv_.empty()) throw Error("vk::ElementKernel: empty SPIR-V");
    }

    /// Hits of each ray over its range, in order, at most max_hits each (max_hits 1: first hit).
    /// `Index` is a DeviceBih or a DeviceElementIndex, matching the shader's SylvaIndexIter.
    template <class Index>
    std::vector<ElementHits> hits(Index& bih, DeviceRecords& recs, std::span<const Ray> rays,
                                  std::span<const Interval> ranges, std::uint32_t max_hits) {
        check(bih, "hits");
        if (rays.size() != ranges.size()) throw Error("vk::ElementKernel::hits: rays and ranges differ in number");
        if (max_hits == 0 || max_hits > (1u << 20)) throw Error("vk::ElementKernel::hits: max_hits must be 1 .. 2^20");
        if (rays.empty()) return {};
        std::vector<std::uint32_t> in(rays.size() * 8);
        for (std::size_t i = 0; i < rays.size(); ++i) {
            float f[8] = {rays[i].origin.x,    rays[i].origin.y,    rays[i].origin.z, rays[i].direction.x,
                          rays[i].direction.y, rays[i].direction.z, ranges[i].t0,     ranges[i].t1};
            std::memcpy(&in[i * 8], f, sizeof f);
        }
        const std::size_t stride = 4 + 3 * std::size_t{max_hits};
        Buffer ray_buf(*ctx_, in.size() * 4), out_buf(*ctx_, rays.size() * stride * 4);
        ray_buf.upload(in);
        ElementPush push;
        push.width = static_cast<std::uint32_t>(std::min<std::size_t>(rays.size(), 256));
        push.height = static_cast<std::uint32_t>((rays.size() + push.width - 1) / push.width);
        push.word_count = bih.word_count();
        push.elem_count = recs.count();
        push.mode = 0;
        push.max_hits = max_hits;
        push.ray_count = static_cast<std::uint32_t>(rays.size());
        std::array<Buffer*, 7> bind{bih.part(0), bih.part(1), bih.part(2), bih.part(3), recs.buffer(), &ray_buf, &out_buf};
        ctx_->dispatch(kernel_for(bih), bind, &push, sizeof push, groups_for(push.width, 8), groups_for(push.height, 8));
        std::vector<std::uint32_t> raw(rays.size() * stride);
        out_buf.download(raw);
        std::vector<ElementHits> out(rays.size());
        for (std::size_t i = 0; i < rays.size(); ++i) {
            const std::uint32_t* r = &raw[i * stride];
            std::uint32_t n = std::min(r[0], max_hits);
            out[i].status = r[1] & 255u;
            out[i].passes = r[1] >> 8;
            out[i].steps = r[2];
            out[i].more = r[3] != 0;
            for (std::uint32_t k = 0; k < n; ++k) {
                shared::SylvaHit h;
                h.elem = r[4 + 3 * k];
                std::memcpy(&h.t0, &r[5 + 3 * k], 4);
                std::memcpy(&h.t1, &r[6 + 3 * k], 4);
                out[i].hits.push_back(h);
            }
        }
        return out;
    }

    /// Front-to-back compositing of a camera image; same layout as sylva::render_elements_cpu.
    /// Rays that spend the loop budget (loop_budget(): kCpuDeviceLoopBudget where loops are cut)
    /// or that the device's loop limiter cut short are run on by further dispatches over the
    /// rectangle of those pixels until none is left (at most kMaxResumes; a ray still running
    /// then is marked an error). A resumed ray walks its index again from the start for the hits
    /// after its last one, so its colour is the one-stretch colour and its steps count the extra
    /// walks. Frame::ms sums the dispatches.
    template <class Index>
    Frame render(Index& bih, DeviceRecords& recs, const CameraFrame& cam, std::uint32_t width,
                 std::uint32_t height, const ParticleRenderConfig& cfg = {}) {
        check(bih, "render");
        check_rays(cfg.rays, width, height);
        Buffer rays = detail::ray_binding(*ctx_, cam, cfg.rays, width, height);
        Buffer out_buf(*ctx_, std::max<std::size_t>(std::size_t{width} * height, 1) * 8 * 4);
        ElementPush push;
        push.cam = cam.floats();
        push.width = width;
        push.height = height;
        push.word_count = bih.word_count();
        push.elem_count = recs.count();
        push.mode = 1;
        push.alpha_stop = cfg.alpha_stop;
        push.ray_source = static_cast<std::uint32_t>(cfg.rays.source);
        push.loop_budget = loop_budget();
        std::array<Buffer*, 7> bind{bih.part(0), bih.part(1), bih.part(2), bih.part(3), recs.buffer(), &rays, &out_buf};
        Frame f{width, height, std::vector<vec4>(std::size_t{width} * height), std::vector<std::uint32_t>(std::size_t{width} * height), 0.0};
        if (f.rgba.empty()) return f;
        std::vector<std::uint32_t> px(std::size_t{width} * height * 8);
        resumes_ = 0;
        std::uint32_t x0 = 0, y0 = 0, x1 = width, y1 = height;  // the pixels [x0, x1) x [y0, y1) to (re)run
        for (;;) {
            push.origin_x = x0;
            push.origin_y = y0;
            f.ms += ctx_->dispatch(kernel_for(bih), bind, &push, sizeof push, groups_for(x1 - x0, 8), groups_for(y1 - y0, 8));
            out_buf.download(px);
            x0 = width, y0 = height, x1 = 0, y1 = 0;
            for (std::uint32_t y = 0; y < height; ++y)
                for (std::uint32_t x = 0; x < width; ++x)
                    if ((px[(std::size_t{y} * width + x) * 8 + 5] & 255u) == SYLVA_ITER_RUNNING)
                        x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1), y1 = std::max(y1, y + 1);
            if (x1 == 0 || resumes_ == kMaxResumes) break;
            push.resume = 1;
            ++resumes_;
        }
        for (std::size_t i = 0; i < f.rgba.size(); ++i) {
            std::memcpy(&f.rgba[i], &px[i * 8], 16);
            std::uint32_t status = px[i * 8 + 5] & 255u;
            f.steps[i] = status == SYLVA_ITER_DONE ? px[i * 8 + 4] : 0xFFFFFFFFu;  // ERROR, or still running
        }
        return f;
    }

    /// Dispatches after the first that the last render() needed to finish its paused rays.
    [[nodiscard]] std::uint32_t resumes() const { return resumes_; }
    /// Loop iterations a ray may run in one dispatch of render(): kCpuDeviceLoopBudget on a
    /// device that cuts long loops (vk::loops_limited), unlimited (0xFFFFFFFF) on others (GPUs,
    /// lavapipe 25), unless set_loop_budget chose one.
    [[nodiscard]] std::uint32_t loop_budget() const {
        if (loop_budget_ != 0) return loop_budget_;
        return loops_limited(*ctx_) ? kCpuDeviceLoopBudget : 0xFFFFFFFFu;
    }
    /// Sets the budget (1 .. 0xFFFFFFFF; 0 restores the device's default), e.g. to exercise
    /// resumption on small scenes.
    void set_loop_budget(std::uint32_t budget) { loop_budget_ = budget; }
    /// Dispatches render() makes at most after the first.
    static constexpr std::uint32_t kMaxResumes = 4096;

private:
    template <class Index>
    void check(const Index& bih, const char* what) const {
        if constexpr (std::is_same_v<Index, DeviceBih>) {
            if (bih.kind() != SYLVA_PAYLOAD_RANGE)
                throw Error(std::string("vk::ElementKernel::") + what + ": the BIH's payload kind " +
                            std::to_string(bih.kind()) + " is not record ranges (SYLVA_PAYLOAD_RANGE, 0)");
        } else {
            static_cast<void>(bih);
            static_cast<void>(what);
        }
    }
    /// The pipeline for the index's specialization constants (element_prologue.glsl): split
    /// shift, BIH stack entries, and the parts of the split index that hold data.
    template <class Index>
    Kernel& kernel_for(Index& bih) {
        auto c = bih.constants();
        std::array<std::uint32_t, 3> key{c[0], c[1], used_parts(bih.word_count(), c[0])};
        auto found = kernels_.find(key);
        if (found == kernels_.end())
            found = kernels_.emplace(key, std::make_unique<Kernel>(*ctx_, spirv_, 7, sizeof(ElementPush), key)).first;
        return *found->second;
    }

    Context* ctx_;
    std::vector<std::uint32_t> spirv_;
    std::uint32_t loop_budget_ = 0;
    std::uint32_t resumes_ = 0;
    std::map<std::array<std::uint32_t, 3>, std::unique_ptr<Kernel>> kernels_;
};

}  // namespace sylva::vk

#endif  // SYLVA_VULKAN_ELEMENTS_HPP
