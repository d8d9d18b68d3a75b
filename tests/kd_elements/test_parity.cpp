// Host vs Vulkan (lavapipe in CI): the element kd-tree's leaf iterator (sylva/shared/kd_elem_iter.h)
// yields the same leaves, intervals (bit for bit), reference lists, statuses and steps, and the
// particle integrator (kd_elem_particles.h) the same colours within 1e-5 (exp and division may
// differ in the last bits), from the same encoding and rays (shaders/kd_elem_parity.comp).
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <array>
#include <cstring>
#include <random>
#include <sstream>

#include <sylva/elements/rbf.hpp>
#include <sylva/elements/voxel.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/shared/kd_elem_particles.h>
#include <sylva/spirv/test_kd_elem_parity.h>
#include <sylva/vulkan/runner.hpp>

#include "common.hpp"

using namespace sylva;
using namespace kde_test;

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
        shared::SylvaKdElemIter it;
        shared::sylva_kde_init(it, w, wc, rays[r].origin, rays[r].direction, 0.0f, 1e30f);
        std::uint32_t n = 0, node, first, count;
        float t0, t1;
        while (shared::sylva_kde_next(it, w, node, t0, t1, first, count)) {
            if (n < kMaxLeaves) {
                std::uint32_t* e = o + 9 + 5 * n;
                e[0] = node, e[1] = bits(t0), e[2] = bits(t1), e[3] = first, e[4] = count;
            }
            ++n;
        }
        o[0] = n, o[1] = it.status, o[2] = it.steps;
        std::uint32_t steps, status;
        vec4 c = shared::sylva_kde_render_particles(w, wc, el, p.records, rays[r].origin, rays[r].direction, 0.0f, 1e30f,
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
    vk::Kernel kernel(ctx, spirv::test_kd_elem_parity, 4, sizeof(Push));
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

/// Host vs device over one set: leaf words exactly, and (with particle records) colours within
/// 1e-5. `records` empty: leaves only (elements that are no particles, e.g. voxel cuboids); the
/// integrator's fields are then not compared.
template <class E>
void run_leaves(vk::Context& ctx, const std::vector<E>& es, const kdtree::ElementConfig& cfg,
                const std::vector<std::uint32_t>& records, std::size_t& leaves, std::size_t& lit) {
    std::span<const E> s(es);
    auto words = kdtree::encode_elements(kdtree::build_elements(s, cfg));
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
        const std::size_t bad = mismatches(ctx, host, dev);
        devtol::note(ctx, std::to_string(bad) + " of " + std::to_string(rays.size()) + " rays differ on " + ctx.device_name());
        CHECK(bad <= devtol::allowed_diverging(ctx, rays.size()));
        for (std::size_t r = 0; r < rays.size(); ++r) {
            CHECK(host[r * kStride + 1] == SYLVA_ITER_DONE);
            leaves += host[r * kStride];
            lit += std::bit_cast<float>(host[r * kStride + 6]) > 0.0f;
        }
        if (records.empty()) break;  // alpha_stop changes nothing else
    }
}

}  // namespace

TEST_CASE("kd elements on Vulkan: leaves, intervals, steps and particle colours equal the host's", "[vulkan]") {
    vk::Context ctx = vk::Context::create();
    std::size_t leaves = 0, lit = 0;
    kdtree::ElementConfig def, small;
    small.leaf_elements = 1;
    small.bins = 8;
    for (const auto& cfg : {def, small}) {
        for (const auto& ps : {testing::random_spheres(3000, 131), clustered_spheres(3000, 132)}) {
            std::vector<std::uint32_t> id(ps.size());
            for (std::size_t i = 0; i < id.size(); ++i) id[i] = std::uint32_t(i);
            run_leaves(ctx, ps, cfg, pack_particles(std::span<const Sphere>(ps), std::span<const std::uint32_t>(id)), leaves, lit);
        }
        auto caps = random_capsules(2000, 133);
        run_leaves(ctx, caps, cfg, {}, leaves, lit);  // a user element: the walk only
    }
    CHECK(leaves > 10000);
    CHECK(lit > 2000);
}
