// The GPU half of the user-element check, built against the installed package's sylva::vulkan.
// The user's capsule (capsule.h, the one definition) runs on the device SYLVA_VULKAN_DEVICE
// picks (lavapipe with =cpu) two ways, both compiled by the installed sylva_add_spirv:
//  1. the library's generic element kernel (capsule.comp, five lines): hits in order per ray,
//     equal to the host's shared kernel (element_hits_cpu) and, through the installed conformance
//     kit, to brute force; and a front-to-back image against render_elements_cpu;
//  2. a hand-written kernel (capsule_first_hit.comp) bound through the generic host API
//     (vk::upload_buffer, vk::Bindings, vk::Kernel): first hit and hit count per ray.
//
// Tolerances (docs/DESIGN.md, parity rules): capsule.h's interval uses + - * / sqrt only, so on
// lavapipe hits are required bit for bit; other devices need not round division and sqrt
// correctly, so there entry and exit compare within 2^-18 relative (near ties accepted). Images
// composite 1 - exp(-tau), and Vulkan's exp is not exact: channels within 1e-5 everywhere.
#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/payload.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/elements.hpp>
#include <sylva/spirv/consumer_capsule.h>
#include <sylva/spirv/consumer_capsule_first_hit.h>
#include <sylva/testing/conformance.hpp>
#include <sylva/vulkan/bih.hpp>
#include <sylva/vulkan/elements.hpp>
#include <sylva/vulkan/runner.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <span>
#include <vector>

#include "capsule.hpp"

namespace {

constexpr std::uint32_t kWidth = 96, kHeight = 96;
constexpr float kHitTolerance = 1.0f / 262144.0f;  // 2^-18, devices other than lavapipe
constexpr float kImageTolerance = 1e-5f;

int failures = 0;

void fail(const char* what) {
    std::fprintf(stderr, "sylva_consumer_gpu: FAILED: %s\n", what);
    ++failures;
}

struct Scene {
    std::vector<consumer::Capsule> capsules = consumer::make_capsules(20000);
    sylva::bih::Tree tree;
    std::vector<std::uint32_t> words;
    std::vector<std::uint32_t> records;  // in the tree's order (record i is element tree.order[i])
    sylva::CameraFrame camera;
    std::vector<sylva::Ray> rays;  // the camera's, row by row

    Scene() {
        const std::span<const consumer::Capsule> view(capsules);
        tree = sylva::bih::build(view);
        words = sylva::bih::encode(tree, view, sylva::bih::RangePayload{});
        records = sylva::pack_elements(view, std::span<const std::uint32_t>(tree.order));
        sylva::Camera cam;
        cam.eye = sylva::vec3(0.5f, 0.6f, -1.4f);
        cam.target = sylva::vec3(0.5f, 0.5f, 0.5f);
        camera = cam.frame(kWidth, kHeight);
        for (std::uint32_t y = 0; y < kHeight; ++y)
            for (std::uint32_t x = 0; x < kWidth; ++x) rays.push_back(camera.ray(x, y, kWidth, kHeight));
    }
    [[nodiscard]] std::span<const consumer::Capsule> view() const { return capsules; }
};

/// Compares the device's results with brute force through the conformance kit.
void check_ray_hits(const Scene& s, const std::vector<sylva::testing::RayHits>& device, bool exact, const char* what) {
    const auto host = sylva::testing::host_ray_hits(s.view(), std::span<const sylva::Ray>(s.rays));
    const sylva::testing::Report report = sylva::testing::compare_ray_hits(
        s.view(), std::span<const sylva::Ray>(s.rays), host, device, exact ? 0.0f : kHitTolerance);
    std::cout << what << ": " << report;
    if (!report.ok()) fail(what);
}

/// 1. The generic element kernel: hits in order and an image.
void check_generic_kernel(sylva::vk::Context& context, const Scene& s, bool exact) {
    sylva::vk::DeviceBih bih(context, s.words);
    sylva::vk::DeviceRecords records(context, s.records, sylva::element_words<consumer::Capsule>());
    sylva::vk::ElementKernel kernel(context, sylva::spirv::consumer_capsule);

    const std::vector<sylva::Interval> ranges(s.rays.size());
    const std::uint32_t max_hits = 256;
    const std::vector<sylva::ElementHits> device = kernel.hits(bih, records, s.rays, ranges, max_hits);
    std::size_t same = 0, hits = 0;
    std::vector<sylva::testing::RayHits> first(s.rays.size());
    for (std::size_t i = 0; i < s.rays.size(); ++i) {
        const sylva::ElementHits host = sylva::element_hits_cpu<consumer::Capsule>(s.words, s.records, s.rays[i], ranges[i]);
        bool equal = device[i].hits.size() == host.hits.size() && device[i].status == host.status && !device[i].more;
        for (std::size_t k = 0; equal && k < host.hits.size(); ++k) {
            const auto &a = device[i].hits[k], &b = host.hits[k];
            equal = a.elem == b.elem && (exact ? (a.t0 == b.t0 && a.t1 == b.t1)
                                               : (std::fabs(a.t0 - b.t0) <= kHitTolerance * std::max(1.0f, std::fabs(b.t0)) &&
                                                  std::fabs(a.t1 - b.t1) <= kHitTolerance * std::max(1.0f, std::fabs(b.t1))));
        }
        same += equal ? 1 : 0;
        hits += device[i].hits.size();
        first[i].count = static_cast<std::uint32_t>(device[i].hits.size());
        if (!device[i].hits.empty()) {
            first[i].first = s.tree.order[device[i].hits[0].elem];
            first[i].t = {device[i].hits[0].t0, device[i].hits[0].t1};
        }
    }
    std::printf("sylva_consumer_gpu: generic kernel: %zu rays, %zu hits; hit sequences equal to the host's shared "
                "kernel on %zu rays (%s)\n",
                s.rays.size(), hits, same, exact ? "bit for bit" : "within 2^-18");
    if (same != s.rays.size()) fail("generic kernel: hit sequences differ from the host's");
    if (hits < s.rays.size()) fail("generic kernel: the scene is hit too little to test anything");
    check_ray_hits(s, first, exact, "generic kernel first hits against brute force");

    sylva::SerialExecutor serial;
    const sylva::Frame host = sylva::render_elements_cpu<consumer::Capsule>(s.words, s.records, s.camera, kWidth, kHeight, serial);
    const sylva::Frame gpu = kernel.render(bih, records, s.camera, kWidth, kHeight);
    float max_diff = 0.0f;
    std::size_t identical = 0, covered = 0;
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        float d = 0.0f;
        for (int c = 0; c < 4; ++c) d = std::max(d, std::fabs(host.rgba[i][c] - gpu.rgba[i][c]));
        max_diff = std::max(max_diff, std::isnan(d) ? INFINITY : d);
        identical += (host.rgba[i] == gpu.rgba[i]) ? 1 : 0;
        covered += host.rgba[i].a > 0.0f ? 1 : 0;
    }
    std::printf("sylva_consumer_gpu: image %ux%u: %zu pixels covered, %zu bit-identical, max channel difference %.3g "
                "(tolerance %.0e)\n",
                kWidth, kHeight, covered, identical, double(max_diff), double(kImageTolerance));
    if (!(max_diff <= kImageTolerance)) fail("generic kernel: the image differs from the host's beyond the tolerance");
    if (covered < host.rgba.size() / 2) fail("generic kernel: the image shows too little of the scene");
}

/// 2. A hand-written kernel through the generic host API.
void check_hand_written_kernel(sylva::vk::Context& context, const Scene& s, bool exact) {
    sylva::vk::DeviceBih bih(context, s.words);  // the encoding, split over bindings 0-3
    sylva::vk::Buffer records = sylva::vk::upload_buffer(context, s.records);
    sylva::vk::Buffer order = sylva::vk::upload_buffer(context, s.tree.order);
    std::vector<float> ray_floats;
    for (const sylva::Ray& r : s.rays) {
        const std::array<float, 8> f{r.origin.x,    r.origin.y,    r.origin.z, r.direction.x,
                                     r.direction.y, r.direction.z, 0.0f,       INFINITY};
        ray_floats.insert(ray_floats.end(), f.begin(), f.end());
    }
    sylva::vk::Buffer ray_buffer = sylva::vk::upload_buffer(context, ray_floats);
    sylva::vk::Buffer out(context, s.rays.size() * 5 * sizeof(std::uint32_t));

    sylva::vk::Bindings bindings;
    bindings.add(*bih.part(0)).add(*bih.part(1)).add(*bih.part(2)).add(*bih.part(3));
    bindings.add(records).add(order).add(ray_buffer).add(out);
    sylva::vk::Kernel kernel(context, sylva::spirv::consumer_capsule_first_hit, bindings.size(), 12, bih.constants());
    const struct {
        std::uint32_t ray_count, word_count, element_count;
    } push{static_cast<std::uint32_t>(s.rays.size()), bih.word_count(), static_cast<std::uint32_t>(s.capsules.size())};
    context.dispatch(kernel, bindings.list(), &push, sizeof push, sylva::vk::groups_for(s.rays.size(), 64));

    const std::vector<std::uint32_t> words = out.download_words();
    std::vector<sylva::testing::RayHits> device(s.rays.size());
    std::size_t errors = 0;
    for (std::size_t i = 0; i < s.rays.size(); ++i) {
        const std::uint32_t* d = &words[i * 5];
        device[i].first = d[0];
        std::memcpy(&device[i].t.t0, &d[1], 4);
        std::memcpy(&device[i].t.t1, &d[2], 4);
        device[i].count = d[3];
        errors += d[4] != 0 ? 1 : 0;
    }
    if (errors != 0) fail("hand-written kernel: the BIH walk reported errors");
    check_ray_hits(s, device, exact, "hand-written kernel against brute force");
}

}  // namespace

int main() {
    try {
        const Scene scene;
        sylva::vk::Context context = sylva::vk::Context::create();
        const bool exact = context.is_cpu();  // lavapipe: + - * / sqrt are correctly rounded
        std::printf("sylva_consumer_gpu: device %s; hits compared %s\n", context.describe().c_str(),
                    exact ? "bit for bit" : "within 2^-18");
        check_generic_kernel(context, scene, exact);
        check_hand_written_kernel(context, scene, exact);
    } catch (const std::exception& e) {
        fail(e.what());
    }
    if (failures == 0) std::puts("sylva_consumer_gpu: OK");
    return failures == 0 ? 0 : 1;
}
