// Transfer functions on Vulkan (lavapipe in CI): float RGBA tables through every volume kernel,
// the GLSL hook (the analytic TF, one shared-subset text with the host's tf_hook) in a
// user kernel of sylva/shared/dvr_main.glsl, kd_dvr_main.glsl (ESS), bih_dvr_main.glsl
// (BIH-DVR, its three modes) and octree_dvr_main.glsl (DVR and iso), and the opacity
// corrections, against the host.
#include <catch2/catch.hpp>
#include "../device_tolerance.hpp"

#include <cstring>

#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/spirv/test_dvr_analytic_tf.h>
#include <sylva/spirv/test_kd_dvr_analytic_tf.h>
#include <sylva/spirv/test_bih_dvr_analytic_tf.h>
#include <sylva/spirv/test_octree_dvr_analytic_tf.h>
#include <sylva/vulkan/kd_volume.hpp>
#include <sylva/vulkan/octree_volume.hpp>
#include <sylva/vulkan/volume.hpp>

#include "dvr_fixtures.hpp"
#include "shaders/analytic_tf.h"

using namespace sylva;
using namespace sylva::dvrtest;

namespace {

std::size_t differing_bits(const Frame& a, const Frame& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        n += (std::memcmp(&a.rgba[i], &b.rgba[i], sizeof(vec4)) != 0 || a.steps[i] != b.steps[i]) ? 1 : 0;
    return n;
}

double summed_alpha(const Frame& f) {
    double s = 0.0;
    for (const vec4& c : f.rgba) s += c.a;
    return s;
}

}  // namespace

TEST_CASE("TFs on Vulkan: float tables, the GLSL hook and the opacity corrections match the host",
          "[parity][vulkan][tf]") {
    vk::Context ctx = vk::Context::create();
    INFO("device " << ctx.describe());
    ThreadPool pool(2);
    volume::Dims dims{24, 20, 18};
    vec3 spacing{1.0f, 1.1f, 1.2f};
    volume::DensityGrid grid = sample_grid(dims, spacing, blobs(vec3(dims) * spacing));
    GridWords gw = GridWords::from(grid);
    vk::DeviceGrid dgrid(ctx, gw);
    vk::Kernel hook_kernel = dgrid.user_kernel(ctx, spirv::test_dvr_analytic_tf);
    VolumeRenderParams base;
    base.width = 40;
    base.height = 32;
    base.camera = Camera::framing(grid.world_box(), vec3(0.5f, 0.35f, 1.0f), 36.0f).frame(base.width, base.height);
    std::vector<float> table;  // 7 entries, float RGBA
    for (int i = 0; i < 7; ++i) {
        float d = float(i) / 6.0f;
        table.insert(table.end(), {0.2f + 0.8f * d, 0.5f, 1.0f - d, d < 0.2f ? 0.0f : 0.35f * d});
    }
    std::vector<std::uint32_t> tf8 = smooth_tf(0.08f, 0.3f);
    std::vector<std::uint32_t> kd = kdtree::encode(kdtree::build_vidal(
        ess_occupancy(ess_codes(grid, 256u, pool), ess_classifier(tf8), pool), kdtree::Config::deep()));
    vk::DeviceKdTree dkd(ctx, kd);
    vk::Kernel kd_hook_kernel = dkd.user_kernel(ctx, dgrid, spirv::test_kd_dvr_analytic_tf);
    auto bih = encode_voxels(grid_cuboids(grid, 0.05f), bih::NodeFormat::Fixed16);
    VoxelBihView view{bih, {}, spacing, grid.world_box()};
    vk::DeviceVoxelBih dbih(ctx, view);
    vk::Kernel bih_hook_kernel = dbih.user_kernel(ctx, spirv::test_bih_dvr_analytic_tf);
    octree::Tree oct = octree::build(grid, pool, {8, 2});
    std::vector<std::uint32_t> oct_words = octree::encode(oct);
    vk::DeviceOctree doct(ctx, OctreeView{oct_words, oct.bricks});
    vk::Kernel oct_hook_kernel = doct.user_kernel(ctx, spirv::test_octree_dvr_analytic_tf);

    for (bool shading : {false, true}) {
        for (OpacityCorrection oc : {OpacityCorrection::Power, OpacityCorrection::None}) {
            VolumeRenderParams p = base;
            p.shading = shading;
            p.opacity = oc;
            p.tf_kind = TfKind::Rgba32f;
            p.tf_rgba32f = table;
            // Shading (specular power) and the power correction use exp2/log2, which lavapipe
            // computes within a few ulps of the host's libm: colours within 5e-5 (as
            // test_dvr_parity.cpp), steps exact. Without either the arithmetic is the same
            // IEEE operations in the same order: bit for bit.
            const bool exact = !shading && oc == OpacityCorrection::None;
            INFO("shading " << shading << " opacity " << static_cast<int>(oc));
            auto check = [&](const char* what, const Frame& host, const Frame& dev) {
                ImageDifference d = compare_frames(host, dev);
                INFO(what << ": max diff " << d.max_abs);
                CHECK(summed_alpha(host) > 10.0);
                const devtol::FrameDiff fd = devtol::compare_frames_on(host, dev);
                devtol::note(ctx, devtol::describe(ctx, fd));
                CHECK(devtol::frames_agree(ctx, fd, 5e-5f));
                if (exact && devtol::exact(ctx)) CHECK(differing_bits(host, dev) == 0);
            };
            check("marcher f32", render_dvr_cpu(gw, p, pool), vk::render_dvr_vulkan(ctx, dgrid, p));
            check("kd f32", render_kd_dvr_cpu(gw, kd, p, pool), vk::render_kd_dvr_vulkan(ctx, dgrid, dkd, p));
            check("octree f32", render_octree_dvr_cpu(OctreeView{oct_words, oct.bricks}, p, pool),
                  vk::render_octree_dvr_vulkan(ctx, doct, p));
            VolumeRenderParams h = p;
            h.tf_kind = TfKind::Hook;
            h.tf_hook = [](float d) { return shared::sylva_tf_user(d); };
            check("marcher hook", render_dvr_cpu(gw, h, pool), vk::render_dvr_vulkan(ctx, dgrid, h, &hook_kernel));
            check("kd hook", render_kd_dvr_cpu(gw, kd, h, pool), vk::render_kd_dvr_vulkan(ctx, dgrid, dkd, h, &kd_hook_kernel));
            for (VolumeMode m : {VolumeMode::BihSingle, VolumeMode::BihMulti}) {
                VolumeRenderParams q = h;
                q.mode = m;
                check("bih hook", render_bih_dvr_cpu(view, q, pool), vk::render_bih_dvr_vulkan(ctx, dbih, q, &bih_hook_kernel));
            }
            check("octree hook", render_octree_dvr_cpu(OctreeView{oct_words, oct.bricks}, h, pool),
                  vk::render_octree_dvr_vulkan(ctx, doct, h, {}, {}, &oct_hook_kernel));
            VolumeRenderParams hv = h;  // the hook's visibility query: the same skipping on both sides
            hv.tf_hook_visible = [](float, float hi) { return hi > 0.1f; };
            check("octree hook, visibility", render_octree_dvr_cpu(OctreeView{oct_words, oct.bricks}, hv, pool),
                  vk::render_octree_dvr_vulkan(ctx, doct, hv, {}, {}, &oct_hook_kernel));
        }
    }
    VolumeRenderParams h = base;
    h.tf_kind = TfKind::Hook;
    h.tf_hook = [](float d) { return shared::sylva_tf_user(d); };
    CHECK_THROWS_WITH(vk::render_dvr_vulkan(ctx, dgrid, h), Catch::Contains("TfKind::Hook runs in your shader"));
    CHECK_THROWS_WITH(vk::render_kd_dvr_vulkan(ctx, dgrid, dkd, h), Catch::Contains("TfKind::Hook runs in your shader"));
    h.mode = VolumeMode::BihSingle;
    CHECK_THROWS_WITH(vk::render_bih_dvr_vulkan(ctx, dbih, h), Catch::Contains("TfKind::Hook runs in your shader"));
    CHECK_THROWS_WITH(vk::render_octree_dvr_vulkan(ctx, doct, h), Catch::Contains("TfKind::Hook runs in your shader"));
    // The iso kernel takes the surface's colour from the hook too (shaded: colours within 5e-5).
    h.iso = 0.5f;
    Frame iso_host = render_octree_iso_cpu(OctreeView{oct_words, oct.bricks}, h, pool);
    Frame iso_dev = vk::render_octree_iso_vulkan(ctx, doct, h, {}, &oct_hook_kernel);
    CHECK(iso_host.steps == iso_dev.steps);
    CHECK(compare_frames(iso_host, iso_dev).max_abs <= 5e-5);
    CHECK(summed_alpha(iso_host) > 10.0);
}
