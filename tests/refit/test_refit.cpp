// Moving elements (issue 14, item 5): after the elements move, a refitted BIH and a refitted
// element octree answer first hit and all hits exactly as brute force over the moved elements;
// a rebuild equals a fresh build. (The kd-tree's refit and rebuild: tests/kd_elements.)
#include <catch2/catch.hpp>

#include <algorithm>
#include <limits>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/bih/refit.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/octree/elements_refit.hpp>

#include "../kd_elements/common.hpp"

using namespace sylva;
using namespace kde_test;

namespace {

std::vector<Sphere> move_all(const std::vector<Sphere>& s, float step) {
    std::vector<Sphere> out(s.size());
    for (std::uint32_t i = 0; i < s.size(); ++i) out[i] = moved(s[i], i, step);
    return out;
}

/// Counts rays whose BIH answers differ from brute force; `hits` counts rays that hit.
template <class E>
std::size_t bih_mismatches(const bih::Tree& t, const std::vector<E>& es, const std::vector<Ray>& rays, std::size_t& hits) {
    std::span<const E> s(es);
    auto w = bih::encode(t, s, bih::RangePayload{});
    std::size_t bad = 0;
    std::vector<bih::ElementHit> got;
    for (const Ray& r : rays) {
        auto want = brute_all(es, r);
        bih::all_hits(w, t, s, r, got);
        bad += !(got == want);
        auto f = bih::first_hit(w, t, s, r);
        bad += !(want.empty() ? !f.has_value() : (f && *f == want.front()));
        hits += !want.empty();
    }
    return bad;
}

}  // namespace

TEST_CASE("refit: a refitted BIH answers brute force on the moved elements", "[bih]") {
    ThreadPool pool(2);
    auto es = testing::random_spheres(4000, 201);
    bih::Config queries = bih::Config::for_queries(), infinite;
    infinite.empty_children = bih::EmptyChildren::Infinite;
    for (const bih::Config& cfg : {bih::Config{}, queries, infinite}) {
        bih::Tree t = bih::build(std::span<const Sphere>(es), cfg, pool);
        auto nodes = t.nodes.size();
        for (float step : {0.01f, 0.05f, 0.3f}) {  // small to large motion
            auto now = move_all(es, step);
            bih::refit(t, std::span<const Sphere>(now), pool);
            REQUIRE(t.nodes.size() == nodes);
            std::size_t hits = 0;
            auto rays = testing::random_rays(2000, scene_of(now), 202);
            CHECK(bih_mismatches(t, now, rays, hits) == 0);
            CHECK(hits > 500);
        }
        // Without the refit, the moved elements are missed: the test can fail.
        bih::Tree stale = bih::build(std::span<const Sphere>(es), cfg, pool);
        std::size_t hits = 0;
        auto now = move_all(es, 0.05f);
        CHECK(bih_mismatches(stale, now, testing::random_rays(2000, scene_of(now), 202), hits) > 20);
    }
    auto caps = random_capsules(3000, 203);
    bih::Tree t = bih::build(std::span<const Capsule>(caps), bih::Config::for_queries(), pool);
    for (auto& c : caps) c = {c.a * 1.2f, c.b * 1.2f + vec3(0.02f), c.radius};
    bih::refit(t, std::span<const Capsule>(caps), pool);
    std::size_t hits = 0;
    CHECK(bih_mismatches(t, caps, testing::random_rays(2000, scene_of(caps), 204), hits) == 0);
    CHECK(hits > 300);
    std::vector<Capsule> fewer(caps.begin(), caps.end() - 1);
    CHECK_THROWS_WITH(bih::refit(t, std::span<const Capsule>(fewer), pool), Catch::Contains("not 2999"));
    caps[5].radius = NAN;
    CHECK_THROWS_WITH(bih::refit(t, std::span<const Capsule>(caps), pool), Catch::Contains("element 5"));
}

TEST_CASE("refit: a BIH rebuild equals a fresh build", "[bih][parallel]") {
    ThreadPool pool(2);
    auto es = testing::random_spheres(20000, 211);
    std::span<const Sphere> s(es);
    bih::Tree t = bih::build(s, bih::Config::for_queries(), pool);
    auto now = move_all(es, 0.1f);
    std::span<const Sphere> m(now);
    bih::rebuild(t, m, bih::Config::for_queries(), pool);
    bih::Tree fresh = bih::build(m, bih::Config::for_queries(), pool);
    CHECK(bih::encode(t, m, bih::RangePayload{}) == bih::encode(fresh, m, bih::RangePayload{}));
    CHECK(std::vector<std::uint32_t>(t.order.begin(), t.order.end()) == std::vector<std::uint32_t>(fresh.order.begin(), fresh.order.end()));
    CHECK(t.stats.nodes == fresh.stats.nodes);
    CHECK(t.stats.leaves == fresh.stats.leaves);
}

TEST_CASE("refit: a refitted element octree answers brute force; leaving the lattice asks for a rebuild", "[octree]") {
    ThreadPool pool(2);
    auto es = clustered_spheres(4000, 221);
    octree::ElementConfig cfg;
    auto et = octree::build_elements(std::span<const Sphere>(es), cfg, pool);
    auto nodes = et.tree.nodes.size();
    auto now = move_all(es, 0.02f);
    for (auto& s : now) s.center = glm::clamp(s.center, scene_of(es).lo + vec3(0.1f), scene_of(es).hi - vec3(0.1f));
    std::span<const Sphere> m(now);
    REQUIRE(octree::refit_elements(et, m, cfg, pool));
    REQUIRE(et.tree.nodes.size() == nodes);
    auto w = octree::encode_elements(et);
    std::size_t bad = 0, hits = 0;
    std::vector<bih::ElementHit> got;
    for (const Ray& r : testing::random_rays(2000, scene_of(now), 222)) {
        auto want = brute_all(now, r);
        octree::all_hits(w, m, r, got);
        bad += !(got == want);
        auto f = octree::first_hit(w, m, r);
        bad += !(want.empty() ? !f.has_value() : (f && *f == want.front()));
        hits += !want.empty();
    }
    CHECK(bad == 0);
    CHECK(hits > 300);
    // Reference lists equal those of a fresh walk down the same nodes: every leaf lists each
    // element whose padded cell box overlaps its closed box.
    for (const octree::Node& n : et.tree.nodes) {
        if (!n.leaf()) continue;
        Aabb box = et.world_box(n);
        std::size_t listed = n.brick == octree::kNone ? 0 : et.list(n.brick).size(), want = 0;
        for (const Sphere& s : now) {
            Aabb b = bounds_of(s);
            vec3 pad = et.tree.spacing * cfg.overlap_pad;
            want += glm::all(glm::lessThanEqual(b.lo - pad, box.hi)) && glm::all(glm::greaterThanEqual(b.hi + pad, box.lo));
        }
        REQUIRE(listed == want);
    }
    auto before = octree::encode_elements(et);
    auto far = now;
    far[7].center = vec3(50.0f);
    CHECK_FALSE(octree::refit_elements(et, std::span<const Sphere>(far), cfg, pool));
    CHECK(octree::encode_elements(et) == before);  // unchanged
    CHECK_FALSE(octree::update_elements(et, std::span<const Sphere>(far), cfg, pool));
    CHECK(octree::encode_elements(et) == octree::encode_elements(octree::build_elements(std::span<const Sphere>(far), cfg, pool)));
}

namespace {

/// first_hit and all_hits over an element octree's encoding against brute force; `hits`
/// counts rays that hit.
std::size_t octree_mismatches(const octree::ElementTree& et, const std::vector<Sphere>& es, const std::vector<Ray>& rays,
                              std::size_t& hits) {
    auto w = octree::encode_elements(et);
    std::span<const Sphere> m(es);
    std::size_t bad = 0;
    std::vector<bih::ElementHit> got;
    for (const Ray& r : rays) {
        auto want = brute_all(es, r);
        octree::all_hits(w, m, r, got);
        bad += !(got == want);
        auto f = octree::first_hit(w, m, r);
        bad += !(want.empty() ? !f.has_value() : (f && *f == want.front()));
        hits += !want.empty();
    }
    return bad;
}

/// Where an element octree's arrays live (equal before and after an update: nothing was
/// reallocated).
std::vector<const void*> octree_arrays(const octree::ElementTree& et) {
    const auto& sc = et.scratch;
    return {et.tree.nodes.data(), et.refs.data(), et.leaf_first.data(), sc.boxes.data(), sc.lists[0].data(),
            sc.lists[1].data(), sc.first[0].data(), sc.first[1].data(), sc.octants.data(), sc.masks.data(),
            sc.segments.data(), sc.node_segment.data()};
}

}  // namespace

TEST_CASE("refit: an element octree rebuild equals a fresh build and reuses its arrays", "[octree][parallel]") {
    ThreadPool pool(2);
    auto es = testing::random_spheres(30000, 231);
    octree::ElementConfig cfg;
    auto et = octree::build_elements(std::span<const Sphere>(es), cfg, pool);
    CHECK(et.scratch.bytes() == 0);  // a still build releases the builder's lists
    for (float step : {0.05f, 0.2f}) {
        auto now = move_all(es, step);
        std::span<const Sphere> m(now);
        octree::rebuild_elements(et, m, cfg, pool);
        auto fresh = octree::build_elements(m, cfg, pool);
        CHECK(octree::encode_elements(et) == octree::encode_elements(fresh));  // nodes, neighbours, lists
        CHECK(et.refs == fresh.refs);
        // The same motion again: every array is reused in place.
        auto where = octree_arrays(et);
        octree::rebuild_elements(et, m, cfg, pool);
        CHECK(octree_arrays(et) == where);
        CHECK(octree::encode_elements(et) == octree::encode_elements(fresh));
    }
    // Serial rebuild == parallel build; a rebuild over fewer elements too (into larger arrays).
    std::vector<Sphere> half(es.begin(), es.begin() + 9000);
    SerialExecutor serial;
    octree::rebuild_elements(et, std::span<const Sphere>(half), cfg, serial);
    CHECK(octree::encode_elements(et) == octree::encode_elements(octree::build_elements(std::span<const Sphere>(half), cfg, pool)));
    std::size_t hits = 0;
    CHECK(octree_mismatches(et, half, testing::random_rays(1500, scene_of(half), 232), hits) == 0);
    CHECK(hits > 200);
}

TEST_CASE("refit: refit_margin leaves room for motion, so element octree refits stay refits", "[octree]") {
    ThreadPool pool(2);
    auto es = testing::random_spheres(20000, 241);
    auto now = move_all(es, 0.02f);  // the moved box reaches outside the first one
    std::span<const Sphere> m(now);
    octree::ElementConfig tight, roomy;
    roomy.refit_margin = 0.05f;
    auto a = octree::build_elements(std::span<const Sphere>(es), tight, pool);
    auto before = octree::encode_elements(a);
    CHECK_FALSE(octree::refit_elements(a, m, tight, pool));
    CHECK(octree::encode_elements(a) == before);  // unchanged
    auto b = octree::build_elements(std::span<const Sphere>(es), roomy, pool);
    // The margin grows the lattice: the world box of the root holds the box grown by 5 %.
    Aabb box = scene_of(es), root = b.world_box(b.tree.nodes[0]);
    float grow = 0.05f * std::max({box.extent().x, box.extent().y, box.extent().z});
    CHECK(glm::all(glm::lessThanEqual(root.lo, box.lo - vec3(grow))));
    CHECK(glm::all(glm::greaterThanEqual(root.hi, box.hi + vec3(grow))));
    auto nodes = b.tree.nodes.size();
    REQUIRE(octree::refit_elements(b, m, roomy, pool));
    CHECK(b.tree.nodes.size() == nodes);
    std::size_t hits = 0;
    auto rays = testing::random_rays(2000, scene_of(now), 242);
    CHECK(octree_mismatches(b, now, rays, hits) == 0);
    CHECK(hits > 300);
    // Refit again with the same motion: equal lists, every array reused in place.
    auto refs = b.refs;
    auto where = octree_arrays(b);
    REQUIRE(octree::refit_elements(b, m, roomy, pool));
    CHECK(b.refs == refs);
    CHECK(octree_arrays(b) == where);
    // Back to the start: the refitted tree answers the original positions too.
    REQUIRE(octree::refit_elements(b, std::span<const Sphere>(es), roomy, pool));
    hits = 0;
    CHECK(octree_mismatches(b, es, testing::random_rays(1000, scene_of(es), 243), hits) == 0);
    // Still answers with the margin's own lattice when rebuilt: the same tree as a fresh build.
    octree::rebuild_elements(b, m, roomy, pool);
    CHECK(octree::encode_elements(b) == octree::encode_elements(octree::build_elements(m, roomy, pool)));
}

TEST_CASE("refit: element octree refit refuses a bad margin and a tree not stored as the builder stores it", "[octree]") {
    ThreadPool pool(2);
    auto es = testing::random_spheres(3000, 251);
    std::span<const Sphere> s(es);
    for (float bad : {-0.1f, 1.5f, std::numeric_limits<float>::quiet_NaN()}) {
        octree::ElementConfig cfg;
        cfg.refit_margin = bad;
        CHECK_THROWS_WITH(octree::build_elements(s, cfg, pool), Catch::Contains("refit_margin"));
    }
    octree::ElementConfig cfg;
    auto et = octree::build_elements(s, cfg, pool);
    REQUIRE(et.tree.nodes.size() > 9);
    auto before = octree::encode_elements(et);
    auto broken = et;
    broken.tree.nodes[0].first_child += 1;  // children no longer where the level order puts them
    CHECK_THROWS_WITH(octree::refit_elements(broken, s, cfg, pool), Catch::Contains("not stored as the builder"));
    CHECK(broken.refs == et.refs);  // nothing rewritten
    CHECK(octree::refit_elements(et, s, cfg, pool));
    CHECK(octree::encode_elements(et) == before);  // a refit in place of the same positions
}

TEST_CASE("refit: a BIH rebuild over a bad element throws and keeps the tree", "[bih][parallel]") {
    ThreadPool pool(2);
    auto es = testing::random_spheres(20000, 262);  // parallel: the nodes are built in regions of t.nodes
    std::span<const Sphere> s(es);
    for (const bih::Config& cfg : {bih::Config{}, bih::Config::for_queries()}) {
        bih::Tree t = bih::build(s, cfg, pool);
        const auto before = bih::encode(t, s, bih::RangePayload{});
        const std::vector<std::uint32_t> order(t.order.begin(), t.order.end());
        const std::size_t nodes = t.stats.nodes;
        auto bad = es;
        bad[1234].radius = std::numeric_limits<float>::quiet_NaN();
        CHECK_THROWS_WITH(bih::rebuild(t, std::span<const Sphere>(bad), cfg, pool), Catch::Contains("element 1234"));
        CHECK(bih::encode(t, s, bih::RangePayload{}) == before);
        CHECK(std::vector<std::uint32_t>(t.order.begin(), t.order.end()) == order);
        CHECK(t.stats.nodes == nodes);
    }
}

TEST_CASE("refit: an element octree rebuild over a bad element throws and keeps the tree", "[octree]") {
    ThreadPool pool(2);
    auto es = testing::random_spheres(3000, 261);
    octree::ElementConfig cfg;
    auto et = octree::build_elements(std::span<const Sphere>(es), cfg, pool);
    auto before = octree::encode_elements(et);
    auto bad = es;
    bad[1234].center.y = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(octree::rebuild_elements(et, std::span<const Sphere>(bad), cfg, pool), Catch::Contains("element 1234"));
    CHECK(octree::encode_elements(et) == before);
    CHECK_THROWS_WITH(octree::refit_elements(et, std::span<const Sphere>(bad), cfg, pool), Catch::Contains("element 1234"));
    CHECK(octree::encode_elements(et) == before);
    octree::ElementConfig wrong;
    wrong.max_growth = 9.0f;
    CHECK_THROWS_WITH(octree::rebuild_elements(et, std::span<const Sphere>(es), wrong, pool), Catch::Contains("max_growth"));
    CHECK(octree::encode_elements(et) == before);
}
