// Moving elements (issue 14, item 5): after the elements move, a refitted BIH and a refitted
// element octree answer first hit and all hits exactly as brute force over the moved elements;
// a rebuild equals a fresh build. (The kd-tree's refit and rebuild: tests/kd_elements.)
#include <catch2/catch.hpp>

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
