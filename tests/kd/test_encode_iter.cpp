// The flat encoding, the shared front-to-back iterator and the validator: encoder against the
// shared decoder, leaf sequences against a brute-force slab test over all leaves, corrupted
// encodings rejected by validate and survived by the iterator.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <limits>
#include <random>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/kdtree/query.hpp>
#include <sylva/kdtree/subvolumes.hpp>
#include <sylva/kdtree/validate.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace sylva::kdtest;
using kdtree::Config;
using kdtree::LeafHit;
using kdtree::Tree;

namespace {

std::vector<Tree> sample_trees() {
    SerialExecutor serial;
    std::vector<Tree> out;
    out.push_back(kdtree::build_vidal(blobby_occupancy({64, 48, 40}, 1), Config::deep()));
    out.push_back(kdtree::build_vidal(blobby_occupancy({37, 70, 29}, 2, 8), Config::shallow()));
    out.push_back(kdtree::build_binned(random_occupancy({45, 33, 50}, 0.002, 3), Config::deep(), serial));
    out.push_back(kdtree::build_vidal(random_occupancy({24, 20, 16}, 1.0, 4), Config::deep()));  // leaves touch
    out.push_back(kdtree::build_vidal(random_occupancy({1, 90, 1}, 0.1, 7), Config::deep()));
    out.push_back(kdtree::build_vidal(random_occupancy({1, 1, 1}, 1.0, 5), Config::deep()));
    return out;
}

std::vector<LeafHit> brute_force(const Tree& t, const Ray& r, Interval range) {
    std::vector<LeafHit> out;
    for (std::uint32_t i = 0; i < t.leaves.size(); ++i) {
        Interval iv = slab(r, t.leaf_box(i), range);
        if (iv.t0 <= iv.t1) out.push_back({i, t.leaves[i], iv});
    }
    return out;
}

std::vector<LeafHit> by_leaf(std::vector<LeafHit> v) {
    std::sort(v.begin(), v.end(), [](const LeafHit& a, const LeafHit& b) { return a.leaf < b.leaf; });
    return v;
}

std::uint32_t bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

}  // namespace

TEST_CASE("encode: the shared decoder reads back every node and the header", "[encode]") {
    for (const Tree& t : sample_trees()) {
        std::vector<std::uint32_t> w = kdtree::encode(t);
        shared::Words buf{w.data(), w.size()};
        shared::SylvaKdHeader h = shared::sylva_kd_read_header(buf, static_cast<std::uint32_t>(w.size()));
        REQUIRE(h.valid == 1u);
        REQUIRE(w.size() == SYLVA_KD_HEADER_WORDS + 4 * t.nodes.size());
        CHECK(h.node_count == t.nodes.size());
        CHECK(h.leaf_count == t.leaves.size());
        CHECK(h.max_depth == t.stats.max_depth);
        CHECK(h.dims == uvec3(t.dims));
        CHECK(h.spacing == t.spacing);
        for (std::uint32_t i = 0; i < t.nodes.size(); ++i) {
            const kdtree::Node& n = t.nodes[i];
            REQUIRE(shared::sylva_kd_box_lo(buf, i) == n.box.lo);
            REQUIRE(shared::sylva_kd_box_hi(buf, i) == n.box.hi);
            std::uint32_t meta = shared::sylva_kd_meta(buf, i);
            REQUIRE((meta & 3u) == n.axis);
            REQUIRE((meta >> 2) == (n.is_leaf() ? n.leaf : n.first_child));
        }
        kdtree::validate(w);
    }
}

TEST_CASE("encode: grids the 16-bit layout cannot hold and bad transforms are errors", "[encode]") {
    Tree t;
    t.dims = {70000, 1, 1};
    CHECK_THROWS_AS(kdtree::encode(t), Error);
    t.dims = {4, 4, 4};
    t.spacing = vec3(1.0f, 0.0f, 1.0f);
    CHECK_THROWS_AS(kdtree::encode(t), Error);
    t.spacing = vec3(1.0f);
    t.origin = vec3(std::numeric_limits<float>::quiet_NaN());
    CHECK_THROWS_AS(kdtree::encode(t), Error);
}

TEST_CASE("iterator: leaves and intervals equal a brute-force slab test over all leaves", "[iter]") {
    for (const Tree& t : sample_trees()) {
        std::vector<std::uint32_t> w = kdtree::encode(t);
        std::vector<Ray> rays = make_rays(t.dims, 3000, 7, false);
        std::mt19937 rng(8);
        for (std::size_t i = 0; i < rays.size(); i += 4) {  // a quarter aim at a leaf centre
            vec3 c = t.world(t.leaf_box(rng() % t.leaves.size())).center();
            rays[i].direction = c - rays[i].origin;
        }
        std::size_t hits = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
            Interval range = (i % 5 == 4) ? Interval{1.5f, 40.0f} : Interval{};
            std::vector<LeafHit> got = kdtree::leaves_along(w, rays[i], range), want = brute_force(t, rays[i], range);
            INFO("ray " << i << " o=(" << rays[i].origin.x << "," << rays[i].origin.y << "," << rays[i].origin.z << ") d=("
                        << rays[i].direction.x << "," << rays[i].direction.y << "," << rays[i].direction.z << ")");
            REQUIRE(by_leaf(got) == by_leaf(want));
            for (std::size_t k = 1; k < got.size(); ++k) REQUIRE(got[k].t.t0 >= got[k - 1].t.t1);  // front to back
            hits += got.size();
        }
        CHECK(hits > rays.size() / 4);  // the rays do meet leaves
    }
}

TEST_CASE("iterator: rays lying in split planes get every leaf they touch", "[iter]") {
    for (const Tree& t : sample_trees()) {
        std::vector<std::uint32_t> w = kdtree::encode(t);
        for (const Ray& r : make_rays(t.dims, 2000, 9, true))
            REQUIRE(by_leaf(kdtree::leaves_along(w, r)) == by_leaf(brute_force(t, r, Interval{})));
    }
}

TEST_CASE("iterator: adjacent leaves share faces exactly, so intervals chain without gaps", "[iter]") {
    Tree t = kdtree::build_vidal(random_occupancy({24, 20, 16}, 1.0, 4), Config::deep());  // space-filling leaves
    REQUIRE(t.leaves.size() >= 16);  // 7680 voxels in leaves under 512
    t.spacing = vec3(0.7f, 1.3f, 0.45f);
    t.origin = vec3(-3.1f, 2.2f, 0.9f);
    std::vector<std::uint32_t> w = kdtree::encode(t);
    Aabb world = t.world(volume::full_box(t.dims));
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 2000; ++i) {
        vec3 a = world.lo + vec3(u(rng), u(rng), u(rng)) * world.extent();
        vec3 b = world.lo + vec3(u(rng), u(rng), u(rng)) * world.extent();
        Ray r{a - 0.5f * (b - a), b - a};
        std::vector<LeafHit> got = kdtree::leaves_along(w, r);
        REQUIRE_FALSE(got.empty());
        for (std::size_t k = 1; k < got.size(); ++k) REQUIRE(got[k].t.t0 == got[k - 1].t.t1);
        auto whole = clip(r, world, Interval{});
        REQUIRE(whole);
        CHECK(got.front().t.t0 == Approx(whole->t0).margin(1e-4));
        CHECK(got.back().t.t1 == Approx(whole->t1).margin(1e-4));
    }
    // World faces of touching leaves are the same floats.
    std::vector<Aabb> boxes = kdtree::world_boxes(t, kdtree::leaf_boxes(t));
    for (std::size_t i = 0; i < boxes.size(); ++i)
        for (std::size_t j = 0; j < boxes.size(); ++j)
            for (int ax = 0; ax < 3; ++ax)
                if (t.leaf_box(i).hi[ax] == t.leaf_box(j).lo[ax]) REQUIRE(bits(boxes[i].hi[ax]) == bits(boxes[j].lo[ax]));
}

TEST_CASE("iterator: world-space intervals agree with sylva::clip under anisotropic spacing", "[iter]") {
    Tree t = kdtree::build_vidal(blobby_occupancy({40, 30, 20}, 5), Config::deep());
    t.spacing = vec3(1.0f, 0.5f, 2.5f);
    std::vector<std::uint32_t> w = kdtree::encode(t);
    std::vector<Aabb> boxes = kdtree::world_boxes(t, kdtree::leaf_boxes(t));
    std::vector<Ray> rays = make_rays(t.dims, 1000, 4, false);
    for (Ray r : rays) {
        r.origin *= t.spacing;
        std::vector<LeafHit> got = kdtree::leaves_along(w, r);
        for (const LeafHit& h : got) {
            auto ref = clip(r, boxes[h.leaf], Interval{});
            if (!ref) continue;  // grazing: rounding may differ
            CHECK(h.t.t0 == Approx(ref->t0).margin(1e-3));
            CHECK(h.t.t1 == Approx(ref->t1).margin(1e-3));
        }
        for (std::uint32_t i = 0; i < boxes.size(); ++i) {
            auto ref = clip(r, boxes[i], Interval{});
            if (ref && ref->t1 - ref->t0 > 1e-3f)
                REQUIRE(std::any_of(got.begin(), got.end(), [&](const LeafHit& h) { return h.leaf == i; }));
        }
    }
}

TEST_CASE("iterator: clip prunes later leaves, NaN rays and empty trees yield nothing", "[iter]") {
    Tree t = kdtree::build_vidal(blobby_occupancy({64, 48, 40}, 1), Config::deep());
    std::vector<std::uint32_t> w = kdtree::encode(t);
    vec3 a = t.world(t.leaf_box(0)).center(), b = t.world(t.leaf_box(t.leaves.size() - 1)).center();
    Ray r{a - (b - a), b - a};  // through the first and the last leaf
    std::vector<LeafHit> all = kdtree::leaves_along(w, r);
    REQUIRE(all.size() >= 2);
    kdtree::LeafIterator it(w, r);
    auto first = it.next();
    REQUIRE(first);
    it.clip(first->t.t1);
    while (auto h = it.next()) CHECK(h->t.t0 <= first->t.t1);
    CHECK(it.status() == SYLVA_ITER_DONE);

    float nan = std::numeric_limits<float>::quiet_NaN();
    for (Ray bad : {Ray{vec3(nan, 1.0f, 1.0f), vec3(1.0f)}, Ray{vec3(1.0f), vec3(0.0f, nan, 1.0f)}}) {
        kdtree::LeafIterator n(w, bad);
        CHECK_FALSE(n.next());
        CHECK(n.status() == SYLVA_ITER_DONE);
    }
    kdtree::LeafIterator n(w, r, Interval{0.0f, nan});
    CHECK_FALSE(n.next());

    Tree empty = kdtree::build_vidal(random_occupancy({5, 6, 7}, 0.0, 1));
    std::vector<std::uint32_t> e = kdtree::encode(empty);
    CHECK(e.size() == SYLVA_KD_HEADER_WORDS);
    kdtree::validate(e);
    kdtree::LeafIterator none(e, r);
    CHECK_FALSE(none.next());
    CHECK(none.status() == SYLVA_ITER_DONE);
}

TEST_CASE("validate: corrupted encodings are rejected with a clear error", "[validate]") {
    Tree t = kdtree::build_vidal(blobby_occupancy({64, 48, 40}, 1), Config::deep());
    const std::vector<std::uint32_t> good = kdtree::encode(t);
    REQUIRE(t.nodes.size() > 8);
    kdtree::validate(good);
    std::uint32_t inner = 0;  // an inner node with leaf children
    while (t.nodes[inner].is_leaf() || !t.nodes[t.nodes[inner].first_child].is_leaf()) ++inner;
    std::uint32_t fc = t.nodes[inner].first_child;
    auto word = [](std::uint32_t node, std::uint32_t k) { return SYLVA_KD_HEADER_WORDS + 4 * node + k; };
    auto corrupt = [&](auto&& edit) {
        std::vector<std::uint32_t> w = good;
        edit(w);
        return w;
    };
    std::vector<std::pair<const char*, std::vector<std::uint32_t>>> bad = {
        {"truncated header", std::vector<std::uint32_t>(good.begin(), good.begin() + 10)},
        {"truncated nodes", std::vector<std::uint32_t>(good.begin(), good.end() - 1)},
        {"magic", corrupt([](auto& w) { w[0] ^= 1u; })},
        {"version", corrupt([](auto& w) { w[1] = 99u; })},
        {"node count", corrupt([](auto& w) { w[3] += 1u; })},
        {"depth over cap", corrupt([](auto& w) { w[4] = SYLVA_KD_DEPTH_CAP + 1; })},
        {"depth understated", corrupt([&](auto& w) { w[4] = t.stats.max_depth - 1; })},
        {"leaf count", corrupt([](auto& w) { w[5] -= 1u; })},
        {"zero dim", corrupt([](auto& w) { w[7] = 0u; })},
        {"NaN spacing", corrupt([](auto& w) { w[14] = 0x7FC00000u; })},
        {"negative spacing", corrupt([](auto& w) { w[13] = bits(-1.0f); })},
        {"child backwards", corrupt([&](auto& w) { w[word(inner, 3)] = (w[word(inner, 3)] & 3u) | (inner << 2); })},
        {"child out of range", corrupt([&](auto& w) { w[word(inner, 3)] = (w[word(inner, 3)] & 3u) | (std::uint32_t(t.nodes.size() - 1) << 2); })},
        {"leaf index out of range", corrupt([&](auto& w) { w[word(fc, 3)] = SYLVA_KD_LEAF | (std::uint32_t(t.leaves.size()) << 2); })},
        {"leaf index repeated", corrupt([&](auto& w) { w[word(fc, 3)] = w[word(fc + 1, 3)]; })},
        {"empty box", corrupt([&](auto& w) { w[word(fc, 0)] = (w[word(fc, 0)] & 0xFFFFu) * 0x10001u; })},
        {"box outside grid", corrupt([&](auto& w) { w[word(0, 2)] = (w[word(0, 2)] & 0xFFFFu) | (41u << 16); })},
        {"child outside parent", corrupt([&](auto& w) { w[word(fc, 1)] = w[word(inner, 1)] + (1u << 16); })},
        {"children overlap", corrupt([&](auto& w) {
             std::uint32_t a = t.nodes[inner].axis;
             std::uint32_t lo_upper = w[word(fc + 1, a)] & 0xFFFFu;
             w[word(fc, a)] = (w[word(fc, a)] & 0xFFFFu) | ((lo_upper + 1u) << 16);
         })},
        {"inner node turned into a leaf", corrupt([&](auto& w) { w[word(inner, 3)] = SYLVA_KD_LEAF; })},
    };
    for (auto& [what, w] : bad) {
        INFO(what);
        CHECK_THROWS_AS(kdtree::validate(w), Error);
    }
}

TEST_CASE("iterator: corrupted encodings end the traversal without reading out of bounds", "[iter][validate]") {
    Tree t = kdtree::build_vidal(blobby_occupancy({40, 36, 30}, 8), Config::deep());
    const std::vector<std::uint32_t> good = kdtree::encode(t);
    std::vector<Ray> rays = make_rays(t.dims, 40, 2, false);
    std::mt19937 rng(17);
    std::size_t accepted = 0, errors = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        std::vector<std::uint32_t> w = good;
        std::size_t at = rng() % w.size();
        w[at] = (trial % 2) ? rng() : (w[at] ^ (1u << (rng() % 32)));
        bool valid = true;
        try {
            kdtree::validate(w);
        } catch (const Error&) {
            valid = false;
        }
        accepted += valid;
        shared::SylvaKdHeader h = shared::sylva_kd_read_header(shared::Words{w.data(), w.size()}, std::uint32_t(w.size()));
        for (const Ray& r : rays) {
            kdtree::LeafIterator it(w, r);
            std::size_t n = 0;
            while (auto hit = it.next()) {
                REQUIRE(hit->leaf < h.leaf_count);
                REQUIRE(++n <= h.node_count);
            }
            REQUIRE(it.steps() <= std::max<std::uint32_t>(h.node_count, 1u));
            if (valid) REQUIRE(it.status() == SYLVA_ITER_DONE);  // validate's guarantee
            errors += it.status() == SYLVA_ITER_ERROR;
        }
    }
    CHECK(accepted > 0);  // some flips only move boxes or the transform
    CHECK(errors > 0);
}

namespace {
/// A hand-built tree over a 4^3 grid: root 0 splits x at 2 into inner node 1 (splits y at 2 into
/// leaves 3, 4) and leaf 2. Depth 2, three leaves; stats left at their defaults.
Tree hand_built_kd() {
    Tree t;
    t.dims = {4, 4, 4};
    auto box = [](uvec3 lo, uvec3 hi) { return kdtree::VoxelBox{lo, hi}; };
    t.nodes.resize(5);
    t.nodes[0] = {box({0, 0, 0}, {4, 4, 4}), 1, kdtree::kNone, 2, 0, 0};
    t.nodes[1] = {box({0, 0, 0}, {2, 4, 4}), 3, kdtree::kNone, 2, 1, 1};
    t.nodes[2] = {box({2, 0, 0}, {4, 4, 4}), kdtree::kNone, 0, 0, kdtree::kLeaf, 1};
    t.nodes[3] = {box({0, 0, 0}, {2, 2, 4}), kdtree::kNone, 1, 0, kdtree::kLeaf, 2};
    t.nodes[4] = {box({0, 2, 0}, {2, 4, 4}), kdtree::kNone, 2, 0, kdtree::kLeaf, 2};
    t.leaves = {2, 3, 4};
    return t;
}
}  // namespace

TEST_CASE("encode: measures the depth itself, so a hand-built tree encodes and validates", "[encode][structure]") {
    Tree t = hand_built_kd();
    std::vector<std::uint32_t> w = kdtree::encode(t);
    CHECK(w[4] == 2u);
    CHECK_NOTHROW(kdtree::validate(w));
}

TEST_CASE("encode: refuses links that are not one tree rooted at node 0", "[encode][structure]") {
    using Catch::Matchers::Contains;
    Tree shared = hand_built_kd();
    shared.nodes[2] = shared.nodes[1];  // node 2 inner with the same children as node 1
    shared.nodes[2].box = {{2, 0, 0}, {4, 4, 4}};
    shared.nodes[3].leaf = 0;
    shared.nodes[4].leaf = 1;
    shared.leaves = {3, 4};
    CHECK_THROWS_WITH(kdtree::encode(shared), Contains("node 3") && Contains("twice"));

    Tree orphan = hand_built_kd();
    orphan.nodes.push_back(orphan.nodes[2]);  // node 5: a leaf nothing points at
    orphan.nodes[5].leaf = 3;
    orphan.leaves.push_back(5);
    CHECK_THROWS_WITH(kdtree::encode(orphan), Contains("node 5") && Contains("not reached"));

    Tree swapped = hand_built_kd();
    swapped.nodes[3].leaf = 0;  // leaf index 0 twice, 1 unused
    CHECK_THROWS_WITH(kdtree::encode(swapped), Contains("leaf index 0"));

    Tree mismatch = hand_built_kd();
    mismatch.leaves = {3, 2, 4};  // Tree::leaves disagrees with the nodes' leaf indices
    CHECK_THROWS_WITH(kdtree::encode(mismatch), Contains("leaf index"));
}
