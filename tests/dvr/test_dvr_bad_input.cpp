// Bad input to the volume renderers throws sylva::Error naming the problem; corrupted
// encodings never crash or read out of bounds.
#include <catch2/catch.hpp>

#include <limits>
#include <random>

#include <sylva/bih/payload.hpp>
#include <sylva/elements/box.hpp>

#include "dvr_fixtures.hpp"

using namespace sylva;
using namespace sylva::dvrtest;

namespace {

struct Small {
    volume::DensityGrid grid = sample_grid({8, 8, 8}, vec3(1.0f), blobs(vec3(8.0f)));
    GridWords words = GridWords::from(grid);
    std::vector<std::uint32_t> bih = encode_voxels(grid_cuboids(grid, 0.05f), bih::NodeFormat::Fixed16);
    VolumeRenderParams params() const {
        VolumeRenderParams p;
        p.camera = Camera::framing(grid.world_box()).frame(16, 16);
        p.width = p.height = 16;
        p.tf = smooth_tf(0.05f, 0.5f);
        return p;
    }
};

template <class F>
void require_error(F&& f, const std::string& fragment) {
    try {
        f();
        FAIL("no sylva::Error; expected one mentioning '" << fragment << "'");
    } catch (const Error& e) {
        INFO("message: " << e.what());
        CHECK(std::string(e.what()).find(fragment) != std::string::npos);
    }
}

}  // namespace

TEST_CASE("Bad render parameters throw sylva::Error naming the problem", "[dvr]") {
    Small s;
    SerialExecutor ex;
    auto with = [&](auto change, const std::string& fragment) {
        VolumeRenderParams p = s.params();
        change(p);
        require_error([&] { render_dvr_cpu(s.words, p, ex); }, fragment);
    };
    with([](VolumeRenderParams& p) { p.tf.clear(); }, "transfer function");
    with([](VolumeRenderParams& p) { p.tf.resize(1); }, "transfer function");
    with([](VolumeRenderParams& p) { p.dt = std::nanf(""); }, "not finite");
    with([](VolumeRenderParams& p) { p.dt = -1.0f; }, "dt");
    with([](VolumeRenderParams& p) { p.dt = 1e-9f; }, "2^24");
    with([](VolumeRenderParams& p) { p.unit = 0.0f; }, "unit");
    with([](VolumeRenderParams& p) { p.alpha_stop = 0.0f; }, "alpha_stop");
    with([](VolumeRenderParams& p) { p.width = 0; }, "image size");
    with([](VolumeRenderParams& p) { p.height = 1u << 30; }, "image size");
    with([](VolumeRenderParams& p) { p.camera.eye.x = std::numeric_limits<float>::infinity(); }, "camera");
    with([](VolumeRenderParams& p) { p.light.y = std::nanf(""); }, "light");
    with([](VolumeRenderParams& p) { p.iso = std::nanf(""); }, "not finite");
}

TEST_CASE("Bad grids throw sylva::Error", "[dvr]") {
    volume::DensityGrid g{{4, 4, 4}, vec3(1.0f), std::vector<float>(64, 0.5f)};
    g.values[17] = std::nanf("");
    require_error([&] { GridWords::from(g); }, "17");
    g.values.resize(63);
    require_error([&] { GridWords::from(g); }, "63 values");
    g.dims = {0, 4, 4};
    require_error([&] { GridWords::from(g); }, "zero");
    g = volume::DensityGrid{{4, 4, 4}, vec3(1.0f, 0.0f, 1.0f), std::vector<float>(64, 0.5f)};
    require_error([&] { GridWords::from(g); }, "spacing");
    g.dims = {1u << 20, 1u << 20, 1u << 20};
    require_error([&] { GridWords::from(g); }, "2^32");
    Small s;
    GridWords broken = s.words;
    broken.words.pop_back();
    SerialExecutor ex;
    require_error([&] { render_dvr_cpu(broken, s.params(), ex); }, "words");
}

TEST_CASE("Bad BIH input throws, corrupted encodings end rays without crashing", "[dvr]") {
    Small s;
    SerialExecutor ex;
    VolumeRenderParams p = s.params();
    p.mode = VolumeMode::BihSingle;
    require_error([&] { render_bih_dvr_cpu(VoxelBihView{{}, {}, vec3(1.0f), {}}, p, ex); }, "not a valid");
    // A BIH over plain boxes has the range payload, not voxels.
    auto boxes = std::vector<BoxElement>{{{vec3(0.0f), vec3(1.0f)}}, {{vec3(2.0f), vec3(3.0f)}}};
    bih::Tree t = bih::build(std::span<const BoxElement>(boxes));
    auto range_words = bih::encode(t, std::span<const BoxElement>(boxes), bih::RangePayload{});
    require_error([&] { render_bih_dvr_cpu(VoxelBihView{range_words, {}, vec3(1.0f), {}}, p, ex); }, "payload kind");
    require_error([&] { render_bih_dvr_cpu(VoxelBihView{s.bih, {}, vec3(0.0f), {}}, p, ex); }, "voxel size");
    p.mode = VolumeMode::DvrReference;
    require_error([&] { render_bih_dvr_cpu(VoxelBihView{s.bih, {}, vec3(1.0f), {}}, p, ex); }, "BIH mode");
    p.mode = VolumeMode::BihIso;
    p.iso_culling = true;
    std::vector<std::uint32_t> short_ranges(3, 0xFFFF0000u);
    require_error([&] { render_bih_dvr_cpu(VoxelBihView{s.bih, short_ranges, vec3(1.0f), {}}, p, ex); }, "node-range");
    require_error([&] { render_volume_cpu(VolumeScene{}, p, ex); }, "BIH");
    p.mode = VolumeMode::DvrReference;
    require_error([&] { render_volume_cpu(VolumeScene{}, p, ex); }, "grid");

    // Random corruption of node words: every ray ends (DONE or ERROR), nothing crashes.
    std::mt19937 rng(3);
    for (VolumeMode mode : {VolumeMode::BihSingle, VolumeMode::BihMulti, VolumeMode::BihIso}) {
        p.mode = mode;
        p.iso_culling = false;
        for (int trial = 0; trial < 20; ++trial) {
            std::vector<std::uint32_t> bad = s.bih;
            for (int k = 0; k < 8; ++k) {
                std::size_t i = SYLVA_BIH_HEADER_WORDS + rng() % (bad.size() - SYLVA_BIH_HEADER_WORDS);
                bad[i] ^= 1u << (rng() % 32);
            }
            Frame f = render_bih_dvr_cpu(VoxelBihView{bad, {}, vec3(1.0f), {}}, p, ex);
            for (const vec4& c : f.rgba) REQUIRE((c.a >= 0.0f && c.a <= 1.0f + 1e-5f));
        }
    }
}
