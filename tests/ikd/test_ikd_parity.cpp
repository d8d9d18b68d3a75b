// Host vs Vulkan (lavapipe in CI): the shared implicit kd-tree iterator yields the same candidate
// cells, intervals, corner densities, statuses and step counts, word for word, from the same
// encoding, grid and rays (shaders/ikd_cells.comp in this folder).
#include <catch2/catch.hpp>

#include "../device_tolerance.hpp"

#include <array>
#include <cstring>
#include <random>

#include <sylva/ikd/build.hpp>
#include <sylva/ikd/encode.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/shared/cell_dda.h>
#include <sylva/spirv/test_ikd_cells.h>
#include <sylva/volume/procedural.hpp>
#include <sylva/vulkan/runner.hpp>

using namespace sylva;

namespace {

constexpr std::uint32_t kMaxCells = 64;
constexpr std::size_t kStride = 3 + 5 * kMaxCells;

struct Push {
    std::uint32_t ray_count, max_cells, iso_count, walker;  ///< walker: 0 the tree, 1 the cell DDA
    float isos[4];
};

struct ParityRay {
    vec3 o, d;
    float t0, t1;
};

std::uint32_t bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

/// The host's records in the layout of ikd_cells.comp.
std::vector<std::uint32_t> host_records(const std::vector<std::uint32_t>& words, const GridWords& g,
                                        const std::vector<ParityRay>& rays, const Push& p) {
    std::vector<std::uint32_t> out(rays.size() * kStride, 0u);
    shared::Words w{words.data(), words.size()}, gw{g.words.data(), g.words.size()};
    for (std::size_t r = 0; r < rays.size(); ++r) {
        shared::SylvaIkdIter it{};
        shared::SylvaDdaIter dda{};
        vec4 isos(p.isos[0], p.isos[1], p.isos[2], p.isos[3]);
        std::uint32_t nw = std::uint32_t(words.size()), ng = std::uint32_t(g.words.size());
        if (p.walker == 0)
            shared::sylva_ikd_init(it, w, nw, ng, rays[r].o, rays[r].d, rays[r].t0, rays[r].t1, isos, p.iso_count);
        else
            shared::sylva_dda_init(dda, w, nw, ng, rays[r].o, rays[r].d, rays[r].t0, rays[r].t1, isos, p.iso_count);
        std::uint32_t n = 0, *o = &out[r * kStride];
        glm::u32vec3 c;
        float t0, t1;
        auto next = [&] { return p.walker == 0 ? shared::sylva_ikd_next(it, w, gw, c, t0, t1) : shared::sylva_dda_next(dda, gw, c, t0, t1); };
        while (next()) {
            if (n < kMaxCells) {
                std::uint32_t* e = o + 3 + 5 * n;
                e[0] = c.x | (c.y << 16);
                e[1] = c.z;
                e[2] = bits(t0);
                e[3] = bits(t1);
                e[4] = bits(p.walker == 0 ? it.corners_lo.x : dda.corners_lo.x);
            }
            ++n;
        }
        o[0] = n;
        o[1] = p.walker == 0 ? it.status : dda.status;
        o[2] = p.walker == 0 ? it.steps : dda.steps;
    }
    return out;
}

std::vector<std::uint32_t> device_records(vk::Context& ctx, const std::vector<std::uint32_t>& words, const GridWords& g,
                                          const std::vector<ParityRay>& rays, const Push& p) {
    std::vector<std::uint32_t> in(rays.size() * 8);
    for (std::size_t i = 0; i < rays.size(); ++i) {
        float f[8] = {rays[i].o.x, rays[i].o.y, rays[i].o.z, rays[i].d.x, rays[i].d.y, rays[i].d.z, rays[i].t0, rays[i].t1};
        std::memcpy(&in[i * 8], f, sizeof f);
    }
    vk::Buffer tree(ctx, words.size() * 4), grid(ctx, g.words.size() * 4), ray_buf(ctx, in.size() * 4),
        out_buf(ctx, rays.size() * kStride * 4);
    tree.upload(words);
    grid.upload(g.words);
    ray_buf.upload(in);
    std::array<std::uint32_t, 1> stack{SYLVA_IKD_MAX_LEVELS};
    vk::Kernel kernel(ctx, spirv::test_ikd_cells, 4, sizeof(Push), stack);
    std::array<vk::Buffer*, 4> bind{&tree, &grid, &ray_buf, &out_buf};
    ctx.dispatch(kernel, bind, &p, sizeof p, vk::groups_for(rays.size(), 64));
    std::vector<std::uint32_t> out(rays.size() * kStride);
    out_buf.download(out);
    return out;
}

/// Camera-like rays through the box, rays parallel to axes and lying in cell planes, rays
/// starting inside, rays ending early.
std::vector<ParityRay> rays_for(vec3 box, std::uint32_t count, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.05f, 0.95f), s(-1.0f, 1.0f);
    std::vector<ParityRay> rays;
    for (std::uint32_t i = 0; i < count; ++i) {
        vec3 target(u(rng) * box.x, u(rng) * box.y, u(rng) * box.z);
        vec3 d = glm::normalize(vec3(s(rng), s(rng), s(rng)) + vec3(1e-3f));
        if (i % 11 == 0) d = vec3(0.0f, 0.0f, i % 2 ? 1.0f : -1.0f);
        if (i % 13 == 0) target.x = std::floor(target.x) + 0.5f;  // in a cell plane (samples sit at v + 0.5)
        vec3 o = i % 5 == 0 ? target : target - d * (2.0f * glm::length(box));
        rays.push_back({o, d, 0.0f, i % 7 == 3 ? glm::length(box) : 1e30f});
    }
    return rays;
}

}  // namespace

TEST_CASE("parity: ikd and cell DDA candidate cells are identical on the host and on Vulkan", "[parity]") {
    vk::Context ctx = vk::Context::create();
    struct Case {
        volume::DensityGrid grid;
        Push push;
    };
    std::vector<Case> cases;
    cases.push_back({volume::marschner_lobb({41, 41, 41}), {0, kMaxCells, 1, 0, {0.5f, 0, 0, 0}}});
    cases.push_back({volume::marschner_lobb({23, 37, 10}), {0, kMaxCells, 3, 0, {0.25f, 0.5f, 0.75f, 0}}});
    volume::DensityGrid padded = volume::radial_falloff({19, 6, 33}, vec3(9.0f, 3.0f, 16.0f), 14.0f, vec3(1.0f, 2.0f, 0.5f));
    cases.push_back({padded, {0, kMaxCells, 4, 0, {0.2f, 0.4f, 0.6f, 0.8f}}});
    std::size_t cells_seen = 0;
    for (Case& c : cases)
    for (std::uint32_t bits : {8u, 16u}) {  // both node formats (the DDA walks without nodes: once)
        CAPTURE(bits);
        ikd::Tree t = ikd::build(c.grid, ikd::Config{ikd::Config{}.brick_levels, bits});
        std::vector<std::uint32_t> words = ikd::encode(t);
        GridWords g = GridWords::from(c.grid);
        std::vector<ParityRay> rays = rays_for(vec3(c.grid.dims) * c.grid.spacing, 4000, c.grid.dims.x);
        c.push.ray_count = static_cast<std::uint32_t>(rays.size());
        for (std::uint32_t walker : {0u, 1u}) {
            if (walker == 1u && bits == 16u) continue;
            c.push.walker = walker;
            std::vector<std::uint32_t> host = host_records(words, g, rays, c.push);
            std::vector<std::uint32_t> dev = device_records(ctx, words, g, rays, c.push);
            REQUIRE(host.size() == dev.size());
            std::size_t mismatches = 0;
            for (std::size_t i = 0; i < host.size(); ++i) {
                if (host[i] != dev[i] && mismatches < 8) {
                    float hf, df;
                    std::memcpy(&hf, &host[i], 4);
                    std::memcpy(&df, &dev[i], 4);
                    UNSCOPED_INFO("ray " << i / kStride << " word " << i % kStride << ": host " << host[i] << " (" << hf
                                         << ") device " << dev[i] << " (" << df << ")");
                }
                mismatches += host[i] != dev[i] ? 1u : 0u;
            }
            const devtol::RecordDiff diff = devtol::compare_records(host, dev, kStride);
            devtol::note(ctx, devtol::describe(ctx, diff));
            CHECK((devtol::exact(ctx) ? mismatches == 0 : devtol::acceptable(ctx, diff)));
            for (std::size_t r = 0; r < rays.size(); ++r) {
                CHECK(host[r * kStride + 1] == SYLVA_ITER_DONE);
                cells_seen += host[r * kStride];
            }
        }
    }
    CHECK(cells_seen > 20000);
}
