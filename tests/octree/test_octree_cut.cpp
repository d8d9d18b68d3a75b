// The view-dependent cut (sylva/octree/cut.hpp): its selection against a brute-force
// definition and both budgets; the stackless walk over a cut (neighbour pointers landing below
// it restart from the root) against the stack-based reference stopping at the cut's leaves;
// DVR over cuts: the full cut renders the marcher's image bit for bit, coarser cuts converge.
#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <set>
#include <vector>

#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/validate.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/volume.hpp>
#include <sylva/shared/octree_iter.h>

#include "rays.hpp"
#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

/// Projected voxel size of a node from its world box, written from the definition.
double brute_size(const octree::Tree& t, const octree::Node& n, vec3 eye, double pixel) {
    glm::dvec3 lo = glm::dvec3(t.box_lo(n)) * glm::dvec3(t.spacing), hi = glm::dvec3(t.box_hi(n)) * glm::dvec3(t.spacing);
    glm::dvec3 e(eye), q = glm::clamp(e, lo, hi);
    double d = glm::length(e - q);
    double voxel = double(std::max({t.spacing.x, t.spacing.y, t.spacing.z})) * double(1u << (t.levels - 1 - n.level));
    return d > 0.0 ? voxel / (d * pixel) : INFINITY;
}

/// With no node budget: node n is a cut leaf iff every ancestor is refined (children, not
/// terminal, size > P) and n is not.
void brute_cut(const octree::Tree& t, std::uint32_t n, vec3 eye, double pixel, double lod,
               const std::vector<std::uint8_t>& terminal, std::vector<std::uint8_t>& leaf) {
    const octree::Node& node = t.nodes[n];
    if (node.leaf() || terminal[n] || !(brute_size(t, node, eye, pixel) > lod)) {
        leaf[n] = 1;
        return;
    }
    for (std::uint32_t k = 0; k < std::uint32_t(std::popcount(node.child_mask)); ++k)
        brute_cut(t, node.first_child + k, eye, pixel, lod, terminal, leaf);
}

std::vector<std::uint8_t> leaf_bytes(const octree::Cut& c) {
    std::vector<std::uint8_t> b(c.state.size());
    for (std::size_t i = 0; i < b.size(); ++i) b[i] = c.state[i] == octree::CutState::Leaf ? 1 : 0;
    return b;
}

std::vector<Leaf> stackless(const std::vector<std::uint32_t>& words, std::size_t brick_words, const TestRay& r,
                            std::uint32_t& status) {
    shared::Words w{words.data(), words.size()};
    shared::SylvaOctIter it{};
    shared::sylva_oct_init(it, w, std::uint32_t(words.size()), std::uint32_t(brick_words), r.o, r.d, r.t0, r.t1, 0xFFFFFFFFu);
    std::vector<Leaf> out;
    std::uint32_t node;
    float t0, t1;
    while (shared::sylva_oct_next(it, w, node, t0, t1)) out.push_back({node, t0, t1});
    status = it.status;
    return out;
}

std::vector<Leaf> reference(const octree::Tree& t, const std::vector<std::uint32_t>& words, const TestRay& r,
                            const std::vector<std::uint8_t>& cut_leaf) {
    shared::Words w{words.data(), words.size()};
    shared::SylvaOctHeader h = shared::sylva_oct_read_header(w, std::uint32_t(words.size()), std::uint32_t(t.bricks.size()));
    VoxelRay v;
    std::vector<Leaf> out;
    if (shared::sylva_ray_to_grid(r.o, r.d, h.origin, h.inv_spacing, r.t0, r.t1, v.org, v.rcp, v.par)) return out;
    reference_walk(t, 0, v, r.t0, r.t1, 0xFFFFFFFFu, out, &cut_leaf);
    return out;
}

octree::CutView view_from(const octree::Tree& t, vec3 from, float dist, std::uint32_t height) {
    Aabb box{vec3(0.0f), vec3(t.dims) * t.spacing};
    Camera cam = Camera::framing(box, from);
    cam.eye = box.center() + (cam.eye - box.center()) * dist;
    return octree::cut_view(cam.frame(height, height), height, height);
}

double rmse(const Frame& a, const Frame& b) {
    double s = 0.0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i)
        for (int c = 0; c < 4; ++c) s += double(a.rgba[i][c] - b.rgba[i][c]) * double(a.rgba[i][c] - b.rgba[i][c]);
    return std::sqrt(s / double(a.rgba.size() * 4));
}

}  // namespace

TEST_CASE("octree cut: selection equals the brute-force definition and respects both budgets", "[octree][cut]") {
    std::size_t checked = 0, budget_bound = 0;
    for (std::uint32_t seed = 0; seed < 6; ++seed) {
        octree::Tree t = seed < 3 ? octree::build(blobs({70, 45, 33}, seed), {4, 1}) : sparse_tree({70, 33, 45}, 4, seed, 0.6f);
        std::vector<std::uint32_t> words = octree::encode(t);
        std::mt19937 rng(seed);
        std::vector<std::uint8_t> terminal(t.nodes.size());
        for (auto& b : terminal) b = (rng() % 7 == 0) ? 1 : 0;
        for (float dist : {0.3f, 1.0f, 3.0f}) {
            octree::CutView v = view_from(t, vec3(0.4f, 0.7f - 0.2f * float(seed), 1.0f), dist, 200);
            for (float lod : {0.5f, 1.0f, 4.0f}) {
                auto term = [&](std::uint32_t n) { return terminal[n] != 0; };
                octree::Cut free = octree::select_cut(words, v, {lod, 0xFFFFFFFFu}, term);
                std::vector<std::uint8_t> want(t.nodes.size(), 0);
                brute_cut(t, 0, v.eye, v.pixel_angle, lod, terminal, want);
                INFO("seed " << seed << " dist " << dist << " lod " << lod);
                CHECK(leaf_bytes(free) == want);
                // Budgets below the free cut's size: never exceeded; the largest projections refined first.
                for (std::uint32_t budget : {1u, 9u, free.nodes / 2 + 1, free.nodes - 1}) {
                    if (budget < 1 || budget >= free.nodes) continue;
                    octree::Cut c = octree::select_cut(words, v, {lod, budget}, term);
                    CHECK(c.nodes <= budget);
                    double inner_min = INFINITY, open_max = 0.0;
                    std::uint32_t nodes = 0, leaves = 0;
                    for (std::size_t n = 0; n < t.nodes.size(); ++n) {
                        double s = brute_size(t, t.nodes[n], v.eye, v.pixel_angle);
                        nodes += c.state[n] != octree::CutState::Below;
                        leaves += c.state[n] == octree::CutState::Leaf;
                        if (c.state[n] == octree::CutState::Inner) inner_min = std::min(inner_min, s);
                        if (c.state[n] == octree::CutState::Leaf && !t.nodes[n].leaf() && !terminal[n] && s > lod)
                            open_max = std::max(open_max, s);
                    }
                    CHECK(nodes == c.nodes);
                    CHECK(leaves == c.leaves);
                    CHECK(open_max > 0.0);  // the budget stopped the refinement
                    CHECK(open_max <= inner_min * (1.0 + 1e-5));
                    ++budget_bound;
                }
                ++checked;
            }
        }
    }
    CHECK(checked == 54);
    CHECK(budget_bound > 60);
    std::vector<std::uint32_t> words = octree::encode(octree::build(blobs({9, 9, 9}, 1), {4, 1}));
    octree::CutView v{vec3(-10.0f), 0.01f};
    auto none = [](std::uint32_t) { return false; };
    CHECK_THROWS_WITH(octree::select_cut(words, v, {0.0f, 10}, none), Catch::Contains("lod_pixels"));
    CHECK_THROWS_WITH(octree::select_cut(words, v, {1.0f, 0}, none), Catch::Contains("budget"));
}

TEST_CASE("octree cut: the stackless walk over a cut visits the stack-based reference's cut leaves", "[octree][cut][walk]") {
    std::size_t rays = 0, leaves = 0, mismatches = 0, coarse = 0;
    for (std::uint32_t seed = 0; seed < 10; ++seed) {
        octree::Tree t = seed < 5 ? octree::build(blobs({61, 37, 50}, 30 + seed), {4, 1})
                                  : sparse_tree({70, 33, 45}, 4, seed, 0.55f);
        std::vector<std::uint32_t> words = octree::encode(t);
        // Views close to a corner (inside the volume for some) refine unevenly: cut leaves at
        // many levels side by side, neighbour pointers crossing into regions below the cut.
        octree::CutView v = view_from(t, vec3(0.9f - 0.3f * float(seed), 0.5f, 0.7f), 0.15f + 0.2f * float(seed % 4), 64);
        octree::Cut c = octree::select_cut(words, v, {1.0f, std::uint32_t(t.nodes.size() / 3)}, [](std::uint32_t) { return false; });
        octree::apply_cut(words, c);
        REQUIRE_NOTHROW(octree::validate(words, t.bricks));
        std::vector<std::uint8_t> cut_leaf = leaf_bytes(c);
        for (std::size_t n = 0; n < t.nodes.size(); ++n) coarse += (cut_leaf[n] && !t.nodes[n].leaf()) ? 1 : 0;
        for (const TestRay& r : test_rays(t, 4000, 500 + seed)) {
            std::uint32_t status = 0;
            std::vector<Leaf> got = stackless(words, t.bricks.size(), r, status);
            std::vector<Leaf> want = reference(t, words, r, cut_leaf);
            ++rays;
            leaves += want.size();
            if (status != SYLVA_ITER_DONE || got != want) ++mismatches;
        }
    }
    CHECK(mismatches == 0);
    CHECK(rays == 40000);
    CHECK(leaves > 40000);
    CHECK(coarse > 50);  // the cuts do stop above the octree's leaves
}

TEST_CASE("octree cut: validate refuses inconsistent cut bits", "[octree][cut]") {
    octree::Tree t = octree::build(blobs({40, 40, 40}, 3), {4, 1});
    std::vector<std::uint32_t> words = octree::encode(t);
    auto flags = [&](std::uint32_t n) -> std::uint32_t& { return words[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * n + 1]; };
    std::vector<std::uint32_t> good = words;
    flags(1) |= SYLVA_OCT_CUT_LEAF;  // a cut leaf whose children are not marked below
    CHECK_THROWS_WITH(octree::validate(words, t.bricks), Catch::Contains("below the cut"));
    words = good;
    flags(0) |= SYLVA_OCT_CUT_BELOW;
    CHECK_THROWS_WITH(octree::validate(words, t.bricks), Catch::Contains("root"));
    words = good;
    flags(3) |= SYLVA_OCT_CUT_LEAF | SYLVA_OCT_CUT_BELOW;
    CHECK_THROWS_WITH(octree::validate(words, t.bricks), Catch::Contains("both"));
    words = good;
    flags(t.nodes[1].first_child) |= SYLVA_OCT_CUT_BELOW;  // below the cut under an inner node
    CHECK_THROWS_WITH(octree::validate(words, t.bricks), Catch::Contains("below the cut"));
}

TEST_CASE("octree cut: DVR through the full cut equals the marcher bit for bit; coarser cuts converge", "[octree][cut][dvr]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({96, 80, 70}, 25);
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p;
    p.camera = Camera::framing(g.world_box(), {0.3f, 0.5f, 1.0f}, 35.0f).frame(64, 64);
    p.width = p.height = 64;
    p.tf.resize(256);
    for (std::uint32_t i = 0; i < 256; ++i) p.tf[i] = (i * 3 / 4) | (200u << 8) | ((255 - i) << 16) | ((i > 70 ? (i - 70) / 3 : 0) << 24);
    p.shading = true;
    Frame ref = render_dvr_cpu(GridWords::from(g), p, pool);  // OctreeView's default border too: a constant 0
    octree::CutView v = octree::cut_view(p.camera, p.width, p.height);
    auto none = [](std::uint32_t) { return false; };
    std::vector<double> err;
    std::vector<std::uint32_t> cut_nodes;
    for (float lod : {8.0f, 2.0f, 0.5f, 0.125f, 1e-6f}) {
        std::vector<std::uint32_t> w = words;
        octree::Cut c = octree::select_cut(w, v, {lod, 0xFFFFFFFFu}, none);
        octree::apply_cut(w, c);
        Frame f = render_octree_dvr_cpu(OctreeView{w, t.bricks}, p, pool);
        err.push_back(rmse(f, ref));
        cut_nodes.push_back(c.nodes);
        for (std::uint32_t s : f.steps) REQUIRE(s != 0xFFFFFFFFu);
    }
    INFO("rmse " << err[0] << " " << err[1] << " " << err[2] << " " << err[3] << " " << err[4]);
    CHECK(cut_nodes.back() == t.nodes.size());
    CHECK(err.back() == 0.0);  // the full cut: the marcher's image bit for bit
    CHECK(err[0] > 1e-3);      // the coarse cut does differ
    for (std::size_t i = 1; i < err.size(); ++i) CHECK(err[i] <= err[i - 1]);
    CHECK(err[0] > 4.0 * err[2]);
}

TEST_CASE("octree cut: an orthographic view refines by voxel size over pixel size, at any distance", "[octree][cut][rays]") {
    // Seen orthographically every voxel of a level projects to the same number of pixels: the
    // free cut stops at one level everywhere (the first whose voxel is at most lod_pixels
    // pixels), where a pinhole view refines the near side deeper than the far one.
    octree::Tree t = octree::build(blobs({96, 80, 70}, 31), {8, 1});
    std::vector<std::uint32_t> words = octree::encode(t);
    Aabb box{vec3(0.0f), vec3(t.dims) * t.spacing};
    Camera cam = Camera::framing(box, {0.3f, 0.5f, 1.0f});
    VolumeRenderParams p;
    p.width = p.height = 60;
    p.camera = cam.ortho_frame(p.width, p.height, 0.5f * glm::length(box.extent()));
    p.rays.source = RaySource::Ortho;
    octree::CutView v = octree_cut_view(p);
    REQUIRE(v.orthographic);
    const float pixel = 2.0f * glm::length(p.camera.v) / float(p.height);  // world units
    CHECK(v.pixel_angle == pixel);
    auto none = [](std::uint32_t) { return false; };
    for (float lod : {2.0f, 1.0f, 0.5f}) {
        octree::Cut c = octree::select_cut(words, v, {lod, 0xFFFFFFFFu}, none);
        std::uint32_t want = 0;  // the first level whose voxel projects to <= lod pixels
        while (want + 1 < t.levels && float(1u << (t.levels - 1 - want)) / pixel > lod) ++want;
        std::set<std::uint32_t> leaf_levels;
        for (std::size_t n = 0; n < t.nodes.size(); ++n)
            if (c.state[n] == octree::CutState::Leaf) leaf_levels.insert(t.nodes[n].level);
        INFO("lod " << lod << " pixel " << pixel << " want level " << want);
        CHECK(leaf_levels == std::set<std::uint32_t>{want});
    }
    // The same eye as a pinhole: near nodes are refined deeper than far ones.
    octree::Cut pin = octree::select_cut(words, octree::cut_view(cam.frame(p.width, p.height), p.width, p.height), {1.0f, 0xFFFFFFFFu},
                                         none);
    std::set<std::uint32_t> pin_levels;
    for (std::size_t n = 0; n < t.nodes.size(); ++n)
        if (pin.state[n] == octree::CutState::Leaf) pin_levels.insert(t.nodes[n].level);
    CHECK(pin_levels.size() > 1);
    // The orthographic cut renders: host frames through it are finite and not empty.
    std::vector<std::uint32_t> w = words;
    octree::apply_cut(w, select_octree_cut(w, p, {1.0f, 0xFFFFFFFFu}, false));
    p.tf.resize(256);
    for (std::uint32_t i = 0; i < 256; ++i) p.tf[i] = (i * 3 / 4) | (200u << 8) | ((255 - i) << 16) | ((i > 70 ? (i - 70) / 3 : 0) << 24);
    ThreadPool pool(2);
    Frame f = render_octree_dvr_cpu(OctreeView{w, t.bricks}, p, pool);
    double alpha = 0.0;
    for (const vec4& c : f.rgba) alpha += c.w;
    CHECK(alpha > 20.0);
}
