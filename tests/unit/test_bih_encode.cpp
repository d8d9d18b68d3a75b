// Encoder offsets and bits against the shared decoder.
#include <catch2/catch.hpp>

#include <cstring>
#include <functional>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/validate.hpp>

#include "generators.hpp"

using namespace sylva;
using namespace sylva::shared;

namespace {
float f(std::uint32_t u) {
    float x;
    std::memcpy(&x, &u, 4);
    return x;
}

/// Walks tree and encoding together through the shared decoder; every node must match.
void compare(const bih::Tree& t, std::span<const std::uint32_t> words, const bih::EncodeConfig& cfg) {
    Words buf{words.data(), words.size()};
    SylvaBihHeader h = sylva_bih_read_header(buf, static_cast<uint>(words.size()));
    REQUIRE(h.valid == 1u);
    REQUIRE(h.node_count == t.nodes.size());
    CHECK(h.max_depth == t.stats.max_depth);
    bool f32 = cfg.format == bih::NodeFormat::Float32;
    vec3 ext = t.bounds.extent();
    std::size_t visited = 0;
    std::function<void(std::uint32_t, std::uint32_t)> walk = [&](std::uint32_t ti, std::uint32_t ei) {
        ++visited;
        const bih::Node& n = t.nodes[ti];
        uint meta = sylva_bih_meta(buf, h, ei);
        if (n.leaf()) {
            REQUIRE((meta & 3u) == SYLVA_BIH_LEAF);
            uvec2 p = sylva_bih_payload(buf, h, ei);
            CHECK(p.x == n.first);
            CHECK(p.y == n.count);
            return;
        }
        REQUIRE((meta & 3u) == n.axis);
        CHECK(((meta & 4u) != 0u) == n.single);
        vec2 pl = sylva_bih_planes(buf, h, ei);
        for (int k = 0; k < 2; ++k) {
            float want = n.plane[k];
            if (std::isinf(want)) {
                CHECK(pl[k] == want);
            } else if (f32) {
                CHECK(pl[k] == want);
            } else {  // fixed point: conservative and within one step
                float world = t.bounds.lo[n.axis] + pl[k] * ext[n.axis];
                float step = ext[n.axis] / 32768.0f;
                bool upper = (k == 0) != n.single;
                CHECK(std::abs(world - want) <= step * 1.01f);
                if (upper) CHECK(world >= want - step * 1e-3f);
                else CHECK(world <= want + step * 1e-3f);
            }
        }
        if (n.single) {
            uint child = (h.flags & SYLVA_BIH_FLAG_CHUNKED) ? (meta >> 3u) : ei + 1u;
            walk(n.child[0], child);
            return;
        }
        uvec2 kids = sylva_bih_children(h, ei, meta, pl);
        CHECK((kids.x == SYLVA_NO_NODE) == (n.child[0] == bih::kNoChild));
        CHECK((kids.y == SYLVA_NO_NODE) == (n.child[1] == bih::kNoChild));
        if (n.child[0] != bih::kNoChild) walk(n.child[0], kids.x);
        if (n.child[1] != bih::kNoChild) walk(n.child[1], kids.y);
    };
    walk(0, 0);
    CHECK(visited == t.nodes.size());
}
}  // namespace

TEST_CASE("encoder output decodes to the built tree in every format and layout", "[bih][encode]") {
    auto elems = testing::clustered_boxes(3000, 31);
    std::span<const BoxElement> es(elems);
    for (auto mode : {bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite}) {
        bih::Config bc;
        bc.empty_children = mode;
        bih::Tree t = bih::build(es, bc);
        for (auto fmt : {bih::NodeFormat::Fixed16, bih::NodeFormat::Float32}) {
            for (auto [layout, depth] : {std::pair{bih::Layout::PreOrder, 0u}, std::pair{bih::Layout::TreeChunks, 0u},
                                         std::pair{bih::Layout::TreeChunks, 2u}, std::pair{bih::Layout::TreeChunks, 5u}}) {
                bih::EncodeConfig ec{fmt, layout, depth};
                auto words = bih::encode(t, es, bih::RangePayload{}, ec);
                CHECK(words.size() == SYLVA_BIH_HEADER_WORDS + t.nodes.size() * (fmt == bih::NodeFormat::Float32 ? 3 : 2));
                compare(t, words, ec);
                CHECK_NOTHROW(bih::validate(words, elems.size()));
            }
        }
    }
}

TEST_CASE("header fields sit at their documented offsets", "[bih][encode]") {
    std::vector<BoxElement> elems{{{vec3(0.0f), vec3(1.0f)}}, {{vec3(2.0f, 0.0f, 0.0f), vec3(4.0f, 1.0f, 2.0f)}}};
    std::span<const BoxElement> es(elems);
    bih::Tree t = bih::build(es);
    auto w = bih::encode(t, es, bih::RangePayload{}, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 3});
    CHECK(w[0] == 0x49425953u);
    CHECK(w[1] == 1u);
    CHECK((w[2] & 1u) == 0u);
    CHECK((w[2] & 2u) == 2u);
    CHECK(((w[2] >> 2) & 15u) == 3u);
    CHECK(((w[2] >> 8) & 255u) == SYLVA_PAYLOAD_RANGE);
    CHECK(w[3] == t.nodes.size());
    CHECK(w[4] == t.stats.max_depth);
    CHECK(w[5] == 2u);
    CHECK(w[6] == 2u);
    CHECK(f(w[8]) == 0.0f);
    CHECK(f(w[11]) == 4.0f);
    CHECK(f(w[13]) == 2.0f);
    CHECK(f(w[17]) == 0.25f);  // 1 / extent x
    CHECK(f(w[19]) == 0.5f);
    // the root splits x in the middle: left plane 1.0 -> 0x4000 + 8192, right 2.0 -> 0x4000 + 16384
    CHECK((w[21] & 3u) == 0u);
    CHECK((w[20] & 0xFFFFu) == 0x4000u + 8192u);
    CHECK((w[20] >> 16) == 0x4000u + 16384u);
}

TEST_CASE("tree chunks store a node's children next to each other", "[bih][encode]") {
    auto elems = testing::grid_boxes(6);
    std::span<const BoxElement> es(elems);
    bih::Tree t = bih::build(es);
    auto w = bih::encode(t, es, bih::RangePayload{}, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2});
    Words buf{w.data(), w.size()};
    SylvaBihHeader h = sylva_bih_read_header(buf, static_cast<uint>(w.size()));
    // the root's chunk: children at 1-2, grandchildren at 3-6, great-grandchildren at 7-14
    uint root = sylva_bih_meta(buf, h, 0);
    CHECK((root >> 3) == 1u);
    uvec2 kids = sylva_bih_children(h, 0, root, sylva_bih_planes(buf, h, 0));
    CHECK(kids.x == 1u);
    CHECK(kids.y == 2u);
    uint left = sylva_bih_meta(buf, h, 1);
    CHECK((left >> 3) == 3u);
    uint right = sylva_bih_meta(buf, h, 2);
    CHECK((right >> 3) == 5u);
}
