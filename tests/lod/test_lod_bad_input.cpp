// Bad input to the statistics, LoD and node-range stages: sylva::Error naming the problem.
#include <catch2/catch.hpp>

#include <limits>

#include <sylva/bih/lod.hpp>
#include <sylva/volume/voxels.hpp>

#include "lod_fixtures.hpp"

using namespace sylva;
using Catch::Contains;

namespace {

std::vector<VoxelCuboid> small_cuboids() {
    return volume::voxel_cuboids(lodtest::synthetic_grid({10, 9, 8}, vec3(1.0f), 2u), 0.1f);
}

}  // namespace

TEST_CASE("build_full refuses empty lists, NaN densities, NaN gradients and NaN boxes", "[lod][bad]") {
    CHECK_THROWS_WITH(bih::build_full(std::span<const VoxelCuboid>()), Contains("empty"));
    std::vector<VoxelCuboid> c = small_cuboids();
    REQUIRE(c.size() > 10);
    auto nan_density = c;
    nan_density[7].density = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(bih::build_full(nan_density), Contains("element 7"));
    auto nan_gradient = c;
    nan_gradient[3].gradient.y = std::numeric_limits<float>::infinity();
    CHECK_THROWS_WITH(bih::build_full(nan_gradient), Contains("element 3"));
    auto nan_box = c;
    nan_box[5].box.lo.x = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(bih::build_full(nan_box), Contains("element 5"));
}

TEST_CASE("LodConfig with NaN or negative criteria or a chunk depth over 15 is refused", "[lod][bad]") {
    std::vector<VoxelCuboid> c = small_cuboids();
    bih::FullBih f = bih::build_full(c);
    bih::Lod lod = bih::extract_lod(f);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    bih::LodConfig bad;
    bad.min_element_density = nan;
    CHECK_THROWS_WITH(bih::extract_lod(f, bad), Contains("min_element_density"));
    bad = {};
    bad.min_element_density = -0.5f;
    CHECK_THROWS_WITH(bih::extract_lod(f, bad), Contains("min_element_density"));
    bad = {};
    bad.max_std_dev = nan;
    CHECK_THROWS_WITH(bih::extract_lod(f, bad), Contains("max_std_dev"));
    bad = {};
    bad.max_std_dev = -0.01f;
    CHECK_THROWS_WITH(bih::extract_lod(f, bad), Contains("max_std_dev"));
    CHECK_THROWS_WITH(bih::encode_lod(lod, bad), Contains("max_std_dev"));
    bad = {};
    bad.chunk_depth = 16;
    CHECK_THROWS_WITH(bih::encode_lod(lod, bad), Contains("chunk_depth"));
    bad = {};
    bad.max_depth = 1000;  // clamped to the cap, not an error
    CHECK(bih::extract_lod(f, bad).tree.nodes.size() == lod.tree.nodes.size());
}

TEST_CASE("inconsistent or corrupted full trees are refused", "[lod][bad]") {
    std::vector<VoxelCuboid> c = small_cuboids();
    bih::FullBih f = bih::build_full(c);
    bih::FullBih short_stats = f;
    short_stats.stats.pop_back();
    CHECK_THROWS_WITH(bih::extract_lod(short_stats), Contains("stats"));
    bih::FullBih bad_link = f;
    bad_link.tree.nodes[0].child[0] = static_cast<std::uint32_t>(f.tree.nodes.size() + 5);
    CHECK_THROWS_AS(bih::extract_lod(bad_link, bih::LodConfig{SYLVA_BIH_DEPTH_CAP, 2.0f, 0.0f, 2}), Error);
    CHECK_THROWS_WITH(bih::node_boxes(bad_link.tree), Contains("out of range"));
    bih::Tree cycle = f.tree;
    cycle.nodes[0].child[1] = cycle.nodes[0].child[0];  // a subtree reached twice
    CHECK_THROWS_WITH(bih::node_boxes(cycle), Contains("reached twice"));
    CHECK_THROWS_AS(bih::node_boxes(bih::Tree{}), Error);
    SerialExecutor serial;
    std::span<const VoxelCuboid> few(c.data(), 3);  // the leaves refer to elements beyond these
    CHECK_THROWS_WITH(bih::node_stats(f.tree, few, std::span<const Aabb>(f.boxes), vec3(1.0f), serial),
                      Contains("element"));
    CHECK_THROWS_WITH(bih::node_stats(f.tree, std::span<const VoxelCuboid>(c), std::span<const Aabb>(f.boxes).first(2),
                                      vec3(1.0f), serial),
                      Contains("boxes"));
}

TEST_CASE("encode_node_ranges refuses corrupted and non-voxel encodings", "[lod][bad]") {
    std::vector<VoxelCuboid> c = small_cuboids();
    bih::FullBih f = bih::build_full(c);
    bih::Lod lod = bih::extract_lod(f);
    std::vector<std::uint32_t> words = bih::encode_lod(lod);
    auto magic = words;
    magic[0] ^= 1u;
    CHECK_THROWS_WITH(bih::encode_node_ranges(magic, lod.voxel_size), Contains("magic"));
    auto truncated = words;
    truncated.resize(words.size() / 2);
    CHECK_THROWS_AS(bih::encode_node_ranges(truncated, lod.voxel_size), Error);
    CHECK_THROWS_AS(bih::encode_node_ranges(std::span<const std::uint32_t>(), lod.voxel_size), Error);
    auto link = words;
    for (std::size_t i = SYLVA_BIH_HEADER_WORDS + 1; i < link.size(); i += 2)
        if ((link[i] & 3u) != SYLVA_BIH_LEAF) {
            link[i] = (link[i] & 7u) | (0x1FFFFFF0u << 3);  // child index far out of range
            break;
        }
    CHECK_THROWS_AS(bih::encode_node_ranges(link, lod.voxel_size), Error);
    std::vector<std::uint32_t> range_payload = bih::encode(lod.tree, std::span<const VoxelCuboid>(lod.leaves), bih::RangePayload{});
    CHECK_THROWS_WITH(bih::encode_node_ranges(range_payload, lod.voxel_size), Contains("not voxels"));
}
