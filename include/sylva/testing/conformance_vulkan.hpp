// sylva/testing/conformance_vulkan.hpp -- the conformance kit's host-against-device check for an
// element type written once in the shared subset (sylva/shared/element.h): its generic element
// kernel (the user's five-line shader, compiled with sylva_add_spirv) runs on a Vulkan device and
// every ray's hit sequence must equal brute force on the host.
//
//   sylva::vk::Context context = sylva::vk::Context::create();   // SYLVA_VULKAN_DEVICE=cpu: lavapipe
//   auto report = sylva::testing::check_device<Capsule>(context, sylva::spirv::capsule, make_capsule);
//   if (!report.ok()) std::cerr << report;
//
// Needs sylva::vulkan (link it; sylva/testing/conformance.hpp alone does not). Tolerance
// (docs/DESIGN.md, parity rules): on a CPU device (lavapipe) + - * / sqrt are correctly rounded,
// so an interval written with them must match bit for bit; pass a relative tolerance for other
// devices or for elements whose interval uses exp, log, pow or trigonometry.
#ifndef SYLVA_TESTING_CONFORMANCE_VULKAN_HPP
#define SYLVA_TESTING_CONFORMANCE_VULKAN_HPP

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "sylva/render/elements.hpp"
#include "sylva/testing/conformance.hpp"
#include "sylva/vulkan/bih.hpp"
#include "sylva/vulkan/elements.hpp"

namespace sylva::testing {

/// Settings of check_device.
struct DeviceCheckConfig {
    std::uint64_t seed = 1;            ///< seeds the generator and the rays
    std::size_t element_count = 3000;  ///< instances in the scene
    std::size_t ray_count = 3000;      ///< random, axis-parallel, inside-start and range-limited rays
    std::uint32_t max_hits = 512;      ///< hits kept per ray on the device (more is reported as a failure)
    /// Relative tolerance on entry and exit t; negative: 0 (bit for bit) on CPU devices, 2^-16
    /// elsewhere (a GPU may compute division, sqrt and log to a few ulp, and an interval end that
    /// takes the square root of a small difference loses more; 2^-18 was too tight for one RBF
    /// ray of 3,000 on an NVIDIA H200).
    float tolerance = -1.0f;
    std::size_t max_reports = 8;
};

/// Runs E's generic element kernel (`spirv`) over a generated scene in a BIH on the device and
/// compares each ray's hit sequence (element, entry, exit, in order) with brute force. Hits that
// enter at the same t may come in any order among themselves (the kernel breaks such ties by
// record index, the host by element index); all others must come in brute force's order.
template <SharedElement E, class Gen>
Report check_device(vk::Context& context, std::span<const std::uint32_t> spirv, Gen&& generate,
                    const DeviceCheckConfig& cfg = {}) {
    Report r;
    r.max_reports = cfg.max_reports;
    Rng rng(cfg.seed);
    const std::vector<E> scene = detail::generate<E>(generate, cfg.element_count, rng);
    const std::span<const E> view(scene);
    const bih::Tree tree = bih::build(view);
    const std::vector<std::uint32_t> words = bih::encode(tree, view, bih::RangePayload{});
    const std::vector<std::uint32_t> records = pack_elements(view, std::span<const std::uint32_t>(tree.order));
    const std::vector<std::pair<Ray, Interval>> probes = detail::scene_rays(detail::scene_box(view), cfg.ray_count, rng);
    std::vector<Ray> rays;
    std::vector<Interval> ranges;
    for (const auto& [ray, range] : probes) {
        rays.push_back(ray);
        ranges.push_back(range);
    }

    vk::DeviceBih bih(context, words);
    vk::DeviceRecords device_records(context, records, element_words<E>());
    vk::ElementKernel kernel(context, spirv);
    const std::vector<ElementHits> device = kernel.hits(bih, device_records, rays, ranges, cfg.max_hits);

    const float tolerance = cfg.tolerance >= 0.0f ? cfg.tolerance : (context.is_cpu() ? 0.0f : 1.0f / 65536.0f);
    auto close = [&](float a, float b) {
        return a == b || std::fabs(a - b) <= tolerance * std::max(1.0f, std::fabs(b));
    };
    std::size_t exact = 0, hits = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const std::vector<bih::ElementHit> expected = bih::brute_force_hits(view, rays[i], ranges[i]);
        std::vector<bih::ElementHit> got;
        for (const shared::SylvaHit& h : device[i].hits)
            got.push_back({h.elem < tree.order.size() ? tree.order[h.elem] : 0xFFFFFFFFu, {h.t0, h.t1}});
        hits += got.size();
        // The kernel orders by entry t, then by record index (the tree's order); the host's
        // queries break ties by element index. Entries must not decrease; ties are then put in
        // element order to compare.
        const bool ordered = std::is_sorted(got.begin(), got.end(), [](const bih::ElementHit& a, const bih::ElementHit& b) {
            return a.t.t0 < b.t.t0;
        });
        r.expect(ordered, "device.order", rays[i], ranges[i], [&] {
            return "the device's hits are not in entry order: " + format_hits(got);
        });
        std::stable_sort(got.begin(), got.end(), bih::hit_before);
        exact += got == expected ? 1 : 0;
        bool same = got.size() == expected.size() && device[i].status == SYLVA_ITER_DONE && !device[i].more;
        for (std::size_t k = 0; same && k < got.size(); ++k)
            same = got[k].element == expected[k].element && close(got[k].t.t0, expected[k].t.t0) &&
                   close(got[k].t.t1, expected[k].t.t1);
        r.expect(same, "device.hits", rays[i], ranges[i], [&] {
            std::string status = device[i].status == SYLVA_ITER_DONE ? "" : " (status error)";
            if (device[i].more) status += " (more than max_hits)";
            return "expected " + format_hits(expected) + "; the device gave " + format_hits(got) + status;
        });
    }
    char tol[32];
    std::snprintf(tol, sizeof tol, "%g", double(tolerance));
    r.notes.push_back("device " + context.describe() + ": " + std::to_string(scene.size()) + " elements, " +
                      std::to_string(rays.size()) + " rays, " + std::to_string(hits) + " hits; " +
                      std::to_string(exact) + " rays bit for bit (tolerance " + tol + ")");
    r.expect(hits > 0, "device.hits", Ray{}, Interval{}, [] { return std::string("no ray hit any element"); });
    return r;
}

}  // namespace sylva::testing

#endif  // SYLVA_TESTING_CONFORMANCE_VULKAN_HPP
