// bih::WideTree (a BIH collapsed into 8-wide nodes for host queries) against brute force.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <set>

#include <sylva/bih/build.hpp>
#include <sylva/bih/wide.hpp>
#include <sylva/bih/wide_build.hpp>

#include "generators.hpp"

using namespace sylva;

namespace {

struct Source {
    const char* name;
    bih::Config build;
};

std::vector<Source> sources() {
    bih::Config infinite, leaf4, filled;
    infinite.empty_children = bih::EmptyChildren::Infinite;
    leaf4.max_leaf_elements = 4;
    leaf4.trim_leaves = false;
    filled = leaf4;
    filled.fill_below = 32;
    return {{"default (trim-both, 1 a leaf)", {}},
            {"infinite planes", infinite},
            {"4 a leaf", leaf4},
            {"4 a leaf, filled below 32", filled},
            {"for_queries (32 a leaf)", bih::Config::for_queries()}};
}

/// first_hit and all_hits over WideTrees of several BIHs and leaf sizes equal brute force.
template <class E>
void check_wide_against_brute_force(const std::vector<E>& elems, const std::vector<Ray>& rays) {
    std::span<const E> es(elems);
    ThreadPool pool(2);
    for (const Source& src : sources()) {
        bih::Tree tree = bih::build(es, src.build, pool);
        for (std::uint32_t leaf : {0u, 1u, 4u, 8u}) {
            INFO("BIH " << src.name << ", WideConfig::max_leaf_elements " << leaf);
            bih::WideTree<E> serial(tree, es, bih::WideConfig{leaf});
            // The same tree through the pool's constructor (from 2^13 BIH nodes, as some of
            // these trees have, the collapse runs on the pool; the 50,000-sphere case below
            // checks its node order in depth): same counts, same answers.
            bih::WideTree<E> wide(tree, es, bih::WideConfig{leaf}, pool);
            REQUIRE(wide.stats().nodes > 0);
            CHECK(wide.stats().nodes == serial.stats().nodes);
            CHECK(wide.stats().leaves == serial.stats().leaves);
            CHECK(wide.stats().depth == serial.stats().depth);
            CHECK(wide.stats().bytes == serial.stats().bytes);
            std::vector<bih::ElementHit> hits;
            std::size_t total = 0, mismatches = 0;
            for (std::size_t i = 0; i < rays.size(); ++i) {
                Interval range = i % 5 == 0 ? Interval{0.25f, 1.75f} : Interval{};
                auto expected = bih::brute_force_hits(es, rays[i], range);
                bih::all_hits(wide, rays[i], hits, range);
                total += expected.size();
                if (hits != expected) ++mismatches;
                auto first = bih::first_hit(wide, rays[i], range);
                if (expected.empty() ? first.has_value() : (!first || *first != expected.front())) ++mismatches;
                bih::all_hits(serial, rays[i], hits, range);
                if (hits != expected) ++mismatches;
            }
            CHECK(mismatches == 0);
            CHECK(total > rays.size() / 10);  // the rays really hit things
        }
    }
}

/// Every element sits in exactly one leaf, and every child box holds the boxes of what lies below.
template <class E>
void check_structure(const bih::WideTree<E>& wide, std::span<const E> es) {
    std::multiset<std::uint32_t> seen;
    std::size_t leaves = 0;
    auto nodes = wide.nodes();
    std::vector<std::pair<std::uint32_t, Aabb>> todo{{0u, Aabb{vec3(-1e30f), vec3(1e30f)}}};
    while (!todo.empty()) {
        auto [at, outer] = todo.back();
        todo.pop_back();
        const bih::WideNode& n = nodes[at];
        for (int c = 0; c < bih::kWideWidth; ++c) {
            if (n.child[c] == bih::kNoChild) continue;
            Aabb box{vec3(n.box[0][c], n.box[2][c], n.box[4][c]), vec3(n.box[1][c], n.box[3][c], n.box[5][c])};
            CHECK(outer.contains(box));
            if (n.count[c] == 0) {
                todo.push_back({n.child[c], box});
                continue;
            }
            ++leaves;
            wide.for_each_leaf_element(n.child[c], n.count[c], [&](std::uint32_t id) {
                seen.insert(id);
                CHECK(box.contains(bounds_of(es[id])));
            });
        }
    }
    CHECK(leaves == wide.stats().leaves);
    REQUIRE(seen.size() == es.size());
    std::uint32_t expect = 0;
    for (std::uint32_t id : seen) CHECK(id == expect++);
}

}  // namespace

TEST_CASE("queries over a WideTree equal brute force on spheres", "[bih][wide]") {
    auto c = testing::sphere_cases(71);
    check_wide_against_brute_force(c.spheres, c.rays);
}

TEST_CASE("queries over a WideTree equal brute force on random, clustered and degenerate boxes", "[bih][wide]") {
    check_wide_against_brute_force(testing::random_boxes(3000, 73),
                                   testing::random_rays(10000, {vec3(0.0f), vec3(1.05f)}, 74));
    check_wide_against_brute_force(testing::clustered_boxes(3000, 75),
                                   testing::random_rays(10000, {vec3(0.0f), vec3(10.0f)}, 76));
    check_wide_against_brute_force(testing::degenerate_boxes(2000, 77),
                                   testing::random_rays(10000, {vec3(0.0f), vec3(1.0f)}, 78));
}

TEST_CASE("WideConfig chooses the leaf size by the tree's size unless told", "[bih][wide]") {
    CHECK(bih::WideConfig{}.leaf_size(1000) == 4u);
    CHECK(bih::WideConfig{}.leaf_size(bih::WideConfig::kSmallTree) == 4u);
    CHECK(bih::WideConfig{}.leaf_size(bih::WideConfig::kSmallTree + 1) == 8u);
    CHECK(bih::WideConfig{3}.leaf_size(1u << 24) == 3u);
    // Leaves hold at most the chosen size (or a whole BIH leaf), so the choice shows in the tree.
    auto spheres = testing::random_spheres(20000, 86);
    std::span<const Sphere> ss(spheres);
    bih::Tree tree = bih::build(ss, bih::Config{});  // one sphere a BIH leaf
    bih::WideTree<Sphere> four(tree, ss), eight(tree, ss, bih::WideConfig{8});
    CHECK(eight.stats().leaves < four.stats().leaves);
    for (const auto* w : {&four, &eight}) {
        std::size_t biggest = 0;
        for (const bih::WideNode& n : w->nodes())
            for (int c = 0; c < bih::kWideWidth; ++c)
                if (n.count[c] != 0) {
                    std::size_t k = 0;
                    w->for_each_leaf_element(n.child[c], n.count[c], [&](std::uint32_t) { ++k; });
                    biggest = std::max(biggest, k);
                }
        CHECK(biggest == (w == &four ? 4u : 8u));
    }
}

/// build_wide (a BIH of wide_source_config, then the collapse) against that BIH collapsed by
/// hand (the same nodes, leaves and depth) and the WideTree of the 4-a-leaf BIH (the same
/// answers).
template <class E>
void check_build_wide(const std::vector<E>& elems, const std::vector<Ray>& rays) {
    std::span<const E> es(elems);
    ThreadPool pool(2);
    const bih::Config src = bih::wide_source_config(es.size());
    CHECK(src.max_leaf_elements == bih::WideConfig{}.leaf_size(es.size()));
    CHECK_FALSE(src.trim_leaves);
    CHECK(bih::wide_source_config(es.size(), bih::WideConfig{13}).max_leaf_elements == 13u);
    CHECK(src.fill_below == 32u);
    CHECK(src.fill_width == 4u);
    bih::Config leaf4;
    leaf4.max_leaf_elements = 4;
    leaf4.trim_leaves = false;
    const bih::WideTree<E> from_leaf4(bih::build(es, leaf4, pool), es, bih::WideConfig{}, pool);
    const bih::WideTree<E> from_source(bih::build(es, src, pool), es, bih::WideConfig{}, pool);
    const bih::WideTree<E> wide = bih::build_wide(es, bih::WideConfig{}, pool);
    const bih::WideTree<E> serial = bih::build_wide(es);
    for (const bih::WideTree<E>* w : {&wide, &serial}) {
        REQUIRE(w->stats().nodes > 0);
        CHECK(w->stats().nodes == from_source.stats().nodes);
        CHECK(w->stats().leaves == from_source.stats().leaves);
        CHECK(w->stats().depth == from_source.stats().depth);
        CHECK(w->stats().bytes == from_source.stats().bytes);
        check_structure(*w, es);
    }
    std::vector<bih::ElementHit> hits, expected;
    std::size_t total = 0, mismatches = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        bih::all_hits(from_leaf4, rays[i], expected);
        if (i % 10 == 0) CHECK(expected == bih::brute_force_hits(es, rays[i]));
        total += expected.size();
        for (const bih::WideTree<E>* w : {&wide, &serial}) {
            bih::all_hits(*w, rays[i], hits);
            if (hits != expected) ++mismatches;
            if (bih::first_hit(*w, rays[i]) != bih::first_hit(from_leaf4, rays[i])) ++mismatches;
        }
    }
    CHECK(mismatches == 0);
    CHECK(total > rays.size());
}

TEST_CASE("build_wide collapses the BIH of wide_source_config and answers as the 4-a-leaf BIH's WideTree",
          "[bih][wide]") {
    SECTION("40,000 spheres: leaves of 8, half the BIH") {
        auto spheres = testing::random_spheres(40000, 91);
        REQUIRE(bih::WideConfig{}.leaf_size(spheres.size()) == 8u);
        check_build_wide(spheres, testing::random_rays(2000, {vec3(-1.0f), vec3(1.0f)}, 92));
    }
    SECTION("clustered boxes above and below 2^15") {
        check_build_wide(testing::clustered_boxes(40000, 93), testing::random_rays(2000, {vec3(0.0f), vec3(10.0f)}, 94));
        check_build_wide(testing::clustered_boxes(3000, 95), testing::random_rays(2000, {vec3(0.0f), vec3(10.0f)}, 96));
    }
    SECTION("bad input is refused as bih::build refuses it") {
        std::vector<Sphere> none;
        CHECK_THROWS_WITH(bih::build_wide(std::span<const Sphere>(none)), Catch::Contains("no elements"));
        auto spheres = testing::random_spheres(100, 97);
        spheres[42].radius = std::numeric_limits<float>::quiet_NaN();
        CHECK_THROWS_WITH(bih::build_wide(std::span<const Sphere>(spheres)), Catch::Contains("42"));
    }
}

TEST_CASE("a WideTree holds every element once, inside every box above it", "[bih][wide]") {
    auto spheres = testing::random_spheres(5000, 79);
    auto boxes = testing::degenerate_boxes(3000, 80);
    std::span<const Sphere> ss(spheres);
    std::span<const BoxElement> bs(boxes);
    ThreadPool pool(2);
    for (const Source& src : sources()) {
        INFO("BIH " << src.name);
        for (std::uint32_t leaf : {1u, 4u, 8u, 13u}) {
            check_structure(bih::WideTree<Sphere>(bih::build(ss, src.build), ss, bih::WideConfig{leaf}), ss);
            check_structure(bih::WideTree<BoxElement>(bih::build(bs, src.build), bs, bih::WideConfig{leaf}), bs);
            check_structure(bih::WideTree<Sphere>(bih::build(ss, src.build), ss, bih::WideConfig{leaf}, pool), ss);
            check_structure(bih::WideTree<BoxElement>(bih::build(bs, src.build), bs, bih::WideConfig{leaf}, pool), bs);
        }
    }
}

TEST_CASE("a WideTree of 50,000 spheres made on a thread pool answers as the serial one", "[bih][wide]") {
    // From 2^13 BIH nodes the refit forks and the subtrees below the top two wide levels are
    // made in parallel and appended: other node order, the same nodes, leaves, depth and hits.
    auto spheres = testing::random_spheres(50000, 86);
    std::span<const Sphere> ss(spheres);
    ThreadPool pool(2);
    bih::Tree tree = bih::build(ss, bih::Config{}, pool);
    REQUIRE(tree.nodes.size() >= (std::size_t{1} << 15));
    auto rays = testing::random_rays(1000, {vec3(-1.0f), vec3(1.0f)}, 87);
    for (std::uint32_t leaf : {1u, 4u}) {
        INFO("WideConfig::max_leaf_elements " << leaf);
        bih::WideTree<Sphere> serial(tree, ss, bih::WideConfig{leaf});
        bih::WideTree<Sphere> wide(tree, ss, bih::WideConfig{leaf}, pool);
        CHECK(wide.stats().nodes == serial.stats().nodes);
        CHECK(wide.stats().leaves == serial.stats().leaves);
        CHECK(wide.stats().depth == serial.stats().depth);
        CHECK(wide.stats().bytes == serial.stats().bytes);
        CHECK(wide.stats().depth >= 4u);  // parts below depth 3 were made
        check_structure(wide, ss);
        std::vector<bih::ElementHit> hits, expected;
        std::size_t mismatches = 0, total = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
            bih::all_hits(serial, rays[i], expected);
            if (i % 10 == 0) CHECK(expected == bih::brute_force_hits(ss, rays[i]));
            bih::all_hits(wide, rays[i], hits);
            total += hits.size();
            if (hits != expected) ++mismatches;
            if (bih::first_hit(wide, rays[i]) != bih::first_hit(serial, rays[i])) ++mismatches;
        }
        CHECK(mismatches == 0);
        CHECK(total > rays.size());
    }
    bih::Tree past = tree;  // refused from inside the parallel refit too
    for (auto& n : past.nodes)
        if (n.leaf()) n.first = static_cast<std::uint32_t>(past.order.size());
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(past, ss, bih::WideConfig{}, pool), Catch::Contains("past the tree's order"));
}

TEST_CASE("WideTree rays lying in box planes see the closed boxes", "[bih][wide]") {
    auto elems = testing::grid_boxes(8);  // unit cells: rays along integer planes touch two cells
    std::span<const BoxElement> es(elems);
    bih::WideTree<BoxElement> wide(bih::build(es, bih::Config{}), es);
    std::vector<bih::ElementHit> hits;
    std::size_t mismatches = 0, total = 0;
    for (int k = 0; k <= 8; ++k)
        for (int j = 0; j <= 8; ++j) {
            float y = static_cast<float>(k), z = static_cast<float>(j);
            for (vec3 dir : {vec3(1.0f, 0.0f, 0.0f), vec3(-1.0f, -0.0f, 0.0f), vec3(1.0f, 0.0f, -0.0f)}) {
                Ray r{vec3(dir.x > 0 ? -1.0f : 9.0f, y, z), dir};
                auto expected = bih::brute_force_hits(es, r);
                bih::all_hits(wide, r, hits);
                total += expected.size();
                mismatches += hits == expected ? 0 : 1;
                auto first = bih::first_hit(wide, r);
                mismatches += expected.empty() ? first.has_value() : (!first || *first != expected.front());
            }
        }
    CHECK(mismatches == 0);
    CHECK(total > 500);
}

TEST_CASE("WideTree spheres decide grazing rays exactly as Sphere::intersect", "[bih][wide]") {
    auto g = testing::grazing_set(40000, 81);
    std::span<const Sphere> es(g.spheres);
    bih::WideTree<Sphere> wide(bih::build(es, bih::Config{}), es);
    std::vector<bih::ElementHit> hits;
    std::size_t mismatches = 0, grazing_hits = 0;
    for (std::size_t k = 0; k < g.rays.size(); ++k) {
        auto expected = bih::brute_force_hits(es, g.rays[k]);
        bih::all_hits(wide, g.rays[k], hits);
        if (hits != expected) ++mismatches;
        for (const auto& h : expected) grazing_hits += h.element == g.target(k) ? 1 : 0;
    }
    CHECK(mismatches == 0);
    CHECK(grazing_hits > g.rays.size() / 10);  // both sides of the rim occur
    CHECK(grazing_hits < g.rays.size() * 9 / 10);
}

TEST_CASE("a WideTree ray that enters every node (more pending nodes than the walk's ring) finds every box",
          "[bih][wide]") {
    // 20000 overlapping boxes that all contain the x axis: the all-hits walk enters every wide
    // node, so its FIFO ring of pending nodes fills and the overflow stack takes over.
    std::mt19937 rng(77);
    std::uniform_real_distribution<float> u(0.0f, 4.0f);
    std::vector<BoxElement> elems;
    for (int i = 0; i < 20000; ++i) {
        vec3 c(u(rng), u(rng) - 2.0f, u(rng) - 2.0f);
        vec3 h(0.5f + u(rng), 2.5f, 2.5f);  // |c.y|, |c.z| <= 2 < 2.5: the x axis passes through
        elems.push_back(BoxElement{Aabb{c - h, c + h}});
    }
    std::span<const BoxElement> es(elems);
    bih::Config leaf4;
    leaf4.max_leaf_elements = 4;
    leaf4.trim_leaves = false;
    bih::WideTree<BoxElement> wide(bih::build(es, leaf4), es, bih::WideConfig{4});
    for (vec3 o : {vec3(-9.0f, 0.0f, 0.0f), vec3(-9.0f, 0.25f, -0.5f), vec3(13.0f, 0.0f, 0.0f)}) {
        Ray ray{o, vec3(o.x < 0.0f ? 1.0f : -1.0f, 0.0f, 0.0f)};
        auto visits = wide.visits(ray);
        CHECK(visits.nodes == wide.stats().nodes);  // every node entered
        CHECK(visits.nodes > 1000u);
        std::vector<bih::ElementHit> hits;
        bih::all_hits(wide, ray, hits);
        CHECK(hits.size() == elems.size());
        CHECK(hits == bih::brute_force_hits(es, ray));
    }
}

TEST_CASE("a WideTree of 5000 coincident spheres (a leaf at the depth cap) answers exactly", "[bih][wide]") {
    std::vector<Sphere> elems(5000, Sphere{vec3(0.5f), 0.1f, vec4(1.0f), 2.0f});
    std::span<const Sphere> es(elems);
    bih::Tree tree = bih::build(es, bih::Config{});
    bih::WideTree<Sphere> wide(tree, es);
    CHECK(wide.stats().depth <= SYLVA_BIH_DEPTH_CAP + 1);
    std::vector<bih::ElementHit> hits;
    bih::all_hits(wide, Ray{vec3(0.5f, 0.5f, -1.0f), vec3(0.0f, 0.0f, 1.0f)}, hits);
    REQUIRE(hits.size() == elems.size());
    for (std::uint32_t k = 0; k < hits.size(); ++k) CHECK(hits[k].element == k);  // ties: by index
    auto first = bih::first_hit(wide, Ray{vec3(0.5f, 0.5f, -1.0f), vec3(0.0f, 0.0f, 1.0f)});
    REQUIRE(first);
    CHECK(first->element == 0u);
}

using testing::PinnedBox;

TEST_CASE("WideTree takes element types without a default constructor", "[bih][wide]") {
    std::vector<PinnedBox> elems;
    for (const BoxElement& b : testing::random_boxes(500, 82)) elems.emplace_back(b.box);
    std::span<const PinnedBox> es(elems);
    bih::WideTree<PinnedBox> wide(bih::build(es, bih::Config::for_queries()), es);
    std::vector<bih::ElementHit> hits;
    std::size_t mismatches = 0, total = 0;
    for (const Ray& r : testing::random_rays(3000, {vec3(0.0f), vec3(1.05f)}, 83)) {
        bih::all_hits(wide, r, hits);
        auto expected = bih::brute_force_hits(es, r);
        total += expected.size();
        mismatches += hits == expected ? 0 : 1;
    }
    CHECK(mismatches == 0);
    CHECK(total > 300);
}

namespace {
/// n spheres of radius 0.4 along the x axis, at x = 0, 1, ..., n - 1 (for hand-made trees).
std::vector<Sphere> sphere_row(int n) {
    std::vector<Sphere> out;
    for (int i = 0; i < n; ++i)
        out.push_back(Sphere{vec3(static_cast<float>(i), 0.0f, 0.0f), 0.4f, vec4(1.0f), 2.0f});
    return out;
}
/// A tree with no nodes yet whose order is 0, 1, ..., n - 1.
bih::Tree tree_in_order(std::size_t n) {
    bih::Tree t;
    t.order.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) t.order[i] = i;
    return t;
}
}  // namespace

TEST_CASE("WideTree refuses trees that do not fit, and an empty tree hits nothing", "[bih][wide][bad-input]") {
    auto many = testing::random_spheres(200, 84);
    auto few = testing::random_spheres(50, 85);
    std::span<const Sphere> ms(many), fs(few);
    bih::Tree big = bih::build(ms, bih::Config{});
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(big, fs), Catch::Contains("refers to element"));

    bih::Tree cyclic = big;  // an inner node whose child links back to the root
    for (auto& n : cyclic.nodes)
        if (!n.leaf() && n.child[0] != bih::kNoChild) {
            n.child[0] = 0;
            break;
        }
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(cyclic, ms), Catch::Contains("reached twice"));
    bih::Tree dangling = big;
    dangling.nodes[0].child[1] = static_cast<std::uint32_t>(dangling.nodes.size()) + 5u;
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(dangling, ms), Catch::Contains("links to node"));
    bih::Tree past = big;
    for (auto& n : past.nodes)
        if (n.leaf()) n.first = static_cast<std::uint32_t>(past.order.size());
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(past, ms), Catch::Contains("past the tree's order"));
    ThreadPool pool(2);  // the same refusals through the pool's constructor (the 50,000-sphere
                         // case above has one thrown from inside the parallel refit)
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(cyclic, ms, bih::WideConfig{}, pool), Catch::Contains("reached twice"));
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(past, ms, bih::WideConfig{}, pool), Catch::Contains("past the tree's order"));

    // A hand-made chain deeper than the builder's cap (1000 levels): refused, so the query
    // stacks and the refit's recursion stay bounded.
    std::vector<Sphere> line = sphere_row(1000);
    bih::Tree deep = tree_in_order(line.size());
    // Node 2i is inner, 2i + 1 the leaf of element i, 2i + 2 the rest.
    for (std::uint32_t i = 0; i + 1 < line.size(); ++i) {
        bih::Node inner;
        inner.axis = 0;
        inner.child[0] = 2 * i + 1;
        inner.child[1] = 2 * i + 2;
        bih::Node leaf;
        leaf.first = i;
        leaf.count = 1;
        deep.nodes.push_back(inner);
        deep.nodes.push_back(leaf);
    }
    bih::Node last;
    last.first = static_cast<std::uint32_t>(line.size()) - 1u;
    last.count = 1;
    deep.nodes.push_back(last);
    std::span<const Sphere> ls(line);
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(deep, ls, bih::WideConfig{1}), Catch::Contains("deeper than"));
    CHECK_THROWS_WITH(bih::WideTree<Sphere>(deep, ls, bih::WideConfig{1}, pool), Catch::Contains("deeper than"));

    bih::WideTree<Sphere> empty;
    std::vector<bih::ElementHit> hits{{1u, {}}};
    bih::all_hits(empty, Ray{vec3(0.0f), vec3(1.0f, 0.0f, 0.0f)}, hits);
    CHECK(hits.empty());
    CHECK_FALSE(bih::first_hit(empty, Ray{vec3(0.0f), vec3(1.0f, 0.0f, 0.0f)}));
}

TEST_CASE("a WideTree of a root that only leads to one big BIH leaf holds each element once", "[bih][wide]") {
    // Hand-made: the root has one child, a leaf of 10 spheres (more than the wide leaf size of
    // 4, as a leaf at the depth cap has). The collapse's chain of one child ends in a leaf: one
    // slot, each sphere once (a ray along the row hits all ten, each one time).
    std::vector<Sphere> row = sphere_row(10);
    bih::Tree tree = tree_in_order(row.size());
    bih::Node root;
    root.axis = 0;
    root.single = true;
    root.child[0] = 1;
    bih::Node leaf;
    leaf.first = 0;
    leaf.count = static_cast<std::uint32_t>(row.size());
    tree.nodes.push_back(root);
    tree.nodes.push_back(leaf);
    std::span<const Sphere> es(row);
    bih::WideTree<Sphere> wide(tree, es, bih::WideConfig{4});
    CHECK(wide.stats().leaves == 1);
    const Ray along{vec3(-5.0f, 0.0f, 0.0f), vec3(1.0f, 0.0f, 0.0f)};
    std::vector<bih::ElementHit> hits;
    bih::all_hits(wide, along, hits);
    const auto expected = bih::brute_force_hits(es, along, Interval{});
    REQUIRE(hits.size() == expected.size());
    CHECK(hits.size() == row.size());
    for (std::size_t i = 0; i < hits.size(); ++i) CHECK(hits[i].element == expected[i].element);
}

#ifdef SYLVA_BIH_WIDE_AVX2
TEST_CASE("the AVX2 node test gives the SSE test's mask and entry t bit for bit", "[bih][wide]") {
    if (!bih::detail::cpu_has_avx2()) {
        WARN("this CPU has no AVX2: the AVX2 node test is not run");
        return;
    }
    std::mt19937 rng(2024);
    std::uniform_real_distribution<float> u(-2.0f, 2.0f);
    const float inf = std::numeric_limits<float>::infinity();
    // Boxes with coincident, inverted and unused (lo = +inf, hi = -inf) slots; rays with zero,
    // signed-zero and tiny direction components (inf reciprocals, NaN slabs in box planes).
    const float specials[] = {0.0f, -0.0f, 1e-30f, -1e-30f, 1.0f};
    std::size_t differing = 0, entered = 0, cases = 0;
    for (int t = 0; t < 20000; ++t) {
        bih::WideNode n{};
        for (int c = 0; c < bih::kWideWidth; ++c) {
            int kind = static_cast<int>(rng() % 8u);
            for (int a = 0; a < 3; ++a) {
                float x = u(rng), y = kind == 0 ? x : u(rng);
                n.box[2 * a][c] = kind == 7 ? inf : std::min(x, y);
                n.box[2 * a + 1][c] = kind == 7 ? -inf : (kind == 6 ? std::min(x, y) - 0.5f : std::max(x, y));
            }
        }
        Ray ray{vec3(u(rng), u(rng), u(rng)), vec3(u(rng), u(rng), u(rng))};
        if (t % 3 == 0) ray.direction[static_cast<int>(rng() % 3u)] = specials[rng() % 5u];
        if (t % 5 == 0) ray.origin[static_cast<int>(rng() % 3u)] = n.box[rng() % 6u][rng() % 8u];  // in a plane
        bih::detail::WideRay r(ray);
        float t0 = t % 7 == 0 ? -inf : 0.0f, t1 = t % 11 == 0 ? 0.5f : inf;
        float tn_sse[bih::kWideWidth], tn_avx[bih::kWideWidth];
        int m_sse = bih::detail::BaseNodeTest::enter(n, r, t0, t1, tn_sse);
        int m_avx = bih::detail::Avx2NodeTest::enter(n, r, t0, t1, tn_avx);
        bool same = m_sse == m_avx;
        for (int c = 0; c < bih::kWideWidth; ++c)
            if (m_sse & (1 << c)) same = same && std::memcmp(&tn_sse[c], &tn_avx[c], sizeof(float)) == 0;
        differing += same ? 0 : 1;
        entered += static_cast<std::size_t>(__builtin_popcount(static_cast<unsigned>(m_sse)));
        ++cases;
    }
    CHECK(differing == 0);
    CHECK(entered > cases / 4);  // slots are entered often enough for the comparison to mean something
}
#endif

TEST_CASE("the walk's compress keeps the masked slots in slot order, on every mask", "[bih][wide]") {
    // The reference is the definition: slot c is kept when bit c is set, in ascending order.
    std::uint32_t a[bih::kWideWidth], b[bih::kWideWidth];
    for (int c = 0; c < bih::kWideWidth; ++c) {
        a[c] = 100u + static_cast<std::uint32_t>(c);
        b[c] = 200u + static_cast<std::uint32_t>(c);
    }
    std::size_t wrong = 0;
    for (int mask = 0; mask < (1 << bih::kWideWidth); ++mask) {
        std::vector<std::uint32_t> want;
        for (int c = 0; c < bih::kWideWidth; ++c)
            if (mask & (1 << c)) want.push_back(static_cast<std::uint32_t>(c));
        auto check = [&](auto test) {
            std::uint32_t out[bih::kWideWidth];
            bih::detail::LeafRef pairs[bih::kWideWidth];
            const int k = decltype(test)::compress(a, mask, out);
            const int kp = decltype(test)::compress_pairs(a, b, mask, pairs);
            bool same = k == static_cast<int>(want.size()) && kp == k;
            for (int j = 0; same && j < k; ++j)
                same = out[j] == a[want[j]] && pairs[j].first == a[want[j]] && pairs[j].count == b[want[j]];
            wrong += same ? 0 : 1;
        };
        check(bih::detail::BaseNodeTest{});
#ifdef SYLVA_BIH_WIDE_AVX2
        if (bih::detail::cpu_has_avx2()) check(bih::detail::Avx2NodeTest{});
#endif
    }
    CHECK(wrong == 0);
}

TEST_CASE("all_hits finds every hit when more nodes are pending than its queue holds", "[bih][wide]") {
    // A ray along a row of 20,000 spheres enters every node of the tree: hundreds of nodes are
    // pending at once, so the walk's queue (64 nodes) moves its pending nodes to the front and
    // then sends whole nodes' children to its stack. Every sphere is hit, each once, in order.
    // 160,000 spheres make a tree of more than 1 MiB of nodes, which the walk prefetches with a
    // queue of 256 nodes: thousands pending, the same overflow.
    for (int count : {20000, 160000}) {
        std::vector<Sphere> row = sphere_row(count);
        std::span<const Sphere> es(row);
        for (std::uint32_t leaf : {4u, 8u}) {
            bih::Tree tree = bih::build(es, bih::wide_source_config(row.size(), bih::WideConfig{leaf}));
            bih::WideTree<Sphere> wide(tree, es, bih::WideConfig{leaf});
            if (count > 100000) CHECK(wide.stats().nodes * sizeof(bih::WideNode) > (std::size_t{1} << 20));
            const Ray along{vec3(-5.0f, 0.0f, 0.0f), vec3(1.0f, 0.0f, 0.0f)};
            CHECK(wide.visits(along).nodes == wide.stats().nodes);
            std::vector<bih::ElementHit> hits;
            bih::all_hits(wide, along, hits);
            const auto expected = bih::brute_force_hits(es, along, Interval{});
            REQUIRE(expected.size() == row.size());
            REQUIRE(hits.size() == expected.size());
            std::size_t differing = 0;
            for (std::size_t i = 0; i < hits.size(); ++i) differing += hits[i].element == expected[i].element ? 0 : 1;
            CHECK(differing == 0);
        }
    }
}

namespace {
/// The slots of `slots` farthest first by entry t, as a sort gives them (ties in slot order).
std::vector<int> far_first_by_sort(const float tn[bih::kWideWidth], int slots) {
    std::vector<int> order;
    for (int c = 0; c < bih::kWideWidth; ++c)
        if (slots & (1 << c)) order.push_back(c);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return tn[a] > tn[b]; });
    return order;
}
/// Equal, or finite and within a few ulps (what the rank's dropped low bits may not tell apart).
bool within_ulps(float a, float b) { return a == b || std::fabs(a - b) <= std::max(std::fabs(a), std::fabs(b)) * 1e-6f; }
}  // namespace

TEST_CASE("first_hit's walk ranks entered children farthest first, as a sort of their entry t", "[bih][wide]") {
    std::mt19937 rng(77);
    std::uniform_real_distribution<float> u(-3.0f, 3.0f);
    const float inf = std::numeric_limits<float>::infinity();
    std::size_t compared = 0;
    for (int t = 0; t < 20000; ++t) {
        float tn[bih::kWideWidth];
        for (int c = 0; c < bih::kWideWidth; ++c) {
            int kind = static_cast<int>(rng() % 10u);
            tn[c] = kind == 0 ? 0.0f : kind == 1 ? -0.0f : kind == 2 ? inf : kind == 3 ? -inf : u(rng);
        }
        const int slots = static_cast<int>(rng() % 256u);
        int rank[bih::kWideWidth];
        bih::detail::BaseNodeTest::rank_far_first(tn, slots, rank);
        const int k = __builtin_popcount(static_cast<unsigned>(slots));
        std::vector<int> at(static_cast<std::size_t>(k), -1);
        for (int c = 0; c < bih::kWideWidth; ++c) {
            if (!(slots & (1 << c))) {
                CHECK(rank[c] == k);  // stored above the entered ones
                continue;
            }
            REQUIRE(rank[c] >= 0);
            REQUIRE(rank[c] < k);
            CHECK(at[static_cast<std::size_t>(rank[c])] == -1);  // a permutation
            at[static_cast<std::size_t>(rank[c])] = c;
        }
        // The order by rank is the order by entry t; only the keys' dropped low bits (and
        // -0 == 0) may reorder slots whose t are within 8 ulps of each other.
        std::vector<int> sorted = far_first_by_sort(tn, slots);
        for (std::size_t i = 0; i + 1 < at.size(); ++i) {
            const float a = tn[at[i]], b = tn[at[i + 1]];
            CHECK((a >= b || within_ulps(a, b)));
        }
        for (std::size_t i = 0; i < at.size(); ++i) CHECK(within_ulps(tn[at[i]], tn[sorted[i]]));
        compared += static_cast<std::size_t>(k);
#ifdef SYLVA_BIH_WIDE_AVX2
        if (bih::detail::cpu_has_avx2()) {
            int rank_avx[bih::kWideWidth];
            bih::detail::Avx2NodeTest::rank_far_first(tn, slots, rank_avx);
            for (int c = 0; c < bih::kWideWidth; ++c) CHECK(rank_avx[c] == rank[c]);
        }
#endif
    }
    CHECK(compared > 50000);
}

namespace {

/// The collapse's objective found by enumeration: over every way of grouping a BIH's subtrees
/// into wide nodes of at most kWideWidth slots, the least sum of the wide nodes' box
/// half-areas. A subtree that is a BIH leaf or a contiguous run of at most `leaf` elements is
/// a leaf slot and never opened. Independent of the builder's dynamic programme: each wide
/// node's slots are found by opening subtrees one by one in every order.
class CollapseReference {
public:
    CollapseReference(const bih::Tree& tree, std::span<const Sphere> es, std::uint32_t leaf)
        : tree_(tree), es_(es), leaf_(leaf), facts_(tree.nodes.size()), cost_(tree.nodes.size(), -1.0) {
        gather(0);
    }
    /// The least total half-area of the wide nodes (0 when the root is a leaf).
    double least() { return is_leaf(0) ? 0.0 : node_cost(0); }

private:
    struct Facts {
        Aabb box;
        std::uint32_t count = 0, lo = UINT32_MAX, hi = 0;  ///< elements, their order range
    };
    const bih::Tree& tree_;
    std::span<const Sphere> es_;
    std::uint32_t leaf_;
    std::vector<Facts> facts_;
    std::vector<double> cost_;

    static double half_area(const Aabb& b) {
        const double x = b.hi.x - b.lo.x, y = b.hi.y - b.lo.y, z = b.hi.z - b.lo.z;
        return x * y + y * z + z * x;
    }
    std::vector<std::uint32_t> kids(std::uint32_t n) const {
        std::vector<std::uint32_t> out;
        const bih::Node& node = tree_.nodes[n];
        if (node.leaf()) return out;
        for (int s = 0; s < (node.single ? 1 : 2); ++s)
            if (node.child[s] != bih::kNoChild && facts_[node.child[s]].count != 0) out.push_back(node.child[s]);
        return out;
    }
    void gather(std::uint32_t n) {
        Facts& f = facts_[n];
        const bih::Node& node = tree_.nodes[n];
        if (node.leaf()) {
            for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
                f.box.extend(es_[tree_.order[k]].bounds());
                f.lo = std::min(f.lo, k);
                f.hi = std::max(f.hi, k + 1);
            }
            f.count = node.count;
            return;
        }
        for (int s = 0; s < (node.single ? 1 : 2); ++s) {
            const std::uint32_t c = node.child[s];
            if (c == bih::kNoChild) continue;
            gather(c);
            if (facts_[c].count == 0) continue;
            f.box.extend(facts_[c].box);
            f.count += facts_[c].count;
            f.lo = std::min(f.lo, facts_[c].lo);
            f.hi = std::max(f.hi, facts_[c].hi);
        }
    }
    bool is_leaf(std::uint32_t n) const {
        const Facts& f = facts_[n];
        return tree_.nodes[n].leaf() || (f.hi - f.lo == f.count && f.count <= leaf_);
    }
    /// n as a wide node: its box plus the best grouping of its subtree below it.
    double node_cost(std::uint32_t n) {
        if (cost_[n] >= 0.0) return cost_[n];
        double best = std::numeric_limits<double>::infinity();
        search(kids(n), 0, best);
        return cost_[n] = half_area(facts_[n].box) + best;
    }
    /// Every slot set reachable from `slots` by opening subtrees at positions >= from.
    void search(const std::vector<std::uint32_t>& slots, std::size_t from, double& best) {
        if (slots.size() > static_cast<std::size_t>(bih::kWideWidth)) return;  // opening never shrinks it
        double here = 0.0;
        for (std::uint32_t c : slots)
            if (!is_leaf(c)) here += node_cost(c);
        best = std::min(best, here);
        for (std::size_t i = from; i < slots.size(); ++i) {
            if (is_leaf(slots[i])) continue;
            std::vector<std::uint32_t> opened(slots.begin(), slots.begin() + static_cast<std::ptrdiff_t>(i));
            for (std::uint32_t k : kids(slots[i])) opened.push_back(k);
            opened.insert(opened.end(), slots.begin() + static_cast<std::ptrdiff_t>(i) + 1, slots.end());
            search(opened, i, best);
        }
    }
};

/// The same sum over the WideTree: each wide node's box is the union of its slots' boxes.
double wide_node_area(const bih::WideTree<Sphere>& wide) {
    double sum = 0.0;
    for (const bih::WideNode& n : wide.nodes()) {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int c = 0; c < bih::kWideWidth; ++c) {
            if (n.child[c] == bih::kNoChild) continue;
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min(lo[a], static_cast<double>(n.box[2 * a][c]));
                hi[a] = std::max(hi[a], static_cast<double>(n.box[2 * a + 1][c]));
            }
        }
        const double x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
        sum += x * y + y * z + z * x;
    }
    return sum;
}

}  // namespace

TEST_CASE("the collapse groups subtrees into wide nodes of the least total area (enumerated)", "[bih][wide]") {
    // Small trees (24 to 68 spheres), uniform and in clusters, with leaves of 1, 2 and 4: the
    // WideTree's nodes' half-areas sum to the least any grouping reaches (its boxes are padded
    // by ~2^-20 relative: hence the tolerance).
    std::size_t trees = 0, beaten = 0;
    for (std::uint32_t seed = 1; seed <= 12; ++seed) {
        std::vector<Sphere> spheres = testing::random_spheres(20 + 4 * seed, seed);
        if (seed % 2 == 0)  // clusters: every third sphere pulled towards one of two points
            for (std::size_t i = 0; i < spheres.size(); i += 3)
                spheres[i].center = spheres[i].center * 0.05f + vec3(i % 2 ? 0.7f : -0.6f, 0.2f, 0.1f);
        std::span<const Sphere> es(spheres);
        for (std::uint32_t leaf : {1u, 2u, 4u}) {
            INFO("seed " << seed << ", leaves of " << leaf);
            bih::Tree tree = bih::build(es, bih::wide_source_config(es.size(), bih::WideConfig{leaf}));
            bih::WideTree<Sphere> wide(tree, es, bih::WideConfig{leaf});
            const double least = CollapseReference(tree, es, leaf).least();
            const double got = wide_node_area(wide);
            REQUIRE(least > 0.0);
            CHECK(got <= least * (1.0 + 1e-4));
            CHECK(got >= least * (1.0 - 1e-4));
            beaten += got > least * (1.0 + 1e-4);
            ++trees;
        }
    }
    CHECK(trees == 36);
    CHECK(beaten == 0);
}
