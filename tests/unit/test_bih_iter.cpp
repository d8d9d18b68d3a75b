// The iterator and the queries against brute force over all elements.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>
#include <sylva/bih/validate.hpp>

#include "generators.hpp"

using namespace sylva;

namespace {

struct Variant {
    const char* name;
    bih::Config build;
    bih::EncodeConfig encode;
};

std::vector<Variant> variants() {
    bih::Config trim_both, infinite, wide;
    infinite.empty_children = bih::EmptyChildren::Infinite;
    wide.max_leaf_elements = 4;
    wide.trim_leaves = false;
    return {
        {"fixed16/chunks/trim-both", trim_both, {bih::NodeFormat::Fixed16, bih::Layout::TreeChunks, 2}},
        {"float32/pre-order/infinite", infinite, {bih::NodeFormat::Float32, bih::Layout::PreOrder, 0}},
        {"fixed16/pre-order/infinite", infinite, {bih::NodeFormat::Fixed16, bih::Layout::PreOrder, 0}},
        {"float32/chunks0/4-per-leaf", wide, {bih::NodeFormat::Float32, bih::Layout::TreeChunks, 0}},
    };
}

/// Runs `rays` through every variant; all hits and first hits must equal brute force.
template <class E>
void check_against_brute_force(const std::vector<E>& elems, const std::vector<Ray>& rays) {
    std::span<const E> es(elems);
    ThreadPool pool(2);
    for (const Variant& v : variants()) {
        INFO("variant " << v.name);
        bih::Tree tree = bih::build(es, v.build, pool);
        auto words = bih::encode(tree, es, bih::RangePayload{}, v.encode);
        REQUIRE_NOTHROW(bih::validate(words, elems.size()));
        std::vector<bih::ElementHit> hits;
        std::size_t total_hits = 0, mismatches = 0;
        for (const Ray& r : rays) {
            auto expected = bih::brute_force_hits(es, r);
            bih::all_hits(words, tree, es, r, hits);
            total_hits += expected.size();
            if (hits != expected) ++mismatches;
            auto first = bih::first_hit(words, tree, es, r);
            if (expected.empty() ? first.has_value() : (!first || *first != expected.front())) ++mismatches;
        }
        CHECK(mismatches == 0);
        CHECK(total_hits > rays.size() / 10);  // the rays really hit things
    }
}

}  // namespace

TEST_CASE("all hits and first hit equal brute force on random boxes", "[bih][iter]") {
    auto elems = testing::random_boxes(3000, 1);
    auto rays = testing::random_rays(30000, {vec3(0.0f), vec3(1.05f)}, 2);
    check_against_brute_force(elems, rays);
}

TEST_CASE("all hits and first hit equal brute force on clustered boxes", "[bih][iter]") {
    auto elems = testing::clustered_boxes(3000, 3);
    auto rays = testing::random_rays(30000, {vec3(0.0f), vec3(10.0f)}, 4);
    check_against_brute_force(elems, rays);
}

TEST_CASE("all hits and first hit equal brute force on degenerate boxes", "[bih][iter]") {
    auto elems = testing::degenerate_boxes(2000, 5);
    auto rays = testing::random_rays(30000, {vec3(0.0f), vec3(1.0f)}, 6);
    check_against_brute_force(elems, rays);
}

TEST_CASE("all hits equal brute force on spheres", "[bih][iter]") {
    auto elems = testing::random_spheres(2000, 7);
    auto rays = testing::random_rays(20000, {vec3(-1.0f), vec3(1.0f)}, 8);
    check_against_brute_force(elems, rays);
}

TEST_CASE("leaves of disjoint elements come strictly front to back", "[bih][iter]") {
    // 16 cells: every cell face k/16 is exact in 16-bit fixed point, so no two leaf boxes overlap
    // (with 12 cells the conservative rounding would make neighbours overlap by one step).
    auto elems = testing::grid_boxes(16);
    std::span<const BoxElement> es(elems);
    auto rays = testing::random_rays(20000, {vec3(0.0f), vec3(16.0f)}, 9);
    for (auto enc : {bih::NodeFormat::Fixed16, bih::NodeFormat::Float32}) {
        bih::Tree tree = bih::build(es);
        auto words = bih::encode(tree, es, bih::RangePayload{}, {enc, bih::Layout::TreeChunks, 2});
        std::size_t violations = 0, leaves = 0;
        for (const Ray& r : rays) {
            bih::LeafIterator it(words, r);
            float last = -std::numeric_limits<float>::infinity();
            while (auto leaf = it.next()) {
                ++leaves;
                if (leaf->t.t0 < last) ++violations;
                last = leaf->t.t0;
                CHECK(leaf->t.t0 <= leaf->t.t1);
            }
            CHECK(it.status() == SYLVA_ITER_DONE);
        }
        CHECK(leaves > 100000);
        CHECK(violations == 0);
    }
}

TEST_CASE("rays lying in a splitting plane see the closed boxes on both sides", "[bih][iter]") {
    // Two unit cubes side by side share the face x = 1; a ray in that face, parallel to it,
    // touches both (closed boxes), whichever sign its zero x component has.
    std::vector<BoxElement> elems{{{vec3(0.0f), vec3(1.0f)}}, {{vec3(1.0f, 0.0f, 0.0f), vec3(2.0f, 1.0f, 1.0f)}}};
    std::span<const BoxElement> es(elems);
    for (auto mode : {bih::EmptyChildren::TrimBoth, bih::EmptyChildren::Infinite}) {
        bih::Config cfg;
        cfg.empty_children = mode;
        bih::Tree tree = bih::build(es, cfg);
        for (auto fmt : {bih::NodeFormat::Fixed16, bih::NodeFormat::Float32}) {
            auto words = bih::encode(tree, es, bih::RangePayload{}, {fmt, bih::Layout::PreOrder, 0});
            for (float zero : {0.0f, -0.0f}) {
                Ray r{{1.0f, 0.5f, -1.0f}, {zero, 0.0f, 1.0f}};
                std::vector<bih::ElementHit> hits;
                bih::all_hits(words, tree, es, r, hits);
                CHECK(hits.size() == 2);
                CHECK(hits == bih::brute_force_hits(es, r));
            }
            Ray starts_inside{{0.5f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}};
            auto first = bih::first_hit(words, tree, es, starts_inside);
            REQUIRE(first);
            CHECK(first->element == 0);
            CHECK(first->t.t0 == 0.0f);
        }
    }
}

TEST_CASE("clip prunes what lies beyond a known hit", "[bih][iter]") {
    auto elems = testing::grid_boxes(8);
    std::span<const BoxElement> es(elems);
    bih::Tree tree = bih::build(es);
    auto words = bih::encode(tree, es, bih::RangePayload{});
    Ray r{{-1.0f, 4.5f, 4.5f}, {1.0f, 0.0f, 0.0f}};
    bih::LeafIterator all(words, r), clipped(words, r);
    std::size_t n_all = 0, n_clipped = 0;
    while (all.next()) ++n_all;
    clipped.clip(3.0f);
    while (auto l = clipped.next()) {
        ++n_clipped;
        CHECK(l->t.t0 <= 3.0f);
    }
    CHECK(n_clipped < n_all);
    CHECK(n_clipped >= 2);
}

namespace {

std::uint32_t float_bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

/// What one traversal yields: leaves with their intervals (bit patterns), then steps and status.
struct Trace {
    std::vector<std::uint32_t> seq;
    bool operator==(const Trace&) const = default;
};

/// Every leaf of the shared iterator, clipping at the entry of the `clip_at`-th leaf (0 = never).
Trace shared_trace(std::span<const std::uint32_t> words, const Ray& r, Interval range, int clip_at) {
    shared::Words w{words.data(), words.size()};
    shared::SylvaBihIter it;
    shared::sylva_bih_init(it, w, static_cast<std::uint32_t>(words.size()), r.origin, r.direction, range.t0, range.t1);
    Trace t;
    std::uint32_t leaf;
    float t0, t1;
    for (int k = 1; shared::sylva_bih_next(it, w, leaf, t0, t1); ++k) {
        t.seq.insert(t.seq.end(), {leaf, float_bits(t0), float_bits(t1)});
        if (k == clip_at) shared::sylva_bih_clip(it, t0);
    }
    t.seq.insert(t.seq.end(), {it.steps, it.status});
    return t;
}

template <int Layout>
Trace walker_trace(std::span<const std::uint32_t> words, const Ray& r, Interval range, int clip_at) {
    bih::detail::Walker<Layout> it(words, r, range);
    Trace t;
    std::uint32_t leaf;
    float t0, t1;
    for (int k = 1; it.next(leaf, t0, t1); ++k) {
        t.seq.insert(t.seq.end(), {leaf, float_bits(t0), float_bits(t1)});
        if (k == clip_at) it.clip(t0);
    }
    t.seq.insert(t.seq.end(), {it.steps(), it.status()});
    return t;
}

/// Traces `rays` through `words` with both iterators (the walker compiled for any layout and
/// for the encoding's own); returns the number of rays where they differ.
std::size_t walker_mismatches(std::span<const std::uint32_t> words, const std::vector<Ray>& rays) {
    std::size_t bad = 0;
    int layout = bih::detail::layout_of(words);
    for (std::size_t i = 0; i < rays.size(); ++i) {
        Interval range = i % 3 == 0 ? Interval{} : Interval{-std::numeric_limits<float>::infinity(), 1.5f};
        int clip_at = static_cast<int>(i % 4);  // 0: never, else after the 1st, 2nd or 3rd leaf
        Trace want = shared_trace(words, rays[i], range, clip_at);
        bool same = walker_trace<bih::detail::kAnyLayout>(words, rays[i], range, clip_at) == want;
        if (layout == bih::detail::kFixed16Chunks)
            same = same && walker_trace<bih::detail::kFixed16Chunks>(words, rays[i], range, clip_at) == want;
        if (layout == bih::detail::kFloat32Chunks)
            same = same && walker_trace<bih::detail::kFloat32Chunks>(words, rays[i], range, clip_at) == want;
        bad += same ? 0 : 1;
    }
    return bad;
}

/// first_hit and all_hits over LeafRecords against brute force, for every variant.
template <class E>
void check_records_against_brute_force(const std::vector<E>& elems, const std::vector<Ray>& rays) {
    std::span<const E> es(elems);
    ThreadPool pool(2);
    std::vector<Variant> vs = variants();
    vs.push_back({"fixed16/chunks/for_queries", bih::Config::for_queries(), {}});
    vs.push_back({"float32/pre-order/for_queries", bih::Config::for_queries(),
                  {bih::NodeFormat::Float32, bih::Layout::PreOrder, 0}});
    for (const Variant& v : vs) {
        INFO("variant " << v.name);
        bih::Tree tree = bih::build(es, v.build, pool);
        auto words = bih::encode(tree, es, bih::RangePayload{}, v.encode);
        bih::LeafRecords<E> records(tree, es, pool);
        REQUIRE(records.size() == elems.size());
        std::vector<bih::ElementHit> hits;
        std::size_t total = 0, mismatches = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
            Interval range = i % 5 == 0 ? Interval{0.25f, 1.75f} : Interval{};
            auto expected = bih::brute_force_hits(es, rays[i], range);
            bih::all_hits(std::span<const std::uint32_t>(words), records, rays[i], hits, range);
            total += expected.size();
            if (hits != expected) ++mismatches;
            auto first = bih::first_hit(std::span<const std::uint32_t>(words), records, rays[i], range);
            if (expected.empty() ? first.has_value() : (!first || *first != expected.front())) ++mismatches;
        }
        CHECK(mismatches == 0);
        CHECK(total > rays.size() / 10);  // the rays really hit things
    }
}

}  // namespace

TEST_CASE("the host walker yields the shared iterator's leaves, intervals, steps and status", "[bih][iter]") {
    std::vector<Variant> vs = variants();
    vs.push_back({"float32/chunks2/for_queries", bih::Config::for_queries(),
                  {bih::NodeFormat::Float32, bih::Layout::TreeChunks, 2}});
    vs.push_back({"fixed16/chunks2/for_queries", bih::Config::for_queries(), {}});
    auto boxes = testing::clustered_boxes(3000, 41);
    auto degenerate = testing::degenerate_boxes(2000, 42);
    auto rays = testing::random_rays(6000, {vec3(0.0f), vec3(10.0f)}, 43);
    auto rays01 = testing::random_rays(6000, {vec3(0.0f), vec3(1.0f)}, 44);
    for (const Variant& v : vs) {
        INFO("variant " << v.name);
        bih::Tree a = bih::build(std::span<const BoxElement>(boxes), v.build);
        bih::Tree b = bih::build(std::span<const BoxElement>(degenerate), v.build);
        auto wa = bih::encode(a, std::span<const BoxElement>(boxes), bih::RangePayload{}, v.encode);
        auto wb = bih::encode(b, std::span<const BoxElement>(degenerate), bih::RangePayload{}, v.encode);
        CHECK(walker_mismatches(wa, rays) == 0);
        CHECK(walker_mismatches(wb, rays01) == 0);
    }
}

TEST_CASE("on corrupted encodings the host walker stops exactly where the shared iterator does", "[bih][iter]") {
    auto elems = testing::random_boxes(500, 45);
    std::span<const BoxElement> es(elems);
    auto rays = testing::random_rays(300, {vec3(0.0f), vec3(1.05f)}, 46);
    std::mt19937 rng(47);
    std::size_t mismatches = 0, errors = 0;
    for (auto ec : {bih::EncodeConfig{}, bih::EncodeConfig{bih::NodeFormat::Float32, bih::Layout::PreOrder, 0}}) {
        auto clean = bih::encode(bih::build(es), es, bih::RangePayload{}, ec);
        for (int trial = 0; trial < 60; ++trial) {
            auto words = clean;
            for (int k = 0; k < 8; ++k) {  // random words of the nodes (the header is checked up front)
                std::size_t at = SYLVA_BIH_HEADER_WORDS + rng() % (words.size() - SYLVA_BIH_HEADER_WORDS);
                words[at] = trial % 2 ? static_cast<std::uint32_t>(rng()) : words[at] ^ (1u << (rng() % 32));
            }
            mismatches += walker_mismatches(words, rays);
            bih::detail::Walker<> it(words, rays[0], {});
            std::uint32_t leaf;
            float t0, t1;
            while (it.next(leaf, t0, t1)) {
            }
            errors += it.status() == SYLVA_ITER_ERROR ? 1 : 0;
        }
    }
    CHECK(mismatches == 0);
    CHECK(errors > 0);  // the corruptions do reach the checks
}

TEST_CASE("queries over LeafRecords equal brute force on spheres (four at a time)", "[bih][iter]") {
    auto c = testing::sphere_cases(51);
    check_records_against_brute_force(c.spheres, c.rays);
}

TEST_CASE("queries over LeafRecords equal brute force on other elements", "[bih][iter]") {
    check_records_against_brute_force(testing::random_boxes(3000, 53),
                                      testing::random_rays(15000, {vec3(0.0f), vec3(1.05f)}, 54));
    check_records_against_brute_force(testing::degenerate_boxes(2000, 55),
                                      testing::random_rays(15000, {vec3(0.0f), vec3(1.0f)}, 56));
}

TEST_CASE("queries refuse elements and encodings that do not belong together", "[bih][iter][bad-input]") {
    auto many = testing::random_spheres(200, 57);
    auto few = testing::random_spheres(50, 58);
    std::span<const Sphere> ms(many), fs(few);
    bih::Tree big = bih::build(ms, bih::Config::for_queries());
    bih::Tree small = bih::build(fs, bih::Config::for_queries());
    auto big_words = bih::encode(big, ms, bih::RangePayload{});
    CHECK_THROWS_AS(bih::LeafRecords<Sphere>(big, fs), Error);  // the tree indexes 200 elements
    bih::LeafRecords<Sphere> small_records(small, fs);
    std::vector<bih::ElementHit> hits;
    std::size_t thrown_records = 0, thrown_tree = 0;
    for (const Ray& r : testing::random_rays(200, {vec3(-1.0f), vec3(1.0f)}, 59)) {
        try {
            bih::all_hits(std::span<const std::uint32_t>(big_words), small_records, r, hits);
        } catch (const Error& e) {
            ++thrown_records;
            CHECK(std::string(e.what()).find("do not match") != std::string::npos);
        }
        try {
            bih::first_hit(std::span<const std::uint32_t>(big_words), small, fs, r);
        } catch (const Error&) {
            ++thrown_tree;
        }
    }
    // Rays that reach leaves past the 50 elements are refused, never read out of bounds.
    CHECK(thrown_records > 20);
    CHECK(thrown_tree > 20);
}

TEST_CASE("spheres four at a time decide grazing rays exactly as Sphere::intersect", "[bih][iter]") {
    auto g = testing::grazing_set(40000, 61);
    std::span<const Sphere> es(g.spheres);
    bih::Tree tree = bih::build(es, bih::Config::for_queries());
    auto words = bih::encode(tree, es, bih::RangePayload{}, {bih::NodeFormat::Float32, bih::Layout::TreeChunks, 2});
    bih::LeafRecords<Sphere> records(tree, es);
    std::vector<bih::ElementHit> hits;
    std::size_t mismatches = 0, grazing_hits = 0;
    for (std::size_t k = 0; k < g.rays.size(); ++k) {
        auto expected = bih::brute_force_hits(es, g.rays[k]);
        bih::all_hits(std::span<const std::uint32_t>(words), records, g.rays[k], hits);
        if (hits != expected) ++mismatches;
        for (const auto& h : expected) grazing_hits += h.element == g.target(k) ? 1 : 0;
    }
    CHECK(mismatches == 0);
    CHECK(grazing_hits > g.rays.size() / 10);  // both sides of the rim occur
    CHECK(grazing_hits < g.rays.size() * 9 / 10);
}

using testing::PinnedBox;

TEST_CASE("LeafRecords takes element types without a default constructor", "[bih][iter]") {
    std::vector<PinnedBox> elems;
    for (const BoxElement& b : testing::random_boxes(500, 63)) elems.emplace_back(b.box);
    std::span<const PinnedBox> es(elems);
    bih::Tree tree = bih::build(es, bih::Config::for_queries());
    auto words = bih::encode(tree, es, bih::RangePayload{});
    bih::LeafRecords<PinnedBox> records(tree, es);
    std::vector<bih::ElementHit> hits;
    std::size_t mismatches = 0, total = 0;
    for (const Ray& r : testing::random_rays(3000, {vec3(0.0f), vec3(1.05f)}, 64)) {
        bih::all_hits(std::span<const std::uint32_t>(words), records, r, hits);
        auto expected = bih::brute_force_hits(es, r);
        total += expected.size();
        mismatches += hits == expected ? 0 : 1;
    }
    CHECK(mismatches == 0);
    CHECK(total > 300);
}
