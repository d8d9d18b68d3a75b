// Host vs Vulkan (lavapipe in CI): the element octree's leaf iterator yields the same leaves,
// intervals (bit for bit), reference lists, statuses and steps, and the particle integrator the
// same colours within 1e-5 (exp and division may differ in the last bits), from the same
// encoding and rays (shaders/octree_elem_parity.comp), over several sets and configurations and
// over corrupted encodings.
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <array>
#include <cstring>
#include <random>
#include <sstream>

#include <sylva/elements/rbf.hpp>
#include <sylva/elements/voxel.hpp>
#include <sylva/shared/octree_particles.h>
#include <sylva/spirv/test_octree_elem_parity.h>
#include <sylva/vulkan/runner.hpp>

#include "common.hpp"

using namespace sylva;
using namespace octe_test;

namespace {

constexpr std::uint32_t kMaxLeaves = 128;
constexpr std::size_t kStride = 9 + 5 * kMaxLeaves;

struct Push {
    std::uint32_t ray_count, max_leaves, records, alpha_stop_bits;
};

std::uint32_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }

std::vector<std::uint32_t> host_records(const std::vector<std::uint32_t>& words, const std::vector<std::uint32_t>& elems,
                                        const std::vector<Ray>& rays, const Push& p) {
    std::vector<std::uint32_t> out(rays.size() * kStride, 0u);
    shared::Words w{words.data(), words.size()}, el{elems.data(), elems.size()};
    auto wc = std::uint32_t(words.size());
    for (std::size_t r = 0; r < rays.size(); ++r) {
        std::uint32_t* o = &out[r * kStride];
        shared::SylvaOctElemIter it;
        shared::sylva_octe_init(it, w, wc, rays[r].origin, rays[r].direction, 0.0f, 1e30f);
        std::uint32_t n = 0, node, first, count;
        float t0, t1;
        while (shared::sylva_octe_next(it, w, node, t0, t1, first, count)) {
            if (n < kMaxLeaves) {
                std::uint32_t* e = o + 9 + 5 * n;
                e[0] = node, e[1] = bits(t0), e[2] = bits(t1), e[3] = first, e[4] = count;
            }
            ++n;
        }
        o[0] = n, o[1] = it.walk.status, o[2] = it.walk.steps;
        std::uint32_t steps, status;
        vec4 c = shared::sylva_octe_render_particles(w, wc, el, p.records, rays[r].origin, rays[r].direction, 0.0f, 1e30f,
                                                     std::bit_cast<float>(p.alpha_stop_bits), steps, status);
        o[3] = bits(c.x), o[4] = bits(c.y), o[5] = bits(c.z), o[6] = bits(c.w), o[7] = status, o[8] = steps;
    }
    return out;
}

std::vector<std::uint32_t> device_records(vk::Context& ctx, const std::vector<std::uint32_t>& words,
                                          const std::vector<std::uint32_t>& elems, const std::vector<Ray>& rays,
                                          const Push& p) {
    std::vector<std::uint32_t> in(rays.size() * 8);
    for (std::size_t i = 0; i < rays.size(); ++i) {
        float f[8] = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z, rays[i].direction.x,
                      rays[i].direction.y, rays[i].direction.z, 0.0f, 1e30f};
        std::memcpy(&in[i * 8], f, sizeof f);
    }
    std::vector<std::uint32_t> el = elems.empty() ? std::vector<std::uint32_t>(8, 0u) : elems;  // a binding needs bytes
    vk::Buffer index(ctx, words.size() * 4), elem_buf(ctx, el.size() * 4), ray_buf(ctx, in.size() * 4),
        out_buf(ctx, rays.size() * kStride * 4);
    index.upload(words);
    elem_buf.upload(el);
    ray_buf.upload(in);
    vk::Kernel kernel(ctx, spirv::test_octree_elem_parity, 4, sizeof(Push));
    std::array<vk::Buffer*, 4> bind{&index, &elem_buf, &ray_buf, &out_buf};
    ctx.dispatch(kernel, bind, &p, sizeof p, vk::groups_for(rays.size(), 64));
    std::vector<std::uint32_t> out(rays.size() * kStride);
    out_buf.download(out);
    return out;
}

/// Leaf words must match exactly (on a GPU floats within devtol::kGpuFloatUlps), colours within
/// 1e-5 (on a GPU devtol::colour_tolerance); returns the count of rays that differ.
std::size_t mismatches(const vk::Context& ctx, const std::vector<std::uint32_t>& host,
                       const std::vector<std::uint32_t>& dev) {
    const std::uint32_t ulps = devtol::exact(ctx) ? 0u : devtol::kGpuFloatUlps;
    const float colour = devtol::colour_tolerance(ctx, 1e-5f);
    std::size_t bad = 0;
    for (std::size_t r = 0; r < host.size() / kStride; ++r) {
        const std::uint32_t *h = &host[r * kStride], *d = &dev[r * kStride];
        bool ok = h[0] == d[0] && h[1] == d[1] && h[2] == d[2] && h[7] == d[7];
        for (std::size_t k = 9; k < 9 + 5 * std::min(h[0], kMaxLeaves); ++k) ok = ok && devtol::ulp_distance(h[k], d[k]) <= ulps;
        for (int c = 3; c < 7; ++c) ok = ok && std::abs(std::bit_cast<float>(h[c]) - std::bit_cast<float>(d[c])) <= colour;
        if (!ok && bad < 1) {
            std::ostringstream os;
            for (std::size_t k = 0; k < 9 + 5 * std::min(std::max(h[0], d[0]), kMaxLeaves); ++k) os << " " << h[k] << "/" << d[k];
            UNSCOPED_INFO("words" << os.str());
        }
        if (!ok && bad < 4)
            UNSCOPED_INFO("ray " << r << ": host leaves " << h[0] << " status " << h[1] << " alpha "
                                 << std::bit_cast<float>(h[6]) << "; device " << d[0] << " " << d[1] << " "
                                 << std::bit_cast<float>(d[6]));
        bad += !ok;
    }
    return bad;
}

/// Host and device records agree: word for word on lavapipe, within devtol's limits on a GPU.
bool records_agree(const vk::Context& ctx, const std::vector<std::uint32_t>& host, const std::vector<std::uint32_t>& dev) {
    const std::size_t bad = mismatches(ctx, host, dev), allowed = devtol::allowed_diverging(ctx, host.size() / kStride);
    devtol::note(ctx, std::to_string(bad) + " of " + std::to_string(host.size() / kStride) + " rays differ on " +
                          ctx.device_name() + " (allowed " + std::to_string(allowed) + ")");
    return bad <= allowed;
}

/// Host vs device over one set: leaf words exactly, and (with particle records) colours within
/// 1e-5. `records` empty: leaves only (elements that are no particles, e.g. voxel cuboids); the
/// integrator's fields are then not compared.
template <class E>
void run_leaves(vk::Context& ctx, const std::vector<E>& es, const octree::ElementConfig& cfg,
                const std::vector<std::uint32_t>& records, std::size_t& leaves, std::size_t& lit) {
    std::span<const E> s(es);
    auto words = octree::encode_elements(octree::build_elements(s, cfg));
    auto rays = testing::random_rays(4000, scene_of(es), 91);
    for (float stop : {0.99f, 2.0f}) {
        Push p{std::uint32_t(rays.size()), kMaxLeaves, std::uint32_t(records.size() / SYLVA_PARTICLE_WORDS), bits(stop)};
        auto host = host_records(words, records, rays, p);
        auto dev = device_records(ctx, words, records, rays, p);
        REQUIRE(host.size() == dev.size());
        if (records.empty()) {  // the integrator reads no records: compare the walk only
            for (std::size_t r = 0; r < rays.size(); ++r)
                for (std::size_t k = 3; k < 9; ++k) host[r * kStride + k] = dev[r * kStride + k] = 0u;
        }
        CHECK(records_agree(ctx, host, dev));
        for (std::size_t r = 0; r < rays.size(); ++r) {
            CHECK(host[r * kStride + 1] == SYLVA_ITER_DONE);
            leaves += host[r * kStride];
            lit += std::bit_cast<float>(host[r * kStride + 6]) > 0.0f;
        }
        if (records.empty()) break;  // alpha_stop changes nothing else
    }
}

template <class P>
void run_case(vk::Context& ctx, const std::vector<P>& ps, const octree::ElementConfig& cfg, std::size_t& leaves,
              std::size_t& lit) {
    std::vector<std::uint32_t> id(ps.size());
    for (std::size_t i = 0; i < id.size(); ++i) id[i] = std::uint32_t(i);
    run_leaves(ctx, ps, cfg, pack_particles(std::span<const P>(ps), std::span<const std::uint32_t>(id)), leaves, lit);
}

}  // namespace

TEST_CASE("parity: element octree leaves and particle colours equal on the host and on Vulkan", "[parity]") {
    vk::Context ctx = vk::Context::create();
    std::size_t leaves = 0, lit = 0;
    for (const auto& cfg : configs()) {
        run_case(ctx, testing::random_spheres(2000, 92), cfg, leaves, lit);
        run_case(ctx, clustered_spheres(3000, 96), cfg, leaves, lit);
    }
    CHECK(leaves > 100000);
    CHECK(lit > 10000);
}

TEST_CASE("parity: element octree leaves over RBFs and voxel cuboids equal on the host and on Vulkan", "[parity]") {
    vk::Context ctx = vk::Context::create();
    std::size_t leaves = 0, lit = 0;
    std::vector<GaussianRbf> rbfs;
    for (const Sphere& p : testing::random_spheres(3000, 97)) rbfs.push_back({p.center, p.radius / 3.0f, 3.0f, p.rgba});
    // Voxel cuboids: the non-empty cells of a grid (as test_build.cpp's), leaves only.
    std::vector<VoxelCuboid> voxels;
    for (int z = 0; z < 24; ++z)
        for (int y = 0; y < 20; ++y)
            for (int x = 0; x < 17; ++x)
                if ((x * x + y * y + z * z) % 7 < 2) voxels.push_back({{vec3(x, y, z), vec3(x + 1, y + 1, z + 1)}, 0.5f});
    std::size_t voxel_leaves = 0, none = 0;
    for (const auto& cfg : configs()) {
        run_case(ctx, rbfs, cfg, leaves, lit);
        run_leaves(ctx, voxels, cfg, {}, voxel_leaves, none);
    }
    CHECK(leaves > 50000);
    CHECK(lit > 5000);
    CHECK(voxel_leaves > 50000);
}

TEST_CASE("parity: corrupted element octrees stop the same way on the host and on Vulkan", "[parity][errors]") {
    vk::Context ctx = vk::Context::create();
    auto ps = testing::random_spheres(500, 93);
    std::span<const Sphere> s(ps);
    std::vector<std::uint32_t> id(ps.size());
    for (std::size_t i = 0; i < id.size(); ++i) id[i] = std::uint32_t(i);
    const auto good = octree::encode_elements(octree::build_elements(s));
    auto records = pack_particles(s, std::span<const std::uint32_t>(id));
    auto rays = testing::random_rays(256, scene_of(ps), 94);
    std::mt19937 rng(95);
    std::size_t errors = 0;
    for (int trial = 0; trial < 40; ++trial) {
        auto w = good;
        std::ostringstream flips;
        for (int k = 0; k < 4; ++k) {
            std::size_t at = rng() % w.size();
            std::uint32_t bit = rng() % 32;
            w[at] ^= 1u << bit;
            flips << " word " << at << " bit " << bit;
        }
        INFO("trial " << trial << ":" << flips.str());
        Push p{std::uint32_t(rays.size()), kMaxLeaves, std::uint32_t(ps.size()), bits(0.99f)};
        auto host = host_records(w, records, rays, p);
        auto dev = device_records(ctx, w, records, rays, p);
        CHECK(records_agree(ctx, host, dev));
        for (std::size_t r = 0; r < rays.size(); ++r) errors += host[r * kStride + 1] == SYLVA_ITER_ERROR;
    }
    CHECK(errors > 20);
}
