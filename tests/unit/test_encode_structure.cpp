// bih::encode does not trust the Tree it is handed: structure checked, depth measured, payload kind range-checked.
#include <catch2/catch.hpp>

#include <sylva/bih/encode.hpp>
#include <sylva/bih/validate.hpp>

#include "generators.hpp"

using namespace sylva;
using Catch::Matchers::Contains;

namespace {
/// root(0) -> inner(1) -> leaves 2, 3; root's right child is leaf 4: depth 2, 3 leaves.
bih::Tree hand_built() {
    bih::Tree t;
    t.bounds = Aabb{vec3(0.0f), vec3(1.0f)};
    t.order = {0, 1, 2};
    t.nodes.resize(5);
    auto inner = [](bih::Node& n, std::uint32_t l, std::uint32_t r, float a, float b) {
        n.axis = 0;
        n.child[0] = l;
        n.child[1] = r;
        n.plane[0] = a;
        n.plane[1] = b;
    };
    inner(t.nodes[0], 1, 4, 0.5f, 0.5f);
    inner(t.nodes[1], 2, 3, 0.25f, 0.25f);
    t.nodes[2].first = 0, t.nodes[2].count = 1;
    t.nodes[3].first = 1, t.nodes[3].count = 1;
    t.nodes[4].first = 2, t.nodes[4].count = 1;
    return t;  // stats left at their defaults, as a hand-built tree has them
}
std::vector<BoxElement> three() { return testing::random_boxes(3, 5); }

struct WidePayload {
    static constexpr std::uint32_t kind = 256u;  // does not fit the header's 8-bit kind field
    template <Bounded E>
    [[nodiscard]] std::uint64_t encode(std::span<const E> leaf, std::uint32_t first) const {
        return bih::RangePayload{}.encode(leaf, first);
    }
};
}  // namespace

TEST_CASE("encode measures depth and leaf count itself: a hand-built tree encodes and validates",
          "[bih][encode][structure]") {
    bih::Tree t = hand_built();
    auto es = three();
    for (bih::Layout layout : {bih::Layout::PreOrder, bih::Layout::TreeChunks}) {
        auto w = bih::encode(t, std::span<const BoxElement>(es), bih::RangePayload{}, {bih::NodeFormat::Float32, layout, 2});
        CHECK(w[4] == 2u);  // max depth (root = 0)
        CHECK(w[5] == 3u);  // leaves
        CHECK(w[6] == 3u);  // elements in leaves
        CHECK_NOTHROW(bih::validate(w, es.size()));
    }
}

TEST_CASE("encode refuses a tree whose links are not a tree rooted at node 0", "[bih][encode][structure]") {
    auto es = three();
    std::span<const BoxElement> s(es);
    for (bih::Layout layout : {bih::Layout::PreOrder, bih::Layout::TreeChunks}) {
        bih::EncodeConfig cfg{bih::NodeFormat::Fixed16, layout, 2};
        bih::Tree cycle = hand_built();
        cycle.nodes[1].child[1] = 0;  // back to the root: a cycle
        CHECK_THROWS_WITH(bih::encode(cycle, s, bih::RangePayload{}, cfg), Contains("node 0") && Contains("twice"));

        bih::Tree shared = hand_built();
        shared.nodes[0].child[1] = 2;  // leaf 2 under two parents, leaf 4 unreached
        CHECK_THROWS_WITH(bih::encode(shared, s, bih::RangePayload{}, cfg), Contains("node 2") && Contains("twice"));

        bih::Tree orphan = hand_built();
        orphan.nodes.push_back(bih::Node{});  // node 5: nothing points at it
        CHECK_THROWS_WITH(bih::encode(orphan, s, bih::RangePayload{}, cfg), Contains("node 5") && Contains("not reached"));

        bih::Tree out = hand_built();
        out.nodes[1].child[0] = 9;
        CHECK_THROWS_WITH(bih::encode(out, s, bih::RangePayload{}, cfg), Contains("node 1") && Contains("out of range"));

        bih::Tree childless = hand_built();
        childless.nodes[1].child[0] = childless.nodes[1].child[1] = bih::kNoChild;
        childless.nodes.resize(2);
        childless.nodes[0].child[1] = bih::kNoChild;
        CHECK_THROWS_WITH(bih::encode(childless, s, bih::RangePayload{}, cfg), Contains("node 1") && Contains("no child"));

        bih::Tree bad_axis = hand_built();
        bad_axis.nodes[1].axis = 7;
        CHECK_THROWS_WITH(bih::encode(bad_axis, s, bih::RangePayload{}, cfg), Contains("node 1") && Contains("axis"));
    }
}

TEST_CASE("encode refuses a tree deeper than the layout's depth cap", "[bih][encode][structure]") {
    bih::Tree t;
    t.bounds = Aabb{vec3(0.0f), vec3(1.0f)};
    t.order = {0};
    std::uint32_t depth = SYLVA_BIH_DEPTH_CAP + 1;
    t.nodes.resize(depth + 1);
    for (std::uint32_t i = 0; i < depth; ++i) {  // a chain of single-child nodes
        t.nodes[i].axis = 0;
        t.nodes[i].single = true;
        t.nodes[i].child[0] = i + 1;
        t.nodes[i].plane[0] = 0.0f;
        t.nodes[i].plane[1] = 1.0f;
    }
    t.nodes[depth].count = 1;
    auto es = testing::random_boxes(1, 3);
    CHECK_THROWS_WITH(bih::encode(t, std::span<const BoxElement>(es), bih::RangePayload{}), Contains("depth"));
}

TEST_CASE("encode refuses a payload kind that does not fit the header's 8-bit field", "[bih][encode][structure]") {
    bih::Tree t = hand_built();
    auto es = three();
    CHECK_THROWS_WITH(bih::encode(t, std::span<const BoxElement>(es), WidePayload{}), Contains("payload kind 256"));
}
