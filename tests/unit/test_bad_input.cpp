// Bad input: clear errors or documented behaviour, never a crash or an out-of-bounds read.
#include <catch2/catch.hpp>

#include <limits>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/bih/validate.hpp>

#include "generators.hpp"

using namespace sylva;
using Catch::Matchers::Contains;

TEST_CASE("empty input is refused", "[bad-input]") {
    std::vector<BoxElement> none;
    CHECK_THROWS_WITH(bih::build(std::span<const BoxElement>(none)), Contains("no elements"));
}

TEST_CASE("NaN and infinite bounds are refused with the element's index", "[bad-input]") {
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    auto elems = testing::random_boxes(100, 41);
    elems[42].box.hi.y = nan;
    CHECK_THROWS_WITH(bih::build(std::span<const BoxElement>(elems)), Contains("element 42") && Contains("non-finite"));
    elems[42].box.hi.y = 1.0f;
    elems[7].box.lo.x = -inf;
    CHECK_THROWS_WITH(bih::build(std::span<const BoxElement>(elems)), Contains("element 7"));
    std::vector<Sphere> spheres{Sphere{{0, 0, 0}, -1.0f}};  // negative radius: inverted box
    CHECK_THROWS_WITH(bih::build(std::span<const Sphere>(spheres)), Contains("element 0") && Contains("inverted"));
}

TEST_CASE("a million coincident elements end in one leaf; near-coincident ones stop at the depth cap",
          "[bad-input]") {
    std::vector<BoxElement> same(1000000, BoxElement{{vec3(1.0f), vec3(2.0f)}});
    ThreadPool pool(2);
    bih::Tree t = bih::build(std::span<const BoxElement>(same), {}, pool);
    CHECK(t.stats.nodes == 1);  // documented: elements whose centres coincide share one leaf
    CHECK(t.stats.max_leaf_elements == 1000000);

    // Distinct but only one float step apart: splits until the depth cap, never beyond.
    std::vector<BoxElement> near;
    float x = 1.0f;
    for (int i = 0; i < 200000; ++i, x = std::nextafter(x, 2.0f)) near.push_back({{vec3(x), vec3(x)}});
    bih::Config cfg;
    cfg.max_depth = 40;
    bih::Tree n = bih::build(std::span<const BoxElement>(near), cfg, pool);
    CHECK(n.stats.max_depth <= 40);
    auto words = bih::encode(n, std::span<const BoxElement>(near), bih::RangePayload{});
    CHECK_NOTHROW(bih::validate(words, near.size()));
}

TEST_CASE("corrupted encodings are rejected by validate and stop the iterator", "[bad-input]") {
    auto elems = testing::random_boxes(500, 43);
    std::span<const BoxElement> es(elems);
    bih::Tree t = bih::build(es);
    auto good = bih::encode(t, es, bih::RangePayload{}, {bih::NodeFormat::Fixed16, bih::Layout::PreOrder, 0});
    Ray ray{{-1.0f, 0.5f, 0.5f}, {1.0f, 0.01f, 0.02f}};

    auto bad_magic = good;
    bad_magic[0] ^= 1u;
    CHECK_THROWS_WITH(bih::validate(bad_magic), Contains("magic"));
    bih::LeafIterator it(bad_magic, ray);
    CHECK_FALSE(it.next());
    CHECK(it.status() == SYLVA_ITER_ERROR);

    auto truncated = std::vector<std::uint32_t>(good.begin(), good.begin() + static_cast<long>(good.size() / 2));
    CHECK_THROWS_WITH(bih::validate(truncated), Contains("header inconsistent"));

    auto deep = good;
    deep[4] = 1000;  // deeper than any stack
    CHECK_THROWS(bih::validate(deep));
    bih::LeafIterator it2(deep, ray);
    CHECK_FALSE(it2.next());

    // Every inner node's link pointed far outside: the iterator must stop with ERROR, not read.
    auto wild = good;
    for (std::size_t i = SYLVA_BIH_HEADER_WORDS + 1; i < wild.size(); i += 2)
        if ((wild[i] & 3u) != SYLVA_BIH_LEAF) wild[i] = (wild[i] & 7u) | (0x1FFFFFF0u << 3);
    CHECK_THROWS_WITH(bih::validate(wild), Contains("out of range"));
    std::size_t errors = 0;
    for (const Ray& r : testing::random_rays(2000, t.bounds, 44)) {
        bih::LeafIterator w(wild, r);
        while (w.next()) {
        }
        errors += w.status() == SYLVA_ITER_ERROR;
    }
    CHECK(errors > 100);

    auto cycle = good;  // a link back to the root
    for (std::size_t i = SYLVA_BIH_HEADER_WORDS + 1; i < cycle.size(); i += 2)
        if ((cycle[i] & 3u) != SYLVA_BIH_LEAF && (cycle[i] & 4u) == 0u) {
            cycle[i] = cycle[i] & 7u;
            break;
        }
    CHECK_THROWS_WITH(bih::validate(cycle), Contains("reached twice"));

    auto range = good;  // a leaf pointing past the elements
    for (std::size_t i = SYLVA_BIH_HEADER_WORDS + 1; i < range.size(); i += 2)
        if ((range[i] & 3u) == SYLVA_BIH_LEAF) {
            range[i - 1] = 499;
            range[i] = SYLVA_BIH_LEAF | (5u << 2);
            break;
        }
    CHECK_THROWS_WITH(bih::validate(range, elems.size()), Contains("beyond"));
}

TEST_CASE("a corrupted link cycle cannot loop the iterator forever (steps are bounded by the node count)", "[bad-input]") {
    auto elems = testing::random_boxes(300, 45);
    std::span<const BoxElement> es(elems);
    bih::Tree t = bih::build(es);
    auto w = bih::encode(t, es, bih::RangePayload{}, {bih::NodeFormat::Float32, bih::Layout::TreeChunks, 1});
    // Point every link at the root's first chunk: traversal revisits nodes, but the stack is
    // bounded and every pop consumes it, so iteration still ends.
    for (std::size_t i = SYLVA_BIH_HEADER_WORDS + 2; i < w.size(); i += 3)
        if ((w[i] & 3u) != SYLVA_BIH_LEAF) w[i] = (w[i] & 7u) | (1u << 3);
    for (const Ray& r : testing::random_rays(500, t.bounds, 46)) {
        bih::LeafIterator it(w, r);
        std::size_t n = 0;
        while (it.next() && n < 10000000) ++n;
        CHECK(n < 10000000);
    }
}

TEST_CASE("brute_force_hits refuses more elements than its 32-bit element index counts", "[bad-input][index-math]") {
    // A span claiming 2^32 + 1 elements over one real one: the count is checked before any
    // element is read (a 32-bit loop counter used to wrap at 2^32 and never end).
    std::vector<Sphere> one{Sphere{{0.0f, 0.0f, 0.0f}, 1.0f}};
    std::span<const Sphere> huge(one.data(), (std::size_t{1} << 32) + 1);
    CHECK_THROWS_WITH(bih::brute_force_hits(huge, Ray{{0.0f, 0.0f, -5.0f}, {0.0f, 0.0f, 1.0f}}),
                      Contains("4294967297 elements"));
}
