// The out-of-core working set driving the Vulkan renderer (lavapipe in CI): a device brick pool
// (vk::DeviceBrickPool over a DeviceOctree's storage buffers) filled slot by slot, the frame index
// uploaded each frame, the shader's visibility feedback read back. In lockstep with the host
// renderer over the same frames: the same working sets, the same feedback words, the same lattice
// samples per pixel and colours within 1e-5 (exp2/log2 differ by a few ulp between targets,
// tests/octree/test_octree_dvr_vulkan.cpp), but for a pixel or two whose opacity ends within
// those ulp of alpha_stop (one sample more or less; 1 of 1280 pixels in one of the 40 frames).
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <sylva/vulkan/octree_volume.hpp>

#include "scene.hpp"

using namespace sylva;
using namespace residency_test;

TEST_CASE("vulkan: progressive out-of-core frames equal the host's, feedback word for word", "[residency][vulkan]") {
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid g = octree_test::blobs({48, 40, 44}, 21);
    octree::Tree t = octree::build(g, {8, 2});
    octree::TreeBrickSource src(t);
    ThreadPool exec(2);
    VolumeRenderParams p = params_for(g, {0.4f, 0.5f, 1.0f}, 40, 32);
    for (std::uint32_t i = 0; i < 256; ++i) p.tf[i] = (p.tf[i] & 0x00FFFFFFu) | ((i < 100 ? 0u : 160u) << 24);
    octree::ResidencyConfig cfg;
    cfg.lod_pixels = 0.4f;
    cfg.max_uploads_per_frame = 12;
    cfg.device_budget_bytes = std::size_t{t.brick_words()} * 4 * 60;  // replacement happens
    const std::uint32_t slots = octree::pool_slots(src.index(), cfg);
    octree::HostBrickPool host_pool(slots, t.brick_words());
    std::vector<std::uint32_t> words0(src.index().begin(), src.index().end());
    words0[7] = slots;
    vk::DeviceOctree dev(ctx, words0, std::size_t{slots} * t.brick_words(), 15);  // pool split over parts
    vk::DeviceBrickPool dev_pool{&dev, t.brick_words()};
    octree::Residency host(src, host_pool, cfg);
    octree::Residency device(src, dev_pool, cfg);
    OctreeTerminal term(src.index(), p, false);
    Frame hf, df;
    std::size_t lit = 0;
    for (int frame = 0; frame < 40; ++frame) {
        float a = 0.05f * float(frame);
        p.camera = Camera::framing(g.world_box(), {0.4f + a, 0.5f, 1.0f - a}, 35.0f).frame(p.width, p.height);
        octree::CutView v = octree::cut_view(p.camera, p.width, p.height);
        const octree::ResidencyFrame& h = host.update(v, term);
        hf = render_octree_dvr_cpu(OctreeView{h.words, host_pool.words, 0xFFFFFFFFu, host.feedback()}, p, exec);
        const octree::ResidencyFrame& d = device.update(v, term);
        dev.set_index(d.words);
        df = vk::render_octree_dvr_vulkan(ctx, dev, p, device.feedback());
        INFO("frame " << frame);
        REQUIRE(h.cut.state == d.cut.state);
        REQUIRE(std::equal(host.feedback().begin(), host.feedback().end(), device.feedback().begin()));
        // Early ray termination compares the accumulated opacity with alpha_stop: where it lands
        // within the transcendentals' few ulp of it, one target takes one more sample. Those
        // pixels (at most a few) are compared within one sample's opacity; the rest exactly.
        std::size_t near_stop = 0;
        double m = 0.0;
        for (std::size_t i = 0; i < hf.steps.size(); ++i) {
            double dm = 0.0;
            for (int c = 0; c < 4; ++c) dm = std::max(dm, double(std::abs(hf.rgba[i][c] - df.rgba[i][c])));
            if (hf.steps[i] != df.steps[i]) {
                ++near_stop;
                REQUIRE(std::abs(hf.rgba[i].w - p.alpha_stop) + std::abs(df.rgba[i].w - p.alpha_stop) < 0.01);
                REQUIRE(std::max(hf.steps[i], df.steps[i]) - std::min(hf.steps[i], df.steps[i]) == 1u);
                REQUIRE(dm < 0.01);
            } else {
                m = std::max(m, dm);
            }
        }
        REQUIRE(near_stop <= hf.steps.size() / 200);
        REQUIRE(m < devtol::colour_tolerance(ctx, 1e-5f));  // exp / exp2 / log2 on a GPU: devtol
        host.wait_loads();
        device.wait_loads();
    }
    for (const vec4& c : df.rgba) lit += c.w > 0.05f ? 1 : 0;
    CHECK(lit > hf.rgba.size() / 20);  // the last image is not empty (95 of 1280 pixels lit)
    CHECK(device.counters().device_evicted > 0);
    CHECK(device.frame().cut.deepest >= 2);
}
