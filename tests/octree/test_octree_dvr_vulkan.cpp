// The octree DVR renderer on Vulkan (lavapipe in CI; sylva/vulkan/octree_volume.hpp,
// shaders/octree_dvr.comp) against the host renderer: the same lattice samples per pixel and
// colours within 1e-5 (exp2/log2 differ by a few ulp between targets), with the bricks in one
// part and split over four, for the full-resolution cut and a coarser one; and against the
// device's own reference marcher.
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <cmath>

#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/lod_error.hpp>
#include <sylva/octree/octants.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/vulkan/loop_limit.hpp>
#include <sylva/vulkan/octree_volume.hpp>
#include <sylva/vulkan/volume.hpp>

#include "frames.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {
/// Host and device frames agree: steps equal and colours within `tolerance` on lavapipe,
/// devtol's limits on a GPU.
bool frames_agree_here(const vk::Context& ctx, const Frame& host, const Frame& device, float tolerance) {
    const devtol::FrameDiff d = devtol::compare_frames_on(host, device);
    devtol::note(ctx, devtol::describe(ctx, d));
    return devtol::frames_agree(ctx, d, tolerance);
}
}  // namespace


TEST_CASE("vulkan: octree DVR on the device equals the host renderer", "[parity][dvr]") {
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid g = blobs({45, 38, 52}, 41, vec3(1.0f, 1.0f, 1.4f));
    octree::Tree t = octree::build(g, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p;
    p.width = 48;
    p.height = 40;
    p.camera = Camera::framing(g.world_box(), {0.5f, 0.4f, 1.0f}, 35.0f).frame(p.width, p.height);
    p.tf.resize(256);
    for (std::uint32_t i = 0; i < 256; ++i)
        p.tf[i] = (60 + i * 3 / 4) | ((230 - i / 2) << 8) | (100u << 16) | ((i < 90 ? 0u : (i - 90) / 2) << 24);
    ThreadPool pool(2);
    std::size_t lit = 0;
    // Clamped edges, and a constant border the TF shows on the faces (1: they blend up to
    // (v + 1) / 2, above the TF's threshold 90 / 255).
    for (GridBorder border : {GridBorder::clamp(), GridBorder::constant(1.0f)}) {
        vk::DeviceGrid grid(ctx, GridWords::from(g, border));
        for (bool shading : {false, true}) {
            p.shading = shading;
            Frame marcher = vk::render_dvr_vulkan(ctx, grid, p);
            for (std::uint32_t shift : {0u, 17u}) {  // 17: the bricks over four parts
                for (std::uint32_t max_level : {0xFFFFFFFFu, 1u}) {
                    OctreeView view{words, t.bricks, max_level, {}, {}, border};
                    vk::DeviceOctree dev(ctx, view, shift);
                    Frame host = render_octree_dvr_cpu(view, p, pool);
                    Frame device = vk::render_octree_dvr_vulkan(ctx, dev, p);
                    INFO("border " << int(border.mode) << " shading " << shading << " shift " << shift << " max level "
                                   << max_level);
                    CHECK(frames_agree_here(ctx, host, device, 1e-5f));
                    if (max_level == 0xFFFFFFFFu) CHECK(max_diff(marcher, device) < 1e-5);
                    for (const vec4& c : device.rgba) lit += c.w > 0.05f ? 1 : 0;
                }
            }
        }
    }
    CHECK(lit > 16 * std::size_t{p.width} * p.height / 20);  // the 16 images are not empty (~8% lit)
    REQUIRE(t.bricks.size() > 3 * (std::size_t{1} << 17));  // the split really uses several parts

    // Octant masks (octree/octants.hpp): the device skips the same octants as the host, so the
    // samples are equal per pixel and fewer than without masks; the image is the unmasked one.
    std::vector<std::uint32_t> masks = octree::octant_masks(octree::octant_ranges(words, t.bricks, pool), tf_opacity_prefix(p.tf));
    std::size_t partial = std::count_if(masks.begin(), masks.end(), [](std::uint32_t m) { return m != 0u && m != 255u; });
    CHECK(partial > 0);
    for (bool shading : {false, true}) {
        p.shading = shading;
        GridBorder border = shading ? GridBorder::constant(1.0f) : GridBorder::clamp();  // face octants kept
        OctreeView view{words, t.bricks, 0xFFFFFFFFu, {}, masks, border};
        vk::DeviceOctree dev(ctx, view, 17u);
        Frame host = render_octree_dvr_cpu(view, p, pool);
        Frame device = vk::render_octree_dvr_vulkan(ctx, dev, p, {}, masks);
        Frame plain = vk::render_octree_dvr_vulkan(ctx, dev, p);
        INFO("masked, shading " << shading << " border " << int(border.mode));
        CHECK(frames_agree_here(ctx, host, device, 1e-5f));
        CHECK(max_diff(plain, device) == 0.0);
        std::uint64_t masked_samples = 0, plain_samples = 0;
        for (std::size_t i = 0; i < device.steps.size(); ++i) {
            masked_samples += device.steps[i];
            plain_samples += plain.steps[i];
        }
        CHECK(masked_samples < plain_samples);
    }
}

TEST_CASE("vulkan: unorm8 and unorm16 bricks on the device equal the host", "[parity][dvr][iso][formats]") {
    vk::Context ctx = vk::Context::create();
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({45, 38, 52}, 44, vec3(1.0f, 1.0f, 1.4f));
    VolumeRenderParams p;
    p.width = 48;
    p.height = 40;
    p.camera = Camera::framing(g.world_box(), {0.5f, 0.4f, 1.0f}, 35.0f).frame(p.width, p.height);
    p.tf.resize(256);
    for (std::uint32_t i = 0; i < 256; ++i)
        p.tf[i] = (60 + i * 3 / 4) | ((230 - i / 2) << 8) | (100u << 16) | ((i < 90 ? 0u : (i - 90) / 2) << 24);
    p.iso = 0.5f;
    std::size_t lit = 0;
    for (octree::BrickFormat format : {octree::BrickFormat::Unorm8, octree::BrickFormat::Unorm16}) {
        octree::Tree t = octree::build(g, pool, {8, 2, format});
        std::vector<std::uint32_t> words = octree::encode(t);
        // Bricks over several parts: 2^15 words a part for unorm8's 110 k words, 2^16 for unorm16's 220 k.
        const std::uint32_t split = format == octree::BrickFormat::Unorm8 ? 15u : 16u;
        for (std::uint32_t shift : {0u, split}) {
            OctreeView view{words, t.bricks};
            vk::DeviceOctree dev(ctx, view, shift);
            for (bool iso : {false, true}) {
                p.shading = iso;
                Frame host = iso ? render_octree_iso_cpu(view, p, pool) : render_octree_dvr_cpu(view, p, pool);
                Frame device = iso ? vk::render_octree_iso_vulkan(ctx, dev, p) : vk::render_octree_dvr_vulkan(ctx, dev, p);
                INFO("format " << static_cast<int>(format) << " shift " << shift << " iso " << iso);
                CHECK(frames_agree_here(ctx, host, device, 1e-5f));
                for (const vec4& c : device.rgba) lit += c.w > 0.05f ? 1 : 0;
            }
        }
        REQUIRE(t.bricks.size() > 2 * (std::size_t{1} << split));
    }
    CHECK(lit > 8 * std::size_t{p.width} * p.height / 20);
}

TEST_CASE("vulkan: a corrupted octree is refused on upload or marks its rays", "[parity][dvr][errors]") {
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid g = blobs({20, 20, 20}, 42);
    octree::Tree t = octree::build(g, {4, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    std::vector<std::uint32_t> bad = words;
    bad[0] = 0;
    CHECK_THROWS_AS(vk::DeviceOctree(ctx, OctreeView{bad, t.bricks}), Error);
    bad = words;
    for (std::size_t n = 0; n < t.nodes.size(); ++n) bad[SYLVA_OCT_HEADER_WORDS + 16 * n + 4] = std::uint32_t(n);
    vk::DeviceOctree dev(ctx, OctreeView{bad, t.bricks});
    VolumeRenderParams p;
    p.width = p.height = 16;
    p.camera = Camera::framing(g.world_box(), {0.3f, 0.5f, 1.0f}, 35.0f).frame(p.width, p.height);
    p.tf = std::vector<std::uint32_t>(256, 0x20808080u);
    Frame f = vk::render_octree_dvr_vulkan(ctx, dev, p);
    SerialExecutor serial;
    Frame host = render_octree_dvr_cpu(OctreeView{bad, t.bricks}, p, serial);
    CHECK(std::count(f.steps.begin(), f.steps.end(), 0xFFFFFFFFu) > 0);
    CHECK(f.steps == host.steps);
}

TEST_CASE("vulkan: octree iso and view-dependent cuts on the device equal the host", "[parity][iso][cut]") {
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid g = blobs({45, 38, 52}, 43, vec3(1.0f, 1.0f, 1.4f));
    octree::Tree t = octree::build(g, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p;
    p.width = 48;
    p.height = 40;
    p.camera = Camera::framing(g.world_box(), {0.5f, 0.4f, 1.0f}, 35.0f).frame(p.width, p.height);
    p.tf.resize(256);
    for (std::uint32_t i = 0; i < 256; ++i)
        p.tf[i] = (60 + i * 3 / 4) | ((230 - i / 2) << 8) | (100u << 16) | ((i < 90 ? 0u : (i - 90) / 2) << 24);
    p.iso = 0.5f;
    p.shading = true;
    ThreadPool pool(2);
    vk::DeviceOctree dev(ctx, OctreeView{words, t.bricks});
    std::size_t hits = 0, coarse_leaves = 0;
    for (float lod : {0.0f, 1.0f, 4.0f}) {  // 0: no cut (the full resolution)
        for (bool iso : {false, true}) {
            std::vector<std::uint32_t> w = words;
            if (lod > 0.0f) {
                octree::Cut c = select_octree_cut(w, p, {lod, 0xFFFFFFFFu}, iso);
                octree::apply_cut(w, c);
                for (std::size_t n = 0; n < t.nodes.size(); ++n)
                    coarse_leaves += (c.state[n] == octree::CutState::Leaf && !t.nodes[n].leaf()) ? 1 : 0;
            }
            dev.set_index(w);
            OctreeView view{w, t.bricks};
            Frame host = iso ? render_octree_iso_cpu(view, p, pool) : render_octree_dvr_cpu(view, p, pool);
            Frame device = iso ? vk::render_octree_iso_vulkan(ctx, dev, p) : vk::render_octree_dvr_vulkan(ctx, dev, p);
            INFO("lod " << lod << " iso " << iso);
            CHECK(frames_agree_here(ctx, host, device, 1e-5f));
            if (iso)
                for (std::size_t i = 0; i < host.rgba.size(); ++i) {
                    CHECK((devtol::exact(ctx) || host.steps[i] != device.steps[i] ||
                           host.rgba[i].w == device.rgba[i].w));  // the same hits (on a GPU where the walk agrees)
                    hits += host.rgba[i].w == 1.0f ? 1 : 0;
                }
        }
    }
    CHECK(hits > 3 * std::size_t{p.width} * p.height / 20);  // ~8% of each iso image hits
    CHECK(coarse_leaves > 20);  // the cuts stop above the octree's leaves
    {  // The transfer-function-aware cut (octree/lod_error.hpp): refines more; the device agrees.
        octree::LodDeviation deviation = octree::lod_deviation(words, t.bricks, pool);
        octree::Cut plain = select_octree_cut(words, p, {4.0f, 0xFFFFFFFFu, 1.0f}, false);
        octree::Cut aware = select_octree_cut(words, p, {4.0f, 0xFFFFFFFFu, 1.0f / 64.0f}, false, {}, &deviation);
        CHECK(aware.nodes > plain.nodes);
        std::vector<std::uint32_t> w = words;
        octree::apply_cut(w, aware);
        dev.set_index(w);
        Frame host = render_octree_dvr_cpu(OctreeView{w, t.bricks}, p, pool);
        Frame device = vk::render_octree_dvr_vulkan(ctx, dev, p);
        CHECK(frames_agree_here(ctx, host, device, 1e-5f));
    }
    // A constant border of 1 puts a surface on the faces (samples there blend up to (v + 1) / 2):
    // set_border changes the device's later renders; hits equal the host's.
    dev.set_index(words);
    dev.set_border(GridBorder::constant(1.0f));
    Frame host = render_octree_iso_cpu(OctreeView{.words = words, .bricks = t.bricks, .border = GridBorder::constant(1.0f)}, p, pool);
    Frame device = vk::render_octree_iso_vulkan(ctx, dev, p);
    CHECK(frames_agree_here(ctx, host, device, 1e-5f));
    std::size_t face_hits = 0;
    for (const vec4& c : device.rgba) face_hits += c.w == 1.0f ? 1 : 0;
    CHECK(face_hits > 2 * hits / 5);  // more than a third of the three iso images' hits together
    CHECK_THROWS_WITH(dev.set_border(GridBorder::constant(INFINITY)), Catch::Contains("not finite"));
    std::vector<std::uint32_t> other = words;
    other.pop_back();
    CHECK_THROWS_AS(dev.set_index(other), Error);
}

/// Lavapipe's loop limiter: some of the host's rays need over 65,535 samples; where the device
/// cuts loops (vk::loops_limited: lavapipe 22.3) some device pixels are marked (steps
/// 0xFFFFFFFF), elsewhere none, and every unmarked pixel is the whole ray: the same steps, and
/// an opacity within 1e-4 plus 1e-7 a sample. The octree DVR's opacity is not bit-exact on
/// lavapipe (README: within 5.6e-5 at the usual sampling); over the same rays both lavapipe 22.3
/// and 25 differ from the host by 5.3e-8 a sample at most (a throw-away probe at 1,191, 59,548
/// and 178,644 samples: 6.4e-5, 3.2e-3 and 9.5e-3), while a ray cut short would lose steps.
void check_limiter_marks(vk::Context& ctx, const Frame& host, const Frame& device) {
    std::size_t past_limit = 0, marked = 0, differing = 0;
    std::uint32_t worst_apart = 0;
    for (std::size_t i = 0; i < host.steps.size(); ++i) {
        if (host.steps[i] > 65535u) ++past_limit;
        if (device.steps[i] == 0xFFFFFFFFu) {
            ++marked;
            continue;
        }
        INFO("pixel " << i);
        if (devtol::exact(ctx)) {
            CHECK(device.steps[i] == host.steps[i]);  // an unmarked pixel is the whole ray
            CHECK(std::abs(device.rgba[i].w - host.rgba[i].w) < 1e-4f + 1e-7f * static_cast<float>(host.steps[i]));
        } else {  // a GPU: within devtol's limits (a 120,000-sample ray meets many brick faces)
            const std::uint32_t apart = std::max(device.steps[i], host.steps[i]) - std::min(device.steps[i], host.steps[i]);
            differing += apart > devtol::step_slack(host.steps[i]) ||
                         std::abs(device.rgba[i].w - host.rgba[i].w) > devtol::colour_tolerance(ctx, 1e-4f);
            worst_apart = std::max(worst_apart, apart);
        }
    }
    devtol::note(ctx, std::to_string(differing) + " of " + std::to_string(host.steps.size()) + " unmarked pixels differ; steps at most " +
                          std::to_string(worst_apart) + " apart, " + std::to_string(marked) + " marked");
    CHECK(differing <= (devtol::exact(ctx) ? 0 : devtol::allowed_diverging(ctx, host.steps.size())));
    INFO(past_limit << " rays need over 65,535 samples; " << marked << " marked on the device");
    CHECK(past_limit > 0);
    if (vk::loops_limited(ctx)) {
        CHECK(marked > 0);  // lavapipe up to Mesa 22.3: the rays past its limiter
    } else {
        CHECK(marked == 0);  // no loop limiter (a GPU, lavapipe 25): every ray whole (the H200: none marked)
    }
}

TEST_CASE("vulkan: a DVR ray past lavapipe's loop limiter is marked an error, never drawn short", "[parity][dvr][errors]") {
    // A lattice 400x finer than the default: about 120,000 samples a ray through the middle, past
    // the 65,535 loop iterations lavapipe allows an invocation (a real GPU has no such limit).
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid g = blobs({24, 24, 24}, 43);
    octree::Tree t = octree::build(g, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p;
    p.width = p.height = 12;
    p.camera = Camera::framing(g.world_box(), {0.3f, 0.4f, 1.0f}, 35.0f).frame(p.width, p.height);
    p.tf = std::vector<std::uint32_t>(256, 0x01808080u);  // faint everywhere: no early termination
    p.dt = 24.0f / 1024.0f / 400.0f;
    p.alpha_stop = 0.99f;
    OctreeView view{words, t.bricks};
    vk::DeviceOctree dev(ctx, view);
    SerialExecutor serial;
    Frame host = render_octree_dvr_cpu(view, p, serial);
    Frame device = vk::render_octree_dvr_vulkan(ctx, dev, p);
    check_limiter_marks(ctx, host, device);
}

TEST_CASE("vulkan: an iso ray past lavapipe's loop limiter is marked an error, never drawn as a miss", "[parity][iso][errors]") {
    // The iso walk never ends RUNNING on the host; a ray whose first hit lies more than 65,535
    // lattice samples in (a lattice 400x finer than the default), or that misses after as many,
    // is cut by lavapipe's limiter and must come back marked, not as a miss or a wrong hit.
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid g = blobs({24, 24, 24}, 43);
    octree::Tree t = octree::build(g, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p;
    p.width = p.height = 12;
    p.camera = Camera::framing(g.world_box(), {0.3f, 0.4f, 1.0f}, 35.0f).frame(p.width, p.height);
    p.tf = std::vector<std::uint32_t>(256, 0xFF808080u);
    p.dt = 24.0f / 1024.0f / 400.0f;
    p.iso = 0.9f;
    OctreeView view{words, t.bricks};
    vk::DeviceOctree dev(ctx, view);
    SerialExecutor serial;
    Frame host = render_octree_iso_cpu(view, p, serial);
    Frame device = vk::render_octree_iso_vulkan(ctx, dev, p);
    check_limiter_marks(ctx, host, device);
}
