// The iterator and the queries against brute force over all elements.
#include <catch2/catch.hpp>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/bih/validate.hpp>

#include "generators.hpp"

using namespace sylva;

namespace {

struct Variant {
    const char* name;
    bih::Config build;
    bih::EncodeConfig encode;
};

std::vector<Variant> variants() {
    bih::Config trim_both, infinite, wide;
    infinite.empty_children = bih::EmptyChildren::Infinite;
    wide.max_leaf_elements = 4;
    wide.trim_leaves = false;
    return {
        {"fixed16/chunks/trim-both", trim_both, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2}},
        {"float32/pre-order/infinite", infinite, {bih::NodeFormat::Float32, bih::Layout::PreOrder, 0}},
        {"fixed16/pre-order/infinite", infinite, {bih::NodeFormat::Fixed16, bih::Layout::PreOrder, 0}},
        {"float32/chunks0/4-per-leaf", wide, {bih::NodeFormat::Float32, bih::Layout::TreeChunks, 0}},
    };
}

/// Runs `rays` through every variant; all hits and first hits must equal brute force.
template <class E>
void check_against_brute_force(const std::vector<E>& elems, const std::vector<Ray>& rays) {
    std::span<const E> es(elems);
    ThreadPool pool(2);
    for (const Variant& v : variants()) {
        INFO("variant " << v.name);
        bih::Tree tree = bih::build(es, v.build, pool);
        auto words = bih::encode(tree, es, bih::RangePayload{}, v.encode);
        REQUIRE_NOTHROW(bih::validate(words, elems.size()));
        std::vector<bih::ElementHit> hits;
        std::size_t total_hits = 0, mismatches = 0;
        for (const Ray& r : rays) {
            auto expected = bih::brute_force_hits(es, r);
            bih::all_hits(words, tree, es, r, hits);
            total_hits += expected.size();
            if (hits != expected) ++mismatches;
            auto first = bih::first_hit(words, tree, es, r);
            if (expected.empty() ? first.has_value() : (!first || *first != expected.front())) ++mismatches;
        }
        CHECK(mismatches == 0);
        CHECK(total_hits > rays.size() / 10);  // the rays really hit things
    }
}

}  // namespace

TEST_CASE("all hits and first hit equal brute force on random boxes", "[bih][iter]") {
    auto elems = testing::random_boxes(3000, 1);
    auto rays = testing::random_rays(30000, {vec3(0.0f), vec3(1.05f)}, 2);
    check_against_brute_force(elems, rays);
}

TEST_CASE("all hits and first hit equal brute force on clustered boxes", "[bih][iter]") {
    auto elems = testing::clustered_boxes(3000, 3);
    auto rays = testing::random_rays(30000, {vec3(0.0f), vec3(10.0f)}, 4);
    check_against_brute_force(elems, rays);
}

TEST_CASE("all hits and first hit equal brute force on degenerate boxes", "[bih][iter]") {
    auto elems = testing::degenerate_boxes(2000, 5);
    auto rays = testing::random_rays(30000, {vec3(0.0f), vec3(1.0f)}, 6);
    check_against_brute_force(elems, rays);
}

TEST_CASE("all hits equal brute force on spheres", "[bih][iter]") {
    auto elems = testing::random_spheres(2000, 7);
    auto rays = testing::random_rays(20000, {vec3(-1.0f), vec3(1.0f)}, 8);
    check_against_brute_force(elems, rays);
}

TEST_CASE("leaves of disjoint elements come strictly front to back", "[bih][iter]") {
    // 16 cells: every cell face k/16 is exact in 16-bit fixed point, so no two leaf boxes overlap
    // (with 12 cells the conservative rounding would make neighbours overlap by one step).
    auto elems = testing::grid_boxes(16);
    std::span<const BoxElement> es(elems);
    auto rays = testing::random_rays(20000, {vec3(0.0f), vec3(16.0f)}, 9);
    for (auto enc : {bih::NodeFormat::Fixed16, bih::NodeFormat::Float32}) {
        bih::Tree tree = bih::build(es);
        auto words = bih::encode(tree, es, bih::RangePayload{}, {enc, bih::Layout::TreeChunks, 2});
        std::size_t violations = 0, leaves = 0;
        for (const Ray& r : rays) {
            bih::LeafIterator it(words, r);
            float last = -std::numeric_limits<float>::infinity();
            while (auto leaf = it.next()) {
                ++leaves;
                if (leaf->t.t0 < last) ++violations;
                last = leaf->t.t0;
                CHECK(leaf->t.t0 <= leaf->t.t1);
            }
            CHECK(it.status() == SYLVA_ITER_DONE);
        }
        CHECK(leaves > 100000);
        CHECK(violations == 0);
    }
}

TEST_CASE("rays lying in a splitting plane see the closed boxes on both sides", "[bih][iter]") {
    // Two unit cubes side by side share the face x = 1; a ray in that face, parallel to it,
    // touches both (closed boxes), whichever sign its zero x component has.
    std::vector<BoxElement> elems{{{vec3(0.0f), vec3(1.0f)}}, {{vec3(1.0f, 0.0f, 0.0f), vec3(2.0f, 1.0f, 1.0f)}}};
    std::span<const BoxElement> es(elems);
    for (auto mode : {bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite}) {
        bih::Config cfg;
        cfg.empty_children = mode;
        bih::Tree tree = bih::build(es, cfg);
        for (auto fmt : {bih::NodeFormat::Fixed16, bih::NodeFormat::Float32}) {
            auto words = bih::encode(tree, es, bih::RangePayload{}, {fmt, bih::Layout::PreOrder, 0});
            for (float zero : {0.0f, -0.0f}) {
                Ray r{{1.0f, 0.5f, -1.0f}, {zero, 0.0f, 1.0f}};
                std::vector<bih::ElementHit> hits;
                bih::all_hits(words, tree, es, r, hits);
                CHECK(hits.size() == 2);
                CHECK(hits == bih::brute_force_hits(es, r));
            }
            Ray starts_inside{{0.5f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}};
            auto first = bih::first_hit(words, tree, es, starts_inside);
            REQUIRE(first);
            CHECK(first->element == 0);
            CHECK(first->t.t0 == 0.0f);
        }
    }
}

TEST_CASE("clip prunes what lies beyond a known hit", "[bih][iter]") {
    auto elems = testing::grid_boxes(8);
    std::span<const BoxElement> es(elems);
    bih::Tree tree = bih::build(es);
    auto words = bih::encode(tree, es, bih::RangePayload{});
    Ray r{{-1.0f, 4.5f, 4.5f}, {1.0f, 0.0f, 0.0f}};
    bih::LeafIterator all(words, r), clipped(words, r);
    std::size_t n_all = 0, n_clipped = 0;
    while (all.next()) ++n_all;
    clipped.clip(3.0f);
    while (auto l = clipped.next()) {
        ++n_clipped;
        CHECK(l->t.t0 <= 3.0f);
    }
    CHECK(n_clipped < n_all);
    CHECK(n_clipped >= 2);
}
