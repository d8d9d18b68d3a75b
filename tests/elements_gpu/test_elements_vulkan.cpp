// elements_gpu.vulkan.*: the generic element kernel on a Vulkan device (lavapipe in CI) against
// the host's shared kernel: hit sequences (record, t0 bits, t1 bits), statuses and steps equal
// word for word; images within 2e-6 per channel (the element media composite 1 - exp(-tau),
// and exp is not exact in Vulkan: docs/DESIGN.md, parity rules), steps equal.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>

#include <sylva/spirv/elements_rbf.h>
#include <sylva/spirv/elements_sphere.h>
#include <sylva/spirv/test_elements_capsule.h>
#include <sylva/spirv/test_elements_capsule_kd.h>
#include <sylva/spirv/test_elements_capsule_octree.h>
#include <sylva/vulkan/elements.hpp>

#include "../device_tolerance.hpp"
#include "scenes.hpp"

using namespace sylva;
using namespace elements_gpu;

namespace {
float max_channel_diff(vec4 a, vec4 b) {
    vec4 d = glm::abs(a - b);
    return std::max(std::max(d.x, d.y), std::max(d.z, d.w));
}

constexpr float kImageTolerance = 2e-6f;

/// Hit sequences agree: the same elements in the same order, distances bit for bit on lavapipe
/// and within devtol::kGpuHitRelative on a GPU.
bool hits_agree(const vk::Context& ctx, const std::vector<shared::SylvaHit>& dev, const std::vector<shared::SylvaHit>& host) {
    if (devtol::exact(ctx)) return same_hits(dev, host);
    if (dev.size() != host.size()) return false;
    for (std::size_t i = 0; i < dev.size(); ++i)
        if (dev[i].elem != host[i].elem || !devtol::distance_agrees(ctx, host[i].t0, dev[i].t0) ||
            !devtol::distance_agrees(ctx, host[i].t1, dev[i].t1))
            return false;
    return true;
}

/// Pixels whose steps differ (with `steps_may_grow`: fewer on the device; a ray resumed after a
/// pause walks its index again) or whose colour differs by more than the device's tolerance for
/// `tolerance`; reports the first.
std::size_t differing_pixels(const vk::Context& ctx, const Frame& host, const Frame& dev, float tolerance,
                             bool steps_may_grow = false) {
    const float tol = devtol::colour_tolerance(ctx, tolerance);
    std::size_t bad = 0;
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        const bool steps_ok = steps_may_grow ? dev.steps[i] >= host.steps[i] : dev.steps[i] == host.steps[i];
        const float d = max_channel_diff(dev.rgba[i], host.rgba[i]);
        if (steps_ok && d <= tol) continue;
        if (bad++ == 0)
            UNSCOPED_INFO("pixel " << i << ": steps " << host.steps[i] << " / " << dev.steps[i] << ", colour difference " << d
                                   << " (tolerance " << tol << ")");
    }
    devtol::note(ctx, std::to_string(bad) + " of " + std::to_string(host.rgba.size()) + " pixels differ (tolerance " +
                          std::to_string(tol) + ")");
    return bad;
}

template <class E, class I = BihIndex, class S>
void check_hits(vk::Context& ctx, std::span<const std::uint32_t> spirv, const S& s, std::uint32_t seed) {
    std::vector<Ray> rs;
    std::vector<Interval> ranges;
    rays(600, seed, rs, ranges);
    std::conditional_t<std::is_same_v<I, BihIndex>, vk::DeviceBih, vk::DeviceElementIndex> bih(ctx, s.words);
    vk::DeviceRecords recs(ctx, s.records, element_words<E>());
    vk::ElementKernel kernel(ctx, spirv);
    for (std::uint32_t max_hits : {1u, 200u}) {
        auto dev = kernel.hits(bih, recs, rs, ranges, max_hits);
        REQUIRE(dev.size() == rs.size());
        std::size_t total = 0, diverging = 0;
        for (std::size_t i = 0; i < rs.size(); ++i) {
            auto host = element_hits_cpu<E, I>(s.words, s.records, rs[i], ranges[i], max_hits);
            INFO("ray " << i << " max_hits " << max_hits);
            if (devtol::exact(ctx)) {
                CHECK(dev[i].status == host.status);
                CHECK(dev[i].passes == host.passes);
                CHECK(dev[i].more == host.more);
                if (!host.more) CHECK(dev[i].steps == host.steps);  // stopping early stops both at the same node
                CHECK(same_hits(dev[i].hits, host.hits));
            } else {  // a GPU: a few rays may take another path (devtol)
                diverging += dev[i].status != host.status || dev[i].passes != host.passes || dev[i].more != host.more ||
                             (!host.more && dev[i].steps != host.steps) || !hits_agree(ctx, dev[i].hits, host.hits);
            }
            if (max_hits == 200u) CHECK(same_hits(host.hits, brute_hits<E>(s.records, s.count(), rs[i], ranges[i])));
            total += host.hits.size();
        }
        devtol::note(ctx, std::to_string(diverging) + " of " + std::to_string(rs.size()) + " rays diverge on " +
                              ctx.device_name() + " (allowed " + std::to_string(devtol::allowed_diverging(ctx, rs.size())) + ")");
        CHECK(diverging <= devtol::allowed_diverging(ctx, rs.size()));
        CHECK(total > (max_hits == 1u ? rs.size() / 3 : rs.size()));
    }
}

template <class E>
void check_image(vk::Context& ctx, std::span<const std::uint32_t> spirv, const Scene<E>& s, std::size_t& exact,
                 std::size_t& pixels, float& max_diff) {
    const std::uint32_t w = 64, h = 48;
    CameraFrame cam = view(w, h);
    SerialExecutor exec;
    vk::DeviceBih bih(ctx, s.words);
    vk::DeviceRecords recs(ctx, s.records, element_words<E>());
    vk::ElementKernel kernel(ctx, spirv);
    Frame host = render_elements_cpu<E>(s.words, s.records, cam, w, h, exec);
    Frame dev = kernel.render(bih, recs, cam, w, h);
    std::size_t lit = 0;
    CHECK(differing_pixels(ctx, host, dev, kImageTolerance) <= devtol::allowed_diverging(ctx, host.rgba.size()));
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        float d = max_channel_diff(dev.rgba[i], host.rgba[i]);
        max_diff = std::max(max_diff, d);
        exact += dev.rgba[i] == host.rgba[i] ? 1 : 0;
        lit += host.rgba[i].a > 0.1f ? 1 : 0;
    }
    pixels += host.rgba.size();
    CHECK(lit > host.rgba.size() / 10);
}
}  // namespace

TEST_CASE("vulkan: capsule hit sequences equal the host's word for word", "[elements][vulkan]") {
    vk::Context ctx = vk::Context::create();
    check_hits<demo::Capsule>(ctx, spirv::test_elements_capsule, Scene<demo::Capsule>(capsules(3000, 61)), 62);
    check_hits<demo::Capsule>(ctx, spirv::test_elements_capsule,
                              Scene<demo::Capsule>(capsules(3000, 63, 0.8f, 0.02f), bih::Config::for_queries()), 64);
}

TEST_CASE("vulkan: capsules over the kd-tree and the octree: hit sequences equal the host's", "[elements][vulkan]") {
    vk::Context ctx = vk::Context::create();
    check_hits<demo::Capsule, KdIndex>(ctx, spirv::test_elements_capsule_kd,
                                       IndexScene<demo::Capsule, KdIndex>(capsules(3000, 65)), 66);
    check_hits<demo::Capsule, OctreeIndex>(ctx, spirv::test_elements_capsule_octree,
                                           IndexScene<demo::Capsule, OctreeIndex>(capsules(3000, 67)), 68);
}

TEST_CASE("vulkan: Sphere and GaussianRbf hit sequences equal the host's word for word", "[elements][vulkan]") {
    vk::Context ctx = vk::Context::create();
    check_hits<Sphere>(ctx, spirv::elements_sphere, Scene<Sphere>(spheres(3000, 71)), 72);
    check_hits<GaussianRbf>(ctx, spirv::elements_rbf, Scene<GaussianRbf>(rbfs(3000, 73), bih::Config::for_queries()), 74);
}

TEST_CASE("vulkan: element images equal the host's within 2e-6", "[elements][vulkan]") {
    vk::Context ctx = vk::Context::create();
    std::size_t exact = 0, pixels = 0;
    float max_diff = 0.0f;
    check_image(ctx, spirv::test_elements_capsule, Scene<demo::Capsule>(capsules(2000, 81)), exact, pixels, max_diff);
    check_image(ctx, spirv::elements_sphere, Scene<Sphere>(spheres(2000, 82)), exact, pixels, max_diff);
    check_image(ctx, spirv::elements_rbf, Scene<GaussianRbf>(rbfs(4000, 83)), exact, pixels, max_diff);
    WARN("bit-identical pixels " << exact << " of " << pixels << ", largest channel difference " << max_diff);
}

TEST_CASE("vulkan: rays past the loop budget pause and later dispatches resume them: the same image", "[elements][vulkan]") {
    // The budget that keeps lavapipe's loop limiter away (vk::kCpuDeviceLoopBudget) pauses only
    // the heaviest rays of large scenes; a small one pauses most rays of this one, several
    // times. The colours equal those of one dispatch bit for bit and the host's within the
    // image tolerance; a resumed ray's steps count its extra index walks.
    auto ps = spheres(1500, 301);
    for (int i = 0; i < 150; ++i)
        ps.push_back(Sphere{vec3(0.5f + 0.0004f * float(i % 5), 0.5f, 0.5f), 0.12f, vec4(0.8f, 0.4f, 0.2f, 0.02f), 1.0f});
    Scene<Sphere> s(ps);
    const std::uint32_t w = 64, h = 48;
    CameraFrame cam = view(w, h);
    SerialExecutor exec;
    vk::Context ctx = vk::Context::create();
    vk::DeviceBih bih(ctx, s.words);
    vk::DeviceRecords recs(ctx, s.records, element_words<Sphere>());
    vk::ElementKernel kernel(ctx, spirv::elements_sphere);
    Frame host = render_elements_cpu<Sphere>(s.words, s.records, cam, w, h, exec);
    kernel.set_loop_budget(0xFFFFFFFFu);
    Frame whole = kernel.render(bih, recs, cam, w, h);
    CHECK(kernel.resumes() == 0u);
    kernel.set_loop_budget(300);
    Frame paused = kernel.render(bih, recs, cam, w, h);
    CHECK(kernel.resumes() > 2u);
    std::size_t resumed = 0;
    CHECK(differing_pixels(ctx, host, whole, kImageTolerance) <= devtol::allowed_diverging(ctx, host.rgba.size()));
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        INFO("pixel " << i);
        REQUIRE(std::memcmp(&paused.rgba[i], &whole.rgba[i], sizeof(vec4)) == 0);  // the same device: bit for bit
        REQUIRE(paused.steps[i] != 0xFFFFFFFFu);
        CHECK(paused.steps[i] >= whole.steps[i]);
        resumed += paused.steps[i] > whole.steps[i];
    }
    CHECK(resumed > host.rgba.size() / 10);
    kernel.set_loop_budget(0);
    CHECK(kernel.loop_budget() == (ctx.is_cpu() ? vk::kCpuDeviceLoopBudget : 0xFFFFFFFFu));
    WARN(resumed << " of " << host.rgba.size() << " rays resumed, " << kernel.resumes() << " dispatches after the first");
}

TEST_CASE("vulkan: rays past lavapipe's loop limiter are run again in later dispatches, never lost or drawn short",
          "[elements][vulkan]") {
    // 2,500 coincident spheres among random ones, no early termination: a ray through the
    // cluster composites all 2,500 over about 40 passes of the hit window, hundreds of thousands
    // of loop iterations. With the device's budget every pixel equals the host's; with no
    // budget, on lavapipe, rays the limiter cuts are run again until they run out of cuts and
    // are marked: a marked pixel, never a wrong colour.
    auto ps = spheres(400, 311);
    for (int i = 0; i < 2500; ++i) ps.push_back(Sphere{vec3(0.5f), 0.1f, vec4(0.9f, 0.5f, 0.2f, 0.001f), 1.0f});
    Scene<Sphere> s(ps);
    const std::uint32_t w = 32, h = 24;
    CameraFrame cam = view(w, h);
    ParticleRenderConfig rc;
    rc.alpha_stop = 2.0f;
    SerialExecutor exec;
    vk::Context ctx = vk::Context::create();
    vk::DeviceBih bih(ctx, s.words);
    vk::DeviceRecords recs(ctx, s.records, element_words<Sphere>());
    vk::ElementKernel kernel(ctx, spirv::elements_sphere);
    Frame host = render_elements_cpu<Sphere>(s.words, s.records, cam, w, h, exec, rc);
    Frame dev = kernel.render(bih, recs, cam, w, h, rc);
    std::size_t through = 0;
    CHECK(differing_pixels(ctx, host, dev, kImageTolerance, true) <= devtol::allowed_diverging(ctx, host.rgba.size()));
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        INFO("pixel " << i << ", host steps " << host.steps[i]);
        REQUIRE(host.steps[i] != 0xFFFFFFFFu);
        REQUIRE(dev.steps[i] != 0xFFFFFFFFu);
        through += host.rgba[i].a > 0.9f;  // 2,500 x 0.001 of opacity and more
    }
    CHECK(through > 4u);
    std::uint32_t resumes = kernel.resumes();
    if (ctx.is_cpu()) CHECK(resumes > 0u);
    kernel.set_loop_budget(0xFFFFFFFFu);
    Frame unlimited = kernel.render(bih, recs, cam, w, h, rc);
    std::size_t marked = 0, wrong = 0;
    const float tol = devtol::colour_tolerance(ctx, kImageTolerance);
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        if (unlimited.steps[i] == 0xFFFFFFFFu) {
            ++marked;
            continue;
        }
        wrong += max_channel_diff(unlimited.rgba[i], host.rgba[i]) > tol;
    }
    CHECK(wrong <= (devtol::exact(ctx) ? 0 : devtol::allowed_diverging(ctx, host.rgba.size())));
    if (ctx.is_cpu()) CHECK(marked > 0u);  // the limiter is real; a real GPU has none
    WARN("cluster of 2,500: " << resumes << " dispatches after the first with the budget; without it, " << marked
                              << " pixels marked on " << ctx.device_name());
}

TEST_CASE("vulkan: the element kernel refuses a BIH that holds no record ranges", "[elements][vulkan]") {
    vk::Context ctx = vk::Context::create();
    auto ss = spheres(50, 91);
    bih::Tree t = bih::build(std::span<const Sphere>(ss));
    auto words = bih::encode(t, std::span<const Sphere>(ss), ParticlePayload{});
    auto rec = pack_elements(std::span<const Sphere>(ss));
    vk::DeviceBih bih(ctx, words);
    vk::DeviceRecords recs(ctx, rec, element_words<Sphere>());
    vk::ElementKernel kernel(ctx, spirv::elements_sphere);
    CHECK_THROWS_WITH(kernel.render(bih, recs, view(8, 8), 8, 8), Catch::Contains("not record ranges"));
    CHECK_THROWS_WITH(vk::DeviceRecords(ctx, std::vector<std::uint32_t>(7), 8), Catch::Contains("whole number"));
}

TEST_CASE("vulkan: 70,000 coincident capsules: the device equals the host or marks the ray, never short", "[elements][vulkan]") {
    std::vector<demo::Capsule> cs(70000);
    for (auto& c : cs) {
        c.a = vec3(0.2f, 0.5f, 0.5f);
        c.b = vec3(0.8f, 0.5f, 0.5f);
        c.radius = 0.1f;
    }
    Scene<demo::Capsule> s(cs);
    std::vector<Ray> rs{{{0.0f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}}, {{0.0f, 0.9f, 0.5f}, {1.0f, 0.0f, 0.0f}}};
    std::vector<Interval> ranges(2);
    vk::Context ctx = vk::Context::create();
    vk::DeviceBih bih(ctx, s.words);
    vk::DeviceRecords recs(ctx, s.records, element_words<demo::Capsule>());
    vk::ElementKernel kernel(ctx, spirv::test_elements_capsule);
    auto dev = kernel.hits(bih, recs, rs, ranges, 1);
    auto host = element_hits_cpu<demo::Capsule>(s.words, s.records, rs[0], ranges[0], 1);
    REQUIRE(host.hits.size() == 1u);
    CHECK(host.more);
    // Equal to the host, or marked as an error with no hit: never a different first hit.
    if (dev[0].status == SYLVA_ITER_ERROR) CHECK(dev[0].hits.empty());
    else CHECK(hits_agree(ctx, dev[0].hits, host.hits));
    WARN("70,000 tests in one call on " << ctx.device_name() << ": status " << dev[0].status);
    CHECK(dev[1].hits.empty());  // the miss is unaffected
    CHECK(dev[1].status == SYLVA_ITER_DONE);
}

TEST_CASE("vulkan: without transcendentals (opaque capsules: tau = +inf, no exp) images are bit-identical",
          "[elements][vulkan]") {
    auto cs = capsules(2000, 85);
    for (auto& c : cs) c.extinction = std::numeric_limits<float>::infinity();
    Scene<demo::Capsule> s(cs);
    const std::uint32_t w = 64, h = 48;
    CameraFrame cam = view(w, h);
    SerialExecutor exec;
    vk::Context ctx = vk::Context::create();
    vk::DeviceBih bih(ctx, s.words);
    vk::DeviceRecords recs(ctx, s.records, element_words<demo::Capsule>());
    vk::ElementKernel kernel(ctx, spirv::test_elements_capsule);
    Frame host = render_elements_cpu<demo::Capsule>(s.words, s.records, cam, w, h, exec);
    Frame dev = kernel.render(bih, recs, cam, w, h);
    std::size_t covered = 0, same = 0;
    for (std::size_t i = 0; i < host.rgba.size(); ++i) {
        same += std::memcmp(&host.rgba[i], &dev.rgba[i], sizeof(vec4)) == 0 ? 1 : 0;
        covered += host.rgba[i].a == 1.0f ? 1 : 0;
        CHECK(dev.steps[i] == host.steps[i]);
    }
    CHECK(same == host.rgba.size());
    CHECK(covered > host.rgba.size() / 4);
}
