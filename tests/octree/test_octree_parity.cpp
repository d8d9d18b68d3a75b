// Host vs Vulkan (lavapipe in CI): the shared stackless octree walk yields the same leaves,
// intervals (bit for bit), statuses and step counts from the same encoding and rays
// (shaders/octree_leaves.comp in this folder), over complete, odd, sparse octrees and cuts, and
// over corrupted encodings (the same ERROR or DONE at the same step).
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <array>
#include <cstring>
#include <random>

#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/shared/octree_iter.h>
#include <sylva/spirv/test_octree_leaves.h>
#include <sylva/vulkan/runner.hpp>

#include "rays.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

constexpr std::uint32_t kMaxLeaves = 96;
constexpr std::size_t kStride = 3 + 3 * kMaxLeaves;

struct Push {
    std::uint32_t ray_count, max_leaves, max_level, brick_buffer_words;
};

std::uint32_t bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

/// The host's records in the layout of octree_leaves.comp.
std::vector<std::uint32_t> host_records(const std::vector<std::uint32_t>& words, std::size_t brick_words,
                                        const std::vector<TestRay>& rays, const Push& p) {
    std::vector<std::uint32_t> out(rays.size() * kStride, 0u);
    shared::Words w{words.data(), words.size()};
    for (std::size_t r = 0; r < rays.size(); ++r) {
        shared::SylvaOctIter it{};
        shared::sylva_oct_init(it, w, std::uint32_t(words.size()), std::uint32_t(brick_words), rays[r].o, rays[r].d,
                               rays[r].t0, rays[r].t1, p.max_level);
        std::uint32_t n = 0, node, *o = &out[r * kStride];
        float t0, t1;
        while (shared::sylva_oct_next(it, w, node, t0, t1)) {
            if (n < kMaxLeaves) {
                o[3 + 3 * n] = node;
                o[4 + 3 * n] = bits(t0);
                o[5 + 3 * n] = bits(t1);
            }
            ++n;
        }
        o[0] = n;
        o[1] = it.status;
        o[2] = it.steps;
    }
    return out;
}

std::vector<std::uint32_t> device_records(vk::Context& ctx, const std::vector<std::uint32_t>& words,
                                          const std::vector<TestRay>& rays, const Push& p) {
    std::vector<std::uint32_t> in(rays.size() * 8);
    for (std::size_t i = 0; i < rays.size(); ++i) {
        float f[8] = {rays[i].o.x, rays[i].o.y, rays[i].o.z, rays[i].d.x, rays[i].d.y, rays[i].d.z, rays[i].t0, rays[i].t1};
        std::memcpy(&in[i * 8], f, sizeof f);
    }
    // The walk reads no brick: a one-word stand-in (the size goes in a push constant).
    std::vector<std::uint32_t> bricks(1, 0u);
    vk::Buffer index(ctx, words.size() * 4), brick_buf(ctx, bricks.size() * 4), ray_buf(ctx, in.size() * 4),
        out_buf(ctx, rays.size() * kStride * 4);
    index.upload(words);
    brick_buf.upload(bricks);
    ray_buf.upload(in);
    vk::Kernel kernel(ctx, spirv::test_octree_leaves, 4, sizeof(Push));
    std::array<vk::Buffer*, 4> bind{&index, &brick_buf, &ray_buf, &out_buf};
    ctx.dispatch(kernel, bind, &p, sizeof p, vk::groups_for(rays.size(), 64));
    std::vector<std::uint32_t> out(rays.size() * kStride);
    out_buf.download(out);
    return out;
}

/// Word-by-word comparison; returns the mismatch count and reports the first few.
std::size_t mismatches(const std::vector<std::uint32_t>& host, const std::vector<std::uint32_t>& dev) {
    std::size_t bad = 0;
    for (std::size_t i = 0; i < host.size(); ++i) {
        if (host[i] != dev[i] && bad < 8)
            UNSCOPED_INFO("ray " << i / kStride << " word " << i % kStride << ": host " << host[i] << " device " << dev[i]);
        bad += host[i] != dev[i] ? 1u : 0u;
    }
    return bad;
}

/// Host and device records agree: word for word on lavapipe, within devtol's limits on a GPU.
bool records_agree(const vk::Context& ctx, const std::vector<std::uint32_t>& host, const std::vector<std::uint32_t>& dev) {
    if (devtol::exact(ctx)) return mismatches(host, dev) == 0;
    const devtol::RecordDiff diff = devtol::compare_records(host, dev, kStride);
    devtol::note(ctx, devtol::describe(ctx, diff));
    return devtol::acceptable(ctx, diff);
}

}  // namespace

TEST_CASE("parity: the stackless octree walk yields the same leaves on the host and on Vulkan", "[parity]") {
    vk::Context ctx = vk::Context::create();
    struct Case {
        octree::Tree tree;
        std::uint32_t max_level;
    };
    std::vector<Case> cases;
    cases.push_back({octree::build(blobs({33, 17, 70}, 1), {4, 1}), 0xFFFFFFFFu});
    cases.push_back({octree::build(blobs({37, 64, 20}, 2, vec3(1.0f, 2.0f, 0.5f)), {4, 2}), 0xFFFFFFFFu});
    cases.push_back({octree::build(blobs({50, 61, 29}, 3), {4, 1}), 2});
    cases.push_back({octree::build(blobs({1, 1, 1}, 4), {32, 2}), 0xFFFFFFFFu});
    cases.push_back({sparse_tree({70, 33, 45}, 4, 5, 0.55f), 0xFFFFFFFFu});
    std::size_t leaves = 0;
    for (Case& c : cases) {
        std::vector<std::uint32_t> words = octree::encode(c.tree);
        std::vector<TestRay> rays = test_rays(c.tree, 4000, c.tree.dims.x);
        Push p{std::uint32_t(rays.size()), kMaxLeaves, c.max_level, std::uint32_t(c.tree.bricks.size())};
        std::vector<std::uint32_t> host = host_records(words, c.tree.bricks.size(), rays, p);
        std::vector<std::uint32_t> dev = device_records(ctx, words, rays, p);
        REQUIRE(host.size() == dev.size());
        INFO("octree " << c.tree.dims.x << "x" << c.tree.dims.y << "x" << c.tree.dims.z << " max level " << c.max_level
                       << " bricks " << c.tree.bricks.size());
        CHECK(records_agree(ctx, host, dev));
        for (std::size_t r = 0; r < rays.size(); ++r) {
            CHECK(host[r * kStride + 1] == SYLVA_ITER_DONE);
            REQUIRE(host[r * kStride] <= kMaxLeaves);
            leaves += host[r * kStride];
        }
    }
    CHECK(leaves > 50000);
}

TEST_CASE("parity: corrupted encodings stop the same way on the host and on Vulkan", "[parity][errors]") {
    vk::Context ctx = vk::Context::create();
    octree::Tree t = octree::build(blobs({37, 21, 50}, 6), {4, 1});
    const std::vector<std::uint32_t> good = octree::encode(t);
    std::vector<TestRay> rays = test_rays(t, 256, 7);
    std::mt19937 rng(8);
    std::size_t errors = 0;
    for (std::uint32_t trial = 0; trial < 40; ++trial) {
        std::vector<std::uint32_t> w = good;
        for (std::uint32_t k = 0; k < 4; ++k) w[SYLVA_OCT_HEADER_WORDS + rng() % (w.size() - SYLVA_OCT_HEADER_WORDS)] ^= 1u << (rng() % 32);
        Push p{std::uint32_t(rays.size()), kMaxLeaves, 0xFFFFFFFFu, std::uint32_t(t.bricks.size())};
        std::vector<std::uint32_t> host = host_records(w, t.bricks.size(), rays, p);
        std::vector<std::uint32_t> dev = device_records(ctx, w, rays, p);
        CHECK(records_agree(ctx, host, dev));
        for (std::size_t r = 0; r < rays.size(); ++r) errors += host[r * kStride + 1] == SYLVA_ITER_ERROR ? 1 : 0;
    }
    CHECK(errors > 20);
}

TEST_CASE("parity: the walk over view-dependent cuts yields the same leaves on the host and on Vulkan",
          "[parity][cut]") {
    vk::Context ctx = vk::Context::create();
    std::vector<octree::Tree> trees;
    trees.push_back(octree::build(blobs({61, 37, 50}, 11), {4, 1}));
    trees.push_back(sparse_tree({70, 33, 45}, 4, 12, 0.55f));
    std::size_t leaves = 0, coarse = 0, restarts_checked = 0;
    std::mt19937 rng(13);
    for (const octree::Tree& t : trees) {
        std::vector<std::uint32_t> words = octree::encode(t);
        Aabb box{vec3(0.0f), vec3(t.dims) * t.spacing};
        Camera cam = Camera::framing(box, {0.8f, 0.5f, 0.6f});
        cam.eye = box.center() + (cam.eye - box.center()) * 0.25f;  // close: cut leaves at many levels
        octree::Cut cut = octree::select_cut(words, octree::cut_view(cam.frame(64, 64), 64, 64),
                                             {1.0f, std::uint32_t(t.nodes.size() / 3)}, [](std::uint32_t) { return false; });
        octree::apply_cut(words, cut);
        for (std::size_t n = 0; n < t.nodes.size(); ++n)
            coarse += (cut.state[n] == octree::CutState::Leaf && !t.nodes[n].leaf()) ? 1 : 0;
        std::vector<TestRay> rays = test_rays(t, 4000, 14);
        Push p{std::uint32_t(rays.size()), kMaxLeaves, 0xFFFFFFFFu, std::uint32_t(t.bricks.size())};
        std::vector<std::uint32_t> host = host_records(words, t.bricks.size(), rays, p);
        std::vector<std::uint32_t> dev = device_records(ctx, words, rays, p);
        CHECK(records_agree(ctx, host, dev));
        for (std::size_t r = 0; r < rays.size(); ++r) {
            CHECK(host[r * kStride + 1] == SYLVA_ITER_DONE);
            leaves += host[r * kStride];
        }
        // Inconsistent cut bits (flipped at random): both targets stop the same way.
        for (std::uint32_t trial = 0; trial < 10; ++trial) {
            std::vector<std::uint32_t> w = words;
            for (std::uint32_t k = 0; k < 6; ++k)
                w[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * (rng() % t.nodes.size()) + 1] ^= (rng() & 1u) ? SYLVA_OCT_CUT_LEAF
                                                                                                              : SYLVA_OCT_CUT_BELOW;
            std::vector<TestRay> few(rays.begin(), rays.begin() + 500);
            Push q{std::uint32_t(few.size()), kMaxLeaves, 0xFFFFFFFFu, std::uint32_t(t.bricks.size())};
            CHECK(records_agree(ctx, host_records(w, t.bricks.size(), few, q), device_records(ctx, w, few, q)));
            ++restarts_checked;
        }
    }
    CHECK(coarse > 20);
    CHECK(leaves > 10000);
    CHECK(restarts_checked == 20);
}
