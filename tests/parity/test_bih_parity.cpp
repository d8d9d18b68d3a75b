// Host vs Vulkan: the shared iterator and particle integrator give the same results.
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <algorithm>
#include <cstring>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/io/particles.hpp>
#include <sylva/vulkan/bih.hpp>

#include "generators.hpp"

using namespace sylva;

namespace {
constexpr std::uint32_t kMaxLeaves = 64;

std::uint32_t bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

/// The host's leaf sequences in the layout of shaders/bih_leaves.comp.
std::vector<std::uint32_t> host_sequences(std::span<const std::uint32_t> words, std::span<const Ray> rays,
                                          std::span<const Interval> ranges) {
    std::size_t stride = 3 + 3 * kMaxLeaves;
    std::vector<std::uint32_t> out(rays.size() * stride, 0u);
    for (std::size_t r = 0; r < rays.size(); ++r) {
        bih::LeafIterator it(words, rays[r], ranges[r]);
        std::uint32_t n = 0;
        std::uint32_t* o = &out[r * stride];
        while (auto leaf = it.next()) {
            if (n < kMaxLeaves) {
                o[3 + 3 * n] = leaf->node;
                o[4 + 3 * n] = bits(leaf->t.t0);
                o[5 + 3 * n] = bits(leaf->t.t1);
            }
            ++n;
        }
        o[0] = n;
        o[1] = it.status();
        o[2] = it.steps();
    }
    return out;
}

/// Rays and ranges: most over [0, inf), some with a finite window.
std::pair<std::vector<Ray>, std::vector<Interval>> rays_for(const Aabb& box, std::size_t n, std::uint32_t seed) {
    auto rays = testing::random_rays(n, box, seed);
    std::vector<Interval> ranges(n);
    for (std::size_t i = 0; i < n; ++i)
        if (i % 7 == 3) ranges[i] = {0.25f, 1.5f};
    return {rays, ranges};
}

template <class E>
void check_sequences(vk::Context& ctx, const std::vector<E>& elems, const bih::Config& bc, const bih::EncodeConfig& ec,
                     std::uint32_t shift) {
    std::span<const E> es(elems);
    bih::Tree t = bih::build(es, bc);
    auto words = bih::encode(t, es, bih::RangePayload{}, ec);
    auto [rays, ranges] = rays_for(t.bounds, 20000, 77);
    vk::DeviceBih dev(ctx, words, shift);
    auto gpu = vk::leaf_sequences(ctx, dev, rays, ranges, kMaxLeaves);
    auto host = host_sequences(words, rays, ranges);
    std::size_t stride = 3 + 3 * kMaxLeaves, differing = 0, leaves = 0;
    const devtol::RecordDiff diff = devtol::compare_records(host, gpu, stride);
    for (std::size_t r = 0; r < rays.size(); ++r) {
        leaves += host[r * stride];
        bool same = std::equal(&host[r * stride], &host[r * stride] + stride, &gpu[r * stride]);
        if (!same && differing < 3) {
            std::string h, g;
            for (std::size_t k = 0; k < std::min<std::size_t>(stride, 12); ++k) {
                h += std::to_string(host[r * stride + k]) + " ";
                g += std::to_string(gpu[r * stride + k]) + " ";
            }
            UNSCOPED_INFO("ray " << r << " o=(" << rays[r].origin.x << "," << rays[r].origin.y << "," << rays[r].origin.z
                                 << ") d=(" << rays[r].direction.x << "," << rays[r].direction.y << ","
                                 << rays[r].direction.z << ")\n host " << h << "\n gpu  " << g);
        }
        differing += !same;
    }
    devtol::note(ctx, devtol::describe(ctx, diff));
    CHECK(devtol::acceptable(ctx, diff));  // on lavapipe: every ray word for word (differing == 0)
    CHECK((!devtol::exact(ctx) || differing == 0));
    CHECK(leaves > rays.size() / 2);
}
}  // namespace

TEST_CASE("GPU leaf sequences equal the host's word for word", "[parity][vulkan]") {
    vk::Context ctx = vk::Context::create();
    INFO("device " << ctx.describe());
    bih::Config trim, inf;
    inf.empty_children = bih::EmptyChildren::Infinite;
    SECTION("random boxes, fixed16, tree chunks") {
        check_sequences(ctx, testing::random_boxes(4000, 1), trim, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2}, 0);
    }
    SECTION("clustered boxes, float32, pre-order, +-inf planes") {
        check_sequences(ctx, testing::clustered_boxes(4000, 2), inf, {bih::NodeFormat::Float32, bih::Layout::PreOrder, 0}, 0);
    }
    SECTION("degenerate boxes, fixed16, pre-order") {
        check_sequences(ctx, testing::degenerate_boxes(3000, 3), trim, {bih::NodeFormat::Fixed16, bih::Layout::PreOrder, 0}, 0);
    }
    SECTION("spheres through four buffer parts of 2^13 words (the >128 MiB path)") {
        auto spheres = testing::random_spheres(3000, 4);
        bih::Tree t = bih::build(std::span<const Sphere>(spheres));
        REQUIRE(SYLVA_BIH_HEADER_WORDS + 2 * t.nodes.size() > 3 * 8192);  // really spans 4 parts
        check_sequences(ctx, spheres, trim, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2}, 13);
    }
}

TEST_CASE("GPU particle images match the host within 1e-5 and visit the same nodes", "[parity][vulkan]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    auto spheres = io::synthetic_galaxy(50000, 5);
    std::span<const Sphere> es(spheres);
    bih::Tree t = bih::build(es, {}, pool);
    for (bool inline_payload : {true, false}) {
        INFO((inline_payload ? "inline payload" : "range payload"));
        auto words = inline_payload ? bih::encode(t, es, ParticlePayload{}) : bih::encode(t, es, bih::RangePayload{});
        auto records = inline_payload ? std::vector<std::uint32_t>{} : pack_particles(es, t.order);
        CameraFrame cam = Camera::framing(t.bounds).frame(160, 120);
        Frame host = render_particles_cpu(words, records, cam, 160, 120, pool);
        vk::DeviceBih dev(ctx, words);
        Frame gpu = vk::render_particles_vulkan(ctx, dev, records, cam, 160, 120);
        {
            // The BIH over three or four buffer parts (each load selects its part; in one part,
            // the default here, loads read part 0 directly): the same frame, bit for bit.
            std::uint32_t shift = 1;
            while ((std::size_t{4} << shift) < words.size()) ++shift;
            REQUIRE(vk::used_parts(words.size(), shift) >= 3u);
            vk::DeviceBih split(ctx, words, shift);
            Frame parts = vk::render_particles_vulkan(ctx, split, records, cam, 160, 120);
            CHECK(parts.steps == gpu.steps);
            CHECK(std::equal(parts.rgba.begin(), parts.rgba.end(), gpu.rgba.begin()));
        }
        float worst = 0.0f, total_alpha = 0.0f;
        for (std::size_t i = 0; i < host.rgba.size(); ++i) {
            for (int k = 0; k < 4; ++k) worst = std::max(worst, std::abs(host.rgba[i][k] - gpu.rgba[i][k]));
            total_alpha += host.rgba[i].a;
        }
        // exp() may differ by a few ulp between the host's libm and lavapipe; everything else
        // is bit-exact, so the step counts (the traversal) must agree exactly. On a GPU
        // (devtol) the colours within its tolerance, a few pixels on another path.
        std::size_t step_diff = 0, first_diff = host.steps.size();
        for (std::size_t i = 0; i < host.steps.size(); ++i)
            if (host.steps[i] != gpu.steps[i] && step_diff++ == 0) first_diff = i;
        INFO("pixels with different steps: " << step_diff << ", first " << first_diff << " host "
             << (first_diff < host.steps.size() ? host.steps[first_diff] : 0) << " gpu "
             << (first_diff < host.steps.size() ? gpu.steps[first_diff] : 0) << "; worst colour difference " << worst);
        if (devtol::exact(ctx)) {
            CHECK(worst <= 1e-5f);
            CHECK(host.steps == gpu.steps);
        } else {
            const devtol::FrameDiff fd = devtol::compare_frames_on(host, gpu);
            devtol::note(ctx, devtol::describe(ctx, fd));
            CHECK(devtol::frames_agree(ctx, fd, 1e-5f));
        }
        CHECK(total_alpha > 100.0f);  // the galaxy is in view
    }
}

namespace {
/// Range payloads claiming another kind, or starting 2^29 records on (e * 8 wraps to the real ones).
template <std::uint32_t Kind, std::uint32_t Offset>
struct ShiftedRange {
    static constexpr std::uint32_t kind = Kind;
    template <Bounded E>
    [[nodiscard]] std::uint64_t encode(std::span<const E> leaf, std::uint32_t first) const {
        return bih::RangePayload{}.encode(leaf, first + Offset);
    }
};
}  // namespace

TEST_CASE("the GPU particle renderer refuses non-particle payload kinds and wrapped record indices",
          "[parity][vulkan][payload-kind]") {
    using Catch::Matchers::Contains;
    vk::Context ctx = vk::Context::create();
    auto spheres = io::synthetic_galaxy(2000, 7);
    std::span<const Sphere> es(spheres);
    bih::Tree t = bih::build(es);
    auto records = pack_particles(es, t.order);
    CameraFrame cam = Camera::framing(t.bounds).frame(32, 24);
    auto voxel = bih::encode(t, es, ShiftedRange<SYLVA_PAYLOAD_VOXEL, 0>{});
    vk::DeviceBih vdev(ctx, voxel);
    CHECK_THROWS_WITH(vk::render_particles_vulkan(ctx, vdev, records, cam, 32, 24), Contains("payload kind 2"));

    // Ranges 2^29 records on: every ray that reaches a leaf ends with an error on both targets.
    auto far = bih::encode(t, es, ShiftedRange<SYLVA_PAYLOAD_RANGE, (1u << 29)>{});
    SerialExecutor serial;
    Frame host = render_particles_cpu(far, records, cam, 32, 24, serial);
    vk::DeviceBih fdev(ctx, far);
    Frame gpu = vk::render_particles_vulkan(ctx, fdev, records, cam, 32, 24);
    CHECK(host.steps == gpu.steps);
    std::size_t errors = 0;
    for (std::size_t i = 0; i < gpu.steps.size(); ++i) {
        errors += gpu.steps[i] == 0xFFFFFFFFu;
        CHECK(gpu.rgba[i].a == 0.0f);
    }
    CHECK(errors > 20);  // the rays that reach a leaf (72 of 768 here)
}

TEST_CASE("one vk::ParticleKernel renders frames over BIHs that change, as render_particles_vulkan does",
          "[parity][vulkan][particle-kernel]") {
    using Catch::Matchers::Contains;
    vk::Context ctx = vk::Context::create();
    vk::ParticleKernel kernel(ctx);
    // Three "frames": two BIHs in different depth buckets (vk::stack_entries_for: depth ~14 ->
    // 16 entries, ~27 -> 32; a different pipeline each), then the first again (its kept
    // pipeline); each frame's BIH and records uploaded anew, as sylva-render --animate does.
    auto small = io::synthetic_galaxy(40, 11), large = io::synthetic_galaxy(6000, 12);
    std::vector<std::uint32_t> depths;
    for (const std::vector<Sphere>* spheres : {&small, &large, &small}) {
        std::span<const Sphere> es(*spheres);
        bih::Tree t = bih::build(es);
        auto words = bih::encode(t, es, bih::RangePayload{});
        auto records = pack_particles(es, t.order);
        CameraFrame cam = Camera::framing(t.bounds).frame(48, 36);
        vk::DeviceBih dev(ctx, words);
        depths.push_back(dev.constants()[1]);
        vk::Buffer recs(ctx, records.size() * 4);
        recs.upload(records);
        Frame kept = kernel.render(dev, recs, cam, 48, 36);
        Frame fresh = vk::render_particles_vulkan(ctx, dev, records, cam, 48, 36);
        CHECK(kept.steps == fresh.steps);
        CHECK(std::memcmp(kept.rgba.data(), fresh.rgba.data(), kept.rgba.size() * sizeof(vec4)) == 0);
        float alpha = 0.0f;
        for (const vec4& p : kept.rgba) alpha += p.a;
        CHECK(alpha > 10.0f);
    }
    CHECK(depths[0] != depths[1]);  // the two BIHs really need two pipelines
    auto spheres = io::synthetic_galaxy(200, 13);
    std::span<const Sphere> es(spheres);
    bih::Tree t = bih::build(es);
    vk::DeviceBih dev(ctx, bih::encode(t, es, bih::RangePayload{}));
    vk::Buffer odd(ctx, 7 * 4);  // not a whole 8-word record
    CHECK_THROWS_WITH(kernel.render(dev, odd, Camera::framing(t.bounds).frame(8, 8), 8, 8),
                      Contains("vk::ParticleKernel::render") && Contains("not a whole number of 8-word"));
}
