// Host vs Vulkan (lavapipe in CI): the shared kd-tree iterator yields the same leaf sequences,
// word for word, from the same encoding and rays (shaders/kd_leaves.comp in this folder).
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <cstring>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/kdtree/query.hpp>
#include <sylva/spirv/test_kd_leaves.h>
#include <sylva/vulkan/runner.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace sylva::kdtest;

namespace {

constexpr std::uint32_t kMaxLeaves = 48;
constexpr std::size_t kStride = 3 + 3 * kMaxLeaves;

std::uint32_t bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

Interval range_of(std::size_t i) { return (i % 7 == 3) ? Interval{0.25f, 30.0f} : Interval{}; }

/// The host's sequences in the layout of kd_leaves.comp.
std::vector<std::uint32_t> host_sequences(const std::vector<std::uint32_t>& words, const std::vector<Ray>& rays) {
    std::vector<std::uint32_t> out(rays.size() * kStride, 0u);
    for (std::size_t r = 0; r < rays.size(); ++r) {
        kdtree::LeafIterator it(words, rays[r], range_of(r));
        std::uint32_t n = 0,* o = &out[r * kStride];
        while (auto h = it.next()) {
            if (n < kMaxLeaves) {
                o[3 + 3 * n] = h->leaf;
                o[4 + 3 * n] = bits(h->t.t0);
                o[5 + 3 * n] = bits(h->t.t1);
            }
            ++n;
        }
        o[0] = n;
        o[1] = it.status();
        o[2] = it.steps();
    }
    return out;
}

std::vector<std::uint32_t> device_sequences(vk::Context& ctx, const std::vector<std::uint32_t>& words,
                                            const std::vector<Ray>& rays) {
    std::vector<std::uint32_t> in(rays.size() * 8);
    for (std::size_t i = 0; i < rays.size(); ++i) {
        Interval t = range_of(i);
        float f[8] = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z, rays[i].direction.x,
                      rays[i].direction.y, rays[i].direction.z, t.t0, t.t1};
        std::memcpy(&in[i * 8], f, sizeof f);
    }
    vk::Buffer tree(ctx, words.size() * 4), ray_buf(ctx, in.size() * 4), out_buf(ctx, rays.size() * kStride * 4);
    tree.upload(words);
    ray_buf.upload(in);
    std::array<std::uint32_t, 1> stack{SYLVA_KD_DEPTH_CAP};
    vk::Kernel kernel(ctx, spirv::test_kd_leaves, 3, 8, stack);
    struct { std::uint32_t ray_count, max_leaves; } push{static_cast<std::uint32_t>(rays.size()), kMaxLeaves};
    std::array<vk::Buffer*, 3> bind{&tree, &ray_buf, &out_buf};
    ctx.dispatch(kernel, bind, &push, sizeof push, vk::groups_for(rays.size(), 64));
    std::vector<std::uint32_t> out(rays.size() * kStride);
    out_buf.download(out);
    return out;
}

}  // namespace

TEST_CASE("parity: kd leaf sequences are identical on the host and on Vulkan", "[parity]") {
    vk::Context ctx = vk::Context::create();
    SerialExecutor serial;
    std::vector<kdtree::Tree> trees;
    trees.push_back(kdtree::build_vidal(blobby_occupancy({64, 48, 40}, 1), kdtree::Config::deep()));
    trees.push_back(kdtree::build_binned(blobby_occupancy({37, 70, 29}, 2, 8), kdtree::Config::shallow(), serial));
    kdtree::Tree full = kdtree::build_vidal(random_occupancy({24, 20, 16}, 1.0, 4), kdtree::Config::deep());
    full.spacing = vec3(0.7f, 1.3f, 0.45f);
    full.origin = vec3(-3.1f, 2.2f, 0.9f);
    trees.push_back(full);
    trees.push_back(kdtree::build_vidal(random_occupancy({5, 6, 7}, 0.0, 1)));  // no nodes
    for (const kdtree::Tree& t : trees) {
        std::vector<std::uint32_t> words = kdtree::encode(t);
        std::vector<Ray> rays = make_rays(t.dims, 6000, 5, false), in_plane = make_rays(t.dims, 2000, 6, true);
        rays.insert(rays.end(), in_plane.begin(), in_plane.end());
        for (Ray& r : rays) r.origin = t.origin + r.origin * t.spacing;
        std::vector<std::uint32_t> host = host_sequences(words, rays), gpu = device_sequences(ctx, words, rays);
        std::size_t differing = 0, leaves = 0;
        for (std::size_t r = 0; r < rays.size(); ++r) {
            leaves += host[r * kStride];
            differing += !std::equal(&host[r * kStride], &host[r * kStride] + kStride, &gpu[r * kStride]);
        }
        const devtol::RecordDiff diff = devtol::compare_records(host, gpu, kStride);
        INFO(t.leaves.size() << " leaves, " << leaves << " leaf hits over " << rays.size() << " rays; "
                             << devtol::describe(ctx, diff));
        devtol::note(ctx, devtol::describe(ctx, diff));
        CHECK((devtol::exact(ctx) ? differing == 0 : devtol::acceptable(ctx, diff)));
        if (!t.leaves.empty()) CHECK(leaves > rays.size() / 10);
    }
}
