// First hit and all hits (in (entry t, element) order) through the element octree equal brute
// force over all elements (bih::brute_force_hits), for 1e5 random rays per set on random,
// clustered and degenerate sets (points, coincident, flat, huge) and spheres, and for rays
// along the octree's node faces and edges and through its corners.
#include <catch2/catch.hpp>

#include "../octree/rays.hpp"
#include <sylva/elements/rbf.hpp>

#include "common.hpp"

using namespace sylva;
using namespace octe_test;

namespace {

/// Counts rays whose all-hits list or first hit differs from brute force.
template <class E>
std::size_t mismatches(const std::vector<std::uint32_t>& words, const std::vector<E>& es, const std::vector<Ray>& rays,
                       const std::vector<Interval>& ranges, std::size_t& total_hits) {
    std::span<const E> s(es);
    std::vector<bih::ElementHit> hits;
    std::size_t bad = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        Interval range = ranges.empty() ? Interval{} : ranges[i];
        auto want = bih::brute_force_hits(s, rays[i], range);
        octree::all_hits(words, s, rays[i], hits, range);
        total_hits += want.size();
        bool ok = hits == want;
        auto first = octree::first_hit(words, s, rays[i], range);
        ok = ok && (want.empty() ? !first.has_value() : (first && *first == want.front()));
        if (!ok && bad < 4)
            UNSCOPED_INFO("ray " << i << ": " << hits.size() << " hits, brute force " << want.size());
        bad += !ok;
    }
    return bad;
}

template <class E>
void check_set(const std::vector<E>& es, std::size_t ray_count, std::uint32_t seed) {
    auto rays = testing::random_rays(ray_count, scene_of(es), seed);
    for (const auto& cfg : configs()) {
        INFO("leaf " << cfg.leaf_elements << " depth " << cfg.max_depth << " growth " << cfg.max_growth);
        ThreadPool pool(2);
        auto et = octree::build_elements(std::span<const E>(es), cfg, pool);
        auto words = octree::encode_elements(et);
        std::size_t total = 0;
        // 1e5 rays through the default tree, a fifth of them through the others.
        std::vector<Ray> some(rays.begin(), rays.begin() + std::ptrdiff_t(cfg.leaf_elements == 8 ? rays.size() : rays.size() / 5));
        CHECK(mismatches(words, es, some, {}, total) == 0);
        CHECK(total > some.size() / 10);  // the rays really hit things
    }
}

}  // namespace

TEST_CASE("element octree queries equal brute force on random boxes", "[query]") {
    check_set(testing::random_boxes(2000, 31), 100000, 32);
}

TEST_CASE("element octree queries equal brute force on clustered boxes", "[query]") {
    check_set(testing::clustered_boxes(2000, 33), 100000, 34);
}

TEST_CASE("element octree queries equal brute force on degenerate boxes", "[query]") {
    // Points, coincident twins, flat boxes, a 2e4-wide box and a long slab.
    check_set(testing::degenerate_boxes(2000, 35), 100000, 36);
}

TEST_CASE("element octree queries equal brute force on spheres", "[query]") {
    check_set(testing::random_spheres(2000, 37), 100000, 38);
}

TEST_CASE("element octree queries equal brute force on rays along node faces, edges and corners", "[query]") {
    // Elements snapped to the octree's own lattice planes: rays in those planes touch boxes
    // exactly on the faces where one leaf ends and the next begins.
    auto loose = testing::random_boxes(3000, 41, 0.1f);
    octree::ElementTree probe = octree::build_elements(std::span<const BoxElement>(loose));
    std::vector<BoxElement> es;
    vec3 s = probe.tree.spacing;
    float w = float(probe.tree.width(4));
    for (auto b : loose) {
        vec3 lo = glm::floor((b.box.lo - probe.origin) / (s * w)) * (s * w) + probe.origin;
        es.push_back({{lo, lo + s * w * (1.0f + glm::floor(b.box.extent().x * 8.0f))}});
    }
    auto et = octree::build_elements(std::span<const BoxElement>(es));
    auto words = octree::encode_elements(et);
    std::vector<Ray> rays;
    std::vector<Interval> ranges;
    for (const auto& r : octree_test::test_rays(et.tree, 20000, 42)) {
        rays.push_back({r.o + et.origin, r.d});
        ranges.push_back({r.t0, r.t1});
    }
    std::size_t total = 0;
    CHECK(mismatches(words, es, rays, ranges, total) == 0);
    CHECK(total > rays.size() / 4);
}

TEST_CASE("element octree queries equal brute force on RBFs and a user type without a default constructor", "[query]") {
    std::vector<GaussianRbf> rbfs;
    for (const Sphere& p : testing::random_spheres(1500, 43)) rbfs.push_back({p.center, p.radius / 3.0f, 3.0f, p.rgba});
    check_set(rbfs, 20000, 44);
    std::vector<testing::PinnedBox> pinned;
    for (const auto& b : testing::clustered_boxes(1500, 45)) pinned.emplace_back(b.box);
    check_set(pinned, 20000, 46);
}
