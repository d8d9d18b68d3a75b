// Kinkelin's Tables 3 and 6 on the real volumes of ../shared/data: the exact element counts
// and the shape of Table 3 on the lobster (node count identity, nodes, depth, default LoD).
#include <catch2/catch.hpp>

#include <cmath>

#include <sylva/bih/lod.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/volume/voxels.hpp>

#include "lod_fixtures.hpp"

using namespace sylva;

TEST_CASE("voxels with density >= 0.1 are exactly the BIH elements of Tables 3 and 6", "[lod][data]") {
    struct Case { const char* file; volume::Dims dims; vec3 spacing; std::size_t elements; };
    const Case cases[] = {
        {"lobster_301x324x56_uint8.raw", {301, 324, 56}, {1.0f, 1.0f, 1.4f}, 341256},      // Table 3
        {"engine_256x256x128_uint8.raw", {256, 256, 128}, {1.0f, 1.0f, 1.0f}, 1352439},    // Table 3
        {"aneurism_256x256x256_uint8.raw", {256, 256, 256}, {1.0f, 1.0f, 1.0f}, 113453},   // Table 6
    };
    ThreadPool pool(2);
    for (const Case& c : cases) {
        INFO(c.file);
        std::optional<volume::DensityGrid> g = lodtest::load_u8(c.file, c.dims, c.spacing);
        if (!g) continue;
        CHECK(volume::voxel_cuboids(*g, 0.1f, pool).size() == c.elements);
    }
}

TEST_CASE("Table 3 shape on the lobster: full BIH and default LoD", "[lod][data][table3]") {
    std::optional<volume::DensityGrid> g =
        lodtest::load_u8("lobster_301x324x56_uint8.raw", {301, 324, 56}, vec3(1.0f, 1.0f, 1.4f));
    if (!g) return;
    ThreadPool pool(2);
    std::vector<VoxelCuboid> cuboids = volume::voxel_cuboids(*g, 0.1f, pool);
    REQUIRE(cuboids.size() == 341256);
    bih::FullBih f = bih::build_full(cuboids, bih::Config{}, pool);
    const bih::BuildStats& s = f.tree.stats;
    // Section 3.3: nodes = 2 * leaves - 1 + single-child nodes, one voxel per leaf
    CHECK(s.leaves == cuboids.size());
    CHECK(s.nodes == 2 * s.elements - 1 + s.single_child_nodes);
    // Table 3: 726,844 nodes (we allow 1 %), 6.1 % single-child nodes, max depth 24
    CHECK(std::fabs(double(s.nodes) - 726844.0) <= 0.01 * 726844.0);
    CHECK(s.percent_single_child() == Approx(6.1).margin(0.5));
    CHECK(s.max_depth == 24);
    CHECK(f.paper_bytes() == s.nodes * 40);

    bih::Lod lod = bih::extract_lod(f);
    // Table 3 default LoD: 515,349 nodes (we allow 2 %), depth 24, 37.75 % of the 16-bit grid
    CHECK(std::fabs(double(lod.stats.nodes) - 515349.0) <= 0.02 * 515349.0);
    CHECK(lod.stats.max_depth == 24);
    double percent = 100.0 * double(lod.node_bytes()) / (2.0 * double(g->values.size()));
    CHECK(percent == Approx(37.75).margin(1.0));
    CHECK(lod.stats.nodes == 2 * lod.stats.leaves - 1 + lod.stats.single_child_nodes);
    CHECK(f.stats[0].count == cuboids.size());
}
