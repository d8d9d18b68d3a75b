// Whole-pipeline extremes (issue 3, "Bad input"): a volume whose voxels are all full, one whose
// voxels are all empty, NaN in a float volume, and the normalisation of each scalar type.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>

#include <sylva/bih/lod.hpp>
#include <sylva/bih/stats.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/volume/grid.hpp>
#include <sylva/volume/voxels.hpp>

using namespace sylva;

namespace {

volume::DensityGrid constant_grid(volume::Dims dims, float d) {
    return volume::DensityGrid{dims, vec3(1.0f), std::vector<float>(volume::voxel_count(dims), d)};
}

/// A TF whose every entry is the same straight colour and alpha.
std::vector<std::uint32_t> flat_tf(std::uint32_t r, std::uint32_t g, std::uint32_t b, std::uint32_t a) {
    return std::vector<std::uint32_t>(256, r | (g << 8) | (b << 16) | (a << 24));
}

VolumeRenderParams params_for(const volume::DensityGrid& g) {
    VolumeRenderParams p;
    p.width = p.height = 24;
    p.camera = Camera::framing(g.world_box(), vec3(0.3f, 0.5f, 1.0f)).frame(p.width, p.height);
    p.tf = flat_tf(255, 128, 0, 51);  // alpha 0.2 per unit length
    p.alpha_stop = 2.0f;             // no early termination: the closed form holds exactly
    return p;
}

}  // namespace

TEST_CASE("An all-full volume collapses to a one-leaf LoD that renders the closed form", "[lod][extremes]") {
    volume::DensityGrid g = constant_grid({24, 16, 8}, 0.6f);
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, 0.1f);
    REQUIRE(cuboids.size() == g.values.size());
    bih::FullBih full = bih::build_full(std::span<const VoxelCuboid>(cuboids));
    CHECK(full.tree.nodes.size() == 2 * cuboids.size() - 1);  // a grid of voxels: no single-child node
    CHECK(full.stats[0].element_density == Approx(1.0));
    CHECK(full.stats[0].std_dev() == Approx(0.0).margin(1e-9));
    bih::Lod lod = bih::extract_lod(full);
    REQUIRE(lod.tree.nodes.size() == 1);  // dense and uniform: the root is the LoD's only leaf
    CHECK(lod.leaves[0].box == g.world_box());
    std::vector<std::uint32_t> words = bih::encode_lod(lod);

    VolumeRenderParams p = params_for(g);
    p.mode = VolumeMode::BihSingle;
    SerialExecutor serial;
    Frame f = render_bih_dvr_cpu(VoxelBihView{words, {}, g.spacing, g.world_box()}, p, serial);
    std::size_t hit = 0;
    for (std::uint32_t y = 0; y < p.height; ++y) {
        for (std::uint32_t x = 0; x < p.width; ++x) {
            Ray r = p.camera.ray(x, y, p.width, p.height);
            std::optional<Interval> in = clip(r, g.world_box(), Interval{0.0f, std::numeric_limits<float>::infinity()});
            vec4 c = f.rgba[std::size_t{y} * p.width + x];
            if (!in) {
                REQUIRE(c.a == 0.0f);
                continue;
            }
            ++hit;
            double L = (double(in->t1) - double(in->t0)) * double(glm::length(r.direction));
            double closed = 1.0 - std::pow(1.0 - 51.0 / 255.0, L);
            REQUIRE(c.a == Approx(closed).margin(1e-4));
            REQUIRE(c.r == Approx(closed).margin(1e-4));
        }
    }
    CHECK(hit > p.width * p.height / 4);
}

TEST_CASE("An all-empty volume has no elements: build_full says so and the marcher shows nothing", "[lod][extremes]") {
    volume::DensityGrid g = constant_grid({16, 16, 16}, 0.05f);  // below the 0.1 threshold everywhere
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(g, 0.1f);
    CHECK(cuboids.empty());
    CHECK_THROWS_WITH(bih::build_full(std::span<const VoxelCuboid>(cuboids)), Catch::Contains("no voxel cuboids"));
    volume::DensityGrid zero = constant_grid({16, 16, 16}, 0.0f);
    VolumeRenderParams p = params_for(zero);
    p.tf = flat_tf(255, 255, 255, 0);  // the TF has no opaque entry
    p.tf[0] = 0xFF0000FFu;             // except at density 0, which the marcher skips
    SerialExecutor serial;
    Frame f = render_dvr_cpu(GridWords::from(zero), p, serial);
    for (const vec4& c : f.rgba) REQUIRE(c == vec4(0.0f));
}

TEST_CASE("Normalisation: uint8 / 255, uint16 / 65535, float over its range, NaN and infinity refused", "[lod][extremes]") {
    volume::Volume u16{volume::ScalarType::U16, {2, 1, 1}, vec3(1.0f), std::vector<std::byte>(4), 0.0f, 65535.0f};
    std::uint16_t v[2] = {0, 6554};
    std::memcpy(u16.bytes.data(), v, 4);
    volume::DensityGrid g = volume::normalize(u16);
    CHECK(g.values[1] == Approx(6554.0 / 65535.0));

    volume::Volume f32{volume::ScalarType::F32, {2, 2, 1}, vec3(1.0f), std::vector<std::byte>(16), -1.0f, 3.0f};
    float fv[4] = {-1.0f, 1.0f, 3.0f, std::nanf("")};
    std::memcpy(f32.bytes.data(), fv, 16);
    CHECK_THROWS_WITH(volume::normalize(f32), Catch::Contains("voxel 3 is not a finite number"));
    fv[3] = std::numeric_limits<float>::infinity();
    std::memcpy(f32.bytes.data(), fv, 16);
    CHECK_THROWS_WITH(volume::normalize(f32), Catch::Contains("voxel 3 is not a finite number"));
    fv[3] = 0.0f;
    std::memcpy(f32.bytes.data(), fv, 16);
    volume::DensityGrid n = volume::normalize(f32);
    CHECK(n.values[0] == 0.0f);
    CHECK(n.values[1] == Approx(0.5f));
    CHECK(n.values[2] == 1.0f);

    volume::Volume short_bytes{volume::ScalarType::U8, {4, 4, 4}, vec3(1.0f), std::vector<std::byte>(10), 0.0f, 255.0f};
    CHECK_THROWS_WITH(volume::normalize(short_bytes), Catch::Contains("10 bytes do not match 64 uint8 voxels"));
}
