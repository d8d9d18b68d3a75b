// Native-type grids and border modes on Vulkan (lavapipe in CI): the marcher and kd DVR over
// uint8 / uint16 words give the host's images (the shaders read the same packed words).
#include <catch2/catch.hpp>

#include <bit>
#include <cstring>
#include <random>

#include <sylva/kdtree/encode.hpp>
#include <sylva/render/kd_volume.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/vulkan/kd_volume.hpp>
#include <sylva/vulkan/volume.hpp>

using namespace sylva;

namespace {

volume::Volume sparse_volume(volume::ScalarType type, volume::Dims dims, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    volume::Volume v;
    v.type = type;
    v.dims = dims;
    std::size_t n = volume::voxel_count(dims), b = volume::scalar_bytes(type);
    v.bytes.resize(n * b);
    for (std::size_t i = 0; i < n; ++i) {
        float x = u(rng) < 0.9f ? 0.0f : u(rng);
        if (type == volume::ScalarType::U8) {
            v.bytes[i] = std::byte(static_cast<std::uint8_t>(x * 255.0f));
        } else {
            auto s = static_cast<std::uint16_t>(x * 65535.0f);
            std::memcpy(&v.bytes[2 * i], &s, 2);
        }
    }
    v.range_lo = 0.0f;
    v.range_hi = type == volume::ScalarType::U8 ? 255.0f : 65535.0f;
    return v;
}

/// sparse_volume with every voxel outside a ball zeroed and a block of one value: the 8^3 bricks
/// are zero, uniform and varied (GridWords::sparse stores only the varied ones).
volume::Volume bricky_volume(volume::ScalarType type, volume::Dims dims, std::uint32_t seed) {
    volume::Volume v = sparse_volume(type, dims, seed);
    std::size_t b = volume::scalar_bytes(type);
    vec3 c = vec3(dims) * 0.5f;
    for (std::uint32_t z = 0; z < dims.z; ++z)
        for (std::uint32_t y = 0; y < dims.y; ++y)
            for (std::uint32_t x = 0; x < dims.x; ++x) {
                std::size_t i = x + std::size_t{dims.x} * (y + std::size_t{dims.y} * z);
                if (x < 8 && y < 8) std::memset(&v.bytes[b * i], 0x70, b);  // uniform 112 (or 28784)
                else if (glm::length(vec3(x, y, z) - c) > 10.0f) std::memset(&v.bytes[b * i], 0, b);
            }
    return v;
}

std::vector<std::uint32_t> ramp_tf() {
    std::vector<std::uint32_t> tf(256);
    for (std::uint32_t i = 0; i < 256; ++i) {
        std::uint32_t a = i > 20 ? (i - 20) / 2 : 0u;
        tf[i] = i | ((255u - i) << 8) | (90u << 16) | (a << 24);
    }
    return tf;
}

/// Colours within 5e-5 (exp2/log2 of the opacity correction may differ by a few ulp between
/// libm and lavapipe; tests/dvr/test_dvr_parity.cpp), steps exactly.
void check_same(const Frame& host, const Frame& gpu) {
    ImageDifference d = compare_frames(host, gpu);
    std::size_t steps = 0;
    double alpha = 0.0;
    for (std::size_t i = 0; i < host.steps.size(); ++i) {
        steps += host.steps[i] != gpu.steps[i];
        alpha += host.rgba[i].a;
    }
    INFO("max diff " << d.max_abs << ", pixels with other steps " << steps << ", summed alpha " << alpha);
    CHECK(d.max_abs <= 5e-5);
    CHECK(steps == 0);
    CHECK(alpha > 20.0);
}

/// 40x40 pixels of the grid's box, the ramp TF, shading on.
VolumeRenderParams params_for(const GridWords& w) {
    VolumeRenderParams p;
    p.width = p.height = 40;
    p.camera = Camera::framing(w.world_box(), vec3(0.5f, 0.3f, 1.0f), 34.0f).frame(40, 40);
    p.tf = ramp_tf();
    p.shading = true;
    return p;
}

/// The marcher and the ESS kd-tree renderer on the device against the host (check_same);
/// returns the host marcher's frame.
Frame check_marcher_and_kd(vk::Context& ctx, vk::DeviceGrid& grid, const GridWords& w, const VolumeRenderParams& p,
                           ThreadPool& pool) {
    Frame host = render_dvr_cpu(w, p, pool);
    check_same(host, vk::render_dvr_vulkan(ctx, grid, p));
    EssRebuilder<ThreadPool> ess(w, kdtree::Config::deep(), pool);
    std::vector<std::uint32_t> kd = kdtree::encode(ess.rebuild(p.tf));
    vk::DeviceKdTree dkd(ctx, kd);
    check_same(render_kd_dvr_cpu(w, kd, p, pool), vk::render_kd_dvr_vulkan(ctx, grid, dkd, p));
    return host;
}

}  // namespace

TEST_CASE("native grids and border modes on Vulkan match the host", "[parity][vulkan]") {
    vk::Context ctx = vk::Context::create();
    INFO("device " << ctx.describe());
    ThreadPool pool(2);
    for (volume::ScalarType type : {volume::ScalarType::U8, volume::ScalarType::U16}) {
        volume::Volume v = sparse_volume(type, {27, 22, 19}, 9);  // odd voxel count: a padded word
        for (GridBorder b : {GridBorder{}, GridBorder::clamp(), GridBorder::constant(0.3f)}) {
            INFO(volume::scalar_name(type) << ", border " << int(b.mode) << " " << b.value);
            GridWords w = GridWords::native(v, b);
            vk::DeviceGrid grid(ctx, w);
            check_marcher_and_kd(ctx, grid, w, params_for(w), pool);
        }
    }
}

TEST_CASE("sparse grids on Vulkan match the host and the dense grid, also split over four bindings", "[parity][vulkan]") {
    vk::Context ctx = vk::Context::create();
    INFO("device " << ctx.describe());
    ThreadPool pool(2);
    struct Case {
        volume::ScalarType type;
        GridBorder border;
        bool split;  // parts of 2^shift words, the grid spread over 3-4 of them (brick offsets cross parts)
    };
    // Each case compiles two pipelines on lavapipe (tens of seconds, more when split): the
    // formats and borders are covered once each, the split once.
    for (Case c : {Case{volume::ScalarType::U8, GridBorder{}, false}, Case{volume::ScalarType::U8, GridBorder::clamp(), false},
                   Case{volume::ScalarType::U16, GridBorder{}, false}, Case{volume::ScalarType::U8, GridBorder{}, true}}) {
        volume::Volume v = bricky_volume(c.type, {35, 29, 27}, 4);
        GridWords w = GridWords::sparse(v, c.border), dense = GridWords::native(v, c.border);
        REQUIRE(w.words.size() < dense.words.size());
        auto shift = c.split ? static_cast<std::uint32_t>(std::bit_width((w.words.size() + 3) / 4 - 1)) : 0u;
        INFO(volume::scalar_name(c.type) << ", border " << int(c.border.mode) << ", shift " << shift << " for "
                                         << w.words.size() << " words");
        vk::DeviceGrid grid(ctx, w, shift);
        if (c.split) REQUIRE(grid.constants()[1] >= 3u);
        VolumeRenderParams p = params_for(w);
        Frame host = check_marcher_and_kd(ctx, grid, w, p, pool);
        CHECK(compare_frames(host, render_dvr_cpu(dense, p, pool)).max_abs == 0.0);
    }
}
