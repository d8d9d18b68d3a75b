// LoD extraction (Kinkelin 5.2): leaf criteria, merged cuboids and coverage, checked against
// brute force over the full tree's elements.
#include <catch2/catch.hpp>

#include <sylva/bih/lod.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/volume/voxels.hpp>

#include "lod_fixtures.hpp"

using namespace sylva;

namespace {

struct Fixture {
    std::vector<VoxelCuboid> cuboids;
    bih::FullBih full;
};

Fixture make_fixture(bih::EmptyChildren variant) {
    volume::DensityGrid g = lodtest::synthetic_grid({32, 28, 20}, vec3(1.0f, 1.0f, 1.4f), 21u);
    Fixture f;
    f.cuboids = volume::voxel_cuboids(g, 0.1f);
    bih::Config cfg;
    cfg.empty_children = variant;
    f.full = bih::build_full(f.cuboids, cfg);
    return f;
}

/// Element density and standard deviation of `elems` inside `box`, by brute force.
struct Measured {
    double density = 0.0, std_dev = 0.0, mean = 0.0;
    glm::dvec3 gradient{0.0};
};

Measured measure(const std::vector<VoxelCuboid>& all, const std::vector<std::uint32_t>& elems, const Aabb& box) {
    Measured m;
    double vol = 0.0;
    for (std::uint32_t i : elems) {
        vec3 e = all[i].box.extent();
        vol += double(e.x) * e.y * e.z;
        m.mean += all[i].density;
        m.gradient += glm::dvec3(all[i].gradient);
    }
    m.mean /= double(elems.size());
    m.gradient /= double(elems.size());
    double var = 0.0;
    for (std::uint32_t i : elems) var += (all[i].density - m.mean) * (all[i].density - m.mean);
    m.std_dev = std::sqrt(var / double(elems.size()));
    vec3 b = box.extent();
    m.density = vol / (double(b.x) * b.y * b.z);
    return m;
}

/// Checks the criteria of every LoD node against brute force; returns the number of leaves
/// that were merged (not full-tree leaves).
std::size_t check_criteria(const Fixture& f, const bih::Lod& lod, const bih::LodConfig& cfg) {
    std::vector<std::uint32_t> depth = lodtest::node_depths(lod.tree);
    std::size_t merged = 0;
    for (std::size_t i = 0; i < lod.tree.nodes.size(); ++i) {
        std::uint32_t src = lod.source[i];
        std::vector<std::uint32_t> elems = lodtest::subtree_elements(f.full.tree, src);
        Measured m = measure(f.cuboids, elems, f.full.boxes[src]);
        bool meets = m.density >= cfg.min_element_density - 1e-6 && m.std_dev <= cfg.max_std_dev + 1e-9;
        bool fails = m.density < cfg.min_element_density + 1e-6 || m.std_dev > cfg.max_std_dev - 1e-9;
        INFO("LoD node " << i << " from full node " << src << ": density " << m.density << ", std " << m.std_dev);
        const bih::Node& n = lod.tree.nodes[i];
        if (!n.leaf()) {
            REQUIRE(fails);  // an inner node never meets the criteria
            REQUIRE(depth[i] < cfg.max_depth);
            continue;
        }
        bool full_leaf = f.full.tree.nodes[src].leaf();
        bool forced = depth[i] >= cfg.max_depth;
        if (!full_leaf && !forced) {
            REQUIRE(meets);
            ++merged;
        }
        const VoxelCuboid& c = lod.leaves[n.first];
        CHECK(c.box == f.full.boxes[src]);
        CHECK(c.density == Approx(m.mean).margin(1e-6));
        CHECK(c.gradient.x == Approx(m.gradient.x).margin(1e-6));
        CHECK(c.gradient.y == Approx(m.gradient.y).margin(1e-6));
        CHECK(c.gradient.z == Approx(m.gradient.z).margin(1e-6));
    }
    return merged;
}

}  // namespace

TEST_CASE("default LoD: criteria hold for every leaf and fail for every inner node", "[lod]") {
    auto variant = GENERATE(bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite);
    Fixture f = make_fixture(variant);
    bih::LodConfig cfg;
    bih::Lod lod = bih::extract_lod(f.full, cfg);
    REQUIRE(lod.source.size() == lod.tree.nodes.size());
    CHECK(lod.tree.nodes.size() < f.full.tree.nodes.size());  // the solid block merges
    std::size_t merged = check_criteria(f, lod, cfg);
    CHECK(merged > 0);
    // the tree's bookkeeping: leaf i holds leaves[i], the stats describe this tree
    CHECK(lod.stats.nodes == lod.tree.nodes.size());
    CHECK(lod.stats.leaves == lod.leaves.size());
    CHECK(lod.stats.nodes == 2 * lod.stats.leaves - 1 + lod.stats.single_child_nodes);
    std::vector<std::uint32_t> depth = lodtest::node_depths(lod.tree);
    CHECK(lod.stats.max_depth == *std::max_element(depth.begin(), depth.end()));
    std::uint32_t next = 0;
    for (const bih::Node& n : lod.tree.nodes)
        if (n.leaf()) {
            CHECK(n.count == 1);
            CHECK(lod.tree.order[n.first] == n.first);
            ++next;
        }
    CHECK(next == lod.leaves.size());
    CHECK(lod.tree.bounds == f.full.tree.bounds);
}

TEST_CASE("every full-tree element lies in exactly one LoD leaf box", "[lod]") {
    Fixture f = make_fixture(bih::EmptyChildren::TrimBoth);
    bih::Lod lod = bih::extract_lod(f.full);
    std::vector<int> hits(f.cuboids.size(), 0);
    for (std::size_t e = 0; e < f.cuboids.size(); ++e)
        for (const VoxelCuboid& leaf : lod.leaves) hits[e] += leaf.box.contains(f.cuboids[e].box) ? 1 : 0;
    for (std::size_t e = 0; e < f.cuboids.size(); ++e) {
        INFO("element " << e);
        REQUIRE(hits[e] == 1);
    }
    // and the merged leaves conserve the element count
    std::size_t total = 0;
    for (std::size_t i = 0; i < lod.tree.nodes.size(); ++i)
        if (lod.tree.nodes[i].leaf()) total += f.full.stats[lod.source[i]].count;
    CHECK(total == f.cuboids.size());
}

TEST_CASE("a depth-limited LoD forces leaves at the limit and nowhere deeper", "[lod]") {
    Fixture f = make_fixture(bih::EmptyChildren::TrimBoth);
    bih::LodConfig cfg;
    cfg.max_depth = 6;
    bih::Lod lod = bih::extract_lod(f.full, cfg);
    CHECK(lod.stats.max_depth == 6);
    check_criteria(f, lod, cfg);
}

TEST_CASE("extreme criteria: never merge gives the full tree, always merge gives one leaf", "[lod]") {
    Fixture f = make_fixture(bih::EmptyChildren::TrimBoth);
    bih::LodConfig never;
    never.min_element_density = 2.0f;  // no box is twice full
    bih::Lod same = bih::extract_lod(f.full, never);
    CHECK(same.tree.nodes.size() == f.full.tree.nodes.size());
    CHECK(same.stats.max_depth == f.full.tree.stats.max_depth);
    REQUIRE(same.leaves.size() == f.cuboids.size());
    for (std::size_t i = 0; i < same.tree.nodes.size(); ++i) {
        const bih::Node& n = same.tree.nodes[i];
        if (!n.leaf()) continue;
        const VoxelCuboid& want = f.cuboids[f.full.tree.order[f.full.tree.nodes[same.source[i]].first]];
        CHECK(same.leaves[n.first].box == want.box);
        CHECK(same.leaves[n.first].density == want.density);
        CHECK(same.leaves[n.first].gradient == want.gradient);
    }
    bih::LodConfig always;
    always.min_element_density = 0.0f;
    always.max_std_dev = std::numeric_limits<float>::infinity();
    bih::Lod one = bih::extract_lod(f.full, always);
    REQUIRE(one.tree.nodes.size() == 1);
    CHECK(one.stats.max_depth == 0);
    CHECK(one.leaves[0].box == f.full.tree.bounds);
    double mean = 0.0;
    for (const VoxelCuboid& c : f.cuboids) mean += c.density;
    CHECK(one.leaves[0].density == Approx(mean / f.cuboids.size()).margin(1e-6));
}
