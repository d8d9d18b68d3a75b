// The kd-tree over any element type (issue 14, item 4): first hit and all hits against brute
// force over all elements (spheres, Gaussian RBFs, boxes, and a capsule the library does not
// ship), the leaves' order and reference lists against the cells, the encoding's validator
// against corruptions, and the particle image against brute-force compositing, the element
// octree and the BIH.
#include <catch2/catch.hpp>

#include <bit>
#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/render/kd_particles.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/render/octree_particles.hpp>

#include "common.hpp"

using namespace sylva;
using namespace kde_test;

namespace {

std::vector<kdtree::ElementConfig> configs() {
    kdtree::ElementConfig def, coarse, shallow;
    coarse.bins = 4;
    coarse.leaf_elements = 1;
    kdtree::ElementConfig small;
    small.leaf_elements = 2;
    shallow.max_depth = 3;
    return {def, coarse, shallow, small};
}

/// Checks first hit and all hits of every ray against brute force; returns the rays that hit.
template <class E>
std::size_t check_queries(const std::vector<E>& es, const std::vector<Ray>& rays, const kdtree::ElementConfig& cfg) {
    std::span<const E> s(es);
    auto t = kdtree::build_elements(s, cfg);
    auto w = kdtree::encode_elements(t);
    REQUIRE_NOTHROW(kdtree::validate_elements(w));
    std::size_t hit = 0, bad_first = 0, bad_all = 0;
    std::vector<bih::ElementHit> got;
    for (const Ray& r : rays) {
        for (Interval range : {Interval{}, Interval{0.5f, 2.0f}}) {
            auto want = brute_all(es, r, range);
            kdtree::all_hits(w, s, r, got, range);
            bad_all += !(got == want);
            auto f = kdtree::first_hit(w, s, r, range);
            bad_first += !(want.empty() ? !f.has_value() : (f && *f == want.front()));
            hit += !want.empty();
        }
    }
    CHECK(bad_all == 0);
    CHECK(bad_first == 0);
    return hit;
}

std::vector<std::uint32_t> identity(std::size_t n) {
    std::vector<std::uint32_t> id(n);
    for (std::size_t i = 0; i < n; ++i) id[i] = std::uint32_t(i);
    return id;
}

}  // namespace

TEST_CASE("kd elements: first hit and all hits equal brute force on spheres, RBFs, boxes and capsules", "[queries]") {
    auto cases = testing::sphere_cases(81);
    std::vector<Ray> rays(cases.rays.end() - 4000, cases.rays.end());
    for (const auto& cfg : configs()) {
        CHECK(check_queries(cases.spheres, rays, cfg) > 1000);
        CHECK(check_queries(clustered_spheres(2000, 82), testing::random_rays(3000, scene_of(clustered_spheres(2000, 82)), 83), cfg) > 500);
        CHECK(check_queries(random_rbfs(2000, 84), rays, cfg) > 500);
        CHECK(check_queries(random_capsules(2000, 85), rays, cfg) > 500);
        CHECK(check_queries(testing::random_boxes(2000, 86), rays, cfg) > 500);
    }
}

TEST_CASE("kd elements: leaves front to back, intervals tile the ray, lists equal the cells' overlaps", "[iter]") {
    auto es = random_capsules(3000, 91);
    std::span<const Capsule> s(es);
    auto t = kdtree::build_elements(s);
    auto w = kdtree::encode_elements(t);
    REQUIRE(t.nodes.size() > 100);
    // Reference lists: every element whose padded box overlaps the leaf's closed cell, ascending.
    struct Item { std::uint32_t n; Aabb cell; };
    std::vector<Item> stack{{0, t.box}};
    std::size_t leaves = 0;
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        const auto& n = t.nodes[it.n];
        if (!n.leaf()) {
            Aabb lc = it.cell, uc = it.cell;
            lc.hi[n.axis] = n.split;
            uc.lo[n.axis] = n.split;
            stack.push_back({n.upper, uc});
            stack.push_back({it.n + 1, lc});
            continue;
        }
        ++leaves;
        std::vector<std::uint32_t> want;
        for (std::uint32_t e = 0; e < es.size(); ++e) {
            const Aabb& b = t.scratch_boxes[e];
            if (glm::all(glm::lessThanEqual(b.lo, it.cell.hi)) && glm::all(glm::greaterThanEqual(b.hi, it.cell.lo))) want.push_back(e);
        }
        auto got = t.list(n);
        REQUIRE(std::vector<std::uint32_t>(got.begin(), got.end()) == want);
    }
    CHECK(leaves == t.leaves);
    // Walk: intervals tile [t_begin, t_end] (each leaf starts where the last one ended, empty
    // leaves included through the skipped gap only), t0 <= t1, and the ray is in each leaf's cell.
    shared::Words ww{w.data(), w.size()};
    std::size_t rays_with_leaves = 0;
    for (const Ray& r : testing::random_rays(3000, scene_of(es), 92)) {
        shared::SylvaKdElemIter it;
        shared::sylva_kde_init(it, ww, std::uint32_t(w.size()), r.origin, r.direction, 0.0f, INFINITY);
        std::uint32_t node, first, count;
        float t0, t1, last = -INFINITY;
        bool any = false;
        while (shared::sylva_kde_next(it, ww, node, t0, t1, first, count)) {
            REQUIRE(t0 <= t1);
            REQUIRE(t0 >= last);
            last = t1;
            any = true;
            REQUIRE(count == t.nodes[node].count);
        }
        REQUIRE(it.status == SYLVA_ITER_DONE);
        rays_with_leaves += any;
    }
    CHECK(rays_with_leaves > 1000);
}

TEST_CASE("kd elements: parallel build equals serial, rebuild equals a fresh build", "[build][parallel]") {
    auto es = clustered_spheres(30000, 95);
    std::span<const Sphere> s(es);
    ThreadPool pool(2);
    kdtree::ElementConfig cfg;
    cfg.parallel_threshold = 512;
    auto a = kdtree::build_elements(s, cfg);
    auto b = kdtree::build_elements(s, cfg, pool);
    CHECK(kdtree::encode_elements(a) == kdtree::encode_elements(b));
    auto moved_es = es;
    for (std::uint32_t i = 0; i < moved_es.size(); ++i) moved_es[i] = moved(es[i], i, 0.05f);
    std::span<const Sphere> m(moved_es);
    kdtree::rebuild_elements(b, m, cfg, pool);
    CHECK(kdtree::encode_elements(b) == kdtree::encode_elements(kdtree::build_elements(m, cfg)));
}

TEST_CASE("kd elements: refit keeps the planes and answers brute force on the moved elements", "[refit]") {
    auto es = random_capsules(3000, 101);
    std::span<const Capsule> s(es);
    ThreadPool pool(2);
    kdtree::ElementConfig cfg;
    auto t = kdtree::build_elements(s, cfg, pool);
    auto before = t.nodes;
    std::vector<Capsule> now = es;
    for (int frame = 1; frame <= 3; ++frame) {
        for (std::uint32_t i = 0; i < now.size(); ++i) {
            vec3 d = 0.03f * float(frame) * vec3(std::cos(float(i)), std::sin(float(i)), 0.5f);
            now[i] = {es[i].a + d, es[i].b + d, es[i].radius};
        }
        now[0] = {vec3(3.0f), vec3(3.2f), 0.1f};  // far outside the old root cell
        std::span<const Capsule> m(now);
        kdtree::refit_elements(t, m, cfg, pool);
        REQUIRE(t.nodes.size() == before.size());
        for (std::size_t n = 0; n < before.size(); ++n) {
            REQUIRE(t.nodes[n].axis == before[n].axis);
            if (!before[n].leaf()) REQUIRE(t.nodes[n].split == before[n].split);
        }
        auto w = kdtree::encode_elements(t);
        REQUIRE_NOTHROW(kdtree::validate_elements(w));
        std::size_t bad = 0, hits = 0;
        std::vector<bih::ElementHit> got;
        auto rays = testing::random_rays(2000, scene_of(now), 102 + frame);
        rays.push_back({vec3(3.1f, 3.1f, -5.0f), vec3(0.0f, 0.0f, 1.0f)});  // through the far capsule
        for (const Ray& r : rays) {
            auto want = brute_all(now, r);
            kdtree::all_hits(w, m, r, got);
            bad += !(got == want);
            auto f = kdtree::first_hit(w, m, r);
            bad += !(want.empty() ? !f.has_value() : (f && *f == want.front()));
            hits += !want.empty();
        }
        CHECK(bad == 0);
        CHECK(hits > 300);
    }
    std::vector<Capsule> fewer(now.begin(), now.end() - 1);
    CHECK_THROWS_WITH(kdtree::refit_elements(t, std::span<const Capsule>(fewer), cfg, pool), Catch::Contains("not 2999"));
}

TEST_CASE("kd elements: the validator and the iterator refuse corrupted encodings", "[bad-input]") {
    auto es = testing::random_spheres(500, 111);
    std::span<const Sphere> s(es);
    auto t = kdtree::build_elements(s);
    auto good = kdtree::encode_elements(t);
    REQUIRE_NOTHROW(kdtree::validate_elements(good));
    auto expect_bad = [&](auto mutate, const char* what) {
        auto w = good;
        mutate(w);
        INFO(what);
        CHECK_THROWS_AS(kdtree::validate_elements(w), Error);
    };
    std::size_t first_inner = 0;
    while (t.nodes[first_inner].leaf()) ++first_inner;
    std::size_t first_leaf = 0;
    while (!t.nodes[first_leaf].leaf() || t.nodes[first_leaf].count < 2) ++first_leaf;
    auto rec = [](std::size_t n) { return SYLVA_KDE_HEADER_WORDS + SYLVA_KDE_NODE_WORDS * n; };
    expect_bad([](auto& w) { w[0] ^= 1u; }, "magic");
    expect_bad([](auto& w) { w[5] += 1u; }, "total words");
    expect_bad([](auto& w) { w[6] = SYLVA_KDE_STACK_SIZE + 1; }, "depth over the stack");
    expect_bad([](auto& w) { w[8] = std::bit_cast<std::uint32_t>(NAN); }, "box NaN");
    expect_bad([&](auto& w) { w[rec(first_inner)] = (w[rec(first_inner)] & 3u) | (std::uint32_t(first_inner + 1) << 2); }, "upper == lower");
    expect_bad([&](auto& w) { w[rec(first_inner)] = (w[rec(first_inner)] & 3u) | (0x3FFFFFFFu << 2); }, "upper past the nodes");
    expect_bad([&](auto& w) { w[rec(first_inner) + 1] = std::bit_cast<std::uint32_t>(1e30f); }, "split outside the cell");
    expect_bad([&](auto& w) { w[rec(first_leaf) + 1] = 3u; }, "list in the header");
    expect_bad([&](auto& w) { w[w[rec(first_leaf) + 1]] = 500u; }, "reference past the elements");
    expect_bad([&](auto& w) { std::swap(w[w[rec(first_leaf) + 1]], w[w[rec(first_leaf) + 1] + 1]); }, "not ascending");
    expect_bad([&](auto& w) { w.back() = w.back(); w[2] -= 1; }, "node count");
    // Random single-word corruptions: queries throw or answer, never read out of bounds (ASan),
    // never loop (steps are bounded by the node count).
    std::mt19937 rng(112);
    auto rays = testing::random_rays(50, scene_of(es), 113);
    std::vector<bih::ElementHit> got;
    for (int k = 0; k < 2000; ++k) {
        auto w = good;
        std::size_t at = rng() % w.size();
        w[at] = (k % 3 == 0) ? rng() : (w[at] ^ (1u << (rng() % 32)));
        for (const Ray& r : rays) {
            try {
                kdtree::all_hits(std::span<const std::uint32_t>(w), s, r, got);
            } catch (const Error&) {
            }
        }
    }
    CHECK_THROWS_WITH(kdtree::all_hits(std::span<const std::uint32_t>(good), std::span<const Sphere>(es.data(), 499), rays[0], got),
                      Catch::Contains("not 499"));
    kdtree::ElementConfig cfg;
    cfg.max_depth = 65;
    CHECK_THROWS_WITH(kdtree::build_elements(s, cfg), Catch::Contains("max_depth"));
    cfg = {};
    cfg.bins = 1;
    CHECK_THROWS_WITH(kdtree::build_elements(s, cfg), Catch::Contains("bins"));
    auto inf = es;
    inf[3].center.x = INFINITY;
    CHECK_THROWS_WITH(kdtree::build_elements(std::span<const Sphere>(inf)), Catch::Contains("element 3"));
    std::vector<Sphere> none;
    auto e = kdtree::build_elements(std::span<const Sphere>(none));
    auto ew = kdtree::encode_elements(e);
    CHECK_NOTHROW(kdtree::validate_elements(ew));
    kdtree::all_hits(std::span<const std::uint32_t>(ew), std::span<const Sphere>(none), rays[0], got);
    CHECK(got.empty());
}

TEST_CASE("kd elements: particle image equals the element octree's bit for bit and the BIH's closely", "[particles]") {
    ThreadPool pool(2);
    auto check = [&](auto elems, const char* name) {
        using E = typename decltype(elems)::value_type;
        std::span<const E> s(elems);
        CameraFrame cam = Camera::framing(scene_of(elems)).frame(160, 120);
        auto rec = pack_particles(s, std::span<const std::uint32_t>(identity(elems.size())));
        auto kw = kdtree::encode_elements(kdtree::build_elements(s, {}, pool));
        auto ow = octree::encode_elements(octree::build_elements(s, {}, pool));
        bih::Tree bt = bih::build(s, {}, pool);
        auto bw = bih::encode(bt, s, bih::RangePayload{});
        auto brec = pack_particles(s, std::span<const std::uint32_t>(bt.order));
        for (float stop : {2.0f, 0.99f}) {
            ParticleRenderConfig rc;
            rc.alpha_stop = stop;
            Frame k = render_particles_kd_cpu(kw, rec, cam, 160, 120, pool, rc);
            Frame o = render_particles_octree_cpu(ow, rec, cam, 160, 120, pool, rc);
            Frame b = render_particles_cpu(bw, brec, cam, 160, 120, pool, rc);
            ImageDifference kb = compare_frames(k, b);
            INFO(name << " alpha_stop " << stop << ": kd vs BIH PSNR " << kb.psnr);
            if (stop > 1.0f) CHECK(k.rgba == o.rgba);  // both the exact (t_c, index) order
            CHECK(kb.psnr >= 50.0);
            std::size_t lit = 0;
            for (const vec4& c : k.rgba) lit += c.a > 0.05f;
            CHECK(lit > k.rgba.size() / 20);
            for (std::uint32_t st : k.steps) REQUIRE(st != 0xFFFFFFFFu);
        }
    };
    check(testing::random_spheres(3000, 121), "spheres");
    check(clustered_spheres(5000, 122), "clustered");
    check(random_rbfs(3000, 123), "rbfs");
}
