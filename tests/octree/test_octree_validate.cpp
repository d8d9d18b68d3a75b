// The bricked octree's encoding: the encoder against the shared decoder, validate() against
// targeted corruptions (each named) and a random bit-flip / truncation fuzz (never crashes; the
// iterator over any corrupted encoding ends, with DONE or ERROR, without reading out of bounds).
#include <catch2/catch.hpp>

#include <bit>
#include <cstdint>
#include <random>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/validate.hpp>
#include <sylva/shared/octree_iter.h>

#include "rays.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;
using Catch::Matchers::Contains;

namespace {

std::size_t record(std::uint32_t n) { return SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n; }

/// validate's message for `words` (empty when it accepts them).
std::string message(const std::vector<std::uint32_t>& words, const std::vector<std::uint32_t>& bricks) {
    try {
        octree::validate(words, bricks);
    } catch (const Error& e) {
        return e.what();
    }
    return {};
}

}  // namespace

TEST_CASE("octree encoding: the shared decoder reads back every field the builder wrote", "[octree][encode]") {
    octree::Tree t = octree::build(blobs({33, 17, 70}, 11, vec3(0.5f, 1.0f, 2.0f)), {16, 2});
    std::vector<std::uint32_t> w = octree::encode(t);
    REQUIRE(w.size() == 20 + 16 * t.nodes.size());
    CHECK(octree::index_bytes(t) == w.size() * 4);
    shared::Words buf{w.data(), w.size()};
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(buf, std::uint32_t(w.size()), std::uint32_t(t.bricks.size()));
    REQUIRE(h.valid == 1u);
    CHECK(h.dims == t.dims);
    CHECK(h.brick_size == 16u);
    CHECK(h.border == 2u);
    CHECK(h.levels == t.levels);
    CHECK(h.node_count == t.nodes.size());
    CHECK(h.brick_count == t.nodes.size());
    CHECK(h.brick_words == 20u * 20u * 20u);
    CHECK(h.spacing == t.spacing);
    CHECK(h.inv_spacing == vec3(2.0f, 1.0f, 0.5f));
    for (std::uint32_t n = 0; n < t.nodes.size(); ++n) {
        const octree::Node& node = t.nodes[n];
        std::uint32_t flags = shared::sylva_oct_flags(buf, n);
        CHECK(shared::sylva_oct_child_mask(flags) == node.child_mask);
        CHECK(shared::sylva_oct_level(flags) == node.level);
        CHECK(shared::sylva_oct_brick_state(flags) == SYLVA_OCT_BRICK_RESIDENT);
        CHECK(shared::sylva_oct_coord(buf, n) == node.coord);
        CHECK(shared::sylva_oct_first_child(buf, n) == node.first_child);
        for (std::uint32_t f = 0; f < 6; ++f) CHECK(shared::sylva_oct_neighbour(buf, n, f) == node.neighbour[f]);
        CHECK(shared::sylva_oct_range(buf, n) == vec2(node.min, node.max));
        CHECK(shared::sylva_oct_brick(buf, n) == node.brick);
        vec3 lo, hi;
        shared::sylva_oct_box(h, node.level, node.coord, lo, hi);
        CHECK(lo == vec3(t.box_lo(node)));
        CHECK(hi == vec3(t.box_hi(node)));
    }
    CHECK_NOTHROW(octree::validate(w, t.bricks));
    // Host-only bricks and a sparse tree without bricks are valid too.
    CHECK_NOTHROW(octree::validate(octree::encode(t, SYLVA_OCT_BRICK_HOST), t.bricks));
    octree::Tree sparse = sparse_tree({70, 33, 45}, 4, 3, 0.5f);
    std::vector<std::uint32_t> sw = octree::encode(sparse);
    CHECK(shared::sylva_oct_brick_state(sw[record(0) + 1]) == SYLVA_OCT_BRICK_ABSENT);
    CHECK_NOTHROW(octree::validate(sw, {}));
}

TEST_CASE("octree validate names each corruption", "[octree][errors]") {
    octree::Tree t = octree::build(blobs({33, 17, 70}, 12), {8, 1});
    const std::vector<std::uint32_t> good = octree::encode(t);
    const std::vector<std::uint32_t>& bricks = t.bricks;
    REQUIRE(message(good, bricks).empty());
    auto with = [&](std::size_t at, std::uint32_t v) {
        std::vector<std::uint32_t> w = good;
        w[at] = v;
        return message(w, bricks);
    };
    CHECK_THAT(message({1, 2, 3}, bricks), Contains("shorter than the 20-word header"));
    CHECK_THAT(with(0, 0), Contains("bad magic"));
    CHECK_THAT(with(1, 7), Contains("version 7"));
    std::vector<std::uint32_t> truncated(good.begin(), good.end() - 16);
    CHECK_THAT(message(truncated, bricks), Contains("truncated"));
    CHECK_THAT(with(3, 0), Contains("extent 0 along axis 1"));
    CHECK_THAT(with(5, good[5] ^ 8u), Contains("brick size"));
    CHECK_THAT(with(5, good[5] + (1u << 16)), Contains("levels"));
    CHECK_THAT(with(5, good[5] | (1u << 24)), Contains("brick format"));
    CHECK_THAT(with(6, good[6] + 1), Contains("nodes stated"));
    CHECK_THAT(with(7, good[7] - 1), Contains("brick buffer holds"));
    CHECK_THAT(with(11, std::bit_cast<std::uint32_t>(-1.0f)), Contains("spacing"));
    CHECK_THAT(with(19, 1), Contains("reserved header word"));
    std::uint32_t inner = 1, leaf = std::uint32_t(t.nodes.size() - 1);
    REQUIRE(!t.nodes[inner].leaf());
    CHECK_THAT(with(record(leaf) + 1, good[record(leaf) + 1] | (1u << 20)), Contains("reserved bits"));
    CHECK_THAT(with(record(leaf) + 1, (good[record(leaf) + 1] & ~0x1F00u) | (9u << 8)), Contains("level 9"));
    CHECK_THAT(with(record(leaf) + 3, 4000), Contains("starts outside the volume"));
    CHECK_THAT(with(record(inner), SYLVA_OCT_NONE), Contains("disagree about it being a leaf"));
    CHECK_THAT(with(record(inner), std::uint32_t(t.nodes.size())), Contains("out of range"));
    CHECK_THAT(with(record(inner), 0), Contains("is not one level down"));  // a cycle through the root
    CHECK_THAT(with(record(inner), t.nodes[inner].first_child + 1), Contains("not one level down"));
    std::vector<std::uint32_t> deep = good;
    deep[record(leaf)] = leaf;
    deep[record(leaf) + 1] |= 1u;
    CHECK_THAT(message(deep, bricks), Contains("children below the last level"));
    CHECK_THAT(with(record(leaf) + 10, std::bit_cast<std::uint32_t>(2.0f)), Contains("bad range"));
    CHECK_THAT(with(record(leaf) + 11, 0x7FC00000u), Contains("bad range"));
    CHECK_THAT(with(record(leaf) + 12, std::uint32_t(t.nodes.size())), Contains("brick index"));
    CHECK_THAT(with(record(leaf) + 1, good[record(leaf) + 1] | (3u << 16)), Contains("brick state 3"));
    CHECK_THAT(with(record(leaf) + 14, 5), Contains("reserved bits"));
    std::uint32_t f = 0;
    while (t.nodes[leaf].neighbour[f] == octree::kNone) ++f;
    CHECK_THAT(with(record(leaf) + 4 + f, SYLVA_OCT_NONE), Contains("neighbour across face " + std::to_string(f)));
    CHECK_THAT(with(record(leaf) + 4 + f, 0), Contains("touches that face"));
    std::uint32_t boundary = 0;
    while (t.nodes[leaf].neighbour[boundary] != octree::kNone) ++boundary;
    CHECK_THAT(with(record(leaf) + 4 + boundary, leaf - 1), Contains("is none"));
    // Two nodes claiming one child: the second parent's pointer moved onto the first's children.
    std::uint32_t a = 1, b = 2;
    while (t.nodes[b].child_mask != t.nodes[a].child_mask) ++b;
    std::vector<std::uint32_t> shared_child = good;
    shared_child[record(b)] = good[record(a)];
    CHECK_THAT(message(shared_child, bricks), Contains("not one level down"));
    std::vector<std::uint32_t> bad_bricks = bricks;
    bad_bricks[1234] = 0x7F800000u;
    CHECK_THAT(message(good, bad_bricks), Contains("brick sample 1234"));
    bad_bricks.pop_back();
    CHECK_THAT(message(good, bad_bricks), Contains("brick buffer holds"));
}

TEST_CASE("octree validate fuzz: bit flips and truncations never crash; the iterator always ends", "[octree][errors][fuzz]") {
    octree::Tree t = octree::build(blobs({37, 21, 50}, 13), {4, 1});
    const std::vector<std::uint32_t> good = octree::encode(t);
    std::vector<TestRay> rays = test_rays(t, 24, 14);
    std::mt19937 rng(15);
    std::size_t rejected = 0, accepted = 0, errors = 0, walks = 0;
    for (std::uint32_t trial = 0; trial < 3000; ++trial) {
        std::vector<std::uint32_t> w = good;
        std::uint32_t flips = 1 + rng() % 3;
        for (std::uint32_t k = 0; k < flips; ++k) {
            // Half the flips in the header and first records, where they matter most.
            std::size_t at = (rng() % 2) ? rng() % std::min<std::size_t>(w.size(), 20 + 16 * 12) : rng() % w.size();
            w[at] ^= 1u << (rng() % 32);
        }
        if (trial % 5 == 0) w.resize(rng() % w.size());
        std::string m = message(w, t.bricks);
        if (m.empty()) {
            ++accepted;
        } else {
            ++rejected;
            REQUIRE_THAT(m, Contains("octree::validate: "));
        }
        // The iterator runs over whatever is there and always ends.
        shared::Words buf{w.data(), w.size()};
        for (const TestRay& r : rays) {
            shared::SylvaOctIter it{};
            shared::sylva_oct_init(it, buf, std::uint32_t(w.size()), std::uint32_t(t.bricks.size()), r.o, r.d, r.t0, r.t1,
                                   0xFFFFFFFFu);
            std::uint32_t node, yielded = 0;
            float t0, t1;
            while (shared::sylva_oct_next(it, buf, node, t0, t1)) {
                REQUIRE(node < t.nodes.size());
                REQUIRE(++yielded <= it.step_limit);
            }
            REQUIRE(it.status != SYLVA_ITER_RUNNING);
            errors += it.status == SYLVA_ITER_ERROR ? 1 : 0;
            if (m.empty()) REQUIRE(it.status == SYLVA_ITER_DONE);  // accepted encodings walk cleanly
            ++walks;
        }
    }
    CHECK(rejected > 2000);
    CHECK(accepted > 50);
    CHECK(errors > 100);
    CHECK(walks == 3000 * rays.size());
}
