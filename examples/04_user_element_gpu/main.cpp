// 04_user_element_gpu: a user element written once (capsule.h, in sylva's shared C++/GLSL
// subset) runs on the host and on a Vulkan device (lavapipe without a GPU) through the generic
// element kernels: a BIH over 20,000 capsules, the hits of some rays in order, and an image
// composited front to back; the two backends are compared (hits bit for bit, image within 2e-6).
// Without a Vulkan device it runs the host part and says so.
#include <algorithm>
#include <cstdio>
#include <random>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/render/elements.hpp>
#ifdef SYLVA_EXAMPLE_VULKAN
#include <sylva/spirv/example_capsule.h>  // capsule.comp, compiled by sylva_add_spirv
#include <sylva/vulkan/elements.hpp>
#endif

#include "capsule.h"

/// Largest channel difference of two pixels.
static float max_channel_diff(sylva::vec4 a, sylva::vec4 b) {
    sylva::vec4 d = glm::abs(a - b);
    return std::max(std::max(d.x, d.y), std::max(d.z, d.w));
}

int main() {
    using namespace sylva;
    // 1. The elements: plain structs, satisfying the library's concepts as they are.
    static_assert(Bounded<demo::Capsule> && Intersectable<demo::Capsule> && RayInteraction<demo::Capsule>);
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), s(-1.0f, 1.0f);
    std::vector<demo::Capsule> capsules(20000);
    for (auto& c : capsules) {
        c.a = vec3(u(rng), u(rng), u(rng));
        c.b = c.a + 0.1f * vec3(s(rng), s(rng), s(rng));
        c.radius = 0.004f + 0.01f * u(rng);
        c.extinction = 20.0f + 60.0f * u(rng);
        c.rgb = vec3(0.3f + 0.7f * u(rng), 0.3f + 0.7f * u(rng), 0.3f + 0.7f * u(rng));
    }
    // 2. Build, encode (record ranges), and pack the records in the tree's order.
    std::span<const demo::Capsule> es(capsules);
    bih::Tree tree = bih::build(es, bih::Config::for_queries());
    auto words = bih::encode(tree, es, bih::RangePayload{});
    auto records = pack_elements(es, std::span<const std::uint32_t>(tree.order.data(), tree.order.size()));

    // 3. Host: hits in order along one ray, and an image.
    Ray ray{{-0.2f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}};
    ElementHits hits = element_hits_cpu<demo::Capsule>(words, records, ray, {}, 8);
    std::printf("host: first %zu hits of the ray along x:", hits.hits.size());
    for (const auto& h : hits.hits) std::printf(" #%u [%.4f, %.4f]", h.elem, h.t0, h.t1);
    std::printf("\n");
    Camera cam;
    cam.eye = vec3(1.8f, 1.3f, 2.2f);
    cam.target = vec3(0.5f);
    const std::uint32_t w = 160, h = 120;
    ThreadPool pool;
    Frame host = render_elements_cpu<demo::Capsule>(words, records, cam.frame(w, h), w, h, pool);
    float coverage = 0.0f;
    for (const vec4& c : host.rgba) coverage += c.a;
    std::printf("host: %ux%u image in %.1f ms, mean opacity %.3f\n", w, h, host.ms, coverage / float(w * h));

#ifdef SYLVA_EXAMPLE_VULKAN
    // 4. Vulkan: the same element through the shader capsule.comp (five lines).
    try {
        vk::Context ctx = vk::Context::create();
        vk::DeviceBih bih(ctx, words);
        vk::DeviceRecords recs(ctx, records, element_words<demo::Capsule>());
        vk::ElementKernel kernel(ctx, spirv::example_capsule);
        auto dev_hits = kernel.hits(bih, recs, std::span<const Ray>(&ray, 1), std::vector<Interval>{Interval{}}, 8);
        bool same = dev_hits[0].hits.size() == hits.hits.size();
        for (std::size_t i = 0; same && i < hits.hits.size(); ++i)
            same = dev_hits[0].hits[i].elem == hits.hits[i].elem && dev_hits[0].hits[i].t0 == hits.hits[i].t0 &&
                   dev_hits[0].hits[i].t1 == hits.hits[i].t1;
        Frame dev = kernel.render(bih, recs, cam.frame(w, h), w, h);
        float worst = 0.0f;
        for (std::size_t i = 0; i < dev.rgba.size(); ++i)
            worst = std::max(worst, max_channel_diff(dev.rgba[i], host.rgba[i]));
        std::printf("vulkan (%s): hits %s the host's; image in %.1f ms, largest difference %.2g\n",
                    ctx.device_name().c_str(), same ? "equal" : "DIFFER from", dev.ms, worst);
        if (!same || worst > 2e-6f) return 1;
    } catch (const Error& e) {
        std::printf("vulkan: %s (host part done)\n", e.what());
    }
#else
    std::printf("built without Vulkan: host part only\n");
#endif
    return 0;
}
