// The GPU half of the user-element check, built against the installed package's sylva::vulkan:
// the user's capsule (capsule.h, the one definition) traced through an encoded BIH on the
// device by the user's own shader (capsule_first_hit.comp, compiled by the installed
// sylva_add_spirv), compared ray by ray with the host's sylva::bih queries over the same
// capsules. Set SYLVA_VULKAN_DEVICE=cpu for lavapipe.
//
// Tolerance: capsule.h uses + - * / and sqrt only. Vulkan does not require sqrt or division to
// be correctly rounded (docs/DESIGN.md, parity rules), so entry and exit t may differ by a few
// ulps; the element hit and the number of capsules hit must be equal, except on rays where the
// host's two nearest entries are within that tolerance of each other (reported, not failed).
#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/payload.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/spirv/capsule_first_hit.h>
#include <sylva/vulkan/bih.hpp>
#include <sylva/vulkan/runner.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <span>
#include <vector>

#include "capsule.hpp"

namespace {

/// Relative tolerance on entry and exit t: 2^-18, about 32 ulps of float.
constexpr float kTolerance = 1.0f / 262144.0f;

bool close(float a, float b) { return std::fabs(a - b) <= kTolerance * std::max(1.0f, std::fabs(b)); }

std::vector<sylva::Ray> camera_rays(int width, int height) {
    std::vector<sylva::Ray> rays;
    const sylva::vec3 eye(0.5f, 0.45f, -1.2f);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            const sylva::vec3 target((static_cast<float>(x) + 0.5f) / static_cast<float>(width),
                                     (static_cast<float>(y) + 0.5f) / static_cast<float>(height), 0.5f);
            rays.push_back({eye, target - eye});
        }
    }
    return rays;
}

int run() {
    const std::vector<consumer::Capsule> capsules = consumer::make_capsules(20000);
    const std::span<const consumer::Capsule> view(capsules);
    const sylva::bih::Tree tree = sylva::bih::build(view);
    const std::vector<std::uint32_t> words = sylva::bih::encode(tree, view, sylva::bih::RangePayload{});
    const std::vector<sylva::Ray> rays = camera_rays(96, 96);

    sylva::vk::Context context = sylva::vk::Context::create();
    std::printf("sylva_consumer_gpu: device %s\n", context.describe().c_str());
    sylva::vk::DeviceBih bih(context, words);  // the encoding, split over bindings 0-3
    sylva::vk::Buffer records = sylva::vk::upload_buffer(context, consumer::pack_capsules(view, tree.order));
    sylva::vk::Buffer order = sylva::vk::upload_buffer(context, tree.order);
    std::vector<float> ray_floats;
    for (const sylva::Ray& r : rays) {
        const std::array<float, 8> f{r.origin.x,    r.origin.y,    r.origin.z, r.direction.x,
                                     r.direction.y, r.direction.z, 0.0f,       INFINITY};
        ray_floats.insert(ray_floats.end(), f.begin(), f.end());
    }
    sylva::vk::Buffer ray_buffer = sylva::vk::upload_buffer(context, ray_floats);
    sylva::vk::Buffer out(context, rays.size() * 5 * sizeof(std::uint32_t));

    sylva::vk::Bindings bindings;
    bindings.add(*bih.part(0)).add(*bih.part(1)).add(*bih.part(2)).add(*bih.part(3));
    bindings.add(records).add(order).add(ray_buffer).add(out);
    sylva::vk::Kernel kernel(context, sylva::spirv::capsule_first_hit, bindings.size(), 12, bih.constants());
    const struct {
        std::uint32_t ray_count, word_count, element_count;
    } push{static_cast<std::uint32_t>(rays.size()), bih.word_count(), static_cast<std::uint32_t>(capsules.size())};
    context.dispatch(kernel, bindings.list(), &push, sizeof push, sylva::vk::groups_for(rays.size(), 64));
    const std::vector<std::uint32_t> device = out.download_words();

    std::size_t hit = 0, exact = 0, near_ties = 0, wrong = 0;
    std::vector<sylva::bih::ElementHit> all;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        sylva::bih::all_hits(words, tree, view, rays[i], all);
        const std::uint32_t* d = &device[i * 5];
        float d0, d1;
        std::memcpy(&d0, &d[1], 4);
        std::memcpy(&d1, &d[2], 4);
        bool ok = d[4] == 0 && d[3] == all.size();
        bool same = ok;
        if (all.empty()) {
            ok = ok && d[0] == 0xFFFFFFFFu;
            same = ok;
        } else {
            ++hit;
            const sylva::bih::ElementHit& h = all.front();
            same = ok && d[0] == h.element && d0 == h.t.t0 && d1 == h.t.t1;
            const bool tie = all.size() > 1 && close(all[1].t.t0, h.t.t0);
            if (d[0] != h.element && tie && ok) {
                ++near_ties;
                continue;
            }
            ok = ok && d[0] == h.element && close(d0, h.t.t0) && close(d1, h.t.t1);
        }
        exact += same ? 1 : 0;
        if (!ok) {
            if (++wrong <= 5) {
                std::fprintf(stderr,
                             "sylva_consumer_gpu: ray %zu (origin %g %g %g, direction %g %g %g): host first %d "
                             "[%.9g, %.9g] of %zu hits, device %d [%.9g, %.9g] of %u (status %u)\n",
                             i, rays[i].origin.x, rays[i].origin.y, rays[i].origin.z, rays[i].direction.x,
                             rays[i].direction.y, rays[i].direction.z,
                             all.empty() ? -1 : static_cast<int>(all.front().element),
                             all.empty() ? 0.0 : double(all.front().t.t0), all.empty() ? 0.0 : double(all.front().t.t1),
                             all.size(), static_cast<int>(d[0]), double(d0), double(d1), d[3], d[4]);
            }
        }
    }
    std::printf("sylva_consumer_gpu: %zu rays, %zu hit capsules; %zu bit-exact, %zu near ties, %zu wrong\n",
                rays.size(), hit, exact, near_ties, wrong);
    if (hit < rays.size() / 4) {
        std::fprintf(stderr, "sylva_consumer_gpu: FAILED: too few rays hit the scene (%zu)\n", hit);
        return 1;
    }
    if (wrong != 0) {
        std::fprintf(stderr, "sylva_consumer_gpu: FAILED: %zu rays differ between host and device\n", wrong);
        return 1;
    }
    std::puts("sylva_consumer_gpu: OK");
    return 0;
}

}  // namespace

int main() {
    try {
        return run();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sylva_consumer_gpu: FAILED: %s\n", e.what());
        return 1;
    }
}
