// The element octree's structure against brute force: reference lists, children, neighbour
// pointers (searched over all nodes), the encoding against the shared decoder, bad input.
#include <catch2/catch.hpp>

#include <functional>
#include <random>
#include <sstream>

#include <sylva/elements/voxel.hpp>
#include <sylva/octree/elements_validate.hpp>
#include <sylva/shared/octree_elem_iter.h>

#include "common.hpp"

using namespace sylva;
using namespace octe_test;

namespace {

/// Closed overlap of two boxes.
bool overlaps(const Aabb& a, const Aabb& b) {
    return a.lo.x <= b.hi.x && a.hi.x >= b.lo.x && a.lo.y <= b.hi.y && a.hi.y >= b.lo.y && a.lo.z <= b.hi.z &&
           a.hi.z >= b.lo.z;
}

/// Every element whose box meets a leaf's closed world box is listed there (what the walk's
/// ordering relies on), lists are ascending and hold nothing farther than the padding allows,
/// and every element with a box is listed somewhere.
template <class E>
void check_references(const octree::ElementTree& et, const std::vector<E>& es, float pad) {
    std::vector<int> listed(es.size(), 0);
    std::size_t missing = 0, too_far = 0, unsorted = 0;
    std::ostringstream why;
    for (const octree::Node& n : et.tree.nodes) {
        if (!n.leaf()) {
            CHECK(n.brick == octree::kNone);
            continue;
        }
        Aabb box = et.world_box(n);
        std::vector<char> in(es.size(), 0);
        if (n.brick != octree::kNone) {
            auto l = et.list(n.brick);
            REQUIRE(!l.empty());
            for (std::size_t k = 0; k < l.size(); ++k) {
                REQUIRE(l[k] < es.size());
                in[l[k]] = 1;
                listed[l[k]] = 1;
                unsorted += k > 0 && l[k - 1] >= l[k];
            }
        }
        // Grown by the padding plus rounding (coordinates 1e4 cells from the origin: ulps of 0.01
        // cells): listed elements lie within it.
        Aabb grown{box.lo - et.tree.spacing * (pad + 0.1f), box.hi + et.tree.spacing * (pad + 0.1f)};
        for (std::size_t e = 0; e < es.size(); ++e) {
            Aabb b = bounds_of(es[e]);
            if (b.empty()) continue;
            if (overlaps(b, box) && !in[e]) ++missing;
            if (in[e] && !overlaps(b, grown)) {
                if (too_far < 3)
                    why << "element " << e << " lo " << b.lo.x << "," << b.lo.y << "," << b.lo.z << " hi " << b.hi.x << ","
                                  << b.hi.y << "," << b.hi.z << " leaf lo " << box.lo.x << "," << box.lo.y << "," << box.lo.z
                                  << " hi " << box.hi.x << "," << box.hi.y << "," << box.hi.z << " cell " << et.tree.spacing.x << "\n";
                ++too_far;
            }
        }
    }
    CHECK(missing == 0);
    INFO(why.str());
    CHECK(too_far == 0);
    CHECK(unsorted == 0);
    for (std::size_t e = 0; e < es.size(); ++e)
        if (!bounds_of(es[e]).empty()) CHECK(listed[e] == 1);
}

/// Children exist exactly for the octants that start inside the lattice, consecutive, one level
/// down, at 2c + octant; nodes are stored level by level.
void check_children(const octree::ElementTree& et) {
    const octree::Tree& t = et.tree;
    std::vector<int> parents(t.nodes.size(), 0);
    for (std::size_t i = 0; i < t.nodes.size(); ++i) {
        const octree::Node& n = t.nodes[i];
        if (i > 0) CHECK(t.nodes[i - 1].level <= n.level);
        if (n.leaf()) continue;
        std::uint32_t c = n.first_child;
        for (std::uint32_t o = 0; o < 8; ++o) {
            glm::u32vec3 cc = 2u * n.coord + glm::u32vec3(o & 1u, (o >> 1) & 1u, (o >> 2) & 1u);
            bool starts_inside = glm::all(glm::lessThan(cc * t.width(n.level + 1), t.dims));
            CHECK(((n.child_mask >> o) & 1u) == (starts_inside ? 1u : 0u));
            if (!((n.child_mask >> o) & 1u)) continue;
            REQUIRE(c < t.nodes.size());
            CHECK(t.nodes[c].level == n.level + 1);
            CHECK(t.nodes[c].coord == cc);
            parents[c]++;
            ++c;
        }
    }
    for (std::size_t i = 1; i < t.nodes.size(); ++i) CHECK(parents[i] == 1);
}

/// Every neighbour pointer against a search over all nodes: the deepest node at the same or a
/// coarser level whose box holds the cell just across the face's centre; none outside.
void check_neighbours(const octree::ElementTree& et) {
    const octree::Tree& t = et.tree;
    std::size_t bad = 0;
    for (const octree::Node& n : t.nodes) {
        glm::u32vec3 lo = t.box_lo(n), hi = t.box_hi(n);
        for (std::uint32_t f = 0; f < 6; ++f) {
            std::uint32_t a = f / 2;
            glm::i64vec3 p = (glm::i64vec3(lo) + glm::i64vec3(hi)) / std::int64_t{2};
            p[a] = (f & 1u) ? std::int64_t(hi[a]) : std::int64_t(lo[a]) - 1;
            std::uint32_t want = octree::kNone, best_level = 0;
            bool outside = p[a] < 0 || p[a] >= std::int64_t(t.dims[a]);
            for (std::size_t m = 0; m < t.nodes.size() && !outside; ++m) {
                const octree::Node& q = t.nodes[m];
                if (q.level > n.level) continue;
                glm::i64vec3 qlo(t.box_lo(q)), qhi(t.box_hi(q));
                if (glm::all(glm::lessThanEqual(qlo, p)) && glm::all(glm::lessThan(p, qhi)) &&
                    (want == octree::kNone || q.level > best_level)) {
                    want = std::uint32_t(m);
                    best_level = q.level;
                }
            }
            bad += n.neighbour[f] != want;
        }
    }
    CHECK(bad == 0);
}

template <class E>
void check_all(const std::vector<E>& es) {
    for (const auto& cfg : configs()) {
        INFO("leaf " << cfg.leaf_elements << " depth " << cfg.max_depth << " growth " << cfg.max_growth);
        ThreadPool pool(2);
        octree::ElementTree et = octree::build_elements(std::span<const E>(es), cfg, pool);
        octree::ElementTree serial = octree::build_elements(std::span<const E>(es), cfg);
        CHECK(et.refs == serial.refs);  // parallel == serial
        CHECK(et.tree.nodes.size() == serial.tree.nodes.size());
        check_references(et, es, cfg.overlap_pad);
        check_children(et);
        if (et.tree.nodes.size() < 6000) check_neighbours(et);
        CHECK(et.tree.levels <= cfg.max_depth + 1);
    }
}

}  // namespace

TEST_CASE("element octree: references, children and neighbours against brute force", "[build]") {
    check_all(testing::random_boxes(1500, 1));
    check_all(testing::clustered_boxes(1500, 2));
    check_all(testing::degenerate_boxes(1000, 3));
    check_all(testing::random_spheres(1500, 4));
    std::vector<testing::PinnedBox> pinned;
    for (const auto& b : testing::random_boxes(300, 5)) pinned.emplace_back(b.box);
    check_all(pinned);
    // Voxel cuboids (Bounded only: no intersect needed to build): the non-empty cells of a grid.
    std::vector<VoxelCuboid> voxels;
    for (int z = 0; z < 24; ++z)
        for (int y = 0; y < 20; ++y)
            for (int x = 0; x < 17; ++x)
                if ((x * x + y * y + z * z) % 7 < 2) voxels.push_back({{vec3(x, y, z), vec3(x + 1, y + 1, z + 1)}, 0.5f});
    check_all(voxels);
}

TEST_CASE("element octree: the builder splits where elements are dense and stops on coincident ones", "[build]") {
    // 4000 coincident points: splitting never separates them; max_growth does not stop it (each
    // split puts all in one octant), so the chain runs to max_depth with one non-empty leaf.
    std::vector<BoxElement> same(4000, BoxElement{{vec3(0.25f), vec3(0.25f)}});
    same.push_back({{vec3(0.0f), vec3(1.0f)}});  // gives the lattice an extent
    octree::ElementTree et = octree::build_elements(std::span<const BoxElement>(same));
    CHECK(et.tree.levels == 17);
    std::size_t lists = et.leaf_first.size() - 1;
    CHECK(et.refs.size() < 2 * same.size() + 8 * lists);
    // Huge elements covering everything: the root's split would list all in all octants.
    std::vector<BoxElement> huge(50, BoxElement{{vec3(-1.0f), vec3(1.0f)}});
    octree::ElementTree h = octree::build_elements(std::span<const BoxElement>(huge));
    CHECK(h.tree.nodes.size() == 1);
    CHECK(h.refs.size() == 50);
    // Uniform small boxes: leaves mostly at the limit, about one list entry per element and leaf.
    auto rnd = testing::random_boxes(20000, 9, 0.01f);
    octree::ElementTree r = octree::build_elements(std::span<const BoxElement>(rnd));
    CHECK(double(r.refs.size()) < 3.0 * double(rnd.size()));
    CHECK(r.tree.levels == 17);
}

TEST_CASE("element octree: the encoding decodes to the tree through the shared decoder", "[encode]") {
    auto es = testing::clustered_boxes(3000, 11);
    octree::ElementTree et = octree::build_elements(std::span<const BoxElement>(es));
    std::vector<std::uint32_t> w = octree::encode_elements(et);
    shared::Words sw{w.data(), w.size()};
    shared::SylvaOctHeader h = shared::sylva_octe_read_header(sw, std::uint32_t(w.size()));
    REQUIRE(h.valid == 1u);
    CHECK(h.dims == et.tree.dims);
    CHECK(h.levels == et.tree.levels);
    CHECK(h.node_count == et.tree.nodes.size());
    CHECK(h.brick_count == es.size());
    CHECK(h.format == SYLVA_OCTE_FORMAT_ELEMENTS);
    CHECK(h.spacing == et.tree.spacing);
    CHECK(h.origin == et.origin);
    // The volume decoder refuses it (another format), so no volume renderer reads it as bricks.
    CHECK(shared::sylva_oct_read_header(sw, std::uint32_t(w.size()), 0u).valid == 0u);
    for (std::uint32_t n = 0; n < et.tree.nodes.size(); ++n) {
        const octree::Node& node = et.tree.nodes[n];
        std::uint32_t fl = shared::sylva_oct_flags(sw, n);
        CHECK(shared::sylva_oct_first_child(sw, n) == node.first_child);
        CHECK(shared::sylva_oct_child_mask(fl) == node.child_mask);
        CHECK(shared::sylva_oct_level(fl) == node.level);
        CHECK(shared::sylva_oct_coord(sw, n) == node.coord);
        for (std::uint32_t f = 0; f < 6; ++f) CHECK(shared::sylva_oct_neighbour(sw, n, f) == node.neighbour[f]);
        std::uint32_t at = shared::sylva_oct_brick(sw, n);
        if (node.brick == octree::kNone) {
            CHECK(at == SYLVA_OCT_NONE);
            CHECK(shared::sylva_oct_brick_state(fl) == SYLVA_OCT_BRICK_ABSENT);
            continue;
        }
        CHECK(shared::sylva_oct_brick_state(fl) == SYLVA_OCT_BRICK_RESIDENT);
        auto l = et.list(node.brick);
        REQUIRE(at + l.size() < w.size());
        CHECK(w[at] == l.size());
        CHECK(std::equal(l.begin(), l.end(), w.begin() + at + 1));
    }
}

TEST_CASE("element octree: bad input is refused with a message", "[bad-input]") {
    using Catch::Matchers::Contains;
    std::vector<BoxElement> nan{{{vec3(0.0f), vec3(1.0f)}}, {{vec3(0.0f), vec3(std::nanf(""), 1.0f, 1.0f)}}};
    // A NaN corner makes the box neither empty nor finite: named.
    CHECK_THROWS_WITH(octree::build_elements(std::span<const BoxElement>(nan)), Contains("element 1"));
    std::vector<BoxElement> inf{{{vec3(0.0f), vec3(INFINITY)}}};
    CHECK_THROWS_WITH(octree::build_elements(std::span<const BoxElement>(inf)), Contains("not finite"));
    std::vector<BoxElement> wide{{{vec3(-3e38f), vec3(3e38f)}}};
    CHECK_THROWS_WITH(octree::build_elements(std::span<const BoxElement>(wide)), Contains("too large"));
    octree::ElementConfig deep;
    deep.max_depth = 17;
    CHECK_THROWS_WITH(octree::build_elements(std::span<const BoxElement>(), deep), Contains("max_depth"));
    // No elements: a root without references; every query finds nothing.
    octree::ElementTree none = octree::build_elements(std::span<const BoxElement>());
    auto w = octree::encode_elements(none);
    std::vector<bih::ElementHit> hits;
    octree::all_hits(w, std::span<const BoxElement>(), Ray{}, hits);
    CHECK(hits.empty());
    // Elements and encoding that do not belong together.
    auto es = testing::random_boxes(100, 3);
    auto w2 = octree::encode_elements(octree::build_elements(std::span<const BoxElement>(es)));
    CHECK_THROWS_WITH(octree::first_hit(w2, std::span<const BoxElement>(es).first(50), Ray{}), Contains("built over 100"));
}

TEST_CASE("element octree: corrupted encodings end the walk, never loop or read outside", "[bad-input]") {
    auto es = testing::random_boxes(500, 21);
    const auto good = octree::encode_elements(octree::build_elements(std::span<const BoxElement>(es)));
    auto rays = testing::random_rays(64, scene_of(es), 22);
    std::mt19937 rng(23);
    std::size_t errors = 0, runs = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        std::vector<std::uint32_t> w = good;
        if (trial % 10 == 0) w.resize(rng() % w.size());
        else
            for (int k = 0; k < 3; ++k) w[rng() % w.size()] ^= 1u << (rng() % 32);
        shared::Words sw{w.data(), w.size()};
        for (const Ray& r : rays) {
            shared::SylvaOctElemIter it;
            shared::sylva_octe_init(it, sw, std::uint32_t(w.size()), r.origin, r.direction, 0.0f, 1e30f);
            std::uint32_t node, first, count, leaves = 0;
            float t0, t1;
            while (shared::sylva_octe_next(it, sw, node, t0, t1, first, count)) {
                REQUIRE(std::size_t(first) + count <= w.size());
                for (std::uint32_t k = 0; k < count; ++k) shared::sylva_octe_element(it, sw, first + k);
                REQUIRE(++leaves < 100000);
            }
            errors += it.walk.status == SYLVA_ITER_ERROR;
            ++runs;
        }
    }
    CHECK(errors > runs / 10);  // the corruptions are seen
}

TEST_CASE("element octree: morton_order is a permutation that puts neighbours next to each other", "[build]") {
    auto es = testing::random_spheres(20000, 101);
    es.push_back({vec3(0.0f), -1.0f, vec4(1.0f), 2.0f});  // an empty box: last
    auto order = octree::morton_order(std::span<const Sphere>(es));
    REQUIRE(order.size() == es.size());
    std::vector<std::uint32_t> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 0; i < sorted.size(); ++i) REQUIRE(sorted[i] == i);
    CHECK(order.back() == es.size() - 1);
    auto path = [&](auto at) {
        double d = 0.0;
        for (std::size_t i = 1; i + 1 < es.size(); ++i) d += glm::distance(es[at(i)].center, es[at(i - 1)].center);
        return d;
    };
    double given = path([](std::size_t i) { return i; });
    double coherent = path([&](std::size_t i) { return order[i]; });
    CHECK(coherent < given / 10.0);  // 20000 random points: ~1.1 apart as given, ~0.03 in Morton order
}

TEST_CASE("element octree: validate_elements accepts every built encoding and names each corruption", "[validate]") {
    using Catch::Matchers::Contains;
    for (const auto& cfg : configs()) {
        auto a = testing::clustered_boxes(2000, 111);
        CHECK_NOTHROW(octree::validate_elements(octree::encode_elements(octree::build_elements(std::span<const BoxElement>(a), cfg)), a.size()));
        auto d = testing::degenerate_boxes(1000, 112);
        CHECK_NOTHROW(octree::validate_elements(octree::encode_elements(octree::build_elements(std::span<const BoxElement>(d), cfg)), d.size()));
    }
    auto es = testing::random_boxes(800, 113);
    octree::ElementTree et = octree::build_elements(std::span<const BoxElement>(es));
    const auto good = octree::encode_elements(et);
    REQUIRE(et.tree.nodes.size() > 9);
    std::uint32_t leaf = 0, inner = 0;
    for (std::uint32_t n = 0; n < et.tree.nodes.size(); ++n) {
        if (et.tree.nodes[n].brick != octree::kNone && !leaf) leaf = n;
        if (!et.tree.nodes[n].leaf() && n > 0 && !inner) inner = n;
    }
    REQUIRE(leaf > 0);
    auto rec = [](std::uint32_t n) { return SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n; };
    std::uint32_t list = good[rec(leaf) + 12];
    struct Case {
        std::function<void(std::vector<std::uint32_t>&)> corrupt;
        const char* message;
    };
    std::vector<Case> cases = {
        {[](auto& w) { w.resize(10); }, "shorter than the 20-word header"},
        {[](auto& w) { w[0] ^= 1u; }, "bad magic"},
        {[](auto& w) { w[5] &= 0x00FFFFFFu; }, "is not 1 (an element octree)"},
        {[](auto& w) { w.push_back(0u); }, "the buffer holds"},
        {[](auto& w) { w[7] += 1u; }, "elements, 800 given"},
        {[](auto& w) { w[6] += 1u; }, "do not fill"},
        {[](auto& w) { w[13] = 0u; }, "out of range"},
        {[&](auto& w) { w[rec(leaf) + 1] |= 1u << 18; }, "reserved bits"},
        {[&](auto& w) { w[rec(leaf) + 14] = 5u; }, "reserved bits"},
        {[&](auto& w) { w[rec(leaf) + 1] = (w[rec(leaf) + 1] & ~(31u << 8)) | (20u << 8); }, "is at level 20"},
        {[&](auto& w) { w[rec(leaf) + 12] = 3u; }, "outside the reference words"},
        {[&](auto& w) { w[list] = 0u; }, "or empty"},
        {[&](auto& w) { w[list + 1] = 5000u; }, "references element 5000"},
        {[&](auto& w) { w[rec(leaf) + 1] &= ~(3u << 16); }, "not a resident leaf"},
        {[&](auto& w) { w[rec(inner)] += 1u; }, "child octant"},
        {[&](auto& w) { w[rec(leaf) + 4] ^= 1u; }, "neighbour across face 0"},
    };
    for (std::size_t i = 0; i < cases.size(); ++i) {
        INFO("case " << i << ": " << cases[i].message);
        auto w = good;
        cases[i].corrupt(w);
        CHECK_THROWS_WITH(octree::validate_elements(w, es.size()), Contains(cases[i].message) && Contains("octree::validate_elements"));
    }
    // Random flips: validate never reads outside the buffer (sanitizer builds) and names a problem
    // for most of them.
    std::mt19937 rng(114);
    int refused = 0;
    for (int t = 0; t < 2000; ++t) {
        auto w = good;
        w[rng() % w.size()] ^= 1u << (rng() % 32);
        try {
            octree::validate_elements(w, es.size());
        } catch (const Error&) {
            ++refused;
        }
    }
    CHECK(refused > 1000);
}
