// Host vs Vulkan (lavapipe in CI): the shared octree DVR integrator (shaders/octree_dvr.comp)
// gives the same samples, leaves and statuses exactly, and colours within the tolerance of the
// transcendentals (exp2/log2 of the opacity correction and shading differ by a few ulp between
// targets: docs/DESIGN.md), for the full-resolution cut and a coarser one, shaded and not.
#include <catch2/catch.hpp>

#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/spirv/test_octree_dvr.h>
#include <sylva/vulkan/runner.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

struct DvrPush {
    std::uint32_t ray_count, max_level;
};

std::vector<std::uint32_t> ramp_tf() {
    std::vector<std::uint32_t> tf(256);
    for (std::uint32_t i = 0; i < 256; ++i) {
        std::uint32_t a = i < 80 ? 0u : (i - 80) * 90 / 175;
        tf[i] = (60 + i * 3 / 4) | ((230 - i / 2) << 8) | (100u << 16) | (a << 24);
    }
    return tf;
}

}  // namespace

TEST_CASE("parity: octree DVR renders the same rays on the host and on Vulkan", "[parity][dvr]") {
    vk::Context ctx = vk::Context::create();
    volume::DensityGrid g = blobs({45, 33, 60}, 31, vec3(1.0f, 1.0f, 0.5f));
    octree::Tree t = octree::build(g, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    std::size_t compared = 0, lit = 0;
    for (bool shading : {false, true})
        for (std::uint32_t max_level : {0xFFFFFFFFu, 1u}) {
            VolumeRenderParams p;
            p.width = p.height = 40;
            p.camera = Camera::framing(g.world_box(), {0.3f, 0.6f, 1.0f}, 35.0f).frame(p.width, p.height);
            p.tf = ramp_tf();
            p.shading = shading;
            std::vector<std::uint32_t> params = octree_dvr_params(OctreeView{words, t.bricks}, p);
            std::vector<std::uint32_t> tfsum = tf_opacity_prefix(p.tf);
            std::vector<std::uint32_t> rays;
            for (std::uint32_t y = 0; y < p.height; ++y)
                for (std::uint32_t x = 0; x < p.width; ++x) {
                    Ray r = p.camera.ray(x, y, p.width, p.height);
                    for (float f : {r.origin.x, r.origin.y, r.origin.z, r.direction.x, r.direction.y, r.direction.z})
                        rays.push_back(std::bit_cast<std::uint32_t>(f));
                }
            std::size_t n = rays.size() / 6;
            // Host.
            shared::Words ow{words.data(), words.size()}, bw{t.bricks.data(), t.bricks.size()}, tw{p.tf.data(), p.tf.size()},
                sw{tfsum.data(), tfsum.size()}, pw{params.data(), params.size()};
            shared::SylvaDvrParams sp = shared::sylva_dvr_params(pw);
            shared::SylvaOctHeader h = shared::sylva_oct_read_header(ow, std::uint32_t(words.size()), std::uint32_t(t.bricks.size()));
            std::vector<std::uint32_t> host(7 * n);
            for (std::size_t r = 0; r < n; ++r) {
                vec3 o(std::bit_cast<float>(rays[6 * r]), std::bit_cast<float>(rays[6 * r + 1]), std::bit_cast<float>(rays[6 * r + 2]));
                vec3 d(std::bit_cast<float>(rays[6 * r + 3]), std::bit_cast<float>(rays[6 * r + 4]),
                       std::bit_cast<float>(rays[6 * r + 5]));
                std::uint32_t steps, visits, status;
                vec4 c = shared::sylva_oct_dvr_ray(ow, bw, tw, sw, sp, h, max_level, o, d, 0.0f, shared::sylva_inf(), steps,
                                                   visits, status);
                for (int k = 0; k < 4; ++k) host[7 * r + k] = std::bit_cast<std::uint32_t>(c[k]);
                host[7 * r + 4] = steps;
                host[7 * r + 5] = visits;
                host[7 * r + 6] = status;
            }
            // Device.
            vk::Buffer ib(ctx, words.size() * 4), bb(ctx, t.bricks.size() * 4), tb(ctx, p.tf.size() * 4),
                sb(ctx, tfsum.size() * 4), pb(ctx, params.size() * 4), rb(ctx, rays.size() * 4), out(ctx, host.size() * 4);
            ib.upload(words);
            bb.upload(t.bricks);
            tb.upload(p.tf);
            sb.upload(tfsum);
            pb.upload(params);
            rb.upload(rays);
            vk::Kernel kernel(ctx, spirv::test_octree_dvr, 7, sizeof(DvrPush));
            std::array<vk::Buffer*, 7> bind{&ib, &bb, &tb, &sb, &pb, &rb, &out};
            DvrPush push{std::uint32_t(n), max_level};
            ctx.dispatch(kernel, bind, &push, sizeof push, vk::groups_for(n, 64));
            std::vector<std::uint32_t> dev(host.size());
            out.download(dev);
            std::size_t count_mismatch = 0;
            double worst = 0.0;
            for (std::size_t r = 0; r < n; ++r) {
                for (int k = 4; k < 7; ++k) count_mismatch += host[7 * r + k] != dev[7 * r + k] ? 1 : 0;
                for (int k = 0; k < 4; ++k)
                    worst = std::max(worst, double(std::abs(std::bit_cast<float>(host[7 * r + k]) - std::bit_cast<float>(dev[7 * r + k]))));
                CHECK(host[7 * r + 6] != SYLVA_ITER_ERROR);  // RUNNING: stopped early (opaque)
                lit += std::bit_cast<float>(host[7 * r + 3]) > 0.05f ? 1 : 0;
                ++compared;
            }
            INFO("shading " << shading << " max level " << max_level);
            CHECK(count_mismatch == 0);
            CHECK(worst < 1e-5);
        }
    CHECK(compared == 4 * 1600);
    CHECK(lit > compared / 10);
}
