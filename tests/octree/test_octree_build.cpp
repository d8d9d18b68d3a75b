// The bricked octree's builder (Gobbetti et al. sections 3 and 4): levels and nodes, brick
// contents and borders against the grid, filtered bricks against a reference downsampling,
// node ranges against brute force, every neighbour pointer against a brute-force search, and
// bad input.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

#include <sylva/octree/build.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace octree_test;
using Catch::Matchers::Contains;

namespace {

struct Case {
    volume::Dims dims;
    octree::Config cfg;
};

/// Odd, non-cubic and tiny extents over every brick size and border the tests use.
std::vector<Case> cases() {
    return {{{33, 17, 70}, {16, 1}}, {{33, 17, 70}, {4, 2}}, {{1, 1, 1}, {32, 2}}, {{2, 2, 2}, {4, 1}},
            {{255, 9, 40}, {16, 2}}, {{64, 64, 64}, {32, 1}}, {{5, 31, 12}, {8, 2}}, {{40, 40, 40}, {32, 2}}, {{255, 255, 255}, {32, 2}}};
}

}  // namespace

TEST_CASE("octree levels and nodes: complete over the volume, level by level, children in octant order", "[octree]") {
    for (const Case& c : cases()) {
        octree::Tree t = octree::build(blobs(c.dims, 1), c.cfg);
        INFO(c.dims.x << "x" << c.dims.y << "x" << c.dims.z << " B " << c.cfg.brick_size);
        std::uint32_t leaves = std::max({(c.dims.x + c.cfg.brick_size - 1) / c.cfg.brick_size,
                                         (c.dims.y + c.cfg.brick_size - 1) / c.cfg.brick_size,
                                         (c.dims.z + c.cfg.brick_size - 1) / c.cfg.brick_size});
        std::uint32_t levels = 1;
        while ((1u << (levels - 1)) < leaves) ++levels;
        REQUIRE(t.levels == levels);
        std::size_t expected = 0;
        for (std::uint32_t l = 0; l < t.levels; ++l) {
            glm::u32vec3 r = t.level_nodes(l);
            expected += std::size_t{r.x} * r.y * r.z;
            CHECK(r.x * t.width(l) >= c.dims.x);
            CHECK((r.x - 1) * t.width(l) < c.dims.x);
        }
        CHECK(t.nodes.size() == expected);
        CHECK(t.brick_count() == t.nodes.size());
        CHECK(t.width(t.levels - 1) == c.cfg.brick_size);
        for (std::size_t n = 0; n < t.nodes.size(); ++n) {
            const octree::Node& node = t.nodes[n];
            CHECK((node.leaf() == (node.level + 1 == t.levels)));
            if (n > 0) CHECK(t.nodes[n - 1].level <= node.level);
            for (std::uint32_t o = 0, k = node.first_child; o < 8; ++o) {
                glm::u32vec3 cc = node.coord * 2u + glm::u32vec3(o & 1u, (o >> 1) & 1u, o >> 2);
                bool exists = !node.leaf() && glm::all(glm::lessThan(cc * t.width(node.level + 1), c.dims));
                REQUIRE(((node.child_mask >> o) & 1u) == (exists ? 1u : 0u));
                if (!exists) continue;
                CHECK(t.nodes[k].level == node.level + 1);
                CHECK(t.nodes[k].coord == cc);
                ++k;
            }
        }
    }
}

TEST_CASE("octree leaf bricks: every sample, borders included, is the grid's voxel, clamped at the edge", "[octree]") {
    std::size_t samples = 0, clamped = 0;
    for (const Case& c : cases()) {
        volume::DensityGrid g = blobs(c.dims, 2);
        octree::Tree t = octree::build(g, c.cfg);
        std::uint32_t s = t.brick_side();
        REQUIRE(s == c.cfg.brick_size + 2 * c.cfg.border);
        for (const octree::Node& node : t.nodes) {
            if (!node.leaf()) continue;
            glm::ivec3 lo = glm::ivec3(node.coord * t.brick_size) - int(t.border);
            for (std::uint32_t z = 0; z < s; ++z)
                for (std::uint32_t y = 0; y < s; ++y)
                    for (std::uint32_t x = 0; x < s; ++x) {
                        glm::ivec3 v = lo + glm::ivec3(x, y, z);
                        float want = g.clamped(v.x, v.y, v.z);
                        if (t.sample(node.brick, x, y, z) != want) {
                            FAIL_CHECK("leaf brick " << node.brick << " sample " << x << "," << y << "," << z);
                            return;
                        }
                        ++samples;
                        clamped += glm::any(glm::lessThan(v, glm::ivec3(0))) ||
                                   glm::any(glm::greaterThanEqual(v, glm::ivec3(c.dims)));
                    }
        }
    }
    CHECK(samples > 1000000);
    CHECK(clamped > 10000);
}

TEST_CASE("octree inner bricks: the LoD pyramid equals a reference mean over the voxels below", "[octree]") {
    std::size_t inner = 0;
    for (const Case& c : cases()) {
        volume::DensityGrid g = blobs(c.dims, 3);
        octree::Tree t = octree::build(g, c.cfg);
        std::vector<RefLod> lod;
        for (std::uint32_t s = 0; s < t.levels; ++s) lod.push_back(reference_lod(g, s));
        std::uint32_t side = t.brick_side();
        double worst = 0.0;
        for (const octree::Node& node : t.nodes) {
            const RefLod& ref = lod[t.levels - 1 - node.level];
            glm::ivec3 lo = glm::ivec3(node.coord * t.brick_size) - int(t.border);
            for (std::uint32_t z = 0; z < side; ++z)
                for (std::uint32_t y = 0; y < side; ++y)
                    for (std::uint32_t x = 0; x < side; ++x)
                        worst = std::max(worst, std::abs(ref.at(lo + glm::ivec3(x, y, z)) - t.sample(node.brick, x, y, z)));
            inner += node.leaf() ? 0 : 1;
        }
        INFO(c.dims.x << "x" << c.dims.y << "x" << c.dims.z);
        CHECK(worst < 2e-6);
    }
    CHECK(inner > 50);
}

TEST_CASE("octree pyramid: a linear ramp's coarse voxels hold the mean position, uneven edges included", "[octree]") {
    // x-ramp over 37 voxels (not a power of two): coarse voxel v of level s covers x in
    // [v 2^s, min((v + 1) 2^s, 37)), whose mean value is known in closed form.
    volume::Dims d(37, 3, 2);
    volume::DensityGrid g{d, vec3(1.0f), std::vector<float>(volume::voxel_count(d))};
    for (std::uint32_t z = 0; z < d.z; ++z)
        for (std::uint32_t y = 0; y < d.y; ++y)
            for (std::uint32_t x = 0; x < d.x; ++x) g.values[volume::voxel_index(d, x, y, z)] = float(x) / 64.0f;
    octree::Tree t = octree::build(g, {4, 1});
    REQUIRE(t.levels == 5);
    for (const octree::Node& node : t.nodes) {
        std::uint32_t s = t.levels - 1 - node.level;
        for (std::uint32_t x = 0; x < t.brick_side(); ++x) {
            int v = std::clamp(int(node.coord.x * t.brick_size) - 1 + int(x), 0, int((d.x + (1u << s) - 1) >> s) - 1);
            int a = v << s, b = std::min(int(d.x), (v + 1) << s);
            double mean = 0.5 * (a + b - 1) / 64.0;
            REQUIRE(t.sample(node.brick, x, 1, 1) == Approx(mean).margin(1e-6));
        }
    }
}

TEST_CASE("octree ranges: min/max of every density trilinear sampling can reach in the node, at any level below", "[octree]") {
    for (const Case& c : cases()) {
        volume::DensityGrid g = blobs(c.dims, 4);
        octree::Tree t = octree::build(g, c.cfg);
        std::vector<RefLod> lod;
        for (std::uint32_t s = 0; s < t.levels; ++s) lod.push_back(reference_lod(g, s));
        for (const octree::Node& node : t.nodes) {
            double lo = 2.0, hi = -1.0;
            std::uint32_t s_node = t.levels - 1 - node.level;
            for (std::uint32_t s = 0; s <= s_node; ++s) {  // the node's voxels at level s, one more around
                const RefLod& ref = lod[s];
                int w = int(t.brick_size) << (s_node - s);
                glm::ivec3 a = glm::max(glm::ivec3(node.coord) * w - 1, glm::ivec3(0));
                glm::ivec3 b = glm::min(glm::ivec3(node.coord + 1u) * w, glm::ivec3(ref.dims) - 1);
                for (int z = a.z; z <= b.z; ++z)
                    for (int y = a.y; y <= b.y; ++y)
                        for (int x = a.x; x <= b.x; ++x) {
                            double v = ref.at({x, y, z});
                            lo = std::min(lo, v);
                            hi = std::max(hi, v);
                        }
            }
            INFO("node level " << node.level << " coord " << node.coord.x << "," << node.coord.y << "," << node.coord.z);
            REQUIRE(node.min == Approx(lo).margin(2e-6));
            REQUIRE(node.max == Approx(hi).margin(2e-6));
            if (node.leaf()) {  // leaves: exactly the grid's voxels
                REQUIRE(double(node.min) == lo);
                REQUIRE(double(node.max) == hi);
            }
        }
    }
}

TEST_CASE("octree neighbour pointers equal a brute-force search, complete and sparse octrees", "[octree]") {
    std::vector<octree::Tree> trees;
    for (const Case& c : cases()) trees.push_back(octree::build(blobs(c.dims, 5), c.cfg));
    for (std::uint32_t seed = 0; seed < 6; ++seed) {
        trees.push_back(sparse_tree({70, 33, 17}, 4, seed, 0.6f));
        trees.push_back(sparse_tree({64, 64, 64}, 4, 100 + seed, 0.5f));
    }
    std::size_t same = 0, coarser = 0, none = 0;
    for (const octree::Tree& t : trees) {
        for (const octree::Node& node : t.nodes)
            for (std::uint32_t f = 0; f < 6; ++f) {
                std::uint32_t want = brute_neighbour(t, node, f);
                INFO("level " << node.level << " coord " << node.coord.x << "," << node.coord.y << "," << node.coord.z
                              << " face " << f);
                REQUIRE(node.neighbour[f] == want);
                if (want == octree::kNone)
                    ++none;
                else if (t.nodes[want].level == node.level)
                    ++same;
                else
                    ++coarser;
            }
    }
    CHECK(same > 10000);
    CHECK(coarser > 1000);
    CHECK(none > 1000);
}

TEST_CASE("octree build is the same with a thread pool", "[octree][parallel]") {
    volume::DensityGrid g = blobs({70, 45, 33}, 6);
    ThreadPool pool(4);
    octree::Tree a = octree::build(g, {8, 2}), b = octree::build(g, pool, {8, 2});
    REQUIRE(a.bricks == b.bricks);
    REQUIRE(a.nodes.size() == b.nodes.size());
    for (std::size_t n = 0; n < a.nodes.size(); ++n) {
        CHECK(a.nodes[n].min == b.nodes[n].min);
        CHECK(a.nodes[n].max == b.nodes[n].max);
        CHECK(a.nodes[n].neighbour == b.nodes[n].neighbour);
    }
}

TEST_CASE("octree bad input: zero or absurd extents, bad values, sizes and borders are named", "[octree][errors]") {
    volume::DensityGrid g = blobs({8, 8, 8}, 7);
    CHECK_THROWS_WITH(octree::build(volume::DensityGrid{{0, 4, 4}, vec3(1.0f), {}}), Contains("at least 1"));
    CHECK_THROWS_WITH(octree::build(volume::DensityGrid{{1u << 24, 1, 1}, vec3(1.0f), {}}), Contains("2^24"));
    volume::DensityGrid short_values = g;
    short_values.values.pop_back();
    CHECK_THROWS_WITH(octree::build(short_values), Contains("values for"));
    volume::DensityGrid nan = g;
    nan.values[77] = std::nanf("");
    CHECK_THROWS_WITH(octree::build(nan), Contains("voxel 77 is NaN"));
    volume::DensityGrid above = g;
    above.values[5] = 1.5f;
    CHECK_THROWS_WITH(octree::build(above), Contains("not a normalised density"));
    volume::DensityGrid spacing = g;
    spacing.spacing.y = 0.0f;
    CHECK_THROWS_WITH(octree::build(spacing), Contains("spacing"));
    CHECK_THROWS_WITH(octree::build(g, {24, 1}), Contains("brick size 24"));
    CHECK_THROWS_WITH(octree::build(g, {128, 1}), Contains("brick size 128"));
    CHECK_THROWS_WITH(octree::build(g, {16, 0}), Contains("border 0"));
    CHECK_THROWS_WITH(octree::build(g, {16, 3}), Contains("border 3"));
    // Too deep for 16-bit node coordinates: 2^19 voxels in bricks of 4 need 18 levels.
    CHECK_THROWS_WITH(octree::build(volume::DensityGrid{{1u << 19, 1, 1}, vec3(1.0f), std::vector<float>(1u << 19, 0.5f)}, {4, 1}),
                      Contains("levels"));
    // A brick larger than the volume is a one-node octree whose brick repeats the edge voxels.
    octree::Tree one = octree::build(volume::DensityGrid{{1, 1, 1}, vec3(1.0f), {0.25f}}, {32, 2});
    REQUIRE(one.nodes.size() == 1);
    CHECK(one.nodes[0].min == 0.25f);
    CHECK(one.nodes[0].max == 0.25f);
    CHECK(one.sample(0, 35, 0, 17) == 0.25f);
}
