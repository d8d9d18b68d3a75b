// Host vs Vulkan (lavapipe in CI): the same cameras through the marcher, single-sample,
// multi-sample and iso BIH-DVR give the same images and the same traversal steps.
#include <catch2/catch.hpp>

#include <cmath>

#include <sylva/bih/query.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/vulkan/volume.hpp>

#include "../device_tolerance.hpp"
#include "dvr_fixtures.hpp"

using namespace sylva;
using namespace sylva::dvrtest;

namespace {

/// The smallest split shift that still spreads `words` over more than one part (at most 4).
std::uint32_t spanning_shift(std::size_t words) {
    std::uint32_t shift = 1;
    while ((std::size_t{4} << shift) < words) ++shift;
    return shift;
}

struct Case {
    std::string name;
    Frame host, gpu;
    bool dense = false;  ///< early ray termination cuts most rays
};

/// Compares one host/GPU pair. exp2/log2 may differ by a few ulp between the host's libm and
/// lavapipe, everything else is bit-exact, so colours agree within 5e-5 (measured <= 1.4e-5)
/// and PSNR >= 100 dB, and the step counts exactly. Where those ulps flip early ray
/// termination one sample more or less past alpha_stop = 0.99 weighs at most
/// (1 - 0.99) * alpha', so there the tolerance is 1e-3 (measured 2.7e-4) and up to 0.5% of
/// the pixels may take one step more or less: only pixels that terminated early on one side
/// (measured: none with a dense TF; 1 of the 16 early-terminated pixels of the marcher case
/// once the blend order changed to NanoVDB's); every other pixel takes the same steps.
void check_pair(const Case& c) {
    ImageDifference d = compare_frames(c.host, c.gpu);
    std::size_t step_diff = 0, step_diff_open = 0;
    for (std::size_t i = 0; i < c.host.steps.size(); ++i) {
        if (c.host.steps[i] == c.gpu.steps[i]) continue;
        ++step_diff;
        step_diff_open += (c.host.rgba[i].a >= 0.99f || c.gpu.rgba[i].a >= 0.99f) ? 0 : 1;
    }
    double visible = 0.0;
    std::size_t terminated = 0;
    for (const vec4& px : c.host.rgba) {
        visible += px.a;
        terminated += px.a >= 0.99f ? 1 : 0;
    }
    INFO(c.name << ": max diff " << d.max_abs << ", PSNR " << d.psnr << " dB, pixels with other steps " << step_diff
                << ", summed alpha " << visible << ", pixels terminated early " << terminated);
    CHECK(d.max_abs <= ((c.dense || step_diff > 0) ? 1e-3 : 5e-5));
    CHECK(d.psnr >= 100.0);
    CHECK(step_diff_open == 0);
    CHECK(step_diff <= c.host.steps.size() / 200);
    if (c.dense) CHECK(terminated > c.host.rgba.size() / 10);
    CHECK(visible > 100.0);
}

}  // namespace

TEST_CASE("Volume renderers on Vulkan match the host", "[parity][vulkan]") {
    vk::Context ctx = vk::Context::create();
    INFO("device " << ctx.describe());
    ThreadPool pool(2);
    volume::Dims dims{32, 30, 28};
    vec3 spacing{1.0f, 1.1f, 1.2f};
    volume::DensityGrid grid = sample_grid(dims, spacing, blobs(vec3(dims) * spacing));
    GridWords gw = GridWords::from(grid);
    auto bih = encode_voxels(grid_cuboids(grid, 0.05f), bih::NodeFormat::Fixed16);
    auto ranges = NodeRanges(bih, spacing).words();
    VoxelBihView view{bih, ranges, spacing, grid.world_box()};
    // Small parts so that all four bindings of each split buffer are really used.
    vk::DeviceGrid dgrid(ctx, gw, spanning_shift(gw.words.size()));
    vk::DeviceVoxelBih dbih(ctx, view, spanning_shift(bih.size()), spanning_shift(ranges.size()));

    std::vector<Case> cases;
    for (vec3 from : {vec3(0.5f, 0.35f, 1.0f), vec3(-0.8f, -0.2f, -0.4f)}) {
        VolumeRenderParams p;
        p.camera = Camera::framing(grid.world_box(), from, 36.0f).frame(64, 64);
        p.width = p.height = 64;
        p.tf = smooth_tf(0.08f, 0.3f);
        p.light = vec3(0.2f, 1.0f, 0.4f);
        for (int variant = 0; variant < 3; ++variant) {
            p.shading = variant == 1;
            // Variant 2: a dense TF, so that early ray termination cuts most rays short.
            p.tf = variant == 2 ? smooth_tf(0.08f, 1.0f) : smooth_tf(0.08f, 0.3f);
            p.unit = variant == 2 ? 0.25f : 1.0f;
            std::string tag = std::string(variant == 1 ? "shaded" : (variant == 2 ? "dense" : "unshaded")) + " from " +
                              std::to_string(from.x);
            p.mode = VolumeMode::DvrReference;
            bool dense = variant == 2;
            cases.push_back({"marcher " + tag, render_dvr_cpu(gw, p, pool), vk::render_dvr_vulkan(ctx, dgrid, p), dense});
            p.mode = VolumeMode::BihSingle;
            cases.push_back(
                {"single " + tag, render_bih_dvr_cpu(view, p, pool), vk::render_bih_dvr_vulkan(ctx, dbih, p), dense});
            p.mode = VolumeMode::BihMulti;
            cases.push_back(
                {"multi " + tag, render_bih_dvr_cpu(view, p, pool), vk::render_bih_dvr_vulkan(ctx, dbih, p), dense});
        }
        p.mode = VolumeMode::BihIso;
        p.tf = smooth_tf(0.08f, 0.3f);
        p.unit = 1.0f;
        p.shading = true;
        p.iso = 0.4f;
        for (bool cull : {false, true}) {
            p.iso_culling = cull;
            cases.push_back({std::string("iso ") + (cull ? "culled" : "plain"), render_bih_dvr_cpu(view, p, pool),
                             vk::render_bih_dvr_vulkan(ctx, dbih, p)});
        }
    }
    // The default split (everything in part 0: the shaders' fast path without part selection).
    vk::DeviceGrid dgrid1(ctx, gw);
    vk::DeviceVoxelBih dbih1(ctx, view);
    REQUIRE(dgrid1.constants()[1] == 1u);
    REQUIRE(dbih1.constants()[3] == 1u);
    VolumeRenderParams p;
    p.camera = Camera::framing(grid.world_box()).frame(64, 64);
    p.width = p.height = 64;
    p.tf = smooth_tf(0.08f, 0.3f);
    cases.push_back({"marcher, one part", render_dvr_cpu(gw, p, pool), vk::render_dvr_vulkan(ctx, dgrid1, p)});
    p.mode = VolumeMode::BihMulti;
    cases.push_back({"multi, one part", render_bih_dvr_cpu(view, p, pool), vk::render_bih_dvr_vulkan(ctx, dbih1, p)});
    p.mode = VolumeMode::BihIso;
    p.iso_culling = true;
    cases.push_back({"iso culled, one part", render_bih_dvr_cpu(view, p, pool), vk::render_bih_dvr_vulkan(ctx, dbih1, p)});
    for (const Case& c : cases) check_pair(c);
}

TEST_CASE("Vulkan volume renderers refuse bad input like the host", "[parity][vulkan]") {
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid grid = sample_grid({8, 8, 8}, vec3(1.0f), blobs(vec3(8.0f)));
    GridWords gw = GridWords::from(grid);
    auto bih = encode_voxels(grid_cuboids(grid, 0.05f), bih::NodeFormat::Fixed16);
    vk::DeviceGrid dgrid(ctx, gw);
    VolumeRenderParams p;
    p.camera = Camera::framing(grid.world_box()).frame(8, 8);
    p.width = p.height = 8;
    CHECK_THROWS_AS(vk::render_dvr_vulkan(ctx, dgrid, p), Error);  // no TF
    p.tf = smooth_tf(0.05f, 0.5f);
    std::vector<std::uint32_t> wrong(5, 0u);
    CHECK_THROWS_AS(vk::DeviceVoxelBih(ctx, VoxelBihView{bih, wrong, vec3(1.0f), {}}), Error);
    vk::DeviceVoxelBih dbih(ctx, VoxelBihView{bih, {}, vec3(1.0f), {}});
    p.mode = VolumeMode::BihIso;
    p.iso_culling = true;  // no ranges uploaded
    CHECK_THROWS_AS(vk::render_bih_dvr_vulkan(ctx, dbih, p), Error);
    p.iso_culling = false;
    Frame f = vk::render_bih_dvr_vulkan(ctx, dbih, p);
    CHECK(f.rgba.size() == 64);
}

TEST_CASE("Voxel BIH leaf sequences on Vulkan (bih_leaves.comp) equal the host's", "[parity][vulkan]") {
    // bih_leaves.comp does not look at payloads, so it serves voxel trees as they are.
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid grid = sample_grid({20, 18, 16}, vec3(1.0f, 1.0f, 1.5f), blobs(vec3(20.0f, 18.0f, 24.0f)));
    for (bih::NodeFormat fmt : {bih::NodeFormat::Fixed16, bih::NodeFormat::Float32}) {
        auto words = encode_voxels(grid_cuboids(grid, 0.05f), fmt);
        auto rays = rays_into(grid.world_box(), 3000, 17);
        std::vector<Interval> ranges(rays.size());
        const std::uint32_t max_leaves = 48;
        vk::DeviceBih dev(ctx, words);
        auto gpu = vk::leaf_sequences(ctx, dev, rays, ranges, max_leaves);
        std::size_t stride = 3 + 3 * std::size_t{max_leaves}, differing = 0, leaves = 0;
        std::vector<std::uint32_t> all_host;
        for (std::size_t r = 0; r < rays.size(); ++r) {
            bih::LeafIterator it(words, rays[r]);
            std::vector<std::uint32_t> host(stride, 0u);
            std::uint32_t n = 0;
            while (auto leaf = it.next()) {
                if (n < max_leaves) {
                    host[3 + 3 * n] = leaf->node;
                    host[4 + 3 * n] = std::bit_cast<std::uint32_t>(leaf->t.t0);
                    host[5 + 3 * n] = std::bit_cast<std::uint32_t>(leaf->t.t1);
                }
                ++n;
            }
            host[0] = n;
            host[1] = it.status();
            host[2] = it.steps();
            leaves += n;
            differing += std::equal(host.begin(), host.end(), gpu.begin() + std::ptrdiff_t(r * stride)) ? 0 : 1;
            all_host.insert(all_host.end(), host.begin(), host.end());
        }
        const devtol::RecordDiff diff = devtol::compare_records(all_host, gpu, stride);
        devtol::note(ctx, devtol::describe(ctx, diff));
        CHECK((devtol::exact(ctx) ? differing == 0 : devtol::acceptable(ctx, diff)));
        CHECK(leaves > rays.size() * 5);
    }
}
