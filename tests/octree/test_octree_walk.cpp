// The stackless neighbour-pointer walk (sylva/shared/octree_iter.h) against a stack-based
// recursive reference walk (tests/octree/reference.hpp): the same leaves, in the same order,
// with bit-identical intervals, for 10^5 rays over complete and sparse octrees, odd extents and
// cuts at every level; rays along faces and edges, through corners, starting inside.
#include <catch2/catch.hpp>

#include <bit>
#include <cstdint>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/validate.hpp>
#include <sylva/shared/octree_iter.h>

#include "rays.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

/// The iterator's leaves for one ray (and its final status and steps).
std::vector<Leaf> stackless(const std::vector<std::uint32_t>& words, std::size_t brick_words, const TestRay& r,
                            std::uint32_t max_level, std::uint32_t& status, std::uint32_t& steps) {
    shared::Words w{words.data(), words.size()};
    shared::SylvaOctIter it{};
    shared::sylva_oct_init(it, w, std::uint32_t(words.size()), std::uint32_t(brick_words), r.o, r.d, r.t0, r.t1, max_level);
    std::vector<Leaf> out;
    std::uint32_t node;
    float t0, t1;
    while (shared::sylva_oct_next(it, w, node, t0, t1)) out.push_back({node, t0, t1});
    status = it.status;
    steps = it.steps;
    return out;
}

/// The reference walk for one ray, mapped to voxel space as the iterator maps it.
std::vector<Leaf> reference(const octree::Tree& t, const std::vector<std::uint32_t>& words, const TestRay& r,
                            std::uint32_t max_level) {
    shared::Words w{words.data(), words.size()};
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(w, std::uint32_t(words.size()), std::uint32_t(t.bricks.size()));
    VoxelRay v;
    std::vector<Leaf> out;
    if (shared::sylva_ray_to_grid(r.o, r.d, h.origin, h.inv_spacing, r.t0, r.t1, v.org, v.rcp, v.par)) return out;
    reference_walk(t, 0, v, r.t0, r.t1, max_level, out);
    return out;
}

struct Tally {
    std::size_t rays = 0, leaves = 0, degenerate_rays = 0, mismatches = 0;
};

void compare(const octree::Tree& t, std::uint32_t rays, std::uint32_t seed, std::uint32_t max_level, Tally& tally) {
    std::vector<std::uint32_t> words = octree::encode(t);
    REQUIRE_NOTHROW(octree::validate(words, t.bricks));
    for (const TestRay& r : test_rays(t, rays, seed)) {
        std::uint32_t status = 0, steps = 0;
        std::vector<Leaf> got = stackless(words, t.bricks.size(), r, max_level, status, steps);
        std::vector<Leaf> want = reference(t, words, r, max_level);
        ++tally.rays;
        tally.leaves += want.size();
        tally.degenerate_rays += (r.d.x == 0.0f || r.d.y == 0.0f || r.d.z == 0.0f) ? 1 : 0;
        if (status != SYLVA_ITER_DONE || got != want) {
            if (++tally.mismatches <= 5) {
                UNSCOPED_INFO("ray o " << r.o.x << "," << r.o.y << "," << r.o.z << " d " << r.d.x << "," << r.d.y << ","
                                       << r.d.z << " t " << r.t0 << ".." << r.t1 << " status " << status << " leaves "
                                       << got.size() << " reference " << want.size());
                for (std::size_t i = 0; i < std::max(got.size(), want.size()) && i < 12; ++i)
                    UNSCOPED_INFO("  " << i << ": " << (i < got.size() ? got[i].node : 0xFFFFFFFFu) << " ["
                                       << (i < got.size() ? got[i].t0 : 0.0f) << ", " << (i < got.size() ? got[i].t1 : 0.0f)
                                       << "]  ref " << (i < want.size() ? want[i].node : 0xFFFFFFFFu) << " ["
                                       << (i < want.size() ? want[i].t0 : 0.0f) << ", "
                                       << (i < want.size() ? want[i].t1 : 0.0f) << "]");
            }
        }
    }
}

}  // namespace

TEST_CASE("octree walk: the stackless walk visits the reference walk's leaves in order, 10^5 rays", "[octree][walk]") {
    Tally tally;
    const std::uint32_t all = 0xFFFFFFFFu;
    // Complete octrees: odd, non-cubic, tiny, non-unit spacing (powers of two, so lattice rays stay exact).
    compare(octree::build(blobs({33, 17, 70}, 1), {4, 1}), 16000, 1, all, tally);
    compare(octree::build(blobs({33, 17, 70}, 2), {16, 1}), 8000, 2, all, tally);
    compare(octree::build(blobs({255, 9, 40}, 3), {8, 1}), 12000, 3, all, tally);
    compare(octree::build(blobs({1, 1, 1}, 4), {32, 2}), 2000, 4, all, tally);
    compare(octree::build(blobs({2, 2, 2}, 5), {4, 1}), 2000, 5, all, tally);
    compare(octree::build(blobs({37, 64, 20}, 6, vec3(1.0f, 2.0f, 0.5f)), {4, 1}), 10000, 6, all, tally);
    // A spacing whose inverse is inexact (the lobster's 1.4): lattice rays are only nearly on planes.
    compare(octree::build(blobs({41, 30, 22}, 16, vec3(1.0f, 0.7f, 1.4f)), {4, 1}), 5000, 16, all, tally);
    // Cuts above the leaves.
    octree::Tree cut = octree::build(blobs({50, 61, 29}, 7), {4, 1});
    for (std::uint32_t level = 0; level < cut.levels; ++level) compare(cut, 2000, 70 + level, level, tally);
    // Sparse octrees: leaves at every depth, coarser neighbours.
    for (std::uint32_t seed = 0; seed < 8; ++seed)
        compare(sparse_tree({70, 33, 45}, 4, seed, 0.55f), 5000, 100 + seed, all, tally);
    CHECK(tally.mismatches == 0);
    CHECK(tally.rays >= 100000);
    CHECK(tally.leaves > 300000);
    CHECK(tally.degenerate_rays > 30000);
}

TEST_CASE("octree walk: intervals tile the ray inside the volume, front to back", "[octree][walk]") {
    octree::Tree t = octree::build(blobs({45, 30, 61}, 8), {4, 1});
    std::vector<std::uint32_t> words = octree::encode(t);
    std::size_t checked = 0;
    for (const TestRay& r : test_rays(t, 4000, 9)) {
        std::uint32_t status, steps;
        std::vector<Leaf> got = stackless(words, t.bricks.size(), r, 0xFFFFFFFFu, status, steps);
        for (std::size_t i = 0; i < got.size(); ++i) {
            REQUIRE(got[i].t0 < got[i].t1);
            REQUIRE(t.nodes[got[i].node].leaf());
            if (i > 0) REQUIRE(std::bit_cast<std::uint32_t>(got[i].t0) == std::bit_cast<std::uint32_t>(got[i - 1].t1));
            // The leaf's box holds the interval's midpoint (up to rounding).
            vec3 p = (r.o + r.d * (0.5f * (got[i].t0 + got[i].t1))) / t.spacing;
            vec3 lo(t.box_lo(t.nodes[got[i].node])), hi(t.box_hi(t.nodes[got[i].node]));
            REQUIRE(glm::all(glm::greaterThanEqual(p, lo - 1e-3f)));
            REQUIRE(glm::all(glm::lessThanEqual(p, hi + 1e-3f)));
            ++checked;
        }
    }
    CHECK(checked > 20000);
}

TEST_CASE("octree walk: NaN rays, rays that miss, empty ranges and a zero direction", "[octree][walk]") {
    octree::Tree t = octree::build(blobs({20, 20, 20}, 10), {4, 1});
    std::vector<std::uint32_t> words = octree::encode(t);
    std::uint32_t status, steps;
    float nan = std::nanf("");
    CHECK(stackless(words, t.bricks.size(), {vec3(nan, 1, 1), vec3(1, 0, 0), 0, 1e30f}, 99, status, steps).empty());
    CHECK(status == SYLVA_ITER_DONE);
    CHECK(stackless(words, t.bricks.size(), {vec3(-5, 1, 1), vec3(1, 0, 0), 0, nan}, 99, status, steps).empty());
    CHECK(stackless(words, t.bricks.size(), {vec3(-5, 30, 1), vec3(1, 0, 0), 0, 1e30f}, 99, status, steps).empty());
    CHECK(stackless(words, t.bricks.size(), {vec3(-5, 1, 1), vec3(1, 0, 0), 9, 9}, 99, status, steps).empty());
    // A zero direction inside: the leaf holding the origin for the whole range.
    std::vector<Leaf> still = stackless(words, t.bricks.size(), {vec3(13, 2, 7.5f), vec3(0.0f), 0, 5}, 99, status, steps);
    REQUIRE(still.size() == 1);
    CHECK(t.box_lo(t.nodes[still[0].node]) == glm::u32vec3(12, 0, 4));
    CHECK(still[0].t0 == 0.0f);
    CHECK(still[0].t1 == 5.0f);
    // Along the x axis through the first row: every leaf of the row once, [x, x + 4] each.
    std::vector<Leaf> row = stackless(words, t.bricks.size(), {vec3(-1, 0.5f, 0.5f), vec3(1, 0, 0), 0, 1e30f}, 99, status, steps);
    REQUIRE(row.size() == 5);
    for (std::size_t i = 0; i < row.size(); ++i) {
        CHECK(t.box_lo(t.nodes[row[i].node]) == glm::u32vec3(4 * i, 0, 0));
        CHECK(row[i].t0 == float(4 * i + 1));
        CHECK(row[i].t1 == float(4 * i + 5));
    }
}
