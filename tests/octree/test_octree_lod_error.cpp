// The transfer-function-aware cut (sylva/octree/lod_error.hpp): the deviation tables against a
// brute force over every child voxel, the per-node TF bound against a loop over the table's
// entries, select_cut's refinement by it, and the images: a one-voxel sheet that the paper's
// projection criterion averages away at a small image is kept by the TF-aware cut.
#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <sylva/core/executor.hpp>
#include <sylva/octree/build.hpp>
#include <sylva/octree/cut.hpp>
#include <sylva/octree/encode.hpp>
#include <sylva/octree/lod_error.hpp>
#include <sylva/render/metrics.hpp>
#include <sylva/render/octree_volume.hpp>
#include <sylva/render/volume.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace octree_test;

namespace {

constexpr std::uint32_t kBins = octree::kLodErrorBins;

/// The deviation tables from the definition, over the grid: for every coarse voxel v of an inner
/// node (level l, coarse voxels of s = 2^(L - 1 - l) voxels a side) whose footprint meets the
/// volume, its brick sample selects the bin and the grid's voxels in footprint and volume give
/// the range.
void brute_tables(const octree::Tree& t, const volume::DensityGrid& g, std::vector<int>& lo, std::vector<int>& hi) {
    const std::uint32_t B = t.brick_size;
    lo.assign(t.nodes.size() * kBins, 256);
    hi.assign(t.nodes.size() * kBins, -1);
    for (std::size_t n = 0; n < t.nodes.size(); ++n) {
        const octree::Node& node = t.nodes[n];
        if (node.leaf()) continue;
        const std::uint32_t s = 1u << (t.levels - 1 - node.level);
        for (std::uint32_t z = 0; z < B; ++z)
            for (std::uint32_t y = 0; y < B; ++y)
                for (std::uint32_t x = 0; x < B; ++x) {
                    const glm::u32vec3 f0 = (node.coord * B + glm::u32vec3(x, y, z)) * s;
                    const glm::u32vec3 f1 = glm::min(f0 + s, glm::u32vec3(g.dims));
                    if (f0.x >= g.dims.x || f0.y >= g.dims.y || f0.z >= g.dims.z) continue;
                    float a = INFINITY, e = -INFINITY;
                    for (std::uint32_t k = f0.z; k < f1.z; ++k)
                        for (std::uint32_t j = f0.y; j < f1.y; ++j)
                            for (std::uint32_t i = f0.x; i < f1.x; ++i) {
                                const float u = g.values[i + g.dims.x * (j + std::size_t{g.dims.y} * k)];
                                a = std::min(a, u);
                                e = std::max(e, u);
                            }
                    const float c = t.sample(node.brick, x + t.border, y + t.border, z + t.border);
                    const std::uint32_t bin = std::min(std::uint32_t(std::clamp(c, 0.0f, 1.0f) * kBins), kBins - 1);
                    lo[n * kBins + bin] = std::min(lo[n * kBins + bin], int(std::floor(double(std::clamp(a, 0.0f, 1.0f)) * 255.0)));
                    hi[n * kBins + bin] = std::max(hi[n * kBins + bin], int(std::ceil(double(std::clamp(e, 0.0f, 1.0f)) * 255.0)));
                }
    }
}

float comp_max(vec4 v) { return std::max(std::max(v.x, v.y), std::max(v.z, v.w)); }

/// A TF of 256 RGBA8 entries, opaque from `from` on (a step), colour by density.
std::vector<std::uint32_t> step_tf(std::uint32_t from, std::uint32_t alpha = 255) {
    std::vector<std::uint32_t> tf(256);
    for (std::uint32_t i = 0; i < 256; ++i) tf[i] = (i * 3 / 4) | (200u << 8) | ((255 - i) << 16) | ((i >= from ? alpha : 0u) << 24);
    return tf;
}

}  // namespace

// [parallel]: the levels are summarised node by node on a thread pool (TSan runs it).
TEST_CASE("octree lod deviation: the tables equal the brute force over the grid's voxels", "[octree][lod-error][parallel]") {
    // Cubes of 2^k voxels: every coarse voxel lies in the volume, the tables equal the brute
    // force; other shapes: the tables hold the brute force's ranges (replicated edge samples of
    // bricks past the volume may widen them).
    ThreadPool pool(2);
    for (std::uint32_t seed = 0; seed < 4; ++seed) {
        const bool cube = seed < 2;
        volume::Dims dims = cube ? volume::Dims{32, 32, 32} : volume::Dims{37, 20, 29};
        volume::DensityGrid g = blobs(dims, 40 + seed);
        octree::Tree t = octree::build(g, pool, {4, 1 + seed % 2});
        REQUIRE(t.levels >= 4);
        std::vector<std::uint32_t> words = octree::encode(t);
        octree::LodDeviation d = octree::lod_deviation(words, t.bricks, pool);
        REQUIRE(d.nodes() == t.nodes.size());
        std::vector<int> lo, hi;
        brute_tables(t, g, lo, hi);
        std::size_t bins_used = 0;
        for (std::size_t i = 0; i < lo.size(); ++i) {
            const bool empty = d.lo[i] > d.hi[i];
            bins_used += empty ? 0 : 1;
            INFO("seed " << seed << " node " << i / kBins << " bin " << i % kBins << ": " << int(d.lo[i]) << ".." << int(d.hi[i])
                         << " against " << lo[i] << ".." << hi[i]);
            if (cube) {
                CHECK(empty == (hi[i] < 0));
                if (!empty) CHECK((int(d.lo[i]) == lo[i] && int(d.hi[i]) == hi[i]));
            } else if (hi[i] >= 0) {
                CHECK((!empty && int(d.lo[i]) <= lo[i] && int(d.hi[i]) >= hi[i]));
            }
        }
        INFO("seed " << seed);
        CHECK(bins_used > 20);
        for (std::size_t n = 0; n < t.nodes.size(); ++n)  // octree leaves: full resolution, empty tables
            if (t.nodes[n].leaf())
                for (std::uint32_t k = 0; k < kBins; ++k) CHECK(d.lo[n * kBins + k] > d.hi[n * kBins + k]);
    }
}

TEST_CASE("octree lod deviation: corrupted encodings are refused or summarised, never read out of bounds",
          "[octree][lod-error][errors]") {
    // Single bit flips anywhere in the index (header and node records): lod_deviation throws
    // sylva::Error or returns tables of the right size; ASan (the sanitizer build) checks that
    // nothing is read out of bounds. A child moved to another level is named.
    ThreadPool pool(2);
    octree::Tree t = octree::build(blobs({21, 17, 26}, 8), pool, {4, 1});
    const std::vector<std::uint32_t> words = octree::encode(t);
    std::mt19937 rng(77);
    std::size_t refused = 0, accepted = 0;
    for (int i = 0; i < 400; ++i) {
        std::vector<std::uint32_t> bad = words;
        const std::size_t at = rng() % bad.size();
        bad[at] ^= 1u << (rng() % 32);
        try {
            octree::LodDeviation d = octree::lod_deviation(bad, t.bricks, pool);
            CHECK(d.lo.size() == d.hi.size());
            CHECK(d.lo.size() % kBins == 0);
            ++accepted;
        } catch (const Error&) {
            ++refused;
        }
    }
    CHECK(refused > 0);
    CHECK(accepted > 0);
    // Node 1's first child made the root: a child on the wrong level.
    std::vector<std::uint32_t> bad = words;
    REQUIRE(!t.nodes[1].leaf());
    bad[SYLVA_OCT_HEADER_WORDS + SYLVA_OCT_NODE_WORDS * 1] = 0u;  // word 0 of a record: its first child
    CHECK_THROWS_WITH(octree::lod_deviation(bad, t.bricks, pool), Catch::Contains("child outside its parent"));
}

TEST_CASE("octree lod deviation: a constant volume has one bin a node and no error under any TF", "[octree][lod-error]") {
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({40, 33, 20}, 3);
    std::fill(g.values.begin(), g.values.end(), 0.4f);
    octree::Tree t = octree::build(g, pool, {4, 2});
    REQUIRE(t.levels >= 3);
    std::vector<std::uint32_t> words = octree::encode(t);
    octree::LodDeviation d = octree::lod_deviation(words, t.bricks, pool);
    std::vector<vec4> tf(256);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (vec4& c : tf) c = vec4(u(rng), u(rng), u(rng), u(rng));
    std::vector<float> err = octree::lod_tf_errors(d, tf);
    for (std::size_t n = 0; n < t.nodes.size(); ++n) {
        std::size_t used = 0;
        for (std::uint32_t k = 0; k < kBins; ++k) used += d.lo[n * kBins + k] <= d.hi[n * kBins + k] ? 1 : 0;
        INFO("node " << n);
        CHECK(used == (t.nodes[n].leaf() ? 0u : 1u));
        // 0.4 lies in bin 25 (0.390..0.406) and between entries 102 and 103 of 256: the bound
        // is the TF's spread over those few entries, not more.
        float spread = 0.0f;
        for (std::size_t i = 99; i <= 104; ++i)
            for (std::size_t j = 99; j <= 104; ++j) spread = std::max(spread, comp_max(glm::abs(tf[i] - tf[j])));
        CHECK(err[n] <= spread);
    }
}

TEST_CASE("octree lod_tf_errors equals a loop over the TF entries of each bin", "[octree][lod-error]") {
    std::mt19937 rng(9);
    std::uniform_int_distribution<int> byte(0, 255);
    octree::LodDeviation d;
    const std::size_t nodes = 60;
    d.lo.resize(nodes * kBins);
    d.hi.resize(nodes * kBins);
    for (std::size_t i = 0; i < d.lo.size(); ++i) {
        int a = byte(rng), b = byte(rng);
        if (rng() % 3 == 0) std::swap(a, b);  // some empty bins (lo > hi)
        d.lo[i] = std::uint8_t(a);
        d.hi[i] = std::uint8_t(b);
    }
    for (std::size_t entries : {2u, 7u, 256u, 1024u}) {
        std::vector<vec4> tf(entries);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (vec4& c : tf) c = vec4(u(rng), u(rng), u(rng), u(rng)) * (rng() % 2 ? 1.0f : 0.1f);
        std::vector<float> err = octree::lod_tf_errors(d, tf);
        REQUIRE(err.size() == nodes);
        const double last = double(entries - 1);
        auto range = [&](double lo, double hi, vec4& mn, vec4& mx) {
            std::size_t i0 = std::size_t(std::floor(lo * last)), i1 = std::min(entries - 1, std::size_t(std::ceil(hi * last)));
            mn = vec4(INFINITY);
            mx = vec4(-INFINITY);
            for (std::size_t i = i0; i <= i1; ++i) mn = glm::min(mn, tf[i]), mx = glm::max(mx, tf[i]);
        };
        for (std::size_t n = 0; n < nodes; ++n) {
            float want = 0.0f;
            for (std::uint32_t k = 0; k < kBins; ++k) {
                std::uint8_t lo = d.lo[n * kBins + k], hi = d.hi[n * kBins + k];
                if (lo > hi) continue;
                vec4 ua, uz, ca, cz;
                range(lo / 255.0, hi / 255.0, ua, uz);
                range(double(k) / kBins, double(k + 1) / kBins, ca, cz);
                want = std::max(want, comp_max(glm::max(uz - ca, cz - ua)));
            }
            INFO("entries " << entries << " node " << n);
            CHECK(err[n] == want);
        }
    }
    CHECK_THROWS_WITH(octree::lod_tf_errors(d, std::vector<vec4>(1)), Catch::Contains("at least 2 entries"));
    d.hi.pop_back();
    CHECK_THROWS_WITH(octree::lod_tf_errors(d, std::vector<vec4>(4)), Catch::Contains("do not match"));
}

TEST_CASE("octree cut: transfer-function errors refine small nodes whose bound exceeds max_tf_error", "[octree][cut][lod-error]") {
    octree::Tree t = octree::build(blobs({70, 45, 33}, 2), {4, 1});
    std::vector<std::uint32_t> words = octree::encode(t);
    Camera cam = Camera::framing(Aabb{vec3(0.0f), vec3(t.dims)}, {0.3f, 0.5f, 1.0f});
    octree::CutView v = octree::cut_view(cam.frame(40, 40), 40, 40);
    auto none = [](std::uint32_t) { return false; };
    const octree::CutConfig cfg{2.0f, 0xFFFFFFFFu, 0.25f};
    octree::Cut plain = octree::select_cut(words, v, cfg, none);
    REQUIRE(plain.nodes < t.nodes.size());
    // No node's bound above the limit: the projection's cut.
    std::vector<float> zero(t.nodes.size(), 0.0f), one(t.nodes.size(), 1.0f);
    CHECK(octree::select_cut(words, v, cfg, none, zero).state == plain.state);
    // Every node's above it: refined to the octree's leaves (the full cut).
    octree::Cut all = octree::select_cut(words, v, cfg, none, one);
    CHECK(all.nodes == t.nodes.size());
    // One subtree's bounds above it: refined there only, to its leaves.
    std::vector<float> some(t.nodes.size(), 0.0f);
    std::uint32_t chosen = octree::kNone;
    for (std::uint32_t n = 0; n < t.nodes.size(); ++n)
        if (plain.state[n] == octree::CutState::Leaf && !t.nodes[n].leaf()) {
            chosen = n;
            break;
        }
    REQUIRE(chosen != octree::kNone);
    std::vector<std::uint32_t> stack{chosen};
    while (!stack.empty()) {
        std::uint32_t n = stack.back();
        stack.pop_back();
        some[n] = 0.5f;
        for (std::uint32_t k = 0; !t.nodes[n].leaf() && k < std::uint32_t(std::popcount(t.nodes[n].child_mask)); ++k)
            stack.push_back(t.nodes[n].first_child + k);
    }
    octree::Cut part = octree::select_cut(words, v, cfg, none, some);
    for (std::uint32_t n = 0; n < t.nodes.size(); ++n) {
        INFO("node " << n);
        if (some[n] > 0.0f) CHECK((part.state[n] == octree::CutState::Inner) == !t.nodes[n].leaf());
        else CHECK(part.state[n] == plain.state[n]);
    }
    // Terminal nodes and the budget still hold.
    CHECK(octree::select_cut(words, v, cfg, [](std::uint32_t n) { return n == 0u; }, one).nodes == 1u);
    octree::Cut budget = octree::select_cut(words, v, {cfg.lod_pixels, plain.nodes + 20, 0.25f}, none, one);
    CHECK(budget.nodes <= plain.nodes + 20);
    CHECK(budget.nodes > plain.nodes);
    // Bad input.
    CHECK_THROWS_WITH(octree::select_cut(words, v, cfg, none, std::vector<float>(3, 0.0f)), Catch::Contains("3 transfer-function errors"));
    CHECK_THROWS_WITH(octree::select_cut(words, v, {1.0f, 10u, -1.0f}, none), Catch::Contains("max_tf_error"));
    ThreadPool pool(2);
    std::vector<std::uint32_t> cut_words = words;
    cut_words.resize(4);
    CHECK_THROWS_WITH(octree::lod_deviation(cut_words, t.bricks, pool), Catch::Contains("not a valid encoded octree"));
}

TEST_CASE("octree cut: a one-voxel opaque sheet the projection's cut averages away is kept by the TF-aware cut",
          "[octree][cut][lod-error][dvr]") {
    // Zeros with a sheet of 1 one voxel thick (plane x = 37) and faint blobs: the coarse levels
    // average the sheet to at most 0.5, below the TF's opaque step at 0.6, so the projection's
    // cut at a small image loses it; its nodes' bound is the TF's full opacity, the blobs' small.
    ThreadPool pool(2);
    volume::DensityGrid g = blobs({64, 64, 64}, 11);
    for (float& v : g.values) v *= 0.3f;
    for (std::uint32_t z = 0; z < 64; ++z)
        for (std::uint32_t y = 0; y < 64; ++y) g.values[37 + 64 * (y + 64 * std::size_t{z})] = 1.0f;
    octree::Tree t = octree::build(g, pool, {8, 2});
    std::vector<std::uint32_t> words = octree::encode(t);
    VolumeRenderParams p;
    p.width = p.height = 24;
    p.camera = Camera::framing(g.world_box(), {1.0f, 0.35f, 0.5f}, 35.0f).frame(p.width, p.height);
    p.tf = step_tf(153);  // opaque from 0.6
    for (std::uint32_t i = 1; i < 153; ++i) p.tf[i] = (p.tf[i] & 0x00FFFFFFu) | (2u << 24);  // the blobs faintly (under 1/64)
    Frame ref = render_dvr_cpu(GridWords::from(g), p, pool);
    octree::LodDeviation d = octree::lod_deviation(words, t.bricks, pool);
    auto render_cut = [&](const octree::Cut& c) {
        std::vector<std::uint32_t> w = words;
        octree::apply_cut(w, c);
        return render_octree_dvr_cpu(OctreeView{w, t.bricks}, p, pool);
    };
    const octree::CutConfig cfg{1.0f, 0xFFFFFFFFu, 1.0f / 64.0f};
    octree::Cut plain = select_octree_cut(words, p, cfg, false);
    octree::Cut aware = select_octree_cut(words, p, cfg, false, {}, &d);
    const double plain_psnr = compare_frames(ref, render_cut(plain)).psnr, aware_psnr = compare_frames(ref, render_cut(aware)).psnr;
    INFO("cut nodes " << plain.nodes << " / " << aware.nodes << " of " << t.nodes.size() << "; PSNR " << plain_psnr << " / "
                      << aware_psnr);
    CHECK(plain.deepest < t.levels - 1);      // the projection stops above the leaves
    CHECK(plain_psnr < 30.0);                 // and the sheet goes
    CHECK(aware_psnr >= 40.0);                // the TF-aware cut keeps it
    CHECK(aware.nodes > plain.nodes);
    CHECK(aware.nodes < t.nodes.size());      // not everything: the faint blobs stay coarse
    // The sheet's nodes are refined: every cut leaf whose box holds x = 37 is an octree leaf.
    for (std::uint32_t n = 0; n < t.nodes.size(); ++n)
        if (aware.state[n] == octree::CutState::Leaf && t.box_lo(t.nodes[n]).x <= 37u && 37u < t.box_hi(t.nodes[n]).x) {
            INFO("node " << n << " level " << t.nodes[n].level);
            CHECK(t.nodes[n].leaf());
        }
    // For isosurfaces the bound is not used (the cut culls by range): the same cut as before.
    CHECK(select_octree_cut(words, p, cfg, true, {}, &d).state == select_octree_cut(words, p, cfg, true).state);
}
