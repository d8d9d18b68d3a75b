// Builder: structure invariants, statistics, configuration, parallel == serial.
#include <catch2/catch.hpp>

#include <functional>

#include <sylva/bih/build.hpp>

#include "generators.hpp"

using namespace sylva;

namespace {
/// Walks the tree checking that every element sits in exactly one leaf and inside the box the
/// planes give that leaf; returns the leaf boxes' count.
std::size_t check_structure(const bih::Tree& t, std::span<const BoxElement> elems, const bih::Config& cfg) {
    std::vector<int> seen(elems.size(), 0);
    std::size_t leaves = 0;
    std::function<void(std::uint32_t, Aabb, std::uint32_t)> walk = [&](std::uint32_t i, Aabb box, std::uint32_t d) {
        const bih::Node& n = t.nodes[i];
        REQUIRE(d <= t.stats.max_depth);
        if (n.leaf()) {
            ++leaves;
            Aabb u;
            for (std::uint32_t k = 0; k < n.count; ++k) {
                std::uint32_t e = t.order[n.first + k];
                ++seen[e];
                CHECK(box.contains(elems[e].box));
                u.extend(elems[e].box);
            }
            if (cfg.trim_leaves && n.count <= cfg.max_leaf_elements && d < cfg.max_depth) CHECK(u == box);
            return;
        }
        int a = n.axis;
        if (n.single) {
            Aabb b = box;
            b.lo[a] = n.plane[0];
            b.hi[a] = n.plane[1];
            walk(n.child[0], b, d + 1);
            return;
        }
        REQUIRE(n.children() >= 1);
        if (n.child[0] != bih::kNoChild) {
            Aabb b = box;
            b.hi[a] = n.plane[0];
            walk(n.child[0], b, d + 1);
        }
        if (n.child[1] != bih::kNoChild) {
            Aabb b = box;
            b.lo[a] = n.plane[1];
            walk(n.child[1], b, d + 1);
        }
    };
    walk(0, t.bounds, 0);
    for (int s : seen) REQUIRE(s == 1);
    return leaves;
}
}  // namespace

TEST_CASE("every element lands in exactly one leaf whose box contains it", "[bih][build]") {
    for (auto mode : {bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite}) {
        for (std::uint32_t leaf_size : {1u, 3u}) {
            bih::Config cfg;
            cfg.empty_children = mode;
            cfg.max_leaf_elements = leaf_size;
            for (auto elems : {testing::random_boxes(2000, 11), testing::clustered_boxes(2000, 12),
                               testing::degenerate_boxes(1000, 13)}) {
                bih::Tree t = bih::build(std::span<const BoxElement>(elems), cfg);
                std::size_t leaves = check_structure(t, elems, cfg);
                CHECK(leaves == t.stats.leaves);
                CHECK(t.stats.nodes == t.nodes.size());
                CHECK(t.stats.max_depth <= SYLVA_BIH_DEPTH_CAP);
            }
        }
    }
}

TEST_CASE("node count is 2 leaves - 1 plus the single-child nodes (Kinkelin 3.3)", "[bih][build]") {
    auto elems = testing::random_boxes(5000, 21);
    bih::Tree t = bih::build(std::span<const BoxElement>(elems));
    CHECK(t.stats.nodes == 2 * t.stats.leaves - 1 + t.stats.single_child_nodes);
    CHECK(t.stats.leaves == elems.size());  // one element per leaf, no coincident ones
    CHECK(t.stats.percent_single_child() > 0.0);
}

TEST_CASE("trim-both needs fewer single-child nodes than +-inf planes", "[bih][build]") {
    auto elems = testing::random_boxes(5000, 22);
    bih::Config inf;
    inf.empty_children = bih::EmptyChildren::Infinite;
    bih::Tree a = bih::build(std::span<const BoxElement>(elems));
    bih::Tree b = bih::build(std::span<const BoxElement>(elems), inf);
    CHECK(a.stats.single_child_nodes < b.stats.single_child_nodes);
    CHECK(a.stats.leaves == b.stats.leaves);
}

TEST_CASE("parallel build equals the serial build", "[bih][build]") {
    auto elems = testing::clustered_boxes(200000, 23);
    std::span<const BoxElement> es(elems);
    bih::Config cfg;
    cfg.parallel_threshold = 1000;
    ThreadPool pool(2);
    bih::Tree s = bih::build(es, cfg);
    bih::Tree p = bih::build(es, cfg, pool);
    REQUIRE(s.nodes.size() == p.nodes.size());
    CHECK(s.order == p.order);
    CHECK(s.stats.max_depth == p.stats.max_depth);
    CHECK(s.stats.single_child_nodes == p.stats.single_child_nodes);
}

TEST_CASE("max depth is honoured and leaves then hold several elements", "[bih][build]") {
    auto elems = testing::random_boxes(4000, 24);
    bih::Config cfg;
    cfg.max_depth = 5;
    bih::Tree t = bih::build(std::span<const BoxElement>(elems), cfg);
    CHECK(t.stats.max_depth == 5);
    CHECK(t.stats.max_leaf_elements > 1);
    check_structure(t, elems, cfg);
}

TEST_CASE("progress is reported up to completion", "[bih][build]") {
    auto elems = testing::random_boxes(20000, 25);
    double last = 0.0;
    int calls = 0;
    bih::Config cfg;
    cfg.on_progress = [&](double f) {
        CHECK(f >= last);
        last = f;
        ++calls;
    };
    bih::build(std::span<const BoxElement>(elems), cfg);
    CHECK(calls >= 50);
    CHECK(last == Approx(1.0));
}
