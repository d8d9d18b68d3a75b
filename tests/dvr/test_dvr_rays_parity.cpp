// The caller's rays on Vulkan (lavapipe in CI): the device's orthographic and pinhole
// generators make the host's rays (a device image from the host-generated ray buffer equals the
// device's own generator bit for bit), and every volume renderer's orthographic image equals the
// host's (steps exact, colours within the transcendentals' ulps).
#include <catch2/catch.hpp>
#include "../device_tolerance.hpp"

#include <cstring>

#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/vulkan/iso.hpp>
#include <sylva/vulkan/kd_volume.hpp>
#include <sylva/vulkan/octree_volume.hpp>
#include <sylva/vulkan/volume.hpp>

#include "dvr_fixtures.hpp"

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

TEST_CASE("Rays on Vulkan: ortho and pinhole generators equal the host's ray sets; images match the host",
          "[parity][vulkan][rays]") {
    vk::Context ctx = vk::Context::create();
    INFO("device " << ctx.describe());
    ThreadPool pool(2);
    volume::Dims dims{24, 20, 18};
    vec3 spacing{1.0f, 1.1f, 1.2f};
    volume::DensityGrid grid = sample_grid(dims, spacing, blobs(vec3(dims) * spacing));
    GridWords gw = GridWords::from(grid);
    auto bih = encode_voxels(grid_cuboids(grid, 0.05f), bih::NodeFormat::Fixed16);
    VoxelBihView view{bih, {}, spacing, grid.world_box()};
    std::vector<std::uint32_t> tf = smooth_tf(0.08f, 0.3f);
    std::vector<std::uint32_t> kd = kdtree::encode(kdtree::build_vidal(
        ess_occupancy(ess_codes(grid, static_cast<std::uint32_t>(tf.size()), pool), ess_classifier(tf), pool),
        kdtree::Config::deep()));
    octree::Tree oct = octree::build(grid, pool, {8, 2});
    std::vector<std::uint32_t> oct_words = octree::encode(oct);
    std::vector<std::uint32_t> ikd_words = ikd::encode(ikd::build(grid));
    vk::DeviceGrid dgrid(ctx, gw);
    vk::DeviceVoxelBih dbih(ctx, view);
    vk::DeviceKdTree dkd(ctx, kd);
    vk::DeviceOctree doct(ctx, OctreeView{oct_words, oct.bricks});
    vk::DeviceIso diso(ctx, ikd_words, gw);

    const std::uint32_t W = 40, H = 32;
    Camera cam = Camera::framing(grid.world_box(), vec3(0.5f, 0.35f, 1.0f), 36.0f);
    for (RaySource source : {RaySource::Pinhole, RaySource::Ortho}) {
        VolumeRenderParams p;
        p.width = W;
        p.height = H;
        p.camera = source == RaySource::Ortho ? cam.ortho_frame(W, H, 0.5f * glm::length(grid.world_box().extent()))
                                              : cam.frame(W, H);
        p.rays.source = source;
        p.tf = tf;
        p.light = vec3(0.2f, 1.0f, 0.4f);
        p.shading = true;
        VolumeRenderParams pb = p;
        pb.rays = PixelRays::from_buffer(ray_buffer(p.camera, p.rays, W, H));
        INFO("source " << static_cast<int>(source));
        // Device generator vs the host's rays uploaded: bit for bit (the same rays, the same
        // shader). Device vs host: steps exact, colours within 5e-5 (exp2/log2 of the opacity
        // correction and the specular power differ by a few ulps; test_dvr_parity.cpp).
        auto check = [&](const char* what, const Frame& host, const Frame& dev, const Frame& dev_buf) {
            ImageDifference d = compare_frames(host, dev);
            INFO(what << ": max diff " << d.max_abs);
            CHECK(summed_alpha(host) > 10.0);
            if (devtol::exact(ctx)) {
                CHECK(differing_bits(dev, dev_buf) == 0);
                CHECK(host.steps == dev.steps);
                CHECK(d.max_abs <= 5e-5);
            } else {  // a GPU: its generator's rays are the host's within a few ulp (devtol)
                const devtol::FrameDiff gen = devtol::compare_frames_on(dev_buf, dev), dh = devtol::compare_frames_on(host, dev);
                devtol::note(ctx, "generator against ray buffer: " + devtol::describe(ctx, gen) + "; against the host " +
                                      devtol::describe(ctx, dh));
                CHECK(devtol::frames_agree(ctx, gen, 0.0f));
                CHECK(devtol::frames_agree(ctx, dh, 5e-5f));
            }
        };
        check("marcher", render_dvr_cpu(gw, p, pool), vk::render_dvr_vulkan(ctx, dgrid, p),
              vk::render_dvr_vulkan(ctx, dgrid, pb));
        for (VolumeMode m : {VolumeMode::BihSingle, VolumeMode::BihMulti, VolumeMode::BihIso}) {
            VolumeRenderParams q = p, qb = pb;
            q.mode = qb.mode = m;
            check("bih", render_bih_dvr_cpu(view, q, pool), vk::render_bih_dvr_vulkan(ctx, dbih, q),
                  vk::render_bih_dvr_vulkan(ctx, dbih, qb));
        }
        check("kd", render_kd_dvr_cpu(gw, kd, p, pool), vk::render_kd_dvr_vulkan(ctx, dgrid, dkd, p),
              vk::render_kd_dvr_vulkan(ctx, dgrid, dkd, pb));
        check("octree", render_octree_dvr_cpu(OctreeView{oct_words, oct.bricks}, p, pool),
              vk::render_octree_dvr_vulkan(ctx, doct, p), vk::render_octree_dvr_vulkan(ctx, doct, pb));

        IsoRenderParams ip;
        ip.width = W;
        ip.height = H;
        ip.camera = p.camera;
        ip.rays.source = source;
        IsoRenderParams ib = ip;
        ib.rays = pb.rays;
        check("iso", render_iso_cpu(ikd_words, gw, ip, pool), diso.render(ctx, ip), diso.render(ctx, ib));
    }
}
